//! Effects a scene may switch on, as kernel type parameters.
//!
//! Each effect that can be off is a type with a zero-sized "off" variant, so the
//! monomorphised kernel of a scene without it contains no code for it: no
//! branch, no storage (rapier's pipeline / LIGGGHTS's `*_OFF` models). The
//! contact-law slots live in [`crate::dem::contact`]; gravity and the domain
//! boundary live here.

use crate::dem::domain::Domain;
use crate::dem::lanes::{Real, Vec3L};
use crate::dem::vec3::Vec3;

/// A uniform body force per unit mass.
pub trait BodyForce: Copy + Send + Sync + 'static {
    /// Name recorded in results.
    const NAME: &'static str;
    /// Acceleration, m/s².
    fn acceleration(&self) -> Vec3;
}

/// Gravity off: adds nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoGravity;

impl BodyForce for NoGravity {
    const NAME: &'static str = "no-gravity";
    #[inline(always)]
    fn acceleration(&self) -> Vec3 {
        Vec3::zeros()
    }
}

/// Uniform gravity, m/s².
#[derive(Clone, Copy, Debug)]
pub struct Gravity(pub Vec3);

impl BodyForce for Gravity {
    const NAME: &'static str = "gravity";
    #[inline(always)]
    fn acceleration(&self) -> Vec3 {
        self.0
    }
}

/// How pair separations are measured across the domain boundary.
pub trait Boundary: Copy + Send + Sync + 'static {
    /// Name recorded in results.
    const NAME: &'static str;
    /// Separation vector x_i − x_j given its raw value `d`, m.
    fn separation(domain: &Domain, d: Vec3) -> Vec3;
    /// [`separation`](Self::separation) of several pairs, one per lane, m.
    fn separation_lanes<T: Real>(domain: &Domain, d: Vec3L<T>) -> Vec3L<T>;
    /// Maps a position back into the domain after a move, m.
    fn wrap(domain: &Domain, p: Vec3) -> Vec3;
}

/// A domain with no periodic axis: separations are raw differences.
#[derive(Clone, Copy, Debug, Default)]
pub struct Open;

impl Boundary for Open {
    const NAME: &'static str = "open";
    #[inline(always)]
    fn separation(_: &Domain, d: Vec3) -> Vec3 {
        d
    }
    #[inline(always)]
    fn separation_lanes<T: Real>(_: &Domain, d: Vec3L<T>) -> Vec3L<T> {
        d
    }
    #[inline(always)]
    fn wrap(_: &Domain, p: Vec3) -> Vec3 {
        p
    }
}

/// A domain with at least one periodic axis: minimum-image separations.
#[derive(Clone, Copy, Debug, Default)]
pub struct Periodic;

impl Boundary for Periodic {
    const NAME: &'static str = "periodic";
    #[inline(always)]
    fn separation(domain: &Domain, d: Vec3) -> Vec3 {
        domain.min_image(d)
    }
    #[inline(always)]
    fn separation_lanes<T: Real>(domain: &Domain, d: Vec3L<T>) -> Vec3L<T> {
        domain.min_image_lanes(d)
    }
    #[inline(always)]
    fn wrap(domain: &Domain, p: Vec3) -> Vec3 {
        domain.wrap(p)
    }
}
