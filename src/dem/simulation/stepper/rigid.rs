//! The stages of a kernel whose world has clumps (rigid bodies of member
//! spheres, [`crate::dem::clump`]).
//!
//! The member spheres go through the same neighbour search, pair sweep and
//! wall contacts as free spheres (pairs of one body are dropped from the
//! list after every build: they never touch); only the kicks and the drift
//! are the bodies'. A step: first half kick of every body (v and the world
//! angular momentum L) from its stored force and torque, drift of its centre
//! and free rotation of its orientation (NO_SQUISH,
//! [`crate::dem::clump::rotation`]), members placed from the body; then
//! the force pass of the spheres, without their own kicks; then per body
//! the sum of its members' forces and of their torques about its centre,
//! and the second half kick. The contact laws see each member moving with
//! its body (v + ω × r, the full-step estimates as for spheres) and the
//! body's mass as its mass.
//!
//! The rigid stages run on the engine's team ([`super::super::team`]), as
//! the sphere passes do. A rigid stage is two passes, the team's barrier
//! between them:
//!
//! - a pass over the bodies, cut into runs of consecutive body indices, as
//!   many as the sphere passes have jobs, of about equal numbers of bodies
//!   (the cut depends on the body count and the job count alone): each
//!   body's kicks, drift and rotation, its members' offsets rotated into
//!   the world frame (kept per member, body after body, for the next pass)
//!   and, after the force pass, the sums of its members' forces and
//!   torques, taken by the one job that owns the body, in shape order;
//! - a pass over the particles, cut into the sphere passes' runs
//!   (`Tiles::shares`): each member given its body's motion, placed after
//!   a drift, and its reported force after the force pass, from its own
//!   offset and its body's values. The drift's findings (a rebuild needed,
//!   a member moved too far, the lowest index of a member that left the
//!   domain) are an `or` and a minimum, the same in any order.
//!
//! As in the sphere loop, the next step's first half kick and drift run in
//! the same two passes as a step's sums and second half kick (the members'
//! velocities in between are never read), except after the last step of an
//! `advance` and after a step whose energy is checked; the operations and
//! their order are the same either way. A step then takes four team tasks:
//! the body and member passes, the pair sweep and the sphere gather.
//!
//! Every operation on a body or a member is the one the serial loop did, in
//! the same order, and no sum crosses from one body to another: the results
//! do not depend on how the jobs are cut or which thread runs them, so they
//! are bit-identical on any number of threads. The energy check (of the
//! bodies, in body order) stays serial.
//!
//! A world without clumps never enters these stages: its kernel runs the
//! fused sphere loop exactly as before (one test per `advance`).

use super::{step_limit_sq, too_far, Stepper};
use crate::dem::clump::bodies::Bodies;
use crate::dem::clump::rotation::{angular_velocity, free_rotation};
use crate::dem::clump::template::{ClumpShape, Member};
use crate::dem::contact::{NormalModel, RollingModel};
use crate::dem::domain::Domain;
use crate::dem::effects::{BodyForce, Boundary};
use crate::dem::health::{HealthError, ENERGY_CHECK_INTERVAL};
use crate::dem::particles::Particles;
use crate::dem::simulation::team::{run_jobs, JOBS_PER_MEMBER};
use crate::dem::simulation::{min_option, World};
use crate::dem::vec3::Vec3;
use nalgebra::UnitQuaternion;

/// Where each body's members are among the particles, refreshed after
/// every reordering of the particles (cell sorts, insertions, removals),
/// and what the body pass of a rigid stage leaves for the member pass.
#[derive(Debug, Default)]
pub(super) struct RigidIndex {
    /// Per particle index: its body's index.
    body_of: Vec<u32>,
    /// Per particle index: its member slot (its place in `members`).
    slot_of: Vec<u32>,
    /// Per body: its members' particle indices are
    /// `members[member_start[b]..member_start[b + 1]]`, in shape order.
    member_start: Vec<u32>,
    /// Member particle indices, body after body.
    members: Vec<u32>,
    /// Per member slot: the member's offset from its body's centre, world
    /// frame, m, as the last body pass rotated it.
    offsets: Vec<Vec3>,
    /// Per body: its motion as the last body pass left it.
    motion: Vec<BodyMotion>,
}

/// A body's motion for its members: velocity (m/s) and angular velocity
/// (rad/s), and after a drift the full-step estimates the contact laws see.
#[derive(Clone, Copy, Debug, Default)]
struct BodyMotion {
    v: Vec3,
    w: Vec3,
    v_est: Vec3,
    w_est: Vec3,
}

impl RigidIndex {
    /// Rebuilds the index from the particles' ids.
    pub(super) fn refresh(&mut self, bodies: &Bodies, p: &Particles) {
        let max_id = p.id.iter().copied().max().map_or(0, |m| m as usize + 1);
        let mut index_of = vec![u32::MAX; max_id];
        for (i, &id) in p.id.iter().enumerate() {
            index_of[id as usize] = i as u32;
        }
        self.body_of.clear();
        self.body_of.resize(p.len(), u32::MAX);
        self.slot_of.clear();
        self.slot_of.resize(p.len(), u32::MAX);
        self.member_start.clear();
        self.members.clear();
        for b in 0..bodies.len() {
            self.member_start.push(self.members.len() as u32);
            for id in bodies.member_ids(b) {
                let i = index_of[id as usize];
                self.body_of[i as usize] = b as u32;
                self.slot_of[i as usize] = self.members.len() as u32;
                self.members.push(i);
            }
        }
        self.member_start.push(self.members.len() as u32);
        self.offsets.resize(self.members.len(), Vec3::zeros());
        self.motion.resize(bodies.len(), BodyMotion::default());
    }

    /// Particle indices of body `b`'s members, in shape order.
    fn members(&self, b: usize) -> &[u32] {
        &self.members[self.member_start[b] as usize..self.member_start[b + 1] as usize]
    }

    /// True when particles `i` and `j` belong to the same body.
    pub(super) fn same_body(&self, i: usize, j: usize) -> bool {
        self.body_of[i] == self.body_of[j]
    }
}

/// The bodies `first..first + len` of one job of a body pass: the state
/// the pass updates, and their members' offsets and motion for the member
/// pass (member slots from `first_slot`).
struct BodyRun<'a> {
    first: usize,
    first_slot: usize,
    position: &'a mut [Vec3],
    velocity: &'a mut [Vec3],
    orientation: &'a mut [UnitQuaternion<f64>],
    angular_momentum: &'a mut [Vec3],
    force: &'a mut [Vec3],
    torque: &'a mut [Vec3],
    motion: &'a mut [BodyMotion],
    offsets: &'a mut [Vec3],
}

impl<'a> BodyRun<'a> {
    /// The bodies' state, their members' offsets and the bodies' motion
    /// (as in [`RigidIndex`], whose `member_start` this is), cut into `jobs`
    /// runs of about equal numbers of bodies: the cut depends on the body
    /// count and `jobs` alone.
    fn cut(
        bodies: BodiesMut<'a>,
        motion: &'a mut [BodyMotion],
        offsets: &'a mut [Vec3],
        member_start: &[u32],
        jobs: usize,
    ) -> Vec<Self> {
        let n = bodies.position.len();
        let mut rest = BodyRun {
            first: 0,
            first_slot: 0,
            position: bodies.position,
            velocity: bodies.velocity,
            orientation: bodies.orientation,
            angular_momentum: bodies.angular_momentum,
            force: bodies.force,
            torque: bodies.torque,
            motion,
            offsets,
        };
        let mut runs = Vec::with_capacity(jobs);
        for t in 1..jobs {
            let (from, to) = (n * (t - 1) / jobs, n * t / jobs);
            let (head, tail) = rest.split_at(to - from, member_start);
            runs.push(head);
            rest = tail;
        }
        runs.push(rest);
        runs
    }

    /// The first `k` bodies and the rest (`member_start` as in
    /// [`RigidIndex`]).
    fn split_at(self, k: usize, member_start: &[u32]) -> (Self, Self) {
        let slots = member_start[self.first + k] as usize - self.first_slot;
        let (x0, x1) = self.position.split_at_mut(k);
        let (v0, v1) = self.velocity.split_at_mut(k);
        let (q0, q1) = self.orientation.split_at_mut(k);
        let (l0, l1) = self.angular_momentum.split_at_mut(k);
        let (f0, f1) = self.force.split_at_mut(k);
        let (t0, t1) = self.torque.split_at_mut(k);
        let (m0, m1) = self.motion.split_at_mut(k);
        let (o0, o1) = self.offsets.split_at_mut(slots);
        let head = Self {
            first: self.first,
            first_slot: self.first_slot,
            position: x0,
            velocity: v0,
            orientation: q0,
            angular_momentum: l0,
            force: f0,
            torque: t0,
            motion: m0,
            offsets: o0,
        };
        let tail = Self {
            first: self.first + k,
            first_slot: self.first_slot + slots,
            position: x1,
            velocity: v1,
            orientation: q1,
            angular_momentum: l1,
            force: f1,
            torque: t1,
            motion: m1,
            offsets: o1,
        };
        (head, tail)
    }

    /// The offsets of body `first + k`'s members (`member_start` as in
    /// [`RigidIndex`]).
    fn offsets_of(&mut self, k: usize, member_start: &[u32]) -> &mut [Vec3] {
        let b = self.first + k;
        let (from, to) = (member_start[b] as usize, member_start[b + 1] as usize);
        &mut self.offsets[from - self.first_slot..to - self.first_slot]
    }
}

impl BodyRun<'_> {
    /// Body `first + k`'s first half kick (v and L) from its stored force
    /// and torque, drift of its centre and free rotation of its
    /// orientation; its members' offsets, and its motion for the member
    /// pass (velocities and the full-step estimates of the contact laws).
    fn kick_drift<B: Boundary>(
        &mut self,
        k: usize,
        read: &BodiesRef<'_>,
        member_start: &[u32],
        dt: f64,
        domain: &Domain,
    ) {
        let b = self.first + k;
        let (m, inertia) = (read.mass[b], read.inertia[b]);
        let dv = self.force[k] * (0.5 * dt / m);
        let dl = self.torque[k] * (0.5 * dt);
        let v = self.velocity[k] + dv;
        let l = self.angular_momentum[k] + dl;
        let x = B::wrap(domain, self.position[k] + v * dt);
        let q = free_rotation(self.orientation[k], l, inertia, dt);
        let w = angular_velocity(&q, l, inertia);
        // Full-step estimates for the contact laws, as for spheres.
        let (v_est, w_est) = (v + dv, angular_velocity(&q, l + dl, inertia));
        self.velocity[k] = v;
        self.angular_momentum[k] = l;
        self.position[k] = x;
        self.orientation[k] = q;
        self.motion[k] = BodyMotion { v, w, v_est, w_est };
        for (offset, member) in self
            .offsets_of(k, member_start)
            .iter_mut()
            .zip(read.members(b))
        {
            *offset = q.transform_vector(&member.offset);
        }
    }
}

/// The state of the bodies a body pass updates (mutable) beside what it
/// only reads.
struct BodiesMut<'a> {
    position: &'a mut [Vec3],
    velocity: &'a mut [Vec3],
    orientation: &'a mut [UnitQuaternion<f64>],
    angular_momentum: &'a mut [Vec3],
    force: &'a mut [Vec3],
    torque: &'a mut [Vec3],
}

/// What the rigid passes only read of the bodies.
#[derive(Clone, Copy)]
struct BodiesRef<'a> {
    shapes: &'a [ClumpShape],
    shape: &'a [u32],
    mass: &'a [f64],
    inertia: &'a [Vec3],
}

impl<'a> BodiesRef<'a> {
    fn of(bodies: &'a Bodies) -> Self {
        Self {
            shapes: &bodies.shapes,
            shape: &bodies.shape,
            mass: &bodies.mass,
            inertia: &bodies.inertia,
        }
    }

    /// Body `b`'s members as its shape lists them.
    fn members(&self, b: usize) -> &'a [Member] {
        &self.shapes[self.shape[b] as usize].members
    }
}

/// `bodies` split into what a body pass updates and what it reads.
fn split_bodies(bodies: &mut Bodies) -> (BodiesMut<'_>, BodiesRef<'_>) {
    let Bodies {
        shapes,
        shape,
        position,
        velocity,
        orientation,
        angular_momentum,
        mass,
        inertia,
        force,
        torque,
        ..
    } = bodies;
    (
        BodiesMut {
            position,
            velocity,
            orientation,
            angular_momentum,
            force,
            torque,
        },
        BodiesRef {
            shapes,
            shape,
            mass,
            inertia,
        },
    )
}

/// What the body pass of a rigid stage does to each body.
#[derive(Clone, Copy, Debug)]
enum BodyPass {
    /// First half kick, drift and rotation, from the stored force and torque.
    KickDrift,
    /// The sums of the members' forces and torques, stored; with `kick`
    /// the second half kick; with `drift` then the next step's first half
    /// kick, drift and rotation (as [`BodyPass::KickDrift`] would do next).
    Collect { kick: bool, drift: bool },
}

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Stepper<N, R, G, B> {
    /// The step loop of a world with clumps (see the module docs). As for
    /// spheres, the next step's first half kick and drift run in the same
    /// passes as this step's sums and second half kick, except after the
    /// last step and after a step whose energy is checked; the operations
    /// and their order are the same either way.
    pub(super) fn rigid_steps(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError> {
        let mut drifted: Option<bool> = None;
        for s in 0..steps {
            let moved = match drifted {
                Some(moved) => moved,
                None => self.rigid_stage(world, BodyPass::KickDrift)?,
            };
            world.time_s += self.dt;
            world.step += 1;
            if moved || self.neighbors.is_stale(world.particles.len()) {
                self.rest_team();
                self.rebuild(world)?;
            }
            self.forces(world, false)?;
            let check = self.energy_check && world.step.is_multiple_of(ENERGY_CHECK_INTERVAL);
            let drift = s + 1 < steps && !check;
            let moved = self.rigid_stage(world, BodyPass::Collect { kick: true, drift })?;
            if check {
                self.rest_team();
                self.check_energy(world)?;
            }
            drifted = drift.then_some(moved);
        }
        Ok(())
    }

    /// The contact laws see a member's mass as its body's (the module docs
    /// of [`crate::dem::clump::bodies`] say why): after every packing.
    pub(super) fn rigid_pack(&mut self, world: &World) {
        let (Some(index), Some(bodies)) = (&self.rigid, &world.bodies) else {
            return;
        };
        for b in 0..bodies.len() {
            for &i in index.members(b) {
                self.records.motion[i as usize].m = bodies.mass[b];
            }
        }
    }

    /// Sums each body's member forces and their torques about its centre
    /// (gravity once, on the body's mass), stores them for the next kick,
    /// with `kick` applies the second half kick, and gives the members
    /// their body's motion. The members' reported forces become their own
    /// contact forces plus gravity on their share of the mass.
    pub(super) fn rigid_collect(&mut self, world: &mut World, kick: bool) {
        let placed = self.rigid_stage(world, BodyPass::Collect { kick, drift: false });
        debug_assert!(matches!(placed, Ok(false)), "no member was placed");
    }

    /// One rigid stage on the team (see the module docs): the body pass
    /// `pass`, then the member pass, which reports the members' forces
    /// after a [`BodyPass::Collect`] and places the members after a drift.
    /// Returns whether a placed member moved far enough to need a
    /// neighbour rebuild (false when none was placed), or the health error
    /// of a drift that moved a member too far or out of the domain.
    fn rigid_stage(&mut self, world: &mut World, pass: BodyPass) -> Result<bool, HealthError> {
        self.cut_tiles();
        let jobs = self
            .team
            .as_ref()
            .map_or(1, |team| JOBS_PER_MEMBER * team.size());
        let (Some(index), Some(bodies)) = (&mut self.rigid, &mut world.bodies) else {
            return Ok(false);
        };
        let (dt, domain, g) = (self.dt, world.domain, self.body.acceleration());
        let team = self.team.as_ref();
        // The bodies, each by the job that owns it.
        let (p, laws) = (&world.particles, &self.records.motion);
        let (state, read) = split_bodies(bodies);
        let (member_start, members) = (&index.member_start, &index.members);
        let runs = BodyRun::cut(
            state,
            &mut index.motion,
            &mut index.offsets,
            member_start,
            jobs,
        );
        run_jobs(team, runs, |mut run| {
            for k in 0..run.position.len() {
                let b = run.first + k;
                let BodyPass::Collect { kick, drift } = pass else {
                    run.kick_drift::<B>(k, &read, member_start, dt, &domain);
                    continue;
                };
                let q = run.orientation[k];
                let mut force = g * read.mass[b];
                let mut torque = Vec3::zeros();
                let ids = &members[member_start[b] as usize..member_start[b + 1] as usize];
                let offsets = run.offsets_of(k, member_start);
                for (offset, member) in offsets.iter_mut().zip(read.members(b)) {
                    *offset = q.transform_vector(&member.offset);
                }
                // In shape order.
                for (offset, &i) in offsets.iter().zip(ids) {
                    let i = i as usize;
                    // The pair sums start at g × the mass the laws see (the body's).
                    let contact = p.force[i] - g * laws[i].m;
                    force += contact;
                    torque += p.torque[i] + offset.cross(&contact);
                }
                if kick {
                    run.velocity[k] += force * (0.5 * dt / read.mass[b]);
                    run.angular_momentum[k] += torque * (0.5 * dt);
                }
                run.force[k] = force;
                run.torque[k] = torque;
                if drift {
                    run.kick_drift::<B>(k, &read, member_start, dt, &domain);
                } else {
                    run.motion[k].v = run.velocity[k];
                    run.motion[k].w =
                        angular_velocity(&q, run.angular_momentum[k], read.inertia[b]);
                }
            }
        });
        // The members, particle by particle.
        let (report, place) = match pass {
            BodyPass::KickDrift => (false, true),
            BodyPass::Collect { drift, .. } => (true, drift),
        };
        let (bodies, index) = (&*bodies, &*index);
        let read = BodiesRef::of(bodies);
        let reference = self.neighbors.reference_positions();
        let limit_sq = self.neighbors.rebuild_distance_sq();
        let step_limit = step_limit_sq(&self.limits);
        let runs = self.records.runs(&mut world.particles, self.tiles.shares());
        let (left, moved, tunnelled) = run_jobs(team, runs, |run| {
            let (mut left, mut moved, mut tunnelled) = (None, false, false);
            for k in 0..run.position.len() {
                let i = run.first + k;
                let (b, slot) = (index.body_of[i] as usize, index.slot_of[i] as usize);
                let (offset, body) = (index.offsets[slot], index.motion[b]);
                if report {
                    let contact = run.force[k] - g * run.motion[k].m;
                    run.force[k] = contact + g * run.mass[k];
                }
                if place {
                    let member = &read.members(b)[slot - index.member_start[b] as usize];
                    let xm = B::wrap(&domain, bodies.position[b] + offset);
                    let step = B::separation(&domain, xm - run.position[k]);
                    tunnelled |= too_far(step, member.radius_m, step_limit);
                    run.position[k] = xm;
                    run.spheres[k].x = xm;
                    run.motion[k].v = body.v_est + body.w_est.cross(&offset);
                    run.motion[k].w = body.w_est;
                    moved |= match reference.get(i) {
                        Some(x0) => {
                            let d2 = B::separation(&domain, xm - x0).norm_squared();
                            d2 > limit_sq || d2.is_nan()
                        }
                        None => true,
                    };
                    if !domain.contains(xm) {
                        left = min_option(left, Some(i));
                    }
                }
                run.velocity[k] = body.v + body.w.cross(&offset);
                run.angular_velocity[k] = body.w;
            }
            (left, moved, tunnelled)
        })
        .into_iter()
        .fold((None, false, false), |a, b| {
            (min_option(a.0, b.0), a.1 || b.1, a.2 | b.2)
        });
        self.tunnelled(world, tunnelled)?;
        self.left_domain(world, left)?;
        Ok(moved)
    }
}
