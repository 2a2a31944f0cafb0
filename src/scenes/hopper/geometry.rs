//! Where everything is in the hopper scene: walls (hopper, plate, lid), the
//! simulation box, the fill region, and which part of the scene a particle is
//! in (inside the hopper, below it, or gone off the plate).
//!
//! Frame: the plate's top face is z = 0, the hopper axis is the z axis, the
//! hopper's flat bottom (an annulus around the orifice) is at z =
//! `drop_height_m`. Gravity is −z.

use crate::dem::domain::{Domain, DomainError};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Motion, Wall, WallError};
use crate::manifest::scene::HopperScene;
use crate::packing::region::Region;
use crate::scenes::physics::STANDARD_GRAVITY_M_S2 as G_M_S2;

/// Wall-material index of the hopper (cylinder, bottom, lid).
pub const HOPPER_MATERIAL: usize = 0;
/// Wall-material index of the plate.
pub const PLATE_MATERIAL: usize = 1;
/// Index of the lid in the wall list (cylinder, bottom, plate, lid).
pub const LID_WALL: usize = 3;
/// Speed no particle in the scene reaches, m/s (free fall from 0.2 m is 2 m/s):
/// a particle that falls off the plate moves less than this times the sample
/// interval before it is removed, which sizes the box margins.
const MAX_SPEED_M_S: f64 = 4.0;
/// Fixed part of the box margins, m.
const BASE_MARGIN_M: f64 = 0.02;

/// The scene's dimensions in its frame (all m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Hopper inner radius.
    pub hopper_radius: f64,
    /// Hopper height (bottom to rim).
    pub hopper_height: f64,
    /// Orifice radius.
    pub orifice_radius: f64,
    /// Height of the hopper bottom (the orifice plane) above the plate.
    pub bottom_z: f64,
    /// Plate radius.
    pub plate_radius: f64,
    /// Representative particle diameter.
    pub d_mean: f64,
    /// Smallest particle diameter.
    pub d_min: f64,
}

impl Geometry {
    /// The geometry of `scene` for particles of mean diameter `d_mean` and
    /// smallest diameter `d_min` (m).
    pub fn new(scene: &HopperScene, d_mean: f64, d_min: f64) -> Self {
        Self {
            hopper_radius: 0.5 * scene.diameter_m,
            hopper_height: scene.height_m,
            orifice_radius: 0.5 * scene.orifice_diameter_m,
            bottom_z: scene.drop_height_m,
            plate_radius: 0.5 * scene.plate_diameter_m,
            d_mean,
            d_min,
        }
    }

    /// Depth of the lid's face below the orifice plane, m: half the smallest
    /// diameter, so no particle fits in the slot between the lid and the
    /// bottom, and a particle resting on the bottom next to the orifice never
    /// touches the lid as well (a coplanar lid would push it twice).
    fn lid_recess(&self) -> f64 {
        0.5 * self.d_min
    }

    /// The walls, in order: hopper cylinder, hopper bottom (annulus around the
    /// orifice), plate (disk), lid (disk under the orifice, overlapping the
    /// bottom by one diameter).
    pub fn walls(&self) -> Result<Vec<Wall>, WallError> {
        let base = Vec3::new(0.0, 0.0, self.bottom_z);
        Ok(vec![
            Wall::cylinder(
                base,
                Vec3::z(),
                self.hopper_radius,
                self.hopper_height,
                HOPPER_MATERIAL,
            )?,
            Wall::annulus(
                base,
                Vec3::z(),
                self.orifice_radius,
                self.hopper_radius,
                HOPPER_MATERIAL,
            )?,
            Wall::disk(Vec3::zeros(), Vec3::z(), self.plate_radius, PLATE_MATERIAL)?,
            Wall::disk(
                Vec3::new(0.0, 0.0, self.bottom_z - self.lid_recess()),
                Vec3::z(),
                self.orifice_radius + self.d_mean,
                HOPPER_MATERIAL,
            )?,
        ])
    }

    /// Speed at which the lid falls away, m/s: 2 √(g h), h the drop from the
    /// lid to one diameter below the plate. A particle released at the same
    /// instant falls g t²/2 while the lid has moved v t, so it cannot catch
    /// the lid before depth 2 v²/g = 8 h: the lid is through the plate first.
    pub fn lid_speed_m_s(&self) -> f64 {
        2.0 * (G_M_S2 * self.lid_travel_m()).sqrt()
    }

    /// How far the lid moves down: to one diameter below the plate's top,
    /// where it parks (nothing is there: particles below the plate are
    /// removed), m.
    fn lid_travel_m(&self) -> f64 {
        self.bottom_z - self.lid_recess() + self.d_mean
    }

    /// The lid's motion when it opens at `t_open_s`: straight down at
    /// [`Geometry::lid_speed_m_s`] until it is under the plate.
    pub fn lid_opening(&self, t_open_s: f64) -> Motion {
        let v = self.lid_speed_m_s();
        Motion::Translate {
            velocity_m_s: Vec3::new(0.0, 0.0, -v),
            start_s: t_open_s,
            end_s: t_open_s + self.lid_travel_m() / v,
        }
    }

    /// Box margin beyond the plate's rim and below its face, m: a particle
    /// that falls off the plate is removed at the next sample, at most
    /// `sample_interval_s` later.
    fn margin(&self, sample_interval_s: f64) -> f64 {
        BASE_MARGIN_M + MAX_SPEED_M_S * sample_interval_s + 2.0 * self.d_mean
    }

    /// The simulation box: the plate (and the hopper) plus a margin sideways
    /// and below, up to `top_z` (the highest placed particle) plus the margin.
    pub fn domain(&self, top_z: f64, sample_interval_s: f64) -> Result<Domain, DomainError> {
        let m = self.margin(sample_interval_s);
        let half = self.plate_radius.max(self.hopper_radius) + m;
        let top = top_z.max(self.bottom_z + self.hopper_height) + m;
        Domain::new(
            Vec3::new(-half, -half, -m),
            Vec3::new(half, half, top),
            [false; 3],
        )
    }

    /// The hopper's inside from the bottom up to `height` (m): where the poured
    /// particles are placed.
    pub fn fill_region(&self, height: f64) -> Region {
        Region::Cylinder {
            axis_xy_m: [0.0, 0.0],
            radius_m: self.hopper_radius,
            z_min_m: self.bottom_z,
            z_max_m: self.bottom_z + height,
        }
    }

    /// Where a particle (centre `p`, radius `r`) is.
    pub fn locate(&self, p: Vec3, r: f64) -> Location {
        if p.z >= self.bottom_z - r {
            Location::Hopper
        } else if p.z < -self.d_mean || p.x.hypot(p.y) > self.plate_radius + self.d_mean {
            Location::Gone
        } else {
            Location::Below
        }
    }

    /// True when a particle is inside the hopper proper (above its bottom and
    /// within its wall): the poured bed, before the lid opens.
    pub fn inside_hopper(&self, p: Vec3, r: f64) -> bool {
        p.z >= self.bottom_z - r && p.x.hypot(p.y) < self.hopper_radius
    }
}

/// The part of the scene a particle is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// Not yet fully below the orifice plane (centre at or above the bottom
    /// minus its radius): still in the hopper (or above its rim).
    Hopper,
    /// Left the hopper: falling, or on the plate.
    Below,
    /// Fell off the plate (more than one diameter below its face or beyond its
    /// rim): removed from the simulation at the next sample.
    Gone,
}

/// yan2015's hopper (D = 50 mm, H = 70 mm, 15 mm orifice 70 mm above a
/// 200 mm plate) with 2 mm spheres: the fixture the hopper's unit tests share.
#[cfg(test)]
pub(super) fn yan2015_geometry() -> Geometry {
    Geometry {
        hopper_radius: 0.025,
        hopper_height: 0.07,
        orifice_radius: 0.0075,
        bottom_z: 0.07,
        plate_radius: 0.1,
        d_mean: 0.002,
        d_min: 0.002,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations() {
        let g = yan2015_geometry();
        let r = 0.001;
        assert_eq!(g.locate(Vec3::new(0.0, 0.0, 0.0695), r), Location::Hopper);
        assert_eq!(g.locate(Vec3::new(0.0, 0.0, 0.0685), r), Location::Below);
        assert_eq!(g.locate(Vec3::new(0.05, 0.0, 0.001), r), Location::Below);
        assert_eq!(g.locate(Vec3::new(0.103, 0.0, 0.001), r), Location::Gone);
        assert_eq!(g.locate(Vec3::new(0.0, 0.0, -0.003), r), Location::Gone);
        assert!(g.inside_hopper(Vec3::new(0.02, 0.0, 0.08), r));
        assert!(!g.inside_hopper(Vec3::new(0.03, 0.0, 0.08), r));
    }

    /// The lid parks one diameter under the plate, and a particle released
    /// with it never reaches it on the way (see `lid_speed_m_s`).
    #[test]
    fn the_lid_outruns_free_fall_to_below_the_plate() {
        let g = yan2015_geometry();
        let m = g.lid_opening(1.0);
        let Motion::Translate {
            velocity_m_s,
            start_s,
            end_s,
        } = m
        else {
            panic!("{m:?}")
        };
        let lid_z0 = g.bottom_z - 0.5 * g.d_min;
        let parked = lid_z0 + velocity_m_s.z * (end_s - start_s);
        assert!((parked + g.d_mean).abs() < 1e-12, "{parked}");
        let v = -velocity_m_s.z;
        for k in 1..=100 {
            let t = (end_s - start_s) * f64::from(k) / 100.0;
            assert!(v * t > 0.5 * G_M_S2 * t * t, "caught at {t}");
        }
    }
}
