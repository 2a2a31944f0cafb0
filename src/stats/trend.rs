//! A straight line y = a + b·x by weighted least squares, and its value
//! extrapolated to another x with a confidence interval: the trend of a
//! response against the particle size d/D, read at the real particle size.
//!
//! # The fit
//! Observations are the individual runs (x_i, y_i) with weights w_i (the
//! caller's: one over its level's sample variance, so a noisy level counts
//! less; or all equal). With X = [1 x] and W = diag(w):
//! β = (XᵀWX)⁻¹XᵀWy, s² = Σ w_i r_i² / (n − 2), Cov β = s² (XᵀWX)⁻¹.
//! The scale s² is estimated from the residuals, so the interval holds even
//! when the weights are right only up to a common factor, and a trend that
//! is not a line shows as a larger s². This is `statsmodels`' `WLS` with
//! `weights = w`, and its `get_prediction(...).summary_frame(alpha=0.05)`
//! `mean_ci_lower`/`mean_ci_upper` give the interval of [`LineFit::at`]
//! (see the test for the exact calls).
//!
//! # Why a line
//! A convergence sweep affords three or four particle sizes; a line in d/D
//! is the lowest-order term of any smooth dependence and leaves the residual
//! degrees of freedom to the runs. The interval at an extrapolated x widens
//! with its distance from the measured sizes as (x₀ − x̄)², which is the
//! honest statement of how far a trend is being trusted.

use super::nlls::LackOfFit;
use super::summary::t_quantile;
use super::{check_finite, StatsError};

/// A weighted least-squares line with its covariance.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LineFit {
    /// Intercept a: the value at x = 0, units of y.
    pub intercept: f64,
    /// Slope b, units of y per unit of x.
    pub slope: f64,
    /// Covariance of (a, b) as [[Var a, Cov], [Cov, Var b]], scaled by s².
    pub covariance: [[f64; 2]; 2],
    /// Weighted residual mean square s² = Σ w r² / (n − 2).
    pub s2: f64,
    /// Residual degrees of freedom n − 2.
    pub df_residual: usize,
}

/// The fitted line's value at one x with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LinePrediction {
    /// x the line was read at.
    pub x: f64,
    /// a + b·x, units of y.
    pub mean: f64,
    /// Standard error of the mean line at x.
    pub std_error: f64,
    /// Half-width of the 95 % interval: t₀.₉₇₅(n − 2) · std_error.
    pub half_width: f64,
}

/// Fits y = a + b·x by weighted least squares (see the module docs).
///
/// Errors: lengths that differ, a non-finite value, a weight that is not
/// positive, fewer than three observations (no residual degree of freedom
/// for two parameters), or fewer than two distinct x (the slope is not
/// estimable).
pub fn weighted_line(x: &[f64], y: &[f64], w: &[f64]) -> Result<LineFit, StatsError> {
    let n = y.len();
    for (what, v) in [("x", x), ("w", w)] {
        if v.len() != n {
            return Err(StatsError::LengthMismatch {
                what: what.to_string(),
                expected: n,
                got: v.len(),
            });
        }
    }
    check_finite("x", x)?;
    check_finite("y", y)?;
    check_finite("w", w)?;
    if let Some((index, &value)) = w.iter().enumerate().find(|(_, &v)| v <= 0.0) {
        return Err(StatsError::NonPositive {
            what: "w".to_string(),
            index,
            value,
        });
    }
    if n < 3 {
        return Err(StatsError::TooFewObservations {
            observations: n,
            parameters: 2,
        });
    }
    let sw: f64 = w.iter().sum();
    let xbar = x.iter().zip(w).map(|(x, w)| w * x).sum::<f64>() / sw;
    let ybar = y.iter().zip(w).map(|(y, w)| w * y).sum::<f64>() / sw;
    // Centred sums: the same normal equations, without cancellation.
    let sxx: f64 = x.iter().zip(w).map(|(x, w)| w * (x - xbar).powi(2)).sum();
    let sxy: f64 = (0..n).map(|i| w[i] * (x[i] - xbar) * (y[i] - ybar)).sum();
    let spread = x.iter().fold(0.0f64, |m, v| m.max((v - xbar).abs()));
    if sxx <= 1e-24 * sw * spread.max(xbar.abs()).max(1e-300).powi(2) {
        return Err(StatsError::Aliased {
            term: "x".to_string(),
        });
    }
    let slope = sxy / sxx;
    let intercept = ybar - slope * xbar;
    let df_residual = n - 2;
    let sse: f64 = (0..n)
        .map(|i| w[i] * (y[i] - intercept - slope * x[i]).powi(2))
        .sum();
    let s2 = sse / df_residual as f64;
    // (XᵀWX)⁻¹ in centred form: Var b = 1/Sxx, Var a = 1/Σw + x̄²/Sxx,
    // Cov(a, b) = −x̄/Sxx (each times s²).
    let var_b = s2 / sxx;
    let covariance = [
        [s2 / sw + xbar * xbar * var_b, -xbar * var_b],
        [-xbar * var_b, var_b],
    ];
    Ok(LineFit {
        intercept,
        slope,
        covariance,
        s2,
        df_residual,
    })
}

impl LineFit {
    /// The line at `x` with its 95 % confidence interval (of the line, not
    /// of one new observation).
    pub fn at(&self, x: f64) -> LinePrediction {
        let c = &self.covariance;
        let var = c[0][0] + 2.0 * x * c[0][1] + x * x * c[1][1];
        let std_error = var.max(0.0).sqrt();
        LinePrediction {
            x,
            mean: self.intercept + self.slope * x,
            std_error,
            half_width: t_quantile(0.975, self.df_residual as f64) * std_error,
        }
    }

    /// Lack of fit of the line against the pure error of replicates (runs
    /// at the same x, bitwise), both weighted as the fit was: whether the
    /// levels' means stray from the line by more than the scatter of their
    /// runs allows. `x`, `y`, `w` are the fit's. `None` without replicates or
    /// with only two distinct x (no degree of freedom for lack of fit).
    /// (A line through 3+ levels read far outside them is only as good as
    /// this test says.)
    pub fn lack_of_fit(&self, x: &[f64], y: &[f64], w: &[f64]) -> Option<LackOfFit> {
        let n = y.len();
        if x.len() != n || w.len() != n || n != self.df_residual + 2 {
            return None;
        }
        let mut groups: std::collections::BTreeMap<u64, Vec<usize>> = Default::default();
        for (i, v) in x.iter().enumerate() {
            groups.entry(v.to_bits()).or_default().push(i);
        }
        let df_pure_error = n - groups.len();
        let df_lack_of_fit = groups.len().checked_sub(2)?;
        if df_pure_error == 0 || df_lack_of_fit == 0 {
            return None;
        }
        let ss_pure_error: f64 = groups
            .values()
            .map(|members| {
                let sw: f64 = members.iter().map(|&i| w[i]).sum();
                let mean = members.iter().map(|&i| w[i] * y[i]).sum::<f64>() / sw;
                members
                    .iter()
                    .map(|&i| w[i] * (y[i] - mean).powi(2))
                    .sum::<f64>()
            })
            .sum();
        let sse = self.s2 * self.df_residual as f64;
        Some(LackOfFit::from_sums(
            sse,
            ss_pure_error,
            df_lack_of_fit,
            df_pure_error,
        ))
    }

    /// The line's change over an x range of width `span` (b·span), with its
    /// standard error (|span|·se(b)) and degrees of freedom: how much the
    /// response moves across the measured sizes.
    pub fn change(&self, span: f64) -> (f64, f64, f64) {
        (
            self.slope * span,
            span.abs() * self.covariance[1][1].max(0.0).sqrt(),
            self.df_residual as f64,
        )
    }

    /// Half-width of the 95 % interval of the slope.
    pub fn slope_half_width(&self) -> f64 {
        t_quantile(0.975, self.df_residual as f64) * self.covariance[1][1].max(0.0).sqrt()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Three sizes × five runs; weights one over each level's variance.
    pub(crate) fn data() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let levels = [
            (0.064, [40.1, 44.3, 38.7, 42.9, 45.6]),
            (0.048, [43.0, 41.2, 44.8, 42.5, 43.9]),
            (0.032, [44.6, 45.1, 43.7, 45.9, 44.2]),
        ];
        let (mut x, mut y, mut w) = (vec![], vec![], vec![]);
        for (xl, ys) in levels {
            let m = ys.iter().sum::<f64>() / 5.0;
            let v = ys.iter().map(|v| (v - m).powi(2)).sum::<f64>() / 4.0;
            for yv in ys {
                x.push(xl);
                y.push(yv);
                w.push(1.0 / v);
            }
        }
        (x, y, w)
    }

    /// Against statsmodels 0.15.0 (scratch venv), on the data above:
    /// ```python
    /// import numpy as np, statsmodels.api as sm
    /// X = sm.add_constant(np.array(x)); r = sm.WLS(np.array(y), X, weights=np.array(w)).fit()
    /// r.params, r.bse, r.scale
    /// f = r.get_prediction(np.array([[1.0, 0.0026]])).summary_frame(alpha=0.05)
    /// f['mean'], f['mean_se'], f['mean_ci_upper'] - f['mean']
    /// r.conf_int(0.05)[1]   # slope interval
    /// ```
    #[test]
    fn matches_statsmodels_wls() {
        let (x, y, w) = data();
        let fit = weighted_line(&x, &y, &w).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
        let expect = [
            (fit.intercept, 47.4364161358811),
            (fit.slope, -86.67864725508048),
            (fit.covariance[0][0].sqrt(), 1.248670362497949),
            (fit.covariance[1][1].sqrt(), 31.845665687366004),
            (fit.s2, 0.9403327033900286),
        ];
        for (i, (got, want)) in expect.iter().enumerate() {
            assert!(close(*got, *want), "value {i}: {got} vs {want}");
        }
        let p = fit.at(0.0026);
        assert!(close(p.mean, 47.2110516530179), "{}", p.mean);
        assert!(close(p.std_error, 1.168513909825582), "{}", p.std_error);
        assert!(close(p.half_width, 2.524420825427974), "{}", p.half_width);
        assert!(close(fit.slope_half_width(), 68.7983779951781));
        // Lack of fit: SSE_w = r.ssr; SS_pe,w = Σ_levels w·Σ(y − ȳ)²
        // (= n − 1 per level, as w = 1/s²); F = (SSE − SS_pe)/1 / (SS_pe/12);
        // scipy.stats.f.sf(F, 1, 12).
        let lof = fit.lack_of_fit(&x, &y, &w).unwrap();
        assert_eq!((lof.df_lack_of_fit, lof.df_pure_error), (1, 12));
        assert!(close(lof.ss_pure_error, 12.0), "{}", lof.ss_pure_error);
        assert!(close(lof.ss_lack_of_fit, 12.224325144070372 - 12.0));
        assert!(close(lof.ratio, 0.22432514407037196), "{}", lof.ratio);
        assert!(close(lof.p_value, 0.6442643074305461), "{}", lof.p_value);
    }

    #[test]
    fn refuses_what_it_cannot_fit() {
        assert!(matches!(
            weighted_line(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0], &[1.0; 3]),
            Err(StatsError::Aliased { .. })
        ));
        assert!(matches!(
            weighted_line(&[1.0, 2.0], &[1.0, 2.0], &[1.0; 2]),
            Err(StatsError::TooFewObservations { .. })
        ));
        assert!(matches!(
            weighted_line(&[1.0, 2.0, 3.0], &[1.0, 2.0, 3.0], &[1.0, 0.0, 1.0]),
            Err(StatsError::NonPositive { .. })
        ));
        assert!(matches!(
            weighted_line(&[1.0, 2.0, 3.0], &[1.0, f64::NAN, 3.0], &[1.0; 3]),
            Err(StatsError::NonFinite { .. })
        ));
    }

    /// Exact data: the line through it, zero scale, a zero-width interval.
    #[test]
    fn an_exact_line_is_recovered() {
        let x = [0.1, 0.2, 0.3, 0.4];
        let y: Vec<f64> = x.iter().map(|x| 30.0 + 50.0 * x).collect();
        let fit = weighted_line(&x, &y, &[1.0; 4]).unwrap();
        assert!((fit.intercept - 30.0).abs() < 1e-12 && (fit.slope - 50.0).abs() < 1e-10);
        assert!(fit.at(0.0).half_width < 1e-6);
    }
}
