//! A study no seed paper ran, through the shared study stages
//! (experiments/mixed-smoke/study.json): he2019's funnel pile and drum as
//! the joint responses of cai2024's Box–Behnken design, a quadratic fit with
//! ANOVA per response, the desirability optimum, and its verification with 2
//! packing seeds per scene. Run once with one worker and once with two: the
//! stores must agree byte for byte, every design point must have run in both
//! scenes with the factor values written into its manifest, and every stage
//! must have written its tables. About 50 CPU-s per store.

mod common;

use std::path::Path;

use repose::report::table::Table;
use serde_json::Value;

const STUDY: &str = "experiments/mixed-smoke/study.json";

fn rsm(store: &Path, jobs: &str) -> String {
    let out = common::repose(store, &["rsm", STUDY, "--jobs", jobs]);
    assert!(out.status.success(), "rsm: {}", common::stderr(&out));
    common::stdout(&out)
}

/// The cell of `column` in `row`.
fn cell<'a>(t: &'a Table, row: usize, column: &str) -> &'a str {
    let i = t
        .index(column)
        .unwrap_or_else(|| panic!("no column {column}"));
    &t.rows[row][i]
}

/// The study's directory in `store` (there is one).
fn study_dir(store: &Path) -> std::path::PathBuf {
    let mut dirs: Vec<_> = std::fs::read_dir(store.join("studies"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(dirs.len(), 1, "{dirs:?}");
    dirs.pop().unwrap()
}

#[test]
fn funnel_and_drum_in_a_box_behnken_run_end_to_end_through_the_shared_stages() {
    let tmp = tempfile::tempdir().unwrap();
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    let printed = rsm(&two, "2");
    rsm(&one, "1");
    common::assert_same_stores(&one, &two);

    let dir = study_dir(&one);
    // Design and runs: 3 factors in a Box–Behnken with one centre point =
    // 13 points, each run in both scenes with its factor values applied.
    let responses = Table::read(&dir.join("rsm/responses.csv")).unwrap();
    assert_eq!(responses.rows.len(), 13);
    for row in 0..responses.rows.len() {
        let a: f64 = cell(&responses, row, "A").parse().unwrap();
        let b: f64 = cell(&responses, row, "B").parse().unwrap();
        for (column, kind) in [("funnel_id", "funnel_pile"), ("drum_id", "drum")] {
            let id = cell(&responses, row, column);
            let text = std::fs::read_to_string(one.join(id).join("manifest.json")).unwrap();
            let m: Value = serde_json::from_str(&text).unwrap();
            assert_eq!(m["scene"]["kind"], kind, "{column} of row {row}");
            let pp = &m["contact"]["particle_particle"];
            assert_eq!(pp["static_friction"].as_f64(), Some(a), "row {row}");
            for wall in m["contact"]["particle_wall"].as_object().unwrap().values() {
                assert_eq!(wall["static_friction"].as_f64(), Some(b), "row {row}");
            }
        }
    }
    // Fit: a quadratic with ANOVA for each response (10 terms for 3 factors).
    for response in ["funnel_angle_deg", "drum_angle_deg"] {
        let c = Table::read(&dir.join(format!("rsm/{response}/coefficients.csv"))).unwrap();
        assert_eq!(c.rows.len(), 10, "{response}");
        assert!(dir.join(format!("rsm/{response}/anova.csv")).is_file());
    }
    // Search: the desirability optimum inside the coded cube.
    let optimum = Table::read(&dir.join("rsm/optimum.csv")).unwrap();
    assert!(!optimum.rows.is_empty());
    for factor in ["A", "B", "C"] {
        let coded: f64 = cell(&optimum, 0, &format!("{factor}_coded"))
            .parse()
            .unwrap();
        assert!((-1.0..=1.0).contains(&coded), "{factor}: {coded}");
    }
    // Verification: the optimum in both scenes with 2 seeds each.
    let v = Table::read(&dir.join("verify/verification.csv")).unwrap();
    let scenes: Vec<&str> = (0..v.rows.len()).map(|r| cell(&v, r, "response")).collect();
    assert_eq!(scenes, ["drum_angle_deg", "funnel_angle_deg"]);
    for r in 0..v.rows.len() {
        assert_eq!(cell(&v, r, "n"), "2");
        assert!(matches!(cell(&v, r, "pass"), "true" | "false"));
    }
    assert!(printed.contains("verification"), "{printed}");
}
