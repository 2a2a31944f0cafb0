//! Helpers shared by the integration tests: example manifests as JSON values and
//! in-place edits by JSON pointer.

#![allow(dead_code)] // each test crate uses a different subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The text of a file under the repository root.
pub fn text(relative: &str) -> String {
    std::fs::read_to_string(root().join(relative)).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

/// An example manifest under `experiments/` as a JSON value.
pub fn example(relative: &str) -> Value {
    serde_json::from_str(&text(&format!("experiments/{relative}"))).expect("example parses")
}

/// A pair-impact experiment (particle against rigid wall).
pub fn pair_wall() -> Value {
    example("validation/pair_hertz_rigid_wall.json")
}

/// A JKR separation experiment (particle against particle).
pub fn pair_jkr() -> Value {
    example("validation/pair_jkr_separation.json")
}

/// The he2019 study.
pub fn study() -> Value {
    example("he2019/study.json")
}

/// `v` with the value at `pointer` replaced (the parent must exist; a missing last
/// key is inserted), or removed when `new` is `None`.
pub fn edit(mut v: Value, pointer: &str, new: Option<Value>) -> Value {
    let (parent, key) = pointer.rsplit_once('/').expect("pointer has a /");
    let target = v
        .pointer_mut(parent)
        .unwrap_or_else(|| panic!("no parent {parent}"));
    match (target, new) {
        (Value::Object(map), Some(new)) => {
            map.insert(key.to_string(), new);
        }
        (Value::Object(map), None) => {
            map.remove(key);
        }
        (Value::Array(items), Some(new)) => items[key.parse::<usize>().unwrap()] = new,
        (other, _) => panic!("cannot edit {pointer} in {other}"),
    }
    v
}

/// Every `*.json` file under `dir`, recursively, sorted, except those in
/// `measured/` folders: they hold measured outputs (e.g.
/// experiments/he2019-quick/measured/outcome.json), not manifests.
pub fn json_files(dir: &Path) -> Vec<PathBuf> {
    files_with_extension(dir, "json", "measured")
}

/// Every file with extension `ext` under `dir`, recursively, sorted, except
/// those in folders named `skip`.
pub fn files_with_extension(dir: &Path, ext: &str, skip: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if path.file_name().is_some_and(|n| n != skip) {
                    stack.push(path);
                }
            } else if path.extension().is_some_and(|e| e == ext) {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Every node below the root of `v` (objects, arrays and leaves) with its JSON
/// pointer, parents before children.
pub fn nodes(v: &Value) -> Vec<(String, Value)> {
    fn walk(v: &Value, pointer: String, out: &mut Vec<(String, Value)>) {
        if !pointer.is_empty() {
            out.push((pointer.clone(), v.clone()));
        }
        match v {
            Value::Object(map) => map
                .iter()
                .for_each(|(k, v)| walk(v, format!("{pointer}/{k}"), out)),
            Value::Array(items) => items
                .iter()
                .enumerate()
                .for_each(|(i, v)| walk(v, format!("{pointer}/{i}"), out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, String::new(), &mut out);
    out
}

/// Runs the `repose` binary from the repository root with `args`, its run store
/// at `store` (REPOSE_STORE) and no backtraces, and returns its output.
pub fn repose(store: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_repose"))
        .args(args)
        .current_dir(root())
        .env("REPOSE_STORE", store)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("the binary runs")
}

/// A command's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A command's standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Every file below `dir` (relative path → bytes), sorted, except each run's
/// wall-clock record ([`repose::store::TIMING_FILE`], non-deterministic by
/// design and hashed nowhere).
pub fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p
                .file_name()
                .is_some_and(|n| n != repose::store::TIMING_FILE)
            {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

/// Asserts that two stores hold the same files with the same bytes.
pub fn assert_same_stores(a: &Path, b: &Path) {
    let (a, b) = (snapshot(a), snapshot(b));
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert!(x.1 == y.1, "{} differs between the stores", x.0.display());
    }
}

/// Compares one cell of `column`: `exact` columns and text exactly, other
/// numbers within `tol` relative (|pinned − now| ≤ tol · max(|pinned|, 1)).
fn same_cell(column: &str, pinned: &str, now: &str, exact: &[&str], tol: f64) -> bool {
    if exact.contains(&column) {
        return pinned == now;
    }
    match (pinned.parse::<f64>(), now.parse::<f64>()) {
        (Ok(a), Ok(b)) => (a - b).abs() <= tol * a.abs().max(1.0),
        _ => pinned == now,
    }
}

/// Asserts that the CSV text `now` matches the golden table `golden_dir/name`
/// (see [`same_cell`]).
pub fn compare_golden(golden_dir: &str, name: &str, now: &str, exact: &[&str], tol: f64) {
    use repose::report::table::Table;
    let golden = root().join(golden_dir).join(name);
    let hint = "if intended, rerun with REPOSE_BLESS=1 and review the diff";
    let pinned = std::fs::read_to_string(&golden)
        .unwrap_or_else(|e| panic!("{}: {e}; {hint}", golden.display()));
    let pinned = Table::parse(&pinned).unwrap();
    let now = Table::parse(now).unwrap();
    assert_eq!(pinned.header, now.header, "{name}: columns; {hint}");
    assert_eq!(
        pinned.rows.len(),
        now.rows.len(),
        "{name}: row count; {hint}"
    );
    for (line, (p, c)) in pinned.rows.iter().zip(&now.rows).enumerate() {
        for ((column, a), b) in pinned.header.iter().zip(p).zip(c) {
            assert!(
                same_cell(column, a, b, exact, tol),
                "{name} line {}, {column}: {b} vs pinned {a}; {hint}",
                line + 2
            );
        }
    }
}

/// True when golden files are to be rewritten (`REPOSE_BLESS=1`).
pub fn blessing() -> bool {
    std::env::var_os("REPOSE_BLESS").is_some_and(|v| v == "1")
}

/// One group's verdict as `repose verdict --table --json` gives it: the
/// group's key cells, the verdict and the TOST p-value (none below two
/// measured values).
#[allow(dead_code)]
pub type TableVerdict = (Vec<String>, String, Option<f64>);

/// `repose verdict --table TABLE --value VALUE --group G... --target T
/// --tolerance F --json`, parsed: how a stage's verdicts are checked to come
/// from the one acceptance rule (the same replicates give the same verdict).
#[allow(dead_code)]
pub fn table_verdicts(
    table: &Path,
    value: &str,
    group: &[&str],
    target: f64,
    tolerance: f64,
) -> Vec<TableVerdict> {
    let mut args = vec![
        "verdict".to_string(),
        "--table".into(),
        table.display().to_string(),
        "--value".into(),
        value.into(),
        "--target".into(),
        target.to_string(),
        "--tolerance".into(),
        tolerance.to_string(),
        "--json".into(),
    ];
    for g in group {
        args.extend(["--group".to_string(), g.to_string()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = repose(table.parent().unwrap(), &args);
    assert!(out.status.success(), "verdict: {}", stderr(&out));
    let v: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    v["groups"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| {
            (
                g["group"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|c| c.as_str().unwrap().to_string())
                    .collect(),
                g["judgement"]["verdict"].as_str().unwrap().to_string(),
                g["judgement"]["tost"]["p"].as_f64(),
            )
        })
        .collect()
}

/// Checks resolution figure `name` of `r` against a hand computation
/// `value` (to 1e-9 relative) and that a warning names it, with its limit,
/// exactly when `unresolved`.
#[allow(dead_code)]
pub fn assert_figure(r: &repose::store::RunResult, name: &str, value: f64, unresolved: bool) {
    let figure = r
        .resolution
        .get(name)
        .unwrap_or_else(|| panic!("no resolution figure `{name}`: {:?}", r.resolution));
    assert!(
        (figure.value - value).abs() <= 1e-9 * value.abs(),
        "{name}: {} vs hand {value}",
        figure.value
    );
    let warned = r
        .warnings
        .iter()
        .any(|w| w.contains(&format!("unresolved at this particle size: {name} = ")));
    assert_eq!(warned, unresolved, "{name}: {:?}", r.warnings);
    assert_eq!(figure.violation().is_some(), unresolved, "{name}");
}

/// A local executor of `jobs` workers without progress bars, default limits
/// and run cap: how the study tests run their stages.
pub fn executor(jobs: usize) -> repose::exec::Executor {
    repose::exec::Executor {
        jobs,
        progress: false,
        limits: Default::default(),
        max_runs: repose::exec::DEFAULT_MAX_RUNS,
        slurm: None,
    }
}

/// The packing noise of a fake run: a fixed pseudo-random value of its
/// packing seed and its point, uniform on ±√3 σ (so its standard deviation
/// is `sigma`), independent between points as a pile's chaotic history makes
/// it even from the same packing.
pub fn packing_noise(seed: u64, point: u64, sigma: f64) -> f64 {
    let mut x =
        (seed ^ point.rotate_left(17)).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5851_f42d_4c95_7f2d;
    x ^= x >> 29;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 32;
    let u = (x >> 11) as f64 / (1u64 << 53) as f64;
    (2.0 * u - 1.0) * 3f64.sqrt() * sigma
}
