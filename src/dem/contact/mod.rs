//! Contact laws, composed from fixed slots like LAMMPS `pair granular`:
//! a normal model ([`normal_hertz`] | [`normal_jkr`]), viscous normal and
//! tangential damping ([`damping`]), the Mindlin tangential spring with a Coulomb
//! cap ([`tangential_mindlin`]) and a rolling model ([`rolling_none`] |
//! [`rolling_cdt`] | [`rolling_epsd`]).
//!
//! Each slot is a type; [`evaluate`] is generic over the normal and rolling
//! models, so a switched-off slot (e.g. [`rolling_none::NoRolling`]) compiles to
//! nothing: no branch per contact and no history storage (its history type is
//! zero-sized). Only JKR acts beyond touching, so only JKR widens the neighbour
//! search ([`NormalModel::reach_m`]).
//!
//! The load L that caps friction (μ_s L) and rolling (μ_r R* L) is the
//! elastic normal force, shifted by twice the pull-off force for JKR:
//! `L = |F_el + 2F_pulloff|` (Hertz: `L = F_el ≥ 0`; JKR: `L ≥ F_pulloff` on
//! the stable branch, vanishing only at the pull-off point as in Thornton's
//! JKR friction). yan2015 Eq. 7 writes |F_n| with the damped force; the damping
//! is left out on purpose: ψ-damping depends on δ only, so its impulse over a
//! whole contact is exactly zero and ∫F_el dt equals the normal impulse
//! (1+e)m*v — the gross-sliding impulse then matches the rigid-body closed
//! form of Chung & Ooi (2011) exactly, where |F_n| overshoots it by 6.7 %
//! (e = 0.5) through the tensile tail of the damped force. It also keeps the
//! cap continuous at contact onset, where the damped force jumps.
//!
//! Sign conventions for one contact between body *i* and its partner *j* (a
//! particle or a wall): `normal` is the unit vector from *j* towards *i*, the
//! overlap `δ` is positive when the bodies interpenetrate, and every returned
//! force and torque acts on *i* (the partner receives the opposite force and the
//! torques the caller computes from the lever arms).

pub mod damping;
pub mod normal_hertz;
pub mod normal_jkr;
pub mod rolling_cdt;
pub mod rolling_epsd;
pub mod rolling_none;
pub mod tangential_mindlin;

use crate::dem::material::{effective_shear_modulus, effective_youngs_modulus, ElasticMaterial};
use crate::dem::vec3::Vec3;

/// The user-facing contact parameters of one pair type (particle–particle or
/// particle–one wall material), before mixing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParameters {
    /// Normal coefficient of restitution, in (0, 1].
    pub restitution: f64,
    /// Coulomb (sliding) friction coefficient μ_s, ≥ 0.
    pub static_friction: f64,
    /// Rolling friction coefficient μ_r, ≥ 0 (dimensionless; the torque cap is
    /// μ_r R* F_n).
    pub rolling_friction: f64,
    /// JKR surface energy per surface Γ, J/m² (work of adhesion 2Γ), ≥ 0.
    pub surface_energy_j_m2: f64,
}

/// A parameter given to the engine was outside what the physics allows.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{name} = {value}: {allowed}")]
pub struct ParameterError {
    /// Which parameter (e.g. `restitution`).
    pub name: &'static str,
    /// The offending value.
    pub value: f64,
    /// What is allowed.
    pub allowed: &'static str,
}

/// Everything a contact law needs about a material pair, mixed once per pair
/// type and never per contact (the "mixed table" of LAMMPS/LIGGGHTS).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairCoefficients {
    /// Effective Young's modulus E*, Pa.
    pub e_star: f64,
    /// Effective shear modulus G*, Pa.
    pub g_star: f64,
    /// Damping ratio ψ = ln e / √(ln² e + π²) ∈ [−1, 0]; −1 in the limit e → 0.
    pub psi: f64,
    /// Coulomb friction coefficient μ_s.
    pub static_friction: f64,
    /// Rolling friction coefficient μ_r.
    pub rolling_friction: f64,
    /// JKR surface energy per surface Γ, J/m².
    pub surface_energy_j_m2: f64,
    /// `2√(5/6) ψ √(2E*)`: the normal damping force is this × √(a m*) × v_n
    /// (see [`damping::normal_damping_force`]).
    pub normal_damping: f64,
    /// `−2√(5/6) ψ √(8G*)` (≥ 0): the tangential damping coefficient is this ×
    /// √(a m*) (see [`damping::tangential_damping_coefficient`]).
    pub tangential_damping: f64,
    /// Clip the damped normal force so damping never pulls the bodies together
    /// beyond the elastic (adhesive) force. Off by default: then the measured
    /// restitution equals the input for every e in (0, 1]. On, the damped Hertz
    /// force is floored at zero and the lowest reachable restitution is about
    /// e⁻² ≈ 0.135 whatever smaller e is asked for.
    pub clip_tensile: bool,
}

impl PairCoefficients {
    /// Mixes two materials and a pair's parameters, checking each parameter.
    pub fn new(
        a: &ElasticMaterial,
        b: &ElasticMaterial,
        p: &PairParameters,
        clip_tensile: bool,
    ) -> Result<Self, ParameterError> {
        check(
            "restitution",
            p.restitution,
            p.restitution > 0.0 && p.restitution <= 1.0,
            "must be in (0, 1]",
        )?;
        check(
            "static_friction",
            p.static_friction,
            p.static_friction >= 0.0,
            "must be finite and >= 0",
        )?;
        check(
            "rolling_friction",
            p.rolling_friction,
            p.rolling_friction >= 0.0,
            "must be finite and >= 0",
        )?;
        check(
            "surface_energy_j_m2",
            p.surface_energy_j_m2,
            p.surface_energy_j_m2 >= 0.0,
            "must be finite and >= 0",
        )?;
        for m in [a, b] {
            if m.youngs_modulus_pa.is_nan() || m.youngs_modulus_pa <= 0.0 {
                return Err(ParameterError {
                    name: "youngs_modulus_pa",
                    value: m.youngs_modulus_pa,
                    allowed: "must be > 0 (infinite means rigid)",
                });
            }
            check(
                "poisson_ratio",
                m.poisson_ratio,
                (0.0..0.5).contains(&m.poisson_ratio),
                "must be in [0, 0.5)",
            )?;
        }
        if a.youngs_modulus_pa.is_infinite() && b.youngs_modulus_pa.is_infinite() {
            return Err(ParameterError {
                name: "youngs_modulus_pa",
                value: f64::INFINITY,
                allowed: "at most one body of a contact may be rigid",
            });
        }
        let e_star = effective_youngs_modulus(a, b);
        let g_star = effective_shear_modulus(a, b);
        let psi = damping::damping_ratio(p.restitution);
        Ok(Self {
            e_star,
            g_star,
            psi,
            normal_damping: damping::DAMPING_PREFACTOR * psi * (2.0 * e_star).sqrt(),
            tangential_damping: -damping::DAMPING_PREFACTOR * psi * (8.0 * g_star).sqrt(),
            static_friction: p.static_friction,
            rolling_friction: p.rolling_friction,
            surface_energy_j_m2: p.surface_energy_j_m2,
            clip_tensile,
        })
    }
}

fn check(
    name: &'static str,
    value: f64,
    ok: bool,
    allowed: &'static str,
) -> Result<(), ParameterError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(ParameterError {
            name,
            value,
            allowed,
        })
    }
}

/// Geometry of one contact at the current step.
#[derive(Clone, Copy, Debug)]
pub struct ContactGeometry {
    /// Unit normal from the partner towards body *i*.
    pub normal: Vec3,
    /// Overlap δ, m: positive when interpenetrating, negative for a gap.
    pub overlap_m: f64,
    /// Effective radius R*, m (R_i for a wall).
    pub r_star_m: f64,
    /// Effective mass m*, kg (m_i for a wall).
    pub m_star_kg: f64,
}

/// Relative motion of body *i* with respect to its partner at the contact.
#[derive(Clone, Copy, Debug)]
pub struct RelativeMotion {
    /// Velocity of *i*'s material at the contact point minus the partner's, m/s.
    pub velocity: Vec3,
    /// Angular velocity ω_i − ω_j, rad/s (ω_j = 0 for a wall).
    pub angular_velocity: Vec3,
}

/// The forces a contact exerts on body *i*.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactResponse {
    /// Total contact force on *i* (normal + tangential), N.
    pub force: Vec3,
    /// The tangential part of `force`, N; the caller turns it into torques
    /// with each body's lever arm.
    pub tangential_force: Vec3,
    /// Rolling-resistance torque on *i*, N·m (the partner receives its negative).
    pub rolling_torque: Vec3,
    /// Signed normal force magnitude along `normal`, N (positive repulsive).
    pub normal_force_n: f64,
}

/// What a normal model reports for a contact that is active this step.
#[derive(Clone, Copy, Debug)]
pub struct NormalResponse {
    /// Elastic (and adhesive) normal force along the normal, N; positive repulsive.
    pub elastic_force_n: f64,
    /// Contact radius a, m: √(R*δ) for Hertz, the JKR radius for JKR. Sets the
    /// normal stiffness S_n = 2E*a, tangential S_t = 8G*a and rolling k_r = 8G*aR*².
    pub contact_radius_m: f64,
    /// Pull-off force 3πΓR*, N (0 for Hertz); the Coulomb and rolling caps use
    /// the load |F_el + 2 F_pulloff| (see the module docs).
    pub pull_off_force_n: f64,
}

/// The normal-force slot.
pub trait NormalModel: Send + Sync + 'static {
    /// Per-contact state this model keeps between steps (zero-sized if none).
    type History: Copy + Default + Send + Sync + std::fmt::Debug;
    /// Name recorded in results (`hertz`, `jkr`).
    const NAME: &'static str;
    /// Whether the model can attract (then surface energy turns into kinetic
    /// energy and the closed-system energy check does not apply).
    const ADHESIVE: bool;
    /// How far beyond touching (m, ≥ 0) this model can still act for a contact
    /// of effective radius `r_star_m`; the neighbour search widens by this.
    fn reach_m(c: &PairCoefficients, r_star_m: f64) -> f64;
    /// Evaluates the model at overlap `overlap_m`; `None` when the bodies do not
    /// interact (the caller then resets the whole contact history).
    fn normal(
        c: &PairCoefficients,
        r_star_m: f64,
        overlap_m: f64,
        history: &mut Self::History,
    ) -> Option<NormalResponse>;
}

/// The rolling-resistance slot.
pub trait RollingModel: Send + Sync + 'static {
    /// Per-contact state (zero-sized if none).
    type History: Copy + Default + Send + Sync + std::fmt::Debug;
    /// Name recorded in results (`none`, `cdt`, `epsd`).
    const NAME: &'static str;
    /// Rolling torque on body *i*, N·m.
    ///
    /// `rolling_velocity` is the tangential part of ω_i − ω_j (rad/s), `load_n`
    /// the cap load |F_el + 2F_pulloff| (N), `dt_s` the step.
    #[allow(clippy::too_many_arguments)]
    fn torque(
        c: &PairCoefficients,
        r_star_m: f64,
        contact_radius_m: f64,
        load_n: f64,
        normal: &Vec3,
        rolling_velocity: &Vec3,
        dt_s: f64,
        history: &mut Self::History,
    ) -> Vec3;
}

/// All history one contact keeps: the normal model's, the tangential spring
/// elongation (m) and the rolling model's.
#[derive(Debug)]
pub struct ContactHistory<N: NormalModel, R: RollingModel> {
    /// Normal-model state (JKR: contact radius, 0 before first touch).
    pub normal: N::History,
    /// Accumulated tangential displacement ξ, m, kept in the tangent plane.
    pub tangential: Vec3,
    /// Rolling-model state (EPSD: the elastic rolling torque).
    pub rolling: R::History,
}

impl<N: NormalModel, R: RollingModel> Clone for ContactHistory<N, R> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<N: NormalModel, R: RollingModel> Copy for ContactHistory<N, R> {}
impl<N: NormalModel, R: RollingModel> Default for ContactHistory<N, R> {
    fn default() -> Self {
        Self {
            normal: N::History::default(),
            tangential: Vec3::zeros(),
            rolling: R::History::default(),
        }
    }
}

/// Evaluates the composed law `N + damping + Mindlin + R` for one contact,
/// updating its history. Returns `None` (and resets the history) when the
/// bodies do not interact.
#[inline(always)]
pub fn evaluate<N: NormalModel, R: RollingModel>(
    c: &PairCoefficients,
    geometry: &ContactGeometry,
    motion: &RelativeMotion,
    dt_s: f64,
    history: &mut ContactHistory<N, R>,
) -> Option<ContactResponse> {
    let r_star = geometry.r_star_m;
    let Some(nr) = N::normal(c, r_star, geometry.overlap_m, &mut history.normal) else {
        *history = ContactHistory::default();
        return None;
    };
    let n = geometry.normal;
    let a = nr.contact_radius_m;
    let m_star = geometry.m_star_kg;
    let v_n = motion.velocity.dot(&n);
    let v_t = motion.velocity - n * v_n;

    let damping_n = damping::normal_damping_force(c, a, m_star, v_n);
    let mut f_n = nr.elastic_force_n + damping_n;
    if c.clip_tensile {
        f_n = f_n.max(nr.elastic_force_n.min(0.0));
    }
    let load = (nr.elastic_force_n + 2.0 * nr.pull_off_force_n).abs();

    let f_t =
        tangential_mindlin::force(c, a, m_star, load, &n, &v_t, dt_s, &mut history.tangential);
    let w = motion.angular_velocity;
    let w_roll = w - n * w.dot(&n);
    let m_r = R::torque(c, r_star, a, load, &n, &w_roll, dt_s, &mut history.rolling);
    Some(ContactResponse {
        force: n * f_n + f_t,
        tangential_force: f_t,
        rolling_torque: m_r,
        normal_force_n: f_n,
    })
}

/// The largest extra search range (m) model `N` needs for any contact with
/// effective radius up to `r_star_max_m` under the given coefficient sets.
pub fn max_reach_m<'a, N: NormalModel>(
    coefficients: impl IntoIterator<Item = &'a PairCoefficients>,
    r_star_max_m: f64,
) -> f64 {
    coefficients
        .into_iter()
        .map(|c| N::reach_m(c, r_star_max_m))
        .fold(0.0, f64::max)
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::*;

    /// Glass-like coefficients for unit tests: E = 5 MPa, ν = 0.3 spheres.
    pub fn coefficients(e: f64, mu: f64, mu_r: f64, gamma: f64) -> PairCoefficients {
        let m = ElasticMaterial {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
        };
        PairCoefficients::new(
            &m,
            &m,
            &PairParameters {
                restitution: e,
                static_friction: mu,
                rolling_friction: mu_r,
                surface_energy_j_m2: gamma,
            },
            false,
        )
        .unwrap()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_checked_with_their_names() {
        let m = ElasticMaterial {
            youngs_modulus_pa: 1e7,
            poisson_ratio: 0.3,
        };
        let mut p = PairParameters {
            restitution: 1.3,
            static_friction: 0.5,
            rolling_friction: 0.1,
            surface_energy_j_m2: 0.0,
        };
        let e = PairCoefficients::new(&m, &m, &p, false).unwrap_err();
        assert_eq!(e.to_string(), "restitution = 1.3: must be in (0, 1]");
        p.restitution = 0.5;
        p.static_friction = f64::NAN;
        assert_eq!(
            PairCoefficients::new(&m, &m, &p, false).unwrap_err().name,
            "static_friction"
        );
        p.static_friction = 0.5;
        let rigid = ElasticMaterial::RIGID;
        assert!(PairCoefficients::new(&rigid, &rigid, &p, false).is_err());
        assert!(PairCoefficients::new(&m, &rigid, &p, false).is_ok());
    }
}
