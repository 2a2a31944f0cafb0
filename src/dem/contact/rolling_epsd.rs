//! Elastic–plastic spring rolling resistance (EPSD, Ai et al. 2011 type C) as
//! yan2015 Eq. 8–10 state it: the rolling torque grows by
//! `ΔM = −k_r Δφ` with `k_r = 8G*aR*²` (a = √(R*δ) for Hertz) and `Δφ = ω_roll dt`,
//! and is capped at `μ_r R* L` (perfectly plastic beyond). The stored torque is
//! rotated into the current tangent plane each step. yan2015 gives no rolling
//! dashpot, so none is added here.

use super::tangential_mindlin::rotate_into_plane;
use super::{PairCoefficients, RollingModel};
use crate::dem::lanes::{Real, Vec3L};
use crate::dem::vec3::Vec3;

/// The EPSD rolling model; its history is the elastic rolling torque, N·m.
#[derive(Clone, Copy, Debug, Default)]
pub struct ElasticPlasticSpring;

impl RollingModel for ElasticPlasticSpring {
    type History = Vec3;
    const NAME: &'static str = "epsd";

    #[inline(always)]
    fn torque(
        c: &PairCoefficients,
        r_star: f64,
        a: f64,
        load: f64,
        n: &Vec3,
        w_roll: &Vec3,
        dt: f64,
        m: &mut Vec3,
    ) -> Vec3 {
        let (n, w) = (Vec3L::<f64>::splat(*n), Vec3L::splat(*w_roll));
        Self::torque_lanes(c, r_star, a, load, &n, &w, dt, std::slice::from_mut(m)).lane(0)
    }

    #[inline(always)]
    fn torque_lanes<T: Real>(
        c: &PairCoefficients,
        r_star: T,
        a: T,
        load: T,
        n: &Vec3L<T>,
        w_roll: &Vec3L<T>,
        dt: f64,
        history: &mut [Vec3],
    ) -> Vec3L<T> {
        let mut m = Vec3L::from_fn(|l| history[l]);
        rotate_into_plane(&mut m, n);
        let k_r = T::splat(8.0 * c.g_star) * a * r_star * r_star;
        m = m - w_roll.scale(k_r * T::splat(dt));
        let cap = T::splat(c.rolling_friction) * r_star * load;
        let len_sq = m.norm_squared();
        m = m
            .scale(cap / len_sq.sqrt())
            .select(len_sq.gt(cap * cap), &m);
        for (l, h) in history.iter_mut().enumerate() {
            *h = m.lane(l);
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::test_support::coefficients;

    #[test]
    fn elastic_then_plastic() {
        let c = coefficients(0.5, 0.5, 0.1, 0.0);
        let (r, a, load, dt) = (1e-3, 1e-5, 1.0, 1e-5);
        let w = Vec3::new(0.0, 1.0, 0.0);
        let mut m = Vec3::zeros();
        let t = ElasticPlasticSpring::torque(&c, r, a, load, &Vec3::z(), &w, dt, &mut m);
        let k_r = 8.0 * c.g_star * a * r * r;
        assert!((t.y + k_r * dt).abs() < 1e-20);
        for _ in 0..1_000_000 {
            ElasticPlasticSpring::torque(&c, r, a, load, &Vec3::z(), &w, dt, &mut m);
        }
        assert!((m.norm() - 0.1 * r * load).abs() < 1e-15);
        // Reversing the rotation unloads elastically from the cap.
        let back = ElasticPlasticSpring::torque(&c, r, a, load, &Vec3::z(), &(-w), dt, &mut m);
        assert!(back.norm() < 0.1 * r * load);
    }
}
