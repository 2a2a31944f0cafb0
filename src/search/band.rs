//! The shared skeleton of he2019's search over a surrogate: resample the
//! unit cube of the ranges by a Latin hypercube from the search stream,
//! score every point by a [`Criterion`], keep the accepted ones, and
//! cluster them by mean shift ([`super::meanshift`]) with a given or
//! estimated bandwidth. The GA-BP search keeps a point when its predicted
//! angle is within the tolerance of the target (he2019 §3.5); the
//! noise-aware search when the probability of the band under the GP's
//! predictive sd reaches a minimum.
//!
//! # The family
//!
//! One angle rarely pins every parameter: the kept points spread along the
//! directions the target does not constrain. [`family`] gives each
//! parameter's mean, standard deviation and range over the kept points, and
//! the principal directions of the kept points in the unit cube of the
//! ranges (eigenvectors of their covariance, largest variance first): a
//! direction with a large share is a combination of parameters the target
//! leaves free; one with a small share is what the target determines.

use nalgebra::{DMatrix, SymmetricEigen};
use serde::{Deserialize, Serialize};

use super::acquisition::probability_in_band;
use super::meanshift::{estimate_bandwidth, mean_shift, Clustering, Kernel};
use crate::doe::lhs::{latin_hypercube, Placement};
use crate::streams::{rng, Stream};
use crate::surrogate::Prediction;

/// Which resampled points a search keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Criterion {
    /// |mean − target| / target ≤ fraction (he2019's tolerance).
    Tolerance {
        /// The target (units of the response).
        target: f64,
        /// The relative tolerance (e.g. 0.05).
        fraction: f64,
    },
    /// P(lo ≤ Y ≤ hi) ≥ min under Y ~ N(mean, sd²) (a prediction without an
    /// sd counts as certain).
    Probability {
        /// Lower end of the band.
        lo: f64,
        /// Upper end of the band.
        hi: f64,
        /// Smallest kept probability.
        min: f64,
    },
}

impl Criterion {
    /// The point's score: its relative deviation from the target
    /// (tolerance) or its probability of the band (probability).
    pub fn score(&self, p: &Prediction) -> f64 {
        match *self {
            Criterion::Tolerance { target, .. } => (p.mean - target).abs() / target,
            Criterion::Probability { lo, hi, .. } => {
                probability_in_band(p.mean, p.sd.unwrap_or(0.0), lo, hi)
            }
        }
    }

    /// Whether a point with this score is kept.
    pub fn accepts(&self, score: f64) -> bool {
        match *self {
            Criterion::Tolerance { fraction, .. } => score <= fraction,
            Criterion::Probability { min, .. } => score >= min,
        }
    }
}

/// `samples` points of a Latin hypercube in the unit cube of `dimensions`
/// parameters, from sub-stream `index` of the search stream of `seed`.
pub fn resample(
    samples: usize,
    dimensions: usize,
    placement: Placement,
    seed: u64,
    index: u64,
) -> Vec<Vec<f64>> {
    latin_hypercube(
        samples,
        dimensions,
        placement,
        &mut rng(seed, Stream::Search, index),
    )
}

/// Indices of the points whose score the criterion accepts, ascending.
pub fn kept(criterion: &Criterion, scores: &[f64]) -> Vec<usize> {
    (0..scores.len())
        .filter(|&i| criterion.accepts(scores[i]))
        .collect()
}

/// The 1-based cluster of each of `points` resampled points: `Some(label +
/// 1)` for the kept point `kept[j]` in cluster `labels[j]`, `None` for the
/// points not kept (the `cluster` column of points.csv).
pub fn cluster_column(points: usize, kept: &[usize], labels: &[usize]) -> Vec<Option<usize>> {
    let mut column = vec![None; points];
    for (&i, &l) in kept.iter().zip(labels) {
        column[i] = Some(l + 1);
    }
    column
}

/// The mean-shift bandwidth: `given`, or estimated from the kept points at
/// `quantile` of their pairwise distances (0 when they are all one point).
pub fn bandwidth(kept_unit: &[Vec<f64>], given: Option<f64>, quantile: f64) -> f64 {
    given.unwrap_or_else(|| estimate_bandwidth(kept_unit, quantile))
}

/// The points a search kept and their mean-shift clusters.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Indices of the kept points, ascending.
    pub kept: Vec<usize>,
    /// The kept points, unit-scaled.
    pub kept_unit: Vec<Vec<f64>>,
    /// The bandwidth (unit-scaled): given, or estimated (0 when the kept
    /// points are all one point).
    pub bandwidth: f64,
    /// The mean-shift result on the kept points.
    pub clustering: Clustering,
}

/// Keeps the points of `unit` whose `scores` the `criterion` accepts and
/// clusters them by mean shift with `kernel` at the bandwidth `given`, or
/// estimated at `quantile`; `None` when no point is kept. A bandwidth of 0
/// (the kept points are one point) clusters them with bandwidth 1, which
/// holds the whole unit cube: one cluster; [`Selection::bandwidth`] still
/// says 0, for a caller that refuses it.
pub fn select(
    unit: &[Vec<f64>],
    scores: &[f64],
    criterion: &Criterion,
    kernel: Kernel,
    given: Option<f64>,
    quantile: f64,
) -> Option<Selection> {
    let kept = kept(criterion, scores);
    if kept.is_empty() {
        return None;
    }
    let kept_unit: Vec<Vec<f64>> = kept.iter().map(|&i| unit[i].clone()).collect();
    let bandwidth = bandwidth(&kept_unit, given, quantile);
    let clustering = mean_shift(
        &kept_unit,
        kernel,
        if bandwidth > 0.0 { bandwidth } else { 1.0 },
    );
    Some(Selection {
        kept,
        kept_unit,
        bandwidth,
        clustering,
    })
}

/// One parameter's spread over the kept points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// The parameter.
    pub parameter: String,
    /// Mean, physical units.
    pub mean: f64,
    /// Standard deviation, physical units.
    pub sd: f64,
    /// Smallest kept value.
    pub min: f64,
    /// Largest kept value.
    pub max: f64,
    /// sd over the width of the range.
    pub relative_sd: f64,
}

/// A principal direction of the kept points (unit cube).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Direction {
    /// Share of the kept points' total variance along it.
    pub variance_share: f64,
    /// Unit vector, one loading per parameter.
    pub loadings: Vec<f64>,
}

/// The parameter sets consistent with the target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Family {
    /// Resampled points.
    pub resampled: usize,
    /// Kept points.
    pub kept: usize,
    /// Per-parameter spread.
    pub spread: Vec<Spread>,
    /// Principal directions, largest share first.
    pub directions: Vec<Direction>,
}

/// The family of the kept points (unit cube of `ranges`, one range per
/// name): each parameter's spread in physical units and the principal
/// directions of the kept points, largest variance share first (module docs).
pub fn family(
    names: &[String],
    ranges: &[(f64, f64)],
    kept_unit: &[Vec<f64>],
    resampled: usize,
) -> Family {
    let n = kept_unit.len();
    let d = names.len();
    let mean_u: Vec<f64> = (0..d)
        .map(|j| kept_unit.iter().map(|u| u[j]).sum::<f64>() / n as f64)
        .collect();
    let denom = (n.max(2) - 1) as f64;
    let cov = DMatrix::from_fn(d, d, |a, b| {
        kept_unit
            .iter()
            .map(|u| (u[a] - mean_u[a]) * (u[b] - mean_u[b]))
            .sum::<f64>()
            / denom
    });
    let spread = names
        .iter()
        .zip(ranges)
        .enumerate()
        .map(|(j, (name, &(lo, hi)))| {
            let width = hi - lo;
            let values: Vec<f64> = kept_unit.iter().map(|u| lo + u[j] * width).collect();
            let sd = cov[(j, j)].sqrt() * width;
            Spread {
                parameter: name.clone(),
                mean: lo + mean_u[j] * width,
                sd,
                min: values.iter().copied().fold(f64::INFINITY, f64::min),
                max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                relative_sd: sd / width,
            }
        })
        .collect();
    let eigen = SymmetricEigen::new(cov);
    let total: f64 = eigen.eigenvalues.iter().map(|v| v.max(0.0)).sum();
    let mut order: Vec<usize> = (0..d).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let directions = order
        .into_iter()
        .map(|k| {
            let mut v: Vec<f64> = eigen.eigenvectors.column(k).iter().copied().collect();
            // Sign convention: the largest loading positive (deterministic).
            let big = v
                .iter()
                .copied()
                .fold(0.0f64, |m, x| if x.abs() > m.abs() { x } else { m });
            if big < 0.0 {
                v.iter_mut().for_each(|x| *x = -*x);
            }
            Direction {
                variance_share: if total > 0.0 {
                    eigen.eigenvalues[k].max(0.0) / total
                } else {
                    0.0
                },
                loadings: v,
            }
        })
        .collect();
    Family {
        resampled,
        kept: n,
        spread,
        directions,
    }
}
