//! The Gaussian-process surrogate of a noise-aware study, beside he2019's
//! GA-BP network, and how well each predicts runs it has not seen.
//!
//! # Data
//!
//! One row per simulated point: the design rows (`batch/replicates.csv`),
//! the noise floor's centre (`noise/noise.csv`, if run) and the adaptive
//! points (`adaptive/replicates.csv`, if any), each with the mean of its
//! measured replicates (points without any are left out). Inputs are the
//! parameters mapped onto the unit cube of the study's ranges
//! ([`crate::stats::gp`]).
//!
//! # Noise
//!
//! The noise of a row's mean is its seed-to-seed variance over nᵢ, the
//! seeds it measured; the replicates say which variance ([`RowNoise`]):
//!
//! - σ² is the variance pooled over every point with two or more measured
//!   seeds, Σ(nᵢ − 1)sᵢ² / Σ(nᵢ − 1).
//! - Bartlett's test ([`crate::stats::homogeneity`], chosen there over
//!   Levene's because most points have two seeds) asks whether those points
//!   share one variance. If it rejects at α = [`HOMOGENEITY_ALPHA`], the
//!   spread varies over the parameter space and each row gets its own
//!   variance, shrunk towards σ²: s̃ᵢ² = (ν₀σ² + (nᵢ − 1)sᵢ²) / (ν₀ + nᵢ − 1)
//!   with ν₀ = [`PRIOR_DF`] (a point with one seed gets σ²). Otherwise (or
//!   when fewer than two points are replicated, or every replicated point's
//!   seeds agree exactly) every row gets σ².
//! - Why shrink: a two-seed variance has one degree of freedom, its 95 %
//!   range spans a factor of 5 000 (χ²₁ from 0.001 to 5.02), so used raw it
//!   would call a point whose seeds happen to agree noise-free and the GP
//!   would interpolate it. σ² weighted as ν₀ seed degrees of freedom keeps a
//!   two-seed point at ≥ ν₀/(ν₀ + 1) = 2/3 of σ² while a point whose seeds
//!   are far apart still stands out. ν₀ = 2 from a simulation of the
//!   design's shape (12 two-seed points and the 8-seed centre, normal
//!   noise, 4 000 tables per scenario, scored only where Bartlett
//!   rejects): the scenarios were ln σᵢ ~ N(0, 0.35²) and N(0, 0.7²), half
//!   the points with 10 times the others' σ, and one point with 5 times.
//!   Smaller ν₀ lowers the mean squared error of ln s̃ᵢ² against ln σᵢ² in
//!   all but the mildest scenario (ν₀ = 1: 0.67, 2.17, 6.13, 0.82; ν₀ = 2:
//!   0.65, 2.54, 6.97, 1.09; pooled alone: 0.87, 3.53, 8.37, 1.99) but
//!   states more rows' variance 4 times or more too low, the error that
//!   makes the GP chase a noisy mean; ν₀ = 2 is the smallest tried (of ¼,
//!   ½, 1, 2, 4) that keeps that at or below 5 % in every scenario (2.0,
//!   4.4, 1.7, 0.8 %; ν₀ = 1 reaches 5.2 %, the pooled σ² alone 7.0 %).
//!   The price is a damped separation: with two seeds a point's own
//!   variance weighs a third, so a 100-fold difference of true variances
//!   shows as a small fraction of that in the rows' noise (in the test with
//!   half the design 10 times noisier, the loud half's rows average 1.35
//!   times the quiet half's noise; the quiet half's fall below σ²/nᵢ).
//! - The GP fits no nugget on top (`fit_nugget` false): the known noise is
//!   the replicates', and a fitted nugget would add a second, unmeasured
//!   noise that the per-point variances are there to replace.
//!
//! The GP assumes the rows' noises are independent: the covariance of the
//! observations adds a diagonal only. Points replicated with the same
//! packing seeds (seed `packing_seed + r` at every point) start from the
//! same packing, so their errors may be correlated, which this model does
//! not see; he2019's noise-aware studies are moving to independent packing
//! seeds per point, which is what the assumption needs.
//!
//! `train/gp.json` records the noise model, the test's statistic and p, the
//! rows' own variances sᵢ² and their noise variances; `train/surrogates.md`
//! states them.
//!
//! # Validation
//!
//! The design rows are split as the network's are (the first
//! `train_fraction` of the samples train, the rest validate); the centre and
//! the adaptive points always train. The noise model is decided once, from
//! every row's replicates. Each surrogate predicts the validation
//! rows' replicate means: R² (Eq. 7), RMSE, and the coverage of its 95 %
//! predictive intervals — the fraction of validation means inside them. The
//! GP's interval for a mean of nᵢ seeds is ± 1.96 √(latent variance +
//! the row's noise variance). The network gives no spread of its own: its
//! interval is ± 1.96 × its RMSE on its own training rows (near zero when it
//! interpolates them, which is what the coverage then shows).
//!
//! The GP used by the search is then fitted to every row (`train/gp.json`
//! keeps its data and hyperparameters, so the search rebuilds it exactly).
//!
//! # Screening
//!
//! Every parameter's main effect under that GP (the predicted angle averaged
//! over the other parameters, [`SCREEN_POINTS`] points of the search
//! stream's sub-stream 2, over the parameter's whole range) is set against
//! one run's seed-to-seed σ, the pooled replicate sd
//! ([`crate::search::screen`]); `gp.json` keeps the result and
//! `screening.csv` and `surrogates.md` report it. With `noise_aware.screen`
//! the parameters below σ are fixed at their centre by the search
//! ([`crate::study::stages::search_probability`]), and the validation is repeated with those inputs
//! dropped from the GP (`gp_screened`: the same training and validation
//! rows), so the R² before and after screening is read at equal run counts.

use std::fmt::Write as _;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::doe::lhs::Placement;
use crate::manifest::Study;
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter};
use crate::search::band::resample;
use crate::search::screen::{main_effects, MainEffect};
use crate::stats::gp::{GaussianProcess, GpHyper, GpSettings};
use crate::stats::homogeneity::bartlett;
use crate::stats::metrics::{mse, noise_ceiling, r_squared, seeds_for_ceiling, NoiseCeiling};
use crate::stats::summary::Z95;
use crate::store::Store;
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::to_unit;
use crate::study::runs::replicated::{pooled_variance, read_replicates_csv, Replicated};
use crate::study::StudyError;

/// Significance level of the homogeneity test below which the rows' noise
/// becomes per point (see the module docs).
pub const HOMOGENEITY_ALPHA: f64 = 0.05;

/// Prior degrees of freedom ν₀ of the pooled variance in a point's shrunk
/// variance (see the module docs for why 2).
pub const PRIOR_DF: f64 = 2.0;

/// The surrogate's training rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GpData {
    /// Where each row comes from: `design`, `noise` or `adaptive`.
    pub source: Vec<String>,
    /// Each row's `sample_index`.
    pub index: Vec<u64>,
    /// Inputs in the unit cube of the ranges.
    pub x_unit: Vec<Vec<f64>>,
    /// Replicate means, degrees.
    pub y: Vec<f64>,
    /// Measured replicates per row.
    pub n: Vec<usize>,
    /// Each row's own seed-to-seed variance sᵢ², deg² (`None` with fewer
    /// than two measured seeds).
    pub sample_var: Vec<Option<f64>>,
    /// Noise variance of each mean, deg²: the row's seed-to-seed variance
    /// ([`RowNoise::seed_var`]) over nᵢ.
    pub noise_var: Vec<f64>,
}

/// Which seed-to-seed variance the rows' noise comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseModel {
    /// One variance σ², pooled over every replicated point, for every row.
    Pooled,
    /// Each row's own variance shrunk towards σ² (homogeneity rejected).
    PerPoint,
}

/// Bartlett's test of the replicated points' variances, as recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HomogeneityTest {
    /// The test: `bartlett`.
    pub test: String,
    /// Points tested: those with two or more measured seeds.
    pub points: usize,
    /// Bartlett's T (dimensionless); `None` when infinite (a point's seeds
    /// gave equal values while others' differ), which JSON cannot hold.
    pub statistic: Option<f64>,
    /// Degrees of freedom of its χ² reference (points − 1).
    pub df: usize,
    /// Its p-value.
    pub p: f64,
    /// The level it is judged at ([`HOMOGENEITY_ALPHA`]).
    pub alpha: f64,
}

/// How the rows' noise variances were set (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RowNoise {
    /// Pooled or per point.
    pub model: NoiseModel,
    /// Pooled seed-to-seed variance σ², deg².
    pub pooled_variance_deg2: f64,
    /// Its degrees of freedom, Σ(nᵢ − 1).
    pub pooled_df: usize,
    /// The homogeneity test (`None` when fewer than two points have two
    /// measured seeds, or every such point's seeds agree exactly: nothing
    /// to compare).
    pub homogeneity: Option<HomogeneityTest>,
    /// ν₀ of the shrinkage when per point ([`PRIOR_DF`]); `None` when
    /// pooled.
    pub prior_df: Option<f64>,
}

impl RowNoise {
    /// Decides the noise model from the simulated points (see the module
    /// docs); `None` when no point has two measured seeds (σ² unknown).
    pub fn of(points: &[&Replicated]) -> Option<Self> {
        let (sigma2, df) = pooled_variance(points)?;
        let groups: Vec<Vec<f64>> = points
            .iter()
            .map(|p| p.values())
            .filter(|v| v.len() >= 2)
            .collect();
        // Every group has two finite values; the one refusal left is
        // "every group constant", which leaves nothing to test.
        let test = (groups.len() >= 2)
            .then(|| bartlett(&groups).ok())
            .flatten()
            .map(|b| HomogeneityTest {
                test: "bartlett".to_string(),
                points: groups.len(),
                statistic: b.statistic.is_finite().then_some(b.statistic),
                df: b.df,
                p: b.p,
                alpha: HOMOGENEITY_ALPHA,
            });
        let per_point = test.as_ref().is_some_and(|t| t.p < HOMOGENEITY_ALPHA);
        Some(Self {
            model: if per_point {
                NoiseModel::PerPoint
            } else {
                NoiseModel::Pooled
            },
            pooled_variance_deg2: sigma2,
            pooled_df: df,
            homogeneity: test,
            prior_df: per_point.then_some(PRIOR_DF),
        })
    }

    /// The seed-to-seed variance (deg²) of a point with these measured
    /// values: σ² when pooled; (ν₀σ² + Σ(y − ȳ)²) / (ν₀ + n − 1) per point,
    /// which is σ² for a single value.
    pub fn seed_var(&self, values: &[f64]) -> f64 {
        match self.prior_df {
            Some(nu) if !values.is_empty() => {
                let n = values.len() as f64;
                let mean = values.iter().sum::<f64>() / n;
                let ss = values.iter().map(|y| (y - mean).powi(2)).sum::<f64>();
                (nu * self.pooled_variance_deg2 + ss) / (nu + n - 1.0)
            }
            _ => self.pooled_variance_deg2,
        }
    }

    /// The noise variance (deg²) of the mean of these measured values (at
    /// least one): [`Self::seed_var`] over their number.
    pub fn mean_var(&self, values: &[f64]) -> f64 {
        self.seed_var(values) / values.len() as f64
    }
}

/// The fitted GP as the search rebuilds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GpModel {
    /// Where the rows' noise variances come from.
    pub noise: RowNoise,
    /// Constant mean, degrees.
    pub mean_deg: f64,
    /// Signal variance, deg².
    pub signal_var: f64,
    /// Length scales in the unit cube, one per parameter.
    pub length_scales: Vec<f64>,
    /// Nugget, deg²: 0, none is fitted on top of the replicates' noise.
    pub nugget_var: f64,
    /// Log marginal likelihood at the fit.
    pub log_marginal_likelihood: f64,
    /// The rows it was fitted to.
    pub data: GpData,
    /// Every parameter's main effect under this GP against one run's σ, and
    /// which the search varies ([`crate::search::screen`]; empty in a file
    /// written before screening existed: every parameter is searched).
    #[serde(default)]
    pub screening: Vec<MainEffect>,
}

impl GpModel {
    /// The GP itself.
    pub fn process(&self) -> Result<GaussianProcess, StudyError> {
        let hyper = GpHyper {
            signal_var: self.signal_var,
            length_scales: self.length_scales.clone(),
            nugget_var: self.nugget_var,
            mean: self.mean_deg,
        };
        GaussianProcess::with_hyper(
            &self.data.x_unit,
            &self.data.y,
            &self.data.noise_var,
            &hyper,
        )
        .map_err(|e| StudyError::Settings(format!("gp: {e}")))
    }
}

/// Validation metrics of one surrogate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SurrogateMetrics {
    /// `gp` or `ga_bp`.
    pub surrogate: String,
    /// Training rows.
    pub train_rows: usize,
    /// Validation rows.
    pub validation_rows: usize,
    /// R² on the validation means (Eq. 7).
    pub validation_r2: Option<f64>,
    /// RMSE on the validation means, degrees.
    pub validation_rmse_deg: Option<f64>,
    /// Fraction of validation means inside their 95 % predictive interval.
    pub interval_coverage: Option<f64>,
    /// What the validation means' own noise allows: the R² ceiling, the RMSE
    /// floor and the signal-to-noise ratio ([`NoiseCeiling`]).
    #[serde(default)]
    pub noise: Option<NoiseCeiling>,
}

/// What the GP training did.
#[derive(Debug, Clone)]
pub struct GpOutcome {
    /// The model fitted to every row.
    pub model: GpModel,
    /// GP and network validation metrics.
    pub metrics: Vec<SurrogateMetrics>,
    /// The Markdown report (also `train/surrogates.md`).
    pub markdown: String,
}

/// Simulated points by source (`design`, `noise`, `adaptive`).
type Sourced = Vec<(String, Replicated)>;

/// A predictor of the angle (degrees) at a physical point.
pub type Predictor<'a> = &'a dyn Fn(&[f64]) -> f64;

/// Reads every replicates table the study has, with the files read.
fn gather(dir: &StudyDir, study: &Study) -> Result<(Sourced, Vec<PathBuf>), StudyError> {
    let design_file = dir.require(dir.replicates_path(), Stage::Batch)?;
    let mut rows: Vec<(String, Replicated)> = read_replicates_csv(&design_file, study)?
        .into_iter()
        .map(|r| ("design".to_string(), r))
        .collect();
    let mut files = vec![design_file];
    for (source, path) in [
        ("noise", dir.noise_runs_path()),
        ("adaptive", dir.adaptive_path()),
    ] {
        if path.is_file() {
            rows.extend(
                read_replicates_csv(&path, study)?
                    .into_iter()
                    .map(|r| (source.to_string(), r)),
            );
            files.push(path);
        }
    }
    Ok((rows, files))
}

fn data_of(study: &Study, rows: &[&(String, Replicated)], noise: &RowNoise) -> GpData {
    let mut d = GpData {
        source: Vec::new(),
        index: Vec::new(),
        x_unit: Vec::new(),
        y: Vec::new(),
        n: Vec::new(),
        sample_var: Vec::new(),
        noise_var: Vec::new(),
    };
    for (source, r) in rows {
        let Some(mean) = r.mean() else { continue };
        let values = r.values();
        d.source.push(source.clone());
        d.index.push(r.index);
        d.x_unit.push(to_unit(study, &r.point));
        d.y.push(mean);
        d.n.push(values.len());
        d.sample_var.push(r.summary().map(|s| s.std * s.std));
        d.noise_var.push(noise.mean_var(&values));
    }
    d
}

/// Fits the GP to the rows with their noise variances and no nugget (see
/// the module docs).
fn fit(data: &GpData, seed: u64) -> Result<GaussianProcess, StudyError> {
    let settings = GpSettings {
        seed,
        fit_nugget: false,
        ..GpSettings::default()
    };
    GaussianProcess::fit(&data.x_unit, &data.y, &data.noise_var, &settings)
        .map_err(|e| StudyError::Settings(format!("gp: {e}")))
}

fn metrics(
    name: &str,
    train_rows: usize,
    observed: &[f64],
    noise_vars: &[f64],
    predicted: &[f64],
    half_widths: &[f64],
) -> SurrogateMetrics {
    let inside = observed
        .iter()
        .zip(predicted)
        .zip(half_widths)
        .filter(|((o, p), h)| (*o - *p).abs() <= **h)
        .count();
    let some = !observed.is_empty();
    SurrogateMetrics {
        surrogate: name.to_string(),
        train_rows,
        validation_rows: observed.len(),
        validation_r2: r_squared(observed, predicted),
        validation_rmse_deg: some.then(|| mse(observed, predicted).sqrt()),
        interval_coverage: some.then(|| inside as f64 / observed.len() as f64),
        noise: noise_ceiling(observed, noise_vars),
    }
}

/// The GP fitted to every row the study has simulated so far (design,
/// noise floor, adaptive points), without writing anything: the adaptive
/// stage refits it after every batch.
pub fn fit_model(dir: &StudyDir, study: &Study, seed: u64) -> Result<GpModel, StudyError> {
    let (rows, _) = gather(dir, study)?;
    let all: Vec<&(String, Replicated)> = rows.iter().collect();
    let noise = row_noise(&all)?;
    let data = data_of(study, &all, &noise);
    let gp = fit(&data, seed)?;
    Ok(model_of(&gp, noise, data))
}

fn row_noise(all: &[&(String, Replicated)]) -> Result<RowNoise, StudyError> {
    RowNoise::of(&all.iter().map(|r| &r.1).collect::<Vec<_>>()).ok_or_else(|| {
        StudyError::Settings(
            "gp: no point has two measured replicates, so the seed-to-seed variance is \
             unknown: run the noise floor (`repose noise`) or use replicates >= 2"
                .into(),
        )
    })
}

fn model_of(gp: &GaussianProcess, noise: RowNoise, data: GpData) -> GpModel {
    let h = gp.hyper();
    GpModel {
        noise,
        mean_deg: h.mean,
        signal_var: h.signal_var,
        length_scales: h.length_scales.clone(),
        nugget_var: h.nugget_var,
        log_marginal_likelihood: gp.log_marginal_likelihood(),
        data,
        screening: Vec::new(),
    }
}

/// Fits the GP, validates both surrogates and writes `train/gp.json`,
/// `train/surrogates.csv` and `.md` (see the module docs). `network`
/// predicts with he2019's kept network when the train stage has written one.
pub fn train_gp(
    dir: &StudyDir,
    study: &Study,
    train_fraction: f64,
    seed: u64,
    network: Option<Predictor>,
) -> Result<GpOutcome, StudyError> {
    let (rows, files) = gather(dir, study)?;
    let all: Vec<&(String, Replicated)> = rows.iter().collect();
    let noise = row_noise(&all)?;
    let (train, validation) = split(&rows, train_fraction);
    let train_data = data_of(study, &train, &noise);
    let val_data = data_of(study, &validation, &noise);
    let mut table = vec![validate_gp("gp", &train_data, &val_data, seed)?];
    if let Some(net) = network {
        table.push(validate_network(net, &train, &validation, &noise));
    }
    let data = data_of(study, &all, &noise);
    let full = fit(&data, seed)?;
    let screening = screen(study, &full, noise.pooled_variance_deg2.sqrt(), seed);
    if screening.iter().any(|e| !e.active) {
        // The same validation with the screened parameters dropped from the
        // GP's inputs: the same rows, so R² before and after screening are
        // read at equal run counts.
        let keep = |d: &GpData| GpData {
            x_unit: d
                .x_unit
                .iter()
                .map(|x| active_inputs(x, &screening))
                .collect(),
            ..d.clone()
        };
        let (t, v) = (keep(&train_data), keep(&val_data));
        table.push(validate_gp("gp_screened", &t, &v, seed)?);
    }
    let mut model = model_of(&full, noise, data);
    model.screening = screening;
    let mut markdown = markdown(study, &model, &table);
    let screen_on = study.noise_aware.as_ref().is_some_and(|n| n.screen);
    markdown.push_str(&screening_markdown(
        &model.screening,
        model.noise.pooled_variance_deg2.sqrt(),
        screen_on,
    ));
    let outcome = GpOutcome {
        model,
        metrics: table,
        markdown,
    };
    write_outputs(dir, study, (train_fraction, seed), &files, &outcome)?;
    Ok(outcome)
}

/// Some of the simulated points, with their source.
type Rows<'a> = Vec<&'a (String, Replicated)>;

/// The training and validation rows: the first `train_fraction` of the
/// design rows train, the rest validate; every other row trains.
fn split(rows: &[(String, Replicated)], train_fraction: f64) -> (Rows<'_>, Rows<'_>) {
    let design_rows = rows.iter().filter(|r| r.0 == "design").count();
    let cut = (design_rows as f64 * train_fraction).round() as usize;
    let mut seen = 0usize;
    let (mut train, mut validation) = (Vec::new(), Vec::new());
    for r in rows {
        if r.0 == "design" {
            if seen < cut {
                train.push(r);
            } else {
                validation.push(r);
            }
            seen += 1;
        } else {
            train.push(r);
        }
    }
    (train, validation)
}

/// The metrics of a GP fitted to `train` predicting the means of
/// `validation`, with 95 % intervals of the latent and the row's noise
/// variance.
fn validate_gp(
    name: &str,
    train: &GpData,
    validation: &GpData,
    seed: u64,
) -> Result<SurrogateMetrics, StudyError> {
    let gp = fit(train, seed)?;
    let (mut pred, mut half) = (Vec::new(), Vec::new());
    for (x, nv) in validation.x_unit.iter().zip(&validation.noise_var) {
        let p = gp.predict(x);
        pred.push(p.mean);
        half.push(Z95 * gp.observation_sd(&p, *nv));
    }
    Ok(metrics(
        name,
        train.y.len(),
        &validation.y,
        &validation.noise_var,
        &pred,
        &half,
    ))
}

/// The metrics of he2019's network `net` predicting the validation rows'
/// means, its interval ± 1.96 × its RMSE on its own (design) training rows.
fn validate_network(
    net: Predictor,
    train: &[&(String, Replicated)],
    validation: &[&(String, Replicated)],
    noise: &RowNoise,
) -> SurrogateMetrics {
    let fitted: Vec<(f64, f64)> = train
        .iter()
        .filter(|r| r.0 == "design")
        .filter_map(|r| r.1.mean().map(|m| (m, net(&r.1.point))))
        .collect();
    let (obs, pred): (Vec<f64>, Vec<f64>) = fitted.into_iter().unzip();
    let train_rmse = if obs.is_empty() {
        0.0
    } else {
        mse(&obs, &pred).sqrt()
    };
    let mut v_obs = Vec::new();
    let mut v_noise = Vec::new();
    let mut v_pred = Vec::new();
    for r in validation {
        if let Some(m) = r.1.mean() {
            v_obs.push(m);
            v_noise.push(noise.mean_var(&r.1.values()));
            v_pred.push(net(&r.1.point));
        }
    }
    let half = vec![Z95 * train_rmse; v_obs.len()];
    metrics("ga_bp", obs.len(), &v_obs, &v_noise, &v_pred, &half)
}

/// Writes the train stage's GP outputs with their lineage (the settings
/// `(train_fraction, seed)` and every replicates file read): `screening.csv`,
/// `surrogates.md`, `surrogates.json` and `gp.json`.
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    (train_fraction, seed): (f64, u64),
    files: &[PathBuf],
    outcome: &GpOutcome,
) -> Result<(), StudyError> {
    dir.prepare_stage(study, Stage::Train)?;
    let mut lineage = dir.lineage(
        Stage::Train,
        json!({ "surrogate": "gp", "kernel": "matern_5_2_ard", "train_fraction": train_fraction,
                "seed": seed, "noise": "seed variance / n: pooled, or per point shrunk towards the pooled \
                 when Bartlett's test rejects homogeneity; no nugget",
                "homogeneity_alpha": HOMOGENEITY_ALPHA, "prior_df": PRIOR_DF }),
    );
    for f in files {
        lineage = lineage.with_input(dir.input("replicates", f)?);
    }
    let out = dir.stage(Stage::Train);
    write_output(
        &out.join("screening.csv"),
        screening_csv(&outcome.model.screening).as_bytes(),
        &lineage,
    )?;
    write_output(
        &out.join("surrogates.md"),
        outcome.markdown.as_bytes(),
        &lineage,
    )?;
    write_output(
        &out.join("surrogates.json"),
        &json_bytes(&outcome.metrics),
        &lineage,
    )?;
    write_output(&dir.gp_path(), &json_bytes(&outcome.model), &lineage)
}

/// Points of the cube (the search stream's sub-stream 2 of the training
/// seed) over which the screening's main effects are averaged.
pub const SCREEN_POINTS: usize = 256;

/// The main effects of `gp`'s mean against one run's σ `noise_sd` (deg),
/// screening when the study asks ([`crate::search::screen`]).
fn screen(study: &Study, gp: &GaussianProcess, noise_sd: f64, seed: u64) -> Vec<MainEffect> {
    let names = crate::study::plan::calibration::parameter_names(study);
    let others = resample(SCREEN_POINTS, names.len(), Placement::Random, seed, 2);
    let on = study.noise_aware.as_ref().is_some_and(|n| n.screen);
    main_effects(&names, |u| gp.predict(u).mean, &others, noise_sd, on)
}

/// The coordinates of `x` whose parameter the screening keeps.
fn active_inputs(x: &[f64], effects: &[MainEffect]) -> Vec<f64> {
    x.iter()
        .zip(effects)
        .filter(|(_, e)| e.active)
        .map(|(v, _)| *v)
        .collect()
}

/// `train/screening.csv`: one row per parameter.
fn screening_csv(effects: &[MainEffect]) -> String {
    let mut csv = CsvWriter::new(&[
        "parameter",
        "main_effect_range_deg",
        "argmax_unit",
        "above_noise",
        "searched",
    ]);
    for e in effects {
        csv.row(&[
            Cell::Text(e.parameter.clone()),
            Cell::Number(e.range),
            Cell::Number(e.argmax_unit),
            Cell::Text(e.above_noise.to_string()),
            Cell::Text(e.active.to_string()),
        ]);
    }
    csv.finish()
}

/// The screening section of `train/surrogates.md`.
fn screening_markdown(effects: &[MainEffect], noise_sd: f64, screen: bool) -> String {
    let mut t = MarkdownTable::new(&[
        "parameter",
        "main-effect range (°)",
        "largest at (unit)",
        "above σ",
        "searched",
    ]);
    for e in effects {
        t.row(&[
            e.parameter.clone(),
            format!("{:.2}", e.range),
            format!("{:.1}", e.argmax_unit),
            if e.above_noise { "yes" } else { "no" }.into(),
            if e.active { "yes" } else { "no (centre)" }.into(),
        ]);
    }
    let mut out = format!(
        "\n## Screening\n\nMain effect of each parameter under the GP fitted to every row (the \
         predicted angle averaged over the other parameters, over the parameter's whole range) \
         against one run's seed-to-seed σ = {noise_sd:.2}° (pooled over the replicated \
         points):\n\n"
    );
    out.push_str(&t.render());
    let fixed: Vec<&str> = effects
        .iter()
        .filter(|e| !e.active)
        .map(|e| e.parameter.as_str())
        .collect();
    let below: Vec<&str> = effects
        .iter()
        .filter(|e| !e.above_noise)
        .map(|e| e.parameter.as_str())
        .collect();
    let _ = if !screen {
        writeln!(
            out,
            "\nNot screened (`noise_aware.screen` is off): the search varies every parameter{}.",
            if below.is_empty() {
                String::new()
            } else {
                format!("; below the noise: {}", below.join(", "))
            }
        )
    } else if fixed.is_empty() {
        writeln!(
            out,
            "\nEvery parameter moves the angle by more than σ over its range: none is fixed."
        )
    } else {
        writeln!(
            out,
            "\nFixed at the centre of their ranges by the search (their whole range moves the \
             predicted angle by less than one run's σ, so these runs cannot calibrate them): {}. \
             `gp_screened` above is the GP validated on the same rows without them.{}",
            fixed.join(", "),
            if effects.iter().any(|e| e.active && !e.above_noise) {
                " No parameter beats the noise; the largest effect is searched alone."
            } else {
                ""
            }
        )
    };
    out
}

/// What the noise of the validation means allows, in words (see
/// [`crate::stats::metrics`]): the ceiling, the signal-to-noise ratio, the
/// seeds per point that would lift the ceiling to 0.9 (when it is below), and which surrogates
/// do not beat the validation targets' mean.
fn noise_sentence(n: &NoiseCeiling, sigma2: f64, metrics: &[SurrogateMetrics]) -> String {
    let mut out = format!(
        "\nThe validation means carry their own noise (σ²/k = {:.2} deg², signal S² ≈ {:.2} \
         deg² across them, S/N {:.2}): a perfect model scores R² ≈ {:.2} and RMSE ≈ {:.2}° \
         against them. ",
        n.noise_var, n.signal_var, n.signal_to_noise, n.r2_ceiling, n.rmse_floor
    );
    if n.r2_ceiling >= 0.9 {
        out.push_str("The ceiling is above 0.9 already.");
    } else {
        match seeds_for_ceiling(n.signal_var, sigma2, 0.9) {
            Some(k) => out.push_str(&format!(
                "{k} seeds per point would lift the ceiling to 0.9."
            )),
            None => out.push_str(
                "No signal stands above the noise across these points: no seed count lifts \
                 the ceiling; the parameters' effects here are below the noise.",
            ),
        }
    }
    let below: Vec<&str> = metrics
        .iter()
        .filter(|s| s.validation_r2.is_some_and(|r| r < 0.0))
        .map(|s| s.surrogate.as_str())
        .collect();
    if !below.is_empty() {
        out.push_str(&format!(
            " {} do(es) not beat the validation targets' mean (R² < 0).",
            below.join(" and ")
        ));
    }
    out.push('\n');
    out
}

/// Reads `train/gp.json`.
pub fn read_gp(dir: &StudyDir) -> Result<GpModel, StudyError> {
    let path = dir.require(dir.gp_path(), Stage::Train)?;
    Store::read_json(&path).map_err(|e| StudyError::Inconsistent {
        path,
        message: format!("{e}: rerun `repose train`"),
    })
}

fn markdown(study: &Study, m: &GpModel, metrics: &[SurrogateMetrics]) -> String {
    let f = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
    let mut t = MarkdownTable::new(&[
        "surrogate",
        "train rows",
        "validation rows",
        "validation R²",
        "R² ceiling (noise)",
        "RMSE (°)",
        "RMSE floor σ/√k (°)",
        "inside 95 % interval",
    ]);
    for s in metrics {
        t.row(&[
            s.surrogate.clone(),
            s.train_rows.to_string(),
            s.validation_rows.to_string(),
            f(s.validation_r2, 3),
            f(s.noise.map(|n| n.r2_ceiling), 3),
            f(s.validation_rmse_deg, 2),
            f(s.noise.map(|n| n.rmse_floor), 2),
            s.interval_coverage
                .map_or("—".into(), |c| format!("{:.0} %", 100.0 * c)),
        ]);
    }
    let mut out = t.render();
    if let Some(n) = metrics.first().and_then(|s| s.noise) {
        out.push_str(&noise_sentence(&n, m.noise.pooled_variance_deg2, metrics));
    }
    let names = crate::study::plan::calibration::parameter_names(study);
    let _ = writeln!(
        out,
        "\nGP (Matérn 5/2, fitted to all {} rows, no nugget): mean {:.2}°, signal σ {:.2}°; \
         length scales (unit cube): {}.",
        m.data.y.len(),
        m.mean_deg,
        m.signal_var.sqrt(),
        names
            .iter()
            .zip(&m.length_scales)
            .map(|(n, l)| format!("{n} {l:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    out.push_str(&noise_paragraph(&m.noise));
    out.push_str(&row_table(&m.data));
    out
}

/// The noise model in words: the pooled σ², the homogeneity test and which
/// variance the rows carry.
fn noise_paragraph(noise: &RowNoise) -> String {
    let mut out = format!(
        "\nNoise of the rows: seed-to-seed σ {:.2}° pooled over the replicated points ({} df). ",
        noise.pooled_variance_deg2.sqrt(),
        noise.pooled_df
    );
    match &noise.homogeneity {
        Some(t) => {
            let statistic = t.statistic.map_or("∞".to_string(), |v| format!("{v:.2}"));
            let _ = write!(
                out,
                "Bartlett's test of equal variances over {} points: T = {statistic}, \
                 χ²({}) p = {:.3} ",
                t.points, t.df, t.p
            );
            let _ = write!(
                out,
                "{} α = {}: {}",
                if t.p < t.alpha { "<" } else { "≥" },
                t.alpha,
                match noise.model {
                    NoiseModel::PerPoint => "the spread varies between points, ",
                    NoiseModel::Pooled => "no evidence that the spread varies, ",
                }
            );
        }
        None => out.push_str("Too few varying replicated points to test homogeneity: "),
    }
    match noise.prior_df {
        Some(nu) => {
            let _ = write!(
                out,
                "so each row's variance is its own shrunk towards the pooled one \
                 ((ν₀σ² + (n − 1)s²)/(ν₀ + n − 1), ν₀ = {nu}), over its n seeds."
            );
        }
        None => out.push_str("so every row's noise is the pooled σ² over its n seeds."),
    }
    out.push('\n');
    out
}

/// One line per row: its source, index, seeds, own variance and the noise
/// variance of its mean.
fn row_table(data: &GpData) -> String {
    let mut t = MarkdownTable::new(&[
        "source",
        "index",
        "seeds",
        "own s² (deg²)",
        "noise of the mean (deg²)",
    ]);
    for i in 0..data.y.len() {
        t.row(&[
            data.source[i].clone(),
            data.index[i].to_string(),
            data.n[i].to_string(),
            data.sample_var[i].map_or("—".to_string(), |v| format!("{v:.3}")),
            format!("{:.4}", data.noise_var[i]),
        ]);
    }
    format!("\n{}", t.render())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::ContentId;
    use crate::stats::assert_rel_within;
    use crate::study::runs::replicated::SeedRun;

    /// A point whose seeds measured `values` (`None`: the seed failed).
    fn point(index: u64, values: &[Option<f64>]) -> Replicated {
        Replicated {
            index,
            point: vec![0.5],
            runs: values
                .iter()
                .enumerate()
                .map(|(r, v)| SeedRun {
                    replicate: r as u32,
                    id: ContentId::of_bytes(format!("{index}/{r}").as_bytes()),
                    value: v.ok_or_else(|| "failed".to_string()),
                })
                .collect(),
        }
    }

    /// Six two-seed design points with the fifth's seeds `fifth`, the
    /// 8-seed centre, and a point whose second seed failed.
    fn table(fifth: [f64; 2]) -> Vec<Replicated> {
        let pairs = [
            [33.1, 33.9],
            [35.2, 34.6],
            [31.0, 31.4],
            [36.8, 35.9],
            fifth,
            [32.5, 32.2],
        ];
        let mut rows: Vec<Replicated> = pairs
            .iter()
            .enumerate()
            .map(|(i, p)| point(i as u64, &[Some(p[0]), Some(p[1])]))
            .collect();
        let centre = [39.3, 39.0, 40.1, 39.6, 38.8, 39.9, 39.2, 40.4];
        rows.push(point(
            100,
            &centre.iter().map(|v| Some(*v)).collect::<Vec<_>>(),
        ));
        rows.push(point(7, &[Some(34.0), None]));
        rows
    }

    fn decide(rows: &[Replicated]) -> RowNoise {
        RowNoise::of(&rows.iter().collect::<Vec<_>>()).unwrap()
    }

    #[test]
    fn a_far_noisier_point_makes_the_noise_per_point() {
        // Reference (scipy 1.17.1, numpy), fifth point [28.4, 36.6]:
        // g = [[33.1,33.9],[35.2,34.6],[31.0,31.4],[36.8,35.9],[28.4,36.6],
        //      [32.5,32.2],[39.3,39.0,40.1,39.6,38.8,39.9,39.2,40.4]]
        // scipy.stats.bartlett(*g) -> 20.583668632382555, 0.0021787376733188265
        // df = [len(a)-1 for a in g]; ss = [sum((a-mean(a))**2) for a in g]
        // pooled = sum(ss)/sum(df)          -> 2.8345192307692333 (13 df)
        // (2*pooled + ss)/(2 + df)          -> fifth 13.096346153846165,
        //                                      centre 0.8741987179487187
        // ... / len(a)                      -> fifth 6.548173076923082
        let rows = table([28.4, 36.6]);
        let noise = decide(&rows);
        assert_eq!(noise.model, NoiseModel::PerPoint);
        assert_eq!(noise.prior_df, Some(PRIOR_DF));
        assert_eq!(noise.pooled_df, 13);
        let t = noise.homogeneity.clone().unwrap();
        assert_eq!((t.test.as_str(), t.points, t.df), ("bartlett", 7, 6));
        assert_rel_within(
            "T, p, pooled",
            &[t.statistic.unwrap(), t.p, noise.pooled_variance_deg2],
            &[
                20.583668632382555,
                0.0021787376733188265,
                2.8345192307692333,
            ],
            1e-9,
        );
        let centre = rows[6].values();
        assert_rel_within(
            "shrunk variances",
            &[
                noise.seed_var(&rows[4].values()),
                noise.mean_var(&rows[4].values()),
                noise.seed_var(&centre),
            ],
            &[13.096346153846165, 6.548173076923082, 0.8741987179487187],
            1e-12,
        );
        // A point with one measured seed carries the pooled variance.
        assert_eq!(
            noise.mean_var(&rows[7].values()),
            noise.pooled_variance_deg2
        );
    }

    #[test]
    fn a_homogeneous_table_keeps_the_pooled_variance() {
        // The fifth point [32.6, 33.3]:
        // scipy.stats.bartlett(*g) -> 1.3023796556500624, 0.9715263230844103
        // pooled = sum(ss)/sum(df)  -> 0.26721153846153806
        let rows = table([32.6, 33.3]);
        let noise = decide(&rows);
        assert_eq!(noise.model, NoiseModel::Pooled);
        assert_eq!(noise.prior_df, None);
        let t = noise.homogeneity.clone().unwrap();
        assert_rel_within(
            "T, p, pooled",
            &[t.statistic.unwrap(), t.p, noise.pooled_variance_deg2],
            &[1.3023796556500624, 0.9715263230844103, 0.26721153846153806],
            1e-9,
        );
        for r in &rows {
            let v = r.values();
            assert_eq!(
                noise.mean_var(&v),
                noise.pooled_variance_deg2 / v.len() as f64
            );
        }
    }

    #[test]
    fn what_cannot_be_tested_stays_pooled() {
        // One replicated point: nothing to compare it with.
        let rows = vec![point(0, &[Some(30.0), Some(31.0)]), point(1, &[Some(33.0)])];
        let noise = decide(&rows);
        assert_eq!(
            (noise.model, noise.homogeneity.clone()),
            (NoiseModel::Pooled, None)
        );
        assert_eq!(noise.pooled_variance_deg2, 0.5);
        // Every replicated point's seeds agree: no variance to compare.
        let rows = vec![
            point(0, &[Some(30.0), Some(30.0)]),
            point(1, &[Some(33.0), Some(33.0)]),
        ];
        assert_eq!(decide(&rows).homogeneity, None);
        // No replicated point: σ² unknown.
        assert_eq!(RowNoise::of(&[&point(0, &[Some(30.0), None])]), None);
    }

    #[test]
    fn seeds_that_agree_exactly_beside_varying_ones_reject_homogeneity() {
        // scipy.stats.bartlett([1., 2.], [3., 3.], [4., 6.]) -> inf, 0.0
        let rows = vec![
            point(0, &[Some(1.0), Some(2.0)]),
            point(1, &[Some(3.0), Some(3.0)]),
            point(2, &[Some(4.0), Some(6.0)]),
        ];
        let noise = decide(&rows);
        let t = noise.homogeneity.clone().unwrap();
        assert_eq!((t.statistic, t.p), (None, 0.0));
        assert_eq!(noise.model, NoiseModel::PerPoint);
        // σ² = 2.5/3; the agreeing point keeps 2σ²/3 = 5/9.
        assert_rel_within(
            "floor",
            &[noise.seed_var(&rows[1].values())],
            &[5.0 / 9.0],
            1e-12,
        );
        // The record survives JSON (an infinite T would not).
        let text = serde_json::to_string(&noise).unwrap();
        assert_eq!(serde_json::from_str::<RowNoise>(&text).unwrap(), noise);
        assert!(text.contains("\"model\":\"per_point\""), "{text}");
    }
}
