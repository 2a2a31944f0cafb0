//! Every committed study lowers to its method's stage list, and
//! `repose stages` prints it (text and JSON) before anything runs.

mod common;

use repose::study::plan::{Analysis, Method, StudyFile, StudySpec};
use serde_json::{json, Value};

fn spec(path: &str, analysis: Analysis, adaptive: bool) -> StudySpec {
    let file = StudyFile::read(&common::root().join(path)).unwrap();
    StudySpec::of(&file, analysis, adaptive)
}

fn names(s: &StudySpec) -> Vec<&'static str> {
    s.stages.iter().map(|st| st.name()).collect()
}

#[test]
fn each_method_is_a_stage_list() {
    let classic = spec(
        "experiments/calibrate-smoke/study.json",
        Analysis::ResponseSurface,
        false,
    );
    assert_eq!(classic.method, Method::He2019);
    assert_eq!(
        names(&classic),
        ["design", "simulate", "fit", "search", "verify"]
    );

    let quick = spec(
        "experiments/he2019-quick/study.json",
        Analysis::ResponseSurface,
        false,
    );
    assert_eq!(quick.method, Method::He2019NoiseAware);
    assert_eq!(
        names(&quick),
        ["noise", "design", "simulate", "fit", "search", "verify"]
    );
    let adaptive = spec(
        "experiments/he2019-quick/study.json",
        Analysis::ResponseSurface,
        true,
    );
    assert_eq!(
        names(&adaptive),
        ["noise", "design", "simulate", "fit", "adaptive", "search", "verify"]
    );

    let cai = spec(
        "experiments/cai2024-smoke/study.json",
        Analysis::ResponseSurface,
        false,
    );
    assert_eq!(cai.method, Method::ResponseSurface);
    assert_eq!(
        names(&cai),
        ["screen", "design", "simulate", "fit", "search", "verify"]
    );

    let yan = spec(
        "experiments/yan2015-smoke/study.json",
        Analysis::Sensitivity,
        false,
    );
    assert_eq!(yan.method, Method::Sensitivity);
    assert_eq!(
        names(&yan),
        ["design", "simulate", "fit", "sensitivity", "verify"]
    );
}

#[test]
fn stages_prints_what_each_stage_uses() {
    let tmp = tempfile::tempdir().unwrap();
    let out = common::repose(
        tmp.path(),
        &["stages", "experiments/he2019-quick/study.json", "--json"],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    let v: Value = serde_json::from_str(&common::stdout(&out)).unwrap();
    assert_eq!(v["method"], "he2019_noise_aware");
    let stages = v["stages"].as_array().unwrap();
    assert_eq!(stages[0], json!({"stage": "noise", "seeds": 8}));
    assert_eq!(
        stages[1],
        json!({"stage": "design", "design": "optimised_lhs", "factors": 5})
    );
    assert_eq!(
        stages[2],
        json!({"stage": "simulate", "scenes": ["funnel"], "points": 12, "replicates": 1})
    );
    assert_eq!(
        stages[3],
        json!({"stage": "fit", "models": ["gp", "ga_bp"]})
    );
    assert_eq!(
        stages[4],
        json!({"stage": "search", "search": "probability", "screen": true})
    );
    assert_eq!(
        stages[5],
        json!({"stage": "verify", "scenes": ["funnel", "baffle", "drum"], "points": 1,
               "seeds": 5, "max_seeds": 28})
    );

    let out = common::repose(
        tmp.path(),
        &[
            "stages",
            "experiments/yan2015-smoke/study.json",
            "--analysis",
            "sensitivity",
        ],
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    let text = common::stdout(&out);
    assert!(text.contains("method sensitivity"), "{text}");
    assert!(
        text.contains("1. design: full_factorial over 3 factor(s)"),
        "{text}"
    );
    assert!(text.contains("3. fit: power_law\n"), "{text}");
    assert!(text.contains("4. sensitivity: levels 1-3\n"), "{text}");

    let out = common::repose(tmp.path(), &["stages", "experiments/nope.json"]);
    assert_eq!(out.status.code(), Some(2), "{}", common::stderr(&out));
}

/// `study` (a committed study file) with `stages` spelled out, written to
/// `dir`.
fn spelled(dir: &std::path::Path, study: &str, stages: &[&str]) -> std::path::PathBuf {
    let mut v: Value = serde_json::from_str(&common::text(study)).unwrap();
    v["stages"] = json!(stages);
    let path = dir.join(format!("spelled-{}.json", stages.len()));
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    path
}

#[test]
fn a_study_file_may_spell_its_stages() {
    let tmp = tempfile::tempdir().unwrap();
    // The list its blocks give: the same stages, same runs.
    let quick = "experiments/he2019-quick/study.json";
    let listed = ["noise", "design", "simulate", "fit", "search", "verify"];
    let file = StudyFile::read(&spelled(tmp.path(), quick, &listed)).unwrap();
    let plain = spec(quick, Analysis::ResponseSurface, false);
    let own = file.spec(None, false).unwrap();
    assert_eq!(own.stages, plain.stages);
    // The committed file's id is untouched: an absent `stages` is not hashed.
    let ids: Value = serde_json::from_str(&common::text("golden/manifest_ids.json")).unwrap();
    assert_eq!(json!(plain.id.to_string()), ids[quick]);

    // Naming `adaptive` is `--adaptive`.
    let with = [
        "noise", "design", "simulate", "fit", "adaptive", "search", "verify",
    ];
    let file = StudyFile::read(&spelled(tmp.path(), quick, &with)).unwrap();
    assert!(file.spells_adaptive());
    assert_eq!(
        file.spec(None, false).unwrap().stages,
        spec(quick, Analysis::ResponseSurface, true).stages
    );

    // A design study's spelled list chooses its analysis.
    let yan = "experiments/yan2015-smoke/study.json";
    let levels = ["design", "simulate", "fit", "sensitivity", "verify"];
    let path = spelled(tmp.path(), yan, &levels);
    let file = StudyFile::read(&path).unwrap();
    assert_eq!(file.spelled_analysis(), Some(Analysis::Sensitivity));
    let own = file.spec(None, false).unwrap();
    assert_eq!(own.method, Method::Sensitivity);
    let out = common::repose(tmp.path(), &["stages", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    assert!(common::stdout(&out).contains("method sensitivity"));
    // ... and a command of the other analysis is refused before any run.
    let out = common::repose(tmp.path(), &["rsm", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", common::stderr(&out));
    let err = common::stderr(&out);
    assert!(err.contains("stages"), "{err}");
    assert!(err.contains("repose sensitivity"), "{err}");
}

#[test]
fn spelled_stages_that_differ_from_the_blocks_are_refused_naming_the_list() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str], &str); 5] = [
        // Out of order.
        (
            "experiments/he2019-quick/study.json",
            &["design", "noise", "simulate", "fit", "search", "verify"],
            "[noise, design, simulate, fit, search, verify], with `adaptive` after `fit`",
        ),
        // A stage the blocks do not give (no `noise_aware`: no noise floor).
        (
            "experiments/calibrate-smoke/study.json",
            &["noise", "design", "simulate", "fit", "search", "verify"],
            "[design, simulate, fit, search, verify]",
        ),
        // A name that is no stage.
        (
            "experiments/cai2024-smoke/study.json",
            &["screen", "design", "simulate", "fit", "optimise", "verify"],
            "[screen, design, simulate, fit, search, verify] for a response surface",
        ),
        // Adaptive rounds in a two-level study (its fine stage replaces them).
        (
            "experiments/he2019-quick/two-level/study.json",
            &[
                "noise", "design", "simulate", "fit", "adaptive", "fine", "search", "verify",
            ],
            "[noise, design, simulate, fit, fine, search, verify]",
        ),
        // A sensitivity list missing its verification.
        (
            "experiments/yan2015-smoke/study.json",
            &["design", "simulate", "fit", "sensitivity"],
            "[design, simulate, fit, sensitivity, verify] for yan2015's sensitivity levels",
        ),
    ];
    for (study, stages, allowed) in cases {
        let path = spelled(tmp.path(), study, stages);
        let out = common::repose(tmp.path(), &["validate", path.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "{study}");
        let err = common::stderr(&out);
        assert!(err.contains("stages"), "{study}: {err}");
        assert!(err.contains(&stages.join(", ")), "{study}: {err}");
        assert!(err.contains(allowed), "{study}: {err}");
        let out = common::repose(tmp.path(), &["stages", path.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "{study}");
    }
}
