//! Builders shared by the engine (dem) integration tests: materials, lattices of
//! spheres with deterministic jitter, and simulation setups.
#![allow(dead_code)]

use repose::dem::contact::PairParameters;
use repose::dem::domain::Domain;
use repose::dem::health::HealthLimits;
use repose::dem::material::{effective_youngs_modulus, ElasticMaterial};
use repose::dem::particles::{ParticleInit, Particles};
use repose::dem::simulation::{ContactSetup, NormalChoice, RollingChoice, SimulationSetup, World};
use repose::dem::timestep::{choose_time_step, StiffestContact, TimeStepRequest};
use repose::dem::vec3::Vec3;
use repose::dem::walls::Wall;
use std::f64::consts::PI;

pub fn material(e_pa: f64, nu: f64) -> ElasticMaterial {
    ElasticMaterial {
        youngs_modulus_pa: e_pa,
        poisson_ratio: nu,
    }
}

pub fn params(e: f64, mu: f64, mu_r: f64, gamma: f64) -> PairParameters {
    PairParameters {
        restitution: e,
        static_friction: mu,
        rolling_friction: mu_r,
        surface_energy_j_m2: gamma,
    }
}

/// One particle material and one (rigid unless given) wall material with the
/// same parameters.
pub fn contact(
    normal: NormalChoice,
    rolling: RollingChoice,
    m: ElasticMaterial,
    p: PairParameters,
) -> ContactSetup {
    ContactSetup {
        normal,
        rolling,
        clip_tensile: false,
        particle_material: m,
        particle_particle: p,
        wall_materials: vec![(ElasticMaterial::RIGID, p)],
    }
}

/// The automatic step (0.2 T_R, ≥ 20 steps per contact at `speed`) for spheres
/// of radius `r` and density `rho` against rigid walls.
pub fn auto_dt(c: &ContactSetup, r: f64, rho: f64, speed: f64) -> f64 {
    let m = rho * 4.0 / 3.0 * PI * r * r * r;
    choose_time_step(&TimeStepRequest {
        min_radius_m: r,
        density_kg_m3: rho,
        material: c.particle_material,
        rayleigh_fraction: 0.2,
        design_speed_m_s: speed,
        stiffest: StiffestContact {
            e_star_pa: effective_youngs_modulus(&c.particle_material, &ElasticMaterial::RIGID),
            r_star_m: r,
            m_star_kg: m,
        },
        requested_dt_s: None,
    })
    .unwrap()
    .dt_s
}

pub fn setup(
    contact: ContactSetup,
    rho: f64,
    gravity: bool,
    dt: f64,
    skin: f64,
) -> SimulationSetup {
    SimulationSetup {
        contact,
        density_kg_m3: rho,
        gravity_m_s2: gravity.then(|| Vec3::new(0.0, 0.0, -9.81)),
        dt_s: dt,
        skin_m: skin,
        health: HealthLimits::default(),
    }
}

/// SplitMix64: a tiny deterministic generator for test jitter.
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Spheres of radius `r` on an `n[0]×n[1]×n[2]` lattice with `spacing`,
/// lowest-left centre at `origin`, each jittered by up to `jitter` per axis.
pub fn lattice(
    n: [usize; 3],
    spacing: f64,
    origin: Vec3,
    r: f64,
    jitter: f64,
    velocity: Vec3,
) -> Vec<ParticleInit> {
    let mut rng = SplitMix(42);
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut p = origin + Vec3::new(i as f64, j as f64, k as f64) * spacing;
                for c in p.iter_mut() {
                    *c += jitter * (2.0 * rng.unit() - 1.0);
                }
                out.push(ParticleInit {
                    position: p,
                    velocity,
                    angular_velocity: Vec3::zeros(),
                    radius_m: r,
                });
            }
        }
    }
    out
}

pub fn world(particles: &[ParticleInit], rho: f64, walls: Vec<Wall>, lo: Vec3, hi: Vec3) -> World {
    let mut p = Particles::default();
    for q in particles {
        p.push(q, rho);
    }
    World::new(p, walls, Domain::new(lo, hi, [false; 3]).unwrap())
}

pub fn all_finite(w: &World) -> bool {
    let p = &w.particles;
    (0..p.len()).all(|i| {
        p.position[i].iter().all(|c| c.is_finite())
            && p.velocity[i].iter().all(|c| c.is_finite())
            && p.angular_velocity[i].iter().all(|c| c.is_finite())
    })
}
