//! Rules for experiments and for the parts studies share with them (materials and
//! pair parameters).

use std::collections::BTreeMap;

use super::checker::{join, number, string, Checker, Interval};
use super::scene::check_scene;
use crate::manifest::experiment::{
    AtRest, CoarseGraining, ContactModel, Experiment, Material, NormalModel, PairParams,
    ParticleShape, RollingModel, SizeDistribution, TimeStep, WallStiffness,
};
use crate::manifest::{Scene, PHYSICS_VERSION, SCHEMA_VERSION};

/// Poisson ratios allowed for isotropic elastic materials.
const POISSON: Interval = Interval {
    lo: -1.0,
    lo_closed: false,
    hi: 0.5,
    hi_closed: true,
};

/// Checks every field of an experiment.
pub(crate) fn check_experiment(c: &mut Checker, e: &Experiment) {
    check_schema_version(c, "schema_version", e.schema_version);
    if e.physics_version != PHYSICS_VERSION {
        c.fail(
            "physics_version",
            e.physics_version.to_string(),
            format!(
                "must equal this engine's physics version {PHYSICS_VERSION} \
                 (the manifest was made for another engine; regenerate it)"
            ),
        );
    }
    check_material(c, "material", &e.material);
    check_pair_params(
        c,
        "contact.particle_particle",
        &e.contact.particle_particle,
        &e.contact.model,
        "contact.model",
    );
    for (wall, params) in &e.contact.particle_wall {
        let path = join("contact.particle_wall", wall);
        if !e.material.walls.contains_key(wall) {
            c.fail(
                &path,
                string(wall),
                "must name a wall material defined in material.walls",
            );
        }
        check_pair_params(c, &path, params, &e.contact.model, "contact.model");
    }
    check_scene(c, "scene", &e.scene, &e.material);
    check_scene_walls_have_params(c, "scene", &e.scene, &e.contact.particle_wall);
    check_time_step(c, "time_step", &e.time_step);
    check_at_rest(c, "at_rest", &e.at_rest);
    if matches!(e.scene, Scene::Pair(_)) && !e.at_rest.is_default() {
        c.fail(
            "at_rest",
            "(present)".into(),
            "must be absent for a pair scene (it has no settling phase)",
        );
    }
    if let Some(cg) = &e.coarse_graining {
        check_coarse_graining(c, "coarse_graining", cg);
        if matches!(e.scene, Scene::Pair(_)) {
            c.fail(
                "coarse_graining",
                "(present)".into(),
                "must be absent for a pair scene (its radii are the simulated ones)",
            );
        }
    }
}

/// Checks a coarse-graining block (also used by studies).
pub(crate) fn check_coarse_graining(c: &mut Checker, path: &str, cg: &CoarseGraining) {
    c.within(
        &join(path, "size_factor"),
        cg.size_factor,
        Interval {
            lo: 1.0,
            lo_closed: true,
            hi: 1000.0,
            hi_closed: true,
        },
    );
    c.within(
        &join(path, "youngs_modulus_factor"),
        cg.youngs_modulus_factor,
        Interval::open_closed(0.0, 1.0),
    );
}

/// Requires the schema version this build reads.
pub(crate) fn check_schema_version(c: &mut Checker, path: &str, v: u32) {
    if v != SCHEMA_VERSION {
        c.fail(
            path,
            v.to_string(),
            format!("must be {SCHEMA_VERSION} (the schema this build reads)"),
        );
    }
}

/// Checks particle and wall materials.
pub(crate) fn check_material(c: &mut Checker, path: &str, m: &Material) {
    let p = join(path, "particle");
    let particle = &m.particle;
    c.positive(&join(&p, "density_kg_m3"), particle.density_kg_m3);
    c.positive(&join(&p, "youngs_modulus_pa"), particle.youngs_modulus_pa);
    c.within(&join(&p, "poisson_ratio"), particle.poisson_ratio, POISSON);
    check_size(c, &join(&p, "size"), &particle.size);
    if let Some(shape) = &particle.shape {
        check_shape(c, &join(&p, "shape"), shape);
    }
    for (name, wall) in &m.walls {
        let wp = join(&join(path, "walls"), name);
        check_wall_name(c, &wp, name);
        if let WallStiffness::Elastic(e) = wall.youngs_modulus_pa {
            c.positive(&join(&wp, "youngs_modulus_pa"), e);
        }
        c.within(&join(&wp, "poisson_ratio"), wall.poisson_ratio, POISSON);
        c.positive(&join(&wp, "density_kg_m3"), wall.density_kg_m3);
    }
}

/// Wall material names become path segments and parameter addresses, so they are
/// restricted to letters, digits, `_` and `-`.
fn check_wall_name(c: &mut Checker, path: &str, name: &str) {
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-');
    if !ok {
        c.fail(
            path,
            string(name),
            "wall material names must be non-empty and use only letters, digits, '_' and '-'",
        );
    }
}

/// Most member spheres a clump shape may have (the engine's bound).
const MAX_CLUMP_MEMBERS: usize = 64;

/// Checks a clump shape's numbers; whether its members form one connected
/// union is checked when a scene builds it (the message names the members).
fn check_shape(c: &mut Checker, path: &str, shape: &ParticleShape) {
    match shape {
        ParticleShape::PairedSpheres { aspect_ratio } => {
            let a = *aspect_ratio;
            if !(a > 1.0 && a < 2.0) {
                c.fail(
                    &join(path, "aspect_ratio"),
                    a.to_string(),
                    "must lie in (1, 2): 1 is a sphere, 2 two spheres touching at a point",
                );
            }
        }
        ParticleShape::Clump { members } => {
            if members.is_empty() || members.len() > MAX_CLUMP_MEMBERS {
                c.fail(
                    &join(path, "members"),
                    format!("{} members", members.len()),
                    format!("must list 1 to {MAX_CLUMP_MEMBERS} member spheres"),
                );
            }
            for (i, m) in members.iter().enumerate() {
                c.positive(&format!("{path}.members[{i}].radius"), m.radius);
                if m.offset.iter().any(|x| !x.is_finite()) {
                    c.fail(
                        &format!("{path}.members[{i}].offset"),
                        format!("{:?}", m.offset),
                        "must be three finite numbers",
                    );
                }
            }
        }
    }
}

fn check_size(c: &mut Checker, path: &str, size: &SizeDistribution) {
    match size {
        SizeDistribution::Monodisperse { radius_m } => {
            c.positive(&join(path, "radius_m"), *radius_m)
        }
        SizeDistribution::List { radii_m, weights } => {
            if radii_m.is_empty() {
                c.fail(
                    &join(path, "radii_m"),
                    "[]".into(),
                    "must list at least one radius",
                );
            }
            if radii_m.len() != weights.len() {
                c.fail(
                    &join(path, "weights"),
                    format!("{} entries", weights.len()),
                    format!("must have one weight per radius ({} radii)", radii_m.len()),
                );
            }
            for (i, r) in radii_m.iter().enumerate() {
                c.positive(&format!("{path}.radii_m[{i}]"), *r);
            }
            for (i, w) in weights.iter().enumerate() {
                c.positive(&format!("{path}.weights[{i}]"), *w);
            }
        }
        SizeDistribution::D10D50D90 {
            d10_m,
            d50_m,
            d90_m,
        } => {
            c.positive(&join(path, "d10_m"), *d10_m);
            c.positive(&join(path, "d50_m"), *d50_m);
            c.positive(&join(path, "d90_m"), *d90_m);
            if d50_m <= d10_m {
                c.fail(
                    &join(path, "d50_m"),
                    number(*d50_m),
                    format!("must be > d10_m = {}", number(*d10_m)),
                );
            }
            if d90_m <= d50_m {
                c.fail(
                    &join(path, "d90_m"),
                    number(*d90_m),
                    format!("must be > d50_m = {}", number(*d50_m)),
                );
            }
        }
    }
}

/// Checks one pair-parameter set against the contact model (`model_path` names the
/// model in the document, for the consistency messages).
pub(crate) fn check_pair_params(
    c: &mut Checker,
    path: &str,
    p: &PairParams,
    model: &ContactModel,
    model_path: &str,
) {
    check_pair_field(
        c,
        &join(path, "restitution"),
        "restitution",
        p.restitution,
        model,
        model_path,
    );
    check_pair_field(
        c,
        &join(path, "static_friction"),
        "static_friction",
        p.static_friction,
        model,
        model_path,
    );
    check_pair_field(
        c,
        &join(path, "rolling_friction"),
        "rolling_friction",
        p.rolling_friction,
        model,
        model_path,
    );
    check_pair_field(
        c,
        &join(path, "surface_energy_j_m2"),
        "surface_energy_j_m2",
        p.surface_energy_j_m2,
        model,
        model_path,
    );
}

/// Checks one pair-parameter value: restitution in (0, 1], the others ≥ 0; a
/// parameter of a switched-off law must be 0 so that equal physics has one id.
pub(crate) fn check_pair_field(
    c: &mut Checker,
    path: &str,
    field: &str,
    v: f64,
    model: &ContactModel,
    model_path: &str,
) {
    if field == "restitution" {
        c.within(path, v, Interval::open_closed(0.0, 1.0));
        return;
    }
    c.non_negative(path, v);
    if field == "surface_energy_j_m2" && model.normal == NormalModel::Hertz && v != 0.0 {
        c.fail(
            path,
            number(v),
            format!("must be 0 when {model_path}.normal = \"hertz\" (Hertz has no surface energy)"),
        );
    }
    if field == "rolling_friction" && model.rolling == RollingModel::None && v != 0.0 {
        c.fail(
            path,
            number(v),
            format!("must be 0 when {model_path}.rolling = \"none\""),
        );
    }
}

/// Every wall material a scene uses must be defined and have particle–wall parameters.
pub(crate) fn check_scene_walls_have_params(
    c: &mut Checker,
    scene_path: &str,
    scene: &crate::manifest::Scene,
    particle_wall: &BTreeMap<String, PairParams>,
) {
    for (field, name) in scene.wall_materials() {
        if !particle_wall.contains_key(name) {
            c.fail(
                &join(scene_path, field),
                string(name),
                "has no particle-wall contact parameters (add them under contact.particle_wall)",
            );
        }
    }
}

/// Checks the time-step rule.
pub(crate) fn check_time_step(c: &mut Checker, path: &str, t: &TimeStep) {
    c.within(
        &join(path, "rayleigh_fraction"),
        t.rayleigh_fraction,
        Interval::open_closed(0.0, 0.5),
    );
    c.positive(
        &join(path, "design_impact_speed_m_s"),
        t.design_impact_speed_m_s,
    );
}

/// Checks the stop criterion of settling phases.
fn check_at_rest(c: &mut Checker, path: &str, r: &AtRest) {
    c.within(
        &join(path, "kinetic_energy_fraction"),
        r.kinetic_energy_fraction,
        Interval::open_closed(0.0, 1.0),
    );
    c.positive(&join(path, "hold_s"), r.hold_s);
}
