//! What a lab scene's particles are — spheres, or rigid clumps of one shape
//! (`material.particle.shape`) — and how the spheres a scene places become
//! them.
//!
//! Scenes place spheres of the size distribution with their own packing
//! (lattices, random placement, rate factories), which keeps them apart and
//! off the walls. With a clump shape the radii are volume-equivalent, and
//! each placed sphere becomes a clump of the same volume (and mass) centred
//! there, at a random orientation: the first of up to
//! [`ORIENTATION_TRIALS`] orientations, drawn uniformly over all rotations
//! from the packing seed's own orientation stream at the place of the body
//! id (so a body's draws do not depend on how the scene batches its
//! insertions), whose members overlap no member already placed (nor its
//! periodic image across a periodic face of the domain) and no wall, and
//! stay inside the domain.
//!
//! A clump reaches beyond its equivalent sphere of radius R, while the
//! layouts keep neighbouring centres as little as about 2.1 R apart (the
//! drum's lattice: 1.05 diameters). Paired spheres of aspect ratio a are two
//! spheres of radius s·R whose union reaches a·s·R from its centre along its
//! axis: 1.15 R at a = 1.3 (s = 0.886), 1.59 R as a approaches 2 (s =
//! 2^(−1/3) = 0.794, two spheres touching). The trials turn a clump into the
//! gaps between its neighbours; in a dense layout some find none, the more
//! the longer the clump (the drum's smoke layout,
//! experiments/drum/smoke-clumps.json: 12 of 182 at a = 1.3, 72 at a =
//! 1.999999, whose least deep orientations overlap a neighbour by up to 0.51
//! of a member radius).
//!
//! A misfit's least deep orientation is kept when it overlaps by at most
//! the engine's overlap bound ([`HealthLimits::max_overlap_ratio`], 0.3 of
//! the smaller radius; the drum's smoke layout at a = 1.3: 0.082 at most),
//! and the run's warnings say how many and how deep: such a layout starts
//! and the contacts push the clumps apart in the first steps. When one
//! misfit of a batch would overlap by more — a layout that could not start —
//! the batch is oriented again, this time against the periodic images of
//! the members too, and all its misfits are moved once every other clump is
//! in place, in order: each to the first of up to [`RELOCATION_TRIALS`]
//! random places free of overlaps, centres uniform in a ball about its
//! sphere's centre whose radius grows from 0 to [`RELOCATION_REACH`] R (near
//! places first), each at a random orientation, drawn from the packing
//! seed's relocation stream at the place of the body id. A place counts only
//! with its centre inside the domain's box and reached from the sphere's
//! centre by a straight move that crosses no wall, so a clump stays on the
//! side of every wall its sphere was placed on. The clumps that fitted at
//! their spheres keep their places and orientations. A misfit that finds no
//! free place takes the least deep of all the places and orientations it
//! tried; the run's warnings say how many clumps were moved, how far, and
//! how many found no free place. The engine's overlap bound still guards the
//! run: an overlap beyond it in the initial layout stops the run at step 0
//! with an error that names the placement, not the time step
//! ([`crate::dem::health`]).
//!
//! Why only layouts that could not start are moved: moving every misfit
//! changes the packing, and so the results, of layouts that run today under
//! the same physics version (measured: docs/performance.md,
//! src/scenes/grains.rs); results keyed by a manifest's id must not change
//! under it. Moving every misfit belongs with the next physics version bump.
//!
//! Why not pack the clumps' bounding spheres instead: they hold only 66 %
//! of the solid of the same layout (paired spheres of aspect 1.3), so a
//! funnel charged to the same fill took 214 clumps against 333 spheres and
//! the clump piles were smaller than the sphere piles they were compared
//! with.

use crate::dem::clump::bodies::{Bodies, ClumpInit};
use crate::dem::clump::template::{ClumpShape, Member};
use crate::dem::domain::Domain;
use crate::dem::health::HealthLimits;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::simulation::{SetupError, Simulation, World};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{PlacedWall, Wall};
use crate::packing::grid::Grid;
use nalgebra::{Quaternion, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cell::Cell;

/// Orientations tried per clump before the least-overlapping one is taken.
pub const ORIENTATION_TRIALS: u32 = 400;

/// The ChaCha8 stream of the packing seed that orients clumps (the packing
/// itself draws from stream 0).
const ORIENTATION_STREAM: u64 = 0x0063_6c75_6d70;

/// Words of the stream reserved per body: 3 uniforms (2 words each) per trial.
const WORDS_PER_BODY: u128 = 8 * ORIENTATION_TRIALS as u128;

/// Places tried for a clump that found no free orientation at its sphere's
/// centre (in a batch that must be moved, see the module docs), each at a random orientation, before the least-overlapping one
/// is taken.
pub const RELOCATION_TRIALS: u32 = 20_000;

/// Farthest a clump is moved from the centre of the sphere it replaces, in
/// that sphere's (volume-equivalent) radii: gaps for clumps near aspect 2
/// lie a few neighbours away in the dense layouts (how far, per layout:
/// docs/performance.md, src/scenes/grains.rs).
pub const RELOCATION_REACH: f64 = 10.0;

/// The ChaCha8 stream of the packing seed that moves misfits.
const RELOCATION_STREAM: u64 = 0x6d6f_7665;

/// Words of the relocation stream reserved per body: 6 uniforms (2 words
/// each) per trial.
const WORDS_PER_RELOCATION: u128 = 12 * RELOCATION_TRIALS as u128;

/// The lab's particles: spheres, or clumps of one shape (see the module docs).
#[derive(Clone, Debug)]
pub struct Grains {
    /// The clump shape at unit volume-equivalent radius, when the particles
    /// are clumps; `None` for spheres.
    pub clump: Option<ClumpShape>,
    /// Particle density, kg/m³.
    density_kg_m3: f64,
    /// The packing seed (orientations come from their own stream of it).
    packing_seed: u64,
    /// What the placement did so far, for the run's warnings.
    tally: Cell<Tally>,
}

/// Counts of clumps that did not fit where their spheres were placed.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    /// Misfits left where their spheres were (overlapping within the bound).
    kept: u64,
    /// The deepest overlap of those, relative to the member's radius.
    kept_deepest: f64,
    /// Misfits moved (their batch held one beyond the bound).
    moved: u64,
    /// The farthest move, in radii of the sphere replaced.
    farthest: f64,
    /// Moved misfits that found no free place.
    stuck: u64,
    /// The deepest overlap of those, relative to the member's radius.
    stuck_deepest: f64,
}

impl Grains {
    /// Spheres (`clump` `None`) or clumps of the unit shape `clump`, of
    /// density `density_kg_m3`, oriented from `packing_seed`.
    pub fn new(clump: Option<ClumpShape>, density_kg_m3: f64, packing_seed: u64) -> Self {
        Self {
            clump,
            density_kg_m3,
            packing_seed,
            tally: Cell::new(Tally::default()),
        }
    }

    /// The world of the scene's `walls` and `domain` holding the spheres
    /// `placed` by the scene, or a clump in each (see the module docs).
    pub fn world(
        &self,
        placed: &[ParticleInit],
        walls: Vec<Wall>,
        domain: Domain,
    ) -> Result<World, SetupError> {
        if self.clump.is_none() {
            let mut particles = Particles::default();
            for p in placed {
                particles.push(p, self.density_kg_m3);
            }
            return Ok(World::new(particles, walls, domain));
        }
        let mut world = World::with_clumps(walls, domain, Vec::new());
        let inits = {
            let (walls, domain) = (world.walls.clone(), world.domain);
            let bodies = world.bodies.as_mut().expect("a world of clumps");
            self.clumps_in(placed, (&[], &[]), &walls, &domain, 0.0, bodies)
        };
        for init in &inits {
            world.push_clump(init, self.density_kg_m3)?;
        }
        Ok(world)
    }

    /// Inserts the spheres `placed` into `sim` as [`world`](Self::world)
    /// would hold them; returns their ids (particle ids of spheres, body
    /// ids of clumps).
    pub fn insert(
        &self,
        sim: &mut Simulation,
        placed: &[ParticleInit],
    ) -> Result<Vec<u32>, SetupError> {
        if self.clump.is_none() {
            return sim.insert(placed);
        }
        let w = sim.world();
        // Only the members' centres and radii are needed (copied: `sim` is
        // borrowed mutably next).
        let existing = (w.particles.position.clone(), w.particles.radius.clone());
        let (walls, domain, t) = (w.walls.clone(), w.domain, w.time_s);
        let bodies = sim.clump_bodies_mut().ok_or(SetupError::NoClumps)?;
        let inits = self.clumps_in(
            placed,
            (&existing.0, &existing.1),
            &walls,
            &domain,
            t,
            bodies,
        );
        sim.insert_clumps(&inits)
    }

    /// The run's warnings about the placement (none when every clump fitted).
    pub fn warnings(&self) -> Vec<String> {
        let t = self.tally.get();
        let mut out = Vec::new();
        if t.kept > 0 {
            out.push(format!(
                "particle shape: {} clumps found no orientation free of overlaps \
                 in {ORIENTATION_TRIALS} tries and started overlapping a neighbour or wall \
                 by up to {:.3} of a member radius (a layout too dense for the shape)",
                t.kept, t.kept_deepest
            ));
        }
        if t.moved > 0 {
            let stuck = if t.stuck > 0 {
                format!(
                    "; {} found no free place in {RELOCATION_TRIALS} tries within \
                     {RELOCATION_REACH} radii and started overlapping a neighbour or wall by \
                     up to {:.3} of a member radius",
                    t.stuck, t.stuck_deepest
                )
            } else {
                String::new()
            };
            out.push(format!(
                "particle shape: {} clumps found no orientation free of overlaps in \
                 {ORIENTATION_TRIALS} tries, some none within the overlap bound, and were \
                 moved up to {:.1} radii from the spheres they replace (a layout too dense for \
                 the shape){stuck}",
                t.moved, t.farthest
            ));
        }
        out
    }

    /// A clump for each of the spheres `placed`, among the member spheres
    /// `existing` (centres, m, and radii, m) and `walls` at time `t_s` inside
    /// `domain`; shapes of new sizes are added to `bodies`. Each clump is
    /// oriented at its sphere's centre, in order; when a misfit overlaps
    /// beyond the engine's bound, the batch is oriented again against
    /// periodic images too and its misfits are moved (see the module docs).
    fn clumps_in(
        &self,
        placed: &[ParticleInit],
        existing: (&[Vec3], &[f64]),
        walls: &[Wall],
        domain: &Domain,
        t_s: f64,
        bodies: &mut Bodies,
    ) -> Vec<ClumpInit> {
        let unit = self.clump.as_ref().expect("called with a clump shape");
        let reach = unit.members.iter().map(|m| m.radius_m).fold(0.0, f64::max);
        let largest = placed
            .iter()
            .map(|p| p.radius_m * reach)
            .chain(existing.1.iter().copied())
            .fold(0.0, f64::max);
        let cell_m = 2.0 * largest.max(f64::MIN_POSITIVE);
        let mut space = Space {
            cell_m,
            grid: Grid::new(cell_m),
            walls: walls.iter().map(|w| w.placed_at(t_s)).collect(),
            domain,
            images: vec![Vec3::zeros()],
        };
        space.reset(existing);
        let (inits, misfits) = self.orient(placed, &mut space, bodies);
        let deepest = misfits.iter().map(|&(_, d)| d).fold(0.0, f64::max);
        let mut t = self.tally.get();
        if deepest <= HealthLimits::default().max_overlap_ratio {
            t.kept += misfits.len() as u64;
            t.kept_deepest = t.kept_deepest.max(deepest);
            self.tally.set(t);
            return inits;
        }
        space.images = periodic_images(domain);
        space.reset(existing);
        let (mut inits, misfits) = self.orient(placed, &mut space, bodies);
        // Every clump but the misfits, then each misfit moved in turn.
        space.reset(existing);
        for (k, init) in inits.iter().enumerate() {
            if misfits.binary_search_by_key(&k, |&(m, _)| m).is_err() {
                space.insert(
                    &bodies.shapes[init.shape].members,
                    init.position,
                    &init.orientation,
                );
            }
        }
        // The relocation stream's key: next_id − batch + k, in wrapping u32
        // arithmetic (the first batch wraps below zero). It is distinct per
        // misfit of a batch and fixed by the packing seed; keying it by the
        // body id `orient` uses (next_id + k) would move every relocated
        // clump of the committed runs, so it is kept as it is.
        let first = bodies.next_id().wrapping_sub(inits.len() as u32);
        for &(k, _) in &misfits {
            let init = &mut inits[k];
            let members = &bodies.shapes[init.shape].members;
            let key = first.wrapping_add(k as u32);
            let mut rng = self.stream(RELOCATION_STREAM, key, WORDS_PER_RELOCATION);
            let radius_m = placed[k].radius_m;
            let (depth, position, orientation) = space.relocate(members, init, radius_m, &mut rng);
            t.moved += 1;
            t.farthest = t.farthest.max((position - init.position).norm() / radius_m);
            if depth > 0.0 {
                t.stuck += 1;
                t.stuck_deepest = t.stuck_deepest.max(depth);
            }
            space.insert(members, position, &orientation);
            init.position = position;
            init.orientation = orientation;
        }
        self.tally.set(t);
        inits
    }

    /// Each of the spheres `placed` as a clump at its centre, at the first
    /// of [`ORIENTATION_TRIALS`] orientations free of overlaps in `space`
    /// or else the least deep, in order, each added to `space`; with the
    /// misfits' indices into `placed` and their depths (relative to the
    /// member's radius), in order.
    fn orient(
        &self,
        placed: &[ParticleInit],
        space: &mut Space,
        bodies: &mut Bodies,
    ) -> (Vec<ClumpInit>, Vec<(usize, f64)>) {
        let unit = self.clump.as_ref().expect("called with a clump shape");
        let mut inits = Vec::with_capacity(placed.len());
        let mut misfits = Vec::new();
        for (k, (body, p)) in (bodies.next_id()..).zip(placed).enumerate() {
            let shape = shape_index(bodies, unit, p.radius_m);
            let members = &bodies.shapes[shape].members;
            let mut rng = self.stream(ORIENTATION_STREAM, body, WORDS_PER_BODY);
            // The trial whose deepest overlap, relative to the member's
            // radius, is smallest; the first free of overlaps ends the search.
            let mut best: Option<(f64, UnitQuaternion<f64>)> = None;
            for _ in 0..ORIENTATION_TRIALS {
                let q = uniform_rotation(&mut rng);
                let depth = space.depth(members, p.position, &q);
                if best.is_none_or(|(least, _)| depth < least) {
                    best = Some((depth, q));
                }
                if depth <= 0.0 {
                    break;
                }
            }
            let (depth, q) = best.expect("at least one trial");
            if depth > 0.0 {
                misfits.push((k, depth));
            }
            // A misfit stays here (until it is moved), so the clumps after
            // it are placed around it.
            space.insert(members, p.position, &q);
            inits.push(ClumpInit {
                shape,
                position: p.position,
                orientation: q,
                velocity: p.velocity,
                angular_velocity: p.angular_velocity,
            });
        }
        (inits, misfits)
    }

    /// The packing seed's ChaCha8 stream `stream` at the words reserved for
    /// body `body` (`words` per body), so a body's draws do not depend on
    /// how the scene batches its insertions.
    fn stream(&self, stream: u64, body: u32, words: u128) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::seed_from_u64(self.packing_seed);
        rng.set_stream(stream);
        rng.set_word_pos(u128::from(body) * words);
        rng
    }
}

/// Where clumps are being placed: the member spheres placed so far (and the
/// world's own), the walls and the domain.
struct Space<'a> {
    /// The grid's cell edge, m (twice the largest member radius).
    cell_m: f64,
    /// Member spheres placed so far, and the world's own particles.
    grid: Grid,
    /// The walls at the time of placement.
    walls: Vec<PlacedWall>,
    /// The simulation box.
    domain: &'a Domain,
    /// Shifts to the periodic images of a point (the zero shift first).
    images: Vec<Vec3>,
}

impl Space<'_> {
    /// The deepest overlap of the clump of `members` at `centre` (m) turned
    /// by `q` with a placed sphere (or its periodic image) or a wall,
    /// relative to the member's radius; 0 when it touches nothing, infinite
    /// when a member's centre lies outside the domain.
    fn depth(&self, members: &[Member], centre: Vec3, q: &UnitQuaternion<f64>) -> f64 {
        members
            .iter()
            .map(|m| {
                let x = centre + q.transform_vector(&m.offset);
                if !self.domain.contains(x) {
                    return f64::INFINITY;
                }
                let walls = self
                    .walls
                    .iter()
                    .filter_map(|w| w.contact(x, m.radius_m, 0.0))
                    .map(|c| c.overlap_m)
                    .fold(0.0, f64::max);
                let spheres = self
                    .images
                    .iter()
                    .map(|s| self.grid.deepest_overlap(&(x + s), m.radius_m))
                    .fold(0.0, f64::max);
                spheres.max(walls) / m.radius_m
            })
            .fold(0.0, f64::max)
    }

    /// Where the clump of `members` placed as `init` (a misfit) goes: its
    /// place if nothing overlaps it any more, else the first of
    /// [`RELOCATION_TRIALS`] random places (centres uniform in a ball about
    /// its sphere's centre whose radius grows from 0 to [`RELOCATION_REACH`]
    /// × `radius_m`, the sphere's radius in m, random orientations) free of
    /// overlaps, else the least deep of them all. A place counts only with
    /// its centre inside the domain's box and reached from the sphere's
    /// centre without crossing a wall. Returns the deepest overlap relative
    /// to the member's radius (0 when free), the centre (m) and orientation.
    fn relocate(
        &self,
        members: &[Member],
        init: &ClumpInit,
        radius_m: f64,
        rng: &mut ChaCha8Rng,
    ) -> (f64, Vec3, UnitQuaternion<f64>) {
        let from = init.position;
        let mut best = (
            self.depth(members, from, &init.orientation),
            from,
            init.orientation,
        );
        let (lo, hi) = (self.domain.lo(), self.domain.hi());
        for trial in 1..=RELOCATION_TRIALS {
            if best.0 <= 0.0 {
                break;
            }
            let reach_m =
                RELOCATION_REACH * radius_m * f64::from(trial) / f64::from(RELOCATION_TRIALS);
            let shift = uniform_in_ball(rng, reach_m);
            let q = uniform_rotation(rng);
            let x = from + shift;
            if !(0..3).all(|a| x[a] >= lo[a] && x[a] <= hi[a]) {
                continue;
            }
            let depth = self.depth(members, x, &q);
            if depth < best.0 && !self.crosses_wall(from, shift, radius_m) {
                best = (depth, x, q);
            }
        }
        best
    }

    /// Whether the straight move by `shift` (m) from `from` (m) may cross a
    /// wall: balls of radius at most `step_m` / 2 (m) strung along it, which
    /// cover it, touch one.
    fn crosses_wall(&self, from: Vec3, shift: Vec3, step_m: f64) -> bool {
        let length = shift.norm();
        let n = (length / step_m).ceil().max(1.0);
        let r = 0.5 * length / n;
        (0..n as u32).any(|i| {
            let x = from + shift * ((f64::from(i) + 0.5) / n);
            self.walls.iter().any(|w| w.contact(x, r, 0.0).is_some())
        })
    }

    /// Empties the grid of placed spheres but the world's own `existing`
    /// (centres, m, and radii, m).
    fn reset(&mut self, existing: (&[Vec3], &[f64])) {
        self.grid = Grid::new(self.cell_m);
        for (x, &r) in existing.0.iter().zip(existing.1) {
            self.grid.insert(*x, r);
        }
    }

    /// Adds the members of the clump at `centre` (m) turned by `q`.
    fn insert(&mut self, members: &[Member], centre: Vec3, q: &UnitQuaternion<f64>) {
        for m in members {
            self.grid
                .insert(centre + q.transform_vector(&m.offset), m.radius_m);
        }
    }
}

/// Shifts (m) from a point to its periodic images across each periodic
/// face of `domain` and their combinations, the zero shift first (just it
/// when nothing is periodic).
fn periodic_images(domain: &Domain) -> Vec<Vec3> {
    let (periodic, lengths) = (domain.periodic(), domain.lengths());
    let mut shifts = vec![Vec3::zeros()];
    for axis in (0..3).filter(|&a| periodic[a]) {
        let mut period = Vec3::zeros();
        period[axis] = lengths[axis];
        shifts = shifts
            .iter()
            .flat_map(|&s| [s, s + period, s - period])
            .collect();
    }
    shifts
}

/// The index in `bodies` of `unit` scaled to volume-equivalent radius
/// `radius_m`, added when this size is new (a size distribution makes one
/// shape per size).
fn shape_index(bodies: &mut Bodies, unit: &ClumpShape, radius_m: f64) -> usize {
    let volume = unit.volume_m3 * radius_m.powi(3);
    match bodies.shapes.iter().position(|s| s.volume_m3 == volume) {
        Some(k) => k,
        None => {
            bodies.shapes.push(unit.scaled(radius_m));
            bodies.shapes.len() - 1
        }
    }
}

/// A point uniform in the ball of radius `radius_m` (m) about the origin,
/// from three uniforms (direction uniform on the sphere, radius ∝ u^(1/3)).
fn uniform_in_ball(rng: &mut ChaCha8Rng, radius_m: f64) -> Vec3 {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let z = 2.0 * u1 - 1.0;
    let phi = 2.0 * std::f64::consts::PI * u2;
    let rho = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(rho * phi.cos(), rho * phi.sin(), z) * (radius_m * u3.cbrt())
}

/// A rotation uniform over all rotations (Shoemake's construction from
/// three uniforms).
fn uniform_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = 2.0 * std::f64::consts::PI;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    UnitQuaternion::from_quaternion(Quaternion::new(
        b * (tau * u3).cos(),
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
    ))
}
