//! The documented outcome of `repose calibrate` (the default study,
//! experiments/he2019-quick) stays the current code's.
//!
//! `experiments/he2019-quick/measured/outcome.json` records one measured run:
//! the study id, the physics version, every experiment id it ran (the 45
//! design samples and the verification runs) and its headline numbers. The
//! READMEs quote those numbers, and this test checks (a) that they quote
//! exactly the file's, and (b) that today's code would run exactly the
//! recorded experiments: the study id, the physics version, the design's
//! experiment ids (re-sampled here, < 1 s) and the verification experiments
//! built from the recorded candidate centres. A change to a manifest, the
//! study, the design or the physics version therefore fails here until
//! someone re-runs `repose calibrate` and updates the file and the READMEs.
//! (Ids cover what a run is asked to do; a change of what the code does for
//! the same manifest must bump the physics version to be caught.)

mod common;

use std::collections::BTreeMap;

use repose::calibrate::sample::{sample, SampleSettings};
use repose::calibrate::StudyDir;
use repose::manifest::{parse_study, PHYSICS_VERSION};
use serde_json::Value;

const OUTCOME: &str = "experiments/he2019-quick/measured/outcome.json";
const STUDY: &str = "experiments/he2019-quick/study.json";
const READMES: [&str; 2] = ["README.md", "experiments/he2019-quick/README.md"];

fn outcome() -> Value {
    serde_json::from_str(&common::text(OUTCOME)).expect("outcome.json parses")
}

/// `x` to `digits` decimals with a typographic minus, as the READMEs print it.
fn number(x: f64, digits: usize) -> String {
    format!("{x:.digits$}").replace('-', "−")
}

/// The phrases every README must contain, built from the file's numbers.
fn quoted(o: &Value) -> Vec<String> {
    let runs = o["batch"]["runs"].as_u64().unwrap();
    let failed = o["batch"]["failed"].as_array().unwrap().len();
    let mut phrases = vec![
        format!(
            "validation R² {}",
            number(o["train"]["validation_r2"].as_f64().unwrap(), 2)
        ),
        format!("{failed} of {runs} funnel runs"),
        format!("{} cluster(s)", o["search"]["clusters"].as_u64().unwrap()),
    ];
    for row in o["verification"].as_array().unwrap() {
        if row["group"] != 1 {
            continue;
        }
        let scene = row["scene"].as_str().unwrap();
        phrases.push(match row["simulated_deg"].as_f64() {
            Some(a) => format!("{scene} {}°", number(a, 1)),
            None => format!("{scene} not measurable"),
        });
    }
    phrases
}

#[test]
fn the_readmes_quote_the_recorded_outcome() {
    let o = outcome();
    for readme in READMES {
        // Line breaks and runs of spaces read as one space.
        let text = common::text(readme)
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        for phrase in quoted(&o) {
            assert!(
                text.contains(&phrase),
                "{readme} does not quote `{phrase}` from {OUTCOME}"
            );
        }
    }
}

#[test]
fn the_recorded_outcome_is_of_the_experiments_todays_code_runs() {
    let o = outcome();
    let study = parse_study(&common::text(STUDY)).unwrap();
    assert_eq!(
        o["study_id"].as_str().unwrap(),
        study.id().to_string(),
        "the study changed: re-run `repose calibrate` and update {OUTCOME} and the READMEs"
    );
    assert_eq!(
        o["physics_version"].as_u64().unwrap(),
        u64::from(PHYSICS_VERSION),
        "the physics version changed: re-measure {OUTCOME}"
    );

    // The design: sampled again with calibrate's defaults.
    let tmp = tempfile::tempdir().unwrap();
    let study_path = common::root().join(STUDY);
    let dir = StudyDir::new(tmp.path(), &study, &study_path);
    let design = sample(&dir, &study, &SampleSettings::default()).unwrap();
    let csv = std::fs::read_to_string(&design.design_file).unwrap();
    let ids: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    let recorded: Vec<&str> = o["design_experiment_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        ids, recorded,
        "the design's experiments changed: re-measure {OUTCOME}"
    );
    assert_eq!(o["batch"]["runs"].as_u64().unwrap(), ids.len() as u64);

    // The verification runs: each candidate centre in each scene.
    let scenes: BTreeMap<&str, _> = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .map(|t| (t.name.as_str(), t))
        .collect();
    let candidates: BTreeMap<u64, BTreeMap<String, f64>> = o["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let centre = c["centre"]
                .as_object()
                .unwrap()
                .iter()
                .map(|(k, v)| (k.clone(), v.as_f64().unwrap()))
                .collect();
            (c["group"].as_u64().unwrap(), centre)
        })
        .collect();
    let rows = o["verification"].as_array().unwrap();
    assert_eq!(rows.len(), candidates.len() * scenes.len());
    for row in rows {
        let group = row["group"].as_u64().unwrap();
        let target = scenes[row["scene"].as_str().unwrap()];
        let experiment = study
            .experiment(&target.scene, &candidates[&group], group)
            .unwrap();
        assert_eq!(
            row["experiment_id"].as_str().unwrap(),
            experiment.id().to_string(),
            "verification of candidate {group} in {}: re-measure {OUTCOME}",
            target.name
        );
        assert_eq!(
            row["measured_deg"].as_f64().unwrap(),
            target.target_angle_deg
        );
    }
}
