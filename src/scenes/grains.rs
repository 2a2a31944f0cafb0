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
//! insertions), whose members overlap no member already placed and no wall
//! and stay inside the domain. A clump reaches beyond its equivalent sphere
//! (paired spheres of aspect 1.3: 15 % of R at each end), so in a dense
//! layout the first draw may poke into a neighbour; the trials turn it into
//! the gaps. When no trial fits, the one whose deepest overlap is smallest
//! is used and counted, and the run's warnings say how many and how deep;
//! the engine's overlap bound still guards the run.
//!
//! Why not pack the clumps' bounding spheres instead: they hold only 66 %
//! of the solid of the same layout (paired spheres of aspect 1.3), so a
//! funnel charged to the same fill took 214 clumps against 333 spheres and
//! the clump piles were smaller than the sphere piles they were compared
//! with.

use crate::dem::clump::bodies::{Bodies, ClumpInit};
use crate::dem::clump::template::ClumpShape;
use crate::dem::domain::Domain;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::simulation::{SetupError, Simulation, World};
use crate::dem::vec3::Vec3;
use crate::dem::walls::Wall;
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
    /// Clumps placed with overlapping members (no trial fitted), so far.
    misfits: Cell<u64>,
    /// The deepest of their overlaps, relative to the member's radius.
    deepest: Cell<f64>,
}

impl Grains {
    /// Spheres (`clump` `None`) or clumps of the unit shape `clump`, of
    /// density `density_kg_m3`, oriented from `packing_seed`.
    pub fn new(clump: Option<ClumpShape>, density_kg_m3: f64, packing_seed: u64) -> Self {
        Self {
            clump,
            density_kg_m3,
            packing_seed,
            misfits: Cell::new(0),
            deepest: Cell::new(0.0),
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
        let misfits = self.misfits.get();
        (misfits > 0)
            .then(|| {
                format!(
                    "particle shape: {misfits} clumps found no orientation free of overlaps \
                     in {ORIENTATION_TRIALS} tries and started overlapping a neighbour or wall \
                     by up to {:.3} of a member radius (a layout too dense for the shape)",
                    self.deepest.get()
                )
            })
            .into_iter()
            .collect()
    }

    /// A clump for each of the spheres `placed`, among the member spheres
    /// `existing` (centres, m, and radii, m) and `walls` at time `t_s` inside
    /// `domain`; shapes of new sizes are added to `bodies`.
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
        let mut grid = Grid::new(2.0 * largest.max(f64::MIN_POSITIVE));
        for (x, &r) in existing.0.iter().zip(existing.1) {
            grid.insert(*x, r);
        }
        let placed_walls: Vec<_> = walls.iter().map(|w| w.placed_at(t_s)).collect();
        let mut inits = Vec::with_capacity(placed.len());
        for (body, p) in (bodies.next_id()..).zip(placed) {
            let shape = shape_index(bodies, unit, p.radius_m);
            let members = &bodies.shapes[shape].members;
            let mut rng = ChaCha8Rng::seed_from_u64(self.packing_seed);
            rng.set_stream(ORIENTATION_STREAM);
            rng.set_word_pos(u128::from(body) * WORDS_PER_BODY);
            // The trial whose deepest overlap, relative to the member's
            // radius, is smallest; the first free of overlaps ends the search.
            let mut best: Option<(f64, UnitQuaternion<f64>)> = None;
            for _ in 0..ORIENTATION_TRIALS {
                let q = uniform_rotation(&mut rng);
                let depth = members
                    .iter()
                    .map(|m| {
                        let x = p.position + q.transform_vector(&m.offset);
                        if !domain.contains(x) {
                            return f64::INFINITY;
                        }
                        let walls = placed_walls
                            .iter()
                            .filter_map(|w| w.contact(x, m.radius_m, 0.0))
                            .map(|c| c.overlap_m)
                            .fold(0.0, f64::max);
                        grid.deepest_overlap(&x, m.radius_m).max(walls) / m.radius_m
                    })
                    .fold(0.0, f64::max);
                if best.is_none_or(|(least, _)| depth < least) {
                    best = Some((depth, q));
                }
                if depth <= 0.0 {
                    break;
                }
            }
            let (depth, q) = best.expect("at least one trial");
            if depth > 0.0 {
                self.misfits.set(self.misfits.get() + 1);
                self.deepest.set(self.deepest.get().max(depth));
            }
            for m in members {
                grid.insert(p.position + q.transform_vector(&m.offset), m.radius_m);
            }
            inits.push(ClumpInit {
                shape,
                position: p.position,
                orientation: q,
                velocity: p.velocity,
                angular_velocity: p.angular_velocity,
            });
        }
        inits
    }
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
