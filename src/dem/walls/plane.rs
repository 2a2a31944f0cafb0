//! Infinite one-sided plane.

use super::{check_finite_vec, check_unit, WallContact, WallError, WallPose};
use crate::dem::vec3::Vec3;

/// An infinite plane; particles live on the side its normal points to.
///
/// The distance is signed: a particle whose centre has crossed the plane gets an
/// overlap larger than its radius and the same normal (no side flip), so it is
/// pushed back rather than through.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane (m).
    point: Vec3,
    /// Unit normal towards the particle side.
    normal: Vec3,
}

impl Plane {
    /// A plane through `point` (m) with normal `normal` (normalised; errors name
    /// `point` or `normal`).
    pub fn new(point: Vec3, normal: Vec3) -> Result<Plane, WallError> {
        Ok(Plane {
            point: check_finite_vec("point", point)?,
            normal: check_unit("normal", normal)?,
        })
    }

    /// A point on the plane (m).
    pub fn point(&self) -> Vec3 {
        self.point
    }

    /// Unit normal towards the particle side.
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// Signed distance (m) of `c` from the plane, positive on the particle side.
    #[inline]
    pub fn signed_distance(&self, c: Vec3) -> f64 {
        (c - self.point).dot(&self.normal)
    }

    /// Contact with a sphere (centre `c`, radius `r`, m) when `overlap_m > −range`;
    /// zero velocity (see [`super::PlacedWall::contact`] for moving walls).
    #[inline]
    pub fn contact(&self, c: Vec3, r: f64, range: f64) -> Option<WallContact> {
        let d = self.signed_distance(c);
        let overlap_m = r - d;
        if overlap_m > -range {
            Some(WallContact {
                normal: self.normal,
                overlap_m,
                point: c - self.normal * d,
                velocity: Vec3::zeros(),
            })
        } else {
            None
        }
    }

    /// The plane moved by `pose` (body → world).
    pub fn transformed(&self, pose: &WallPose) -> Plane {
        Plane {
            point: pose.to_world(self.point),
            normal: pose.to_world_dir(self.normal),
        }
    }
}
