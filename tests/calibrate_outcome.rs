//! The documented outcome of `repose calibrate` (the default study,
//! experiments/he2019-quick, noise-aware) stays the current code's.
//!
//! `experiments/he2019-quick/measured/outcome.json` records one measured run:
//! the study id, the physics version, every experiment id it ran (noise
//! floor, design replicates, verification) and the outcome `repose calibrate
//! --json` printed. The READMEs quote its headline numbers, and this test
//! checks (a) that they quote exactly the file's, and (b) that today's code
//! would run exactly the recorded experiments: the study id, the physics
//! version, the noise floor's and the design's experiment ids (re-sampled
//! here, < 1 s) and the verification experiments built from the recorded
//! candidate centres and the seeds of the recorded acceptance record. A change to a manifest, the study, the design or the
//! physics version therefore fails here until someone re-runs `repose
//! calibrate` and updates the file and the READMEs. (Ids cover what a run is
//! asked to do; a change of what the code does for the same manifest must
//! bump the physics version to be caught.)

mod common;

use std::collections::BTreeMap;

use repose::manifest::{parse_study, PHYSICS_VERSION};
use repose::study::dir::StudyDir;
use repose::study::plan::calibration::parameter_names;
use repose::study::plan::calibration::to_physical;
use repose::study::plan::calibration::{ADAPTIVE_INDEX, NOISE_INDEX, VERIFY_INDEX};
use repose::study::stages::design::{sample, SampleSettings};
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
    let out = &o["outcome"];
    let mut phrases = vec![format!(
        "noise floor σ {}°",
        number(out["noise_floor"]["sd_deg"].as_f64().unwrap(), 2)
    )];
    for s in out["surrogates"].as_array().unwrap() {
        let name = match s["surrogate"].as_str().unwrap() {
            "gp" => "GP",
            "gp_screened" => "screened GP",
            _ => "GA-BP",
        };
        if let Some(r2) = s["validation_r2"].as_f64() {
            phrases.push(format!("{name} validation R² {}", number(r2, 2)));
        }
    }
    for row in out["verification"].as_array().unwrap() {
        if row["group"] != 1 {
            continue;
        }
        let scene = row["scene"].as_str().unwrap();
        phrases.push(
            match (
                row["mean_deg"].as_f64(),
                row["ci95_half_width_deg"].as_f64(),
            ) {
                (Some(m), Some(h)) => format!("{scene} {} ± {}°", number(m, 2), number(h, 2)),
                _ => format!("{scene} not measurable"),
            },
        );
        phrases.push(format!(
            "{scene} verdict: {}",
            row["judgement"]["verdict"].as_str().unwrap()
        ));
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

fn recorded(o: &Value, key: &str) -> Vec<String> {
    o[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect()
}

#[test]
fn the_recorded_outcome_is_of_the_experiments_todays_code_runs() {
    let o = outcome();
    let study = parse_study(&common::text(STUDY)).unwrap();
    let spec = study.noise_aware.expect("the default study is noise-aware");
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
    let names = parameter_names(&study);
    let point = |values: &[f64]| -> BTreeMap<String, f64> {
        names.iter().cloned().zip(values.iter().copied()).collect()
    };

    // The noise floor: the centre of the ranges, one run per seed.
    let centre = to_physical(&study, &vec![0.5; names.len()]);
    let noise: Vec<String> = (0..spec.noise_seeds)
        .map(|r| {
            let e = study.replicate_experiment(
                &study.calibration.scene,
                &point(&centre),
                NOISE_INDEX,
                r,
            );
            e.unwrap().id().to_string()
        })
        .collect();
    assert_eq!(
        noise,
        recorded(&o, "noise_experiment_ids"),
        "re-measure {OUTCOME}"
    );

    // The design: sampled again with calibrate's defaults, every replicate.
    let tmp = tempfile::tempdir().unwrap();
    let study_path = common::root().join(STUDY);
    let dir = StudyDir::new(tmp.path(), &study, &study_path);
    let design = sample(&dir, &study, &SampleSettings::default()).unwrap();
    let mut ids = Vec::new();
    for (index, p) in design.points.iter().enumerate() {
        for r in 0..spec.replicates {
            let e =
                study.replicate_experiment(&study.calibration.scene, &point(p), index as u64, r);
            ids.push(e.unwrap().id().to_string());
        }
    }
    assert_eq!(
        ids,
        recorded(&o, "design_experiment_ids"),
        "the design's experiments changed: re-measure {OUTCOME}"
    );

    // The verification: each verified candidate's centre in each scene, one
    // run per seed (scene by scene, candidate by candidate).
    let rows = o["outcome"]["verification"].as_array().unwrap();
    let groups: Vec<u64> =
        rows.iter()
            .map(|r| r["group"].as_u64().unwrap())
            .fold(Vec::new(), |mut g, x| {
                if !g.contains(&x) {
                    g.push(x);
                }
                g
            });
    let centres: BTreeMap<u64, Vec<f64>> = o["outcome"]["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let centre = c["centre"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            (c["group"].as_u64().unwrap(), centre)
        })
        .collect();
    // Seeds per scene as the recorded acceptance record pre-registered them.
    let seeds: Vec<u64> = o["outcome"]["acceptance"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["seeds"].as_u64().unwrap())
        .collect();
    let mut ids = Vec::new();
    let targets = std::iter::once(&study.calibration).chain(&study.verification);
    for (target, seeds) in targets.zip(&seeds) {
        for g in &groups {
            let index = if *g >= ADAPTIVE_INDEX {
                *g
            } else {
                VERIFY_INDEX + g
            };
            for r in 0..*seeds as u32 {
                let e = study.replicate_experiment(&target.scene, &point(&centres[g]), index, r);
                ids.push(e.unwrap().id().to_string());
            }
        }
    }
    assert_eq!(
        ids,
        recorded(&o, "verification_experiment_ids"),
        "the verification experiments changed: re-measure {OUTCOME}"
    );
    for row in rows {
        let scene = row["scene"].as_str().unwrap();
        let target = std::iter::once(&study.calibration)
            .chain(&study.verification)
            .find(|t| t.name == scene)
            .unwrap();
        assert_eq!(row["target_deg"].as_f64().unwrap(), target.target_angle_deg);
    }
}
