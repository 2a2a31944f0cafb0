//! Tiles of the pair sweep: most pair forces are added straight into
//! per-particle sums instead of passing through the per-pair buffer.
//!
//! Particles are cut into index ranges (tiles) with about the same number of
//! pairs in each: one per member of the stepper's team (one tile on one
//! thread). A tile's pairs are the rows of its particles
//! (`[i, j]`, `i` in the tile, `j > i`), evaluated in pair order by one task.
//! A particle that some pair of an *earlier* tile reaches is a *head* of its
//! tile: its sum has contributions that another task computes. For every pair
//! touching a head the kernel writes the pair's forces to the per-pair
//! buffer, and the head's sum is gathered from that buffer afterwards in pair
//! order (the stepper's gather). Every other particle has its pairs' forces
//! added to its [`Accumulated`] sum in the order the kernel meets them, which
//! is also pair order. Both ways add the same terms in the same order as
//! gathering every particle from the buffer, so the results do not depend on
//! the tiles at all — they are bit-identical on any thread count — and only
//! the memory traffic differs: a pair's 72-byte record is neither written nor
//! read back unless it touches a head. On one thread there is one tile and no
//! heads; on more, the heads are about one cell slab per tile boundary (plus
//! the last slab of a periodic axis, which the first tile reaches).

use super::pair_kernel::{Motion, PairForce, PairSink};
use crate::dem::vec3::Vec3;

/// Cost of gathering a head (summing its pairs' records from the buffer)
/// relative to a particle whose sum is ready. Measured on the 5,120-particle
/// bench bed on two threads (2026-11-26): with 2 and 3, the two shares' gather
/// profiles agree within 20 % and the step ran 17.9–18.7 Mps/s, against
/// 12–16 with 0 and 13–15 with 1 (alternating runs on a noisy host).
const HEAD_GATHER_COST: f64 = 3.0;

/// How the pair sweep is cut into tiles, kept until the neighbour list is
/// rebuilt or the thread count changes.
#[derive(Clone, Debug, Default)]
pub(super) struct Tiles {
    /// First particle of each tile, then the particle count.
    particles: Vec<usize>,
    /// First pair of each tile, then the pair count.
    pairs: Vec<usize>,
    /// Per particle: a head of its tile.
    head: Vec<bool>,
    /// First particle of each share of the per-particle gather, then the
    /// particle count (see [`gather_bounds`](Self::gather_bounds)).
    gather: Vec<usize>,
    /// (Neighbour build, tiles, particles, pairs) the cut is for.
    cut_for: Option<(u64, usize, usize, usize)>,
}

impl Tiles {
    /// Cuts `tiles` tiles, with about equal shares of the pairs, for
    /// neighbour build number `build` with rows `rows` (CSR offsets, len =
    /// particles + 1) and `pairs`; keeps the cut if it is for the same.
    pub(super) fn cut(&mut self, build: u64, rows: &[u32], pairs: &[[u32; 2]], tiles: usize) {
        let n = rows.len() - 1;
        let total = pairs.len();
        let cut_for = Some((build, tiles, n, total));
        if self.cut_for == cut_for {
            return;
        }
        self.cut_for = cut_for;
        self.particles.clear();
        self.particles.extend((0..tiles).map(|t| {
            rows.partition_point(|&start| start as usize * tiles < total * t)
                .min(n)
        }));
        self.particles.push(n);
        self.pairs.clear();
        self.pairs
            .extend(self.particles.iter().map(|&i| rows[i] as usize));
        self.head.clear();
        self.head.resize(n, false);
        for (tile, range) in self.particles.windows(2).zip(self.pairs.windows(2)) {
            for &[_, j] in &pairs[range[0]..range[1]] {
                if j as usize >= tile[1] {
                    self.head[j as usize] = true;
                }
            }
        }
        // Cut the gather where the cumulative cost, heads counted at
        // HEAD_GATHER_COST, reaches each tile's share.
        let cost = |i: usize| if self.head[i] { HEAD_GATHER_COST } else { 1.0 };
        let total_cost: f64 = (0..n).map(cost).sum();
        self.gather.clear();
        let mut sum = 0.0;
        let mut i = 0;
        for t in 0..tiles {
            let target = total_cost * t as f64 / tiles as f64;
            while i < n && sum < target {
                sum += cost(i);
                i += 1;
            }
            self.gather.push(i);
        }
        self.gather.push(n);
    }

    /// First particle of each tile, then the particle count.
    pub(super) fn bounds(&self) -> &[usize] {
        &self.particles
    }

    /// First particle of each share of the gather, then the particle count:
    /// the tiles' cut moved so that each share costs about the same, a head
    /// counting as [`HEAD_GATHER_COST`] particles. Without the move, the
    /// heads, all in later tiles, made the last share of two 1.5–2× as
    /// costly as the first at 5,120 particles.
    pub(super) fn gather_bounds(&self) -> &[usize] {
        &self.gather
    }

    /// Whether particle `i` is a head (its sum is gathered from the buffer).
    #[inline]
    pub(super) fn is_head(&self, i: usize) -> bool {
        self.head[i]
    }

    /// One job per tile, from the sweep's pairs and their history, the
    /// per-pair buffer and the per-particle sums (each as long as the cut's
    /// pairs or particles).
    pub(super) fn jobs<'a, H>(
        &'a self,
        pairs: &'a [[u32; 2]],
        mut history: &'a mut [H],
        mut buffer: &'a mut [PairForce],
        mut sums: &'a mut [Accumulated],
    ) -> Vec<TileJob<'a, H>> {
        let mut jobs = Vec::with_capacity(self.particles.len());
        for (tile, range) in self.particles.windows(2).zip(self.pairs.windows(2)) {
            let len = range[1] - range[0];
            let (h, rest_h) = std::mem::take(&mut history).split_at_mut(len);
            let (b, rest_b) = std::mem::take(&mut buffer).split_at_mut(len);
            let (s, rest_s) = std::mem::take(&mut sums).split_at_mut(tile[1] - tile[0]);
            (history, buffer, sums) = (rest_h, rest_b, rest_s);
            jobs.push(TileJob {
                pairs: &pairs[range[0]..range[1]],
                history: h,
                sink: TileSink {
                    first_particle: tile[0],
                    first_pair: range[0],
                    head: &self.head,
                    sums: s,
                    buffer: b,
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

/// One particle's sum of forces (N) and torques (N·m) over its pairs so far,
/// started at the body force.
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

/// Where one tile's pair forces go: into the sums of the tile's non-head
/// particles, and into the per-pair buffer for pairs touching a head.
pub(super) struct TileSink<'a> {
    /// Index of the tile's first particle.
    first_particle: usize,
    /// Index of the tile's first pair.
    first_pair: usize,
    /// Head flags of all particles.
    head: &'a [bool],
    /// The tile's particles' sums.
    sums: &'a mut [Accumulated],
    /// The tile's pairs' slots in the per-pair buffer.
    buffer: &'a mut [PairForce],
}

impl TileSink<'_> {
    /// Index of the tile's first pair.
    pub(super) fn first_pair(&self) -> usize {
        self.first_pair
    }

    /// Starts every sum of the tile at the body force `g · m` (N), with the
    /// masses of `motion` (all particles' records).
    pub(super) fn start(&mut self, g: Vec3, motion: &[Motion]) {
        for (s, p) in self.sums.iter_mut().zip(&motion[self.first_particle..]) {
            *s = Accumulated::body_force(g * p.m);
        }
    }
}

impl PairSink for TileSink<'_> {
    #[inline(always)]
    fn put(&mut self, pair: usize, i: usize, j: usize, force: &PairForce) {
        let (head_i, head_j) = (self.head[i], self.head[j]);
        if head_i || head_j {
            self.buffer[pair - self.first_pair] = *force;
        }
        if !head_i {
            let s = &mut self.sums[i - self.first_particle];
            s.force += force.force_on_first;
            s.torque += force.torque[0];
        }
        if !head_j {
            // j is in this tile: a j of a later tile is a head there.
            let s = &mut self.sums[j - self.first_particle];
            s.force -= force.force_on_first;
            s.torque += force.torque[1];
        }
    }

    #[inline(always)]
    fn skip(&mut self, pair: usize, i: usize, j: usize) {
        if self.head[i] || self.head[j] {
            self.buffer[pair - self.first_pair] = PairForce::default();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CSR row offsets of `pairs` (sorted by first particle) for `n` particles.
    fn rows_of(pairs: &[[u32; 2]], n: usize) -> Vec<u32> {
        let mut rows = vec![0u32; n + 1];
        for &[i, _] in pairs {
            rows[i as usize + 1] += 1;
        }
        for i in 0..n {
            rows[i + 1] += rows[i];
        }
        rows
    }

    #[test]
    fn tiles_split_the_pairs_evenly_and_heads_are_the_particles_reached_from_earlier_tiles() {
        // A chain 0-1-2-...-11 plus one long pair 0-11 (a periodic wrap).
        let n = 12;
        let mut pairs: Vec<[u32; 2]> = (0..11).map(|i| [i, i + 1]).collect();
        pairs.insert(1, [0, 11]);
        let rows = rows_of(&pairs, n);
        let mut tiles = Tiles::default();
        tiles.cut(1, &rows, &pairs, 3);
        // 12 pairs in three tiles of 4: rows 0 (2 pairs), 1, 2 | 3, 4, 5, 6 | 7..11.
        assert_eq!(tiles.particles, vec![0, 3, 7, 12]);
        assert_eq!(tiles.pairs, vec![0, 4, 8, 12]);
        let heads: Vec<usize> = (0..n).filter(|&i| tiles.is_head(i)).collect();
        // 3 and 7 are reached from the tile before; 11 from the first tile.
        assert_eq!(heads, vec![3, 7, 11]);
        // The gather's shares cost the same, each within one head of a third.
        let cost = |i: usize| {
            if tiles.is_head(i) {
                HEAD_GATHER_COST
            } else {
                1.0
            }
        };
        let total: f64 = (0..n).map(cost).sum();
        let bounds = tiles.gather_bounds();
        assert_eq!((bounds.len(), bounds[0], bounds[3]), (4, 0, n));
        for w in bounds.windows(2) {
            let share: f64 = (w[0]..w[1]).map(cost).sum();
            assert!(
                (share - total / 3.0).abs() < HEAD_GATHER_COST,
                "{bounds:?}: share {share} of {total}"
            );
        }
        // One tile: no heads.
        tiles.cut(1, &rows, &pairs, 1);
        assert!((0..n).all(|i| !tiles.is_head(i)));
        assert_eq!(tiles.particles, vec![0, 12]);
    }

    #[test]
    fn a_sink_adds_non_heads_in_place_and_buffers_pairs_that_touch_a_head() {
        let mut tiles = Tiles::default();
        let pairs = [[0u32, 1], [1, 2], [2, 3]];
        let rows = rows_of(&pairs, 4);
        tiles.cut(7, &rows, &pairs, 2);
        // Tiles [0, 2) and [2, 4): particle 2 is reached from the first tile.
        assert_eq!(tiles.particles, vec![0, 2, 4]);
        let mut history = [(); 3];
        let mut buffer = [PairForce::default(); 3];
        let mut sums = [Accumulated::default(); 4];
        let f = |x: f64| PairForce {
            force_on_first: Vec3::new(x, 0.0, 0.0),
            torque: [Vec3::new(0.0, x, 0.0), Vec3::new(0.0, 0.0, x)],
        };
        let mut jobs = tiles.jobs(&pairs, &mut history, &mut buffer, &mut sums);
        jobs[0].sink.put(0, 0, 1, &f(1.0));
        jobs[0].sink.put(1, 1, 2, &f(2.0));
        jobs[1].sink.put(2, 2, 3, &f(4.0));
        drop(jobs);
        assert_eq!(sums[0].force.x, 1.0);
        assert_eq!(sums[1].force.x, -1.0 + 2.0);
        assert_eq!(sums[1].torque, Vec3::new(0.0, 2.0, 1.0));
        assert_eq!(sums[3].force.x, -4.0);
        assert_eq!(sums[2].force.x, 0.0, "a head's sum is not used");
        assert_eq!(buffer[0].force_on_first.x, 0.0, "no head: not buffered");
        assert_eq!(buffer[1].force_on_first.x, 2.0);
        assert_eq!(buffer[2].force_on_first.x, 4.0);
    }
}
