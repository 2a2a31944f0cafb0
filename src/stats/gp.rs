//! Gaussian-process regression with a noise term: the noise-aware surrogate
//! of he2019's calibration, fitted to simulated angles of repose at design
//! points in the unit cube.
//!
//! # Model
//!
//! Inputs xᵢ ∈ [0, 1]^d (the study maps each calibrated parameter to the unit
//! interval), outputs yᵢ (angles in degrees) and per-point known noise
//! variances `noise_var[i]` ≥ 0 (deg²; the replicate variance of the mean,
//! s²/R, or all zero). The output is modelled as
//!
//! y(x) = m + f(x) + εᵢ,  f ~ GP(0, k),  εᵢ ~ N(0, `noise_var[i]` + σ_n²),
//!
//! - **Mean.** m is the arithmetic mean of y (a constant, not fitted by
//!   likelihood and not weighted by the noise); the process is fitted to
//!   y − m. [`GaussianProcess::with_hyper`] uses the m it is given.
//! - **Kernel.** σ_f² times the Matérn 5/2 correlation with one length scale
//!   per input (automatic relevance determination):
//!   k(x, x') = σ_f² (1 + √5 r + 5r²/3) exp(−√5 r),
//!   r² = Σₖ ((xₖ − x'ₖ)/ℓₖ)².
//!   Matérn 5/2 is the standard kernel for computer experiments that are
//!   deterministic up to noise (a DEM angle of repose varies smoothly with
//!   the parameters, plus packing noise): its sample paths are twice
//!   differentiable (Matérn ν: ⌈ν⌉ − 1 times), smooth enough for a physical
//!   response without the squared exponential's infinite smoothness, which
//!   over-smooths kinks and makes K badly conditioned; Matérn 3/2
//!   (once-differentiable paths) is rougher than such responses.
//! - **Noise.** The covariance of the observations is
//!   K = k(X, X) + diag(noise_var) + σ_n² I.
//!   `noise_var` is the *known* part: the variance of each point's mean over
//!   its replicates. σ_n² (the nugget, [`GpHyper::nugget_var`]) is the part
//!   the replicates miss (too few replicates, numerical noise between
//!   nearby parameter sets, model error); it is fitted when
//!   [`GpSettings::fit_nugget`] is true and 0 otherwise. The diagonal always
//!   receives max(σ_n², 10⁻¹⁰·σ_f²), so a fit without a nugget still carries
//!   a jitter of 10⁻¹⁰·σ_f² for numerical positive-definiteness (the fitted
//!   nugget's lower bound is far above it). The jitter is not part of the
//!   prediction variances.
//!
//! # Hyperparameters
//!
//! θ = (ln σ_f², ln ℓ₁ … ln ℓ_d, [ln σ_n²]) maximises the log marginal
//! likelihood L = −½ yᵀK⁻¹y − ½ ln|K| − (n/2) ln 2π (y centred), with the
//! analytic gradient ∂L/∂θⱼ = ½ tr((ααᵀ − K⁻¹) ∂K/∂θⱼ), α = K⁻¹y, by a
//! projected BFGS on θ within the box (variables on a bound with the gradient
//! pushing outwards are held; trial points are clamped into the box; Armijo
//! backtracking; inverse-Hessian scaled after the first step, reset to the
//! identity when its direction is not ascent). A run stops when the largest
//! free component of ∇L is ≤ 10⁻⁷, when the line search fails, when a step
//! changes neither θ (≤ 10⁻¹⁰) nor L, or after 200 iterations. The bounds,
//! with v = var(y) (population variance, floored at 10⁻¹²):
//!
//! - ℓₖ ∈ [0.05, 20] (in unit-cube units);
//! - σ_f² ∈ [10⁻³ v, 10² v] (10⁴ v in a fit with a trend, [`GaussianProcess::fit_trend`]);
//! - σ_n² ∈ [10⁻⁶ v, v].
//!
//! Start 0 is σ_f² = v, every ℓₖ = 0.5, σ_n² = 0.1 v; then
//! [`GpSettings::restarts`] more starts uniform in the box (in θ) from a
//! ChaCha8 generator seeded with [`GpSettings::seed`]. The best L wins, the
//! earlier start on a tie; everything is sequential, so a fit is
//! bit-identical across runs.
//!
//! # Prediction
//!
//! At x*: mean m + k*ᵀα and latent variance k(x*, x*) − k*ᵀK⁻¹k* (clamped at
//! 0); [`GaussianProcess::observation_sd`] adds σ_n² and the new
//! observation's own noise variance. [`crate::search::acquisition`] turns a
//! prediction into the acquisition quantities of a calibration towards a
//! target angle.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bounds of each length scale ℓₖ, in unit-cube units.
const LENGTH_SCALE_BOUNDS: (f64, f64) = (0.05, 20.0);
/// Bounds of σ_f² as multiples of var(y).
const SIGNAL_VAR_BOUNDS: (f64, f64) = (1e-3, 1e2);
/// Upper bound of σ_f² as a multiple of var(y) in a fit with a trend
/// ([`GaussianProcess::fit_trend`]): the two-level process's discrepancy
/// is often a smooth trend beyond its constant (the Forrester pair's is
/// linear), which a long-length-scale Matérn carries only at a large
/// variance, beyond the constant-mean bound (measured on the Forrester
/// pair: docs/performance.md, src/stats/gp_two_level.rs).
const TREND_SIGNAL_VAR_MAX: f64 = 1e4;
/// Bounds of σ_n² as multiples of var(y).
const NUGGET_VAR_BOUNDS: (f64, f64) = (1e-6, 1.0);
/// Floor of var(y) (deg²) when setting the bounds, for constant outputs.
const VARIANCE_FLOOR: f64 = 1e-12;
/// Smallest diagonal addition, as a multiple of σ_f².
const JITTER: f64 = 1e-10;
/// How far (absolute) a coordinate may lie outside [0, 1].
const UNIT_CUBE_TOLERANCE: f64 = 1e-9;
/// Iteration limit of one BFGS run.
const MAX_ITERATIONS: usize = 200;
/// Halvings of the step before a line search gives up.
const MAX_BACKTRACKS: usize = 40;
/// Largest component (in ln units) of a trial step.
const MAX_STEP: f64 = 3.0;
/// Convergence: largest component of the projected gradient of L.
const GRADIENT_TOLERANCE: f64 = 1e-7;
/// Armijo sufficient-increase constant.
const ARMIJO: f64 = 1e-4;

/// Settings of [`GaussianProcess::fit`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GpSettings {
    /// Random starts of the hyperparameter optimisation besides the fixed
    /// start 0 (count).
    pub restarts: usize,
    /// Fit a nugget σ_n² (deg²) on top of the known noise variances; when
    /// false σ_n² = 0 and only the jitter 10⁻¹⁰·σ_f² is added.
    pub fit_nugget: bool,
    /// Seed of the ChaCha8 generator drawing the random starts.
    pub seed: u64,
}

impl Default for GpSettings {
    /// 8 restarts, a fitted nugget, seed 0.
    fn default() -> Self {
        Self {
            restarts: 8,
            fit_nugget: true,
            seed: 0,
        }
    }
}

/// Hyperparameters of a [`GaussianProcess`].
#[derive(Debug, Clone, PartialEq)]
pub struct GpHyper {
    /// Signal variance σ_f² (deg²): the prior variance of the latent
    /// function.
    pub signal_var: f64,
    /// Length scales ℓₖ of the Matérn 5/2 kernel, one per input (unit-cube
    /// units).
    pub length_scales: Vec<f64>,
    /// Nugget σ_n² (deg²): noise variance on top of each point's known
    /// `noise_var`; 0 when not fitted.
    pub nugget_var: f64,
    /// Constant mean m (deg); a fit sets it to the arithmetic mean of y.
    pub mean: f64,
}

impl GpHyper {
    /// Free parameters: the signal variance, one length scale per input and
    /// the nugget when fitted.
    pub fn parameter_count(&self) -> usize {
        1 + self.length_scales.len() + usize::from(self.nugget_var > 0.0)
    }
}

/// Prediction of the latent function at one input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpPrediction {
    /// Predictive mean m + k*ᵀα (deg).
    pub mean: f64,
    /// Latent (noise-free) predictive standard deviation (deg); see
    /// [`GaussianProcess::observation_sd`] for a new observation's.
    pub sd: f64,
}

/// Why a Gaussian process could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpError {
    /// Fewer than two points.
    #[error("{got} points given; a Gaussian process needs at least 2")]
    TooFewPoints {
        /// Points given.
        got: usize,
    },
    /// Two inputs that must pair up have different lengths.
    #[error("lengths differ: {what} has {got} values where {expected} are needed")]
    LengthMismatch {
        /// What has the wrong length (`y`, `noise_var`, `length_scales`).
        what: String,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// The first point has no coordinates.
    #[error("x[0] has no coordinates; the input dimension must be at least 1")]
    NoCoordinates,
    /// A point's dimension differs from the first point's.
    #[error(
        "x[{point}] has {got} coordinates where {expected} (the dimension of x[0]) are needed"
    )]
    DimensionMismatch {
        /// Index of the point.
        point: usize,
        /// The dimension of `x[0]`.
        expected: usize,
        /// The dimension of this point.
        got: usize,
    },
    /// An input value is NaN or infinite.
    #[error("non-finite value {value} in {what}")]
    NonFinite {
        /// Which value: `x[3][1]`, `y[2]`, `noise_var[0]`, `signal_var`.
        what: String,
        /// The value.
        value: f64,
    },
    /// A coordinate lies outside [0, 1] by more than 10⁻⁹.
    #[error("x[{point}][{coordinate}] = {value} lies outside the unit interval [0, 1]")]
    OutsideUnitCube {
        /// Index of the point.
        point: usize,
        /// Index of the coordinate.
        coordinate: usize,
        /// The value.
        value: f64,
    },
    /// A variance or length scale that must be positive (or non-negative)
    /// is not.
    #[error("{what} = {value} is invalid: it must be {requirement}")]
    OutOfRange {
        /// Which value: `noise_var[2]`, `signal_var`, `length_scales[0]`,
        /// `nugget_var`.
        what: String,
        /// The value.
        value: f64,
        /// What it must be (`>= 0`, `> 0`).
        requirement: String,
    },
    /// K is not positive definite even with the jitter (Cholesky failed).
    #[error(
        "the covariance matrix is not positive definite even with the jitter \
         (signal variance {signal_var}, length scales {length_scales:?}, \
         diagonal addition {diagonal})"
    )]
    NotPositiveDefinite {
        /// σ_f² (deg²).
        signal_var: f64,
        /// ℓₖ (unit-cube units).
        length_scales: Vec<f64>,
        /// max(σ_n², 10⁻¹⁰·σ_f²) added to the diagonal besides `noise_var`
        /// (deg²).
        diagonal: f64,
    },
    /// Every start of the optimisation gave a covariance that is not
    /// positive definite.
    #[error(
        "no start of the hyperparameter optimisation gave a positive-definite \
         covariance matrix ({starts} starts)"
    )]
    NoFeasibleStart {
        /// Starts tried.
        starts: usize,
    },
}

/// The checked data: points, centred outputs and known noise variances.
#[derive(Debug, Clone)]
struct Data {
    x: Vec<Vec<f64>>,
    /// y − m.
    y: DVector<f64>,
    noise: Vec<f64>,
    /// Arithmetic mean of y.
    mean: f64,
    /// Regressors of a trend estimated by GLS at every θ (one row per
    /// point; [`GaussianProcess::fit_trend`]); `None` for the constant mean.
    trend: Option<DMatrix<f64>>,
}

impl Data {
    /// Checks the inputs in order: the number of points, the lengths of y
    /// and noise_var, the dimensions, finiteness, noise_var ≥ 0 and the unit
    /// cube.
    fn new(x: &[Vec<f64>], y: &[f64], noise_var: &[f64]) -> Result<Self, GpError> {
        let n = x.len();
        if n < 2 {
            return Err(GpError::TooFewPoints { got: n });
        }
        for (what, got) in [("y", y.len()), ("noise_var", noise_var.len())] {
            if got != n {
                return Err(GpError::LengthMismatch {
                    what: what.to_string(),
                    expected: n,
                    got,
                });
            }
        }
        let d = x[0].len();
        if d == 0 {
            return Err(GpError::NoCoordinates);
        }
        for (point, xi) in x.iter().enumerate() {
            if xi.len() != d {
                return Err(GpError::DimensionMismatch {
                    point,
                    expected: d,
                    got: xi.len(),
                });
            }
            for (coordinate, &value) in xi.iter().enumerate() {
                if !value.is_finite() {
                    return Err(GpError::NonFinite {
                        what: format!("x[{point}][{coordinate}]"),
                        value,
                    });
                }
                if !(-UNIT_CUBE_TOLERANCE..=1.0 + UNIT_CUBE_TOLERANCE).contains(&value) {
                    return Err(GpError::OutsideUnitCube {
                        point,
                        coordinate,
                        value,
                    });
                }
            }
        }
        for (name, values) in [("y", y), ("noise_var", noise_var)] {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(GpError::NonFinite {
                    what: format!("{name}[{i}]"),
                    value: values[i],
                });
            }
        }
        if let Some(i) = noise_var.iter().position(|&v| v < 0.0) {
            return Err(GpError::OutOfRange {
                what: format!("noise_var[{i}]"),
                value: noise_var[i],
                requirement: ">= 0".to_string(),
            });
        }
        let mean = y.iter().sum::<f64>() / n as f64;
        Ok(Self {
            x: x.to_vec(),
            y: DVector::from_iterator(n, y.iter().map(|v| v - mean)),
            noise: noise_var.to_vec(),
            mean,
            trend: None,
        })
    }

    fn dimension(&self) -> usize {
        self.x[0].len()
    }

    /// Population variance of y (with a trend: of y less its
    /// least-squares trend), floored at [`VARIANCE_FLOOR`].
    fn variance(&self) -> f64 {
        let residual = match &self.trend {
            None => self.y.clone(),
            Some(f) => {
                let fit = (f.transpose() * f)
                    .try_inverse()
                    .map(|a| f * (a * (f.transpose() * &self.y)))
                    .unwrap_or_else(|| DVector::zeros(self.y.len()));
                &self.y - fit
            }
        };
        (residual.norm_squared() / self.y.len() as f64).max(VARIANCE_FLOOR)
    }
}

/// The Matérn 5/2 correlation at scaled distance r.
fn matern52(r: f64) -> f64 {
    let s = 5.0_f64.sqrt() * r;
    (1.0 + s + s * s / 3.0) * (-s).exp()
}

/// Scaled distance r between two points.
fn scaled_distance(a: &[f64], b: &[f64], length_scales: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(length_scales)
        .map(|((p, q), l)| ((p - q) / l).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// What the diagonal receives besides `noise_var`: max(σ_n², jitter·σ_f²).
fn diagonal_addition(hyper: &GpHyper) -> f64 {
    hyper.nugget_var.max(JITTER * hyper.signal_var)
}

/// K = σ_f² M + diag(noise_var) + max(σ_n², jitter·σ_f²) I.
fn covariance(data: &Data, hyper: &GpHyper) -> DMatrix<f64> {
    let n = data.x.len();
    let extra = diagonal_addition(hyper);
    DMatrix::from_fn(n, n, |i, j| {
        let r = scaled_distance(&data.x[i], &data.x[j], &hyper.length_scales);
        let k = hyper.signal_var * matern52(r);
        if i == j {
            k + data.noise[i] + extra
        } else {
            k
        }
    })
}

/// The Cholesky factor of K, α = K⁻¹y and L.
#[derive(Debug, Clone)]
struct Factor {
    cholesky: Cholesky<f64, Dyn>,
    alpha: DVector<f64>,
    lml: f64,
}

/// Factorises K; `None` when it is not positive definite (or L is not
/// finite).
fn factorise(data: &Data, hyper: &GpHyper) -> Option<Factor> {
    let cholesky = Cholesky::new(covariance(data, hyper))?;
    // With a trend, L is profiled over its coefficients: y less its GLS
    // trend under this K (the gradient formula holds unchanged, the
    // coefficients being at their optimum).
    let residual = match &data.trend {
        None => data.y.clone(),
        Some(f) => {
            let kinv_f = cholesky.solve(f);
            let a = Cholesky::new(f.transpose() * &kinv_f)?;
            &data.y - f * a.solve(&(kinv_f.transpose() * &data.y))
        }
    };
    let alpha = cholesky.solve(&residual);
    let n = data.y.len();
    let half_log_det: f64 = (0..n).map(|i| cholesky.l_dirty()[(i, i)].ln()).sum();
    let lml = -0.5 * residual.dot(&alpha)
        - half_log_det
        - 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
    lml.is_finite().then_some(Factor {
        cholesky,
        alpha,
        lml,
    })
}

/// Hyperparameters from θ = (ln σ_f², ln ℓ₁ … ln ℓ_d, [ln σ_n²]).
fn hyper_from_theta(theta: &[f64], d: usize, fit_nugget: bool, mean: f64) -> GpHyper {
    GpHyper {
        signal_var: theta[0].exp(),
        length_scales: theta[1..=d].iter().map(|t| t.exp()).collect(),
        nugget_var: if fit_nugget { theta[d + 1].exp() } else { 0.0 },
        mean,
    }
}

/// ∂L/∂θ at the factorised hyperparameters: ½ Σ_ab W_ab ∂K_ab/∂θⱼ with
/// W = ααᵀ − K⁻¹.
fn lml_gradient(data: &Data, hyper: &GpHyper, factor: &Factor, fit_nugget: bool) -> Vec<f64> {
    let n = data.x.len();
    let d = data.dimension();
    let k_inv = factor.cholesky.inverse();
    let alpha = &factor.alpha;
    let w = |a: usize, b: usize| alpha[a] * alpha[b] - k_inv[(a, b)];
    let sf2 = hyper.signal_var;
    let sqrt5 = 5.0_f64.sqrt();
    let jitter_active = hyper.nugget_var < JITTER * sf2;
    let mut grad = vec![0.0; d + 1 + usize::from(fit_nugget)];
    let mut trace_w = 0.0;
    for a in 0..n {
        let waa = w(a, a);
        trace_w += waa;
        // ∂K_aa/∂ln σ_f² = σ_f² (plus the jitter when it is the diagonal
        // addition); the length scales do not change K_aa.
        grad[0] += waa * sf2 * (1.0 + if jitter_active { JITTER } else { 0.0 });
        for b in 0..a {
            let wab = 2.0 * w(a, b);
            let r = scaled_distance(&data.x[a], &data.x[b], &hyper.length_scales);
            let e = (-sqrt5 * r).exp();
            grad[0] += wab * sf2 * (1.0 + sqrt5 * r + 5.0 * r * r / 3.0) * e;
            // ∂k/∂ln ℓₖ = (5/3) σ_f² (1 + √5 r) e^{−√5 r} ((x_k − x'_k)/ℓₖ)².
            let c = wab * 5.0 / 3.0 * sf2 * (1.0 + sqrt5 * r) * e;
            for (k, l) in hyper.length_scales.iter().enumerate() {
                grad[1 + k] += c * ((data.x[a][k] - data.x[b][k]) / l).powi(2);
            }
        }
    }
    if fit_nugget && !jitter_active {
        grad[d + 1] = trace_w * hyper.nugget_var;
    }
    grad.iter().map(|g| 0.5 * g).collect()
}

/// L and ∂L/∂θ at θ; `None` when K is not positive definite there.
fn evaluate(data: &Data, theta: &[f64], fit_nugget: bool) -> Option<(f64, Vec<f64>)> {
    let hyper = hyper_from_theta(theta, data.dimension(), fit_nugget, data.mean);
    let factor = factorise(data, &hyper)?;
    let grad = lml_gradient(data, &hyper, &factor, fit_nugget);
    Some((factor.lml, grad))
}

/// Box bounds of θ.
fn theta_bounds(d: usize, fit_nugget: bool, var_y: f64, signal_max: f64) -> Vec<(f64, f64)> {
    let mut bounds = vec![(
        (SIGNAL_VAR_BOUNDS.0 * var_y).ln(),
        (signal_max * var_y).ln(),
    )];
    bounds.extend(std::iter::repeat_n(
        (LENGTH_SCALE_BOUNDS.0.ln(), LENGTH_SCALE_BOUNDS.1.ln()),
        d,
    ));
    if fit_nugget {
        bounds.push((
            (NUGGET_VAR_BOUNDS.0 * var_y).ln(),
            (NUGGET_VAR_BOUNDS.1 * var_y).ln(),
        ));
    }
    bounds
}

/// Maximises L from `start` by projected BFGS within `bounds`; the final θ
/// and L, or `None` when K is not positive definite at the start.
fn maximise(
    data: &Data,
    fit_nugget: bool,
    start: &[f64],
    bounds: &[(f64, f64)],
) -> Option<(Vec<f64>, f64)> {
    let p = start.len();
    let clamp = |t: &mut [f64]| {
        for (v, (lo, hi)) in t.iter_mut().zip(bounds) {
            *v = v.clamp(*lo, *hi);
        }
    };
    let mut theta = start.to_vec();
    clamp(&mut theta);
    let (mut lml, mut grad) = evaluate(data, &theta, fit_nugget)?;
    // Inverse-Hessian approximation of −L.
    let mut h = DMatrix::<f64>::identity(p, p);
    for iteration in 0..MAX_ITERATIONS {
        // The ascent direction is +∇L; a variable on a bound is held when ∇L
        // points out of the box.
        let held: Vec<bool> = (0..p)
            .map(|i| {
                (theta[i] <= bounds[i].0 && grad[i] < 0.0)
                    || (theta[i] >= bounds[i].1 && grad[i] > 0.0)
            })
            .collect();
        let projected = (0..p)
            .filter(|&i| !held[i])
            .map(|i| grad[i].abs())
            .fold(0.0, f64::max);
        if projected <= GRADIENT_TOLERANCE {
            break;
        }
        let mut direction: Vec<f64> = (0..p)
            .map(|i| {
                if held[i] {
                    0.0
                } else {
                    (0..p)
                        .filter(|&j| !held[j])
                        .map(|j| h[(i, j)] * grad[j])
                        .sum()
                }
            })
            .collect();
        let mut slope: f64 = direction.iter().zip(&grad).map(|(d, g)| d * g).sum();
        if slope <= 0.0 {
            // Not an ascent direction: restart from steepest ascent.
            h.fill_with_identity();
            direction = (0..p)
                .map(|i| if held[i] { 0.0 } else { grad[i] })
                .collect();
            slope = direction.iter().zip(&grad).map(|(d, g)| d * g).sum();
        }
        if slope <= 0.0 {
            break;
        }
        let longest = direction.iter().fold(0.0, |m: f64, d| m.max(d.abs()));
        let mut step = if longest > MAX_STEP {
            MAX_STEP / longest
        } else {
            1.0
        };
        let mut accepted = None;
        for _ in 0..MAX_BACKTRACKS {
            let mut trial: Vec<f64> = theta
                .iter()
                .zip(&direction)
                .map(|(t, d)| t + step * d)
                .collect();
            clamp(&mut trial);
            if let Some((trial_lml, trial_grad)) = evaluate(data, &trial, fit_nugget) {
                let gain: f64 = grad
                    .iter()
                    .zip(trial.iter().zip(&theta))
                    .map(|(g, (a, b))| g * (a - b))
                    .sum();
                if trial_lml >= lml + ARMIJO * gain {
                    accepted = Some((trial, trial_lml, trial_grad));
                    break;
                }
            }
            step *= 0.5;
        }
        let Some((trial, trial_lml, trial_grad)) = accepted else {
            break;
        };
        // BFGS update of the inverse Hessian of −L: s = Δθ, y = Δ(−∇L).
        let s = DVector::from_iterator(p, trial.iter().zip(&theta).map(|(a, b)| a - b));
        let y = DVector::from_iterator(p, grad.iter().zip(&trial_grad).map(|(a, b)| a - b));
        let sy = s.dot(&y);
        if sy > 1e-12 * s.norm() * y.norm() {
            if iteration == 0 {
                h *= sy / y.norm_squared();
            }
            let rho = 1.0 / sy;
            let hy = &h * &y;
            let yhy = y.dot(&hy);
            // H ← H − ρ(s (Hy)ᵀ + (Hy) sᵀ) + (ρ² yᵀHy + ρ) s sᵀ.
            h -= (&s * hy.transpose() + &hy * s.transpose()) * rho;
            h += &s * s.transpose() * (rho * rho * yhy + rho);
        }
        let converged = (trial_lml - lml).abs() <= 1e-13 * lml.abs().max(1.0) && s.amax() <= 1e-10;
        theta = trial;
        lml = trial_lml;
        grad = trial_grad;
        if converged {
            break;
        }
    }
    Some((theta, lml))
}

/// The maximum-likelihood hyperparameters of `data` (module docs): start 0
/// and `settings.restarts` random starts, the best L winning.
fn fitted_hyper(data: &Data, settings: &GpSettings) -> Result<GpHyper, GpError> {
    let d = data.dimension();
    let var_y = data.variance();
    let signal_max = match data.trend {
        None => SIGNAL_VAR_BOUNDS.1,
        Some(_) => TREND_SIGNAL_VAR_MAX,
    };
    let bounds = theta_bounds(d, settings.fit_nugget, var_y, signal_max);
    let mut start = vec![var_y.ln()];
    start.extend(std::iter::repeat_n(0.5_f64.ln(), d));
    if settings.fit_nugget {
        start.push((0.1 * var_y).ln());
    }
    let mut starts = vec![start];
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    for _ in 0..settings.restarts {
        starts.push(
            bounds
                .iter()
                .map(|(lo, hi)| lo + (hi - lo) * rng.random::<f64>())
                .collect(),
        );
    }
    let mut best: Option<(Vec<f64>, f64)> = None;
    for start in &starts {
        if let Some((theta, lml)) = maximise(data, settings.fit_nugget, start, &bounds) {
            if best.as_ref().is_none_or(|(_, b)| lml > *b) {
                best = Some((theta, lml));
            }
        }
    }
    let (theta, _) = best.ok_or(GpError::NoFeasibleStart {
        starts: starts.len(),
    })?;
    Ok(hyper_from_theta(&theta, d, settings.fit_nugget, data.mean))
}

/// A Gaussian process fitted to points in the unit cube (see the module
/// documentation for the model).
#[derive(Debug, Clone)]
pub struct GaussianProcess {
    x: Vec<Vec<f64>>,
    alpha: DVector<f64>,
    cholesky: Cholesky<f64, Dyn>,
    hyper: GpHyper,
    lml: f64,
}

impl GaussianProcess {
    /// Fits the hyperparameters by maximising the log marginal likelihood
    /// (multi-start projected BFGS within the documented bounds) and
    /// conditions on the data. `x`: points in [0, 1]^d; `y`: outputs (deg);
    /// `noise_var`: known noise variance of each output (deg², ≥ 0).
    pub fn fit(
        x: &[Vec<f64>],
        y: &[f64],
        noise_var: &[f64],
        settings: &GpSettings,
    ) -> Result<Self, GpError> {
        let data = Data::new(x, y, noise_var)?;
        let hyper = fitted_hyper(&data, settings)?;
        Self::condition(data, hyper)
    }

    /// The hyperparameters maximising the likelihood profiled over a trend
    /// Σⱼ bⱼ fⱼ(x) in place of the constant mean: at every θ the
    /// coefficients are y's generalised least-squares fit under that K.
    /// `trend` holds one row of regressors per point (the two-level
    /// process's (μ_coarse(xᵢ), 1), [`super::gp_two_level`]); the bounds of
    /// σ_f² and σ_n² scale with the variance of y less its least-squares
    /// trend. The returned `mean` is 0: the trend is the caller's.
    pub fn fit_trend(
        x: &[Vec<f64>],
        y: &[f64],
        noise_var: &[f64],
        trend: &[Vec<f64>],
        settings: &GpSettings,
    ) -> Result<GpHyper, GpError> {
        let mut data = Data::new(x, y, noise_var)?;
        let p = trend.first().map_or(0, Vec::len);
        if trend.len() != x.len() || trend.iter().any(|row| row.len() != p) || p == 0 {
            return Err(GpError::LengthMismatch {
                what: "trend".to_string(),
                expected: x.len(),
                got: trend.len(),
            });
        }
        data.trend = Some(DMatrix::from_fn(x.len(), p, |i, j| trend[i][j]));
        let hyper = fitted_hyper(&data, settings)?;
        Ok(GpHyper { mean: 0.0, ..hyper })
    }

    /// Conditions on the data with the hyperparameters given, without
    /// optimisation (for tests, and to refit new data with earlier
    /// hyperparameters). `hyper.mean` is used as given, not recomputed from
    /// y. Units as in [`fit`](Self::fit).
    pub fn with_hyper(
        x: &[Vec<f64>],
        y: &[f64],
        noise_var: &[f64],
        hyper: &GpHyper,
    ) -> Result<Self, GpError> {
        let mut data = Data::new(x, y, noise_var)?;
        let d = data.dimension();
        if hyper.length_scales.len() != d {
            return Err(GpError::LengthMismatch {
                what: "length_scales".to_string(),
                expected: d,
                got: hyper.length_scales.len(),
            });
        }
        let positive = std::iter::once(("signal_var".to_string(), hyper.signal_var)).chain(
            hyper
                .length_scales
                .iter()
                .enumerate()
                .map(|(k, &l)| (format!("length_scales[{k}]"), l)),
        );
        for (what, value) in positive {
            check_hyper(what, value, false)?;
        }
        check_hyper("nugget_var".to_string(), hyper.nugget_var, true)?;
        if !hyper.mean.is_finite() {
            return Err(GpError::NonFinite {
                what: "mean".to_string(),
                value: hyper.mean,
            });
        }
        // Re-centre y on the mean given.
        data.y.add_scalar_mut(data.mean - hyper.mean);
        data.mean = hyper.mean;
        Self::condition(data, hyper.clone())
    }

    /// Factorises K for the data and hyperparameters.
    fn condition(data: Data, hyper: GpHyper) -> Result<Self, GpError> {
        let factor = factorise(&data, &hyper).ok_or_else(|| GpError::NotPositiveDefinite {
            signal_var: hyper.signal_var,
            length_scales: hyper.length_scales.clone(),
            diagonal: diagonal_addition(&hyper),
        })?;
        Ok(Self {
            x: data.x,
            alpha: factor.alpha,
            cholesky: factor.cholesky,
            hyper,
            lml: factor.lml,
        })
    }

    /// Predictive mean (deg) and latent standard deviation (deg) at `x`, a
    /// point of the unit cube.
    ///
    /// # Panics
    ///
    /// When `x` does not have [`dimension`](Self::dimension) coordinates.
    pub fn predict(&self, x: &[f64]) -> GpPrediction {
        assert_eq!(
            x.len(),
            self.dimension(),
            "predict: point has {} coordinates, the process {}",
            x.len(),
            self.dimension()
        );
        let h = &self.hyper;
        let k = self.covariances(x);
        let mean = h.mean + k.dot(&self.alpha);
        let v = self
            .cholesky
            .l_dirty()
            .solve_lower_triangular(&k)
            .expect("a Cholesky factor has a positive diagonal");
        let variance = (h.signal_var - v.norm_squared()).max(0.0);
        GpPrediction {
            mean,
            sd: variance.sqrt(),
        }
    }

    /// k(x, X): the prior covariances (deg²) of the latent function at `x`
    /// with the data points, in their order.
    pub(crate) fn covariances(&self, x: &[f64]) -> DVector<f64> {
        let h = &self.hyper;
        DVector::from_iterator(
            self.x.len(),
            self.x
                .iter()
                .map(|xi| h.signal_var * matern52(scaled_distance(x, xi, &h.length_scales))),
        )
    }

    /// K⁻¹ b for the observations' covariance K (module docs), by its
    /// Cholesky factor.
    pub(crate) fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        self.cholesky.solve(b)
    }

    /// Predictive standard deviation (deg) of a new observation at the
    /// predicted point whose known noise variance is `noise_var` (deg²):
    /// √(latent variance + σ_n² + noise_var).
    pub fn observation_sd(&self, prediction: &GpPrediction, noise_var: f64) -> f64 {
        (prediction.sd * prediction.sd + self.hyper.nugget_var + noise_var).sqrt()
    }

    /// The hyperparameters.
    pub fn hyper(&self) -> &GpHyper {
        &self.hyper
    }

    /// Log marginal likelihood L of the centred outputs (dimensionless, for
    /// y in deg) at the hyperparameters.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Input dimension d.
    pub fn dimension(&self) -> usize {
        self.x[0].len()
    }
}

/// Checks a variance or length scale: finite and > 0 (≥ 0 when `zero_allowed`).
fn check_hyper(what: String, value: f64, zero_allowed: bool) -> Result<(), GpError> {
    if !value.is_finite() {
        return Err(GpError::NonFinite { what, value });
    }
    if value < 0.0 || (value == 0.0 && !zero_allowed) {
        let requirement = if zero_allowed { ">= 0" } else { "> 0" };
        return Err(GpError::OutOfRange {
            what,
            value,
            requirement: requirement.to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Asserts |actual − expected| ≤ tol · |expected| for each pair.
    fn assert_close(what: &str, actual: &[f64], expected: &[f64], tol: f64) {
        assert_eq!(actual.len(), expected.len(), "{what}: lengths");
        for (i, (a, e)) in actual.iter().zip(expected).enumerate() {
            assert!(
                (a - e).abs() <= tol * e.abs(),
                "{what}[{i}]: {a} vs reference {e}"
            );
        }
    }

    /// The 2-D data of tests 1 and 2 (y with an offset of about 30 deg).
    fn data_2d() -> (Vec<Vec<f64>>, Vec<f64>) {
        let x = [
            [0.1, 0.2],
            [0.4, 0.9],
            [0.8, 0.3],
            [0.55, 0.5],
            [0.95, 0.85],
            [0.25, 0.7],
            [0.7, 0.05],
            [0.05, 0.95],
        ];
        let y = vec![31.2, 34.5, 29.8, 32.1, 35.9, 33.0, 29.1, 34.2];
        (x.iter().map(|p| p.to_vec()).collect(), y)
    }

    const TEST_POINTS_2D: [[f64; 2]; 3] = [[0.3, 0.4], [0.6, 0.75], [0.9, 0.1]];

    /// σ_f² = 4, ℓ = (0.3, 0.7), σ_n² = 0.05, m = mean(y).
    fn hyper_2d(y: &[f64]) -> GpHyper {
        GpHyper {
            signal_var: 4.0,
            length_scales: vec![0.3, 0.7],
            nugget_var: 0.05,
            mean: y.iter().sum::<f64>() / y.len() as f64,
        }
    }

    /// Predictions at [`TEST_POINTS_2D`] and L of `with_hyper`.
    fn fixed_fit(noise_var: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
        let (x, y) = data_2d();
        let gp = GaussianProcess::with_hyper(&x, &y, noise_var, &hyper_2d(&y)).unwrap();
        assert_eq!(gp.dimension(), 2);
        assert_eq!(gp.hyper(), &hyper_2d(&y));
        let predictions: Vec<GpPrediction> = TEST_POINTS_2D.iter().map(|p| gp.predict(p)).collect();
        (
            predictions.iter().map(|p| p.mean).collect(),
            predictions.iter().map(|p| p.sd).collect(),
            gp.log_marginal_likelihood(),
        )
    }

    // References for tests 1 and 2 (scikit-learn 1.x, numpy; m = y.mean()):
    //   k = C(4.0,'fixed')*Matern(length_scale=[0.3,0.7], nu=2.5,
    //         length_scale_bounds='fixed') + WhiteKernel(0.05,'fixed')
    //   g = GaussianProcessRegressor(kernel=k, alpha=nv, optimizer=None,
    //         normalize_y=False).fit(X, y - m)
    //   mean = g.predict(Xs) + m;  lml = g.log_marginal_likelihood_value_
    // The latent sd comes from a second regressor without the WhiteKernel
    // and with alpha = nv + 0.05 (its std has no white-noise term):
    //   g2 = GaussianProcessRegressor(kernel=C(4.0,'fixed')*Matern(...),
    //         alpha=nv + 0.05, optimizer=None, normalize_y=False).fit(X, y - m)
    //   sd = g2.predict(Xs, return_std=True)[1]
    // (it agrees with sqrt(std_white² − 0.05) to 1e-15, and g2's LML with
    // g's).

    #[test]
    fn fixed_hyperparameters_match_sklearn() {
        // nv = np.full(8, 0.02)
        let (mean, sd, lml) = fixed_fit(&[0.02; 8]);
        let mean_ref = [31.823876113640686, 33.484972048478646, 29.893000532717465];
        let sd_ref = [0.7683011361393531, 0.7502971319078454, 0.9586537533413126];
        let lml_ref = -17.54238554019156;
        assert_close("mean", &mean, &mean_ref, 1e-9);
        assert_close("sd", &sd, &sd_ref, 1e-9);
        assert_close("lml", &[lml], &[lml_ref], 1e-9);
    }

    #[test]
    fn per_point_noise_matches_sklearn() {
        // nv = np.array([0.01,0.05,0.0,0.2,0.03,0.1,0.0,0.07])
        let (mean, sd, lml) = fixed_fit(&[0.01, 0.05, 0.0, 0.2, 0.03, 0.1, 0.0, 0.07]);
        let mean_ref = [31.86679409988607, 33.42415537720227, 29.87671239883978];
        let sd_ref = [0.8051763724213261, 0.808046597396176, 0.9584181246431398];
        let lml_ref = -17.61671225389749;
        assert_close("mean", &mean, &mean_ref, 1e-9);
        assert_close("sd", &sd, &sd_ref, 1e-9);
        assert_close("lml", &[lml], &[lml_ref], 1e-9);
    }

    /// 20 points in the unit cube: np.random.default_rng(7), X3 =
    /// round(uniform(size=(20,3)), 4), y3 = round(30 + 5 sin(3 x0) + 3 x1² −
    /// 2 x0 x2 + normal(0, 0.3), 4); noise_var 0.03 each.
    fn data_3d() -> (Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
        let x = [
            [0.6251, 0.8972, 0.7757],
            [0.2252, 0.3002, 0.8736],
            [0.0053, 0.8212, 0.7971],
            [0.4679, 0.303, 0.2784],
            [0.2549, 0.4451, 0.5045],
            [0.5535, 0.9955, 0.7927],
            [0.6222, 0.989, 0.2153],
            [0.1602, 0.6125, 0.0439],
            [0.0357, 0.5149, 0.4662],
            [0.9172, 0.6292, 0.5141],
            [0.4969, 0.2475, 0.0118],
            [0.1924, 0.692, 0.2006],
            [0.3695, 0.0037, 0.83],
            [0.1545, 0.2676, 0.8803],
            [0.5098, 0.8472, 0.6397],
            [0.7418, 0.0915, 0.5411],
            [0.5078, 0.8713, 0.3613],
            [0.5982, 0.0593, 0.3876],
            [0.323, 0.1502, 0.8163],
            [0.3794, 0.9787, 0.59],
        ];
        let y = vec![
            36.0124, 33.0647, 31.9552, 34.9834, 33.4426, 36.9016, 37.3904, 33.6926, 31.6401,
            31.7485, 34.9176, 34.2819, 33.2641, 32.0393, 36.4675, 33.5659, 37.1118, 34.324,
            33.5514, 36.8902,
        ];
        (x.iter().map(|p| p.to_vec()).collect(), y, vec![0.03; 20])
    }

    #[test]
    fn optimised_fit_matches_sklearn() {
        // v = np.var(y3); m = y3.mean()
        // k = C(v, (1e-3*v, 1e2*v)) * Matern(length_scale=[0.5]*3,
        //       length_scale_bounds=(0.05, 20), nu=2.5)
        //     + WhiteKernel(0.1*v, (1e-6*v, v))
        // g = GaussianProcessRegressor(kernel=k, alpha=np.full(20, 0.03),
        //       n_restarts_optimizer=10, random_state=0,
        //       normalize_y=False).fit(X3, y3 - m)
        // g.kernel_ = 6.49**2 * Matern(length_scale=[0.924, 2.6, 6.65])
        //             + WhiteKernel(noise_level=3.42e-06) (the nugget's lower bound)
        // g.log_marginal_likelihood_value_ = -18.605574757205808
        // g.predict(X3s) + m, X3s = [[0.2,0.5,0.5],[0.7,0.3,0.8],[0.5,0.9,0.1]]:
        //   [33.36218774935527, 33.87237679864326, 37.51957726966613]
        // range of y3 = 5.750299999999999
        let (x, y, noise) = data_3d();
        let settings = GpSettings {
            restarts: 10,
            ..GpSettings::default()
        };
        let gp = GaussianProcess::fit(&x, &y, &noise, &settings).unwrap();
        let lml_ref = -18.605574757205808;
        let lml = gp.log_marginal_likelihood();
        println!("lml {lml} (sklearn {lml_ref}), hyper {:?}", gp.hyper());
        assert!(lml >= lml_ref - 1e-3, "lml {lml} vs sklearn {lml_ref}");
        let points = [[0.2, 0.5, 0.5], [0.7, 0.3, 0.8], [0.5, 0.9, 0.1]];
        let means_ref = [33.36218774935527, 33.87237679864326, 37.51957726966613];
        for (p, m_ref) in points.iter().zip(means_ref) {
            let m = gp.predict(p).mean;
            println!("mean at {p:?}: {m} (sklearn {m_ref})");
            assert!(
                (m - m_ref).abs() <= 0.01 * 5.750299999999999,
                "{m} vs {m_ref}"
            );
        }
    }

    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let (x, y, _) = data_3d();
        let noise: Vec<f64> = (0..20).map(|i| 0.01 * (i % 4) as f64).collect();
        let data = Data::new(&x, &y, &noise).unwrap();
        for fit_nugget in [true, false] {
            let bounds = theta_bounds(3, fit_nugget, data.variance(), SIGNAL_VAR_BOUNDS.1);
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let theta: Vec<f64> = bounds
                .iter()
                .map(|(lo, hi)| lo + (hi - lo) * rng.random::<f64>())
                .collect();
            let (_, grad) = evaluate(&data, &theta, fit_nugget).unwrap();
            let h = 1e-5;
            for j in 0..theta.len() {
                let shifted = |delta: f64| {
                    let mut t = theta.clone();
                    t[j] += delta;
                    evaluate(&data, &t, fit_nugget).unwrap().0
                };
                let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
                assert!(
                    (grad[j] - fd).abs() <= 1e-5 * fd.abs().max(1e-3),
                    "fit_nugget {fit_nugget}, θ{j} = {}: analytic {} vs finite difference {fd}",
                    theta[j],
                    grad[j]
                );
            }
        }
    }

    #[test]
    fn observation_sd_adds_the_nugget_and_new_noise() {
        let (x, y) = data_2d();
        let gp = GaussianProcess::with_hyper(&x, &y, &[0.0; 8], &hyper_2d(&y)).unwrap();
        let p = GpPrediction {
            mean: 30.0,
            sd: 0.3,
        };
        let expected = (0.09_f64 + 0.05 + 0.1).sqrt();
        assert!((gp.observation_sd(&p, 0.1) - expected).abs() <= 1e-15);
    }

    #[test]
    fn fits_are_bit_identical() {
        let (x, y, noise) = data_3d();
        let fits: Vec<GaussianProcess> = (0..2)
            .map(|_| GaussianProcess::fit(&x, &y, &noise, &GpSettings::default()).unwrap())
            .collect();
        let bits = |gp: &GaussianProcess| {
            let h = gp.hyper();
            let p = gp.predict(&[0.3, 0.6, 0.2]);
            let mut v = vec![
                h.signal_var,
                h.nugget_var,
                h.mean,
                gp.log_marginal_likelihood(),
            ];
            v.extend(&h.length_scales);
            v.extend([p.mean, p.sd]);
            v.iter().map(|f| f.to_bits()).collect::<Vec<u64>>()
        };
        assert_eq!(bits(&fits[0]), bits(&fits[1]));
        let fixed = GpSettings {
            fit_nugget: false,
            ..GpSettings::default()
        };
        let gp = GaussianProcess::fit(&x, &y, &noise, &fixed).unwrap();
        assert_eq!(gp.hyper().nugget_var, 0.0);
    }

    #[test]
    fn bad_inputs_are_refused_naming_them() {
        let (x, y) = data_2d();
        let nv = [0.0; 8];
        let s = GpSettings::default();
        let message = |r: Result<GaussianProcess, GpError>| r.unwrap_err().to_string();
        assert_eq!(
            message(GaussianProcess::fit(&x[..1], &y[..1], &nv[..1], &s)),
            "1 points given; a Gaussian process needs at least 2"
        );
        assert_eq!(
            message(GaussianProcess::fit(&x, &y[..7], &nv, &s)),
            "lengths differ: y has 7 values where 8 are needed"
        );
        assert_eq!(
            message(GaussianProcess::fit(&x, &y, &nv[..3], &s)),
            "lengths differ: noise_var has 3 values where 8 are needed"
        );
        let mut bad_x = x.clone();
        bad_x[3] = vec![0.5];
        assert_eq!(
            message(GaussianProcess::fit(&bad_x, &y, &nv, &s)),
            "x[3] has 1 coordinates where 2 (the dimension of x[0]) are needed"
        );
        let empty = vec![vec![]; 8];
        assert_eq!(
            message(GaussianProcess::fit(&empty, &y, &nv, &s)),
            "x[0] has no coordinates; the input dimension must be at least 1"
        );
        let mut bad_x = x.clone();
        bad_x[2][1] = 1.01;
        assert_eq!(
            message(GaussianProcess::fit(&bad_x, &y, &nv, &s)),
            "x[2][1] = 1.01 lies outside the unit interval [0, 1]"
        );
        let mut edge_x = x.clone();
        edge_x[2][1] = 1.0 + 1e-10;
        assert!(GaussianProcess::with_hyper(&edge_x, &y, &nv, &hyper_2d(&y)).is_ok());
        let mut bad_x = x.clone();
        bad_x[1][0] = f64::NAN;
        assert_eq!(
            message(GaussianProcess::fit(&bad_x, &y, &nv, &s)),
            "non-finite value NaN in x[1][0]"
        );
        let mut bad_y = y.clone();
        bad_y[5] = f64::INFINITY;
        assert_eq!(
            message(GaussianProcess::fit(&x, &bad_y, &nv, &s)),
            "non-finite value inf in y[5]"
        );
        let mut bad_nv = nv;
        bad_nv[4] = -0.1;
        assert_eq!(
            message(GaussianProcess::fit(&x, &y, &bad_nv, &s)),
            "noise_var[4] = -0.1 is invalid: it must be >= 0"
        );
        let with = |h: GpHyper| message(GaussianProcess::with_hyper(&x, &y, &nv, &h));
        let h = hyper_2d(&y);
        assert_eq!(
            with(GpHyper {
                length_scales: vec![0.3],
                ..h.clone()
            }),
            "lengths differ: length_scales has 1 values where 2 are needed"
        );
        assert_eq!(
            with(GpHyper {
                length_scales: vec![0.3, 0.0],
                ..h.clone()
            }),
            "length_scales[1] = 0 is invalid: it must be > 0"
        );
        assert_eq!(
            with(GpHyper {
                signal_var: -1.0,
                ..h.clone()
            }),
            "signal_var = -1 is invalid: it must be > 0"
        );
        assert_eq!(
            with(GpHyper {
                nugget_var: -0.5,
                ..h.clone()
            }),
            "nugget_var = -0.5 is invalid: it must be >= 0"
        );
        assert_eq!(
            with(GpHyper {
                mean: f64::NAN,
                ..h.clone()
            }),
            "non-finite value NaN in mean"
        );
        // Two identical points without noise or nugget: the jitter keeps K
        // positive definite.
        let twins = vec![vec![0.5, 0.5], vec![0.5, 0.5]];
        let twin_hyper = GpHyper {
            signal_var: 1.0,
            length_scales: vec![0.5, 0.5],
            nugget_var: 0.0,
            mean: 0.0,
        };
        assert!(GaussianProcess::with_hyper(&twins, &[1.0, 2.0], &[0.0, 0.0], &twin_hyper).is_ok());
        // A signal variance whose products overflow: the factorisation fails.
        let huge = GpHyper {
            signal_var: f64::MAX,
            ..twin_hyper
        };
        assert_eq!(
            message(GaussianProcess::with_hyper(
                &twins,
                &[1.0, 2.0],
                &[0.0, 0.0],
                &huge
            )),
            format!(
                "the covariance matrix is not positive definite even with the jitter \
                 (signal variance {}, length scales [0.5, 0.5], diagonal addition {})",
                f64::MAX,
                1e-10 * f64::MAX
            )
        );
    }
    #[test]
    #[should_panic(expected = "predict: point has 3 coordinates, the process 2")]
    fn predict_refuses_a_point_of_the_wrong_dimension() {
        let (x, y) = data_2d();
        let gp = GaussianProcess::with_hyper(&x, &y, &[0.0; 8], &hyper_2d(&y)).unwrap();
        gp.predict(&[0.1, 0.2, 0.3]);
    }
}
