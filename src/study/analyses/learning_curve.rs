//! `repose learning-curve STUDY`: accuracy against the number of DEM
//! simulations — how the surrogate's validation R² and the calibrated
//! parameters' spread change as the training set grows, and what the DEM runs
//! cost.
//!
//! Subsets: nested prefixes of the study's one seeded design. The design splits
//! as `train` splits it ([`DEFAULT_TRAIN_FRACTION`]: the first two thirds by
//! sample index train, the rest validate); the validation rows stay fixed for
//! every size, and size n trains on the first n training rows. So every size
//! is scored on the same rows, the runs of a smaller size are a subset of a
//! larger one's (one batch serves the whole curve; a size costs only its
//! extra runs), and the curve is cheap to extend. The price: a prefix of a
//! Latin hypercube is not itself a Latin hypercube (its strata are not all
//! filled), so small sizes cover the ranges less evenly than a design of that
//! size would. Runs without an angle (failed) are left out and counted.
//!
//! For each size: the GA-BP hidden-size sweep with the `train` stage's
//! defaults and seed (the study's design seed), the kept network's R² and
//! RMSE on the validation rows (optimistic, as in `train`: the validation rows
//! also pick the hidden size), and the `search` stage's defaults on that
//! network: how many resampled points are kept, how many clusters they form,
//! the largest cluster's centre and each parameter's standard deviation over
//! the kept points (physical units; `relative_spread` is their mean over the
//! parameters as a fraction of the range). A size whose network keeps no
//! point (or a single one) has empty spread cells. Cost: the summed wall time
//! of the n training runs from their `timing.json` (the store records wall
//! time only, and only for successful runs; on a loaded machine it exceeds CPU
//! time), and with the validation runs added. Wall-time columns are the only non-deterministic
//! cells of the table.
//!
//! Outputs in `<study dir>/learning-curve/`: `curve.csv`, `curve.md`,
//! `curve.svg` (R² and spread against n, each point labelled with its DEM
//! time), each with its lineage record.

use std::fmt::Write;
use std::path::PathBuf;

use serde_json::json;

use crate::manifest::{ContentId, Study};
use crate::report::markdown::MarkdownTable;
use crate::report::svg::{learning_curve_plot, CurvePoint};
use crate::report::table::{Cell, CsvWriter};
use crate::store::Store;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::parameter_names;
use crate::study::plan::calibration::SearchSettings;
use crate::study::plan::{Stage as PlanStage, StudySpec};
use crate::study::records::{read_angles, AngleRow};
use crate::study::stages::fit_network::input_scales;
use crate::study::stages::search_tolerance::find;
use crate::study::stages::simulate::read_design;
use crate::study::StudyError;
use crate::surrogate::ga_bp::{split_at, DEFAULT_TRAIN_FRACTION};
use crate::surrogate::ga_bp::{sweep, Dataset, TrainSettings};

/// One size of the learning curve.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveRow {
    /// DEM runs in the training prefix (n).
    pub size: usize,
    /// Of these, runs with an angle (used for training).
    pub train_rows: usize,
    /// Validation rows with an angle (the same for every size).
    pub validation_rows: usize,
    /// Id of the last experiment of the prefix (sample index n − 1).
    pub last_id: ContentId,
    /// Hidden size of the kept network.
    pub hidden: usize,
    /// The kept network's validation R² (Eq. 7).
    pub validation_r2: f64,
    /// Its validation RMSE, degrees.
    pub validation_rmse_deg: f64,
    /// Resampled points predicted within tolerance.
    pub kept: usize,
    /// Mean-shift clusters of the kept points.
    pub clusters: usize,
    /// Centre of the largest cluster, physical units, in parameter order.
    pub centre: Option<Vec<f64>>,
    /// Standard deviation of each parameter over the kept points, physical units.
    pub spread: Option<Vec<f64>>,
    /// Mean over parameters of spread / (max − min) of the study's range.
    pub relative_spread: Option<f64>,
    /// Of the n training runs, those with a `timing.json` (failed runs have
    /// none, so their time is not counted).
    pub timed_runs: usize,
    /// Summed wall time of the timed training runs, s.
    pub dem_wall_s: f64,
    /// The same plus the timed validation runs, s.
    pub dem_wall_with_validation_s: f64,
}

/// What the learning curve produced.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveOutcome {
    /// One row per size, in increasing size.
    pub rows: Vec<CurveRow>,
    /// Runs available for training (the training part of the design).
    pub train_capacity: usize,
    /// The table as Markdown (also in curve.md).
    pub markdown: String,
    /// Where the outputs were written.
    pub out_dir: PathBuf,
}

/// The default sizes: a quarter, a half, three quarters and all of the
/// `capacity` training rows (at least 2 each, duplicates dropped).
pub fn default_sizes(capacity: usize) -> Vec<usize> {
    let mut sizes: Vec<usize> = (1..=4)
        .map(|k| ((capacity * k) as f64 / 4.0).round() as usize)
        .filter(|&n| n >= 2)
        .collect();
    sizes.dedup();
    sizes
}

/// Checks that `sizes` is strictly increasing within [2, capacity].
fn check_sizes(sizes: &[usize], capacity: usize) -> Result<(), StudyError> {
    let fail = |m: String| Err(StudyError::Settings(m));
    if sizes.is_empty() {
        return fail("--sizes: give at least one size".to_string());
    }
    for (i, &n) in sizes.iter().enumerate() {
        if n < 2 || n > capacity {
            return fail(format!(
                "--sizes: {n} is not in [2, {capacity}] (the design's {capacity} training rows; \
                 its remaining rows validate)"
            ));
        }
        if i > 0 && n <= sizes[i - 1] {
            return fail(format!(
                "--sizes: {n} follows {}: sizes must increase",
                sizes[i - 1]
            ));
        }
    }
    Ok(())
}

/// Refuses `sizes` (`None`: the defaults) that `study`'s design cannot
/// give, before its batch runs: the capacity is the training part of the
/// design's points as the study's stage list counts them.
pub fn check_sizes_of(study: &Study, sizes: Option<&[usize]>) -> Result<(), StudyError> {
    let Some(sizes) = sizes else {
        return Ok(());
    };
    let spec = StudySpec::calibration(study, false, 1);
    let points = spec
        .stages
        .iter()
        .find_map(|s| match s {
            PlanStage::Simulate { points, .. } => Some(*points),
            _ => None,
        })
        .unwrap_or(0);
    check_sizes(sizes, split_at(points as usize, DEFAULT_TRAIN_FRACTION))
}

/// Computes the learning curve of `study` from its batch (which must have run)
/// and writes it into `learning-curve/`. `sizes`: `None` for [`default_sizes`].
pub fn learning_curve(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    sizes: Option<&[usize]>,
) -> Result<CurveOutcome, StudyError> {
    let design = read_design(dir, study)?;
    let (angles_file, angles) = read_angles(dir, study)?;
    if angles.len() != design.len() || angles.iter().zip(&design).any(|(a, d)| a.index != d.index) {
        return Err(StudyError::Inconsistent {
            path: angles_file,
            message: "its rows differ from sample/design.csv: rerun `repose batch`".to_string(),
        });
    }
    let capacity = split_at(design.len(), DEFAULT_TRAIN_FRACTION);
    let sizes = sizes.map_or_else(|| default_sizes(capacity), <[usize]>::to_vec);
    check_sizes(&sizes, capacity)?;
    let wall: Vec<Option<f64>> = design
        .iter()
        .map(|d| store.timing(&d.id).map(|t| t.wall_time_s))
        .collect();
    let sum = |range: std::ops::Range<usize>| -> f64 { wall[range].iter().flatten().sum() };
    let validation_wall = sum(capacity..design.len());
    let mut rows = Vec::with_capacity(sizes.len());
    for &n in &sizes {
        let mut row = one_size(study, &angles, n, capacity, design[n - 1].id.clone())?;
        row.timed_runs = wall[..n].iter().flatten().count();
        row.dem_wall_s = sum(0..n);
        row.dem_wall_with_validation_s = row.dem_wall_s + validation_wall;
        rows.push(row);
    }

    let out_dir = dir.stage(Stage::LearningCurve);
    dir.prepare_stage(study, Stage::LearningCurve)?;
    let lineage = dir
        .lineage(
            Stage::LearningCurve,
            json!({ "sizes": sizes, "train_fraction": DEFAULT_TRAIN_FRACTION,
                    "train": TrainSettings::with_seed(study.design.seed),
                    "search": SearchSettings::with_seed(study.design.seed) }),
        )
        .with_input(dir.input("design", &dir.design_path())?)
        .with_input(dir.input("angles", &angles_file)?);
    let names = parameter_names(study);
    let markdown = markdown(study, &names, &rows, capacity, design.len() - capacity);
    let points: Vec<CurvePoint> = rows
        .iter()
        .map(|r| CurvePoint {
            size: r.size,
            validation_r2: r.validation_r2,
            relative_spread: r.relative_spread,
            dem_wall_s: r.dem_wall_s,
        })
        .collect();
    let title = format!("Learning curve of `{}`", study.name);
    write_output(
        &out_dir.join("curve.svg"),
        learning_curve_plot(&points, &title).as_bytes(),
        &lineage,
    )?;
    write_output(&out_dir.join("curve.md"), markdown.as_bytes(), &lineage)?;
    write_output(
        &out_dir.join("curve.csv"),
        csv(&names, &rows).as_bytes(),
        &lineage,
    )?;
    Ok(CurveOutcome {
        rows,
        train_capacity: capacity,
        markdown,
        out_dir,
    })
}

/// Trains on the first `n` rows, validates on rows `capacity..`, searches;
/// `last_id` is the id of row n − 1. The DEM times are filled in by the caller.
fn one_size(
    study: &Study,
    angles: &[AngleRow],
    n: usize,
    capacity: usize,
    last_id: ContentId,
) -> Result<CurveRow, StudyError> {
    let with_angle = |range: std::ops::Range<usize>| -> Vec<usize> {
        range.filter(|&i| angles[i].angle_deg.is_some()).collect()
    };
    let data = Dataset {
        inputs: input_scales(study),
        target: "angle_deg".to_string(),
        rows: angles.iter().map(|r| r.point.clone()).collect(),
        targets: angles
            .iter()
            .map(|r| r.angle_deg.unwrap_or(f64::NAN))
            .collect(),
        train: with_angle(0..n),
        validation: with_angle(capacity..angles.len()),
    };
    let trained = sweep(&data, &TrainSettings::with_seed(study.design.seed))?;
    let best = &trained.rows[trained.best];
    let mut row = CurveRow {
        size: n,
        train_rows: data.train.len(),
        validation_rows: data.validation.len(),
        last_id,
        hidden: best.hidden,
        validation_r2: best.validation_r2,
        validation_rmse_deg: best.validation_rmse_deg,
        kept: 0,
        clusters: 0,
        centre: None,
        spread: None,
        relative_spread: None,
        timed_runs: 0,
        dem_wall_s: 0.0,
        dem_wall_with_validation_s: 0.0,
    };
    let found = match find(
        study,
        &trained.model,
        &SearchSettings::with_seed(study.design.seed),
    ) {
        Ok(found) => found,
        // A network that keeps no point, or one point (bandwidth 0), has no
        // spread; that is a finding of the curve, not a failure.
        Err(StudyError::NothingKept(_) | StudyError::Settings(_)) => return Ok(row),
        Err(other) => return Err(other),
    };
    row.kept = found.selection.kept.len();
    row.clusters = found.clusters.len();
    row.centre = found.clusters.first().map(|c| c.centre.clone());
    let kept: Vec<&Vec<f64>> = found
        .selection
        .kept
        .iter()
        .map(|&i| &found.physical[i])
        .collect();
    let spread: Vec<f64> = (0..study.parameters.len())
        .map(|j| standard_deviation(kept.iter().map(|p| p[j])))
        .collect();
    row.relative_spread = Some(
        spread
            .iter()
            .zip(study.parameters.values())
            .map(|(s, r)| s / (r.max - r.min))
            .sum::<f64>()
            / spread.len() as f64,
    );
    row.spread = Some(spread);
    Ok(row)
}

/// Sample standard deviation (n − 1), 0 for fewer than two values.
fn standard_deviation(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    if v.len() < 2 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// Header of curve.csv for the given parameter names.
pub fn csv_header(names: &[String]) -> Vec<String> {
    let mut h: Vec<String> = [
        "size",
        "train_rows",
        "validation_rows",
        "last_id",
        "hidden",
        "validation_r2",
        "validation_rmse_deg",
        "kept",
        "clusters",
    ]
    .map(String::from)
    .to_vec();
    h.extend(names.iter().map(|n| format!("{n}_centre")));
    h.extend(names.iter().map(|n| format!("{n}_sd")));
    h.extend(
        [
            "relative_spread",
            "timed_runs",
            "dem_wall_s",
            "dem_wall_with_validation_s",
        ]
        .map(String::from),
    );
    h
}

fn csv(names: &[String], rows: &[CurveRow]) -> String {
    let mut csv = CsvWriter::new(&csv_header(names));
    let number = |v: Option<f64>| v.map_or(Cell::Empty, Cell::Number);
    let each = |v: &Option<Vec<f64>>, j: usize| number(v.as_ref().map(|x| x[j]));
    for r in rows {
        let mut cells = vec![
            Cell::Integer(r.size as u64),
            Cell::Integer(r.train_rows as u64),
            Cell::Integer(r.validation_rows as u64),
            Cell::Text(r.last_id.to_string()),
            Cell::Integer(r.hidden as u64),
            Cell::Number(r.validation_r2),
            Cell::Number(r.validation_rmse_deg),
            Cell::Integer(r.kept as u64),
            Cell::Integer(r.clusters as u64),
        ];
        cells.extend((0..names.len()).map(|j| each(&r.centre, j)));
        cells.extend((0..names.len()).map(|j| each(&r.spread, j)));
        cells.push(number(r.relative_spread));
        cells.push(Cell::Integer(r.timed_runs as u64));
        cells.push(Cell::Number(r.dem_wall_s));
        cells.push(Cell::Number(r.dem_wall_with_validation_s));
        csv.row(&cells);
    }
    csv.finish()
}

fn markdown(
    study: &Study,
    names: &[String],
    rows: &[CurveRow],
    capacity: usize,
    validation: usize,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Learning curve of `{}`\n", study.name);
    let _ = writeln!(
        s,
        "Size n trains on the first n of the design's {capacity} training rows; the same \
         {validation} rows validate every size. Spread: standard deviation over the kept \
         search points; centre: the largest cluster's. DEM time: summed wall time of the n \
         runs (timing.json).\n"
    );
    let mut header: Vec<String> = [
        "n",
        "hidden",
        "validation R²",
        "RMSE (deg)",
        "kept",
        "clusters",
    ]
    .map(String::from)
    .to_vec();
    header.extend(names.iter().map(|n| format!("{n} centre ± sd")));
    header.extend(["relative spread", "DEM wall (s)"].map(String::from));
    let mut table = MarkdownTable::new(&header);
    for r in rows {
        let mut cells = vec![
            r.size.to_string(),
            r.hidden.to_string(),
            format!("{:.3}", r.validation_r2),
            format!("{:.2}", r.validation_rmse_deg),
            r.kept.to_string(),
            r.clusters.to_string(),
        ];
        cells.extend((0..names.len()).map(|j| match (&r.centre, &r.spread) {
            (Some(c), Some(sd)) => format!("{:.4} ± {:.4}", c[j], sd[j]),
            _ => "–".to_string(),
        }));
        cells.push(
            r.relative_spread
                .map_or("–".to_string(), |v| format!("{v:.3}")),
        );
        cells.push(format!("{:.0}", r.dem_wall_s));
        table.row(&cells);
    }
    s.push_str(&table.render());
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_sizes_are_quarters_of_the_training_rows() {
        assert_eq!(default_sizes(80), [20, 40, 60, 80]);
        assert_eq!(default_sizes(8), [2, 4, 6, 8]);
        assert_eq!(default_sizes(3), [2, 3]);
    }

    #[test]
    fn sizes_out_of_range_or_not_increasing_are_refused() {
        assert!(check_sizes(&[2, 4, 8], 8).is_ok());
        for (bad, fragment) in [
            (vec![], "at least one"),
            (vec![1, 4], "1 is not in [2, 8]"),
            (vec![4, 9], "9 is not in [2, 8]"),
            (vec![4, 4], "4 follows 4"),
        ] {
            let err = check_sizes(&bad, 8).unwrap_err().to_string();
            assert!(err.contains(fragment), "{bad:?}: {err}");
        }
    }

    #[test]
    fn standard_deviation_is_the_sample_one() {
        assert_eq!(standard_deviation([1.0].into_iter()), 0.0);
        let sd = standard_deviation([1.0, 2.0, 3.0, 4.0].into_iter());
        assert!((sd - (5.0f64 / 3.0).sqrt()).abs() < 1e-15);
    }
}
