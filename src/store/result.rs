//! The result of one run (`runs/<id>/result.json`) and the side records of a run.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::manifest::{ContentId, Experiment, Profile};

/// The key of [`RunResult::unmeasured`] that says why a run has no headline
/// angle (beside the key of the measurement the headline is).
pub const HEADLINE_KEY: &str = "headline_angle_deg";

/// What a run produced. Deterministic: identical manifests give byte-identical
/// result.json (wall-clock times live in timing.json instead).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunResult {
    /// Id of the experiment that produced it.
    pub id: ContentId,
    /// Scene kind (e.g. `pair`, `drum`).
    pub scene: String,
    /// Fidelity profile of the run.
    pub profile: Profile,
    /// Name of the engine kernel that ran (the force-law combination).
    pub kernel: String,
    /// Scalar measurements by name; the name states the unit (e.g. `restitution`,
    /// `contact_time_s`).
    pub measurements: BTreeMap<String, f64>,
    /// Named time series sampled during the run.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub traces: BTreeMap<String, Trace>,
    /// The angle of repose the scene reports, degrees (none for pair scenes).
    pub headline_angle_deg: Option<f64>,
    /// Real and simulated particle when the experiment coarse-grains.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse_graining: Option<CoarseGrainingReport>,
    /// What the run met that its settings did not foresee and that may have
    /// changed the answer (e.g. contacts faster than the time step resolves,
    /// see [`crate::dem::timestep::TimeStepPlan::under_resolved`]), one
    /// sentence each. Absent from result.json when empty, so a run without a
    /// warning writes the same bytes as before warnings existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Measurements the scene could not take in this run, by measurement key
    /// (e.g. a funnel's side-view `angle_deg`), each with the reason (a
    /// "not measurable" sentence). A run reports every measurement it can
    /// take: one it cannot never discards the others, and a study counts it
    /// as a missing replicate of that response with this reason. Absent from
    /// result.json when empty.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub unmeasured: BTreeMap<String, String>,
    /// The scene's resolution figures (particle diameters across the device,
    /// bed depth, Froude number, …; [`crate::scenes::resolution`]), each with
    /// its limits; one outside them also adds a warning. Absent from
    /// result.json when empty.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub resolution: BTreeMap<String, ResolutionFigure>,
}

/// One resolution figure of a run and the limits it must lie within.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolutionFigure {
    /// The figure (dimensionless: diameters, a Froude number).
    pub value: f64,
    /// Lowest resolved value, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// Highest resolved value, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
}

impl ResolutionFigure {
    /// How the value breaks its limits (`below 20`, `above 0.01`), if it does.
    /// A value within 10⁻⁹ (relative) of a limit meets it: figures are ratios
    /// of decimal lengths (0.018 m / 0.003 m is 5.999… in binary).
    pub fn violation(&self) -> Option<String> {
        const SLACK: f64 = 1e-9;
        match (self.min, self.max) {
            (Some(min), _) if self.value < min - SLACK * min.abs() => Some(format!("below {min}")),
            (_, Some(max)) if self.value > max + SLACK * max.abs() => Some(format!("above {max}")),
            _ => None,
        }
    }
}

/// What coarse graining did to the particle (he2019 Eq. 1–3, cai2024 §1.2):
/// the factors applied and the particle–particle cohesion before and after.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoarseGrainingReport {
    /// The surface-energy rule (`surface_energy_proportional`, `cohesion_number`
    /// or `constant_bond`).
    pub rule: String,
    /// Simulated / real radius.
    pub size_factor: f64,
    /// Simulated / real particle Young's modulus.
    pub youngs_modulus_factor: f64,
    /// Simulated / real surface energy, applied to every pair type.
    pub surface_energy_factor: f64,
    /// Representative real particle radius (mean of a list, d50/2), m.
    pub real_radius_m: f64,
    /// The same particle as simulated, m.
    pub simulated_radius_m: f64,
    /// Real particle Young's modulus, Pa.
    pub real_youngs_modulus_pa: f64,
    /// Simulated particle Young's modulus, Pa.
    pub simulated_youngs_modulus_pa: f64,
    /// Real particle–particle surface energy, J/m².
    pub real_surface_energy_j_m2: f64,
    /// Simulated particle–particle surface energy, J/m².
    pub simulated_surface_energy_j_m2: f64,
    /// he2019 Eq. 2 cohesion number of the real pair of representative particles
    /// (m² as printed; see [`crate::packing::coarse`]); 0 without cohesion.
    pub real_cohesion_number: f64,
    /// The same for the simulated pair.
    pub simulated_cohesion_number: f64,
}

/// A time series: `values[i]` at simulated time `time_s[i]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trace {
    /// Simulated times, s.
    pub time_s: Vec<f64>,
    /// Values, in `unit`.
    pub values: Vec<f64>,
    /// Unit of the values (e.g. `J`, `deg`, `1`).
    pub unit: String,
}

impl RunResult {
    /// The run as `repose run` prints it: id and how it was obtained (`cache
    /// hit`, or `computed` with the engine's `threads` when this call ran
    /// it), `directory`, scene, profile and kernel, the headline angle, every
    /// measurement and why any response was not measured.
    pub fn summary(
        &self,
        id: &ContentId,
        directory: &std::path::Path,
        threads: Option<usize>,
    ) -> String {
        let how = if threads.is_some() {
            "computed"
        } else {
            "cache hit"
        };
        let mut out = format!("run {id} ({how})\n  directory: {}\n", directory.display());
        if let Some(threads) = threads {
            out.push_str(&format!("  threads: {threads}\n"));
        }
        out.push_str(&format!(
            "  scene: {}  profile: {}  kernel: {}\n",
            self.scene, self.profile, self.kernel
        ));
        if let Some(angle) = self.headline_angle_deg {
            out.push_str(&format!("  angle of repose: {angle:.2} deg\n"));
        }
        for (name, value) in &self.measurements {
            out.push_str(&format!("  {name} = {value}\n"));
        }
        for (name, why) in &self.unmeasured {
            out.push_str(&format!("  {name}: {why}\n"));
        }
        out
    }

    /// An empty result for `experiment` (id, scene kind and profile filled in).
    pub fn new(experiment: &Experiment, kernel: impl Into<String>) -> RunResult {
        RunResult {
            id: experiment.id(),
            scene: experiment.scene.kind().to_string(),
            profile: experiment.profile,
            kernel: kernel.into(),
            measurements: BTreeMap::new(),
            traces: BTreeMap::new(),
            headline_angle_deg: None,
            coarse_graining: None,
            warnings: Vec::new(),
            unmeasured: BTreeMap::new(),
            resolution: BTreeMap::new(),
        }
    }

    /// The resolution figures outside their limits, by name.
    pub fn unresolved(&self) -> Vec<&str> {
        self.resolution
            .iter()
            .filter(|(_, f)| f.violation().is_some())
            .map(|(name, _)| name.as_str())
            .collect()
    }

    /// Why the run has no headline angle, when it has none and the scene
    /// said why ([`HEADLINE_KEY`] of [`RunResult::unmeasured`]).
    pub fn headline_reason(&self) -> Option<&str> {
        match self.headline_angle_deg {
            Some(_) => None,
            None => self.unmeasured.get(HEADLINE_KEY).map(String::as_str),
        }
    }

    /// Why this result cannot be stored, if it cannot: a non-finite number (JSON has
    /// none) or a trace whose columns differ in length.
    pub fn defect(&self) -> Option<String> {
        if let Some((name, v)) = self.measurements.iter().find(|(_, v)| !v.is_finite()) {
            return Some(format!("measurement `{name}` is not finite ({v})"));
        }
        if let Some(a) = self.headline_angle_deg.filter(|a| !a.is_finite()) {
            return Some(format!("headline angle is not finite ({a})"));
        }
        for (name, t) in &self.traces {
            if t.time_s.len() != t.values.len() {
                return Some(format!(
                    "trace `{name}` has {} times but {} values",
                    t.time_s.len(),
                    t.values.len()
                ));
            }
            if t.time_s.iter().chain(&t.values).any(|v| !v.is_finite()) {
                return Some(format!("trace `{name}` holds a non-finite number"));
            }
        }
        None
    }
}

/// `runs/<id>/error.json`: why a run failed (a failed run never has a result).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorRecord {
    /// Id of the experiment.
    pub id: ContentId,
    /// The error, as displayed.
    pub error: String,
    /// Its chain of causes, outermost first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub causes: Vec<String>,
}

/// `runs/<id>/timing.json`: wall-clock cost of the run. Non-deterministic by nature,
/// which is why it is kept out of result.json.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimingRecord {
    /// Wall time of the runner, s.
    pub wall_time_s: f64,
    /// CPU time (user + system) of the thread that ran the runner, s: the
    /// run's whole CPU cost when its engine ran on that one thread, as every
    /// executor run does; a lower bound for a run given more threads (their
    /// time is not counted). Absent on platforms without per-thread CPU
    /// clocks and in timing files written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thread_cpu_s: Option<f64>,
}

impl TimingRecord {
    /// The run's CPU cost, s: its thread's CPU time, or its wall time where
    /// the platform has no per-thread clock (a run of an executor uses one
    /// thread, so the two agree up to waiting). The one rule every stage,
    /// sweep and analysis prices a run by.
    pub fn cpu_s(&self) -> f64 {
        self.thread_cpu_s.unwrap_or(self.wall_time_s)
    }
}
