//! Experiment identity: canonical JSON and sha256 ids are invariant under key order,
//! whitespace, number spelling and spelled-out defaults, change whenever a hashed
//! field changes, and are pinned for the example manifests in golden/.

mod common;

use std::collections::BTreeMap;

use common::{edit, json_files, pair_jkr, pair_wall, root};
use proptest::prelude::*;
use repose::manifest::scene::{
    BaffleLiftScene, DrumScene, EndWalls, FunnelPileScene, HopperScene, StaticPileScene,
};
use repose::manifest::{
    canonical_json, parse_document, parse_experiment, AtRest, CoarseGraining, CoarseGrainingRule,
    Contact, ContactModel, ContentId, Experiment, Material, NormalModel, PairMode, PairParams,
    PairScene, ParticleMaterial, Partner, Profile, RollingModel, Scene, Seeds, SizeDistribution,
    TimeStep, WallMaterial, WallStiffness,
};
use serde_json::{json, Value};

fn id_of(text: &str) -> ContentId {
    parse_document(text, None)
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
        .id()
}

/// Writes `v` with every object's keys in reverse order and generous whitespace.
fn scrambled(v: &Value) -> String {
    match v {
        Value::Object(map) => {
            let mut entries: Vec<_> = map.iter().collect();
            entries.reverse();
            let body: Vec<String> = entries
                .into_iter()
                .map(|(k, v)| format!("\n\t{}  :\r\n {}", Value::String(k.clone()), scrambled(v)))
                .collect();
            format!("{{ {} \n}}", body.join(" ,  "))
        }
        Value::Array(items) => format!(
            "[ {} ]",
            items.iter().map(scrambled).collect::<Vec<_>>().join(" , ")
        ),
        scalar => scalar.to_string(),
    }
}

#[test]
fn id_ignores_key_order_and_whitespace() {
    for doc in [pair_wall(), pair_jkr(), common::study()] {
        assert_eq!(id_of(&doc.to_string()), id_of(&scrambled(&doc)));
        assert_eq!(
            id_of(&doc.to_string()),
            id_of(&serde_json::to_string_pretty(&doc).unwrap())
        );
    }
}

#[test]
fn id_ignores_number_spelling_in_float_fields() {
    let base = id_of(&pair_wall().to_string());
    let template = edit(
        pair_wall(),
        "/material/particle/density_kg_m3",
        Some(json!("DENSITY")),
    )
    .to_string();
    let template = template.replace("\"DENSITY\"", "DENSITY");
    for spelling in ["2500", "2500.0", "2.5e3", "2.5E+3", "25e2", "2500.000"] {
        assert_eq!(
            id_of(&template.replace("DENSITY", spelling)),
            base,
            "spelling {spelling}"
        );
    }
    let one = edit(
        pair_wall(),
        "/contact/particle_particle/restitution",
        Some(json!(1.0)),
    )
    .to_string();
    let one_id = id_of(&one);
    for spelling in ["1", "1.0", "1e0", "0.1e1", "10e-1"] {
        let text = one.replace(
            "\"restitution\":1.0",
            &format!("\"restitution\":{spelling}"),
        );
        assert!(
            spelling == "1.0" || text != one,
            "the template must contain the field"
        );
        assert_eq!(id_of(&text), one_id, "spelling {spelling}");
    }
}

#[test]
fn spelled_out_defaults_hash_like_omitted_ones() {
    let full = pair_wall();
    let base = id_of(&full.to_string());
    let lean = edit(full.clone(), "/scene/gravity", None);
    let lean = edit(lean, "/time_step/rayleigh_fraction", None);
    let lean = edit(lean, "/contact/model/clip_tensile_normal_force", None);
    assert_eq!(id_of(&lean.to_string()), base);
    assert_eq!(
        id_of(&edit(full.clone(), "/scene/pull_speed_m_s", Some(Value::Null)).to_string()),
        base
    );
    let rest = json!({"kinetic_energy_fraction": 1e-6, "hold_s": 0.05});
    assert_eq!(id_of(&edit(full, "/at_rest", Some(rest)).to_string()), base);
}

#[test]
fn drum_end_walls_rotating_hash_like_omitted_and_fixed_is_hashed() {
    let full = edit(
        common::example("drum/smoke.json"),
        "/scene/periodic_slice_m",
        None,
    );
    let base = id_of(&full.to_string());
    let rotating = edit(full.clone(), "/scene/end_walls", Some(json!("rotating")));
    assert_eq!(id_of(&rotating.to_string()), base);
    let fixed = edit(full, "/scene/end_walls", Some(json!("fixed")));
    assert_ne!(id_of(&fixed.to_string()), base);
    assert!(
        canonical_json(&parse_experiment(&fixed.to_string()).unwrap())
            .contains(r#""end_walls":"fixed""#)
    );
}

#[test]
fn a_stop_criterion_other_than_the_default_is_hashed() {
    let drum = common::example("drum/smoke.json");
    let base = id_of(&drum.to_string());
    let looser = edit(
        drum,
        "/at_rest",
        Some(json!({"kinetic_energy_fraction": 1e-5})),
    );
    assert_ne!(id_of(&looser.to_string()), base);
}

#[test]
fn canonical_json_is_sorted_compact_and_its_sha256_is_the_id() {
    let e = parse_experiment(&scrambled(&pair_wall())).unwrap();
    let c = canonical_json(&e);
    assert!(!c.contains(' ') && !c.contains('\n'));
    assert!(
        c.starts_with("{\"contact\":{\"model\":{\"clip_tensile_normal_force\":false"),
        "{c}"
    );
    assert!(c.contains("\"youngs_modulus_pa\":100000000.0"), "{c}");
    assert_eq!(ContentId::of_bytes(c.as_bytes()), e.id());
    assert_eq!(e.id().as_str().len(), 64);
}

#[test]
fn negative_zero_hashes_like_zero() {
    let zero = edit(
        pair_wall(),
        "/scene/tangential_velocity_m_s",
        Some(json!(0.0)),
    )
    .to_string();
    let negative = zero.replace(
        "\"tangential_velocity_m_s\":0.0",
        "\"tangential_velocity_m_s\":-0.0",
    );
    assert_ne!(zero, negative);
    assert_eq!(id_of(&zero), id_of(&negative));
}

#[test]
fn the_physics_version_is_hashed() {
    let mut e = parse_experiment(&pair_wall().to_string()).unwrap();
    let before = e.id();
    e.physics_version += 1;
    assert_ne!(e.id(), before);
}

// ---- generated experiments

fn float() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>().prop_filter("finite", |v| v.is_finite()),
        (-1e3..1e3f64),
        (0u32..1000).prop_map(f64::from),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
        Just(5e-324),
        Just(f64::MAX),
    ]
}

fn name() -> impl Strategy<Value = String> {
    "[a-z][a-z0-9_]{0,8}"
}

fn pair_params() -> impl Strategy<Value = PairParams> {
    (float(), float(), float(), float()).prop_map(
        |(restitution, static_friction, rolling_friction, surface_energy_j_m2)| PairParams {
            restitution,
            static_friction,
            rolling_friction,
            surface_energy_j_m2,
        },
    )
}

fn size() -> impl Strategy<Value = SizeDistribution> {
    prop_oneof![
        float().prop_map(|radius_m| SizeDistribution::Monodisperse { radius_m }),
        (
            prop::collection::vec(float(), 0..4),
            prop::collection::vec(float(), 0..4)
        )
            .prop_map(|(radii_m, weights)| SizeDistribution::List { radii_m, weights }),
        (float(), float(), float()).prop_map(|(d10_m, d50_m, d90_m)| SizeDistribution::D10D50D90 {
            d10_m,
            d50_m,
            d90_m
        }),
    ]
}

fn wall() -> impl Strategy<Value = WallMaterial> {
    (
        prop_oneof![
            float().prop_map(WallStiffness::Elastic),
            Just(WallStiffness::Rigid)
        ],
        float(),
        float(),
    )
        .prop_map(
            |(youngs_modulus_pa, poisson_ratio, density_kg_m3)| WallMaterial {
                youngs_modulus_pa,
                poisson_ratio,
                density_kg_m3,
            },
        )
}

fn scene() -> impl Strategy<Value = Scene> {
    let pair = (
        prop_oneof![Just(PairMode::Impact), Just(PairMode::Separation)],
        float(),
        prop_oneof![
            float().prop_map(|radius_m| Partner::Particle { radius_m }),
            name().prop_map(|material| Partner::Wall { material })
        ],
        (float(), float(), [float(), float(), float()]),
        any::<bool>(),
        prop::option::of(float()),
        float(),
    )
        .prop_map(
            |(
                mode,
                radius_m,
                partner,
                (normal_velocity_m_s, tangential_velocity_m_s, angular_velocity_rad_s),
                gravity,
                pull_speed_m_s,
                max_time_s,
            )| {
                Scene::Pair(PairScene {
                    mode,
                    radius_m,
                    partner,
                    normal_velocity_m_s,
                    tangential_velocity_m_s,
                    angular_velocity_rad_s,
                    gravity,
                    pull_speed_m_s,
                    max_time_s,
                })
            },
        );
    let funnel = (
        prop::collection::vec(float(), 11),
        prop::option::of(float()),
        name(),
        name(),
    )
        .prop_map(|(f, brush_rpm, a, b)| {
            Scene::FunnelPile(FunnelPileScene {
                funnel_top_diameter_m: f[0],
                funnel_outlet_diameter_m: f[1],
                funnel_height_m: f[2],
                outlet_tilt_deg: f[3],
                outlet_height_m: f[4],
                outlet_tube_length_m: None,
                platform_diameter_m: f[5],
                brush_rpm,
                brush_blades: None,
                brush_gap_m: None,
                brush_width_m: None,
                brush_material: None,
                fill_fraction: f[6],
                fill_height_m: None,
                fill_time_s: f[7],
                standing_time_s: f[8],
                total_time_s: f[9],
                settle_time_s: f[10],
                sample_interval_s: None,
                funnel_material: a,
                platform_material: b,
            })
        });
    let optional = prop::collection::vec(prop::option::of(float()), 4);
    let baffle =
        (prop::collection::vec(float(), 6), optional, name(), name()).prop_map(|(f, o, a, b)| {
            Scene::BaffleLift(BaffleLiftScene {
                box_length_m: f[0],
                box_width_m: f[1],
                box_height_m: f[2],
                powder_mass_kg: f[3],
                lift_speed_m_s: f[4],
                settle_time_s: f[5],
                box_material: a,
                floor_material: b,
                periodic_slice_m: o[0],
                floor_overhang_m: o[1],
                settle_max_s: o[2],
                sample_interval_s: o[3],
            })
        });
    let end_walls = prop_oneof![Just(EndWalls::Rotating), Just(EndWalls::Fixed)];
    let drum = (prop::collection::vec(float(), 6), name(), end_walls).prop_map(|(f, w, e)| {
        Scene::Drum(DrumScene {
            inner_diameter_m: f[0],
            length_m: f[1],
            fill_fraction: f[2],
            rpm: f[3],
            rotation_time_s: f[4],
            standing_time_s: f[5],
            periodic_slice_m: None,
            end_walls: e,
            settle_max_s: f[0],
            sample_interval_s: f[1],
            wall_material: w,
        })
    });
    let hopper = (prop::collection::vec(float(), 8), name(), name()).prop_map(|(f, a, b)| {
        Scene::Hopper(HopperScene {
            diameter_m: f[0],
            height_m: f[1],
            orifice_diameter_m: f[2],
            drop_height_m: f[3],
            plate_diameter_m: f[4],
            packing_fraction: f[5],
            no_discharge_stop_s: f[6],
            max_time_s: f[7],
            hopper_material: a,
            plate_material: b,
            fill_height_m: None,
            settle_max_s: None,
            sample_interval_s: None,
        })
    });
    let pile = (
        prop::collection::vec(float(), 9),
        any::<u64>(),
        name(),
        name(),
    )
        .prop_map(|(f, particle_count, a, b)| {
            Scene::StaticPile(StaticPileScene {
                cone_angle_deg: f[0],
                funnel_top_diameter_m: f[1],
                outlet_diameter_m: f[2],
                outlet_height_m: f[3],
                disk_diameter_m: f[4],
                particle_count,
                insertion_rate_per_s: f[5],
                settle_time_s: f[6],
                insertion_interval_s: f[7],
                sample_interval_s: f[8],
                funnel_material: a,
                disk_material: b,
            })
        });
    prop_oneof![pair, funnel, baffle, drum, hopper, pile]
}

prop_compose! {
    fn experiment()(
        versions in (any::<u32>(), any::<u32>()),
        profile in prop_oneof![Just(Profile::Smoke), Just(Profile::Quick), Just(Profile::Paper), Just(Profile::Standard)],
        scene in scene(),
        particle in (float(), float(), float(), size()),
        walls in prop::collection::btree_map(name(), wall(), 0..3),
        model in (prop_oneof![Just(NormalModel::Hertz), Just(NormalModel::Jkr)],
                  prop_oneof![Just(RollingModel::None), Just(RollingModel::Cdt), Just(RollingModel::Epsd)], any::<bool>()),
        particle_particle in pair_params(),
        particle_wall in prop::collection::btree_map(name(), pair_params(), 0..3),
        seeds in (any::<u64>(), any::<u64>(), any::<u64>()),
        time_step in (float(), float()),
        coarse in prop::option::of((float(), float(), prop_oneof![
            Just(CoarseGrainingRule::SurfaceEnergyProportional), Just(CoarseGrainingRule::CohesionNumber)])),
        at_rest in (float(), float()),
    ) -> Experiment {
        Experiment {
            schema_version: versions.0,
            physics_version: versions.1,
            profile,
            scene,
            material: Material {
                particle: ParticleMaterial { density_kg_m3: particle.0, youngs_modulus_pa: particle.1, poisson_ratio: particle.2, size: particle.3, shape: None },
                walls,
            },
            contact: Contact {
                model: ContactModel { normal: model.0, rolling: model.1, clip_tensile_normal_force: model.2 },
                particle_particle,
                particle_wall,
            },
            seeds: Seeds { design_seed: seeds.0, sample_index: seeds.1, packing_seed: seeds.2 },
            time_step: TimeStep { rayleigh_fraction: time_step.0, design_impact_speed_m_s: time_step.1 },
            coarse_graining: coarse.map(|(size_factor, youngs_modulus_factor, rule)| CoarseGraining { size_factor, youngs_modulus_factor, rule }),
            at_rest: AtRest { kinetic_energy_fraction: at_rest.0, hold_s: at_rest.1 },
        }
    }
}

/// A different value of the same JSON type, or `None` for strings (enum tags).
fn changed(leaf: &Value) -> Option<Value> {
    match leaf {
        Value::Bool(b) => Some(json!(!b)),
        Value::Number(n) if n.is_u64() => Some(json!(n.as_u64()?.wrapping_add(1))),
        Value::Number(n) => {
            let x = n.as_f64()?;
            let y = if x == 0.0 {
                1.0
            } else if x.abs() < 1e300 {
                x * 2.0
            } else {
                x / 2.0
            };
            Some(json!(y))
        }
        _ => None,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn canonical_form_is_a_fixed_point(e in experiment()) {
        let c = canonical_json(&e);
        let back: Experiment = serde_json::from_str(&c).unwrap();
        prop_assert_eq!(&back, &e);
        prop_assert_eq!(canonical_json(&back), c);
    }

    #[test]
    fn changing_any_hashed_field_changes_the_id(e in experiment(), pick in any::<prop::sample::Index>()) {
        let value: Value = serde_json::from_str(&canonical_json(&e)).unwrap();
        let all: Vec<(String, Value)> =
            common::nodes(&value).into_iter().filter(|(_, v)| !v.is_object() && !v.is_array()).collect();
        let (pointer, leaf) = pick.get(&all).clone();
        let new = changed(&leaf);
        prop_assume!(new.is_some());
        let edited = edit(value, &pointer, new);
        let other: Result<Experiment, _> = serde_json::from_value(edited);
        prop_assume!(other.is_ok());
        prop_assert_ne!(other.unwrap().id(), e.id(), "changing {} kept the id", pointer);
    }
}

// ---- pinned ids of the example manifests

const GOLDEN: &str = "golden/manifest_ids.json";

#[test]
fn example_manifest_ids_are_pinned() {
    let experiments = root().join("experiments");
    let mut ids = BTreeMap::new();
    for path in json_files(&experiments) {
        let relative = path
            .strip_prefix(root())
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let text = std::fs::read_to_string(&path).unwrap();
        let id = if repose::study::plan::design_study::is_design_study(&text) {
            let study: repose::study::plan::design_study::DesignStudy =
                serde_json::from_str(&text).unwrap_or_else(|e| panic!("{relative}: {e}"));
            study
                .validate()
                .unwrap_or_else(|e| panic!("{relative}: {e}"));
            study.id()
        } else {
            parse_document(&text, None)
                .unwrap_or_else(|e| panic!("{relative}: {e}"))
                .id()
        };
        ids.insert(relative, id.to_string());
    }
    let current = serde_json::to_string_pretty(&ids).unwrap() + "\n";
    let golden_path = root().join(GOLDEN);
    if std::env::var_os("REPOSE_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&golden_path, &current).unwrap();
        return;
    }
    let pinned = std::fs::read_to_string(&golden_path).unwrap_or_default();
    assert!(
        pinned == current,
        "example manifest ids differ from {GOLDEN} (a changed manifest, schema or physics version).\n\
         If intended, rerun with REPOSE_BLESS=1 and review the diff.\npinned:\n{pinned}\ncurrent:\n{current}"
    );
}
