//! Levenberg–Marquardt refinement of the network weights, as MATLAB's `trainlm`
//! (used by he2019) does it: the one loop of [`crate::stats::levenberg`] with
//! identity damping — solve (JᵀJ + μI) δ = −Jᵀr, accept the step and
//! multiply μ by `mu_dec` when the sum of squares falls, else multiply μ by
//! `mu_inc` and retry; stop after `epochs` accepted steps, when the largest
//! gradient component falls below `min_gradient`, or when μ exceeds `mu_max`.
//! trainlm's defaults are μ₀ = 0.001, μ_dec = 0.1, μ_inc = 10, μ_max = 1e10,
//! min_grad = 1e-7 ([`TrainlmSettings::default`]); the 200-step budget is ours and
//! doubles as early stopping (see [`super`] for what it does on
//! he2019's Table A1).
//!
//! The weight decay of [`Objective`] enters as augmented residuals √λ θ, so
//! the normal matrix becomes JᵀJ + (λ + μ) I and the gradient Jᵀr + λθ.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::objective::Objective;
use crate::stats::levenberg::{minimise, Damping, LeastSquares, LmOutcome, LmSettings, Stopping};

/// trainlm's settings of the refinement, as a study records them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainlmSettings {
    /// Maximum number of accepted steps.
    pub epochs: usize,
    /// Initial damping μ₀.
    pub mu_initial: f64,
    /// Factor applied to μ after an accepted step (< 1).
    pub mu_dec: f64,
    /// Factor applied to μ after a rejected step (> 1).
    pub mu_inc: f64,
    /// Stop when μ exceeds this.
    pub mu_max: f64,
    /// Stop when max |gradient component| of the sum of squares falls below this.
    pub min_gradient: f64,
}

impl Default for TrainlmSettings {
    /// MATLAB trainlm's damping schedule with a 200-step budget.
    fn default() -> Self {
        TrainlmSettings {
            epochs: 200,
            mu_initial: 1e-3,
            mu_dec: 0.1,
            mu_inc: 10.0,
            mu_max: 1e10,
            min_gradient: 1e-7,
        }
    }
}

impl TrainlmSettings {
    /// The settings of the one Levenberg–Marquardt loop.
    pub fn lm(&self) -> LmSettings {
        LmSettings {
            damping: Damping::Identity {
                initial: self.mu_initial,
                dec: self.mu_dec,
                inc: self.mu_inc,
                max: self.mu_max,
            },
            stopping: Stopping {
                max_accepted: Some(self.epochs),
                min_gradient: Some(self.min_gradient),
                ..Stopping::default()
            },
        }
    }
}

impl LeastSquares for Objective<'_> {
    fn objective(&self, theta: &[f64]) -> f64 {
        self.sum_of_squares(theta)
    }

    fn linearise(&self, theta: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let lin = Objective::linearise(self, theta);
        (lin.residuals, lin.jacobian)
    }

    fn penalty(&self) -> f64 {
        self.weight_decay
    }
}

/// Refines `theta` by Levenberg–Marquardt on `objective`. Never returns worse
/// parameters than it was given.
/// The outcome's objective is the sum of squares with the penalty, and its
/// accepted steps are trainlm's epochs.
pub fn refine(objective: &Objective, theta: &[f64], settings: &TrainlmSettings) -> LmOutcome {
    minimise(objective, theta, &settings.lm())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surrogate::ga_bp::network::Shape;

    #[test]
    fn recovers_a_network_that_generated_the_data() {
        // Targets made by a known 1-2-1 network; LM started nearby must drive
        // the error to (numerically) zero: the model can represent the data exactly.
        let shape = Shape {
            inputs: 1,
            hidden: 2,
        };
        let truth = [3.0, -2.0, 0.5, 1.0, 1.5, -1.0, 0.2];
        let xs: Vec<Vec<f64>> = (0..20).map(|i| vec![-1.0 + i as f64 / 9.5]).collect();
        let ts: Vec<f64> = xs.iter().map(|x| shape.forward(&truth, x)).collect();
        let objective = Objective {
            shape,
            xs: &xs,
            ts: &ts,
            weight_decay: 0.0,
        };
        let start: Vec<f64> = truth.iter().map(|w| w * 0.8 + 0.1).collect();
        let out = refine(&objective, &start, &TrainlmSettings::default());
        assert!(out.initial_objective > 1e-2, "{out:?}");
        assert!(out.objective < 1e-16, "{out:?}");
    }

    #[test]
    fn never_returns_a_worse_point() {
        let shape = Shape {
            inputs: 1,
            hidden: 1,
        };
        let xs = vec![vec![0.0], vec![1.0]];
        let ts = vec![0.0, 1.0];
        let objective = Objective {
            shape,
            xs: &xs,
            ts: &ts,
            weight_decay: 0.1,
        };
        let start = [0.3, 0.1, 0.7, -0.2];
        let out = refine(&objective, &start, &TrainlmSettings::default());
        assert!(out.objective <= out.initial_objective);
        assert_eq!(out.objective, objective.sum_of_squares(&out.theta));
    }
}
