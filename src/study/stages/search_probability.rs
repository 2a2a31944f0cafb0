//! The search of a noise-aware study: resampled points kept by the
//! probability, under the GP surrogate, that their angle lies in the target
//! band; mean-shift clusters of the kept points as candidates; and the
//! family of parameter sets consistent with the target.
//!
//! Each resampled point x gets the GP's predictive mean μ(x) and latent
//! standard deviation s(x) of the angle (the mean over packings, not one
//! run), and P(x) = Φ((hi − μ)/s) − Φ((lo − μ)/s) for the band [lo, hi] =
//! target (1 ∓ tolerance). Points with P ≥ `min_probability` are kept: a
//! point the surrogate knows little about is not kept on a lucky mean, and
//! one it knows well is kept only when its mean is inside. The kept points
//! are clustered by mean shift as in he2019 (§3.5, [`crate::search::meanshift`]),
//! and the clusters (largest first) are the candidates `verify` re-simulates.
//! In a two-level study (`noise_aware.fidelity`) μ and s are the fine
//! level's, from the two-level process of the fine stage ([`crate::study::stages::fine`]).
//!
//! # The family
//!
//! `family.md` reports the parameter sets consistent with the target
//! ([`crate::search::band::family`]).
//!
//! The resampling is `10 × samples` points of a Latin hypercube from the
//! search stream (the GP is cheap to evaluate; a narrow band in five
//! parameters needs thousands of points to be populated).
//!
//! # Screening
//!
//! The train stage sets every parameter's main effect under the GP against
//! one run's seed-to-seed σ (`train/gp.json`, `screening.csv`;
//! [`crate::study::stages::fit_gp`]). With `noise_aware.screen`, the parameters below the
//! noise are fixed at the centre of their ranges in every resampled point,
//! so the kept points, the clusters and the candidates vary only the
//! parameters these runs can calibrate; the run budget is unchanged (the
//! screening reads the surrogate, not new runs).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::manifest::Study;
use crate::report::markdown::MarkdownTable;
use crate::report::svg::scatter_matrix;
use crate::report::table::{Cell, CsvWriter};
use crate::search::acquisition::probability_in_band;
use crate::search::band::{cluster_column, family, resample, select, Criterion, Family, Selection};
use crate::search::meanshift::Clustering;
use crate::search::screen::{fix_inactive, MainEffect};
use crate::stats::gp::GpPrediction;
use crate::stats::gp_two_level::Predictor;
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::noise_aware;
use crate::study::plan::calibration::parameter_names;
use crate::study::plan::calibration::to_physical;
use crate::study::plan::calibration::SearchSettings;
use crate::study::StudyError;
use crate::surrogate::Prediction;

/// Resampled points per point of the network's search.
pub const RESAMPLE_FACTOR: usize = 10;

/// A candidate: one cluster of kept points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Group number (1 = largest).
    pub group: usize,
    /// Kept points in the cluster.
    pub size: usize,
    /// The cluster centre, physical units, in parameter order.
    pub centre: Vec<f64>,
    /// GP mean at the centre, degrees.
    pub predicted_deg: f64,
    /// GP latent standard deviation at the centre, degrees.
    pub predicted_sd_deg: f64,
    /// Probability of the band at the centre.
    pub probability: f64,
}

/// What the search did.
#[derive(Debug, Clone)]
pub struct GpSearchOutcome {
    /// The candidates, largest cluster first.
    pub candidates: Vec<Candidate>,
    /// The family report.
    pub family: Family,
    /// Every parameter's main effect under the GP against the noise floor's
    /// σ, and whether the search varied it (fixed at the centre when the
    /// study screens and the effect is below the noise).
    pub screening: Vec<MainEffect>,
    /// The Markdown report (clusters and family).
    pub markdown: String,
}

/// The resampled points of one search and what the GP says of each.
struct Resampled {
    /// The points, unit cube of the ranges, inactive parameters fixed.
    unit: Vec<Vec<f64>>,
    /// The GP's mean and latent sd of the angle at each point, degrees.
    predictions: Vec<GpPrediction>,
    /// Each point's probability of an angle in the band.
    probability: Vec<f64>,
}

/// What one search found, ready to be written.
struct Found<'a> {
    /// The parameter names, in order.
    names: Vec<String>,
    /// The resampled points.
    resampled: &'a Resampled,
    /// The kept points and their clusters.
    selection: &'a Selection,
    /// The candidates, largest cluster first.
    candidates: &'a [Candidate],
    /// The family report.
    family: &'a Family,
    /// The target band [lo, hi], degrees.
    band: (f64, f64),
    /// The probability a kept point needs.
    min_probability: f64,
}

/// Runs the noise-aware search (see the module docs) on `predictor` (a
/// two-level study's fine level, else the trained GP) with the fit stage's
/// screening `effects` (the driver reads both from the earlier stages).
pub fn gp_search(
    dir: &StudyDir,
    study: &Study,
    (predictor, effects): (&Predictor, &[MainEffect]),
    settings: &SearchSettings,
) -> Result<GpSearchOutcome, StudyError> {
    let spec = noise_aware(study)?;
    let names = parameter_names(study);
    let samples = settings.samples * RESAMPLE_FACTOR;
    let unit: Vec<Vec<f64>> = resample(samples, names.len(), settings.placement, settings.seed, 1)
        .iter()
        .map(|u| fix_inactive(u, effects))
        .collect();
    let (lo, hi) = study.calibration.band_deg();
    let criterion = Criterion::Probability {
        lo,
        hi,
        min: spec.min_probability,
    };
    let resampled = score(predictor, &criterion, unit);
    let Some(selection) = select(
        &resampled.unit,
        &resampled.probability,
        &criterion,
        settings.kernel,
        settings.bandwidth,
        settings.quantile,
    ) else {
        return Err(nothing_kept(
            study,
            predictor,
            &resampled,
            spec.min_probability,
        ));
    };
    let candidates = candidates(study, predictor, &selection.clustering, (lo, hi));
    let ranges = crate::study::plan::calibration::ranges(study);
    let family = family(&names, &ranges, &selection.kept_unit, samples);
    let found = Found {
        names,
        resampled: &resampled,
        selection: &selection,
        candidates: &candidates,
        family: &family,
        band: (lo, hi),
        min_probability: spec.min_probability,
    };
    let markdown = write_outputs(dir, study, (predictor, effects), settings, &found)?;
    Ok(GpSearchOutcome {
        candidates,
        family,
        markdown,
        screening: effects.to_vec(),
    })
}

/// The GP's prediction at every point of `unit` and its score under
/// `criterion` (the probability of the band).
fn score(predictor: &Predictor, criterion: &Criterion, unit: Vec<Vec<f64>>) -> Resampled {
    let predictions: Vec<GpPrediction> = unit.iter().map(|u| predictor.predict(u)).collect();
    let probability: Vec<f64> = predictions
        .iter()
        .map(|p| {
            criterion.score(&Prediction {
                mean: p.mean,
                sd: Some(p.sd),
            })
        })
        .collect();
    Resampled {
        unit,
        predictions,
        probability,
    }
}

/// The refusal when no resampled point reaches `min_probability`: the best
/// point, its probability and prediction, and what would help.
fn nothing_kept(
    study: &Study,
    predictor: &Predictor,
    resampled: &Resampled,
    min_probability: f64,
) -> StudyError {
    let Resampled {
        unit,
        predictions,
        probability,
    } = resampled;
    let samples = unit.len();
    let (lo, hi) = study.calibration.band_deg();
    let best = (0..unit.len())
        .max_by(|&a, &b| probability[a].total_cmp(&probability[b]))
        .unwrap_or(0);
    let (model, remedy) = if predictor.is_two_level() {
        (
            "the two-level GP's fine level",
            "more fine points (noise_aware.fidelity.fine_points)",
        )
    } else {
        ("the GP", "more runs near the target (`--adaptive`)")
    };
    StudyError::NothingKept(format!(
        "none of the {samples} resampled points has probability >= {} of an angle in \
         {lo:.2}–{hi:.2} deg under {model}; the best has {:.3} (mean {:.2} ± {:.2} deg) at \
         {}: {remedy} or a lower min_probability",
        min_probability,
        probability[best],
        predictions[best].mean,
        predictions[best].sd,
        to_physical(study, &unit[best])
            .iter()
            .zip(&parameter_names(study))
            .map(|(v, n)| format!("{n} = {v:.4}"))
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// One candidate per cluster of `clustering`, at its centre, with the GP's
/// prediction and the probability of the band `(lo, hi)` there.
fn candidates(
    study: &Study,
    predictor: &Predictor,
    clustering: &Clustering,
    (lo, hi): (f64, f64),
) -> Vec<Candidate> {
    clustering
        .centres
        .iter()
        .zip(&clustering.sizes)
        .enumerate()
        .map(|(k, (c, &size))| {
            let p = predictor.predict(c);
            Candidate {
                group: k + 1,
                size,
                centre: to_physical(study, c),
                predicted_deg: p.mean,
                predicted_sd_deg: p.sd,
                probability: probability_in_band(p.mean, p.sd, lo, hi),
            }
        })
        .collect()
}

/// Writes the search's outputs with their lineage (the settings, the GP and
/// the two-level process it read): `points.csv`, `scatter.svg`,
/// `family.json`, `clusters.md` and the candidates' table; returns the
/// Markdown report.
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    (predictor, effects): (&Predictor, &[MainEffect]),
    settings: &SearchSettings,
    found: &Found<'_>,
) -> Result<String, StudyError> {
    let Found {
        names,
        resampled,
        selection,
        candidates,
        family,
        band: (lo, hi),
        min_probability,
    } = found;
    let (lo, hi, min_probability) = (*lo, *hi, *min_probability);
    let samples = resampled.unit.len();
    let out = dir.stage(Stage::Search);
    dir.prepare_stage(study, Stage::Search)?;
    let surrogate = if predictor.is_two_level() {
        "two_level_gp"
    } else {
        "gp"
    };
    let mut lineage = dir
        .lineage(
            Stage::Search,
            json!({ "settings": settings, "surrogate": surrogate, "resampled": samples,
                    "min_probability": min_probability, "band_deg": [lo, hi],
                    "fixed_by_screening": effects.iter().filter(|e| !e.active)
                        .map(|e| e.parameter.clone()).collect::<Vec<_>>(),
                    "bandwidth_used": selection.bandwidth }),
        )
        .with_input(dir.input("gp", &dir.gp_path())?);
    if predictor.is_two_level() {
        lineage = lineage.with_input(dir.input("two_level", &dir.two_level_path())?);
    }
    let ranges = crate::study::plan::calibration::ranges(study);
    let svg = scatter_matrix(
        names,
        &ranges,
        &selection.kept_unit,
        &selection.clustering.labels,
        &selection.clustering.centres,
        &format!(
            "{} of {samples} points with P(angle in {lo:.1}–{hi:.1} deg) >= {}",
            selection.kept.len(),
            min_probability
        ),
    );
    let markdown = markdown(names, candidates, family, min_probability, (lo, hi));
    write_output(
        &out.join("points.csv"),
        points_csv(study, names, resampled, selection).as_bytes(),
        &lineage,
    )?;
    write_output(&out.join("scatter.svg"), svg.as_bytes(), &lineage)?;
    write_output(&out.join("family.json"), &json_bytes(family), &lineage)?;
    write_output(&out.join("clusters.md"), markdown.as_bytes(), &lineage)?;
    write_output(
        &dir.clusters_path(),
        clusters_csv(names, candidates).as_bytes(),
        &lineage,
    )?;
    Ok(markdown)
}

/// Every resampled point, physical units, with its prediction, probability
/// and cluster (empty when not kept).
fn points_csv(
    study: &Study,
    names: &[String],
    resampled: &Resampled,
    selection: &Selection,
) -> String {
    let unit = &resampled.unit;
    let label = cluster_column(unit.len(), &selection.kept, &selection.clustering.labels);
    let mut header = vec!["point".to_string()];
    header.extend(names.iter().cloned());
    header.extend(
        [
            "predicted_deg",
            "predicted_sd_deg",
            "probability",
            "cluster",
        ]
        .map(String::from),
    );
    let mut points = CsvWriter::new(&header);
    for (i, u) in unit.iter().enumerate() {
        let mut cells = vec![Cell::Integer(i as u64)];
        cells.extend(to_physical(study, u).into_iter().map(Cell::Number));
        cells.push(Cell::Number(resampled.predictions[i].mean));
        cells.push(Cell::Number(resampled.predictions[i].sd));
        cells.push(Cell::Number(resampled.probability[i]));
        cells.push(label[i].map_or(Cell::Empty, |l| Cell::Integer(l as u64)));
        points.row(&cells);
    }
    points.finish()
}

/// The candidates' table: group, size, centre and its prediction.
fn clusters_csv(names: &[String], candidates: &[Candidate]) -> String {
    let mut header = vec!["group".to_string(), "size".to_string()];
    header.extend(names.iter().cloned());
    header.extend(["predicted_angle_deg", "predicted_sd_deg", "probability"].map(String::from));
    let mut clusters = CsvWriter::new(&header);
    for c in candidates {
        let mut cells = vec![Cell::Integer(c.group as u64), Cell::Integer(c.size as u64)];
        cells.extend(c.centre.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Number(c.predicted_deg));
        cells.push(Cell::Number(c.predicted_sd_deg));
        cells.push(Cell::Number(c.probability));
        clusters.row(&cells);
    }
    clusters.finish()
}

fn markdown(
    names: &[String],
    candidates: &[Candidate],
    family: &Family,
    min_probability: f64,
    band: (f64, f64),
) -> String {
    let mut t = MarkdownTable::new(
        &[
            vec!["group".to_string(), "size".to_string()],
            names.to_vec(),
            vec!["GP mean ± sd (°)".to_string(), "P(in band)".to_string()],
        ]
        .concat()
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>(),
    );
    for c in candidates {
        let mut row = vec![c.group.to_string(), c.size.to_string()];
        row.extend(c.centre.iter().map(|v| format!("{v:.4}")));
        row.push(format!(
            "{:.2} ± {:.2}",
            c.predicted_deg, c.predicted_sd_deg
        ));
        row.push(format!("{:.2}", c.probability));
        t.row(&row);
    }
    let mut out = format!(
        "{} of {} resampled points have P(angle in {:.2}–{:.2}°) ≥ {min_probability} under the GP; \
         mean shift gives {} cluster(s):\n\n",
        family.kept,
        family.resampled,
        band.0,
        band.1,
        candidates.len()
    );
    out.push_str(&t.render());
    out.push_str("\n## The family of parameter sets consistent with the target\n\n");
    let mut s = MarkdownTable::new(&["parameter", "mean", "sd", "min", "max", "sd / range"]);
    for p in &family.spread {
        s.row(&[
            p.parameter.clone(),
            format!("{:.4}", p.mean),
            format!("{:.4}", p.sd),
            format!("{:.4}", p.min),
            format!("{:.4}", p.max),
            format!("{:.2}", p.relative_sd),
        ]);
    }
    out.push_str(&s.render());
    out.push_str(
        "\nPrincipal directions of the kept points (unit cube of the ranges, largest share \
         first; a large share is a combination the target leaves free):\n\n",
    );
    let mut d = MarkdownTable::new(
        &[vec!["share".to_string()], names.to_vec()]
            .concat()
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    for dir in &family.directions {
        let mut row = vec![format!("{:.0} %", 100.0 * dir.variance_share)];
        row.extend(dir.loadings.iter().map(|v| format!("{v:+.2}")));
        d.row(&row);
    }
    out.push_str(&d.render());
    let _ = writeln!(out);
    out
}
