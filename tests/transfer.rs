//! The transfer test (issue 55) end to end on the noise-aware smoke study
//! with a fake runner whose angle is a known function of the contact
//! parameters, the drum's speed and the particle radius: at the verified
//! size and at 0.75 of it the angle is the calibrated one (plus 0.2° at
//! 0.75), at half the radius it is 6° lower. A candidate that passes its
//! verification must transfer to 0.75 and no further, in every scene; the
//! plan must be on record before the first transfer run; the verified
//! size's column must be the verification's own runs; the rule must reach
//! the experiments; and a transfer the study cannot support is refused.

mod common;

use std::path::Path;

use repose::manifest::{parse_study, Experiment, SizeDistribution, Study};
use repose::store::{RunDir, RunResult, Store};
use repose::study::acceptance::Verdict;
use repose::study::dir::StudyDir;
use repose::study::pipeline::calibrate_noise_aware;
use repose::study::plan::calibration::SearchSettings;
use repose::study::plan::{Stage, StudySpec};
use repose::study::run::CalibrationSettings;
use repose::study::stages::design::SampleSettings;
use repose::study::stages::fit_network::TrainOptions;
use repose::study::stages::transfer::{transfer, TransferSettings};
use repose::study::sweeps::convergence::plan::SurfaceEnergyRule;
use serde_json::{json, Value};

/// Seed-to-seed sd of the fake angle, degrees.
const SIGMA: f64 = 0.5;
/// The smoke study's particle radius, m.
const RADIUS: f64 = 0.001;

fn radius(e: &Experiment) -> f64 {
    match &e.material.particle.size {
        SizeDistribution::Monodisperse { radius_m } => *radius_m,
        other => panic!("monodisperse expected, got {other:?}"),
    }
}

/// The drum's speed, rpm (30 in the calibration scene, 15 in the
/// verification scene).
fn rpm(e: &Experiment) -> f64 {
    serde_json::to_value(&e.scene).unwrap()["rpm"]
        .as_f64()
        .unwrap()
}

/// How the fake angle moves with the radius, degrees.
fn size_shift(e: &Experiment) -> f64 {
    let k = radius(e) / RADIUS;
    if (k - 1.0).abs() < 1e-9 {
        0.0
    } else if (k - 0.75).abs() < 1e-9 {
        0.2
    } else if (k - 0.5).abs() < 1e-9 {
        -6.0
    } else {
        panic!("an unplanned size {k}")
    }
}

/// 20 + 30 μ + 40 μ_r degrees at 30 rpm, 2° less at 15 rpm (whose target is
/// 2° lower), shifted by the size, plus the packing noise.
fn fake(e: &Experiment, _: &RunDir) -> Result<RunResult, std::io::Error> {
    let pp = e.contact.particle_particle;
    let speed = if rpm(e) < 20.0 { -2.0 } else { 0.0 };
    let noise = common::packing_noise(e.seeds.packing_seed, e.seeds.sample_index, SIGMA);
    let mut r = RunResult::new(e, "fake");
    r.headline_angle_deg = Some(
        20.0 + 30.0 * pp.static_friction
            + 40.0 * pp.rolling_friction
            + speed
            + size_shift(e)
            + noise,
    );
    Ok(r)
}

/// The noise-aware block of every study here.
fn noise_aware() -> Value {
    json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 } })
}

fn study(dir: &Path, transfer: Option<Value>) -> (Study, std::path::PathBuf) {
    let mut v = common::example("calibrate-smoke/study.json");
    v = common::edit(v, "/noise_aware", Some(noise_aware()));
    v = common::edit(v, "/transfer", transfer);
    let path = dir.join("study.json");
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    (parse_study(&v.to_string()).unwrap(), path)
}

fn settings(study: &Study) -> CalibrationSettings {
    CalibrationSettings {
        candidates: 1,
        adaptive: false,
        sample: SampleSettings::default(),
        train: TrainOptions::defaults(study),
        search: SearchSettings::with_seed(study.design.seed),
        transfer: TransferSettings::of_study(study),
    }
}

#[test]
fn a_verified_candidate_transfers_as_far_as_every_scene_passes() {
    let tmp = tempfile::tempdir().unwrap();
    let block = json!({ "sizes": [0.5, 0.75], "rule": "surface_energy_proportional" });
    let (study, path) = study(tmp.path(), Some(block));
    let spec = StudySpec::calibration(&study, false, 1);
    let last = spec.stages.last().unwrap();
    assert!(
        matches!(last, Stage::Transfer { sizes, .. } if sizes == &[0.75, 0.5]),
        "the study's transfer block adds the stage last, coarsest size first: {last:?}"
    );

    let root = tmp.path().join("store");
    let store = Store::open(&root).unwrap();
    let dir = StudyDir::new(&root, &study, &path);
    let outcome = calibrate_noise_aware(
        &dir,
        &study,
        &store,
        &common::executor(2),
        &settings(&study),
        fake,
        &mut |_| {},
    )
    .unwrap();
    let verified = &outcome.verification;
    assert!(
        verified
            .iter()
            .all(|r| r.judgement.verdict == Verdict::Pass),
        "the fake's candidate passes both scenes at the verified size: {verified:?}"
    );
    let record = outcome.transfer.as_ref().expect("the transfer stage ran");
    assert_eq!(record.candidates[0].transfers_to, Some(0.75));
    assert_eq!(outcome.runs.transfer, record.finer_runs);

    // The stage again on its own (what `repose transfer` runs): cached.
    let t = transfer(
        &dir,
        &study,
        &TransferSettings::of_study(&study).unwrap(),
        (&store, &common::executor(1)),
        |_: &Experiment, _: &RunDir| -> Result<RunResult, std::io::Error> {
            panic!("every transfer run is in the store")
        },
    )
    .unwrap();
    assert_eq!(t.plan.sizes, vec![0.75, 0.5]);
    assert_eq!(t.plan.rule, "proportional");
    assert_eq!(t.rows.len(), 2, "one candidate x two scenes");
    for row in &t.rows {
        let verdicts: Vec<Verdict> = row.cells.iter().map(|c| c.judgement.verdict).collect();
        assert_eq!(
            verdicts,
            vec![Verdict::Pass, Verdict::Pass, Verdict::Fail],
            "{}: pass at x1 and x0.75, fail 6° low at x0.5",
            row.scene
        );
        assert_eq!(row.transfers_to, Some(0.75));
        let shift = row.cells[2].judgement.mean.unwrap() - row.cells[0].judgement.mean.unwrap();
        assert!(
            (shift + 6.0).abs() < 3.0 * SIGMA,
            "{}: the x0.5 mean sits 6° below the verified one ({shift:.2})",
            row.scene
        );
    }
    assert_eq!(t.candidates.len(), 1);
    assert_eq!(t.candidates[0].transfers_to, Some(0.75));
    assert!(!t.candidates[0].every_size);
    assert!(t
        .markdown
        .contains("transfers down to ×0.75 in every scene, not further"));

    // The verified size's column is the verification's own runs.
    let verify_runs = std::fs::read_to_string(dir.verify_runs_path()).unwrap();
    let transfer_runs = std::fs::read_to_string(
        dir.stage(repose::study::dir::Stage::Transfer)
            .join("runs.csv"),
    )
    .unwrap();
    for line in verify_runs.lines().skip(1) {
        let id = line.split(',').nth(6).unwrap();
        assert!(
            transfer_runs.contains(id),
            "verification run {id} in the transfer table"
        );
    }
    // The plan went on record before the runs: its lineage names the
    // acceptance record and the verified runs, not any transfer result.
    let plan = repose::store::Lineage::read_beside(&dir.transfer_plan_path()).unwrap();
    let plan = serde_json::to_value(&plan).unwrap();
    let roles: Vec<&str> = plan["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["role"].as_str().unwrap())
        .collect();
    assert_eq!(roles, vec!["study", "acceptance", "verified"]);
}

#[test]
fn the_rule_reaches_the_finer_experiments() {
    let tmp = tempfile::tempdir().unwrap();
    // A cohesive copy of the smoke study: JKR, Γ = 0.04 J/m² between
    // particles.
    let mut v = common::example("calibrate-smoke/study.json");
    v = common::edit(v, "/noise_aware", Some(noise_aware()));
    v = common::edit(v, "/contact_model/normal", Some(json!("jkr")));
    v = common::edit(
        v,
        "/fixed/particle_particle.surface_energy_j_m2",
        Some(json!(0.04)),
    );
    let path = tmp.path().join("study.json");
    std::fs::write(&path, v.to_string()).unwrap();
    let study = parse_study(&v.to_string()).unwrap();
    let root = tmp.path().join("store");
    let store = Store::open(&root).unwrap();
    let dir = StudyDir::new(&root, &study, &path);
    calibrate_noise_aware(
        &dir,
        &study,
        &store,
        &common::executor(2),
        &settings(&study),
        fake,
        &mut |_| {},
    )
    .unwrap();
    for (rule, exponent) in [
        (SurfaceEnergyRule::ConstantBond, 2.0),
        (SurfaceEnergyRule::Proportional, 1.0),
        (SurfaceEnergyRule::CohesionNumber, 0.4),
    ] {
        let seen = std::sync::Mutex::new(Vec::new());
        let record = |e: &Experiment, d: &RunDir| {
            seen.lock().unwrap().push((
                radius(e) / RADIUS,
                e.contact.particle_particle.surface_energy_j_m2,
            ));
            fake(e, d)
        };
        let settings = TransferSettings {
            sizes: vec![0.75],
            rule,
        };
        transfer(
            &dir,
            &study,
            &settings,
            (&store, &common::executor(1)),
            record,
        )
        .unwrap();
        let seen = seen.into_inner().unwrap();
        assert!(!seen.is_empty(), "{rule:?}: the x0.75 runs are new");
        for (k, gamma) in seen {
            assert!((k - 0.75).abs() < 1e-12, "only x0.75 runs: {k}");
            let expected = 0.04 * 0.75f64.powf(exponent);
            assert!(
                (gamma - expected).abs() < 1e-15,
                "{rule:?}: Γ = {gamma}, expected 0.04 x 0.75^{exponent} = {expected}"
            );
        }
    }
}

#[test]
fn a_transfer_the_study_cannot_support_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (study, _) = study(tmp.path(), None);
    let check = |sizes: Vec<f64>, rule| TransferSettings { sizes, rule }.check(&study);
    let err = check(vec![1.0], SurfaceEnergyRule::Proportional).unwrap_err();
    assert!(err.to_string().contains("(0, 1)"), "{err}");
    let err = check(vec![0.5, 0.5], SurfaceEnergyRule::Proportional).unwrap_err();
    assert!(err.to_string().contains("listed twice"), "{err}");
    let err = check(vec![], SurfaceEnergyRule::Proportional).unwrap_err();
    assert!(err.to_string().contains("at least one size"), "{err}");

    // A two-level study's fine level scales Γ ∝ R²: its transfer must too.
    let mut v = common::example("calibrate-smoke/study.json");
    let block = json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 },
        "fidelity": { "fine_size": 0.75, "fine_points": 5, "fine_replicates": 3 } });
    v = common::edit(v, "/noise_aware", Some(block));
    v = common::edit(
        v,
        "/transfer",
        Some(json!({ "sizes": [0.5], "rule": "surface_energy_proportional" })),
    );
    let err = parse_study(&v.to_string()).unwrap_err().to_string();
    assert!(
        err.contains("transfer.rule") && err.contains("constant_bond"),
        "{err}"
    );
    let v = common::edit(
        v,
        "/transfer",
        Some(json!({ "sizes": [0.5, 1.5, 0.5], "rule": "constant_bond" })),
    );
    let err = parse_study(&v.to_string()).unwrap_err().to_string();
    assert!(
        err.contains("transfer.sizes[1]") && err.contains("transfer.sizes[2]"),
        "{err}"
    );

    // Without the verification's record there is nothing to transfer.
    let root = tmp.path().join("store");
    let store = Store::open(&root).unwrap();
    let dir = StudyDir::new(&root, &study, &tmp.path().join("study.json"));
    let settings = TransferSettings {
        sizes: vec![0.5],
        rule: SurfaceEnergyRule::Proportional,
    };
    let err = transfer(
        &dir,
        &study,
        &settings,
        (&store, &common::executor(1)),
        fake,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("verify"), "{err}");
}
