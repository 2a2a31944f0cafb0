//! The yan2015 smoke study end to end with real DEM runs
//! (experiments/yan2015-smoke/study.json): `repose sensitivity` runs the
//! reduced full factorial (2 × 2 × 2 points, one packing seed each) in the
//! hopper, fits the power laws and the flow-rate curves (level 1), the PCA
//! of the sensitivity matrices (level 2), the contact-law norms and
//! cross-correlations (level 3), and re-simulates the paper's example point
//! with 2 seeds. Once with one worker and once with two: the stores must
//! agree byte for byte, the analysis tables must match golden/yan2015_smoke/
//! (ids, seeds and counts exactly, floats within [`TOL`]), and the level-3
//! tables — deterministic functions of the contact laws, no simulation —
//! byte for byte.
//!
//! `REPOSE_BLESS=1 cargo test --release --test yan2015_golden` rewrites the
//! pinned files (after the determinism check); review their diff in the
//! commit. About 2 minutes of CPU per store.

mod common;

use std::path::{Path, PathBuf};

use repose::commands::sensitivity;
use repose::exec::Executor;
use repose::scenes::plan::Limits;
use repose::study::plan::design_study::read_design_study;
use repose::study::stages::sensitivity::Levels;

const STUDY: &str = "experiments/yan2015-smoke/study.json";
const GOLDEN_DIR: &str = "golden/yan2015_smoke";

/// Relative tolerance of floating-point cells of the run-based tables. On
/// one platform the study is bit-identical (this test checks the analysis
/// on one and two workers byte for byte), so any difference is a change of behaviour; the
/// band absorbs last-digit libm differences in the analysis between
/// platforms (a DEM run amplifies last-bit differences: where libm differs,
/// re-bless and review the diff).
const TOL: f64 = 1e-9;

/// Columns compared exactly: ids, seeds, indices, counts, names, statuses.
const EXACT: [&str; 15] = [
    "verdict",
    "unresolved",
    "seeds_to_decide",
    "point",
    "replicate",
    "packing_seed",
    "hopper_id",
    "status",
    "response",
    "parameter",
    "observations",
    "missing_runs",
    "dof",
    "equation",
    "component",
];

fn study_dir(store: &Path) -> PathBuf {
    let path = common::root().join(STUDY);
    let study = read_design_study(&path).unwrap();
    store
        .join("studies")
        .join(format!("{}-{}", study.name, study.id().short(12)))
}

/// `repose sensitivity STUDY --jobs <jobs> [--json]` into `store`; returns
/// what it prints.
fn run(store: &Path, jobs: usize, json: bool) -> String {
    let mut out = Vec::new();
    sensitivity(
        store,
        &common::root().join(STUDY),
        &Executor::local(jobs, Limits::default()),
        Levels::ALL,
        json,
        &mut out,
    )
    .unwrap_or_else(|e| panic!("sensitivity failed: {e}\n{}", String::from_utf8_lossy(&out)));
    String::from_utf8(out).unwrap()
}

/// Copies the run directories of store `from` (everything but `studies/`)
/// into a new store `to`.
fn copy_runs(from: &Path, to: &Path) {
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        if entry.file_name() == "studies" {
            continue;
        }
        copy_tree(&entry.path(), &to.join(entry.file_name()));
    }
}

fn copy_tree(from: &Path, to: &Path) {
    if from.is_dir() {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap() {
            let entry = entry.unwrap();
            copy_tree(&entry.path(), &to.join(entry.file_name()));
        }
    } else {
        std::fs::copy(from, to).unwrap();
    }
}

/// Doubles the first number found in `v` (depth first); false if none.
fn double_first_number(v: &mut serde_json::Value) -> bool {
    match v {
        serde_json::Value::Number(n) => {
            *v = serde_json::json!(2.0 * n.as_f64().unwrap() + 1.0);
            true
        }
        serde_json::Value::Array(items) => items.iter_mut().any(double_first_number),
        serde_json::Value::Object(map) => map.values_mut().any(double_first_number),
        _ => false,
    }
}

#[test]
fn the_smoke_study_is_deterministic_and_matches_the_golden_tables() {
    let tmp = tempfile::tempdir().unwrap();
    let one = tmp.path().join("one-worker");
    let two = tmp.path().join("two-workers");
    let summary = run(&two, 2, false);
    eprintln!("{summary}");
    // The analysis again on one worker, over the same runs: the second store
    // starts with the first one's runs (and no study outputs), so what is
    // recomputed is every stage of the analysis. That the DEM runs
    // themselves do not depend on the worker count is checked by
    // cai2024_golden (a whole study on one and two workers) and
    // dem_determinism; simulating this study twice cost 3–4 minutes of CI.
    copy_runs(&two, &one);
    run(&one, 1, false);
    // Every file of the two stores — study outputs, lineage, manifests, each
    // run's result.json and MCAP log — is byte-identical: no output says how
    // many runs were already stored (issue 40.5).
    let (a, b) = (common::snapshot(&one), common::snapshot(&two));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert!(x.1 == y.1, "{} differs between the stores", x.0.display());
    }
    for level in ["Level 1", "Level 2", "Level 3", "yan2015_example"] {
        assert!(summary.contains(level), "{level} missing:\n{summary}");
    }

    // A second call reads every level back from the store.
    let json: serde_json::Value = serde_json::from_str(&run(&two, 2, true)).unwrap();
    let stages = json["stages"].as_array().unwrap();
    assert_eq!(stages.len(), 3);
    assert!(stages.iter().all(|s| s["cached"] == true), "{stages:?}");
    assert_eq!(json["cached_runs"], json["runs"]);

    let dir = study_dir(&two).join("sensitivity");
    // Issue 40.2: an edited stage outcome is never served from the cache.
    // Double one number of level1.json in the first store: `audit` reports
    // the edit, and the next run recomputes level 1 (its stage no longer
    // cached) and restores every output byte for byte.
    let level1 = study_dir(&one).join("sensitivity/level1/level1.json");
    let original = std::fs::read(&level1).unwrap();
    let mut v: serde_json::Value = serde_json::from_slice(&original).unwrap();
    assert!(double_first_number(&mut v), "level1.json holds a number");
    std::fs::write(&level1, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
    let tampered = repose::audit::audit(
        &repose::store::Store::open(&one).unwrap(),
        &study_dir(&one),
        0,
        0,
    )
    .unwrap();
    assert!(
        tampered.broken.iter().any(|b| b
            .problem
            .contains("level1.json changed since the stage wrote it")),
        "{tampered:#?}"
    );
    let json: serde_json::Value = serde_json::from_str(&run(&one, 1, true)).unwrap();
    let level1_state = json["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == "level1")
        .unwrap();
    assert_eq!(level1_state["cached"], false, "{}", json["stages"]);
    assert_eq!(std::fs::read(&level1).unwrap(), original);
    assert_eq!(common::snapshot(&one), a, "the first store is restored");
    // The same for any other output of a cached stage: an edited or deleted
    // estimates.csv, a deleted lineage record or a deleted level-3 table is
    // rewritten by the next run (before, level 1 was served from its JSON
    // and estimates.csv stayed as edited or missing).
    let stage_file = |p: &str| study_dir(&one).join("sensitivity").join(p);
    let estimates = stage_file("level1/estimates.csv");
    let tamper = |case: &str| match case {
        "edited estimates.csv" => {
            let mut text = std::fs::read_to_string(&estimates).unwrap();
            text.push_str("mu_s,theta_deg,9,9,9\n");
            std::fs::write(&estimates, text).unwrap();
        }
        "deleted estimates.csv" => std::fs::remove_file(&estimates).unwrap(),
        "deleted lineage record" => {
            std::fs::remove_file(stage_file("level1/fits.csv.lineage.json")).unwrap()
        }
        "deleted norms.csv" => std::fs::remove_file(stage_file("level3/norms.csv")).unwrap(),
        _ => unreachable!("{case}"),
    };
    for case in [
        "edited estimates.csv",
        "deleted estimates.csv",
        "deleted lineage record",
        "deleted norms.csv",
    ] {
        tamper(case);
        assert_ne!(common::snapshot(&one), a, "{case}");
        if case == "deleted lineage record" {
            // audit names the output whose record is gone.
            let report = repose::audit::audit(
                &repose::store::Store::open(&one).unwrap(),
                &study_dir(&one),
                0,
                0,
            )
            .unwrap();
            assert!(
                report
                    .broken
                    .iter()
                    .any(|b| b.problem.contains("fits.csv has no lineage record")),
                "{report:#?}"
            );
        }
        run(&one, 1, true);
        assert_eq!(common::snapshot(&one), a, "{case}: the store is restored");
    }

    let mut audit_out = Vec::new();
    repose::commands::audit(&two, &study_dir(&two), 2, 1, &mut audit_out)
        .unwrap_or_else(|e| panic!("audit: {e}\n{}", String::from_utf8_lossy(&audit_out)));
    for svg in [
        "level1/alpha_deg.svg",
        "level1/theta_deg.svg",
        "level1/flow_curves.svg",
    ] {
        let text = std::fs::read_to_string(dir.join(svg)).unwrap();
        assert!(text.contains("<svg"), "{svg}");
    }
    // 8 design points × 1 replicate, α and θ measured in every run (four
    // ortho-slice angles each enter the fits).
    let responses = std::fs::read_to_string(dir.join("responses.csv")).unwrap();
    assert_eq!(responses.lines().count(), 1 + 8, "{responses}");
    let observations = std::fs::read_to_string(dir.join("level1/observations.csv")).unwrap();
    assert_eq!(
        observations
            .lines()
            .filter(|l| l.contains(",theta_deg,"))
            .count(),
        8 * 4
    );

    let run_tables = [
        ("responses.csv", dir.join("responses.csv")),
        ("estimates.csv", dir.join("level1/estimates.csv")),
        ("fits.csv", dir.join("level1/fits.csv")),
        ("flow_curves.csv", dir.join("level1/flow_curves.csv")),
        ("pca.csv", dir.join("level2/pca.csv")),
        ("verification.csv", dir.join("noise/verification.csv")),
    ];
    let exact_tables = [
        ("norms.csv", dir.join("level3/norms.csv")),
        (
            "cross_correlation.csv",
            dir.join("level3/cross_correlation.csv"),
        ),
    ];
    let golden = common::root().join(GOLDEN_DIR);
    if common::blessing() {
        std::fs::create_dir_all(&golden).unwrap();
        for (name, path) in run_tables.iter().chain(&exact_tables) {
            std::fs::copy(path, golden.join(name)).unwrap();
        }
        return;
    }
    for (name, path) in &run_tables {
        let now = std::fs::read_to_string(path).unwrap();
        common::compare_golden(GOLDEN_DIR, name, &now, &EXACT, TOL);
    }
    for (name, path) in &exact_tables {
        let now = std::fs::read_to_string(path).unwrap();
        let pinned = std::fs::read_to_string(golden.join(name)).unwrap();
        assert!(
            now == pinned,
            "{name} differs from {GOLDEN_DIR}/{name}: level 3 is a deterministic function \
             of the contact laws; if the laws changed on purpose, rerun with REPOSE_BLESS=1"
        );
    }

    // `--table` fits the same power law from any CSV: θ's observations give
    // the level-1 estimates again, at full precision in JSON.
    let theta: Vec<&str> = observations
        .lines()
        .enumerate()
        .filter(|(i, l)| *i == 0 || l.contains(",theta_deg,"))
        .map(|(_, l)| l)
        .collect();
    let table = tmp.path().join("theta.csv");
    std::fs::write(&table, theta.join("\n") + "\n").unwrap();
    let o = common::repose(
        tmp.path(),
        &[
            "sensitivity",
            "--table",
            table.to_str().unwrap(),
            "--response",
            "value",
            "--factors",
            "e,mu_r,mu_s",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
    let fit: serde_json::Value = serde_json::from_str(&common::stdout(&o)).unwrap();
    let level1: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("level1/level1.json")).unwrap()).unwrap();
    let theta_fit = level1["fits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["response"] == "theta_deg")
        .unwrap();
    assert_eq!(fit["fit"]["estimates"], theta_fit["fit"]["estimates"]);
    assert_eq!(fit["fit"]["ci_low"], theta_fit["fit"]["ci_low"]);
    assert_eq!(fit["fit"]["correlation"], theta_fit["fit"]["correlation"]);
}

#[test]
fn level_three_alone_runs_no_simulation() {
    let tmp = tempfile::tempdir().unwrap();
    let o = common::repose(
        tmp.path(),
        &[
            "sensitivity",
            "experiments/yan2015-quick/study.json",
            "--level",
            "3",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&common::stdout(&o)).unwrap();
    assert_eq!(json["runs"], 0);
    let sets = json["level3"]["Ok"]["sets"].as_array().unwrap();
    // The base set and 36 design points, force and torque each.
    assert_eq!(sets.len(), 2 * 37);
    // No run directory was created: only the study's outputs.
    let entries: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(entries, vec![std::ffi::OsString::from("studies")]);
}

#[test]
fn the_table_fit_names_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let table = tmp.path().join("t.csv");
    std::fs::write(&table, "a,b,y\n1,2,3\n2,1,4\n3,3,5\n0,2,6\n4,4,7\n5,1,8\n").unwrap();
    let fit = |response: &str, factors: &str| {
        common::repose(
            tmp.path(),
            &[
                "sensitivity",
                "--table",
                table.to_str().unwrap(),
                "--response",
                response,
                "--factors",
                factors,
            ],
        )
    };
    let o = fit("y", "a,b");
    assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
    assert!(
        common::stderr(&o).contains("factor `a`"),
        "{}",
        common::stderr(&o)
    );
    let o = fit("y", "b,c");
    assert_eq!(o.status.code(), Some(2));
    assert!(common::stderr(&o).contains("'c'") || common::stderr(&o).contains("c"));
    let o = fit("y", "b");
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(common::stdout(&o).contains("Parameter correlations"));
}
