//! The `repose` binary: exit codes (2 invalid input, 1 runtime failure), error
//! reports naming fields and positions, the run store commands.

mod common;

use common::{edit, pair_wall, repose, stderr, stdout};
use serde_json::json;

#[test]
fn validate_reports_every_field_error_and_exits_2() {
    let tmp = tempfile::tempdir().unwrap();
    let bad = edit(
        pair_wall(),
        "/contact/particle_particle/restitution",
        Some(json!(1.3)),
    );
    let bad = edit(bad, "/scene/radius_m", Some(json!(0)));
    let path = tmp.path().join("bad.json");
    std::fs::write(&path, serde_json::to_string_pretty(&bad).unwrap()).unwrap();
    let out = repose(tmp.path(), &["validate", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("contact.particle_particle.restitution = 1.3: must be in (0, 1]"),
        "{err}"
    );
    assert!(
        err.contains("scene.radius_m = 0.0: must be a finite number > 0"),
        "{err}"
    );
    assert!(!err.contains("backtrace"), "{err}");
}

#[test]
fn malformed_json_reports_line_and_column_and_exits_2() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("broken.json");
    std::fs::write(&path, "{\n  \"schema_version\": 1,\n  \"scene\": {,}\n}\n").unwrap();
    let out = repose(tmp.path(), &["validate", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("broken.json:3:13: "),
        "{}",
        stderr(&out)
    );
}

#[test]
fn validate_accepts_every_example_and_names_its_kind() {
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(
        tmp.path(),
        &[
            "validate",
            "experiments/he2019/study.json",
            "experiments/validation/pair_jkr_separation.json",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stdout(&out).contains("ok study "));
    assert!(stdout(&out).contains("ok experiment "));
}

/// A manifest that cannot be read (missing, a directory, not UTF-8) is bad
/// input for every command that takes one: exit 2, naming the file, the OS
/// error said once.
#[test]
fn an_unreadable_input_file_exits_2_from_every_command() {
    let tmp = tempfile::tempdir().unwrap();
    let latin1 = tmp.path().join("latin1.json");
    std::fs::write(&latin1, b"{\"name\": \"caf\xe9\"}").unwrap();
    let dir = tmp.path().to_str().unwrap().to_string();
    for file in ["no/such/file.json", &dir, latin1.to_str().unwrap()] {
        for command in [
            "hash",
            "validate",
            "run",
            "inspect",
            "tradeoff",
            "sample",
            "batch",
            "noise",
            "calibrate",
        ] {
            let out = repose(tmp.path(), &[command, file]);
            assert_eq!(
                out.status.code(),
                Some(2),
                "{command} {file}: {}",
                stderr(&out)
            );
            let err = stderr(&out);
            assert!(err.contains(file), "{command} {file}: {err}");
            assert!(!err.contains("panicked"), "{err}");
            assert!(err.matches("os error").count() <= 1, "{err}");
        }
    }
}

/// `repose noise` on an experiment manifest needs --seeds; with too few
/// seeds it says how many it needs; both before any run.
#[test]
fn noise_of_an_experiment_asks_for_seeds() {
    let tmp = tempfile::tempdir().unwrap();
    let file = "experiments/drum/smoke.json";
    let out = repose(tmp.path(), &["noise", file]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("give --seeds N"), "{}", stderr(&out));
    let out = repose(tmp.path(), &["noise", file, "--seeds", "1"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--seeds = 1: at least 2"),
        "{}",
        stderr(&out)
    );
    let runs = std::fs::read_dir(tmp.path())
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().len() == 64)
        .count();
    assert_eq!(runs, 0, "nothing ran");
}

/// serde_json says only "expected value" at a NaN; the report says why.
#[test]
fn a_nan_or_infinity_literal_is_explained() {
    let tmp = tempfile::tempdir().unwrap();
    let text = common::text("experiments/validation/pair_hertz_particle_particle.json");
    for literal in ["NaN", "Infinity", "-Infinity"] {
        let bad = text.replacen("0.5", literal, 1);
        assert_ne!(bad, text);
        let path = tmp.path().join("nan.json");
        std::fs::write(&path, bad).unwrap();
        for command in ["validate", "run"] {
            let out = repose(tmp.path(), &[command, path.to_str().unwrap()]);
            assert_eq!(out.status.code(), Some(2), "{command}");
            assert!(
                stderr(&out).contains("JSON has no NaN or Infinity"),
                "{command} {literal}: {}",
                stderr(&out)
            );
        }
    }
}

/// `repose inspect F | head`: the reader goes away; repose stops quietly.
#[test]
fn a_closed_output_pipe_is_not_an_error() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let file = "experiments/validation/pair_hertz_particle_particle.json";
    assert!(repose(&store, &["run", file]).status.success());
    let id = stdout(&repose(&store, &["hash", file])).trim().to_string();
    let log = store.join(&id).join("run.mcap");
    for args in [
        vec!["inspect", log.to_str().unwrap()],
        vec!["runs", "list"],
        vec!["runs", "show", &id[..8]],
        vec!["run", file],
    ] {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_repose"))
            .args(&args)
            .current_dir(common::root())
            .env("REPOSE_STORE", &store)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).is_empty(), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn hash_prints_the_pinned_id() {
    let tmp = tempfile::tempdir().unwrap();
    let golden: serde_json::Value =
        serde_json::from_str(&common::text("golden/manifest_ids.json")).unwrap();
    let file = "experiments/validation/pair_hertz_particle_particle.json";
    let out = repose(tmp.path(), &["hash", file]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(stdout(&out).trim(), golden[file].as_str().unwrap());
    let out = repose(tmp.path(), &["hash", "--kind", "study", file]);
    assert_eq!(out.status.code(), Some(2), "an experiment is not a study");
}

#[test]
fn run_stores_the_manifest_and_a_failure_then_lists_and_shows_it() {
    // A pair impact given far too little time to finish: a runtime failure
    // (exit 1) recorded in error.json, never a result.
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("store");
    let base: serde_json::Value = serde_json::from_str(&common::text(
        "experiments/validation/pair_hertz_particle_particle.json",
    ))
    .unwrap();
    let short = edit(base, "/scene/max_time_s", Some(serde_json::json!(1e-6)));
    let file = tmp.path().join("short.json");
    std::fs::write(&file, serde_json::to_string_pretty(&short).unwrap()).unwrap();
    let file = file.to_str().unwrap();
    let out = repose(&store, &["run", file]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("did not end within max_time_s"),
        "{}",
        stderr(&out)
    );
    let id = stdout(&repose(&store, &["hash", file])).trim().to_string();
    assert!(store.join(&id).join("manifest.json").is_file());
    assert!(store.join(&id).join("error.json").is_file());
    assert!(!store.join(&id).join("result.json").exists());
    assert!(!store.join(&id).join("run.mcap").exists());

    let list = stdout(&repose(&store, &["runs", "list"]));
    let row = list
        .lines()
        .find(|l| l.starts_with(&id[..12]))
        .unwrap_or_else(|| panic!("{list}"));
    assert!(
        row.contains("pair") && row.contains("smoke") && row.contains("failed"),
        "{row}"
    );

    let show = repose(
        &store,
        &["--store", store.to_str().unwrap(), "runs", "show", &id[..8]],
    );
    assert_eq!(show.status.code(), Some(0), "{}", stderr(&show));
    assert!(stdout(&show).contains(&id) && stdout(&show).contains("max_time_s"));
}

#[test]
fn runs_show_names_every_candidate_of_an_ambiguous_prefix() {
    let tmp = tempfile::tempdir().unwrap();
    let a = format!("cd{}", "0".repeat(62));
    let b = format!("cd{}", "1".repeat(62));
    for id in [&a, &b] {
        std::fs::create_dir_all(tmp.path().join(id)).unwrap();
    }
    let out = repose(tmp.path(), &["runs", "show", "cd"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("ambiguous")
            && stderr(&out).contains(&a)
            && stderr(&out).contains(&b),
        "{}",
        stderr(&out)
    );
    let out = repose(tmp.path(), &["runs", "show", "ee"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("no run"), "{}", stderr(&out));
}

#[test]
fn an_empty_store_lists_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(tmp.path(), &["runs", "list"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(stdout(&out).starts_with("no runs in"));
}

#[test]
fn responses_lists_every_scene_or_one_and_refuses_an_unknown_one() {
    let tmp = tempfile::tempdir().unwrap();
    let out = repose(tmp.path(), &["responses"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    for kind in repose::scenes::responses::kinds() {
        assert!(text.lines().any(|l| l == *kind), "{kind} missing:\n{text}");
    }
    assert!(text.contains("angle_2h_d_deg") && text.contains("flow_rate_1s_per_s"));

    let out = repose(tmp.path(), &["responses", "drum", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(doc[0]["scene"], "drum");
    let names: Vec<&str> = doc[0]["responses"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["dynamic_angle_deg", "static_angle_deg"]);
    assert_eq!(doc[0]["responses"][0]["unit"], "deg");

    let out = repose(tmp.path(), &["responses", "tumbler"]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains("unknown scene kind 'tumbler'") && err.contains("hopper, static_pile"),
        "{err}"
    );
}

/// Issue 40, low item: `--poll-seconds 1e300` panicked converting to a
/// `Duration`; it is refused (exit 2) naming the option and its bounds.
/// Issue 54, low: 1e-12 was reported as `= 0`, and 1e300 printed with 300
/// digits; each is shown as given.
#[test]
fn a_poll_interval_past_a_day_or_below_a_millisecond_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    for value in ["1e300", "86401", "0", "NaN", "1e-12"] {
        let out = repose(
            tmp.path(),
            &[
                "batch",
                "experiments/calibrate-smoke/study.json",
                "--executor",
                "slurm",
                "--poll-seconds",
                value,
            ],
        );
        assert_eq!(out.status.code(), Some(2), "{value}: {}", stderr(&out));
        let err = stderr(&out);
        let shown = value.parse::<f64>().unwrap();
        assert!(
            err.contains(&format!(
                "--poll-seconds = {shown:?}: must lie in [0.001, 86400]"
            )),
            "{err}"
        );
        assert!(err.len() < 300, "{err}");
    }
}

/// Issue 40, low items: a knob value NaN or infinite is refused naming it
/// (the message used to print `null` after a JSON error), a huge one is
/// printed short (1e308 used to print 309 digits), and `--jobs 0` (or its
/// old name `--threads 0`) is refused before the sweep is planned.
#[test]
fn tradeoff_values_must_be_finite_and_jobs_at_least_one() {
    let tmp = tempfile::tempdir().unwrap();
    let m = "experiments/drum/smoke.json";
    for (values, expected) in [
        (
            "rayleigh_fraction=NaN,0.2",
            "knob `rayleigh_fraction` = NaN: must be a finite number",
        ),
        (
            "rayleigh_fraction=0.1,inf",
            "knob `rayleigh_fraction` = inf: must be a finite number",
        ),
        (
            "rayleigh_fraction=0.1,1e308",
            "knob `rayleigh_fraction` = 1e308: time_step.rayleigh_fraction",
        ),
    ] {
        let out = repose(
            tmp.path(),
            &[
                "tradeoff",
                m,
                "--knobs",
                "rayleigh_fraction",
                "--values",
                values,
            ],
        );
        assert_eq!(out.status.code(), Some(2), "{values}: {}", stderr(&out));
        assert!(stderr(&out).contains(expected), "{}", stderr(&out));
        assert!(stderr(&out).len() < 400, "{}", stderr(&out));
    }
    for flag in ["--jobs", "--threads"] {
        let out = repose(tmp.path(), &["tradeoff", m, flag, "0"]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(
            stderr(&out).contains("--jobs = 0: must be >= 1"),
            "{}",
            stderr(&out)
        );
        assert!(stdout(&out).is_empty(), "{}", stdout(&out));
    }
}
