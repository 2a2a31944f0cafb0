//! Analytic parameter sensitivities of the contact laws (yan2015 §2.2.3
//! "Level 3" and §4.2.3): the force and torque magnitudes of one
//! particle–particle contact and their derivatives with respect to the four
//! calibrated parameters — restitution e, sliding friction μs, rolling
//! friction μr and Young's modulus E — at an a-priori contact state.
//!
//! The derivatives are written from the same laws the engine evaluates
//! ([`super::normal_hertz`], [`super::damping`], [`super::tangential_mindlin`],
//! [`super::rolling_epsd`], [`super::rolling_cdt`], [`super::rolling_none`]),
//! through the coefficients [`PairCoefficients::new`] mixes, and
//! [`engine_response`] evaluates the engine's own [`evaluate`] at the same
//! state, so a test can hold the closed form to the engine (values and
//! central finite differences) and the sensitivities cannot drift from the
//! physics. Only the Hertz normal model is covered: JKR (adhesion, its own
//! contact radius and a shifted cap load) is out of scope.
//!
//! # Contact set-up
//!
//! Two identical spheres of radius R and density ρ ([`PairSpec`]) touch with
//! the state of [`ContactState`]:
//!
//! - normal n = +z (from j towards i), overlap δn, R* = R/2 and m* = m/2
//!   with m = ρ·(4/3)πR³ — the engine's harmonic means for identical spheres;
//! - relative velocity of i at the contact (vt, 0, −vn): the bodies approach
//!   at vn, so the normal damping is repulsive and adds to the elastic force;
//! - relative angular velocity (0, ω, 0), tangent to the contact (all of it
//!   is rolling);
//! - tangential spring history ξ = (δt, 0, 0), along the slip, so spring and
//!   damping both oppose it (the magnitudes add, as in a loading contact);
//! - rolling history (EPSD only): the elastic torque of an accumulated
//!   relative rotation φ = δt/R* opposing ω, m = (0, −k_r φ, 0) with
//!   k_r = 8G*aR*², the rotation that rolls the contact through the same
//!   displacement δt (mirroring yan2015's choice δn = δt);
//! - time step dt = 0, so [`evaluate`] adds no increment to either history
//!   and the state is exactly the one described.
//!
//! The force magnitude is |F| of the total contact force on i
//! (F = f_n n + F_t), the torque magnitude |τ| with τ = M_r − (n × F_t)·arm_i
//! and arm_i = R − δn/2, exactly as the pair kernel
//! (`crate::dem::simulation::pair_kernel`) turns a contact into torques.
//! With this set-up the friction force on i points along −x, so its torque
//! (n × F_t)·arm_i acts along −y and enters τ with a plus sign, while the
//! rolling torque opposes ω (along −y): the two partly cancel in |τ|. This
//! follows from taking the slip and the spin of yan2015's states as
//! independent (a pure roll of i with ω > 0 would slip along −x instead).
//!
//! # What each parameter reaches
//!
//! - Normal: f_n = F_el + F_d with F_el = (4/3)E*aδn, a = √(R*δn), and
//!   F_d = 2√(5/6) ψ √(2E*) √(a m*) (−vn), ψ(e) = ln e/√(ln²e + π²). The cap
//!   load L is the elastic force F_el (see [`super`]).
//! - Tangential (Mindlin, Coulomb cap μs L), every branch of
//!   [`super::tangential_mindlin::force`]: *sliding* when the spring force
//!   8G*a|δt| alone exceeds μs L (then |F_t| = μs L), *clipped* when it does
//!   not but spring plus damping η_t vt does (|F_t| = μs L), *sticking*
//!   otherwise (F_t = spring + damping, with no μs in it).
//! - Rolling: EPSD *elastic* (|M_r| = k_r φ = 8G*aR*δt, no μr) or *plastic*
//!   at the cap μr R* L; CDT always μr R* L along −ω̂ (zero for ω = 0); none
//!   zero.
//! - E* and G* are both proportional to E (fixed ν), so ∂E*/∂E = E*/E and
//!   ∂G*/∂E = G*/E; the dashpots go as √E.
//!
//! Our EPSD has no rolling dashpot (yan2015 Eq. 8–10 give none) and CDT uses
//! only the direction of ω, so ω does not enter our force or torque except
//! through its sign: the a-priori states that differ only in ω give equal
//! rows. That is a property of these laws, not an omission here.
//!
//! # What yan2015's states do with these laws
//!
//! With δt = δn the ratio of spring force to Coulomb cap,
//! 8G*aδt / (μs (4/3)E*aδn) = 6G*/(E* μs), is the same at every state, and
//! so is the ratio of the EPSD elastic torque to its cap, 6G*/(E* μr)
//! (6G*/E* = 1.286 for ν = 0.25): for μs < 6G*/E* all 81 states slide, and
//! for μr < 6G*/E* EPSD sits at its cap at all of them — yan2015's own
//! values (μs = 0.5, μr = 0.05) do both. Then the torque is
//! L(μs·arm − μr R*) (for EPSD and CDT; L μs·arm without rolling), which is
//! proportional to E and free of e: its e column is zero and its scaled E
//! column is exactly μs·∂τ/∂μs + μr·∂τ/∂μr (Euler's theorem), so the torque
//! sensitivity matrix alone has rank 2. The force never depends on μr (its
//! μr column is zero), but its √E normal dashpot separates E from the
//! frictions, so force and torque rows together are of full rank. Larger
//! μs (or a shorter δt) makes the spring stick, with the damping clipped at
//! the cap at the fastest slips; then μs drops out of the sticking rows.
//!
//! Derivatives of the magnitudes follow ∂|v|/∂p = v·∂v/∂p / |v| (zero where
//! |v| = 0, where the magnitude has no derivative). At a cap switch the
//! response has a kink and the derivative given is that of the branch the
//! engine takes.

use super::damping::DAMPING_PREFACTOR;
use super::normal_hertz::Hertz;
use super::rolling_cdt::ConstantDirectionalTorque;
use super::rolling_epsd::ElasticPlasticSpring;
use super::rolling_none::NoRolling;
use super::{
    evaluate, ContactGeometry, ContactHistory, PairCoefficients, PairParameters, RelativeMotion,
    RollingModel,
};
use crate::dem::material::ElasticMaterial;
use crate::dem::vec3::Vec3;
use std::f64::consts::PI;

/// The four parameters, in this order everywhere: e, μs, μr, E.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Parameter {
    /// Normal coefficient of restitution e, dimensionless, in (0, 1].
    Restitution,
    /// Coulomb (sliding) friction coefficient μs, dimensionless.
    StaticFriction,
    /// Rolling friction coefficient μr, dimensionless.
    RollingFriction,
    /// Young's modulus E of the particle material, Pa.
    YoungsModulus,
}

impl Parameter {
    /// All four parameters in the order of every array indexed by parameter
    /// (e, μs, μr, E).
    pub const ALL: [Parameter; 4] = [
        Parameter::Restitution,
        Parameter::StaticFriction,
        Parameter::RollingFriction,
        Parameter::YoungsModulus,
    ];

    /// Machine name, as the parameter is spelled in manifests and results.
    pub fn name(self) -> &'static str {
        match self {
            Parameter::Restitution => "restitution",
            Parameter::StaticFriction => "static_friction",
            Parameter::RollingFriction => "rolling_friction",
            Parameter::YoungsModulus => "youngs_modulus_pa",
        }
    }

    /// Short symbol for tables and plots.
    pub fn symbol(self) -> &'static str {
        match self {
            Parameter::Restitution => "e",
            Parameter::StaticFriction => "μs",
            Parameter::RollingFriction => "μr",
            Parameter::YoungsModulus => "E",
        }
    }

    /// Position of the parameter in [`Parameter::ALL`] and in the arrays of
    /// [`Sensitivity`].
    fn index(self) -> usize {
        self as usize
    }
}

/// Which rolling slot the contact uses (the normal slot is Hertz).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rolling {
    /// No rolling resistance ([`super::rolling_none`]).
    None,
    /// Constant directional torque ([`super::rolling_cdt`]).
    Cdt,
    /// Elastic–plastic spring ([`super::rolling_epsd`]).
    Epsd,
}

/// Two identical spheres of one material (a particle–particle contact) and
/// the contact parameters of the pair: everything the sensitivities depend on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairSpec {
    /// Sphere radius R, m.
    pub radius_m: f64,
    /// Particle density ρ, kg/m³ (sets the mass in the dashpots).
    pub density_kg_m3: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio ν, dimensionless, in [0, 0.5) (held fixed).
    pub poisson_ratio: f64,
    /// Coefficient of restitution e, in (0, 1].
    pub restitution: f64,
    /// Sliding friction coefficient μs, ≥ 0.
    pub static_friction: f64,
    /// Rolling friction coefficient μr, ≥ 0.
    pub rolling_friction: f64,
    /// The rolling model.
    pub rolling: Rolling,
}

impl PairSpec {
    /// The value of parameter `p` in this spec, in the parameter's own units
    /// (Pa for E).
    pub fn value(&self, p: Parameter) -> f64 {
        match p {
            Parameter::Restitution => self.restitution,
            Parameter::StaticFriction => self.static_friction,
            Parameter::RollingFriction => self.rolling_friction,
            Parameter::YoungsModulus => self.youngs_modulus_pa,
        }
    }

    /// This spec with parameter `p` set to `v` (its own units).
    pub fn with(&self, p: Parameter, v: f64) -> PairSpec {
        let mut s = *self;
        match p {
            Parameter::Restitution => s.restitution = v,
            Parameter::StaticFriction => s.static_friction = v,
            Parameter::RollingFriction => s.rolling_friction = v,
            Parameter::YoungsModulus => s.youngs_modulus_pa = v,
        }
        s
    }

    /// The engine's mixed coefficients for this pair (no surface energy, no
    /// tensile clipping). Panics if a parameter is outside what
    /// [`PairCoefficients::new`] accepts.
    fn coefficients(&self) -> PairCoefficients {
        let m = ElasticMaterial {
            youngs_modulus_pa: self.youngs_modulus_pa,
            poisson_ratio: self.poisson_ratio,
        };
        let p = PairParameters {
            restitution: self.restitution,
            static_friction: self.static_friction,
            rolling_friction: self.rolling_friction,
            surface_energy_j_m2: 0.0,
        };
        PairCoefficients::new(&m, &m, &p, false)
            .unwrap_or_else(|e| panic!("sensitivity of an invalid pair: {e}"))
    }

    /// Effective radius R* = R/2, m.
    fn r_star(&self) -> f64 {
        0.5 * self.radius_m
    }

    /// Effective mass m* = m/2, kg, with m = ρ(4/3)πR³.
    fn m_star(&self) -> f64 {
        0.5 * self.density_kg_m3 * (4.0 / 3.0) * PI * self.radius_m.powi(3)
    }
}

/// An a-priori contact state (yan2015 §4.2.3): what the contact looks like at
/// the instant its forces are evaluated (see the module docs for the
/// directions).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactState {
    /// Normal overlap δn, m (> 0: the spheres touch).
    pub normal_overlap_m: f64,
    /// Tangential spring elongation δt, m (the history ξ = (δt, 0, 0)).
    pub tangential_overlap_m: f64,
    /// Relative normal speed vn, m/s, positive while the spheres approach.
    pub normal_speed_m_s: f64,
    /// Relative tangential (slip) speed vt at the contact, m/s.
    pub tangential_speed_m_s: f64,
    /// Relative angular speed ω (rolling, about the y axis), rad/s.
    pub angular_speed_rad_s: f64,
}

/// yan2015's 81 a-priori states for spheres of diameter `diameter_m` (m):
/// vn, vt ∈ {1e-4, 1e-2, 1} m/s, ω ∈ {0.01, 1, 100} rad/s and
/// δn = δt ∈ {0.1, 1, 10} % of the diameter, all combinations.
///
/// Order: δ varies slowest, then vn, then vt, and ω fastest, so state
/// `27·iδ + 9·ivn + 3·ivt + iω` has the `iδ`-th overlap, and so on (each
/// level list ascending). Consecutive triples differ only in ω.
pub fn a_priori_states(diameter_m: f64) -> Vec<ContactState> {
    const SPEEDS_M_S: [f64; 3] = [1e-4, 1e-2, 1.0];
    const SPINS_RAD_S: [f64; 3] = [0.01, 1.0, 100.0];
    const OVERLAP_FRACTIONS: [f64; 3] = [1e-3, 1e-2, 1e-1];
    let mut states = Vec::with_capacity(81);
    for f in OVERLAP_FRACTIONS {
        let delta = f * diameter_m;
        for vn in SPEEDS_M_S {
            for vt in SPEEDS_M_S {
                for w in SPINS_RAD_S {
                    states.push(ContactState {
                        normal_overlap_m: delta,
                        tangential_overlap_m: delta,
                        normal_speed_m_s: vn,
                        tangential_speed_m_s: vt,
                        angular_speed_rad_s: w,
                    });
                }
            }
        }
    }
    states
}

/// Force and torque magnitudes on body i at one contact state, and their
/// analytic derivatives with respect to each [`Parameter`] (indexed as
/// [`Parameter::ALL`], each in the parameter's own units: per Pa for E).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Sensitivity {
    /// |F|, N: magnitude of the total contact force on i.
    pub force_n: f64,
    /// |τ|, N·m: magnitude of the torque on i (rolling torque plus the
    /// friction force's moment about i's centre).
    pub torque_n_m: f64,
    /// ∂|F|/∂P_k, N per unit of P_k.
    pub d_force: [f64; 4],
    /// ∂|τ|/∂P_k, N·m per unit of P_k.
    pub d_torque: [f64; 4],
}

/// A value and its derivatives with respect to the four parameters.
#[derive(Clone, Copy, Debug)]
struct Dual {
    v: f64,
    d: [f64; 4],
}

impl Dual {
    fn new(v: f64, d: [f64; 4]) -> Self {
        Self { v, d }
    }
    fn add(self, o: Dual) -> Dual {
        Dual::new(self.v + o.v, std::array::from_fn(|k| self.d[k] + o.d[k]))
    }
    fn scale(self, s: f64) -> Dual {
        Dual::new(self.v * s, self.d.map(|d| d * s))
    }
    /// √(x² + y²) and its derivatives (zero derivatives at the origin).
    fn hypot(x: Dual, y: Dual) -> Dual {
        let v = (x.v * x.v + y.v * y.v).sqrt();
        let d = std::array::from_fn(|k| {
            if v > 0.0 {
                (x.v * x.d[k] + y.v * y.d[k]) / v
            } else {
                0.0
            }
        });
        Dual::new(v, d)
    }
}

/// How the tangential law resolved at a state (the branches of
/// [`super::tangential_mindlin::force`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tangential {
    /// The spring alone exceeds the Coulomb cap.
    Sliding,
    /// The spring is within the cap but spring plus damping exceeds it.
    Clipped,
    /// Spring plus damping within the cap.
    Sticking,
}

/// How the rolling law resolved at a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RollingRegime {
    /// EPSD within its cap.
    Elastic,
    /// EPSD at its cap, or CDT.
    Capped,
    /// No rolling torque (model none, or CDT with ω = 0).
    Zero,
}

/// What the closed form found besides the sensitivities: the branches taken
/// and the smallest relative distance to a branch switch (or to τ = 0, where
/// |τ| has a kink), for the finite-difference test.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))] // read by the tests only
struct Branches {
    tangential: Tangential,
    rolling: RollingRegime,
    margin: f64,
}

/// dψ/de for ψ(e) = ln e/√(ln²e + π²): π²/(e (ln²e + π²)^{3/2}).
fn damping_ratio_derivative(e: f64) -> f64 {
    let l = e.ln();
    PI * PI / (e * (l * l + PI * PI).powf(1.5))
}

/// Relative distance of `x` from `cap` (infinite when the cap is zero and x
/// is not, zero when both are).
fn relative_gap(x: f64, cap: f64) -> f64 {
    let scale = x.abs().max(cap.abs());
    if scale > 0.0 {
        (x.abs() - cap.abs()).abs() / scale
    } else {
        0.0
    }
}

fn sign(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Force and torque magnitudes on body i and their analytic derivatives with
/// respect to e, μs, μr and E (closed form, the set-up of the module docs).
///
/// Panics if a parameter of `spec` is outside what
/// [`PairCoefficients::new`] accepts.
pub fn sensitivity(spec: &PairSpec, state: &ContactState) -> Sensitivity {
    analyse(spec, state).0
}

fn analyse(spec: &PairSpec, state: &ContactState) -> (Sensitivity, Branches) {
    let c = spec.coefficients();
    let (r_star, m_star) = (spec.r_star(), spec.m_star());
    let young = spec.youngs_modulus_pa;
    let delta_n = state.normal_overlap_m;
    let delta_t = state.tangential_overlap_m;
    let a = (r_star * delta_n).sqrt();
    let root = (a * m_star).sqrt();
    let dpsi = damping_ratio_derivative(spec.restitution);
    let [e, mu_s, mu_r, modulus] = Parameter::ALL.map(Parameter::index);
    let only = |k: usize, v: f64| {
        let mut d = [0.0; 4];
        d[k] = v;
        d
    };

    // Normal: elastic Hertz ∝ E*, dashpot ∝ ψ √E*.
    let elastic = (4.0 / 3.0) * c.e_star * a * delta_n;
    let f_el = Dual::new(elastic, only(modulus, elastic / young));
    let v_n = -state.normal_speed_m_s;
    let damp_n = c.normal_damping * root * v_n;
    let mut d_damp_n = only(modulus, 0.5 * damp_n / young);
    d_damp_n[e] = DAMPING_PREFACTOR * dpsi * (2.0 * c.e_star).sqrt() * root * v_n;
    let f_n = f_el.add(Dual::new(damp_n, d_damp_n));
    let load = f_el;

    // Tangential, x component (the only one).
    let spring_x = -(8.0 * c.g_star * a) * delta_t;
    let spring = Dual::new(spring_x, only(modulus, spring_x / young));
    let eta = c.tangential_damping * root;
    let damp_t = -eta * state.tangential_speed_m_s;
    let mut d_damp_t = only(modulus, 0.5 * damp_t / young);
    d_damp_t[e] =
        DAMPING_PREFACTOR * dpsi * (8.0 * c.g_star).sqrt() * root * state.tangential_speed_m_s;
    let total = spring.add(Dual::new(damp_t, d_damp_t));
    let mut cap = load.scale(spec.static_friction);
    cap.d[mu_s] = load.v;
    let tangential = if spring.v * spring.v > cap.v * cap.v {
        Tangential::Sliding
    } else if total.v * total.v > cap.v * cap.v {
        Tangential::Clipped
    } else {
        Tangential::Sticking
    };
    let f_t = match tangential {
        Tangential::Sliding => cap.scale(sign(spring.v)),
        Tangential::Clipped => cap.scale(sign(total.v)),
        Tangential::Sticking => total,
    };
    let mut margin = relative_gap(spring.v, cap.v).min(relative_gap(total.v, cap.v));

    // Rolling, y component (the only one).
    let mut cap_r = load.scale(spec.rolling_friction * r_star);
    cap_r.d[mu_r] = r_star * load.v;
    let w = state.angular_speed_rad_s;
    let (rolling, m_r) = match spec.rolling {
        Rolling::None => (RollingRegime::Zero, Dual::new(0.0, [0.0; 4])),
        Rolling::Cdt if w == 0.0 => (RollingRegime::Zero, Dual::new(0.0, [0.0; 4])),
        Rolling::Cdt => (RollingRegime::Capped, cap_r.scale(-sign(w))),
        Rolling::Epsd => {
            let m_y = epsd_history(&c, r_star, a, delta_t, w).y;
            margin = margin.min(relative_gap(m_y, cap_r.v));
            if m_y * m_y > cap_r.v * cap_r.v {
                (RollingRegime::Capped, cap_r.scale(sign(m_y)))
            } else {
                (
                    RollingRegime::Elastic,
                    Dual::new(m_y, only(modulus, m_y / young)),
                )
            }
        }
    };

    // τ = M_r − (n × F_t)·arm with n × (F_x, 0, 0) = (0, F_x, 0).
    let arm = spec.radius_m - 0.5 * delta_n;
    let tau = m_r.add(f_t.scale(-arm));
    let parts = m_r.v.abs() + f_t.v.abs() * arm;
    if parts > 0.0 {
        margin = margin.min(tau.v.abs() / parts);
    }
    let zero = Dual::new(0.0, [0.0; 4]);
    let force = Dual::hypot(f_t, f_n);
    let torque = Dual::hypot(tau, zero);
    (
        Sensitivity {
            force_n: force.v,
            torque_n_m: torque.v,
            d_force: force.d,
            d_torque: torque.d,
        },
        Branches {
            tangential,
            rolling,
            margin,
        },
    )
}

/// The EPSD history of the set-up: the elastic torque of a relative rotation
/// φ = δt/R* opposing ω (ω = 0 counts as positive), N·m.
fn epsd_history(c: &PairCoefficients, r_star: f64, a: f64, delta_t: f64, w: f64) -> Vec3 {
    let k_r = 8.0 * c.g_star * a * r_star * r_star;
    Vec3::new(0.0, -sign(w) * k_r * (delta_t / r_star), 0.0)
}

/// The force and torque magnitudes (|F| in N, |τ| in N·m) of the set-up in
/// the module docs, computed by the engine's own code:
/// [`PairCoefficients::new`], the history set up as described and
/// [`evaluate`]`::<Hertz, R>` with dt = 0, the torque formed as the pair
/// kernel forms it. The reference for [`sensitivity`]'s values and, by
/// central differences, its derivatives.
///
/// Panics if a parameter of `spec` is invalid or the spheres do not touch
/// (δn ≤ 0).
pub fn engine_response(spec: &PairSpec, state: &ContactState) -> (f64, f64) {
    let c = spec.coefficients();
    let r_star = spec.r_star();
    let a = (r_star * state.normal_overlap_m).sqrt();
    let w = state.angular_speed_rad_s;
    let rolling = epsd_history(&c, r_star, a, state.tangential_overlap_m, w);
    match spec.rolling {
        Rolling::None => respond::<NoRolling>(spec, state, &c, ()),
        Rolling::Cdt => respond::<ConstantDirectionalTorque>(spec, state, &c, ()),
        Rolling::Epsd => respond::<ElasticPlasticSpring>(spec, state, &c, rolling),
    }
}

fn respond<R: RollingModel>(
    spec: &PairSpec,
    state: &ContactState,
    c: &PairCoefficients,
    rolling: R::History,
) -> (f64, f64) {
    let normal = Vec3::z();
    let geometry = ContactGeometry {
        normal,
        overlap_m: state.normal_overlap_m,
        r_star_m: spec.r_star(),
        m_star_kg: spec.m_star(),
    };
    let motion = RelativeMotion {
        velocity: Vec3::new(state.tangential_speed_m_s, 0.0, -state.normal_speed_m_s),
        angular_velocity: Vec3::new(0.0, state.angular_speed_rad_s, 0.0),
    };
    let mut history = ContactHistory::<Hertz, R> {
        normal: (),
        tangential: Vec3::new(state.tangential_overlap_m, 0.0, 0.0),
        rolling,
    };
    let r = evaluate::<Hertz, R>(c, &geometry, &motion, 0.0, &mut history)
        .expect("the a-priori state must overlap (δn > 0)");
    let arm = spec.radius_m - 0.5 * state.normal_overlap_m;
    let torque = r.rolling_torque - normal.cross(&r.tangential_force) * arm;
    (r.force.norm(), torque.norm())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::sensitivity::{cross_correlation, CrossCorrelation};

    /// yan2015-like glass beads: R = 1 mm, ρ = 2500, E = 2e7 Pa, ν = 0.25,
    /// e = 0.45, μs = μr = 0.25, EPSD.
    fn base() -> PairSpec {
        PairSpec {
            radius_m: 1e-3,
            density_kg_m3: 2500.0,
            youngs_modulus_pa: 2e7,
            poisson_ratio: 0.25,
            restitution: 0.45,
            static_friction: 0.25,
            rolling_friction: 0.25,
            rolling: Rolling::Epsd,
        }
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    #[test]
    fn parameter_names_and_order() {
        let names = Parameter::ALL.map(Parameter::name);
        assert_eq!(
            names,
            [
                "restitution",
                "static_friction",
                "rolling_friction",
                "youngs_modulus_pa"
            ]
        );
        assert_eq!(
            Parameter::ALL.map(Parameter::symbol),
            ["e", "μs", "μr", "E"]
        );
        let s = base();
        for (k, p) in Parameter::ALL.into_iter().enumerate() {
            assert_eq!(p.index(), k);
            assert_eq!(s.with(p, 0.7).value(p), 0.7);
        }
    }

    #[test]
    fn a_priori_states_follow_the_documented_order() {
        let s = a_priori_states(2e-3);
        assert_eq!(s.len(), 81);
        let i = 27 * 2 + 9 + 3 * 2;
        assert!(close(s[i].normal_overlap_m, 2e-4, 1e-15));
        assert_eq!(s[i].tangential_overlap_m, s[i].normal_overlap_m);
        assert_eq!(s[i].normal_speed_m_s, 1e-2);
        assert_eq!(s[i].tangential_speed_m_s, 1.0);
        assert_eq!(s[i].angular_speed_rad_s, 0.01);
        assert_eq!(s[80].angular_speed_rad_s, 100.0);
        assert!(close(s[0].normal_overlap_m, 2e-6, 1e-15));
    }

    /// Parameter sets spanning every branch: sliding and plastic (yan2015's
    /// own values are of this kind), sticking with damping clipped at the
    /// cap, sticking within it and EPSD elastic, CDT and no rolling.
    fn specs() -> Vec<PairSpec> {
        let b = base();
        vec![
            b,
            PairSpec {
                static_friction: 2.0,
                rolling_friction: 2.0,
                ..b
            },
            PairSpec {
                static_friction: 1.3,
                rolling_friction: 1.3,
                restitution: 0.9,
                ..b
            },
            PairSpec {
                static_friction: 0.5,
                rolling_friction: 0.05,
                rolling: Rolling::Cdt,
                ..b
            },
            PairSpec {
                static_friction: 1.3,
                restitution: 0.2,
                rolling: Rolling::None,
                ..b
            },
            PairSpec {
                rolling: Rolling::Cdt,
                ..b
            },
            PairSpec {
                rolling: Rolling::None,
                ..b
            },
        ]
    }

    /// yan2015's states and the same with a spring elongation δt = δn/10
    /// (which sticks at μs = 0.25).
    fn states() -> Vec<ContactState> {
        let s = a_priori_states(2e-3);
        let short = s.iter().map(|x| ContactState {
            tangential_overlap_m: 0.1 * x.tangential_overlap_m,
            ..*x
        });
        s.iter().copied().chain(short).collect()
    }

    #[test]
    fn closed_form_values_equal_the_engine() {
        for spec in specs() {
            for state in states() {
                let s = sensitivity(&spec, &state);
                let (f, t) = engine_response(&spec, &state);
                assert!(close(s.force_n, f, 1e-12), "{spec:?} {state:?}: {s:?} {f}");
                assert!(
                    close(s.torque_n_m, t, 1e-12),
                    "{spec:?} {state:?}: {s:?} {t}"
                );
            }
        }
    }

    #[test]
    fn analytic_derivatives_match_central_differences_of_the_engine() {
        let mut seen = std::collections::BTreeSet::new();
        let mut checked = 0;
        for spec in specs() {
            for state in states() {
                let (s, b) = analyse(&spec, &state);
                seen.insert(format!("{:?}/{:?}", b.tangential, b.rolling));
                if b.margin < 1e-4 {
                    continue;
                }
                for p in Parameter::ALL {
                    let k = p.index();
                    let v = spec.value(p);
                    let h = 1e-6 * v;
                    let up = engine_response(&spec.with(p, v + h), &state);
                    let down = engine_response(&spec.with(p, v - h), &state);
                    let fd = [(up.0 - down.0) / (2.0 * h), (up.1 - down.1) / (2.0 * h)];
                    let an = [s.d_force[k], s.d_torque[k]];
                    let value = [s.force_n, s.torque_n_m];
                    for j in 0..2 {
                        // In scaled units P ∂f/∂P, with a floor for derivatives
                        // that vanish (round-off of the difference).
                        let err = (v * (fd[j] - an[j])).abs();
                        let tol = 1e-5 * (v * an[j]).abs() + 1e-8 * value[j];
                        assert!(
                            err <= tol,
                            "{p:?} {j}: fd {} analytic {} ({spec:?} {state:?} {b:?})",
                            fd[j],
                            an[j]
                        );
                        checked += 1;
                    }
                }
            }
        }
        for branch in [
            "Sliding/Capped",
            "Sticking/Elastic",
            "Clipped/Elastic",
            "Sticking/Capped",
            "Clipped/Capped",
            "Sliding/Zero",
            "Clipped/Zero",
        ] {
            assert!(seen.contains(branch), "{branch} not exercised: {seen:?}");
        }
        assert!(checked > 6_000, "{checked}");
    }

    fn matrix(spec: &PairSpec, torque: bool) -> Vec<Vec<f64>> {
        a_priori_states(2.0 * spec.radius_m)
            .iter()
            .map(|state| {
                let s = sensitivity(spec, state);
                let d = if torque { s.d_torque } else { s.d_force };
                Parameter::ALL
                    .map(|p| spec.value(p) * d[p.index()])
                    .to_vec()
            })
            .collect()
    }

    /// Findings on yan2015's own states: at yan2015's parameters every state
    /// slides and EPSD sits at its cap; then the torque is L(μs·arm − μr R*),
    /// proportional to E and free of e, so its scaled E column is exactly
    /// μs·col(μs) + μr·col(μr) (Euler) and its e column is zero; the force
    /// never depends on μr. Rows differing only in ω are equal.
    #[test]
    fn yan2015_parameters_slide_and_make_the_torque_collinear_in_e() {
        let spec = PairSpec {
            static_friction: 0.5,
            rolling_friction: 0.05,
            ..base()
        };
        for state in a_priori_states(2e-3) {
            let b = analyse(&spec, &state).1;
            assert_eq!(
                (b.tangential, b.rolling),
                (Tangential::Sliding, RollingRegime::Capped)
            );
        }
        let t = matrix(&spec, true);
        for row in &t {
            assert_eq!(row[0], 0.0);
            assert!(close(row[3], row[1] + row[2], 1e-12), "{row:?}");
        }
        for triple in t.chunks(3) {
            assert_eq!(triple[0], triple[1]);
            assert_eq!(triple[1], triple[2]);
        }
        match cross_correlation(&t) {
            CrossCorrelation::Singular { rank, .. } => assert_eq!(rank, 2),
            full => panic!("expected singular, got {full:?}"),
        }
        let f = matrix(&spec, false);
        assert!(f.iter().all(|row| row[2] == 0.0));
        match cross_correlation(&f) {
            CrossCorrelation::Singular { rank, null_vector } => {
                assert_eq!(rank, 3);
                for (v, e) in null_vector.iter().zip([0.0, 0.0, 1.0, 0.0]) {
                    assert!((v - e).abs() < 1e-12, "{null_vector:?}");
                }
            }
            full => panic!("expected singular, got {full:?}"),
        }
        // Force and torque rows together: full rank (the force separates E
        // from μs + μr through the √E normal dashpot).
        let both: Vec<Vec<f64>> = f.into_iter().chain(t).collect();
        assert!(matches!(
            cross_correlation(&both),
            CrossCorrelation::Full(_)
        ));
    }
}
