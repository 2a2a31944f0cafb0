//! Particle state as structure-of-arrays (the hot loops see dense slices).

use crate::dem::vec3::Vec3;
use std::f64::consts::PI;

/// A sphere to add to a world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleInit {
    /// Centre, m.
    pub position: Vec3,
    /// Velocity, m/s.
    pub velocity: Vec3,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3,
    /// Radius, m.
    pub radius_m: f64,
}

/// Spheres in structure-of-arrays form. Index order may change (particles are
/// re-sorted by cell for memory locality); `id` is the stable identity.
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Stable particle ids (insertion order), never reused.
    pub id: Vec<u32>,
    /// Centres, m.
    pub position: Vec<Vec3>,
    /// Velocities, m/s.
    pub velocity: Vec<Vec3>,
    /// Angular velocities, rad/s.
    pub angular_velocity: Vec<Vec3>,
    /// Radii, m.
    pub radius: Vec<f64>,
    /// Masses, kg.
    pub mass: Vec<f64>,
    /// Total force of the last force evaluation, N.
    pub force: Vec<Vec3>,
    /// Total torque of the last force evaluation, N·m.
    pub torque: Vec<Vec3>,
    next_id: u32,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Appends a solid sphere of density `density_kg_m3`; returns its id.
    pub fn push(&mut self, p: &ParticleInit, density_kg_m3: f64) -> u32 {
        let id = self.next_id;
        self.next_id += 1;
        self.id.push(id);
        self.position.push(p.position);
        self.velocity.push(p.velocity);
        self.angular_velocity.push(p.angular_velocity);
        self.radius.push(p.radius_m);
        self.mass
            .push(density_kg_m3 * 4.0 / 3.0 * PI * p.radius_m.powi(3));
        self.force.push(Vec3::zeros());
        self.torque.push(Vec3::zeros());
        id
    }

    /// Moment of inertia of particle `i` about its centre, kg·m² (solid sphere 2/5 m r²).
    #[inline(always)]
    pub fn inertia(&self, i: usize) -> f64 {
        0.4 * self.mass[i] * self.radius[i] * self.radius[i]
    }

    /// Reorders every array so that new index k holds old index `order[k]`.
    pub fn permute(&mut self, order: &[u32]) {
        fn apply<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            *v = order.iter().map(|&o| v[o as usize]).collect();
        }
        apply(&mut self.id, order);
        apply(&mut self.position, order);
        apply(&mut self.velocity, order);
        apply(&mut self.angular_velocity, order);
        apply(&mut self.radius, order);
        apply(&mut self.mass, order);
        apply(&mut self.force, order);
        apply(&mut self.torque, order);
    }

    /// Keeps only the particles for which `keep(index)` is true, preserving order.
    pub fn retain_indices(&mut self, keep: &[bool]) {
        let order: Vec<u32> = (0..self.len() as u32)
            .filter(|&i| keep[i as usize])
            .collect();
        self.permute(&order);
    }

    /// Translational plus rotational kinetic energy, J (summed in index order).
    pub fn kinetic_energy_j(&self) -> f64 {
        (0..self.len())
            .map(|i| {
                0.5 * self.mass[i] * self.velocity[i].norm_squared()
                    + 0.5 * self.inertia(i) * self.angular_velocity[i].norm_squared()
            })
            .sum()
    }
}

/// `count` resting particles in a row for tests: particle `k` at x = `k` m,
/// of radius `k + 1` mm and density 1000 kg/m³.
#[cfg(test)]
pub(crate) fn row_of_particles(count: usize) -> Particles {
    let mut p = Particles::default();
    for k in 0..count {
        p.push(
            &ParticleInit {
                position: Vec3::new(k as f64, 0.0, 0.0),
                velocity: Vec3::zeros(),
                angular_velocity: Vec3::zeros(),
                radius_m: 1e-3 * (k + 1) as f64,
            },
            1000.0,
        );
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_permute_retain_keep_ids_with_their_data() {
        let mut p = row_of_particles(4);
        p.permute(&[3, 1, 0, 2]);
        assert_eq!(p.id, vec![3, 1, 0, 2]);
        assert_eq!(p.position[0].x, 3.0);
        p.retain_indices(&[true, false, true, true]);
        assert_eq!(p.id, vec![3, 0, 2]);
        assert!((p.mass[0] - 1000.0 * 4.0 / 3.0 * PI * 64e-9).abs() < 1e-15);
    }
}
