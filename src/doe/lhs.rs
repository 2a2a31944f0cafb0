//! Latin hypercube designs on the unit cube (he2019 §3.1, Eq. 4–5) and their
//! space-filling optimisation.
//!
//! Each of the `d` columns is cut into `n` equal-probability strata
//! ((i − 1)/n, i/n), i = 1..n (the parameters are uniform over their ranges, so
//! equal probability means equal width). Every stratum of every column holds
//! exactly one point: the value in stratum i is either its midpoint
//! (i − ½)/n (he2019 §3.1 step 1, [`Placement::Midpoint`]) or Eq. 4's
//! Vᵢ = V/n + (i − 1)/n with V uniform in [0, 1) ([`Placement::Random`]),
//! which satisfies Eq. 5's (i − 1)/n ≤ Vᵢ < i/n. Each column's values are then
//! put in an independent random order (a Fisher–Yates shuffle; step 2), so
//! sample k takes the k-th value of every column.
//!
//! The optimised design ([`optimise`]) starts from such a design and exchanges
//! two values within one column (which keeps it a Latin hypercube) whenever
//! that lowers the Morris–Mitchell criterion φ_p = (Σ_{i<j} d_ij^−p)^{1/p}
//! with p = 50 (Morris & Mitchell 1995, J. Stat. Plan. Inference 43:381):
//! for large p, minimising φ_p maximises the smallest pairwise distance
//! (maximin) and, among designs with the same smallest distance, reduces how
//! often it occurs.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Where a sample sits inside its stratum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// The stratum's midpoint (i − ½)/n (he2019 §3.1 step 1).
    Midpoint,
    /// Uniformly random within the stratum (he2019 Eq. 4).
    Random,
}

/// Exponent p of the Morris–Mitchell criterion.
pub const PHI_P: i32 = 50;

/// A Latin hypercube of `n` points in `[0, 1]^d`: row k is sample k.
pub fn latin_hypercube(
    n: usize,
    d: usize,
    placement: Placement,
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<f64>> {
    let mut points = vec![vec![0.0; d]; n];
    for column in 0..d {
        let mut values: Vec<f64> = (0..n)
            .map(|i| {
                let offset = match placement {
                    Placement::Midpoint => 0.5,
                    Placement::Random => rng.random::<f64>(),
                };
                (i as f64 + offset) / n as f64
            })
            .collect();
        shuffle(&mut values, rng);
        for (point, v) in points.iter_mut().zip(values) {
            point[column] = v;
        }
    }
    points
}

/// Fisher–Yates shuffle (Durstenfeld's form).
fn shuffle(values: &mut [f64], rng: &mut ChaCha8Rng) {
    for i in (1..values.len()).rev() {
        let j = rng.random_range(0..=i);
        values.swap(i, j);
    }
}

/// The Morris–Mitchell criterion φ_p of a design (smaller is more
/// space-filling). Coincident points make it infinite.
pub fn phi_p(points: &[Vec<f64>]) -> f64 {
    let mut sum = 0.0;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            sum += distance(&points[i], &points[j]).powi(-PHI_P);
        }
    }
    sum.powf(1.0 / PHI_P as f64)
}

/// Euclidean distance.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// What [`optimise`] did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Optimisation {
    /// Exchanges tried.
    pub iterations: usize,
    /// Exchanges kept.
    pub accepted: usize,
    /// φ_p before.
    pub initial_phi_p: f64,
    /// φ_p after.
    pub final_phi_p: f64,
}

/// Improves `points` (a Latin hypercube) in place by `iterations` random
/// within-column exchanges, each kept only if it lowers φ_p. The result is
/// still a Latin hypercube with the same values in every column.
pub fn optimise(points: &mut [Vec<f64>], iterations: usize, rng: &mut ChaCha8Rng) -> Optimisation {
    let n = points.len();
    let d = points.first().map_or(0, Vec::len);
    let initial = phi_p(points);
    let mut current = initial;
    let mut accepted = 0;
    if n >= 2 && d >= 1 {
        for _ in 0..iterations {
            let column = rng.random_range(0..d);
            let a = rng.random_range(0..n);
            let b = (a + rng.random_range(1..n)) % n;
            swap_in_column(points, column, a, b);
            let candidate = phi_p(points);
            if candidate < current {
                current = candidate;
                accepted += 1;
            } else {
                swap_in_column(points, column, a, b);
            }
        }
    }
    Optimisation {
        iterations,
        accepted,
        initial_phi_p: initial,
        final_phi_p: current,
    }
}

fn swap_in_column(points: &mut [Vec<f64>], column: usize, a: usize, b: usize) {
    let t = points[a][column];
    points[a][column] = points[b][column];
    points[b][column] = t;
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The stratum index of every value of a column, sorted.
    fn strata(points: &[Vec<f64>], column: usize) -> Vec<usize> {
        let n = points.len() as f64;
        let mut s: Vec<usize> = points
            .iter()
            .map(|p| (p[column] * n).floor() as usize)
            .collect();
        s.sort();
        s
    }

    #[test]
    fn every_column_hits_every_stratum_once() {
        for placement in [Placement::Midpoint, Placement::Random] {
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let points = latin_hypercube(17, 4, placement, &mut rng);
            assert_eq!(points.len(), 17);
            for c in 0..4 {
                assert_eq!(
                    strata(&points, c),
                    (0..17).collect::<Vec<_>>(),
                    "{placement:?}"
                );
            }
        }
    }

    #[test]
    fn midpoints_sit_at_the_centre_of_their_stratum() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let points = latin_hypercube(8, 2, Placement::Midpoint, &mut rng);
        for p in &points {
            for v in p {
                // (i − ½)/n for n = 8: 1/16, 3/16, ... exactly representable.
                let i = v * 8.0 - 0.5;
                assert_eq!(i, i.round(), "{v} is not a stratum midpoint");
            }
        }
    }

    #[test]
    fn random_values_are_inside_their_stratum_and_not_midpoints() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let points = latin_hypercube(50, 3, Placement::Random, &mut rng);
        let off_centre = points
            .iter()
            .flatten()
            .filter(|v| {
                let i = (*v * 50.0).floor();
                let inside = i / 50.0 <= **v && **v < (i + 1.0) / 50.0;
                assert!(inside, "{v}");
                ((*v * 50.0) - i - 0.5).abs() > 1e-9
            })
            .count();
        assert_eq!(off_centre, 150, "Eq. 4 draws V uniformly, never exactly ½");
    }

    #[test]
    fn columns_are_permuted_independently() {
        // With identical permutations every column would equal the first.
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let points = latin_hypercube(30, 3, Placement::Midpoint, &mut rng);
        assert!(points.iter().any(|p| p[0] != p[1]));
        assert!(points.iter().any(|p| p[1] != p[2]));
    }

    #[test]
    fn optimisation_keeps_the_hypercube_and_lowers_phi_p() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut points = latin_hypercube(20, 3, Placement::Midpoint, &mut rng);
        let before = points.clone();
        let out = optimise(&mut points, 2000, &mut rng);
        assert!(
            out.accepted > 0 && out.final_phi_p < out.initial_phi_p,
            "{out:?}"
        );
        assert_eq!(out.final_phi_p, phi_p(&points));
        for c in 0..3 {
            assert_eq!(strata(&points, c), strata(&before, c));
        }
    }
}
