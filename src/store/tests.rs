//! Store tests that need the crate-private fault hook: interrupted writes, failed
//! runs, cache hits.

use std::cell::Cell;
use std::io;
use std::path::Path;

use super::*;
use crate::manifest::parse_experiment;

fn experiment() -> Experiment {
    parse_experiment(include_str!(
        "../../experiments/validation/pair_hertz_rigid_wall.json"
    ))
    .expect("valid example")
}

fn result_for(e: &Experiment) -> RunResult {
    let mut r = RunResult::new(e, "test-kernel");
    r.measurements.insert("restitution".into(), 0.5);
    r.headline_angle_deg = Some(30.0);
    r
}

#[derive(Debug, thiserror::Error)]
#[error("the test runner failed")]
struct Boom;

type Never = std::convert::Infallible;

#[test]
fn cache_hit_returns_the_stored_result_without_calling_the_runner() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let calls = Cell::new(0);
    let runner = |e: &Experiment, _: &RunDir| -> Result<RunResult, Never> {
        calls.set(calls.get() + 1);
        Ok(result_for(e))
    };
    let (first, outcome) = store.run_cached(&e, runner).unwrap();
    assert_eq!(outcome, CacheOutcome::Computed);
    let (second, outcome) = store.run_cached(&e, runner).unwrap();
    assert_eq!(outcome, CacheOutcome::Hit);
    assert_eq!(calls.get(), 1, "the runner must not run on a cache hit");
    assert_eq!(first, second);
    assert_eq!(store.status(&e.id()), RunStatus::Complete);
    // manifest.json is the canonical JSON, so its sha256 is the id.
    let manifest = std::fs::read(store.run_dir(&e.id()).manifest_path()).unwrap();
    assert_eq!(ContentId::of_bytes(&manifest), e.id());
    assert!(store.run_dir(&e.id()).timing_path().is_file());
}

#[test]
fn identical_manifests_give_byte_identical_results() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let e = experiment();
    for dir in [a.path(), b.path()] {
        Store::open(dir)
            .unwrap()
            .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
            .unwrap();
    }
    let read = |d: &Path| std::fs::read(d.join(e.id().as_str()).join(RESULT_FILE)).unwrap();
    assert_eq!(read(a.path()), read(b.path()));
}

#[test]
fn a_failed_run_records_error_json_and_no_result_then_a_retry_completes() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let err = store
        .run_cached(&e, |_, _| Err::<RunResult, _>(Boom))
        .unwrap_err();
    assert!(matches!(
        err,
        RunError::Runner {
            record_failure: None,
            ..
        }
    ));
    let dir = store.run_dir(&e.id());
    assert_eq!(store.status(&e.id()), RunStatus::Failed);
    assert!(!dir.result_path().exists());
    let record = store.load_error(&e.id()).unwrap().unwrap();
    assert_eq!(record.error, "the test runner failed");

    let (_, outcome) = store
        .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
        .unwrap();
    assert_eq!(outcome, CacheOutcome::Computed);
    assert_eq!(store.status(&e.id()), RunStatus::Complete);
    assert!(
        !dir.error_path().exists(),
        "a completed retry leaves no stale error.json"
    );
}

#[test]
fn a_write_interrupted_before_rename_leaves_no_complete_looking_run() {
    let tmp = tempfile::tempdir().unwrap();
    let mut store = Store::open(tmp.path()).unwrap();
    store.fault = Some(Box::new(|temp: &Path| {
        if temp.to_string_lossy().contains(RESULT_FILE) {
            Err(io::Error::other(
                "injected crash between temp write and rename",
            ))
        } else {
            Ok(())
        }
    }));
    let e = experiment();
    let err = store
        .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
        .unwrap_err();
    assert!(
        matches!(err, RunError::Store(StoreError::Io { .. })),
        "{err}"
    );
    let dir = store.run_dir(&e.id());
    assert_eq!(store.status(&e.id()), RunStatus::Incomplete);
    assert!(!dir.result_path().exists());
    assert!(store.load_result(&e.id()).unwrap().is_none());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(TEMP_PREFIX))
        .collect();
    assert!(leftovers.is_empty(), "temp files left: {leftovers:?}");

    // The next attempt (no fault) computes instead of trusting the partial run.
    store.fault = None;
    let (_, outcome) = store
        .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
        .unwrap();
    assert_eq!(outcome, CacheOutcome::Computed);
}

#[test]
fn a_temp_file_left_by_a_killed_process_does_not_count_as_a_result() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let dir = store.run_dir(&e.id());
    std::fs::create_dir_all(dir.path()).unwrap();
    std::fs::write(
        dir.path().join(format!("{TEMP_PREFIX}{RESULT_FILE}-1-0")),
        b"{\"partial\":",
    )
    .unwrap();
    assert_eq!(store.status(&e.id()), RunStatus::Incomplete);
    let summaries = store.list().unwrap();
    assert_eq!(summaries.len(), 1);
    assert_eq!(summaries[0].status, RunStatus::Incomplete);
}

#[test]
fn a_result_with_a_non_finite_number_is_refused_and_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let err = store
        .run_cached(&e, |e, _| {
            let mut r = result_for(e);
            r.measurements.insert("peak_force_n".into(), f64::NAN);
            Ok::<_, Never>(r)
        })
        .unwrap_err();
    assert!(
        matches!(err, RunError::BadResult(ref m) if m.contains("peak_force_n")),
        "{err}"
    );
    assert_eq!(store.status(&e.id()), RunStatus::Failed);
}

#[test]
fn a_result_for_another_experiment_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let mut other = e.clone();
    other.seeds.packing_seed += 1;
    let err = store
        .run_cached(&e, |_, _| Ok::<_, Never>(result_for(&other)))
        .unwrap_err();
    assert!(
        matches!(err, RunError::Store(StoreError::ResultMismatch { .. })),
        "{err}"
    );
    assert_ne!(store.status(&e.id()), RunStatus::Complete);
}

#[test]
fn an_invalid_experiment_is_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let mut e = experiment();
    e.contact.particle_particle.restitution = 1.3;
    let err = store
        .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
        .unwrap_err();
    assert!(matches!(err, RunError::Invalid(_)));
    assert_eq!(store.status(&e.id()), RunStatus::Missing);
}

#[test]
fn prefixes_resolve_uniquely_or_name_every_candidate() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let a = format!("ab{}", "0".repeat(62));
    let b = format!("ab{}", "1".repeat(62));
    for id in [&a, &b] {
        std::fs::create_dir_all(tmp.path().join(id)).unwrap();
    }
    std::fs::create_dir_all(tmp.path().join("not-a-run")).unwrap();
    assert_eq!(store.resolve_prefix("ab0").unwrap().as_str(), a);
    match store.resolve_prefix("ab").unwrap_err() {
        StoreError::Ambiguous { candidates, .. } => {
            let c: Vec<&str> = candidates.iter().map(ContentId::as_str).collect();
            assert_eq!(c, [a.as_str(), b.as_str()]);
        }
        other => panic!("expected ambiguity, got {other}"),
    }
    assert!(matches!(
        store.resolve_prefix("ff"),
        Err(StoreError::NoMatch { .. })
    ));
    assert!(matches!(
        store.resolve_prefix("AB"),
        Err(StoreError::BadPrefix { .. })
    ));
    assert!(matches!(
        store.resolve_prefix(""),
        Err(StoreError::BadPrefix { .. })
    ));
}

#[test]
fn lineage_is_written_beside_its_output_and_names_its_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("table.csv");
    std::fs::write(&input, b"a,b\n1,2\n").unwrap();
    let output = tmp.path().join("report.md");
    std::fs::write(&output, b"# report\n").unwrap();
    let e = experiment();
    let lineage = Lineage::new("report", serde_json::json!({"digits": 3}))
        .with_input(InputRef::id("run", &e.id()))
        .with_input(InputRef::file("table", &input).unwrap());
    let path = lineage.write_beside(&output).unwrap();
    assert_eq!(path, tmp.path().join("report.md.lineage.json"));
    let back = Lineage::read_beside(&output).unwrap();
    assert_eq!(back, lineage);
    assert_eq!(back.repose_version, env!("CARGO_PKG_VERSION"));
    assert_eq!(
        back.inputs[1].sha256,
        hex::encode(<sha2::Sha256 as sha2::Digest>::digest(b"a,b\n1,2\n"))
    );
}
