//! The joint optimum of several fitted responses: Derringer–Suich
//! desirability, maximised over the coded cube by a multi-start local search.
//!
//! Each response with a target gets a target-is-best desirability (weights
//! 1): d = (y − L)/(T − L) for L ≤ y ≤ T, (U − y)/(U − T) for T ≤ y ≤ U, 0
//! outside (L, U) = the target's `low`, `high`. The overall desirability is
//! their geometric mean. The search starts at the centre and at `starts − 1`
//! uniform points of the cube (ChaCha8 stream of the study seed) and climbs
//! by compass search (±step along each axis in a fixed order, step halved
//! when no move improves, until 1e-7 coded), clamped to [−1, 1]. Where every
//! d of a point is not positive the search climbs the negative total
//! distance to the bands instead, so it can leave the flat zero region. The
//! optimum need not be unique, so the distinct local optima (more than 0.02
//! coded apart in every way) are reported best first.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// The ChaCha stream of the starts ("optimum" in ASCII), apart from the
/// packing seeds' streams.
const OPTIMISER_STREAM: u64 = 0x006f_7074_696d_756d;

/// A fitted model: coded factors → predicted response.
pub type Model<'a> = Box<dyn Fn(&[f64]) -> f64 + 'a>;

/// A response's fitted model and its goal.
pub struct Goal<'a> {
    /// Response name.
    pub response: String,
    /// The model: coded factors → predicted response.
    pub predict: Model<'a>,
    /// Target value T.
    pub target: f64,
    /// Lower end L (d = 0 at and below).
    pub low: f64,
    /// Upper end U (d = 0 at and above).
    pub high: f64,
}

/// Target-is-best desirability of `y` (see the module docs).
pub fn desirability(y: f64, target: f64, low: f64, high: f64) -> f64 {
    if !(y > low && y < high) {
        0.0
    } else if y <= target {
        (y - low) / (target - low)
    } else {
        (high - y) / (high - target)
    }
}

/// One local optimum.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Optimum {
    /// Coded factor values.
    pub coded: Vec<f64>,
    /// Overall desirability, in [0, 1].
    pub desirability: f64,
    /// Per response: (name, predicted value, its desirability).
    pub responses: Vec<(String, f64, f64)>,
}

/// What the search found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Search {
    /// Number of starts.
    pub starts: usize,
    /// Distinct local optima, best first (at most 5).
    pub optima: Vec<Optimum>,
}

fn evaluate(goals: &[Goal], x: &[f64]) -> (f64, Vec<(String, f64, f64)>) {
    let mut product = 1.0;
    let mut outside = 0.0;
    let mut parts = Vec::with_capacity(goals.len());
    for g in goals {
        let y = (g.predict)(x);
        let d = desirability(y, g.target, g.low, g.high);
        product *= d;
        let width = g.high - g.low;
        outside += ((g.low - y).max(0.0) + (y - g.high).max(0.0)) / width
            + if d == 0.0 { 1e-9 } else { 0.0 };
        parts.push((g.response.clone(), y, d));
    }
    let overall = product.powf(1.0 / goals.len() as f64);
    let score = if overall > 0.0 { overall } else { -outside };
    (score, parts)
}

fn climb(goals: &[Goal], start: Vec<f64>) -> Vec<f64> {
    let mut x = start;
    let mut best = evaluate(goals, &x).0;
    let mut step = 0.25;
    let mut evaluations = 0;
    while step > 1e-7 && evaluations < 200_000 {
        let mut moved = false;
        for i in 0..x.len() {
            for sign in [1.0, -1.0] {
                let mut y = x.clone();
                y[i] = (y[i] + sign * step).clamp(-1.0, 1.0);
                if y[i] == x[i] {
                    continue;
                }
                evaluations += 1;
                let s = evaluate(goals, &y).0;
                if s > best {
                    best = s;
                    x = y;
                    moved = true;
                }
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    x
}

/// Maximises the overall desirability of `goals` over the coded cube of
/// `factors` dimensions (see the module docs).
pub fn maximise(goals: &[Goal], factors: usize, starts: usize, seed: u64) -> Search {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(OPTIMISER_STREAM);
    let mut found: Vec<Optimum> = Vec::new();
    for s in 0..starts.max(1) {
        let start: Vec<f64> = if s == 0 {
            vec![0.0; factors]
        } else {
            (0..factors).map(|_| rng.random_range(-1.0..=1.0)).collect()
        };
        let x = climb(goals, start);
        let (score, responses) = evaluate(goals, &x);
        found.push(Optimum {
            coded: x,
            desirability: score.max(0.0),
            responses,
        });
    }
    found.sort_by(|a, b| {
        b.desirability.total_cmp(&a.desirability).then_with(|| {
            a.coded
                .partial_cmp(&b.coded)
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    let mut distinct: Vec<Optimum> = Vec::new();
    for o in found {
        let near = distinct.iter().any(|d| {
            d.coded
                .iter()
                .zip(&o.coded)
                .all(|(a, b)| (a - b).abs() <= 0.02)
        });
        if !near && distinct.len() < 5 {
            distinct.push(o);
        }
    }
    Search {
        starts: starts.max(1),
        optima: distinct,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn desirability_is_one_at_the_target_and_zero_at_the_ends() {
        assert_eq!(desirability(40.0, 40.0, 30.0, 60.0), 1.0);
        assert_eq!(desirability(30.0, 40.0, 30.0, 60.0), 0.0);
        assert_eq!(desirability(60.0, 40.0, 30.0, 60.0), 0.0);
        assert!((desirability(35.0, 40.0, 30.0, 60.0) - 0.5).abs() < 1e-15);
        assert!((desirability(50.0, 40.0, 30.0, 60.0) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn two_planes_meet_their_targets_on_a_line_and_the_search_finds_it() {
        // y1 = 40 + 5 a, y2 = 60 + 5 b: both targets met at a = 0.4, b = −0.2.
        let goals = vec![
            Goal {
                response: "y1".into(),
                predict: Box::new(|x: &[f64]| 40.0 + 5.0 * x[0]),
                target: 42.0,
                low: 30.0,
                high: 50.0,
            },
            Goal {
                response: "y2".into(),
                predict: Box::new(|x: &[f64]| 60.0 + 5.0 * x[1]),
                target: 59.0,
                low: 50.0,
                high: 70.0,
            },
        ];
        let s = maximise(&goals, 3, 8, 1);
        let best = &s.optima[0];
        assert!((best.desirability - 1.0).abs() < 1e-6, "{best:?}");
        assert!((best.coded[0] - 0.4).abs() < 1e-6 && (best.coded[1] + 0.2).abs() < 1e-6);
        assert_eq!(s, maximise(&goals, 3, 8, 1), "deterministic");
    }

    #[test]
    fn the_search_leaves_the_zero_region() {
        let goals = vec![Goal {
            response: "y".into(),
            predict: Box::new(|x: &[f64]| 100.0 * x[0]),
            target: 90.0,
            low: 80.0,
            high: 100.0,
        }];
        let s = maximise(&goals, 1, 1, 0);
        assert!((s.optima[0].coded[0] - 0.9).abs() < 1e-6, "{s:?}");
    }
}
