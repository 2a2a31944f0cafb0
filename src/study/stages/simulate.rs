//! `repose batch STUDY`: runs every sampled experiment that is not complete
//! and writes the simulated-angle table (the equivalent of he2019's Table A1).
//!
//! The runs are handed to the one executor ([`crate::exec`]): a
//! complete run is never repeated, a batch killed midway resumes where it
//! stopped, and a run whose plan is inconsistent or over the limits refuses
//! the stage before anything runs. A failed run is reported at the end and
//! does not stop the others; the next batch tries it again.

use std::path::PathBuf;

use serde_json::json;

use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::Executor;
use crate::manifest::{read_experiment, ContentId, Experiment, Study};
use crate::report::table::{Cell, CsvWriter, Table};
use crate::store::{RunDir, RunResult, RunStatus, Store};
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::parameter_names;
use crate::study::runs::replicated::{replicates_csv, run_replicated, Replicated};
use crate::study::StudyError;

/// One row of design.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignRow {
    /// Sample index.
    pub index: usize,
    /// Parameter values, physical units, in the study's parameter order.
    pub point: Vec<f64>,
    /// The experiment id.
    pub id: ContentId,
}

/// A run that failed in this batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// Sample index.
    pub index: usize,
    /// Experiment id.
    pub id: ContentId,
    /// Why it failed.
    pub message: String,
}

/// What the batch did.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchOutcome {
    /// Samples in the design.
    pub total: usize,
    /// Runs this batch did not simulate: complete before it started (and,
    /// for a noise-aware study, runs that had failed before: they are not
    /// retried there).
    pub cached: usize,
    /// Runs simulated and completed by this batch.
    pub computed: usize,
    /// Runs that failed in this batch.
    pub failures: Vec<Failure>,
    /// angles.csv.
    pub table: PathBuf,
}

impl BatchOutcome {
    /// The report as `repose batch` prints it: the counts, each failure, and
    /// the table's path.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{} samples: {} complete before, {} computed, {} failed\n",
            self.total,
            self.cached,
            self.computed,
            self.failures.len()
        );
        for f in &self.failures {
            out.push_str(&format!(
                "  sample {} ({}) failed: {}\n",
                f.index,
                f.id.short(12),
                f.message
            ));
        }
        if !self.failures.is_empty() {
            out.push_str(
                "  each failed run's error.json holds its whole error (`repose runs show ID`)\n",
            );
        }
        out.push_str(&format!("  angles: {}\n", self.table.display()));
        out
    }
}

/// Reads `sample/design.csv`, checking its columns against the study.
pub fn read_design(dir: &StudyDir, study: &Study) -> Result<Vec<DesignRow>, StudyError> {
    let path = dir.require(dir.design_path(), Stage::Sample)?;
    let table = Table::read(&path)?;
    let names = parameter_names(study);
    let mut expected = vec!["index".to_string()];
    expected.extend(names.iter().cloned());
    expected.push("experiment_id".to_string());
    if table.header != expected {
        return Err(StudyError::Inconsistent {
            path,
            message: format!(
                "columns {} differ from the study's ({}): rerun `repose sample`",
                table.header.join(","),
                expected.join(",")
            ),
        });
    }
    let index = table.numbers(&path, "index")?;
    let columns = names
        .iter()
        .map(|n| table.numbers(&path, n))
        .collect::<Result<Vec<_>, _>>()?;
    let id_column = table.require(&path, "experiment_id")?;
    let mut rows = Vec::with_capacity(table.rows.len());
    for (i, cells) in table.rows.iter().enumerate() {
        let id = ContentId::parse(&cells[id_column]).ok_or_else(|| StudyError::Inconsistent {
            path: path.clone(),
            message: format!(
                "line {}: `{}` is not an experiment id",
                i + 2,
                cells[id_column]
            ),
        })?;
        rows.push(DesignRow {
            index: index[i] as usize,
            point: columns.iter().map(|c| c[i]).collect(),
            id,
        });
    }
    Ok(rows)
}

/// Loads the manifest of a design row and checks that it hashes to the row's id.
fn load_experiment(dir: &StudyDir, row: &DesignRow) -> Result<Experiment, StudyError> {
    let path = dir.experiment_path(row.index);
    let experiment = read_experiment(&path).map_err(|e| StudyError::Inconsistent {
        path: path.clone(),
        message: format!("{e}: rerun `repose sample`"),
    })?;
    if experiment.id() != row.id {
        return Err(StudyError::Inconsistent {
            path,
            message: format!(
                "hashes to {}, but design.csv lists {}: rerun `repose sample`",
                experiment.id(),
                row.id
            ),
        });
    }
    Ok(experiment)
}

/// Runs the batch stage with `runner` (see the module docs).
pub fn batch<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    settings: &Executor,
    runner: F,
) -> Result<BatchOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let design = read_design(dir, study)?;
    if let Some(spec) = study.noise_aware {
        return batch_replicated(
            dir,
            study,
            store,
            settings,
            &runner,
            &design,
            spec.replicates,
        );
    }
    let experiments = design
        .iter()
        .map(|row| load_experiment(dir, row))
        .collect::<Result<Vec<_>, _>>()?;
    let collected = run_collect(&experiments, store, settings, &runner, Retry::Failed)?;
    let failures: Vec<Failure> = design
        .iter()
        .zip(&collected.outcomes)
        .filter_map(|(row, o)| match o {
            RunOutcome::FailedNow(message) => Some(Failure {
                index: row.index,
                id: row.id.clone(),
                message: message.clone(),
            }),
            _ => None,
        })
        .collect();
    let table = write_angles(dir, study, store, &design, &collected.outcomes)?;
    Ok(BatchOutcome {
        total: design.len(),
        cached: collected.cached,
        computed: design.len() - collected.cached - failures.len(),
        failures,
        table,
    })
}

/// Writes angles.csv from the outcome of every design row's run.
fn write_angles(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    design: &[DesignRow],
    outcomes: &[RunOutcome],
) -> Result<PathBuf, StudyError> {
    let names = parameter_names(study);
    let mut header = vec!["index".to_string()];
    header.extend(names.iter().cloned());
    header.extend(["experiment_id", "angle_deg", "status"].map(String::from));
    let mut csv = CsvWriter::new(&header);
    let mut lineage = dir
        .lineage(Stage::Batch, json!({ "angle": "headline_angle_deg" }))
        .with_input(dir.input("design", &dir.design_path())?);
    for (row, outcome) in design.iter().zip(outcomes) {
        let angle = match outcome.result() {
            Some(result) => {
                let result_file = store.run_dir(&row.id).result_path();
                lineage = lineage.with_input(dir.input("result", &result_file)?);
                result.headline_angle_deg
            }
            None => None,
        };
        let mut cells = vec![Cell::Integer(row.index as u64)];
        cells.extend(row.point.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Text(row.id.to_string()));
        cells.push(angle.map_or(Cell::Empty, Cell::Number));
        cells.push(Cell::Text(outcome.status().to_string()));
        csv.row(&cells);
    }
    let path = dir.angles_path();
    crate::study::plan::calibration::create_dir(&dir.stage(Stage::Batch))?;
    write_output(&path, csv.finish().as_bytes(), &lineage)?;
    Ok(path)
}

/// The batch of a noise-aware study: `replicates` packing seeds per design
/// row ([`crate::study::runs::replicated`]); angles.csv gives each row's replicate mean
/// (with the count and spread), so he2019's network trains on means.
fn batch_replicated<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    settings: &Executor,
    runner: &F,
    design: &[DesignRow],
    replicates: u32,
) -> Result<BatchOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let points: Vec<(u64, Vec<f64>)> = design
        .iter()
        .map(|r| (r.index as u64, r.point.clone()))
        .collect();
    let total = design.len() * replicates as usize;
    let (runs, tally) = run_replicated(
        study,
        &study.calibration,
        &points,
        replicates,
        store,
        settings,
        runner,
        false,
    )?;
    for (row, p) in design.iter().zip(&runs) {
        if p.runs[0].id != row.id {
            return Err(StudyError::Inconsistent {
                path: dir.design_path(),
                message: format!(
                    "sample {}: replicate 0 hashes to {}, the design lists {}: rerun `repose sample`",
                    row.index, p.runs[0].id, row.id
                ),
            });
        }
    }
    let failures: Vec<Failure> = runs
        .iter()
        .flat_map(|p| {
            p.runs.iter().filter_map(move |r| {
                r.value.as_ref().err().map(|m| Failure {
                    index: p.index as usize,
                    id: r.id.clone(),
                    message: m.clone(),
                })
            })
        })
        .collect();
    let table = write_replicated(dir, study, store, design, &runs, replicates)?;
    Ok(BatchOutcome {
        total,
        cached: tally.not_simulated,
        computed: total - tally.not_simulated - tally.failed_now,
        failures,
        table,
    })
}

/// Writes `replicates.csv` (every replicate's run) and `angles.csv` (each
/// design row's replicate mean, count and spread) with their lineage (the
/// response, the replicates, the design and every run's result); returns
/// the path of `angles.csv`.
fn write_replicated(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    design: &[DesignRow],
    runs: &[Replicated],
    replicates: u32,
) -> Result<PathBuf, StudyError> {
    let mut lineage = dir
        .lineage(
            Stage::Batch,
            json!({ "angle": study.calibration.response.clone()
                        .unwrap_or_else(|| "headline_angle_deg".into()),
                    "replicates": replicates, "value": "mean of the measured replicates" }),
        )
        .with_input(dir.input("design", &dir.design_path())?);
    for p in runs {
        for r in &p.runs {
            let file = store.run_dir(&r.id).result_path();
            if file.is_file() {
                lineage = lineage.with_input(dir.input("result", &file)?);
            }
        }
    }
    crate::study::plan::calibration::create_dir(&dir.stage(Stage::Batch))?;
    write_output(
        &dir.replicates_path(),
        replicates_csv(study, &[(&study.calibration.name, runs)]).as_bytes(),
        &lineage,
    )?;
    let table = dir.angles_path();
    write_output(
        &table,
        replicated_angles_csv(study, design, runs, replicates).as_bytes(),
        &lineage,
    )?;
    Ok(table)
}

/// `angles.csv` of a replicated batch: per design row its replicates' mean
/// angle (degrees), status (failed when no replicate measured), replicate
/// and measured counts and the angles' sd (degrees).
fn replicated_angles_csv(
    study: &Study,
    design: &[DesignRow],
    runs: &[Replicated],
    replicates: u32,
) -> String {
    let names = parameter_names(study);
    let mut header = vec!["index".to_string()];
    header.extend(names.iter().cloned());
    header.extend(
        [
            "experiment_id",
            "angle_deg",
            "status",
            "replicates",
            "measured",
            "angle_sd_deg",
        ]
        .map(String::from),
    );
    let mut csv = CsvWriter::new(&header);
    for (row, p) in design.iter().zip(runs) {
        let values = p.values();
        let mut cells = vec![Cell::Integer(row.index as u64)];
        cells.extend(row.point.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Text(row.id.to_string()));
        cells.push(p.mean().map_or(Cell::Empty, Cell::Number));
        let status = if values.is_empty() {
            RunStatus::Failed
        } else {
            RunStatus::Complete
        };
        cells.push(Cell::Text(status.to_string()));
        cells.push(Cell::Integer(u64::from(replicates)));
        cells.push(Cell::Integer(values.len() as u64));
        cells.push(p.summary().map_or(Cell::Empty, |s| Cell::Number(s.std)));
        csv.row(&cells);
    }
    csv.finish()
}
