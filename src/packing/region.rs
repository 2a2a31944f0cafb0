//! Insertion regions: where new particle centres may go.
//!
//! A sphere fits a region when its centre lies at least (radius + clearance) inside
//! every bounding surface. All regions are convex, so that is the distance to each
//! face's plane: for a cone frustum, the distance from a centre at radius ρ and
//! height z to the lateral surface is (R(z) − ρ)·cos β, β being the half-angle of
//! the cone (the tangent plane at the centre's azimuth is the nearest one).

use super::{check_positive, sphere_volume, PackingError};
use crate::dem::vec3::Vec3;
use std::f64::consts::PI;

/// A convex region, coordinates in m, z up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    /// Axis-aligned box.
    Box {
        /// Lower corner, m.
        min_m: Vec3,
        /// Upper corner, m.
        max_m: Vec3,
    },
    /// Vertical circular cylinder.
    Cylinder {
        /// Axis (x, y), m.
        axis_xy_m: [f64; 2],
        /// Radius, m.
        radius_m: f64,
        /// Bottom, m.
        z_min_m: f64,
        /// Top, m.
        z_max_m: f64,
    },
    /// Vertical cone frustum (a funnel's inside): radius varies linearly from
    /// `radius_bottom_m` at `z_bottom_m` to `radius_top_m` at `z_top_m`.
    Frustum {
        /// Axis (x, y), m.
        axis_xy_m: [f64; 2],
        /// Bottom height, m.
        z_bottom_m: f64,
        /// Radius at the bottom, m (>= 0).
        radius_bottom_m: f64,
        /// Top height, m.
        z_top_m: f64,
        /// Radius at the top, m (>= 0).
        radius_top_m: f64,
    },
}

impl Region {
    /// Checks the dimensions: finite, positive extents.
    pub fn validate(&self) -> Result<(), PackingError> {
        let bad = |name, value| PackingError::BadParameter {
            name,
            value,
            allowed: "finite, with top above bottom and positive extents",
        };
        match *self {
            Self::Box { min_m, max_m } => {
                for k in 0..3 {
                    if !(min_m[k].is_finite() && max_m[k].is_finite() && min_m[k] < max_m[k]) {
                        return Err(bad("box", max_m[k]));
                    }
                }
            }
            Self::Cylinder {
                axis_xy_m,
                radius_m,
                z_min_m,
                z_max_m,
            } => {
                check_positive("radius_m", radius_m)?;
                if !(axis_xy_m.iter().all(|c| c.is_finite())
                    && z_min_m.is_finite()
                    && z_max_m > z_min_m
                    && z_max_m.is_finite())
                {
                    return Err(bad("cylinder", z_max_m));
                }
            }
            Self::Frustum {
                axis_xy_m,
                z_bottom_m,
                radius_bottom_m,
                z_top_m,
                radius_top_m,
            } => {
                let radii_ok = radius_bottom_m >= 0.0
                    && radius_top_m >= 0.0
                    && radius_bottom_m.max(radius_top_m) > 0.0
                    && radius_bottom_m.is_finite()
                    && radius_top_m.is_finite();
                if !(radii_ok
                    && axis_xy_m.iter().all(|c| c.is_finite())
                    && z_bottom_m.is_finite()
                    && z_top_m > z_bottom_m
                    && z_top_m.is_finite())
                {
                    return Err(bad("frustum", z_top_m));
                }
            }
        }
        Ok(())
    }

    /// Volume, m³.
    pub fn volume(&self) -> f64 {
        match *self {
            Self::Box { min_m, max_m } => (max_m - min_m).product(),
            Self::Cylinder {
                radius_m,
                z_min_m,
                z_max_m,
                ..
            } => PI * radius_m * radius_m * (z_max_m - z_min_m),
            Self::Frustum {
                z_bottom_m,
                radius_bottom_m: a,
                z_top_m,
                radius_top_m: b,
                ..
            } => PI / 3.0 * (z_top_m - z_bottom_m) * (a * a + a * b + b * b),
        }
    }

    /// Axis-aligned bounding box (lower, upper), m.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Self::Box { min_m, max_m } => (min_m, max_m),
            Self::Cylinder {
                axis_xy_m: [x, y],
                radius_m: r,
                z_min_m,
                z_max_m,
            } => (
                Vec3::new(x - r, y - r, z_min_m),
                Vec3::new(x + r, y + r, z_max_m),
            ),
            Self::Frustum {
                axis_xy_m: [x, y],
                z_bottom_m,
                radius_bottom_m,
                z_top_m,
                radius_top_m,
            } => {
                let r = radius_bottom_m.max(radius_top_m);
                (
                    Vec3::new(x - r, y - r, z_bottom_m),
                    Vec3::new(x + r, y + r, z_top_m),
                )
            }
        }
    }

    /// Distance from `p` to the region's boundary, positive inside, m (for points
    /// outside, a negative number whose magnitude is at most the true distance).
    pub fn depth(&self, p: &Vec3) -> f64 {
        match *self {
            Self::Box { min_m, max_m } => (0..3)
                .map(|k| (p[k] - min_m[k]).min(max_m[k] - p[k]))
                .fold(f64::INFINITY, f64::min),
            Self::Cylinder {
                axis_xy_m,
                radius_m,
                z_min_m,
                z_max_m,
            } => frustum_depth(p, axis_xy_m, z_min_m, radius_m, z_max_m, radius_m),
            Self::Frustum {
                axis_xy_m,
                z_bottom_m,
                radius_bottom_m,
                z_top_m,
                radius_top_m,
            } => frustum_depth(
                p,
                axis_xy_m,
                z_bottom_m,
                radius_bottom_m,
                z_top_m,
                radius_top_m,
            ),
        }
    }

    /// True when a sphere of radius `radius_m` centred at `p` lies inside with at
    /// least `clearance_m` to every surface.
    pub fn fits(&self, p: &Vec3, radius_m: f64, clearance_m: f64) -> bool {
        self.depth(p) >= radius_m + clearance_m
    }

    /// Solid volume fraction of spheres of the given radii in this region.
    pub fn fill_fraction(&self, radii: impl IntoIterator<Item = f64>) -> f64 {
        radii.into_iter().map(sphere_volume).sum::<f64>() / self.volume()
    }
}

fn frustum_depth(p: &Vec3, [cx, cy]: [f64; 2], zb: f64, rb: f64, zt: f64, rt: f64) -> f64 {
    let h = zt - zb;
    let rho = (p.x - cx).hypot(p.y - cy);
    let r_at = rb + (rt - rb) * (p.z - zb) / h;
    let cos_beta = h / h.hypot(rt - rb);
    ((r_at - rho) * cos_beta).min(p.z - zb).min(zt - p.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frustum_depth_and_volume() {
        // A 60° funnel (half-angle 30°): radius 2.5 mm at z = 0 growing to 2.5 mm +
        // 40 mm · tan 30° at z = 40 mm.
        let t = 30f64.to_radians().tan();
        let f = Region::Frustum {
            axis_xy_m: [0.0, 0.0],
            z_bottom_m: 0.0,
            radius_bottom_m: 0.0025,
            z_top_m: 0.04,
            radius_top_m: 0.0025 + 0.04 * t,
        };
        f.validate().unwrap();
        // On the axis at mid height: distance to the wall is R(z) cos 30°.
        let r_mid = 0.0025 + 0.02 * t;
        let d = f.depth(&Vec3::new(0.0, 0.0, 0.02));
        assert!((d - r_mid * 30f64.to_radians().cos()).abs() < 1e-12);
        assert!(f.depth(&Vec3::new(0.1, 0.0, 0.02)) < 0.0);
        let cyl = Region::Cylinder {
            axis_xy_m: [0.0, 0.0],
            radius_m: 1.0,
            z_min_m: 0.0,
            z_max_m: 2.0,
        };
        assert!((cyl.volume() - 2.0 * PI).abs() < 1e-12);
        assert!((cyl.depth(&Vec3::new(0.5, 0.0, 1.0)) - 0.5).abs() < 1e-12);
        let b = Region::Box {
            min_m: Vec3::zeros(),
            max_m: Vec3::new(1.0, 2.0, 3.0),
        };
        assert_eq!(b.volume(), 6.0);
        assert!(b.fits(&Vec3::new(0.5, 1.0, 1.0), 0.4, 0.1));
        assert!(!b.fits(&Vec3::new(0.5, 1.0, 1.0), 0.45, 0.1));
        assert!(Region::Box {
            min_m: Vec3::zeros(),
            max_m: Vec3::new(1.0, 0.0, 1.0)
        }
        .validate()
        .is_err());
    }
}
