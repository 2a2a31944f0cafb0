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
use crate::dem::vec3::Vec3;

/// Tangential force on body *i*, N, updating the spring elongation `xi` (m).
///
/// `a` is the contact radius (m), `m_star` the effective mass (kg), `load_n`
/// the Coulomb cap load (N), `normal` the unit contact normal and `v_t` the
/// tangential relative velocity of *i* at the contact (m/s).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn force(
    c: &PairCoefficients,
    a: f64,
    m_star: f64,
    load_n: f64,
    normal: &Vec3,
    v_t: &Vec3,
    dt_s: f64,
    xi: &mut Vec3,
) -> Vec3 {
    rotate_into_plane(xi, normal);
    *xi += v_t * dt_s;
    let k_t = 8.0 * c.g_star * a;
    let spring = *xi * -k_t;
    let cap = c.static_friction * load_n;
    let spring_sq = spring.norm_squared();
    if spring_sq > cap * cap {
        let scale = cap / spring_sq.sqrt();
        *xi *= scale;
        return spring * scale;
    }
    let total = spring - v_t * tangential_damping_coefficient(c, a, m_star);
    let total_sq = total.norm_squared();
    if total_sq > cap * cap {
        total * (cap / total_sq.sqrt())
    } else {
        total
    }
}

/// Projects `v` onto the plane normal to `normal`, keeping its length: the
/// history vectors of a contact follow the contact plane as bodies roll.
#[inline(always)]
pub fn rotate_into_plane(v: &mut Vec3, normal: &Vec3) {
    let len_sq = v.norm_squared();
    if len_sq == 0.0 {
        return;
    }
    let projected = *v - normal * v.dot(normal);
    let p_sq = projected.norm_squared();
    *v = if p_sq > 0.0 {
        projected * (len_sq / p_sq).sqrt()
    } else {
        Vec3::zeros()
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::test_support::coefficients;

    #[test]
    fn sticking_spring_then_sliding_at_the_cap() {
        let c = coefficients(1.0, 0.5, 0.0, 0.0); // e = 1: no damping
        let n = Vec3::z();
        let v_t = Vec3::new(1e-3, 0.0, 0.0);
        let mut xi = Vec3::zeros();
        let a = 1e-5;
        let f = force(&c, a, 1e-6, 1.0, &n, &v_t, 1e-4, &mut xi);
        // Sticking: F = −8G*a ξ with ξ = v dt.
        assert!((f.x + 8.0 * c.g_star * a * 1e-7).abs() < 1e-15);
        // Keep pushing: the force saturates at μL = 0.5 N.
        for _ in 0..1_000_000 {
            force(&c, a, 1e-6, 1.0, &n, &v_t, 1e-4, &mut xi);
        }
        let f = force(&c, a, 1e-6, 1.0, &n, &v_t, 1e-4, &mut xi);
        assert!((f.norm() - 0.5).abs() < 1e-12);
        assert!((xi.norm() * 8.0 * c.g_star * a - 0.5).abs() < 1e-9);
    }

    #[test]
    fn history_rotates_with_the_contact_plane() {
        let mut v = Vec3::new(1.0, 0.0, 0.1);
        rotate_into_plane(&mut v, &Vec3::z());
        assert!((v.norm() - (1.01f64).sqrt()).abs() < 1e-15 && v.z == 0.0);
    }
}
