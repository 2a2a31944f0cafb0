//! Viscous damping of the normal and tangential springs (yan2015 Eq. 4–5):
//! `F_d = 2√(5/6) ψ √(S m*) v` with stiffness `S_n = 2E*a` (normal) or
//! `S_t = 8G*a` (tangential) and ψ = ln e / √(ln² e + π²), so that a Hertz
//! impact restitutes with coefficient e.

use super::PairCoefficients;
use crate::dem::lanes::Real;
use std::f64::consts::PI;

/// 2√(5/6), the prefactor of the Tsuji-type damping used by EDEM and LIGGGHTS.
pub const DAMPING_PREFACTOR: f64 = 1.825_741_858_350_553_8;

/// Damping ratio ψ for restitution `e` ∈ (0, 1]: ln e / √(ln² e + π²).
/// ψ(1) = 0 (no damping); as e → 0, ψ → −1 (never NaN, even for e = 0).
pub fn damping_ratio(e: f64) -> f64 {
    if e <= 0.0 {
        return -1.0;
    }
    let l = e.ln();
    if l.is_infinite() {
        -1.0
    } else {
        l / (l * l + PI * PI).sqrt()
    }
}

/// Normal damping force along the normal, N (positive repulsive), per lane:
/// for an approaching contact (`v_n < 0`, m/s) it pushes the bodies apart.
/// `2√(5/6) ψ √(S_n m*) v_n` with `S_n = 2E*a`, evaluated as
/// `[2√(5/6) ψ √(2E*)] · √(a m*) · v_n` (the bracket is mixed once per pair
/// type: [`PairCoefficients::normal_damping`]); `a` is the contact radius (m),
/// `m*` the effective mass (kg).
#[inline(always)]
pub fn normal_damping_force<T: Real>(
    c: &PairCoefficients,
    contact_radius_m: T,
    m_star_kg: T,
    v_n: T,
) -> T {
    T::splat(c.normal_damping) * (contact_radius_m * m_star_kg).sqrt() * v_n
}

/// Tangential damping coefficient η_t = −2√(5/6) ψ √(S_t m*), N·s/m (≥ 0), per
/// lane, with `S_t = 8G*a`; the damping force is −η_t v_t. Evaluated as
/// `[−2√(5/6) ψ √(8G*)] · √(a m*)` ([`PairCoefficients::tangential_damping`]),
/// so a contact shares one square root between normal and tangential damping.
#[inline(always)]
pub fn tangential_damping_coefficient<T: Real>(
    c: &PairCoefficients,
    contact_radius_m: T,
    m_star_kg: T,
) -> T {
    T::splat(c.tangential_damping) * (contact_radius_m * m_star_kg).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefactor_is_two_root_five_sixths() {
        assert!((DAMPING_PREFACTOR - 2.0 * (5.0f64 / 6.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn damping_ratio_limits() {
        assert_eq!(damping_ratio(1.0), 0.0);
        assert_eq!(damping_ratio(0.0), -1.0);
        let tiny = damping_ratio(1e-300);
        assert!(tiny.is_finite() && tiny > -1.0 && tiny < -0.99);
        // e = 0.5: ln 0.5 = −0.6931, √(0.4805 + 9.8696) = 3.2172 → ψ = −0.21545.
        assert!((damping_ratio(0.5) + 0.215_44).abs() < 1e-4);
    }
}
