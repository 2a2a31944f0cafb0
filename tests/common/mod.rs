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
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if path.file_name().is_some_and(|n| n != "measured") {
                    stack.push(path);
                }
            } else if path.extension().is_some_and(|e| e == "json") {
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
