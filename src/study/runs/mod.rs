//! Points × replicates × scenes → the executor → a response table.
//!
//! Every stage that simulates (screen, rsm, verify) lists its points in
//! actual units; this module makes one experiment per (point, replicate,
//! scene) with the replicate's packing seed ([`packing_seed`]), hands them
//! all to the one executor, and reads each named response back from the
//! stored results. A run that failed, or a result that lacks a response,
//! leaves that cell empty with the reason in the row's status; the analysis
//! decides what it can do without it.

pub mod replicated;

use std::collections::BTreeMap;
use std::path::Path;

use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::Executor;
use crate::manifest::{ContentId, Experiment};
use crate::report::table::{Cell, CsvWriter};
use crate::scenes::responses::response;
use crate::store::{InputRef, RunDir, RunResult, Store};
use crate::streams::SeedRule;
use crate::study::plan::design_study::{DesignStudy, SeedStage};
use crate::study::StudyError;

/// One point of a stage, in actual units.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Its index in the stage (the experiments' `sample_index`).
    pub index: u64,
    /// The values it sets: (address, actual value).
    pub values: Vec<(String, f64)>,
    /// The values shown in the table's columns (e.g. the factors), in
    /// [`Runs::columns`] order.
    pub shown: Vec<f64>,
}

/// One replicate of one point: its runs and responses.
#[derive(Debug, Clone, PartialEq)]
pub struct Replicate {
    /// Position of the point in the stage's list.
    pub point: usize,
    /// Replicate number (0-based).
    pub replicate: u32,
    /// The packing seed all its scenes used.
    pub packing_seed: u64,
    /// Experiment id per scene name.
    pub ids: BTreeMap<String, ContentId>,
    /// Response values by response name (`None`: failed or not measured).
    pub responses: BTreeMap<String, Option<f64>>,
    /// Why a response is missing (empty when all are there).
    pub problems: Vec<String>,
}

/// What a stage ran and measured.
#[derive(Debug, Clone)]
pub struct Runs {
    /// Column names of [`Point::shown`].
    pub columns: Vec<String>,
    /// The stage's points.
    pub points: Vec<Point>,
    /// Every replicate, point by point.
    pub replicates: Vec<Replicate>,
    /// Response names, in study order.
    pub responses: Vec<String>,
    /// Runs the store already held complete.
    pub cached: usize,
    /// Runs in total.
    pub total: usize,
    /// Input references of every result read (for lineage).
    pub inputs: Vec<InputRef>,
}

impl Runs {
    /// The values of `response` per point: one vector per point, one value
    /// per replicate that measured it.
    pub fn by_point(&self, response: &str) -> Vec<Vec<f64>> {
        let mut out = vec![Vec::new(); self.points.len()];
        for r in &self.replicates {
            if let Some(Some(v)) = r.responses.get(response) {
                out[r.point].push(*v);
            }
        }
        out
    }

    /// Replicates that lack at least one response (a failed or unmeasurable
    /// run; their status in the table says why).
    pub fn incomplete(&self) -> usize {
        self.replicates
            .iter()
            .filter(|r| !r.problems.is_empty())
            .count()
    }

    /// The response table as CSV: point, replicate, the shown columns, the
    /// packing seed, one id column per scene, one column per response, and a
    /// status (`ok` or the problems).
    pub fn csv(&self, scenes: &[String]) -> String {
        let mut header = vec!["point".to_string(), "replicate".to_string()];
        header.extend(self.columns.iter().cloned());
        header.push("packing_seed".into());
        header.extend(scenes.iter().map(|s| format!("{s}_id")));
        header.extend(self.responses.iter().cloned());
        header.push("status".into());
        let mut csv = CsvWriter::new(&header);
        for r in &self.replicates {
            let p = &self.points[r.point];
            let mut cells = vec![
                Cell::Integer(p.index),
                Cell::Integer(u64::from(r.replicate)),
            ];
            cells.extend(p.shown.iter().map(|v| Cell::Number(*v)));
            cells.push(Cell::Integer(r.packing_seed));
            for s in scenes {
                cells.push(Cell::Text(
                    r.ids.get(s).map(|i| i.to_string()).unwrap_or_default(),
                ));
            }
            for name in &self.responses {
                cells.push(
                    r.responses
                        .get(name)
                        .copied()
                        .flatten()
                        .map_or(Cell::Empty, Cell::Number),
                );
            }
            let status = if r.problems.is_empty() {
                "ok".to_string()
            } else {
                r.problems.join("; ")
            };
            cells.push(Cell::Text(status));
            csv.row(&cells);
        }
        csv.finish()
    }
}

/// The scenes the study's responses need, in name order.
pub fn needed_scenes(study: &DesignStudy) -> Vec<String> {
    let mut scenes: Vec<String> = study.responses.values().map(|r| r.scene.clone()).collect();
    scenes.sort();
    scenes.dedup();
    scenes
}

/// Runs `points` × `replicates` × the needed scenes of `stage` through the
/// executor and reads every response back (see the module docs).
#[allow(clippy::too_many_arguments)]
pub fn run_points<E, F>(
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
    stage: SeedStage,
    columns: Vec<String>,
    points: Vec<Point>,
    replicates: u32,
) -> Result<Runs, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let scenes = needed_scenes(study);
    let mut experiments = Vec::new();
    let mut slots = Vec::new();
    for (k, p) in points.iter().enumerate() {
        let values: Vec<(&str, f64)> = p.values.iter().map(|(a, v)| (a.as_str(), *v)).collect();
        for r in 0..replicates {
            let seed = SeedRule::Drawn {
                seed: study.seed,
                stage,
                point: p.index,
            }
            .packing_seed(u64::from(r));
            for s in &scenes {
                let e = study
                    .experiment(s, &values, p.index, seed)
                    .map_err(|errors| StudyError::InvalidPoint {
                        point: p.index,
                        scene: s.clone(),
                        errors,
                    })?;
                slots.push((k, r, seed, s.clone()));
                experiments.push(e);
            }
        }
    }
    let collected = run_collect(&experiments, store, pool, runner, Retry::Failed)?;
    let mut replicates_out: Vec<Replicate> = Vec::new();
    let mut inputs = Vec::new();
    for ((e, outcome), (k, r, seed, scene)) in
        experiments.iter().zip(&collected.outcomes).zip(&slots)
    {
        if replicates_out
            .last()
            .is_none_or(|last| last.point != *k || last.replicate != *r)
        {
            replicates_out.push(Replicate {
                point: *k,
                replicate: *r,
                packing_seed: *seed,
                ids: BTreeMap::new(),
                responses: BTreeMap::new(),
                problems: Vec::new(),
            });
        }
        let rep = replicates_out.last_mut().expect("pushed above");
        let id = e.id();
        rep.ids.insert(scene.clone(), id.clone());
        let result = match outcome {
            RunOutcome::FailedNow(message) => {
                Err(format!("{scene} run {} failed: {message}", id.short(12)))
            }
            RunOutcome::Complete(result) => {
                inputs.push(InputRef::file(
                    format!("{scene}_result"),
                    &store.run_dir(&id).result_path(),
                    Some(store.root()),
                )?);
                Ok(result)
            }
            RunOutcome::Stored(state) => Err(format!(
                "{scene} run {} is {}",
                id.short(12),
                state.status()
            )),
        };
        for (name, rr) in study.responses.iter().filter(|(_, rr)| &rr.scene == scene) {
            let value = match &result {
                Ok(res) => response(res, e.scene.kind(), &rr.response)
                    .map_err(|err| format!("{name}: {err}")),
                Err(m) => Err(m.clone()),
            };
            match value {
                Ok(v) => {
                    rep.responses.insert(name.clone(), Some(v));
                }
                Err(m) => {
                    rep.responses.insert(name.clone(), None);
                    if !rep.problems.contains(&m) {
                        rep.problems.push(m);
                    }
                }
            }
        }
    }
    Ok(Runs {
        columns,
        points,
        replicates: replicates_out,
        responses: study.responses.keys().cloned().collect(),
        cached: collected.cached,
        total: experiments.len(),
        inputs,
    })
}

/// Writes the response table of `runs` to `path` with its lineage.
pub fn write_table(
    dir: &crate::study::dir::StudyDir,
    stage: &str,
    study: &DesignStudy,
    runs: &Runs,
    path: &Path,
) -> Result<(), StudyError> {
    let mut lineage = dir.lineage(stage, serde_json::json!({ "table": "responses" }));
    for input in &runs.inputs {
        lineage = lineage.with_input(input.clone());
    }
    crate::study::dir::write_output(path, runs.csv(&needed_scenes(study)).as_bytes(), &lineage)
}

/// A sentence on replicates without every response, or nothing.
pub fn incomplete_note(incomplete: usize) -> String {
    if incomplete == 0 {
        String::new()
    } else {
        format!(
            " {incomplete} replicate(s) lack a response: their runs failed or could not \
             measure it (the status column of responses.csv says why); the analysis \
             uses the rest."
        )
    }
}

/// The runs' points of a design given in actual units: point `i` is the
/// design's row `i` (its `sample_index`), setting every factor's address.
pub fn design_points(study: &DesignStudy, actual: &[Vec<f64>]) -> Vec<Point> {
    actual
        .iter()
        .enumerate()
        .map(|(i, row)| Point {
            index: i as u64,
            values: study
                .factors
                .values()
                .zip(row)
                .map(|(f, v)| (f.address.clone(), *v))
                .collect(),
            shown: row.clone(),
        })
        .collect()
}
