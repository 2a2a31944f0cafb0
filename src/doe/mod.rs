//! Designs of experiments: which parameter points to simulate, as pure
//! functions of their settings (no I/O, no clocks, no thread counts; the
//! random designs draw only from the ChaCha stream they are given).
//!
//! # Units
//!
//! The two-level and three-level designs are written in *coded units*: for a
//! factor ranging over `[low, high]` in its physical (*actual*) units, coded −1
//! is `low`, +1 is `high` and 0 the midpoint, linearly in between
//! ([`Range::to_actual`], [`Range::to_coded`], [`to_actual`] for a whole
//! point). The Latin hypercubes are on the unit cube `[0, 1]^d`; explicit
//! level lists ([`factorial`], [`ofat`]) are in actual units.
//!
//! # Designs and their run order
//!
//! Every design returns its runs in a fixed, documented order, so the same
//! settings always give the same table row for row.
//!
//! - [`box_behnken::box_behnken`]: Box–Behnken (Box & Behnken 1960,
//!   Technometrics 2:455) for k ≥ 3 factors, coded −1/0/+1. For every pair of
//!   factors (i, j), i < j, in lexicographic order — (A,B), (A,C), …, (A,K),
//!   (B,C), … — the four corners of that pair's square with every other factor
//!   at 0: (−,−), (−,+), (+,−), (+,+) as (factor i, factor j); then the centre
//!   points (all 0). This is pyDOE3's `bbdesign` row for row.
//!   2k(k − 1) + centre-point runs.
//! - [`factorial::full_factorial`]: every combination of explicit per-factor
//!   level lists (actual units), in standard order: the first factor changes
//!   fastest, the last slowest (pyDOE3's `fullfact` order). As many runs as the
//!   product of the list lengths.
//! - [`ofat::one_factor_at_a_time`]: around a base point, factor by factor and
//!   within a factor level by level, every other factor at the base
//!   (actual units). As many runs as the levels listed.
//! - [`lhs::latin_hypercube`]: a Latin hypercube on `[0, 1]^d` (he2019 §3.1),
//!   sample k in row k; [`lhs::optimise`] improves its space filling by
//!   within-column exchanges.
//!
//! [`diagnostics`] measures any design on the unit cube: centred L2
//! discrepancy, smallest pairwise distance, column correlations.

pub mod box_behnken;
pub mod diagnostics;
pub mod factorial;
pub mod lhs;
pub mod ofat;

/// The interval a factor spans in actual (physical) units, mapping coded −1 to
/// `low` and +1 to `high`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// The factor's value at coded −1 (actual units).
    pub low: f64,
    /// The factor's value at coded +1 (actual units).
    pub high: f64,
}

impl Range {
    /// A range from `low` to `high` (actual units), refused unless both are
    /// finite and `low < high` (otherwise coding would divide by zero or
    /// reverse the factor).
    pub fn new(low: f64, high: f64) -> Result<Range, DesignError> {
        if low.is_finite() && high.is_finite() && low < high {
            Ok(Range { low, high })
        } else {
            Err(DesignError::InvalidRange { low, high })
        }
    }

    /// The actual value of coded value `coded`: −1 gives `low` and +1 gives
    /// `high` exactly, 0 the midpoint; linear in between and beyond.
    pub fn to_actual(&self, coded: f64) -> f64 {
        ((1.0 - coded) * self.low + (1.0 + coded) * self.high) / 2.0
    }

    /// The coded value of actual value `actual`: `low` gives −1 and `high`
    /// gives +1 exactly; linear in between and beyond.
    pub fn to_coded(&self, actual: f64) -> f64 {
        ((actual - self.low) - (self.high - actual)) / (self.high - self.low)
    }
}

/// A coded point in actual units: coordinate i through `ranges[i]`.
///
/// # Panics
///
/// When `coded` and `ranges` differ in length (a programming error: a design
/// and its ranges always come from the same factor list).
pub fn to_actual(coded: &[f64], ranges: &[Range]) -> Vec<f64> {
    assert_eq!(
        coded.len(),
        ranges.len(),
        "a coded point of {} coordinates got {} ranges; it needs one per coordinate",
        coded.len(),
        ranges.len()
    );
    coded
        .iter()
        .zip(ranges)
        .map(|(c, r)| r.to_actual(*c))
        .collect()
}

/// Why a design cannot be built from its settings. Factors and levels are
/// numbered from 0, in the order given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DesignError {
    /// A Box–Behnken design needs at least three factors.
    #[error("a Box–Behnken design needs at least 3 factors; got k = {factors}")]
    TooFewFactors {
        /// The number of factors asked for.
        factors: usize,
    },
    /// A design needs at least one factor.
    #[error("no factors: a design needs at least one factor's level list")]
    NoFactors,
    /// A full factorial needs every factor to have at least one level.
    #[error("factor {factor} has an empty level list; each factor needs at least one level")]
    EmptyLevels {
        /// The factor.
        factor: usize,
    },
    /// A level is NaN or infinite.
    #[error("factor {factor} level {level} is {value}; levels must be finite numbers")]
    NonFiniteLevel {
        /// The factor.
        factor: usize,
        /// The level's position in the factor's list.
        level: usize,
        /// The value given.
        value: f64,
    },
    /// A factor lists the same level twice (it would repeat runs).
    #[error("factor {factor} lists level {value} twice (levels {first} and {second}); levels must be distinct")]
    DuplicateLevel {
        /// The factor.
        factor: usize,
        /// The repeated value.
        value: f64,
        /// Position of its first occurrence.
        first: usize,
        /// Position of its second occurrence.
        second: usize,
    },
    /// The base point of a one-factor-at-a-time design has the wrong length.
    #[error("the base point has {base} coordinates but {factors} factors have level lists; they must be equal")]
    BaseLength {
        /// Coordinates in the base point.
        base: usize,
        /// Level lists given.
        factors: usize,
    },
    /// A base-point coordinate is NaN or infinite.
    #[error("base point coordinate {factor} is {value}; it must be a finite number")]
    NonFiniteBase {
        /// The factor.
        factor: usize,
        /// The value given.
        value: f64,
    },
    /// A range is not finite or not increasing.
    #[error("range [{low}, {high}]: low and high must be finite with low < high")]
    InvalidRange {
        /// The low end given.
        low: f64,
        /// The high end given.
        high: f64,
    },
}

/// Checks one factor's level list: finite values, none repeated. Emptiness is
/// the caller's rule (a full factorial refuses it, OFAT holds the factor).
fn check_levels(factor: usize, levels: &[f64]) -> Result<(), DesignError> {
    for (level, &value) in levels.iter().enumerate() {
        if !value.is_finite() {
            return Err(DesignError::NonFiniteLevel {
                factor,
                level,
                value,
            });
        }
        if let Some(first) = levels[..level].iter().position(|v| *v == value) {
            return Err(DesignError::DuplicateLevel {
                factor,
                value,
                first,
                second: level,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn coding_is_exact_at_the_ends_and_linear_between() {
        let r = Range::new(0.1, 0.3).unwrap();
        assert_eq!(r.to_actual(-1.0), 0.1);
        assert_eq!(r.to_actual(1.0), 0.3);
        assert!((r.to_actual(0.0) - 0.2).abs() < 1e-15);
        assert!((r.to_actual(0.5) - 0.25).abs() < 1e-15);
        assert_eq!(r.to_coded(0.1), -1.0);
        assert_eq!(r.to_coded(0.3), 1.0);
        assert!(r.to_coded(0.2).abs() < 1e-15);
        for c in [-1.0, -0.3, 0.0, 0.7, 1.0] {
            assert!((r.to_coded(r.to_actual(c)) - c).abs() < 1e-14, "{c}");
        }
    }

    #[test]
    fn a_point_maps_coordinate_by_coordinate() {
        let ranges = [
            Range::new(0.0, 2.0).unwrap(),
            Range::new(-5.0, 5.0).unwrap(),
        ];
        assert_eq!(to_actual(&[-1.0, 1.0], &ranges), vec![0.0, 5.0]);
        assert_eq!(to_actual(&[0.0, 0.0], &ranges), vec![1.0, 0.0]);
    }

    #[test]
    fn bad_ranges_are_refused_naming_the_values() {
        for (low, high) in [
            (1.0, 1.0),
            (2.0, 1.0),
            (f64::NAN, 1.0),
            (0.0, f64::INFINITY),
        ] {
            let e = Range::new(low, high).unwrap_err();
            assert!(matches!(e, DesignError::InvalidRange { .. }));
            assert!(e.to_string().contains("low < high"), "{e}");
        }
    }

    /// Every design, bit for bit (the LHS with its optimisation).
    fn all_designs() -> Vec<Vec<u64>> {
        let bits = |rows: Vec<Vec<f64>>| -> Vec<u64> {
            rows.iter().flatten().map(|v| v.to_bits()).collect()
        };
        let mut r = ChaCha8Rng::seed_from_u64(7);
        let mut lhs = lhs::latin_hypercube(40, 5, lhs::Placement::Random, &mut r);
        let mut o = ChaCha8Rng::seed_from_u64(8);
        lhs::optimise(&mut lhs, 500, &mut o);
        let levels = vec![vec![0.05, 0.15, 0.25, 0.5], vec![0.05, 0.25, 0.45]];
        let ofat = ofat::one_factor_at_a_time(&[0.25, 0.25], &levels)
            .unwrap()
            .into_iter()
            .map(|run| run.point)
            .collect();
        vec![
            bits(lhs),
            bits(box_behnken::box_behnken(5, 3).unwrap()),
            bits(factorial::full_factorial(&levels).unwrap()),
            bits(ofat),
        ]
    }

    #[test]
    fn designs_do_not_depend_on_the_thread_pool() {
        let in_pool = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(all_designs)
        };
        let one = in_pool(1);
        assert_eq!(one, in_pool(2));
        assert_eq!(one, all_designs());
    }
}
