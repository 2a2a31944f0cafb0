//! `repose verify STUDY`: he2019 §3.6 — every candidate parameter set (a
//! cluster centre of the search) is simulated again, in the calibration scene
//! (so the surrogate's prediction meets the DEM it stands for) and in each of
//! the study's verification scenes (he2019: baffle lift and rotating drum);
//! the simulated angles are compared with the measured ones: the equivalent of
//! he2019's Table 3 (simulated, measured, relative error), with the verdict
//! of the project's one acceptance rule ([`crate::study::acceptance`]) —
//! which a single run cannot satisfy: it has no interval, so every row is
//! inconclusive, and the table says so rather than passing a candidate on one
//! draw of a noisy test. The noise-aware method verifies with seeds.
//!
//! Verification experiments are ordinary experiments of the study
//! ([`Study::experiment`]) with `sample_index` = the cluster's group number,
//! cached by id in the store like every run; a killed verify resumes, and a
//! failed run is reported in its row without stopping the others.
//!
//! A run whose scene could not measure an angle (a baffle slope or a drum
//! surface with too few surface points, a pile too flat) completes without
//! one and records why ([`RunResult::unmeasured`]): that is an outcome of
//! the candidate, not a fault, and the row says why
//! ([`VerifyStatus::NotMeasurable`], read from the result, never from an
//! error's text). A run that failed (the engine's health check, I/O) is an
//! error ([`VerifyStatus::Failed`], [`VerifyOutcome::errors`]) that
//! `repose verify` and `repose calibrate` exit with after writing the table.

use std::fmt::Write as _;
use std::path::PathBuf;

use serde_json::json;

use super::{parameter_names, write_output, Stage, StudyDir, StudyError};
use crate::exec::{run_incomplete, Executor, Ran};
use crate::manifest::{ContentId, Experiment, Study};
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter, Table};
use crate::store::{RunDir, RunResult, Store};
use crate::study::acceptance::{judge, Judgement};

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
    /// The band, target × (1 ∓ tolerance), degrees.
    pub band_deg: (f64, f64),
    /// How the run ended.
    pub status: VerifyStatus,
}

impl VerifyRow {
    /// The acceptance rule ([`crate::study::acceptance`]) on this row's one
    /// run: one value has no interval, so it is never decided — he2019's
    /// Table 3 judges a single run, which the rule does not sign. The
    /// noise-aware method's verification (`verify_seeds`) runs the seeds
    /// that decide.
    pub fn judgement(&self) -> Judgement {
        let values: Vec<f64> = self.simulated_deg.into_iter().collect();
        judge(&values, self.band_deg)
    }
}

/// How a verification run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum VerifyStatus {
    /// The scene measured an angle.
    Measured,
    /// The run ended, but its scene could not measure an angle; the reason
    /// it recorded ([`RunResult::headline_reason`]) tells why.
    NotMeasurable(String),
    /// The run failed for another reason (the message), or gave no angle.
    Failed(String),
}

impl VerifyStatus {
    /// The reason a run has no angle (none when it was measured).
    pub fn reason(&self) -> Option<&str> {
        match self {
            VerifyStatus::Measured => None,
            VerifyStatus::NotMeasurable(m) | VerifyStatus::Failed(m) => Some(m),
        }
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

impl VerifyOutcome {
    /// The rows whose run failed for a reason other than an unmeasurable
    /// angle: the errors the commands exit with.
    pub fn errors(&self) -> usize {
        self.rows
            .iter()
            .filter(|r| matches!(r.status, VerifyStatus::Failed(_)))
            .count()
    }

    /// The rows whose scene could not measure an angle (failed candidates).
    pub fn not_measurable(&self) -> usize {
        self.rows
            .iter()
            .filter(|r| matches!(r.status, VerifyStatus::NotMeasurable(_)))
            .count()
    }
}

/// `search/clusters.csv` (written by the network's and the GP's search).
pub fn clusters_path(dir: &StudyDir) -> PathBuf {
    dir.stage(Stage::Search).join("clusters.csv")
}

/// Cluster centres to verify: (group, physical point in parameter order).
pub(crate) type Centres = Vec<(u64, Vec<f64>)>;

/// The centres of the first `candidates` clusters of `search/clusters.csv`:
/// (group, physical point in parameter order), with the file read.
pub(crate) fn read_candidates(
    dir: &StudyDir,
    study: &Study,
    candidates: usize,
) -> Result<(PathBuf, Centres), StudyError> {
    if candidates == 0 {
        return Err(StudyError::Settings(
            "--candidates = 0: must be >= 1".into(),
        ));
    }
    let clusters_file = dir.require(clusters_path(dir), Stage::Search)?;
    let table = Table::read(&clusters_file)?;
    let groups = table.numbers(&clusters_file, "group")?;
    let columns = parameter_names(study)
        .iter()
        .map(|n| table.numbers(&clusters_file, n))
        .collect::<Result<Vec<_>, _>>()?;
    let points = groups
        .iter()
        .enumerate()
        .take(candidates)
        .map(|(row, g)| (*g as u64, columns.iter().map(|c| c[row]).collect()))
        .collect();
    Ok((clusters_file, points))
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
    settings: &Executor,
    candidates: usize,
    runner: F,
) -> Result<VerifyOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let (clusters_file, centres) = read_candidates(dir, study, candidates)?;
    let names = parameter_names(study);
    let scenes: Vec<_> = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .collect();
    let mut planned = Vec::new();
    for (group, centre) in &centres {
        let point = names.iter().cloned().zip(centre.iter().copied()).collect();
        for target in &scenes {
            let experiment = study
                .experiment(&target.scene, &point, *group)
                .map_err(|errors| StudyError::InvalidPoint {
                    point: *group,
                    scene: target.name.clone(),
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
        let simulated = result.as_ref().and_then(|r| r.headline_angle_deg);
        let reason = result.as_ref().and_then(RunResult::headline_reason);
        let status = match (failures.iter().find(|f| f.0 == i), simulated, reason) {
            (Some((_, message)), _, _) => VerifyStatus::Failed(message.clone()),
            (None, Some(_), _) => VerifyStatus::Measured,
            (None, None, Some(why)) => VerifyStatus::NotMeasurable(why.to_string()),
            (None, None, None) => VerifyStatus::Failed("no angle".to_string()),
        };
        rows.push(VerifyRow {
            group: *group,
            scene: target.name.clone(),
            id,
            simulated_deg: simulated,
            measured_deg: target.target_angle_deg,
            relative_error: simulated
                .map(|s| (s - target.target_angle_deg).abs() / target.target_angle_deg),
            tolerance: target.tolerance_fraction,
            band_deg: target.band_deg(),
            status,
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
        "verdict",
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
            Cell::Text(r.judgement().verdict.to_string()),
            Cell::Text(csv_word(r.status.reason().unwrap_or_default())),
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

/// `text` as a CSV cell of [`Cell::Text`]: commas become semicolons, quotes
/// apostrophes and line breaks spaces (an error message such as "has 1 surface
/// points, at least 3 are needed" would otherwise split its row). The Markdown
/// table quotes the message as it is.
pub(crate) fn csv_word(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            ',' => ';',
            '"' => '\'',
            '\n' | '\r' => ' ',
            c => c,
        })
        .collect()
}

fn markdown(rows: &[VerifyRow]) -> String {
    let mut table = MarkdownTable::new(&[
        "candidate",
        "scene",
        "simulated (°)",
        "measured (°)",
        "relative error",
        "verdict",
    ]);
    for r in rows {
        let simulated = match (&r.status, r.simulated_deg) {
            (VerifyStatus::Measured, Some(s)) => format!("{s:.2}"),
            (VerifyStatus::NotMeasurable(_), _) => "not measurable".to_string(),
            _ => "failed".to_string(),
        };
        table.row(&[
            r.group.to_string(),
            r.scene.clone(),
            simulated,
            format!("{:.2}", r.measured_deg),
            r.relative_error
                .map_or_else(|| "—".to_string(), |e| format!("{:.1} %", 100.0 * e)),
            r.judgement().verdict_text(),
        ]);
    }
    let mut out = table.render();
    let reasons: Vec<_> = rows
        .iter()
        .filter_map(|r| r.status.reason().map(|why| (r, why)))
        .collect();
    if !reasons.is_empty() {
        out.push_str("\nWhy a scene has no angle:\n\n");
        for (r, why) in reasons {
            let _ = writeln!(out, "- candidate {} {}: {why}", r.group, r.scene);
        }
    }
    out
}
