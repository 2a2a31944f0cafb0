//! Translating an experiment's materials, contact parameters and time-step
//! settings into the engine's types: the one place manifests meet `dem`.

use crate::dem::contact::PairParameters;
use crate::dem::material::{effective_youngs_modulus, ElasticMaterial};
use crate::dem::simulation::{ContactSetup, NormalChoice, RollingChoice};
use crate::dem::timestep::{
    choose_time_step, StiffestContact, TimeStepError, TimeStepPlan, TimeStepRequest,
};
use crate::manifest::{
    Experiment, NormalModel, PairParams, RollingModel, WallMaterial, WallStiffness,
};
use std::f64::consts::PI;

/// The particle material as the engine sees it.
pub fn particle_material(exp: &Experiment) -> ElasticMaterial {
    ElasticMaterial {
        youngs_modulus_pa: exp.material.particle.youngs_modulus_pa,
        poisson_ratio: exp.material.particle.poisson_ratio,
    }
}

fn wall_material(w: &WallMaterial) -> ElasticMaterial {
    match w.youngs_modulus_pa {
        WallStiffness::Rigid => ElasticMaterial::RIGID,
        WallStiffness::Elastic(e) => ElasticMaterial {
            youngs_modulus_pa: e,
            poisson_ratio: w.poisson_ratio,
        },
    }
}

fn pair_parameters(p: &PairParams) -> PairParameters {
    PairParameters {
        restitution: p.restitution,
        static_friction: p.static_friction,
        rolling_friction: p.rolling_friction,
        surface_energy_j_m2: p.surface_energy_j_m2,
    }
}

/// The contact setup, with wall material `k` of the engine being `walls[k]`
/// (names of `material.walls`; validation guarantees each exists and has
/// particle–wall parameters).
pub fn contact_setup(exp: &Experiment, walls: &[&str]) -> ContactSetup {
    let c = &exp.contact;
    ContactSetup {
        normal: match c.model.normal {
            NormalModel::Hertz => NormalChoice::Hertz,
            NormalModel::Jkr => NormalChoice::Jkr,
        },
        rolling: match c.model.rolling {
            RollingModel::None => RollingChoice::None,
            RollingModel::Cdt => RollingChoice::Cdt,
            RollingModel::Epsd => RollingChoice::Epsd,
        },
        clip_tensile: c.model.clip_tensile_normal_force,
        particle_material: particle_material(exp),
        particle_particle: pair_parameters(&c.particle_particle),
        wall_materials: walls
            .iter()
            .map(|name| {
                (
                    wall_material(&exp.material.walls[*name]),
                    pair_parameters(&c.particle_wall[*name]),
                )
            })
            .collect(),
    }
}

/// The time step for particles no smaller than `min_radius_m`: the manifest's
/// Rayleigh fraction and design impact speed, resolving both particle–particle
/// and particle–wall contacts (see [`crate::dem::timestep`]).
pub fn time_step(
    exp: &Experiment,
    setup: &ContactSetup,
    min_radius_m: f64,
) -> Result<TimeStepPlan, TimeStepError> {
    let rho = exp.material.particle.density_kg_m3;
    let mass = rho * 4.0 / 3.0 * PI * min_radius_m.powi(3);
    let particle = setup.particle_material;
    let pp = StiffestContact {
        e_star_pa: effective_youngs_modulus(&particle, &particle),
        r_star_m: 0.5 * min_radius_m,
        m_star_kg: 0.5 * mass,
    };
    // The stiffest wall (largest E*) with R* = r and m* = m gives the shortest
    // wall contact; compare contact times through t_c ∝ (m*²/(R*E*²))^{1/5}.
    let stiffest = setup
        .wall_materials
        .iter()
        .map(|(w, _)| StiffestContact {
            e_star_pa: effective_youngs_modulus(&particle, w),
            r_star_m: min_radius_m,
            m_star_kg: mass,
        })
        .chain(std::iter::once(pp))
        .min_by(|a, b| {
            let key = |s: &StiffestContact| {
                s.m_star_kg * s.m_star_kg / (s.r_star_m * s.e_star_pa * s.e_star_pa)
            };
            key(a).total_cmp(&key(b))
        })
        .unwrap_or(pp);
    choose_time_step(&TimeStepRequest {
        min_radius_m,
        density_kg_m3: rho,
        material: particle,
        rayleigh_fraction: exp.time_step.rayleigh_fraction,
        design_speed_m_s: exp.time_step.design_impact_speed_m_s,
        stiffest,
        requested_dt_s: None,
    })
}
