//! yan2015's power law y = A·Πⱼ xⱼ^bⱼ as a [`Surrogate`]: fitted by nonlinear
//! least squares from the log-linear start ([`fit_power_law`]) on physical
//! inputs (every input and response must be > 0). The predicted sd is the
//! delta-method standard error of the fitted mean, √(gᵀ Σ g) with g the
//! gradient of the model in its parameters and Σ their covariance
//! s²(JᵀJ)⁻¹.

use super::{Prediction, Surrogate, SurrogateError, Table};
use crate::stats::nlls::{fit_power_law, Model, NllsFit, PowerLaw};

/// A fitted power law.
#[derive(Debug, Clone)]
pub struct PowerLawSurrogate {
    /// The model (its factor names).
    pub model: PowerLaw,
    /// The fit: A, the exponents, their covariance and intervals.
    pub fit: NllsFit,
}

impl Surrogate for PowerLawSurrogate {
    type Settings = ();
    const KIND: &'static str = "power_law";

    fn fit(table: &Table, _: &()) -> Result<Self, SurrogateError> {
        table.check()?;
        let fit =
            fit_power_law(table.x, table.y, table.names).map_err(|e| SurrogateError::Fit {
                kind: Self::KIND,
                message: e.to_string(),
            })?;
        Ok(PowerLawSurrogate {
            model: PowerLaw {
                factors: table.names.to_vec(),
            },
            fit,
        })
    }

    fn predict(&self, x: &[f64]) -> Prediction {
        let p = &self.fit.estimates;
        let mut g = vec![0.0; p.len()];
        self.model.gradient(p, x, &mut g);
        let var: f64 = g
            .iter()
            .zip(&self.fit.covariance)
            .map(|(gi, row)| gi * row.iter().zip(&g).map(|(c, gj)| c * gj).sum::<f64>())
            .sum();
        Prediction {
            mean: self.model.value(p, x),
            sd: Some(var.max(0.0).sqrt()),
        }
    }

    fn parameter_count(&self) -> usize {
        self.fit.estimates.len()
    }
}
