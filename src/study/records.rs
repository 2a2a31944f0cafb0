//! What stages wrote that later stages read, typed and read back through
//! the layout ([`super::dir::StudyDir`]): a stage reads an earlier stage's
//! output from here, never by importing the stage that wrote it.
//!
//! - the noise floor (`noise/noise.json`, [`NoiseFloor`]);
//! - the design's angles (`batch/angles.csv`, [`AngleRow`]);
//! - the adaptive rounds' passing candidate (`adaptive/replicates.csv`
//!   judged by the acceptance rule, [`Hit`]);
//! - the acceptance record and the verified candidates (`verify/acceptance.json`,
//!   `verify/runs.csv`: [`read_acceptance`], [`read_verified`]).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::manifest::Study;
use crate::report::table::{parse_number, Table};
use crate::store::Store;
use crate::study::acceptance::{Record, Verdict};
use crate::study::dir::{Stage, StudyDir};
use crate::study::plan::calibration::{parameter_names, ADAPTIVE_INDEX, ROUND_STRIDE};
use crate::study::runs::replicated::{read_replicates_csv, Replicated};
use crate::study::StudyError;

/// The noise floor of the calibration response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// Response the floor is of (the target's response name, or
    /// `headline_angle_deg`).
    pub response: String,
    /// The centre of the ranges, physical units, in parameter order.
    pub centre: Vec<f64>,
    /// Seeds run.
    pub seeds: usize,
    /// Seeds measured.
    pub measured: usize,
    /// Mean, degrees.
    pub mean_deg: Option<f64>,
    /// Seed-to-seed standard deviation σ, degrees.
    pub sd_deg: Option<f64>,
    /// Half-width of the 95 % interval of the mean, degrees.
    pub ci95_half_width_deg: Option<f64>,
    /// Mean wall time per run, s (non-deterministic).
    pub wall_s_per_run: Option<f64>,
    /// Threads each run had.
    pub threads_per_run: usize,
    /// σ² × CPU seconds per run, deg²·s (non-deterministic).
    pub precision_per_cost_deg2_s: Option<f64>,
}

/// Reads `noise/noise.json`.
pub fn read_noise(dir: &StudyDir) -> Result<NoiseFloor, StudyError> {
    let path = dir.require(dir.noise_path(), Stage::Noise)?;
    Store::read_json(&path).map_err(|e| StudyError::Inconsistent {
        path,
        message: format!("{e}: rerun `repose noise`"),
    })
}

/// One row of angles.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleRow {
    /// Sample index.
    pub index: usize,
    /// Parameter values, physical units.
    pub point: Vec<f64>,
    /// The simulated angle, degrees (`None` unless the run is complete).
    pub angle_deg: Option<f64>,
}

/// Reads `batch/angles.csv` for `study`.
pub fn read_angles(dir: &StudyDir, study: &Study) -> Result<(PathBuf, Vec<AngleRow>), StudyError> {
    let path = dir.require(dir.angles_path(), Stage::Batch)?;
    let table = Table::read(&path)?;
    let names = parameter_names(study);
    let index = table.numbers(&path, "index")?;
    let columns = names
        .iter()
        .map(|n| table.numbers(&path, n))
        .collect::<Result<Vec<_>, _>>()?;
    let angle = table.require(&path, "angle_deg")?;
    let rows = (0..table.rows.len())
        .map(|i| AngleRow {
            index: index[i] as usize,
            point: columns.iter().map(|c| c[i]).collect(),
            angle_deg: parse_number(&table.rows[i][angle]),
        })
        .collect();
    Ok((path, rows))
}

/// An adaptive candidate that passed in the calibration scene.
#[derive(Debug, Clone, Serialize)]
pub struct Hit {
    /// Its `sample_index`.
    pub index: u64,
    /// Parameter values, physical units, in the study's parameter order.
    pub point: Vec<f64>,
    /// Seeds it ran.
    pub seeds: usize,
    /// Seeds that measured the response.
    pub measured: usize,
    /// Mean of the measured seeds, degrees.
    pub mean_deg: f64,
}

/// The first round candidate among `points` that the acceptance `rule`
/// passes in the calibration scene (its first target): the rule of
/// verification, at the record's α.
pub fn passing(points: &[Replicated], rule: &Record) -> Option<Hit> {
    points
        .iter()
        .filter(|p| (p.index - ADAPTIVE_INDEX).is_multiple_of(ROUND_STRIDE))
        .find_map(|p| {
            let v = p.values();
            let mean = p.mean()?;
            (rule.judge(0, &v).verdict == Verdict::Pass).then(|| Hit {
                index: p.index,
                point: p.point.clone(),
                seeds: p.runs.len(),
                measured: v.len(),
                mean_deg: mean,
            })
        })
}

/// The adaptive stage's passing candidate under verification's `rule`, when
/// the stage has run and found one (`adaptive/replicates.csv`): verification
/// re-simulates it in every scene beside the search's candidates, so the
/// point that ended the stage is the one judged.
pub fn passing_candidate(
    dir: &StudyDir,
    study: &Study,
    rule: &Record,
) -> Result<Option<Hit>, StudyError> {
    let path = dir.adaptive_path();
    if !path.is_file() {
        return Ok(None);
    }
    let points = read_replicates_csv(&path, study)?;
    Ok(passing(&points, rule))
}

/// Candidates as (`sample_index`, physical point in parameter order).
pub type Points = Vec<(u64, Vec<f64>)>;

/// Reads `verify/acceptance.json`: the rule, α, seeds and bands the
/// verification pre-registered.
pub fn read_acceptance(dir: &StudyDir) -> Result<(PathBuf, Record), StudyError> {
    let path = dir.require(dir.acceptance_path(), Stage::Verify)?;
    let record = Store::read_json(&path).map_err(|e| StudyError::Inconsistent {
        path: path.clone(),
        message: format!("{e}: rerun `repose verify`"),
    })?;
    Ok((path, record))
}

/// The candidates the verification judged, in its order: (`sample_index`,
/// physical point in parameter order), read from `verify/runs.csv` (whose
/// numbers round-trip, so a candidate's experiments at the verified size
/// are verification's own).
pub fn read_verified(dir: &StudyDir, study: &Study) -> Result<(PathBuf, Points), StudyError> {
    let path = dir.require(dir.verify_runs_path(), Stage::Verify)?;
    let mut points: Vec<(u64, Vec<f64>)> = Vec::new();
    for p in read_replicates_csv(&path, study)? {
        if !points.iter().any(|(index, _)| *index == p.index) {
            points.push((p.index, p.point));
        }
    }
    Ok((path, points))
}
