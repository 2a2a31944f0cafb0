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
        assert!(matches!(
            cell(&v, r, "verdict"),
            "pass" | "fail" | "inconclusive"
        ));
    }
    // The verdicts are the one rule's: `repose verdict --table` on the
    // verification's own replicates gives the same verdict and TOST p.
    let replicates = dir.join("verify/responses.csv");
    for (response, target) in [("drum_angle_deg", 47.1), ("funnel_angle_deg", 47.801)] {
        let from_table = common::table_verdicts(&replicates, response, &["point"], target, 0.05);
        let rows: Vec<usize> = (0..v.rows.len())
            .filter(|&r| cell(&v, r, "response") == response)
            .collect();
        assert_eq!(from_table.len(), rows.len(), "{response}");
        for ((_, verdict, p), r) in from_table.iter().zip(rows) {
            assert_eq!(verdict, cell(&v, r, "verdict"), "{response}");
            let stage_p: Option<f64> = cell(&v, r, "tost_p").parse().ok();
            assert_eq!(*p, stage_p, "{response}");
        }
    }
    assert!(printed.contains("verification"), "{printed}");
}

/// cai2024's scenes with he2019's design and surrogate: a Latin hypercube and
/// a Gaussian process per response, then desirability and verification.
#[test]
fn cai2024_scenes_with_an_lhs_and_gps_run_end_to_end() {
    const LHS_GP: &str = "experiments/mixed-lhs-gp-smoke/study.json";
    let tmp = tempfile::tempdir().unwrap();
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    for (store, jobs) in [(&two, "2"), (&one, "1")] {
        let out = common::repose(store, &["rsm", LHS_GP, "--jobs", jobs]);
        assert!(out.status.success(), "rsm: {}", common::stderr(&out));
    }
    common::assert_same_stores(&one, &two);
    let dir = study_dir(&one);
    // Design: 8 LHS points, one per stratum of each factor's range.
    let responses = Table::read(&dir.join("rsm/responses.csv")).unwrap();
    assert_eq!(responses.rows.len(), 8);
    for (factor, (lo, hi)) in [("A", (0.2, 0.6)), ("B", (0.1, 0.5))] {
        let mut strata: Vec<usize> = (0..8)
            .map(|r| {
                let v: f64 = cell(&responses, r, factor).parse().unwrap();
                ((v - lo) / (hi - lo) * 8.0).floor() as usize
            })
            .collect();
        strata.sort();
        assert_eq!(strata, (0..8).collect::<Vec<_>>(), "{factor}");
    }
    // Fit: a GP per response, no ANOVA.
    for response in ["static_angle_deg", "dynamic_angle_deg"] {
        let text = std::fs::read_to_string(dir.join(format!("rsm/{response}/gp.json"))).unwrap();
        let gp: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            gp["length_scales"].as_array().unwrap().len(),
            2,
            "{response}"
        );
        assert!(gp["nugget_var"].as_f64().unwrap() >= 0.0);
        assert!(!dir.join(format!("rsm/{response}/anova.csv")).exists());
    }
    // Search and verification through the same stages as a quadratic study.
    let optimum = Table::read(&dir.join("rsm/optimum.csv")).unwrap();
    assert!(!optimum.rows.is_empty());
    let v = Table::read(&dir.join("verify/verification.csv")).unwrap();
    assert_eq!(v.rows.len(), 2);
    for r in 0..v.rows.len() {
        assert_eq!(cell(&v, r, "n"), "2");
        let predicted: f64 = cell(&v, r, "predicted").parse().unwrap();
        assert!(predicted.is_finite());
    }
}
