//! The training objective of one network: scaled training data, the network
//! shape and an optional weight decay.
//!
//! E(θ) = (Σᵢ (f(xᵢ; θ) − tᵢ)² + λ Σₖ θₖ²) / N — the mean squared error of
//! he2019 §3.2 plus a ridge penalty λ on every weight and threshold. With
//! λ = 0 it is exactly the MSE. The genetic algorithm minimises E; Levenberg–
//! Marquardt minimises N·E as the sum of squares of the augmented residuals
//! [rᵢ; √λ θₖ].
//!
//! Effective degrees of freedom ([`Objective::effective_dof`]): the trace of
//! the hat matrix of the network linearised at its solution,
//! tr(J (JᵀJ + λI)⁻¹ Jᵀ) = Σᵢ sᵢ² / (sᵢ² + λ) over the singular values sᵢ of
//! the Jacobian J of the outputs with respect to the weights on the training
//! rows, λ the weight decay above. It counts how many directions of the data
//! the fit can follow: at most min(rows, weights), and equal to the number of
//! rows when the network can interpolate them. Without decay (λ = 0) it is
//! rank(J), counted with [`RANK_TOLERANCE`]. Levenberg–Marquardt's damping μ
//! does not enter: it steers the steps, it is not part of what is minimised.

use nalgebra::{DMatrix, DVector};

use super::network::Shape;

/// Relative rank tolerance of [`hat_trace`] without a penalty: a singular
/// value counts when it exceeds `RANK_TOLERANCE · max(rows, columns) · s_max`,
/// numpy.linalg.matrix_rank's default (ε of f64 times the larger dimension
/// times the largest singular value), i.e. what rounding alone can produce.
pub const RANK_TOLERANCE: f64 = f64::EPSILON;

/// tr(J (JᵀJ + λI)⁻¹ Jᵀ) for a Jacobian `jacobian` (rows × parameters) and
/// ridge penalty `penalty` λ ≥ 0 (in the units of JᵀJ): Σ s²/(s² + λ) over
/// J's singular values s, or for λ = 0 the numerical rank of J (module
/// docs). Dimensionless; between 0 and min(rows, parameters).
pub fn hat_trace(jacobian: &DMatrix<f64>, penalty: f64) -> f64 {
    if jacobian.is_empty() {
        return 0.0;
    }
    let s = jacobian.clone().svd(false, false).singular_values;
    if penalty > 0.0 {
        s.iter().map(|v| v * v / (v * v + penalty)).sum()
    } else {
        let largest = s.iter().copied().fold(0.0, f64::max);
        let size = jacobian.nrows().max(jacobian.ncols()) as f64;
        let tolerance = RANK_TOLERANCE * size * largest;
        s.iter().filter(|&&v| v > tolerance).count() as f64
    }
}

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

    /// Effective degrees of freedom of the network at θ on these rows: the
    /// [`hat_trace`] of its Jacobian with this objective's weight decay
    /// (module docs). Dimensionless, at most min(rows, weights).
    pub fn effective_dof(&self, theta: &[f64]) -> f64 {
        hat_trace(&self.linearise(theta).jacobian, self.weight_decay)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed 2-3-1 network (13 weights) and `n` fixed input rows; the
    /// targets do not enter the Jacobian.
    fn fixed(n: usize) -> (Shape, Vec<f64>, Vec<Vec<f64>>, Vec<f64>) {
        let shape = Shape {
            inputs: 2,
            hidden: 3,
        };
        let theta = (0..shape.parameter_count())
            .map(|k| 1.3 * (0.731 * k as f64).sin())
            .collect();
        let xs = (0..n)
            .map(|i| {
                let i = i as f64;
                vec![(1.7 * i + 0.3).sin(), (0.9 * i).cos()]
            })
            .collect();
        (shape, theta, xs, vec![0.0; n])
    }

    fn dof(n: usize, weight_decay: f64) -> f64 {
        let (shape, theta, xs, ts) = fixed(n);
        let objective = Objective {
            shape,
            xs: &xs,
            ts: &ts,
            weight_decay,
        };
        objective.effective_dof(&theta)
    }

    // Expected values from an independent numpy implementation of the same
    // network and its Jacobian (numpy 2, written for this test):
    //   m, h = 2, 3; p = h*(m+2)+1; th = 1.3*np.sin(0.731*np.arange(p))
    //   W1, b1, w2 = th[:h*m].reshape(h, m), th[h*m:h*m+h], th[h*m+h:h*m+2*h]
    //   i = np.arange(n); X = np.column_stack([np.sin(1.7*i+0.3), np.cos(0.9*i)])
    //   A = 1/(1+np.exp(-(X @ W1.T + b1))); D = A*(1-A)*w2
    //   J = np.hstack([(D[:,:,None]*X[:,None,:]).reshape(n, h*m), D, A, np.ones((n,1))])
    //   λ = 0: np.linalg.matrix_rank(J)
    //   λ > 0: np.trace(J @ np.linalg.solve(J.T @ J + lam*np.eye(p), J.T))

    #[test]
    fn many_rows_give_the_parameter_count() {
        // 40 rows ≫ 13 weights, no decay: np.linalg.matrix_rank(J) = 13.
        assert_eq!(dof(40, 0.0), 13.0);
    }

    #[test]
    fn few_rows_cap_the_dof_at_the_row_count() {
        // 5 rows < 13 weights, no decay: np.linalg.matrix_rank(J) = 5.
        assert_eq!(dof(5, 0.0), 5.0);
    }

    #[test]
    fn weight_decay_gives_the_numpy_hat_trace() {
        // n = 40, lam = 0.01: np.trace(...) = 6.011758388758711
        let a = dof(40, 0.01);
        assert!((a - 6.011758388758711).abs() < 1e-9, "{a}");
        // n = 5, lam = 0.1: np.trace(...) = 2.752267750269316
        let b = dof(5, 0.1);
        assert!((b - 2.752267750269316).abs() < 1e-9, "{b}");
    }

    #[test]
    fn an_empty_jacobian_has_no_dof() {
        assert_eq!(hat_trace(&DMatrix::zeros(0, 4), 0.0), 0.0);
    }
}
