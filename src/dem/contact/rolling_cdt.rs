//! Constant directional torque rolling resistance (CDT, Ai et al. 2011 type A;
//! LIGGGHTS `rolling_friction cdt`): `M_r = −μ_r R* L ω̂_roll`, with ω_roll the
//! rolling (tangent-plane) part of ω_i − ω_j and L the cap load of the contact.
//! No history. A resting contact makes the torque flip sign from step to step
//! (the known CDT chatter); it does not drive motion.

use super::{PairCoefficients, RollingModel};
use crate::dem::vec3::Vec3;

/// The CDT rolling model.
#[derive(Clone, Copy, Debug, Default)]
pub struct ConstantDirectionalTorque;

impl RollingModel for ConstantDirectionalTorque {
    type History = ();
    const NAME: &'static str = "cdt";

    #[inline(always)]
    fn torque(
        c: &PairCoefficients,
        r_star: f64,
        _: f64,
        load: f64,
        _: &Vec3,
        w_roll: &Vec3,
        _: f64,
        _: &mut (),
    ) -> Vec3 {
        let w = w_roll.norm();
        if w > 0.0 {
            w_roll * (-c.rolling_friction * r_star * load / w)
        } else {
            Vec3::zeros()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::test_support::coefficients;

    #[test]
    fn torque_opposes_rolling_with_magnitude_mu_r_r_load() {
        let c = coefficients(0.5, 0.5, 0.1, 0.0);
        let m = ConstantDirectionalTorque::torque(
            &c,
            1e-3,
            0.0,
            2.0,
            &Vec3::z(),
            &Vec3::new(0.0, 3.0, 0.0),
            1e-5,
            &mut (),
        );
        assert!((m.y + 0.1 * 1e-3 * 2.0).abs() < 1e-18 && m.x == 0.0);
    }
}
