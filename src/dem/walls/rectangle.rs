//! Bounded plane (baffle, box side), a two-sided thin shell.

use super::{check_finite_vec, check_nonneg, check_unit, WallContact, WallError, WallPose};
use crate::dem::vec3::Vec3;

/// A rectangle: the set `centre + a u + b v` with `|a| <= half_u_m`,
/// `|b| <= half_v_m`, `v = normal × u`.
///
/// Two-sided thin shell: the closest point is the clamped projection, so faces,
/// edges and corners are all felt; the contact normal points from that point to the
/// sphere centre (on either side). A centre that crosses the sheet is pushed out
/// of the side it is then on, so the time step must keep overlaps below the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    /// Centre (m).
    centre: Vec3,
    /// Unit normal.
    normal: Vec3,
    /// Unit in-plane axis u.
    u: Vec3,
    /// Unit in-plane axis v = normal × u.
    v: Vec3,
    /// Half-extent along u (m).
    half_u_m: f64,
    /// Half-extent along v (m).
    half_v_m: f64,
}

impl Rectangle {
    /// A rectangle centred at `centre` (m) with normal `normal`, in-plane axis `u`
    /// (both normalised; `u` must be perpendicular to `normal` to 1e-6 and is then
    /// made exactly so), and half-extents (m, >= 0; not both zero).
    pub fn new(
        centre: Vec3,
        normal: Vec3,
        u: Vec3,
        half_u_m: f64,
        half_v_m: f64,
    ) -> Result<Rectangle, WallError> {
        let centre = check_finite_vec("centre", centre)?;
        let normal = check_unit("normal", normal)?;
        let u = check_unit("u", u)?;
        if u.dot(&normal).abs() > 1e-6 {
            return Err(WallError::NotPerpendicular {
                field: "u",
                other: "normal",
            });
        }
        let u = (u - normal * u.dot(&normal)).normalize();
        let half_u_m = check_nonneg("half_u_m", half_u_m)?;
        let half_v_m = check_nonneg("half_v_m", half_v_m)?;
        if half_u_m == 0.0 && half_v_m == 0.0 {
            return Err(WallError::Degenerate {
                field: "half_u_m",
                reason: "both half-extents are zero",
            });
        }
        Ok(Rectangle {
            centre,
            normal,
            u,
            v: normal.cross(&u),
            half_u_m,
            half_v_m,
        })
    }

    /// Centre (m).
    pub fn centre(&self) -> Vec3 {
        self.centre
    }
    /// Unit normal.
    pub fn normal(&self) -> Vec3 {
        self.normal
    }
    /// Unit in-plane axis u.
    pub fn u(&self) -> Vec3 {
        self.u
    }
    /// Unit in-plane axis v = normal × u.
    pub fn v(&self) -> Vec3 {
        self.v
    }
    /// Half-extent along u (m).
    pub fn half_u_m(&self) -> f64 {
        self.half_u_m
    }
    /// Half-extent along v (m).
    pub fn half_v_m(&self) -> f64 {
        self.half_v_m
    }

    /// Contact with a sphere (centre `c`, radius `r`, m) when `overlap_m > −range`;
    /// zero velocity.
    #[inline]
    pub fn contact(&self, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        let d = c - self.centre;
        let h = d.dot(&self.normal);
        let reach = r + range;
        if h.abs() >= reach {
            return None;
        }
        let a = d.dot(&self.u);
        let b = d.dot(&self.v);
        let da = a - a.clamp(-self.half_u_m, self.half_u_m);
        let db = b - b.clamp(-self.half_v_m, self.half_v_m);
        let (normal, dist, diff) = if da == 0.0 && db == 0.0 {
            // Face: the normal is exactly ±normal (+normal when on the sheet).
            let n = if h >= 0.0 { self.normal } else { -self.normal };
            (n, h.abs(), self.normal * h)
        } else {
            // Edge or corner.
            let diff = self.u * da + self.v * db + self.normal * h;
            let dist2 = da * da + db * db + h * h;
            if dist2 >= reach * reach {
                return None;
            }
            let dist = dist2.sqrt();
            // dist2 can underflow to 0 for absurdly small offsets: stay finite.
            let n = if dist > 0.0 { diff / dist } else { self.normal };
            (n, dist, diff)
        };
        Some(WallContact {
            normal,
            overlap_m: r - dist,
            point: c - diff,
            velocity: Vec3::zeros(),
        })
    }

    /// The rectangle moved by `pose` (body → world).
    pub fn transformed(&self, pose: &WallPose) -> Rectangle {
        Rectangle {
            centre: pose.to_world(self.centre),
            normal: pose.to_world_dir(self.normal),
            u: pose.to_world_dir(self.u),
            v: pose.to_world_dir(self.v),
            ..*self
        }
    }

    /// Axis-aligned bounding box `(min, max)` (m).
    pub fn aabb(&self) -> (Vec3, Vec3) {
        let ext = self.u.map(f64::abs) * self.half_u_m + self.v.map(f64::abs) * self.half_v_m;
        (self.centre - ext, self.centre + ext)
    }
}
