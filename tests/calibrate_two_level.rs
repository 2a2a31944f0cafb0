//! The two-level (multi-fidelity) calibration (issue 43) end to end on the
//! smoke study with a fast fake runner whose angle depends on the particle
//! size: the coarse level is 20 + 30 μ + 40 μr degrees and the fine level
//! (radius × 0.75) is ρ·coarse + β with ρ = 0.8 and β = 8°, each with its
//! own packing noise. The coarse design, the fine points chosen by the
//! model, the two-level fit, the search on the fine level and the
//! verification at the fine size run through the one pipeline; the stores
//! are the same bytes with 1 and 2 workers.

mod common;

use std::path::{Path, PathBuf};

use repose::manifest::{parse_study, Experiment, SizeDistribution, Study};
use repose::store::{RunDir, RunResult, Store};
use repose::study::acceptance::Verdict;
use repose::study::analyses::holdout::{holdout, read_pilot};
use repose::study::dir::StudyDir;
use repose::study::pipeline::{calibrate_noise_aware, CalibrationOutcome};
use repose::study::plan::calibration::SearchSettings;
use repose::study::plan::{Stage, StudySpec};
use repose::study::run::CalibrationSettings;
use repose::study::stages::design::SampleSettings;
use repose::study::stages::fine::{load_two_level, Choice, SPACE_FILLING_POINTS};
use repose::study::stages::fit_gp::read_gp;
use repose::study::stages::fit_network::TrainOptions;
use repose::study::sweeps::pilot::{Pilot, PilotPoint};
use serde_json::{json, Value};

/// Seed-to-seed sd of the fake angle at either size, degrees.
const SIGMA: f64 = 0.5;
/// The smoke study's particle radius (m) and the fine factor.
const COARSE_RADIUS: f64 = 0.001;
const FINE_SIZE: f64 = 0.75;
/// The fine level's scale and shift of the coarse response.
const RHO: f64 = 0.8;
const BETA: f64 = 8.0;

/// A fixed pseudo-random value of (seed, point) uniform on ±√3 σ.
fn packing_noise(seed: u64, point: u64) -> f64 {
    common::packing_noise(seed, point, SIGMA)
}

fn radius(e: &Experiment) -> f64 {
    match &e.material.particle.size {
        SizeDistribution::Monodisperse { radius_m } => *radius_m,
        other => panic!("monodisperse expected, got {other:?}"),
    }
}

fn is_fine(e: &Experiment) -> bool {
    (radius(e) - COARSE_RADIUS * FINE_SIZE).abs() < 1e-12
}

fn coarse_mean(e: &Experiment) -> f64 {
    let pp = e.contact.particle_particle;
    20.0 + 30.0 * pp.static_friction + 40.0 * pp.rolling_friction
}

fn fake(e: &Experiment, _: &RunDir) -> Result<RunResult, std::io::Error> {
    let (seed, point) = (e.seeds.packing_seed, e.seeds.sample_index);
    let angle = if is_fine(e) {
        RHO * coarse_mean(e) + BETA + packing_noise(seed ^ 0xf1ae, point)
    } else {
        assert!((radius(e) - COARSE_RADIUS).abs() < 1e-12, "a third size");
        coarse_mean(e) + packing_noise(seed, point)
    };
    let mut r = RunResult::new(e, "fake");
    r.headline_angle_deg = Some(angle);
    Ok(r)
}

fn study(dir: &Path, fidelity: Value) -> (Study, PathBuf) {
    let mut v = common::example("calibrate-smoke/study.json");
    let block = json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 },
        "fidelity": fidelity });
    v = common::edit(v, "/noise_aware", Some(block));
    let path = dir.join("study.json");
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    (parse_study(&v.to_string()).unwrap(), path)
}

fn fidelity() -> Value {
    json!({ "fine_size": FINE_SIZE, "fine_points": 5, "fine_replicates": 3 })
}

fn calibrate(root: &Path, study: &Study, path: &Path, jobs: usize) -> CalibrationOutcome {
    let store = Store::open(root).unwrap();
    let dir = StudyDir::new(root, study, path);
    let options = CalibrationSettings {
        candidates: 1,
        adaptive: false,
        sample: SampleSettings::default(),
        train: TrainOptions::defaults(study),
        search: SearchSettings::with_seed(study.design.seed),
        transfer: None,
    };
    calibrate_noise_aware(
        &dir,
        study,
        &store,
        &common::executor(jobs),
        &options,
        fake,
        &mut |_| {},
    )
    .unwrap()
}

/// Every file of `root` but the timing records and the files that carry
/// CPU or wall time (the noise floor's tables, the outcome, fine/cost.json,
/// each with its lineage record).
fn deterministic_files(root: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    common::snapshot(root)
        .into_iter()
        .filter(|(p, _)| {
            let s = p.to_string_lossy();
            !(s.contains("/noise/") || s.contains("outcome.json") || s.contains("cost.json"))
        })
        .collect()
}

#[test]
fn a_two_level_calibration_verifies_at_the_fine_size_and_reproduces() {
    let tmp = tempfile::tempdir().unwrap();
    let (study, path) = study(tmp.path(), fidelity());

    // The stage list shows the fine stage and the fine-size verification.
    let spec = StudySpec::calibration(&study, false, 1);
    let names: Vec<&str> = spec.stages.iter().map(|s| s.name()).collect();
    assert_eq!(
        names,
        ["noise", "design", "simulate", "fit", "fine", "search", "verify"]
    );
    assert!(spec.stages.iter().any(|s| matches!(
        s,
        Stage::Verify { size: Some(f), max_seeds: None, .. } if *f == FINE_SIZE
    )));

    let outcome = calibrate(&tmp.path().join("a"), &study, &path, 2);
    let fine_record = outcome.fine.as_ref().expect("the fine stage ran");

    // The fine points: 3 by space filling, then 2 by the model, all design
    // points, none twice, 3 seeds each.
    assert_eq!(fine_record.points.len(), 5);
    for (k, p) in fine_record.points.iter().enumerate() {
        let expected = if k < SPACE_FILLING_POINTS {
            Choice::SpaceFilling
        } else {
            Choice::FineSd
        };
        assert_eq!(p.chosen_by, expected, "point {k}");
        assert!(p.index < 12, "a design point");
        assert_eq!(p.seeds, 3);
        assert_eq!(p.predicted_sd_deg.is_some(), k >= SPACE_FILLING_POINTS);
    }
    let mut indices: Vec<u64> = fine_record.points.iter().map(|p| p.index).collect();
    indices.sort_unstable();
    indices.dedup();
    assert_eq!(indices.len(), 5);
    assert_eq!(outcome.runs.fine, 15);

    // ρ and β are recovered within their 95 % intervals.
    let (rho, rho_se) = fine_record.fit.rho;
    let (beta, beta_se) = fine_record.fit.beta;
    assert!(
        (rho - RHO).abs() <= 1.96 * rho_se,
        "rho {rho} ± {rho_se} against {RHO}"
    );
    assert!(
        (beta - BETA).abs() <= 1.96 * beta_se,
        "beta {beta} ± {beta_se} against {BETA}"
    );

    // The candidate is the fine level's: its true fine angle is in the band
    // (30° ± 5 %), where the coarse angle at the same point is not.
    let c = &outcome.candidates[0];
    let mu = c.centre[0] * 30.0 + c.centre[1] * 40.0 + 20.0;
    let fine_true = RHO * mu + BETA;
    assert!((28.5..=31.5).contains(&fine_true), "fine {fine_true}");
    assert!(!(28.5..=31.5).contains(&mu), "coarse {mu}");

    // Verification ran at the fine size in every scene and passed the
    // calibration scene.
    let calibration = outcome
        .verification
        .iter()
        .find(|r| r.scene == study.calibration.name)
        .unwrap();
    assert_eq!(calibration.seeds, 5);
    assert_eq!(calibration.judgement.verdict, Verdict::Pass);
    assert!(outcome.calibrated);
    assert!(outcome.verification.iter().all(|r| r.seeds == 5));

    // The same study on one worker: the same bytes.
    calibrate(&tmp.path().join("b"), &study, &path, 1);
    let (a, b) = (
        deterministic_files(&tmp.path().join("a")),
        deterministic_files(&tmp.path().join("b")),
    );
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert!(
            x.1 == y.1,
            "{} differs between 1 and 2 workers",
            x.0.display()
        );
    }
    // Timing files exist for the cost: the fine runs cost something.
    let cost: Value = serde_json::from_str(
        &std::fs::read_to_string(
            StudyDir::new(&tmp.path().join("a"), &study, &path)
                .path()
                .join("fine/cost.json"),
        )
        .unwrap(),
    )
    .unwrap();
    assert_eq!(cost["fine_runs"], 15);
    assert_eq!(cost["coarse_runs"], 24);

    // Held out: a pilot's fine points (built here from the fake's fine
    // level, 3 seeds each) against the two-level prediction.
    let root = tmp.path().join("a");
    let dir = StudyDir::new(&root, &study, &path);
    let store = Store::open(&root).unwrap();
    let pilot = pilot_of(&study);
    let h = holdout(&dir, &study, &store, &pilot, &study).unwrap();
    let model = load_two_level(&dir, read_gp(&dir).unwrap().process().unwrap()).unwrap();
    assert_eq!(h.model, "two_level");
    assert_eq!(h.points.len(), pilot.points.len());
    let mut ss = 0.0;
    for (held, p) in h.points.iter().zip(&pilot.points) {
        let unit: Vec<f64> = study
            .parameters
            .values()
            .zip(&p.point)
            .map(|(r, v)| (v - r.min) / (r.max - r.min))
            .collect();
        let pred = model.predict(&unit);
        let observed = p.fine.iter().sum::<f64>() / p.fine.len() as f64;
        assert_eq!(held.predicted, (pred.mean, pred.sd));
        assert!((held.observed.0 - observed).abs() < 1e-12);
        assert!((held.error - (pred.mean - observed)).abs() < 1e-12);
        ss += held.error * held.error;
        // The fake's fine level is what the model learned: within a degree.
        assert!(
            held.error.abs() < 1.0,
            "error {} at {:?}",
            held.error,
            p.point
        );
    }
    assert!((h.rmse - (ss / h.points.len() as f64).sqrt()).abs() < 1e-12);
    assert_eq!(h.training_runs, 8 + 24 + 15);

    // A one-level study is compared only when its particle is the pilot's
    // fine one.
    let (coarse_only, coarse_path) = {
        let sub = tmp.path().join("one-level");
        std::fs::create_dir_all(&sub).unwrap();
        let mut v = common::example("calibrate-smoke/study.json");
        v = common::edit(
            v,
            "/noise_aware",
            Some(
                json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
                "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 } }),
            ),
        );
        let path = sub.join("study.json");
        std::fs::write(&path, v.to_string()).unwrap();
        (parse_study(&v.to_string()).unwrap(), path)
    };
    let one = StudyDir::new(&root, &coarse_only, &coarse_path);
    let err = holdout(&one, &coarse_only, &store, &pilot, &study)
        .unwrap_err()
        .to_string();
    assert!(err.contains("fine one"), "{err}");

    // Issue 54 item 8: a pilot is used only with the study it ran (by the id
    // it records) ...
    let err = holdout(&dir, &study, &store, &pilot, &coarse_only)
        .unwrap_err()
        .to_string();
    assert!(err.contains("is not the study the pilot ran"), "{err}");
    let mut unrecorded = pilot.clone();
    unrecorded.study = None;
    let err = holdout(&dir, &study, &store, &unrecorded, &study)
        .unwrap_err()
        .to_string();
    assert!(err.contains("records no study id"), "{err}");

    // ... and only as `repose pilot` wrote it: its lineage record describes
    // the bytes read.
    let file = tmp.path().join("pilot").join("pilot.json");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    let bytes = serde_json::to_vec_pretty(&pilot).unwrap();
    let lineage = repose::store::Lineage::new("pilot", json!({}));
    repose::study::dir::write_output(&file, &bytes, &lineage).unwrap();
    assert_eq!(read_pilot(&file).unwrap().points.len(), pilot.points.len());
    let edited = String::from_utf8(bytes)
        .unwrap()
        .replacen("\"drum\"", "\"Drum\"", 1);
    std::fs::write(&file, edited).unwrap();
    for (path, says) in [
        (file.clone(), "edited after it was written"),
        (tmp.path().join("nonexistent.json"), "cannot read it"),
    ] {
        let err = read_pilot(&path).unwrap_err();
        assert!(err.is_invalid_input(), "{err}");
        assert!(err.to_string().contains(says), "{err}");
    }
    std::fs::remove_file(repose::store::Lineage::path_beside(&file)).unwrap();
    let err = read_pilot(&file).unwrap_err().to_string();
    assert!(err.contains("no readable lineage record"), "{err}");
}

/// A pilot of 4 points off the design (sample indices 4e9 + i) with the
/// fake's fine values at 3 seeds.
fn pilot_of(study: &Study) -> Pilot {
    let points = [[0.1, 0.3], [0.25, 0.5], [0.05, 0.7], [0.2, 0.2]];
    Pilot {
        study: Some(study.id()),
        scene: "drum".into(),
        response: "headline angle".into(),
        parameters: study.parameters.keys().cloned().collect(),
        fine_factor: FINE_SIZE,
        points: points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let index = 4_000_000_000 + i as u64;
                let mean = RHO * (20.0 + 30.0 * p[1] + 40.0 * p[0]) + BETA;
                PilotPoint {
                    index,
                    point: p.to_vec(),
                    coarse: vec![],
                    fine: (0..3)
                        .map(|r| mean + packing_noise(r + 77, index))
                        .collect(),
                }
            })
            .collect(),
        cpu_s: (None, None),
        correlation: None,
        fit: Err("not fitted".into()),
    }
}

#[test]
fn the_fine_stage_says_what_is_wrong() {
    let tmp = tempfile::tempdir().unwrap();
    // Fields out of range are named with their value and what is allowed.
    let mut v = common::example("calibrate-smoke/study.json");
    let block = json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 },
        "fidelity": { "fine_size": 1.5, "fine_points": 40, "fine_replicates": 1 } });
    v = common::edit(v, "/noise_aware", Some(block));
    let err = parse_study(&v.to_string()).unwrap_err().to_string();
    for field in [
        "noise_aware.fidelity.fine_size",
        "noise_aware.fidelity.fine_points",
        "noise_aware.fidelity.fine_replicates",
    ] {
        assert!(err.contains(field), "{field} not named in: {err}");
    }

    // The stage before train: it names the stage to run first (the driver
    // reads the fit stage's model before the fine stage starts).
    let (study, path) = study(tmp.path(), fidelity());
    let out = common::repose(&tmp.path().join("store"), &["fine", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", common::stderr(&out));
    let err = common::stderr(&out);
    assert!(err.contains("repose train"), "{err}");

    // --adaptive is refused in a two-level study.
    let store = Store::open(tmp.path()).unwrap();
    let dir = StudyDir::new(tmp.path(), &study, &path);
    let options = CalibrationSettings {
        candidates: 1,
        adaptive: true,
        sample: SampleSettings::default(),
        train: TrainOptions::defaults(&study),
        search: SearchSettings::with_seed(study.design.seed),
        transfer: None,
    };
    let err = calibrate_noise_aware(
        &dir,
        &study,
        &store,
        &common::executor(1),
        &options,
        fake,
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("--adaptive"), "{err}");
}
