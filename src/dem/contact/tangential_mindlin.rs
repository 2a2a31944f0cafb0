//! Mindlin tangential spring with viscous damping and a Coulomb cap
//! (yan2015 Eq. 5–7): `F_t = −S_t ξ − η_t v_t`, `S_t = 8G*a`, `|F_t| ≤ μ_s L`.
//!
//! ξ is the accumulated tangential displacement of the contact, kept per
//! contact, rotated into the current tangent plane every step (keeping its
//! length) and incremented by `v_t dt`. When the spring force alone exceeds
//! the cap the contact slides: ξ is shortened so the spring force equals the
//! cap (the "reset on sliding") and the force is that, without damping.
//! Otherwise damping is added and the sum is clipped to the cap, leaving ξ
//! alone. So |F_t| ≤ μ_s L always, and ξ never points against the slip: backing
//! ξ out of a capped spring-plus-damping force (as LAMMPS does) makes ξ
//! negative at contact onset, where damping alone exceeds the tiny cap, and
//! the friction then pushes along the slip once the stiffness has grown (seen
//! as a 6 % friction-impulse deficit in the Chung & Ooi oblique test).
//! The cap load L is the elastic normal force, shifted by 2F_pulloff for JKR
//! (see the [`super`] module docs for why damping is left out).

use super::damping::tangential_damping_coefficient;
use super::PairCoefficients;
use crate::dem::lanes::{Real, Vec3L};

/// Tangential force on body *i*, N, per lane, updating the spring elongations
/// `xi` (m).
///
/// `a` is the contact radius (m), `m_star` the effective mass (kg), `load_n`
/// the Coulomb cap load (N), `normal` the unit contact normal and `v_t` the
/// tangential relative velocity of *i* at the contact (m/s). Both the sliding
/// and the sticking answer are computed and each lane keeps its own.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn force<T: Real>(
    c: &PairCoefficients,
    a: T,
    m_star: T,
    load_n: T,
    normal: &Vec3L<T>,
    v_t: &Vec3L<T>,
    dt_s: f64,
    xi: &mut Vec3L<T>,
) -> Vec3L<T> {
    rotate_into_plane(xi, normal);
    *xi = *xi + v_t.scale(T::splat(dt_s));
    let spring = xi.scale(-(T::splat(8.0 * c.g_star) * a));
    let cap = T::splat(c.static_friction) * load_n;
    let spring_sq = spring.norm_squared();
    let sliding = spring_sq.gt(cap * cap);
    let total = spring - v_t.scale(tangential_damping_coefficient(c, a, m_star));
    let total_sq = total.norm_squared();
    // One root serves both branches: a sliding lane scales the spring, a
    // sticking one the damped total (when that exceeds the cap).
    let scale = cap / T::select(sliding, spring_sq, total_sq).sqrt();
    let sticking = total.scale(scale).select(total_sq.gt(cap * cap), &total);
    *xi = xi.scale(scale).select(sliding, xi);
    spring.scale(scale).select(sliding, &sticking)
}

/// Projects each lane's `v` onto the plane normal to its `normal`, keeping
/// its length: the history vectors of a contact follow the contact plane as
/// bodies roll. A zero `v` stays as it is; one along the normal becomes zero.
#[inline(always)]
pub fn rotate_into_plane<T: Real>(v: &mut Vec3L<T>, normal: &Vec3L<T>) {
    let len_sq = v.norm_squared();
    let projected = *v - normal.scale(v.dot(normal));
    let p_sq = projected.norm_squared();
    let zero = T::splat(0.0);
    let rotated = projected
        .scale((len_sq / p_sq).sqrt())
        .select(p_sq.gt(zero), &Vec3L::zeros());
    *v = v.select(len_sq.eq(zero), &rotated);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::test_support::coefficients;
    use crate::dem::lanes::F64x4;
    use crate::dem::vec3::Vec3;

    /// One lane of [`force`] with scalar arguments.
    fn force_one(c: &PairCoefficients, a: f64, v_t: &Vec3, xi: &mut Vec3) -> Vec3 {
        let mut x = Vec3L::<f64>::splat(*xi);
        let (n, v) = (Vec3L::splat(Vec3::z()), Vec3L::splat(*v_t));
        let f = force(c, a, 1e-6, 1.0, &n, &v, 1e-4, &mut x);
        *xi = x.lane(0);
        f.lane(0)
    }

    #[test]
    fn sticking_spring_then_sliding_at_the_cap() {
        let c = coefficients(1.0, 0.5, 0.0, 0.0); // e = 1: no damping
        let v_t = Vec3::new(1e-3, 0.0, 0.0);
        let mut xi = Vec3::zeros();
        let a = 1e-5;
        let f = force_one(&c, a, &v_t, &mut xi);
        // Sticking: F = −8G*a ξ with ξ = v dt.
        assert!((f.x + 8.0 * c.g_star * a * 1e-7).abs() < 1e-15);
        // Keep pushing: the force saturates at μL = 0.5 N.
        for _ in 0..1_000_000 {
            force_one(&c, a, &v_t, &mut xi);
        }
        let f = force_one(&c, a, &v_t, &mut xi);
        assert!((f.norm() - 0.5).abs() < 1e-12);
        assert!((xi.norm() * 8.0 * c.g_star * a - 0.5).abs() < 1e-9);
    }

    #[test]
    fn history_rotates_with_the_contact_plane() {
        let start = [
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::zeros(),
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::x(),
        ];
        let mut v = Vec3L::<F64x4>::from_fn(|l| start[l]);
        rotate_into_plane(&mut v, &Vec3L::splat(Vec3::z()));
        let tilted = v.lane(0);
        assert!((tilted.norm() - (1.01f64).sqrt()).abs() < 1e-15 && tilted.z == 0.0);
        assert_eq!(v.lane(1), Vec3::zeros(), "zero stays zero (no 0/0)");
        assert_eq!(v.lane(2), Vec3::zeros(), "along the normal: nothing left");
        assert_eq!(v.lane(3), Vec3::x(), "already in the plane: unchanged");
    }
}
