//! `repose audit`: a clean chain passes, and each kind of tampering is found
//! and named; re-runs reproduce result.json and run.mcap byte for byte.

use std::fs;
use std::path::Path;

use repose::audit::audit;
use repose::manifest::read_experiment;
use repose::scenes::run_experiment;
use repose::store::{InputRef, Lineage, Store};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A store with one completed pair run, and a study output directory whose
/// `table.csv` names that run and a file input.
fn setup(tmp: &Path) -> (Store, std::path::PathBuf) {
    let store = Store::open(tmp.join("runs")).unwrap();
    let experiment =
        read_experiment(&root().join("experiments/validation/pair_hertz_particle_particle.json"))
            .unwrap();
    store
        .run_cached(&experiment, |e, dir| {
            run_experiment(e, Some(&dir.mcap_path()))
        })
        .unwrap();
    let out = tmp.join("runs/studies/demo");
    fs::create_dir_all(&out).unwrap();
    let input = out.join("design.csv");
    fs::write(&input, "index,x\n0,0.5\n").unwrap();
    let table = out.join("table.csv");
    fs::write(&table, "index,angle\n0,30\n").unwrap();
    Lineage::new("batch", serde_json::json!({}))
        .with_input(InputRef::file("design", &input, Some(store.root())).unwrap())
        .with_input(InputRef::id("run", &experiment.id()))
        .write_beside(&table)
        .unwrap();
    // A second table names the run by its result file, relative to the store
    // root (as the calibration stages record it).
    let result = store.run_dir(&experiment.id()).result_path();
    let by_file = InputRef::file("run_result", &result, Some(store.root())).unwrap();
    assert_eq!(
        by_file.id_or_path,
        format!("{}/result.json", experiment.id())
    );
    let fit = out.join("fit.csv");
    fs::write(&fit, "x\n").unwrap();
    Lineage::new("train", serde_json::json!({}))
        .with_input(by_file)
        .write_beside(&fit)
        .unwrap();
    (store, out)
}

#[test]
fn a_clean_chain_passes_and_reruns_reproduce() {
    let tmp = tempfile::tempdir().unwrap();
    let (store, out) = setup(tmp.path());
    let report = audit(&store, &out, 1, 0).unwrap();
    assert_eq!(report.records, 2);
    assert_eq!(report.files_checked, 2);
    assert_eq!(report.runs_checked, 1);
    assert_eq!(report.reruns.len(), 1);
    assert!(report.is_clean(), "{report:#?}");
    // The scratch store is gone afterwards.
    let leftovers: Vec<_> = fs::read_dir(store.root())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".audit-"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn a_changed_input_file_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let (store, out) = setup(tmp.path());
    fs::write(out.join("design.csv"), "index,x\n0,0.6\n").unwrap();
    let report = audit(&store, &out, 0, 0).unwrap();
    assert!(!report.is_clean());
    assert_eq!(report.broken.len(), 1);
    let problem = &report.broken[0].problem;
    assert!(
        problem.contains("design") && problem.contains("changed since the stage ran"),
        "{problem}"
    );
}

#[test]
fn a_tampered_or_missing_run_and_a_missing_output_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let (store, out) = setup(tmp.path());
    let id = store.ids().unwrap().remove(0);
    let manifest = store.run_dir(&id).manifest_path();
    let text = fs::read_to_string(&manifest).unwrap();
    fs::write(&manifest, text.replace("0.5", "0.25")).unwrap();
    fs::remove_file(out.join("table.csv")).unwrap();
    let report = audit(&store, &out, 0, 0).unwrap();
    let problems: Vec<&str> = report.broken.iter().map(|b| b.problem.as_str()).collect();
    assert!(
        problems
            .iter()
            .any(|p| p.contains("output") && p.contains("missing")),
        "{problems:?}"
    );
    assert!(
        problems
            .iter()
            .any(|p| p.contains("damaged") && p.contains("manifest.json")),
        "{problems:?}"
    );

    fs::remove_dir_all(store.run_dir(&id).path()).unwrap();
    let report = audit(&store, &out, 0, 0).unwrap();
    assert!(
        report.broken.iter().any(|b| b.problem.contains("no run")),
        "{report:#?}"
    );
}

#[test]
fn a_directory_without_lineage_is_an_error() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path().join("runs")).unwrap();
    let err = audit(&store, tmp.path(), 0, 0).unwrap_err();
    assert!(err.to_string().contains("no lineage records"), "{err}");
}

/// Every file of a run is checked against its seal without `--rerun`: a
/// deleted log or an edited result is a broken link, named.
#[test]
fn a_deleted_log_or_an_edited_result_is_found_without_rerunning() {
    for (file, damage) in [
        (
            "run.mcap",
            (|p: &Path| fs::remove_file(p).unwrap()) as fn(&Path),
        ),
        ("result.json", |p: &Path| {
            let t = fs::read_to_string(p).unwrap();
            fs::write(p, t.replacen('1', "2", 1)).unwrap()
        }),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let (store, out) = setup(tmp.path());
        let id = store.ids().unwrap().remove(0);
        damage(&store.run_dir(&id).path().join(file));
        let report = audit(&store, &out, 0, 0).unwrap();
        assert!(
            report
                .broken
                .iter()
                .any(|b| b.problem.contains("damaged") && b.problem.contains(file)),
            "{file}: {report:#?}"
        );
    }
}
