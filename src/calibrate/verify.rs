//! `repose verify STUDY`: he2019 §3.6 — every candidate parameter set (a
//! cluster centre of the search) is simulated again, in the calibration scene
//! (so the surrogate's prediction meets the DEM it stands for) and in each of
//! the study's verification scenes (he2019: baffle lift and rotating drum);
//! the simulated angles are compared with the measured ones: the equivalent of
//! he2019's Table 3 (simulated, measured, relative error, pass/fail against
//! the scene's tolerance).
//!
//! Verification experiments are ordinary experiments of the study
//! ([`Study::experiment`]) with `sample_index` = the cluster's group number,
//! cached by id in the store like every run; a killed verify resumes, and a
//! failed run is reported in its row without stopping the others.

use std::fmt::Write as _;
use std::path::PathBuf;

use serde_json::json;

use super::batch::{run_incomplete, BatchSettings, Ran};
use super::table::{Cell, CsvWriter, Table};
use super::{parameter_names, write_output, CalibrateError, Stage, StudyDir};
use crate::manifest::{ContentId, Experiment, Study};
use crate::store::{RunDir, RunResult, Store};

/// One row of the Table 3 equivalent.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyRow {
    /// Cluster group number (1 = largest).
    pub group: usize,
    /// Scene name (`funnel`, `baffle`, `drum`, ...).
    pub scene: String,
    /// The experiment.
    pub id: ContentId,
    /// Simulated angle, degrees (none if the run failed).
    pub simulated_deg: Option<f64>,
    /// Measured (target) angle, degrees.
    pub measured_deg: f64,
    /// |simulated − measured| / measured.
    pub relative_error: Option<f64>,
    /// The scene's accepted relative error.
    pub tolerance: f64,
    /// Why the run failed, if it did.
    pub failure: Option<String>,
}

impl VerifyRow {
    /// Whether the simulated angle is within tolerance.
    pub fn passes(&self) -> bool {
        self.relative_error.is_some_and(|e| e <= self.tolerance)
    }
}

/// What verify did.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyOutcome {
    /// One row per candidate and scene, candidates in group order.
    pub rows: Vec<VerifyRow>,
    /// The Markdown table (also in verification.md).
    pub markdown: String,
    /// verification.csv.
    pub table: PathBuf,
}

/// `search/clusters.csv`.
fn clusters_path(dir: &StudyDir) -> PathBuf {
    dir.stage(Stage::Search).join("clusters.csv")
}

/// `verify/verification.csv`.
pub fn verification_path(dir: &StudyDir) -> PathBuf {
    dir.stage(Stage::Verify).join("verification.csv")
}

/// Runs the verify stage on at most `candidates` clusters (largest first).
pub fn verify<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    settings: &BatchSettings,
    candidates: usize,
    runner: F,
) -> Result<VerifyOutcome, CalibrateError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    if candidates == 0 {
        return Err(CalibrateError::Settings(
            "--candidates = 0: must be >= 1".into(),
        ));
    }
    let clusters_file = dir.require(clusters_path(dir), Stage::Search)?;
    let table = Table::read(&clusters_file)?;
    let names = parameter_names(study);
    let groups = table.numbers(&clusters_file, "group")?;
    let columns = names
        .iter()
        .map(|n| table.numbers(&clusters_file, n))
        .collect::<Result<Vec<_>, _>>()?;
    let scenes: Vec<_> = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .collect();
    let mut planned = Vec::new();
    for (row, group) in groups.iter().enumerate().take(candidates) {
        let point = names
            .iter()
            .zip(&columns)
            .map(|(n, c)| (n.clone(), c[row]))
            .collect();
        for target in &scenes {
            let experiment = study
                .experiment(&target.scene, &point, *group as u64)
                .map_err(|errors| CalibrateError::InvalidPoint {
                    index: *group as usize,
                    errors,
                })?;
            planned.push((*group as usize, *target, experiment));
        }
    }
    let experiments: Vec<Experiment> = planned.iter().map(|p| p.2.clone()).collect();
    let Ran { failures, .. } = run_incomplete(&experiments, store, settings, &runner)?;

    let mut lineage = dir
        .lineage(Stage::Verify, json!({ "candidates": candidates }))
        .with_input(dir.input("clusters", &clusters_file)?);
    let mut rows = Vec::new();
    for (i, (group, target, experiment)) in planned.iter().enumerate() {
        let id = experiment.id();
        let result = store.load_result(&id)?;
        if result.is_some() {
            lineage = lineage.with_input(dir.input("result", &store.run_dir(&id).result_path())?);
        }
        let simulated = result.and_then(|r| r.headline_angle_deg);
        let failure = failures
            .iter()
            .find(|f| f.0 == i)
            .map(|f| f.1.clone())
            .or_else(|| simulated.is_none().then(|| "no angle".to_string()));
        rows.push(VerifyRow {
            group: *group,
            scene: target.name.clone(),
            id,
            simulated_deg: simulated,
            measured_deg: target.target_angle_deg,
            relative_error: simulated
                .map(|s| (s - target.target_angle_deg).abs() / target.target_angle_deg),
            tolerance: target.tolerance_fraction,
            failure,
        });
    }
    let mut csv = CsvWriter::new(&[
        "group",
        "scene",
        "experiment_id",
        "simulated_deg",
        "measured_deg",
        "relative_error",
        "tolerance",
        "pass",
        "failure",
    ]);
    for r in &rows {
        csv.row(&[
            Cell::Integer(r.group as u64),
            Cell::Text(r.scene.clone()),
            Cell::Text(r.id.to_string()),
            r.simulated_deg.map_or(Cell::Empty, Cell::Number),
            Cell::Number(r.measured_deg),
            r.relative_error.map_or(Cell::Empty, Cell::Number),
            Cell::Number(r.tolerance),
            Cell::Text(if r.passes() { "yes" } else { "no" }.into()),
            Cell::Text(r.failure.clone().unwrap_or_default()),
        ]);
    }
    let markdown = markdown(&rows);
    super::create_dir(&dir.stage(Stage::Verify))?;
    let md_path = dir.stage(Stage::Verify).join("verification.md");
    write_output(&md_path, markdown.as_bytes(), &lineage)?;
    let path = verification_path(dir);
    write_output(&path, csv.finish().as_bytes(), &lineage)?;
    Ok(VerifyOutcome {
        rows,
        markdown,
        table: path,
    })
}

fn markdown(rows: &[VerifyRow]) -> String {
    let mut out = String::from(
        "| candidate | scene | simulated (°) | measured (°) | relative error | pass |\n\
         |---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {} | {} |",
            r.group,
            r.scene,
            r.simulated_deg
                .map_or_else(|| "failed".to_string(), |s| format!("{s:.2}")),
            r.measured_deg,
            r.relative_error
                .map_or_else(|| "—".to_string(), |e| format!("{:.1} %", 100.0 * e)),
            if r.passes() {
                "yes".to_string()
            } else {
                format!("no (tolerance {:.0} %)", 100.0 * r.tolerance)
            },
        );
    }
    out
}
