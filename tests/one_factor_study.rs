//! A design study with one factor (issue 40, item 1): cai2024-smoke reduced
//! to its static scene with factor A on a three-level full factorial and two
//! replicates. `rsm` used to panic after writing half its outputs (the
//! contour plot read a second factor); it now writes the whole analysis,
//! with the fitted curve through the runs in place of a contour. The runs
//! come from a fake runner, an exact quadratic of μs plus a small
//! seed-dependent scatter, so the fit can be checked.

mod common;

use repose::exec::Executor;
use repose::manifest::Experiment;
use repose::report::table::Table;
use repose::store::{RunDir, RunResult, Store};
use repose::study::plan::design_study::parse_design_study;
use serde_json::json;

/// 30 + 20 μ + 10 μ² degrees plus ±10⁻⁶° from the packing seed (a pure
/// error that is not zero, too small to move the coefficients past 10⁻³:
/// a level mean off by 10⁻⁶ moves the μ² coefficient by at most 5·10⁻⁵).
fn fake(e: &Experiment, _: &RunDir) -> Result<RunResult, std::io::Error> {
    let mu = e.contact.particle_particle.static_friction;
    let scatter = if e.seeds.packing_seed.is_multiple_of(2) {
        1e-6
    } else {
        -1e-6
    };
    let mut r = RunResult::new(e, "fake");
    let angle = 30.0 + 20.0 * mu + 10.0 * mu * mu + scatter;
    r.measurements.insert("height_angle_deg".into(), angle);
    r.headline_angle_deg = Some(angle);
    Ok(r)
}

/// cai2024-smoke reduced to its static scene and factor A, on `design`
/// with `replicates`.
fn one_factor(design: serde_json::Value, replicates: u32) -> serde_json::Value {
    let mut v = common::example("cai2024-smoke/study.json");
    let o = v.as_object_mut().unwrap();
    o["scenes"].as_object_mut().unwrap().remove("drum");
    o["responses"]
        .as_object_mut()
        .unwrap()
        .remove("dynamic_angle_deg");
    o["targets"]
        .as_object_mut()
        .unwrap()
        .remove("dynamic_angle_deg");
    o["factors"]
        .as_object_mut()
        .unwrap()
        .retain(|name, _| name == "A");
    o.insert("design".into(), design);
    o.insert("replicates".into(), json!(replicates));
    o.remove("screening");
    o.remove("verification");
    v
}

#[test]
fn a_one_factor_study_is_analysed_whole() {
    let v = one_factor(
        json!({ "kind": "full_factorial", "levels": { "A": [0.2, 0.4, 0.6] } }),
        2,
    );
    let study = parse_design_study(&v.to_string()).unwrap();

    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let pool = Executor::local(1, Default::default());
    let report = repose::study::run_rsm(tmp.path(), &study, &store, &pool, &fake).unwrap();
    let a = &report.rsm.analyses[0];
    assert_eq!(a.response, "static_angle_deg");

    let dir = report.rsm.dir.clone();
    let sub = dir.join("static_angle_deg");
    for file in [
        "anova.csv",
        "anova.md",
        "coefficients.csv",
        "fit.json",
        "parity.svg",
        "curve.svg",
    ] {
        assert!(sub.join(file).is_file(), "{file}");
    }
    assert!(!sub.join("contour.svg").exists());
    // The quadratic in actual units is the fake's: 30 + 20 μ + 10 μ².
    let c = Table::read(&sub.join("coefficients.csv")).unwrap();
    let actual = c
        .numbers(&sub.join("coefficients.csv"), "actual_coefficient")
        .unwrap();
    for (got, want) in actual.iter().zip([30.0, 20.0, 10.0]) {
        assert!((got - want).abs() < 1e-3, "{actual:?}");
    }
    assert_eq!(
        Table::read(&dir.join("responses.csv")).unwrap().rows.len(),
        6
    );
}

/// Issue 40 (low): a design that cannot carry the quadratic (two levels of a
/// factor, or no more runs than terms) is refused before any run, not
/// simulated and then refused.
#[test]
fn a_design_the_quadratic_cannot_fit_is_refused_before_the_runs() {
    let runs = std::sync::atomic::AtomicUsize::new(0);
    let counting = |e: &Experiment, d: &RunDir| {
        runs.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        fake(e, d)
    };
    let pool = Executor::local(1, Default::default());
    for (design, replicates, says) in [
        (
            json!({ "kind": "full_factorial", "levels": { "A": [0.2, 0.6] } }),
            2,
            "design.levels.A = [0.2, 0.6]: a quadratic fit needs at least 3 levels",
        ),
        (
            json!({ "kind": "full_factorial", "levels": { "A": [0.2, 0.4, 0.6] } }),
            1,
            "3 runs are too few for the 3 terms",
        ),
    ] {
        let study = parse_design_study(&one_factor(design, replicates).to_string()).unwrap();
        study.validate().unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::open(tmp.path()).unwrap();
        let err = repose::study::run_rsm(tmp.path(), &study, &store, &pool, &counting).unwrap_err();
        assert!(err.is_invalid_input());
        assert!(err.to_string().contains(says), "{err}");
    }
    assert_eq!(runs.into_inner(), 0);
}
