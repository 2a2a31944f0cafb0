//! The study: a calibration plan (`experiments/<study>/study.json`) from which the
//! sampler generates experiments.
//!
//! A study fixes the material and contact model, says which contact parameters are
//! calibrated (with ranges) and which are fixed, and names the calibration scene and
//! the verification scenes with their measured target angles.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::experiment::{ContactModel, Material, Profile, TimeStep};
use super::scene::Scene;

/// A calibration study.
///
/// Contact parameters are addressed as `particle_particle.<field>` or
/// `particle_wall.<wall>.<field>`, where `<field>` is one of
/// [`super::PAIR_PARAM_FIELDS`] and `<wall>` a wall material name or `*` (every wall
/// material: one parameter drives all walls, as he2019's single e_pw / mu_pw do).
/// Every parameter slot is either calibrated or fixed, exactly once.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Study {
    /// Manifest format version; must equal [`super::SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Short name of the study (e.g. `he2019`).
    pub name: String,
    /// Free text: sources, and every choice made where the paper is silent.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Fidelity profile of the generated experiments.
    pub profile: Profile,
    /// Particle and wall materials.
    pub material: Material,
    /// Force-law choice of the generated experiments.
    pub contact_model: ContactModel,
    /// Calibrated parameters by address, with their ranges.
    pub parameters: BTreeMap<String, ParameterRange>,
    /// Fixed parameters by address.
    pub fixed: BTreeMap<String, f64>,
    /// The scene whose angle the parameters are calibrated against.
    pub calibration: TargetScene,
    /// Scenes that re-simulate the calibrated candidates.
    #[serde(default)]
    pub verification: Vec<TargetScene>,
    /// The sampling plan.
    pub design: Design,
    /// Packing seed shared by the generated experiments.
    pub packing_seed: u64,
    /// Time-step rule of the generated experiments.
    pub time_step: TimeStep,
}

/// A closed range `[min, max]` of a calibrated parameter (min < max).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterRange {
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
}

/// A lab scene with its measured angle of repose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetScene {
    /// Short name used in reports (e.g. `funnel`, `drum`).
    pub name: String,
    /// The scene (a lab scene; `pair` has no angle of repose).
    pub scene: Scene,
    /// Measured angle of repose, degrees, in (0, 90).
    pub target_angle_deg: f64,
    /// Accepted relative deviation |sim − target| / target, in (0, 1)
    /// (he2019 Eq. 8–10 uses 0.05).
    pub tolerance_fraction: f64,
}

/// The sampling plan over the calibrated parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Design {
    /// Which design.
    pub kind: DesignKind,
    /// LHS: number of samples (≥ 2). Full factorial: levels per parameter (≥ 2).
    /// Box–Behnken: number of centre points (≥ 1).
    pub size: u64,
    /// Seed of the design's random stream.
    pub seed: u64,
}

/// Kinds of sampling plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DesignKind {
    /// Latin hypercube (midpoints of equal-probability strata, random permutations).
    Lhs,
    /// Latin hypercube optimised for space filling.
    LhsOptimised,
    /// Every combination of equally spaced levels.
    FullFactorial,
    /// Box–Behnken (needs at least 3 parameters).
    BoxBehnken,
}
