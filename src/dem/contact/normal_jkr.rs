//! JKR adhesive normal force in the EDEM "Hertz-Mindlin with JKR" form:
//! `F = 4E*a³/(3R*) − 4√(πΓE*) a^{3/2}` with the contact radius a given by
//! `δ = a²/R* − √(4πΓa/E*)`, Γ the surface energy per surface (work of adhesion
//! 2Γ). Positive F is repulsive. Under force control the pair separates at the
//! pull-off force 3πΓR*.
//!
//! Attraction acts only on contacts that have touched (δ > 0 once) and lasts
//! until the overlap falls to the separation overlap `δ_c = −3a_c²/R*`, the
//! minimum of δ(a), reached at `a_c = (cR*/4)^{2/3}` with `c = √(4πΓ/E*)`;
//! there the contact breaks and its history is reset. Two approaching bodies
//! that have not touched feel nothing.
//!
//! a(δ) is the largest root of the convex function `f(a) = a²/R* − c√a − δ` on
//! `a ≥ a_c`; Newton's method started right of the root converges monotonically
//! (f is convex and increasing there). The history keeps a, which warm-starts
//! the next step, and a_c, which costs a power function and is computed once
//! per contact, at its first touch.

use super::{NormalLanes, NormalModel, PairCoefficients};
use crate::dem::lanes::Real;
use std::f64::consts::PI;

/// The JKR normal model; its history is a [`JkrContact`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Jkr;

/// What a JKR contact keeps between steps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JkrContact {
    /// Contact radius a, m; 0 before the first touch and after the contact broke.
    pub radius_m: f64,
    /// Critical contact radius a_c, m, set at the first touch: it depends
    /// only on the pair type and R*, which a contact never changes.
    pub critical_radius_m: f64,
}

/// Critical contact radius a_c (m) where δ(a) is minimal, for c = √(4πΓ/E*).
#[inline(always)]
fn critical_radius(c: f64, r_star: f64) -> f64 {
    (c * r_star / 4.0).powf(2.0 / 3.0)
}

/// Separation overlap δ_c (m, ≤ 0) at which a JKR contact of effective radius
/// `r_star_m` breaks under displacement control.
pub fn separation_overlap_m(coef: &PairCoefficients, r_star_m: f64) -> f64 {
    let c = coef.jkr_adhesion;
    let ac = critical_radius(c, r_star_m);
    -3.0 * ac * ac / r_star_m
}

/// Pull-off force 3πΓR*, N: the largest tensile force a JKR contact sustains
/// (per lane for effective radii `r_star_m`, m).
#[inline(always)]
pub fn pull_off_force_n<T: Real>(coef: &PairCoefficients, r_star_m: T) -> T {
    T::splat(3.0 * PI * coef.surface_energy_j_m2) * r_star_m
}

/// Contact radius a (m) per lane for overlaps δ ≥ δ_c, by Newton's method
/// from `guess` (the previous radius) or from a start right of the root;
/// only the lanes in `active` are solved. Each lane stops on its own test and
/// keeps its value while others go on, so a lane gives bit for bit what it
/// gives alone.
#[inline(always)]
fn contact_radius<T: Real>(c: f64, r_star: T, overlap: T, ac: T, guess: T, active: T::Mask) -> T {
    let zero = T::splat(0.0);
    // 4a_c + √(R*δ⁺) is always right of the root (see the module docs); a
    // previous radius comfortably above a_c is a better start.
    let positive = T::select(overlap.ge(zero), overlap, zero);
    let safe = T::splat(4.0) * ac + (r_star * positive).sqrt();
    let warm = T::and(guess.gt(T::splat(1.01) * ac), safe.gt(guess));
    let mut a = T::select(warm, guess, safe);
    let mut running = active;
    for _ in 0..100 {
        let sa = a.sqrt();
        let f = a * a / r_star - T::splat(c) * sa - overlap;
        let df = T::splat(2.0) * a / r_star - T::splat(0.5 * c) / sa;
        running = T::and(running, T::not(df.le(zero)));
        let step = a - f / df;
        let next = T::select(step.ge(ac), step, ac);
        let done = (next - a).abs().le(T::splat(1e-14) * a);
        a = T::select(running, next, a);
        running = T::and(running, T::not(done));
        if !T::any(running) {
            break;
        }
    }
    a
}

impl NormalModel for Jkr {
    type History = JkrContact;
    const NAME: &'static str = "jkr";
    const ADHESIVE: bool = true;

    fn reach_m(coef: &PairCoefficients, r_star_m: f64) -> f64 {
        -separation_overlap_m(coef, r_star_m)
    }

    /// Lane-wise: only the critical radius of a contact's first touch (a
    /// power function, once per contact) is computed lane by lane.
    #[inline(always)]
    fn normal_lanes<T: Real>(
        coef: &PairCoefficients,
        r_star: T,
        overlap: T,
        history: &mut [JkrContact],
    ) -> NormalLanes<T> {
        let c = coef.jkr_adhesion;
        let zero = T::splat(0.0);
        let guess = T::from_fn(|l| history[l].radius_m);
        let untouched = guess.le(zero);
        // Not touching yet: no force, and no power function until it does.
        let first = T::and(untouched, overlap.gt(zero));
        if T::any(first) {
            for (l, h) in history.iter_mut().enumerate() {
                if T::flag(first, l) {
                    h.critical_radius_m = critical_radius(c, r_star.lane(l));
                }
            }
        }
        let ac = T::from_fn(|l| history[l].critical_radius_m);
        let broken = overlap.le(T::splat(-3.0) * ac * ac / r_star);
        let active = T::and(T::not(T::and(untouched, overlap.le(zero))), T::not(broken));
        let a = T::select(
            active,
            contact_radius(c, r_star, overlap, ac, guess, active),
            zero,
        );
        for (l, h) in history.iter_mut().enumerate() {
            if T::flag(active, l) {
                h.radius_m = a.lane(l);
            } else {
                *h = JkrContact::default();
            }
        }
        let elastic = T::splat(4.0 * coef.e_star) * a * a * a / (T::splat(3.0) * r_star)
            - T::splat(coef.jkr_tension) * a * a.sqrt();
        let pull_off = pull_off_force_n(coef, r_star);
        NormalLanes {
            active,
            elastic_force_n: T::select(active, elastic, zero),
            contact_radius_m: a,
            pull_off_force_n: T::select(active, pull_off, zero),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::normal_hertz::Hertz;
    use crate::dem::contact::test_support::coefficients;

    #[test]
    fn contact_radius_solves_the_jkr_relation() {
        let coef = coefficients(0.5, 0.5, 0.0, 0.05);
        let r = 5e-4;
        let c = coef.jkr_adhesion;
        let dc = separation_overlap_m(&coef, r);
        for k in 0..50 {
            let delta = dc + (k as f64 + 0.5) * (1e-5 - dc) / 50.0;
            let mut h = JkrContact {
                radius_m: 1e-9, // touched, no usable warm start
                critical_radius_m: critical_radius(c, r),
            };
            Jkr::normal(&coef, r, delta, &mut h).unwrap();
            let a = h.radius_m;
            let back = a * a / r - (c * c * a).sqrt();
            assert!(
                (back - delta).abs() < 1e-12 * r,
                "δ = {delta}: a = {a}, δ(a) = {back}"
            );
        }
    }

    #[test]
    fn zero_surface_energy_reduces_to_hertz() {
        let coef = coefficients(0.5, 0.5, 0.0, 0.0);
        let mut h = JkrContact::default();
        let j = Jkr::normal(&coef, 5e-4, 2e-6, &mut h).unwrap();
        let hz = Hertz::normal(&coef, 5e-4, 2e-6, &mut ()).unwrap();
        assert!((j.elastic_force_n / hz.elastic_force_n - 1.0).abs() < 1e-12);
        assert_eq!(j.pull_off_force_n, 0.0);
        assert_eq!(Jkr::reach_m(&coef, 5e-4), 0.0);
    }

    #[test]
    fn untouched_pairs_do_not_attract_and_touched_pairs_break_at_delta_c() {
        let coef = coefficients(0.5, 0.5, 0.0, 0.05);
        let r = 5e-4;
        let dc = separation_overlap_m(&coef, r);
        let mut h = JkrContact::default();
        assert!(Jkr::normal(&coef, r, 0.5 * dc, &mut h).is_none());
        assert!(Jkr::normal(&coef, r, 1e-7, &mut h).is_some());
        // Now touched: still attracting in the neck.
        let f = Jkr::normal(&coef, r, 0.5 * dc, &mut h)
            .unwrap()
            .elastic_force_n;
        assert!(f < 0.0);
        assert!(Jkr::normal(&coef, r, 1.0001 * dc, &mut h).is_none());
        assert_eq!(h, JkrContact::default());
    }

    #[test]
    fn largest_tension_is_the_pull_off_force() {
        // JKR theory (Johnson, Kendall & Roberts 1971): the tensile force is
        // maximal, 3πΓR* (= 1.5 π w R* with w = 2Γ), at a = (9πΓR*²/(4E*))^{1/3}... scan δ.
        let coef = coefficients(0.5, 0.5, 0.0, 0.05);
        let r = 5e-4;
        let dc = separation_overlap_m(&coef, r);
        let mut h = JkrContact::default(); // touches at the first δ > 0
        let mut min_f = f64::MAX;
        for k in 0..20000 {
            let delta = 1e-6 - (k as f64) * (1e-6 - dc) / 20000.0;
            if let Some(nr) = Jkr::normal(&coef, r, delta, &mut h) {
                min_f = min_f.min(nr.elastic_force_n);
            }
        }
        let pull_off = 3.0 * PI * 0.05 * r;
        assert!(
            (-min_f / pull_off - 1.0).abs() < 1e-4,
            "{min_f} vs {pull_off}"
        );
    }
}
