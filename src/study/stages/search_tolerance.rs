//! `repose search STUDY`: he2019 §3.5 — resample the parameter space by Latin
//! hypercube, predict each point's angle with the trained network, keep the
//! points whose relative deviation from the measured angle is within the
//! tolerance (Eq. 8–10: |pred − target| / target ≤ tol, inputs within their
//! ranges by construction; target and tolerance from the study's calibration
//! scene), and cluster the kept points by mean shift in unit-scaled parameters
//! (each range mapped onto [0, 1]). The centres, in physical units, with the
//! size of their cluster and the network's angle at the centre are the
//! equivalent of he2019's Table 2.
//!
//! The bandwidth is given (unit-scaled) or estimated from the kept points by
//! [`crate::search::meanshift::estimate_bandwidth`] with a configurable quantile
//! (default 0.3, scikit-learn's); both choices are recorded.

use std::fmt::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::json;

use crate::manifest::Study;
use crate::report::markdown::MarkdownTable;
use crate::report::svg::scatter_matrix;
use crate::report::table::{Cell, CsvWriter};
use crate::search::band::{cluster_column, resample, select, Criterion, Selection};
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::serde_name;
use crate::study::plan::calibration::to_physical;
use crate::study::plan::calibration::{parameter_names, SearchSettings};
use crate::study::StudyError;
use crate::surrogate::ga_bp::Model;
use crate::surrogate::Prediction;

/// One cluster of kept points (a row of the Table 2 equivalent).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClusterRow {
    /// Group number, 1 = largest.
    pub group: usize,
    /// Kept points in the cluster.
    pub size: usize,
    /// Centre, physical units, in parameter order.
    pub centre: Vec<f64>,
    /// The network's angle at the centre, degrees.
    pub predicted_angle_deg: f64,
}

/// What the search found.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchOutcome {
    /// Parameter addresses (column order).
    pub parameters: Vec<String>,
    /// Predicted angle of every resampled point, degrees.
    pub predicted: Vec<f64>,
    /// Indices of the kept points.
    pub kept: Vec<usize>,
    /// Bandwidth used (unit-scaled).
    pub bandwidth: f64,
    /// Distinct modes before merging.
    pub modes: usize,
    /// The clusters, largest first.
    pub clusters: Vec<ClusterRow>,
    /// The Table 2 equivalent as Markdown (also in clusters.md).
    pub markdown: String,
    /// Where the outputs were written.
    pub out_dir: PathBuf,
}

/// Runs the search stage.
pub fn search(
    dir: &StudyDir,
    study: &Study,
    settings: &SearchSettings,
) -> Result<SearchOutcome, StudyError> {
    settings.check()?;
    let model_file = dir.require(dir.stage(Stage::Train).join("model.json"), Stage::Train)?;
    let model = load_model(&model_file)?;
    let names = parameter_names(study);
    let model_inputs: Vec<String> = model.inputs.iter().map(|s| s.name.clone()).collect();
    if model_inputs != names {
        return Err(StudyError::Inconsistent {
            path: model_file,
            message: format!(
                "the model's inputs ({}) are not the study's parameters ({}): rerun `repose train`",
                model_inputs.join(", "),
                names.join(", ")
            ),
        });
    }
    let found = find(study, &model, settings)?;
    let Selection {
        kept, bandwidth, ..
    } = &found.selection;
    let markdown = markdown(
        study,
        settings,
        &names,
        &found.clusters,
        kept.len(),
        *bandwidth,
    );
    let out_dir = write_outputs(
        dir,
        study,
        settings,
        (&model_file, &names),
        &found,
        &markdown,
    )?;
    let Found {
        predicted,
        selection:
            Selection {
                kept,
                bandwidth,
                clustering,
                ..
            },
        clusters,
        ..
    } = found;
    Ok(SearchOutcome {
        parameters: names,
        predicted,
        kept,
        bandwidth,
        modes: clustering.modes,
        clusters,
        markdown,
        out_dir,
    })
}

/// Writes the search's outputs with their lineage (the settings, the
/// bandwidth used, the target and the model file): `points.csv`,
/// `scatter.svg`, `clusters.md` and `clusters.csv`; returns the stage
/// directory.
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    settings: &SearchSettings,
    (model_file, names): (&Path, &[String]),
    found: &Found,
    markdown: &str,
) -> Result<PathBuf, StudyError> {
    let target = &study.calibration;
    let Found {
        physical,
        predicted,
        selection:
            Selection {
                kept,
                kept_unit,
                bandwidth,
                clustering,
            },
        clusters,
    } = found;
    let label = cluster_column(predicted.len(), kept, &clustering.labels);
    let out_dir = dir.stage(Stage::Search);
    dir.prepare_stage(study, Stage::Search)?;
    let lineage = dir
        .lineage(
            Stage::Search,
            json!({ "settings": settings, "bandwidth_used": bandwidth,
                    "target_angle_deg": target.target_angle_deg,
                    "tolerance_fraction": target.tolerance_fraction }),
        )
        .with_input(dir.input("model", model_file)?);
    let ranges = crate::study::plan::calibration::ranges(study);
    let svg = scatter_matrix(
        names,
        &ranges,
        kept_unit,
        &clustering.labels,
        &clustering.centres,
        &format!(
            "{} of {} points within {}% of {} deg",
            kept.len(),
            predicted.len(),
            target.tolerance_fraction * 100.0,
            target.target_angle_deg
        ),
    );
    write_output(
        &out_dir.join("points.csv"),
        points_csv(names, physical, predicted, &label).as_bytes(),
        &lineage,
    )?;
    write_output(&out_dir.join("scatter.svg"), svg.as_bytes(), &lineage)?;
    write_output(&out_dir.join("clusters.md"), markdown.as_bytes(), &lineage)?;
    write_output(
        &out_dir.join("clusters.csv"),
        clusters_csv(names, clusters).as_bytes(),
        &lineage,
    )?;
    Ok(out_dir)
}

/// The search without its outputs: the resampled points, their predicted
/// angles, the kept ones and their mean-shift clusters. `search` writes these;
/// the learning curve ([`crate::study::analyses::learning_curve`]) calls it once per training size.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The same points, physical units.
    pub physical: Vec<Vec<f64>>,
    /// Predicted angle of every point, degrees.
    pub predicted: Vec<f64>,
    /// The kept points and their mean-shift clusters.
    pub selection: Selection,
    /// The clusters, largest first.
    pub clusters: Vec<ClusterRow>,
}

/// Resamples the study's ranges, predicts with `model`, keeps the points
/// within tolerance and clusters them (see the module docs).
pub fn find(study: &Study, model: &Model, settings: &SearchSettings) -> Result<Found, StudyError> {
    settings.check()?;
    let target = &study.calibration;
    let names = parameter_names(study);
    let unit = resample(
        settings.samples,
        names.len(),
        settings.placement,
        settings.seed,
        0,
    );
    let physical: Vec<Vec<f64>> = unit.iter().map(|u| to_physical(study, u)).collect();
    let predicted: Vec<f64> = physical.iter().map(|x| model.predict(x)).collect();
    let criterion = Criterion::Tolerance {
        target: target.target_angle_deg,
        fraction: target.tolerance_fraction,
    };
    let deviation: Vec<f64> = predicted
        .iter()
        .map(|&mean| criterion.score(&Prediction { mean, sd: None }))
        .collect();
    let Some(selection) = select(
        &unit,
        &deviation,
        &criterion,
        settings.kernel,
        settings.bandwidth,
        settings.quantile,
    ) else {
        let lo = predicted.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = predicted.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        return Err(StudyError::NothingKept(format!(
            "none of the {} predicted angles ({lo:.2}–{hi:.2} deg) is within {}% of the target \
             {} deg of `{}`: the parameter ranges may not reach the target",
            predicted.len(),
            target.tolerance_fraction * 100.0,
            target.target_angle_deg,
            target.name
        )));
    };
    if selection.bandwidth <= 0.0 {
        return Err(StudyError::Settings(format!(
            "the estimated bandwidth is 0 ({} kept point(s), quantile {}): raise --quantile or give --bandwidth",
            selection.kept.len(),
            settings.quantile
        )));
    }
    let clusters: Vec<ClusterRow> = selection
        .clustering
        .centres
        .iter()
        .zip(&selection.clustering.sizes)
        .enumerate()
        .map(|(k, (c, &size))| {
            let centre = to_physical(study, c);
            ClusterRow {
                group: k + 1,
                size,
                predicted_angle_deg: model.predict(&centre),
                centre,
            }
        })
        .collect();

    Ok(Found {
        physical,
        predicted,
        selection,
        clusters,
    })
}

/// Reads and checks a trained network (`train/model.json`).
pub(crate) fn load_model(path: &std::path::Path) -> Result<Model, StudyError> {
    let inconsistent = |message: String| StudyError::Inconsistent {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| inconsistent(e.to_string()))?;
    let model: Model = serde_json::from_slice(&bytes).map_err(|e| inconsistent(e.to_string()))?;
    model.check().map_err(inconsistent)?;
    Ok(model)
}

fn points_csv(
    names: &[String],
    physical: &[Vec<f64>],
    predicted: &[f64],
    label: &[Option<usize>],
) -> String {
    let mut header = vec!["index".to_string()];
    header.extend(names.iter().cloned());
    header.extend(["predicted_angle_deg", "kept", "cluster"].map(String::from));
    let mut csv = CsvWriter::new(&header);
    for (i, x) in physical.iter().enumerate() {
        let mut cells = vec![Cell::Integer(i as u64)];
        cells.extend(x.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Number(predicted[i]));
        cells.push(Cell::Text(
            if label[i].is_some() { "yes" } else { "no" }.to_string(),
        ));
        cells.push(label[i].map_or(Cell::Empty, |l| Cell::Integer(l as u64)));
        csv.row(&cells);
    }
    csv.finish()
}

fn clusters_csv(names: &[String], clusters: &[ClusterRow]) -> String {
    let mut header = vec!["group".to_string(), "size".to_string()];
    header.extend(names.iter().cloned());
    header.push("predicted_angle_deg".to_string());
    let mut csv = CsvWriter::new(&header);
    for c in clusters {
        let mut cells = vec![Cell::Integer(c.group as u64), Cell::Integer(c.size as u64)];
        cells.extend(c.centre.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Number(c.predicted_angle_deg));
        csv.row(&cells);
    }
    csv.finish()
}

fn markdown(
    study: &Study,
    settings: &SearchSettings,
    names: &[String],
    clusters: &[ClusterRow],
    kept: usize,
    bandwidth: f64,
) -> String {
    let t = &study.calibration;
    let how = match settings.bandwidth {
        Some(_) => "given".to_string(),
        None => format!("estimated, quantile {}", settings.quantile),
    };
    let mut s = String::new();
    let _ = writeln!(s, "# Mean-shift clusters of `{}`\n", study.name);
    let _ = writeln!(
        s,
        "{kept} of {} resampled points predict `{}` within {}% of {} deg; \
         {} kernel, bandwidth {bandwidth:.4} (unit-scaled, {how}).\n",
        settings.samples,
        t.name,
        t.tolerance_fraction * 100.0,
        t.target_angle_deg,
        serde_name(settings.kernel)
    );
    let mut header = vec!["group".to_string(), "size".to_string()];
    header.extend(names.iter().cloned());
    header.push("predicted angle (deg)".to_string());
    let mut table = MarkdownTable::new(&header);
    for c in clusters {
        let mut cells = vec![c.group.to_string(), c.size.to_string()];
        cells.extend(c.centre.iter().map(|v| format!("{v:.6}")));
        cells.push(format!("{:.2}", c.predicted_angle_deg));
        table.row(&cells);
    }
    s.push_str(&table.render());
    s
}
