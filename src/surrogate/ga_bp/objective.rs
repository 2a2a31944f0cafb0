//! The training objective of one network: scaled training data, the network
//! shape and an optional weight decay.
//!
//! E(θ) = (Σᵢ (f(xᵢ; θ) − tᵢ)² + λ Σₖ θₖ²) / N — the mean squared error of
//! he2019 §3.2 plus a ridge penalty λ on every weight and threshold. With
//! λ = 0 it is exactly the MSE. The genetic algorithm minimises E; Levenberg–
//! Marquardt minimises N·E as the sum of squares of the augmented residuals
//! [rᵢ; √λ θₖ].

use nalgebra::{DMatrix, DVector};

use super::network::Shape;

/// Scaled training data for one network shape.
#[derive(Debug, Clone)]
pub struct Objective<'a> {
    /// The network shape (its `inputs` equals the length of every `xs` row).
    pub shape: Shape,
    /// Scaled inputs, one row per training sample.
    pub xs: &'a [Vec<f64>],
    /// Scaled targets, one per row of `xs`.
    pub ts: &'a [f64],
    /// Ridge penalty λ (≥ 0) on the weights and thresholds, in units of the
    /// squared scaled output.
    pub weight_decay: f64,
}

/// Residuals r = f(x; θ) − t and their Jacobian dr/dθ (one row per sample).
#[derive(Debug, Clone)]
pub struct Linearisation {
    /// Residuals, one per sample.
    pub residuals: DVector<f64>,
    /// Jacobian, samples × parameters.
    pub jacobian: DMatrix<f64>,
}

impl Objective<'_> {
    /// Number of training samples N.
    pub fn len(&self) -> usize {
        self.ts.len()
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.ts.is_empty()
    }

    /// N·E(θ): squared residuals plus λ|θ|².
    pub fn sum_of_squares(&self, theta: &[f64]) -> f64 {
        let data: f64 = self
            .xs
            .iter()
            .zip(self.ts)
            .map(|(x, t)| (self.shape.forward(theta, x) - t).powi(2))
            .sum();
        data + self.penalty(theta)
    }

    /// λ|θ|².
    pub fn penalty(&self, theta: &[f64]) -> f64 {
        self.weight_decay * theta.iter().map(|w| w * w).sum::<f64>()
    }

    /// E(θ) = [`Objective::sum_of_squares`] / N (+∞ when not finite, so a
    /// diverged genome always ranks last).
    pub fn mean(&self, theta: &[f64]) -> f64 {
        let e = self.sum_of_squares(theta) / self.len().max(1) as f64;
        if e.is_finite() {
            e
        } else {
            f64::INFINITY
        }
    }

    /// Residuals and Jacobian at θ (data part only; the penalty's are √λ θ and
    /// √λ I).
    pub fn linearise(&self, theta: &[f64]) -> Linearisation {
        let p = self.shape.parameter_count();
        let n = self.len();
        let mut residuals = DVector::zeros(n);
        let mut jacobian = DMatrix::zeros(n, p);
        let mut row = vec![0.0; p];
        for (i, (x, t)) in self.xs.iter().zip(self.ts).enumerate() {
            residuals[i] = self.shape.forward_with_gradient(theta, x, &mut row) - t;
            for (k, g) in row.iter().enumerate() {
                jacobian[(i, k)] = *g;
            }
        }
        Linearisation {
            residuals,
            jacobian,
        }
    }
}
