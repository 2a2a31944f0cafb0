//! Levenberg–Marquardt: the one damped Gauss–Newton loop of the project.
//! The GA-BP network's training (MATLAB `trainlm`'s schedule, he2019) and the
//! nonlinear least-squares fits of [`super::nlls`] (yan2015's power law,
//! FR(t)) are two settings of [`minimise`], not two loops.
//!
//! # Iteration
//!
//! The problem ([`LeastSquares`]) gives the objective S(θ) = Σᵢ eᵢ(θ)² +
//! λ‖θ‖² (λ ≥ 0 a ridge penalty, 0 for plain least squares) and the
//! residuals e = model − data with their Jacobian J = ∂e/∂θ. At the current
//! θ the gradient is g = Jᵀe + λθ and a trial step δ solves (JᵀJ + D) δ = −g
//! by Cholesky factorisation, with the damping D of [`Damping`]:
//!
//! - [`Damping::Identity`] (trainlm): D = (λ + μ) I; μ × `dec` after an
//!   accepted step, × `inc` after a rejected one, stop when μ > `max`;
//! - [`Damping::Marquardt`]: D = μ · diag(JᵀJ) (each entry floored at
//!   ε · its largest, so a flat direction still gets damping), invariant to
//!   the units of each parameter; μ ÷ 10 (at least the smallest positive
//!   float) after an accepted step, × 10 after a rejected one.
//!
//! A trial with a smaller S is accepted; a trial whose damped matrix is not
//! positive definite, or whose S is larger or not finite, is rejected. The
//! [`Stopping`] rules end the loop; each is off when `None`.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// A least-squares problem in parameters θ.
pub trait LeastSquares {
    /// S(θ) = Σ eᵢ² + λ‖θ‖²; NaN or ∞ where the model is not finite (such a
    /// trial is rejected).
    fn objective(&self, theta: &[f64]) -> f64;
    /// Residuals e(θ) = model − data and their Jacobian ∂e/∂θ (rows:
    /// observations), at a θ whose objective is finite.
    fn linearise(&self, theta: &[f64]) -> (DVector<f64>, DMatrix<f64>);
    /// The ridge penalty λ ≥ 0 inside [`objective`](Self::objective).
    fn penalty(&self) -> f64 {
        0.0
    }
}

/// How the normal matrix is damped and the damping adapted (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Damping {
    /// D = (λ + μ) I, MATLAB trainlm's schedule.
    Identity {
        /// μ₀.
        initial: f64,
        /// Factor on μ after an accepted step (< 1).
        dec: f64,
        /// Factor on μ after a rejected step (> 1).
        inc: f64,
        /// Stop ([`LmStop::MuMax`]) when μ exceeds this.
        max: f64,
    },
    /// D = μ · diag(JᵀJ), Marquardt's scaling; μ ÷ 10 / × 10.
    Marquardt {
        /// μ₀.
        initial: f64,
    },
}

/// When [`minimise`] stops; every rule is off when `None` (or `false`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stopping {
    /// Stop when S = 0 (an exact fit).
    pub exact: bool,
    /// Stop after this many accepted steps ([`LmStop::Epochs`]).
    pub max_accepted: Option<usize>,
    /// Give up after this many trial steps ([`LmStop::Iterations`]).
    pub max_trials: Option<usize>,
    /// Stop when max |gᵢ| falls below this.
    pub min_gradient: Option<f64>,
    /// Stop when the largest cosine |(Jᵀe)ⱼ| / √((JᵀJ)ⱼⱼ · S) between the
    /// residuals and a Jacobian column is at most this.
    pub gradient_cosine: Option<f64>,
    /// Stop after an accepted step that reduced S by at most this fraction.
    pub objective_gain: Option<f64>,
    /// Stop when a trial step is short: ‖δ‖ ≤ tol · (‖θ‖ + tol) (an accepted
    /// short step is taken first).
    pub step: Option<f64>,
}

/// Settings of [`minimise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmSettings {
    /// The damping and its schedule.
    pub damping: Damping,
    /// The stopping rules.
    pub stopping: Stopping,
}

/// Why [`minimise`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LmStop {
    /// The accepted-step budget was used up.
    Epochs,
    /// The gradient (or its cosine with the residuals) became negligible.
    Gradient,
    /// No step reduced S even with the largest damping.
    MuMax,
    /// S = 0.
    Exact,
    /// An accepted step gained at most the objective tolerance.
    SmallGain,
    /// A trial step was shorter than the step tolerance.
    ShortStep,
    /// The trial budget ran out before any other rule held.
    Iterations,
}

impl LmStop {
    /// True unless the trial budget ran out.
    pub fn converged(self) -> bool {
        self != LmStop::Iterations
    }
}

/// What [`minimise`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct LmOutcome {
    /// The parameters at the stop (never worse than the start).
    pub theta: Vec<f64>,
    /// S at the start.
    pub initial_objective: f64,
    /// S at `theta`.
    pub objective: f64,
    /// Accepted steps.
    pub accepted: usize,
    /// Trial steps (accepted or rejected).
    pub trials: usize,
    /// Why it stopped.
    pub stop: LmStop,
}

/// Minimises the problem's objective from `start` (module docs).
pub fn minimise<P: LeastSquares>(problem: &P, start: &[f64], settings: &LmSettings) -> LmOutcome {
    let stopping = &settings.stopping;
    let p = start.len();
    let lambda = problem.penalty();
    let mut theta = DVector::from_column_slice(start);
    let mut s = problem.objective(theta.as_slice());
    let initial = s;
    let mut mu = match settings.damping {
        Damping::Identity { initial, .. } | Damping::Marquardt { initial } => initial,
    };
    let (mut accepted, mut trials) = (0, 0);
    let stop = 'outer: loop {
        if stopping.exact && s == 0.0 {
            break LmStop::Exact;
        }
        if stopping.max_accepted.is_some_and(|m| accepted >= m) {
            break LmStop::Epochs;
        }
        let (e, jacobian) = problem.linearise(theta.as_slice());
        let jt = jacobian.transpose();
        let gradient = &jt * &e + &theta * lambda;
        if stopping.min_gradient.is_some_and(|t| gradient.amax() < t) {
            break LmStop::Gradient;
        }
        let jtj = &jt * &jacobian;
        if let Some(tolerance) = stopping.gradient_cosine {
            let cosine = (0..p)
                .map(|j| {
                    let d = jtj[(j, j)];
                    if d > 0.0 {
                        gradient[j].abs() / (d * s).sqrt()
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max);
            if cosine <= tolerance {
                break LmStop::Gradient;
            }
        }
        let floor = f64::EPSILON * (0..p).map(|j| jtj[(j, j)]).fold(0.0, f64::max);
        let rhs = -&gradient;
        loop {
            if let Damping::Identity { max, .. } = settings.damping {
                if mu > max {
                    break 'outer LmStop::MuMax;
                }
            }
            if stopping.max_trials.is_some_and(|m| trials >= m) {
                break 'outer LmStop::Iterations;
            }
            trials += 1;
            let normal = match settings.damping {
                Damping::Identity { .. } => &jtj + DMatrix::identity(p, p) * (lambda + mu),
                Damping::Marquardt { .. } => {
                    let mut damped = jtj.clone();
                    for j in 0..p {
                        damped[(j, j)] += mu * jtj[(j, j)].max(floor);
                    }
                    damped
                }
            };
            if let Some(cholesky) = normal.cholesky() {
                let step = cholesky.solve(&rhs);
                let short = stopping
                    .step
                    .is_some_and(|t| step.norm() <= t * (theta.norm() + t));
                let candidate = &theta + &step;
                let trial = problem.objective(candidate.as_slice());
                if trial < s {
                    let small_gain = stopping.objective_gain.is_some_and(|t| s - trial <= t * s);
                    mu = match settings.damping {
                        Damping::Identity { dec, .. } => mu * dec,
                        Damping::Marquardt { .. } => (mu / 10.0).max(f64::MIN_POSITIVE),
                    };
                    theta = candidate;
                    s = trial;
                    accepted += 1;
                    if short {
                        break 'outer LmStop::ShortStep;
                    }
                    if small_gain {
                        break 'outer LmStop::SmallGain;
                    }
                    continue 'outer;
                }
                if short {
                    break 'outer LmStop::ShortStep;
                }
            }
            mu *= match settings.damping {
                Damping::Identity { inc, .. } => inc,
                Damping::Marquardt { .. } => 10.0,
            };
        }
    };
    LmOutcome {
        theta: theta.as_slice().to_vec(),
        initial_objective: initial,
        objective: s,
        accepted,
        trials,
        stop,
    }
}
