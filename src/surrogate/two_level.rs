//! The two-level Gaussian process ([`crate::stats::gp_two_level`]) as a
//! [`Surrogate`] of the fine level: the table is the fine level's rows (a
//! few expensive runs), and the coarse level's rows (many cheap runs) come
//! with the settings, since the fine fit is conditioned on them. Inputs of
//! both levels are mapped onto the unit cube of the table's ranges; each
//! level's known noise variances are taken as given (zero for a fine table
//! without them, so δ's fitted nugget carries the noise). The predicted sd
//! is the fine level's latent sd. A study's fine stage ([`crate::study::stages::fine`])
//! fits the same process on its trained coarse GP instead.

use super::{to_unit, Prediction, Surrogate, SurrogateError, Table};
use crate::stats::gp::GpSettings;
use crate::stats::gp_two_level::{LevelData, TwoLevelGp};

/// The coarse level's data and the likelihood maximisations' settings.
#[derive(Debug, Clone)]
pub struct TwoLevelSettings {
    /// Coarse inputs, physical units, one row per point.
    pub coarse_x: Vec<Vec<f64>>,
    /// Coarse responses.
    pub coarse_y: Vec<f64>,
    /// Known noise variance of each coarse response (units of y squared).
    pub coarse_noise_var: Vec<f64>,
    /// Settings of both levels' fits.
    pub gp: GpSettings,
}

/// A fitted two-level process with the ranges that scale its inputs.
#[derive(Debug, Clone)]
pub struct TwoLevel {
    /// The process, on unit-cube inputs.
    pub process: TwoLevelGp,
    /// The input ranges, physical units.
    pub ranges: Vec<(f64, f64)>,
}

impl Surrogate for TwoLevel {
    type Settings = TwoLevelSettings;
    const KIND: &'static str = "two_level_gaussian_process";

    fn fit(table: &Table, settings: &TwoLevelSettings) -> Result<Self, SurrogateError> {
        table.check()?;
        let coarse = Table {
            x: &settings.coarse_x,
            y: &settings.coarse_y,
            noise_var: Some(&settings.coarse_noise_var),
            ..*table
        };
        coarse
            .check()
            .map_err(|e| SurrogateError::Table(format!("coarse level: {e}")))?;
        let ranges = table.ranges.to_vec();
        let unit =
            |x: &[Vec<f64>]| -> Vec<Vec<f64>> { x.iter().map(|r| to_unit(r, &ranges)).collect() };
        let (coarse_unit, fine_unit) = (unit(&settings.coarse_x), unit(table.x));
        let zeros = vec![0.0; table.y.len()];
        let process = TwoLevelGp::fit(
            LevelData {
                x: &coarse_unit,
                y: &settings.coarse_y,
                noise_var: &settings.coarse_noise_var,
            },
            LevelData {
                x: &fine_unit,
                y: table.y,
                noise_var: table.noise_var.unwrap_or(&zeros),
            },
            &settings.gp,
        )
        .map_err(|e| SurrogateError::Fit {
            kind: Self::KIND,
            message: e.to_string(),
        })?;
        Ok(TwoLevel { process, ranges })
    }

    fn predict(&self, x: &[f64]) -> Prediction {
        self.process.predict(&to_unit(x, &self.ranges)).into()
    }

    /// Each level's signal variance, length scales and fitted nugget, and
    /// ρ and β.
    fn parameter_count(&self) -> usize {
        let (coarse, delta) = self.process.hyper();
        coarse.parameter_count() + delta.parameter_count() + 2
    }
}
