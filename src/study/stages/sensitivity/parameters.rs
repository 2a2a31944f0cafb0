//! Which study factors are contact parameters, and the particle–particle
//! contact of a generated experiment as [`PairSpec`] for the sensitivity
//! levels 2 and 3.
//!
//! A factor is a contact parameter when its address is one of the
//! particle–particle parameters (`contact.particle_particle.restitution`,
//! `.static_friction`, `.rolling_friction`) or the particle's Young's
//! modulus (`material.particle.youngs_modulus_pa`). Other factors (a wall's
//! friction, a scene knob) have no place in the contact-law sensitivities and
//! are listed as such. The pair is built from the experiment's *nominal*
//! material (the manifest's particle, before coarse graining: yan2015's
//! R = 1 mm, E = 0.02 GPa), because level 3 is an a-priori analysis of the
//! material's contact law, not of the simulated stand-in.

use crate::dem::contact::sensitivity::{PairSpec, Parameter, Rolling};
use crate::manifest::{Experiment, NormalModel, RollingModel, SizeDistribution};

/// The contact parameter a factor address sets, if it is one.
pub fn parameter_of(address: &str) -> Option<Parameter> {
    match address {
        "contact.particle_particle.restitution" => Some(Parameter::Restitution),
        "contact.particle_particle.static_friction" => Some(Parameter::StaticFriction),
        "contact.particle_particle.rolling_friction" => Some(Parameter::RollingFriction),
        "material.particle.youngs_modulus_pa" => Some(Parameter::YoungsModulus),
        _ => None,
    }
}

/// The nominal particle radius of a size distribution, m: the radius of a
/// monodisperse material, the number-weighted mean of a list, half the d50
/// of a percentile description.
pub fn nominal_radius_m(size: &SizeDistribution) -> f64 {
    match size {
        SizeDistribution::Monodisperse { radius_m } => *radius_m,
        SizeDistribution::List { radii_m, weights } => {
            let total: f64 = weights.iter().sum();
            radii_m.iter().zip(weights).map(|(r, w)| r * w).sum::<f64>() / total
        }
        SizeDistribution::D10D50D90 { d50_m, .. } => 0.5 * d50_m,
    }
}

/// The particle–particle contact of `experiment` (see the module docs), or
/// why it has no analytic sensitivities (the JKR law is not covered).
pub fn pair_spec(experiment: &Experiment) -> Result<PairSpec, String> {
    if experiment.contact.model.normal == NormalModel::Jkr {
        return Err(
            "the contact-law sensitivities cover the Hertz normal law; this study's \
             contact.model.normal is jkr"
                .into(),
        );
    }
    let p = &experiment.material.particle;
    let pp = &experiment.contact.particle_particle;
    Ok(PairSpec {
        radius_m: nominal_radius_m(&p.size),
        density_kg_m3: p.density_kg_m3,
        youngs_modulus_pa: p.youngs_modulus_pa,
        poisson_ratio: p.poisson_ratio,
        restitution: pp.restitution,
        static_friction: pp.static_friction,
        rolling_friction: pp.rolling_friction,
        rolling: match experiment.contact.model.rolling {
            RollingModel::None => Rolling::None,
            RollingModel::Cdt => Rolling::Cdt,
            RollingModel::Epsd => Rolling::Epsd,
        },
    })
}
