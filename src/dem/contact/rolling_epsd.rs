//! Elastic–plastic spring rolling resistance (EPSD, Ai et al. 2011 type C) as
//! yan2015 Eq. 8–10 state it: the rolling torque grows by
//! `ΔM = −k_r Δφ` with `k_r = 8G*aR*²` (a = √(R*δ) for Hertz) and `Δφ = ω_roll dt`,
//! and is capped at `μ_r R* L` (perfectly plastic beyond). The stored torque is
//! rotated into the current tangent plane each step. yan2015 gives no rolling
//! dashpot, so none is added here.

use super::tangential_mindlin::rotate_into_plane;
use super::{PairCoefficients, RollingModel};
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
        rotate_into_plane(m, n);
        let k_r = 8.0 * c.g_star * a * r_star * r_star;
        *m -= w_roll * (k_r * dt);
        let cap = c.rolling_friction * r_star * load;
        let len_sq = m.norm_squared();
        if len_sq > cap * cap {
            *m *= cap / len_sq.sqrt();
        }
        *m
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
