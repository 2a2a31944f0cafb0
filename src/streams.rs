//! Seeded random streams: every random draw of a study (design strata,
//! optimiser exchanges, search resampling, the genetic algorithm, adaptive
//! candidate pools) comes from a ChaCha8 stream of one seed and one
//! [`Stream`] purpose, so adding draws to one purpose never shifts another
//! and the same seed gives the same draws on any machine and thread count.

use rand::SeedableRng;
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
}

/// The ChaCha8 stream for `purpose` (and sub-stream `index`) of `seed`.
pub fn rng(seed: u64, purpose: Stream, index: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(((purpose as u64) << 32) | (index & 0xffff_ffff));
    r
}
