//! Translating an experiment's materials, contact parameters and time-step
//! settings into the engine's and the packing module's types: the one place
//! manifests meet `dem`.
//!
//! Coarse graining happens here and nowhere else: with a `coarse_graining`
//! block, [`size_distribution`] returns the simulated (scaled) sizes,
//! [`particle_material`] the simulated modulus and [`contact_setup`] the
//! simulated surface energies, so scenes never see the real particle.

use super::SceneError;
use crate::dem::clump::template::{ClumpShape, ClumpTemplate, Member};
use crate::dem::contact::PairParameters;
use crate::dem::material::{effective_youngs_modulus, ElasticMaterial};
use crate::dem::simulation::{ContactSetup, NormalChoice, RollingChoice};
use crate::dem::timestep::{
    choose_time_step, StiffestContact, TimeStepError, TimeStepPlan, TimeStepRequest,
};
use crate::dem::vec3::Vec3;
use crate::manifest::{
    CoarseGrainingRule, Experiment, NormalModel, PairParams, ParticleShape, RollingModel,
    SizeDistribution, WallMaterial, WallStiffness,
};
use crate::packing::coarse::{
    coarse_grain, effective_modulus, surface_energy_factor, CohesionState, ScalingRule,
};
use crate::packing::distribution::SizeDistribution as PackingSizes;
use crate::packing::PackingError;
use crate::store::CoarseGrainingReport;
use std::f64::consts::PI;

/// Standard gravity, m/s² (lab scenes pull along −z with it; pair tests when asked).
pub const STANDARD_GRAVITY_M_S2: f64 = 9.81;

/// The factors coarse graining applies: (size, Young's modulus, surface energy);
/// all 1 without a `coarse_graining` block.
fn scale_factors(exp: &Experiment) -> (f64, f64, f64) {
    match &exp.coarse_graining {
        None => (1.0, 1.0, 1.0),
        Some(cg) => (
            cg.size_factor,
            cg.youngs_modulus_factor,
            surface_energy_factor(
                scaling_rule(cg.rule),
                cg.size_factor,
                cg.youngs_modulus_factor,
            ),
        ),
    }
}

fn scaling_rule(rule: CoarseGrainingRule) -> ScalingRule {
    match rule {
        CoarseGrainingRule::SurfaceEnergyProportional => ScalingRule::SurfaceEnergyProportional,
        CoarseGrainingRule::CohesionNumber => ScalingRule::CohesionNumber,
        CoarseGrainingRule::ConstantBond => ScalingRule::ConstantBond,
    }
}

/// The particle material as the engine sees it (simulated modulus).
pub fn particle_material(exp: &Experiment) -> ElasticMaterial {
    ElasticMaterial {
        youngs_modulus_pa: exp.material.particle.youngs_modulus_pa * scale_factors(exp).1,
        poisson_ratio: exp.material.particle.poisson_ratio,
    }
}

/// What coarse graining did, for result.json; `None` without a
/// `coarse_graining` block. Cohesion numbers are he2019 Eq. 2 for a pair of
/// representative particles (R* = r/2).
pub fn coarse_graining_report(exp: &Experiment) -> Option<CoarseGrainingReport> {
    let cg = exp.coarse_graining.as_ref()?;
    let (_, d_real) = diameter_bounds(&real_sizes(exp)).ok()?;
    let particle = &exp.material.particle;
    let e_real = particle.youngs_modulus_pa;
    let real = CohesionState {
        surface_energy_j_m2: exp.contact.particle_particle.surface_energy_j_m2,
        effective_modulus_pa: effective_modulus(
            e_real,
            particle.poisson_ratio,
            e_real,
            particle.poisson_ratio,
        ),
        effective_radius_m: 0.25 * d_real,
        density_kg_m3: particle.density_kg_m3,
    };
    let scaled = coarse_grain(
        &real,
        scaling_rule(cg.rule),
        cg.size_factor,
        cg.youngs_modulus_factor,
        STANDARD_GRAVITY_M_S2,
    )
    .ok()?;
    let rule = serde_json::to_value(cg.rule)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default();
    Some(CoarseGrainingReport {
        rule,
        size_factor: cg.size_factor,
        youngs_modulus_factor: cg.youngs_modulus_factor,
        surface_energy_factor: scale_factors(exp).2,
        real_radius_m: 0.5 * d_real,
        simulated_radius_m: 0.5 * d_real * cg.size_factor,
        real_youngs_modulus_pa: e_real,
        simulated_youngs_modulus_pa: e_real * cg.youngs_modulus_factor,
        real_surface_energy_j_m2: real.surface_energy_j_m2,
        simulated_surface_energy_j_m2: scaled.after.surface_energy_j_m2,
        real_cohesion_number: scaled.coh_before,
        simulated_cohesion_number: scaled.coh_after,
    })
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

fn pair_parameters(p: &PairParams, surface_energy_factor: f64) -> PairParameters {
    PairParameters {
        restitution: p.restitution,
        static_friction: p.static_friction,
        rolling_friction: p.rolling_friction,
        surface_energy_j_m2: p.surface_energy_j_m2 * surface_energy_factor,
    }
}

/// The contact setup, with wall material `k` of the engine being `walls[k]`
/// (names of `material.walls`; validation guarantees each exists and has
/// particle–wall parameters).
pub fn contact_setup(exp: &Experiment, walls: &[&str]) -> ContactSetup {
    let c = &exp.contact;
    let gamma_factor = scale_factors(exp).2;
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
        particle_particle: pair_parameters(&c.particle_particle, gamma_factor),
        wall_materials: walls
            .iter()
            .map(|name| {
                (
                    wall_material(&exp.material.walls[*name]),
                    pair_parameters(&c.particle_wall[*name], gamma_factor),
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

/// The result's warnings about the time step `plan` after a run whose
/// fastest contact approached at `reached_m_s` (m/s, the engine's
/// [`StepStats::max_approach_speed_m_s`](crate::dem::simulation::StepStats::max_approach_speed_m_s)):
/// one if the step resolved that contact with fewer than the minimum steps
/// (see [`crate::dem::timestep`]), naming the manifest setting that fixes
/// it; none otherwise.
pub fn time_step_warnings(plan: &TimeStepPlan, reached_m_s: f64) -> Vec<String> {
    plan.under_resolved(reached_m_s)
        .map(|w| {
            format!(
                "time_step: {w}; raise time_step.design_impact_speed_m_s to at least {:.3e} m/s",
                w.reached_m_s
            )
        })
        .into_iter()
        .collect()
}

/// The manifest's clump shape at unit volume-equivalent radius (`None` for
/// spheres); an invalid clump (members that do not form one connected
/// union, a member inside another) is an error naming the shape.
pub fn clump_shape(exp: &Experiment) -> Result<Option<ClumpShape>, SceneError> {
    let template = match &exp.material.particle.shape {
        None => return Ok(None),
        Some(ParticleShape::PairedSpheres { aspect_ratio }) => {
            ClumpTemplate::paired_spheres(*aspect_ratio)
        }
        Some(ParticleShape::Clump { members }) => ClumpTemplate::new(
            "clump",
            members
                .iter()
                .map(|m| Member {
                    offset: Vec3::from(m.offset),
                    radius_m: m.radius,
                })
                .collect(),
        ),
    };
    let template = template.map_err(|e| SceneError::Shape(e.to_string()))?;
    Ok(Some(template.shape(1.0)))
}

/// The simulated particle size distribution as the packing module's
/// (diameters; d10/d50/d90 become a truncated log-normal), coarse-grained when
/// the manifest says so.
pub fn size_distribution(exp: &Experiment) -> PackingSizes {
    real_sizes(exp).scaled(scale_factors(exp).0)
}

/// The manifest's (real) size distribution.
fn real_sizes(exp: &Experiment) -> PackingSizes {
    match &exp.material.particle.size {
        SizeDistribution::Monodisperse { radius_m } => PackingSizes::Mono {
            diameter_m: 2.0 * radius_m,
        },
        SizeDistribution::List { radii_m, weights } => PackingSizes::Discrete {
            diameters_m: radii_m.iter().map(|r| 2.0 * r).collect(),
            weights: weights.clone(),
        },
        SizeDistribution::D10D50D90 {
            d10_m,
            d50_m,
            d90_m,
        } => PackingSizes::LogNormal {
            d10_m: *d10_m,
            d50_m: *d50_m,
            d90_m: *d90_m,
        },
    }
}

/// Smallest diameter that can be drawn and a representative diameter (the
/// number-weighted mean of a list, d50 of a log-normal), m.
pub fn diameter_bounds(sizes: &PackingSizes) -> Result<(f64, f64), PackingError> {
    let d_min = sizes.sampler()?.min_diameter();
    let d_mean = match sizes {
        PackingSizes::Mono { diameter_m } => *diameter_m,
        PackingSizes::Discrete {
            diameters_m,
            weights,
        } => {
            let total: f64 = weights.iter().sum();
            diameters_m
                .iter()
                .zip(weights)
                .map(|(d, w)| d * w)
                .sum::<f64>()
                / total
        }
        PackingSizes::LogNormal { d50_m, .. } => *d50_m,
    };
    Ok((d_min, d_mean))
}
