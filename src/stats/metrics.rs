//! Fit metrics: he2019 Eq. 7 (coefficient of determination) and the mean
//! squared error.

/// he2019 Eq. 7: R² = 1 − Σ(yᵢ − ŷᵢ)² / Σ(yᵢ − ȳ)², with `simulated` the yᵢ and
/// `predicted` the ŷᵢ. `None` when there are no points or the simulated values
/// are all equal (the denominator is zero and R² is undefined).
pub fn r_squared(simulated: &[f64], predicted: &[f64]) -> Option<f64> {
    assert_eq!(simulated.len(), predicted.len(), "paired values");
    if simulated.is_empty() {
        return None;
    }
    let mean = simulated.iter().sum::<f64>() / simulated.len() as f64;
    let total: f64 = simulated.iter().map(|y| (y - mean).powi(2)).sum();
    if total == 0.0 {
        return None;
    }
    let residual: f64 = simulated
        .iter()
        .zip(predicted)
        .map(|(y, p)| (y - p).powi(2))
        .sum();
    Some(1.0 - residual / total)
}

/// Mean squared error between paired values (0 for none).
pub fn mse(simulated: &[f64], predicted: &[f64]) -> f64 {
    assert_eq!(simulated.len(), predicted.len(), "paired values");
    if simulated.is_empty() {
        return 0.0;
    }
    simulated
        .iter()
        .zip(predicted)
        .map(|(y, p)| (y - p).powi(2))
        .sum::<f64>()
        / simulated.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn r_squared_by_hand() {
        // y = 1, 2, 3 (mean 2, total 2); ŷ = 1, 2, 4 (residual 1): 1 − 1/2.
        assert_eq!(r_squared(&[1.0, 2.0, 3.0], &[1.0, 2.0, 4.0]), Some(0.5));
        assert_eq!(r_squared(&[1.0, 2.0, 3.0], &[1.0, 2.0, 3.0]), Some(1.0));
        // Predicting the mean everywhere scores 0.
        assert_eq!(r_squared(&[1.0, 2.0, 3.0], &[2.0; 3]), Some(0.0));
        assert_eq!(r_squared(&[2.0, 2.0], &[1.0, 3.0]), None);
        assert_eq!(r_squared(&[], &[]), None);
    }

    #[test]
    fn mse_by_hand() {
        assert_eq!(mse(&[1.0, 2.0], &[2.0, 4.0]), 2.5);
    }
}
