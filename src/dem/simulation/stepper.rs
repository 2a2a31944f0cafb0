//! One monomorphised kernel: the state and stages of a simulation with fixed
//! effects.

mod rigid;

use super::pair_kernel::{Motion, PairFound, PairKernel, Sphere};
use super::particle_runs::ParticleRecords;
use super::team::{run_jobs, Team, JOBS_PER_MEMBER};
use super::tiles::{Accumulated, Tiles};
use super::{min_option, worse, Kernel, SetupError, SimulationSetup, StepStats, World};
use crate::dem::contact::{
    evaluate, ContactGeometry, ContactHistory, NormalModel, PairCoefficients, RelativeMotion,
    RollingModel,
};
use crate::dem::domain::Domain;
use crate::dem::effects::{BodyForce, Boundary};
use crate::dem::health::{HealthCause, HealthError, HealthLimits, ENERGY_CHECK_INTERVAL};
use crate::dem::material::harmonic;
use crate::dem::neighbor::{NeighborError, NeighborList};
use crate::dem::vec3::Vec3;
use crate::dem::walls::PlacedWall;

/// One kernel: state and scratch of a simulation with fixed effects.
pub(super) struct Stepper<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> {
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
    /// Partial sums of the pairs that reach a particle from an earlier block
    /// (see [`super::tiles`]).
    partials: Vec<Accumulated>,
    /// How the pair sweep is cut into blocks and tiles, one tile per team
    /// member, and the per-particle passes into shares (see
    /// [`super::tiles`]).
    tiles: Tiles,
    /// The threads that run the stages on more than one thread (see
    /// [`super::team`]); `None` on one.
    team: Option<Team>,
    /// The walls placed at the current time.
    placed: Vec<PlacedWall>,
    /// Per-particle records: packed state, kick factors, wall contact
    /// history and the sweep's sums.
    records: ParticleRecords<ContactHistory<N, R>>,
    stats: StepStats,
    limits: HealthLimits,
    /// Energy check enabled (non-adhesive kernel — the JKR kernel runs only
    /// with non-zero surface energy; skipped while any wall moves or any
    /// particle is prescribed) and its
    /// reference, J.
    energy_reference: Option<f64>,
    energy_check: bool,
    rebuilds_since_sort: u32,
    /// Where the clumps' members are (`None`: a world of free spheres).
    rigid: Option<rigid::RigidIndex>,
    _boundary: std::marker::PhantomData<B>,
}

/// Re-sort particles by cell every this many neighbour rebuilds.
const SORT_EVERY_REBUILDS: u32 = 8;

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Stepper<N, R, G, B> {
    pub(super) fn new(
        world: &mut World,
        setup: &SimulationSetup,
        body: G,
    ) -> Result<Self, SetupError> {
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
        let mut stepper = Self {
            particle_particle,
            wall_coefficients,
            pair_reach,
            wall_reach,
            dt: setup.dt_s,
            body,
            neighbors,
            partials: Vec::new(),
            tiles: Tiles::default(),
            team: None,
            placed: Vec::new(),
            records: ParticleRecords::new(world.particles.len(), world.walls.len()),
            stats: StepStats::default(),
            limits: setup.health,
            energy_reference: None,
            energy_check: !N::ADHESIVE,
            rebuilds_since_sort: 0,
            rigid: world.bodies.as_ref().map(|_| rigid::RigidIndex::default()),
            _boundary: std::marker::PhantomData,
        };
        stepper
            .sort_and_rebuild(world)
            .map_err(SetupError::Neighbor)?;
        stepper.records.pack(&world.particles, stepper.dt);
        stepper.rigid_pack(world);
        stepper.join_team();
        stepper.forces(world, false).map_err(SetupError::Health)?;
        stepper.rigid_collect(world, false);
        stepper.rest_team();
        Ok(stepper)
    }

    /// Makes the team as large as rayon's current thread count (the pool
    /// the caller runs in); no team on one thread.
    fn join_team(&mut self) {
        let threads = rayon::current_num_threads();
        if threads <= 1 {
            self.team = None;
        } else if self.team.as_ref().map(Team::size) != Some(threads) {
            self.team = Some(Team::new(threads));
        }
    }

    /// Lets the team's helpers yield their CPUs until the next stage (before
    /// rayon's parallel work and when `advance` returns).
    fn rest_team(&self) {
        if let Some(team) = &self.team {
            team.rest();
        }
    }

    /// Cuts the tiles (kept while the neighbour list, the particles and the
    /// team stay the same): [`JOBS_PER_MEMBER`] per team member, one
    /// without a team.
    fn cut_tiles(&mut self) {
        self.tiles.cut(
            self.neighbors.rebuild_count(),
            self.neighbors.row_offsets(),
            self.neighbors.pairs(),
            self.team
                .as_ref()
                .map_or(1, |team| JOBS_PER_MEMBER * team.size()),
        );
    }

    /// First half kick and drift on its own (when the last force pass did
    /// not drift), from the stored forces and torques; returns whether some
    /// particle moved far enough to need a neighbour rebuild.
    fn kick_and_drift(&mut self, world: &mut World) -> Result<bool, HealthError> {
        self.cut_tiles();
        let drift = Drift::<B>::new(world.domain, self.dt, &self.neighbors, &self.limits);
        let runs = self.records.runs(&mut world.particles, self.tiles.shares());
        let (left, moved, tunnelled) = run_jobs(self.team.as_ref(), runs, |run| {
            let mut found = (None, false, false);
            for (k, ((((x, v), w), (f, t)), ((sphere, motion), kick))) in run
                .position
                .iter_mut()
                .zip(run.velocity.iter_mut())
                .zip(run.angular_velocity.iter_mut())
                .zip(run.force.iter().zip(run.torque.iter()))
                .zip(
                    run.spheres
                        .iter_mut()
                        .zip(run.motion.iter_mut())
                        .zip(run.kick),
                )
                .enumerate()
            {
                let state = ParticleMut {
                    x,
                    v,
                    w,
                    sphere,
                    motion,
                };
                let (v0, w0) = (*state.v, *state.w);
                let (left, moved, tunnelled) =
                    drift.apply(run.first + k, v0, w0, f * kick.v, t * kick.w, state);
                found = (
                    min_option(found.0, left),
                    found.1 || moved,
                    found.2 | tunnelled,
                );
            }
            found
        })
        .into_iter()
        .fold((None, false, false), |a, b| {
            (min_option(a.0, b.0), a.1 || b.1, a.2 | b.2)
        });
        self.tunnelled(world, tunnelled)?;
        self.left_domain(world, left)?;
        Ok(moved)
    }

    /// If the drift just made moved some particle too far (`tunnelled`),
    /// the error for the lowest-indexed one: the drift of step
    /// `world.step + 1`, so the error names that step and the time at its
    /// end. The drift only flags (an `or` per particle); the search repeats
    /// its test, on the velocity the drift stored, when the flag is up.
    fn tunnelled(&self, world: &World, tunnelled: bool) -> Result<(), HealthError> {
        if !tunnelled {
            return Ok(());
        }
        let p = &world.particles;
        let limit_sq = step_limit_sq(&self.limits);
        let Some(i) =
            (0..p.len()).find(|&i| too_far(p.velocity[i] * self.dt, p.radius[i], limit_sq))
        else {
            return Ok(());
        };
        Err(HealthError {
            particle_id: p.id[i],
            body_id: body_id(world, p.id[i]),
            step: world.step + 1,
            time_s: world.time_s + self.dt,
            cause: HealthCause::Tunnelling {
                displacement_m: p.velocity[i].norm() * self.dt,
                radius_m: p.radius[i],
                limit: self.limits.max_overlap_ratio,
            },
        })
    }

    /// The error for the lowest-indexed particle that left the domain, if any.
    fn left_domain(&self, world: &World, left: Option<usize>) -> Result<(), HealthError> {
        match left {
            Some(i) => Err(self.health(
                world,
                i,
                HealthCause::LeftDomain {
                    position: world.particles.position[i],
                },
            )),
            None => Ok(()),
        }
    }

    fn health(&self, world: &World, index: usize, cause: HealthCause) -> HealthError {
        HealthError {
            particle_id: world.particles.id[index],
            body_id: body_id(world, world.particles.id[index]),
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
                .map(|()| self.exclude_members())
        };
        result.map_err(|e| self.neighbor_failure(world, e))
    }

    /// Drops the pairs of members of one clump from the neighbour list.
    fn exclude_members(&mut self) {
        if let Some(index) = &self.rigid {
            self.neighbors.exclude(|i, j| index.same_body(i, j));
        }
    }

    fn neighbor_failure(&self, world: &World, e: NeighborError) -> HealthError {
        let index = match e {
            NeighborError::InvalidRadius { index, .. }
            | NeighborError::NonFinitePosition { index } => index,
            _ => 0,
        };
        let particle_id = world.particles.id.get(index).copied().unwrap_or(0);
        HealthError {
            particle_id,
            body_id: body_id(world, particle_id),
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
        self.records.permute(&order);
        if let (Some(index), Some(bodies)) = (&mut self.rigid, &world.bodies) {
            index.refresh(bodies, p);
        }
        self.neighbors
            .rebuild(&p.position, &p.radius, &p.id, &world.domain)?;
        self.exclude_members();
        Ok(())
    }

    /// Pair forces into the per-particle sums (started at the body force)
    /// and partials; then per particle: its pair sum, walls, second half
    /// kick, finiteness check, and with `drift` the next step's first half
    /// kick and drift. Returns whether that drift moved
    /// some particle far enough to need a neighbour rebuild.
    fn forces(&mut self, world: &mut World, drift: bool) -> Result<bool, HealthError> {
        let pairs = self.pair_forces(world);
        let found = self.gather(world, drift);
        let (worst_pair, worst_wall) = (pairs.worst, found.worst_wall);
        self.stats = StepStats {
            contacts: pairs.contacts,
            wall_contacts: found.wall_contacts,
            max_overlap_ratio: worst_pair.0.max(worst_wall.0),
            rebuilds: self.neighbors.rebuild_count(),
            max_approach_speed_m_s: self
                .stats
                .max_approach_speed_m_s
                .max(pairs.approach_m_s)
                .max(found.wall_approach_m_s),
        };
        if let Some(i) = found.non_finite {
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
                    worst_wall.1 / self.records.wall_slots,
                    format!("wall {}", worst_wall.1 % self.records.wall_slots),
                )
            };
            return Err(self.health(
                world,
                index,
                HealthCause::Overlap {
                    ratio,
                    limit: self.limits.max_overlap_ratio,
                    partner,
                    position: world.particles.position[index],
                },
            ));
        }
        self.tunnelled(world, found.tunnelled)?;
        self.left_domain(world, found.left)?;
        Ok(found.moved)
    }

    /// Returns the number of force-carrying contacts, (worst overlap ratio,
    /// pair index) and the fastest approach.
    ///
    /// Evaluates the listed pairs tile by tile (see [`super::tiles`]),
    /// [`PAIR_LANES`](super::pair_kernel::PAIR_LANES) at a time
    /// ([`evaluate_lanes`](crate::dem::contact::evaluate_lanes); a short tail
    /// one at a time), each lane bit-identical to evaluating its pair alone.
    fn pair_forces(&mut self, world: &World) -> PairFound {
        self.cut_tiles();
        let kernel = PairKernel::<B> {
            spheres: &self.records.spheres,
            motion: &self.records.motion,
            domain: world.domain,
            coef: self.particle_particle,
            reach: self.pair_reach,
            dt: self.dt,
            _boundary: std::marker::PhantomData,
        };
        let g = self.body.acceleration();
        let (pairs, history) = self.neighbors.pairs_and_history_mut();
        self.partials
            .resize(self.tiles.partial_count(), Accumulated::default());
        let sums = &mut self.records.sums;
        sums.resize(world.particles.len(), Accumulated::default());
        let jobs = self.tiles.jobs(pairs, history, &mut self.partials, sums);
        run_jobs(self.team.as_ref(), jobs, |mut job| {
            job.sink.start(g, kernel.motion);
            let first_pair = job.sink.first_pair();
            kernel.run::<N, R, _>(first_pair, job.pairs, job.history, &mut job.sink)
        })
        .into_iter()
        .fold(PairFound::default(), PairFound::merge)
    }

    /// Per particle: its pair sum (own sum plus partials), walls,
    /// second half kick and finiteness check; with `drift` also the next
    /// step's first half kick and drift (forces and torques are then not
    /// stored: the next force pass replaces them), else the forces and
    /// torques are stored for it.
    fn gather(&mut self, world: &mut World, drift: bool) -> GatherFound {
        let t = world.time_s;
        self.placed.clear();
        self.placed
            .extend(world.walls.iter().map(|w| w.placed_at(t)));
        let dt = self.dt;
        let slots = self.records.wall_slots;
        let placed = &self.placed;
        let wall_coef = &self.wall_coefficients;
        let wall_reach = &self.wall_reach;
        let partials = &self.partials;
        let tiles = &self.tiles;
        let neighbors = &self.neighbors;
        let limits = &self.limits;
        let drift = drift.then(|| Drift::<B>::new(world.domain, dt, neighbors, limits));
        let runs = self.records.runs(&mut world.particles, tiles.shares());
        run_jobs(self.team.as_ref(), runs, |run| {
            let mut found = GatherFound::default();
            for (offset, (((((((f, t), v), w), x), hist), (sphere, motion)), (kick, sum))) in run
                .force
                .iter_mut()
                .zip(run.torque.iter_mut())
                .zip(run.velocity.iter_mut())
                .zip(run.angular_velocity.iter_mut())
                .zip(run.position.iter_mut())
                .zip(run.wall_history.chunks_mut(slots))
                .zip(run.spheres.iter_mut().zip(run.motion.iter_mut()))
                .zip(run.kick.iter().zip(run.sums))
                .enumerate()
            {
                let i = run.first + offset;
                let (xc, r, m) = (sphere.x, sphere.r, motion.m);
                let (ve, we) = (motion.v, motion.w);
                let Accumulated {
                    mut force,
                    mut torque,
                } = tiles.pair_sum(i, sum, partials);
                for (k, wall) in placed.iter().enumerate() {
                    let Some(wc) = wall.contact(xc, r, wall_reach[k]) else {
                        // Most particles touch no wall: leave their empty
                        // history unwritten rather than dirty its cache line.
                        if hist[k] != ContactHistory::default() {
                            hist[k] = ContactHistory::default();
                        }
                        continue;
                    };
                    let n = wc.normal;
                    let arm = r - 0.5 * wc.overlap_m;
                    let motion = RelativeMotion {
                        velocity: ve - (we * arm).cross(&n) - wc.velocity,
                        angular_velocity: we,
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
                        found.wall_contacts += 1;
                        found.wall_approach_m_s =
                            found.wall_approach_m_s.max(-c.normal_velocity_m_s);
                        found.worst_wall =
                            worse(found.worst_wall, (wc.overlap_m.max(0.0) / r, i * slots + k));
                    }
                }
                let dv = force * kick.v;
                let dw = torque * kick.w;
                let (v1, w1) = (*v + dv, *w + dw);
                // 0·c is 0 for a finite c and NaN otherwise: one test, no branches.
                let probe = xc * 0.0 + v1 * 0.0 + w1 * 0.0;
                if probe.x + probe.y + probe.z != 0.0 {
                    found.non_finite = found.non_finite.or(Some(i));
                }
                match &drift {
                    Some(drift) => {
                        let state = ParticleMut {
                            x,
                            v,
                            w,
                            sphere,
                            motion,
                        };
                        let (left, moved, tunnelled) = drift.apply(i, v1, w1, dv, dw, state);
                        found.left = found.left.or(left);
                        found.moved |= moved;
                        found.tunnelled |= tunnelled;
                    }
                    None => {
                        *v = v1;
                        *w = w1;
                        *f = force;
                        *t = torque;
                    }
                }
            }
            found
        })
        .into_iter()
        .fold(GatherFound::default(), GatherFound::merge)
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
        let (kinetic, potential): (f64, f64) = match &world.bodies {
            None => (
                p.kinetic_energy_j(),
                (0..p.len())
                    .map(|i| -p.mass[i] * g.dot(&(p.position[i] - floor)))
                    .sum(),
            ),
            Some(bodies) => (
                bodies.kinetic_energy_j(),
                (0..bodies.len())
                    .map(|b| -bodies.mass[b] * g.dot(&(bodies.position[b] - floor)))
                    .sum(),
            ),
        };
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
        kinetic + potential + elastic + wall_elastic
    }

    fn check_energy(&mut self, world: &World) -> Result<(), HealthError> {
        if self.records.any_prescribed() || world.walls.iter().any(|w| !w.motion().is_static()) {
            // Driven: prescribed particles and moving walls do work on the
            // particles.
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

    /// The step loop of [`Kernel::advance`] (see there), on the team
    /// [`join_team`](Self::join_team) made.
    fn steps(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError> {
        if self.rigid.is_some() {
            return self.rigid_steps(world, steps);
        }
        let mut drifted: Option<bool> = None;
        for s in 0..steps {
            let moved = match drifted {
                Some(moved) => moved,
                None => self.kick_and_drift(world)?,
            };
            world.time_s += self.dt;
            world.step += 1;
            if moved || self.neighbors.is_stale(world.particles.len()) {
                // The rebuild is rayon's: the team's helpers rest meanwhile.
                self.rest_team();
                self.rebuild(world)?;
            }
            let check = self.energy_check && world.step.is_multiple_of(ENERGY_CHECK_INTERVAL);
            let drift = s + 1 < steps && !check;
            let moved = self.forces(world, drift)?;
            if check {
                self.rest_team();
                self.check_energy(world)?;
            }
            drifted = drift.then_some(moved);
        }
        Ok(())
    }
}

/// The id of the clump whose member has particle id `particle` (`None` in
/// a world of spheres).
fn body_id(world: &World, particle: u32) -> Option<u32> {
    let bodies = world.bodies.as_ref()?;
    bodies.body_of_member(particle).map(|b| bodies.id[b])
}

/// Hertz elastic energy (8/15) E* √R* δ^{5/2}, J (0 without overlap).
fn hertz_energy(e_star: f64, r_star: f64, overlap: f64) -> f64 {
    if overlap <= 0.0 {
        0.0
    } else {
        8.0 / 15.0 * e_star * r_star.sqrt() * overlap.powf(2.5)
    }
}

/// The tunnelling bound of `limits` as the drift tests it: the largest
/// displacement in one step per radius, squared.
fn step_limit_sq(limits: &HealthLimits) -> f64 {
    limits.max_overlap_ratio * limits.max_overlap_ratio
}

/// Whether a particle of radius `r` (m) that moved by `step` (m) in one step
/// went farther than the tunnelling bound `limit_sq` (see [`step_limit_sq`]).
/// The drift and the search for the particle evaluate this same expression.
#[inline(always)]
fn too_far(step: Vec3, r: f64, limit_sq: f64) -> bool {
    step.norm_squared() > limit_sq * r * r
}

/// The first half kick and the drift.
///
/// Also estimates the full-step velocities the contact laws use,
/// `v½ + ½dt·F_old/m`: damping evaluated with the half-step velocity alone
/// lags by dt/2 and makes the restitution error first order in dt (4 % at
/// e = 0.1 with 50 steps per contact); the estimate makes it second order.
struct Drift<'a, B: Boundary> {
    domain: Domain,
    /// Time step, s.
    dt: f64,
    /// Positions of the last neighbour build, m.
    reference: &'a [Vec3],
    /// Squared displacement that asks for a rebuild, m².
    limit_sq: f64,
    /// Squared largest displacement in one step per squared radius (the
    /// tunnelling bound, see [`crate::dem::health`]).
    step_limit_sq: f64,
    _boundary: std::marker::PhantomData<B>,
}

/// One particle's state that a drift updates.
struct ParticleMut<'a> {
    x: &'a mut Vec3,
    v: &'a mut Vec3,
    w: &'a mut Vec3,
    sphere: &'a mut Sphere,
    motion: &'a mut Motion,
}

impl<'a, B: Boundary> Drift<'a, B> {
    /// The drift of a step of `dt` (s) in `domain`, testing displacements
    /// against the last build of `neighbors` and, per step, against the
    /// tunnelling bound of `limits`.
    fn new<H: Copy + Default + Send + Sync>(
        domain: Domain,
        dt: f64,
        neighbors: &'a NeighborList<H>,
        limits: &HealthLimits,
    ) -> Self {
        Self {
            domain,
            dt,
            reference: neighbors.reference_positions(),
            limit_sq: neighbors.rebuild_distance_sq(),
            step_limit_sq: step_limit_sq(limits),
            _boundary: std::marker::PhantomData,
        }
    }

    /// Kicks particle `i`, whose velocities are `v` (m/s) and `w` (rad/s),
    /// by `dv` and `dw`, moves it and stores its state and packed records
    /// (centre and velocity estimates; radius and mass never change there).
    /// Returns (`Some(i)` if it left the domain, whether it moved more than
    /// half the skin since the last neighbour build — the neighbour list's
    /// own test, fused into this pass —, whether this step moved it farther
    /// than the tunnelling bound).
    ///
    /// Velocities and centre are passed and stored from registers, never
    /// re-read from the stores just made: a load right after a store to the
    /// same place stalls on store forwarding (a profile at 5,120 particles
    /// put 12 % of the gather's samples on re-reading the velocity).
    #[inline(always)]
    fn apply(
        &self,
        i: usize,
        v: Vec3,
        w: Vec3,
        dv: Vec3,
        dw: Vec3,
        p: ParticleMut<'_>,
    ) -> (Option<usize>, bool, bool) {
        let (v, w) = (v + dv, w + dw);
        *p.v = v;
        *p.w = w;
        let step = v * self.dt;
        let tunnelled = too_far(step, p.sphere.r, self.step_limit_sq);
        let x = B::wrap(&self.domain, *p.x + step);
        *p.x = x;
        p.sphere.x = x;
        p.motion.v = v + dv;
        p.motion.w = w + dw;
        // A NaN position also asks for a rebuild (which then reports it).
        let moved = match self.reference.get(i) {
            Some(x0) => {
                let d2 = B::separation(&self.domain, x - x0).norm_squared();
                d2 > self.limit_sq || d2.is_nan()
            }
            None => true,
        };
        ((!self.domain.contains(x)).then_some(i), moved, tunnelled)
    }
}

/// What a gather found (all reductions exact and order-independent).
#[derive(Clone, Copy, Debug)]
struct GatherFound {
    /// Force-carrying wall contacts.
    wall_contacts: usize,
    /// Worst (overlap ratio, particle * slots + wall).
    worst_wall: (f64, usize),
    /// Lowest index of a particle with non-finite state.
    non_finite: Option<usize>,
    /// Largest relative normal approach speed of a wall contact, m/s.
    wall_approach_m_s: f64,
    /// Lowest index of a particle that drifted out of the domain.
    left: Option<usize>,
    /// Some particle drifted farther than the tunnelling bound.
    tunnelled: bool,
    /// Some particle drifted far enough to need a neighbour rebuild.
    moved: bool,
}

impl Default for GatherFound {
    fn default() -> Self {
        Self {
            wall_contacts: 0,
            worst_wall: (0.0, usize::MAX),
            non_finite: None,
            wall_approach_m_s: 0.0,
            left: None,
            tunnelled: false,
            moved: false,
        }
    }
}

impl GatherFound {
    fn merge(self, o: Self) -> Self {
        Self {
            wall_contacts: self.wall_contacts + o.wall_contacts,
            worst_wall: worse(self.worst_wall, o.worst_wall),
            non_finite: min_option(self.non_finite, o.non_finite),
            wall_approach_m_s: self.wall_approach_m_s.max(o.wall_approach_m_s),
            left: min_option(self.left, o.left),
            tunnelled: self.tunnelled || o.tunnelled,
            moved: self.moved || o.moved,
        }
    }
}

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Kernel for Stepper<N, R, G, B> {
    /// Advances `steps` velocity-Verlet steps. Each step: half kick and drift,
    /// neighbour update, forces at the new positions (damping sees estimated
    /// full-step velocities, see [`Drift`]), half kick. The next step's half
    /// kick and drift run inside this step's force pass (one pass over the
    /// particles instead of two), except after the last step (the caller sees
    /// whole steps) and after a step whose energy is checked (the check needs
    /// the undrifted state); the operations and their order are the same
    /// either way.
    fn advance(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError> {
        self.join_team();
        let result = self.steps(world, steps);
        self.rest_team();
        result
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
        self.records.keep(kept, world.particles.len());
        self.energy_reference = None;
        self.sort_and_rebuild(world)
            .map_err(|e| self.neighbor_failure(world, e))?;
        self.records.pack(&world.particles, self.dt);
        self.rigid_pack(world);
        self.join_team();
        let result = self.forces(world, false).map(|_| ());
        self.rigid_collect(world, false);
        self.rest_team();
        result
    }

    fn prescribe(&mut self, world: &World, ids: &[u32]) {
        self.records.prescribe(ids, &world.particles, self.dt);
        self.energy_reference = None;
    }
}
