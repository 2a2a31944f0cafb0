//! The sweep plan: fidelity knobs as edits of a base experiment manifest, the
//! reference point and the one-knob-at-a-time points around it.
//!
//! A knob is a named manifest edit with values listed finest first. The
//! reference is the base manifest with every swept knob at its finest value
//! (the most accurate setting the sweep can afford); every other point moves
//! exactly one knob away from it. Each point is run `replicates` times with
//! packing seeds `base, base + 1, ...`, so packing noise is measured, not
//! mistaken for numerical error. Every point is an ordinary experiment:
//! validated, hashed, cached and resumable.

use crate::study::plan::StudySpec;
use crate::study::sweeps::noise_floor::with_packing_offset;

use crate::manifest::{
    validate_experiment, CoarseGraining, CoarseGrainingRule, Experiment, ExperimentDoc,
    ValidationErrors,
};

/// A fidelity knob: what it changes and the values it takes, finest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Knob {
    /// Name used in tables and on the plot.
    pub name: &'static str,
    /// What the values mean (unit or factor), for the report.
    pub meaning: &'static str,
    /// Values, finest (most accurate, most expensive) first.
    pub values: Vec<f64>,
}

/// Names of the knobs [`Knob::preset`] knows, in report order.
pub const KNOB_NAMES: [&str; 6] = [
    "rayleigh_fraction",
    "youngs_modulus_factor",
    "size_factor",
    "periodic_slices",
    "stop_threshold",
    "stop_hold",
];

impl Knob {
    /// The default sweep of a named knob, or `None` for an unknown name.
    /// - `rayleigh_fraction`: time step as a fraction of the Rayleigh time.
    /// - `youngs_modulus_factor`: particle E × factor (surface energy follows
    ///   the experiment's coarse-graining rule; cohesion number if none).
    /// - `size_factor`: particle radius × factor relative to the base.
    /// - `periodic_slices`: drums only; the slice thickness as a multiple of
    ///   the base slice (1 = the base; the finest is the base's own setting).
    /// - `stop_threshold`: the at-rest kinetic-energy fraction × factor
    ///   relative to the base (smaller = stricter = finer).
    /// - `stop_hold`: the at-rest hold time × factor relative to the base
    ///   (longer = finer).
    pub fn preset(name: &str) -> Option<Knob> {
        let (name, meaning, values): (&'static str, &'static str, Vec<f64>) = match name {
            "rayleigh_fraction" => (
                "rayleigh_fraction",
                "time step / Rayleigh time",
                vec![0.05, 0.1, 0.2, 0.3, 0.4],
            ),
            "youngs_modulus_factor" => (
                "youngs_modulus_factor",
                "simulated / base Young's modulus",
                vec![1.0, 0.1, 0.01, 0.001],
            ),
            "size_factor" => (
                "size_factor",
                "simulated / base particle radius",
                vec![1.0, 1.5, 2.0, 3.0, 4.0],
            ),
            "periodic_slices" => (
                "periodic_slices",
                "drum slice thickness / base slice thickness",
                vec![2.0, 1.0, 0.5],
            ),
            "stop_threshold" => (
                "stop_threshold",
                "at-rest kinetic-energy fraction / base fraction",
                vec![0.1, 1.0, 10.0],
            ),
            "stop_hold" => (
                "stop_hold",
                "at-rest hold time / base hold time",
                vec![2.0, 1.0, 0.5],
            ),
            _ => return None,
        };
        Some(Knob {
            name,
            meaning,
            values,
        })
    }

    /// The same knob with other values (finest first).
    pub fn with_values(mut self, values: Vec<f64>) -> Knob {
        self.values = values;
        self
    }
}

/// One point of the sweep: a knob setting (or the reference) and its replicates.
#[derive(Debug, Clone)]
pub struct Point {
    /// `reference`, or the knob moved away from it.
    pub knob: &'static str,
    /// The knob's value (for the reference: empty).
    pub value: Option<f64>,
    /// One experiment per replicate (packing seed base + r).
    pub replicates: Vec<Experiment>,
}

impl Point {
    /// A short label for tables and plots: `reference` or `knob=value`.
    pub fn label(&self) -> String {
        match self.value {
            None => self.knob.to_string(),
            Some(v) => format!("{}={}", self.knob, v),
        }
    }
}

/// Why a plan could not be built.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A knob does not apply to this scene.
    #[error("knob `{knob}` does not apply: {why}")]
    NotApplicable {
        /// The knob.
        knob: &'static str,
        /// Why.
        why: String,
    },
    /// A knob value makes an invalid experiment (e.g. a step fraction above the
    /// stable limit): refused up front, never run.
    #[error("knob `{knob}` = {value:?}: {errors}")]
    Invalid {
        /// The knob.
        knob: &'static str,
        /// The value.
        value: f64,
        /// What validation said.
        errors: ValidationErrors,
    },
    /// A knob value is NaN or infinite (refused before any experiment is
    /// built from it; written as Rust's `{:?}` prints it, `NaN`, `inf`).
    #[error("knob `{knob}` = {value:?}: must be a finite number")]
    NotFinite {
        /// The knob.
        knob: &'static str,
        /// The value.
        value: f64,
    },
    /// Replicates must be at least 2 for a confidence interval.
    #[error("replicates = {0}: must be at least 2 (a confidence interval needs two runs)")]
    Replicates(usize),
}

/// The sweep as a one-stage study ([`StudySpec::tradeoff`]) named `name`:
/// the reference and every coarser value of each knob, × `replicates` runs,
/// so its size is known before anything is built.
pub fn study_spec(name: &str, base: &Experiment, knobs: &[Knob], replicates: usize) -> StudySpec {
    let points = 1 + knobs
        .iter()
        .map(|k| k.values.len().saturating_sub(1) as u64)
        .sum::<u64>();
    StudySpec::tradeoff(
        name,
        base.id(),
        knobs.iter().map(|k| k.name.to_string()).collect(),
        points,
        replicates as u64,
    )
}

/// Builds the reference and the one-knob-away points for `base`.
pub fn plan(base: &Experiment, knobs: &[Knob], replicates: usize) -> Result<Vec<Point>, PlanError> {
    if replicates < 2 {
        return Err(PlanError::Replicates(replicates));
    }
    for knob in knobs {
        if let Some(&value) = knob.values.iter().find(|v| !v.is_finite()) {
            return Err(PlanError::NotFinite {
                knob: knob.name,
                value,
            });
        }
    }
    let mut reference = base.clone();
    for knob in knobs {
        let finest = knob.values[0];
        reference = apply(&reference, base, knob.name, finest)?;
    }
    let mut points = vec![Point {
        knob: "reference",
        value: None,
        replicates: replicate(&reference, replicates),
    }];
    for knob in knobs {
        for &value in &knob.values[1..] {
            let e = apply(&reference, base, knob.name, value)?;
            points.push(Point {
                knob: knob.name,
                value: Some(value),
                replicates: replicate(&e, replicates),
            });
        }
    }
    Ok(points)
}

/// `e` with packing seeds base, base + 1, ... (the replicate convention of
/// one experiment's studies, [`with_packing_offset`]).
pub(crate) fn replicate(e: &Experiment, n: usize) -> Vec<Experiment> {
    (0..n as u64).map(|r| with_packing_offset(e, r)).collect()
}

/// `e` with knob `name` set to `value` (factors relative to `base`),
/// written at the knob's one address ([`crate::manifest::address`]) and
/// validated. A size or modulus knob on an experiment without coarse
/// graining first adds the identity block (factors 1, the cohesion-number
/// rule).
fn apply(
    e: &Experiment,
    base: &Experiment,
    name: &'static str,
    value: f64,
) -> Result<Experiment, PlanError> {
    let not_applicable = |why: String| PlanError::NotApplicable { knob: name, why };
    let mut e = e.clone();
    let (address, absolute) = match name {
        "rayleigh_fraction" => ("time_step.rayleigh_fraction", value),
        "size_factor" | "youngs_modulus_factor" => {
            let cg = base.coarse_graining.unwrap_or(CoarseGraining {
                size_factor: 1.0,
                youngs_modulus_factor: 1.0,
                rule: CoarseGrainingRule::CohesionNumber,
            });
            e.coarse_graining.get_or_insert(cg);
            if name == "size_factor" {
                ("coarse_graining.size_factor", cg.size_factor * value)
            } else {
                (
                    "coarse_graining.youngs_modulus_factor",
                    cg.youngs_modulus_factor * value,
                )
            }
        }
        "periodic_slices" => {
            let slice = base_slice(base).ok_or_else(|| {
                not_applicable("only a drum with `periodic_slice_m` has a slice to vary".into())
            })?;
            ("scene.periodic_slice_m", slice * value)
        }
        "stop_threshold" => (
            "at_rest.kinetic_energy_fraction",
            base.at_rest.kinetic_energy_fraction * value,
        ),
        "stop_hold" => ("at_rest.hold_s", base.at_rest.hold_s * value),
        _ => {
            return Err(not_applicable(format!(
                "unknown knob; known: {}",
                KNOB_NAMES.join(", ")
            )))
        }
    };
    let mut doc = ExperimentDoc::of(&e);
    doc.set(address, absolute).map_err(not_applicable)?;
    let e = doc.into_experiment().map_err(not_applicable)?;
    validate_experiment(&e).map_err(|errors| PlanError::Invalid {
        knob: name,
        value,
        errors,
    })?;
    Ok(e)
}

fn base_slice(base: &Experiment) -> Option<f64> {
    match &base.scene {
        crate::manifest::Scene::Drum(d) => d.periodic_slice_m,
        _ => None,
    }
}
