//! Every committed study lowers to its method's stage list, and
//! `repose stages` prints it (text and JSON) before anything runs.

mod common;

use repose::study::stages::{Analysis, Method, StudyFile, StudySpec};
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
