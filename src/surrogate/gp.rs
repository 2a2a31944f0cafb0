//! The Gaussian process as a [`Surrogate`]: inputs mapped onto the unit cube
//! of their ranges, each point's known noise variance taken from the table
//! (zero when the table has none, so the fitted nugget carries the noise),
//! hyperparameters by maximum marginal likelihood ([`GaussianProcess::fit`]).
//! The predicted sd is the latent one: the uncertainty of the mean response,
//! not of one more noisy run.

use super::{to_unit, Prediction, Surrogate, SurrogateError, Table};
use crate::stats::gp::{GaussianProcess, GpSettings};

/// A fitted Gaussian process with the ranges that scale its inputs.
#[derive(Debug, Clone)]
pub struct Gp {
    /// The process, on unit-cube inputs.
    pub process: GaussianProcess,
    /// The input ranges, physical units.
    pub ranges: Vec<(f64, f64)>,
}

impl Surrogate for Gp {
    type Settings = GpSettings;
    const KIND: &'static str = "gaussian_process";

    fn fit(table: &Table, settings: &GpSettings) -> Result<Self, SurrogateError> {
        table.check()?;
        let ranges = table.ranges.to_vec();
        let unit: Vec<Vec<f64>> = table.x.iter().map(|r| to_unit(r, &ranges)).collect();
        let zeros = vec![0.0; table.y.len()];
        let noise = table.noise_var.unwrap_or(&zeros);
        let process = GaussianProcess::fit(&unit, table.y, noise, settings).map_err(|e| {
            SurrogateError::Fit {
                kind: Self::KIND,
                message: e.to_string(),
            }
        })?;
        Ok(Gp { process, ranges })
    }

    fn predict(&self, x: &[f64]) -> Prediction {
        self.process.predict(&to_unit(x, &self.ranges)).into()
    }

    /// Signal variance, one length scale per input, the nugget when fitted.
    fn parameter_count(&self) -> usize {
        self.process.hyper().parameter_count()
    }
}
