//! The run store under faults, through the CLI: a killed run re-runs (also
//! when the next process has the same pid, as PID 1 in a container does), a
//! damaged run is reported by `runs list`, `runs show` and `audit` and
//! recomputed by `run`, and two processes running one experiment simulate it
//! once.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{repose, root, stderr, stdout};

/// The fast pair experiment (a few milliseconds).
const PAIR: &str = "experiments/validation/pair_hertz_particle_particle.json";
/// The tiny drum (152 particles; seconds), for runs that must last a while.
const DRUM: &str = "experiments/tradeoff/drum_tiny.json";

/// The single run directory of `store`.
fn run_dir(store: &Path) -> PathBuf {
    let dirs: Vec<PathBuf> = std::fs::read_dir(store)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    assert_eq!(dirs.len(), 1, "{dirs:?}");
    dirs.into_iter().next().unwrap()
}

/// Names of the temp files in `dir` that start with `prefix`.
fn temps_of(dir: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

fn temps(dir: &Path) -> Vec<String> {
    temps_of(dir, ".tmp-")
}

#[test]
fn a_killed_run_runs_again_and_its_temp_files_are_removed() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("runs");
    let mut child = Command::new(env!("CARGO_BIN_EXE_repose"))
        .args(["run", DRUM])
        .current_dir(root())
        .env("REPOSE_STORE", &store)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill it while it streams its log into a temp file (which lives until
    // the run ends).
    let started = Instant::now();
    let streaming = |p: &Path| p.is_dir() && !temps_of(p, ".tmp-run.mcap-").is_empty();
    let dir = loop {
        if let Some(dir) = std::fs::read_dir(&store)
            .ok()
            .and_then(|mut d| d.find_map(|e| Some(e.ok()?.path()).filter(|p| streaming(p))))
        {
            break dir;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no temp file appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!temps(&dir).is_empty());
    assert!(!dir.join("seal.json").exists() && !dir.join("result.json").exists());
    // The next process may have the killed one's pid (PID 1 in a container):
    // that its temp names then skip the leftovers is tested in
    // src/store/atomic.rs, where the pid is known.

    let again = repose(&store, &["run", DRUM]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(stdout(&again).contains("(computed)"));
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
    assert!(dir.join("seal.json").is_file());
}

#[test]
fn two_processes_running_one_experiment_simulate_it_once() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("runs");
    let spawn = || {
        Command::new(env!("CARGO_BIN_EXE_repose"))
            .args(["run", DRUM])
            .current_dir(root())
            .env("REPOSE_STORE", &store)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    assert!(
        a.status.success() && b.status.success(),
        "{}{}",
        stderr(&a),
        stderr(&b)
    );
    let mut how: Vec<bool> = [&a, &b]
        .iter()
        .map(|o| stdout(o).contains("(computed)"))
        .collect();
    how.sort();
    assert_eq!(how, [false, true], "{}\n{}", stdout(&a), stdout(&b));
    let waited = if stdout(&a).contains("(cache hit)") {
        &a
    } else {
        &b
    };
    assert!(stdout(waited).contains("(cache hit)"));
}

/// One finished pair run in `store`; returns its directory and the bytes of
/// result.json and run.mcap.
fn finished(store: &Path) -> (PathBuf, Vec<u8>, Vec<u8>) {
    let o = repose(store, &["run", PAIR]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dir = run_dir(store);
    let result = std::fs::read(dir.join("result.json")).unwrap();
    let log = std::fs::read(dir.join("run.mcap")).unwrap();
    (dir, result, log)
}

#[test]
fn a_damaged_run_is_listed_shown_and_recomputed_never_reused() {
    type Damage = fn(&Path);
    let cases: [(&str, Damage); 4] = [
        ("result.json", |d| {
            let mut b = std::fs::read(d.join("result.json")).unwrap();
            let at = b.iter().position(u8::is_ascii_digit).unwrap();
            b[at] = if b[at] == b'9' { b'8' } else { b[at] + 1 };
            std::fs::write(d.join("result.json"), b).unwrap();
        }),
        ("manifest.json", |d| {
            let t = std::fs::read_to_string(d.join("manifest.json")).unwrap();
            std::fs::write(d.join("manifest.json"), t.replacen("0.", "1.", 1)).unwrap();
        }),
        ("run.mcap", |d| {
            std::fs::remove_file(d.join("run.mcap")).unwrap()
        }),
        ("result.json", |d| {
            std::fs::write(d.join("result.json"), b"").unwrap()
        }),
    ];
    for (file, damage) in cases {
        let tmp = tempfile::tempdir().unwrap();
        let store = tmp.path().join("runs");
        let (dir, result, log) = finished(&store);
        damage(&dir);
        let id = dir.file_name().unwrap().to_string_lossy().into_owned();

        let list = repose(&store, &["runs", "list"]);
        assert_eq!(list.status.code(), Some(1), "{file}: {}", stdout(&list));
        assert!(stdout(&list).contains("damaged") && stdout(&list).contains(file));

        let show = repose(&store, &["runs", "show", &id[..12]]);
        assert_eq!(show.status.code(), Some(1), "{file}");
        assert!(
            stdout(&show).contains("status:    damaged") && stdout(&show).contains(file),
            "{file}: {}",
            stdout(&show)
        );

        let run = repose(&store, &["run", PAIR]);
        assert!(run.status.success(), "{file}: {}", stderr(&run));
        assert!(stdout(&run).contains("(computed)"), "{file}");
        assert!(
            stderr(&run).contains("damaged") && stderr(&run).contains("recomputing"),
            "{file}: {}",
            stderr(&run)
        );
        assert_eq!(std::fs::read(dir.join("result.json")).unwrap(), result);
        assert_eq!(std::fs::read(dir.join("run.mcap")).unwrap(), log);
        let list = repose(&store, &["runs", "list"]);
        assert!(list.status.success() && stdout(&list).contains("complete"));
    }
}

/// `audit` looks up a lineage's relative inputs in the audited store only:
/// a result.json deleted from the store is broken even when the audit runs
/// from a folder that happens to hold a file of that relative name.
#[test]
fn audit_does_not_find_a_deleted_input_in_the_current_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("runs");
    let (dir, _, _) = finished(&store);
    let id = dir.file_name().unwrap().to_string_lossy().into_owned();
    let out = store.join("studies/demo");
    std::fs::create_dir_all(&out).unwrap();
    let table = out.join("table.csv");
    std::fs::write(&table, "x\n").unwrap();
    let result = dir.join("result.json");
    let lineage = serde_json::json!({
        "stage": "batch",
        "repose_version": "0",
        "parameters": {},
        "inputs": [{
            "role": "result",
            "id_or_path": format!("{id}/result.json"),
            "sha256": hex::encode(<sha2::Sha256 as sha2::Digest>::digest(std::fs::read(&result).unwrap())),
        }],
    });
    std::fs::write(out.join("table.csv.lineage.json"), lineage.to_string()).unwrap();
    let audit = |cwd: &Path| {
        Command::new(env!("CARGO_BIN_EXE_repose"))
            .args(["--store"])
            .arg(&store)
            .arg("audit")
            .arg(&out)
            .current_dir(cwd)
            .output()
            .unwrap()
    };
    assert!(audit(tmp.path()).status.success());

    // Another store's folder, with a copy of the run under the same id.
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    let copy = other.join(&id);
    std::fs::create_dir_all(&copy).unwrap();
    for f in ["manifest.json", "result.json", "run.mcap", "seal.json"] {
        std::fs::copy(dir.join(f), copy.join(f)).unwrap();
    }
    std::fs::remove_file(&result).unwrap();
    let o = audit(&other);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stdout(&o).contains("BROKEN"), "{}", stdout(&o));
}

/// A full disk while the log is written (a 100 kB tmpfs, mounted in a private
/// user and mount namespace so no privilege is needed): the run fails with
/// the root cause named once, error.json records it, and nothing is left that
/// looks complete or half-written.
#[test]
fn a_full_disk_names_its_cause_once_and_leaves_nothing_complete() {
    let tmp = tempfile::tempdir().unwrap();
    let store = tmp.path().join("small");
    std::fs::create_dir_all(&store).unwrap();
    let script = r#"
        mount -t tmpfs -o size=100k tmpfs "$1" || exit 99
        "$2" --store "$1" run "$3"
        echo "exit=$?"
        ls -a "$1"/*/
        cat "$1"/*/error.json
    "#;
    let out = Command::new("unshare")
        .args([
            "--user",
            "--map-root-user",
            "--mount",
            "sh",
            "-c",
            script,
            "sh",
        ])
        .arg(&store)
        .arg(env!("CARGO_BIN_EXE_repose"))
        .arg(DRUM)
        .current_dir(root())
        .output()
        .expect("unshare (util-linux) runs");
    let (text, err) = (stdout(&out), stderr(&out));
    assert_ne!(out.status.code(), Some(99), "cannot mount a tmpfs: {err}");
    assert!(text.contains("exit=1"), "{text}\n{err}");
    assert_eq!(err.matches("No space left on device").count(), 1, "{err}");
    assert!(err.contains("run log"), "{err}");
    let files: Vec<&str> = text.lines().collect();
    for absent in ["seal.json", "result.json", "run.mcap"] {
        assert!(!files.contains(&absent), "{absent} in {files:?}");
    }
    assert!(!files.iter().any(|f| f.starts_with(".tmp-")), "{files:?}");
    assert!(files.contains(&"error.json") && text.contains("No space left on device"));
}

/// Issue 40, low item: temp files a killed process left in a study's
/// directories were never removed. The next command that opens the study
/// removes those older than ten minutes (an atomic write lives for
/// milliseconds) and leaves a fresh one, which may be another client's
/// write in progress.
#[test]
fn a_killed_writers_old_temp_files_in_a_study_are_removed() {
    let tmp = tempfile::tempdir().unwrap();
    let study = "experiments/calibrate-smoke/study.json";
    let out = common::repose(tmp.path(), &["sample", study]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let studies = tmp.path().join("studies");
    let dir = std::fs::read_dir(&studies)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let stage = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.is_dir())
        .unwrap();
    let old = stage.join(".tmp-design.csv-4242-0");
    let fresh = stage.join(".tmp-design.csv-4242-1");
    // Issue 54 (low): a fresh temp of a writer of this host that has ended
    // (a stage killed and re-run at once) is a leftover too.
    let ended = {
        let mut child = Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
        stage.join(format!(".tmp-design.csv-{}-{pid}-0", host.trim()))
    };
    for p in [&old, &fresh, &ended] {
        std::fs::write(p, b"half a table").unwrap();
    }
    let hour_ago = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
    std::fs::File::options()
        .write(true)
        .open(&old)
        .unwrap()
        .set_modified(hour_ago)
        .unwrap();
    let out = common::repose(tmp.path(), &["sample", study]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    assert!(
        !old.exists(),
        "the killed writer's temp file is still there"
    );
    assert!(
        !ended.exists(),
        "the ended writer's fresh temp file is still there"
    );
    assert!(fresh.exists(), "a fresh temp file was removed");
    assert!(
        common::stderr(&out).contains("removed 2 temp file(s)"),
        "{}",
        common::stderr(&out)
    );
}
