//! Studies under hostile input (issue 54, round 3): names that would escape the
//! store, he2019 parameters that alias, sweeps counted before they are planned.
//! Each test reproduces a fault found by trying the commands as a hostile user
//! would; it failed on the code before the fix.

mod common;

use std::path::Path;

use common::{edit, example, repose, stderr};
use serde_json::{json, Value};

/// Writes `study` into `dir` as `study.json` and returns its path as text.
fn write_study(dir: &Path, study: &Value) -> String {
    let path = dir.join("study.json");
    std::fs::write(&path, serde_json::to_string_pretty(study).unwrap()).unwrap();
    path.to_string_lossy().into_owned()
}

/// Renames the key `from` of the object at `pointer` to `to`.
fn rename_key(mut v: Value, pointer: &str, from: &str, to: &str) -> Value {
    let map = v.pointer_mut(pointer).unwrap().as_object_mut().unwrap();
    let value = map
        .remove(from)
        .unwrap_or_else(|| panic!("no {from} in {pointer}"));
    map.insert(to.to_string(), value);
    v
}

/// Every entry below `dir` (recursively), sorted.
fn entries(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out.sort();
    out
}

#[test]
fn a_name_that_would_leave_the_store_is_refused_by_validate_and_by_rsm() {
    let base = example("cai2024-smoke/study.json");
    let tmp = tempfile::tempdir().unwrap();
    let outside = tmp.path().join("outside");
    let escapes = [
        outside.to_string_lossy().into_owned(),
        "../../../../../../../../tmp/repose-escape".to_string(),
        "..".to_string(),
        "nul\0byte".to_string(),
        "esc\u{1b}[31m".to_string(),
        "x".repeat(300),
    ];
    for bad in &escapes {
        // (the study as edited, the field the refusal must name)
        let mut response = rename_key(base.clone(), "/responses", "static_angle_deg", bad);
        response = rename_key(response, "/targets", "static_angle_deg", bad);
        let mut scene = rename_key(base.clone(), "/scenes", "static", bad);
        scene = edit(scene, "/responses/static_angle_deg/scene", Some(json!(bad)));
        let factor = rename_key(base.clone(), "/factors", "A", bad);
        let name = edit(base.clone(), "/name", Some(json!(bad)));
        let mut he2019 = example("calibrate-smoke/study.json");
        he2019 = edit(he2019, "/name", Some(json!(bad)));
        let he2019_target = edit(
            example("calibrate-smoke/study.json"),
            "/calibration/name",
            Some(json!(bad)),
        );
        for (study, field) in [
            (response, "responses (a key)"),
            (scene, "scenes (a key)"),
            (factor, "factors (a key)"),
            (name.clone(), "name"),
            (he2019, "name"),
            (he2019_target, "calibration.name"),
        ] {
            let work = tempfile::tempdir_in(tmp.path()).unwrap();
            let path = write_study(work.path(), &study);
            let store = work.path().join("store");
            let v = repose(&store, &["validate", &path]);
            assert_eq!(
                v.status.code(),
                Some(2),
                "{field} = {bad:?}: {}",
                stderr(&v)
            );
            assert!(
                stderr(&v).contains(&format!("{field} = ")),
                "{field} = {bad:?}: {}",
                stderr(&v)
            );
            if study.get("factors").is_some() {
                let r = repose(&store, &["rsm", &path]);
                assert_eq!(
                    r.status.code(),
                    Some(2),
                    "rsm, {field} = {bad:?}: {}",
                    stderr(&r)
                );
            }
            assert!(!outside.exists(), "{field} = {bad:?} wrote {outside:?}");
            assert!(
                !Path::new("/tmp/repose-escape").exists(),
                "{field} = {bad:?}"
            );
            let written: Vec<_> = entries(work.path())
                .into_iter()
                .filter(|p| !p.starts_with(&store) && !p.ends_with("study.json"))
                .collect();
            assert!(written.is_empty(), "{field} = {bad:?} wrote {written:?}");
        }
    }
}

#[test]
fn a_wildcard_he2019_parameter_that_sets_no_wall_is_refused() {
    let base = example("calibrate-smoke/study.json");
    // Two parameters, the wildcard and the only wall's own address.
    let mut two = edit(
        base.clone(),
        "/fixed/particle_wall.steel.static_friction",
        None,
    );
    for address in [
        "particle_wall.*.static_friction",
        "particle_wall.steel.static_friction",
    ] {
        two = edit(
            two,
            &format!("/parameters/{address}"),
            Some(json!({"min": 0.3, "max": 0.9})),
        );
    }
    // A wildcard parameter beside the only wall's fixed value.
    let beside_fixed = edit(
        base,
        "/parameters/particle_wall.*.static_friction",
        Some(json!({"min": 0.3, "max": 0.9})),
    );
    for study in [two, beside_fixed] {
        let tmp = tempfile::tempdir().unwrap();
        let path = write_study(tmp.path(), &study);
        let store = tmp.path().join("store");
        let v = repose(&store, &["validate", &path]);
        assert_eq!(v.status.code(), Some(2), "{}", stderr(&v));
        assert!(
            stderr(&v).contains("parameters.particle_wall.*.static_friction = ")
                && stderr(&v).contains("sets no contact parameter"),
            "{}",
            stderr(&v)
        );
        let s = repose(&store, &["sample", &path]);
        assert_eq!(s.status.code(), Some(2), "{}", stderr(&s));
        assert!(!store.join("studies").exists(), "sample wrote a study");
    }
}

#[test]
fn a_convergence_sweep_is_counted_before_it_is_planned() {
    // A billion replicates once built a 544 GB plan before --max-runs was read.
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(
        &tmp.path().join("store"),
        &[
            "convergence",
            "experiments/drum/smoke.json",
            "--replicates",
            "1000000000",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("--max-runs"), "{}", stderr(&out));
}

/// Issue 54 item 9: a fine size of 1e-9 (1.8e29 particles) once ran the
/// noise, design and training stages before the fine runs were refused.
#[test]
fn every_stages_run_limits_are_checked_before_the_first_run() {
    let block = json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 },
        "fidelity": { "fine_size": 1e-9, "fine_points": 5, "fine_replicates": 3 } });
    let study = edit(
        example("calibrate-smoke/study.json"),
        "/noise_aware",
        Some(block),
    );
    let tmp = tempfile::tempdir().unwrap();
    let path = write_study(tmp.path(), &study);
    let store = tmp.path().join("store");
    let out = repose(&store, &["calibrate", &path]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("at particle size x 0.000000001")
            && stderr(&out).contains("refused before the study's first run"),
        "{}",
        stderr(&out)
    );
    // No run was started: the store holds no run directory.
    let runs: Vec<_> = std::fs::read_dir(&store)
        .map(|d| d.map(|e| e.unwrap().file_name()).collect())
        .unwrap_or_default();
    assert!(
        runs.iter()
            .all(|n| n == "studies" || n.to_string_lossy().starts_with('.')),
        "{runs:?}"
    );
}

/// Issue 54, low: an empty `stages` list hashed as absent; a spelled
/// `adaptive` on a two-level study was refused without the reason, and
/// `repose stages --adaptive` dropped the flag silently there.
#[test]
fn stage_lists_that_say_nothing_or_the_impossible_are_refused_with_the_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let empty = edit(
        example("calibrate-smoke/study.json"),
        "/stages",
        Some(json!([])),
    );
    let path = write_study(tmp.path(), &empty);
    let v = repose(&store, &["validate", &path]);
    assert_eq!(v.status.code(), Some(2), "{}", stderr(&v));
    assert!(stderr(&v).contains("an empty list"), "{}", stderr(&v));

    let block = json!({ "replicates": 2, "noise_seeds": 8, "min_probability": 0.5,
        "verification_seeds": 5, "adaptive": { "batch": 2, "max_runs": 8 },
        "fidelity": { "fine_size": 0.75, "fine_points": 5, "fine_replicates": 3 } });
    let two_level = edit(
        example("calibrate-smoke/study.json"),
        "/noise_aware",
        Some(block),
    );
    let own = [
        "noise", "design", "simulate", "fit", "fine", "search", "verify",
    ];
    let spelled = edit(two_level.clone(), "/stages", Some(json!(own)));
    let path = write_study(tmp.path(), &spelled);
    let v = repose(&store, &["validate", &path]);
    assert_eq!(v.status.code(), Some(0), "its own list: {}", stderr(&v));
    let s = repose(&store, &["stages", "--adaptive", &path]);
    assert_eq!(s.status.code(), Some(2), "{}", stderr(&s));
    assert!(
        stderr(&s).contains("--adaptive = (given)"),
        "{}",
        stderr(&s)
    );
    let mut with_adaptive = own.to_vec();
    with_adaptive.insert(4, "adaptive");
    let path = write_study(
        tmp.path(),
        &edit(two_level, "/stages", Some(json!(with_adaptive))),
    );
    let v = repose(&store, &["validate", &path]);
    assert_eq!(v.status.code(), Some(2), "{}", stderr(&v));
    assert!(
        stderr(&v).contains("which a two-level study (noise_aware.fidelity) does not run"),
        "{}",
        stderr(&v)
    );
}

/// Issue 54, low: learning-curve simulated its 12-run batch before refusing
/// `--sizes 0`; `noise --seeds 2^64-1` reported a saturated count.
#[test]
fn sweeps_refuse_their_sizes_and_counts_before_any_run() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let out = repose(
        &store,
        &[
            "learning-curve",
            "experiments/calibrate-smoke/study.json",
            "--sizes",
            "0",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--sizes: 0 is not in [2, "),
        "{}",
        stderr(&out)
    );
    let runs = std::fs::read_dir(&store).map_or(0, |d| {
        d.filter(|e| e.as_ref().unwrap().file_name() != "studies")
            .count()
    });
    assert_eq!(runs, 0, "a run was started");
    let out = repose(
        &store,
        &[
            "noise",
            "experiments/drum/smoke.json",
            "--seeds",
            "18446744073709551615",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("up to 18,446,744,073,709,551,615 runs"),
        "{}",
        stderr(&out)
    );
}

/// Issue 54, low: a study refused before any stage wrote (a two-level
/// factorial asked for a quadratic surface) left an empty study directory.
#[test]
fn a_study_refused_before_its_first_stage_leaves_no_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let out = repose(&store, &["rsm", "experiments/yan2015-smoke/study.json"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let studies: Vec<_> = std::fs::read_dir(store.join("studies"))
        .map(|d| d.map(|e| e.unwrap().file_name()).collect())
        .unwrap_or_default();
    assert!(studies.is_empty(), "{studies:?}");
}

/// Issue 54, low: the wrong kind of manifest was answered with serde's
/// `unknown field physics_version`.
#[test]
fn a_manifest_of_the_wrong_kind_is_named_as_what_it_is() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let drum = "experiments/drum/smoke.json";
    for args in [
        vec!["pilot", drum, "--scene", "calibration"],
        vec!["fine", drum],
        vec!["report", drum],
    ] {
        let out = repose(&store, &args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("this is an experiment manifest (it has `scene`)")
                && !stderr(&out).contains("unknown field"),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    let out = repose(
        &store,
        &["convergence", "experiments/calibrate-smoke/study.json"],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains(
            "this is a calibration study (it has `calibration`); the command needs an \
             experiment manifest"
        ),
        "{}",
        stderr(&out)
    );
    let out = repose(
        &store,
        &[
            "convergence",
            "experiments/validation/pair_jkr_separation.json",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("no angle of repose to converge"),
        "{}",
        stderr(&out)
    );
}
