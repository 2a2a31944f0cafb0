//! The back-propagation network of he2019 §3.2 (Fig. 10): one hidden layer of
//! logistic-sigmoid neurons and a linear output neuron.
//!
//! All weights and thresholds (biases) live in one flat vector so the genetic
//! algorithm and Levenberg–Marquardt see the same genome. Layout for `m` inputs
//! and `h` hidden neurons (`h·(m + 2) + 1` numbers):
//!
//! ```text
//! [ W1 (h × m, row j = hidden neuron j) | b1 (h) | w2 (h) | b2 ]
//! ```
//!
//! Inputs and output are in scaled units (see [`super::Scale`]);
//! the network itself knows nothing of physical units.

/// Shape of a one-hidden-layer network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    /// Number of inputs `m`.
    pub inputs: usize,
    /// Number of hidden neurons `h`.
    pub hidden: usize,
}

/// The logistic sigmoid 1 / (1 + e^−z) (he2019's "Sigmoid weighting function").
pub fn sigmoid(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

impl Shape {
    /// Number of weights and thresholds: `h·(m + 2) + 1`.
    pub fn parameter_count(&self) -> usize {
        self.hidden * (self.inputs + 2) + 1
    }

    fn b1(&self) -> usize {
        self.hidden * self.inputs
    }

    fn w2(&self) -> usize {
        self.b1() + self.hidden
    }

    fn b2(&self) -> usize {
        self.w2() + self.hidden
    }

    /// The network output for input `x` (length `inputs`) with parameters
    /// `theta` (length [`Shape::parameter_count`]).
    pub fn forward(&self, theta: &[f64], x: &[f64]) -> f64 {
        debug_assert_eq!(theta.len(), self.parameter_count());
        debug_assert_eq!(x.len(), self.inputs);
        let mut y = theta[self.b2()];
        for j in 0..self.hidden {
            y += theta[self.w2() + j] * self.activation(theta, x, j);
        }
        y
    }

    /// Activation of hidden neuron `j`.
    fn activation(&self, theta: &[f64], x: &[f64], j: usize) -> f64 {
        let row = &theta[j * self.inputs..(j + 1) * self.inputs];
        let z = theta[self.b1() + j] + row.iter().zip(x).map(|(w, x)| w * x).sum::<f64>();
        sigmoid(z)
    }

    /// The output for `x` and its gradient with respect to every parameter
    /// (written into `grad`, length [`Shape::parameter_count`]): the row of the
    /// Jacobian that back-propagation and Levenberg–Marquardt use.
    pub fn forward_with_gradient(&self, theta: &[f64], x: &[f64], grad: &mut [f64]) -> f64 {
        debug_assert_eq!(grad.len(), self.parameter_count());
        let mut y = theta[self.b2()];
        for j in 0..self.hidden {
            let a = self.activation(theta, x, j);
            let w = theta[self.w2() + j];
            y += w * a;
            // dy/dz_j = w2_j σ'(z_j), σ' = σ (1 − σ)
            let delta = w * a * (1.0 - a);
            for (k, xk) in x.iter().enumerate() {
                grad[j * self.inputs + k] = delta * xk;
            }
            grad[self.b1() + j] = delta;
            grad[self.w2() + j] = a;
        }
        grad[self.b2()] = 1.0;
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> (Shape, Vec<f64>) {
        let shape = Shape {
            inputs: 3,
            hidden: 4,
        };
        // Arbitrary but fixed, of order one, so no neuron saturates.
        let theta = (0..shape.parameter_count())
            .map(|i| ((i as f64) * 0.731).sin() * 1.3)
            .collect();
        (shape, theta)
    }

    #[test]
    fn parameter_count_follows_the_layout() {
        // he2019's best network: 5 inputs, 7 hidden: 7·5 + 7 + 7 + 1 = 50.
        let s = Shape {
            inputs: 5,
            hidden: 7,
        };
        assert_eq!(s.parameter_count(), 50);
    }

    #[test]
    fn gradient_matches_central_finite_differences() {
        // The analytic gradient must agree with (f(θ+ε) − f(θ−ε)) / 2ε, whose
        // error is O(ε²) ≈ 1e-12 here; 1e-8 leaves room for rounding.
        let (shape, theta) = example();
        let x = [0.3, -0.7, 0.9];
        let mut grad = vec![0.0; shape.parameter_count()];
        let y = shape.forward_with_gradient(&theta, &x, &mut grad);
        assert_eq!(y, shape.forward(&theta, &x));
        let eps = 1e-6;
        for i in 0..theta.len() {
            let mut plus = theta.clone();
            plus[i] += eps;
            let mut minus = theta.clone();
            minus[i] -= eps;
            let fd = (shape.forward(&plus, &x) - shape.forward(&minus, &x)) / (2.0 * eps);
            assert!(
                (fd - grad[i]).abs() < 1e-8,
                "parameter {i}: analytic {} vs finite difference {fd}",
                grad[i]
            );
        }
    }

    #[test]
    fn a_single_neuron_is_a_scaled_sigmoid() {
        // m = 1, h = 1: y = w2 σ(w1 x + b1) + b2, by hand at x = 0.5.
        let shape = Shape {
            inputs: 1,
            hidden: 1,
        };
        let theta = [2.0, -1.0, 3.0, 0.5];
        let expected = 3.0 * sigmoid(2.0 * 0.5 - 1.0) + 0.5;
        assert_eq!(shape.forward(&theta, &[0.5]), expected);
        assert_eq!(expected, 2.0); // σ(0) = 1/2
    }
}
