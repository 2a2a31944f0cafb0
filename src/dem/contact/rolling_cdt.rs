//! Constant directional torque rolling resistance (CDT, Ai et al. 2011 type A;
//! LIGGGHTS `rolling_friction cdt`): `M_r = −μ_r R* L ω̂_roll`, with ω_roll the
//! rolling (tangent-plane) part of ω_i − ω_j and L the cap load of the contact.
//! No history. A resting contact makes the torque flip sign from step to step
//! (the known CDT chatter); it does not drive motion.

use super::{PairCoefficients, RollingModel};
use crate::dem::lanes::{Real, Vec3L};
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
        a: f64,
        load: f64,
        n: &Vec3,
        w_roll: &Vec3,
        dt: f64,
        _: &mut (),
    ) -> Vec3 {
        let (n, w) = (Vec3L::<f64>::splat(*n), Vec3L::splat(*w_roll));
        Self::torque_lanes(c, r_star, a, load, &n, &w, dt, &mut [()]).lane(0)
    }

    #[inline(always)]
    fn torque_lanes<T: Real>(
        c: &PairCoefficients,
        r_star: T,
        _: T,
        load: T,
        _: &Vec3L<T>,
        w_roll: &Vec3L<T>,
        _: f64,
        _: &mut [()],
    ) -> Vec3L<T> {
        let w = w_roll.norm();
        w_roll
            .scale(T::splat(-c.rolling_friction) * r_star * load / w)
            .select(w.gt(T::splat(0.0)), &Vec3L::zeros())
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
