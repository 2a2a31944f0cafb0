//! The size levels of a convergence sweep: the base experiment with its
//! particles scaled, each level run with replicates (packing seeds).
//!
//! A level is a size factor f relative to the base's simulated particle
//! (1 = the base, 0.5 = half its radius). How f is applied:
//! - **a base with coarse graining** (`coarse_graining.size_factor` k over a
//!   real particle): the simulated particle is k·f times the real one, and
//!   the surface energy follows the manifest's own rule (he2019's cohesion
//!   number, cai2024's Γ ∝ size); the real particle is the manifest's.
//! - **a base that states its simulated particle directly** (no coarse
//!   graining, e.g. he2019-quick's 3 mm spheres standing in for a 0.125 mm
//!   powder): every radius of the size distribution is scaled by f and every
//!   surface energy (particle–particle and particle–wall) by f^p, p from the
//!   [`SurfaceEnergyRule`] (default: constant Bond number, p = 2).
//!
//! Everything else (densities, moduli, friction, restitution, the scene's
//! geometry and times, the time-step rule) is unchanged, so a level differs
//! from the base only in its particle size and what must follow it. Level
//! f = 1 with the base's packing seed *is* the base experiment (same id),
//! so the base's cached runs are reused. Replicate r has packing seed
//! base + r, as in the tradeoff sweep.

use serde::Serialize;

use crate::manifest::{
    validate_experiment, CoarseGrainingRule, Experiment, SizeDistribution, ValidationErrors,
};
use crate::study::sweeps::tradeoff::plan::{replicate, Point};

/// How the surface energy follows the particle radius R when a base without
/// coarse graining is scaled: Γ ∝ R^p.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceEnergyRule {
    /// p = 2: the JKR pull-off force (1.5 π Γ R*) over the particle's weight
    /// (∝ ρ g R³), the granular Bond number, stays constant: cohesion
    /// matters to the bulk as much at every size. The default.
    ConstantBond,
    /// p = 1: Γ/R* constant (cai2024 §1.2, after Feng & Loughran).
    Proportional,
    /// p = 2/5: he2019 Eq. 2's cohesion number as printed, at a fixed modulus.
    CohesionNumber,
    /// p = 0: the surface energy stays as stated.
    Fixed,
}

/// Names of the rules, as the command line and reports write them.
pub const RULE_NAMES: [&str; 4] = ["constant_bond", "proportional", "cohesion_number", "fixed"];

impl SurfaceEnergyRule {
    /// The rule the project's convergence sweeps support best (Γ ∝ R: the
    /// funnel's angle moves least across sizes under it; evidence and
    /// sources in experiments/funnel_pile/README.md): the default wherever a
    /// size changes and no rule is stated.
    pub const MEASURED: SurfaceEnergyRule = SurfaceEnergyRule::Proportional;

    /// The rule named `name` (one of [`RULE_NAMES`]).
    pub fn parse(name: &str) -> Option<SurfaceEnergyRule> {
        Some(match name {
            "constant_bond" => SurfaceEnergyRule::ConstantBond,
            "proportional" => SurfaceEnergyRule::Proportional,
            "cohesion_number" => SurfaceEnergyRule::CohesionNumber,
            "fixed" => SurfaceEnergyRule::Fixed,
            _ => return None,
        })
    }

    /// The exponent p of Γ ∝ R^p.
    pub fn exponent(self) -> f64 {
        match self {
            SurfaceEnergyRule::ConstantBond => 2.0,
            SurfaceEnergyRule::Proportional => 1.0,
            SurfaceEnergyRule::CohesionNumber => 0.4,
            SurfaceEnergyRule::Fixed => 0.0,
        }
    }

    /// The rule of a manifest's `coarse_graining.rule` (or a study's
    /// `transfer.rule`), which names the same three scalings.
    pub fn of_manifest(rule: CoarseGrainingRule) -> SurfaceEnergyRule {
        match rule {
            CoarseGrainingRule::ConstantBond => SurfaceEnergyRule::ConstantBond,
            CoarseGrainingRule::SurfaceEnergyProportional => SurfaceEnergyRule::Proportional,
            CoarseGrainingRule::CohesionNumber => SurfaceEnergyRule::CohesionNumber,
        }
    }

    /// The name in [`RULE_NAMES`].
    pub fn name(self) -> &'static str {
        match self {
            SurfaceEnergyRule::ConstantBond => RULE_NAMES[0],
            SurfaceEnergyRule::Proportional => RULE_NAMES[1],
            SurfaceEnergyRule::CohesionNumber => RULE_NAMES[2],
            SurfaceEnergyRule::Fixed => RULE_NAMES[3],
        }
    }
}

/// Why a sweep could not be planned.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A size factor that is not a positive finite number.
    #[error("size factor {0:?}: must be a finite number > 0 (1 = the base's particle)")]
    Factor(f64),
    /// The same size factor twice.
    #[error("size factor {0} is listed twice")]
    Duplicate(f64),
    /// Fewer than two levels: there is no trend to fit.
    #[error("{0} size level(s): at least 2 are needed for a trend (3 or more for its scatter)")]
    Levels(usize),
    /// Fewer than two replicates per level: no interval.
    #[error("replicates = {0}: must be at least 2 (a confidence interval needs two runs)")]
    Replicates(usize),
    /// A surface-energy rule given for a base with coarse graining, whose
    /// manifest rule already says how Γ follows the size.
    #[error(
        "--rule {0}: the base manifest has coarse_graining, whose own rule scales the \
         surface energy; leave --rule out"
    )]
    RuleWithCoarseGraining(&'static str),
    /// A pair scene: two particles have no angle whose convergence a sweep
    /// could measure.
    #[error(
        "the base manifest is a pair scene, which has no angle of repose to converge; \
         convergence sweeps a lab scene (funnel_pile, baffle_lift, drum, hopper, static_pile)"
    )]
    PairScene,
    /// A real particle radius that is not a positive finite number at most
    /// the largest swept radius.
    #[error(
        "--real-radius {0:?}: must be a finite number > 0 and at most the largest swept \
         radius, {1:?} m (the real powder is the finer end the sweep extrapolates to)"
    )]
    RealRadius(f64, f64),
    /// A level is not a valid experiment (e.g. a coarse-graining factor
    /// below 1, a slice thinner than the neighbour search allows).
    #[error("size factor {factor}: {errors}")]
    Invalid {
        /// The level.
        factor: f64,
        /// What validation said.
        errors: ValidationErrors,
    },
}

/// One size level: its factor, its simulated particle and its runs.
#[derive(Debug, Clone)]
pub struct Level {
    /// Size factor relative to the base's simulated particle.
    pub factor: f64,
    /// Nominal simulated particle radius, m (the radius of a monodisperse
    /// material, the number-weighted mean of a list, d50/2; times the
    /// coarse-graining factor).
    pub radius_m: f64,
    /// The level as a sweep point (`size=f`) with one experiment per replicate.
    pub point: Point,
}

/// The sweep: levels coarsest first, and what the real particle is.
#[derive(Debug, Clone)]
pub struct SizePlan {
    /// The levels, coarsest (largest factor) first.
    pub levels: Vec<Level>,
    /// The rule applied (`None`: the base's coarse graining decides).
    pub rule: Option<SurfaceEnergyRule>,
    /// The real particle's nominal radius, m, when known (the manifest's
    /// radius under coarse graining, or the caller's).
    pub real_radius_m: Option<f64>,
}

/// Plans `factors` × `replicates` around `base` (see the module docs).
/// `rule` applies only to a base without coarse graining (default
/// [`SurfaceEnergyRule::ConstantBond`]); `real_radius_m` is the real
/// particle's radius for such a base (ignored with coarse graining, whose
/// manifest radius is the real one).
pub fn plan(
    base: &Experiment,
    factors: &[f64],
    replicates: usize,
    rule: Option<SurfaceEnergyRule>,
    real_radius_m: Option<f64>,
) -> Result<SizePlan, PlanError> {
    if matches!(base.scene, crate::manifest::Scene::Pair(_)) {
        return Err(PlanError::PairScene);
    }
    if replicates < 2 {
        return Err(PlanError::Replicates(replicates));
    }
    if let Some(&f) = factors.iter().find(|f| !(f.is_finite() && **f > 0.0)) {
        return Err(PlanError::Factor(f));
    }
    let mut sorted = factors.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(PlanError::Duplicate(w[0]));
    }
    if sorted.len() < 2 {
        return Err(PlanError::Levels(sorted.len()));
    }
    let nominal = crate::study::stages::sensitivity::parameters::nominal_radius_m;
    let (rule, real_radius_m) = match (&base.coarse_graining, rule) {
        (Some(_), Some(r)) => return Err(PlanError::RuleWithCoarseGraining(r.name())),
        (Some(_), None) => (None, Some(nominal(&base.material.particle.size))),
        (None, r) => (
            Some(r.unwrap_or(SurfaceEnergyRule::ConstantBond)),
            real_radius_m,
        ),
    };
    let levels = sorted
        .into_iter()
        .map(|factor| {
            let e = scaled(base, factor, rule)
                .map_err(|errors| PlanError::Invalid { factor, errors })?;
            let k = e.coarse_graining.map_or(1.0, |cg| cg.size_factor);
            Ok(Level {
                factor,
                radius_m: nominal(&e.material.particle.size) * k,
                point: Point {
                    knob: "size",
                    value: Some(factor),
                    replicates: replicate(&e, replicates),
                },
            })
        })
        .collect::<Result<Vec<_>, PlanError>>()?;
    let largest = levels.iter().map(|l| l.radius_m).fold(0.0, f64::max);
    if let Some(r) = real_radius_m.filter(|r| !(r.is_finite() && *r > 0.0 && *r <= largest)) {
        return Err(PlanError::RealRadius(r, largest));
    }
    Ok(SizePlan {
        levels,
        rule,
        real_radius_m,
    })
}

/// `base` at size factor `f`, validated. A factor of exactly 1 leaves every
/// number as it is (so the id is the base's).
pub(crate) fn scaled(
    base: &Experiment,
    f: f64,
    rule: Option<SurfaceEnergyRule>,
) -> Result<Experiment, ValidationErrors> {
    let mut e = base.clone();
    if f != 1.0 {
        match (&mut e.coarse_graining, rule) {
            (Some(cg), _) => cg.size_factor *= f,
            (None, rule) => {
                scale_sizes(&mut e.material.particle.size, f);
                let gamma = f.powf(rule.map_or(0.0, SurfaceEnergyRule::exponent));
                e.contact.particle_particle.surface_energy_j_m2 *= gamma;
                for pair in e.contact.particle_wall.values_mut() {
                    pair.surface_energy_j_m2 *= gamma;
                }
            }
        }
    }
    validate_experiment(&e)?;
    Ok(e)
}

/// Every length of a size distribution × `f`.
fn scale_sizes(size: &mut SizeDistribution, f: f64) {
    match size {
        SizeDistribution::Monodisperse { radius_m } => *radius_m *= f,
        SizeDistribution::List { radii_m, .. } => radii_m.iter_mut().for_each(|r| *r *= f),
        SizeDistribution::D10D50D90 {
            d10_m,
            d50_m,
            d90_m,
        } => {
            *d10_m *= f;
            *d50_m *= f;
            *d90_m *= f;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_experiment;

    fn funnel() -> Experiment {
        parse_experiment(include_str!(
            "../../../../experiments/funnel_pile/quick.json"
        ))
        .unwrap()
    }

    /// The base level is the base experiment (same ids, seeds base, base + 1,
    /// …); a finer level scales the radius and Γ by f² (constant Bond) and
    /// nothing else; levels come coarsest first whatever the order given.
    #[test]
    fn levels_scale_the_particle_and_keep_the_base_ids() {
        let base = funnel();
        let plan = plan(&base, &[0.5, 1.0, 0.75], 3, None, Some(0.000125)).unwrap();
        let factors: Vec<f64> = plan.levels.iter().map(|l| l.factor).collect();
        assert_eq!(factors, [1.0, 0.75, 0.5]);
        assert_eq!(plan.levels[0].point.replicates[0].id(), base.id());
        let seeds: Vec<u64> = plan.levels[2]
            .point
            .replicates
            .iter()
            .map(|e| e.seeds.packing_seed)
            .collect();
        assert_eq!(seeds, [0, 1, 2]);
        let fine = &plan.levels[2].point.replicates[0];
        assert_eq!(
            fine.material.particle.size,
            SizeDistribution::Monodisperse { radius_m: 0.0015 }
        );
        assert_eq!(plan.levels[2].radius_m, 0.0015);
        let gamma = fine.contact.particle_particle.surface_energy_j_m2;
        assert!((gamma - 0.05 * 0.25).abs() < 1e-15, "{gamma}");
        let mut back = fine.clone();
        back.material.particle.size = base.material.particle.size.clone();
        back.contact.particle_particle.surface_energy_j_m2 =
            base.contact.particle_particle.surface_energy_j_m2;
        back.seeds = base.seeds;
        assert_eq!(back, base, "only the size and Γ differ");
        // The same plan again: the same experiments (deterministic).
        let again = super::plan(&base, &[1.0, 0.75, 0.5], 3, None, Some(0.000125)).unwrap();
        for (a, b) in plan.levels.iter().zip(&again.levels) {
            let ids = |l: &Level| {
                l.point
                    .replicates
                    .iter()
                    .map(|e| e.id())
                    .collect::<Vec<_>>()
            };
            assert_eq!(ids(a), ids(b));
        }
    }

    /// Issue 54 (low): a pair scene and a real radius of 1e300 m were
    /// accepted.
    #[test]
    fn pair_scenes_and_impossible_real_radii_are_refused() {
        let pair = parse_experiment(include_str!(
            "../../../../experiments/validation/pair_hertz_particle_particle.json"
        ))
        .unwrap();
        assert!(matches!(
            plan(&pair, &[1.0, 0.5], 2, None, None),
            Err(PlanError::PairScene)
        ));
        let base =
            parse_experiment(include_str!("../../../../experiments/drum/smoke.json")).unwrap();
        for r in [1e300, 0.0, -1.0, f64::NAN] {
            let e = plan(&base, &[1.0, 0.5], 2, None, Some(r)).unwrap_err();
            assert!(matches!(e, PlanError::RealRadius(..)), "{r}: {e}");
        }
        assert!(plan(&base, &[1.0, 0.5], 2, None, Some(1e-4)).is_ok());
    }

    /// Under coarse graining the factor multiplies k and the manifest's rule
    /// stays; a --rule is refused, as is a level below k = 1.
    #[test]
    fn coarse_grained_bases_scale_k() {
        let text = include_str!("../../../../experiments/funnel_pile/quick.json")
            .replace("\"radius_m\": 0.003", "\"radius_m\": 0.000125");
        let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
        doc["coarse_graining"] =
            serde_json::json!({"size_factor": 24.0, "rule": "cohesion_number"});
        let base = parse_experiment(&doc.to_string()).unwrap();
        let p = plan(&base, &[1.0, 0.5], 2, None, None).unwrap();
        let cg = p.levels[1].point.replicates[0].coarse_graining.unwrap();
        assert_eq!(cg.size_factor, 12.0);
        assert_eq!(p.real_radius_m, Some(0.000125));
        assert!((p.levels[1].radius_m - 0.0015).abs() < 1e-15);
        assert!(matches!(
            plan(&base, &[1.0, 0.5], 2, Some(SurfaceEnergyRule::Fixed), None),
            Err(PlanError::RuleWithCoarseGraining("fixed"))
        ));
        assert!(matches!(
            plan(&base, &[1.0, 0.01], 2, None, None),
            Err(PlanError::Invalid { factor, .. }) if factor == 0.01
        ));
    }

    #[test]
    fn bad_sweeps_are_refused() {
        let base = funnel();
        assert!(matches!(
            plan(&base, &[1.0, 0.5], 1, None, None),
            Err(PlanError::Replicates(1))
        ));
        assert!(matches!(
            plan(&base, &[1.0], 2, None, None),
            Err(PlanError::Levels(1))
        ));
        assert!(matches!(
            plan(&base, &[1.0, 1.0], 2, None, None),
            Err(PlanError::Duplicate(_))
        ));
        assert!(matches!(
            plan(&base, &[1.0, -0.5], 2, None, None),
            Err(PlanError::Factor(_))
        ));
        assert_eq!(
            SurfaceEnergyRule::parse("constant_bond"),
            Some(SurfaceEnergyRule::ConstantBond)
        );
        assert_eq!(SurfaceEnergyRule::parse("bond"), None);
    }
}
