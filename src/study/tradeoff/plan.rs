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

use crate::streams::SeedRule;
use crate::study::stages::StudySpec;
use serde_json::json;

use crate::manifest::{Experiment, ValidationErrors};

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

/// `e` with packing seeds base, base + 1, ...
pub(crate) fn replicate(e: &Experiment, n: usize) -> Vec<Experiment> {
    (0..n as u64)
        .map(|r| {
            let mut x = e.clone();
            x.seeds.packing_seed = SeedRule::Offset {
                base: e.seeds.packing_seed,
            }
            .packing_seed(r);
            x
        })
        .collect()
}

/// `e` with knob `name` set to `value` (factors relative to `base`), validated.
fn apply(
    e: &Experiment,
    base: &Experiment,
    name: &'static str,
    value: f64,
) -> Result<Experiment, PlanError> {
    let mut doc = serde_json::to_value(e).expect("experiments serialise");
    let base_cg = base.coarse_graining;
    match name {
        "rayleigh_fraction" => doc["time_step"]["rayleigh_fraction"] = json!(value),
        "youngs_modulus_factor" | "size_factor" => {
            let (size, modulus, rule) = match base_cg {
                Some(cg) => (
                    cg.size_factor,
                    cg.youngs_modulus_factor,
                    serde_json::to_value(cg.rule).expect("rule serialises"),
                ),
                None => (1.0, 1.0, json!("cohesion_number")),
            };
            let cg = doc
                .as_object_mut()
                .expect("experiment is an object")
                .entry("coarse_graining")
                .or_insert_with(
                    || json!({"size_factor": size, "youngs_modulus_factor": modulus, "rule": rule}),
                );
            if name == "size_factor" {
                cg["size_factor"] = json!(size * value);
            } else {
                cg["youngs_modulus_factor"] = json!(modulus * value);
            }
        }
        "periodic_slices" => {
            let slice = base_slice(base).ok_or_else(|| PlanError::NotApplicable {
                knob: name,
                why: "only a drum with `periodic_slice_m` has a slice to vary".into(),
            })?;
            doc["scene"]["periodic_slice_m"] = json!(slice * value);
        }
        "stop_threshold" => {
            let fraction = base.at_rest.kinetic_energy_fraction * value;
            doc["at_rest"]["kinetic_energy_fraction"] = json!(fraction);
        }
        "stop_hold" => doc["at_rest"]["hold_s"] = json!(base.at_rest.hold_s * value),
        _ => {
            return Err(PlanError::NotApplicable {
                knob: name,
                why: format!("unknown knob; known: {}", KNOB_NAMES.join(", ")),
            })
        }
    }
    let text = doc.to_string();
    crate::manifest::parse_experiment(&text).map_err(|e| match e {
        crate::manifest::ManifestError::Invalid(errors) => PlanError::Invalid {
            knob: name,
            value,
            errors,
        },
        other => PlanError::NotApplicable {
            knob: name,
            why: other.to_string(),
        },
    })
}

fn base_slice(base: &Experiment) -> Option<f64> {
    match &base.scene {
        crate::manifest::Scene::Drum(d) => d.periodic_slice_m,
        _ => None,
    }
}
