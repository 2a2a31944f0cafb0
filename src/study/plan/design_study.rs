//! The design study manifest (`experiments/<study>/study.json`): a study as
//! data — factors by address over any numeric field of the generated
//! experiments, a design, replicates (packing seeds), one or more scenes per
//! design point, named responses, targets, a one-factor screening and a
//! verification plan. cai2024 is one; yan2015 and a noise-aware he2019 are
//! others. (he2019's original calibration study, `manifest::Study`, keeps its
//! own format so its golden chain keeps its ids.) A study file is a design
//! study when it has a `factors` object.
//!
//! # Generated experiments
//!
//! Every run is the `base` block with one of the study's `scenes`, the seeds
//! `{design_seed: seed, sample_index: point, packing_seed}` and the factor
//! values written into it by address ([`crate::manifest::address`], the one
//! addressing every study uses): the dotted JSON path of a number in the
//! experiment, such as `contact.particle_particle.static_friction`,
//! `contact.particle_wall.*.restitution` or `scene.rpm` (a scene field is
//! set in the scenes that have it; at least one must).
//!
//! # Seeds
//!
//! Every replicate is its own hashed experiment: its packing seed is drawn
//! from the ChaCha8 stream of (study seed, stage, design point), one draw
//! per replicate ([`SeedRule::Drawn`]), so replicates differ, a centre point
//! repeated in the design gets fresh packings (and the lack-of-fit test a
//! real pure error), and the same study gives the same seeds everywhere.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::doe::box_behnken::box_behnken;
use crate::doe::factorial::full_factorial;
use crate::doe::lhs::{latin_hypercube, Placement};
use crate::manifest::validate::{check_path_component, number, string};
use crate::manifest::{
    validate_experiment, AtRest, CoarseGraining, Contact, ContentId, Experiment, ExperimentDoc,
    FieldError, Material, Profile, Scene, Seeds, TimeStep, ValidationErrors, PHYSICS_VERSION,
    SCHEMA_VERSION,
};
use crate::scenes::responses::catalogue;
#[cfg(doc)]
use crate::streams::SeedRule;
pub use crate::streams::SeedStage;
use crate::streams::{rng, Stream};
use crate::study::StudyError;

/// A design study (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignStudy {
    /// Manifest format version; must equal [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Short name (e.g. `cai2024-quick`); names the study's directory.
    pub name: String,
    /// Free text: sources, and every choice made where the paper is silent.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// What every generated experiment shares.
    pub base: Base,
    /// The scenes every design point runs, by name (e.g. `static`, `drum`).
    pub scenes: BTreeMap<String, Scene>,
    /// The design's factors by short name (`A`, `B`, …: the model's term
    /// names), in name order.
    pub factors: BTreeMap<String, Factor>,
    /// The analysed responses by name.
    pub responses: BTreeMap<String, ResponseRef>,
    /// Measured values per response name (zero or more).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub targets: BTreeMap<String, Target>,
    /// The design over the factors.
    pub design: DesignSpec,
    /// The surrogate fitted to each response (default: quadratic).
    #[serde(default, skip_serializing_if = "FitChoice::is_quadratic")]
    pub fit: FitChoice,
    /// Packing seeds per design point (≥ 1; ≥ 2 gives a pure error).
    pub replicates: u32,
    /// Seed of every random stream of the study (packing seeds, optimiser
    /// starts).
    pub seed: u64,
    /// One-factor-at-a-time screening (`repose screen`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub screening: Option<Screening>,
    /// Re-simulation of the optimum and of named points (`repose verify`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verification: Option<Verification>,
    /// The stages the study runs, spelled out in order (absent: the list
    /// its blocks give for the command that runs it). When present it must
    /// be one of those lists, and it chooses the analysis: `search` for
    /// response surfaces (`repose rsm`), `sensitivity` for yan2015's levels
    /// (`repose sensitivity`); see `crate::study::plan`.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "crate::manifest::study::spelled_stages"
    )]
    pub stages: Vec<String>,
}

/// What every generated experiment shares (an experiment without its scene
/// and seeds).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Base {
    /// Fidelity profile.
    pub profile: Profile,
    /// Particle and wall materials.
    pub material: Material,
    /// Contact model and parameters (factors overwrite some of them).
    pub contact: Contact,
    /// Time-step rule.
    pub time_step: TimeStep,
    /// Coarse graining (absent: real particles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_graining: Option<CoarseGraining>,
    /// Settling criterion (absent: the default).
    #[serde(default, skip_serializing_if = "AtRest::is_default")]
    pub at_rest: AtRest,
}

/// A design factor: an address and its range in actual units (coded −1 at
/// `min`, +1 at `max`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Factor {
    /// Dotted path of the number it sets (see the module docs).
    pub address: String,
    /// Low end of the range, actual units.
    pub min: f64,
    /// High end of the range, actual units.
    pub max: f64,
    /// Name in reports (e.g. `μs pp`); default: the address.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub label: String,
}

impl Factor {
    /// The name reports show: the label, or the address without one.
    pub fn display_name(&self) -> String {
        display_name(&self.label, &self.address)
    }
}

impl ScreenFactor {
    /// The name reports show: the label, or the address without one.
    pub fn display_name(&self) -> String {
        display_name(&self.label, &self.address)
    }
}

fn display_name(label: &str, address: &str) -> String {
    if label.is_empty() { address } else { label }.to_string()
}

/// Where a response comes from: a study scene and one of its scene kind's
/// named responses (`repose responses SCENE`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseRef {
    /// A key of the study's `scenes`.
    pub scene: String,
    /// A response name of that scene's kind.
    pub response: String,
}

/// A measured value of a response and how close a simulation must come.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Target {
    /// The measured value, the response's units.
    pub value: f64,
    /// Accepted |simulated − value| / value in verification, in (0, 1).
    pub tolerance_fraction: f64,
    /// Lower end of the target-is-best desirability (d = 0 at and below).
    pub low: f64,
    /// Upper end of the target-is-best desirability (d = 0 at and above).
    pub high: f64,
}

/// The design over the factors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DesignSpec {
    /// Box–Behnken: the edge midpoints of every factor pair, then centre
    /// points (k ≥ 3).
    BoxBehnken {
        /// Centre points (≥ 1; cai2024: 5).
        centre_points: u32,
    },
    /// Every combination of explicit levels, actual units (yan2015).
    FullFactorial {
        /// Levels per factor name (every factor, ≥ 2 levels each, within its
        /// range).
        levels: BTreeMap<String, Vec<f64>>,
    },
    /// A Latin hypercube of `points` points over the factor ranges (he2019's
    /// design), each point uniform within its stratum, from the design
    /// stream of the study's seed.
    Lhs {
        /// Points (≥ factors + 2, so a surface has residual freedom).
        points: u32,
    },
}

/// The surrogate `repose rsm` fits to each response ([`crate::surrogate`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitChoice {
    /// The full quadratic with its ANOVA (cai2024; the default).
    #[default]
    Quadratic,
    /// A Gaussian process on the coded cube (its noise a fitted nugget): for
    /// designs without the structure a quadratic's ANOVA needs, e.g. an LHS.
    Gp,
}

impl FitChoice {
    /// True for the default, which a study file need not write (so existing
    /// study ids stay as they were).
    pub fn is_quadratic(&self) -> bool {
        *self == FitChoice::Quadratic
    }
}

/// One-factor-at-a-time screening around the base experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Screening {
    /// Screened factors by name; every other quantity stays at the base
    /// (design factors at the centre of their ranges).
    pub factors: BTreeMap<String, ScreenFactor>,
    /// Packing seeds per level (≥ 2: the one-way ANOVA needs them).
    pub replicates: u32,
    /// Significance level of the one-way ANOVA, in (0, 1); default 0.05.
    #[serde(default = "default_alpha")]
    pub alpha: f64,
}

fn default_alpha() -> f64 {
    0.05
}

/// A screened factor: an address and its levels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScreenFactor {
    /// Dotted path of the number it sets (see the module docs).
    pub address: String,
    /// Levels, actual units (≥ 2, distinct).
    pub levels: Vec<f64>,
    /// Name in reports; default: the address.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub label: String,
}

/// What `repose verify` re-simulates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Verification {
    /// Packing seeds per point and scene (≥ 2; the CI needs them).
    pub replicates: u32,
    /// Further points by name (e.g. the paper's optimum), each giving every
    /// factor in actual units; the desirability optimum is always verified.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub points: BTreeMap<String, BTreeMap<String, f64>>,
}

impl DesignStudy {
    /// The study id: sha256 of its canonical JSON.
    pub fn id(&self) -> ContentId {
        crate::manifest::content_id(self)
    }

    /// Factor names in order (the model's term letters).
    pub fn factor_names(&self) -> Vec<String> {
        self.factors.keys().cloned().collect()
    }

    /// Factor ranges in factor order, for the designs' coded units.
    pub fn ranges(&self) -> Vec<crate::doe::Range> {
        self.factors
            .values()
            .map(|f| crate::doe::Range {
                low: f.min,
                high: f.max,
            })
            .collect()
    }

    /// The experiment of scene `scene` with `values` (address, actual value)
    /// written in, at `sample_index` with `packing_seed`; validated.
    pub fn experiment(
        &self,
        scene: &str,
        values: &[(&str, f64)],
        sample_index: u64,
        packing_seed: u64,
    ) -> Result<Experiment, ValidationErrors> {
        let reject = |path: String, value: String, rule: String| {
            ValidationErrors(vec![FieldError { path, value, rule }])
        };
        let Some(scene_spec) = self.scenes.get(scene) else {
            return Err(reject(
                "scene".into(),
                scene.into(),
                format!("is not one of the study's scenes ({})", self.scene_names()),
            ));
        };
        let experiment = Experiment {
            schema_version: SCHEMA_VERSION,
            physics_version: PHYSICS_VERSION,
            profile: self.base.profile,
            scene: scene_spec.clone(),
            material: self.base.material.clone(),
            contact: self.base.contact.clone(),
            seeds: Seeds {
                design_seed: self.seed,
                sample_index,
                packing_seed,
            },
            time_step: self.base.time_step,
            coarse_graining: self.base.coarse_graining,
            at_rest: self.base.at_rest,
        };
        let mut doc = ExperimentDoc::of(&experiment);
        for (address, value) in values {
            match doc.set(address, *value) {
                Ok(()) => {}
                // A scene knob applies to the scenes that have it.
                Err(_) if address.starts_with("scene.") => {}
                Err(rule) => return Err(reject(address.to_string(), number(*value), rule)),
            }
        }
        let experiment: Experiment = doc.into_experiment().map_err(|e| {
            reject(
                format!("scenes.{scene}"),
                "(generated experiment)".into(),
                format!("does not form an experiment: {e}"),
            )
        })?;
        validate_experiment(&experiment)?;
        Ok(experiment)
    }

    fn scene_names(&self) -> String {
        self.scenes.keys().cloned().collect::<Vec<_>>().join(", ")
    }

    /// Checks everything the types do not: every error names the field, its
    /// value and what is allowed.
    pub fn validate(&self) -> Result<(), ValidationErrors> {
        let mut errors = Vec::new();
        let mut fail = |path: String, value: String, rule: String| {
            errors.push(FieldError { path, value, rule });
        };
        if self.schema_version != SCHEMA_VERSION {
            fail(
                "schema_version".into(),
                self.schema_version.to_string(),
                format!("must be {SCHEMA_VERSION}"),
            );
        }
        // Every name that becomes a path component, checked by the one rule.
        let names = std::iter::once(("name".to_string(), &self.name))
            .chain(
                self.scenes
                    .keys()
                    .map(|n| ("scenes (a key)".to_string(), n)),
            )
            .chain(
                self.factors
                    .keys()
                    .map(|n| ("factors (a key)".to_string(), n)),
            )
            .chain(
                self.responses
                    .keys()
                    .map(|n| ("responses (a key)".to_string(), n)),
            );
        for (path, name) in names {
            if let Err(rule) = check_path_component(name) {
                fail(path, string(name), rule);
            }
        }
        if self.scenes.is_empty() {
            fail(
                "scenes".into(),
                "{}".into(),
                "needs at least one scene".into(),
            );
        }
        for (name, scene) in &self.scenes {
            if matches!(scene, Scene::Pair(_)) {
                fail(
                    format!("scenes.{name}.kind"),
                    "\"pair\"".into(),
                    "must be a lab scene (pair has no bulk response)".into(),
                );
            }
        }
        if self.factors.is_empty() {
            fail(
                "factors".into(),
                "{}".into(),
                "needs at least one factor".into(),
            );
        }
        for (name, f) in &self.factors {
            let path = format!("factors.{name}");
            if !(f.min.is_finite() && f.max.is_finite() && f.min < f.max) {
                fail(
                    format!("{path}.min"),
                    format!("{} (max {})", number(f.min), number(f.max)),
                    "must be finite and below max".into(),
                );
            }
            if let Err(rule) = self.check_address(&f.address) {
                fail(format!("{path}.address"), format!("{:?}", f.address), rule);
            }
        }
        for (i, (a, fa)) in self.factors.iter().enumerate() {
            for (b, fb) in self.factors.iter().skip(i + 1) {
                if addresses_overlap(&fa.address, &fb.address) {
                    fail(
                        format!("factors.{b}.address"),
                        format!("{:?}", fb.address),
                        format!(
                            "sets the same field as factors.{a}.address ({:?}): two factors \
                             on one field alias (the later value overwrites the earlier, and \
                             the analysis would credit effects to a factor never applied)",
                            fa.address
                        ),
                    );
                }
            }
        }
        if self.responses.is_empty() {
            fail(
                "responses".into(),
                "{}".into(),
                "needs at least one response".into(),
            );
        }
        for (name, r) in &self.responses {
            let path = format!("responses.{name}");
            match self.scenes.get(&r.scene) {
                None => fail(
                    format!("{path}.scene"),
                    format!("{:?}", r.scene),
                    format!("must be one of the study's scenes ({})", self.scene_names()),
                ),
                Some(scene) => {
                    let names = catalogue(scene.kind()).unwrap_or(&[]);
                    if !names.iter().any(|s| s.name == r.response) {
                        fail(
                            format!("{path}.response"),
                            format!("{:?}", r.response),
                            format!(
                                "is not a response of a {} scene; allowed: {}",
                                scene.kind(),
                                names.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
                            ),
                        );
                    }
                }
            }
        }
        for (name, t) in &self.targets {
            let path = format!("targets.{name}");
            if !self.responses.contains_key(name) {
                fail(
                    path.clone(),
                    "(present)".into(),
                    "must name one of the study's responses".into(),
                );
            }
            if !(t.value.is_finite() && t.low < t.value && t.value < t.high) {
                fail(
                    format!("{path}.value"),
                    format!(
                        "{} (low {}, high {})",
                        number(t.value),
                        number(t.low),
                        number(t.high)
                    ),
                    "must be finite with low < value < high".into(),
                );
            }
            if !(t.tolerance_fraction > 0.0 && t.tolerance_fraction < 1.0) {
                fail(
                    format!("{path}.tolerance_fraction"),
                    number(t.tolerance_fraction),
                    "must be in (0, 1)".into(),
                );
            }
        }
        match &self.design {
            DesignSpec::BoxBehnken { centre_points } => {
                if self.factors.len() < 3 {
                    fail(
                        "design.kind".into(),
                        "\"box_behnken\"".into(),
                        format!(
                            "needs at least 3 factors; the study has {}",
                            self.factors.len()
                        ),
                    );
                }
                if *centre_points < 1 {
                    fail(
                        "design.centre_points".into(),
                        centre_points.to_string(),
                        "must be >= 1".into(),
                    );
                }
            }
            DesignSpec::FullFactorial { levels } => {
                for (name, f) in &self.factors {
                    let path = format!("design.levels.{name}");
                    match levels.get(name) {
                        None => fail(path, "(absent)".into(), "every factor needs levels".into()),
                        Some(l) => {
                            if let Err(rule) = check_levels(l, Some((f.min, f.max))) {
                                fail(path, format!("{l:?}"), rule);
                            }
                        }
                    }
                }
                for name in levels.keys().filter(|n| !self.factors.contains_key(*n)) {
                    fail(
                        format!("design.levels.{name}"),
                        "(present)".into(),
                        "is not a factor of the study".into(),
                    );
                }
            }
            DesignSpec::Lhs { points } => {
                let least = self.factors.len() + 2;
                if (*points as usize) < least {
                    fail(
                        "design.points".into(),
                        points.to_string(),
                        format!(
                            "must be >= {least} (the factors + 2) for {} factor(s)",
                            self.factors.len()
                        ),
                    );
                }
            }
        }
        if self.replicates < 1 {
            fail(
                "replicates".into(),
                self.replicates.to_string(),
                "must be >= 1".into(),
            );
        }

        if let Some(s) = &self.screening {
            if s.factors.is_empty() {
                fail(
                    "screening.factors".into(),
                    "{}".into(),
                    "needs at least one factor".into(),
                );
            }
            for (name, f) in &s.factors {
                let path = format!("screening.factors.{name}");
                if let Err(rule) = self.check_address(&f.address) {
                    fail(format!("{path}.address"), format!("{:?}", f.address), rule);
                }
                if let Err(rule) = check_levels(&f.levels, None) {
                    fail(format!("{path}.levels"), format!("{:?}", f.levels), rule);
                }
            }
            if s.replicates < 2 {
                fail(
                    "screening.replicates".into(),
                    s.replicates.to_string(),
                    "must be >= 2 (the one-way ANOVA needs a within-level spread)".into(),
                );
            }
            if !(s.alpha > 0.0 && s.alpha < 1.0) {
                fail(
                    "screening.alpha".into(),
                    number(s.alpha),
                    "must be in (0, 1)".into(),
                );
            }
        }
        if let Some(v) = &self.verification {
            if v.replicates < 2 {
                fail(
                    "verification.replicates".into(),
                    v.replicates.to_string(),
                    "must be >= 2 (a confidence interval needs them)".into(),
                );
            }
            for (name, point) in &v.points {
                for (factor, f) in &self.factors {
                    if !point.contains_key(factor) {
                        fail(
                            format!("verification.points.{name}.{factor}"),
                            "(absent)".into(),
                            "every factor needs a value".into(),
                        );
                    } else if !point[factor].is_finite() {
                        fail(
                            format!("verification.points.{name}.{factor}"),
                            number(point[factor]),
                            format!(
                                "must be finite (range {}..{})",
                                number(f.min),
                                number(f.max)
                            ),
                        );
                    }
                }
                for factor in point.keys().filter(|k| !self.factors.contains_key(*k)) {
                    fail(
                        format!("verification.points.{name}.{factor}"),
                        "(present)".into(),
                        "is not a factor of the study".into(),
                    );
                }
            }
        }
        if errors.is_empty() {
            // Every scene at the centre of the design must make a valid experiment.
            let centre: Vec<(String, f64)> = self
                .factors
                .values()
                .map(|f| (f.address.clone(), 0.5 * (f.min + f.max)))
                .collect();
            let values: Vec<(&str, f64)> = centre.iter().map(|(a, v)| (a.as_str(), *v)).collect();
            for name in self.scenes.keys() {
                if let Err(e) = self.experiment(name, &values, 0, 0) {
                    for mut fe in e.0 {
                        fe.path = format!("(scenes.{name} at the design centre) {}", fe.path);
                        errors.push(fe);
                    }
                }
            }
        }
        if errors.is_empty() {
            Ok(())
        } else {
            Err(ValidationErrors(errors))
        }
    }

    /// Points of the design, counted without building it (saturating): an
    /// LHS's `points`, the product of a full factorial's level counts (a
    /// factor without levels counts 0), a Box–Behnken's 2k(k − 1) edge
    /// midpoints and its centre points.
    pub fn points(&self) -> u64 {
        let k = self.factors.len() as u64;
        match &self.design {
            DesignSpec::BoxBehnken { centre_points } => {
                (2 * k * k.saturating_sub(1)).saturating_add(u64::from(*centre_points))
            }
            DesignSpec::FullFactorial { levels } => self.factors.keys().fold(1u64, |n, f| {
                n.saturating_mul(levels.get(f).map_or(0, Vec::len) as u64)
            }),
            DesignSpec::Lhs { points } => u64::from(*points),
        }
    }

    /// Whether the design can carry a full quadratic fit: three levels of
    /// each factor and more runs than the (k + 1)(k + 2)/2 terms. `repose
    /// rsm` asks this before any run (a sensitivity study needs neither, so
    /// validation does not), so a design that cannot be fitted is refused
    /// instead of simulated and then refused.
    pub fn check_quadratic(&self) -> Result<(), crate::study::StudyError> {
        let mut problems = Vec::new();
        let k = self.factors.len();
        let terms = (k + 1) * (k + 2) / 2;
        if let DesignSpec::FullFactorial { levels } = &self.design {
            for (name, l) in levels.iter().filter(|(_, l)| l.len() < 3) {
                problems.push(format!(
                    "design.levels.{name} = {l:?}: a quadratic fit needs at least 3 levels of \
                     each factor (or fit \"gp\")"
                ));
            }
        }
        // A Box–Behnken always has more points than the quadratic has terms.
        let points = match &self.design {
            DesignSpec::BoxBehnken { .. } => usize::MAX,
            _ => usize::try_from(self.points()).unwrap_or(usize::MAX),
        };
        let runs = points.saturating_mul(self.replicates as usize);
        if runs <= terms {
            problems.push(format!(
                "replicates = {}: {points} design point(s) x {} replicate(s) = {runs} runs are \
                 too few for the {terms} terms of a full quadratic in {k} factor(s) (more than \
                 {terms} are needed for a residual)",
                self.replicates, self.replicates
            ));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(crate::study::StudyError::Settings(problems.join("; ")))
        }
    }

    /// Whether `address` names a number in at least one scene's experiment
    /// (and in every scene's for addresses outside `scene.`).
    fn check_address(&self, address: &str) -> Result<(), String> {
        let mut found = 0;
        for name in self.scenes.keys() {
            let e = self.experiment(name, &[], 0, 0);
            let Ok(e) = e else { return Ok(()) }; // reported by the centre check
            match ExperimentDoc::of(&e).set(address, 1.0) {
                Ok(()) => found += 1,
                Err(rule) if !address.starts_with("scene.") => return Err(rule),
                Err(_) => {}
            }
        }
        if found == 0 {
            return Err("no scene of the study has this field".into());
        }
        Ok(())
    }
}

/// Whether two factor addresses can set the same number: the same path, a
/// `*` matching any map key, and the derived shear modulus counting as the
/// Young's modulus it sets.
fn addresses_overlap(a: &str, b: &str) -> bool {
    let canonical = |s: &str| {
        s.replace(
            "material.particle.shear_modulus_pa",
            "material.particle.youngs_modulus_pa",
        )
    };
    let (a, b) = (canonical(a), canonical(b));
    let (sa, sb): (Vec<&str>, Vec<&str>) = (a.split('.').collect(), b.split('.').collect());
    sa.len() == sb.len()
        && sa
            .iter()
            .zip(&sb)
            .all(|(x, y)| x == y || *x == "*" || *y == "*")
}

/// Levels must be ≥ 2, finite, distinct and (if `range`) within it.
fn check_levels(levels: &[f64], range: Option<(f64, f64)>) -> Result<(), String> {
    if levels.len() < 2 {
        return Err("needs at least 2 levels".into());
    }
    if levels.iter().any(|v| !v.is_finite()) {
        return Err("levels must be finite".into());
    }
    for (i, a) in levels.iter().enumerate() {
        if levels[..i].contains(a) {
            return Err(format!("level {} appears twice", number(*a)));
        }
    }
    if let Some((min, max)) = range {
        if levels.iter().any(|v| *v < min || *v > max) {
            return Err(format!(
                "levels must lie within the factor's range [{}, {}]",
                number(min),
                number(max)
            ));
        }
    }
    Ok(())
}

/// Reads and validates a design study.
pub fn read_design_study(path: &Path) -> Result<DesignStudy, crate::manifest::ManifestError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| crate::manifest::ManifestError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    parse_design_study(&text)
}

/// Parses and validates a design study's JSON text.
pub fn parse_design_study(text: &str) -> Result<DesignStudy, crate::manifest::ManifestError> {
    let study: DesignStudy = crate::manifest::parse_kind(text, crate::manifest::A_DESIGN_STUDY)?;
    study
        .validate()
        .map_err(crate::manifest::ManifestError::Invalid)?;
    Ok(study)
}

/// Whether the JSON text is a design study (it has a `factors` object).
pub fn is_design_study(text: &str) -> bool {
    serde_json::from_str::<Value>(text)
        .map(|v| v.get("factors").is_some_and(Value::is_object))
        .unwrap_or(false)
}

/// The design's points in coded units, in run order.
pub fn coded_design(study: &DesignStudy) -> Result<Vec<Vec<f64>>, StudyError> {
    let ranges = study.ranges();
    Ok(match &study.design {
        DesignSpec::BoxBehnken { centre_points } => {
            box_behnken(study.factors.len(), *centre_points as usize)?
        }
        DesignSpec::FullFactorial { levels } => {
            let lists: Vec<Vec<f64>> = study.factors.keys().map(|f| levels[f].clone()).collect();
            full_factorial(&lists)?
                .iter()
                .map(|row| {
                    row.iter()
                        .zip(&ranges)
                        .map(|(x, r)| r.to_coded(*x))
                        .collect()
                })
                .collect()
        }
        DesignSpec::Lhs { points } => latin_hypercube(
            *points as usize,
            study.factors.len(),
            Placement::Random,
            &mut rng(study.seed, Stream::Design, 0),
        )
        .into_iter()
        .map(|u| u.into_iter().map(|v| 2.0 * v - 1.0).collect())
        .collect(),
    })
}

/// The design's points in actual units, in run order: a full factorial's
/// levels exactly as the study writes them (so every experiment carries the
/// study's numbers, not a coded round trip of them), a Box–Behnken design
/// decoded from the factor ranges.
pub fn actual_design(study: &DesignStudy) -> Result<Vec<Vec<f64>>, StudyError> {
    if let DesignSpec::FullFactorial { levels } = &study.design {
        let lists: Vec<Vec<f64>> = study.factors.keys().map(|f| levels[f].clone()).collect();
        return Ok(full_factorial(&lists)?);
    }
    let ranges = study.ranges();
    Ok(coded_design(study)?
        .iter()
        .map(|c| {
            c.iter()
                .zip(&ranges)
                .map(|(x, r)| r.to_actual(*x))
                .collect()
        })
        .collect())
}
