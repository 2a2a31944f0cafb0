//! The per-particle state a step updates, cut into runs of consecutive
//! particles, one run per team member: at the tiles of the pair sweep, or
//! at the gather's cut (`Tiles::gather_bounds`), which moves the tiles' so
//! that the shares cost the same. Either way a member mostly finishes the
//! particles whose forces it summed.

use super::pair_kernel::{Kick, Motion, Sphere};
use super::tiles::Accumulated;
use crate::dem::particles::Particles;
use crate::dem::vec3::Vec3;

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
    /// All particles as one run: the particles' own state and the stepper's
    /// per-particle records (each as long as the particles, `sums` possibly
    /// empty and `wall_history` `slots` per particle).
    pub(super) fn whole(
        p: &'a mut Particles,
        spheres: &'a mut [Sphere],
        motion: &'a mut [Motion],
        kick: &'a [Kick],
        wall_history: &'a mut [H],
        sums: &'a [Accumulated],
    ) -> Self {
        Self {
            first: 0,
            position: &mut p.position,
            velocity: &mut p.velocity,
            angular_velocity: &mut p.angular_velocity,
            force: &mut p.force,
            torque: &mut p.torque,
            spheres,
            motion,
            kick,
            wall_history,
            sums,
        }
    }

    /// Cuts the run at the particle indices `bounds` (ascending, starting at
    /// `first` and ending at `first + len`): one run per window.
    pub(super) fn cut(self, bounds: &[usize], slots: usize) -> Vec<Self> {
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
            spheres: s1,
            motion: m1,
            kick: k1,
            wall_history: h1,
            sums: u1,
        };
        (head, tail)
    }
}
