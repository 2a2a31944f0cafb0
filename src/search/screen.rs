//! Screening by main effects: which calibrated parameters move a surrogate's
//! prediction by more than the noise of one run, so a search can calibrate
//! those and fix the rest at the centre of their ranges.
//!
//! # Main effect
//!
//! For a prediction μ(x) on the unit cube [0, 1]^d, the main effect of input
//! k is the function
//!
//! m_k(u) = E[μ(x) | x_k = u],
//!
//! the prediction averaged over the other inputs (uniform on their ranges),
//! estimated here on [`GRID`] equally spaced values of u ∈ [0, 1] as the mean
//! over a fixed set of points of the cube (`others`, e.g. a Latin hypercube)
//! with their coordinate k replaced by u. Its **range** max m_k − min m_k is
//! how far the predicted response moves, on average, when the parameter
//! sweeps its whole range: the same quantity a one-factor screening design
//! estimates, read from the surrogate instead of from new runs (so the
//! screening costs no simulation and the run budget is unchanged).
//!
//! # The rule
//!
//! A parameter is **above the noise** when its main-effect range is at least
//! the `threshold` (the study passes the seed-to-seed σ of one run): an
//! effect below one run's noise over the parameter's whole range is one the
//! runs cannot resolve, and fixing the parameter at its centre moves the
//! response by less than that. When screening, only the parameters above the
//! noise are **active** (searched); the others are fixed at the centre (0.5
//! in the unit cube). At least one parameter stays active: when every range
//! is below the threshold, the largest is kept, so a search still has
//! something to vary (and the report says that nothing beats the noise).
//! Without screening every parameter is active and the ranges are reported
//! only.

use serde::{Deserialize, Serialize};

/// Values of u ∈ [0, 1] at which each main effect is evaluated (0, 0.1, …,
/// 1).
pub const GRID: usize = 11;

/// One input's main effect and the screening decision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MainEffect {
    /// Input name.
    pub parameter: String,
    /// max − min of m_k over the grid, units of the prediction.
    pub range: f64,
    /// u ∈ [0, 1] (unit cube) where m_k is largest.
    pub argmax_unit: f64,
    /// Range ≥ the threshold.
    pub above_noise: bool,
    /// Searched (true) or fixed at the centre (false).
    pub active: bool,
}

/// The main effects of `predict` (a function on the unit cube of
/// `names.len()` inputs) averaged over `others` (points of the cube), which
/// are above `threshold` (units of the prediction, ≥ 0) and, when
/// `screen`, which the rule (module docs) keeps active.
pub fn main_effects(
    names: &[String],
    predict: impl Fn(&[f64]) -> f64,
    others: &[Vec<f64>],
    threshold: f64,
    screen: bool,
) -> Vec<MainEffect> {
    let mut effects: Vec<MainEffect> = names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let curve: Vec<f64> = (0..GRID)
                .map(|g| {
                    let u = g as f64 / (GRID - 1) as f64;
                    let sum: f64 = others
                        .iter()
                        .map(|x| {
                            let mut x = x.clone();
                            x[k] = u;
                            predict(&x)
                        })
                        .sum();
                    sum / others.len().max(1) as f64
                })
                .collect();
            let (lo, hi) = curve
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                });
            let argmax = (0..GRID)
                .max_by(|&a, &b| curve[a].total_cmp(&curve[b]))
                .unwrap_or(0);
            MainEffect {
                parameter: name.clone(),
                range: hi - lo,
                argmax_unit: argmax as f64 / (GRID - 1) as f64,
                above_noise: hi - lo >= threshold,
                active: !screen || hi - lo >= threshold,
            }
        })
        .collect();
    if !effects.iter().any(|e| e.active) {
        if let Some(largest) = effects
            .iter_mut()
            .max_by(|a, b| a.range.total_cmp(&b.range))
        {
            largest.active = true;
        }
    }
    effects
}

/// `unit` with every inactive input of `effects` set to the centre 0.5; an
/// input without an effect (none screened, as in a model written before
/// screening) stays as it is.
pub fn fix_inactive(unit: &[f64], effects: &[MainEffect]) -> Vec<f64> {
    unit.iter()
        .enumerate()
        .map(|(k, &u)| match effects.get(k) {
            Some(e) if !e.active => 0.5,
            _ => u,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(d: usize) -> Vec<String> {
        (0..d).map(|k| format!("p{k}")).collect()
    }

    fn cube(n: usize, d: usize) -> Vec<Vec<f64>> {
        // A deterministic spread of points: (i + 0.5)/n shifted per axis.
        (0..n)
            .map(|i| {
                (0..d)
                    .map(|k| ((i * (2 * k + 1) + k) % n) as f64 / n as f64 + 0.5 / n as f64)
                    .collect()
            })
            .collect()
    }

    /// An additive function's main effects are its terms: 10·x₀ has range
    /// 10, 0.5·x₁ range 0.5, x₂ none; at threshold 1 only x₀ is active.
    #[test]
    fn additive_terms_are_their_main_effects() {
        let f = |x: &[f64]| 10.0 * x[0] + 0.5 * x[1] + 3.0;
        let e = main_effects(&names(3), f, &cube(16, 3), 1.0, true);
        assert!((e[0].range - 10.0).abs() < 1e-12);
        assert!((e[1].range - 0.5).abs() < 1e-12);
        assert!(e[2].range.abs() < 1e-12);
        assert_eq!(
            e.iter().map(|e| e.active).collect::<Vec<_>>(),
            [true, false, false]
        );
        assert_eq!(e[0].argmax_unit, 1.0);
        let all = main_effects(&names(3), f, &cube(16, 3), 1.0, false);
        assert!(all.iter().all(|e| e.active));
        assert!(!all[1].above_noise);
        assert_eq!(fix_inactive(&[0.2, 0.9, 0.1], &e), [0.2, 0.5, 0.5]);
    }

    /// An interaction averages out of a main effect: x₀·(x₁ − ½) has no main
    /// effect in x₀ over a sample whose x₁ averages ½, and a quadratic bowl
    /// (x₀ − ½)² has range ¼ with its maximum at an end.
    #[test]
    fn interactions_average_out_and_curvature_counts() {
        let others = cube(16, 2);
        let mean_x1 = others.iter().map(|x| x[1]).sum::<f64>() / 16.0;
        assert!((mean_x1 - 0.5).abs() < 1e-12);
        let e = main_effects(&names(2), |x| x[0] * (x[1] - 0.5), &others, 0.01, true);
        assert!(e[0].range < 1e-12, "{e:?}");
        let bowl = main_effects(&names(2), |x| (x[0] - 0.5).powi(2), &others, 0.01, true);
        assert!((bowl[0].range - 0.25).abs() < 1e-12);
    }

    /// Nothing above the threshold: the largest effect stays active.
    #[test]
    fn one_input_always_stays_active() {
        let e = main_effects(
            &names(2),
            |x| 0.1 * x[0] + 0.2 * x[1],
            &cube(8, 2),
            5.0,
            true,
        );
        assert_eq!(e.iter().filter(|e| e.active).count(), 1);
        assert!(e[1].active);
    }
}
