//! The calibration subcommands on the command line: stage order, option and
//! table errors (exit 2 with a message naming what to do), the diagnostics of
//! he2019's Table A1, and a cheap sample → diagnostics round.

mod common;

use common::{repose, stderr, stdout};
use serde_json::json;

const STUDY: &str = "experiments/calibrate-smoke/study.json";

#[test]
fn each_stage_refuses_to_run_before_its_input_stage() {
    let tmp = tempfile::tempdir().unwrap();
    for (stage, before) in [("batch", "sample"), ("train", "batch"), ("search", "train")] {
        let out = repose(tmp.path(), &[stage, STUDY]);
        assert_eq!(out.status.code(), Some(2), "{stage}: {}", stderr(&out));
        let expected = format!("run `repose {before} {STUDY}` first");
        assert!(
            stderr(&out).contains(&expected),
            "{stage}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn sample_writes_the_design_and_prints_its_diagnostics() {
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(tmp.path(), &["--quiet", "sample", STUDY]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("sampled 12 points of 2 parameter(s)"),
        "{text}"
    );
    assert!(
        text.contains("centred L2 discrepancy (squared, Hickernell 1998)"),
        "{text}"
    );
    assert!(text.contains("minimum pairwise distance"), "{text}");
    assert!(text.contains("max |Spearman| correlation"), "{text}");
    let studies: Vec<_> = std::fs::read_dir(tmp.path().join("studies"))
        .unwrap()
        .collect();
    assert_eq!(studies.len(), 1);
    let name = studies[0].as_ref().unwrap().file_name();
    assert!(
        name.to_string_lossy().starts_with("calibrate-smoke-"),
        "{name:?}"
    );
}

#[test]
fn diagnose_flags_table_a1_as_degenerate() {
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(
        tmp.path(),
        &[
            "sample",
            "--diagnose",
            "experiments/he2019-table-a1/table_a1.csv",
            "--columns",
            "e_pp,mu_pp,e_pw,mu_pw,gamma",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("max |Spearman| correlation: 1.0000"),
        "{}",
        stdout(&out)
    );
    assert!(stdout(&out).contains("DEGENERATE"), "{}", stdout(&out));
    assert!(
        stderr(&out).contains("warning: degenerate design"),
        "{}",
        stderr(&out)
    );
    assert!(
        stderr(&out).contains("warning: columns `e_pp` and `mu_pp` are strongly correlated"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn bad_options_and_tables_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (
            &["train", STUDY, "--train-fraction", "1.5"],
            "--train-fraction = 1.5: must be in (0, 1)",
        ),
        (
            &["search", STUDY, "--quantile", "0"],
            "--quantile = 0: must be in (0, 1]",
        ),
        (
            &["sample", STUDY, "--max-correlation", "2"],
            "--max-correlation = 2: must be in (0, 1]",
        ),
        (
            &[
                "sample",
                "--diagnose",
                "experiments/he2019-table-a1/table_a1.csv",
                "--columns",
                "e_pp,nope",
            ],
            "no column `nope` (columns: row, set, e_pp",
        ),
        (
            &[
                "train",
                "--table",
                "experiments/he2019-table-a1/table_a1.csv",
                "--inputs",
                "e_pp,set",
                "--target",
                "aor",
                "--out",
                "unused",
            ],
            "table_a1.csv:2: column `set` = `train`: must be a finite number",
        ),
    ];
    for (args, message) in cases {
        let out = repose(tmp.path(), args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(message), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn sample_refuses_design_kinds_it_does_not_make() {
    let tmp = tempfile::tempdir().unwrap();
    let v = common::edit(
        common::example("calibrate-smoke/study.json"),
        "/design/kind",
        Some(json!("full_factorial")),
    );
    let path = tmp.path().join("factorial.json");
    std::fs::write(&path, v.to_string()).unwrap();
    let out = repose(tmp.path(), &["sample", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains(
            "design.kind = \"full_factorial\": `repose sample` makes Latin hypercubes (lhs, lhs_optimised) only"
        ),
        "{}",
        stderr(&out)
    );
}

#[test]
fn train_on_table_a1_prints_the_sweep_and_the_papers_r2() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("a1");
    let out = repose(
        tmp.path(),
        &[
            "train",
            "--table",
            "experiments/he2019-table-a1/table_a1.csv",
            "--inputs",
            "e_pp,mu_pp,e_pw,mu_pw",
            "--target",
            "aor",
            "--reference",
            "pred_aor",
            "--out",
            out_dir.to_str().unwrap(),
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("80 training rows, 40 validation rows"),
        "{text}"
    );
    assert!(text.contains("<- kept"), "{text}");
    assert!(
        text.contains("reference predictions on the validation rows: R2 0.8962"),
        "{text}"
    );
    for f in ["sweep.csv", "model.json", "parity.svg", "summary.json"] {
        assert!(out_dir.join(f).is_file(), "{f}");
        assert!(out_dir.join(format!("{f}.lineage.json")).is_file(), "{f}");
    }
}
