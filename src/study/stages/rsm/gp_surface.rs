//! The Gaussian-process alternative of the response-surface stage
//! (`fit: "gp"` in a design study): each response's replicate values over
//! the coded design (every factor on [−1, 1]) fitted by
//! [`crate::surrogate::gp::Gp`] through the [`Surrogate`] trait, with a
//! fitted nugget as its noise (a replicate's own value is one draw). The
//! desirability search and the verification then use the GP's mean as they
//! use a quadratic's prediction. A GP has no ANOVA: its report is its
//! hyperparameters — the length scale of each factor in coded units says how
//! far that factor must move for the response to change (a length scale far
//! beyond 2, the width of the coded range, says the factor hardly matters) —
//! and the GP mean at the design points against the simulated values.

use serde::Serialize;

use crate::stats::gp::GpSettings;
use crate::study::StudyError;
use crate::surrogate::gp::Gp;
use crate::surrogate::{Surrogate, Table};

/// One response's GP.
#[derive(Debug, Clone, Serialize)]
pub struct GpAnalysis {
    /// The response.
    pub response: String,
    /// Observations that entered the fit.
    pub observations: usize,
    /// Observations missing (failed or unmeasured runs).
    pub missing: usize,
    /// Signal variance σ_f² (units of the response squared).
    pub signal_var: f64,
    /// Length scale per factor, coded units (the range is 2 wide).
    pub length_scales: Vec<f64>,
    /// Nugget σ_n²: the noise variance of one observation (units squared).
    pub nugget_var: f64,
    /// Constant mean (units of the response).
    pub mean: f64,
    /// Log marginal likelihood at the fitted hyperparameters.
    pub log_marginal_likelihood: f64,
    /// GP mean at each observation's point, in observation order.
    pub fitted: Vec<f64>,
    /// The model (coded inputs).
    #[serde(skip)]
    pub model: Gp,
}

impl GpAnalysis {
    /// The GP mean at a coded point.
    pub fn predict(&self, coded: &[f64]) -> f64 {
        self.model.predict(coded).mean
    }
}

/// Fits `response`'s GP to coded rows `x` and values `y` (`missing` counts
/// the observations left out), its optimiser seeded by `seed`.
pub fn analyse_gp(
    response: &str,
    x: &[Vec<f64>],
    y: &[f64],
    names: &[String],
    missing: usize,
    seed: u64,
) -> Result<GpAnalysis, StudyError> {
    let coded = vec![(-1.0, 1.0); names.len()];
    let table = Table {
        names,
        ranges: &coded,
        x,
        y,
        noise_var: None,
    };
    let settings = GpSettings {
        seed,
        ..GpSettings::default()
    };
    let model = Gp::fit(&table, &settings).map_err(|e| StudyError::Analysis {
        response: response.into(),
        message: e.to_string(),
    })?;
    let hyper = model.process.hyper().clone();
    Ok(GpAnalysis {
        response: response.into(),
        observations: y.len(),
        missing,
        signal_var: hyper.signal_var,
        // The GP works on the unit cube; a coded unit is half the range.
        length_scales: hyper.length_scales.iter().map(|l| 2.0 * l).collect(),
        nugget_var: hyper.nugget_var,
        mean: hyper.mean,
        log_marginal_likelihood: model.process.log_marginal_likelihood(),
        fitted: x.iter().map(|r| model.predict(r).mean).collect(),
        model,
    })
}
