//! Bad input never panics: random bytes, random JSON values, and valid manifests
//! with random leaves replaced all go through parsing, validation and the run
//! plan (with its limits) to an `Ok` or an error.

mod common;

use common::{edit, json_files, root};
use proptest::prelude::*;
use repose::manifest::{parse_document, parse_experiment, parse_study, DocumentKind};
use repose::scenes::plan::{plan, Limits};
use serde_json::{json, Value};

fn any_json() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        any::<i64>().prop_map(|i| json!(i)),
        any::<u64>().prop_map(|u| json!(u)),
        any::<f64>()
            .prop_filter("finite", |f| f.is_finite())
            .prop_map(|f| json!(f)),
        prop_oneof![
            Just(-1.0),
            Just(0.0),
            Just(1e-300),
            Just(1e300),
            Just(0.5),
            Just(1.0)
        ]
        .prop_map(|f: f64| json!(f)),
        "[a-z_*.]{0,12}".prop_map(Value::String),
        prop_oneof![
            Just("rigid"),
            Just("pair"),
            Just("drum"),
            Just("jkr"),
            Just("hertz"),
            Just("lhs"),
            Just("smoke")
        ]
        .prop_map(|s| json!(s)),
    ];
    leaf.prop_recursive(4, 64, 8, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..8).prop_map(Value::Array),
            prop::collection::btree_map("[a-z_]{1,10}", inner, 0..8)
                .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// Every example manifest as a JSON value.
fn examples() -> Vec<Value> {
    json_files(&root().join("experiments"))
        .iter()
        .map(|p| serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap())
        .collect()
}

fn exercise(text: &str) {
    let _ = parse_document(text, None);
    let _ = parse_document(text, Some(DocumentKind::Experiment));
    let _ = parse_document(text, Some(DocumentKind::Study));
    if let Ok(e) = parse_experiment(text) {
        let _ = e.id();
        if let Ok(p) = plan(&e) {
            let _ = p.check(&Limits::default());
            let _ = p.to_string();
        }
    }
    if let Ok(s) = parse_study(text) {
        let _ = s.id();
    }
    if let Ok(s) = serde_json::from_str::<repose::study::plan::design_study::DesignStudy>(text) {
        let _ = s.id();
        if s.validate().is_ok() {
            let _ = repose::study::plan::design_study::coded_design(&s);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        exercise(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_strings(text in "[{}\\[\\]\":,0-9a-z_.eE+ -]{0,200}") {
        exercise(&text);
    }

    #[test]
    fn random_json_values(v in any_json()) {
        exercise(&v.to_string());
    }

    #[test]
    fn examples_with_one_node_replaced(which in any::<prop::sample::Index>(), at in any::<prop::sample::Index>(), new in any_json()) {
        let all = examples();
        let doc = which.get(&all).clone();
        let ptrs: Vec<String> = common::nodes(&doc).into_iter().map(|(p, _)| p).collect();
        let pointer = at.get(&ptrs).clone();
        exercise(&edit(doc, &pointer, Some(new)).to_string());
    }

    #[test]
    fn examples_with_one_node_removed(which in any::<prop::sample::Index>(), at in any::<prop::sample::Index>()) {
        let all = examples();
        let doc = which.get(&all).clone();
        let ptrs: Vec<String> = common::nodes(&doc).into_iter().map(|(p, _)| p).collect();
        let pointer = at.get(&ptrs).clone();
        let is_array_item = doc.pointer(pointer.rsplit_once('/').unwrap().0).is_some_and(Value::is_array);
        prop_assume!(!is_array_item);
        exercise(&edit(doc, &pointer, None).to_string());
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let text = "[".repeat(100_000);
    assert!(parse_document(&text, None).is_err());
    let text = format!("{{\"scene\":{}", "{\"a\":".repeat(100_000));
    assert!(parse_document(&text, None).is_err());
}

/// Issue 24 item 2: manifests that validated and then panicked (capacity
/// overflow), allocated without limit or would run for ever are refused by the
/// plan or its default limits, without panicking.
#[test]
fn manifests_that_crashed_the_runner_are_refused_by_the_plan() {
    let drum = common::example("drum/smoke.json");
    let pair = common::pair_wall();
    let cases = [
        (drum.clone(), "/scene/inner_diameter_m", json!(1e308)),
        (
            drum.clone(),
            "/material/particle/size/radius_m",
            json!(1e-5),
        ),
        (
            drum.clone(),
            "/material/particle/size/radius_m",
            json!(1e308),
        ),
        (
            drum.clone(),
            "/material/particle/youngs_modulus_pa",
            json!(1e30),
        ),
        (
            drum.clone(),
            "/material/particle/youngs_modulus_pa",
            json!(1e308),
        ),
        (drum.clone(), "/scene/rotation_time_s", json!(1e308)),
        (drum.clone(), "/scene/sample_interval_s", json!(1e-300)),
        (drum, "/scene/standing_time_s", json!(1e308)),
        (
            pair.clone(),
            "/time_step/design_impact_speed_m_s",
            json!(1e308),
        ),
        (pair, "/scene/max_time_s", json!(1e308)),
    ];
    for (doc, pointer, value) in cases {
        let text = edit(doc, pointer, Some(value)).to_string();
        exercise(&text);
        let e = parse_experiment(&text).expect("passes the field rules");
        let refused = plan(&e).map(|p| p.check(&Limits::default()));
        assert!(!matches!(refused, Ok(Ok(()))), "{pointer}: {refused:?}");
    }
}
