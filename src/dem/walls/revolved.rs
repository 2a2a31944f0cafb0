//! Surfaces of revolution of a segment: disks, annuli, cylinders, cone frusta.

use super::{
    check_finite, check_finite_vec, check_nonneg, check_positive, check_unit, perpendicular,
    WallContact, WallError, WallPose,
};
use crate::dem::vec3::Vec3;

/// The segment from (r0, z0) to (r1, z1) in the meridian half-plane (ρ >= 0) of an
/// axis through `origin` along unit `axis`, revolved about that axis.
///
/// Point `p` has axial coordinate `z = (p − origin)·axis` (m) and radial distance
/// `ρ` (m) from the axis. The closest surface point to a sphere centre is the
/// closest point of the 2-D segment to the centre's (ρ, z), lifted back to 3-D in the
/// centre's own meridian half-plane (exact, because the segment has ρ >= 0). Rims
/// are the segment end points, so a sphere at a rim feels the rim circle. Two-sided
/// thin shell: inside and outside both act (a centre that crosses the shell is
/// pushed out of the side it is then on). A centre on the axis (ρ = 0) uses a
/// fixed perpendicular chosen at construction, so the answer is deterministic and
/// finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RevolvedSegment {
    /// A point on the axis, where z = 0 (m).
    origin: Vec3,
    /// Unit axis direction (z grows along it).
    axis: Vec3,
    /// Fixed unit perpendicular to `axis`, used for centres on the axis.
    perp: Vec3,
    /// `axis × perp`, completing the right-handed frame (perp, perp2, axis).
    perp2: Vec3,
    /// Radius of the first end point (m, >= 0).
    r0: f64,
    /// Axial coordinate of the first end point (m).
    z0: f64,
    /// Radius of the second end point (m, >= 0).
    r1: f64,
    /// Axial coordinate of the second end point (m).
    z1: f64,
    /// r1 − r0 (m).
    dr: f64,
    /// z1 − z0 (m).
    dz: f64,
    /// 1 / ((r1 − r0)² + (z1 − z0)²) (1/m²).
    inv_len2: f64,
    /// Unit 2-D normal of the segment (−dz, dr)/len, (ρ, z) components; used only
    /// when a centre lies exactly on the surface.
    n_rho: f64,
    /// See `n_rho`.
    n_z: f64,
}

/// What a [`RevolvedSegment`] looks like (for logs and messages).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RevolvedKind {
    /// z0 = z1 and one radius zero: a full disk.
    Disk,
    /// z0 = z1, both radii non-zero: a flat ring.
    Annulus,
    /// r0 = r1: an open cylinder.
    Cylinder,
    /// Anything else: an open cone frustum (a cone when one radius is zero).
    ConeFrustum,
}

impl RevolvedSegment {
    /// The general constructor: segment (r0_m, z0_m)–(r1_m, z1_m) about the axis
    /// through `origin` (m) along `axis` (normalised). Radii must be >= 0 and not
    /// both zero; the segment must have non-zero length.
    pub fn new(
        origin: Vec3,
        axis: Vec3,
        r0_m: f64,
        z0_m: f64,
        r1_m: f64,
        z1_m: f64,
    ) -> Result<RevolvedSegment, WallError> {
        let origin = check_finite_vec("origin", origin)?;
        let axis = check_unit("axis", axis)?;
        let r0 = check_nonneg("r0_m", r0_m)?;
        let z0 = check_finite("z0_m", z0_m)?;
        let r1 = check_nonneg("r1_m", r1_m)?;
        let z1 = check_finite("z1_m", z1_m)?;
        if r0 == 0.0 && r1 == 0.0 {
            return Err(WallError::Degenerate {
                field: "r1_m",
                reason: "r0 = r1 = 0: a segment on the axis has no area",
            });
        }
        let (dr, dz) = (r1 - r0, z1 - z0);
        let len2 = dr * dr + dz * dz;
        let inv_len2 = 1.0 / len2;
        if !(len2 > 0.0 && inv_len2.is_finite()) {
            return Err(WallError::Degenerate {
                field: "z1_m",
                reason: "the segment (r0, z0)-(r1, z1) has zero length",
            });
        }
        let len = len2.sqrt();
        let perp = perpendicular(axis);
        Ok(RevolvedSegment {
            origin,
            axis,
            perp,
            perp2: axis.cross(&perp),
            r0,
            z0,
            r1,
            z1,
            dr,
            dz,
            inv_len2,
            n_rho: -dz / len,
            n_z: dr / len,
        })
    }

    /// A full disk of radius `radius_m` (> 0) centred at `centre` (m), face normal
    /// `normal`.
    pub fn disk(centre: Vec3, normal: Vec3, radius_m: f64) -> Result<RevolvedSegment, WallError> {
        let r = check_positive("radius_m", radius_m)?;
        RevolvedSegment::new(centre, normal, 0.0, 0.0, r, 0.0).map_err(rename("axis", "normal"))
    }

    /// A flat ring between `inner_radius_m` (>= 0) and `outer_radius_m`
    /// (> inner) centred at `centre` (m), face normal `normal`.
    pub fn annulus(
        centre: Vec3,
        normal: Vec3,
        inner_radius_m: f64,
        outer_radius_m: f64,
    ) -> Result<RevolvedSegment, WallError> {
        let ri = check_nonneg("inner_radius_m", inner_radius_m)?;
        let ro = check_finite("outer_radius_m", outer_radius_m)?;
        if ro <= ri {
            return Err(WallError::OutOfRange {
                field: "outer_radius_m",
                value: ro,
                allowed: "> inner_radius_m",
            });
        }
        RevolvedSegment::new(centre, normal, ri, 0.0, ro, 0.0).map_err(rename("axis", "normal"))
    }

    /// An open cylinder (no caps) of radius `radius_m` (> 0) from `base_centre` (m,
    /// z = 0) along `axis` to z = `length_m` (> 0).
    pub fn cylinder(
        base_centre: Vec3,
        axis: Vec3,
        radius_m: f64,
        length_m: f64,
    ) -> Result<RevolvedSegment, WallError> {
        let r = check_positive("radius_m", radius_m)?;
        let l = check_positive("length_m", length_m)?;
        RevolvedSegment::new(base_centre, axis, r, 0.0, r, l)
            .map_err(rename("origin", "base_centre"))
    }

    /// An open cone frustum from radius `radius0_m` at `base_centre` (m, z = 0) to
    /// radius `radius1_m` at z = `length_m` (> 0) along `axis`. Radii >= 0, not both
    /// zero. A funnel: base at the outlet, small `radius0_m`, axis up.
    pub fn cone_frustum(
        base_centre: Vec3,
        axis: Vec3,
        radius0_m: f64,
        radius1_m: f64,
        length_m: f64,
    ) -> Result<RevolvedSegment, WallError> {
        let r0 = check_nonneg("radius0_m", radius0_m)?;
        let r1 = check_nonneg("radius1_m", radius1_m)?;
        let l = check_positive("length_m", length_m)?;
        RevolvedSegment::new(base_centre, axis, r0, 0.0, r1, l)
            .map_err(rename("origin", "base_centre"))
            .map_err(rename("r1_m", "radius1_m"))
    }

    /// A point on the axis where z = 0 (m).
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
    /// Unit axis direction.
    pub fn axis(&self) -> Vec3 {
        self.axis
    }
    /// The fixed unit perpendicular used for centres on the axis.
    pub fn perp(&self) -> Vec3 {
        self.perp
    }
    /// The end points `(r0, z0, r1, z1)` (m).
    pub fn segment(&self) -> (f64, f64, f64, f64) {
        (self.r0, self.z0, self.r1, self.z1)
    }

    /// Disk, annulus, cylinder or cone frustum.
    pub fn kind(&self) -> RevolvedKind {
        if self.dz == 0.0 {
            if self.r0 == 0.0 || self.r1 == 0.0 {
                RevolvedKind::Disk
            } else {
                RevolvedKind::Annulus
            }
        } else if self.dr == 0.0 {
            RevolvedKind::Cylinder
        } else {
            RevolvedKind::ConeFrustum
        }
    }

    /// Contact with a sphere (centre `c`, radius `r`, m) when `overlap_m > −range`;
    /// zero velocity.
    #[inline]
    pub fn contact(&self, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        // Coordinates in the orthonormal frame (perp, perp2, axis): the radial
        // direction is then a combination of perp and perp2, exactly perpendicular
        // to the axis even for centres a rounding error off the axis (subtracting
        // the axial part of `c − origin` instead would leave noise along the axis).
        let w = c - self.origin;
        let z = w.dot(&self.axis);
        let x = w.dot(&self.perp);
        let y = w.dot(&self.perp2);
        let rho = (x * x + y * y).sqrt();
        // Closest point of the 2-D segment to (rho, z).
        let s =
            (((rho - self.r0) * self.dr + (z - self.z0) * self.dz) * self.inv_len2).clamp(0.0, 1.0);
        let q_rho = self.r0 + s * self.dr;
        let q_z = self.z0 + s * self.dz;
        let (x_rho, x_z) = (rho - q_rho, z - q_z);
        let dist2 = x_rho * x_rho + x_z * x_z;
        let reach = r + range;
        if dist2 >= reach * reach {
            return None;
        }
        let e_rho = if rho > 0.0 {
            (self.perp * x + self.perp2 * y) / rho
        } else {
            self.perp
        };
        let dist = dist2.sqrt();
        let (n_rho, n_z) = if dist > 0.0 {
            (x_rho / dist, x_z / dist)
        } else {
            (self.n_rho, self.n_z)
        };
        Some(WallContact {
            normal: e_rho * n_rho + self.axis * n_z,
            overlap_m: r - dist,
            point: self.origin + self.axis * q_z + e_rho * q_rho,
            velocity: Vec3::zeros(),
        })
    }

    /// The surface moved by `pose` (body → world).
    pub fn transformed(&self, pose: &WallPose) -> RevolvedSegment {
        RevolvedSegment {
            origin: pose.to_world(self.origin),
            axis: pose.to_world_dir(self.axis),
            perp: pose.to_world_dir(self.perp),
            perp2: pose.to_world_dir(self.perp2),
            ..*self
        }
    }

    /// Axis-aligned bounding box `(min, max)` (m): the union of the boxes of the two
    /// end circles (box bounds are linear along the segment).
    pub fn aabb(&self) -> (Vec3, Vec3) {
        // Half-extent of a unit circle about `axis` along world axis i: sqrt(1 − a_i²).
        let k = self.axis.map(|a| (1.0 - a * a).max(0.0).sqrt());
        let c0 = self.origin + self.axis * self.z0;
        let c1 = self.origin + self.axis * self.z1;
        let (e0, e1) = (k * self.r0, k * self.r1);
        ((c0 - e0).inf(&(c1 - e1)), (c0 + e0).sup(&(c1 + e1)))
    }
}

/// Renames the field of an error from the general constructor to the argument name
/// of a convenience constructor.
fn rename(from: &'static str, to: &'static str) -> impl Fn(WallError) -> WallError {
    move |e| {
        if e.field() != from {
            return e;
        }
        match e {
            WallError::NotFinite { .. } => WallError::NotFinite { field: to },
            WallError::ZeroVector { .. } => WallError::ZeroVector { field: to },
            WallError::OutOfRange { value, allowed, .. } => WallError::OutOfRange {
                field: to,
                value,
                allowed,
            },
            WallError::NotPerpendicular { other, .. } => {
                WallError::NotPerpendicular { field: to, other }
            }
            WallError::Degenerate { reason, .. } => WallError::Degenerate { field: to, reason },
        }
    }
}
