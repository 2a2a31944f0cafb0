//! Building experiments from a study: calibrated values at a design point plus the
//! fixed ones, only the walls the scene uses, seeds from the study.

mod common;

use std::collections::BTreeMap;

use repose::manifest::{parse_study, Study, PHYSICS_VERSION};

fn he2019() -> Study {
    parse_study(&common::text("experiments/he2019/study.json")).unwrap()
}

fn midpoint(s: &Study) -> BTreeMap<String, f64> {
    s.parameters
        .iter()
        .map(|(a, r)| (a.clone(), (r.min + r.max) / 2.0))
        .collect()
}

#[test]
fn a_design_point_becomes_a_valid_experiment() {
    let s = he2019();
    let drum = &s.verification[1].scene;
    let e = s.experiment(drum, &midpoint(&s), 7).unwrap();
    assert_eq!(e.physics_version, PHYSICS_VERSION);
    assert_eq!(
        (
            e.seeds.design_seed,
            e.seeds.sample_index,
            e.seeds.packing_seed
        ),
        (2019, 7, 1)
    );
    let pp = e.contact.particle_particle;
    assert_eq!(
        (
            pp.restitution,
            pp.static_friction,
            pp.surface_energy_j_m2,
            pp.rolling_friction
        ),
        (0.3, 0.525, 5.5, 0.001)
    );
    // The drum is Plexiglas only: steel parameters would change the id for nothing.
    assert_eq!(
        e.contact.particle_wall.keys().collect::<Vec<_>>(),
        ["plexiglas"]
    );
    let pw = e.contact.particle_wall["plexiglas"];
    assert_eq!(
        (
            pw.restitution,
            pw.static_friction,
            pw.rolling_friction,
            pw.surface_energy_j_m2
        ),
        (0.35, 1.5, 0.001, 0.0)
    );
}

#[test]
fn the_wildcard_sets_every_wall_the_scene_uses() {
    let s = he2019();
    let e = s
        .experiment(&s.calibration.scene, &midpoint(&s), 0)
        .unwrap();
    for wall in ["steel", "plexiglas"] {
        assert_eq!(e.contact.particle_wall[wall].static_friction, 1.5, "{wall}");
    }
}

#[test]
fn a_point_must_give_exactly_the_calibrated_parameters() {
    let s = he2019();
    let mut point = midpoint(&s);
    point.remove("particle_particle.restitution");
    point.insert("particle_particle.rolling_friction".into(), 0.1);
    let err = s
        .experiment(&s.calibration.scene, &point, 0)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("point.particle_particle.restitution = (absent)"),
        "{err}"
    );
    assert!(
        err.contains("point.particle_particle.rolling_friction = (present)"),
        "{err}"
    );
}

#[test]
fn a_point_outside_the_allowed_range_is_refused() {
    let s = he2019();
    let mut point = midpoint(&s);
    point.insert("particle_particle.restitution".into(), 1.5);
    let err = s
        .experiment(&s.calibration.scene, &point, 0)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("contact.particle_particle.restitution = 1.5: must be in (0, 1]"),
        "{err}"
    );
}
