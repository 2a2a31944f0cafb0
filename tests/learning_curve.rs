//! `repose learning-curve` on the smoke study with a fake runner: nested
//! prefixes with fixed validation rows, counts and ids per size, DEM time that
//! grows with the size, failed runs counted, reruns reproducing the
//! deterministic columns, and bad sizes refused.

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use repose::exec::Executor;
use repose::manifest::{parse_study, Experiment, Study};
use repose::store::{Lineage, RunDir, RunResult, Store};
use repose::study::analyses::learning_curve::{csv_header, learning_curve};
use repose::study::dir::Stage;
use repose::study::dir::StudyDir;
use repose::study::plan::calibration::parameter_names;
use repose::study::stages::design::{sample, SampleSettings};
use repose::study::stages::simulate::{batch, read_design};
use repose::study::StudyError;
use serde_json::json;

/// The smoke study with a 36-point design: 24 training rows, 12 validation.
fn study(dir: &Path) -> (Study, PathBuf) {
    let v = common::edit(
        common::example("calibrate-smoke/study.json"),
        "/design/size",
        Some(json!(36)),
    );
    let path = dir.join("study.json");
    std::fs::write(&path, v.to_string()).unwrap();
    (parse_study(&v.to_string()).unwrap(), path)
}

#[derive(Debug, thiserror::Error)]
#[error("injected failure")]
struct Injected;

/// A smooth made-up response (20 + 30 μ + 40 μ_r degrees, as in
/// tests/calibrate_pipeline.rs) that takes 3 ms of wall time; sample 3 fails.
fn fake(e: &Experiment, _: &RunDir) -> Result<RunResult, Injected> {
    std::thread::sleep(Duration::from_millis(3));
    if e.seeds.sample_index == 3 {
        return Err(Injected);
    }
    let pp = e.contact.particle_particle;
    let mut r = RunResult::new(e, "fake");
    r.headline_angle_deg = Some(20.0 + 30.0 * pp.static_friction + 40.0 * pp.rolling_friction);
    Ok(r)
}

fn prepared(tmp: &Path) -> (Study, StudyDir, Store) {
    let (s, path) = study(tmp);
    let store = Store::open(tmp.join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let settings = Executor {
        jobs: 2,
        progress: false,
        limits: Default::default(),
        max_runs: repose::exec::DEFAULT_MAX_RUNS,
        slurm: None,
    };
    let out = batch(&dir, &s, &store, &settings, fake).unwrap();
    assert_eq!((out.total, out.failures.len()), (36, 1));
    (s, dir, store)
}

#[test]
fn nested_prefixes_with_fixed_validation_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, dir, store) = prepared(tmp.path());
    let design = read_design(&dir, &s).unwrap();
    let out = learning_curve(&dir, &s, &store, Some(&[6, 12, 24])).unwrap();
    assert_eq!(out.train_capacity, 24);
    let sizes: Vec<usize> = out.rows.iter().map(|r| r.size).collect();
    assert_eq!(sizes, [6, 12, 24]);
    for r in &out.rows {
        // Sample 3 failed: every prefix contains it, so one row less trains
        // and one run less is timed; the 12 validation rows all ran.
        assert_eq!(r.train_rows, r.size - 1, "{r:?}");
        assert_eq!(r.timed_runs, r.size - 1, "{r:?}");
        assert_eq!(r.validation_rows, 12, "{r:?}");
        assert_eq!(r.last_id, design[r.size - 1].id);
        // Every timed run slept 3 ms.
        assert!(r.dem_wall_s >= 0.003 * r.timed_runs as f64, "{r:?}");
        assert!(r.dem_wall_with_validation_s >= r.dem_wall_s + 0.003 * 12.0);
        assert!(r.validation_r2.is_finite() && r.validation_r2 <= 1.0);
    }
    // Nested prefixes: a bigger size costs strictly more DEM time.
    for w in out.rows.windows(2) {
        assert!(w[1].dem_wall_s > w[0].dem_wall_s, "{:?}", out.rows);
    }
    // The response is linear, so 23 rows fit it well (a network trained on
    // the full smoke table reaches R² > 0.9 in tests/calibrate_pipeline.rs).
    assert!(out.rows[2].validation_r2 > 0.9, "{:?}", out.rows[2]);
    // Kept points exist at the target (30° lies inside 20–55.5°), and their
    // spread is a standard deviation within the ranges.
    let names = parameter_names(&s);
    for r in &out.rows {
        let (Some(sd), Some(rel)) = (&r.spread, r.relative_spread) else {
            continue;
        };
        assert_eq!(sd.len(), names.len());
        for (v, range) in sd.iter().zip(s.parameters.values()) {
            assert!(*v >= 0.0 && *v <= range.max - range.min, "{r:?}");
        }
        assert!(rel > 0.0 && rel < 1.0, "{r:?}");
    }
    assert!(out.rows[2].kept > 0, "{:?}", out.rows[2]);

    // The table: header, one line per size, ids and counts as computed.
    let csv_path = dir.stage(Stage::LearningCurve).join("curve.csv");
    let text = std::fs::read_to_string(&csv_path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), csv_header(&names).join(","));
    for (line, r) in lines.zip(&out.rows) {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(
            cells[..4],
            [
                r.size.to_string().as_str(),
                r.train_rows.to_string().as_str(),
                "12",
                r.last_id.as_str()
            ]
        );
    }
    assert_eq!(text.lines().count(), 4);
    let lineage = Lineage::read_beside(&csv_path).unwrap();
    assert_eq!(lineage.stage, "learning-curve");
    assert!(
        std::fs::read_to_string(dir.stage(Stage::LearningCurve).join("curve.svg"))
            .unwrap()
            .starts_with("<svg")
    );

    // A rerun (nothing new to simulate) reproduces every column but the
    // wall times byte for byte.
    let again = learning_curve(&dir, &s, &store, Some(&[6, 12, 24])).unwrap();
    let strip = |rows: &[repose::study::analyses::learning_curve::CurveRow]| {
        rows.iter()
            .map(|r| {
                let mut r = r.clone();
                r.dem_wall_s = 0.0;
                r.dem_wall_with_validation_s = 0.0;
                r
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&out.rows), strip(&again.rows));
    assert_eq!(out.rows, again.rows, "timings are read, not re-measured");
}

#[test]
fn sizes_beyond_the_training_rows_are_refused_naming_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, dir, store) = prepared(tmp.path());
    match learning_curve(&dir, &s, &store, Some(&[12, 30])) {
        Err(StudyError::Settings(m)) => {
            assert!(m.contains("30 is not in [2, 24]"), "{m}")
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    // Default sizes: quarters of the 24 training rows.
    let out = learning_curve(&dir, &s, &store, None).unwrap();
    let sizes: Vec<usize> = out.rows.iter().map(|r| r.size).collect();
    assert_eq!(sizes, [6, 12, 18, 24]);
}

/// Pinned: every column but the wall times of the fake-runner curve (ids and
/// counts exact, floats to 1e-9 relative: the network sweep is deterministic,
/// see golden/he2019_table_a1_sweep.csv). `REPOSE_BLESS=1` rewrites it.
#[test]
fn the_fake_runner_curve_is_pinned() {
    const GOLDEN: &str = "golden/learning_curve_fake.csv";
    let tmp = tempfile::tempdir().unwrap();
    let (s, dir, store) = prepared(tmp.path());
    learning_curve(&dir, &s, &store, Some(&[6, 12, 24])).unwrap();
    let text = std::fs::read_to_string(dir.stage(Stage::LearningCurve).join("curve.csv")).unwrap();
    let deterministic: String = text
        .lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            cells[..cells.len() - 2].join(",") + "\n"
        })
        .collect();
    let golden = common::root().join(GOLDEN);
    if std::env::var_os("REPOSE_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&golden, &deterministic).unwrap();
    }
    let pinned = std::fs::read_to_string(&golden).expect("golden file (REPOSE_BLESS=1 writes it)");
    assert_eq!(pinned.lines().count(), deterministic.lines().count());
    for (p, n) in pinned.lines().zip(deterministic.lines()) {
        for (a, b) in p.split(',').zip(n.split(',')) {
            match (a.parse::<f64>(), b.parse::<f64>()) {
                (Ok(x), Ok(y)) => assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{p} vs {n}"),
                _ => assert_eq!(a, b, "{p} vs {n}"),
            }
        }
    }
}
