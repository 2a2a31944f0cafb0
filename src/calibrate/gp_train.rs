//! The Gaussian-process surrogate of a noise-aware study, beside he2019's
//! GA-BP network, and how well each predicts runs it has not seen.
//!
//! # Data
//!
//! One row per simulated point: the design rows (`batch/replicates.csv`),
//! the noise floor's centre (`noise/noise.csv`, if run) and the adaptive
//! points (`adaptive/replicates.csv`, if any), each with the mean of its
//! measured replicates (points without any are left out). The noise of a
//! row's mean is σ²/nᵢ, with σ² the seed-to-seed variance pooled over every
//! point with two or more measured seeds (a two-seed variance alone is too
//! noisy to trust per point); the GP fits a nugget on top for what the
//! replicates miss. Inputs are the parameters mapped onto the unit cube of
//! the study's ranges ([`crate::stats::gp`]).
//!
//! # Validation
//!
//! The design rows are split as the network's are (the first
//! `train_fraction` of the samples train, the rest validate); the centre and
//! the adaptive points always train. Each surrogate predicts the validation
//! rows' replicate means: R² (Eq. 7), RMSE, and the coverage of its 95 %
//! predictive intervals — the fraction of validation means inside them. The
//! GP's interval for a mean of nᵢ seeds is ± 1.96 √(latent variance +
//! nugget + σ²/nᵢ). The network gives no spread of its own: its interval is
//! ± 1.96 × its RMSE on its own training rows (near zero when it
//! interpolates them, which is what the coverage then shows).
//!
//! The GP used by the search is then fitted to every row (`train/gp.json`
//! keeps its data and hyperparameters, so the search rebuilds it exactly).

use std::fmt::Write as _;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use serde_json::json;

use super::batch::replicates_path;
use super::noise::noise_runs_path;
use super::replicates::{pooled_variance, read_replicates_csv, Replicated};
use super::{json_bytes, to_unit, write_output, Stage, StudyDir, StudyError};
use crate::manifest::Study;
use crate::report::markdown::MarkdownTable;
use crate::stats::gp::{GaussianProcess, GpHyper, GpSettings};
use crate::stats::metrics::{mse, noise_ceiling, r_squared, seeds_for_ceiling, NoiseCeiling};
use crate::store::Store;

/// z of a two-sided 95 % normal interval.
const Z95: f64 = 1.959_963_984_540_054;

/// `adaptive/replicates.csv`.
pub fn adaptive_path(dir: &StudyDir) -> PathBuf {
    dir.stage(Stage::Adaptive).join("replicates.csv")
}

/// `train/gp.json`.
pub fn gp_path(dir: &StudyDir) -> PathBuf {
    dir.stage(Stage::Train).join("gp.json")
}

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
    /// Noise variance of each mean, σ²/nᵢ, deg².
    pub noise_var: Vec<f64>,
}

/// The fitted GP as the search rebuilds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GpModel {
    /// Pooled seed-to-seed variance σ², deg².
    pub pooled_variance_deg2: f64,
    /// Its degrees of freedom.
    pub pooled_df: usize,
    /// Constant mean, degrees.
    pub mean_deg: f64,
    /// Signal variance, deg².
    pub signal_var: f64,
    /// Length scales in the unit cube, one per parameter.
    pub length_scales: Vec<f64>,
    /// Fitted nugget, deg².
    pub nugget_var: f64,
    /// Log marginal likelihood at the fit.
    pub log_marginal_likelihood: f64,
    /// The rows it was fitted to.
    pub data: GpData,
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
    let design_file = dir.require(replicates_path(dir), Stage::Batch)?;
    let mut rows: Vec<(String, Replicated)> = read_replicates_csv(&design_file, study)?
        .into_iter()
        .map(|r| ("design".to_string(), r))
        .collect();
    let mut files = vec![design_file];
    for (source, path) in [
        ("noise", noise_runs_path(dir)),
        ("adaptive", adaptive_path(dir)),
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

fn data_of(study: &Study, rows: &[&(String, Replicated)], sigma2: f64) -> GpData {
    let mut d = GpData {
        source: Vec::new(),
        index: Vec::new(),
        x_unit: Vec::new(),
        y: Vec::new(),
        n: Vec::new(),
        noise_var: Vec::new(),
    };
    for (source, r) in rows {
        let Some(mean) = r.mean() else { continue };
        let n = r.values().len();
        d.source.push(source.clone());
        d.index.push(r.index);
        d.x_unit.push(to_unit(study, &r.point));
        d.y.push(mean);
        d.n.push(n);
        d.noise_var.push(sigma2 / n as f64);
    }
    d
}

fn fit(data: &GpData, seed: u64) -> Result<GaussianProcess, StudyError> {
    let settings = GpSettings {
        seed,
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
    let (sigma2, df) = pooled(&all)?;
    let data = data_of(study, &all, sigma2);
    let gp = fit(&data, seed)?;
    Ok(model_of(&gp, sigma2, df, data))
}

fn pooled(all: &[&(String, Replicated)]) -> Result<(f64, usize), StudyError> {
    pooled_variance(&all.iter().map(|r| &r.1).collect::<Vec<_>>()).ok_or_else(|| {
        StudyError::Settings(
            "gp: no point has two measured replicates, so the seed-to-seed variance is \
             unknown: run the noise floor (`repose noise`) or use replicates >= 2"
                .into(),
        )
    })
}

fn model_of(gp: &GaussianProcess, sigma2: f64, df: usize, data: GpData) -> GpModel {
    let h = gp.hyper();
    GpModel {
        pooled_variance_deg2: sigma2,
        pooled_df: df,
        mean_deg: h.mean,
        signal_var: h.signal_var,
        length_scales: h.length_scales.clone(),
        nugget_var: h.nugget_var,
        log_marginal_likelihood: gp.log_marginal_likelihood(),
        data,
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
    let (sigma2, df) = pooled(&all)?;
    let design_rows = rows.iter().filter(|r| r.0 == "design").count();
    let cut = (design_rows as f64 * train_fraction).round() as usize;
    let mut seen = 0usize;
    let (mut train, mut validation) = (Vec::new(), Vec::new());
    for r in &rows {
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
    let train_data = data_of(study, &train, sigma2);
    let val_data = data_of(study, &validation, sigma2);
    let gp = fit(&train_data, seed)?;
    let mut gp_pred = Vec::new();
    let mut gp_half = Vec::new();
    for (x, nv) in val_data.x_unit.iter().zip(&val_data.noise_var) {
        let p = gp.predict(x);
        gp_pred.push(p.mean);
        gp_half.push(Z95 * gp.observation_sd(&p, *nv));
    }
    let mut table = vec![metrics(
        "gp",
        train_data.y.len(),
        &val_data.y,
        &val_data.noise_var,
        &gp_pred,
        &gp_half,
    )];
    if let Some(net) = network {
        let design_train: Vec<&&(String, Replicated)> =
            train.iter().filter(|r| r.0 == "design").collect();
        let fitted: Vec<(f64, f64)> = design_train
            .iter()
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
        for r in &validation {
            if let Some(m) = r.1.mean() {
                v_obs.push(m);
                v_noise.push(sigma2 / r.1.values().len() as f64);
                v_pred.push(net(&r.1.point));
            }
        }
        let half = vec![Z95 * train_rmse; v_obs.len()];
        table.push(metrics(
            "ga_bp",
            obs.len(),
            &v_obs,
            &v_noise,
            &v_pred,
            &half,
        ));
    }
    let data = data_of(study, &all, sigma2);
    let full = fit(&data, seed)?;
    let model = model_of(&full, sigma2, df, data);
    dir.prepare_stage(study, Stage::Train)?;
    let mut lineage = dir.lineage(
        Stage::Train,
        json!({ "surrogate": "gp", "kernel": "matern_5_2_ard", "train_fraction": train_fraction,
                "seed": seed, "noise": "pooled seed variance / n plus a fitted nugget" }),
    );
    for f in &files {
        lineage = lineage.with_input(dir.input("replicates", f)?);
    }
    let markdown = markdown(study, &model, &table);
    let out = dir.stage(Stage::Train);
    write_output(&out.join("surrogates.md"), markdown.as_bytes(), &lineage)?;
    write_output(&out.join("surrogates.json"), &json_bytes(&table), &lineage)?;
    write_output(&gp_path(dir), &json_bytes(&model), &lineage)?;
    Ok(GpOutcome {
        model,
        metrics: table,
        markdown,
    })
}

/// What the noise of the validation means allows, in words (see
/// [`crate::stats::metrics`]): the ceiling, the signal-to-noise ratio, the
/// seeds per point that would lift the ceiling to 0.9, and which surrogates
/// do not beat the validation targets' mean.
fn noise_sentence(n: &NoiseCeiling, sigma2: f64, metrics: &[SurrogateMetrics]) -> String {
    let mut out = format!(
        "\nThe validation means carry their own noise (σ²/k = {:.2} deg², signal S² ≈ {:.2} \
         deg² across them, S/N {:.2}): a perfect model scores R² ≈ {:.2} and RMSE ≈ {:.2}° \
         against them. ",
        n.noise_var, n.signal_var, n.signal_to_noise, n.r2_ceiling, n.rmse_floor
    );
    match seeds_for_ceiling(n.signal_var, sigma2, 0.9) {
        Some(k) => out.push_str(&format!(
            "{k} seeds per point would lift the ceiling to 0.9."
        )),
        None => out.push_str(
            "No signal stands above the noise across these points: no seed count lifts \
             the ceiling; the parameters' effects here are below the noise.",
        ),
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
    let path = dir.require(gp_path(dir), Stage::Train)?;
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
        out.push_str(&noise_sentence(&n, m.pooled_variance_deg2, metrics));
    }
    let names = super::parameter_names(study);
    let _ = writeln!(
        out,
        "\nGP (Matérn 5/2, fitted to all {} rows): mean {:.2}°, signal σ {:.2}°, nugget σ {:.2}°, \
         seed-to-seed σ {:.2}° (pooled, {} df); length scales (unit cube): {}.",
        m.data.y.len(),
        m.mean_deg,
        m.signal_var.sqrt(),
        m.nugget_var.sqrt(),
        m.pooled_variance_deg2.sqrt(),
        m.pooled_df,
        names
            .iter()
            .zip(&m.length_scales)
            .map(|(n, l)| format!("{n} {l:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    out
}
