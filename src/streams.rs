//! Seeded random streams: every random draw of a study (design strata,
//! optimiser exchanges, search resampling, the genetic algorithm and its
//! cross-validation folds, adaptive candidate pools) comes from a ChaCha8 stream of one seed and one
//! [`Stream`] purpose, so adding draws to one purpose never shifts another
//! and the same seed gives the same draws on any machine and thread count.
//!
//! The packing seeds of a point's replicates follow one [`SeedRule`]. Both
//! rules are inside the experiment ids of every committed study and cached
//! run, so neither may change:
//! - [`SeedRule::Offset`]: base, base + 1, … — classic he2019 studies
//!   (replicate r of sample i runs the study's packing seed + r) and the
//!   tradeoff sweep (replicates of one manifest), where a replicate is "the
//!   same experiment, next packing";
//! - [`SeedRule::Drawn`]: the r-th draw of the ChaCha8 stream of (study seed,
//!   [`SeedStage`], point), below 2³² so any JSON reader keeps it exact —
//!   design studies and noise-aware he2019 studies, where every point of
//!   every stage gets unrelated packings (a centre point repeated in a design
//!   gets a real pure error; a GP's noise is independent between points).

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The purposes that draw random numbers; each gets its own ChaCha stream of
/// a seed, so adding draws to one never shifts another. The discriminants are
/// part of every seeded output (designs, searches, trained networks) and must
/// never change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// The sampled design's strata positions and permutations.
    Design = 1,
    /// Exchanges of the optimised Latin hypercube.
    Optimise = 2,
    /// The search stage's resampled points.
    Search = 3,
    /// The genetic algorithm (one sub-stream per hidden size).
    Genetic = 4,
    /// The adaptive stage's candidate pools (one sub-stream per round).
    Adaptive = 5,
    /// The genetic algorithm of the GA-BP sweep's cross-validation folds (one
    /// sub-stream per hidden size and fold).
    CrossValidation = 6,
    /// The two-level pilot's design points (`repose pilot`).
    Pilot = 7,
}

/// The ChaCha8 stream for `purpose` (and sub-stream `index`) of `seed`.
pub fn rng(seed: u64, purpose: Stream, index: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(((purpose as u64) << 32) | (index & 0xffff_ffff));
    r
}

/// The design-study stages that draw packing seeds, each its own stream of
/// [`SeedRule::Drawn`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeedStage {
    /// `repose screen`.
    Screen = 1,
    /// `repose rsm` (the design).
    Design = 2,
    /// `repose verify`.
    Verify = 3,
    /// Every point of a noise-aware he2019 calibration (design, noise floor,
    /// adaptive, verification: disjoint sample indices).
    Calibrate = 4,
}

/// How the replicates of one point get their packing seeds (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeedRule {
    /// Replicate r gets `base + r` (wrapping).
    Offset {
        /// The packing seed of replicate 0.
        base: u64,
    },
    /// Replicate r gets the r-th draw (from 0) of the ChaCha8 stream of
    /// (`seed`, `stage`, `point`).
    Drawn {
        /// The study's seed.
        seed: u64,
        /// The stage drawing.
        stage: SeedStage,
        /// The design point's index in its stage.
        point: u64,
    },
}

impl SeedRule {
    /// The packing seed of `replicate`.
    pub fn packing_seed(&self, replicate: u64) -> u64 {
        match *self {
            SeedRule::Offset { base } => base.wrapping_add(replicate),
            SeedRule::Drawn { seed, stage, point } => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(((stage as u64) << 40) | (point & 0xff_ffff_ffff));
                let mut value = 0;
                for _ in 0..=replicate {
                    value = rng.next_u32();
                }
                u64::from(value)
            }
        }
    }
}
