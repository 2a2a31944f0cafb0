//! Neighbour search: a cell grid feeding a Verlet half list with a skin, whose
//! per-pair contact history survives rebuilds.
//!
//! # What the stepper does with it
//!
//! ```text
//! if nl.needs_rebuild(&x) {
//!     // optional, e.g. every k-th rebuild: re-sort particles by cell for locality
//!     let perm = nl.cell_order(&x, &r, &domain)?;
//!     apply_permutation(&perm, &mut x); ... every per-particle array, ids included ...
//!     nl.rebuild(&x, &r, &ids, &domain)?;   // mandatory after a permutation
//! }
//! // per pair k, row by row (pairs[row_offsets()[i]..row_offsets()[i + 1]] are row i):
//! //     the force between pairs[k][0] and pairs[k][1] from history[k], updated in place
//! ```
//!
//! # Conventions
//!
//! * **Pairs**: each pair once, `[i, j]` with `i < j` (current particle indices), sorted
//!   by `(i, j)`. A pair is listed when `|min_image(x_j − x_i)| < r_i + r_j + extra_range
//!   + skin` at the last build (tested as `d·d < cut·cut`, `cut = r_i + r_j + (extra_range
//!   + skin)`). As long as no particle moved more than `skin / 2` since then, every pair
//!   within interaction range `r_i + r_j + extra_range` is listed.
//! * **History**: `history()[k]` belongs to `pairs()[k]`. On rebuild the history of every
//!   pair still listed is carried over, matched by the caller's stable particle ids (not
//!   by index), so it survives re-sorting. New pairs start at `H::default()`. A pair
//!   leaves the list, and loses its history, only once it is beyond its cutoff + skin,
//!   i.e. when the contact has certainly ended — the fix for contact loss at rebuilds
//!   (adhesive JKR contacts stretched beyond touching keep their state).
//! * **Permutations**: [`NeighborList::cell_order`] gives `perm` with `perm[new] = old`;
//!   [`apply_permutation`] gathers an array with it. After permuting the particle arrays
//!   (ids included) the caller **must** call [`NeighborList::rebuild`] before using the
//!   list again (pairs and rows are index-based); the history is not lost
//!   because it is matched by id. There is no `remap`: re-sorting happens when a rebuild is
//!   due anyway, and a rebuild costs about as much as a remap would.
//!
//! # Cost
//!
//! Rebuild is O(N + pairs): counting sorts (no comparison sort of all pairs, no hash map),
//! the search parallel over fixed particle chunks with rayon and bit-identical to a
//! serial build. Two search modes, chosen per build from the radii:
//!
//! * **Narrow distribution** (largest radius ≤ 1.5 × mean): cells of edge
//!   `2 r_max + extra_range + skin`; each particle scans later slots of its own cell and
//!   its 13 forward neighbour cells (half stencil), from contiguous cell-sorted memory.
//! * **Wide distribution** (e.g. 1:10): cells sized for the *mean* particle,
//!   `2 r_mean + extra_range + skin`; particle `i` scans the cells within
//!   `2 r_i + extra_range + skin` and lists only partners no larger than itself, so each
//!   pair is found once, by its larger member. Small particles scan 27 small cells; only
//!   the few large ones scan many, so the cost per particle stays near the monodisperse
//!   one. What still grows is the work of the large particles themselves,
//!   ∝ (r_i / r_mean)³ cells each: a bed whose *volume* is mostly large particles pays
//!   roughly as if that volume were filled with mean-sized ones.
//!
//! Sparse scenes (hoppers, funnels: a bounding box of many empty cells) are capped at
//! `16 N + 4096` cells, beyond which cells grow.
//!
//! All buffers are kept between rebuilds; `needs_rebuild` allocates nothing.
//!
//! Measurements, and what was tried and not kept, are in `docs/performance.md`.

use crate::dem::domain::{Domain, DomainError};
use crate::dem::vec3::Vec3;
use rayon::prelude::*;
use std::fmt;
use std::ops::Range;

/// Particles handled per parallel task; fixed (never derived from the thread count) so
/// the work split, and hence every output, is independent of the pool size.
const CHUNK: usize = 512;
/// Pairs handled per parallel task in the history merge.
const PAIR_CHUNK: usize = 4096;
/// Relative margin by which cells exceed the cutoff, so that float rounding in binning
/// can never put two points closer than the cutoff two cells apart.
const CELL_MARGIN: f64 = 1e-9;
/// Above this ratio of largest to mean radius the grid is sized for the mean particle
/// and searched with per-particle stencils (see [`NeighborList::rebuild`]).
const WIDE_RATIO: f64 = 1.5;

/// Per-chunk summary of the input, reduced in chunk order.
#[derive(Debug, Clone, Copy)]
struct ChunkStats {
    lo: [f64; 3],
    hi: [f64; 3],
    r_max: f64,
    r_sum: f64,
    bad: bool,
}

impl ChunkStats {
    const EMPTY: ChunkStats = ChunkStats {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
        r_max: 0.0,
        r_sum: 0.0,
        bad: false,
    };
}

/// Why a neighbour list could not be built.
#[derive(Debug, Clone, PartialEq)]
pub enum NeighborError {
    /// `skin` must be finite and ≥ 0 (m).
    InvalidSkin {
        /// The rejected value (m).
        value: f64,
    },
    /// `extra_range` must be finite and ≥ 0 (m).
    InvalidExtraRange {
        /// The rejected value (m).
        value: f64,
    },
    /// A per-particle slice has a different length than `positions`.
    LengthMismatch {
        /// Which argument (`"radii"` or `"ids"`).
        field: &'static str,
        /// `positions.len()`.
        expected: usize,
        /// Its length.
        found: usize,
    },
    /// A radius is not finite or not > 0 (m).
    InvalidRadius {
        /// Particle index.
        index: usize,
        /// The rejected radius (m).
        value: f64,
    },
    /// A position component is NaN or infinite.
    NonFinitePosition {
        /// Particle index.
        index: usize,
    },
    /// Two particles carry the same id, so their contact histories cannot be told apart.
    DuplicateId {
        /// The repeated id.
        id: u32,
    },
    /// More particles than a `u32` index can address (limit `u32::MAX − 1`).
    TooManyParticles {
        /// The number of particles given.
        count: usize,
    },
    /// More pairs than the row offsets (`u32`) can address (limit 2³² − 1).
    TooManyPairs {
        /// The number of pairs found.
        count: usize,
    },
    /// The domain cannot host this search (a periodic axis shorter than 2 × cutoff).
    Domain(DomainError),
}

impl fmt::Display for NeighborError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NeighborError::InvalidSkin { value } => {
                write!(f, "neighbor.skin = {value} m: must be finite and >= 0")
            }
            NeighborError::InvalidExtraRange { value } => {
                write!(
                    f,
                    "neighbor.extra_range = {value} m: must be finite and >= 0"
                )
            }
            NeighborError::LengthMismatch {
                field,
                expected,
                found,
            } => write!(
                f,
                "neighbor: {field} has {found} entries but positions has {expected}"
            ),
            NeighborError::InvalidRadius { index, value } => write!(
                f,
                "neighbor: radius of particle {index} is {value} m: must be finite and > 0"
            ),
            NeighborError::NonFinitePosition { index } => {
                write!(f, "neighbor: position of particle {index} is not finite")
            }
            NeighborError::DuplicateId { id } => {
                write!(f, "neighbor: particle id {id} is used more than once")
            }
            NeighborError::TooManyParticles { count } => {
                write!(f, "neighbor: {count} particles exceed the u32 index limit")
            }
            NeighborError::TooManyPairs { count } => {
                write!(f, "neighbor: {count} pairs exceed the 2^32 - 1 limit")
            }
            NeighborError::Domain(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for NeighborError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            NeighborError::Domain(e) => Some(e),
            _ => None,
        }
    }
}

impl From<DomainError> for NeighborError {
    fn from(e: DomainError) -> Self {
        NeighborError::Domain(e)
    }
}

/// The cell grid of one build: origin, cell widths and counts per axis.
#[derive(Debug, Clone, Copy)]
struct Grid {
    origin: [f64; 3],
    inv_width: [f64; 3],
    n: [usize; 3],
    periodic: [bool; 3],
    width: f64,
    /// Cells sized for the mean particle, per-particle stencils (wide distribution).
    wide: bool,
}

impl Grid {
    /// Grid with cells at least `cutoff` wide covering the periodic box on periodic axes
    /// and the particles' bounding box on the others, coarsened if it would have more
    /// than `16 N + 4096` cells (a sparse scene: the per-rebuild cost of empty cells is
    /// bounded by O(N), at the price of more candidates per cell).
    fn new(
        domain: &Domain,
        bb_lo: [f64; 3],
        bb_hi: [f64; 3],
        cutoff: f64,
        n_part: usize,
        wide: bool,
    ) -> Grid {
        let cap = (16.0 * n_part as f64 + 4096.0).min(f64::from(u32::MAX - 1));
        let mut s = cutoff * (1.0 + CELL_MARGIN);
        if s.is_nan() || s <= 0.0 {
            s = f64::MIN_POSITIVE;
        }
        let (lo, len, per) = (domain.lo(), domain.lengths(), domain.periodic());
        loop {
            let mut origin = [0.0; 3];
            let mut inv_width = [0.0; 3];
            let mut nf = [1.0f64; 3];
            for a in 0..3 {
                if per[a] {
                    let n = (len[a] / s).floor().max(1.0);
                    origin[a] = lo[a];
                    nf[a] = n;
                    inv_width[a] = n / len[a];
                } else {
                    let ext = (bb_hi[a] - bb_lo[a]).max(0.0);
                    nf[a] = (ext / s).floor() + 1.0;
                    origin[a] = bb_lo[a];
                    inv_width[a] = 1.0 / s;
                }
            }
            if nf[0] * nf[1] * nf[2] <= cap {
                return Grid {
                    origin,
                    inv_width,
                    n: nf.map(|v| v as usize),
                    periodic: per,
                    width: s,
                    wide,
                };
            }
            s *= 1.5;
        }
    }

    #[inline]
    fn n_cells(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// Cell coordinates of a (finite) position; `p` must already be wrapped on
    /// periodic axes.
    #[inline]
    fn coords(&self, p: Vec3) -> [usize; 3] {
        let mut c = [0usize; 3];
        for (a, ca) in c.iter_mut().enumerate() {
            let u = (p[a] - self.origin[a]) * self.inv_width[a];
            // Truncation is floor for u >= 0 (no libm call); `as` saturates, so
            // negatives give 0 and huge values are clamped to the last cell.
            *ca = (u as usize).min(self.n[a] - 1);
        }
        c
    }

    #[inline]
    fn linear(&self, c: [usize; 3]) -> usize {
        c[0] + self.n[0] * (c[1] + self.n[1] * c[2])
    }

    /// The neighbour cells of `c` along axis `a` (itself and ±1; wrapped on periodic
    /// axes with ≥ 3 cells, clipped otherwise — on a periodic axis with ≤ 2 cells every
    /// cell is a neighbour and minimum image does the wrapping), as up to two runs
    /// `[first, last]` of consecutive cells, and the run count. Each cell appears once.
    #[inline]
    fn runs(&self, a: usize, c: usize) -> ([[usize; 2]; 2], usize) {
        let n = self.n[a];
        if !self.wraps(a) || (c > 0 && c + 1 < n) {
            return ([[c.saturating_sub(1), (c + 1).min(n - 1)], [0, 0]], 1);
        }
        if n == 3 {
            ([[0, 2], [0, 0]], 1)
        } else if c == 0 {
            ([[0, 1], [n - 1, n - 1]], 2)
        } else {
            ([[0, 0], [n - 2, n - 1]], 2)
        }
    }

    /// The cells within `k` cells of `c` along axis `a` (wrapped on periodic axes, clipped
    /// otherwise; every cell once, all of them when `2k + 1` covers the axis), as up to
    /// two runs `[first, last]` and the run count.
    #[inline]
    fn runs_k(&self, a: usize, c: usize, k: usize) -> ([[usize; 2]; 2], usize) {
        let n = self.n[a];
        if 2 * k + 1 >= n {
            return ([[0, n - 1], [0, 0]], 1);
        }
        if !self.periodic[a] || (c >= k && c + k < n) {
            return ([[c.saturating_sub(k), (c + k).min(n - 1)], [0, 0]], 1);
        }
        if c < k {
            // Wraps below 0: [0, c + k] and [n - (k - c), n - 1].
            ([[0, c + k], [n + c - k, n - 1]], 2)
        } else {
            // Wraps above n - 1: [0, c + k - n] and [c - k, n - 1].
            ([[0, c + k - n], [c - k, n - 1]], 2)
        }
    }

    /// Cells per axis a particle of search distance `d` (m) must look at on each side.
    #[inline]
    fn reach_cells(&self, d: f64) -> [usize; 3] {
        let d = d * (1.0 + CELL_MARGIN);
        [0, 1, 2].map(|a| ((d * self.inv_width[a]).ceil() as usize).max(1))
    }

    /// True when cell indices wrap around on axis `a` (periodic with ≥ 3 cells, so that
    /// the cells at −1 and +1 differ).
    #[inline]
    fn wraps(&self, a: usize) -> bool {
        self.periodic[a] && self.n[a] >= 3
    }

    /// The forward neighbour cell (+1) of `c` along axis `a`, if any. Together with
    /// [`runs`](Self::runs) this defines a half stencil visiting every unordered pair of
    /// neighbouring cells exactly once.
    #[inline]
    fn forward(&self, a: usize, c: usize) -> Option<usize> {
        if c + 1 < self.n[a] {
            Some(c + 1)
        } else if self.wraps(a) {
            Some(0)
        } else {
            None
        }
    }
}

/// Reusable scratch of the build (kept between rebuilds so nothing is reallocated in
/// steady state).
#[derive(Debug, Default)]
struct Scratch<H> {
    /// Per-chunk input summaries.
    stats: Vec<ChunkStats>,
    /// Linear cell index of each particle.
    cell_of: Vec<u32>,
    /// Start of each cell in `sorted` (len cells + 1).
    cell_start: Vec<u32>,
    /// Particle indices sorted by cell, ties by index.
    sorted: Vec<u32>,
    /// `[x, y, z, r]` of `sorted` particles, contiguous per cell.
    sorted_xr: Vec<[f64; 4]>,
    /// Per-chunk pair output of the search.
    chunk_pairs: Vec<Vec<[u32; 2]>>,
    /// Pairs of the previous build.
    old_pairs: Vec<[u32; 2]>,
    /// History of the previous build.
    old_history: Vec<H>,
    /// Old particle index -> new index (u32::MAX: gone).
    carry: Vec<u32>,
    /// id -> new index (dense ids) or (id, new index) sorted (sparse ids).
    id_table: Vec<u32>,
    id_sorted: Vec<(u32, u32)>,
    /// Old pairs expressed in new indices with their old pair index, `[i, j, k_old]`,
    /// sorted by (i, j); `rem_start` is the row start of each i during the counting sort.
    rem_start: Vec<u32>,
    rem: Vec<[u32; 3]>,
    /// Fill cursors of the pairs' counting sort.
    cursor: Vec<u32>,
}

/// Verlet half list over a cell grid, with per-pair contact history `H` carried across
/// rebuilds.
///
/// `H` is whatever a contact law keeps per contact (e.g. the tangential spring, whether a
/// JKR contact has touched); `()` or another zero-sized type when it keeps nothing, in
/// which case `history` stores nothing and the carry-over is skipped entirely.
#[derive(Debug)]
pub struct NeighborList<H> {
    skin: f64,
    extra_range: f64,
    /// Domain, grid and cutoff of the last build (`None`: never built).
    domain: Option<Domain>,
    grid_dims: [usize; 3],
    cell_size: f64,
    wide: bool,
    cutoff: f64,
    stale: bool,
    rebuilds: u64,
    pairs: Vec<[u32; 2]>,
    history: Vec<H>,
    /// `pairs[row_start[i]..row_start[i+1]]` are the pairs whose first particle is `i`.
    row_start: Vec<u32>,
    ref_pos: Vec<Vec3>,
    ids: Vec<u32>,
    scratch: Scratch<H>,
}

impl<H: Copy + Default + Send + Sync> NeighborList<H> {
    /// An empty list (never built: [`needs_rebuild`](Self::needs_rebuild) is true).
    ///
    /// `skin` (m, ≥ 0): extra search distance; larger skins rebuild less often but list
    /// more pairs. `extra_range` (m, ≥ 0): how far beyond touching the contact law acts
    /// (the JKR separation distance `|δ_c|`; 0 for laws that act only in contact).
    pub fn new(skin: f64, extra_range: f64) -> Result<Self, NeighborError> {
        if !(skin.is_finite() && skin >= 0.0) {
            return Err(NeighborError::InvalidSkin { value: skin });
        }
        if !(extra_range.is_finite() && extra_range >= 0.0) {
            return Err(NeighborError::InvalidExtraRange { value: extra_range });
        }
        Ok(NeighborList {
            skin,
            extra_range,
            domain: None,
            grid_dims: [0; 3],
            cell_size: 0.0,
            wide: false,
            cutoff: 0.0,
            stale: true,
            rebuilds: 0,
            pairs: Vec::new(),
            history: Vec::new(),
            row_start: Vec::new(),
            ref_pos: Vec::new(),
            ids: Vec::new(),
            scratch: Scratch {
                stats: Vec::new(),
                cell_of: Vec::new(),
                cell_start: Vec::new(),
                sorted: Vec::new(),
                sorted_xr: Vec::new(),
                chunk_pairs: Vec::new(),
                old_pairs: Vec::new(),
                old_history: Vec::new(),
                carry: Vec::new(),
                id_table: Vec::new(),
                id_sorted: Vec::new(),
                rem_start: Vec::new(),
                rem: Vec::new(),
                cursor: Vec::new(),
            },
        })
    }

    /// The skin (m).
    #[inline]
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// The contact law's reach beyond touching (m).
    #[inline]
    pub fn extra_range(&self) -> f64 {
        self.extra_range
    }

    /// Largest pair search distance of the last build, `2 r_max + extra_range + skin` (m);
    /// 0 before the first build.
    #[inline]
    pub fn cutoff(&self) -> f64 {
        self.cutoff
    }

    /// Nominal cell edge length of the last build (m): ≥ [`cutoff`](Self::cutoff) for a
    /// narrow size distribution, ≥ `2 r_mean + extra_range + skin` for a wide one (see
    /// [`wide_distribution`](Self::wide_distribution)); larger when the grid was coarsened
    /// for a sparse scene. On periodic axes the cells are stretched to tile the period.
    #[inline]
    pub fn cell_size(&self) -> f64 {
        self.cell_size
    }

    /// True when the last build treated the radii as a wide distribution (largest radius
    /// above 1.5 × the mean): cells sized for the mean particle, each particle searching as many
    /// cells as its own diameter needs and listing only partners no larger than itself.
    /// False: cells sized for the largest particle, half stencil.
    #[inline]
    pub fn wide_distribution(&self) -> bool {
        self.wide
    }

    /// Number of cells per axis of the last build.
    #[inline]
    pub fn grid_dims(&self) -> [usize; 3] {
        self.grid_dims
    }

    /// How many times [`rebuild`](Self::rebuild) succeeded.
    #[inline]
    pub fn rebuild_count(&self) -> u64 {
        self.rebuilds
    }

    /// Number of particles of the last build.
    #[inline]
    pub fn num_particles(&self) -> usize {
        self.ref_pos.len()
    }

    /// Number of listed pairs.
    #[inline]
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// True when no pair is listed.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The listed pairs `[i, j]`, `i < j`, sorted by `(i, j)`.
    #[inline]
    pub fn pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// Per-pair contact history, aligned with [`pairs`](Self::pairs).
    #[inline]
    pub fn history(&self) -> &[H] {
        &self.history
    }

    /// Mutable per-pair contact history, aligned with [`pairs`](Self::pairs).
    #[inline]
    pub fn history_mut(&mut self) -> &mut [H] {
        &mut self.history
    }

    /// Pairs and mutable history together, for a kernel that reads one and updates the
    /// other (e.g. `par_iter().zip(par_iter_mut())`).
    #[inline]
    pub fn pairs_and_history_mut(&mut self) -> (&[[u32; 2]], &mut [H]) {
        (&self.pairs, &mut self.history)
    }

    /// Indices (into [`pairs`](Self::pairs)) of the pairs whose *first* particle is `i`:
    /// a contiguous range, since pairs are sorted by `(i, j)`.
    #[inline]
    pub fn pair_range(&self, i: usize) -> Range<usize> {
        self.row_start[i] as usize..self.row_start[i + 1] as usize
    }

    /// Drops the listed pairs for which `excluded(i, j)` is true, keeping the
    /// order, the rows and the history of the others (e.g. the member spheres
    /// of one rigid clump, which never touch each other). Call it after every
    /// [`rebuild`](Self::rebuild); a dropped pair has no history to lose
    /// (it is never evaluated). O(pairs), serial.
    pub fn exclude(&mut self, excluded: impl Fn(usize, usize) -> bool) {
        let mut kept = 0usize;
        let rows = self.row_start.len().saturating_sub(1);
        let mut start = 0usize;
        for i in 0..rows {
            let end = self.row_start[i + 1] as usize;
            self.row_start[i] = kept as u32;
            for k in start..end {
                let [a, b] = self.pairs[k];
                if !excluded(a as usize, b as usize) {
                    self.pairs[kept] = self.pairs[k];
                    self.history[kept] = self.history[k];
                    kept += 1;
                }
            }
            start = end;
        }
        if rows > 0 {
            self.row_start[rows] = kept as u32;
        }
        self.pairs.truncate(kept);
        self.history.truncate(kept);
    }

    /// CSR offsets of the rows: the pairs whose first particle is `i` are
    /// `pairs()[offsets[i]..offsets[i + 1]]` (len = particles + 1).
    #[inline]
    pub fn row_offsets(&self) -> &[u32] {
        &self.row_start
    }

    /// Marks the list out of date, so [`needs_rebuild`](Self::needs_rebuild) returns true
    /// (e.g. after the caller permuted its arrays or changed radii). History is kept.
    #[inline]
    pub fn invalidate(&mut self) {
        self.stale = true;
    }

    /// True when the list must be rebuilt before the next force evaluation: never built,
    /// invalidated, the particle count changed, or some particle moved more than
    /// `skin / 2` (minimum-image distance) since the last build.
    ///
    /// O(N), parallel for large N, allocation-free. Radii growing between builds is not
    /// detected: call [`invalidate`](Self::invalidate) then.
    pub fn needs_rebuild(&self, positions: &[Vec3]) -> bool {
        let Some(domain) = self.domain else {
            return true;
        };
        if self.is_stale(positions.len()) {
            return true;
        }
        let lim = self.rebuild_distance_sq();
        let moved = |a: &[Vec3], b: &[Vec3]| {
            a.iter().zip(b).any(|(p0, p)| {
                let d = if domain.any_periodic() {
                    domain.min_image(p - p0)
                } else {
                    p - p0
                };
                // A NaN position also asks for a rebuild (which then reports it).
                let d2 = d.norm_squared();
                d2 > lim || d2.is_nan()
            })
        };
        if positions.len() < 4 * CHUNK {
            moved(&self.ref_pos, positions)
        } else {
            self.ref_pos
                .par_chunks(4 * CHUNK)
                .zip(positions.par_chunks(4 * CHUNK))
                .any(|(a, b)| moved(a, b))
        }
    }

    /// True when the list must be rebuilt whatever the particles did: never built,
    /// invalidated, or built for a different number of particles than `n`. A caller
    /// that tracks displacements itself (e.g. fused into its drift loop) rebuilds when
    /// this is true or some particle moved farther than
    /// `√`[`rebuild_distance_sq`](Self::rebuild_distance_sq) (minimum image) from its
    /// [`reference_positions`](Self::reference_positions) entry — exactly the test of
    /// [`needs_rebuild`](Self::needs_rebuild).
    #[inline]
    pub fn is_stale(&self, n: usize) -> bool {
        self.domain.is_none() || self.stale || n != self.ref_pos.len()
    }

    /// `(skin / 2)²` (m²): a displacement whose square exceeds this since the last
    /// build (or is NaN) asks for a rebuild.
    #[inline]
    pub fn rebuild_distance_sq(&self) -> f64 {
        0.25 * self.skin * self.skin
    }

    /// The positions (m) of the last build, by particle index.
    #[inline]
    pub fn reference_positions(&self) -> &[Vec3] {
        &self.ref_pos
    }

    /// A permutation sorting particles by grid cell (ties by current index), using the
    /// grid a rebuild with these arguments would use.
    ///
    /// Cells are visited with the axis of fewest cells fastest and the axis of most
    /// cells slowest (ties: x before y before z; a flat bed runs z fastest). A
    /// particle's partners in the next cell along the slowest axis lie one slab
    /// (`n_fast × n_mid` cells) further on in memory, so this order keeps that distance
    /// — and with it the time between a pair's force being written and its second
    /// particle reading it — as short as a row-by-row order can. On the 50,000-particle
    /// benchmark bed (47 × 47 × 13 cells) it shortens the slab from 2,209 to 611 cells
    /// and runs 7–9 % faster than x fastest.
    ///
    /// `perm[new] = old`: apply it to every per-particle array with [`apply_permutation`],
    /// ids included, then call [`rebuild`](Self::rebuild) (mandatory). Deterministic.
    pub fn cell_order(
        &mut self,
        positions: &[Vec3],
        radii: &[f64],
        domain: &Domain,
    ) -> Result<Vec<u32>, NeighborError> {
        let (grid, _) = self.bin(positions, radii, domain)?;
        let s = &self.scratch;
        let mut axes = [0, 1, 2];
        axes.sort_by_key(|&a| grid.n[a]);
        let [fast, mid, slow] = axes;
        let mut order = Vec::with_capacity(positions.len());
        for k_slow in 0..grid.n[slow] {
            for k_mid in 0..grid.n[mid] {
                for k_fast in 0..grid.n[fast] {
                    let mut c = [0; 3];
                    (c[fast], c[mid], c[slow]) = (k_fast, k_mid, k_slow);
                    let cell = grid.linear(c);
                    let run = s.cell_start[cell] as usize..s.cell_start[cell + 1] as usize;
                    order.extend_from_slice(&s.sorted[run]);
                }
            }
        }
        Ok(order)
    }

    /// Validates input, checks the domain and bins particles into cells (fills
    /// `scratch.cell_of/cell_start/sorted/sorted_xr`). Returns the grid and cutoff.
    fn bin(
        &mut self,
        positions: &[Vec3],
        radii: &[f64],
        domain: &Domain,
    ) -> Result<(Grid, f64), NeighborError> {
        let n = positions.len();
        if radii.len() != n {
            return Err(NeighborError::LengthMismatch {
                field: "radii",
                expected: n,
                found: radii.len(),
            });
        }
        if n >= u32::MAX as usize {
            return Err(NeighborError::TooManyParticles { count: n });
        }
        // One fused pass: bounding box, largest radius, radius sum, and whether anything
        // is invalid. Fixed chunks, collected in order and reduced serially, so the result
        // (the radius sum included) does not depend on the thread count.
        positions
            .par_chunks(CHUNK)
            .zip(radii.par_chunks(CHUNK))
            .map(|(xs, rs)| {
                let mut st = ChunkStats::EMPTY;
                for (p, &r) in xs.iter().zip(rs) {
                    for a in 0..3 {
                        st.lo[a] = st.lo[a].min(p[a]);
                        st.hi[a] = st.hi[a].max(p[a]);
                    }
                    st.r_max = st.r_max.max(r);
                    st.r_sum += r;
                    st.bad |= !(r.is_finite() && r > 0.0)
                        | !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite());
                }
                st
            })
            .collect_into_vec(&mut self.scratch.stats);
        let mut st = ChunkStats::EMPTY;
        for c in &self.scratch.stats {
            for a in 0..3 {
                st.lo[a] = st.lo[a].min(c.lo[a]);
                st.hi[a] = st.hi[a].max(c.hi[a]);
            }
            st.r_max = st.r_max.max(c.r_max);
            st.r_sum += c.r_sum;
            st.bad |= c.bad;
        }
        let (bb_lo, bb_hi, r_max, bad) = (st.lo, st.hi, st.r_max, st.bad);
        if bad {
            if let Some(index) = radii.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
                return Err(NeighborError::InvalidRadius {
                    index,
                    value: radii[index],
                });
            }
            let index = positions
                .iter()
                .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
                .unwrap_or(0);
            return Err(NeighborError::NonFinitePosition { index });
        }
        let reach = self.extra_range + self.skin;
        let cutoff = 2.0 * r_max + reach;
        domain.check_cutoff(cutoff)?;
        // Wide size distribution: cells sized for the mean particle, larger particles
        // search more cells (see `search`). Narrow: cells sized for the largest.
        let r_mean = if n > 0 { st.r_sum / n as f64 } else { 0.0 };
        let wide = r_max > WIDE_RATIO * r_mean;
        let cell_cutoff = if wide { 2.0 * r_mean + reach } else { cutoff };
        let grid = Grid::new(domain, bb_lo, bb_hi, cell_cutoff, n, wide);
        let s = &mut self.scratch;

        s.cell_of.resize(n, 0);
        s.cell_of
            .par_chunks_mut(CHUNK)
            .zip(positions.par_chunks(CHUNK))
            .for_each(|(cs, xs)| {
                for (c, &p) in cs.iter_mut().zip(xs) {
                    *c = grid.linear(grid.coords(domain.wrap(p))) as u32;
                }
            });

        // Stable counting sort by cell.
        let nc = grid.n_cells();
        offsets_of(&mut s.cell_start, nc, s.cell_of.iter().map(|&c| c as usize));
        s.sorted.resize(n, 0);
        s.sorted_xr.resize(n, [0.0; 4]);
        // cell_start[c] doubles as the fill cursor of cell c ...
        for (i, &c) in s.cell_of.iter().enumerate() {
            let slot = s.cell_start[c as usize] as usize;
            s.cell_start[c as usize] += 1;
            s.sorted[slot] = i as u32;
            let p = positions[i];
            s.sorted_xr[slot] = [p.x, p.y, p.z, radii[i]];
        }
        // ... and ends as the end of cell c = start of cell c + 1: shift back.
        for c in (1..=nc).rev() {
            s.cell_start[c] = s.cell_start[c - 1];
        }
        s.cell_start[0] = 0;
        Ok((grid, cutoff))
    }

    /// Rebuilds the list for the current particles.
    ///
    /// `positions` (m), `radii` (m, > 0) and `ids` (the caller's stable, unique particle
    /// tags, used to carry contact history across rebuilds and permutations) are indexed
    /// by particle. Positions need not be wrapped into the periodic box.
    ///
    /// Errors (the list is then left unusable until a successful rebuild; the history of
    /// the last good build is kept): length mismatch, non-positive or non-finite radius,
    /// non-finite position, duplicate id, a periodic axis shorter than
    /// `2 (2 r_max + extra_range + skin)`, or index overflow.
    pub fn rebuild(
        &mut self,
        positions: &[Vec3],
        radii: &[f64],
        ids: &[u32],
        domain: &Domain,
    ) -> Result<(), NeighborError> {
        let n = positions.len();
        if ids.len() != n {
            return Err(NeighborError::LengthMismatch {
                field: "ids",
                expected: n,
                found: ids.len(),
            });
        }
        self.stale = true;
        let (grid, cutoff) = self.bin(positions, radii, domain)?;
        let identity = self.compute_carry(ids)?;
        self.search(&grid, domain, n)?;
        self.carry_history(identity);

        self.ref_pos.clear();
        self.ref_pos.extend_from_slice(positions);
        self.ids.clear();
        self.ids.extend_from_slice(ids);
        self.domain = Some(*domain);
        self.grid_dims = grid.n;
        self.cell_size = grid.width;
        self.wide = grid.wide;
        self.cutoff = cutoff;
        self.stale = false;
        self.rebuilds += 1;
        Ok(())
    }

    /// Cell-grid search: fills `pairs` and `row_start`; the previous pairs and history
    /// move to `scratch.old_*`.
    ///
    /// Works in slot space (particles in cell order). Narrow distribution: half stencil, a
    /// particle looks at later slots of its own cell and at the forward neighbour cells
    /// only, so each candidate pair is examined once, from contiguous memory. Wide: each
    /// particle scans the cells its own diameter needs and keeps partners no larger than
    /// itself (ties: later slots), so each pair is found once, by its larger particle.
    /// The pairs found are
    /// then put in `(i, j)` index order by a counting sort on `i` and a sort of each
    /// (short) row on `j`.
    fn search(&mut self, grid: &Grid, domain: &Domain, n: usize) -> Result<(), NeighborError> {
        let reach = self.extra_range + self.skin;
        let s = &mut self.scratch;
        let n_chunks = n.div_ceil(CHUNK);
        if s.chunk_pairs.len() < n_chunks {
            s.chunk_pairs.resize_with(n_chunks, Vec::new);
        }
        let (cell_start, sorted, sorted_xr) = (&s.cell_start, &s.sorted, &s.sorted_xr);
        let periodic = domain.any_periodic();
        let cs = |cell: usize| cell_start[cell] as usize;
        s.chunk_pairs[..n_chunks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(ci, out)| {
                out.clear();
                let s1 = ((ci + 1) * CHUNK).min(n);
                for slot in ci * CHUNK..s1 {
                    let i = sorted[slot];
                    let q = sorted_xr[slot];
                    let (xi, ri) = (Vec3::new(q[0], q[1], q[2]), q[3]);
                    // Same arithmetic as binning, so the same cell.
                    let c = grid.coords(domain.wrap(xi));
                    let row = |y: usize, z: usize| grid.n[0] * (y + grid.n[1] * z);
                    // Tests candidate slot t, records the pair if within range.
                    let check = |out: &mut Vec<[u32; 2]>, t: usize, q: [f64; 4]| {
                        let mut d = Vec3::new(q[0], q[1], q[2]) - xi;
                        if periodic {
                            d = domain.min_image(d);
                        }
                        let cut = ri + q[3] + reach;
                        if d.norm_squared() < cut * cut {
                            let j = sorted[t];
                            out.push(if i < j { [i, j] } else { [j, i] });
                        }
                    };
                    if grid.wide {
                        // Each pair is found once, by its larger particle (ties: the later
                        // slot is found from the earlier), whose stencil covers
                        // 2 r_i + reach >= r_i + r_j + reach.
                        let k = grid.reach_cells(2.0 * ri + reach);
                        let (xr, nxr) = grid.runs_k(0, c[0], k[0]);
                        let (yr, nyr) = grid.runs_k(1, c[1], k[1]);
                        let (zr, nzr) = grid.runs_k(2, c[2], k[2]);
                        for zrun in &zr[..nzr] {
                            for z in zrun[0]..=zrun[1] {
                                for yrun in &yr[..nyr] {
                                    for y in yrun[0]..=yrun[1] {
                                        let base = row(y, z);
                                        for xrun in &xr[..nxr] {
                                            let (a, b) =
                                                (cs(base + xrun[0]), cs(base + xrun[1] + 1));
                                            for (t, &q) in (a..b).zip(&sorted_xr[a..b]) {
                                                if q[3] < ri || (q[3] == ri && t > slot) {
                                                    check(out, t, q);
                                                }
                                            }
                                        }
                                    }
                                }
                            }
                        }
                        continue;
                    }
                    // Candidate slot ranges of the half stencil (at most 2 + 2 + 3 × 2).
                    let mut ranges = [(0usize, 0usize); 10];
                    let mut nr = 1;
                    // Own row: later slots of the own cell, then the forward x cell.
                    let own = row(c[1], c[2]);
                    ranges[0] = (slot + 1, cs(own + c[0] + 1));
                    match grid.forward(0, c[0]) {
                        Some(fx) if fx == c[0] + 1 => ranges[0].1 = cs(own + fx + 1),
                        Some(fx) => {
                            ranges[1] = (cs(own + fx), cs(own + fx + 1));
                            nr = 2;
                        }
                        None => {}
                    }
                    let (xr, nxr) = grid.runs(0, c[0]);
                    let mut add_row = |base: usize| {
                        for r in &xr[..nxr] {
                            ranges[nr] = (cs(base + r[0]), cs(base + r[1] + 1));
                            nr += 1;
                        }
                    };
                    // Forward y row (same z): all x neighbours.
                    if let Some(fy) = grid.forward(1, c[1]) {
                        add_row(row(fy, c[2]));
                    }
                    // Forward z layer: all y and x neighbours.
                    if let Some(fz) = grid.forward(2, c[2]) {
                        let (yr, nyr) = grid.runs(1, c[1]);
                        for r in &yr[..nyr] {
                            for y in r[0]..=r[1] {
                                add_row(row(y, fz));
                            }
                        }
                    }
                    for &(a, b) in &ranges[..nr] {
                        for (t, &q) in (a..b).zip(&sorted_xr[a..b]) {
                            check(out, t, q);
                        }
                    }
                }
            });
        // Row lengths, overflow check.
        let chunks = &s.chunk_pairs[..n_chunks];
        let total: usize = chunks.iter().map(Vec::len).sum();
        if total > u32::MAX as usize {
            return Err(NeighborError::TooManyPairs { count: total });
        }
        offsets_of(
            &mut self.row_start,
            n,
            chunks.iter().flatten().map(|p| p[0] as usize),
        );
        std::mem::swap(&mut self.pairs, &mut s.old_pairs);
        std::mem::swap(&mut self.history, &mut s.old_history);
        self.pairs.clear();
        // Counting sort by i (in chunk order), then sort each short row by j.
        self.pairs.resize(total, [0, 0]);
        s.cursor.clear();
        s.cursor.extend_from_slice(&self.row_start[..n]);
        for p in chunks.iter().flatten() {
            let c = &mut s.cursor[p[0] as usize];
            self.pairs[*c as usize] = *p;
            *c += 1;
        }
        // Rows are independent: sorting them in parallel cannot change the result.
        self.pairs
            .par_chunk_by_mut(|a, b| a[0] == b[0])
            .for_each(|row| row.sort_unstable_by_key(|p| p[1]));
        Ok(())
    }

    /// Maps old particle indices to new ones through the ids (`scratch.carry`). Returns
    /// true when the ids are unchanged (identity map, nothing stored).
    fn compute_carry(&mut self, ids: &[u32]) -> Result<bool, NeighborError> {
        if self.ids.as_slice() == ids && self.domain.is_some() {
            return Ok(true);
        }
        let n = ids.len();
        let s = &mut self.scratch;
        s.carry.clear();
        let max_id = ids.iter().copied().max().unwrap_or(0) as usize;
        if max_id <= 4 * n + 4096 {
            s.id_table.clear();
            s.id_table.resize(max_id + 1, u32::MAX);
            for (new, &id) in ids.iter().enumerate() {
                let e = &mut s.id_table[id as usize];
                if *e != u32::MAX {
                    return Err(NeighborError::DuplicateId { id });
                }
                *e = new as u32;
            }
            let table = &s.id_table;
            s.carry.extend(
                self.ids
                    .iter()
                    .map(|&id| table.get(id as usize).copied().unwrap_or(u32::MAX)),
            );
        } else {
            s.id_sorted.clear();
            s.id_sorted
                .extend(ids.iter().enumerate().map(|(k, &id)| (id, k as u32)));
            s.id_sorted.par_sort_unstable();
            if let Some(w) = s.id_sorted.windows(2).find(|w| w[0].0 == w[1].0) {
                return Err(NeighborError::DuplicateId { id: w[0].0 });
            }
            let sorted = &s.id_sorted;
            s.carry.extend(self.ids.iter().map(|&id| {
                sorted
                    .binary_search_by_key(&id, |e| e.0)
                    .map_or(u32::MAX, |k| sorted[k].1)
            }));
        }
        Ok(false)
    }

    /// Fills `history` for the new `pairs`: carried over from the previous build for
    /// pairs of the same two ids, `H::default()` otherwise.
    fn carry_history(&mut self, identity: bool) {
        let np = self.pairs.len();
        let s = &mut self.scratch;
        if std::mem::size_of::<H>() == 0 {
            // Nothing to carry: a Vec of a zero-sized type never allocates.
            self.history.clear();
            self.history.resize(np, H::default());
            return;
        }
        self.history.resize(np, H::default());
        if identity {
            let (old_pairs, old_hist) = (&s.old_pairs, &s.old_history);
            merge_history(
                &self.pairs,
                old_pairs.len(),
                |o| key(old_pairs[o]),
                |o| old_hist[o],
                &mut self.history,
            );
            return;
        }
        // Express the old pairs in new indices and sort them by (i, j): counting sort by
        // i, then sort each (short) row by j, rows in parallel.
        let n = self.row_start.len() - 1;
        let carry = &s.carry;
        let mapped = |p: &[u32; 2]| {
            let (a, b) = (carry[p[0] as usize], carry[p[1] as usize]);
            (a != u32::MAX && b != u32::MAX).then_some(if a < b { (a, b) } else { (b, a) })
        };
        offsets_of(
            &mut s.rem_start,
            n,
            s.old_pairs
                .iter()
                .filter_map(|p| Some(mapped(p)?.0 as usize)),
        );
        let m = s.rem_start[n] as usize;
        s.rem.clear();
        s.rem.resize(m, [0; 3]);
        for (k, p) in s.old_pairs.iter().enumerate() {
            if let Some((a, b)) = mapped(p) {
                let c = &mut s.rem_start[a as usize];
                s.rem[*c as usize] = [a, b, k as u32];
                *c += 1;
            }
        }
        s.rem
            .par_chunk_by_mut(|a, b| a[0] == b[0])
            .for_each(|row| row.sort_unstable_by_key(|e| e[1]));
        let (rem, old_hist) = (&s.rem, &s.old_history);
        merge_history(
            &self.pairs,
            rem.len(),
            |o| key([rem[o][0], rem[o][1]]),
            |o| old_hist[rem[o][2] as usize],
            &mut self.history,
        );
    }
}

#[inline]
fn key(p: [u32; 2]) -> u64 {
    (u64::from(p[0]) << 32) | u64::from(p[1])
}

/// Merge-join of two (i, j)-sorted pair lists: `out[k]` = history of the old pair equal
/// to `new[k]`, or default. The old list is given by its length, its keys
/// ([`key`] of each pair, increasing) and its histories. Parallel over fixed chunks; each
/// chunk finds its start in the old list by binary search, so the result does not depend
/// on the thread count.
fn merge_history<H, K, F>(new: &[[u32; 2]], old_len: usize, old_key: K, old_hist: F, out: &mut [H])
where
    H: Copy + Default + Send,
    K: Fn(usize) -> u64 + Sync,
    F: Fn(usize) -> H + Sync,
{
    out.par_chunks_mut(PAIR_CHUNK)
        .zip(new.par_chunks(PAIR_CHUNK))
        .for_each(|(out, new)| {
            // First old entry with key >= the chunk's first key.
            let first = key(new[0]);
            let (mut lo, mut hi) = (0, old_len);
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if old_key(mid) < first {
                    lo = mid + 1;
                } else {
                    hi = mid;
                }
            }
            let mut o = lo;
            for (h, &p) in out.iter_mut().zip(new) {
                let kp = key(p);
                while o < old_len && old_key(o) < kp {
                    o += 1;
                }
                *h = if o < old_len && old_key(o) == kp {
                    old_hist(o)
                } else {
                    H::default()
                };
            }
        });
}

/// Fills `offsets` with the CSR offsets of `keys` in `bins` bins (len =
/// bins + 1): `offsets[b]` is how many keys are below `b`, so bin `b`'s
/// entries go to `offsets[b]..offsets[b + 1]` of a counting sort.
pub(crate) fn offsets_of(
    offsets: &mut Vec<u32>,
    bins: usize,
    keys: impl IntoIterator<Item = usize>,
) {
    offsets.clear();
    offsets.resize(bins + 1, 0);
    for key in keys {
        offsets[key + 1] += 1;
    }
    for b in 0..bins {
        offsets[b + 1] += offsets[b];
    }
}

/// Re-orders `v` by `perm` (`perm[new] = old`, as from [`NeighborList::cell_order`]):
/// afterwards `v[new] == old_v[perm[new]]`. Allocates one new array; use
/// [`apply_permutation_into`] to reuse a buffer.
///
/// Panics if `perm` has a different length than `v` or an index out of range.
pub fn apply_permutation<T: Copy>(perm: &[u32], v: &mut Vec<T>) {
    let mut out = Vec::with_capacity(v.len());
    apply_permutation_into(perm, v, &mut out);
    *v = out;
}

/// Writes `src` re-ordered by `perm` into `dst` (cleared first, capacity reused):
/// `dst[new] = src[perm[new]]`.
///
/// Panics if `perm` has a different length than `src` or an index out of range.
pub fn apply_permutation_into<T: Copy>(perm: &[u32], src: &[T], dst: &mut Vec<T>) {
    assert_eq!(perm.len(), src.len(), "permutation length != array length");
    dst.clear();
    dst.extend(perm.iter().map(|&k| src[k as usize]));
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// SplitMix64: a tiny deterministic generator for test data.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        fn f(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.f()
        }
    }

    fn v(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x, y, z)
    }

    /// O(N²) reference with the documented criterion.
    fn brute(x: &[Vec3], r: &[f64], domain: &Domain, reach: f64) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                let d = domain.min_image(x[j] - x[i]);
                let cut = r[i] + r[j] + reach;
                if d.norm_squared() < cut * cut {
                    out.push([i as u32, j as u32]);
                }
            }
        }
        out
    }

    /// Random polydisperse particles (radius ratio 1:10) in `domain`, many of them at or
    /// just across the faces (also outside the box on periodic axes: not wrapped).
    fn random_particles(n: usize, seed: u64, domain: &Domain) -> (Vec<Vec3>, Vec<f64>) {
        random_particles_ratio(n, seed, domain, 10.0)
    }

    /// As [`random_particles`], radii log-uniform in `[0.5 / ratio, 0.5]`.
    fn random_particles_ratio(
        n: usize,
        seed: u64,
        domain: &Domain,
        ratio: f64,
    ) -> (Vec<Vec3>, Vec<f64>) {
        let mut rng = Rng(seed);
        let (lo, hi, len) = (domain.lo(), domain.hi(), domain.lengths());
        let mut x = Vec::with_capacity(n);
        let mut r = Vec::with_capacity(n);
        for k in 0..n {
            r.push(0.5 / ratio * ratio.powf(rng.f()));
            let mut p = v(
                rng.range(lo.x, hi.x),
                rng.range(lo.y, hi.y),
                rng.range(lo.z, hi.z),
            );
            match k % 5 {
                // Near a face (inside), on a random axis.
                0 | 1 => {
                    let a = (rng.next_u64() % 3) as usize;
                    let off = rng.range(0.0, 0.6);
                    p[a] = if rng.f() < 0.5 {
                        lo[a] + off
                    } else {
                        hi[a] - off
                    };
                }
                // Exactly on a face or slightly outside the box (unwrapped).
                2 => {
                    let a = (rng.next_u64() % 3) as usize;
                    p[a] = match rng.next_u64() % 4 {
                        0 => lo[a],
                        1 => hi[a],
                        2 => lo[a] - rng.range(0.0, 0.3),
                        _ => hi[a] + rng.range(0.0, 0.3),
                    };
                    if rng.f() < 0.2 {
                        // Several periods away.
                        p[a] += 3.0 * len[a];
                    }
                }
                _ => {}
            }
            x.push(p);
        }
        (x, r)
    }

    fn ids(n: usize) -> Vec<u32> {
        (0..n as u32).collect()
    }

    #[test]
    fn verlet_list_equals_brute_force() {
        let lo = v(-1.0, 0.0, 2.0);
        let cases: [(Vec3, [bool; 3]); 6] = [
            (v(9.0, 7.0, 10.0), [false; 3]),
            (v(9.0, 7.0, 10.0), [true; 3]),
            (v(9.0, 7.0, 10.0), [true, false, true]),
            (v(9.0, 7.0, 10.0), [false, true, false]),
            // Periodic axes with 2, 3 and 4 cells (cutoff 0.5 + 0.5 + 0.1 + 0.06 = 1.16).
            (v(2.4, 3.6, 4.7), [true, true, true]),
            // Exactly 2 × cutoff: a single cell on x and y.
            (
                v(2.32 * (1.0 + 5e-10), 2.32 * (1.0 + 5e-10), 3.0),
                [true, true, false],
            ),
        ];
        for (c, &(size, per)) in cases.iter().enumerate() {
            let domain = Domain::new(lo, lo + size, per).unwrap();
            for (seed, n, ratio) in [
                (1u64, 1500usize, 10.0),
                (2, 400, 10.0),
                (3, 2, 10.0),
                (4, 1500, 1.2),
                (5, 300, 1.0),
            ] {
                let (x, mut r) = random_particles_ratio(n, seed * 100 + c as u64, &domain, ratio);
                r[0] = 0.5;
                let mut nl = NeighborList::<u8>::new(0.1, 0.06).unwrap();
                nl.rebuild(&x, &r, &ids(n), &domain).unwrap();
                let want = brute(&x, &r, &domain, 0.16);
                assert_eq!(nl.pairs(), want.as_slice(), "case {c} seed {seed}");
                if n > 10 {
                    assert_eq!(nl.wide_distribution(), ratio > 2.0, "case {c} seed {seed}");
                }
                if c == 5 && ratio < 1.5 {
                    assert_eq!(nl.grid_dims()[..2], [1, 1]);
                }
                assert_eq!(nl.history().len(), want.len());
                for i in 0..n {
                    for k in nl.pair_range(i) {
                        assert_eq!(nl.pairs()[k][0] as usize, i);
                    }
                }
                if per.iter().any(|&p| p) && n > 100 {
                    // The test must exercise pairs across periodic faces.
                    let across = want
                        .iter()
                        .filter(|p| {
                            let d = x[p[1] as usize] - x[p[0] as usize];
                            (domain.min_image(d) - d).norm() > 1e-9
                        })
                        .count();
                    assert!(across > 0, "case {c}: no pair across a periodic face");
                }
            }
        }
    }

    /// A particle far from the others (non-periodic axes) makes the bounding box huge;
    /// the grid is coarsened to bound the cell count, and the list stays exact.
    #[test]
    fn sparse_scene_coarsens_grid_and_stays_exact() {
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(6.0, 6.0, 6.0), [true, false, false]).unwrap();
        let n = 600;
        let (mut x, r) = random_particles(n, 17, &domain);
        x[5] = v(3.0, 500.0, -900.0);
        let mut nl = NeighborList::<()>::new(0.1, 0.0).unwrap();
        nl.rebuild(&x, &r, &ids(n), &domain).unwrap();
        let cells: usize = nl.grid_dims().iter().product();
        assert!(cells <= 16 * n + 4096, "{:?}", nl.grid_dims());
        assert!(nl.cell_size() > nl.cutoff() * 1.4);
        assert_eq!(nl.pairs(), brute(&x, &r, &domain, 0.1).as_slice());
    }

    #[test]
    fn pairs_are_sorted_unique_and_ordered() {
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(8.0, 8.0, 8.0), [true; 3]).unwrap();
        let (x, r) = random_particles(3000, 7, &domain);
        let mut nl = NeighborList::<()>::new(0.2, 0.0).unwrap();
        nl.rebuild(&x, &r, &ids(3000), &domain).unwrap();
        assert!(nl.len() > 1000);
        assert!(nl.pairs().iter().all(|p| p[0] < p[1]));
        assert!(nl.pairs().windows(2).all(|w| key(w[0]) < key(w[1])));
    }

    #[test]
    fn empty_and_single_particle() {
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), [true; 3]).unwrap();
        let mut nl = NeighborList::<u32>::new(0.01, 0.0).unwrap();
        nl.rebuild(&[], &[], &[], &domain).unwrap();
        assert!(nl.is_empty() && nl.num_particles() == 0);
        assert!(!nl.needs_rebuild(&[]));
        nl.rebuild(&[v(0.5, 0.5, 0.5)], &[0.1], &[9], &domain)
            .unwrap();
        assert!(nl.is_empty());
        assert_eq!(nl.row_offsets(), &[0, 0]);
    }

    #[test]
    fn needs_rebuild_at_half_skin() {
        let skin = 0.2;
        let domain =
            Domain::new(v(0.0, 0.0, 0.0), v(10.0, 10.0, 10.0), [true, false, false]).unwrap();
        let x0 = vec![v(9.99, 5.0, 5.0), v(3.0, 3.0, 3.0), v(6.0, 6.0, 6.0)];
        let r = vec![1.0; 3];
        let mut nl = NeighborList::<()>::new(skin, 0.0).unwrap();
        assert!(nl.needs_rebuild(&x0), "never built");
        nl.rebuild(&x0, &r, &ids(3), &domain).unwrap();
        assert!(!nl.needs_rebuild(&x0));
        let dir = v(1.0, 2.0, -2.0) / 3.0;
        for (f, want) in [(1.0 - 1e-9, false), (1.0 + 1e-9, true)] {
            let mut x = x0.clone();
            x[1] += dir * (0.5 * skin * f);
            assert_eq!(nl.needs_rebuild(&x), want, "moved {f} x skin/2");
        }
        // Crossing the periodic face and wrapping is a small move (min-image aware).
        let mut x = x0.clone();
        x[0] = domain.wrap(x[0] + v(0.05, 0.0, 0.0));
        assert!(x[0].x < 1.0);
        assert!(!nl.needs_rebuild(&x));
        // Count changed.
        assert!(nl.needs_rebuild(&x0[..2]));
        // NaN asks for a rebuild (which then reports it).
        let mut x = x0.clone();
        x[2].z = f64::NAN;
        assert!(nl.needs_rebuild(&x));
        assert_eq!(
            nl.rebuild(&x, &r, &ids(3), &domain),
            Err(NeighborError::NonFinitePosition { index: 2 })
        );
        nl.rebuild(&x0, &r, &ids(3), &domain).unwrap();
        nl.invalidate();
        assert!(nl.needs_rebuild(&x0));
        // Large N takes the parallel path; same threshold.
        let n = 10_000;
        let xs: Vec<Vec3> = (0..n)
            .map(|k| {
                v(
                    (k % 20) as f64 * 0.45,
                    (k / 20 % 20) as f64 * 0.45,
                    (k / 400) as f64 * 0.39,
                )
            })
            .collect();
        let rs = vec![0.1; n];
        let big = Domain::new(v(0.0, 0.0, 0.0), v(9.0, 9.0, 10.0), [true, true, false]).unwrap();
        nl.rebuild(&xs, &rs, &ids(n), &big).unwrap();
        for (f, want) in [(1.0 - 1e-9, false), (1.0 + 1e-9, true)] {
            let mut x = xs.clone();
            x[n - 3] += dir * (0.5 * skin * f);
            assert_eq!(nl.needs_rebuild(&x), want);
        }
    }

    /// The JKR case: a contact stretched beyond touching but within cutoff + skin keeps
    /// its history across any number of rebuilds; once beyond, it is gone for good.
    #[test]
    fn history_survives_rebuilds_until_separation() {
        let (skin, extra) = (0.2, 0.1);
        let domain = Domain::new(v(-5.0, -5.0, -5.0), v(5.0, 5.0, 5.0), [true; 3]).unwrap();
        let r = vec![1.0, 1.0, 0.5];
        let ids = vec![70, 3, 12];
        let mut x = vec![v(0.0, 0.0, 0.0), v(1.95, 0.0, 0.0), v(-3.0, 3.0, 3.0)];
        let mut nl = NeighborList::<f64>::new(skin, extra).unwrap();
        nl.rebuild(&x, &r, &ids, &domain).unwrap();
        assert_eq!(nl.pairs(), &[[0, 1]]);
        nl.history_mut()[0] = 42.5;
        // Pull the pair apart to just inside 2 R + extra + skin = 2.3, rebuilding every time
        // (forced), with the third particle wandering around and across the box.
        for step in 0..200 {
            let s = 1.95 + (2.3 - 1e-6 - 1.95) * step as f64 / 199.0;
            x[1] = v(s, 0.0, 0.0);
            x[2] = domain.wrap(x[2] + v(0.037, -0.051, 0.029));
            nl.invalidate();
            nl.rebuild(&x, &r, &ids, &domain).unwrap();
            assert_eq!(nl.pairs(), &[[0, 1]], "step {step}");
            assert_eq!(nl.history(), &[42.5], "step {step}");
        }
        // Also across the periodic boundary: move the pair so it straddles the x face.
        x[0] = v(4.5, 0.0, 0.0);
        x[1] = domain.wrap(v(4.5 + 2.29, 0.0, 0.0));
        nl.rebuild(&x, &r, &ids, &domain).unwrap();
        assert_eq!(nl.history(), &[42.5]);
        // Separated beyond cutoff + skin: dropped ...
        x[1] = domain.wrap(v(4.5 + 2.31, 0.0, 0.0));
        nl.rebuild(&x, &r, &ids, &domain).unwrap();
        assert!(nl.is_empty());
        // ... and a new contact of the same two particles starts fresh.
        x[1] = domain.wrap(v(4.5 + 1.9, 0.0, 0.0));
        nl.rebuild(&x, &r, &ids, &domain).unwrap();
        assert_eq!(nl.history(), &[0.0]);
    }

    /// History tagged by the ids of each pair, checked after random motion, rebuilds and
    /// permutations (dense and sparse ids).
    #[test]
    fn history_carries_over_across_permutations() {
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(6.0, 6.0, 6.0), [true, true, false]).unwrap();
        for sparse in [false, true] {
            let n = 1200;
            let (mut x, mut r) = random_particles(n, 11 + sparse as u64, &domain);
            let mut id: Vec<u32> = if sparse {
                (0..n as u32)
                    .map(|k| k.wrapping_mul(2_654_435_761) | 1)
                    .collect()
            } else {
                (0..n as u32).rev().collect()
            };
            let tag = |a: u32, b: u32| u64::from(a.min(b)) << 32 | u64::from(a.max(b));
            let mut nl = NeighborList::<u64>::new(0.15, 0.05).unwrap();
            nl.rebuild(&x, &r, &id, &domain).unwrap();
            let mut rng = Rng(5);
            let mut carried_total = 0;
            for round in 0..12 {
                // Tag every listed pair, remember the listed id pairs.
                let (pairs, hist) = nl.pairs_and_history_mut();
                let mut before = BTreeSet::new();
                for (p, h) in pairs.iter().zip(hist.iter_mut()) {
                    let t = tag(id[p[0] as usize], id[p[1] as usize]);
                    *h = t;
                    before.insert(t);
                }
                for p in x.iter_mut() {
                    *p += v(
                        rng.range(-0.2, 0.2),
                        rng.range(-0.2, 0.2),
                        rng.range(-0.2, 0.2),
                    );
                }
                if round % 3 != 2 {
                    let perm = nl.cell_order(&x, &r, &domain).unwrap();
                    let mut seen = vec![false; n];
                    for &k in &perm {
                        assert!(!std::mem::replace(&mut seen[k as usize], true));
                    }
                    apply_permutation(&perm, &mut x);
                    apply_permutation(&perm, &mut r);
                    apply_permutation(&perm, &mut id);
                }
                nl.rebuild(&x, &r, &id, &domain).unwrap();
                assert_eq!(nl.pairs(), brute(&x, &r, &domain, 0.2).as_slice());
                for (p, &h) in nl.pairs().iter().zip(nl.history()) {
                    let t = tag(id[p[0] as usize], id[p[1] as usize]);
                    if before.contains(&t) {
                        assert_eq!(h, t, "round {round}: history lost or mixed up");
                        carried_total += 1;
                    } else {
                        assert_eq!(h, 0, "round {round}: new pair must start at default");
                    }
                }
            }
            assert!(carried_total > 1000, "{carried_total}");
        }
    }

    #[test]
    fn cell_order_sorts_by_cell_and_is_stable() {
        let domain =
            Domain::new(v(0.0, 0.0, 0.0), v(10.0, 10.0, 10.0), [true, false, true]).unwrap();
        let (mut x, mut r) = random_particles(2000, 3, &domain);
        let mut nl = NeighborList::<()>::new(0.1, 0.0).unwrap();
        nl.rebuild(&x, &r, &ids(2000), &domain).unwrap();
        let perm = nl.cell_order(&x, &r, &domain).unwrap();
        assert_cell_ordered(&nl, &perm);
        apply_permutation(&perm, &mut x);
        apply_permutation(&perm, &mut r);
        let again = nl.cell_order(&x, &r, &domain).unwrap();
        assert_eq!(again, ids(2000), "sorted input gives the identity");
        // apply_permutation semantics: v[new] = old_v[perm[new]].
        let mut a = vec![10, 11, 12, 13];
        apply_permutation(&[2, 0, 3, 1], &mut a);
        assert_eq!(a, vec![12, 10, 13, 11]);
        let mut dst = Vec::new();
        apply_permutation_into(&[1, 0], &[5.0, 6.0], &mut dst);
        assert_eq!(dst, vec![6.0, 5.0]);
    }

    #[test]
    fn cell_order_runs_the_axis_of_fewest_cells_fastest() {
        // A flat bed: fewest cells along z, then x, most along y.
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(8.0, 14.0, 1.2), [true, true, false]).unwrap();
        let (x, r) = random_particles_ratio(1500, 8, &domain, 1.2);
        let mut nl = NeighborList::<()>::new(0.1, 0.0).unwrap();
        nl.rebuild(&x, &r, &ids(1500), &domain).unwrap();
        let perm = nl.cell_order(&x, &r, &domain).unwrap();
        let [nx, ny, nz] = nl.grid_dims();
        assert!(nz < nx && nx < ny, "{nx} {ny} {nz}");
        assert_cell_ordered(&nl, &perm);
        let mut seen = perm.clone();
        seen.sort_unstable();
        assert_eq!(seen, ids(1500), "a permutation");
    }

    /// Asserts that `perm` visits cells with the axis of fewest cells fastest (ties:
    /// x, y, z), particles in a cell by index. Uses the grid of `nl`'s last build,
    /// which must match the one `cell_order` binned with.
    fn assert_cell_ordered(nl: &NeighborList<()>, perm: &[u32]) {
        let n = nl.grid_dims();
        let mut axes = [0, 1, 2];
        axes.sort_by_key(|&a| n[a]);
        let key = |k: u32| {
            let c = nl.scratch.cell_of[k as usize] as usize;
            let xyz = [c % n[0], c / n[0] % n[1], c / (n[0] * n[1])];
            xyz[axes[0]] + n[axes[0]] * (xyz[axes[1]] + n[axes[1]] * xyz[axes[2]])
        };
        for p in perm.windows(2) {
            let (a, b) = (key(p[0]), key(p[1]));
            assert!(a < b || (a == b && p[0] < p[1]), "{p:?}: {a} then {b}");
        }
    }

    #[test]
    fn zero_sized_history_stores_nothing() {
        #[derive(Clone, Copy, Default)]
        struct NoHistory;
        assert_eq!(std::mem::size_of::<NoHistory>(), 0);
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(5.0, 5.0, 5.0), [true; 3]).unwrap();
        let (x, r) = random_particles(800, 2, &domain);
        let mut nl = NeighborList::<NoHistory>::new(0.1, 0.0).unwrap();
        let mut id = ids(800);
        nl.rebuild(&x, &r, &id, &domain).unwrap();
        id.reverse();
        nl.rebuild(&x, &r, &id, &domain).unwrap();
        assert!(!nl.is_empty());
        assert_eq!(nl.history().len(), nl.len());
        assert_eq!(std::mem::size_of_val(nl.history()), 0);
        assert_eq!(std::mem::size_of_val(nl.scratch.old_history.as_slice()), 0);
    }

    #[test]
    fn parallel_build_is_bit_identical_to_serial() {
        let domain =
            Domain::new(v(0.0, 0.0, 0.0), v(14.0, 14.0, 14.0), [true, true, false]).unwrap();
        let n = 12_000;
        for ratio in [10.0, 1.2] {
            let (x, r) = random_particles_ratio(n, 99, &domain, ratio);
            let mut id: Vec<u32> = (0..n as u32).map(|k| k * 7 + 3).collect();
            id.reverse();
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| {
                    let mut nl = NeighborList::<[f64; 2]>::new(0.1, 0.02).unwrap();
                    nl.rebuild(&x, &r, &id, &domain).unwrap();
                    for (k, h) in nl.history_mut().iter_mut().enumerate() {
                        *h = [k as f64, -(k as f64)];
                    }
                    let perm = nl.cell_order(&x, &r, &domain).unwrap();
                    let (mut x2, mut r2, mut id2) = (x.clone(), r.clone(), id.clone());
                    apply_permutation(&perm, &mut x2);
                    apply_permutation(&perm, &mut r2);
                    apply_permutation(&perm, &mut id2);
                    nl.rebuild(&x2, &r2, &id2, &domain).unwrap();
                    let hist: Vec<[u64; 2]> = nl
                        .history()
                        .iter()
                        .map(|h| [h[0].to_bits(), h[1].to_bits()])
                        .collect();
                    (
                        perm,
                        nl.pairs().to_vec(),
                        hist,
                        nl.row_offsets().to_vec(),
                        nl.needs_rebuild(&x2),
                    )
                })
            };
            let one = run(1);
            let two = run(2);
            assert!(one.1.len() > 5_000, "{}", one.1.len());
            assert_eq!(one, two);
        }
    }

    #[test]
    fn errors() {
        assert_eq!(
            NeighborList::<()>::new(-0.1, 0.0).unwrap_err(),
            NeighborError::InvalidSkin { value: -0.1 }
        );
        assert!(matches!(
            NeighborList::<()>::new(0.1, f64::NAN),
            Err(NeighborError::InvalidExtraRange { .. })
        ));
        // Periodic box too small: cutoff = 2·0.5 + 0.05 + 0.1 = 1.15, needs 2.3.
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(3.0, 2.29, 1.0), [true, true, false]).unwrap();
        let mut nl = NeighborList::<u8>::new(0.1, 0.05).unwrap();
        let x = vec![v(0.5, 0.5, 0.5), v(1.5, 1.5, 0.5)];
        let e = nl.rebuild(&x, &[0.5, 0.2], &[0, 1], &domain).unwrap_err();
        match e {
            NeighborError::Domain(DomainError::PeriodicTooSmall {
                axis,
                length,
                required,
            }) => {
                assert_eq!((axis, length), (1, 2.29));
                assert!((required - 2.3).abs() < 1e-12);
            }
            e => panic!("{e:?}"),
        }
        assert!(e.to_string().contains("periodic y axis"));
        assert!(nl.needs_rebuild(&x));
        // Smaller particles fit.
        nl.rebuild(&x, &[0.4, 0.2], &[0, 1], &domain).unwrap();
        assert_eq!(
            nl.rebuild(&x, &[0.4, 0.0], &[0, 1], &domain),
            Err(NeighborError::InvalidRadius {
                index: 1,
                value: 0.0
            })
        );
        assert_eq!(
            nl.rebuild(&x, &[0.4], &[0, 1], &domain),
            Err(NeighborError::LengthMismatch {
                field: "radii",
                expected: 2,
                found: 1
            })
        );
        assert_eq!(
            nl.rebuild(&x, &[0.4, 0.2], &[0], &domain),
            Err(NeighborError::LengthMismatch {
                field: "ids",
                expected: 2,
                found: 1
            })
        );
        assert_eq!(
            nl.rebuild(&x, &[0.4, 0.2], &[4, 4], &domain),
            Err(NeighborError::DuplicateId { id: 4 })
        );
        assert_eq!(
            nl.rebuild(&x, &[0.4, 0.2], &[u32::MAX, u32::MAX], &domain),
            Err(NeighborError::DuplicateId { id: u32::MAX })
        );
    }

    /// Rebuild timings for a dense bed (jittered cubic lattice, spacing 2.4 mm, R = 1 mm,
    /// skin 0.2 mm, periodic in x and y). Run with
    /// `cargo test --release --lib neighbor::tests::timing -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn timing() {
        use std::time::Instant;
        #[derive(Clone, Copy, Default)]
        #[allow(dead_code)]
        struct Hist {
            spring: [f64; 3],
            touched: bool,
        }
        let (radius, skin) = (1e-3, 2e-4);
        // 2.4 mm: the brief's lattice (gaps 0.4 mm > skin: few pairs); 2.05 mm: about as
        // many pairs per particle as a settled bed.
        for (a, n) in [2.4e-3, 2.05e-3]
            .into_iter()
            .flat_map(|a| [5_000usize, 20_000, 50_000].map(|n| (a, n)))
        {
            let side = (n as f64).cbrt().ceil() as usize;
            let nz = n.div_ceil(side * side);
            let domain = Domain::new(
                v(0.0, 0.0, 0.0),
                v(side as f64 * a, side as f64 * a, nz as f64 * a + 0.01),
                [true, true, false],
            )
            .unwrap();
            let mut rng = Rng(n as u64);
            // Random order (as after insertion), so the first build is cache-unfriendly.
            let mut x: Vec<Vec3> = (0..n)
                .map(|k| {
                    let (i, j, l) = (k % side, k / side % side, k / (side * side));
                    v(
                        (i as f64 + 0.5) * a + rng.range(-0.15e-3, 0.15e-3),
                        (j as f64 + 0.5) * a + rng.range(-0.15e-3, 0.15e-3),
                        (l as f64 + 0.5) * a + rng.range(-0.15e-3, 0.15e-3),
                    )
                })
                .collect();
            for k in (1..n).rev() {
                x.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            let mut r = vec![radius; n];
            let mut id = ids(n);
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| {
                    let (mut x, mut r, mut id) = (x.clone(), r.clone(), id.clone());
                    let mut nl = NeighborList::<Hist>::new(skin, 0.0).unwrap();
                    let t = Instant::now();
                    nl.rebuild(&x, &r, &id, &domain).unwrap();
                    let first = t.elapsed();
                    let t = Instant::now();
                    let perm = nl.cell_order(&x, &r, &domain).unwrap();
                    apply_permutation(&perm, &mut x);
                    apply_permutation(&perm, &mut r);
                    apply_permutation(&perm, &mut id);
                    let sort = t.elapsed();
                    let t = Instant::now();
                    nl.rebuild(&x, &r, &id, &domain).unwrap();
                    let permuted = t.elapsed();
                    // Minimum over repeats: the machine is shared, means mostly measure
                    // the neighbours' load.
                    let min_of = |reps: usize, f: &mut dyn FnMut()| {
                        (0..reps)
                            .map(|_| {
                                let t = Instant::now();
                                f();
                                t.elapsed()
                            })
                            .min()
                            .unwrap()
                    };
                    let steady = min_of(20, &mut || {
                        nl.invalidate();
                        nl.rebuild(&x, &r, &id, &domain).unwrap();
                    });
                    let mut nz = NeighborList::<()>::new(skin, 0.0).unwrap();
                    nz.rebuild(&x, &r, &id, &domain).unwrap();
                    let steady_zst = min_of(20, &mut || {
                        nz.rebuild(&x, &r, &id, &domain).unwrap();
                    });
                    // Steady state of the id-remap path: every rebuild sees the particles
                    // in a new order (alternately reversed), so ids never match.
                    let rev: Vec<u32> = (0..n as u32).rev().collect();
                    let (mut xp, mut rp, mut idp) = (x.clone(), r.clone(), id.clone());
                    let remapped = min_of(10, &mut || {
                        apply_permutation(&rev, &mut xp);
                        apply_permutation(&rev, &mut rp);
                        apply_permutation(&rev, &mut idp);
                        nl.rebuild(&xp, &rp, &idp, &domain).unwrap();
                    });
                    let mut any = false;
                    let check = min_of(100, &mut || {
                        any |= nl.needs_rebuild(std::hint::black_box(&x));
                    });
                    assert!(!any);
                    println!(
                        "spacing={:.2}mm N={n:6} threads={threads}: pairs/particle={:.2} first(unsorted)={:7.2?} \
                         cell_order+permute(3 arrays)={:6.2?} first rebuild after permute={:6.2?} \
                         steady rebuild after permute (incl. permuting 3 arrays)={:6.2?} \
                         steady rebuild={:6.2?} ({:.0} ns/particle) steady rebuild ZST={:6.2?} \
                         needs_rebuild={:6.2?}",
                        a * 1e3,
                        nl.len() as f64 / n as f64,
                        first,
                        sort,
                        permuted,
                        remapped,
                        steady,
                        steady.as_nanos() as f64 / n as f64,
                        steady_zst,
                        check
                    );
                });
            }
            // Keep the originals alive for the next thread count.
            let _ = (&mut x, &mut r, &mut id);
        }
    }

    /// Rebuild time for a 1:10 bidisperse bed (1 mm spheres on a jittered 2.4 mm lattice,
    /// about 1 site in 300 holding a 10 mm sphere, small spheres inside a large one
    /// removed). Run like [`timing`].
    #[test]
    #[ignore]
    fn timing_bidisperse() {
        use std::time::Instant;
        let (a, skin, side) = (2.4e-3, 2e-4, 40usize);
        let mut rng = Rng(3);
        let lattice = |k: usize, rng: &mut Rng| {
            v(
                ((k % side) as f64 + 0.5) * a + rng.range(-1e-4, 1e-4),
                ((k / side % side) as f64 + 0.5) * a + rng.range(-1e-4, 1e-4),
                ((k / (side * side)) as f64 + 0.5) * a + rng.range(-1e-4, 1e-4),
            )
        };
        let mut big = Vec::new();
        for k in 0..side * side * side {
            let p = lattice(k, &mut rng);
            if rng.f() < 1.0 / 300.0 && big.iter().all(|q: &Vec3| (p - q).norm() > 0.02) {
                big.push(p);
            }
        }
        let (mut x, mut r) = (big.clone(), vec![1e-2; big.len()]);
        for k in 0..side * side * side {
            let p = lattice(k, &mut rng);
            if big.iter().all(|q| (p - q).norm() > 1.1e-2) {
                x.push(p);
                r.push(1e-3);
            }
        }
        let n = x.len();
        let l = side as f64 * a;
        let domain = Domain::new(v(0.0, 0.0, 0.0), v(l, l, l), [true, true, false]).unwrap();
        let mut nl = NeighborList::<[f64; 3]>::new(skin, 0.0).unwrap();
        let perm = nl.cell_order(&x, &r, &domain).unwrap();
        apply_permutation(&perm, &mut x);
        apply_permutation(&perm, &mut r);
        let id = ids(n);
        nl.rebuild(&x, &r, &id, &domain).unwrap();
        let best = (0..10)
            .map(|_| {
                let t = Instant::now();
                nl.invalidate();
                nl.rebuild(&x, &r, &id, &domain).unwrap();
                t.elapsed()
            })
            .min()
            .unwrap();
        println!(
            "bidisperse 1:10: N={n} ({} large) pairs/particle={:.2} wide={} cells={:?} \
             rebuild={best:.2?} ({:.0} ns/particle)",
            big.len(),
            nl.len() as f64 / n as f64,
            nl.wide_distribution(),
            nl.grid_dims(),
            best.as_nanos() as f64 / n as f64
        );
    }
}
