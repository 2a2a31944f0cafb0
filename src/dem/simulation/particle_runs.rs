//! The per-particle state a step updates: the stepper's own records
//! ([`ParticleRecords`]) beside the particles' state, cut into runs of
//! consecutive particles, one run per job of the team (equal shares of the
//! particles, `Tiles::shares`; where there are at least as many blocks as
//! members, a member mostly finishes the particles whose forces it
//! summed).
//!
//! Prescribed kinematics: the particles the caller drives itself (see
//! [`Simulation::prescribe`](super::Simulation::prescribe)) get zero kick
//! factors. The kick, the drift and the gather then run unchanged, with no
//! branch per particle: a prescribed particle's velocities stay what the
//! caller set (and so do the estimates the contact laws' damping reads), it
//! still drifts `x += v·dt` and still receives and reports contact forces.
//! The set is kept by particle id (sorted), so it survives the cell sort's
//! permutations, insertions and removals; `pack` zeroes the factors again
//! whenever it recomputes them. Without prescribed particles the factors are
//! exactly those of before, so such a run is bit-identical.

use super::pair_kernel::{Kick, Motion, Sphere};
use super::tiles::Accumulated;
use crate::dem::neighbor::apply_permutation;
use crate::dem::particles::Particles;
use crate::dem::vec3::Vec3;

/// The stepper's own per-particle records, in the particles' index order
/// (permuted with them): packed copies of what the force stages read, the
/// kick factors, the wall contact history and the sweep's sums.
pub(super) struct ParticleRecords<H> {
    /// Centre and radius per particle, refreshed by every drift.
    pub(super) spheres: Vec<Sphere>,
    /// Velocity estimates, mass and inverse radius, refreshed by every drift.
    pub(super) motion: Vec<Motion>,
    /// Kick factors per particle (see [`Kick`]); zero for prescribed ones.
    pub(super) kick: Vec<Kick>,
    /// Ids of the particles with prescribed kinematics, sorted, no repeats
    /// (see the module docs).
    prescribed: Vec<u32>,
    /// Contact history per (particle, wall): index `p * wall_slots + w`.
    pub(super) wall_history: Vec<H>,
    /// `max(walls, 1)`, so a particle's run of wall history is never empty.
    pub(super) wall_slots: usize,
    /// Per particle: its own sum of the sweep's pair forces (see
    /// [`super::tiles`]); empty before the first sweep.
    pub(super) sums: Vec<Accumulated>,
}

impl<H: Copy + Default> ParticleRecords<H> {
    /// Records for `particles` particles and `walls` walls: empty wall
    /// histories, nothing packed yet (see [`pack`](Self::pack)).
    pub(super) fn new(particles: usize, walls: usize) -> Self {
        let wall_slots = walls.max(1);
        Self {
            spheres: Vec::new(),
            motion: Vec::new(),
            kick: Vec::new(),
            prescribed: Vec::new(),
            wall_history: vec![H::default(); particles * wall_slots],
            wall_slots,
            sums: Vec::new(),
        }
    }

    /// Fills the packed records and kick factors (step `dt`, s; zero for
    /// prescribed particles) from the particles, with the velocities
    /// themselves as estimates (no force history yet: at setup and after
    /// particles were added or removed).
    pub(super) fn pack(&mut self, p: &Particles, dt: f64) {
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
        self.kick_factors(p, dt);
    }

    /// Makes exactly the particles with ids `ids` (current or not, repeats
    /// allowed) prescribed and recomputes the kick factors of `p` (step
    /// `dt`, s); the other packed records are left as they are.
    pub(super) fn prescribe(&mut self, ids: &[u32], p: &Particles, dt: f64) {
        self.prescribed = ids.to_vec();
        self.prescribed.sort_unstable();
        self.prescribed.dedup();
        self.kick_factors(p, dt);
    }

    /// Whether some particle id is prescribed.
    pub(super) fn any_prescribed(&self) -> bool {
        !self.prescribed.is_empty()
    }

    /// The kick factors of `p` for step `dt` (s), zero for prescribed ids.
    fn kick_factors(&mut self, p: &Particles, dt: f64) {
        self.kick.clear();
        self.kick.extend(
            p.mass
                .iter()
                .zip(&p.radius)
                .map(|(&m, &r)| Kick::new(dt, m, r)),
        );
        if self.any_prescribed() {
            for (kick, id) in self.kick.iter_mut().zip(&p.id) {
                if self.prescribed.binary_search(id).is_ok() {
                    *kick = Kick::default();
                }
            }
        }
    }

    /// Applies the permutation `order` (`order[new] = old`) of the
    /// particles: wall histories always, packed records and kick factors
    /// when they are packed for as many particles (before a
    /// [`pack`](Self::pack) they are not used).
    pub(super) fn permute(&mut self, order: &[u32]) {
        if self.spheres.len() == order.len() && self.motion.len() == order.len() {
            apply_permutation(order, &mut self.spheres);
            apply_permutation(order, &mut self.motion);
        }
        if self.kick.len() == order.len() {
            apply_permutation(order, &mut self.kick);
        }
        self.gather_wall_history(order.iter().map(|&o| o as usize));
    }

    /// Keeps the wall histories of the particles flagged in `kept` (all
    /// when `None`), in order, then gives empty histories to the particles
    /// beyond them up to `particles` (the ones just added).
    pub(super) fn keep(&mut self, kept: Option<&[bool]>, particles: usize) {
        if let Some(mask) = kept {
            self.gather_wall_history(mask.iter().enumerate().filter(|(_, k)| **k).map(|(i, _)| i));
        }
        self.wall_history
            .resize(particles * self.wall_slots, H::default());
    }

    /// Replaces the wall histories by those of the old particle indices
    /// `from`, in that order.
    fn gather_wall_history(&mut self, from: impl Iterator<Item = usize>) {
        let slots = self.wall_slots;
        let old = std::mem::take(&mut self.wall_history);
        self.wall_history = from
            .flat_map(|i| old[i * slots..(i + 1) * slots].iter().copied())
            .collect();
    }

    /// The state of the particles `p` and these records cut into runs at
    /// the particle indices `bounds` (ascending, from 0 to the particle
    /// count): one run per window.
    pub(super) fn runs<'a>(
        &'a mut self,
        p: &'a mut Particles,
        bounds: &[usize],
    ) -> Vec<ParticleRun<'a, H>> {
        let slots = self.wall_slots;
        ParticleRun {
            first: 0,
            position: &mut p.position,
            velocity: &mut p.velocity,
            angular_velocity: &mut p.angular_velocity,
            force: &mut p.force,
            torque: &mut p.torque,
            mass: &p.mass,
            spheres: &mut self.spheres,
            motion: &mut self.motion,
            kick: &self.kick,
            wall_history: &mut self.wall_history,
            sums: &self.sums,
        }
        .cut(bounds, slots)
    }
}

/// The state of particles `first..first + len` that the kick, drift and
/// gather update, one slice per quantity (all in the particles' index order).
pub(super) struct ParticleRun<'a, H> {
    /// Index of the run's first particle.
    pub(super) first: usize,
    /// Centres, m.
    pub(super) position: &'a mut [Vec3],
    /// Velocities, m/s.
    pub(super) velocity: &'a mut [Vec3],
    /// Angular velocities, rad/s.
    pub(super) angular_velocity: &'a mut [Vec3],
    /// Forces (N) and torques (N·m), stored when no drift follows.
    pub(super) force: &'a mut [Vec3],
    pub(super) torque: &'a mut [Vec3],
    /// Masses, kg (in a world of clumps, each member's share of its body's).
    pub(super) mass: &'a [f64],
    /// Packed records the pair kernel reads.
    pub(super) spheres: &'a mut [Sphere],
    pub(super) motion: &'a mut [Motion],
    pub(super) kick: &'a [Kick],
    /// Contact history per (particle, wall), `slots` per particle.
    pub(super) wall_history: &'a mut [H],
    /// Pair-force sums from the sweep (empty before the first sweep).
    pub(super) sums: &'a [Accumulated],
}

impl<'a, H> ParticleRun<'a, H> {
    /// Cuts the run at the particle indices `bounds` (ascending, starting at
    /// `first` and ending at `first + len`): one run per window.
    fn cut(self, bounds: &[usize], slots: usize) -> Vec<Self> {
        let mut runs = Vec::with_capacity(bounds.len().saturating_sub(1));
        let mut rest = self;
        for w in bounds.windows(2).take(bounds.len().saturating_sub(2)) {
            let (head, tail) = rest.split_at(w[1] - w[0], slots);
            runs.push(head);
            rest = tail;
        }
        runs.push(rest);
        runs
    }

    /// The first `k` particles and the rest.
    fn split_at(self, k: usize, slots: usize) -> (Self, Self) {
        let (x0, x1) = self.position.split_at_mut(k);
        let (v0, v1) = self.velocity.split_at_mut(k);
        let (w0, w1) = self.angular_velocity.split_at_mut(k);
        let (f0, f1) = self.force.split_at_mut(k);
        let (t0, t1) = self.torque.split_at_mut(k);
        let (n0, n1) = self.mass.split_at(k);
        let (s0, s1) = self.spheres.split_at_mut(k);
        let (m0, m1) = self.motion.split_at_mut(k);
        let (k0, k1) = self.kick.split_at(k);
        let (h0, h1) = self.wall_history.split_at_mut(k * slots);
        let (u0, u1) = self.sums.split_at(k.min(self.sums.len()));
        let head = Self {
            first: self.first,
            position: x0,
            velocity: v0,
            angular_velocity: w0,
            force: f0,
            torque: t0,
            mass: n0,
            spheres: s0,
            motion: m0,
            kick: k0,
            wall_history: h0,
            sums: u0,
        };
        let tail = Self {
            first: self.first + k,
            position: x1,
            velocity: v1,
            angular_velocity: w1,
            force: f1,
            torque: t1,
            mass: n1,
            spheres: s1,
            motion: m1,
            kick: k1,
            wall_history: h1,
            sums: u1,
        };
        (head, tail)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::particles::row_of_particles;

    #[test]
    fn records_follow_their_particles_through_permutations_and_removals() {
        let mut p = row_of_particles(3);
        // Two walls; history (particle, wall) tagged 10 * particle + wall.
        let mut records = ParticleRecords::<u32>::new(3, 2);
        assert_eq!(records.wall_history, vec![0; 6]);
        records.wall_history = vec![0, 1, 10, 11, 20, 21];
        records.pack(&p, 1e-5);
        let order = [2, 0, 1];
        p.permute(&order);
        records.permute(&order);
        assert_eq!(records.wall_history, vec![20, 21, 0, 1, 10, 11]);
        let radii: Vec<f64> = records.spheres.iter().map(|s| s.r).collect();
        assert_eq!(
            radii, p.radius,
            "packed records permuted with the particles"
        );
        assert_eq!(records.motion[0].m, p.mass[0]);
        // Drop the middle particle (old 0) and add one: empty history for it.
        records.keep(Some(&[true, false, true]), 3);
        assert_eq!(records.wall_history, vec![20, 21, 10, 11, 0, 0]);
    }

    /// The kick factors as bits, per particle.
    fn kick_bits(records: &ParticleRecords<u32>) -> Vec<(u64, u64)> {
        records
            .kick
            .iter()
            .map(|k| (k.v.to_bits(), k.w.to_bits()))
            .collect()
    }

    #[test]
    fn prescribed_particles_have_zero_kick_factors_that_follow_their_ids() {
        let dt = 1e-5;
        let mut p = row_of_particles(3);
        let mut records = ParticleRecords::<u32>::new(3, 0);
        records.pack(&p, dt);
        let free = kick_bits(&records);
        assert!(free.iter().all(|&(v, w)| v != 0 && w != 0));
        // Id 1 prescribed (7 is no particle's): only its factors are zero.
        records.prescribe(&[7, 1, 1], &p, dt);
        let zero = (0.0f64.to_bits(), 0.0f64.to_bits());
        assert_eq!(kick_bits(&records), vec![free[0], zero, free[2]]);
        // Through a permutation, a repack and a removal the zero stays with id 1.
        let order = [1, 2, 0];
        p.permute(&order);
        records.permute(&order);
        assert_eq!(kick_bits(&records), vec![zero, free[2], free[0]]);
        records.pack(&p, dt);
        assert_eq!(kick_bits(&records), vec![zero, free[2], free[0]]);
        let kept = [true, false, true];
        p.retain_indices(&kept);
        records.keep(Some(&kept), 2);
        records.pack(&p, dt);
        assert_eq!(kick_bits(&records), vec![zero, free[0]]);
        // Ending the prescription restores exactly the factors of before.
        records.prescribe(&[], &p, dt);
        assert!(!records.any_prescribed());
        assert_eq!(kick_bits(&records), vec![free[1], free[0]]);
    }

    #[test]
    fn runs_cut_every_quantity_at_the_same_particles() {
        let mut p = row_of_particles(3);
        let mut records = ParticleRecords::<u32>::new(3, 2);
        records.wall_history = vec![0, 1, 10, 11, 20, 21];
        records.pack(&p, 1e-5);
        let masses = p.mass.clone();
        let runs = records.runs(&mut p, &[0, 1, 3]);
        assert_eq!(runs.len(), 2);
        assert_eq!((runs[0].first, runs[1].first), (0, 1));
        assert_eq!(
            runs[1].position,
            &[Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0)]
        );
        assert_eq!(runs[1].wall_history, &[10, 11, 20, 21]);
        assert_eq!((runs[0].spheres.len(), runs[1].kick.len()), (1, 2));
        assert_eq!(runs[1].mass, &masses[1..]);
        assert!(runs.iter().all(|r| r.sums.is_empty()), "no sweep yet");
    }
}
