//! Nonlinear least squares: the parameters p minimising the sum of squared
//! residuals SSE(p) = Σᵢ (yᵢ − f(p; xᵢ))² of a [`Model`] with an analytic
//! parameter gradient, by Levenberg–Marquardt.
//!
//! # Iteration
//!
//! The one Levenberg–Marquardt loop of [`super::levenberg`] with
//! Marquardt damping and these rules ([`NllsSettings::lm`]). At the current
//! p, with J the n × p Jacobian ∂f(p; xᵢ)/∂p_j and r = y − f, the trial
//! step δ solves (JᵀJ + λ·diag(JᵀJ)) δ = Jᵀr (Marquardt's scaling, so the
//! damping is invariant to the units of each parameter) by Cholesky
//! factorisation. A trial point with a smaller SSE is accepted and λ divided
//! by 10 (towards Gauss–Newton); otherwise (or when the damped matrix is not
//! positive definite, or the model is not finite at the trial point) it is
//! rejected and λ multiplied by 10 (towards a short steepest-descent step).
//! Every trial step counts as one iteration.
//!
//! The fit has converged when any of these holds ([`NllsSettings`]):
//! - SSE = 0 (an exact fit);
//! - the gradient is negligible: maxⱼ |(Jᵀr)ⱼ| / √((JᵀJ)ⱼⱼ · SSE) ≤
//!   `gradient_tolerance` (the largest cosine between r and a column of J);
//! - an accepted step reduced SSE by at most `sse_tolerance` · SSE;
//! - a trial step is short: ‖δ‖ ≤ `step_tolerance` · (‖p‖ + `step_tolerance`)
//!   (an accepted short step is taken first; a rejected one means no
//!   representable improvement is left).
//!
//! Reaching `max_iterations` first is [`StatsError::NotConverged`].
//!
//! # Inference at the solution
//!
//! The covariance of the estimates is s²·(JᵀJ)⁻¹ with s² = SSE/(n − p) and J
//! at the solution — what `scipy.optimize.curve_fit(..., absolute_sigma=False)`
//! returns as `pcov`. (JᵀJ)⁻¹ = R⁻¹R⁻ᵀ from the Householder QR J = QR, and
//! JᵀJ counts as singular (refused with [`StatsError::Singular`], naming the
//! parameter) when a column of J has a part orthogonal to the columns before
//! it no longer than 1e-9 of its length: that parameter is not determined by
//! the data. Confidence intervals are estimate ∓ t₀.₉₇₅(n − p)·SE
//! (linearised, as usual for nonlinear least squares).
//!
//! [`lack_of_fit`] splits SSE into pure error (between replicates of the same
//! x) and lack of fit, as for the response surfaces in
//! [`rsm`](super::rsm).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

use super::levenberg::{minimise, Damping, LeastSquares, LmSettings, Stopping};
use super::regression::ols_named;
use super::summary::{f_survival, t_quantile};
use super::{check_finite, StatsError};

/// Relative length below which a Jacobian column's part orthogonal to the
/// columns before it counts as zero (JᵀJ singular).
const SINGULAR_TOLERANCE: f64 = 1e-9;

/// A model y = f(p; x) with an analytic parameter gradient, fitted by
/// [`fit`]. Each observation's x is one row (a slice of the model's inputs,
/// in the order and length the model expects).
pub trait Model {
    /// Names of the parameters, in the order of `p` (reported in [`NllsFit`]
    /// and in errors).
    fn parameter_names(&self) -> Vec<String>;
    /// The model value f(p; x), in the units of y.
    fn value(&self, p: &[f64], x: &[f64]) -> f64;
    /// The gradient ∂f(p; x)/∂p_j written to `out[j]` (`out` has one entry
    /// per parameter).
    fn gradient(&self, p: &[f64], x: &[f64], out: &mut [f64]);
}

/// Iteration limit, initial damping and convergence tolerances of the
/// Levenberg–Marquardt iteration (the module docs give the tests).
#[derive(Debug, Clone, PartialEq)]
pub struct NllsSettings {
    /// Most trial steps (accepted or rejected) before
    /// [`StatsError::NotConverged`]. Default 500.
    pub max_iterations: usize,
    /// Initial damping λ (relative to diag(JᵀJ)). Default 1e-3.
    pub lambda_initial: f64,
    /// Converged when an accepted step reduces SSE by at most this fraction
    /// of it. Default 1e-15.
    pub sse_tolerance: f64,
    /// Converged when a trial step is at most this fraction of the parameter
    /// vector's length. Default 1e-12.
    pub step_tolerance: f64,
    /// Converged when the largest cosine between the residuals and a
    /// gradient column is at most this. Default 1e-12.
    pub gradient_tolerance: f64,
}

impl NllsSettings {
    /// The settings of the one Levenberg–Marquardt loop: Marquardt damping
    /// and these stopping rules.
    pub fn lm(&self) -> LmSettings {
        LmSettings {
            damping: Damping::Marquardt {
                initial: self.lambda_initial,
            },
            stopping: Stopping {
                exact: true,
                max_trials: Some(self.max_iterations),
                gradient_cosine: Some(self.gradient_tolerance),
                objective_gain: Some(self.sse_tolerance),
                step: Some(self.step_tolerance),
                ..Stopping::default()
            },
        }
    }
}

impl Default for NllsSettings {
    fn default() -> Self {
        NllsSettings {
            max_iterations: 500,
            lambda_initial: 1e-3,
            sse_tolerance: 1e-15,
            step_tolerance: 1e-12,
            gradient_tolerance: 1e-12,
        }
    }
}

/// A nonlinear least-squares fit: estimates in the units of their parameter,
/// with the linearised inference of the module docs.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NllsFit {
    /// Parameter names, from [`Model::parameter_names`].
    pub names: Vec<String>,
    /// Estimates p̂, one per parameter.
    pub estimates: Vec<f64>,
    /// Standard errors √(covariance_jj).
    pub standard_errors: Vec<f64>,
    /// Lower 95 % confidence bounds p̂ − t₀.₉₇₅(n − p)·SE.
    pub ci_low: Vec<f64>,
    /// Upper 95 % confidence bounds p̂ + t₀.₉₇₅(n − p)·SE.
    pub ci_high: Vec<f64>,
    /// The Student-t quantile t₀.₉₇₅(n − p) of the intervals.
    pub t_quantile: f64,
    /// Correlation matrix of the estimates, covariance_ij / (SE_i·SE_j)
    /// (computed from (JᵀJ)⁻¹, so defined even for an exact fit).
    pub correlation: Vec<Vec<f64>>,
    /// Covariance matrix of the estimates s²·(JᵀJ)⁻¹ (`pcov` of
    /// `scipy.optimize.curve_fit` with `absolute_sigma=False`).
    pub covariance: Vec<Vec<f64>>,
    /// Sum of squared residuals at the solution (units of y squared).
    pub sse: f64,
    /// Residual variance s² = SSE / (n − p).
    pub s2: f64,
    /// Residual degrees of freedom n − p.
    pub dof: usize,
    /// Observations n.
    pub observations: usize,
    /// R² = 1 − SSE/SST with SST about the mean of y (NaN when all y are
    /// equal).
    pub r2: f64,
    /// Fitted values f(p̂; xᵢ), one per observation.
    pub fitted: Vec<f64>,
    /// Residuals yᵢ − f(p̂; xᵢ).
    pub residuals: Vec<f64>,
    /// Levenberg–Marquardt trial steps taken.
    pub iterations: usize,
}

/// Model values and Jacobian at `p`; the first non-finite value or gradient
/// entry is returned as `Err((row, column, value))` (column `None` for the
/// value).
#[allow(clippy::type_complexity)]
fn evaluate<M: Model>(
    model: &M,
    x: &[Vec<f64>],
    p: &[f64],
) -> Result<(DVector<f64>, DMatrix<f64>), (usize, Option<usize>, f64)> {
    let n = x.len();
    let k = p.len();
    let mut values = DVector::zeros(n);
    let mut jacobian = DMatrix::zeros(n, k);
    let mut row = vec![0.0; k];
    for (i, xi) in x.iter().enumerate() {
        let v = model.value(p, xi);
        if !v.is_finite() {
            return Err((i, None, v));
        }
        values[i] = v;
        model.gradient(p, xi, &mut row);
        for (j, &g) in row.iter().enumerate() {
            if !g.is_finite() {
                return Err((i, Some(j), g));
            }
            jacobian[(i, j)] = g;
        }
    }
    Ok((values, jacobian))
}

/// Fits `model` to observations (`x[i]`, `y[i]`) by Levenberg–Marquardt from
/// `start` (module docs), and returns the estimates with their covariance,
/// confidence intervals and fit statistics.
///
/// Errors: `x` rows ≠ `y` values or `start` not one value per parameter
/// ([`StatsError::LengthMismatch`]); a non-finite x, y or start value, or a
/// model value or gradient that is not finite at the start
/// ([`StatsError::NonFinite`]); n ≤ p ([`StatsError::TooFewObservations`]);
/// no convergence within `settings.max_iterations`
/// ([`StatsError::NotConverged`]); JᵀJ singular at the solution
/// ([`StatsError::Singular`]).
pub fn fit<M: Model>(
    model: &M,
    x: &[Vec<f64>],
    y: &[f64],
    start: &[f64],
    settings: &NllsSettings,
) -> Result<NllsFit, StatsError> {
    let names = model.parameter_names();
    let k = names.len();
    let n = y.len();
    if start.len() != k {
        return Err(StatsError::LengthMismatch {
            what: "start (one value per parameter)".to_string(),
            expected: k,
            got: start.len(),
        });
    }
    if x.len() != n {
        return Err(StatsError::LengthMismatch {
            what: "x (rows)".to_string(),
            expected: n,
            got: x.len(),
        });
    }
    check_finite("y", y)?;
    for (i, row) in x.iter().enumerate() {
        check_finite(&format!("row {i} of x"), row)?;
    }
    check_finite("start", start)?;
    if n <= k || k == 0 {
        return Err(StatsError::TooFewObservations {
            observations: n,
            parameters: k,
        });
    }
    let yv = DVector::from_column_slice(y);
    evaluate(model, x, start).map_err(|(i, j, value)| StatsError::NonFinite {
        what: match j {
            None => "model value at the start".to_string(),
            Some(j) => format!("model gradient ∂f/∂{} at the start", names[j]),
        },
        index: i,
        value,
    })?;
    let problem = Problem { model, x, y: &yv };
    let out = minimise(&problem, start, &settings.lm());
    if !out.stop.converged() {
        return Err(StatsError::NotConverged {
            iterations: out.trials,
            sse: out.objective,
        });
    }
    let (values, jacobian) =
        evaluate(model, x, &out.theta).expect("an accepted point has a finite model");
    let residuals = &yv - values;
    let p = DVector::from_column_slice(&out.theta);
    inference(
        names,
        p,
        &jacobian,
        &yv,
        &residuals,
        out.objective,
        out.trials,
    )
}

/// A model and its data as the Levenberg–Marquardt problem: residuals
/// f − y, objective SSE (NaN where the model or its gradient is not finite).
struct Problem<'a, M> {
    model: &'a M,
    x: &'a [Vec<f64>],
    y: &'a DVector<f64>,
}

impl<M: Model> LeastSquares for Problem<'_, M> {
    fn objective(&self, theta: &[f64]) -> f64 {
        match evaluate(self.model, self.x, theta) {
            Ok((values, _)) => (self.y - values).norm_squared(),
            Err(_) => f64::NAN,
        }
    }

    fn linearise(&self, theta: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let (values, jacobian) =
            evaluate(self.model, self.x, theta).expect("linearised at an accepted point");
        (values - self.y, jacobian)
    }
}

/// The covariance, intervals and fit statistics at the solution `p`.
fn inference(
    names: Vec<String>,
    p: DVector<f64>,
    jacobian: &DMatrix<f64>,
    y: &DVector<f64>,
    residuals: &DVector<f64>,
    sse: f64,
    iterations: usize,
) -> Result<NllsFit, StatsError> {
    let (n, k) = jacobian.shape();
    let qr = jacobian.clone().qr();
    let r = qr.r();
    for j in 0..k {
        if r[(j, j)].abs() <= SINGULAR_TOLERANCE * jacobian.column(j).norm() {
            return Err(StatsError::Singular {
                what: format!(
                    "JᵀJ at the solution: parameter `{}` is not determined by the data \
                     (its gradient column is a linear combination of the others')",
                    names[j]
                ),
            });
        }
    }
    let r_inv = r
        .solve_upper_triangular(&DMatrix::identity(k, k))
        .expect("R has a non-zero diagonal");
    let unscaled = &r_inv * r_inv.transpose();
    let dof = n - k;
    let s2 = sse / dof as f64;
    let covariance: Vec<Vec<f64>> = (0..k)
        .map(|i| (0..k).map(|j| s2 * unscaled[(i, j)]).collect())
        .collect();
    let correlation: Vec<Vec<f64>> = (0..k)
        .map(|i| {
            (0..k)
                .map(|j| unscaled[(i, j)] / (unscaled[(i, i)] * unscaled[(j, j)]).sqrt())
                .collect()
        })
        .collect();
    let standard_errors: Vec<f64> = (0..k).map(|j| covariance[j][j].sqrt()).collect();
    let t = t_quantile(0.975, dof as f64);
    let estimates: Vec<f64> = p.iter().copied().collect();
    let mean = y.mean();
    let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    Ok(NllsFit {
        names,
        ci_low: estimates
            .iter()
            .zip(&standard_errors)
            .map(|(e, se)| e - t * se)
            .collect(),
        ci_high: estimates
            .iter()
            .zip(&standard_errors)
            .map(|(e, se)| e + t * se)
            .collect(),
        estimates,
        standard_errors,
        t_quantile: t,
        correlation,
        covariance,
        sse,
        s2,
        dof,
        observations: n,
        r2: if sst > 0.0 { 1.0 - sse / sst } else { f64::NAN },
        fitted: (y - residuals).iter().copied().collect(),
        residuals: residuals.iter().copied().collect(),
        iterations,
    })
}

/// The power law y = A · Πⱼ xⱼ^{bⱼ} of yan2015 Eq. 19 (angle of repose or
/// flow rate = A·e^b·μs^c·μr^d): a multiplicative model of positive factors
/// whose exponents are the elasticities of y. Parameters are named "A" (units
/// of y) then one exponent per factor (dimensionless), named after the
/// factor; x rows hold one value (> 0) per factor.
#[derive(Debug, Clone, PartialEq)]
pub struct PowerLaw {
    /// Factor names, in the order of the x columns.
    pub factors: Vec<String>,
}

impl Model for PowerLaw {
    fn parameter_names(&self) -> Vec<String> {
        std::iter::once("A".to_string())
            .chain(self.factors.iter().cloned())
            .collect()
    }

    fn value(&self, p: &[f64], x: &[f64]) -> f64 {
        p[0] * x
            .iter()
            .zip(&p[1..])
            .map(|(x, b)| x.powf(*b))
            .product::<f64>()
    }

    fn gradient(&self, p: &[f64], x: &[f64], out: &mut [f64]) {
        let product: f64 = x.iter().zip(&p[1..]).map(|(x, b)| x.powf(*b)).product();
        out[0] = product;
        for (o, xj) in out[1..].iter_mut().zip(x) {
            *o = p[0] * product * xj.ln();
        }
    }
}

/// Fits [`PowerLaw`] with `factors` (one per x column) to (`x`, `y`),
/// starting from the log-linear ordinary least-squares fit
/// ln y = ln A + Σⱼ bⱼ ln xⱼ (which minimises relative rather than absolute
/// errors, so it is close to but not the nonlinear solution) with the default
/// [`NllsSettings`].
///
/// Errors: those of [`fit`]; a row of x without one value per factor
/// ([`StatsError::LengthMismatch`]); an x or y value ≤ 0 (it has no
/// logarithm), as [`StatsError::NonPositive`] naming `y` or the factor and
/// its column; a factor whose logarithm is a linear combination of the
/// others' ([`StatsError::Aliased`] naming it).
pub fn fit_power_law(x: &[Vec<f64>], y: &[f64], factors: &[String]) -> Result<NllsFit, StatsError> {
    let n = y.len();
    if x.len() != n {
        return Err(StatsError::LengthMismatch {
            what: "x (rows)".to_string(),
            expected: n,
            got: x.len(),
        });
    }
    check_finite("y", y)?;
    for (i, row) in x.iter().enumerate() {
        if row.len() != factors.len() {
            return Err(StatsError::LengthMismatch {
                what: format!("row {i} of x (one value per factor)"),
                expected: factors.len(),
                got: row.len(),
            });
        }
        check_finite(&format!("row {i} of x"), row)?;
    }
    if let Some(index) = y.iter().position(|&v| v <= 0.0) {
        return Err(StatsError::NonPositive {
            what: "y".to_string(),
            index,
            value: y[index],
        });
    }
    for (j, factor) in factors.iter().enumerate() {
        if let Some(index) = x.iter().position(|row| row[j] <= 0.0) {
            return Err(StatsError::NonPositive {
                what: format!("factor `{factor}` (column {j} of x)"),
                index,
                value: x[index][j],
            });
        }
    }
    let model = PowerLaw {
        factors: factors.to_vec(),
    };
    let log_x: Vec<Vec<f64>> = x
        .iter()
        .map(|row| {
            std::iter::once(1.0)
                .chain(row.iter().map(|v| v.ln()))
                .collect()
        })
        .collect();
    let log_y: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let linear = ols_named(&log_x, &log_y, &model.parameter_names())?;
    let mut start = linear.coefficients;
    start[0] = start[0].exp();
    fit(&model, x, y, &start, &NllsSettings::default())
}

/// The flow-rate decay FR(t) = FR0 / (1 + (K·t)ⁿ) of yan2015 Eq. 20:
/// parameters "FR0" (the initial flow rate, in the units of FR, e.g. 1/s or
/// g/s), "K" (1/s; 1/K is the time at which FR has fallen to FR0/2) and "n"
/// (dimensionless steepness). x rows hold one value, the time t > 0 in s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FlowDecay;

impl Model for FlowDecay {
    fn parameter_names(&self) -> Vec<String> {
        vec!["FR0".to_string(), "K".to_string(), "n".to_string()]
    }

    fn value(&self, p: &[f64], x: &[f64]) -> f64 {
        p[0] / (1.0 + (p[1] * x[0]).powf(p[2]))
    }

    fn gradient(&self, p: &[f64], x: &[f64], out: &mut [f64]) {
        let kt = p[1] * x[0];
        let u = kt.powf(p[2]);
        let d = 1.0 + u;
        out[0] = 1.0 / d;
        out[1] = -p[0] / (d * d) * p[2] * u / p[1];
        out[2] = -p[0] / (d * d) * u * kt.ln();
    }
}

/// Fits [`FlowDecay`] to the flow rates `flow_rate` at times `t_s` (s, > 0)
/// with the default [`NllsSettings`], from a start read off the data: FR0 =
/// the largest flow rate; K = 1/t½ with t½ the first time after that maximum
/// (times sorted) at which the flow rate has fallen to FR0/2, interpolated
/// linearly between the observations either side (or the largest time when
/// it never falls that far); n = 2.
///
/// Errors: those of [`fit`]; `t_s` and `flow_rate` of different lengths; a
/// time ≤ 0 ([`StatsError::NonPositive`] naming `t`).
pub fn fit_flow_decay(t_s: &[f64], flow_rate: &[f64]) -> Result<NllsFit, StatsError> {
    if t_s.len() != flow_rate.len() {
        return Err(StatsError::LengthMismatch {
            what: "t".to_string(),
            expected: flow_rate.len(),
            got: t_s.len(),
        });
    }
    check_finite("t", t_s)?;
    check_finite("flow rate", flow_rate)?;
    if let Some(index) = t_s.iter().position(|&t| t <= 0.0) {
        return Err(StatsError::NonPositive {
            what: "t".to_string(),
            index,
            value: t_s[index],
        });
    }
    let x: Vec<Vec<f64>> = t_s.iter().map(|&t| vec![t]).collect();
    let mut order: Vec<usize> = (0..t_s.len()).collect();
    order.sort_by(|&a, &b| t_s[a].total_cmp(&t_s[b]));
    let start = match order
        .iter()
        .enumerate()
        .max_by(|a, b| flow_rate[*a.1].total_cmp(&flow_rate[*b.1]))
    {
        None => vec![1.0, 1.0, 2.0], // no data: fit reports too few observations
        Some((peak, &i_max)) => {
            let fr0 = flow_rate[i_max];
            let half = fr0 / 2.0;
            let t_max = t_s[*order.last().expect("not empty")];
            let t_half = order[peak..]
                .windows(2)
                .find(|w| flow_rate[w[1]] <= half)
                .map_or(t_max, |w| {
                    let (t0, f0, t1, f1) = (t_s[w[0]], flow_rate[w[0]], t_s[w[1]], flow_rate[w[1]]);
                    t0 + (f0 - half) / (f0 - f1) * (t1 - t0)
                });
            vec![fr0, 1.0 / t_half, 2.0]
        }
    };
    fit(&FlowDecay, &x, flow_rate, &start, &NllsSettings::default())
}

/// Lack of fit against pure error for a fit with replicated x rows: whether
/// the model's residual scatter exceeds the scatter between replicates.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LackOfFit {
    /// SS_lof = SSE − SS_pe (units of y squared; 0 if rounding makes it
    /// negative).
    pub ss_lack_of_fit: f64,
    /// Degrees of freedom of lack of fit: distinct x rows − parameters.
    pub df_lack_of_fit: usize,
    /// SS_pe: sum over groups of identical x rows of the squared deviations
    /// of y from the group mean.
    pub ss_pure_error: f64,
    /// Degrees of freedom of pure error: observations − distinct x rows.
    pub df_pure_error: usize,
    /// F = (SS_lof/df_lof) / (SS_pe/df_pe) (infinite when only SS_pe = 0,
    /// NaN when both are 0).
    pub ratio: f64,
    /// P(F(df_lof, df_pe) ≥ ratio): small values mean the model misses
    /// systematic variation.
    pub p_value: f64,
}

/// Lack of fit of `fit` (made from these `x`, `y`) against pure error.
/// Observations whose x rows are identical (bitwise f64 equality: the same
/// level values) form a group. `None` when there is no replicate (df_pe = 0),
/// when there are no more distinct rows than parameters (df_lof = 0), or when
/// `x` and `y` do not have the fit's number of observations.
pub fn lack_of_fit(fit: &NllsFit, x: &[Vec<f64>], y: &[f64]) -> Option<LackOfFit> {
    let n = y.len();
    if x.len() != n || fit.observations != n {
        return None;
    }
    // A BTreeMap, not a HashMap: the sum over groups must run in the same
    // order on every call, or SS_pe differs in its last bits between runs.
    let mut groups: BTreeMap<Vec<u64>, Vec<usize>> = BTreeMap::new();
    for (i, row) in x.iter().enumerate() {
        groups
            .entry(row.iter().map(|v| v.to_bits()).collect())
            .or_default()
            .push(i);
    }
    let df_pure_error = n - groups.len();
    let df_lack_of_fit = groups.len().checked_sub(fit.estimates.len())?;
    if df_pure_error == 0 || df_lack_of_fit == 0 {
        return None;
    }
    let ss_pure_error: f64 = groups
        .values()
        .map(|members| {
            let mean = members.iter().map(|&i| y[i]).sum::<f64>() / members.len() as f64;
            members.iter().map(|&i| (y[i] - mean).powi(2)).sum::<f64>()
        })
        .sum();
    Some(LackOfFit::from_sums(
        fit.sse,
        ss_pure_error,
        df_lack_of_fit,
        df_pure_error,
    ))
}

impl LackOfFit {
    /// The test from a fit's residual sum of squares `sse` and the pure
    /// error's `ss_pure_error`, with their degrees of freedom.
    pub fn from_sums(
        sse: f64,
        ss_pure_error: f64,
        df_lack_of_fit: usize,
        df_pure_error: usize,
    ) -> LackOfFit {
        let ss_lack_of_fit = (sse - ss_pure_error).max(0.0);
        let ratio =
            (ss_lack_of_fit / df_lack_of_fit as f64) / (ss_pure_error / df_pure_error as f64);
        LackOfFit {
            ss_lack_of_fit,
            df_lack_of_fit,
            ss_pure_error,
            df_pure_error,
            ratio,
            p_value: f_survival(ratio, df_lack_of_fit as f64, df_pure_error as f64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::assert_rel;

    /// Reference numbers are from scipy 1.17.1 / numpy 2.4.6, with the same
    /// data as [`power_law_data`] built and fitted by:
    ///
    /// ```python
    /// E=[0.05,0.45,0.85]; MS=[0.05,0.15,0.25,0.5]; MR=[0.05,0.25,0.45]
    /// rows=[]; y=[]; k=0
    /// for e in E:
    ///   for ms in MS:
    ///     for mr in MR:
    ///       for r in range(4):
    ///         rows.append([e,ms,mr])
    ///         y.append(40.0*e**-0.05*ms**0.3*mr**0.1*(1+0.2*ms*ms)*(1+0.02*np.sin(1.3*k+0.7))); k+=1
    /// X=np.array(rows).T; y=np.array(y); n=len(y); p=4
    /// def f(X,A,b,c,d): return A*X[0]**b*X[1]**c*X[2]**d
    /// def jac(X,A,b,c,d):
    ///     v=f(X,A,b,c,d); return np.column_stack([v/A, v*np.log(X[0]), v*np.log(X[1]), v*np.log(X[2])])
    /// popt,pcov=curve_fit(f,X,y,p0=[30,0,0,0],jac=jac,absolute_sigma=False,
    ///                     ftol=1e-15,xtol=1e-15,gtol=1e-15,maxfev=100000)
    /// se=np.sqrt(np.diag(pcov)); tq=stats.t.ppf(0.975,n-p)
    /// lo=popt-tq*se; hi=popt+tq*se; corr=pcov/np.outer(se,se)
    /// res=y-f(X,*popt); sse=res@res; s2=sse/(n-p); r2=1-sse/np.sum((y-y.mean())**2)
    /// ```
    ///
    /// The (1 + 0.2 μs²) factor is a deliberate departure from the power law
    /// so that lack of fit is detectable; the sine is deterministic "noise"
    /// that differs between the 4 replicates of each of the 36 points.
    fn power_law_data() -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut k = 0;
        for e in [0.05, 0.45, 0.85] {
            for ms in [0.05, 0.15, 0.25, 0.5] {
                for mr in [0.05, 0.25, 0.45] {
                    for _ in 0..4 {
                        x.push(vec![e, ms, mr]);
                        y.push(
                            40.0 * f64::powf(e, -0.05)
                                * f64::powf(ms, 0.3)
                                * f64::powf(mr, 0.1)
                                * (1.0 + 0.2 * ms * ms)
                                * (1.0 + 0.02 * (1.3 * k as f64 + 0.7).sin()),
                        );
                        k += 1;
                    }
                }
            }
        }
        (x, y)
    }

    fn factors() -> Vec<String> {
        ["e", "mu_s", "mu_r"].map(String::from).to_vec()
    }

    /// Compares a correlation matrix with its reference; entries the
    /// reference gives as rounding-level zeros (|r| < 1e-12: the full
    /// factorial makes the exponents' gradient columns orthogonal) are
    /// checked as |r| ≤ 1e-9, the rest with [`assert_rel`].
    fn assert_correlation(got: &[Vec<f64>], reference: &[f64]) {
        let k = got.len();
        for i in 0..k {
            for j in 0..k {
                let e = reference[i * k + j];
                let what = format!("correlation[{i}][{j}]");
                if e.abs() < 1e-12 {
                    assert!(got[i][j].abs() <= 1e-9, "{what}: {} vs ~0", got[i][j]);
                } else {
                    assert_rel(&what, &[got[i][j]], &[e]);
                }
            }
        }
    }

    fn check_power_law(f: &NllsFit) {
        assert_eq!(f.names, ["A", "e", "mu_s", "mu_r"]);
        assert_eq!((f.observations, f.dof), (144, 140));
        // popt
        assert_rel(
            "estimates",
            &f.estimates,
            &[
                42.42207771073159,
                -0.04983689983383159,
                0.32430600729427256,
                0.10054197299686561,
            ],
        );
        // np.sqrt(np.diag(pcov))
        assert_rel(
            "standard errors",
            &f.standard_errors,
            &[
                0.18500209284869684,
                0.0011557862310063048,
                0.0020237850115989793,
                0.0016503327533323698,
            ],
        );
        // stats.t.ppf(0.975, 140)
        assert_rel("t quantile", &[f.t_quantile], &[1.9770537196570985]);
        // popt - tq*se, popt + tq*se
        assert_rel(
            "ci low",
            &f.ci_low,
            &[
                42.05631863492073,
                -0.05212195130097107,
                0.3203048756093045,
                0.0972791764882179,
            ],
        );
        assert_rel(
            "ci high",
            &f.ci_high,
            &[
                42.78783678654246,
                -0.047551848366692115,
                0.32830713897924063,
                0.10380476950551332,
            ],
        );
        // pcov/np.outer(se,se)
        assert_correlation(
            &f.correlation,
            &[
                1.0,
                0.3896443381122488,
                0.6237864915257806,
                0.591420299039262,
                0.3896443381122488,
                1.0000000000000002,
                -5.980059889122894e-16,
                9.477588777986125e-17,
                0.6237864915257806,
                -5.980059889122894e-16,
                1.0000000000000002,
                1.2827819965307802e-16,
                0.591420299039262,
                9.477588777986125e-17,
                1.2827819965307802e-16,
                1.0,
            ],
        );
        // pcov[0, :] (the other off-diagonals are rounding-level zeros,
        // checked through the correlations)
        assert_rel(
            "covariance row 0",
            &f.covariance[0],
            &[
                0.03422577435839785,
                8.331487128636536e-05,
                0.00023354844615034522,
                0.00018056949644532197,
            ],
        );
        // sse, sse/(n-p), r2
        assert_rel(
            "SSE, s², R²",
            &[f.sse, f.s2, f.r2],
            &[23.042449316168508, 0.1645889236869179, 0.9960531051922814],
        );
        let (_, y) = power_law_data();
        for ((fitted, residual), y) in f.fitted.iter().zip(&f.residuals).zip(&y) {
            assert!((fitted + residual - y).abs() < 1e-12);
        }
    }

    #[test]
    fn power_law_from_log_linear_start_matches_curve_fit() {
        let (x, y) = power_law_data();
        let f = fit_power_law(&x, &y, &factors()).unwrap();
        check_power_law(&f);
    }

    #[test]
    fn power_law_from_other_starts_matches_curve_fit() {
        let (x, y) = power_law_data();
        let model = PowerLaw { factors: factors() };
        for start in [
            [30.0, 0.0, 0.0, 0.0],
            [80.0, 0.5, -0.5, 0.5],
            [5.0, -0.3, 1.0, 0.0],
        ] {
            let f = fit(&model, &x, &y, &start, &NllsSettings::default()).unwrap();
            check_power_law(&f);
        }
    }

    #[test]
    fn lack_of_fit_matches_numpy() {
        // groups={}; [groups.setdefault(tuple(r),[]).append(i) for i,r in enumerate(rows)]
        // sspe=sum(np.sum((y[g]-y[g].mean())**2) for g in groups.values())
        // dfpe=n-len(groups); dflof=len(groups)-p; sslof=sse-sspe
        // F=(sslof/dflof)/(sspe/dfpe); stats.f.sf(F,dflof,dfpe)
        let (x, y) = power_law_data();
        let f = fit_power_law(&x, &y, &factors()).unwrap();
        let lof = lack_of_fit(&f, &x, &y).unwrap();
        assert_eq!((lof.df_lack_of_fit, lof.df_pure_error), (32, 108));
        assert_rel(
            "SS_lof, SS_pe, F, p",
            &[
                lof.ss_lack_of_fit,
                lof.ss_pure_error,
                lof.ratio,
                lof.p_value,
            ],
            &[
                7.541627154891017,
                15.50082216127749,
                1.6420413951552293,
                0.03139618065784975,
            ],
        );
        // Without replicates there is no pure error.
        let distinct: Vec<usize> = (0..x.len()).step_by(4).collect();
        let x1: Vec<Vec<f64>> = distinct.iter().map(|&i| x[i].clone()).collect();
        let y1: Vec<f64> = distinct.iter().map(|&i| y[i]).collect();
        let f1 = fit_power_law(&x1, &y1, &factors()).unwrap();
        assert_eq!(lack_of_fit(&f1, &x1, &y1), None);
    }

    #[test]
    fn flow_decay_matches_curve_fit() {
        // t=np.array([0.25*(i+1) for i in range(24)])
        // fr=np.array([50.0/(1+(0.8*ti)**1.5)*(1+0.03*np.sin(2.1*i+0.4)) for i,ti in enumerate(t)])
        // def g(t,F0,K,m): return F0/(1+(K*t)**m)
        // def gj(t,F0,K,m):
        //     u=(K*t)**m; return np.column_stack([1/(1+u), -F0/(1+u)**2*m*u/K, -F0/(1+u)**2*u*np.log(K*t)])
        // popt,pcov=curve_fit(g,t,fr,p0=[fr.max(),1.0,2.0],jac=gj,absolute_sigma=False,
        //                     ftol=1e-15,xtol=1e-15,gtol=1e-15,maxfev=100000)
        // se=np.sqrt(np.diag(pcov)); tq=stats.t.ppf(0.975,21); corr=pcov/np.outer(se,se)
        let t: Vec<f64> = (0..24).map(|i| 0.25 * (i + 1) as f64).collect();
        let fr: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                50.0 / (1.0 + f64::powf(0.8 * t, 1.5)) * (1.0 + 0.03 * (2.1 * i as f64 + 0.4).sin())
            })
            .collect();
        let x: Vec<Vec<f64>> = t.iter().map(|&t| vec![t]).collect();
        // The data-driven start of fit_flow_decay and two explicit starts
        // must all reach the curve_fit solution.
        let from_data = fit_flow_decay(&t, &fr).unwrap();
        for f in [
            from_data,
            fit(
                &FlowDecay,
                &x,
                &fr,
                &[20.0, 3.0, 1.0],
                &NllsSettings::default(),
            )
            .unwrap(),
            fit(
                &FlowDecay,
                &x,
                &fr,
                &[100.0, 0.2, 3.0],
                &NllsSettings::default(),
            )
            .unwrap(),
        ] {
            check_flow_decay(&f);
        }
    }

    fn check_flow_decay(f: &NllsFit) {
        assert_eq!(f.names, ["FR0", "K", "n"]);
        assert_eq!(f.dof, 21);
        assert_rel(
            "estimates",
            &f.estimates,
            &[50.91734653487737, 0.8225902028065734, 1.4803560120363177],
        );
        assert_rel(
            "standard errors",
            &f.standard_errors,
            &[
                0.5869625364768873,
                0.017232133536757732,
                0.02228466931217014,
            ],
        );
        assert_rel("t quantile", &[f.t_quantile], &[2.0796138447276795]);
        assert_rel(
            "ci low",
            &f.ci_low,
            &[49.69669111768356, 0.7867540193293359, 1.4340125052095507],
        );
        assert_rel(
            "ci high",
            &f.ci_high,
            &[52.13800195207118, 0.8584263862838108, 1.5266995188630847],
        );
        assert_correlation(
            &f.correlation,
            &[
                0.9999999999999999,
                0.937616880747213,
                -0.7790037586722176,
                0.937616880747213,
                1.0,
                -0.8504637515043612,
                -0.7790037586722176,
                -0.8504637515043612,
                1.0,
            ],
        );
        // sse, 1-sse/np.sum((fr-fr.mean())**2)
        assert_rel(
            "SSE, R²",
            &[f.sse, f.r2],
            &[2.8934400432938037, 0.9991196130637494],
        );
    }

    #[test]
    fn fits_refuse_bad_input() {
        let model = PowerLaw {
            factors: vec!["e".to_string()],
        };
        let x = vec![vec![0.1], vec![0.2]];
        assert_eq!(
            fit(
                &model,
                &x,
                &[1.0, 2.0],
                &[1.0, 0.5],
                &NllsSettings::default()
            ),
            Err(StatsError::TooFewObservations {
                observations: 2,
                parameters: 2
            })
        );
        assert_eq!(
            fit_flow_decay(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]),
            Err(StatsError::TooFewObservations {
                observations: 3,
                parameters: 3
            })
        );
        let x = vec![vec![0.1], vec![0.2], vec![0.0], vec![0.4]];
        assert_eq!(
            fit_power_law(&x, &[1.0, 2.0, 3.0, 4.0], &["e".to_string()]),
            Err(StatsError::NonPositive {
                what: "factor `e` (column 0 of x)".to_string(),
                index: 2,
                value: 0.0
            })
        );
        let x = vec![vec![0.1], vec![0.2], vec![0.3], vec![0.4]];
        assert_eq!(
            fit_power_law(&x, &[1.0, -2.0, 3.0, 4.0], &["e".to_string()]),
            Err(StatsError::NonPositive {
                what: "y".to_string(),
                index: 1,
                value: -2.0
            })
        );
        let err = fit_power_law(&x, &[1.0, 2.0, f64::NAN, 4.0], &["e".to_string()]).unwrap_err();
        assert_eq!(err.to_string(), "non-finite value NaN in y at index 2");
        let x = vec![vec![0.1], vec![f64::NAN], vec![0.3], vec![0.4]];
        let err = fit(
            &model,
            &x,
            &[1.0, 2.0, 3.0, 4.0],
            &[1.0, 0.5],
            &NllsSettings::default(),
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "non-finite value NaN in row 1 of x at index 0"
        );
        assert!(matches!(
            fit_flow_decay(&[0.0, 1.0, 2.0, 3.0], &[4.0, 3.0, 2.0, 1.0]),
            Err(StatsError::NonPositive { index: 0, .. })
        ));
        // An iteration limit too small to converge.
        let (x, y) = power_law_data();
        let settings = NllsSettings {
            max_iterations: 2,
            ..NllsSettings::default()
        };
        let model = PowerLaw { factors: factors() };
        assert!(matches!(
            fit(&model, &x, &y, &[5.0, -0.3, 1.0, 0.0], &settings),
            Err(StatsError::NotConverged { iterations: 2, .. })
        ));
        // A factor constant across all observations: its exponent and A are
        // not separately determined.
        let x: Vec<Vec<f64>> = (0..6).map(|i| vec![0.5, 0.1 * (i + 1) as f64]).collect();
        let y = [1.0, 1.3, 1.5, 1.6, 1.8, 1.9];
        let model = PowerLaw {
            factors: vec!["e".to_string(), "mu_s".to_string()],
        };
        assert_eq!(
            fit(&model, &x, &y, &[2.0, 0.0, 0.3], &NllsSettings::default()),
            Err(StatsError::Singular {
                what: "JᵀJ at the solution: parameter `e` is not determined by the data \
                       (its gradient column is a linear combination of the others')"
                    .to_string()
            })
        );
    }
}
