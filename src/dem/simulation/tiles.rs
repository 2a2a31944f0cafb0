//! Blocks and tiles of the pair sweep: every pair force goes straight into a
//! per-particle sum, in an order that never depends on the threads.
//!
//! The particles are cut into *blocks*: index ranges with about the same
//! number of pairs each, as many as [`blocks_for`] gives for the particle
//! count, bounded where the neighbour list's rows reach each block's share
//! of the pairs (never by the thread count). A block's pairs are the rows of its
//! particles (`[i, j]`, `i` in the block, `j > i`). Every particle has an own
//! sum, started at the body force, of the pairs in its own block's rows, in
//! pair order; and for every earlier block whose rows reach it (a slab at
//! each block boundary, plus the last slab of a periodic axis, which the
//! first block reaches) a *partial* sum of those pairs, in pair order,
//! started at zero. Its total is its own sum plus its partials in block
//! order. The blocks fix every term and every addition, so the result is
//! bit-identical on any number of threads.
//!
//! The pair sweep is cut into *tiles*, one per team member: runs of whole
//! blocks with about the same number of pairs. A tile writes the own sums of
//! its particles and the partials of its blocks (partials are laid out block
//! by block), so tiles run side by side without sharing a sum. On one thread
//! the single tile still writes the partials: that is what keeps its result
//! the same as on two.
//!
//! Measurements and what was tried: docs/performance.md ("src/dem/simulation/tiles.rs").

use super::pair_kernel::{Motion, PairForce, PairSink};
use crate::dem::neighbor::offsets_of;
use crate::dem::vec3::Vec3;

/// Particles per block on average, at least: [`blocks_for`] gives the
/// largest power of two of blocks that keeps the average this large (blocks
/// are cut at equal shares of the pairs, so one may hold fewer). A block boundary costs a
/// partial for about one cell slab of particles, on any thread count, and a
/// team of more members than blocks leaves the extra members without a tile
/// in the pair sweep. At this size the partials cost one thread no
/// measurable time against the same bed cut into two blocks.
///
/// Measured: docs/performance.md ("src/dem/simulation/tiles.rs").
const PARTICLES_PER_BLOCK: usize = 2_500;

/// Most blocks: enough tiles for a team of this many members.
const MAX_BLOCKS: usize = 64;

/// Blocks of the pair sweep for `particles` particles: the largest power of
/// two (so that teams of 2, 4, 8... members split them evenly) with at least
/// 2,500 particles per block on average, between 1 and 64. A team of more members than
/// blocks sweeps the pairs on as many members as there are blocks (a scene
/// of fewer than 5,000 particles on one), and the blocks, not the threads,
/// fix the order in which each particle's pair forces are added.
pub fn blocks_for(particles: usize) -> usize {
    let most = (particles / PARTICLES_PER_BLOCK).clamp(1, MAX_BLOCKS);
    1 << most.ilog2()
}

/// How the pair sweep is cut into blocks (kept until the neighbour list is
/// rebuilt) and tiles (kept until then or until the team changes).
#[derive(Clone, Debug, Default)]
pub(super) struct Tiles {
    /// First particle of each block, then the particle count.
    block_particles: Vec<usize>,
    /// First pair of each block, then the pair count.
    block_pairs: Vec<usize>,
    /// First partial of each block (partials are laid out by the block whose
    /// rows they sum), then the partial count.
    block_partials: Vec<usize>,
    /// Per particle: its block.
    block_of: Vec<u32>,
    /// Per particle: where its partials start in `partial_of`, then the
    /// partial count (CSR offsets, len = particles + 1).
    partials_start: Vec<u32>,
    /// Per particle, in block order: `[block, partial index]` of each of its
    /// partials.
    partial_of: Vec<[u32; 2]>,
    /// Per particle, scratch of the cut: the last block found reaching it,
    /// then the fill cursor of its partials.
    scratch: Vec<u32>,
    /// Per partial: its particle (scratch of the cut).
    partial_particle: Vec<u32>,
    /// First block of each tile, then the block count.
    tile_blocks: Vec<usize>,
    /// First particle of each share of the per-particle passes, then the
    /// particle count.
    shares: Vec<usize>,
    /// (Neighbour build, particles, pairs) the blocks are for.
    blocks_cut_for: Option<(u64, usize, usize)>,
    /// Tiles the tile cut is for (`None`: cut again).
    tiles_for: Option<usize>,
}

impl Tiles {
    /// Cuts the blocks for neighbour build number `build` with rows `rows`
    /// (CSR offsets, len = particles + 1) and `pairs`, and groups them into
    /// `tiles` tiles; keeps what is already cut for the same.
    pub(super) fn cut(&mut self, build: u64, rows: &[u32], pairs: &[[u32; 2]], tiles: usize) {
        let blocks_cut_for = Some((build, rows.len() - 1, pairs.len()));
        if self.blocks_cut_for != blocks_cut_for {
            self.blocks_cut_for = blocks_cut_for;
            self.cut_blocks(rows, pairs, blocks_for(rows.len() - 1));
            self.tiles_for = None;
        }
        if self.tiles_for != Some(tiles) {
            self.tiles_for = Some(tiles);
            self.group_tiles(tiles);
        }
    }

    /// `blocks` blocks with about equal shares of the pairs, and the
    /// partials.
    fn cut_blocks(&mut self, rows: &[u32], pairs: &[[u32; 2]], blocks: usize) {
        let n = rows.len() - 1;
        let total = pairs.len();
        self.block_particles.clear();
        self.block_particles.extend((0..blocks).map(|b| {
            rows.partition_point(|&start| start as usize * blocks < total * b)
                .min(n)
        }));
        self.block_particles.push(n);
        self.block_pairs.clear();
        self.block_pairs
            .extend(self.block_particles.iter().map(|&i| rows[i] as usize));
        self.find_partials(pairs);
    }

    /// Each particle's block, and the partials of the blocks as cut.
    fn find_partials(&mut self, pairs: &[[u32; 2]]) {
        let n = *self.block_particles.last().expect("blocks are cut");
        self.block_of.clear();
        for (b, w) in self.block_particles.windows(2).enumerate() {
            self.block_of.resize(w[1], b as u32);
        }
        // The partials, block by block, each particle once per block in the
        // order the block's pairs first reach it.
        self.scratch.clear();
        self.scratch.resize(n, u32::MAX);
        self.partial_particle.clear();
        self.block_partials.clear();
        for (b, w) in self.block_pairs.windows(2).enumerate() {
            self.block_partials.push(self.partial_particle.len());
            let b = b as u32;
            for &[_, j] in &pairs[w[0]..w[1]] {
                let reached = &mut self.scratch[j as usize];
                if self.block_of[j as usize] != b && *reached != b {
                    *reached = b;
                    self.partial_particle.push(j);
                }
            }
        }
        self.block_partials.push(self.partial_particle.len());
        // Per particle, its partials in block order (a counting sort).
        offsets_of(
            &mut self.partials_start,
            n,
            self.partial_particle.iter().map(|&j| j as usize),
        );
        self.partial_of.clear();
        self.partial_of.resize(self.partial_particle.len(), [0, 0]);
        self.scratch.clear();
        self.scratch.extend_from_slice(&self.partials_start[..n]);
        for (b, w) in self.block_partials.windows(2).enumerate() {
            for k in w[0]..w[1] {
                let slot = &mut self.scratch[self.partial_particle[k] as usize];
                self.partial_of[*slot as usize] = [b as u32, k as u32];
                *slot += 1;
            }
        }
    }

    /// `tiles` runs of whole blocks with about equal shares of the pairs
    /// (some empty if there are fewer blocks), and as many equal shares of
    /// the particles for the per-particle passes.
    fn group_tiles(&mut self, tiles: usize) {
        let n = *self.block_particles.last().expect("blocks are cut");
        let total = *self.block_pairs.last().expect("blocks are cut");
        let blocks = self.block_pairs.len() - 1;
        self.tile_blocks.clear();
        self.tile_blocks.extend((0..tiles).map(|t| {
            // The block boundary nearest to the tile's share of the pairs
            // (on a tie the later one).
            let target = total as f64 * t as f64 / tiles as f64;
            let after = self
                .block_pairs
                .partition_point(|&p| (p as f64) < target)
                .min(blocks);
            let before = after.saturating_sub(1);
            let (low, high) = (
                self.block_pairs[before] as f64,
                self.block_pairs[after] as f64,
            );
            if target - low < high - target {
                before
            } else {
                after
            }
        }));
        self.tile_blocks.push(blocks);
        self.shares.clear();
        self.shares.extend((0..=tiles).map(|t| n * t / tiles));
    }

    /// First particle of each share of the per-particle passes (kick, drift,
    /// gather), then the particle count: equal shares, one per tile.
    pub(super) fn shares(&self) -> &[usize] {
        &self.shares
    }

    /// Particle `i`'s sum of pair forces (N) and torques (N·m): its own sum
    /// `own` plus its partials (of all `partials`) in block order. Always
    /// inlined: left to the compiler, the gather called it and one thread
    /// ran slower.
    ///
    /// Measured: docs/performance.md ("src/dem/simulation/tiles.rs").
    #[inline(always)]
    pub(super) fn pair_sum(
        &self,
        i: usize,
        own: &Accumulated,
        partials: &[Accumulated],
    ) -> Accumulated {
        let range = self.partials_start[i] as usize..self.partials_start[i + 1] as usize;
        let mut sum = *own;
        for &[_, k] in &self.partial_of[range] {
            sum.force += partials[k as usize].force;
            sum.torque += partials[k as usize].torque;
        }
        sum
    }

    /// Partials in all (the length the partial sums need).
    pub(super) fn partial_count(&self) -> usize {
        *self.block_partials.last().unwrap_or(&0)
    }

    /// The index of particle `j`'s partial for the rows of block `b`.
    #[inline(always)]
    fn partial(&self, j: usize, b: u32) -> usize {
        let range = self.partials_start[j] as usize..self.partials_start[j + 1] as usize;
        let found = self.partial_of[range]
            .iter()
            .find(|&&[block, _]| block == b);
        found.expect("a block reaching a particle has its partial")[1] as usize
    }

    /// One job per tile, from the sweep's pairs and their history, the
    /// partial sums and the own sums (each as long as the cut's pairs,
    /// partials or particles).
    pub(super) fn jobs<'a, H>(
        &'a self,
        pairs: &'a [[u32; 2]],
        mut history: &'a mut [H],
        mut partials: &'a mut [Accumulated],
        mut sums: &'a mut [Accumulated],
    ) -> Vec<TileJob<'a, H>> {
        let mut jobs = Vec::with_capacity(self.tile_blocks.len());
        for w in self.tile_blocks.windows(2) {
            let (b0, b1) = (w[0], w[1]);
            let pair_range = self.block_pairs[b0]..self.block_pairs[b1];
            let (h, rest_h) = std::mem::take(&mut history).split_at_mut(pair_range.len());
            let (p, rest_p) = std::mem::take(&mut partials)
                .split_at_mut(self.block_partials[b1] - self.block_partials[b0]);
            let (s, rest_s) = std::mem::take(&mut sums)
                .split_at_mut(self.block_particles[b1] - self.block_particles[b0]);
            (history, partials, sums) = (rest_h, rest_p, rest_s);
            jobs.push(TileJob {
                pairs: &pairs[pair_range.clone()],
                history: h,
                sink: TileSink {
                    first_particle: self.block_particles[b0],
                    first_pair: pair_range.start,
                    first_partial: self.block_partials[b0],
                    tiles: self,
                    sums: s,
                    partials: p,
                },
            });
        }
        jobs
    }
}

/// One tile's work: its pairs, their contact history, and where their
/// forces go.
pub(super) struct TileJob<'a, H> {
    pub(super) pairs: &'a [[u32; 2]],
    pub(super) history: &'a mut [H],
    pub(super) sink: TileSink<'a>,
}

/// A sum of forces (N) and torques (N·m) over pairs.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Accumulated {
    pub(super) force: Vec3,
    pub(super) torque: Vec3,
}

impl Accumulated {
    /// The sum before any pair: the body force `force` (N), no torque.
    pub(super) fn body_force(force: Vec3) -> Self {
        Self {
            force,
            torque: Vec3::zeros(),
        }
    }
}

/// Where one tile's pair forces go: the own sums of its particles and the
/// partials of its blocks.
pub(super) struct TileSink<'a> {
    /// Index of the tile's first particle.
    first_particle: usize,
    /// Index of the tile's first pair.
    first_pair: usize,
    /// Index of the tile's first partial.
    first_partial: usize,
    /// The cut (blocks and partials of all particles).
    tiles: &'a Tiles,
    /// The tile's particles' own sums.
    sums: &'a mut [Accumulated],
    /// The tile's blocks' partials.
    partials: &'a mut [Accumulated],
}

impl TileSink<'_> {
    /// Index of the tile's first pair.
    pub(super) fn first_pair(&self) -> usize {
        self.first_pair
    }

    /// Starts the own sums of the tile's particles at the body force `g · m`
    /// (N), with the masses of `motion` (all particles' records), and its
    /// partials at zero.
    pub(super) fn start(&mut self, g: Vec3, motion: &[Motion]) {
        for (s, p) in self.sums.iter_mut().zip(&motion[self.first_particle..]) {
            *s = Accumulated::body_force(g * p.m);
        }
        self.partials.fill(Accumulated::default());
    }
}

impl PairSink for TileSink<'_> {
    #[inline(always)]
    fn put(&mut self, i: usize, j: usize, force: &PairForce) {
        // i's row is in its own block, so in this tile.
        let s = &mut self.sums[i - self.first_particle];
        s.force += force.force_on_first;
        s.torque += force.torque[0];
        let block = self.tiles.block_of[i];
        let s = if self.tiles.block_of[j] == block {
            &mut self.sums[j - self.first_particle]
        } else {
            &mut self.partials[self.tiles.partial(j, block) - self.first_partial]
        };
        s.force -= force.force_on_first;
        s.torque += force.torque[1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CSR row offsets of `pairs` (sorted by first particle) for `n` particles.
    fn rows_of(pairs: &[[u32; 2]], n: usize) -> Vec<u32> {
        let mut rows = Vec::new();
        offsets_of(&mut rows, n, pairs.iter().map(|&[i, _]| i as usize));
        rows
    }

    #[test]
    fn blocks_are_powers_of_two_of_at_least_the_block_size() {
        assert_eq!(blocks_for(0), 1);
        assert_eq!(blocks_for(2 * PARTICLES_PER_BLOCK - 1), 1);
        assert_eq!(blocks_for(2 * PARTICLES_PER_BLOCK), 2);
        assert_eq!(blocks_for(7 * PARTICLES_PER_BLOCK), 4);
        assert_eq!(blocks_for(1000 * PARTICLES_PER_BLOCK), MAX_BLOCKS);
    }

    /// A chain 0-1-...-(n−1) plus a long pair 0-(n−1) (a periodic wrap), cut
    /// into `blocks` blocks by hand (the cut's block count depends on the
    /// particle count alone, and a test bed of thousands would hide the
    /// structure).
    fn chain_in_blocks(n: usize, blocks: usize) -> (Vec<[u32; 2]>, Tiles) {
        let mut pairs: Vec<[u32; 2]> = (0..n as u32 - 1).map(|i| [i, i + 1]).collect();
        pairs.insert(1, [0, n as u32 - 1]);
        let rows = rows_of(&pairs, n);
        let mut tiles = Tiles::default();
        tiles.cut(1, &rows, &pairs, 1);
        assert_eq!(
            tiles.block_particles,
            vec![0, n],
            "{n} particles: one block"
        );
        tiles.cut_blocks(&rows, &pairs, blocks);
        (pairs, tiles)
    }

    #[test]
    fn a_particle_gets_a_partial_for_each_earlier_block_that_reaches_it() {
        // 12 pairs in three blocks of 4: rows 0 (2 pairs), 1, 2 | 3..6 | 7..11.
        let mut tiles = chain_in_blocks(12, 3).1;
        assert_eq!(tiles.block_particles, vec![0, 3, 7, 12]);
        // 11 is reached by block 0 (the wrap) and block 2 is its own; 3 by
        // block 0; 7 by block 1.
        let reached: Vec<(usize, Vec<usize>)> = (0..12)
            .map(|i| {
                let range = tiles.partials_start[i] as usize..tiles.partials_start[i + 1] as usize;
                let partials = tiles.partial_of[range].iter().map(|&[_, k]| k as usize);
                (i, partials.collect::<Vec<_>>())
            })
            .filter(|(_, p)| !p.is_empty())
            .collect();
        assert_eq!(reached, vec![(3, vec![1]), (7, vec![2]), (11, vec![0])]);
        // Partials are laid out by the block whose rows they sum: block 0
        // reaches 11 (pair 0-11 comes before 2-3) then 3.
        assert_eq!(tiles.block_partials, vec![0, 2, 3, 3]);
        assert_eq!(tiles.partial(11, 0), 0);
        assert_eq!(tiles.partial(3, 0), 1);
        assert_eq!(tiles.partial(7, 1), 2);
        // Two tiles of three blocks: the boundary nearest half the pairs.
        tiles.group_tiles(2);
        assert_eq!(tiles.tile_blocks.len(), 3);
        assert!(tiles.tile_blocks[1] == 1 || tiles.tile_blocks[1] == 2);
        assert_eq!(tiles.shares(), &[0, 6, 12]);
        // Four tiles of three blocks: one stays empty.
        tiles.group_tiles(4);
        let sizes: Vec<usize> = tiles.tile_blocks.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!((sizes.iter().sum::<usize>(), sizes.contains(&0)), (3, true));
    }

    #[test]
    fn sums_do_not_depend_on_how_blocks_are_grouped_into_tiles() {
        let (pairs, mut tiles) = chain_in_blocks(12, 3);
        let f = |k: usize| PairForce {
            force_on_first: Vec3::new(1.0 + k as f64 * 0.1, 0.0, 0.0),
            torque: [Vec3::new(0.0, k as f64, 0.0), Vec3::new(0.0, 0.0, k as f64)],
        };
        let mut results = Vec::new();
        // Four tiles of three blocks leave one tile empty.
        for count in [1, 2, 3, 4] {
            tiles.group_tiles(count);
            let mut history = vec![(); pairs.len()];
            let mut partials = vec![Accumulated::default(); tiles.partial_count()];
            let mut sums = vec![Accumulated::default(); 12];
            for job in tiles.jobs(&pairs, &mut history, &mut partials, &mut sums) {
                let mut sink = job.sink;
                let first = sink.first_pair();
                for (k, &[i, j]) in job.pairs.iter().enumerate() {
                    sink.put(i as usize, j as usize, &f(first + k));
                }
            }
            let totals: Vec<[f64; 6]> = (0..12)
                .map(|i| {
                    let a = tiles.pair_sum(i, &sums[i], &partials);
                    let (f, t) = (a.force, a.torque);
                    [f.x, f.y, f.z, t.x, t.y, t.z]
                })
                .collect();
            results.push(totals);
        }
        assert!(results.iter().all(|r| *r == results[0]));
        // Particle 11: −(pair 0-11) from its partial, −(pair 10-11) own.
        assert_eq!(results[0][11][0], -(1.0 + 0.1) - (1.0 + 1.1));
    }
}
