//! Bounded study sizes (issue 40, item 7). Every study stage knows how many
//! runs it may start before anything is built; a study, sweep or noise floor
//! over `--max-runs` (default 10,000) is refused with exit 2, naming the
//! count and the flag. Before: `replicates: 1000000` spun for minutes,
//! `centre_points: 1000000000` and `tradeoff --replicates 1000000000` aborted
//! allocating 24 GB and 544 GB (exit 134), and `noise … --seeds 100000`
//! started 100,000 runs. Each case here runs no simulation: it is refused
//! first, so the store stays empty.

mod common;

use std::path::Path;

use serde_json::{json, Value};

/// Writes `v` as `name` in `dir` and returns its path as a string.
fn write(dir: &Path, name: &str, v: &Value) -> String {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(v).unwrap()).unwrap();
    p.display().to_string()
}

/// Runs repose and checks it was refused with exit 2, the message naming
/// `--max-runs` and `count`, and that no run was started.
fn assert_refused(store: &Path, args: &[&str], count: &str) {
    let out = common::repose(store, args);
    let err = common::stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains("--max-runs"), "{err}");
    assert!(err.contains(count), "expected {count} in: {err}");
    let runs = std::fs::read_dir(store)
        .map(|d| {
            d.filter_map(Result::ok)
                .filter(|e| e.file_name().len() == 64)
                .count()
        })
        .unwrap_or(0);
    assert_eq!(runs, 0, "{args:?} started runs");
}

#[test]
fn a_million_replicates_are_refused_before_the_design_is_built() {
    let tmp = tempfile::tempdir().unwrap();
    let mut v = common::example("cai2024-smoke/study.json");
    v["replicates"] = json!(1_000_000);
    let path = write(tmp.path(), "study.json", &v);
    // cai2024-smoke: a Box–Behnken of k factors (2k(k − 1) edge points and
    // its centre points) in its scenes, each point × 10⁶ seeds.
    let k = v["factors"].as_object().unwrap().len() as u64;
    let centre = v["design"]["centre_points"].as_u64().unwrap();
    let scenes = v["scenes"].as_object().unwrap().len() as u64;
    let runs = (2 * k * (k - 1) + centre) * scenes;
    let count = format!("simulate {runs},000,000");
    assert_refused(tmp.path(), &["rsm", &path], &count);
    assert_refused(tmp.path(), &["sensitivity", &path], &count);
}

#[test]
fn a_billion_centre_points_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let mut v = common::example("cai2024-smoke/study.json");
    v["design"]["centre_points"] = json!(1_000_000_000u64);
    let path = write(tmp.path(), "study.json", &v);
    assert_refused(tmp.path(), &["rsm", &path], "simulate");
}

#[test]
fn a_tradeoff_of_a_billion_replicates_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let manifest = common::root().join("experiments/drum/smoke.json");
    assert_refused(
        tmp.path(),
        &[
            "tradeoff",
            manifest.to_str().unwrap(),
            "--replicates",
            "1000000000",
        ],
        ",000,000,000 runs",
    );
}

#[test]
fn a_noise_floor_over_the_limit_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let manifest = common::root().join("experiments/drum/smoke.json");
    let m = manifest.to_str().unwrap();
    assert_refused(tmp.path(), &["noise", m, "--seeds", "100000"], "100,000");
    // The flag sets the limit both ways.
    assert_refused(
        tmp.path(),
        &["--max-runs", "2", "noise", m, "--seeds", "3"],
        "3 runs",
    );
}

#[test]
fn a_calibration_design_over_the_limit_is_refused_by_every_stage() {
    let tmp = tempfile::tempdir().unwrap();
    let mut v = common::example("calibrate-smoke/study.json");
    v["design"]["size"] = json!(1_000_000_000u64);
    let path = write(tmp.path(), "study.json", &v);
    for cmd in ["sample", "batch", "calibrate"] {
        assert_refused(tmp.path(), &[cmd, &path], "1,000,000,");
    }
}

#[test]
fn stages_prints_the_most_runs_of_each_stage() {
    let tmp = tempfile::tempdir().unwrap();
    let out = common::repose(
        tmp.path(),
        &[
            "stages",
            "experiments/he2019-quick/study.json",
            "--adaptive",
        ],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    let text = common::stdout(&out);
    // noise 8, design 12 × 1 seed, adaptive 60, verify 1 candidate × 3
    // scenes × up to 28 seeds.
    for line in [
        "1. noise: 8 packing seeds at one point [up to 8 runs]",
        "[up to 12 runs]",
        "[up to 60 runs]",
        "[up to 84 runs]",
        "at most 164 runs in all",
    ] {
        assert!(text.contains(line), "{line}\n{text}");
    }
}
