//! One rejecting test per validation rule: each edits a valid example and asserts
//! the report names the field path (and, for the rule the issue spells out, the
//! exact message).

mod common;

use common::{edit, pair_jkr, pair_wall, study};
use repose::manifest::{parse_document, validate_experiment, ManifestError};
use serde_json::{json, Value};

/// Every error line of `doc`, which must be rejected by validation.
fn errors(doc: &Value) -> Vec<String> {
    match parse_document(&doc.to_string(), None) {
        Err(ManifestError::Invalid(e)) => e.0.iter().map(ToString::to_string).collect(),
        Err(other) => panic!("expected validation errors, got: {other}"),
        Ok(_) => panic!("expected a rejection of {doc}"),
    }
}

/// Asserts one error line starts with `path = ` and contains `fragment`.
fn assert_rejects(doc: Value, path: &str, fragment: &str) {
    let errors = errors(&doc);
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with(&format!("{path} = ")) && e.contains(fragment)),
        "no error for `{path}` containing `{fragment}` in {errors:#?}"
    );
}

macro_rules! reject {
    ($name:ident, $base:expr, $pointer:expr, $value:expr, $path:expr, $fragment:expr) => {
        #[test]
        fn $name() {
            assert_rejects(edit($base, $pointer, $value), $path, $fragment);
        }
    };
}

// The message format of the issue, verbatim.
#[test]
fn restitution_above_one_reads_exactly_as_specified() {
    let doc = edit(
        pair_wall(),
        "/contact/particle_particle/restitution",
        Some(json!(1.3)),
    );
    assert!(errors(&doc)
        .contains(&"contact.particle_particle.restitution = 1.3: must be in (0, 1]".to_string()));
}

#[test]
fn several_errors_are_reported_together() {
    let doc = edit(
        pair_wall(),
        "/contact/particle_particle/restitution",
        Some(json!(1.3)),
    );
    let doc = edit(doc, "/scene/radius_m", Some(json!(-1)));
    let doc = edit(doc, "/time_step/rayleigh_fraction", Some(json!(0.9)));
    assert_eq!(errors(&doc).len(), 3, "{:#?}", errors(&doc));
}

// --- experiment: versions
reject!(
    schema_version_must_match,
    pair_wall(),
    "/schema_version",
    Some(json!(2)),
    "schema_version",
    "must be 1"
);
reject!(
    physics_version_must_match,
    pair_wall(),
    "/physics_version",
    Some(json!(99)),
    "physics_version",
    "physics version 1"
);

// --- particle material
reject!(
    particle_density_positive,
    pair_wall(),
    "/material/particle/density_kg_m3",
    Some(json!(0)),
    "material.particle.density_kg_m3",
    "> 0"
);
reject!(
    particle_modulus_positive,
    pair_wall(),
    "/material/particle/youngs_modulus_pa",
    Some(json!(-1e9)),
    "material.particle.youngs_modulus_pa",
    "> 0"
);
reject!(
    particle_poisson_range,
    pair_wall(),
    "/material/particle/poisson_ratio",
    Some(json!(0.6)),
    "material.particle.poisson_ratio",
    "(-1, 0.5]"
);
reject!(
    monodisperse_radius_positive,
    pair_wall(),
    "/material/particle/size/radius_m",
    Some(json!(0)),
    "material.particle.size.radius_m",
    "> 0"
);
reject!(
    list_needs_a_radius,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "list", "radii_m": [], "weights": []})),
    "material.particle.size.radii_m",
    "at least one"
);
reject!(
    list_weights_match_radii,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "list", "radii_m": [0.001, 0.002], "weights": [1]})),
    "material.particle.size.weights",
    "one weight per radius"
);
reject!(
    list_radii_positive,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "list", "radii_m": [-0.001], "weights": [1]})),
    "material.particle.size.radii_m[0]",
    "> 0"
);
reject!(
    list_weights_positive,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "list", "radii_m": [0.001], "weights": [0]})),
    "material.particle.size.weights[0]",
    "> 0"
);
reject!(
    percentiles_increase,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "d10_d50_d90", "d10_m": 2e-6, "d50_m": 1e-6, "d90_m": 7e-6})),
    "material.particle.size.d50_m",
    "> d10_m"
);
reject!(
    percentiles_positive,
    pair_wall(),
    "/material/particle/size",
    Some(json!({"kind": "d10_d50_d90", "d10_m": -1e-6, "d50_m": 4e-6, "d90_m": 7e-6})),
    "material.particle.size.d10_m",
    "> 0"
);

// --- wall materials
reject!(
    wall_modulus_positive,
    pair_wall(),
    "/material/walls/rigid/youngs_modulus_pa",
    Some(json!(0)),
    "material.walls.rigid.youngs_modulus_pa",
    "> 0"
);
reject!(
    wall_poisson_range,
    pair_wall(),
    "/material/walls/rigid/poisson_ratio",
    Some(json!(-1)),
    "material.walls.rigid.poisson_ratio",
    "(-1, 0.5]"
);
reject!(
    wall_density_positive,
    pair_wall(),
    "/material/walls/rigid/density_kg_m3",
    Some(json!(0)),
    "material.walls.rigid.density_kg_m3",
    "> 0"
);
reject!(
    wall_names_are_plain,
    pair_wall(),
    "/material/walls/a.b",
    Some(json!({"youngs_modulus_pa": 1e9, "poisson_ratio": 0.3, "density_kg_m3": 1000})),
    "material.walls.a.b",
    "letters, digits"
);

// --- contact parameters
reject!(
    restitution_positive,
    pair_wall(),
    "/contact/particle_particle/restitution",
    Some(json!(0)),
    "contact.particle_particle.restitution",
    "(0, 1]"
);
reject!(
    static_friction_non_negative,
    pair_wall(),
    "/contact/particle_wall/rigid/static_friction",
    Some(json!(-0.1)),
    "contact.particle_wall.rigid.static_friction",
    ">= 0"
);
reject!(
    rolling_friction_non_negative,
    pair_wall(),
    "/contact/particle_particle/rolling_friction",
    Some(json!(-1)),
    "contact.particle_particle.rolling_friction",
    ">= 0"
);
reject!(
    surface_energy_non_negative,
    pair_jkr(),
    "/contact/particle_particle/surface_energy_j_m2",
    Some(json!(-0.05)),
    "contact.particle_particle.surface_energy_j_m2",
    ">= 0"
);
reject!(
    hertz_has_no_surface_energy,
    pair_wall(),
    "/contact/particle_particle/surface_energy_j_m2",
    Some(json!(0.05)),
    "contact.particle_particle.surface_energy_j_m2",
    "must be 0 when contact.model.normal = \"hertz\""
);
reject!(
    no_rolling_law_no_rolling_friction,
    pair_wall(),
    "/contact/particle_particle/rolling_friction",
    Some(json!(0.01)),
    "contact.particle_particle.rolling_friction",
    "must be 0 when contact.model.rolling = \"none\""
);
reject!(
    particle_wall_names_a_defined_wall,
    pair_wall(),
    "/contact/particle_wall/glass",
    Some(
        json!({"restitution": 0.5, "static_friction": 0.3, "rolling_friction": 0, "surface_energy_j_m2": 0})
    ),
    "contact.particle_wall.glass",
    "defined in material.walls"
);
reject!(
    scene_wall_has_contact_params,
    pair_wall(),
    "/contact/particle_wall/rigid",
    None,
    "scene.partner.material",
    "no particle-wall contact parameters"
);
reject!(
    scene_wall_is_defined,
    pair_wall(),
    "/scene/partner/material",
    Some(json!("glass")),
    "scene.partner.material",
    "defined in material.walls"
);

// --- time step
reject!(
    rayleigh_fraction_range,
    pair_wall(),
    "/time_step/rayleigh_fraction",
    Some(json!(0.6)),
    "time_step.rayleigh_fraction",
    "(0, 0.5]"
);
reject!(
    design_speed_positive,
    pair_wall(),
    "/time_step/design_impact_speed_m_s",
    Some(json!(0)),
    "time_step.design_impact_speed_m_s",
    "> 0"
);

// --- pair scene
reject!(
    pair_radius_positive,
    pair_wall(),
    "/scene/radius_m",
    Some(json!(0)),
    "scene.radius_m",
    "> 0"
);
reject!(
    pair_partner_radius_positive,
    pair_jkr(),
    "/scene/partner/radius_m",
    Some(json!(-0.001)),
    "scene.partner.radius_m",
    "> 0"
);
reject!(
    pair_normal_speed_non_negative,
    pair_jkr(),
    "/scene/normal_velocity_m_s",
    Some(json!(-1)),
    "scene.normal_velocity_m_s",
    ">= 0"
);
reject!(
    pair_impact_needs_approach,
    pair_wall(),
    "/scene/normal_velocity_m_s",
    Some(json!(0)),
    "scene.normal_velocity_m_s",
    "impact mode"
);
reject!(
    pair_tangential_non_negative,
    pair_wall(),
    "/scene/tangential_velocity_m_s",
    Some(json!(-1)),
    "scene.tangential_velocity_m_s",
    ">= 0"
);
reject!(
    pair_separation_needs_pull_speed,
    pair_jkr(),
    "/scene/pull_speed_m_s",
    None,
    "scene.pull_speed_m_s",
    "required in separation mode"
);
reject!(
    pair_pull_speed_positive,
    pair_jkr(),
    "/scene/pull_speed_m_s",
    Some(json!(0)),
    "scene.pull_speed_m_s",
    "> 0"
);
reject!(
    pair_max_time_positive,
    pair_wall(),
    "/scene/max_time_s",
    Some(json!(0)),
    "scene.max_time_s",
    "> 0"
);

#[test]
fn pair_angular_velocity_finite() {
    // JSON cannot spell NaN, so this rule guards programmatic construction.
    let mut e: repose::manifest::Experiment = serde_json::from_value(pair_wall()).unwrap();
    if let repose::manifest::Scene::Pair(p) = &mut e.scene {
        p.angular_velocity_rad_s[1] = f64::NAN;
    }
    let errors = validate_experiment(&e).unwrap_err().to_string();
    assert!(
        errors.contains("scene.angular_velocity_rad_s[1] = NaN: must be a finite number"),
        "{errors}"
    );
}

// --- lab scenes (inside the study, so they also check the study's scene paths)
const FUNNEL: &str = "/calibration/scene";
const BAFFLE: &str = "/verification/0/scene";
const DRUM: &str = "/verification/1/scene";

fn with_scene(pointer: &str, scene: Value) -> Value {
    edit(study(), pointer, Some(scene))
}

fn hopper() -> Value {
    json!({"kind": "hopper", "diameter_m": 0.05, "height_m": 0.07, "orifice_diameter_m": 0.015, "drop_height_m": 0.07,
           "plate_diameter_m": 0.2, "packing_fraction": 0.567, "no_discharge_stop_s": 0.5, "max_time_s": 10,
           "hopper_material": "steel", "plate_material": "steel"})
}

fn static_pile() -> Value {
    json!({"kind": "static_pile", "cone_angle_deg": 60, "funnel_top_diameter_m": 0.06, "outlet_diameter_m": 0.005,
           "outlet_height_m": 0.08, "disk_diameter_m": 0.08, "particle_count": 20000, "insertion_rate_per_s": 5000,
           "settle_time_s": 1, "funnel_material": "steel", "disk_material": "steel"})
}

reject!(
    funnel_outlet_narrower_than_top,
    study(),
    "/calibration/scene/funnel_outlet_diameter_m",
    Some(json!(0.2)),
    "calibration.scene.funnel_outlet_diameter_m",
    "< funnel_top_diameter_m"
);
reject!(
    funnel_tilt_range,
    study(),
    "/calibration/scene/outlet_tilt_deg",
    Some(json!(90)),
    "calibration.scene.outlet_tilt_deg",
    "[0, 90)"
);
reject!(
    funnel_fill_below_packing_limit,
    study(),
    "/calibration/scene/fill_fraction",
    Some(json!(0.7)),
    "calibration.scene.fill_fraction",
    "(0, 0.64)"
);
reject!(
    funnel_time_left_to_discharge,
    study(),
    "/calibration/scene/total_time_s",
    Some(json!(4)),
    "calibration.scene.total_time_s",
    "no time left"
);
reject!(
    funnel_brush_speed_positive,
    study(),
    "/calibration/scene/brush_rpm",
    Some(json!(0)),
    "calibration.scene.brush_rpm",
    "> 0"
);
reject!(
    funnel_geometry_positive,
    study(),
    "/calibration/scene/platform_diameter_m",
    Some(json!(-0.094)),
    "calibration.scene.platform_diameter_m",
    "> 0"
);
reject!(
    baffle_powder_fits_the_box,
    study(),
    "/verification/0/scene/powder_mass_kg",
    Some(json!(0.015)),
    "verification[0].scene.powder_mass_kg",
    "packing limit"
);
reject!(
    baffle_lift_speed_positive,
    study(),
    "/verification/0/scene/lift_speed_m_s",
    Some(json!(0)),
    "verification[0].scene.lift_speed_m_s",
    "> 0"
);
reject!(
    drum_fill_range,
    study(),
    "/verification/1/scene/fill_fraction",
    Some(json!(1)),
    "verification[1].scene.fill_fraction",
    "(0, 1)"
);
reject!(
    drum_rpm_positive,
    study(),
    "/verification/1/scene/rpm",
    Some(json!(0)),
    "verification[1].scene.rpm",
    "> 0"
);
reject!(
    drum_wall_defined,
    study(),
    "/verification/1/scene/wall_material",
    Some(json!("glass")),
    "verification[1].scene.wall_material",
    "defined in material.walls"
);
reject!(
    hopper_orifice_narrower_than_hopper,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/orifice_diameter_m",
    Some(json!(0.06)),
    "verification[1].scene.orifice_diameter_m",
    "< diameter_m"
);
reject!(
    hopper_packing_below_limit,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/packing_fraction",
    Some(json!(0.65)),
    "verification[1].scene.packing_fraction",
    "(0, 0.64)"
);
reject!(
    hopper_stop_time_positive,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/no_discharge_stop_s",
    Some(json!(0)),
    "verification[1].scene.no_discharge_stop_s",
    "> 0"
);
reject!(
    static_pile_cone_angle_range,
    with_scene(BAFFLE, static_pile()),
    "/verification/0/scene/cone_angle_deg",
    Some(json!(180)),
    "verification[0].scene.cone_angle_deg",
    "(0, 180)"
);
reject!(
    static_pile_needs_particles,
    with_scene(BAFFLE, static_pile()),
    "/verification/0/scene/particle_count",
    Some(json!(0)),
    "verification[0].scene.particle_count",
    "> 0"
);
reject!(
    static_pile_outlet_narrower_than_top,
    with_scene(BAFFLE, static_pile()),
    "/verification/0/scene/outlet_diameter_m",
    Some(json!(0.07)),
    "verification[0].scene.outlet_diameter_m",
    "< funnel_top_diameter_m"
);

#[test]
fn hopper_and_static_pile_examples_are_valid() {
    let doc = with_scene(DRUM, hopper());
    let doc = edit(doc, BAFFLE, Some(static_pile()));
    let doc = edit(doc, FUNNEL, Some(hopper()));
    parse_document(&doc.to_string(), None).unwrap();
}

// --- study
reject!(
    study_name_non_empty,
    study(),
    "/name",
    Some(json!(" ")),
    "name",
    "non-empty"
);
reject!(
    study_parameter_address_known,
    study(),
    "/parameters/particle_particle.stiffness",
    Some(json!({"min": 0, "max": 1})),
    "parameters.particle_particle.stiffness",
    "must address a contact parameter"
);
reject!(
    study_parameter_wall_defined,
    study(),
    "/parameters/particle_wall.glass.restitution",
    Some(json!({"min": 0.1, "max": 0.5})),
    "parameters.particle_wall.glass.restitution",
    "defined in material.walls"
);
reject!(
    study_range_ordered,
    study(),
    "/parameters/particle_particle.restitution",
    Some(json!({"min": 0.5, "max": 0.1})),
    "parameters.particle_particle.restitution.min",
    "must be < max"
);
reject!(
    study_range_inside_field_range,
    study(),
    "/parameters/particle_particle.restitution",
    Some(json!({"min": 0.5, "max": 1.5})),
    "parameters.particle_particle.restitution.max",
    "(0, 1]"
);
reject!(
    study_fixed_inside_field_range,
    study(),
    "/fixed/particle_particle.rolling_friction",
    Some(json!(-0.001)),
    "fixed.particle_particle.rolling_friction",
    ">= 0"
);
reject!(
    study_parameter_set_once,
    study(),
    "/fixed/particle_particle.restitution",
    Some(json!(0.5)),
    "fixed.particle_particle.restitution",
    "already sets"
);

/// A wall material named for a field is set by that address, and `*` covers
/// the other walls (a funnel's brush with its own restitution beside one
/// calibrated e_pw): not a double setting.
#[test]
fn study_named_wall_overrides_the_star() {
    let doc = edit(
        study(),
        "/fixed/particle_wall.steel.restitution",
        Some(json!(0.5)),
    );
    let parsed = parse_document(&doc.to_string(), None);
    assert!(parsed.is_ok(), "{:?}", parsed.err().map(|e| e.to_string()));
    // Named twice (calibrated and fixed) is still refused.
    let twice = edit(
        edit(
            doc,
            "/parameters/particle_wall.steel.restitution",
            Some(json!({"min": 0.1, "max": 0.6})),
        ),
        "/fixed/particle_particle.restitution",
        None,
    );
    let errors = errors(&twice);
    assert!(
        errors.iter().any(|e| e.contains("already sets")),
        "{errors:#?}"
    );
}
reject!(
    study_every_parameter_given,
    study(),
    "/fixed/particle_particle.rolling_friction",
    None,
    "fixed.particle_particle.rolling_friction",
    "must be fixed here or calibrated"
);
reject!(
    study_calibrates_something,
    edit(study(), "/parameters", Some(json!({}))),
    "/fixed/particle_particle.restitution",
    Some(json!(0.3)),
    "parameters",
    "at least one"
);
reject!(
    study_target_scene_is_a_lab_scene,
    study(),
    "/calibration/scene",
    Some(pair_wall()["scene"].clone()),
    "calibration.scene.kind",
    "lab scene"
);
reject!(
    study_target_angle_range,
    study(),
    "/calibration/target_angle_deg",
    Some(json!(90)),
    "calibration.target_angle_deg",
    "(0, 90)"
);
reject!(
    study_tolerance_range,
    study(),
    "/verification/1/tolerance_fraction",
    Some(json!(0)),
    "verification[1].tolerance_fraction",
    "(0, 1)"
);
reject!(
    study_target_name_non_empty,
    study(),
    "/verification/0/name",
    Some(json!("")),
    "verification[0].name",
    "non-empty"
);
reject!(
    study_lhs_size,
    study(),
    "/design/size",
    Some(json!(1)),
    "design.size",
    ">= 2"
);
reject!(
    study_factorial_levels,
    edit(study(), "/design/kind", Some(json!("full_factorial"))),
    "/design/size",
    Some(json!(1)),
    "design.size",
    "levels per parameter"
);
reject!(
    study_box_behnken_parameter_count,
    edit(study(), "/design/kind", Some(json!("box_behnken"))),
    "/parameters",
    Some(json!({"particle_particle.restitution": {"min": 0.1, "max": 0.5}})),
    "design.kind",
    "at least 3"
);
reject!(
    study_material_checked,
    study(),
    "/material/particle/poisson_ratio",
    Some(json!(0.5000001)),
    "material.particle.poisson_ratio",
    "(-1, 0.5]"
);
reject!(
    study_time_step_checked,
    study(),
    "/time_step/rayleigh_fraction",
    Some(json!(0)),
    "time_step.rayleigh_fraction",
    "(0, 0.5]"
);
reject!(
    study_schema_version,
    study(),
    "/schema_version",
    Some(json!(0)),
    "schema_version",
    "must be 1"
);
reject!(
    study_hertz_has_no_surface_energy,
    edit(study(), "/contact_model/normal", Some(json!("hertz"))),
    "/name",
    Some(json!("he2019-hertz")),
    "parameters.particle_particle.surface_energy_j_m2.min",
    "must be 0 when contact_model.normal = \"hertz\""
);

// --- parse errors carry line and column
#[test]
fn malformed_json_reports_line_and_column() {
    let err =
        parse_document("{\n  \"schema_version\": 1,\n  \"scene\": [1,,]\n}", None).unwrap_err();
    match err {
        ManifestError::Syntax { line, column, .. } => assert_eq!((line, column), (3, 15)),
        other => panic!("expected a syntax error, got {other}"),
    }
}

#[test]
fn unknown_fields_report_their_name_and_position() {
    let text =
        serde_json::to_string_pretty(&edit(pair_wall(), "/seeds/lucky", Some(json!(7)))).unwrap();
    let err = parse_document(&text, None).unwrap_err();
    assert!(
        matches!(err, ManifestError::Syntax { line, .. } if line > 1),
        "{err}"
    );
    assert!(err.to_string().contains("unknown field `lucky`"), "{err}");
}

#[test]
fn wrong_types_are_reported() {
    let err = parse_document(
        &edit(pair_wall(), "/seeds/packing_seed", Some(json!(-1))).to_string(),
        None,
    )
    .unwrap_err();
    assert!(matches!(err, ManifestError::Syntax { .. }), "{err}");
}

#[test]
fn a_document_of_unknown_kind_is_refused() {
    assert!(matches!(
        parse_document("{\"x\": 1}", None),
        Err(ManifestError::UnknownKind)
    ));
    assert!(matches!(
        parse_document("[1]", None),
        Err(ManifestError::UnknownKind)
    ));
}

// --- coarse graining
fn coarse(size_factor: f64, youngs_modulus_factor: f64) -> Option<Value> {
    Some(
        json!({"size_factor": size_factor, "youngs_modulus_factor": youngs_modulus_factor,
                "rule": "cohesion_number"}),
    )
}

reject!(
    coarse_graining_size_factor_at_least_one,
    study(),
    "/coarse_graining",
    coarse(0.5, 1.0),
    "coarse_graining.size_factor",
    "must be in [1, 1000]"
);
reject!(
    coarse_graining_modulus_factor_at_most_one,
    study(),
    "/coarse_graining",
    coarse(4.0, 2.0),
    "coarse_graining.youngs_modulus_factor",
    "must be in (0, 1]"
);
reject!(
    coarse_graining_not_for_pair_scenes,
    pair_wall(),
    "/coarse_graining",
    coarse(2.0, 1.0),
    "coarse_graining",
    "must be absent for a pair scene"
);

// --- hopper scene: the optional fields added with its simulation
reject!(
    hopper_fill_height_fits_the_hopper,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/fill_height_m",
    Some(json!(0.08)),
    "verification[1].scene.fill_height_m",
    "must be <= height_m = 0.07"
);
reject!(
    hopper_fill_height_positive,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/fill_height_m",
    Some(json!(0)),
    "verification[1].scene.fill_height_m",
    "> 0"
);
reject!(
    hopper_settle_max_positive,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/settle_max_s",
    Some(json!(-1)),
    "verification[1].scene.settle_max_s",
    "> 0"
);
reject!(
    hopper_sample_interval_range,
    with_scene(DRUM, hopper()),
    "/verification/1/scene/sample_interval_s",
    Some(json!(0.1)),
    "verification[1].scene.sample_interval_s",
    "(0, 0.05]"
);
// --- at_rest: the stop criterion of settling phases
fn drum() -> Value {
    common::example("drum/smoke.json")
}

reject!(
    at_rest_fraction_positive,
    drum(),
    "/at_rest",
    Some(json!({"kinetic_energy_fraction": 0, "hold_s": 0.05})),
    "at_rest.kinetic_energy_fraction",
    "must be in (0, 1]"
);
reject!(
    at_rest_fraction_at_most_one,
    drum(),
    "/at_rest",
    Some(json!({"kinetic_energy_fraction": 2})),
    "at_rest.kinetic_energy_fraction",
    "must be in (0, 1]"
);
reject!(
    at_rest_hold_positive,
    drum(),
    "/at_rest",
    Some(json!({"hold_s": -0.01})),
    "at_rest.hold_s",
    "must be a finite number > 0"
);
reject!(
    at_rest_not_for_pair_scenes,
    pair_wall(),
    "/at_rest",
    Some(json!({"hold_s": 0.1})),
    "at_rest",
    "must be absent for a pair scene"
);

#[test]
fn at_rest_fields_default_separately_and_unknown_ones_are_refused() {
    let hold_only = edit(drum(), "/at_rest", Some(json!({"hold_s": 0.2})));
    let e = repose::manifest::parse_experiment(&hold_only.to_string()).unwrap();
    assert_eq!(e.at_rest.hold_s, 0.2);
    assert_eq!(
        e.at_rest.kinetic_energy_fraction,
        repose::manifest::experiment::DEFAULT_REST_ENERGY_FRACTION
    );
    let typo = edit(drum(), "/at_rest", Some(json!({"hold": 0.2})));
    let err = parse_document(&typo.to_string(), None).unwrap_err();
    assert!(err.to_string().contains("unknown field `hold`"), "{err}");
}

// --- drum end walls: only a full drum has them
#[test]
fn fixed_end_walls_on_a_periodic_slice_read_as_specified() {
    // drum/smoke.json simulates a 9 mm periodic slice: no end walls to fix.
    let doc = edit(drum(), "/scene/end_walls", Some(json!("fixed")));
    let errors = errors(&doc);
    assert!(
        errors.contains(
            &"scene.end_walls = \"fixed\": must be left out (or \"rotating\", the default) \
              with periodic_slice_m = 0.009: a periodic slice has no end walls; \"fixed\" needs \
              the full drum (remove periodic_slice_m)"
                .to_string()
        ),
        "{errors:#?}"
    );
}

#[test]
fn end_walls_are_accepted_on_the_full_drum_and_the_default_on_a_slice() {
    let full = edit(drum(), "/scene/periodic_slice_m", None);
    for value in ["fixed", "rotating"] {
        let doc = edit(full.clone(), "/scene/end_walls", Some(json!(value)));
        parse_document(&doc.to_string(), None).unwrap_or_else(|e| panic!("{value}: {e}"));
    }
    // A spelled-out default is the manifest without the field (same id).
    let slice = edit(drum(), "/scene/end_walls", Some(json!("rotating")));
    parse_document(&slice.to_string(), None).unwrap();
    // Any other value is refused naming the two allowed.
    let glass = edit(full, "/scene/end_walls", Some(json!("glass")));
    let err = parse_document(&glass.to_string(), None)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("unknown variant `glass`, expected `rotating` or `fixed`"),
        "{err}"
    );
}

// --- static pile: insertion and sampling intervals
reject!(
    static_pile_insertion_interval_positive,
    with_scene(BAFFLE, static_pile()),
    "/verification/0/scene/insertion_interval_s",
    Some(json!(0)),
    "verification[0].scene.insertion_interval_s",
    "> 0"
);
reject!(
    static_pile_samples_at_insertion_windows,
    with_scene(BAFFLE, static_pile()),
    "/verification/0/scene/sample_interval_s",
    Some(json!(0.001)),
    "verification[0].scene.sample_interval_s",
    ">= insertion_interval_s = 0.01"
);

// --- baffle_lift optional fields
reject!(
    baffle_slice_within_the_box_width,
    study(),
    "/verification/0/scene/periodic_slice_m",
    Some(json!(0.07)),
    "verification[0].scene.periodic_slice_m",
    "<= box_width_m = 0.06"
);
reject!(
    baffle_slice_positive,
    study(),
    "/verification/0/scene/periodic_slice_m",
    Some(json!(0)),
    "verification[0].scene.periodic_slice_m",
    "> 0"
);
reject!(
    baffle_floor_overhang_positive,
    study(),
    "/verification/0/scene/floor_overhang_m",
    Some(json!(-0.01)),
    "verification[0].scene.floor_overhang_m",
    "> 0"
);
reject!(
    baffle_settle_max_positive,
    study(),
    "/verification/0/scene/settle_max_s",
    Some(json!(0)),
    "verification[0].scene.settle_max_s",
    "> 0"
);
reject!(
    baffle_sample_interval_at_most_50_ms,
    study(),
    "/verification/0/scene/sample_interval_s",
    Some(json!(0.1)),
    "verification[0].scene.sample_interval_s",
    "(0, 0.05]"
);

// --- funnel_pile fields added with the simulated scene (issue 4)
reject!(
    funnel_tube_length_positive,
    study(),
    "/calibration/scene/outlet_tube_length_m",
    Some(json!(0)),
    "calibration.scene.outlet_tube_length_m",
    "> 0"
);
reject!(
    funnel_tube_clears_the_platform,
    study(),
    "/calibration/scene/outlet_tube_length_m",
    Some(json!(0.07)),
    "calibration.scene.outlet_height_m",
    "the tube would reach the platform"
);
reject!(
    funnel_brush_blade_count,
    study(),
    "/calibration/scene/brush_blades",
    Some(json!(9)),
    "calibration.scene.brush_blades",
    "1 to 8"
);
reject!(
    funnel_brush_gap_non_negative,
    study(),
    "/calibration/scene/brush_gap_m",
    Some(json!(-0.001)),
    "calibration.scene.brush_gap_m",
    ">= 0"
);
reject!(
    funnel_brush_width_positive,
    study(),
    "/calibration/scene/brush_width_m",
    Some(json!(0)),
    "calibration.scene.brush_width_m",
    "> 0"
);
reject!(
    funnel_brush_inside_the_funnel,
    study(),
    "/calibration/scene/brush_width_m",
    Some(json!(0.06)),
    "calibration.scene.brush_width_m",
    "brush_gap_m + brush_width_m < funnel_top_diameter_m / 2"
);
reject!(
    funnel_fill_height_within_the_cone,
    study(),
    "/calibration/scene/fill_height_m",
    Some(json!(0.2)),
    "calibration.scene.fill_height_m",
    "(0, 0.095]"
);
reject!(
    funnel_sample_interval_positive,
    study(),
    "/calibration/scene/sample_interval_s",
    Some(json!(0)),
    "calibration.scene.sample_interval_s",
    "> 0"
);

#[test]
fn funnel_brush_settings_need_a_brush() {
    let doc = edit(study(), "/calibration/scene/brush_rpm", None);
    let doc = edit(doc, "/calibration/scene/brush_gap_m", Some(json!(0.002)));
    assert_rejects(doc, "calibration.scene.brush_gap_m", "requires brush_rpm");
}
