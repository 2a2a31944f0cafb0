//! Fit metrics: he2019 Eq. 7 (coefficient of determination), the mean
//! squared error, and the ceiling the noise of the targets sets on R².
//!
//! # The noise ceiling
//!
//! A surrogate is scored against replicate means, which carry their own
//! noise: with a signal of variance S² across the points and a per-run noise
//! σ², a k-seed mean has variance σ²/k about the truth, so even the true
//! response function scores R² ≈ S² / (S² + σ²/k) against them, and an RMSE
//! of about σ/√k. [`noise_ceiling`] estimates S² from the targets themselves
//! (their sample variance less the mean noise variance of a mean, clipped at
//! 0), so a printed R² can be read beside what the noise allows.

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

/// What the noise of the targets allows a surrogate (see the module docs);
/// variances in the targets' units squared.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NoiseCeiling {
    /// Estimated signal variance S² across the targets.
    pub signal_var: f64,
    /// Mean noise variance of one target (σ²/k averaged over the targets).
    pub noise_var: f64,
    /// The R² a perfect model reaches in expectation, S² / (S² + σ²/k).
    pub r2_ceiling: f64,
    /// The RMSE a perfect model reaches, √(σ²/k).
    pub rmse_floor: f64,
    /// Signal-to-noise ratio of the targets, S / √(σ²/k).
    pub signal_to_noise: f64,
}

/// The R² ceiling of a signal variance `signal_var` against means whose noise
/// variance is `noise_var`: S² / (S² + σ²/k). 0 when both are 0.
pub fn r2_ceiling(signal_var: f64, noise_var: f64) -> f64 {
    let total = signal_var + noise_var;
    if total > 0.0 {
        signal_var / total
    } else {
        0.0
    }
}

/// The ceiling for `targets` (replicate means) whose noise variances are
/// `noise_vars` (σ²/kᵢ each); `None` for fewer than two targets.
pub fn noise_ceiling(targets: &[f64], noise_vars: &[f64]) -> Option<NoiseCeiling> {
    assert_eq!(targets.len(), noise_vars.len(), "paired values");
    let n = targets.len();
    if n < 2 {
        return None;
    }
    let mean = targets.iter().sum::<f64>() / n as f64;
    let observed = targets.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let noise_var = noise_vars.iter().sum::<f64>() / n as f64;
    let signal_var = (observed - noise_var).max(0.0);
    Some(NoiseCeiling {
        signal_var,
        noise_var,
        r2_ceiling: r2_ceiling(signal_var, noise_var),
        rmse_floor: noise_var.sqrt(),
        signal_to_noise: if noise_var > 0.0 {
            (signal_var / noise_var).sqrt()
        } else {
            f64::INFINITY
        },
    })
}

/// Seeds per point that lift the ceiling of a signal variance `signal_var`
/// with per-run noise variance `sigma2` to at least `ceiling` (in (0, 1)):
/// the least k with S² / (S² + σ²/k) ≥ ceiling; `None` without a signal.
pub fn seeds_for_ceiling(signal_var: f64, sigma2: f64, ceiling: f64) -> Option<usize> {
    if signal_var <= 0.0 || !(0.0..1.0).contains(&ceiling) {
        return None;
    }
    let k = ceiling * sigma2 / ((1.0 - ceiling) * signal_var);
    let mut seeds = (k.ceil() as usize).max(1);
    // Guard the rounding at an exact boundary.
    while r2_ceiling(signal_var, sigma2 / seeds as f64) < ceiling {
        seeds += 1;
    }
    Some(seeds)
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

    /// The numbers: S = 5°, σ = 4.1°: 25 / (25 + 16.81 / k) is 0.60
    /// for k = 1, 0.75 for k = 2 and 0.88 for k = 5.
    #[test]
    fn the_ceiling_by_hand() {
        let (s2, sigma2) = (25.0, 4.1f64 * 4.1);
        let c = |k: f64| r2_ceiling(s2, sigma2 / k);
        assert!((c(1.0) - 25.0 / 41.81).abs() < 1e-12);
        assert_eq!(
            [c(1.0), c(2.0), c(5.0)].map(|v| (100.0 * v).round() / 100.0),
            [0.60, 0.75, 0.88]
        );
        // 0.9 needs k ≥ 0.9 · 16.81 / (0.1 · 25) = 6.05: 7 seeds.
        assert_eq!(seeds_for_ceiling(s2, sigma2, 0.9), Some(7));
        assert_eq!(seeds_for_ceiling(0.0, sigma2, 0.9), None);
        // Targets 1, 3, 5 (sample variance 4) with noise variance 1 each:
        // S² = 3, ceiling 3/4, RMSE floor 1, S/N √3.
        let n = noise_ceiling(&[1.0, 3.0, 5.0], &[1.0; 3]).unwrap();
        assert_eq!((n.signal_var, n.noise_var, n.r2_ceiling), (3.0, 1.0, 0.75));
        assert_eq!(n.rmse_floor, 1.0);
        assert!((n.signal_to_noise - 3f64.sqrt()).abs() < 1e-12);
        // Noise larger than the spread: no signal, ceiling 0.
        assert_eq!(
            noise_ceiling(&[1.0, 2.0], &[4.0; 2]).unwrap().r2_ceiling,
            0.0
        );
        assert!(noise_ceiling(&[1.0], &[1.0]).is_none());
    }

    #[test]
    fn mse_by_hand() {
        assert_eq!(mse(&[1.0, 2.0], &[2.0, 4.0]), 2.5);
    }
}
