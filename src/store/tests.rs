//! Store tests that need the crate-private fault hook: interrupted writes, failed
//! runs, cache hits.

use std::cell::Cell;
use std::io;
use std::path::Path;
use std::sync::Arc;

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
        .with_input(InputRef::file("table", &input, Some(tmp.path())).unwrap())
        .with_input(InputRef::file("outside", &input, Some(&tmp.path().join("runs"))).unwrap());
    let path = lineage.write_beside(&output).unwrap();
    assert_eq!(path, tmp.path().join("report.md.lineage.json"));
    let back = Lineage::read_beside(&output).unwrap();
    assert_eq!(back, lineage);
    assert_eq!(back.repose_version, env!("CARGO_PKG_VERSION"));
    assert_eq!(
        back.inputs[1].sha256,
        hex::encode(<sha2::Sha256 as sha2::Digest>::digest(b"a,b\n1,2\n"))
    );
    // Inside the store: relative to its root; outside: absolute.
    assert_eq!(back.inputs[1].id_or_path, "table.csv");
    assert_eq!(back.inputs[2].id_or_path, input.display().to_string());
    assert!(Path::new(&back.inputs[2].id_or_path).is_absolute());
}

/// A complete run of `experiment()` with a log, in a fresh store; returns the
/// store (in `tmp`), the run directory and the bytes of result.json and run.mcap.
fn complete_run(tmp: &Path) -> (Store, RunDir, Vec<u8>, Vec<u8>) {
    let store = Store::open(tmp).unwrap();
    let e = experiment();
    store
        .run_cached(&e, |e, dir| {
            std::fs::write(dir.mcap_path(), b"a log").unwrap();
            Ok::<_, Never>(result_for(e))
        })
        .unwrap();
    let dir = store.run_dir(&e.id());
    let result = std::fs::read(dir.result_path()).unwrap();
    let log = std::fs::read(dir.mcap_path()).unwrap();
    (store, dir, result, log)
}

/// One way a finished run can be changed outside repose.
struct Tampering {
    /// The file it changes.
    file: &'static str,
    /// The change.
    apply: fn(&RunDir),
    /// Whether a listing (which compares the log's length only) sees it.
    listed: bool,
}

/// Each way a finished run can be changed outside repose.
fn tamperings() -> Vec<Tampering> {
    fn flip_result_byte(d: &RunDir) {
        let mut b = std::fs::read(d.result_path()).unwrap();
        let at = b.iter().position(|&c| c == b'5').unwrap();
        b[at] = b'6';
        std::fs::write(d.result_path(), b).unwrap();
    }
    fn edit_manifest(d: &RunDir) {
        let t = std::fs::read_to_string(d.manifest_path()).unwrap();
        std::fs::write(d.manifest_path(), t.replacen("0.", "1.", 1)).unwrap();
    }
    fn delete_log(d: &RunDir) {
        std::fs::remove_file(d.mcap_path()).unwrap();
    }
    fn empty_result(d: &RunDir) {
        std::fs::write(d.result_path(), b"").unwrap();
    }
    fn flip_log_byte(d: &RunDir) {
        std::fs::write(d.mcap_path(), b"a lug").unwrap();
    }
    let t = |file, apply, listed| Tampering {
        file,
        apply,
        listed,
    };
    vec![
        t(RESULT_FILE, flip_result_byte, true),
        t(MANIFEST_FILE, edit_manifest, true),
        t(MCAP_FILE, delete_log, true),
        t(RESULT_FILE, empty_result, true),
        t(MCAP_FILE, flip_log_byte, false),
    ]
}

#[test]
fn a_tampered_run_is_damaged_never_a_cache_hit_and_is_recomputed() {
    for Tampering {
        file,
        apply,
        listed,
    } in tamperings()
    {
        let tmp = tempfile::tempdir().unwrap();
        let (store, dir, result, log) = complete_run(tmp.path());
        apply(&dir);
        let id = dir.id().clone();
        match store.check(&id, Depth::Full) {
            RunState::Damaged(problem) => assert!(problem.contains(file), "{file}: {problem}"),
            other => panic!("{file}: expected damaged, got {other:?}"),
        }
        assert_eq!(store.status(&id), RunStatus::Damaged, "{file}");
        assert!(
            matches!(store.load_result(&id), Err(StoreError::Damaged { .. })),
            "{file}"
        );
        let summary = store.list().unwrap().remove(0);
        // A listing compares the log's length only: a same-length edit of the
        // log is found by the full checks (cache hit, show, audit).
        if listed {
            assert_eq!(summary.status, RunStatus::Damaged, "{file}");
            assert!(summary.problem.unwrap().contains(file));
        } else {
            assert_eq!(summary.status, RunStatus::Complete, "{file}");
        }

        let notes = Arc::new(std::sync::Mutex::new(Vec::new()));
        let sink = notes.clone();
        let store = store.with_notices(Arc::new(move |t: &str| {
            sink.lock().unwrap().push(t.to_string())
        }));
        let calls = Cell::new(0);
        let (_, outcome) = store
            .run_cached(&experiment(), |e, dir| {
                calls.set(calls.get() + 1);
                std::fs::write(dir.mcap_path(), b"a log").unwrap();
                Ok::<_, Never>(result_for(e))
            })
            .unwrap();
        assert_eq!(
            (outcome, calls.get()),
            (CacheOutcome::Computed, 1),
            "{file}"
        );
        assert!(
            notes.lock().unwrap().iter().any(|n| n.contains("damaged")),
            "{file}: the recomputation is announced"
        );
        assert_eq!(std::fs::read(dir.result_path()).unwrap(), result, "{file}");
        assert_eq!(std::fs::read(dir.mcap_path()).unwrap(), log, "{file}");
        assert_eq!(store.status(&id), RunStatus::Complete, "{file}");
    }
}

#[test]
fn a_run_is_complete_only_once_sealed() {
    let tmp = tempfile::tempdir().unwrap();
    let (store, dir, _, _) = complete_run(tmp.path());
    let seal: Seal = Store::read_json(&dir.seal_path()).unwrap();
    assert_eq!(seal.id, *dir.id());
    let names: Vec<&str> = seal.files.keys().map(String::as_str).collect();
    assert_eq!(names, [MANIFEST_FILE, RESULT_FILE, MCAP_FILE]);
    assert_eq!(seal.files[MANIFEST_FILE].sha256, dir.id().as_str());
    // A kill between result.json and seal.json: not complete, so recomputed.
    std::fs::remove_file(dir.seal_path()).unwrap();
    assert_eq!(store.status(dir.id()), RunStatus::Incomplete);
}

#[test]
fn two_callers_of_one_run_compute_it_once() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().to_path_buf();
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let outcomes: Vec<CacheOutcome> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                // Two stores on one root: as two processes would open it.
                let store = Store::open(&root).unwrap();
                let calls = &calls;
                s.spawn(move || {
                    store
                        .run_cached(&experiment(), |e, _| {
                            calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                            std::thread::sleep(std::time::Duration::from_millis(300));
                            Ok::<_, Never>(result_for(e))
                        })
                        .unwrap()
                        .1
                })
            })
            .collect();
        workers.into_iter().map(|w| w.join().unwrap()).collect()
    });
    assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 1);
    let mut outcomes = outcomes;
    outcomes.sort_by_key(|o| *o == CacheOutcome::Hit);
    assert_eq!(outcomes, [CacheOutcome::Computed, CacheOutcome::Hit]);
}

#[test]
fn temp_files_of_killed_writers_are_removed_when_the_run_is_claimed() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let e = experiment();
    let dir = store.run_dir(&e.id());
    std::fs::create_dir_all(dir.path()).unwrap();
    // As a killed PID 1 leaves them (the container case), and one with this
    // process's own pid.
    let stale = [
        format!("{TEMP_PREFIX}{MCAP_FILE}-1-0"),
        format!("{TEMP_PREFIX}{RESULT_FILE}-{}-0", std::process::id()),
    ];
    for name in &stale {
        std::fs::write(dir.path().join(name), b"partial").unwrap();
    }
    store
        .run_cached(&e, |e, _| Ok::<_, Never>(result_for(e)))
        .unwrap();
    for name in &stale {
        assert!(!dir.path().join(name).exists(), "{name} was left behind");
    }
}
