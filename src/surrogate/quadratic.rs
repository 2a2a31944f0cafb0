//! The full quadratic response surface as a [`Surrogate`]: inputs coded onto
//! [−1, 1] by their ranges (−1 at min, +1 at max, as cai2024's Box–Behnken
//! analysis codes them) and fitted by least squares with its ANOVA
//! ([`fit_quadratic`]). Design-Expert reports no predictive sd for the
//! optimum, so none is given here.

use super::{Prediction, Surrogate, SurrogateError, Table};
use crate::doe::Range;
use crate::stats::rsm::{fit_quadratic, RsmFit};

/// A fitted quadratic response surface with the ranges that code its inputs.
#[derive(Debug, Clone)]
pub struct Quadratic {
    /// The fit (coded units) with its ANOVA.
    pub fit: RsmFit,
    /// The input ranges, physical units (coded −1 and +1).
    pub ranges: Vec<Range>,
}

/// `x` (physical units) in the coded units of `ranges`.
fn coded(ranges: &[Range], x: &[f64]) -> Vec<f64> {
    x.iter().zip(ranges).map(|(v, r)| r.to_coded(*v)).collect()
}

impl Surrogate for Quadratic {
    type Settings = ();
    const KIND: &'static str = "quadratic_response_surface";

    fn fit(table: &Table, _: &()) -> Result<Self, SurrogateError> {
        table.check()?;
        // Table::check has refused every range that Range::new would.
        let ranges: Vec<Range> = table
            .ranges
            .iter()
            .map(|&(low, high)| Range { low, high })
            .collect();
        let x: Vec<Vec<f64>> = table.x.iter().map(|r| coded(&ranges, r)).collect();
        let fit = fit_quadratic(&x, table.y, table.names).map_err(|e| SurrogateError::Fit {
            kind: Self::KIND,
            message: e.to_string(),
        })?;
        Ok(Quadratic { fit, ranges })
    }

    fn predict(&self, x: &[f64]) -> Prediction {
        Prediction {
            mean: self.fit.predict(&coded(&self.ranges, x)),
            sd: None,
        }
    }

    fn parameter_count(&self) -> usize {
        self.fit.coefficients.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surrogate::tests::with_grid;

    #[test]
    fn predicts_the_least_squares_quadratic_in_physical_units() {
        // numpy: X = 5 x 5 grid of [0.5, 0.875, 1.25, 1.625, 2.0]^2,
        // y = 30 a^0.3 b^-0.2, c(x) = 2(x - 0.5)/1.5 - 1, terms [1, A, B, AB,
        // A^2, B^2] of (c(a), c(b)); beta = np.linalg.lstsq(T, y)[0];
        // np.dot(terms(probe), beta)
        let expected = [
            ([0.7, 1.1], 26.232542017926402),
            ([1.4, 0.6], 36.94279760293566),
            ([1.9, 1.8], 32.159648986130655),
            ([1.0, 1.0], 29.994216336993336),
        ];
        let q = with_grid(|table| Quadratic::fit(table, &())).unwrap();
        for (probe, want) in expected {
            let got = q.predict(&probe).mean;
            assert!(
                (got - want).abs() < 1e-9 * want,
                "{probe:?}: {got} vs {want}"
            );
        }
        assert_eq!(q.parameter_count(), 6);
    }
}
