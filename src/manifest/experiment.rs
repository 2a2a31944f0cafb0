//! The experiment: one fully specified DEM run (scene, profile, material, contact
//! parameters, seeds, time step and the engine physics version).
//!
//! Every field is hashed into the experiment id (see [`super::canonical`]), so two
//! manifests with the same physics share one id and one cached result. Units are SI
//! and stated in the field names.

use std::collections::BTreeMap;
use std::fmt;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::scene::Scene;

/// One DEM run, as read from an experiment manifest (`runs/<id>/manifest.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Experiment {
    /// Manifest format version; must equal [`super::SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Engine physics version the run is meant for; must equal
    /// [`super::PHYSICS_VERSION`]. Hashed, so a physics change gives new ids.
    pub physics_version: u32,
    /// Fidelity profile (how much accuracy is traded for time).
    pub profile: Profile,
    /// What is simulated: a two-body check or a lab test.
    pub scene: Scene,
    /// Intrinsic properties of the particles and of the wall materials.
    pub material: Material,
    /// Contact law choice and its parameters per pair type.
    pub contact: Contact,
    /// Every seed the run depends on.
    pub seeds: Seeds,
    /// How the integration time step is chosen.
    pub time_step: TimeStep,
    /// Fidelity scaling of the real particles (bigger, softer) with the rule that
    /// keeps cohesion similar; absent: the particles are simulated as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_graining: Option<CoarseGraining>,
    /// When a settling phase may end early (every scene that settles uses it);
    /// absent: [`AtRest::default`]. Default values are not serialised, so a
    /// manifest that spells them out hashes like one that omits the block.
    #[serde(default, skip_serializing_if = "AtRest::is_default")]
    pub at_rest: AtRest,
}

/// Fidelity profile: `smoke` (seconds, CI), `quick` (minutes, the default),
/// `paper` (the paper's sizes; hours) or `standard` (the size a convergence
/// sweep chose). Declared in that order, so ordering the older three is
/// unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// Seconds per run; for CI.
    Smoke,
    /// Minutes per run; the default for calibration.
    Quick,
    /// The paper's geometry and particle count; for a cluster.
    Paper,
    /// The coarsest particle size whose estimated bias from the converged
    /// (real-size) value is within half the scene's tolerance, measured by
    /// `repose convergence`; hours per study, for `--executor slurm`.
    Standard,
}

impl Profile {
    /// The profile's name as written in manifests.
    pub fn as_str(self) -> &'static str {
        match self {
            Profile::Smoke => "smoke",
            Profile::Quick => "quick",
            Profile::Standard => "standard",
            Profile::Paper => "paper",
        }
    }
}

impl fmt::Display for Profile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Intrinsic material properties: the particle material and the named wall materials.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// The (single) particle material.
    pub particle: ParticleMaterial,
    /// Wall materials by name (e.g. `steel`, `plexiglas`); scenes refer to these names.
    pub walls: BTreeMap<String, WallMaterial>,
}

/// Intrinsic properties of the particle material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleMaterial {
    /// Solid density, kg/m³.
    pub density_kg_m3: f64,
    /// Young's modulus, Pa.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio, dimensionless, in (-1, 0.5].
    pub poisson_ratio: f64,
    /// Particle size distribution (used by lab scenes; pair scenes state their radii).
    /// With a clump `shape`, the radii are volume-equivalent: a particle of
    /// radius R is a clump of the volume (and mass) of a sphere of radius R.
    pub size: SizeDistribution,
    /// Particle shape in the lab scenes: spheres when absent (and then left
    /// out of the canonical form, so sphere manifests keep their ids), or
    /// rigid multi-sphere clumps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<ParticleShape>,
}

/// A rigid multi-sphere particle shape (see [`crate::dem::clump`]), scaled
/// per particle to the size distribution's volume-equivalent radius.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ParticleShape {
    /// Two equal overlapping spheres whose union has length / width =
    /// `aspect_ratio` (he2019 §2.3.1: 1.3), in (1, 2).
    PairedSpheres {
        /// Length over width of the pair, dimensionless.
        aspect_ratio: f64,
    },
    /// Member spheres given explicitly (any unit: only their proportions
    /// count), each overlapping another; at most 64.
    Clump {
        /// The member spheres.
        members: Vec<ClumpMember>,
    },
}

/// One member sphere of an explicit clump shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClumpMember {
    /// Centre, in the shape's own frame and unit.
    pub offset: [f64; 3],
    /// Radius, in the same unit.
    pub radius: f64,
}

/// Particle size distribution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SizeDistribution {
    /// Every particle has the same radius.
    Monodisperse {
        /// Particle radius, m.
        radius_m: f64,
    },
    /// A discrete list of radii with relative weights (by number of particles).
    List {
        /// Radii, m.
        radii_m: Vec<f64>,
        /// Relative number weights, one per radius, each > 0 (need not sum to 1).
        weights: Vec<f64>,
    },
    /// Diameter percentiles of a measured distribution (cai2024's CaCO3).
    #[serde(rename = "d10_d50_d90")]
    D10D50D90 {
        /// 10th percentile diameter, m.
        d10_m: f64,
        /// Median diameter, m.
        d50_m: f64,
        /// 90th percentile diameter, m.
        d90_m: f64,
    },
}

/// Intrinsic properties of one wall material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallMaterial {
    /// Young's modulus in Pa, or `"rigid"` for a wall that does not deform.
    pub youngs_modulus_pa: WallStiffness,
    /// Poisson ratio, dimensionless, in (-1, 0.5].
    pub poisson_ratio: f64,
    /// Density, kg/m³ (walls are kinematic; recorded for completeness and reports).
    pub density_kg_m3: f64,
}

/// A wall's Young's modulus: a finite value in Pa, or rigid (infinite stiffness, so
/// the contact's effective modulus comes from the particle alone).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WallStiffness {
    /// Young's modulus, Pa.
    Elastic(f64),
    /// The wall does not deform.
    Rigid,
}

impl Serialize for WallStiffness {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            WallStiffness::Elastic(e) => serializer.serialize_f64(*e),
            WallStiffness::Rigid => serializer.serialize_str("rigid"),
        }
    }
}

impl<'de> Deserialize<'de> for WallStiffness {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct StiffnessVisitor;
        impl Visitor<'_> for StiffnessVisitor {
            type Value = WallStiffness;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a Young's modulus in Pa or the string \"rigid\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<WallStiffness, E> {
                Ok(WallStiffness::Elastic(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<WallStiffness, E> {
                Ok(WallStiffness::Elastic(v as f64))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<WallStiffness, E> {
                Ok(WallStiffness::Elastic(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<WallStiffness, E> {
                if v == "rigid" {
                    Ok(WallStiffness::Rigid)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
        }
        deserializer.deserialize_any(StiffnessVisitor)
    }
}

/// The contact law and its parameters per pair type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// Which force laws fill the normal and rolling slots.
    pub model: ContactModel,
    /// Parameters of particle–particle contacts.
    pub particle_particle: PairParams,
    /// Parameters of particle–wall contacts, by wall material name.
    pub particle_wall: BTreeMap<String, PairParams>,
}

/// The choice of force laws (tangential is always Mindlin with Coulomb cap).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactModel {
    /// Normal force law.
    pub normal: NormalModel,
    /// Rolling resistance law.
    pub rolling: RollingModel,
    /// Clip a tensile (attractive) total normal force from damping to zero
    /// (Hertz only matters here; JKR's attraction is physical and kept).
    #[serde(default)]
    pub clip_tensile_normal_force: bool,
}

/// Normal force law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalModel {
    /// Hertz elastic repulsion with viscous damping (no cohesion).
    Hertz,
    /// Johnson–Kendall–Roberts: Hertz plus surface-energy adhesion (EDEM form).
    Jkr,
}

/// Rolling resistance law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RollingModel {
    /// No rolling resistance.
    None,
    /// Constant directional torque (EDEM's default rolling friction).
    Cdt,
    /// Elastic–plastic spring–dashpot (yan2015 Eq. 8–10).
    Epsd,
}

/// Contact parameters of one pair type.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairParams {
    /// Coefficient of restitution, in (0, 1].
    pub restitution: f64,
    /// Coefficient of static (sliding) friction, ≥ 0.
    pub static_friction: f64,
    /// Coefficient of rolling friction, ≥ 0 (0 when the rolling model is `none`).
    pub rolling_friction: f64,
    /// JKR surface energy, J/m² (0 when the normal model is `hertz`).
    pub surface_energy_j_m2: f64,
}

/// The names of the [`PairParams`] fields, in declaration order; studies address
/// parameters by these names.
pub const PAIR_PARAM_FIELDS: [&str; 4] = [
    "restitution",
    "static_friction",
    "rolling_friction",
    "surface_energy_j_m2",
];

/// Coarse graining and modulus reduction: the manifest states the real particle
/// (size, Young's modulus, surface energies) and this block says how the simulated
/// one differs. Radii are multiplied by `size_factor`, the particle Young's modulus by
/// `youngs_modulus_factor`, and every surface energy by the factor `rule` gives, so
/// cohesion stays comparable (see [`crate::packing::coarse`]). Density, friction,
/// restitution, wall materials and scene geometry are kept.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoarseGraining {
    /// Simulated radius / real radius, in [1, 1000].
    pub size_factor: f64,
    /// Simulated / real particle Young's modulus, in (0, 1]; default 1.
    #[serde(default = "unit_factor")]
    pub youngs_modulus_factor: f64,
    /// How the surface energy follows the scaling.
    pub rule: CoarseGrainingRule,
}

/// How surface energies are rescaled under coarse graining.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CoarseGrainingRule {
    /// cai2024: Γ ∝ particle size (Γ/R* constant keeps the JKR law similar).
    SurfaceEnergyProportional,
    /// he2019 Eq. 1–3: the cohesion number is kept, Γ' = Γ (k m)^(2/5).
    CohesionNumber,
    /// Γ' = k² Γ: the granular Bond number (JKR pull-off over weight) is
    /// kept, so cohesion weighs as much against gravity at every size.
    ConstantBond,
}

fn unit_factor() -> f64 {
    1.0
}

/// Seeds: the only sources of randomness in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Seeds {
    /// Seed of the design (sampling plan) this experiment came from.
    pub design_seed: u64,
    /// Index of this experiment within its design.
    pub sample_index: u64,
    /// Seed of the particle packing / insertion stream.
    pub packing_seed: u64,
}

/// How the time step is chosen: a fraction of the Rayleigh time, with a design impact
/// speed so the Hertz collision time can be checked too.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeStep {
    /// Time step as a fraction of the Rayleigh time, in (0, 0.5]; default 0.2.
    #[serde(default = "default_rayleigh_fraction")]
    pub rayleigh_fraction: f64,
    /// Largest relative impact speed the step must resolve, m/s, > 0.
    pub design_impact_speed_m_s: f64,
}

/// The default Rayleigh fraction (yan2015 uses 10–20 %, cai2024 uses 1/5).
pub const DEFAULT_RAYLEIGH_FRACTION: f64 = 0.2;

fn default_rayleigh_fraction() -> f64 {
    DEFAULT_RAYLEIGH_FRACTION
}

/// The stop criterion of settling phases: the bed is at rest once the mean
/// kinetic energy per particle stays below `kinetic_energy_fraction` · m g d
/// for `hold_s` of simulated time, with m (kg) and d (m) the mass and diameter
/// of the scene's representative particle (m g d: the energy of lifting it by
/// one diameter). A looser threshold or a shorter hold ends phases sooner and
/// costs less; `repose tradeoff` measures what it does to the angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AtRest {
    /// Threshold on the mean kinetic energy per particle as a fraction of
    /// m g d, in (0, 1]; default [`DEFAULT_REST_ENERGY_FRACTION`].
    #[serde(default = "default_rest_energy_fraction")]
    pub kinetic_energy_fraction: f64,
    /// How long the energy must stay below the threshold, s, > 0; default
    /// [`DEFAULT_REST_HOLD_S`].
    #[serde(default = "default_rest_hold_s")]
    pub hold_s: f64,
}

/// The default rest threshold, a fraction of m g d (the value every scene used
/// before the criterion became a manifest option).
pub const DEFAULT_REST_ENERGY_FRACTION: f64 = 1e-6;
/// The default hold time below the rest threshold, s.
pub const DEFAULT_REST_HOLD_S: f64 = 0.05;

fn default_rest_energy_fraction() -> f64 {
    DEFAULT_REST_ENERGY_FRACTION
}

fn default_rest_hold_s() -> f64 {
    DEFAULT_REST_HOLD_S
}

impl Default for AtRest {
    fn default() -> Self {
        Self {
            kinetic_energy_fraction: DEFAULT_REST_ENERGY_FRACTION,
            hold_s: DEFAULT_REST_HOLD_S,
        }
    }
}

impl AtRest {
    /// True for the default criterion (then the block is left out of the
    /// canonical JSON, keeping the ids of manifests that omit it).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}
