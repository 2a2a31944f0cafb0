//! Experiment tracking (issue 42): `repose runs list` with queries, `repose
//! diff` of runs and of studies, `repose studies`, on synthetic stores written
//! through the store's own writer (valid seals, no simulation).
//!
//! Expected statistics are computed with scipy 1.17.1; each call is written
//! beside its number.

mod common;

use std::path::{Path, PathBuf};

use common::{edit, example, repose, stderr, stdout};
use repose::manifest::{parse_experiment, ContentId};
use repose::store::{RunResult, RunSummary, Store};
use repose::study::dir::StudyDir;
use repose::study::plan::design_study::parse_design_study;
use serde_json::{json, Value};

/// Writes one run of experiments/drum/smoke.json with `edits` (JSON pointer,
/// value) through [`Store::run_cached`]: complete with `angle_deg` (and the
/// same headline angle) when `angle` is given, failed otherwise.
fn put(store: &Store, edits: &[(&str, Value)], angle: Option<f64>) -> ContentId {
    let mut manifest = example("drum/smoke.json");
    for (pointer, value) in edits {
        manifest = edit(manifest, pointer, Some(value.clone()));
    }
    let experiment = parse_experiment(&manifest.to_string()).expect("a valid edit");
    let _ = store.run_cached(&experiment, |e, _| match angle {
        Some(a) => {
            let mut r = RunResult::new(e, "synthetic");
            r.measurements.insert("angle_deg".into(), a);
            r.headline_angle_deg = Some(a);
            Ok(r)
        }
        None => Err(std::io::Error::other("synthetic failure")),
    });
    experiment.id()
}

/// μs particle–particle and packing seed, the edits of most runs here.
fn mu_seed(mu: f64, seed: u64) -> [(&'static str, Value); 2] {
    [
        ("/contact/particle_particle/static_friction", json!(mu)),
        ("/seeds/packing_seed", json!(seed)),
    ]
}

/// The angles of the query fixture: three replicates (seeds 0, 1, 2) at
/// each of three frictions.
const ANGLES: [(f64, [f64; 3]); 3] = [
    (0.3, [32.0, 33.0, 33.5]),
    (0.4, [31.0, 32.5, 34.0]),
    (0.5, [36.0, 37.0, 41.0]),
];

/// Nine complete runs ([`ANGLES`]) and one failed run at μs 0.7.
fn query_store(dir: &Path) -> Store {
    let store = Store::open(dir).unwrap();
    for (mu, angles) in ANGLES {
        for (seed, a) in angles.iter().enumerate() {
            put(&store, &mu_seed(mu, seed as u64), Some(*a));
        }
    }
    put(&store, &mu_seed(0.7, 0), None);
    store
}

/// `repose runs list ARGS --json`, parsed; the command must succeed.
fn list_json(store: &Path, args: &[&str]) -> Vec<Value> {
    let mut all = vec!["runs", "list", "--json"];
    all.extend_from_slice(args);
    let out = repose(store, &all);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    serde_json::from_str(&stdout(&out)).expect("JSON output parses")
}

fn column(rows: &[Value], name: &str) -> Vec<Value> {
    rows.iter().map(|r| r[name].clone()).collect()
}

const MU: &str = "contact.particle_particle.static_friction";

#[test]
fn where_filters_each_operator_on_manifest_fields_responses_and_status() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let count = |expr: &str| list_json(tmp.path(), &["--where", expr]).len();
    assert_eq!(count(&format!("{MU}=0.4")), 3);
    assert_eq!(
        count(&format!("{MU} != 0.4")),
        7,
        "the failed run has μs 0.7"
    );
    assert_eq!(count(&format!("{MU}<0.4")), 3);
    assert_eq!(count(&format!("{MU}<=0.4")), 6);
    assert_eq!(count(&format!("{MU}>0.4")), 4);
    assert_eq!(count(&format!("{MU}>=0.5")), 4);
    // Numbers compare as numbers: 9 < 10 although "9" > "10" as text.
    assert_eq!(count("seeds.packing_seed<10"), 10);
    assert_eq!(count("angle_deg>33"), 5, "33.5, 34, 36, 37 and 41");
    assert_eq!(count("status=failed"), 1);
    assert_eq!(count("scene=drum"), 10);
    assert_eq!(count("physics_version=1"), 10);
    // Filters combine with AND; a run without the response passes no filter.
    let rows = list_json(
        tmp.path(),
        &["--where", &format!("{MU}>=0.4"), "--where", "angle_deg!=0"],
    );
    assert_eq!(rows.len(), 6);
}

#[test]
fn sorts_ascending_descending_stable_with_missing_values_last() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let angles = |args: &[&str]| -> Vec<Option<f64>> {
        let rows = list_json(tmp.path(), args);
        column(&rows, "headline_angle_deg")
            .iter()
            .map(Value::as_f64)
            .collect()
    };
    let asc = angles(&["--sort", "angle_deg"]);
    let desc = angles(&["--sort", "angle_deg:desc"]);
    let mut expected: Vec<Option<f64>> = ANGLES.iter().flat_map(|(_, a)| a.map(Some)).collect();
    expected.sort_by(|a, b| a.unwrap().total_cmp(&b.unwrap()));
    let mut want = expected.clone();
    want.push(None);
    assert_eq!(asc, want, "the failed run (no angle) comes last");
    expected.reverse();
    expected.push(None);
    assert_eq!(desc, expected, "and last when descending too");

    // Ties keep the store's id order: sorted by μs only, each friction's
    // three runs appear in id order.
    let rows = list_json(tmp.path(), &["--sort", &format!("{MU}:desc")]);
    let mus: Vec<f64> = column(&rows, MU)
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(mus, [0.7, 0.5, 0.5, 0.5, 0.4, 0.4, 0.4, 0.3, 0.3, 0.3]);
    for block in rows[1..].chunks(3) {
        let ids: Vec<String> = column(block, "id").iter().map(|v| v.to_string()).collect();
        let mut sorted = ids.clone();
        sorted.sort();
        assert_eq!(ids, sorted);
    }
    // A comma list is two keys: scene (all equal), then the angle.
    assert_eq!(angles(&["--sort", "scene,angle_deg"]), asc);
}

#[test]
fn group_seeds_folds_replicates_with_mean_and_t_interval() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let rows = list_json(tmp.path(), &["--group-seeds", "--sort", MU]);
    assert_eq!(column(&rows, "n"), [json!(3), json!(3), json!(3), json!(1)]);
    let mu04 = &rows[1];
    assert_eq!(mu04[MU], json!(0.4));
    assert_eq!(mu04["ids"].as_array().unwrap().len(), 3);
    let angle = &mu04["angle_deg"];
    assert_eq!(angle["n"], json!(3));
    assert!((angle["mean"].as_f64().unwrap() - 32.5).abs() < 1e-12);
    // scipy.stats.t.ppf(0.975, 2) * numpy.std([31.0, 32.5, 34.0], ddof=1) / numpy.sqrt(3)
    let expected = 3.7262065676254954;
    assert!((angle["ci95_half_width"].as_f64().unwrap() - expected).abs() < 1e-9);
    // The failed run is a group of one without responses.
    assert_eq!(rows[3]["status"], json!("failed"));
    assert_eq!(rows[3]["angle_deg"], Value::Null);

    // Text: one row per group, `mean ± half-width`.
    let out = stdout(&repose(tmp.path(), &["runs", "list", "--group-seeds"]));
    assert_eq!(out.lines().count(), 5, "{out}");
    assert!(out.contains("32.5 ± 3.72621"), "{out}");
}

#[test]
fn only_changed_keeps_the_fields_that_differ() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let rows = list_json(
        tmp.path(),
        &["--where", &format!("{MU}=0.4"), "--only-changed"],
    );
    let keys: Vec<&String> = rows[0].as_object().unwrap().keys().collect();
    assert_eq!(
        keys,
        [
            "angle_deg",
            "headline_angle_deg",
            "id",
            "seeds.packing_seed"
        ],
        "id, then only what varies over the three replicates (JSON keys sorted)"
    );
    // With --columns: the changed ones among those asked for.
    let rows = list_json(
        tmp.path(),
        &["--only-changed", "--columns", &format!("scene,{MU},status")],
    );
    let keys: Vec<&String> = rows[0].as_object().unwrap().keys().collect();
    assert_eq!(keys, [MU, "id", "status"]);
}

#[test]
fn csv_output_parses_and_keeps_every_digit() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let out = repose(
        tmp.path(),
        &[
            "runs",
            "list",
            "--csv",
            "--columns",
            &format!("{MU},angle_deg"),
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let table = repose::report::table::Table::parse(&stdout(&out)).unwrap();
    assert_eq!(table.header, ["id", MU, "angle_deg"]);
    assert_eq!(table.rows.len(), 10);
    assert!(table.rows.iter().all(|r| r[0].len() == 64), "full ids");
    let grouped = repose(tmp.path(), &["runs", "list", "--csv", "--group-seeds"]);
    let table = repose::report::table::Table::parse(&stdout(&grouped)).unwrap();
    assert!(table.header.contains(&"angle_deg_ci95".to_string()));
    assert_eq!(table.rows.len(), 4);
}

#[test]
fn the_plain_listing_is_the_classic_table() {
    let tmp = tempfile::tempdir().unwrap();
    let store = query_store(tmp.path());
    let mut expected = format!("{}\n", repose::store::runs_line(&RunSummary::HEADER));
    for run in store.list().unwrap() {
        expected.push_str(&format!("{}\n", repose::store::runs_line(&run.row())));
    }
    let out = repose(tmp.path(), &["runs", "list"]);
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(stdout(&out), expected);
}

#[test]
fn an_unknown_field_exits_2_naming_it_and_the_closest() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    for args in [
        ["--where", "static_frction>0.4"],
        ["--sort", "static_frction"],
        ["--columns", "static_frction"],
    ] {
        let mut all = vec!["runs", "list"];
        all.extend_from_slice(&args);
        let out = repose(tmp.path(), &all);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = stderr(&out);
        assert!(
            err.contains("unknown field `static_frction`") && err.contains(MU),
            "{err}"
        );
    }
    let out = repose(tmp.path(), &["runs", "list", "--where", "scene~drum"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("= != < <= > >="), "{}", stderr(&out));
}

/// Issue 54 item 6: `runs list --where 'angle_2h_d_deg>30'` was an unknown
/// field although `repose responses static_pile` lists it.
#[test]
fn every_name_repose_responses_prints_is_a_field_of_runs_list() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    for (kind, specs) in repose::scenes::responses::listing(None).unwrap() {
        for spec in specs {
            let out = repose(
                tmp.path(),
                &["runs", "list", "--where", &format!("{}>0", spec.name)],
            );
            assert_eq!(
                out.status.code(),
                Some(0),
                "{kind} {}: {}",
                spec.name,
                stderr(&out)
            );
        }
    }
    // A drum run answers its catalogue's names, derived from its measurements.
    let drum = repose::scenes::responses::catalogue("drum").unwrap();
    let shown: Vec<&str> = drum.iter().map(|s| s.name).collect();
    let rows = list_json(
        tmp.path(),
        &["--where", "status=complete", "--columns", &shown.join(",")],
    );
    assert_eq!(rows.len(), 9);
}

/// Issue 54, low: filters that matched nothing or everything silently.
#[test]
fn a_filter_that_cannot_mean_what_it_says_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    for (filter, says) in [
        (format!("{MU}>abc"), "holds numbers and `abc` is not one"),
        ("scene==drum".to_string(), "`==` is not an operator"),
        ("scene>5".to_string(), "`scene` holds words"),
        ("scene=".to_string(), "no value after the operator"),
    ] {
        let out = repose(tmp.path(), &["runs", "list", "--where", &filter]);
        assert_eq!(out.status.code(), Some(2), "{filter}: {}", stdout(&out));
        assert!(stderr(&out).contains(says), "{filter}: {}", stderr(&out));
    }
    // Words still order against words, numbers against numbers.
    assert_eq!(list_json(tmp.path(), &["--where", "scene>=drum"]).len(), 10);
    assert_eq!(
        list_json(tmp.path(), &["--where", "angle_deg>=41"]).len(),
        1
    );
}

/// Issue 54, low: `diff good damaged` exited 0 and printed the seal's size
/// of a damaged file; a prefix of a run id and of a study's name went to the
/// run.
#[test]
fn diff_reports_a_damaged_run_and_refuses_an_ambiguous_prefix() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let a = put(&store, &mu_seed(0.4, 0), Some(31.0));
    let b = put(&store, &mu_seed(0.5, 0), Some(33.0));
    let result = store.run_dir(&b).path().join("result.json");
    let mut text = std::fs::read_to_string(&result).unwrap();
    text.push_str("\n\n");
    std::fs::write(&result, &text).unwrap();
    let (ha, hb) = (a.to_string(), b.to_string());
    let out = repose(tmp.path(), &["diff", &ha[..12], &hb[..12], "--json"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("damaged"), "{}", stderr(&out));
    let d: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let file = d["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["file"] == "result.json")
        .unwrap();
    assert_eq!(file["b"]["bytes"], json!(text.len()), "{file}");

    // A study whose name starts with the run's first hex digit.
    let first = &ha[..1];
    let study = edit(cai_smoke(), "/name", Some(json!(format!("{first}study"))));
    put_study(tmp.path(), &study, &[]);
    let out = repose(tmp.path(), &["diff", first, &hb[..12]]);
    assert_eq!(out.status.code(), Some(2), "{}", stdout(&out));
    let err = stderr(&out);
    assert!(
        err.contains("is ambiguous")
            && err.contains(&format!("run {ha}"))
            && err.contains("study "),
        "{err}"
    );
}

#[test]
fn diff_of_two_runs_reports_exactly_the_fields_that_differ() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let a = put(&store, &mu_seed(0.4, 0), Some(31.0));
    let b = put(
        &store,
        &[
            ("/contact/particle_particle/static_friction", json!(0.5)),
            ("/contact/particle_particle/rolling_friction", json!(0.002)),
            ("/scene/rpm", json!(45)),
            ("/seeds/packing_seed", json!(0)),
        ],
        Some(36.0),
    );
    let out = repose(
        tmp.path(),
        &["diff", &a.as_str()[..10], &b.as_str()[..10], "--json"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let d: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(d["kind"], json!("runs"));
    let fields: Vec<&str> = d["manifest"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["field"].as_str().unwrap())
        .collect();
    assert_eq!(
        fields,
        [
            "contact.particle_particle.rolling_friction",
            MU,
            "scene.rpm"
        ]
    );
    assert_eq!(d["manifest"][1]["a"], json!(0.4));
    assert_eq!(d["manifest"][1]["b"], json!(0.5));
    let angle = &d["responses"][0];
    assert_eq!(angle["response"], json!("angle_deg"));
    assert_eq!(angle["difference"], json!(5.0));
    assert_eq!(angle["seed_noise"], Value::Null, "no replicates");
    assert_eq!(d["physics_version"], json!([1, 1]));
    let files: Vec<&str> = d["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["file"].as_str().unwrap())
        .collect();
    assert_eq!(files, ["manifest.json", "result.json"]);
    let text = stdout(&repose(
        tmp.path(),
        &["diff", &a.as_str()[..10], &b.as_str()[..10]],
    ));
    assert!(text.contains("scene.rpm: 60 → 45"), "{text}");
}

#[test]
fn diff_says_whether_a_difference_is_inside_the_seed_noise() {
    let tmp = tempfile::tempdir().unwrap();
    query_store(tmp.path());
    let store = Store::open(tmp.path()).unwrap();
    let id = |mu: f64| {
        let mut m = example("drum/smoke.json");
        for (p, v) in mu_seed(mu, 0) {
            m = edit(m, p, Some(v));
        }
        parse_experiment(&m.to_string()).unwrap().id()
    };
    let noise = |a: f64, b: f64| -> Value {
        let out = repose(
            store.root(),
            &[
                "diff",
                &id(a).as_str()[..12],
                &id(b).as_str()[..12],
                "--json",
            ],
        );
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let d: Value = serde_json::from_str(&stdout(&out)).unwrap();
        d["responses"][0]["seed_noise"].clone()
    };
    // scipy.stats.ttest_ind([36.0, 37.0, 41.0], [31.0, 32.5, 34.0],
    //     equal_var=False).confidence_interval(0.95): (0.0733450005, 10.9266549995)
    let beyond = noise(0.4, 0.5);
    assert!((beyond["difference"].as_f64().unwrap() - 5.5).abs() < 1e-12);
    assert!((beyond["ci95_half_width"].as_f64().unwrap() - 5.426654999460583).abs() < 1e-6);
    assert_eq!(beyond["inside_noise"], json!(false));
    assert_eq!(
        (beyond["n_a"].clone(), beyond["n_b"].clone()),
        (json!(3), json!(3))
    );
    // scipy.stats.ttest_ind([32.0, 33.0, 33.5], [31.0, 32.5, 34.0],
    //     equal_var=False).confidence_interval(0.95): (-2.7761643318, 3.4428309985)
    let inside = noise(0.4, 0.3);
    assert!((inside["ci95_half_width"].as_f64().unwrap() - 3.109497665175729).abs() < 1e-6);
    assert_eq!(inside["inside_noise"], json!(true));
}

/// Writes the design study `study` into the store as `repose rsm` would
/// start it (its directory and study.json), with `rsm/responses.csv` of
/// `rows`; returns the directory.
fn put_study(store: &Path, study: &Value, rows: &[&str]) -> PathBuf {
    let study = parse_design_study(&study.to_string()).expect("a valid study");
    let dir = StudyDir::prepare(store, &study).unwrap();
    let rsm = dir.create_stage("rsm").unwrap();
    let header = "point,replicate,A,packing_seed,drum_id,dynamic_angle_deg,status";
    std::fs::write(
        rsm.join("responses.csv"),
        format!("{header}\n{}\n", rows.join("\n")),
    )
    .unwrap();
    dir.path().to_path_buf()
}

fn cai_smoke() -> Value {
    example("cai2024-smoke/study.json")
}

#[test]
fn diff_of_two_studies_differing_in_one_factor_range() {
    let tmp = tempfile::tempdir().unwrap();
    let (r1, r2, r3) = ("1".repeat(64), "2".repeat(64), "3".repeat(64));
    let a = put_study(
        tmp.path(),
        &cai_smoke(),
        &[
            &format!("0,0,0.2,7,{r1},38.5,ok"),
            &format!("1,0,0.6,8,{r2},44.1,ok"),
        ],
    );
    let b = put_study(
        tmp.path(),
        &edit(cai_smoke(), "/factors/A/max", Some(json!(0.7))),
        &[
            &format!("0,0,0.2,7,{r1},38.5,ok"),
            &format!("1,0,0.7,8,{r3},47.0,ok"),
        ],
    );
    // A fitted term that moved: coefficients.csv rows are keyed by term.
    for (dir, b_a) in [(&a, "2.5"), (&b, "3.1")] {
        let sub = dir.join("rsm").join("dynamic_angle_deg");
        std::fs::create_dir_all(&sub).unwrap();
        let csv = format!("term,coefficient\nintercept,40\nA,{b_a}\nB,-1\n");
        std::fs::write(sub.join("coefficients.csv"), csv).unwrap();
    }
    // Issue 54 (low): a JSON output that differs only in its measured times
    // (two runs of one study) is listed apart; one that differs elsewhere
    // too is a difference.
    for (dir, wall, sd) in [(&a, 1.25, 0.5), (&b, 1.5, 0.5)] {
        let noise = dir.join("noise");
        std::fs::create_dir_all(&noise).unwrap();
        let record = json!({"sd_deg": sd, "wall_s_per_run": wall,
            "precision_per_cost_deg2_s": wall * sd * sd});
        std::fs::write(noise.join("noise.json"), record.to_string()).unwrap();
        let cost = json!({"fine_runs": 3, "fine_cpu_s": wall, "coarse_cpu_s": 2.0 * wall});
        std::fs::write(noise.join("cost.json"), cost.to_string()).unwrap();
        let other = json!({"sd_deg": sd + wall, "wall_s_per_run": wall});
        std::fs::write(noise.join("other.json"), other.to_string()).unwrap();
    }
    let out = repose(
        tmp.path(),
        &["diff", a.to_str().unwrap(), b.to_str().unwrap(), "--json"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let d: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(d["kind"], json!("studies"));
    assert_eq!(
        d["spec"],
        json!([{"field": "factors.A.max", "a": 0.6, "b": 0.7}])
    );
    let noise = &d["stages"][0];
    assert_eq!(noise["stage"], json!("noise"));
    assert_eq!(noise["differ"], json!(["other.json"]));
    assert_eq!(
        noise["differ_in_times_only"],
        json!(["cost.json", "noise.json"])
    );
    let rsm = &d["stages"][1];
    assert_eq!(rsm["stage"], json!("rsm"));
    assert_eq!(
        rsm["differ"],
        json!(["dynamic_angle_deg/coefficients.csv", "responses.csv"])
    );
    assert_eq!(rsm["shared_runs"], json!([r1]));
    assert_eq!(
        (rsm["runs_only_a"].clone(), rsm["runs_only_b"].clone()),
        (json!(1), json!(1))
    );
    let terms = &rsm["tables"][0];
    assert_eq!(terms["key"], json!(["term"]));
    assert_eq!(
        terms["changed"],
        json!([{"key": ["A"], "cells": [["coefficient", "2.5", "3.1"]]}])
    );
    let table = &rsm["tables"][1];
    assert_eq!(table["key"], json!(["point", "replicate"]));
    assert_eq!(
        table["changed"],
        json!([{"key": ["1", "0"], "cells": [
            ["A", "0.6", "0.7"],
            ["drum_id", r2, r3],
            ["dynamic_angle_deg", "44.1", "47.0"]
        ]}])
    );
    // By id prefix, as text.
    let id = |dir: &Path| {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        name.rsplit_once('-').unwrap().1.to_string()
    };
    let out = repose(tmp.path(), &["diff", &id(&a), &id(&b)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("factors.A.max: 0.6 → 0.7")
            && stdout(&out).contains("  differs in measured times only: noise.json\n"),
        "{}",
        stdout(&out)
    );
    // A name both share is ambiguous; a run and a study do not compare.
    let out = repose(tmp.path(), &["diff", "cai2024-smoke", &id(&b)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("ambiguous"), "{}", stderr(&out));
}

#[test]
fn studies_lists_each_study_with_stages_run_counts_and_verdicts() {
    let tmp = tempfile::tempdir().unwrap();
    let store = Store::open(tmp.path()).unwrap();
    let done = put(&store, &mu_seed(0.4, 0), Some(31.0));
    let done2 = put(&store, &mu_seed(0.4, 1), Some(32.0));
    let failed = put(&store, &mu_seed(0.7, 0), None);
    let pending = "4".repeat(64);
    let a = put_study(
        tmp.path(),
        &cai_smoke(),
        &[
            &format!("0,0,0.2,7,{done},31,ok"),
            &format!("1,0,0.6,8,{done2},32,ok"),
            &format!("2,0,0.4,9,{failed},,failed"),
            &format!("3,0,0.4,9,{pending},,pending"),
        ],
    );
    let verify = a.join("verify");
    std::fs::create_dir_all(&verify).unwrap();
    repose::study::dir::write_output(
        &verify.join("verification.csv"),
        b"point,response,verdict\noptimum,dynamic_angle_deg,inconclusive\n\
         cai2024,dynamic_angle_deg,pass\nother,dynamic_angle_deg,pass\n",
        &repose::store::Lineage::new("verify", json!({})),
    )
    .unwrap();
    let b =
        parse_design_study(&edit(cai_smoke(), "/replicates", Some(json!(2))).to_string()).unwrap();
    StudyDir::prepare(tmp.path(), &b).unwrap();

    let out = repose(tmp.path(), &["studies", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let list: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let list = list.as_array().unwrap();
    assert_eq!(list.len(), 2);
    let first = list
        .iter()
        .find(|s| Path::new(s["directory"].as_str().unwrap()) == a)
        .unwrap();
    assert_eq!(first["name"], json!("cai2024-smoke"));
    assert_eq!(first["method"], json!("response_surface"));
    assert_eq!(first["stages"], json!(["rsm", "verify"]));
    assert_eq!(
        first["runs"],
        json!({"complete": 2, "failed": 1, "damaged": 0, "pending": 1})
    );
    assert_eq!(first["verdicts"], json!({"inconclusive": 1, "pass": 2}));
    let when = first["last_change"].as_str().unwrap();
    assert!(
        when.len() == 20 && when.ends_with('Z') && when.as_bytes()[10] == b'T',
        "{when}"
    );
    let second = list.iter().find(|s| s != &first).unwrap();
    assert_eq!(second["stages"], json!([]));
    assert_eq!(second["runs"]["complete"], json!(0));

    let text = stdout(&repose(tmp.path(), &["studies"]));
    assert!(
        text.contains("runs:        2 complete, 1 failed, 0 damaged, 1 pending"),
        "{text}"
    );
    assert!(
        text.contains("verdicts:    1 inconclusive, 2 pass\n"),
        "{text}"
    );
    assert_eq!(first["verdicts_edited"], json!(false));

    // Issue 54 (low): an edited verdict is marked where it is shown, in
    // `studies` and in the report's Verdicts section; a stage file that is
    // not UTF-8 is marked on the page, which is still written.
    let csv = verify.join("verification.csv");
    let edited = std::fs::read_to_string(&csv)
        .unwrap()
        .replace("inconclusive", "pass");
    std::fs::write(&csv, edited).unwrap();
    let text = stdout(&repose(tmp.path(), &["studies"]));
    assert!(
        text.contains("verdicts:    3 pass (EDITED: verify/verification.csv is not what"),
        "{text}"
    );
    std::fs::write(a.join("rsm").join("latin1.csv"), b"a,b\n\xe9t\xe9,1\n").unwrap();
    let out = repose(
        tmp.path(),
        &["report", "experiments/cai2024-smoke/study.json"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let html = std::fs::read_to_string(stdout(&out).trim()).unwrap();
    assert!(
        html.contains("Verdicts of verify/verification.csv — EDITED: changed since the stage"),
        "no EDITED mark on the verdicts"
    );
    assert!(
        html.contains("rsm/latin1.csv — UNREADABLE"),
        "no UNREADABLE mark"
    );
}

/// The benchmark of issue 42 (not a timed test; run it with
/// `scripts/bench-runs-list.sh`): a store of 10⁴ synthetic runs (1 000
/// frictions × 10 seeds) on tmpfs when there is one, then `repose runs list`
/// plain, with `--where` and with `--group-seeds`, each timed three times.
#[test]
#[ignore = "benchmark: scripts/bench-runs-list.sh"]
fn bench_runs_list_on_ten_thousand_runs() {
    let shm = Path::new("/dev/shm");
    let tmp = if shm.is_dir() {
        tempfile::tempdir_in(shm).unwrap()
    } else {
        tempfile::tempdir().unwrap()
    };
    let store = Store::open(tmp.path()).unwrap();
    let started = std::time::Instant::now();
    for i in 0..1000u32 {
        let mu = 0.1 + f64::from(i) * 0.0008;
        for seed in 0..10u64 {
            put(
                &store,
                &mu_seed(mu, seed),
                Some(30.0 + 10.0 * mu + seed as f64 * 0.1),
            );
        }
    }
    println!(
        "store of 10^4 runs written in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    // In-process: the store's own listing (seals checked, manifests and
    // results parsed) against the whole query, to see what the fields cost.
    let started = std::time::Instant::now();
    let listed = store.list().unwrap().len();
    let store_only = started.elapsed().as_secs_f64();
    let started = std::time::Instant::now();
    let options = repose::tracking::ListOptions::default();
    let rows = repose::tracking::list_runs(&store, &options)
        .unwrap()
        .rows
        .len();
    let query = started.elapsed().as_secs_f64();
    println!("in process: Store::list {store_only:.2} s ({listed} runs), list_runs {query:.2} s ({rows} rows)");
    for args in [
        vec!["runs", "list"],
        vec![
            "runs",
            "list",
            "--where",
            "contact.particle_particle.static_friction>0.5",
        ],
        vec!["runs", "list", "--group-seeds"],
    ] {
        let mut seconds = Vec::new();
        let mut lines = 0;
        for _ in 0..3 {
            let started = std::time::Instant::now();
            let out = repose(tmp.path(), &args);
            seconds.push(started.elapsed().as_secs_f64());
            assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
            lines = stdout(&out).lines().count();
        }
        let seconds: Vec<String> = seconds.iter().map(|s| format!("{s:.2}")).collect();
        println!(
            "repose {}: {} s, {lines} lines",
            args.join(" "),
            seconds.join(" / ")
        );
    }
}
