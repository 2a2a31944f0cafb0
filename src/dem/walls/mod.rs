//! Analytic walls and their motion.
//!
//! The engine asks, every step, for every particle near every wall: does a sphere
//! at centre `c` (m) with radius `r` (m) touch, or come within `range` (m) of, this
//! wall at time `t`, and where? The answer is a [`WallContact`].
//!
//! # Shapes
//! - [`Plane`]: infinite and one-sided (signed distance; a particle that has crossed
//!   gets a large overlap, the normal never flips).
//! - [`Rectangle`]: a bounded plane, two-sided thin shell; faces, edges and corners.
//! - [`RevolvedSegment`]: a segment (r0, z0)–(r1, z1) of the meridian half-plane
//!   revolved about an axis, two-sided thin shell: disks, annuli, cylinders, cone
//!   frusta. Rims are the segment end points, so a sphere hitting a rim feels the
//!   rim circle.
//!
//! # Use in the hot loop
//! Build a [`PlacedWall`] once per step with [`Wall::placed_at`] (all trigonometry
//! happens there), then query it per particle with [`PlacedWall::contact`] (no
//! allocation, no trigonometry). [`PlacedWall::aabb`] lets the engine skip far
//! particles. A moving wall is placed by moving its body-frame geometry into the
//! world frame once per step; this is the same as moving every sphere centre into
//! the body frame, computing the contact there and moving point and normal back
//! (tested), but costs nothing per particle.
//!
//! # Conventions
//! - SI units, world frame; `normal` points from the closest wall point towards the
//!   sphere centre; `overlap_m = r − distance`, positive when overlapping; a contact
//!   is reported only when `overlap_m > −range`.
//! - Direction arguments of constructors need not be unit: they are normalised; a
//!   zero or non-finite one is an error naming the field.

mod motion;
mod plane;
mod rectangle;
mod revolved;

pub use motion::{rpm_to_rad_s, Motion, WallPose, WallVelocity};
pub use plane::Plane;
pub use rectangle::Rectangle;
pub use revolved::{RevolvedKind, RevolvedSegment};

use crate::dem::vec3::Vec3;
use std::fmt;

/// Where and how deeply a sphere touches a wall (all world frame, SI).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallContact {
    /// Unit vector from the closest wall surface point towards the sphere centre.
    pub normal: Vec3,
    /// `r − distance(centre, point)` (m): > 0 overlapping, < 0 a gap (reported only
    /// when `> −range`). For a [`Plane`] the distance is signed.
    pub overlap_m: f64,
    /// Closest point on the wall surface (m).
    pub point: Vec3,
    /// Velocity of the wall material at `point` (m/s), from the wall's motion.
    pub velocity: Vec3,
}

/// A constructor argument that cannot describe a wall; `field` names it.
#[derive(Clone, Debug, PartialEq)]
pub enum WallError {
    /// A number or vector component is NaN or infinite.
    NotFinite {
        /// The offending field.
        field: &'static str,
    },
    /// A direction vector is zero (or too short to normalise).
    ZeroVector {
        /// The offending field.
        field: &'static str,
    },
    /// A number is outside its allowed range.
    OutOfRange {
        /// The offending field.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// A direction that must be perpendicular to another is not.
    NotPerpendicular {
        /// The offending field.
        field: &'static str,
        /// The direction it must be perpendicular to.
        other: &'static str,
    },
    /// The arguments together describe a shape with no area.
    Degenerate {
        /// The field blamed.
        field: &'static str,
        /// Why the shape is degenerate.
        reason: &'static str,
    },
}

impl WallError {
    /// The name of the offending field (e.g. `"normal"`, `"motion.rpm"`).
    pub fn field(&self) -> &'static str {
        match self {
            WallError::NotFinite { field }
            | WallError::ZeroVector { field }
            | WallError::OutOfRange { field, .. }
            | WallError::NotPerpendicular { field, .. }
            | WallError::Degenerate { field, .. } => field,
        }
    }
}

impl fmt::Display for WallError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WallError::NotFinite { field } => write!(f, "wall field `{field}` is not finite"),
            WallError::ZeroVector { field } => {
                write!(
                    f,
                    "wall field `{field}` is a zero vector; a direction is needed"
                )
            }
            WallError::OutOfRange {
                field,
                value,
                allowed,
            } => write!(f, "wall field `{field}` = {value}; allowed: {allowed}"),
            WallError::NotPerpendicular { field, other } => {
                write!(f, "wall field `{field}` must be perpendicular to `{other}`")
            }
            WallError::Degenerate { field, reason } => {
                write!(f, "wall field `{field}`: degenerate shape ({reason})")
            }
        }
    }
}

impl std::error::Error for WallError {}

pub(crate) fn check_finite(field: &'static str, x: f64) -> Result<f64, WallError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(WallError::NotFinite { field })
    }
}

pub(crate) fn check_finite_vec(field: &'static str, v: Vec3) -> Result<Vec3, WallError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(WallError::NotFinite { field })
    }
}

/// A finite, non-negative length (m).
pub(crate) fn check_nonneg(field: &'static str, x: f64) -> Result<f64, WallError> {
    check_finite(field, x)?;
    if x >= 0.0 {
        Ok(x)
    } else {
        Err(WallError::OutOfRange {
            field,
            value: x,
            allowed: "finite and >= 0",
        })
    }
}

/// A finite, strictly positive length (m).
pub(crate) fn check_positive(field: &'static str, x: f64) -> Result<f64, WallError> {
    check_finite(field, x)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(WallError::OutOfRange {
            field,
            value: x,
            allowed: "finite and > 0",
        })
    }
}

/// A finite, non-zero direction, returned normalised.
pub(crate) fn check_unit(field: &'static str, v: Vec3) -> Result<Vec3, WallError> {
    check_finite_vec(field, v)?;
    let n = v.norm();
    if n > 0.0 && n.is_finite() {
        let u = v / n;
        if (u.norm() - 1.0).abs() < 1e-12 {
            return Ok(u);
        }
    }
    Err(WallError::ZeroVector { field })
}

/// A fixed unit vector perpendicular to unit `e`: the cross product with the world
/// axis least aligned with `e`, so the choice is deterministic.
pub(crate) fn perpendicular(e: Vec3) -> Vec3 {
    let a = e.map(f64::abs);
    let helper = if a.x <= a.y && a.x <= a.z {
        Vec3::x()
    } else if a.y <= a.z {
        Vec3::y()
    } else {
        Vec3::z()
    };
    e.cross(&helper).normalize()
}

/// The geometry of a wall, in its body frame (or, inside a [`PlacedWall`], in the
/// world frame at the placement time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WallShape {
    /// Infinite one-sided plane.
    Plane(Plane),
    /// Bounded two-sided rectangle.
    Rectangle(Rectangle),
    /// Disk, annulus, cylinder or cone frustum (two-sided).
    Revolved(RevolvedSegment),
}

impl WallShape {
    /// Contact of a sphere (centre `c`, radius `r`, both m) with this shape held
    /// still; `velocity` is zero. `None` when the gap is `>= range` (m).
    #[inline]
    pub fn contact(&self, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        match self {
            WallShape::Plane(s) => s.contact(c, r, range),
            WallShape::Rectangle(s) => s.contact(c, r, range),
            WallShape::Revolved(s) => s.contact(c, r, range),
        }
    }

    /// The shape moved by `pose` (body → world).
    pub fn transformed(&self, pose: &WallPose) -> WallShape {
        match self {
            WallShape::Plane(s) => WallShape::Plane(s.transformed(pose)),
            WallShape::Rectangle(s) => WallShape::Rectangle(s.transformed(pose)),
            WallShape::Revolved(s) => WallShape::Revolved(s.transformed(pose)),
        }
    }

    /// Axis-aligned bounding box `(min, max)` (m); `None` for an infinite plane.
    pub fn aabb(&self) -> Option<(Vec3, Vec3)> {
        match self {
            WallShape::Plane(_) => None,
            WallShape::Rectangle(s) => Some(s.aabb()),
            WallShape::Revolved(s) => Some(s.aabb()),
        }
    }
}

/// A wall: body-frame geometry, a material index and a motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall {
    shape: WallShape,
    /// Index into the engine's wall-material table.
    pub material: usize,
    motion: Motion,
}

impl Wall {
    /// A wall from a validated shape, a material index and a motion (validated here).
    pub fn new(shape: WallShape, material: usize, motion: Motion) -> Result<Wall, WallError> {
        Ok(Wall {
            shape,
            material,
            motion: motion.validated()?,
        })
    }

    /// The same wall with another motion (validated; errors name `motion.<field>`).
    pub fn with_motion(self, motion: Motion) -> Result<Wall, WallError> {
        Wall::new(self.shape, self.material, motion)
    }

    /// Static infinite plane through `point` (m); particles live on the side
    /// `normal` points to. See [`Plane::new`].
    pub fn plane(point: Vec3, normal: Vec3, material: usize) -> Result<Wall, WallError> {
        Ok(Wall::still(
            WallShape::Plane(Plane::new(point, normal)?),
            material,
        ))
    }

    /// Static rectangle. See [`Rectangle::new`].
    pub fn rectangle(
        centre: Vec3,
        normal: Vec3,
        u: Vec3,
        half_u_m: f64,
        half_v_m: f64,
        material: usize,
    ) -> Result<Wall, WallError> {
        let s = Rectangle::new(centre, normal, u, half_u_m, half_v_m)?;
        Ok(Wall::still(WallShape::Rectangle(s), material))
    }

    /// Static full disk. See [`RevolvedSegment::disk`].
    pub fn disk(
        centre: Vec3,
        normal: Vec3,
        radius_m: f64,
        material: usize,
    ) -> Result<Wall, WallError> {
        let s = RevolvedSegment::disk(centre, normal, radius_m)?;
        Ok(Wall::still(WallShape::Revolved(s), material))
    }

    /// Static annulus. See [`RevolvedSegment::annulus`].
    pub fn annulus(
        centre: Vec3,
        normal: Vec3,
        inner_radius_m: f64,
        outer_radius_m: f64,
        material: usize,
    ) -> Result<Wall, WallError> {
        let s = RevolvedSegment::annulus(centre, normal, inner_radius_m, outer_radius_m)?;
        Ok(Wall::still(WallShape::Revolved(s), material))
    }

    /// Static open cylinder (no end caps). See [`RevolvedSegment::cylinder`].
    pub fn cylinder(
        base_centre: Vec3,
        axis: Vec3,
        radius_m: f64,
        length_m: f64,
        material: usize,
    ) -> Result<Wall, WallError> {
        let s = RevolvedSegment::cylinder(base_centre, axis, radius_m, length_m)?;
        Ok(Wall::still(WallShape::Revolved(s), material))
    }

    /// Static open cone frustum. See [`RevolvedSegment::cone_frustum`].
    pub fn cone_frustum(
        base_centre: Vec3,
        axis: Vec3,
        radius0_m: f64,
        radius1_m: f64,
        length_m: f64,
        material: usize,
    ) -> Result<Wall, WallError> {
        let s = RevolvedSegment::cone_frustum(base_centre, axis, radius0_m, radius1_m, length_m)?;
        Ok(Wall::still(WallShape::Revolved(s), material))
    }

    fn still(shape: WallShape, material: usize) -> Wall {
        Wall {
            shape,
            material,
            motion: Motion::Static,
        }
    }

    /// Body-frame geometry (the world geometry at t = 0).
    pub fn shape(&self) -> &WallShape {
        &self.shape
    }

    /// The (validated) motion.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// Rigid pose body → world at time `t` (s), for drawing the wall.
    pub fn pose_at(&self, t: f64) -> WallPose {
        self.motion.pose_at(t)
    }

    /// The wall at time `t` (s), ready for per-particle queries. Build once per
    /// step; all trigonometry happens here.
    pub fn placed_at(&self, t: f64) -> PlacedWall {
        let shape = if self.motion.is_static() {
            self.shape
        } else {
            self.shape.transformed(&self.motion.pose_at(t))
        };
        PlacedWall {
            shape,
            velocity: self.motion.velocity_at(t),
            material: self.material,
        }
    }

    /// Axis-aligned bounding box `(min, max)` (m) of the wall at time `t` (s);
    /// `None` for an infinite plane.
    pub fn aabb(&self, t: f64) -> Option<(Vec3, Vec3)> {
        self.placed_at(t).aabb()
    }

    /// One-off contact query at time `t` (s). In loops use [`Wall::placed_at`] once
    /// and [`PlacedWall::contact`] per particle instead.
    pub fn contact_at(&self, t: f64, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        self.placed_at(t).contact(c, r, range)
    }
}

/// A wall placed at one time: world-frame geometry plus the material velocity
/// field. Cheap to query per particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedWall {
    shape: WallShape,
    velocity: WallVelocity,
    /// Index into the engine's wall-material table.
    pub material: usize,
}

impl PlacedWall {
    /// Contact of a sphere with centre `c` (m) and radius `r` (m): `Some` when the
    /// gap is smaller than `range` (m, >= 0), i.e. `overlap_m > −range`.
    #[inline]
    pub fn contact(&self, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        let mut k = self.shape.contact(c, r, range)?;
        k.velocity = self.velocity.at(k.point);
        Some(k)
    }

    /// World-frame geometry at the placement time (engines may match on it once and
    /// call the shape's own `contact` in a monomorphic loop, then add
    /// [`PlacedWall::velocity_at`]).
    pub fn shape(&self) -> &WallShape {
        &self.shape
    }

    /// Velocity of the wall material at world point `p` (m), in m/s.
    #[inline]
    pub fn velocity_at(&self, p: Vec3) -> Vec3 {
        self.velocity.at(p)
    }

    /// The material velocity field at the placement time.
    pub fn velocity_field(&self) -> &WallVelocity {
        &self.velocity
    }

    /// Axis-aligned bounding box `(min, max)` (m); `None` for an infinite plane.
    pub fn aabb(&self) -> Option<(Vec3, Vec3)> {
        self.shape.aabb()
    }
}

#[cfg(test)]
mod tests;
