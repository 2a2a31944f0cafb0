//! Mean-shift clustering (he2019 §3.5.2: kernel-density hill climbing that
//! needs no cluster count; Comaniciu & Meer 2002).
//!
//! Every point starts a climb: x ← Σ K(|x − pᵢ|/h) pᵢ / Σ K(|x − pᵢ|/h), with
//! the flat kernel (K = 1 within the bandwidth h, else 0) or the Gaussian
//! kernel (K = exp(−|x − pᵢ|²/2h²)), until the shift is below 10⁻³ h or after
//! 300 iterations (scikit-learn's MeanShift stopping rule). The modes reached
//! are merged greedily in order of decreasing kernel density (ties by the
//! index of the starting point): a mode within h of an already kept centre
//! joins it — scikit-learn's rule for removing near-duplicate centres. Each
//! point is labelled with the centre its own climb ended at (he2019: a point
//! belongs to the mode its climb visits), and clusters are numbered by
//! decreasing size (ties by centre coordinates).
//!
//! The bandwidth may be given or estimated by [`estimate_bandwidth`].

use serde::{Deserialize, Serialize};

use crate::doe::lhs::distance;

/// The kernel of the density estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    /// 1 within the bandwidth, 0 beyond (scikit-learn's MeanShift).
    Flat,
    /// exp(−d²/2h²).
    Gaussian,
}

/// Climbs stop when a shift is shorter than this fraction of the bandwidth.
pub const STOP_FRACTION: f64 = 1e-3;
/// Climbs stop after this many iterations at the latest.
pub const MAX_ITERATIONS: usize = 300;

/// The result of [`mean_shift`].
#[derive(Debug, Clone, PartialEq)]
pub struct Clustering {
    /// Cluster centres (modes), largest cluster first.
    pub centres: Vec<Vec<f64>>,
    /// Points per cluster.
    pub sizes: Vec<usize>,
    /// Cluster of every input point.
    pub labels: Vec<usize>,
    /// Distinct modes reached before merging.
    pub modes: usize,
}

/// The bandwidth of scikit-learn's `estimate_bandwidth`: with k = ⌊n · quantile⌋
/// (at least 1), the mean over points of the distance to the k-th nearest
/// point, the point itself counting as the first (distance 0).
pub fn estimate_bandwidth(points: &[Vec<f64>], quantile: f64) -> f64 {
    let n = points.len();
    if n == 0 {
        return 0.0;
    }
    let k = ((n as f64 * quantile).floor() as usize).clamp(1, n);
    let total: f64 = points
        .iter()
        .map(|p| {
            let mut d: Vec<f64> = points.iter().map(|q| distance(p, q)).collect();
            d.sort_by(f64::total_cmp);
            d[k - 1]
        })
        .sum();
    total / n as f64
}

fn weight(kernel: Kernel, d: f64, h: f64) -> f64 {
    match kernel {
        Kernel::Flat => {
            if d <= h {
                1.0
            } else {
                0.0
            }
        }
        Kernel::Gaussian => (-(d * d) / (2.0 * h * h)).exp(),
    }
}

/// Kernel density (unnormalised) at `x`.
fn density(points: &[Vec<f64>], x: &[f64], kernel: Kernel, h: f64) -> f64 {
    points
        .iter()
        .map(|p| weight(kernel, distance(x, p), h))
        .sum()
}

/// One climb from `start` to a mode.
fn climb(points: &[Vec<f64>], start: &[f64], kernel: Kernel, h: f64) -> Vec<f64> {
    let mut x = start.to_vec();
    for _ in 0..MAX_ITERATIONS {
        let mut sum = vec![0.0; x.len()];
        let mut total = 0.0;
        for p in points {
            let w = weight(kernel, distance(&x, p), h);
            if w > 0.0 {
                total += w;
                for (s, v) in sum.iter_mut().zip(p) {
                    *s += w * v;
                }
            }
        }
        if total == 0.0 {
            break;
        }
        let next: Vec<f64> = sum.iter().map(|s| s / total).collect();
        let shift = distance(&next, &x);
        x = next;
        if shift < STOP_FRACTION * h {
            break;
        }
    }
    x
}

/// Clusters `points` by mean shift with bandwidth `h` (> 0).
pub fn mean_shift(points: &[Vec<f64>], kernel: Kernel, h: f64) -> Clustering {
    let modes: Vec<Vec<f64>> = points.iter().map(|p| climb(points, p, kernel, h)).collect();
    let densities: Vec<f64> = modes
        .iter()
        .map(|m| density(points, m, kernel, h))
        .collect();
    let mut order: Vec<usize> = (0..modes.len()).collect();
    order.sort_by(|&a, &b| densities[b].total_cmp(&densities[a]).then(a.cmp(&b)));
    let mut centres: Vec<Vec<f64>> = Vec::new();
    let mut mode_centre = vec![0; modes.len()];
    for &i in &order {
        match centres.iter().position(|c| distance(c, &modes[i]) <= h) {
            Some(c) => mode_centre[i] = c,
            None => {
                mode_centre[i] = centres.len();
                centres.push(modes[i].clone());
            }
        }
    }
    let mut sizes = vec![0; centres.len()];
    for &c in &mode_centre {
        sizes[c] += 1;
    }
    // Renumber: largest first, ties by centre coordinates.
    let mut rank: Vec<usize> = (0..centres.len()).collect();
    rank.sort_by(|&a, &b| {
        sizes[b].cmp(&sizes[a]).then_with(|| {
            centres[a]
                .iter()
                .zip(&centres[b])
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    let mut new_label = vec![0; centres.len()];
    for (new, &old) in rank.iter().enumerate() {
        new_label[old] = new;
    }
    Clustering {
        centres: rank.iter().map(|&c| centres[c].clone()).collect(),
        sizes: rank.iter().map(|&c| sizes[c]).collect(),
        labels: mode_centre.iter().map(|&c| new_label[c]).collect(),
        modes: distinct_modes(&modes, h),
    }
}

/// Number of modes that differ by more than the climbs' stopping tolerance.
fn distinct_modes(modes: &[Vec<f64>], h: f64) -> usize {
    let mut seen: Vec<&Vec<f64>> = Vec::new();
    for m in modes {
        if seen
            .iter()
            .all(|s| distance(s, m) > 10.0 * STOP_FRACTION * h)
        {
            seen.push(m);
        }
    }
    seen.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Three tight blobs (±0.04 uniform noise) around well-separated centres.
    fn blobs() -> (Vec<Vec<f64>>, Vec<usize>, [[f64; 2]; 3]) {
        let centres = [[0.2, 0.2], [0.8, 0.3], [0.5, 0.85]];
        let sizes = [30, 20, 10];
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut points = Vec::new();
        let mut truth = Vec::new();
        for (k, (c, n)) in centres.iter().zip(sizes).enumerate() {
            for _ in 0..n {
                points.push(vec![
                    c[0] + rng.random_range(-0.04..0.04),
                    c[1] + rng.random_range(-0.04..0.04),
                ]);
                truth.push(k);
            }
        }
        (points, truth, centres)
    }

    #[test]
    fn finds_well_separated_blobs_and_labels_every_point() {
        let (points, truth, centres) = blobs();
        for kernel in [Kernel::Flat, Kernel::Gaussian] {
            let c = mean_shift(&points, kernel, 0.15);
            assert_eq!(c.sizes, vec![30, 20, 10], "{kernel:?}");
            // Largest first, so cluster k is blob k here.
            assert_eq!(c.labels, truth, "{kernel:?}");
            for (found, expected) in c.centres.iter().zip(centres) {
                // A centre is a density mode of a ±0.04 blob: within its spread.
                assert!(distance(found, &expected) < 0.04, "{kernel:?} {found:?}");
            }
        }
    }

    #[test]
    fn a_huge_bandwidth_merges_everything() {
        let (points, _, _) = blobs();
        let c = mean_shift(&points, Kernel::Flat, 5.0);
        assert_eq!(c.sizes, vec![60]);
    }

    #[test]
    fn bandwidth_estimate_by_hand() {
        // Points 0, 1, 3 on a line, quantile 0.7: k = ⌊2.1⌋ = 2, the nearest
        // other point: distances 1, 1, 2 → mean 4/3.
        let pts = vec![vec![0.0], vec![1.0], vec![3.0]];
        assert!((estimate_bandwidth(&pts, 0.7) - 4.0 / 3.0).abs() < 1e-15);
        // quantile 1: k = 3, the farthest point: 3, 2, 3 → 8/3.
        assert!((estimate_bandwidth(&pts, 1.0) - 8.0 / 3.0).abs() < 1e-15);
        // k < 1 becomes 1: the point itself, bandwidth 0.
        assert_eq!(estimate_bandwidth(&pts, 0.1), 0.0);
    }

    #[test]
    fn the_estimated_bandwidth_separates_the_blobs() {
        // With scikit-learn's default quantile 0.3 (k = 18 of 60) the estimate
        // lies between the blob size (~0.08) and their separation (≥ 0.6).
        let (points, _, _) = blobs();
        let h = estimate_bandwidth(&points, 0.3);
        assert!(h > 0.04 && h < 0.5, "{h}");
        assert_eq!(mean_shift(&points, Kernel::Flat, h).sizes, vec![30, 20, 10]);
    }
}
