//! Run plans (issue 24, items 2 and 5): every run knows its particles, steps
//! and log size before it starts; manifests that used to crash, exhaust the
//! machine or fail at run time are refused up front with the manifest's own
//! field names and exit 2; the limits are raised by flags; `repose plan` and
//! `repose run --dry-run` print the estimates.

mod common;

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::{edit, example, repose, stderr, stdout};
use repose::exec::{ExecError, Executor};
use repose::manifest::{parse_experiment, parse_study, Experiment};
use repose::scenes::plan::{plan, Limits, ENGINE_MAX_PARTICLES};
use repose::scenes::run_experiment;
use repose::store::{RunDir, RunResult, Store};
use repose::study::dir::StudyDir;
use repose::study::stages::design::{sample, SampleSettings};
use repose::study::stages::simulate::batch;
use repose::study::StudyError;
use serde_json::{json, Value};

/// `base` (an example under experiments/) with the edits applied.
fn edited(base: &str, edits: &[(&str, Value)]) -> Value {
    edits
        .iter()
        .fold(example(base), |v, (p, new)| edit(v, p, Some(new.clone())))
}

/// Writes `doc` to `dir/name` and returns the path as a string.
fn write(dir: &Path, name: &str, doc: &Value) -> String {
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(doc).unwrap()).unwrap();
    path.to_str().unwrap().to_string()
}

/// The plan's field errors of a manifest that passes the field rules.
fn plan_errors(doc: &Value) -> String {
    let e = parse_experiment(&doc.to_string()).expect("passes the field rules");
    plan(&e).expect_err("the plan refuses it").to_string()
}

/// True when the store holds nothing: no run directory was made.
fn store_is_empty(store: &Path) -> bool {
    !store.exists() || std::fs::read_dir(store).unwrap().next().is_none()
}

/// Item 2: the manifests that crashed (capacity overflow, exit 101), allocated
/// without limit (4.9 GB, exit 134) or would run for ever or fill the disk are
/// refused by `repose run` before anything is simulated or stored, with the
/// field or the estimate in the message and exit 2.
#[test]
fn manifests_that_crashed_or_exhausted_the_machine_are_refused_before_running() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let cases: [(&str, Value, &str); 5] = [
        (
            "/scene/inner_diameter_m",
            json!(1e308),
            "scene.inner_diameter_m = 1e+308: gives an estimated inf particles",
        ),
        (
            "/material/particle/size/radius_m",
            json!(1e-5),
            "refused: estimated 6.151e8 particles exceed the limit 2000000 (raise it with --max-particles N",
        ),
        (
            "/material/particle/youngs_modulus_pa",
            json!(1e30),
            "particle-steps exceed the limit 100000000000000 (raise it with --max-particle-steps N",
        ),
        (
            "/scene/rotation_time_s",
            json!(1e308),
            "refused: estimated inf particle-steps exceed the limit",
        ),
        (
            "/scene/sample_interval_s",
            json!(1e-300),
            "scene.sample_interval_s = 1e-300: must be >= the time step 1.1087e-5 s",
        ),
    ];
    for (i, (pointer, value, expected)) in cases.into_iter().enumerate() {
        let doc = edited("drum/smoke.json", &[(pointer, value)]);
        let file = write(tmp.path(), &format!("case{i}.json"), &doc);
        let out = repose(&store, &["run", &file]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{pointer}: {err}");
        assert!(err.contains(expected), "{pointer}: {err}");
        assert!(!err.contains("panicked"), "{pointer}: {err}");
        assert!(store_is_empty(&store), "{pointer}: nothing is stored");
    }
}

/// Item 5: values that passed `validate`, then failed at run time with an
/// engine-side message and a failed run in the store, are now validation
/// errors naming the manifest's fields (exit 2 from `validate` and `run`).
#[test]
fn run_time_failures_are_validation_errors_naming_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let cases: [(&str, Value, &str); 6] = [
        (
            "drum/smoke.json",
            json!({"/material/particle/youngs_modulus_pa": 1e308}),
            "material.particle.youngs_modulus_pa = 1e+308: leaves no time step",
        ),
        (
            "validation/pair_hertz_rigid_wall.json",
            json!({"/time_step/design_impact_speed_m_s": 1e308}),
            "time_step.design_impact_speed_m_s = 1e+308: leaves no time step",
        ),
        (
            "drum/smoke.json",
            json!({"/material/particle/size/radius_m": 0.004}),
            "scene.periodic_slice_m = 0.009: must be >= 0.01761 m, twice the neighbour-search cutoff",
        ),
        (
            "drum/smoke.json",
            json!({"/material/particle/size/radius_m": 0.03, "/scene/length_m": 0.1}),
            "material.particle.size.radius_m = 0.03: the largest simulated particle (diameter 0.06 m) must be smaller than the side of the square inscribed in scene.inner_diameter_m",
        ),
        (
            "drum/smoke.json",
            json!({"/scene/fill_fraction": 1e-6}),
            "scene.fill_fraction = 1e-6: gives 0 particles",
        ),
        (
            "drum/smoke.json",
            json!({"/material/particle/size/radius_m": 1e308}),
            "material.particle.size.radius_m = 1e+308: gives simulated diameters",
        ),
    ];
    for (i, (base, edits, expected)) in cases.into_iter().enumerate() {
        let edits: Vec<(&str, Value)> = edits
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.as_str(), v.clone()))
            .collect();
        let doc = edited(base, &edits);
        let file = write(tmp.path(), &format!("case{i}.json"), &doc);
        for command in ["validate", "run"] {
            let out = repose(&store, &[command, &file]);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(2), "{command} {expected}: {err}");
            assert!(err.contains(expected), "{command}: {err}");
            assert!(
                !err.contains("diameter_m = inf"),
                "no internal names: {err}"
            );
        }
        assert!(store_is_empty(&store), "{expected}: no failed run stored");
    }
}

/// The full drum (no slice) with a radius above the drum: the rule names the
/// field even though the drum is long enough.
#[test]
fn a_particle_longer_than_the_full_drum_is_named() {
    let doc = edit(example("drum/smoke.json"), "/scene/periodic_slice_m", None);
    let doc = edit(doc, "/scene/length_m", Some(json!(0.003)));
    let err = plan_errors(&doc);
    assert!(
        err.contains("material.particle.size.radius_m = 0.0015: the largest simulated particle (diameter 0.003 m) must be smaller than scene.length_m (0.003 m)"),
        "{err}"
    );
}

/// The other scenes' rules: particles that cannot pass the opening they must
/// flow through, slices too thin for the neighbour search, and amounts too
/// small for one particle or too large for the engine.
#[test]
fn every_scene_checks_that_its_particles_fit() {
    let cases: [(&str, &str, Value, &str); 8] = [
        (
            "funnel_pile/smoke.json",
            "/material/particle/size/radius_m",
            json!(0.016),
            "material.particle.size.radius_m = 0.016: the largest simulated particle (diameter 0.032 m) must be smaller than scene.funnel_outlet_diameter_m",
        ),
        (
            "hopper/smoke.json",
            "/scene/orifice_diameter_m",
            json!(0.002),
            "material.particle.size.radius_m = 0.001: the largest simulated particle (diameter 0.003 m) must be smaller than scene.orifice_diameter_m",
        ),
        (
            "hopper/smoke.json",
            "/scene/fill_height_m",
            json!(1e-7),
            "scene.packing_fraction = 0.567: gives 0 particles",
        ),
        (
            "static_pile/smoke.json",
            "/scene/outlet_diameter_m",
            json!(0.002),
            "must be smaller than scene.outlet_diameter_m",
        ),
        (
            "static_pile/smoke.json",
            "/scene/particle_count",
            json!(5_000_000_000u64),
            "scene.particle_count = 5000000000: gives an estimated 5.000e9 particles (as stated); the engine holds at most 4.295e9",
        ),
        (
            "baffle_lift/smoke.json",
            "/scene/periodic_slice_m",
            json!(0.005),
            "scene.periodic_slice_m = 0.005: must be >= 0.01321 m",
        ),
        (
            "baffle_lift/smoke.json",
            "/scene/powder_mass_kg",
            json!(1e-9),
            "scene.powder_mass_kg = 1e-9: gives 0 particles",
        ),
        (
            "funnel_pile/smoke.json",
            "/scene/fill_fraction",
            json!(1e-9),
            "scene.fill_fraction = 1e-9: gives 0 particles",
        ),
    ];
    for (base, pointer, value, expected) in cases {
        let err = plan_errors(&edited(base, &[(pointer, value)]));
        assert!(err.contains(expected), "{base} {pointer}: {err}");
    }
    assert_eq!(ENGINE_MAX_PARTICLES, u32::MAX as f64);
}

/// Every committed experiment makes a plan within the default limits, so the
/// defaults refuse none of the profiles.
#[test]
fn every_committed_experiment_is_within_the_default_limits() {
    let mut seen = 0;
    for path in common::json_files(&common::root().join("experiments")) {
        let text = std::fs::read_to_string(&path).unwrap();
        if repose::study::plan::design_study::is_design_study(&text) {
            // Each scene of a design study, at the centre of its ranges.
            let study: repose::study::plan::design_study::DesignStudy =
                serde_json::from_str(&text).unwrap();
            let centre: Vec<(String, f64)> = study
                .factors
                .values()
                .map(|f| (f.address.clone(), 0.5 * (f.min + f.max)))
                .collect();
            let values: Vec<(&str, f64)> = centre.iter().map(|(a, v)| (a.as_str(), *v)).collect();
            for scene in study.scenes.keys() {
                let e = study.experiment(scene, &values, 0, 0).unwrap();
                let p = plan(&e).unwrap_or_else(|err| panic!("{}: {err}", path.display()));
                p.check(&Limits::default())
                    .unwrap_or_else(|err| panic!("{} {scene}: {err}", path.display()));
            }
            continue;
        }
        if !text.contains("\"physics_version\"") {
            continue; // a study
        }
        let e = parse_experiment(&text).unwrap_or_else(|err| panic!("{}: {err}", path.display()));
        let p = plan(&e).unwrap_or_else(|err| panic!("{}: {err}", path.display()));
        p.check(&Limits::default())
            .unwrap_or_else(|err| panic!("{}: {err}", path.display()));
        seen += 1;
    }
    assert!(seen >= 20, "{seen} experiments");
}

/// The estimates are the run's: the drum's particle count and step are exact,
/// the step count an upper bound (settling may end early).
#[test]
fn the_plan_matches_what_the_run_does() {
    let text = common::text("experiments/tradeoff/drum_tiny.json");
    let e: Experiment = parse_experiment(&text).unwrap();
    let p = plan(&e).unwrap();
    let r = run_experiment(&e, None).unwrap();
    assert_eq!(p.particles, r.measurements["particles"]);
    assert_eq!(p.dt_s, r.measurements["dt_s"]);
    let steps = r.measurements["steps"];
    assert!(
        steps <= p.steps && steps > 0.5 * p.steps,
        "{steps} vs {}",
        p.steps
    );
}

/// A limit refuses a run with the estimate in the message; the flag raises it;
/// a run already complete is served from the cache whatever the limits.
#[test]
fn a_limit_refuses_a_run_and_its_flag_raises_it() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let file = "experiments/validation/pair_hertz_rigid_wall.json";
    let out = repose(&store, &["run", file, "--max-particle-steps", "100"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("refused: estimated 247 particle-steps exceed the limit 100 (raise it with --max-particle-steps N"),
        "{err}"
    );
    assert!(store_is_empty(&store));
    let out = repose(&store, &["run", file, "--max-particle-steps", "1000"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stdout(&out).contains("(computed)"), "{}", stdout(&out));
    // A complete run is served from the cache whatever the limits.
    let out = repose(&store, &["run", file, "--max-particle-steps", "100"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stdout(&out).contains("(cache hit)"), "{}", stdout(&out));
}

/// `repose plan` and `repose run --dry-run` print the estimates (text and
/// JSON) and whether they are within the limits; they run and store nothing.
#[test]
fn plan_and_dry_run_print_the_estimates() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let file = "experiments/drum/smoke.json";
    let out = repose(&store, &["plan", file]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    for line in [
        "  scene: drum",
        "  particles: 182",
        "  dt_s: 1.1087e-5",
        "  steps: 117253",
        "  particle_steps: 2.134e7",
        "  within limits: yes",
    ] {
        assert!(text.contains(line), "{line}: {text}");
    }
    let out = repose(&store, &["run", "--dry-run", file]);
    assert_eq!(stdout(&out), text, "--dry-run prints the plan");

    let out = repose(&store, &["plan", "--json", file, "--max-particles", "100"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(v["plan"]["particles"], json!(182.0));
    assert_eq!(v["plan"]["steps"], json!(117253.0));
    assert_eq!(v["plan"]["scene"], json!("drum"));
    assert_eq!(v["limits"]["max_particles"], json!(100));
    assert_eq!(v["within_limits"], json!(false));
    assert_eq!(v["excess"][0]["quantity"], json!("particles"));
    assert_eq!(v["excess"][0]["flag"], json!("--max-particles"));
    let out = repose(&store, &["run", "--dry-run", "--json", file]);
    let v: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(v["within_limits"], json!(true));
    assert!(v["plan"]["log_bytes"].as_f64().unwrap() > 0.0);
    assert!(store_is_empty(&store), "a plan stores nothing");
}

/// `batch` refuses a study whose runs exceed the limits before any runs.
#[test]
fn batch_refuses_over_limit_runs_before_running_any() {
    let tmp = tempfile::tempdir().unwrap();
    let v = example("calibrate-smoke/study.json");
    let path = tmp.path().join("study.json");
    std::fs::write(&path, v.to_string()).unwrap();
    let s = parse_study(&v.to_string()).unwrap();
    let store = Store::open(tmp.path().join("store")).unwrap();
    let dir = StudyDir::new(store.root(), &s, &path);
    sample(&dir, &s, &SampleSettings::default()).unwrap();
    let calls = AtomicUsize::new(0);
    let runner = |e: &Experiment, _: &RunDir| -> Result<RunResult, std::io::Error> {
        calls.fetch_add(1, Ordering::SeqCst);
        Ok(RunResult::new(e, "fake"))
    };
    let settings = Executor {
        jobs: 1,
        progress: false,
        limits: Limits {
            max_particles: 10,
            ..Limits::default()
        },
        max_runs: repose::exec::DEFAULT_MAX_RUNS,
        slurm: None,
    };
    let err = batch(&dir, &s, &store, &settings, runner).unwrap_err();
    assert!(
        matches!(err, StudyError::Exec(ExecError::Refused { .. })),
        "{err}"
    );
    assert!(err.is_invalid_input());
    assert!(
        err.to_string().contains("particles exceed the limit 10"),
        "{err}"
    );
    assert_eq!(calls.load(Ordering::SeqCst), 0, "nothing ran");
}
