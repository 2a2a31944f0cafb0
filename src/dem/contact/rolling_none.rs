//! No rolling resistance: the slot compiles away (zero-sized history, zero torque).

use super::{PairCoefficients, RollingModel};
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
}
