//! `repose tradeoff`: what accuracy costs in time, measured on the user's own
//! scene.
//!
//! [`plan`] turns a base experiment and fidelity knobs into a reference point
//! and one-knob-away points, each with replicates (packing seeds); [`run`]
//! runs them all through the store (cached, resumable, parallel over runs) and
//! [`summarise`] turns the results into rows: angle mean ± 95 % CI, error vs
//! the reference with its Welch CI, wall time, particle-steps, speed-up,
//! health, and whether the point is on the Pareto front of (|error|, wall
//! time). [`report`] writes them as CSV, Markdown and SVG.

pub mod pareto;
pub mod plan;
pub mod report;

use std::path::{Path, PathBuf};

use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::{ExecError, Executor};
use crate::manifest::{ContentId, Experiment};
use crate::scenes::run_logged;
use crate::stats::summary::{difference_ci, mean_ci, MeanCi};
use crate::store::{InputRef, Lineage, RunResult, RunState, RunStatus, Store, StoreError};
use crate::study::StudyError;
use pareto::pareto_front;
use plan::Point;

/// What [`sweep`] did.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The table rows, the reference first.
    pub rows: Vec<Row>,
    /// Where tradeoff.csv, .md and .svg were written.
    pub dir: PathBuf,
    /// The Markdown table.
    pub markdown: String,
}

/// Where a sweep around `base` writes by default:
/// `<store>/tradeoff/<first 12 hex of the base id>`.
pub fn default_dir(store: &Store, base: &Experiment) -> PathBuf {
    store.root().join("tradeoff").join(base.id().short(12))
}

/// Says on stderr what a sweep of `points` (each `unit`) will run and how
/// much of it the store already holds: `<what>: 3 points x 5 replicates =
/// 15 runs (4 already complete) on 2 thread(s)`.
pub(crate) fn announce(what: &str, unit: &str, store: &Store, points: &[Point], pool: &Executor) {
    let total: usize = points.iter().map(|p| p.replicates.len()).sum();
    let done = points
        .iter()
        .flat_map(|p| &p.replicates)
        .filter(|e| store.status(&e.id()) == RunStatus::Complete)
        .count();
    let replicates = points.first().map_or(0, |p| p.replicates.len());
    eprintln!(
        "{what}: {} {unit} x {replicates} replicates = {total} runs ({done} already complete) on \
         {} thread(s)",
        points.len(),
        pool.jobs
    );
}

/// `repose tradeoff`: runs the planned `points` (see [`run`]), summarises
/// them and writes tradeoff.csv / .md / .svg with one lineage record beside
/// each (the knobs, the replicates, the base manifest file and every run id)
/// into `out_dir` (default `<store>/tradeoff/<first 12 hex of the base id>`).
pub fn sweep(
    store: &Store,
    base: &Experiment,
    manifest: &Path,
    points: &[Point],
    knobs: &[plan::Knob],
    pool: &Executor,
    out_dir: Option<PathBuf>,
) -> Result<Sweep, StudyError> {
    announce("tradeoff", "points", store, points, pool);
    let replicates = points.first().map_or(0, |p| p.replicates.len());
    let outcomes = run(store, points, pool)?;
    let rows = summarise(points, &outcomes);
    let dir = out_dir.unwrap_or_else(|| default_dir(store, base));
    std::fs::create_dir_all(&dir).map_err(StoreError::io(&dir))?;
    let title = format!(
        "What accuracy costs: {} ({})",
        base.scene.kind(),
        manifest.display()
    );
    let markdown = report::markdown(&rows, &title);
    let outputs = [
        (dir.join("tradeoff.csv"), report::csv(&rows)),
        (dir.join("tradeoff.md"), markdown.clone()),
        (dir.join("tradeoff.svg"), report::svg(&rows, &title)),
    ];
    let mut lineage = Lineage::new(
        "tradeoff",
        serde_json::json!({
            "knobs": knobs.iter().map(|k| (k.name, k.values.clone())).collect::<Vec<_>>(),
            "replicates": replicates,
        }),
    )
    .with_input(InputRef::file(
        "base_manifest",
        manifest,
        Some(store.root()),
    )?);
    for row in &rows {
        for id in &row.ids {
            lineage = lineage.with_input(InputRef::id(row.label.clone(), id));
        }
    }
    for (path, text) in &outputs {
        crate::study::dir::write_output(path, text.as_bytes(), &lineage)?;
    }
    Ok(Sweep {
        rows,
        dir,
        markdown,
    })
}

/// The outcome of one replicate.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The experiment id.
    pub id: ContentId,
    /// Its result, when the run stayed healthy.
    pub result: Option<RunResult>,
    /// Why it failed, otherwise.
    pub failure: Option<String>,
    /// Wall time of the run when it was computed (timing.json), s.
    pub wall_time_s: Option<f64>,
}

/// Runs every replicate of every point through the one executor
/// ([`crate::exec`]: cached by id, already complete runs are not
/// repeated, each run on one thread of its own, `pool.jobs` at once) and
/// reads the outcomes back from the store, in plan order. Refused before
/// anything runs when a replicate's plan is inconsistent or over the pool's
/// limits.
pub fn run(
    store: &Store,
    points: &[Point],
    pool: &Executor,
) -> Result<Vec<Vec<Outcome>>, ExecError> {
    let all: Vec<Experiment> = points
        .iter()
        .flat_map(|p| p.replicates.iter().cloned())
        .collect();
    let collected = run_collect(&all, store, pool, &run_logged, Retry::Failed)?;
    let mut flat: Vec<Outcome> = all
        .iter()
        .zip(collected.outcomes)
        .map(|(e, o)| outcome(store, e, o))
        .collect();
    let mut out = Vec::new();
    for p in points {
        let rest = flat.split_off(p.replicates.len());
        out.push(std::mem::replace(&mut flat, rest));
    }
    Ok(out)
}

/// The row outcome of `e` from its run's outcome `o`.
fn outcome(store: &Store, e: &Experiment, o: RunOutcome) -> Outcome {
    let id = e.id();
    let loaded = match o {
        RunOutcome::Complete(result) => Ok(*result),
        RunOutcome::FailedNow(message) => Err(message),
        RunOutcome::Stored(RunState::Damaged(problem)) => {
            Err(crate::errors::chain(&StoreError::Damaged {
                id: id.clone(),
                problem,
            }))
        }
        RunOutcome::Stored(_) => Err("the run is not complete".to_string()),
    };
    let timing = store.timing(&id);
    match loaded {
        Ok(result) => Outcome {
            id,
            result: Some(result),
            failure: None,
            wall_time_s: timing.map(|t| t.wall_time_s),
        },
        Err(message) => Outcome {
            id,
            result: None,
            failure: Some(message),
            wall_time_s: None,
        },
    }
}

/// One row of the tradeoff table.
#[derive(Debug, Clone)]
pub struct Row {
    /// `reference` or `knob=value`.
    pub label: String,
    /// The knob (or `reference`).
    pub knob: &'static str,
    /// The knob's value.
    pub value: Option<f64>,
    /// Replicates run.
    pub replicates: usize,
    /// Replicates that stayed healthy and gave an angle.
    pub healthy: usize,
    /// Headline angle over healthy replicates, degrees.
    pub angle: Option<MeanCi>,
    /// Angle − reference angle and its 95 % CI half-width, degrees.
    pub error_deg: Option<(f64, f64)>,
    /// Mean wall time per run, s.
    pub wall_time_s: Option<f64>,
    /// Time step the runs used (the engine takes min(fraction · T_R, t_c / 20),
    /// so a step-fraction knob stops mattering once the contact time binds), s.
    pub dt_s: Option<f64>,
    /// Mean particle-steps per run (particles × steps as the scene reports).
    pub particle_steps: Option<f64>,
    /// Reference wall time / this wall time.
    pub speed_up: Option<f64>,
    /// On the Pareto front of (|error|, wall time).
    pub pareto: bool,
    /// Ids of the replicates, in seed order.
    pub ids: Vec<ContentId>,
    /// The first failure, if any replicate failed.
    pub failure: Option<String>,
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = values.collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The table: one row per point, the reference first.
pub fn summarise(points: &[Point], outcomes: &[Vec<Outcome>]) -> Vec<Row> {
    let mut rows: Vec<Row> = points
        .iter()
        .zip(outcomes)
        .map(|(p, o)| {
            let angles: Vec<f64> = o
                .iter()
                .filter_map(|x| x.result.as_ref()?.headline_angle_deg)
                .collect();
            let particle_steps = mean(o.iter().filter_map(|x| {
                let m = &x.result.as_ref()?.measurements;
                Some(m.get("particles")? * m.get("steps")?)
            }));
            let dt_s = mean(
                o.iter()
                    .filter_map(|x| x.result.as_ref()?.measurements.get("dt_s").copied()),
            );
            Row {
                label: p.label(),
                dt_s,
                knob: p.knob,
                value: p.value,
                replicates: o.len(),
                healthy: angles.len(),
                angle: mean_ci(&angles),
                error_deg: None,
                wall_time_s: mean(o.iter().filter_map(|x| x.wall_time_s)),
                particle_steps,
                speed_up: None,
                pareto: false,
                ids: o.iter().map(|x| x.id.clone()).collect(),
                failure: o.iter().find_map(|x| x.failure.clone()),
            }
        })
        .collect();
    let reference = rows.first().and_then(|r| r.angle.zip(r.wall_time_s));
    if let Some((ref_angle, ref_time)) = reference {
        for row in &mut rows {
            row.error_deg = row.angle.map(|a| difference_ci(&a, &ref_angle));
            row.speed_up = row.wall_time_s.map(|t| ref_time / t);
        }
    }
    let candidates: Vec<(usize, (f64, f64))> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| Some((i, (r.error_deg?.0.abs(), r.wall_time_s?))))
        .collect();
    let coords: Vec<(f64, f64)> = candidates.iter().map(|c| c.1).collect();
    for k in pareto_front(&coords) {
        rows[candidates[k].0].pareto = true;
    }
    rows
}
