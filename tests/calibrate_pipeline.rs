//! The calibration stages end to end on the smoke study
//! (experiments/calibrate-smoke/study.json): sample → batch → train → search
//! with a fast deterministic fake runner (resume, failures, byte-identical
//! reruns, lineage), and once with the real drum simulation.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use repose::manifest::{parse_study, Experiment, Study};
use repose::scenes::run_experiment;
use repose::store::{Lineage, RunDir, RunResult, RunStatus, Store};
use repose::study::acceptance::Verdict;
use repose::study::dir::Stage;
use repose::study::dir::StudyDir;
use repose::study::plan::calibration::SearchSettings;
use repose::study::plan::calibration::VERIFY_INDEX;
use repose::study::records::read_angles;
use repose::study::stages::design::{sample, SampleSettings};
use repose::study::stages::fit_network::{train_study, TrainOptions};
use repose::study::stages::search_tolerance::search;
use repose::study::stages::simulate::batch;
use repose::study::stages::verify_candidates::verify;
use repose::study::StudyError;
use repose::surrogate::ga_bp::TrainSettings;
use repose::surrogate::ga_bp::DEFAULT_TRAIN_FRACTION;
use serde_json::{json, Value};
use sha2::{Digest, Sha256};

/// The smoke study with edits (JSON pointer → value), written into `dir`.
fn study(dir: &Path, edits: &[(&str, Value)]) -> (Study, PathBuf) {
    let mut v = common::example("calibrate-smoke/study.json");
    for (pointer, value) in edits {
        v = common::edit(v, pointer, Some(value.clone()));
    }
    let path = dir.join("study.json");
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    (parse_study(&v.to_string()).unwrap(), path)
}

/// A made-up smooth response: 20 + 30 μ + 40 μ_r degrees (20.0–55.5 over the
/// study's ranges), so the network has something learnable and known.
fn fake_angle(e: &Experiment) -> f64 {
    let pp = e.contact.particle_particle;
    20.0 + 30.0 * pp.static_friction + 40.0 * pp.rolling_friction
}

#[derive(Debug, thiserror::Error)]
#[error("injected failure of sample {0}")]
struct Injected(u64);

/// A fake runner that counts its calls and fails the listed sample indices.
struct Fake {
    calls: AtomicUsize,
    fail: Vec<u64>,
}

impl Fake {
    fn new(fail: &[u64]) -> Fake {
        Fake {
            calls: AtomicUsize::new(0),
            fail: fail.to_vec(),
        }
    }

    fn run(&self, e: &Experiment, _: &RunDir) -> Result<RunResult, Injected> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        if self.fail.contains(&e.seeds.sample_index) {
            return Err(Injected(e.seeds.sample_index));
        }
        let mut r = RunResult::new(e, "fake");
        r.headline_angle_deg = Some(fake_angle(e));
        Ok(r)
    }
}

fn sha256(path: &Path) -> String {
    hex::encode(Sha256::digest(std::fs::read(path).unwrap()))
}

#[test]
fn sample_writes_one_valid_manifest_per_point_and_reruns_byte_identically() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[]);
    let dir = StudyDir::new(&tmp.path().join("store"), &s, &path);
    let out = sample(&dir, &s, &SampleSettings::default()).unwrap();
    assert_eq!(out.points.len(), 12);
    let design = std::fs::read_to_string(dir.design_path()).unwrap();
    let mut strata: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); 2];
    for (i, line) in design.lines().skip(1).enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells[0], i.to_string());
        let manifest = dir.experiment_path(i);
        // The manifest is canonical JSON: its sha256 is the listed id.
        assert_eq!(sha256(&manifest), cells[3]);
        let e = repose::manifest::read_experiment(&manifest).unwrap();
        assert_eq!(e.seeds.sample_index, i as u64);
        assert_eq!(e.seeds.design_seed, 7);
        for (k, (address, range)) in s.parameters.iter().enumerate() {
            let v: f64 = cells[1 + k].parse().unwrap();
            let u = (v - range.min) / (range.max - range.min);
            strata[k].insert((u * 12.0).floor() as usize);
            let field = address.rsplit('.').next().unwrap();
            let pp = e.contact.particle_particle;
            let set = if field == "static_friction" {
                pp.static_friction
            } else {
                pp.rolling_friction
            };
            assert_eq!(set, v, "{address}");
        }
    }
    for s in &strata {
        assert_eq!(s.len(), 12, "one sample per stratum in every column");
    }
    let lineage = Lineage::read_beside(&dir.design_path()).unwrap();
    assert_eq!(lineage.stage, "sample");
    assert_eq!(lineage.inputs[0].sha256, s.id().to_string());
    assert_eq!(sha256(&dir.study_file()), s.id().to_string());

    let first = common::snapshot(dir.path());
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    assert_eq!(first, common::snapshot(dir.path()));
}

#[test]
fn the_optimised_design_is_more_space_filling() {
    let tmp = tempfile::tempdir().unwrap();
    let (plain, p1) = study(tmp.path(), &[("/design/size", json!(30))]);
    let (opt, p2) = study(
        tmp.path(),
        &[
            ("/design/size", json!(30)),
            ("/design/kind", json!("lhs_optimised")),
        ],
    );
    let store = tmp.path().join("store");
    let a = sample(
        &StudyDir::new(&store, &plain, &p1),
        &plain,
        &SampleSettings::default(),
    )
    .unwrap();
    let b = sample(
        &StudyDir::new(&store, &opt, &p2),
        &opt,
        &SampleSettings::default(),
    )
    .unwrap();
    let o = b.optimisation.unwrap();
    assert!(o.final_phi_p < o.initial_phi_p);
    // Same seed and stream: the optimisation starts from the plain design.
    assert!(b.diagnostics.min_pairwise_distance > a.diagnostics.min_pairwise_distance);
}

#[test]
fn batch_runs_every_sample_and_a_rerun_computes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let fake = Fake::new(&[]);
    let out = batch(&dir, &s, &store, &common::executor(3), |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    assert_eq!((out.total, out.cached, out.computed), (12, 0, 12));
    assert_eq!(fake.calls.load(Ordering::SeqCst), 12);
    let (_, rows) = read_angles(&dir, &s).unwrap();
    for row in &rows {
        let e = repose::manifest::read_experiment(&dir.experiment_path(row.index)).unwrap();
        assert_eq!(row.angle_deg, Some(fake_angle(&e)));
    }
    // Lineage: the design and every result, by sha256.
    let lineage = Lineage::read_beside(&dir.angles_path()).unwrap();
    assert_eq!(lineage.inputs.len(), 2 + 12);
    assert_eq!(lineage.inputs[1].sha256, sha256(&dir.design_path()));
    for input in &lineage.inputs[2..] {
        assert_eq!(input.sha256, sha256(&store.root().join(&input.id_or_path)));
    }

    let before = common::snapshot(dir.path());
    let again = Fake::new(&[]);
    let out = batch(&dir, &s, &store, &common::executor(1), |e, d| {
        again.run(e, d)
    })
    .unwrap();
    assert_eq!((out.cached, out.computed), (12, 0));
    assert_eq!(again.calls.load(Ordering::SeqCst), 0);
    assert_eq!(
        before,
        common::snapshot(dir.path()),
        "a rerun reproduces the table byte for byte"
    );
}

#[test]
fn a_killed_batch_resumes_without_repeating_work() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    // What a kill leaves: samples 0–4 complete, sample 5 started (its directory
    // and manifest, no result), the rest untouched.
    let earlier = Fake::new(&[]);
    for i in 0..5 {
        let e = repose::manifest::read_experiment(&dir.experiment_path(i)).unwrap();
        store.run_cached(&e, |e, d| earlier.run(e, d)).unwrap();
    }
    let e5 = repose::manifest::read_experiment(&dir.experiment_path(5)).unwrap();
    let d5 = store.run_dir(&e5.id());
    std::fs::create_dir_all(d5.path()).unwrap();
    std::fs::write(d5.manifest_path(), repose::manifest::canonical_json(&e5)).unwrap();
    assert_eq!(store.status(&e5.id()), RunStatus::Incomplete);

    let seen = Mutex::new(Vec::new());
    let resumed = Fake::new(&[]);
    let out = batch(&dir, &s, &store, &common::executor(2), |e, d| {
        seen.lock().unwrap().push(e.seeds.sample_index);
        resumed.run(e, d)
    })
    .unwrap();
    assert_eq!((out.cached, out.computed), (5, 7));
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    assert_eq!(
        seen,
        (5..12).collect::<Vec<u64>>(),
        "only the unfinished samples run"
    );
    let (_, rows) = read_angles(&dir, &s).unwrap();
    assert!(rows.iter().all(|r| r.angle_deg.is_some()));
}

#[test]
fn failures_are_recorded_reported_and_retried_without_stopping_the_others() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    let design = sample(&dir, &s, &SampleSettings::default()).unwrap();
    assert_eq!(design.points.len(), 12);
    let flaky = Fake::new(&[3, 8]);
    let out = batch(&dir, &s, &store, &common::executor(2), |e, d| {
        flaky.run(e, d)
    })
    .unwrap();
    assert_eq!(
        out.failures.iter().map(|f| f.index).collect::<Vec<_>>(),
        [3, 8]
    );
    assert_eq!(out.computed, 10);
    assert!(out.failures[0]
        .message
        .contains("injected failure of sample 3"));
    let table = std::fs::read_to_string(dir.angles_path()).unwrap();
    let statuses: Vec<&str> = table
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    for (i, status) in statuses.iter().enumerate() {
        let expected = if i == 3 || i == 8 {
            "failed"
        } else {
            "complete"
        };
        assert_eq!(*status, expected, "sample {i}");
    }
    for f in &out.failures {
        let record = store.load_error(&f.id).unwrap().unwrap();
        assert!(record.error.contains("injected failure"));
    }
    // The next batch retries exactly the two failures.
    let healthy = Fake::new(&[]);
    let out = batch(&dir, &s, &store, &common::executor(2), |e, d| {
        healthy.run(e, d)
    })
    .unwrap();
    assert_eq!((out.cached, out.computed, out.failures.len()), (10, 2, 0));
    assert_eq!(healthy.calls.load(Ordering::SeqCst), 2);
}

#[test]
fn train_and_search_recover_the_fake_response_and_rerun_byte_identically() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[("/design/size", json!(60))]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let fake = Fake::new(&[]);
    batch(&dir, &s, &store, &common::executor(2), |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    let options = TrainOptions {
        settings: TrainSettings::with_seed(7),
        train_fraction: DEFAULT_TRAIN_FRACTION,
    };
    let trained = train_study(&dir, &s, &options).unwrap();
    assert_eq!((trained.train_rows, trained.validation_rows), (40, 20));
    let best = &trained.sweep.rows[trained.sweep.best];
    // The response is linear in the inputs, which a sigmoid network can follow
    // almost exactly: anything below 0.99 would mean broken training.
    assert!(best.validation_r2 > 0.99, "{best:?}");

    let found = search(&dir, &s, &SearchSettings::with_seed(7)).unwrap();
    // Kept = predicted within 5 % of 30 deg; with the model this accurate the
    // true response of every kept point is within the band widened by 1 deg.
    assert!(!found.kept.is_empty() && found.kept.len() < 300);
    let points = std::fs::read_to_string(dir.stage(Stage::Search).join("points.csv")).unwrap();
    for line in points.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let (mu_r, mu, pred): (f64, f64, f64) = (
            c[1].parse().unwrap(),
            c[2].parse().unwrap(),
            c[3].parse().unwrap(),
        );
        let kept = c[4] == "yes";
        assert_eq!(kept, (pred - 30.0).abs() <= 1.5, "{line}");
        assert_eq!(
            kept,
            !c[5].is_empty(),
            "kept points carry a cluster: {line}"
        );
        if kept {
            assert!(
                (20.0 + 30.0 * mu + 40.0 * mu_r - 30.0).abs() <= 2.5,
                "{line}"
            );
        }
    }
    let total: usize = found.clusters.iter().map(|c| c.size).sum();
    assert_eq!(total, found.kept.len());
    for c in &found.clusters {
        assert!((c.predicted_angle_deg - 30.0).abs() < 3.0, "{c:?}");
    }

    // Verify: each candidate re-simulated in the calibration scene and the
    // study's verification scene (the drum at 15 rpm, target 28 deg). The fake
    // DEM's angle at a centre is known (it ignores the rpm), so the table's
    // simulated angle, relative error and verdict are checked against it.
    let checked = verify(&dir, &s, &store, &common::executor(2), 2, |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    let candidates = found.clusters.len().min(2);
    assert_eq!(checked.rows.len(), 2 * candidates);
    for (k, row) in checked.rows.iter().enumerate() {
        let cluster = &found.clusters[k / 2];
        let (scene, measured) = [("drum", 30.0), ("drum15", 28.0)][k % 2];
        assert_eq!((row.group, row.scene.as_str()), (cluster.group, scene));
        assert_eq!(row.target_deg, measured);
        let (mu_r, mu) = (cluster.centre[0], cluster.centre[1]);
        let truth = 20.0 + 30.0 * mu + 40.0 * mu_r;
        // The classic method runs one seed per scene (he2019's Table 3).
        assert_eq!((row.seeds, row.measured), (1, 1));
        assert_eq!(row.mean_deg, Some(truth));
        assert_eq!(
            row.relative_error,
            Some((truth - measured).abs() / measured)
        );
        // One run has no interval: the one acceptance rule cannot decide.
        assert_eq!(row.judgement.verdict, Verdict::Inconclusive);
    }

    let first = common::snapshot(dir.path());
    train_study(&dir, &s, &options).unwrap();
    search(&dir, &s, &SearchSettings::with_seed(7)).unwrap();
    verify(&dir, &s, &store, &common::executor(1), 2, |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    assert_eq!(first, common::snapshot(dir.path()));
}

#[test]
fn each_stage_names_the_stage_to_run_first() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    let fake = Fake::new(&[]);
    let err = batch(&dir, &s, &store, &common::executor(1), |e, d| {
        fake.run(e, d)
    })
    .unwrap_err();
    assert!(matches!(
        &err,
        StudyError::MissingStage { stage, .. } if stage == Stage::Sample.name()
    ));
    assert!(err
        .to_string()
        .ends_with(&format!("run `repose sample {}` first", path.display())));
    let options = TrainOptions {
        settings: TrainSettings::with_seed(0),
        train_fraction: DEFAULT_TRAIN_FRACTION,
    };
    let err = train_study(&dir, &s, &options).unwrap_err();
    assert!(matches!(
        &err,
        StudyError::MissingStage { stage, .. } if stage == Stage::Batch.name()
    ));
    let err = search(&dir, &s, &SearchSettings::with_seed(0)).unwrap_err();
    assert!(matches!(
        &err,
        StudyError::MissingStage { stage, .. } if stage == Stage::Train.name()
    ));
}

#[test]
fn a_real_drum_design_runs_end_to_end() {
    // Three real drum runs (each a few seconds of CPU), two at a time.
    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[("/design/size", json!(3))]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let out = batch(&dir, &s, &store, &common::executor(2), |e, d| {
        run_experiment(e, Some(&d.mcap_path()))
    })
    .unwrap();
    assert!(out.failures.is_empty(), "{:?}", out.failures);
    let (_, rows) = read_angles(&dir, &s).unwrap();
    for row in &rows {
        let e = repose::manifest::read_experiment(&dir.experiment_path(row.index)).unwrap();
        let result = store.load_result(&e.id()).unwrap().unwrap();
        assert_eq!(row.angle_deg, result.headline_angle_deg);
        let a = row.angle_deg.unwrap();
        eprintln!("sample {}: {:?} -> {a:.2} deg", row.index, row.point);
        // A dry granular bed in a drum: anywhere between flat and vertical
        // would be a broken scene.
        assert!(a > 5.0 && a < 70.0, "{a}");
        assert!(store.run_dir(&e.id()).mcap_path().is_file());
    }
}

/// The smoke study sampled and batched with the fake DEM on one worker, in a
/// store under `tmp`.
fn sampled_and_batched(tmp: &Path) -> (Study, Store, StudyDir) {
    let (s, path) = study(tmp, &[]);
    let store = Store::open(tmp.join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let fake = Fake::new(&[]);
    batch(&dir, &s, &store, &common::executor(1), |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    (s, store, dir)
}

/// A stage output edited after its stage ran is never read by the next
/// stage (issue 40.2): train refuses the edited angles table, naming it and
/// the stage to rerun, and a rerun of that stage restores it.
#[test]
fn an_edited_stage_output_is_refused_not_trusted() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, store, dir) = sampled_and_batched(tmp.path());
    let fake = Fake::new(&[]);
    let angles = dir.stage(Stage::Batch).join("angles.csv");
    let original = std::fs::read_to_string(&angles).unwrap();
    let line = original.lines().nth(1).unwrap().to_string();
    // The first sample's angle becomes 99°.
    let mut cells: Vec<&str> = line.split(',').collect();
    let at = cells.len() - 2;
    cells[at] = "99";
    let edited_line = cells.join(",");
    assert_ne!(line, edited_line, "{line}");
    std::fs::write(&angles, original.replacen(&line, &edited_line, 1)).unwrap();
    let options = TrainOptions {
        settings: TrainSettings::with_seed(7),
        train_fraction: DEFAULT_TRAIN_FRACTION,
    };
    let err = train_study(&dir, &s, &options).unwrap_err().to_string();
    assert!(
        err.contains("angles.csv") && err.contains("changed since its stage wrote it"),
        "{err}"
    );
    assert!(err.contains("rerun `repose batch`"), "{err}");
    batch(&dir, &s, &store, &common::executor(1), |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    assert_eq!(std::fs::read_to_string(&angles).unwrap(), original);
    train_study(&dir, &s, &options).unwrap();
}

/// A run damaged after the batch (an emptied result.json, an edited one) is
/// recomputed by the next batch, alone, and the new lineage names the
/// recomputed result's hash, not the tampered one's.
#[test]
fn a_damaged_run_is_recomputed_by_the_next_batch_not_trusted() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, store, dir) = sampled_and_batched(tmp.path());
    let before = common::snapshot(dir.path());

    let e3 = repose::manifest::read_experiment(&dir.experiment_path(3)).unwrap();
    let e7 = repose::manifest::read_experiment(&dir.experiment_path(7)).unwrap();
    std::fs::write(store.run_dir(&e3.id()).result_path(), b"").unwrap();
    let r7 = store.run_dir(&e7.id()).result_path();
    let text = std::fs::read_to_string(&r7).unwrap();
    std::fs::write(
        &r7,
        text.replacen("\"kernel\": \"fake\"", "\"kernel\": \"fakf\"", 1),
    )
    .unwrap();
    assert_eq!(store.status(&e3.id()), RunStatus::Damaged);
    assert_eq!(store.status(&e7.id()), RunStatus::Damaged);

    let seen = Mutex::new(Vec::new());
    let again = Fake::new(&[]);
    let out = batch(&dir, &s, &store, &common::executor(2), |e, d| {
        seen.lock().unwrap().push(e.seeds.sample_index);
        again.run(e, d)
    })
    .unwrap();
    assert_eq!((out.cached, out.computed), (10, 2));
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    assert_eq!(seen, [3, 7]);
    assert_eq!(
        before,
        common::snapshot(dir.path()),
        "the table and its lineage are as before the damage"
    );
}

/// he2019-quick's `repose calibrate` (2026-11-26) ended with `error: 2 of 3
/// run(s) failed` because the candidate's baffle slope and drum surface had
/// too few surface points to fit. A scene that cannot measure an angle is
/// the candidate failing that scene, with the reason in the table; another
/// failure (here an injected one, as an engine error would be) stays an error.
#[test]
fn a_verification_scene_that_cannot_measure_an_angle_is_a_failed_candidate() {
    use repose::dem::health::{HealthCause, HealthError};
    use repose::manifest::Scene;
    use repose::measure::MeasureError;
    use repose::scenes::{drum::DrumError, SceneError};
    use repose::store::HEADLINE_KEY;

    let tmp = tempfile::tempdir().unwrap();
    let (s, path) = study(tmp.path(), &[("/design/size", json!(60))]);
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let fake = Fake::new(&[]);
    batch(&dir, &s, &store, &common::executor(2), |e, d| {
        fake.run(e, d)
    })
    .unwrap();
    let options = TrainOptions {
        settings: TrainSettings::with_seed(7),
        train_fraction: DEFAULT_TRAIN_FRACTION,
    };
    train_study(&dir, &s, &options).unwrap();
    let found = search(&dir, &s, &SearchSettings::with_seed(7)).unwrap();
    assert!(!found.clusters.is_empty());

    // The 15 rpm verification drum's surface is too short to fit; the
    // calibration drum of candidate 2 fails for another reason.
    let is_drum15 = |e: &Experiment| matches!(&e.scene, Scene::Drum(d) if d.rpm == 15.0);
    let runner = |e: &Experiment, d: &RunDir| -> Result<RunResult, SceneError> {
        if is_drum15(e) {
            // As the drum scene records a surface it cannot fit: the run
            // completes without an angle and says why.
            let why = DrumError::Angle(MeasureError::TooFewPoints {
                what: "drum free surface",
                found: 2,
                needed: 3,
            })
            .to_string();
            let mut r = RunResult::new(e, "fake");
            r.unmeasured.insert("static_angle_deg".into(), why.clone());
            r.unmeasured.insert(HEADLINE_KEY.into(), why);
            return Ok(r);
        }
        if e.seeds.sample_index == VERIFY_INDEX + 2 {
            return Err(DrumError::from(HealthError {
                particle_id: 7,
                body_id: None,
                step: 100,
                time_s: 0.01,
                cause: HealthCause::NonFinite,
            })
            .into());
        }
        Ok(fake.run(e, d).unwrap())
    };
    let checked = verify(&dir, &s, &store, &common::executor(2), 2, runner).unwrap();
    let candidates = found.clusters.len().min(2);
    assert_eq!(checked.rows.len(), 2 * candidates);
    let reason = "drum: static angle: not measurable: drum free surface has 2 \
                  surface points, at least 3 are needed";
    for row in &checked.rows {
        match (row.scene.as_str(), row.group) {
            ("drum15", _) => {
                // A missing replicate with its reason, never a value.
                assert_eq!(row.failures, vec![format!("seed 0: {reason}")]);
                assert_eq!((row.mean_deg, row.relative_error), (None, None));
                assert_eq!(row.judgement.verdict, Verdict::Inconclusive);
            }
            (_, 2) => assert_eq!((row.measured, row.failures.len()), (0, 1), "{row:?}"),
            _ => assert_eq!((row.measured, row.failures.len()), (1, 0), "{row:?}"),
        }
    }
    // Only the engine failure counts as a failed run (by its store status):
    // the command exits with it after writing the tables.
    assert_eq!(checked.failed_runs, candidates - 1);
    assert_eq!(checked.runs, 2 * candidates);
    // The Markdown table says why.
    assert!(
        checked
            .markdown
            .contains("| 1 | drum15 | 1 (0) | not measurable | — | 28.00 | — | — | inconclusive (< 2 seeds measured) |"),
        "{}",
        checked.markdown
    );
    assert!(
        checked
            .markdown
            .contains(&format!("- candidate 1 drum15: seed 0: {reason}")),
        "{}",
        checked.markdown
    );
    // runs.csv's cells hold no commas: the message's comma is a semicolon,
    // and the table reads back with every row as wide as its header.
    let csv = std::fs::read_to_string(checked.table.with_file_name("runs.csv")).unwrap();
    let first = format!("drum15,{},", VERIFY_INDEX + 1);
    let drum15 = csv.lines().find(|l| l.starts_with(&first)).unwrap();
    let cell = reason.replace(',', ";");
    assert!(drum15.ends_with(&format!(",{cell}")), "{drum15}");
    let table = repose::report::table::Table::parse(&csv).unwrap();
    assert!(table.rows.iter().all(|r| r.len() == table.header.len()));
}
