//! A rate factory: particles inserted at a given rate into the free space of a
//! region (he2019's and cai2024's generation at the funnel top).
//!
//! The number due by time t is floor(rate · (t − t_start)); each call to
//! [`RateFactory::insert`] covers the window from the previous call's end to the
//! given time and creates the particles that fell due in it, all at once at the
//! window's end (the caller's window, e.g. he2019's 0.01 s generation interval,
//! sets the time resolution). Each new particle draws a diameter and tries up to
//! `attempts_per_particle` random centres in the region, checked against the
//! current particles and the ones created in the same window; one that finds no
//! free place is skipped and counted in the shortfall (not carried over: a full
//! region stays full until particles leave it), unless the caller hands it back
//! with [`RateFactory::carry_over`], which adds it to the next window's due
//! particles (an EDEM factory with a total number keeps trying this way). The
//! ChaCha8 stream lives in the factory, so the same seed, call sequence and
//! snapshots give the same particles.

use super::distribution::{SizeDistribution, SizeSampler};
use super::grid::Grid;
use super::place::uniform_in;
use super::region::Region;
use super::{check_non_negative, check_positive, PackingError};
use crate::dem::particles::ParticleInit;
use crate::dem::vec3::Vec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What a factory inserts.
#[derive(Clone, Debug, PartialEq)]
pub struct RateFactorySpec {
    /// Where new centres go.
    pub region: Region,
    /// Particle sizes.
    pub sizes: SizeDistribution,
    /// Particles per second.
    pub rate_per_s: f64,
    /// Velocity of new particles, m/s.
    pub velocity_m_s: Vec3,
    /// Seed of the factory's ChaCha8 stream.
    pub seed: u64,
    /// Gap kept between new spheres and the region's surfaces, m.
    pub clearance_m: f64,
    /// Random centres tried per particle before it is skipped.
    pub attempts_per_particle: usize,
}

/// Particles created in one window.
#[derive(Clone, Debug, PartialEq)]
pub struct Insertion {
    /// The new particles.
    pub particles: Vec<ParticleInit>,
    /// Particles due in the window.
    pub requested: usize,
    /// Due particles that found no free place and were skipped.
    pub shortfall: usize,
}

/// A running rate factory.
#[derive(Clone, Debug)]
pub struct RateFactory {
    spec: RateFactorySpec,
    sampler: SizeSampler,
    rng: ChaCha8Rng,
    t_start_s: f64,
    t_last_s: f64,
    due_so_far: u64,
    carried: usize,
}

impl RateFactory {
    /// A factory that starts inserting at `t_start_s`.
    pub fn new(spec: RateFactorySpec, t_start_s: f64) -> Result<Self, PackingError> {
        spec.region.validate()?;
        check_positive("rate_per_s", spec.rate_per_s)?;
        check_non_negative("clearance_m", spec.clearance_m)?;
        if !t_start_s.is_finite() {
            return Err(PackingError::BadParameter {
                name: "t_start_s",
                value: t_start_s,
                allowed: "a finite time",
            });
        }
        if spec.attempts_per_particle == 0 || !spec.velocity_m_s.iter().all(|c| c.is_finite()) {
            return Err(PackingError::BadParameter {
                name: "attempts_per_particle",
                value: spec.attempts_per_particle as f64,
                allowed: "at least 1 attempt, and a finite velocity",
            });
        }
        Ok(Self {
            sampler: spec.sizes.sampler()?,
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            spec,
            t_start_s,
            t_last_s: t_start_s,
            due_so_far: 0,
            carried: 0,
        })
    }

    /// Adds `n` particles to those the next [`RateFactory::insert`] creates
    /// (e.g. a shortfall the caller wants retried rather than dropped).
    pub fn carry_over(&mut self, n: usize) {
        self.carried += n;
    }

    /// Creates the particles due between the previous call (or the start) and
    /// `t_end_s`, avoiding the current particles (`positions`, `radii`, m).
    pub fn insert(
        &mut self,
        t_end_s: f64,
        positions: &[Vec3],
        radii: &[f64],
    ) -> Result<Insertion, PackingError> {
        if !(t_end_s.is_finite() && t_end_s >= self.t_last_s) {
            return Err(PackingError::BadParameter {
                name: "t_end_s",
                value: t_end_s,
                allowed: "a finite time not before the previous window's end",
            });
        }
        if positions.len() != radii.len() {
            return Err(PackingError::BadParameter {
                name: "radii",
                value: radii.len() as f64,
                allowed: "one radius per position",
            });
        }
        self.t_last_s = t_end_s;
        let due = (self.spec.rate_per_s * (t_end_s - self.t_start_s)).floor() as u64;
        let requested = due.saturating_sub(self.due_so_far) as usize + self.carried;
        self.carried = 0;
        self.due_so_far = due.max(self.due_so_far);
        // Only particles that can touch the region matter.
        let r_new = 0.5 * self.sampler.max_diameter();
        let (lo, hi) = self.spec.region.bounds();
        let near = |p: &Vec3, r: f64| {
            (0..3).all(|k| p[k] >= lo[k] - r - r_new && p[k] <= hi[k] + r + r_new)
        };
        let nearby: Vec<(Vec3, f64)> = positions
            .iter()
            .zip(radii)
            .filter(|(p, &r)| near(p, r))
            .map(|(p, &r)| (*p, r))
            .collect();
        let r_max = nearby.iter().map(|s| s.1).fold(r_new, f64::max);
        let mut grid = Grid::new(2.0 * r_max);
        for &(p, r) in &nearby {
            grid.insert(p, r);
        }
        let mut particles = Vec::with_capacity(requested);
        for _ in 0..requested {
            let r = self.sampler.sample_radius(&mut self.rng);
            let spot = (0..self.spec.attempts_per_particle)
                .map(|_| uniform_in(&mut self.rng, &lo, &hi))
                .find(|p| {
                    self.spec.region.fits(p, r, self.spec.clearance_m) && !grid.overlaps(p, r)
                });
            if let Some(p) = spot {
                grid.insert(p, r);
                particles.push(ParticleInit {
                    position: p,
                    velocity: self.spec.velocity_m_s,
                    angular_velocity: Vec3::zeros(),
                    radius_m: r,
                });
            }
        }
        Ok(Insertion {
            shortfall: requested - particles.len(),
            particles,
            requested,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::place::tests::assert_valid;
    use super::*;

    fn spec() -> RateFactorySpec {
        RateFactorySpec {
            region: Region::Cylinder {
                axis_xy_m: [0.0, 0.0],
                radius_m: 0.01,
                z_min_m: 0.1,
                z_max_m: 0.11,
            },
            sizes: SizeDistribution::Mono { diameter_m: 1e-3 },
            rate_per_s: 5000.0,
            velocity_m_s: Vec3::new(0.0, 0.0, -0.5),
            seed: 9,
            clearance_m: 0.0,
            attempts_per_particle: 50,
        }
    }

    /// cai2024's 5000 /s with 0.01 s windows: 50 per window, exactly 500 after
    /// 0.1 s whatever the windows; the existing particles are avoided.
    #[test]
    fn rate_windows_and_free_space() {
        let mut f = RateFactory::new(spec(), 0.0).unwrap();
        let blocker = vec![Vec3::new(0.0, 0.0, 0.105)];
        let blocker_r = vec![0.004];
        let mut all: Vec<ParticleInit> = Vec::new();
        for k in 1..=10 {
            let ins = f
                .insert(0.01 * k as f64 + 1e-12, &blocker, &blocker_r)
                .unwrap();
            assert_eq!(ins.requested, 50);
            assert_eq!(ins.shortfall, 0);
            for p in &ins.particles {
                assert!((p.position - blocker[0]).norm() >= 0.004 + p.radius_m);
                assert_eq!(p.velocity, Vec3::new(0.0, 0.0, -0.5));
            }
            all.extend(ins.particles);
        }
        assert_eq!(all.len(), 500);
        assert_valid(&spec().region, 0.0, &all[..50]);
        let mut again = RateFactory::new(spec(), 0.0).unwrap();
        let first = again.insert(0.01 + 1e-12, &blocker, &blocker_r).unwrap();
        assert_eq!(
            first.particles,
            all[..50].to_vec(),
            "same seed, same particles"
        );
    }

    /// A shortfall handed back is tried again in the next window, on top of
    /// that window's own particles (50 per 0.01 s at 5000 /s), and placed once
    /// the region has room.
    #[test]
    fn carried_shortfall_is_retried() {
        let mut s = spec();
        s.region = Region::Box {
            min_m: Vec3::zeros(),
            max_m: Vec3::new(0.002, 0.002, 0.002),
        };
        let mut f = RateFactory::new(s, 0.0).unwrap();
        let first = f.insert(0.01, &[], &[]).unwrap();
        assert!(first.shortfall > 0, "{first:?}");
        f.carry_over(first.shortfall);
        // The region is empty again (the first particles "left"): 50 new ones
        // plus the carried shortfall are due, and as few fit as before.
        let second = f.insert(0.02, &[], &[]).unwrap();
        assert_eq!(second.requested, 50 + first.shortfall);
        assert_eq!(second.particles.len() + second.shortfall, second.requested);
        // Not carried again: the next window has only its own 50.
        let third = f.insert(0.03, &[], &[]).unwrap();
        assert_eq!(third.requested, 50);
    }

    /// A region that holds only a few spheres reports the rest as shortfall.
    #[test]
    fn full_region_reports_shortfall() {
        let mut s = spec();
        s.region = Region::Box {
            min_m: Vec3::zeros(),
            max_m: Vec3::new(0.002, 0.002, 0.002),
        };
        let mut f = RateFactory::new(s, 0.0).unwrap();
        let ins = f.insert(0.01, &[], &[]).unwrap();
        assert_eq!(ins.requested, 50);
        assert!(
            ins.shortfall > 40 && ins.particles.len() + ins.shortfall == 50,
            "{ins:?}"
        );
        assert!(f.insert(0.005, &[], &[]).is_err(), "time must not go back");
    }
}
