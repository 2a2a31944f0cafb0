//! The study: a calibration plan (`experiments/<study>/study.json`) from which the
//! sampler generates experiments.
//!
//! A study fixes the material and contact model, says which contact parameters are
//! calibrated (with ranges) and which are fixed, and names the calibration scene and
//! the verification scenes with their measured target angles.

use crate::streams::{SeedRule, SeedStage};
use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::experiment::{
    AtRest, CoarseGraining, CoarseGrainingRule, Contact, ContactModel, Experiment, Material,
    PairParams, Profile, Seeds, TimeStep, PAIR_PARAM_FIELDS,
};
use super::scene::Scene;
use super::validate::{validate_experiment, FieldError, ValidationErrors};
use super::{ExperimentDoc, PHYSICS_VERSION, SCHEMA_VERSION};

/// A calibration study.
///
/// Contact parameters are addressed as `particle_particle.<field>` or
/// `particle_wall.<wall>.<field>`, where `<field>` is one of
/// [`super::PAIR_PARAM_FIELDS`] and `<wall>` a wall material name or `*` (every wall
/// material: one parameter drives all walls, as he2019's single e_pw / mu_pw do —
/// except a wall material whose same field is named explicitly elsewhere in
/// `parameters` or `fixed`, which that address sets instead: e.g. a funnel's
/// brush with its own friction beside one calibrated μ_pw for every other wall).
/// Every parameter slot is either calibrated or fixed, exactly once, and every
/// address sets at least one slot: a wildcard whose every wall is named
/// explicitly would be a design column no run uses, and is refused.
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
    /// Coarse graining of the generated experiments (absent: real particles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_graining: Option<CoarseGraining>,
    /// Noise-aware calibration (absent: he2019's one-shot method, one packing
    /// seed per sample): replicates, the noise floor, the Gaussian-process
    /// search and the multi-seed verification (see [`NoiseAware`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_aware: Option<NoiseAware>,
    /// The stages the study runs, spelled out in order (absent: the list
    /// its blocks give; `repose stages FILE` prints it). When present it
    /// must be that list, and naming `adaptive` adds the adaptive rounds
    /// as `--adaptive` does (see `crate::study::plan`).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "crate::manifest::study::spelled_stages"
    )]
    pub stages: Vec<String>,
    /// The transfer test (absent: none): after verification, every verified
    /// candidate is simulated again at each of these finer particle sizes,
    /// with the acceptance record's seeds, and judged by the same rule
    /// (`crate::study::stages::transfer`; `repose transfer` runs it on any
    /// study).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transfer: Option<Box<Transfer>>,
}

/// Finer particle sizes a verified candidate must also pass at, and how the
/// surface energy follows the radius there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transfer {
    /// Particle radius / the verified one, each in (0, 1), distinct.
    pub sizes: Vec<f64>,
    /// How every surface energy follows the radius: Γ ∝ R² (`constant_bond`),
    /// Γ ∝ R (`surface_energy_proportional`) or Γ ∝ R^0.4
    /// (`cohesion_number`). A study with `coarse_graining` must name its
    /// block's rule; a two-level study its fine level's (`constant_bond`).
    pub rule: CoarseGrainingRule,
}

/// How a noise-aware calibration treats the packing noise of its runs.
///
/// Every point — a design sample, the noise floor's centre, an adaptive
/// point, a verified candidate — draws its own packing seeds: replicate `r`
/// of the point with `sample_index` i runs with the r-th draw of the ChaCha
/// stream ([`SeedRule::Drawn`]) of (`packing_seed`, [`SeedStage::Calibrate`],
/// i). The sample indices of the stages are disjoint (design 0…, noise floor
/// `NOISE_INDEX`, adaptive `ADAPTIVE_INDEX` + …, verification
/// `VERIFY_INDEX` + group), so no two points share a packing: the noise of
/// two points' means is independent, as the Gaussian process's noise model
/// and the acceptance rule's t-tests assume, and a candidate is never
/// verified on the packings its surrogate was trained on. (The one place a
/// comparison reuses runs on purpose: the adaptive candidate that ended the
/// adaptive stage is verified in the calibration scene on the very runs that
/// passed it.) The classic method keeps he2019's one packing seed for every
/// run ([`SeedRule::Offset`]), as its committed study ids record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseAware {
    /// Packing seeds per design point (≥ 1); the response is their mean.
    pub replicates: u32,
    /// Packing seeds of the noise floor at the centre of the ranges (≥ 3;
    /// 8 or more recommended).
    pub noise_seeds: u32,
    /// Smallest probability, under the Gaussian-process surrogate, that a
    /// resampled point's angle lies inside the target band for the search to
    /// keep it, in (0, 1).
    pub min_probability: f64,
    /// Packing seeds of a candidate in each scene whose noise the study has
    /// not measured, and the fewest in the calibration scene (≥ 5).
    pub verification_seeds: u32,
    /// Most packing seeds of a candidate in the calibration scene: the
    /// acceptance record's power calculation on the noise floor's σ picks
    /// the seeds (TOST power 0.8 at the band's centre) between
    /// `verification_seeds` and this cap (absent: `verification_seeds`, no
    /// power calculation raises it). See `crate::study::stages::verify_candidates`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_verification_seeds: Option<u32>,
    /// Active learning after the initial design (`repose calibrate
    /// --adaptive`).
    pub adaptive: Adaptive,
    /// Screen before searching: parameters whose main effect under the GP
    /// (over their whole range) is below the noise floor's σ are fixed at
    /// the centre of their ranges and only the others are searched
    /// ([`crate::search::screen`]); absent or false: every parameter is
    /// searched and the main effects are reported only.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub screen: bool,
    /// A second, finer particle size (absent: one size): the design runs at
    /// the study's size, a few of its points again at the fine size, a
    /// two-level Gaussian process predicts the fine level, and the search
    /// and the verification are the fine level's (`crate::study::stages::fine`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<Fidelity>,
}

/// The fine level of a two-level (multi-fidelity) calibration: every
/// experiment of it is the study's experiment with its particle radius ×
/// `fine_size` and its surface energies × `fine_size`² (Γ ∝ R², the
/// constant-Bond rule of `repose convergence` and `repose pilot`), so the
/// pull-off force per weight of a grain is the study's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fidelity {
    /// Fine particle radius / the study's, in (0, 1).
    pub fine_size: f64,
    /// Design points run again at the fine size (≥ 3, at most the design's
    /// samples): the fine points are a subset of the design's (a nested
    /// design).
    pub fine_points: u32,
    /// Packing seeds per fine point (≥ 2: each fine mean's noise variance
    /// is its replicates' s²/n).
    pub fine_replicates: u32,
}

/// Batches of points chosen by the surrogate until a point's replicate mean
/// is inside the target band or the budget is spent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adaptive {
    /// Points per adaptive round (≥ 1): the GP's candidate runs
    /// `verification_seeds` seeds, the others `replicates` seeds each.
    pub batch: u32,
    /// Most DEM runs the adaptive stage may add (≥ 1).
    pub max_runs: u32,
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
    /// The scene's named response compared with the target (`repose
    /// responses KIND`; absent: the scene's headline angle).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response: Option<String>,
}

impl TargetScene {
    /// The target band [target (1 − tol), target (1 + tol)], degrees
    /// ([`crate::stats::equivalence::band`]).
    pub fn band_deg(&self) -> (f64, f64) {
        crate::stats::equivalence::band(self.target_angle_deg, self.tolerance_fraction)
    }
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

/// One contact-parameter slot: a pair type and one field of its [`PairParams`].
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Slot {
    /// `None` for particle–particle, else the wall material name.
    pub wall: Option<String>,
    /// One of [`PAIR_PARAM_FIELDS`].
    pub field: &'static str,
}

impl Slot {
    /// The slot's address in an experiment ([`crate::manifest::address`]):
    /// `contact.particle_particle.<field>` or
    /// `contact.particle_wall.<wall>.<field>`.
    pub fn address(&self) -> String {
        format!("contact.{self}")
    }
}

impl fmt::Display for Slot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.wall {
            None => write!(f, "particle_particle.{}", self.field),
            Some(w) => write!(f, "particle_wall.{w}.{}", self.field),
        }
    }
}

impl Study {
    /// The slots a parameter address stands for (`particle_wall.*.x` expands to every
    /// wall material), or what is wrong with the address.
    pub fn resolve_address(&self, address: &str) -> Result<Vec<Slot>, String> {
        const RULE: &str = "must address a contact parameter: particle_particle.<field> or \
                            particle_wall.<wall material or *>.<field>, with <field> one of \
                            restitution, static_friction, rolling_friction, surface_energy_j_m2";
        let parts: Vec<&str> = address.split('.').collect();
        let (walls, field): (Vec<Option<String>>, &str) = match parts.as_slice() {
            ["particle_particle", field] => (vec![None], field),
            ["particle_wall", "*", field] => (
                self.material
                    .walls
                    .keys()
                    .filter(|w| {
                        let named = format!("particle_wall.{w}.{field}");
                        !self.parameters.contains_key(&named) && !self.fixed.contains_key(&named)
                    })
                    .map(|w| Some(w.clone()))
                    .collect(),
                field,
            ),
            ["particle_wall", wall, field] if self.material.walls.contains_key(*wall) => {
                (vec![Some(wall.to_string())], field)
            }
            ["particle_wall", _, _] => {
                return Err("must name a wall material defined in material.walls (or *)".into())
            }
            _ => return Err(RULE.into()),
        };
        let field = PAIR_PARAM_FIELDS
            .iter()
            .find(|f| **f == field)
            .ok_or_else(|| RULE.to_string())?;
        Ok(walls.into_iter().map(|wall| Slot { wall, field }).collect())
    }

    /// The fine level of a two-level study (`noise_aware.fidelity`).
    pub fn fidelity(&self) -> Option<Fidelity> {
        self.noise_aware.and_then(|n| n.fidelity)
    }

    /// Packing seeds per design point (1 without `noise_aware`).
    pub fn replicates(&self) -> u32 {
        self.noise_aware.map_or(1, |n| n.replicates)
    }

    /// The experiment that runs `scene` with the calibrated parameters at `point`
    /// (address → value, one entry per entry of `parameters`) and the fixed ones;
    /// material, contact model, profile, time step and seeds come from the study
    /// (design seed, `sample_index`, packing seed). Only the wall materials the scene
    /// uses get particle–wall parameters, so unused walls do not change the id. The
    /// experiment is validated; a point outside a field's allowed range is an error.
    pub fn experiment(
        &self,
        scene: &Scene,
        point: &BTreeMap<String, f64>,
        sample_index: u64,
    ) -> Result<Experiment, ValidationErrors> {
        self.replicate_experiment(scene, point, sample_index, 0)
    }

    /// How the replicates of the point `sample_index` get their packing
    /// seeds: drawn per point in a noise-aware study, `packing_seed + r` in
    /// the classic method (see [`NoiseAware`]).
    pub fn seed_rule(&self, sample_index: u64) -> SeedRule {
        if self.noise_aware.is_some() {
            SeedRule::Drawn {
                seed: self.packing_seed,
                stage: SeedStage::Calibrate,
                point: sample_index,
            }
        } else {
            SeedRule::Offset {
                base: self.packing_seed,
            }
        }
    }

    /// [`Study::experiment`] with the packing seed of `replicate` by
    /// [`Study::seed_rule`].
    pub fn replicate_experiment(
        &self,
        scene: &Scene,
        point: &BTreeMap<String, f64>,
        sample_index: u64,
        replicate: u32,
    ) -> Result<Experiment, ValidationErrors> {
        let mut errors = Vec::new();
        for address in self.parameters.keys().filter(|a| !point.contains_key(*a)) {
            errors.push(FieldError {
                path: format!("point.{address}"),
                value: "(absent)".into(),
                rule: "every calibrated parameter needs a value".into(),
            });
        }
        for address in point.keys().filter(|a| !self.parameters.contains_key(*a)) {
            errors.push(FieldError {
                path: format!("point.{address}"),
                value: "(present)".into(),
                rule: "is not a calibrated parameter of this study".into(),
            });
        }
        if !errors.is_empty() {
            return Err(ValidationErrors(errors));
        }
        let zero = PairParams {
            restitution: 0.0,
            static_friction: 0.0,
            rolling_friction: 0.0,
            surface_energy_j_m2: 0.0,
        };
        let used: Vec<&str> = scene.wall_materials().into_iter().map(|(_, w)| w).collect();
        let particle_wall = used.iter().map(|w| (w.to_string(), zero)).collect();
        let experiment = Experiment {
            schema_version: SCHEMA_VERSION,
            physics_version: PHYSICS_VERSION,
            profile: self.profile,
            scene: scene.clone(),
            material: self.material.clone(),
            contact: Contact {
                model: self.contact_model,
                particle_particle: zero,
                particle_wall,
            },
            seeds: Seeds {
                design_seed: self.design.seed,
                sample_index,
                packing_seed: self
                    .seed_rule(sample_index)
                    .packing_seed(u64::from(replicate)),
            },
            time_step: self.time_step,
            coarse_graining: self.coarse_graining,
            at_rest: AtRest::default(),
        };
        // Every slot of a wall the scene uses (unused walls stay out of the id).
        let mut doc = ExperimentDoc::of(&experiment);
        for (address, value) in self.fixed.iter().chain(point.iter()) {
            let slots = self.resolve_address(address).unwrap_or_default();
            for slot in slots
                .iter()
                .filter(|s| s.wall.as_deref().is_none_or(|w| used.contains(&w)))
            {
                doc.set(&slot.address(), *value)
                    .expect("a resolved slot of a used wall is a number of the experiment");
            }
        }
        let experiment = doc
            .into_experiment()
            .expect("numbers written into an experiment keep it an experiment");
        validate_experiment(&experiment)?;
        Ok(experiment)
    }
}

/// Reads a study's `stages`: absent is the study's own list; an empty list is
/// refused (it would hash as absent, so two different documents would share
/// an id, and it says nothing a missing field does not).
pub(crate) fn spelled_stages<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<Vec<String>, D::Error> {
    let stages = Vec::<String>::deserialize(deserializer)?;
    if stages.is_empty() {
        return Err(serde::de::Error::custom(
            "stages = []: an empty list; leave `stages` out for the list the study's blocks \
             give (repose stages FILE prints it)",
        ));
    }
    Ok(stages)
}
