//! `repose calibrate --adaptive`: after the initial design, batches of
//! points chosen by the GP surrogate until a simulated point's replicate
//! mean is inside the target band or the run budget is spent
//! (`noise_aware.adaptive` of the study).
//!
//! Each batch: the GP is refitted to every point simulated so far
//! ([`super::gp_train::fit_model`]); a pool of [`POOL`] Latin-hypercube
//! points (the adaptive stream, one sub-stream per batch) is scored by the
//! probability that its angle lies in the band; the batch takes the best
//! point, then the best of those at least [`MIN_SEPARATION`] (unit cube)
//! from every point taken, and so on, so one batch does not spend its runs
//! on one spot. Each point runs `replicates` seeds; the points are indexed
//! from [`ADAPTIVE_INDEX`] on and written to `adaptive/replicates.csv`,
//! which the GP's training then includes. A killed stage resumes: the table
//! is rewritten after every batch and the runs are cached.

use serde::Serialize;
use serde_json::json;

use super::gp_train::{adaptive_path, fit_model};
use super::replicates::{read_replicates_csv, replicates_csv, run_replicated, Replicated};
use super::{
    parameter_names, rng, to_physical, write_output, CalibrateError, Stage, Stream, StudyDir,
};
use crate::doe::lhs::{latin_hypercube, Placement};
use crate::exec::Executor;
use crate::manifest::{Experiment, Study};
use crate::stats::gp::probability_in_band;
use crate::store::{RunDir, RunResult, Store};

/// `sample_index` of the first adaptive point.
pub const ADAPTIVE_INDEX: u64 = 2_000_000_000;
/// Points scored per batch.
pub const POOL: usize = 2000;
/// Smallest distance between two points of one batch (unit cube).
pub const MIN_SEPARATION: f64 = 0.15;

/// Why the adaptive stage stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// A simulated point's replicate mean is inside the band.
    Reached,
    /// The next batch would exceed the run budget.
    Budget,
}

/// What the adaptive stage did.
#[derive(Debug, Clone, Serialize)]
pub struct AdaptiveOutcome {
    /// Batches run (by this call and before).
    pub batches: usize,
    /// Runs the adaptive points took.
    pub runs: usize,
    /// Why it stopped.
    pub stop: Stop,
    /// The simulated point whose mean is in the band, if any: (source,
    /// sample index, mean).
    pub hit: Option<(String, u64, f64)>,
}

/// Runs the adaptive batches (see the module docs), seeded by `seed`.
pub fn adaptive<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    seed: u64,
    runner: F,
    progress: &mut dyn FnMut(&str),
) -> Result<AdaptiveOutcome, CalibrateError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let spec = super::noise::noise_aware(study)?;
    let path = adaptive_path(dir);
    let mut points: Vec<Replicated> = if path.is_file() {
        read_replicates_csv(&path, study)?
    } else {
        Vec::new()
    };
    let per_point = spec.replicates as usize;
    let batch = spec.adaptive.batch as usize;
    let budget = spec.adaptive.max_runs as usize;
    let (lo, hi) = study.calibration.band_deg();
    let names = parameter_names(study);
    loop {
        let model = fit_model(dir, study, seed)?;
        let batches = points.len().div_ceil(batch.max(1));
        let runs: usize = points.iter().map(|p| p.runs.len()).sum();
        let hit = (0..model.data.y.len())
            .find(|&i| model.data.y[i] >= lo && model.data.y[i] <= hi)
            .map(|i| {
                (
                    model.data.source[i].clone(),
                    model.data.index[i],
                    model.data.y[i],
                )
            });
        if hit.is_some() {
            return Ok(AdaptiveOutcome {
                batches,
                runs,
                stop: Stop::Reached,
                hit,
            });
        }
        if runs + batch * per_point > budget {
            return Ok(AdaptiveOutcome {
                batches,
                runs,
                stop: Stop::Budget,
                hit: None,
            });
        }
        let gp = model.process()?;
        let pool_points = latin_hypercube(
            POOL,
            names.len(),
            Placement::Random,
            &mut rng(seed, Stream::Adaptive, batches as u64),
        );
        let mut scored: Vec<(f64, usize)> = pool_points
            .iter()
            .enumerate()
            .map(|(i, u)| {
                let p = gp.predict(u);
                (probability_in_band(p.mean, p.sd, lo, hi), i)
            })
            .collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut chosen: Vec<&Vec<f64>> = Vec::new();
        for (_, i) in &scored {
            let u = &pool_points[*i];
            let far = chosen.iter().all(|c| {
                c.iter()
                    .zip(u)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
                    .sqrt()
                    >= MIN_SEPARATION
            });
            if far {
                chosen.push(u);
                if chosen.len() == batch {
                    break;
                }
            }
        }
        let first = ADAPTIVE_INDEX + points.len() as u64;
        let new: Vec<(u64, Vec<f64>)> = chosen
            .iter()
            .enumerate()
            .map(|(k, u)| (first + k as u64, to_physical(study, u)))
            .collect();
        progress(&format!(
            "adaptive batch {}: {} point(s) x {} seed(s), best P(in band) {:.2}",
            batches + 1,
            new.len(),
            spec.replicates,
            scored.first().map_or(0.0, |s| s.0)
        ));
        let (ran, _) = run_replicated(
            study,
            &study.calibration,
            &new,
            spec.replicates,
            store,
            pool,
            &runner,
            false,
        )?;
        points.extend(ran);
        dir.prepare(study, Stage::Adaptive)?;
        let mut lineage = dir.lineage(
            Stage::Adaptive,
            json!({ "batch": batch, "max_runs": budget, "pool": POOL,
                    "min_separation": MIN_SEPARATION, "seed": seed,
                    "score": "probability of the target band under the GP" }),
        );
        for r in points.iter().flat_map(|p| &p.runs) {
            let file = store.run_dir(&r.id).result_path();
            if file.is_file() {
                lineage = lineage.with_input(dir.input("result", &file)?);
            }
        }
        write_output(&path, replicates_csv(study, &points).as_bytes(), &lineage)?;
    }
}
