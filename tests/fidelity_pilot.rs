//! `repose pilot` on the smoke calibration study's drum: both sizes run
//! through the one executor, the two-level fit is made, and pilot.json is
//! byte-identical with 1 and 2 workers (it holds no timing).

mod common;

use std::process::Command;

fn pilot(jobs: &str, store: &std::path::Path) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_repose"))
        .current_dir(common::root())
        .args(["--store"])
        .arg(store)
        .args([
            "pilot",
            "experiments/calibrate-smoke/study.json",
            "--scene",
            "drum",
            "--fine-size",
            "0.9",
            "--points",
            "3",
            "--seeds",
            "2",
            "--jobs",
            jobs,
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_smoke_pilot_fits_and_is_the_same_on_one_and_two_workers() {
    let dirs = [tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap()];
    let one = pilot("1", dirs[0].path());
    let two = pilot("2", dirs[1].path());
    let points = one["points"].as_array().unwrap();
    assert_eq!(points.len(), 3);
    for p in points {
        assert_eq!(p["coarse"].as_array().unwrap().len(), 2, "{p}");
        assert_eq!(p["fine"].as_array().unwrap().len(), 2, "{p}");
    }
    assert!(
        one["fit"]["Ok"]["rho"][0].as_f64().unwrap().is_finite(),
        "{}",
        one["fit"]
    );
    // Everything but the CPU seconds is a function of the study.
    let strip = |mut v: serde_json::Value| {
        v.as_object_mut().unwrap().remove("cpu_s");
        v
    };
    assert_eq!(strip(one), strip(two));
    let file = |d: &tempfile::TempDir| {
        let dir = std::fs::read_dir(d.path().join("pilot"))
            .unwrap()
            .next()
            .unwrap()
            .unwrap();
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("pilot.json")).unwrap()).unwrap();
        strip(v)
    };
    assert_eq!(file(&dirs[0]), file(&dirs[1]));
}
