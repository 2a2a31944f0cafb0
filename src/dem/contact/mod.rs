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
//! Every slot is written once, generic over a lane type
//! ([`crate::dem::lanes::Real`]): [`evaluate_lanes`] runs four contacts side
//! by side for the pair kernel, and [`evaluate`] is its one-lane case (walls).
//! Slots whose formula has branches the lanes cannot share (JKR's Newton
//! solve) keep a scalar method, and the trait's default runs it lane by lane.
//!
//! [`sensitivity`] differentiates the Hertz laws analytically with respect to
//! the calibrated parameters (yan2015 "Level 3"), checked against [`evaluate`].
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
pub mod sensitivity;
pub mod tangential_mindlin;

use crate::dem::lanes::{Real, Vec3L, MAX_LANES};
use crate::dem::material::{effective_shear_modulus, effective_youngs_modulus, ElasticMaterial};
use crate::dem::vec3::Vec3;
use std::f64::consts::PI;

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
    /// JKR's `√(4πΓ/E*)`, m^½: δ = a²/R* − this × √a (kept here so the JKR
    /// law does not recompute it per contact and step).
    pub jkr_adhesion: f64,
    /// JKR's `4√(πΓE*)`, N/m^{3/2}: the adhesive force is this × a^{3/2}.
    pub jkr_tension: f64,
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
            jkr_adhesion: (4.0 * PI * p.surface_energy_j_m2 / e_star).sqrt(),
            jkr_tension: 4.0 * (PI * p.surface_energy_j_m2 * e_star).sqrt(),
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
    /// Relative normal velocity of *i* along `normal`, m/s (negative while
    /// the bodies approach).
    pub normal_velocity_m_s: f64,
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

/// A normal model's answer for several contacts at once (one per lane of
/// `T`): [`NormalResponse`] per lane, with `active` false where the bodies do
/// not interact (the other fields are then meaningless).
#[derive(Clone, Copy, Debug)]
pub struct NormalLanes<T: Real> {
    /// Which lanes interact.
    pub active: T::Mask,
    /// Elastic (and adhesive) normal force, N; positive repulsive.
    pub elastic_force_n: T,
    /// Contact radius a, m.
    pub contact_radius_m: T,
    /// Pull-off force 3πΓR*, N (0 for Hertz).
    pub pull_off_force_n: T,
}

/// The normal-force slot.
pub trait NormalModel: Send + Sync + 'static {
    /// Per-contact state this model keeps between steps (zero-sized if none).
    type History: Copy + Default + PartialEq + Send + Sync + std::fmt::Debug;
    /// Name recorded in results (`hertz`, `jkr`).
    const NAME: &'static str;
    /// Whether the model can attract (then surface energy turns into kinetic
    /// energy and the closed-system energy check does not apply).
    const ADHESIVE: bool;
    /// How far beyond touching (m, ≥ 0) this model can still act for a contact
    /// of effective radius `r_star_m`; the neighbour search widens by this.
    fn reach_m(c: &PairCoefficients, r_star_m: f64) -> f64;
    /// Evaluates the model for `T::LANES` contacts at once (`history` holds
    /// one entry per lane): overlaps `overlap_m` (m), effective radii
    /// `r_star_m` (m). Lanes where the bodies do not interact are inactive
    /// (the caller then resets their whole contact history).
    fn normal_lanes<T: Real>(
        c: &PairCoefficients,
        r_star_m: T,
        overlap_m: T,
        history: &mut [Self::History],
    ) -> NormalLanes<T>;
    /// [`normal_lanes`](Self::normal_lanes) for one contact; `None` when the
    /// bodies do not interact.
    #[inline(always)]
    fn normal(
        c: &PairCoefficients,
        r_star_m: f64,
        overlap_m: f64,
        history: &mut Self::History,
    ) -> Option<NormalResponse> {
        let r = Self::normal_lanes::<f64>(c, r_star_m, overlap_m, std::slice::from_mut(history));
        r.active.then_some(NormalResponse {
            elastic_force_n: r.elastic_force_n,
            contact_radius_m: r.contact_radius_m,
            pull_off_force_n: r.pull_off_force_n,
        })
    }
}

/// The rolling-resistance slot.
pub trait RollingModel: Send + Sync + 'static {
    /// Per-contact state (zero-sized if none).
    type History: Copy + Default + PartialEq + Send + Sync + std::fmt::Debug;
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
    /// [`torque`](Self::torque) for `T::LANES` contacts at once (`history`
    /// holds one entry per lane). The default asks [`torque`](Self::torque)
    /// lane by lane; branch-free models override it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn torque_lanes<T: Real>(
        c: &PairCoefficients,
        r_star_m: T,
        contact_radius_m: T,
        load_n: T,
        normal: &Vec3L<T>,
        rolling_velocity: &Vec3L<T>,
        dt_s: f64,
        history: &mut [Self::History],
    ) -> Vec3L<T> {
        Vec3L::from_fn(|l| {
            Self::torque(
                c,
                r_star_m.lane(l),
                contact_radius_m.lane(l),
                load_n.lane(l),
                &normal.lane(l),
                &rolling_velocity.lane(l),
                dt_s,
                &mut history[l],
            )
        })
    }
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
impl<N: NormalModel, R: RollingModel> PartialEq for ContactHistory<N, R> {
    fn eq(&self, o: &Self) -> bool {
        self.normal == o.normal && self.tangential == o.tangential && self.rolling == o.rolling
    }
}
impl<N: NormalModel, R: RollingModel> Default for ContactHistory<N, R> {
    fn default() -> Self {
        Self {
            normal: N::History::default(),
            tangential: Vec3::zeros(),
            rolling: R::History::default(),
        }
    }
}

/// [`ContactGeometry`] of several contacts, one per lane of `T`.
#[derive(Clone, Copy, Debug)]
pub struct GeometryLanes<T: Real> {
    /// Unit normals from the partner towards body *i*.
    pub normal: Vec3L<T>,
    /// Overlaps δ, m.
    pub overlap_m: T,
    /// Effective radii R*, m.
    pub r_star_m: T,
    /// Effective masses m*, kg.
    pub m_star_kg: T,
}

/// [`RelativeMotion`] of several contacts, one per lane of `T`.
#[derive(Clone, Copy, Debug)]
pub struct MotionLanes<T: Real> {
    /// Contact-point velocity of *i* minus the partner's, m/s.
    pub velocity: Vec3L<T>,
    /// ω_i − ω_j, rad/s.
    pub angular_velocity: Vec3L<T>,
}

/// [`ContactResponse`] of several contacts, one per lane of `T`; lanes with
/// `active` false do not interact (their other fields are meaningless).
#[derive(Clone, Copy, Debug)]
pub struct ResponseLanes<T: Real> {
    /// Which lanes interact.
    pub active: T::Mask,
    /// Total contact force on *i*, N.
    pub force: Vec3L<T>,
    /// Its tangential part, N.
    pub tangential_force: Vec3L<T>,
    /// Rolling torque on *i*, N·m.
    pub rolling_torque: Vec3L<T>,
    /// Signed normal force along the normal, N (positive repulsive).
    pub normal_force_n: T,
    /// Relative normal velocity along the normal, m/s (negative while the
    /// bodies approach).
    pub normal_velocity_m_s: T,
}

/// Evaluates the composed law `N + damping + Mindlin + R` for `T::LANES`
/// contacts sharing one coefficient set, updating their histories (one entry
/// per lane). Lanes with `in_range` false, or that the normal model finds
/// apart, do not interact: their history is reset. Each lane's result is
/// bit-identical to evaluating its contact alone (see [`crate::dem::lanes`]).
#[inline(always)]
pub fn evaluate_lanes<N: NormalModel, R: RollingModel, T: Real>(
    c: &PairCoefficients,
    geometry: &GeometryLanes<T>,
    motion: &MotionLanes<T>,
    in_range: T::Mask,
    dt_s: f64,
    history: &mut [ContactHistory<N, R>],
) -> ResponseLanes<T> {
    let lanes = T::LANES;
    let r_star = geometry.r_star_m;
    let mut normal_history: [N::History; MAX_LANES] = std::array::from_fn(|l| {
        if l < lanes {
            history[l].normal
        } else {
            Default::default()
        }
    });
    let nr = N::normal_lanes(c, r_star, geometry.overlap_m, &mut normal_history[..lanes]);
    let active = T::and(in_range, nr.active);
    let n = geometry.normal;
    let a = nr.contact_radius_m;
    let m_star = geometry.m_star_kg;
    let v_n = motion.velocity.dot(&n);
    let v_t = motion.velocity - n.scale(v_n);

    let elastic = nr.elastic_force_n;
    let mut f_n = elastic + damping::normal_damping_force(c, a, m_star, v_n);
    if c.clip_tensile {
        f_n = T::from_fn(|l| f_n.lane(l).max(elastic.lane(l).min(0.0)));
    }
    let load = (elastic + T::splat(2.0) * nr.pull_off_force_n).abs();

    let mut xi = Vec3L::from_fn(|l| history[l].tangential);
    let f_t = tangential_mindlin::force(c, a, m_star, load, &n, &v_t, dt_s, &mut xi);
    let w = motion.angular_velocity;
    let w_roll = w - n.scale(w.dot(&n));
    let mut rolling_history: [R::History; MAX_LANES] = std::array::from_fn(|l| {
        if l < lanes {
            history[l].rolling
        } else {
            Default::default()
        }
    });
    let m_r = R::torque_lanes(
        c,
        r_star,
        a,
        load,
        &n,
        &w_roll,
        dt_s,
        &mut rolling_history[..lanes],
    );
    for (l, h) in history.iter_mut().enumerate().take(lanes) {
        *h = if T::flag(active, l) {
            ContactHistory {
                normal: normal_history[l],
                tangential: xi.lane(l),
                rolling: rolling_history[l],
            }
        } else {
            ContactHistory::default()
        };
    }
    ResponseLanes {
        active,
        force: n.scale(f_n) + f_t,
        tangential_force: f_t,
        rolling_torque: m_r,
        normal_force_n: f_n,
        normal_velocity_m_s: v_n,
    }
}

/// Evaluates the composed law `N + damping + Mindlin + R` for one contact,
/// updating its history. Returns `None` (and resets the history) when the
/// bodies do not interact. The one-lane case of [`evaluate_lanes`].
#[inline(always)]
pub fn evaluate<N: NormalModel, R: RollingModel>(
    c: &PairCoefficients,
    geometry: &ContactGeometry,
    motion: &RelativeMotion,
    dt_s: f64,
    history: &mut ContactHistory<N, R>,
) -> Option<ContactResponse> {
    let lanes = GeometryLanes::<f64> {
        normal: Vec3L::splat(geometry.normal),
        overlap_m: geometry.overlap_m,
        r_star_m: geometry.r_star_m,
        m_star_kg: geometry.m_star_kg,
    };
    let motion = MotionLanes {
        velocity: Vec3L::splat(motion.velocity),
        angular_velocity: Vec3L::splat(motion.angular_velocity),
    };
    let r = evaluate_lanes::<N, R, f64>(
        c,
        &lanes,
        &motion,
        true,
        dt_s,
        std::slice::from_mut(history),
    );
    r.active.then(|| ContactResponse {
        force: r.force.lane(0),
        tangential_force: r.tangential_force.lane(0),
        rolling_torque: r.rolling_torque.lane(0),
        normal_force_n: r.normal_force_n,
        normal_velocity_m_s: r.normal_velocity_m_s,
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
    use super::normal_hertz::Hertz;
    use super::normal_jkr::Jkr;
    use super::rolling_cdt::ConstantDirectionalTorque;
    use super::rolling_epsd::ElasticPlasticSpring;
    use super::rolling_none::NoRolling;
    use super::*;
    use crate::dem::lanes::F64x4;
    use rand::{Rng, SeedableRng};

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

    /// A random contact: overlaps from apart to deep, sticking and sliding
    /// tangential speeds, spins, and histories from empty to beyond the cap.
    fn random_contact<N: NormalModel, R: RollingModel>(
        rng: &mut impl Rng,
    ) -> (ContactGeometry, RelativeMotion, ContactHistory<N, R>) {
        let unit =
            |rng: &mut dyn FnMut() -> f64| Vec3::new(rng(), rng(), rng()) * 2.0 - Vec3::repeat(1.0);
        let mut draw = || rng.random::<f64>();
        let normal = unit(&mut draw).normalize();
        let velocity = unit(&mut draw);
        let angular_velocity = unit(&mut draw) * 300.0;
        let xi = unit(&mut draw) * 1e-6;
        let spin = unit(&mut draw);
        let seeded_normal = unit(&mut draw).normalize();
        let r_star = 5e-4 * (1.0 + rng.random::<f64>());
        let mut history = ContactHistory::<N, R>::default();
        if rng.random::<f64>() < 0.7 {
            // A contact that has been touching: seed every history slot by
            // evaluating once at a healthy overlap.
            let seeded = ContactGeometry {
                normal: seeded_normal,
                overlap_m: 1e-6,
                r_star_m: r_star,
                m_star_kg: 1e-6,
            };
            let motion = RelativeMotion {
                velocity: spin * 0.1,
                angular_velocity: spin * 50.0,
            };
            history.tangential = xi;
            evaluate(
                &coefficients_for_lanes(),
                &seeded,
                &motion,
                1e-5,
                &mut history,
            );
        }
        let geometry = ContactGeometry {
            normal,
            overlap_m: 4e-6 * (rng.random::<f64>() - 0.2),
            r_star_m: r_star,
            m_star_kg: 1e-6 * (1.0 + rng.random::<f64>()),
        };
        let motion = RelativeMotion {
            velocity: velocity * rng.random::<f64>(),
            angular_velocity: if rng.random::<f64>() < 0.2 {
                Vec3::zeros()
            } else {
                angular_velocity
            },
        };
        (geometry, motion, history)
    }

    fn coefficients_for_lanes() -> PairCoefficients {
        test_support::coefficients(0.3, 0.4, 0.2, 0.05)
    }

    /// Four lanes give bit for bit what four scalar evaluations give, for
    /// every normal × rolling kernel (the pair kernel's SIMD path against the
    /// walls' scalar path; see crate::dem::lanes).
    fn four_lanes_equal_four_scalars<N: NormalModel, R: RollingModel>() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261121);
        let c = coefficients_for_lanes();
        let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let mut active_lanes = 0;
        for _ in 0..2_000 {
            let contacts: [_; 4] = std::array::from_fn(|_| random_contact::<N, R>(&mut rng));
            let in_range = [true, true, true, rng.random::<f64>() < 0.8];
            let geometry = GeometryLanes::<F64x4> {
                normal: Vec3L::from_fn(|l| contacts[l].0.normal),
                overlap_m: F64x4::from_fn(|l| contacts[l].0.overlap_m),
                r_star_m: F64x4::from_fn(|l| contacts[l].0.r_star_m),
                m_star_kg: F64x4::from_fn(|l| contacts[l].0.m_star_kg),
            };
            let motion = MotionLanes {
                velocity: Vec3L::from_fn(|l| contacts[l].1.velocity),
                angular_velocity: Vec3L::from_fn(|l| contacts[l].1.angular_velocity),
            };
            let mut lane_history: [ContactHistory<N, R>; 4] =
                std::array::from_fn(|l| contacts[l].2);
            let mask = F64x4::mask_from_fn(|l| in_range[l]);
            let r = evaluate_lanes(&c, &geometry, &motion, mask, 1e-5, &mut lane_history);
            for l in 0..4 {
                let (g, m, mut h) = contacts[l];
                let scalar = if in_range[l] {
                    evaluate(&c, &g, &m, 1e-5, &mut h)
                } else {
                    h = ContactHistory::default();
                    None
                };
                assert_eq!(F64x4::flag(r.active, l), scalar.is_some(), "lane {l}");
                let lh = &lane_history[l];
                assert_eq!(bits(lh.tangential), bits(h.tangential), "history, lane {l}");
                // Debug prints each f64 so that it round-trips: equal text, equal bits.
                assert_eq!(format!("{:?}", lh.normal), format!("{:?}", h.normal));
                assert_eq!(format!("{:?}", lh.rolling), format!("{:?}", h.rolling));
                if let Some(s) = scalar {
                    active_lanes += 1;
                    assert_eq!(bits(r.force.lane(l)), bits(s.force), "force, lane {l}");
                    assert_eq!(bits(r.tangential_force.lane(l)), bits(s.tangential_force));
                    assert_eq!(bits(r.rolling_torque.lane(l)), bits(s.rolling_torque));
                    assert_eq!(
                        r.normal_force_n.lane(l).to_bits(),
                        s.normal_force_n.to_bits()
                    );
                }
            }
        }
        assert!(
            active_lanes > 4_000,
            "too few touching lanes: {active_lanes}"
        );
    }

    #[test]
    fn lanes_are_bit_identical_to_scalar_evaluation() {
        four_lanes_equal_four_scalars::<Hertz, NoRolling>();
        four_lanes_equal_four_scalars::<Hertz, ConstantDirectionalTorque>();
        four_lanes_equal_four_scalars::<Hertz, ElasticPlasticSpring>();
        four_lanes_equal_four_scalars::<Jkr, ConstantDirectionalTorque>();
        four_lanes_equal_four_scalars::<Jkr, ElasticPlasticSpring>();
    }
}
