//! Settings the manifest allows but the run outgrows (issue 24, item 7): a
//! step so large that contacts are stepped over stops the run as tunnelling,
//! and a step that resolves the contacts the run actually met with fewer
//! than the minimum steps leaves a warning in result.json and on stderr.
//! Each test reads what a user sees (the error text, result.json, stderr).

mod common;

use common::{edit, example, repose, stderr, stdout};
use repose::manifest::parse_experiment;
use repose::scenes::run_experiment;
use serde_json::{json, Value};

/// A pair experiment (`validation/<name>`) at normal speed `speed` (m/s) with
/// a step of Rayleigh fraction `fraction` designed for `design` (m/s).
fn pair(name: &str, speed: f64, fraction: f64, design: f64) -> Value {
    let v = edit(
        example(&format!("validation/{name}")),
        "/scene/normal_velocity_m_s",
        Some(json!(speed)),
    );
    edit(
        v,
        "/time_step",
        Some(json!({"rayleigh_fraction": fraction, "design_impact_speed_m_s": design})),
    )
}

fn run(v: &Value) -> Result<repose::store::RunResult, String> {
    let exp = parse_experiment(&v.to_string()).expect("a valid manifest");
    run_experiment(&exp, None).map_err(|e| e.to_string())
}

#[test]
fn impacts_at_1000_m_s_with_a_step_for_half_a_metre_per_second_are_tunnelling() {
    // The step (4.7e-6 s against a particle, 4.1e-6 s against the wall)
    // carries the sphere 4 radii per step: it used to pass through its
    // partner and fail with `the contact did not end` (or, at 5,000 m/s,
    // `left the domain` 214 steps later); against the wall the overlap
    // bound happened to catch it.
    for (name, speed) in [
        ("pair_hertz_particle_particle.json", 1000.0),
        ("pair_hertz_particle_particle.json", 5000.0),
        ("pair_hertz_rigid_wall.json", 1000.0),
    ] {
        let e = run(&pair(name, speed, 0.2, 0.5)).expect_err("no contact is resolved");
        assert!(
            e.contains("at step 1 ") && e.contains("particle 0: tunnelling: moved"),
            "{name} at {speed} m/s: {e}"
        );
        assert!(
            e.contains("raise its design impact speed"),
            "{name} at {speed} m/s: {e}"
        );
    }
}

#[test]
fn a_pair_faster_than_its_design_speed_is_warned_about() {
    // Designed for 0.01 m/s with the largest Rayleigh fraction (so the
    // contact time sets the step: 20 steps at 0.01 m/s), met at 0.5 m/s:
    // 20 · 50^(-1/5) = 9.1 steps per contact, 10 required.
    let fast = run(&pair("pair_hertz_particle_particle.json", 0.5, 0.5, 0.01)).unwrap();
    let json = serde_json::to_value(&fast).unwrap();
    let warnings = json["warnings"].as_array().expect("a warnings list");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let w = warnings[0].as_str().unwrap();
    assert!(
        w.starts_with(
            "time_step: under-resolved contacts: the fastest contact approached at 5.000e-1 m/s"
        ) && w.contains("9.1")
            && w.contains("raise time_step.design_impact_speed_m_s to at least 5.000e-1 m/s"),
        "{w}"
    );
    // Designed for the speed it meets: no warning, and no `warnings` key at
    // all, so result.json keeps the bytes it had before warnings existed.
    let designed = run(&pair("pair_hertz_particle_particle.json", 0.5, 0.5, 0.5)).unwrap();
    let json = serde_json::to_value(&designed).unwrap();
    assert!(json.get("warnings").is_none(), "{json}");
}

/// Runs `manifest` with the binary into a fresh store; returns (stderr,
/// result.json).
fn cli_run(manifest: &Value) -> (String, String) {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("manifest.json");
    std::fs::write(&file, manifest.to_string()).unwrap();
    let store = tmp.path().join("store");
    let out = repose(&store, &["--quiet", "run", file.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let id = stdout(&out)
        .split_whitespace()
        .nth(1)
        .expect("run <id> (computed)")
        .to_string();
    let result = std::fs::read_to_string(store.join(id).join("result.json")).unwrap();
    (stderr(&out), result)
}

#[test]
fn the_largest_allowed_step_in_the_drum_smoke_is_warned_about() {
    // Rayleigh fraction 0.5 and design speed 1 mm/s: the particles reach
    // about 0.5 m/s, which this step resolves with under 6 steps per
    // contact; the angle moved from 31.4° to 41.2° without a word.
    let drum = edit(
        example("drum/smoke.json"),
        "/time_step",
        Some(json!({"rayleigh_fraction": 0.5, "design_impact_speed_m_s": 1e-3})),
    );
    let (err, result) = cli_run(&drum);
    assert!(
        err.contains("warning: run ")
            && err.contains("time_step: under-resolved contacts")
            && err.contains("raise time_step.design_impact_speed_m_s"),
        "{err}"
    );
    let result: Value = serde_json::from_str(&result).unwrap();
    let warnings: Vec<&str> = result["warnings"]
        .as_array()
        .expect("warnings in result.json")
        .iter()
        .map(|w| w.as_str().unwrap())
        .filter(|w| w.contains("time_step"))
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(err.contains(warnings[0]), "{err}");
}

/// The smoke drum resolves its contacts in time; its only warnings are that
/// the drum (15 grains across, 5 deep, Fr 0.09) is too coarse for its test
/// (`src/scenes/resolution.rs`).
#[test]
fn the_drum_smoke_as_shipped_has_no_time_step_warning() {
    let (err, result) = cli_run(&example("drum/smoke.json"));
    assert!(!err.contains("time_step"), "{err}");
    let result: Value = serde_json::from_str(&result).unwrap();
    for w in result["warnings"].as_array().unwrap() {
        let w = w.as_str().unwrap();
        assert!(w.starts_with("unresolved at this particle size: "), "{w}");
        assert!(err.contains(w), "{err}");
    }
}
