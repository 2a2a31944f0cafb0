//! The simulation: a [`World`] plus a kernel monomorphised for exactly the
//! effects the scene asked for.
//!
//! [`Simulation::new`] matches the effect choice once and builds a
//! `Stepper` generic over the normal model, the rolling model, the body
//! force and the boundary (2 × 3 × 2 × 2 kernels); nothing in the loops asks
//! which effects are on. A step runs named stages in order (rapier's
//! pipeline): kick and drift, neighbours, pair forces, gather (walls, body
//! force, kick), health. Within one `advance`, the gather also runs the next
//! step's kick and drift, saving a pass over the particles; the operations and
//! their order are unchanged. The pair stage adds each pair's forces straight
//! into per-particle sums: a particle's own sum for the pairs of its own
//! block of particles and a partial sum for each earlier block whose pairs
//! reach it (`tiles`), so no pair's forces are ever written to a buffer and
//! read back. How many blocks there are depends on the particle count alone,
//! where they start on the neighbour list, neither on the threads; on more
//! than one thread the sweep runs one tile (a run of whole blocks) per
//! thread. On more than one thread the stages run on a `team` of threads
//! that stays awake between them, instead of rayon's fork-join. Each stage is
//! cut into one job per member (a tile of the sweep, an equal share of the
//! particles in the per-particle passes); member `t` first runs its own and
//! then takes the job of a member that has not started yet.
//!
//! Determinism: each particle sums its pairs in the neighbour list's fixed
//! order, its own block's pairs in its own sum and each earlier block's in a
//! partial, and adds its partials in block order (see `tiles`); the blocks
//! never depend on the thread count, so there are no accumulation races and
//! no order that changes with the threads; reductions are either exact (max,
//! counts) or summed serially. The result is bit-identical on any number of
//! threads.
//!
//! Measurements, and what was tried and not kept, are in `docs/performance.md`.

use crate::dem::clump::bodies::{Bodies, ClumpInit};
use crate::dem::clump::template::ClumpShape;
use crate::dem::contact::normal_hertz::Hertz;
use crate::dem::contact::normal_jkr::Jkr;
use crate::dem::contact::rolling_cdt::ConstantDirectionalTorque;
use crate::dem::contact::rolling_epsd::ElasticPlasticSpring;
use crate::dem::contact::rolling_none::NoRolling;
use crate::dem::contact::{NormalModel, PairParameters, ParameterError, RollingModel};
use crate::dem::domain::Domain;
use crate::dem::effects::{BodyForce, Gravity, NoGravity, Open, Periodic};
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::material::ElasticMaterial;
use crate::dem::neighbor::NeighborError;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Motion as WallMotion, Wall, WallError};

mod pair_kernel;
mod particle_runs;
mod stepper;
mod team;
mod tiles;

use stepper::Stepper;
pub use tiles::blocks_for as sweep_blocks;

/// Everything the engine simulates: particles, walls, the domain and the clock.
#[derive(Clone, Debug)]
pub struct World {
    /// The spheres (in a world with clumps: the bodies' member spheres).
    pub particles: Particles,
    /// The rigid clumps, when the world has them ([`World::with_clumps`]):
    /// then every particle is a member of a body and moves with it.
    pub bodies: Option<Bodies>,
    /// Analytic walls.
    pub walls: Vec<Wall>,
    /// The simulation box (periodic axes, and where particles may go).
    pub domain: Domain,
    /// Simulated time, s.
    pub time_s: f64,
    /// Steps taken.
    pub step: u64,
}

impl World {
    /// A world at time 0, step 0.
    pub fn new(particles: Particles, walls: Vec<Wall>, domain: Domain) -> Self {
        Self {
            particles,
            walls,
            domain,
            bodies: None,
            time_s: 0.0,
            step: 0,
        }
    }

    /// Number of particles as a user counts them: bodies in a world of
    /// clumps, spheres otherwise.
    pub fn grains(&self) -> usize {
        self.bodies
            .as_ref()
            .map_or(self.particles.len(), Bodies::len)
    }

    /// Centres (m) and radii (m) of the grains, for counting where they
    /// are: the spheres, or in a world of clumps the bodies' centres of mass
    /// and bounding radii (so a body is counted once, where it is).
    pub fn grain_centres(&self) -> (Vec<Vec3>, Vec<f64>) {
        match &self.bodies {
            None => (
                self.particles.position.clone(),
                self.particles.radius.clone(),
            ),
            Some(b) => (
                b.position.clone(),
                b.shape
                    .iter()
                    .map(|&s| b.shapes[s as usize].bounding_radius_m)
                    .collect(),
            ),
        }
    }

    /// A world of rigid clumps of the given shapes (no particles yet: add
    /// them with [`push_clump`](Self::push_clump) or
    /// [`Simulation::insert_clumps`]). Its simulation moves bodies, not
    /// spheres (see [`crate::dem::clump`]).
    pub fn with_clumps(walls: Vec<Wall>, domain: Domain, shapes: Vec<ClumpShape>) -> Self {
        Self {
            bodies: Some(Bodies::new(shapes)),
            ..Self::new(Particles::default(), walls, domain)
        }
    }

    /// Adds a clump of density `density_kg_m3` before the simulation is
    /// built; returns its body id. Errors when the world has no clumps or
    /// the shape index is unknown.
    pub fn push_clump(&mut self, init: &ClumpInit, density_kg_m3: f64) -> Result<u32, SetupError> {
        let bodies = self.bodies.as_mut().ok_or(SetupError::NoClumps)?;
        if init.shape >= bodies.shapes.len() {
            return Err(SetupError::ClumpShape {
                shape: init.shape,
                count: bodies.shapes.len(),
            });
        }
        Ok(bodies.push(init, density_kg_m3, &mut self.particles))
    }
}

/// Normal-force slot choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalChoice {
    /// Hertz, no adhesion.
    Hertz,
    /// JKR adhesion (the cohesion effect).
    Jkr,
}

/// Rolling-resistance slot choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RollingChoice {
    /// No rolling resistance.
    None,
    /// Constant directional torque (type A).
    Cdt,
    /// Elastic–plastic spring (type C, yan2015 Eq. 8–10).
    Epsd,
}

/// Contact physics: law slots, materials and parameters.
#[derive(Clone, Debug)]
pub struct ContactSetup {
    /// Normal slot.
    pub normal: NormalChoice,
    /// Rolling slot.
    pub rolling: RollingChoice,
    /// Floor the damped normal force at the elastic force (see
    /// [`PairCoefficients::clip_tensile`](crate::dem::contact::PairCoefficients::clip_tensile)).
    pub clip_tensile: bool,
    /// The particles' material.
    pub particle_material: ElasticMaterial,
    /// Particle–particle parameters.
    pub particle_particle: PairParameters,
    /// Per wall material (indexed by [`Wall`]'s material index): its elastic
    /// properties and the particle–wall parameters.
    pub wall_materials: Vec<(ElasticMaterial, PairParameters)>,
}

/// Everything besides the world that a simulation needs.
#[derive(Clone, Debug)]
pub struct SimulationSetup {
    /// Contact physics.
    pub contact: ContactSetup,
    /// Particle density, kg/m³ (used for inserted particles).
    pub density_kg_m3: f64,
    /// Gravity, m/s²; `None` switches the effect off.
    pub gravity_m_s2: Option<Vec3>,
    /// Time step, s (see [`crate::dem::timestep`]).
    pub dt_s: f64,
    /// Verlet skin, m.
    pub skin_m: f64,
    /// Health thresholds.
    pub health: HealthLimits,
}

/// Why a simulation could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A contact parameter is invalid.
    #[error("{context}.{source}")]
    Parameter {
        /// Which pair type (`particle_particle`, `particle_wall[k]`).
        context: String,
        /// The parameter error.
        source: ParameterError,
    },
    /// A wall refers to a material index with no parameters.
    #[error(
        "wall {wall} uses material index {material}, but only {count} wall materials are defined"
    )]
    WallMaterial {
        /// Wall index.
        wall: usize,
        /// Its material index.
        material: usize,
        /// Number of defined wall materials.
        count: usize,
    },
    /// A scalar setting is invalid.
    #[error("{name} = {value}: {allowed}")]
    Setting {
        /// Setting name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// The neighbour search rejected the particles or the domain.
    #[error("neighbour search: {0}")]
    Neighbor(NeighborError),
    /// The initial state is already unhealthy (e.g. overlapping particles).
    #[error(transparent)]
    Health(HealthError),
    /// Clumps were inserted into a world built without them.
    #[error("this world has no clumps: build it with World::with_clumps to insert clumps")]
    NoClumps,
    /// Spheres were inserted into a world of clumps.
    #[error("this world moves clumps: insert clumps (a sphere is a one-member clump shape)")]
    SpheresInClumpWorld,
    /// A clump names a shape the world does not have.
    #[error("clump shape = {shape}: the world has {count} shapes (0..{count})")]
    ClumpShape {
        /// The shape index given.
        shape: usize,
        /// Number of shapes.
        count: usize,
    },
}

/// Statistics of the last force evaluation (and two running totals).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Particle–particle contacts carrying force.
    pub contacts: usize,
    /// Particle–wall contacts carrying force.
    pub wall_contacts: usize,
    /// Largest overlap / smaller radius over all contacts.
    pub max_overlap_ratio: f64,
    /// Neighbour-list rebuilds so far.
    pub rebuilds: u64,
    /// Largest relative normal approach speed of any force-carrying contact
    /// (particle pairs and walls) in every force evaluation so far, m/s; for
    /// an impact that is its speed at contact onset (the contact then slows
    /// the approach). What a run's time step must resolve: see
    /// [`crate::dem::timestep::TimeStepPlan::under_resolved`].
    pub max_approach_speed_m_s: f64,
}

/// The monomorphised kernel behind a [`Simulation`].
trait Kernel: Send {
    fn advance(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError>;
    fn name(&self) -> String;
    fn stats(&self) -> StepStats;
    /// Particles were added (appended) or removed (`kept` mask of the old indices).
    fn particles_changed(
        &mut self,
        world: &mut World,
        kept: Option<&[bool]>,
    ) -> Result<(), HealthError>;
    /// Exactly the particles with ids `ids` have prescribed kinematics.
    fn prescribe(&mut self, world: &World, ids: &[u32]);
}

/// A DEM simulation: the world and its kernel.
pub struct Simulation {
    world: World,
    kernel: Box<dyn Kernel>,
    density_kg_m3: f64,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("kernel", &self.kernel.name())
            .field("particles", &self.world.particles.len())
            .field("time_s", &self.world.time_s)
            .finish()
    }
}

impl Simulation {
    /// Builds the kernel for `setup`'s effects and evaluates the initial forces.
    pub fn new(mut world: World, setup: &SimulationSetup) -> Result<Self, SetupError> {
        for (name, value, ok) in [
            ("dt_s", setup.dt_s, setup.dt_s > 0.0),
            ("skin_m", setup.skin_m, setup.skin_m >= 0.0),
            (
                "density_kg_m3",
                setup.density_kg_m3,
                setup.density_kg_m3 > 0.0,
            ),
        ] {
            if !(ok && value.is_finite()) {
                return Err(SetupError::Setting {
                    name,
                    value,
                    allowed: "must be finite and positive",
                });
            }
        }
        // JKR with zero surface energy everywhere is exactly Hertz (see
        // normal_jkr's tests): absent cohesion runs the Hertz kernel and costs
        // nothing (the JKR kernel at Γ = 0 measured 45 % slower).
        let c = &setup.contact;
        let cohesive = c.particle_particle.surface_energy_j_m2 != 0.0
            || c.wall_materials
                .iter()
                .any(|(_, p)| p.surface_energy_j_m2 != 0.0);
        let kernel = match c.normal {
            NormalChoice::Jkr if cohesive => with_normal::<Jkr>(&mut world, setup)?,
            NormalChoice::Hertz | NormalChoice::Jkr => with_normal::<Hertz>(&mut world, setup)?,
        };
        Ok(Self {
            world,
            kernel,
            density_kg_m3: setup.density_kg_m3,
        })
    }

    /// Advances `steps` steps, stopping at the first health failure.
    pub fn advance(&mut self, steps: u64) -> Result<(), HealthError> {
        self.kernel.advance(&mut self.world, steps)
    }

    /// The current state.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Sets particle state between steps (e.g. the velocity of a particle
    /// made prescribed with [`prescribe`](Self::prescribe)). Do not add or remove particles here; use [`Simulation::insert`]
    /// and [`Simulation::retain`]. Radii and masses must not change here either:
    /// the kernel keeps factors derived from them (the half-kick factors and 1/r).
    pub fn particles_mut(&mut self) -> &mut Particles {
        &mut self.world.particles
    }

    /// Gives exactly the particles with ids `ids` prescribed kinematics
    /// (replacing any earlier set; `&[]` ends it): the engine never kicks
    /// them, so their velocity (m/s) and angular velocity (rad/s) stay what
    /// they are, or what the caller sets with
    /// [`particles_mut`](Self::particles_mut) (set them after this call: the
    /// force evaluation of [`new`](Self::new) and [`insert`](Self::insert)
    /// half-kicks the particles not yet prescribed), and the contact laws'
    /// damping sees exactly these velocities; they still drift
    /// (`x += v·dt` each step) and still receive contact forces, reported in
    /// [`Particles::force`] and [`Particles::torque`] after each `advance`.
    /// For driven particles (a particle pulled at a set speed, a held
    /// partner) whose contact force is measured at the prescribed position.
    /// Keyed by id: the set survives re-sorting, insertions and removals;
    /// ids not (or no longer) present are ignored. Prescribed particles do
    /// work, so the energy health check is skipped while any is prescribed.
    /// Costs nothing per step (their kick factors are zero); without
    /// prescribed particles a run is bit-identical to one that never called this.
    /// In a world of clumps the bodies move their members, not the kicks of
    /// the spheres: prescribing a member has no effect there.
    pub fn prescribe(&mut self, ids: &[u32]) {
        self.kernel.prescribe(&self.world, ids);
    }

    /// Changes wall `wall`'s motion between steps (e.g. start a drum once its
    /// bed has settled, with a rotation window from now on).
    pub fn set_wall_motion(&mut self, wall: usize, motion: WallMotion) -> Result<(), WallError> {
        let Some(slot) = self.world.walls.get_mut(wall) else {
            return Err(WallError::OutOfRange {
                field: "wall",
                value: wall as f64,
                allowed: "an index of World::walls",
            });
        };
        *slot = (*slot).with_motion(motion)?;
        Ok(())
    }

    /// The kernel's name, e.g. `hertz+mindlin+cdt+gravity+open`, for results.
    pub fn kernel_name(&self) -> String {
        self.kernel.name()
    }

    /// Statistics of the last force evaluation.
    pub fn stats(&self) -> StepStats {
        self.kernel.stats()
    }

    /// Adds particles (the caller guarantees they do not overlap); returns
    /// their ids. A world of clumps takes clumps only
    /// ([`insert_clumps`](Self::insert_clumps)).
    pub fn insert(&mut self, new: &[ParticleInit]) -> Result<Vec<u32>, SetupError> {
        if self.world.bodies.is_some() {
            return Err(SetupError::SpheresInClumpWorld);
        }
        let ids = new
            .iter()
            .map(|p| self.world.particles.push(p, self.density_kg_m3))
            .collect();
        self.kernel
            .particles_changed(&mut self.world, None)
            .map_err(SetupError::Health)?;
        Ok(ids)
    }

    /// The bodies of a world of clumps, to add shapes between steps
    /// (`None` for a world of spheres). Do not add or remove bodies here
    /// ([`insert_clumps`](Self::insert_clumps), [`retain`](Self::retain)).
    pub fn clump_bodies_mut(&mut self) -> Option<&mut Bodies> {
        self.world.bodies.as_mut()
    }

    /// Adds clumps to a world of clumps (the caller guarantees they do not
    /// overlap); returns their body ids.
    pub fn insert_clumps(&mut self, new: &[ClumpInit]) -> Result<Vec<u32>, SetupError> {
        let ids = new
            .iter()
            .map(|c| self.world.push_clump(c, self.density_kg_m3))
            .collect::<Result<Vec<_>, _>>()?;
        self.kernel
            .particles_changed(&mut self.world, None)
            .map_err(SetupError::Health)?;
        Ok(ids)
    }

    /// Removes the particles for which `keep` is false (e.g. discharged
    /// ones); returns how many grains went (particles, or in a world of
    /// clumps bodies: see [`World::grains`]). In a world of clumps a body
    /// goes with all its members as soon as `keep` is false for one of them
    /// (its first member through an outlet takes the body along, before
    /// another member could leave the domain).
    pub fn retain(
        &mut self,
        keep: impl Fn(&Particles, usize) -> bool,
    ) -> Result<usize, HealthError> {
        let grains = self.world.grains();
        let p = &self.world.particles;
        let mut mask: Vec<bool> = (0..p.len()).map(|i| keep(p, i)).collect();
        if let Some(bodies) = &mut self.world.bodies {
            mask = body_mask(bodies, p, &mask);
        }
        if mask.iter().any(|k| !k) {
            self.world.particles.retain_indices(&mask);
            self.kernel
                .particles_changed(&mut self.world, Some(&mask))?;
        }
        Ok(grains - self.world.grains())
    }
}

fn with_normal<N: NormalModel>(
    world: &mut World,
    setup: &SimulationSetup,
) -> Result<Box<dyn Kernel>, SetupError> {
    match setup.contact.rolling {
        RollingChoice::None => with_rolling::<N, NoRolling>(world, setup),
        RollingChoice::Cdt => with_rolling::<N, ConstantDirectionalTorque>(world, setup),
        RollingChoice::Epsd => with_rolling::<N, ElasticPlasticSpring>(world, setup),
    }
}

fn with_rolling<N: NormalModel, R: RollingModel>(
    world: &mut World,
    setup: &SimulationSetup,
) -> Result<Box<dyn Kernel>, SetupError> {
    match setup.gravity_m_s2 {
        Some(g) => with_body_force::<N, R, Gravity>(world, setup, Gravity(g)),
        None => with_body_force::<N, R, NoGravity>(world, setup, NoGravity),
    }
}

fn with_body_force<N: NormalModel, R: RollingModel, G: BodyForce>(
    world: &mut World,
    setup: &SimulationSetup,
    body: G,
) -> Result<Box<dyn Kernel>, SetupError> {
    if world.domain.any_periodic() {
        Ok(Box::new(Stepper::<N, R, G, Periodic>::new(
            world, setup, body,
        )?))
    } else {
        Ok(Box::new(Stepper::<N, R, G, Open>::new(world, setup, body)?))
    }
}

/// Removes from `bodies` every body one of whose members `mask` drops, and
/// returns the particle mask that drops all those bodies' members.
fn body_mask(bodies: &mut Bodies, p: &Particles, mask: &[bool]) -> Vec<bool> {
    let body_of = |i: usize| {
        bodies
            .body_of_member(p.id[i])
            .expect("every particle is a member")
    };
    let mut keep_body = vec![true; bodies.len()];
    for (i, &k) in mask.iter().enumerate() {
        if !k {
            keep_body[body_of(i)] = false;
        }
    }
    let particle_mask = (0..p.len()).map(|i| keep_body[body_of(i)]).collect();
    bodies.retain_indices(&keep_body);
    particle_mask
}

/// The larger ratio; on ties the lower index (so reductions are order-independent).
fn worse(a: (f64, usize), b: (f64, usize)) -> (f64, usize) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}

/// The lower of two optional indices.
fn min_option(a: Option<usize>, b: Option<usize>) -> Option<usize> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, None) => x,
        (None, y) => y,
    }
}
