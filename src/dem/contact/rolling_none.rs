//! No rolling resistance: the slot compiles away (zero-sized history, zero torque).

use super::{PairCoefficients, RollingModel};
use crate::dem::lanes::{Real, Vec3L};
use crate::dem::vec3::Vec3;

/// The absent rolling model.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoRolling;

impl RollingModel for NoRolling {
    type History = ();
    const NAME: &'static str = "none";

    #[inline(always)]
    fn torque(
        _: &PairCoefficients,
        _: f64,
        _: f64,
        _: f64,
        _: &Vec3,
        _: &Vec3,
        _: f64,
        _: &mut (),
    ) -> Vec3 {
        Vec3::zeros()
    }

    #[inline(always)]
    fn torque_lanes<T: Real>(
        _: &PairCoefficients,
        _: T,
        _: T,
        _: T,
        _: &Vec3L<T>,
        _: &Vec3L<T>,
        _: f64,
        _: &mut [()],
    ) -> Vec3L<T> {
        Vec3L::zeros()
    }
}
