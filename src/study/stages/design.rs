//! `repose sample STUDY`: the study's Latin hypercube (he2019 §3.1) over the
//! calibrated parameters, one experiment manifest per sample, and the
//! design's diagnostics ([`crate::doe::diagnostics`]).
//!
//! Design kinds: `lhs` is [`crate::doe::lhs::latin_hypercube`]; `lhs_optimised`
//! adds [`crate::doe::lhs::optimise`] (maximin through φ_p). The full-factorial and
//! Box–Behnken kinds are not produced by this stage (yet) and are refused.
//!
//! Also `repose sample --diagnose TABLE.csv`: the same diagnostics for any
//! table of points, each column mapped onto [0, 1] by its own min–max (the
//! table carries no ranges; CD² depends on that choice).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::doe::diagnostics::{diagnose, unit_scaled, Diagnostics};
use crate::doe::lhs::{latin_hypercube, optimise, Optimisation, Placement};
use crate::manifest::{canonical_json, DesignKind, Study};
use crate::report::table::{Cell, CsvWriter, Table};
use crate::streams::{rng, Stream};
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::create_dir;
use crate::study::plan::calibration::parameter_names;
use crate::study::plan::calibration::serde_name;
use crate::study::plan::calibration::to_physical;
use crate::study::plan::calibration::write_file;
use crate::study::StudyError;

/// Options of the sample stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleSettings {
    /// Where a sample sits in its stratum.
    pub placement: Placement,
    /// Exchanges tried by `lhs_optimised` (ignored for `lhs`).
    pub optimise_iterations: usize,
    /// |correlation| at or above which columns are reported as strongly correlated.
    pub strong_correlation: f64,
}

impl Default for SampleSettings {
    /// Midpoints, 5000 exchanges, warning at |r| ≥ 0.5.
    fn default() -> Self {
        SampleSettings {
            placement: Placement::Midpoint,
            optimise_iterations: 5000,
            strong_correlation: crate::doe::diagnostics::STRONG_CORRELATION,
        }
    }
}

impl SampleSettings {
    fn check(&self) -> Result<(), StudyError> {
        if !(self.strong_correlation > 0.0 && self.strong_correlation <= 1.0) {
            return Err(StudyError::Settings(format!(
                "--max-correlation = {}: must be in (0, 1]",
                self.strong_correlation
            )));
        }
        Ok(())
    }
}

/// What the sample stage produced.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleOutcome {
    /// Physical design points, one per sample, in parameter order.
    pub points: Vec<Vec<f64>>,
    /// Parameter addresses (column order).
    pub parameters: Vec<String>,
    /// The design's diagnostics (also in diagnostics.json).
    pub diagnostics: Diagnostics,
    /// What the optimisation did (`lhs_optimised` only).
    pub optimisation: Option<Optimisation>,
    /// design.csv.
    pub design_file: PathBuf,
}

/// Contents of diagnostics.json.
#[derive(Serialize)]
struct DiagnosticsRecord<'a> {
    design: &'a str,
    settings: &'a SampleSettings,
    #[serde(skip_serializing_if = "Option::is_none")]
    optimisation: Option<&'a Optimisation>,
    diagnostics: &'a Diagnostics,
}

/// Runs the sample stage.
pub fn sample(
    dir: &StudyDir,
    study: &Study,
    settings: &SampleSettings,
) -> Result<SampleOutcome, StudyError> {
    settings.check()?;
    let kind = study.design.kind;
    let kind_name = match kind {
        DesignKind::Lhs => "lhs",
        DesignKind::LhsOptimised => "lhs_optimised",
        DesignKind::FullFactorial | DesignKind::BoxBehnken => {
            return Err(StudyError::Unsupported(format!(
                "design.kind = \"{}\": `repose sample` makes Latin hypercubes (lhs, lhs_optimised) only",
                serde_name(kind)
            )));
        }
    };
    let names = parameter_names(study);
    let n = study.design.size as usize;
    let mut unit = latin_hypercube(
        n,
        names.len(),
        settings.placement,
        &mut rng(study.design.seed, Stream::Design, 0),
    );
    let optimisation = (kind == DesignKind::LhsOptimised).then(|| {
        optimise(
            &mut unit,
            settings.optimise_iterations,
            &mut rng(study.design.seed, Stream::Optimise, 0),
        )
    });
    let diagnostics = diagnose(&names, &unit, settings.strong_correlation);
    let points: Vec<Vec<f64>> = unit.iter().map(|u| to_physical(study, u)).collect();

    let design = write_experiments(dir, study, &names, &points)?;
    let lineage = dir.lineage(
        Stage::Sample,
        json!({ "design": kind_name, "size": n, "seed": study.design.seed, "settings": settings }),
    );
    let record = DiagnosticsRecord {
        design: kind_name,
        settings,
        optimisation: optimisation.as_ref(),
        diagnostics: &diagnostics,
    };
    let stage_dir = dir.stage(Stage::Sample);
    write_output(
        &stage_dir.join("diagnostics.json"),
        &json_bytes(&record),
        &lineage,
    )?;
    let design_file = dir.design_path();
    write_output(&design_file, design.as_bytes(), &lineage)?;
    Ok(SampleOutcome {
        points,
        parameters: names,
        diagnostics,
        optimisation,
        design_file,
    })
}

/// Writes every design point's experiment manifest (`experiments/NNNN.json`,
/// those of an earlier, larger design removed) and returns the design table
/// (index, the point in physical units, the experiment's id).
fn write_experiments(
    dir: &StudyDir,
    study: &Study,
    names: &[String],
    points: &[Vec<f64>],
) -> Result<String, StudyError> {
    dir.prepare_stage(study, Stage::Sample)?;
    let experiments_dir = dir.stage(Stage::Sample).join("experiments");
    create_dir(&experiments_dir)?;
    let mut header = vec!["index".to_string()];
    header.extend(names.iter().cloned());
    header.push("experiment_id".to_string());
    let mut design = CsvWriter::new(&header);
    let mut written = Vec::with_capacity(points.len());
    for (index, point) in points.iter().enumerate() {
        let map: BTreeMap<String, f64> = names.iter().cloned().zip(point.iter().copied()).collect();
        let experiment = study
            .experiment(&study.calibration.scene, &map, index as u64)
            .map_err(|errors| StudyError::InvalidPoint {
                point: index as u64,
                scene: study.calibration.name.clone(),
                errors,
            })?;
        let path = dir.experiment_path(index);
        write_file(&path, canonical_json(&experiment).as_bytes())?;
        written.push(path);
        let mut row = vec![Cell::Integer(index as u64)];
        row.extend(point.iter().map(|v| Cell::Number(*v)));
        row.push(Cell::Text(experiment.id().to_string()));
        design.row(&row);
    }
    remove_stale(&experiments_dir, &written)?;
    Ok(design.finish())
}

/// Removes manifests of an earlier, larger design (`NNNN.json` not just written).
fn remove_stale(dir: &Path, keep: &[PathBuf]) -> Result<(), StudyError> {
    let io = |source| crate::store::StoreError::Io {
        path: dir.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        let numbered = path
            .file_stem()
            .and_then(|s| s.to_str())
            .is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()));
        if numbered && path.extension().is_some_and(|e| e == "json") && !keep.contains(&path) {
            std::fs::remove_file(&path).map_err(io)?;
        }
    }
    Ok(())
}

/// Diagnostics of the points of a CSV table: `columns` (default: every
/// all-numeric column), each mapped onto [0, 1] by its own min–max.
pub fn diagnose_table(
    path: &Path,
    columns: Option<&[String]>,
    strong_correlation: f64,
) -> Result<Diagnostics, StudyError> {
    SampleSettings {
        strong_correlation,
        ..SampleSettings::default()
    }
    .check()?;
    let table = Table::read(path)?;
    let names: Vec<String> = match columns {
        Some(c) => c.to_vec(),
        None => table.numeric_columns(),
    };
    if names.len() < 2 {
        return Err(StudyError::Settings(format!(
            "{}: {} numeric column(s) chosen ({}): the diagnostics need at least 2 (see --columns)",
            path.display(),
            names.len(),
            names.join(", ")
        )));
    }
    let values = names
        .iter()
        .map(|n| table.numbers(path, n))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(diagnose(&names, &unit_scaled(&values), strong_correlation))
}
