//! Ordinary least squares y = Xβ + ε by Householder QR of the design matrix.
//!
//! X = QR with Q (n × p) orthonormal and R (p × p) upper triangular; then
//! β = R⁻¹Qᵀy, (XᵀX)⁻¹ = R⁻¹R⁻ᵀ, and the leverages (the diagonal of the hat
//! matrix X(XᵀX)⁻¹Xᵀ = QQᵀ) are the squared row norms of Q.
//!
//! Rank deficiency is found column by column: |R_jj| is the length of the
//! part of column j orthogonal to the columns before it, so a column with
//! |R_jj| ≤ 1e-9 · ‖x_j‖ is (to rounding) a linear combination of earlier
//! columns and the fit is refused with [`StatsError::Aliased`] naming it,
//! rather than returning arbitrary coefficients.

use nalgebra::{DMatrix, DVector};

use super::summary::t_two_sided_p;
use super::{check_finite, StatsError};

/// Relative length below which a column's part orthogonal to the earlier
/// columns counts as zero (the column is aliased).
const ALIAS_TOLERANCE: f64 = 1e-9;

/// An ordinary least-squares fit; coefficients are in the units of y per unit
/// of their column.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OlsFit {
    /// β, one per column of X.
    pub coefficients: Vec<f64>,
    /// Standard errors of β: √(s² · (XᵀX)⁻¹_jj).
    pub std_errors: Vec<f64>,
    /// Diagonal of (XᵀX)⁻¹ (the variances of β per unit s²).
    pub unscaled_variances: Vec<f64>,
    /// t statistics β_j / se_j (infinite or NaN when s² = 0, an exact fit).
    pub t: Vec<f64>,
    /// Two-sided p-values of the t statistics on `df_residual` degrees of
    /// freedom.
    pub p: Vec<f64>,
    /// Fitted values Xβ, one per observation.
    pub fitted: Vec<f64>,
    /// Residuals y − Xβ.
    pub residuals: Vec<f64>,
    /// Leverages h_ii, the diagonal of the hat matrix (each in [0, 1]; they
    /// sum to the number of columns).
    pub leverage: Vec<f64>,
    /// Sum of squared residuals.
    pub sse: f64,
    /// Residual degrees of freedom n − p.
    pub df_residual: usize,
    /// Residual mean square s² = SSE / (n − p), the estimate of Var(ε).
    pub s2: f64,
}

/// Fits y = Xβ + ε by least squares; `x` holds one row per observation (put
/// a column of ones in it for an intercept). Columns are named `x0`, `x1`, …
/// in errors.
///
/// Errors: rows of different lengths or a row count other than `y.len()`; a
/// non-finite value; n ≤ p (no residual degree of freedom); a column that is
/// a linear combination of the columns before it.
pub fn ols(x: &[Vec<f64>], y: &[f64]) -> Result<OlsFit, StatsError> {
    fit(x, y, |j| format!("x{j}"))
}

/// [`ols`] with the columns named by `names` (one per column) in errors.
pub(crate) fn ols_named(x: &[Vec<f64>], y: &[f64], names: &[String]) -> Result<OlsFit, StatsError> {
    fit(x, y, |j| names[j].clone())
}

fn fit(x: &[Vec<f64>], y: &[f64], name: impl Fn(usize) -> String) -> Result<OlsFit, StatsError> {
    let n = y.len();
    check_finite("y", y)?;
    if x.len() != n {
        return Err(StatsError::LengthMismatch {
            what: "x (rows)".to_string(),
            expected: n,
            got: x.len(),
        });
    }
    let p = x.first().map_or(0, Vec::len);
    if let Some((i, row)) = x.iter().enumerate().find(|(_, r)| r.len() != p) {
        return Err(StatsError::LengthMismatch {
            what: format!("row {i} of x"),
            expected: p,
            got: row.len(),
        });
    }
    if n <= p || p == 0 {
        return Err(StatsError::TooFewObservations {
            observations: n,
            parameters: p,
        });
    }
    let design = DMatrix::from_fn(n, p, |i, j| x[i][j]);
    for j in 0..p {
        let column: Vec<f64> = design.column(j).iter().copied().collect();
        check_finite(&format!("term `{}`", name(j)), &column)?;
    }
    let qr = design.clone().qr();
    let r = qr.r();
    for j in 0..p {
        if r[(j, j)].abs() <= ALIAS_TOLERANCE * design.column(j).norm() {
            return Err(StatsError::Aliased { term: name(j) });
        }
    }
    let q = qr.q();
    let yv = DVector::from_column_slice(y);
    let beta = r
        .solve_upper_triangular(&(q.transpose() * &yv))
        .expect("R has a non-zero diagonal");
    let r_inv = r
        .solve_upper_triangular(&DMatrix::identity(p, p))
        .expect("R has a non-zero diagonal");
    let fitted = &design * &beta;
    let residuals = &yv - &fitted;
    let sse = residuals.norm_squared();
    let df_residual = n - p;
    let s2 = sse / df_residual as f64;
    let unscaled_variances: Vec<f64> = (0..p).map(|j| r_inv.row(j).norm_squared()).collect();
    let std_errors: Vec<f64> = unscaled_variances.iter().map(|c| (s2 * c).sqrt()).collect();
    let t: Vec<f64> = beta.iter().zip(&std_errors).map(|(b, se)| b / se).collect();
    let p_values = t
        .iter()
        .map(|&t| t_two_sided_p(t, df_residual as f64))
        .collect();
    Ok(OlsFit {
        coefficients: beta.iter().copied().collect(),
        std_errors,
        unscaled_variances,
        t,
        p: p_values,
        fitted: fitted.iter().copied().collect(),
        residuals: residuals.iter().copied().collect(),
        leverage: (0..n).map(|i| q.row(i).norm_squared()).collect(),
        sse,
        df_residual,
        s2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    #[test]
    fn ols_matches_statsmodels() {
        // x1 = [1..10]; x2, y as below
        // X = sm.add_constant(np.column_stack([x1, x2])); f = sm.OLS(y, X).fit()
        // f.params, f.bse, f.tvalues, f.pvalues, f.ssr, f.mse_resid,
        // f.get_influence().hat_matrix_diag, f.fittedvalues[0], f.resid[9]
        let x2 = [0.5, -1.2, 0.3, 2.2, -0.7, 1.1, 0.0, -1.8, 0.9, 1.4];
        let y = [3.1, 4.9, 7.2, 9.8, 10.1, 13.4, 14.2, 15.1, 18.9, 21.3];
        let x: Vec<Vec<f64>> = (0..10).map(|i| vec![1.0, (i + 1) as f64, x2[i]]).collect();
        let f = ols(&x, &y).unwrap();
        assert_rel(
            "coefficients",
            &f.coefficients,
            &[1.1953085684373947, 1.9002467464486186, 0.5679049114636903],
        );
        assert_rel(
            "standard errors",
            &f.std_errors,
            &[0.23628478545246362, 0.03832040849966851, 0.094378198672356],
        );
        assert_rel(
            "t",
            &f.t,
            &[5.058762315772845, 49.58837394609342, 6.017331538984261],
        );
        assert_rel(
            "p",
            &f.p,
            &[
                0.0014653805420304319,
                3.55038317394496e-10,
                0.0005329762702332561,
            ],
        );
        assert_eq!(f.df_residual, 7);
        assert_rel(
            "SSE, s²",
            &[f.sse, f.s2],
            &[0.8374040540784445, 0.11962915058263493],
        );
        assert_rel(
            "leverage",
            &f.leverage,
            &[
                0.3595142686955109,
                0.37643815093590344,
                0.17729373116008726,
                0.42456002599231035,
                0.16984260211909513,
                0.15155322106099162,
                0.1357881626685438,
                0.5307891554304071,
                0.26499611920362437,
                0.4092245627335245,
            ],
        );
        assert_rel(
            "fitted[0], residual[9]",
            &[f.fitted[0], f.residuals[9]],
            &[3.3795077706178587, 0.3071570910272534],
        );
    }

    #[test]
    fn ols_refuses_bad_input() {
        let x = vec![vec![1.0, 2.0], vec![1.0, 3.0], vec![1.0]];
        assert_eq!(
            ols(&x, &[1.0, 2.0, 3.0]),
            Err(StatsError::LengthMismatch {
                what: "row 2 of x".to_string(),
                expected: 2,
                got: 1
            })
        );
        let x = vec![vec![1.0, 2.0], vec![1.0, 3.0]];
        assert_eq!(
            ols(&x, &[1.0, 2.0]),
            Err(StatsError::TooFewObservations {
                observations: 2,
                parameters: 2
            })
        );
        let x = vec![vec![1.0, 2.0], vec![1.0, f64::INFINITY], vec![1.0, 4.0]];
        let err = ols(&x, &[1.0, 2.0, 3.0]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "non-finite value inf in term `x1` at index 1"
        );
        // Third column = 2 × second.
        let x: Vec<Vec<f64>> = (0..5)
            .map(|i| vec![1.0, i as f64, 2.0 * i as f64])
            .collect();
        assert_eq!(
            ols(&x, &[1.0, 2.0, 3.0, 5.0, 4.0]),
            Err(StatsError::Aliased {
                term: "x2".to_string()
            })
        );
    }
}
