//! Hertz normal force: `F = (4/3) E* √R* δ^{3/2}` for overlap δ > 0
//! (yan2015 Eq. 4), written as `(4/3) E* a³ / R*` with contact radius a = √(R*δ).

use super::{NormalLanes, NormalModel, PairCoefficients};
use crate::dem::lanes::Real;

/// The Hertz normal model: acts only while the bodies overlap, keeps no history.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hertz;

impl NormalModel for Hertz {
    type History = ();
    const NAME: &'static str = "hertz";
    const ADHESIVE: bool = false;

    #[inline(always)]
    fn reach_m(_: &PairCoefficients, _: f64) -> f64 {
        0.0
    }

    #[inline(always)]
    fn normal_lanes<T: Real>(
        c: &PairCoefficients,
        r_star_m: T,
        overlap_m: T,
        _: &mut [()],
    ) -> NormalLanes<T> {
        let a = (r_star_m * overlap_m).sqrt();
        NormalLanes {
            // A NaN overlap counts as touching, so the health check sees it.
            active: T::not(overlap_m.le(T::splat(0.0))),
            // (4/3) E* a³/R* = (4/3) E* a δ: no division.
            elastic_force_n: T::splat((4.0 / 3.0) * c.e_star) * a * overlap_m,
            contact_radius_m: a,
            pull_off_force_n: T::splat(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::test_support::coefficients;

    #[test]
    fn force_matches_the_hertz_formula() {
        let c = coefficients(0.5, 0.5, 0.0, 0.0);
        let (r, d) = (5e-4, 1e-6);
        let f = Hertz::normal(&c, r, d, &mut ()).unwrap().elastic_force_n;
        let expected = 4.0 / 3.0 * c.e_star * r.sqrt() * d.powf(1.5);
        assert!((f / expected - 1.0).abs() < 1e-12);
        assert!(Hertz::normal(&c, r, 0.0, &mut ()).is_none());
        assert!(Hertz::normal(&c, r, -1e-9, &mut ()).is_none());
    }
}
