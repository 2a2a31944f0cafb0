//! `repose calibrate --adaptive`: after the initial design, rounds of points
//! chosen by the GP surrogate until one of its candidates passes the
//! acceptance rule in the calibration scene, or the run budget is spent
//! (`noise_aware.adaptive` of the study).
//!
//! Each round: the GP is refitted to every point simulated so far (the fit
//! stage's model, supplied by the driver as `refit`); a pool of [`POOL`] Latin-hypercube
//! points (the adaptive stream, one sub-stream per round) is scored by the
//! probability that its angle lies in the band. The best point is the
//! round's **candidate** and runs the calibration scene's pre-registered
//! seeds, as verification would; the next best at least [`MIN_SEPARATION`] (unit cube)
//! from every point taken, up to `batch` points in all, explore with
//! `replicates` seeds each, so one round does not spend its runs on one
//! spot. The stage stops when the acceptance rule
//! ([`crate::study::acceptance`], verification's rule) passes a candidate
//! in the calibration scene, or when the next round would pass `max_runs`.
//!
//! Each round tries a new candidate until one passes: a sequential search
//! whose every round is a chance of a wrong pass. The stage therefore writes
//! its acceptance record (`adaptive/acceptance.json`, the rule, the seeds
//! and α) before its first round, with α = 0.05 divided by every round the
//! budget allows plus the search candidates verification will judge
//! ([`crate::study::plan::calibration::max_rounds`], [`crate::study::plan::calibration::comparisons`]; Bonferroni), the same
//! record verification then writes: stopping at the first pass keeps the
//! chance of any wrong pass ≤ 0.05.
//!
//! A design point or the noise floor's centre whose mean happens to fall in
//! the band does not end the stage: a 2-seed mean is one draw of a noisy
//! pile and lands in the band from well outside it often enough to matter
//! (the measured chance: docs/performance.md, "src/study/stages/adaptive.rs"), so
//! only a point run with the verification's seeds counts, and a failed
//! candidate's seeds become data for the next fit. Round k's points are indexed from [`ADAPTIVE_INDEX`] +
//! [`ROUND_STRIDE`] × k, the candidate first; they are written to
//! `adaptive/replicates.csv`, which the GP's training then includes. A killed
//! stage resumes: the table is rewritten after every round and the runs are
//! cached.

use serde::Serialize;
use serde_json::json;

use crate::doe::lhs::{latin_hypercube, Placement};
use crate::exec::Executor;
use crate::manifest::{Experiment, NoiseAware, Study};
use crate::search::acquisition::probability_in_band;
use crate::stats::gp::GaussianProcess;
use crate::store::{RunDir, RunResult, Store};
use crate::streams::{rng, Stream};
use crate::study::acceptance::{Record, RULE};
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::to_physical;
use crate::study::plan::calibration::{acceptance, comparisons, parameter_names, round_runs};
use crate::study::plan::calibration::{ADAPTIVE_INDEX, ROUND_STRIDE};
use crate::study::records::{passing, read_noise, Hit};
use crate::study::runs::replicated::{
    read_replicates_csv, replicates_csv, run_replicated, Replicated,
};
use crate::study::StudyError;

/// Points scored per round.
pub const POOL: usize = 2000;
/// Smallest distance between two points of one round (unit cube).
pub const MIN_SEPARATION: f64 = 0.15;

/// Why the adaptive stage stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// A round's candidate passed the acceptance rule in the band.
    Reached,
    /// The next round would exceed the run budget.
    Budget,
}

/// What the adaptive stage did.
#[derive(Debug, Clone, Serialize)]
pub struct AdaptiveOutcome {
    /// Rounds run (by this call and before).
    pub rounds: usize,
    /// Runs the adaptive points took.
    pub runs: usize,
    /// Why it stopped.
    pub stop: Stop,
    /// The candidate that passed, if any.
    pub hit: Option<Hit>,
}

/// Runs the adaptive rounds (see the module docs), seeded by `seed`, for a
/// calibration that will verify `candidates` search candidates beside them;
/// `refit` fits the GP to every row simulated so far (the fit stage's model,
/// which the driver supplies), before each round.
#[allow(clippy::too_many_arguments)]
pub fn adaptive<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    seed: u64,
    candidates: usize,
    refit: &dyn Fn() -> Result<GaussianProcess, StudyError>,
    runner: F,
    progress: &mut dyn FnMut(&str),
) -> Result<AdaptiveOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let spec = crate::study::plan::calibration::noise_aware(study)?;
    let path = dir.adaptive_path();
    let mut points: Vec<Replicated> = if path.is_file() {
        read_replicates_csv(&path, study)?
    } else {
        Vec::new()
    };
    let noise_sd = read_noise(dir).ok().and_then(|f| f.sd_deg);
    let rule = acceptance(study, noise_sd, comparisons(study, candidates, true));
    // The rule goes on record before the first round.
    dir.prepare_stage(study, Stage::Adaptive)?;
    write_output(
        &dir.stage(Stage::Adaptive).join("acceptance.json"),
        &json_bytes(&rule),
        &dir.lineage(Stage::Adaptive, json!({ "record": "acceptance rule" })),
    )?;
    let seeds = rule.targets[0].seeds;
    let round_runs = round_runs(&spec, seeds);
    loop {
        let budget = spec.adaptive.max_runs as usize;
        if let Some(outcome) = stopped(&points, &rule, round_runs, budget) {
            return Ok(outcome);
        }
        let rounds = rounds_run(&points);
        let gp = refit()?;
        let (mut new, best) = next_points(study, &gp, seed, rounds, spec.adaptive.batch as usize);
        progress(&format!(
            "adaptive round {}: candidate x {seeds} seeds (P(in band) {:.2}), {} more point(s) x {} seeds",
            rounds + 1,
            best,
            new.len().saturating_sub(1),
            spec.replicates as usize,
        ));
        let explorers = new.split_off(1.min(new.len()));
        for (group, replicates) in [(&new, seeds as u32), (&explorers, spec.replicates)] {
            let (r, _) = run_replicated(
                study,
                &study.calibration,
                group,
                replicates,
                store,
                pool,
                &runner,
                false,
            )?;
            points.extend(r);
        }
        write_points(dir, study, store, (&spec, &rule, seed), &points)?;
    }
}

/// Rounds run so far: one past the highest round among `points`' indices.
fn rounds_run(points: &[Replicated]) -> usize {
    points
        .iter()
        .map(|p| (p.index - ADAPTIVE_INDEX) / ROUND_STRIDE + 1)
        .max()
        .unwrap_or(0) as usize
}

/// The outcome when the stage stops before another round: a candidate of
/// `points` passed `rule`, or the next round's `round_runs` would take the
/// runs past `budget`; `None` while it goes on.
fn stopped(
    points: &[Replicated],
    rule: &Record,
    round_runs: usize,
    budget: usize,
) -> Option<AdaptiveOutcome> {
    let runs: usize = points.iter().map(|p| p.runs.len()).sum();
    let hit = passing(points, rule);
    let stop = if hit.is_some() {
        Stop::Reached
    } else if runs + round_runs > budget {
        Stop::Budget
    } else {
        return None;
    };
    Some(AdaptiveOutcome {
        rounds: rounds_run(points),
        runs,
        stop,
        hit,
    })
}

/// Round `round`'s points, physical units, indexed from its first index:
/// the [`POOL`] points of its sub-stream of the adaptive stream scored by
/// `gp`'s probability of the band, the best first, then the next best at
/// least [`MIN_SEPARATION`] from every point taken, up to `batch` in all;
/// and the best point's probability (0 with an empty pool).
fn next_points(
    study: &Study,
    gp: &GaussianProcess,
    seed: u64,
    round: usize,
    batch: usize,
) -> (Vec<(u64, Vec<f64>)>, f64) {
    let (lo, hi) = study.calibration.band_deg();
    let pool_points = latin_hypercube(
        POOL,
        parameter_names(study).len(),
        Placement::Random,
        &mut rng(seed, Stream::Adaptive, round as u64),
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
    let first = ADAPTIVE_INDEX + ROUND_STRIDE * round as u64;
    let new = chosen
        .iter()
        .enumerate()
        .map(|(k, u)| (first + k as u64, to_physical(study, u)))
        .collect();
    (new, scored.first().map_or(0.0, |s| s.0))
}

/// Rewrites `adaptive/replicates.csv` with every adaptive point so far,
/// its lineage the stage's settings (the noise-aware block, the acceptance
/// `rule` and the adaptive `seed`) and every run's result.
fn write_points(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    (spec, rule, seed): (&NoiseAware, &Record, u64),
    points: &[Replicated],
) -> Result<(), StudyError> {
    let mut lineage = dir.lineage(
        Stage::Adaptive,
        json!({ "batch": spec.adaptive.batch, "max_runs": spec.adaptive.max_runs as usize, "pool": POOL,
                "min_separation": MIN_SEPARATION, "seed": seed,
                "candidate_seeds": rule.targets[0].seeds, "explore_seeds": spec.replicates as usize,
                "rule": RULE, "alpha": rule.alpha, "comparisons": rule.comparisons,
                "score": "probability of the target band under the GP" }),
    );
    for r in points.iter().flat_map(|p| &p.runs) {
        let file = store.run_dir(&r.id).result_path();
        if file.is_file() {
            lineage = lineage.with_input(dir.input("result", &file)?);
        }
    }
    write_output(
        &dir.adaptive_path(),
        replicates_csv(study, &[(&study.calibration.name, points)]).as_bytes(),
        &lineage,
    )
}
