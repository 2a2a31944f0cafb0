//! The funnel flow meter's geometry: walls, the simulation box, the charge
//! region, and the zones the protocol and the measurement use.
//!
//! Frame: the platform's top face is the plane z = 0, centred on the z axis,
//! which is also the funnel's axis; the outlet tube leans towards +x.

use crate::dem::domain::{Domain, DomainError};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{rpm_to_rad_s, Motion, Wall, WallError};
use crate::manifest::scene::FunnelPileScene;
use crate::packing::region::Region;

/// Gravitational acceleration, m/s² (−z).
pub const G_M_S2: f64 = 9.81;
/// Particles whose centre sinks this many mean diameters below the platform's
/// top face have fallen off it and are removed.
pub const REMOVAL_DEPTH_DIAMETERS: f64 = 2.0;
/// Clearance between the keep zone and the walls or the simulation box, in
/// mean diameters.
const MARGIN_DIAMETERS: f64 = 2.0;

/// Wall-material index of the funnel, its tube and the brush.
pub const FUNNEL_MATERIAL: usize = 0;
/// Wall-material index of the platform.
pub const PLATFORM_MATERIAL: usize = 1;

/// Everything the scene derives from the manifest's dimensions, m.
#[derive(Clone, Debug, PartialEq)]
pub struct FunnelGeometry {
    /// Radius of the outlet (cone bottom and tube), m.
    pub outlet_radius_m: f64,
    /// Radius of the funnel's top rim, m.
    pub top_radius_m: f64,
    /// Height of the cone's lower rim above the platform, m.
    pub rim_z_m: f64,
    /// Height of the funnel's top rim above the platform, m.
    pub top_z_m: f64,
    /// Cone half-angle (wall to axis), rad.
    pub half_angle_rad: f64,
    /// Unit direction of the outlet tube's axis, from the cone rim downwards.
    pub tube_axis: Vec3,
    /// Tube length along its axis, m.
    pub tube_length_m: f64,
    /// Height of the tube's lowest point above the platform, m: a particle whose
    /// centre is below it has left the funnel.
    pub exit_z_m: f64,
    /// Platform radius, m.
    pub platform_radius_m: f64,
    /// Mean particle diameter, m.
    pub d_mean_m: f64,
    /// Bound on particle speed used to size the safety margins, m/s: free fall
    /// from the funnel top to the removal depth plus the brush tip speed.
    pub speed_bound_m_s: f64,
    /// Particles whose centre is below this height are removed, m.
    pub removal_z_m: f64,
    /// Particles farther than this from the axis along x or y are removed, m.
    pub keep_half_width_m: f64,
    /// Interval at which particles are removed, s.
    pub sample_interval_s: f64,
}

impl FunnelGeometry {
    /// The geometry of a (validated) scene for particles of mean diameter
    /// `d_mean_m`.
    pub fn new(scene: &FunnelPileScene, d_mean_m: f64) -> FunnelGeometry {
        let tilt = scene.outlet_tilt_deg.to_radians();
        let outlet_radius_m = 0.5 * scene.funnel_outlet_diameter_m;
        let top_radius_m = 0.5 * scene.funnel_top_diameter_m;
        let rim_z_m = scene.outlet_height_m;
        let top_z_m = rim_z_m + scene.funnel_height_m;
        let platform_radius_m = 0.5 * scene.platform_diameter_m;
        let removal_z_m = -REMOVAL_DEPTH_DIAMETERS * d_mean_m;
        let tip_speed = scene.brush_rpm.map_or(0.0, |rpm| rpm_to_rad_s(rpm).abs()) * top_radius_m;
        let speed_bound_m_s = (2.0 * G_M_S2 * (top_z_m - removal_z_m)).sqrt() + tip_speed;
        let tube_axis = Vec3::new(tilt.sin(), 0.0, -tilt.cos());
        let tube_length_m = scene.outlet_tube_length();
        let tube_end_x = tube_length_m * tilt.sin() + outlet_radius_m;
        let keep_half_width_m =
            top_radius_m.max(platform_radius_m).max(tube_end_x) + MARGIN_DIAMETERS * d_mean_m;
        FunnelGeometry {
            outlet_radius_m,
            top_radius_m,
            rim_z_m,
            top_z_m,
            half_angle_rad: scene.cone_half_angle_rad(),
            tube_axis,
            tube_length_m,
            exit_z_m: rim_z_m - scene.outlet_tube_drop(),
            platform_radius_m,
            d_mean_m,
            speed_bound_m_s,
            removal_z_m,
            keep_half_width_m,
            sample_interval_s: scene.sample_interval(),
        }
    }

    /// How far a particle can travel in one sample interval, plus a margin, m:
    /// the distance between the keep zone and the simulation box, so that a
    /// particle leaving the keep zone is removed before it leaves the box.
    fn travel_margin_m(&self) -> f64 {
        let dt = self.sample_interval_s;
        self.speed_bound_m_s * dt + 0.5 * G_M_S2 * dt * dt + MARGIN_DIAMETERS * self.d_mean_m
    }

    /// The simulation box: the keep zone widened by one sample interval's travel;
    /// the top clears the funnel rim by the same amount.
    pub fn domain(&self) -> Result<Domain, DomainError> {
        let m = self.travel_margin_m();
        let half = self.keep_half_width_m + m;
        Domain::new(
            Vec3::new(-half, -half, self.removal_z_m - m),
            Vec3::new(half, half, self.top_z_m + m),
            [false; 3],
        )
    }

    /// True while a particle at `p` is inside the keep zone (above the removal
    /// depth and within the keep half-width along x and y).
    pub fn keeps(&self, p: &Vec3) -> bool {
        p.z >= self.removal_z_m
            && p.x.abs() <= self.keep_half_width_m
            && p.y.abs() <= self.keep_half_width_m
    }

    /// True when a particle centre at `p` lies on the platform: between the
    /// platform's face and the tube's exit, within the platform's radius.
    pub fn on_platform(&self, p: &Vec3) -> bool {
        p.z >= 0.0 && p.z < self.exit_z_m && p.x.hypot(p.y) <= self.platform_radius_m
    }

    /// The charge region: the inside of the cone from the outlet up to
    /// `fill_height_m` above it.
    pub fn charge_region(&self, fill_height_m: f64) -> Region {
        Region::Frustum {
            axis_xy_m: [0.0, 0.0],
            z_bottom_m: self.rim_z_m,
            radius_bottom_m: self.outlet_radius_m,
            z_top_m: self.rim_z_m + fill_height_m,
            radius_top_m: self.outlet_radius_m + fill_height_m * self.half_angle_rad.tan(),
        }
    }
}

/// The walls in order: the cone (0), the outlet tube (1), the platform (2), then
/// the brush blades (none without a brush), each blade turning about the z axis
/// at `brush_rpm` from `brush_start_s` to `brush_end_s`.
pub fn walls(
    scene: &FunnelPileScene,
    geom: &FunnelGeometry,
    brush_start_s: f64,
    brush_end_s: f64,
) -> Result<Vec<Wall>, WallError> {
    let rim = Vec3::new(0.0, 0.0, geom.rim_z_m);
    let mut walls = vec![
        Wall::cone_frustum(
            rim,
            Vec3::z(),
            geom.outlet_radius_m,
            geom.top_radius_m,
            scene.funnel_height_m,
            FUNNEL_MATERIAL,
        )?,
        Wall::cylinder(
            rim,
            geom.tube_axis,
            geom.outlet_radius_m,
            geom.tube_length_m,
            FUNNEL_MATERIAL,
        )?,
        Wall::disk(
            Vec3::zeros(),
            Vec3::z(),
            geom.platform_radius_m,
            PLATFORM_MATERIAL,
        )?,
    ];
    if let Some(rpm) = scene.brush_rpm {
        let spin = Motion::Rotate {
            axis_point: Vec3::zeros(),
            axis_dir: Vec3::z(),
            rpm,
            start_s: brush_start_s,
            end_s: brush_end_s,
        };
        let n = scene.brush_blade_count();
        for k in 0..n {
            let azimuth = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
            walls.push(blade(scene, geom, azimuth)?.with_motion(spin)?);
        }
    }
    Ok(walls)
}

/// One brush blade at `azimuth_rad` (from +x): a rectangle in the meridian
/// plane, its outer long edge parallel to the cone wall at `brush_gap()` from
/// it, reaching `brush_width()` further inwards perpendicular to the wall's
/// slope. Along the slope it runs from the top rim's height down into the
/// throat until its inner lower corner is level with the outlet rim, so it
/// sweeps the region where a cohesive powder arches over the outlet (a
/// stirrer reaches down to the nozzle).
fn blade(
    scene: &FunnelPileScene,
    geom: &FunnelGeometry,
    azimuth_rad: f64,
) -> Result<Wall, WallError> {
    let (s, c) = azimuth_rad.sin_cos();
    let radial = Vec3::new(c, s, 0.0);
    let tangential = Vec3::new(-s, c, 0.0);
    let (sb, cb) = geom.half_angle_rad.sin_cos();
    // Up the wall's slope, and inwards perpendicular to it in the meridian plane.
    let up_slope = radial * sb + Vec3::z() * cb;
    let inwards = Vec3::z() * sb - radial * cb;
    let (gap, width) = (scene.brush_gap(), scene.brush_width());
    // Slant coordinates along the wall from the outlet rim: the top rim is at
    // H / cos β; the inner lower corner is level with the rim at −(g + w) tan β.
    let (s0, s1) = (-(gap + width) * sb / cb, scene.funnel_height_m / cb);
    let rim = Vec3::new(0.0, 0.0, geom.rim_z_m) + radial * geom.outlet_radius_m;
    let centre = rim + up_slope * (0.5 * (s0 + s1)) + inwards * (gap + 0.5 * width);
    Wall::rectangle(
        centre,
        tangential,
        up_slope,
        0.5 * (s1 - s0),
        0.5 * width,
        FUNNEL_MATERIAL,
    )
}
