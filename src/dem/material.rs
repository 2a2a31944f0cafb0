//! Elastic materials and their mixing into effective contact moduli.
//!
//! A contact between two bodies sees effective moduli (Hertz / Mindlin theory):
//! `E* = [(1−ν₁²)/E₁ + (1−ν₂²)/E₂]⁻¹` and `G* = [(2−ν₁)/G₁ + (2−ν₂)/G₂]⁻¹` with
//! `G = E / (2(1+ν))` (yan2015 Eq. 4–5 and the text below them). A rigid body
//! (E → ∞) contributes nothing to either sum. Mixing happens once per material
//! pair, never per contact (see [`crate::dem::contact::PairCoefficients`]).

use std::f64::consts::PI;

/// Intrinsic elastic properties of a particle or wall material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticMaterial {
    /// Young's modulus, Pa; `f64::INFINITY` for a rigid body.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio, dimensionless, in [0, 0.5).
    pub poisson_ratio: f64,
}

impl ElasticMaterial {
    /// A rigid material (E → ∞): its compliance terms vanish in the mixing rules.
    pub const RIGID: ElasticMaterial = ElasticMaterial {
        youngs_modulus_pa: f64::INFINITY,
        poisson_ratio: 0.0,
    };

    /// Shear modulus `G = E / (2(1+ν))`, Pa (infinite for a rigid body).
    pub fn shear_modulus_pa(&self) -> f64 {
        self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))
    }

    /// Normal compliance `(1−ν²)/E`, 1/Pa; zero for a rigid body.
    fn normal_compliance(&self) -> f64 {
        if self.youngs_modulus_pa.is_infinite() {
            0.0
        } else {
            (1.0 - self.poisson_ratio * self.poisson_ratio) / self.youngs_modulus_pa
        }
    }

    /// Tangential compliance `(2−ν)/G`, 1/Pa; zero for a rigid body.
    fn tangential_compliance(&self) -> f64 {
        if self.youngs_modulus_pa.is_infinite() {
            0.0
        } else {
            (2.0 - self.poisson_ratio) / self.shear_modulus_pa()
        }
    }
}

/// Effective Young's modulus `E*` of a contact between `a` and `b`, Pa.
pub fn effective_youngs_modulus(a: &ElasticMaterial, b: &ElasticMaterial) -> f64 {
    1.0 / (a.normal_compliance() + b.normal_compliance())
}

/// Effective shear modulus `G*` of a contact between `a` and `b`, Pa.
pub fn effective_shear_modulus(a: &ElasticMaterial, b: &ElasticMaterial) -> f64 {
    1.0 / (a.tangential_compliance() + b.tangential_compliance())
}

/// Harmonic combination `x₁x₂/(x₁+x₂)` used for R* and m*; an infinite partner
/// (a wall) returns the other value.
#[inline]
pub fn harmonic(a: f64, b: f64) -> f64 {
    if b.is_infinite() {
        a
    } else if a.is_infinite() {
        b
    } else {
        a * b / (a + b)
    }
}

/// Rayleigh time `T_R = π R √(ρ/G) / (0.1631 ν + 0.8766)`, s: the time a Rayleigh
/// surface wave needs to cross a sphere of radius `radius_m` (Thornton & Randall,
/// yan2015 Eq. 11). Explicit DEM steps are a fraction of it.
pub fn rayleigh_time_s(radius_m: f64, density_kg_m3: f64, material: &ElasticMaterial) -> f64 {
    PI * radius_m * (density_kg_m3 / material.shear_modulus_pa()).sqrt()
        / (0.1631 * material.poisson_ratio + 0.8766)
}

/// Duration of an elastic Hertz impact, s:
/// `t_c = 2.868 (m*² / (R* E*² v))^{1/5}` for approach speed `speed_m_s`
/// (Johnson, Contact Mechanics §11.4, with `m*`, `R*`, `E*` effective values).
pub fn hertz_contact_time_s(m_star: f64, r_star: f64, e_star: f64, speed_m_s: f64) -> f64 {
    2.868 * (m_star * m_star / (r_star * e_star * e_star * speed_m_s)).powf(0.2)
}

/// Maximum overlap of an elastic Hertz impact, m:
/// `δ_max = (15 m* v² / (16 E* √R*))^{2/5}` (energy balance of the Hertz law).
pub fn hertz_max_overlap_m(m_star: f64, r_star: f64, e_star: f64, speed_m_s: f64) -> f64 {
    (15.0 * m_star * speed_m_s * speed_m_s / (16.0 * e_star * r_star.sqrt())).powf(0.4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_materials_mix_to_textbook_values() {
        // E* = E / (2(1−ν²)) and G* = G / (2(2−ν)) for two identical bodies.
        let m = ElasticMaterial {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
        };
        let e = effective_youngs_modulus(&m, &m);
        assert!((e - 5e6 / (2.0 * 0.91)).abs() < 1e-6);
        let g = effective_shear_modulus(&m, &m);
        let g1 = 5e6 / 2.6;
        assert!((g - g1 / (2.0 * 1.7)).abs() < 1e-6);
    }

    #[test]
    fn rigid_partner_contributes_nothing() {
        let m = ElasticMaterial {
            youngs_modulus_pa: 1e7,
            poisson_ratio: 0.25,
        };
        let e = effective_youngs_modulus(&m, &ElasticMaterial::RIGID);
        assert!((e - 1e7 / (1.0 - 0.0625)).abs() < 1e-6);
        assert!(e.is_finite());
        assert_eq!(harmonic(0.001, f64::INFINITY), 0.001);
        assert_eq!(harmonic(2.0, 2.0), 1.0);
    }

    #[test]
    fn contact_time_is_2_94_max_overlap_over_speed() {
        // Johnson §11.4: t_c = 2.94 δ_max / v for a Hertz impact.
        let (m, r, e, v) = (5e-6, 5e-4, 5e7, 0.5);
        let ratio = hertz_contact_time_s(m, r, e, v) * v / hertz_max_overlap_m(m, r, e, v);
        assert!((ratio - 2.94).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn rayleigh_time_matches_the_benchmark_deck() {
        // ../shared/bench: R = 1 mm, ρ = 2500, E = 5 MPa, ν = 0.3 → dt = 2.4477e-5 s
        // is 0.2 × T_R.
        let m = ElasticMaterial {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
        };
        let t = rayleigh_time_s(1e-3, 2500.0, &m);
        assert!((0.2 * t - 2.4477e-5).abs() < 1e-9, "0.2 T_R = {}", 0.2 * t);
    }
}
