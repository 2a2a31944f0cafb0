//! experiments/cai2024-drum: the three manifests are cai2024-quick's drum at
//! cai2024's reported optimum (A 0.36, B 0.31, C 0.38, D 0.22; METHODS.md),
//! differing only in their end walls, so a change to the study's base or drum
//! scene shows up here instead of leaving the manifests behind.

mod common;

use repose::manifest::scene::{DrumScene, EndWalls};
use repose::manifest::{parse_experiment, Experiment, Scene, Seeds};
use repose::study::plan::design_study::DesignStudy;

fn manifest(name: &str) -> Experiment {
    parse_experiment(&common::text(&format!(
        "experiments/cai2024-drum/{name}.json"
    )))
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn drum(e: &Experiment) -> &DrumScene {
    match &e.scene {
        Scene::Drum(d) => d,
        other => panic!("not a drum: {}", other.kind()),
    }
}

#[test]
fn the_three_drums_are_cai2024_quick_at_cai2024s_optimum() {
    let study: DesignStudy =
        serde_json::from_str(&common::text("experiments/cai2024-quick/study.json")).unwrap();
    let optimum = study.verification.as_ref().unwrap().points["cai2024"].clone();
    let values: Vec<(&str, f64)> = study
        .factors
        .iter()
        .map(|(name, f)| (f.address.as_str(), optimum[name]))
        .collect();
    assert_eq!(
        values,
        [
            ("contact.particle_particle.static_friction", 0.36),
            ("contact.particle_particle.rolling_friction", 0.31),
            ("contact.particle_wall.*.static_friction", 0.38),
            ("contact.particle_wall.*.rolling_friction", 0.22),
        ]
    );
    let mut expected = study.experiment("drum", &values, 0, 0).unwrap();
    expected.seeds = Seeds {
        design_seed: 0,
        sample_index: 0,
        packing_seed: 0,
    };

    let slice = manifest("slice");
    assert_eq!(slice, expected);
    assert_eq!(drum(&slice).periodic_slice_m, Some(0.025));

    // The full 100 mm drum: no slice, end caps turning with it (the default).
    let rotating = manifest("rotating");
    let mut full = expected.clone();
    if let Scene::Drum(d) = &mut full.scene {
        d.periodic_slice_m = None;
    }
    assert_eq!(rotating, full);
    assert_eq!(drum(&rotating).end_walls, EndWalls::Rotating);

    // The same with end caps at rest.
    let fixed = manifest("fixed");
    if let Scene::Drum(d) = &mut full.scene {
        d.end_walls = EndWalls::Fixed;
    }
    assert_eq!(fixed, full);
}
