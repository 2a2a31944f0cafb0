//! The rigid bodies of a world with clumps, as structure-of-arrays.
//!
//! Every member sphere of a body is an ordinary particle of
//! [`Particles`](crate::dem::particles::Particles) — the neighbour search,
//! the contact laws, the walls and the logs see spheres, unchanged — and a
//! body owns a run of consecutive particle ids, pushed together. The body
//! holds what the spheres cannot: the centre of mass, the orientation, the
//! angular momentum and the principal inertia of the union of its members.
//!
//! Masses: a body's mass is density × union volume (overlaps counted
//! once). Each member particle carries the share of the body's mass
//! proportional to its own sphere volume (so sums of particle masses — a
//! discharged mass, a bed's mass — are the bodies' masses), while the
//! contact laws see the body's whole mass as the member's mass (the body
//! moves as one, so its mass is what an impact on a member decelerates;
//! multi-sphere codes do the same). Bodies keep their insertion order and
//! stable ids; only removal reorders nothing but drops entries.

use crate::dem::clump::rotation;
use crate::dem::clump::template::ClumpShape;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::vec3::Vec3;
use nalgebra::UnitQuaternion;
use std::ops::Range;

/// A clump to add to a world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClumpInit {
    /// Index of its shape in [`Bodies::shapes`].
    pub shape: usize,
    /// Centre of mass, m.
    pub position: Vec3,
    /// Orientation: the rotation from the shape's principal frame to the world.
    pub orientation: UnitQuaternion<f64>,
    /// Velocity of the centre of mass, m/s.
    pub velocity: Vec3,
    /// Angular velocity, rad/s (world frame).
    pub angular_velocity: Vec3,
}

/// Rigid bodies made of member particles.
#[derive(Clone, Debug, Default)]
pub struct Bodies {
    /// The shapes bodies may take (principal frame, actual size).
    pub shapes: Vec<ClumpShape>,
    /// Stable body ids (insertion order), never reused.
    pub id: Vec<u32>,
    /// Index of each body's shape in [`shapes`](Self::shapes).
    pub shape: Vec<u32>,
    /// Id of each body's first member particle; its members have the ids
    /// `first_member .. first_member + members`, in the shape's order.
    pub first_member: Vec<u32>,
    /// Centres of mass, m.
    pub position: Vec<Vec3>,
    /// Velocities of the centres of mass, m/s.
    pub velocity: Vec<Vec3>,
    /// Orientations (principal frame → world).
    pub orientation: Vec<UnitQuaternion<f64>>,
    /// Angular momenta about the centres of mass, world frame, kg·m²/s.
    pub angular_momentum: Vec<Vec3>,
    /// Masses, kg.
    pub mass: Vec<f64>,
    /// Principal moments of inertia, kg·m².
    pub inertia: Vec<Vec3>,
    /// Total force of the last force evaluation (gravity included), N.
    pub force: Vec<Vec3>,
    /// Total torque about the centre of mass of the last force evaluation, N·m.
    pub torque: Vec<Vec3>,
    next_id: u32,
}

impl Bodies {
    /// No bodies yet, able to take the given shapes.
    pub fn new(shapes: Vec<ClumpShape>) -> Self {
        Self {
            shapes,
            ..Self::default()
        }
    }

    /// The id the next body pushed will get.
    pub fn next_id(&self) -> u32 {
        self.next_id
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Number of members of body `b`.
    pub fn member_count(&self, b: usize) -> usize {
        self.shapes[self.shape[b] as usize].members.len()
    }

    /// The ids of body `b`'s member particles.
    pub fn member_ids(&self, b: usize) -> Range<u32> {
        let first = self.first_member[b];
        first..first + self.member_count(b) as u32
    }

    /// Index of the body whose member has particle id `id` (bodies keep
    /// insertion order, so their first member ids ascend: a binary search).
    pub fn body_of_member(&self, id: u32) -> Option<usize> {
        let b = self.first_member.partition_point(|&first| first <= id);
        (b > 0 && self.member_ids(b - 1).contains(&id)).then(|| b - 1)
    }

    /// Offset of member `k` of body `b` from its centre of mass, world
    /// frame, m.
    pub fn member_offset(&self, b: usize, k: usize) -> Vec3 {
        let shape = &self.shapes[self.shape[b] as usize];
        self.orientation[b].transform_vector(&shape.members[k].offset)
    }

    /// Angular velocity of body `b`, rad/s (world frame).
    pub fn angular_velocity(&self, b: usize) -> Vec3 {
        rotation::angular_velocity(
            &self.orientation[b],
            self.angular_momentum[b],
            self.inertia[b],
        )
    }

    /// Adds a body of density `density_kg_m3` and its members to
    /// `particles`; returns the body id. The caller guarantees the shape
    /// index is valid (checked by the simulation's insert).
    pub fn push(&mut self, init: &ClumpInit, density_kg_m3: f64, particles: &mut Particles) -> u32 {
        let shape = &self.shapes[init.shape];
        let mass = shape.mass_kg(density_kg_m3);
        let inertia = shape.principal_inertia(density_kg_m3);
        let sphere_volume: f64 = shape.members.iter().map(|m| m.radius_m.powi(3)).sum();
        let mut first = None;
        for member in &shape.members {
            let offset = init.orientation.transform_vector(&member.offset);
            let id = particles.push(
                &ParticleInit {
                    position: init.position + offset,
                    velocity: init.velocity + init.angular_velocity.cross(&offset),
                    angular_velocity: init.angular_velocity,
                    radius_m: member.radius_m,
                },
                density_kg_m3,
            );
            // The member's share of the body's mass (see the module docs).
            let last = particles.len() - 1;
            particles.mass[last] = mass * member.radius_m.powi(3) / sphere_volume;
            first.get_or_insert(id);
        }
        let id = self.next_id;
        self.next_id += 1;
        self.id.push(id);
        self.shape.push(init.shape as u32);
        self.first_member.push(first.expect("a shape has members"));
        self.position.push(init.position);
        self.velocity.push(init.velocity);
        self.orientation.push(init.orientation);
        self.angular_momentum.push(rotation::angular_momentum(
            &init.orientation,
            init.angular_velocity,
            inertia,
        ));
        self.mass.push(mass);
        self.inertia.push(inertia);
        self.force.push(Vec3::zeros());
        self.torque.push(Vec3::zeros());
        id
    }

    /// Keeps only the bodies flagged in `keep`, in order.
    pub fn retain_indices(&mut self, keep: &[bool]) {
        fn apply<T: Copy>(v: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            v.retain(|_| *k.next().unwrap_or(&true));
        }
        apply(&mut self.id, keep);
        apply(&mut self.shape, keep);
        apply(&mut self.first_member, keep);
        apply(&mut self.position, keep);
        apply(&mut self.velocity, keep);
        apply(&mut self.orientation, keep);
        apply(&mut self.angular_momentum, keep);
        apply(&mut self.mass, keep);
        apply(&mut self.inertia, keep);
        apply(&mut self.force, keep);
        apply(&mut self.torque, keep);
    }

    /// Linear momentum, kg·m/s (summed in body order).
    pub fn momentum(&self) -> Vec3 {
        self.mass
            .iter()
            .zip(&self.velocity)
            .fold(Vec3::zeros(), |a, (&m, &v)| a + v * m)
    }

    /// Angular momentum about the origin, kg·m²/s: Σ (x × m v + L).
    pub fn angular_momentum_about_origin(&self) -> Vec3 {
        (0..self.len()).fold(Vec3::zeros(), |a, b| {
            a + self.position[b].cross(&(self.velocity[b] * self.mass[b]))
                + self.angular_momentum[b]
        })
    }

    /// Translational plus rotational kinetic energy, J (summed in body order).
    pub fn kinetic_energy_j(&self) -> f64 {
        (0..self.len())
            .map(|b| {
                0.5 * self.mass[b] * self.velocity[b].norm_squared()
                    + rotation::rotational_energy(
                        &self.orientation[b],
                        self.angular_momentum[b],
                        self.inertia[b],
                    )
            })
            .sum()
    }
}
