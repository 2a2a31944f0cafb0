//! he2019's calibration study (§3): its stages `sample`, `batch`, `train`,
//! `search`, `verify` are the sibling modules named below; this module holds
//! what they share (the stage directories, parameter names and scaling).
//!
//! ```text
//! study.json ── sample ──▶ design.csv + one experiment manifest per sample
//!            ── batch  ──▶ angles.csv (the Table A1 equivalent; runs cached in the store)
//!            ── train  ──▶ sweep.csv (Fig. 12) + model.json + parity.svg (Fig. 13)
//!            ── search ──▶ points.csv + clusters.csv/.md (Table 2) + scatter.svg (Fig. 14)
//!            ── verify ──▶ verification.csv/.md (Table 3)
//! ```
//!
//! # Layout
//!
//! A study's outputs live in the run store (`--store`, default `runs/`), in a
//! directory named by the study's name and the first 12 hex digits of its id:
//!
//! ```text
//! <store>/studies/<name>-<id12>/
//!   study.json                      canonical JSON of the study (sha256 = study id)
//!   sample/design.csv               index, one column per calibrated parameter
//!                                   (physical units), experiment_id
//!   sample/diagnostics.json         CD², min distance, correlations, warnings
//!   sample/experiments/<index>.json one experiment manifest per sample (canonical
//!                                   JSON: its sha256 is the experiment id)
//!   batch/angles.csv                index, parameters, experiment_id, angle_deg, status
//!   train/sweep.csv                 hidden size, train/validation R² and RMSE, ...,
//!                                   weights, effective dof, CV score when it chose
//!   train/model.json                the kept network with its scaling (search reuses it)
//!   train/parity.svg                predicted vs simulated, train and validation marked
//!   search/points.csv               resampled points, predicted angle, kept, cluster
//!   search/clusters.csv, .md        centres (physical units), sizes, predicted angle
//!   search/scatter.svg              scatter matrix of the kept points by cluster
//!   verify/acceptance.json          the acceptance rule, written before the runs
//!   verify/verification.csv, .md,   each candidate in every scene: simulated mean
//!   verify/runs.csv                 (one run, or the noise-aware seeds), measured
//!                                   angle, TOST p, verdict ([`crate::study::stages::verify_candidates`])
//!   learning-curve/curve.csv, .md   validation R², parameter spread and DEM time
//!   learning-curve/curve.svg        against the number of training runs
//!                                   (see [`crate::study::analyses::learning_curve`])
//! ```
//!
//! A noise-aware study (`noise_aware` block, [`crate::manifest::NoiseAware`])
//! runs each point with several packing seeds and adds ([`crate::study::pipeline`]):
//!
//! ```text
//!   noise/noise.csv, .md, .json     the centre of the ranges x noise seeds: σ,
//!                                   95 % CI, cost per run, σ² x CPU s ([`crate::study::stages::noise`])
//!   batch/replicates.csv            every replicate run; angles.csv holds the
//!                                   replicate means ([`crate::study::runs::replicated`])
//!   train/gp.json, surrogates.*     the Gaussian process beside the network,
//!                                   validation R², RMSE and 95 % interval
//!                                   coverage of both ([`crate::study::stages::fit_gp`])
//!   train/screening.csv             each parameter's main effect under the GP
//!                                   against one run's σ; searched or fixed
//!   adaptive/acceptance.json        the rule, its seeds and α, before round 1
//!   adaptive/replicates.csv         points the GP chose (`--adaptive`, [`crate::study::stages::adaptive`])
//!   search/points.csv, clusters.*,  kept by the probability of the target band;
//!   search/family.json              the family of consistent parameter sets
//!                                   ([`crate::study::stages::search_probability`])
//!   verify/verification.*, runs.csv every candidate x scene x its pre-registered
//!                                   seeds: mean ± CI, verdict ([`crate::study::stages::verify_candidates`])
//!   outcome.json                    the whole outcome (`calibrate --json`)
//! ```
//!
//! The runs themselves stay where `repose run` puts them (`<store>/<id>/`), so a
//! sample shared by two studies, or run by hand, is simulated once.
//!
//! Sample indices are 0-based (`sample_index` of the experiment's seeds);
//! he2019's Table A1 numbers its rows from 1.
//!
//! # Provenance
//!
//! Beside every output file `F` (except the per-sample manifests, which are
//! content-addressed and listed with their ids in design.csv) lies
//! `F.lineage.json` ([`crate::store::Lineage`]): the stage, the repose version,
//! every stage setting, and every input — the study by id, each input file by
//! its path relative to the store root and the sha256 of its bytes, each run
//! result (`<id>/result.json`) by its sha256. An audit walks these records back
//! from any table to the study and the runs.
//!
//! Every file is written atomically ([`crate::store::write_atomic`]); each stage
//! writes its main table last, so a stage killed midway leaves its previous
//! (or no) table, never a partial one. Outputs are pure functions of the inputs
//! and settings (no times, host names or thread counts), so re-running a stage
//! reproduces them byte for byte. Each stage refuses to start when the stage it
//! reads has not run, naming the command to run first.
//!
//! Randomness comes from ChaCha8 streams of the study's design seed (or a seed
//! given on the command line), one stream per purpose ([`crate::streams::Stream`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::doe::lhs::Placement;
use crate::manifest::NoiseAware;
use crate::manifest::Study;
use crate::search::meanshift::Kernel;
use crate::store::{write_atomic, StoreError};
use crate::study::acceptance::{comparison_alpha, AcceptedTarget, Record};
use crate::study::StudyError;

pub(crate) fn create_dir(path: &Path) -> Result<(), StudyError> {
    std::fs::create_dir_all(path).map_err(|source| {
        StoreError::Io {
            path: path.to_path_buf(),
            source,
        }
        .into()
    })
}

pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), StudyError> {
    write_atomic(path, bytes).map_err(|source| {
        StoreError::Io {
            path: path.to_path_buf(),
            source,
        }
        .into()
    })
}

/// The name serde gives a unit enum variant (e.g. `full_factorial`), as
/// manifests and the command line spell it.
pub(crate) fn serde_name<T: serde::Serialize>(value: T) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(s)) => s,
        other => format!("{other:?}"),
    }
}

/// The calibrated parameters' addresses, in the study's (sorted) order.
pub fn parameter_names(study: &Study) -> Vec<String> {
    study.parameters.keys().cloned().collect()
}

/// The calibrated parameters' ranges (min, max), in the study's order.
pub fn ranges(study: &Study) -> Vec<(f64, f64)> {
    study.parameters.values().map(|r| (r.min, r.max)).collect()
}

/// Maps unit-cube points onto the study's parameter ranges.
pub fn to_physical(study: &Study, unit: &[f64]) -> Vec<f64> {
    study
        .parameters
        .values()
        .zip(unit)
        .map(|(r, u)| r.min + u * (r.max - r.min))
        .collect()
}

/// Maps physical points onto the unit cube of the study's ranges.
pub fn to_unit(study: &Study, physical: &[f64]) -> Vec<f64> {
    study
        .parameters
        .values()
        .zip(physical)
        .map(|(r, x)| (x - r.min) / (r.max - r.min))
        .collect()
}

/// Fewest packing seeds per candidate and scene: a noise-aware study's
/// `verification_seeds`; one (he2019's Table 3) for the classic method.
pub fn verification_seeds(study: &Study) -> u32 {
    study
        .noise_aware
        .as_ref()
        .map_or(1, |n| n.verification_seeds)
}

/// The study's acceptance record for `comparisons` candidates (see the
/// module docs); `noise_sd_deg` is the calibration scene's σ from the noise
/// floor, when measured, from which the calibration scene's seeds are
/// chosen by power within [`verification_seeds`, `max_verification_seeds`].
pub fn acceptance(study: &Study, noise_sd_deg: Option<f64>, comparisons: usize) -> Record {
    let seeds = verification_seeds(study) as usize;
    let cap = study
        .noise_aware
        .as_ref()
        .and_then(|n| n.max_verification_seeds)
        .map_or(seeds, |c| c as usize);
    let alpha = comparison_alpha(comparisons);
    let targets = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .enumerate()
        .map(|(k, t)| {
            let target = AcceptedTarget::new(
                &t.name,
                t.response.as_deref().unwrap_or("headline_angle_deg"),
                t.target_angle_deg,
                t.tolerance_fraction,
                seeds,
            );
            match noise_sd_deg.filter(|s| *s > 0.0) {
                Some(sigma) if k == 0 => target.with_power(sigma, cap, alpha),
                _ => target,
            }
        })
        .collect();
    Record::new(comparisons, targets)
}

/// Candidates a calibration judges, K of the acceptance rule: the search's
/// `candidates` and, when the adaptive stage runs, every round its budget
/// allows (each round's candidate is a chance of a wrong pass).
pub fn comparisons(study: &Study, candidates: usize, adaptive: bool) -> usize {
    candidates + if adaptive { max_rounds(study) } else { 0 }
}

/// Runs one round takes: the candidate's pre-registered seeds in the
/// calibration scene and `replicates` for each other point of the batch.
pub fn round_runs(n: &NoiseAware, candidate_seeds: usize) -> usize {
    candidate_seeds + (n.adaptive.batch as usize).saturating_sub(1) * n.replicates as usize
}

/// The most rounds the adaptive budget allows: the rounds the acceptance
/// rule counts as comparisons before the first one runs. They are counted
/// at the fewest seeds a candidate may run (`verification_seeds`), so the
/// count bounds the rounds whatever the power calculation picks.
pub fn max_rounds(study: &Study) -> usize {
    study.noise_aware.as_ref().map_or(0, |n| {
        n.adaptive.max_runs as usize / round_runs(n, n.verification_seeds as usize).max(1)
    })
}

/// The noise-aware block of `study`, or the error saying the stage needs it.
pub fn noise_aware(study: &Study) -> Result<NoiseAware, StudyError> {
    study.noise_aware.ok_or_else(|| {
        StudyError::Settings(format!(
            "study `{}` has no `noise_aware` block: the noise floor, replicates and the \
             noise-aware search need one (experiments/he2019-quick/study.json has an example)",
            study.name
        ))
    })
}

/// The particle size factor of a study's search and verification: the fine
/// level's when it has one, else 1.
pub fn verified_size(study: &Study) -> f64 {
    study.fidelity().map_or(1.0, |f| f.fine_size)
}

// The index spaces of a study's runs: each stage's `sample_index` range, so
// the packing seeds drawn from an index never repeat between stages.

/// `sample_index` of the noise floor's runs (no design reaches it).
pub const NOISE_INDEX: u64 = 1_000_000_000;

/// `sample_index` of the first adaptive point.
pub const ADAPTIVE_INDEX: u64 = 2_000_000_000;

/// Index distance between the points of two rounds: round k's points are
/// `ADAPTIVE_INDEX + ROUND_STRIDE * k + j`, its candidate `j = 0`.
pub const ROUND_STRIDE: u64 = 1000;

/// `sample_index` of the first verification point: the search's candidate
/// of cluster group g is verified as `VERIFY_INDEX + g`, so its packing seeds
/// in a noise-aware study are drawn apart from the design's (whose indices
/// start at 0), the noise floor's and the adaptive points'.
pub const VERIFY_INDEX: u64 = 3_000_000_000;

/// Options of the search stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchSettings {
    /// Resampled points (he2019: 300).
    pub samples: usize,
    /// Seed of the resampling stream.
    pub seed: u64,
    /// Where a resampled point sits in its stratum.
    pub placement: Placement,
    /// Mean-shift kernel.
    pub kernel: Kernel,
    /// Bandwidth in unit-scaled parameters; `None` to estimate it.
    pub bandwidth: Option<f64>,
    /// Quantile of the bandwidth estimate (used when `bandwidth` is `None`).
    pub quantile: f64,
}

impl SearchSettings {
    /// he2019's 300 points, random placement within strata (Eq. 4), the flat
    /// kernel, bandwidth estimated with quantile 0.3.
    pub fn with_seed(seed: u64) -> SearchSettings {
        SearchSettings {
            samples: 300,
            seed,
            placement: Placement::Random,
            kernel: Kernel::Flat,
            bandwidth: None,
            quantile: 0.3,
        }
    }

    pub(crate) fn check(&self) -> Result<(), StudyError> {
        let fail = |m: String| Err(StudyError::Settings(m));
        if self.samples < 1 {
            return fail("--samples = 0: must be >= 1".to_string());
        }
        if !(self.quantile > 0.0 && self.quantile <= 1.0) {
            return fail(format!("--quantile = {}: must be in (0, 1]", self.quantile));
        }
        if let Some(h) = self.bandwidth.filter(|h| !(h.is_finite() && *h > 0.0)) {
            return fail(format!("--bandwidth = {h}: must be a finite number > 0"));
        }
        Ok(())
    }
}
