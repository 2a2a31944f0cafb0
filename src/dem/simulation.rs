//! The simulation: a [`World`] plus a kernel monomorphised for exactly the
//! effects the scene asked for.
//!
//! [`Simulation::new`] matches the effect choice once and builds a
//! [`Stepper`] generic over the normal model, the rolling model, the body
//! force and the boundary (2 × 3 × 2 × 2 kernels); nothing in the loops asks
//! which effects are on. A step runs named stages in order (rapier's
//! pipeline): kick and drift, neighbours, pair forces, gather (walls, body
//! force, kick), health.
//!
//! Determinism: pair forces go to a per-pair buffer (no accumulation races),
//! and each particle sums its pairs in the neighbour list's fixed order;
//! reductions are either exact (max, counts) or summed serially. The result is
//! bit-identical on any number of threads.

use crate::dem::contact::normal_hertz::Hertz;
use crate::dem::contact::normal_jkr::Jkr;
use crate::dem::contact::rolling_cdt::ConstantDirectionalTorque;
use crate::dem::contact::rolling_epsd::ElasticPlasticSpring;
use crate::dem::contact::rolling_none::NoRolling;
use crate::dem::contact::{
    evaluate, evaluate_lanes, ContactGeometry, ContactHistory, GeometryLanes, MotionLanes,
    NormalModel, PairCoefficients, PairParameters, ParameterError, RelativeMotion, RollingModel,
};
use crate::dem::domain::Domain;
use crate::dem::effects::{BodyForce, Boundary, Gravity, NoGravity, Open, Periodic};
use crate::dem::health::{HealthCause, HealthError, HealthLimits, ENERGY_CHECK_INTERVAL};
use crate::dem::lanes::{F64x4, Real, Vec3L, MAX_LANES};
use crate::dem::material::{harmonic, ElasticMaterial};
use crate::dem::neighbor::{apply_permutation, NeighborError, NeighborList, PairRef};
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{Motion as WallMotion, PlacedWall, Wall, WallError};
use rayon::prelude::*;

/// Everything the engine simulates: particles, walls, the domain and the clock.
#[derive(Clone, Debug)]
pub struct World {
    /// The spheres.
    pub particles: Particles,
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
            time_s: 0.0,
            step: 0,
        }
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
    /// [`PairCoefficients::clip_tensile`]).
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
}

/// Per-step statistics of the last force evaluation.
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
}

/// What the pair kernel reads first of a particle, packed in one 32-byte
/// record: centre (m) and radius (m). Enough to reject a listed pair that does
/// not touch.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Sphere {
    x: Vec3,
    r: f64,
}

/// What the contact laws read of a touching particle, packed in one 64-byte
/// record: the full-step velocity estimates v½ + ½dt·F/m (m/s) and
/// ω½ + ½dt·T/I (rad/s) (see [`Stepper::kick_and_drift`]), the mass (kg) and
/// the inverse radius (1/m, for overlap ratios).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Motion {
    v: Vec3,
    w: Vec3,
    m: f64,
    inv_r: f64,
}

/// Per-particle factors that depend only on mass and radius, computed when
/// particles are added or removed instead of every step (each is the same
/// expression the kick would evaluate, so results do not change): the
/// half-kick factors ½dt/m (s/kg) and ½dt/I (s/(kg·m²), I = 0.4 m r²) and the
/// inverse radius 1/r (1/m).
#[derive(Clone, Copy, Debug, Default)]
struct Kick {
    v: f64,
    w: f64,
    inv_r: f64,
}

impl Kick {
    fn new(dt: f64, m: f64, r: f64) -> Self {
        Self {
            v: 0.5 * dt / m,
            w: 0.5 * dt / (0.4 * m * r * r),
            inv_r: 1.0 / r,
        }
    }
}

/// The force a pair exerts, stored per pair and gathered per particle.
#[derive(Clone, Copy, Debug, Default)]
struct PairForce {
    force_on_first: Vec3,
    /// Torque on the first and on the second particle, N·m.
    torque: [Vec3; 2],
}

/// Contacts evaluated side by side in the pair kernel (one AVX2 register of
/// f64, two SSE2 registers).
const PAIR_LANES: usize = 4;

/// What the pair kernel reads, borrowed for one force evaluation.
struct PairKernel<'a, B: Boundary> {
    spheres: &'a [Sphere],
    motion: &'a [Motion],
    domain: Domain,
    coef: PairCoefficients,
    /// Extra contact range, m (JKR only).
    reach: f64,
    dt: f64,
    _boundary: std::marker::PhantomData<B>,
}

impl<B: Boundary> PairKernel<'_, B> {
    /// Evaluates a run of listed pairs whose first pair has index `first`,
    /// writing each pair's forces to `out`, four at a time and a short tail one
    /// at a time; returns the force-carrying contacts and the worst (overlap
    /// ratio, pair index).
    fn run<N: NormalModel, R: RollingModel>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        out: &mut [PairForce],
    ) -> (usize, (f64, usize)) {
        let whole = pairs.len() / PAIR_LANES * PAIR_LANES;
        let (history, history_tail) = history.split_at_mut(whole);
        let (out, out_tail) = out.split_at_mut(whole);
        let a = self.run_lanes::<N, R, F64x4>(first, &pairs[..whole], history, out);
        let b = self.run_lanes::<N, R, f64>(first + whole, &pairs[whole..], history_tail, out_tail);
        (a.0 + b.0, worse(a.1, b.1))
    }

    /// [`run`](Self::run) for a number of pairs that `T::LANES` divides.
    fn run_lanes<N: NormalModel, R: RollingModel, T: Real>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        out: &mut [PairForce],
    ) -> (usize, (f64, usize)) {
        let mut acc = (0, (0.0, usize::MAX));
        for (k, ((p, h), o)) in pairs
            .chunks_exact(T::LANES)
            .zip(history.chunks_exact_mut(T::LANES))
            .zip(out.chunks_exact_mut(T::LANES))
            .enumerate()
        {
            let found = self.lanes::<N, R, T>(first + k * T::LANES, p, h, o);
            acc = (acc.0 + found.0, worse(acc.1, found.1));
        }
        acc
    }

    /// `T::LANES` listed pairs with indices `first..` at once (each slice
    /// holds one entry per lane).
    #[inline(always)]
    fn lanes<N: NormalModel, R: RollingModel, T: Real>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        out: &mut [PairForce],
    ) -> (usize, (f64, usize)) {
        let at = |l: usize| pairs[l.min(T::LANES - 1)].map(|k| k as usize);
        let si: [&Sphere; MAX_LANES] = std::array::from_fn(|l| &self.spheres[at(l)[0]]);
        let sj: [&Sphere; MAX_LANES] = std::array::from_fn(|l| &self.spheres[at(l)[1]]);
        let mi: [&Motion; MAX_LANES] = std::array::from_fn(|l| &self.motion[at(l)[0]]);
        let mj: [&Motion; MAX_LANES] = std::array::from_fn(|l| &self.motion[at(l)[1]]);
        let d = B::separation_lanes(
            &self.domain,
            Vec3L::<T>::from_fn(|l| si[l].x) - Vec3L::from_fn(|l| sj[l].x),
        );
        let dist_sq = d.norm_squared();
        let (ri, rj) = (T::from_fn(|l| si[l].r), T::from_fn(|l| sj[l].r));
        let touch = ri + rj;
        let limit = touch + T::splat(self.reach);
        let in_range = T::not(dist_sq.ge(limit * limit));
        let dist = dist_sq.sqrt();
        let n = d.scale(T::splat(1.0) / dist);
        let overlap = touch - dist;
        let half = T::splat(0.5);
        let arm_i = ri - half * overlap;
        let arm_j = rj - half * overlap;
        let (wi, wj) = (
            Vec3L::<T>::from_fn(|l| mi[l].w),
            Vec3L::<T>::from_fn(|l| mj[l].w),
        );
        let motion = MotionLanes {
            velocity: Vec3L::from_fn(|l| mi[l].v)
                - Vec3L::from_fn(|l| mj[l].v)
                - (wi.scale(arm_i) + wj.scale(arm_j)).cross(&n),
            angular_velocity: wi - wj,
        };
        // `harmonic` of two finite values, lane-wise: particles are never rigid.
        let (m_i, m_j) = (T::from_fn(|l| mi[l].m), T::from_fn(|l| mj[l].m));
        let geometry = GeometryLanes {
            normal: n,
            overlap_m: overlap,
            r_star_m: ri * rj / (ri + rj),
            m_star_kg: m_i * m_j / (m_i + m_j),
        };
        let c =
            evaluate_lanes::<N, R, T>(&self.coef, &geometry, &motion, in_range, self.dt, history);
        let lever = n.cross(&c.tangential_force);
        let torque_i = c.rolling_torque - lever.scale(arm_i);
        let torque_j = -c.rolling_torque - lever.scale(arm_j);
        let mut found = (0, (0.0, usize::MAX));
        for (l, o) in out.iter_mut().enumerate() {
            *o = if T::flag(c.active, l) {
                let ratio = overlap.lane(l).max(0.0) * mi[l].inv_r.max(mj[l].inv_r);
                found = (found.0 + 1, worse(found.1, (ratio, first + l)));
                PairForce {
                    force_on_first: c.force.lane(l),
                    torque: [torque_i.lane(l), torque_j.lane(l)],
                }
            } else {
                PairForce::default()
            };
        }
        found
    }
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

    /// Prescribes particle kinematics between steps (e.g. a held or pulled
    /// particle). Do not add or remove particles here; use [`Simulation::insert`]
    /// and [`Simulation::retain`]. Radii and masses must not change here either:
    /// the kernel keeps factors derived from them (the half-kick factors and 1/r).
    pub fn particles_mut(&mut self) -> &mut Particles {
        &mut self.world.particles
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

    /// Adds particles (the caller guarantees they do not overlap); returns their ids.
    pub fn insert(&mut self, new: &[ParticleInit]) -> Result<Vec<u32>, HealthError> {
        let ids = new
            .iter()
            .map(|p| self.world.particles.push(p, self.density_kg_m3))
            .collect();
        self.kernel.particles_changed(&mut self.world, None)?;
        Ok(ids)
    }

    /// Removes the particles for which `keep` is false (e.g. discharged ones).
    pub fn retain(
        &mut self,
        keep: impl Fn(&Particles, usize) -> bool,
    ) -> Result<usize, HealthError> {
        let p = &self.world.particles;
        let mask: Vec<bool> = (0..p.len()).map(|i| keep(p, i)).collect();
        let removed = mask.iter().filter(|k| !**k).count();
        if removed > 0 {
            self.world.particles.retain_indices(&mask);
            self.kernel
                .particles_changed(&mut self.world, Some(&mask))?;
        }
        Ok(removed)
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

/// One kernel: state and scratch of a simulation with fixed effects.
struct Stepper<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> {
    particle_particle: PairCoefficients,
    /// Coefficients per wall (not per wall material: looked up once here).
    wall_coefficients: Vec<PairCoefficients>,
    /// Extra contact range of particle pairs, m (non-zero only for JKR).
    pair_reach: f64,
    /// Extra contact range per wall, m (non-zero only for JKR).
    wall_reach: Vec<f64>,
    dt: f64,
    body: G,
    neighbors: NeighborList<ContactHistory<N, R>>,
    pair_forces: Vec<PairForce>,
    /// Contact history per (particle, wall): index `p * wall_slots + w`.
    wall_history: Vec<ContactHistory<N, R>>,
    /// `max(walls, 1)`, so per-particle chunks are never empty.
    wall_slots: usize,
    placed: Vec<PlacedWall>,
    /// Per particle (same index order as the world's particles): packed
    /// copies of what the force stages read, refreshed by every drift.
    spheres: Vec<Sphere>,
    motion: Vec<Motion>,
    /// Per particle, same index order: see [`Kick`].
    kick: Vec<Kick>,
    stats: StepStats,
    limits: HealthLimits,
    /// Energy check enabled (non-adhesive kernel — the JKR kernel runs only
    /// with non-zero surface energy; skipped while any wall moves) and its
    /// reference, J.
    energy_reference: Option<f64>,
    energy_check: bool,
    rebuilds_since_sort: u32,
    _boundary: std::marker::PhantomData<B>,
}

/// Re-sort particles by cell every this many neighbour rebuilds.
const SORT_EVERY_REBUILDS: u32 = 8;
/// Pairs or particles per parallel task (fixed, so work splitting never
/// depends on the thread count).
const PAR_MIN_LEN: usize = 256;

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Stepper<N, R, G, B> {
    fn new(world: &mut World, setup: &SimulationSetup, body: G) -> Result<Self, SetupError> {
        let c = &setup.contact;
        let particle_particle = PairCoefficients::new(
            &c.particle_material,
            &c.particle_material,
            &c.particle_particle,
            c.clip_tensile,
        )
        .map_err(|source| SetupError::Parameter {
            context: "particle_particle".into(),
            source,
        })?;
        let by_material = c
            .wall_materials
            .iter()
            .enumerate()
            .map(|(k, (m, p))| {
                PairCoefficients::new(&c.particle_material, m, p, c.clip_tensile).map_err(
                    |source| SetupError::Parameter {
                        context: format!("particle_wall[{k}]"),
                        source,
                    },
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut wall_coefficients = Vec::with_capacity(world.walls.len());
        for (w, wall) in world.walls.iter().enumerate() {
            let coef = by_material
                .get(wall.material)
                .ok_or(SetupError::WallMaterial {
                    wall: w,
                    material: wall.material,
                    count: by_material.len(),
                })?;
            wall_coefficients.push(*coef);
        }
        let r_max = world.particles.radius.iter().cloned().fold(0.0, f64::max);
        // JKR reach grows with R*; use a generous radius bound so particles
        // inserted later (up to twice the current largest) stay covered.
        let r_bound = if r_max > 0.0 { 2.0 * r_max } else { 1.0 };
        let pair_reach = N::reach_m(&particle_particle, 0.5 * r_bound);
        let wall_reach: Vec<f64> = wall_coefficients
            .iter()
            .map(|w| N::reach_m(w, r_bound))
            .collect();
        let neighbors =
            NeighborList::new(setup.skin_m, pair_reach).map_err(SetupError::Neighbor)?;
        let wall_slots = world.walls.len().max(1);
        let mut stepper = Self {
            particle_particle,
            wall_coefficients,
            pair_reach,
            wall_reach,
            dt: setup.dt_s,
            body,
            neighbors,
            pair_forces: Vec::new(),
            wall_history: vec![ContactHistory::default(); world.particles.len() * wall_slots],
            wall_slots,
            placed: Vec::new(),
            spheres: Vec::new(),
            motion: Vec::new(),
            kick: Vec::new(),
            stats: StepStats::default(),
            limits: setup.health,
            energy_reference: None,
            energy_check: !N::ADHESIVE,
            rebuilds_since_sort: 0,
            _boundary: std::marker::PhantomData,
        };
        stepper
            .sort_and_rebuild(world)
            .map_err(SetupError::Neighbor)?;
        stepper.pack(world);
        stepper.forces(world).map_err(SetupError::Health)?;
        Ok(stepper)
    }

    /// One velocity-Verlet step: half kick and drift, forces at the new
    /// positions (damping sees the half-step velocities, as in LAMMPS), half kick.
    fn step(&mut self, world: &mut World) -> Result<(), HealthError> {
        let moved = self.kick_and_drift(world)?;
        world.time_s += self.dt;
        world.step += 1;
        if moved || self.neighbors.is_stale(world.particles.len()) {
            self.rebuild(world)?;
        }
        self.forces(world)?;
        if self.energy_check && world.step.is_multiple_of(ENERGY_CHECK_INTERVAL) {
            self.check_energy(world)?;
        }
        Ok(())
    }

    /// First half kick and drift. Also estimates the full-step velocities the
    /// contact laws use, `v½ + ½dt·F_old/m`: damping evaluated with the
    /// half-step velocity alone lags by dt/2 and makes the restitution error
    /// first order in dt (4 % at e = 0.1 with 50 steps per contact); the
    /// estimate makes it second order. Fills the packed [`Sphere`] and
    /// [`Motion`] records, and returns whether some particle moved more than
    /// half the skin since the last neighbour build (the neighbour list's own
    /// test, fused into this pass).
    fn kick_and_drift(&mut self, world: &mut World) -> Result<bool, HealthError> {
        let dt = self.dt;
        let domain = world.domain;
        let p = &mut world.particles;
        self.spheres.resize(p.len(), Sphere::default());
        self.motion.resize(p.len(), Motion::default());
        let reference = self.neighbors.reference_positions();
        let limit_sq = self.neighbors.rebuild_distance_sq();
        let (left, moved) = p
            .position
            .par_iter_mut()
            .zip(p.velocity.par_iter_mut())
            .zip(p.angular_velocity.par_iter_mut())
            .zip(p.force.par_iter().zip(p.torque.par_iter()))
            .zip(p.mass.par_iter().zip(p.radius.par_iter()))
            .zip(self.spheres.par_iter_mut().zip(self.motion.par_iter_mut()))
            .zip(self.kick.par_iter())
            .enumerate()
            .with_min_len(PAR_MIN_LEN)
            .map(
                |(i, ((((((x, v), w), (f, t)), (&m, &r)), (sphere, motion)), kick))| {
                    let dv = f * kick.v;
                    let dw = t * kick.w;
                    *v += dv;
                    *w += dw;
                    *x = B::wrap(&domain, *x + *v * dt);
                    *sphere = Sphere { x: *x, r };
                    *motion = Motion {
                        v: *v + dv,
                        w: *w + dw,
                        m,
                        inv_r: kick.inv_r,
                    };
                    // A NaN position also asks for a rebuild (which then reports it).
                    let moved = match reference.get(i) {
                        Some(x0) => {
                            let d2 = B::separation(&domain, *x - x0).norm_squared();
                            d2 > limit_sq || d2.is_nan()
                        }
                        None => true,
                    };
                    ((!domain.contains(*x)).then_some(i), moved)
                },
            )
            .reduce(|| (None, false), |a, b| (min_option(a.0, b.0), a.1 || b.1));
        match left {
            Some(i) => Err(self.health(
                world,
                i,
                HealthCause::LeftDomain {
                    position: world.particles.position[i],
                },
            )),
            None => Ok(moved),
        }
    }

    /// Fills the packed records from the particles with the velocities
    /// themselves as estimates (no force history yet: at setup and after
    /// particles were added or removed).
    fn pack(&mut self, world: &World) {
        let p = &world.particles;
        self.spheres.clear();
        self.spheres.extend(
            p.position
                .iter()
                .zip(&p.radius)
                .map(|(&x, &r)| Sphere { x, r }),
        );
        self.motion.clear();
        self.motion.extend((0..p.len()).map(|i| Motion {
            v: p.velocity[i],
            w: p.angular_velocity[i],
            m: p.mass[i],
            inv_r: 1.0 / p.radius[i],
        }));
        self.kick.clear();
        self.kick.extend(
            p.mass
                .iter()
                .zip(&p.radius)
                .map(|(&m, &r)| Kick::new(self.dt, m, r)),
        );
    }

    fn health(&self, world: &World, index: usize, cause: HealthCause) -> HealthError {
        HealthError {
            particle_id: world.particles.id[index],
            step: world.step,
            time_s: world.time_s,
            cause,
        }
    }

    fn rebuild(&mut self, world: &mut World) -> Result<(), HealthError> {
        self.rebuilds_since_sort += 1;
        let result = if self.rebuilds_since_sort >= SORT_EVERY_REBUILDS {
            self.sort_and_rebuild(world)
        } else {
            let p = &world.particles;
            self.neighbors
                .rebuild(&p.position, &p.radius, &p.id, &world.domain)
        };
        result.map_err(|e| self.neighbor_failure(world, e))
    }

    fn neighbor_failure(&self, world: &World, e: NeighborError) -> HealthError {
        let index = match e {
            NeighborError::InvalidRadius { index, .. }
            | NeighborError::NonFinitePosition { index } => index,
            _ => 0,
        };
        HealthError {
            particle_id: world.particles.id.get(index).copied().unwrap_or(0),
            step: world.step,
            time_s: world.time_s,
            cause: HealthCause::NeighborSearch(e.to_string()),
        }
    }

    /// Re-sorts particles by cell (locality) and rebuilds the neighbour list.
    fn sort_and_rebuild(&mut self, world: &mut World) -> Result<(), NeighborError> {
        self.rebuilds_since_sort = 0;
        let p = &mut world.particles;
        let order = self
            .neighbors
            .cell_order(&p.position, &p.radius, &world.domain)?;
        p.permute(&order);
        if self.spheres.len() == order.len() && self.motion.len() == order.len() {
            apply_permutation(&order, &mut self.spheres);
            apply_permutation(&order, &mut self.motion);
        }
        if self.kick.len() == order.len() {
            apply_permutation(&order, &mut self.kick);
        }
        let slots = self.wall_slots;
        let old = std::mem::take(&mut self.wall_history);
        self.wall_history = order
            .iter()
            .flat_map(|&o| {
                old[o as usize * slots..(o as usize + 1) * slots]
                    .iter()
                    .copied()
            })
            .collect();
        self.neighbors
            .rebuild(&p.position, &p.radius, &p.id, &world.domain)
    }

    /// Pair forces into the per-pair buffer, then per particle: gather, walls,
    /// body force, second half kick, finiteness check.
    fn forces(&mut self, world: &mut World) -> Result<(), HealthError> {
        let (contacts, worst_pair) = self.pair_forces(world);
        let (wall_contacts, worst_wall, non_finite) = self.gather(world);
        self.stats = StepStats {
            contacts,
            wall_contacts,
            max_overlap_ratio: worst_pair.0.max(worst_wall.0),
            rebuilds: self.neighbors.rebuild_count(),
        };
        if let Some(i) = non_finite {
            return Err(self.health(world, i, HealthCause::NonFinite));
        }
        if self.stats.max_overlap_ratio > self.limits.max_overlap_ratio {
            let (ratio, index, partner) = if worst_pair.0 >= worst_wall.0 {
                let [i, j] = self.neighbors.pairs()[worst_pair.1];
                (
                    worst_pair.0,
                    i as usize,
                    format!("particle {}", world.particles.id[j as usize]),
                )
            } else {
                (
                    worst_wall.0,
                    worst_wall.1 / self.wall_slots,
                    format!("wall {}", worst_wall.1 % self.wall_slots),
                )
            };
            return Err(self.health(
                world,
                index,
                HealthCause::Overlap {
                    ratio,
                    limit: self.limits.max_overlap_ratio,
                    partner,
                },
            ));
        }
        Ok(())
    }

    /// Returns the number of force-carrying contacts and (worst overlap ratio, pair index).
    ///
    /// Evaluates the listed pairs [`PAIR_LANES`] at a time
    /// ([`evaluate_lanes`]; a short tail one at a time), each lane
    /// bit-identical to evaluating its pair alone.
    fn pair_forces(&mut self, world: &World) -> (usize, (f64, usize)) {
        let kernel = PairKernel::<B> {
            spheres: &self.spheres,
            motion: &self.motion,
            domain: world.domain,
            coef: self.particle_particle,
            reach: self.pair_reach,
            dt: self.dt,
            _boundary: std::marker::PhantomData,
        };
        let (pairs, history) = self.neighbors.pairs_and_history_mut();
        self.pair_forces.resize(pairs.len(), PairForce::default());
        pairs
            .par_chunks(PAR_MIN_LEN)
            .zip(history.par_chunks_mut(PAR_MIN_LEN))
            .zip(self.pair_forces.par_chunks_mut(PAR_MIN_LEN))
            .enumerate()
            .map(|(chunk, ((pairs, history), out))| {
                kernel.run::<N, R>(chunk * PAR_MIN_LEN, pairs, history, out)
            })
            .reduce(
                || (0, (0.0, usize::MAX)),
                |a, b| (a.0 + b.0, worse(a.1, b.1)),
            )
    }

    /// Returns wall contacts, (worst wall overlap ratio, particle*slots+wall),
    /// and the lowest index of a particle with non-finite state.
    fn gather(&mut self, world: &mut World) -> (usize, (f64, usize), Option<usize>) {
        let t = world.time_s;
        self.placed.clear();
        self.placed
            .extend(world.walls.iter().map(|w| w.placed_at(t)));
        let dt = self.dt;
        let slots = self.wall_slots;
        let g = self.body.acceleration();
        let placed = &self.placed;
        let wall_coef = &self.wall_coefficients;
        let wall_reach = &self.wall_reach;
        let buffer = &self.pair_forces;
        let neighbors = &self.neighbors;
        let p = &mut world.particles;
        p.force
            .par_iter_mut()
            .zip(p.torque.par_iter_mut())
            .zip(p.velocity.par_iter_mut())
            .zip(p.angular_velocity.par_iter_mut())
            .zip(self.wall_history.par_chunks_mut(slots))
            .zip(self.spheres.par_iter().zip(self.motion.par_iter()))
            .zip(self.kick.par_iter())
            .enumerate()
            .with_min_len(PAR_MIN_LEN)
            .map(
                |(i, ((((((f, t), v), w), hist), (sphere, motion)), kick))| {
                    let (x, r, m) = (&sphere.x, sphere.r, motion.m);
                    let (ve, we) = (&motion.v, &motion.w);
                    let (mut force, mut torque) =
                        sum_pair_forces(neighbors.incident(i), buffer, g * m);
                    let mut contacts = 0;
                    let mut worst = (0.0, usize::MAX);
                    for (k, wall) in placed.iter().enumerate() {
                        let Some(wc) = wall.contact(*x, r, wall_reach[k]) else {
                            hist[k] = ContactHistory::default();
                            continue;
                        };
                        let n = wc.normal;
                        let arm = r - 0.5 * wc.overlap_m;
                        let motion = RelativeMotion {
                            velocity: ve - (we * arm).cross(&n) - wc.velocity,
                            angular_velocity: *we,
                        };
                        let geometry = ContactGeometry {
                            normal: n,
                            overlap_m: wc.overlap_m,
                            r_star_m: r,
                            m_star_kg: m,
                        };
                        if let Some(c) =
                            evaluate::<N, R>(&wall_coef[k], &geometry, &motion, dt, &mut hist[k])
                        {
                            force += c.force;
                            torque += c.rolling_torque - n.cross(&c.tangential_force) * arm;
                            contacts += 1;
                            worst = worse(worst, (wc.overlap_m.max(0.0) / r, i * slots + k));
                        }
                    }
                    *f = force;
                    *t = torque;
                    *v += force * kick.v;
                    *w += torque * kick.w;
                    // 0·c is 0 for a finite c and NaN otherwise: one test, no branches.
                    let probe = x * 0.0 + *v * 0.0 + *w * 0.0;
                    let finite = probe.x + probe.y + probe.z == 0.0;
                    (contacts, worst, (!finite).then_some(i))
                },
            )
            .reduce(
                || (0, (0.0, usize::MAX), None),
                |a, b| (a.0 + b.0, worse(a.1, b.1), min_option(a.2, b.2)),
            )
    }

    /// Kinetic + gravitational (measured from the domain corner lowest along
    /// gravity, so it is never negative) + Hertz elastic energy, J, summed serially.
    fn mechanical_energy(&self, world: &World) -> f64 {
        let p = &world.particles;
        let g = self.body.acceleration();
        let (lo, hi) = (world.domain.lo(), world.domain.hi());
        let floor = Vec3::new(
            if g.x < 0.0 { lo.x } else { hi.x },
            if g.y < 0.0 { lo.y } else { hi.y },
            if g.z < 0.0 { lo.z } else { hi.z },
        );
        let potential: f64 = (0..p.len())
            .map(|i| -p.mass[i] * g.dot(&(p.position[i] - floor)))
            .sum();
        let coef = &self.particle_particle;
        let elastic: f64 = self
            .neighbors
            .pairs()
            .iter()
            .map(|&[i, j]| {
                let (i, j) = (i as usize, j as usize);
                let d = B::separation(&world.domain, p.position[i] - p.position[j]).norm();
                let overlap = p.radius[i] + p.radius[j] - d;
                hertz_energy(coef.e_star, harmonic(p.radius[i], p.radius[j]), overlap)
            })
            .sum();
        let wall_elastic: f64 = (0..p.len())
            .flat_map(|i| self.placed.iter().enumerate().map(move |(k, w)| (i, k, w)))
            .filter_map(|(i, k, w)| {
                let c = w.contact(p.position[i], p.radius[i], 0.0)?;
                Some(hertz_energy(
                    self.wall_coefficients[k].e_star,
                    p.radius[i],
                    c.overlap_m,
                ))
            })
            .sum();
        p.kinetic_energy_j() + potential + elastic + wall_elastic
    }

    fn check_energy(&mut self, world: &World) -> Result<(), HealthError> {
        if world.walls.iter().any(|w| !w.motion().is_static()) {
            // Driven: moving walls do work on the particles.
            self.energy_reference = None;
            return Ok(());
        }
        let e = self.mechanical_energy(world);
        let Some(reference) = self.energy_reference else {
            self.energy_reference = Some(e);
            return Ok(());
        };
        if e > reference * (1.0 + self.limits.energy_growth) + f64::MIN_POSITIVE {
            // Name the fastest particle: the likeliest culprit.
            let p = &world.particles;
            let fastest = (0..p.len())
                .max_by(|&a, &b| {
                    p.velocity[a]
                        .norm_squared()
                        .total_cmp(&p.velocity[b].norm_squared())
                })
                .unwrap_or(0);
            return Err(self.health(
                world,
                fastest,
                HealthCause::EnergyGrowth {
                    energy_j: e,
                    reference_j: reference,
                },
            ));
        }
        Ok(())
    }
}

/// Hertz elastic energy (8/15) E* √R* δ^{5/2}, J (0 without overlap).
fn hertz_energy(e_star: f64, r_star: f64, overlap: f64) -> f64 {
    if overlap <= 0.0 {
        0.0
    } else {
        8.0 / 15.0 * e_star * r_star.sqrt() * overlap.powf(2.5)
    }
}

/// `start` plus the force and the torque of each listed pair on one particle,
/// in the order of its gather list (N, N·m).
#[inline(always)]
fn sum_pair_forces(incident: &[PairRef], buffer: &[PairForce], start: Vec3) -> (Vec3, Vec3) {
    let (mut fx, mut fy, mut fz) = (start.x, start.y, start.z);
    let (mut tx, mut ty, mut tz) = (0.0, 0.0, 0.0);
    for e in incident {
        let pf = &buffer[e.pair()];
        // Branch-free: x + (−1)·f is bit-identical to x − f.
        let sign = e.sign();
        let t = &pf.torque[usize::from(!e.is_first())];
        fx += pf.force_on_first.x * sign;
        fy += pf.force_on_first.y * sign;
        fz += pf.force_on_first.z * sign;
        tx += t.x;
        ty += t.y;
        tz += t.z;
    }
    (Vec3::new(fx, fy, fz), Vec3::new(tx, ty, tz))
}

/// The larger ratio; on ties the lower index (so reductions are order-independent).
fn worse(a: (f64, usize), b: (f64, usize)) -> (f64, usize) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}

fn min_option(a: Option<usize>, b: Option<usize>) -> Option<usize> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, None) => x,
        (None, y) => y,
    }
}

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Kernel for Stepper<N, R, G, B> {
    fn advance(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError> {
        for _ in 0..steps {
            self.step(world)?;
        }
        Ok(())
    }

    fn name(&self) -> String {
        format!("{}+mindlin+{}+{}+{}", N::NAME, R::NAME, G::NAME, B::NAME)
    }

    fn stats(&self) -> StepStats {
        self.stats
    }

    fn particles_changed(
        &mut self,
        world: &mut World,
        kept: Option<&[bool]>,
    ) -> Result<(), HealthError> {
        let slots = self.wall_slots;
        if let Some(mask) = kept {
            let old = std::mem::take(&mut self.wall_history);
            self.wall_history = mask
                .iter()
                .enumerate()
                .filter(|(_, k)| **k)
                .flat_map(|(i, _)| old[i * slots..(i + 1) * slots].iter().copied())
                .collect();
        }
        self.wall_history
            .resize(world.particles.len() * slots, ContactHistory::default());
        self.energy_reference = None;
        self.sort_and_rebuild(world)
            .map_err(|e| self.neighbor_failure(world, e))?;
        self.pack(world);
        self.forces(world)
    }
}
