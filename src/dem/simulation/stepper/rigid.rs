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
//! body's mass as its mass. Bodies are visited in body order and members in
//! shape order, serially, so the sums do not depend on the thread count.
//!
//! A world without clumps never enters these stages: its kernel runs the
//! fused sphere loop exactly as before (one test per `advance`).

use super::{step_limit_sq, too_far, Stepper};
use crate::dem::clump::bodies::Bodies;
use crate::dem::clump::rotation::{angular_velocity, free_rotation};
use crate::dem::contact::{NormalModel, RollingModel};
use crate::dem::effects::{BodyForce, Boundary};
use crate::dem::health::{HealthError, ENERGY_CHECK_INTERVAL};
use crate::dem::particles::Particles;
use crate::dem::simulation::{min_option, World};
use crate::dem::vec3::Vec3;

/// Where each body's members are among the particles, refreshed after
/// every reordering of the particles (cell sorts, insertions, removals).
#[derive(Debug, Default)]
pub(super) struct RigidIndex {
    /// Per particle index: its body's index.
    body_of: Vec<u32>,
    /// Per body: its members' particle indices are
    /// `members[member_start[b]..member_start[b + 1]]`, in shape order.
    member_start: Vec<u32>,
    /// Member particle indices, body after body.
    members: Vec<u32>,
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
        self.member_start.clear();
        self.members.clear();
        for b in 0..bodies.len() {
            self.member_start.push(self.members.len() as u32);
            for id in bodies.member_ids(b) {
                let i = index_of[id as usize];
                self.members.push(i);
                self.body_of[i as usize] = b as u32;
            }
        }
        self.member_start.push(self.members.len() as u32);
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

impl<N: NormalModel, R: RollingModel, G: BodyForce, B: Boundary> Stepper<N, R, G, B> {
    /// The step loop of a world with clumps (see the module docs).
    pub(super) fn rigid_steps(&mut self, world: &mut World, steps: u64) -> Result<(), HealthError> {
        for _ in 0..steps {
            let moved = self.rigid_kick_drift(world)?;
            world.time_s += self.dt;
            world.step += 1;
            if moved || self.neighbors.is_stale(world.particles.len()) {
                self.rest_team();
                self.rebuild(world)?;
            }
            self.forces(world, false)?;
            self.rigid_collect(world, true);
            if self.energy_check && world.step.is_multiple_of(ENERGY_CHECK_INTERVAL) {
                self.rest_team();
                self.check_energy(world)?;
            }
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

    /// First half kick, drift and free rotation of every body, and its
    /// members placed and given its motion; returns whether a member moved
    /// far enough to need a neighbour rebuild.
    fn rigid_kick_drift(&mut self, world: &mut World) -> Result<bool, HealthError> {
        let (Some(index), Some(bodies)) = (&self.rigid, &mut world.bodies) else {
            return Ok(false);
        };
        let (dt, domain) = (self.dt, world.domain);
        let p = &mut world.particles;
        let reference = self.neighbors.reference_positions();
        let limit_sq = self.neighbors.rebuild_distance_sq();
        let step_limit = step_limit_sq(&self.limits);
        let (mut moved, mut tunnelled, mut left) = (false, false, None);
        for b in 0..bodies.len() {
            let (m, inertia) = (bodies.mass[b], bodies.inertia[b]);
            let dv = bodies.force[b] * (0.5 * dt / m);
            let dl = bodies.torque[b] * (0.5 * dt);
            let v = bodies.velocity[b] + dv;
            let l = bodies.angular_momentum[b] + dl;
            let x = B::wrap(&domain, bodies.position[b] + v * dt);
            let q = free_rotation(bodies.orientation[b], l, inertia, dt);
            let w = angular_velocity(&q, l, inertia);
            // Full-step estimates for the contact laws, as for spheres.
            let (v_est, w_est) = (v + dv, angular_velocity(&q, l + dl, inertia));
            bodies.velocity[b] = v;
            bodies.angular_momentum[b] = l;
            bodies.position[b] = x;
            bodies.orientation[b] = q;
            let shape = &bodies.shapes[bodies.shape[b] as usize];
            for (member, &i) in shape.members.iter().zip(index.members(b)) {
                let i = i as usize;
                let offset = q.transform_vector(&member.offset);
                let xm = B::wrap(&domain, x + offset);
                let step = B::separation(&domain, xm - p.position[i]);
                tunnelled |= too_far(step, member.radius_m, step_limit);
                p.position[i] = xm;
                p.velocity[i] = v + w.cross(&offset);
                p.angular_velocity[i] = w;
                self.records.spheres[i].x = xm;
                self.records.motion[i].v = v_est + w_est.cross(&offset);
                self.records.motion[i].w = w_est;
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
        }
        self.tunnelled(world, tunnelled)?;
        self.left_domain(world, left)?;
        Ok(moved)
    }

    /// Sums each body's member forces and their torques about its centre
    /// (gravity once, on the body's mass), stores them for the next kick,
    /// with `kick` applies the second half kick, and gives the members
    /// their body's motion. The members' reported forces become their own
    /// contact forces plus gravity on their share of the mass.
    pub(super) fn rigid_collect(&mut self, world: &mut World, kick: bool) {
        let (Some(index), Some(bodies)) = (&self.rigid, &mut world.bodies) else {
            return;
        };
        let g = self.body.acceleration();
        let dt = self.dt;
        let p = &mut world.particles;
        // The members' offsets, world frame, rotated once per body and used
        // for the torque and the members' velocities.
        let mut offsets: Vec<Vec3> = Vec::new();
        for b in 0..bodies.len() {
            let q = bodies.orientation[b];
            let shape = &bodies.shapes[bodies.shape[b] as usize];
            let mut force = g * bodies.mass[b];
            let mut torque = Vec3::zeros();
            offsets.clear();
            offsets.extend(shape.members.iter().map(|m| q.transform_vector(&m.offset)));
            for (offset, &i) in offsets.iter().zip(index.members(b)) {
                let i = i as usize;
                // The pair sums start at g × the mass the laws see (the body's).
                let contact = p.force[i] - g * self.records.motion[i].m;
                force += contact;
                torque += p.torque[i] + offset.cross(&contact);
                p.force[i] = contact + g * p.mass[i];
            }
            if kick {
                bodies.velocity[b] += force * (0.5 * dt / bodies.mass[b]);
                bodies.angular_momentum[b] += torque * (0.5 * dt);
            }
            bodies.force[b] = force;
            bodies.torque[b] = torque;
            let (v, w) = (bodies.velocity[b], bodies.angular_velocity(b));
            for (offset, &i) in offsets.iter().zip(index.members(b)) {
                p.velocity[i as usize] = v + w.cross(offset);
                p.angular_velocity[i as usize] = w;
            }
        }
    }
}
