//! The Slurm executor on a real Slurm: `scripts/slurm-local.sh up` installs
//! (Debian packages, as root) and starts a one-node cluster; the smoke study
//! then runs through `--executor slurm` and through the local pool into two
//! stores. Skips, saying why, only where Slurm cannot be installed (not root,
//! no apt-get); a failed install or start fails the test.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::root;
use serde_json::Value;

/// A running one-node Slurm; stopped on drop if this test started it.
struct Slurm {
    conf: String,
    started_here: bool,
}

impl Drop for Slurm {
    fn drop(&mut self) {
        if self.started_here {
            let _ = script().arg("down").output();
        }
    }
}

fn script() -> Command {
    Command::new(root().join("scripts/slurm-local.sh"))
}

/// Brings Slurm up, or `None` (with the reason on stderr) where it cannot be
/// installed.
fn slurm() -> Option<Slurm> {
    let before = script().arg("status").output().expect("run slurm-local.sh");
    let was_up = String::from_utf8_lossy(&before.stdout).contains("slurmctld: running");
    let up = script().arg("up").output().expect("run slurm-local.sh up");
    let stderr = String::from_utf8_lossy(&up.stderr);
    match up.status.code() {
        Some(0) => {}
        Some(3) => {
            eprintln!("SKIPPED: Slurm cannot be installed here: {stderr}");
            return None;
        }
        _ => panic!("slurm-local.sh up failed ({}):\n{stderr}", up.status),
    }
    let stdout = String::from_utf8_lossy(&up.stdout);
    let conf = stdout
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("SLURM_CONF="))
        .unwrap_or_else(|| panic!("no SLURM_CONF line in `{stdout}`"))
        .to_string();
    Some(Slurm {
        conf,
        started_here: !was_up,
    })
}

/// `repose --store STORE ARGS…` from the repository root.
fn repose_command(store: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_repose"));
    c.arg("--store").arg(store).args(args).current_dir(root());
    c
}

fn repose(slurm: &Slurm, store: &Path, args: &[&str]) -> Output {
    repose_command(store, args)
        .env("SLURM_CONF", &slurm.conf)
        .output()
        .expect("run repose")
}

/// `repose batch STUDY --executor slurm EXTRA…` against `store`.
fn batch_on_slurm(slurm: &Slurm, store: &Path, study: &str, extra: &[&str]) -> Output {
    let mut args = vec!["batch", study, "--executor", "slurm"];
    args.extend_from_slice(extra);
    repose(slurm, store, &args)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[track_caller]
fn expect_code(out: &Output, code: i32) {
    assert_eq!(
        out.status.code(),
        Some(code),
        "stdout:\n{}\nstderr:\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
}

fn status(slurm: &Slurm, store: &Path, study: &str) -> Value {
    let out = repose(slurm, store, &["status", study, "--json"]);
    expect_code(&out, 0);
    serde_json::from_slice(&out.stdout).expect("status --json is JSON")
}

fn count(status: &Value, state: &str) -> u64 {
    status["counts"][state].as_u64().unwrap()
}

/// Polls `status` until `done` holds (at most `limit`); returns the last status.
fn status_until(
    slurm: &Slurm,
    store: &Path,
    study: &str,
    limit: Duration,
    done: impl Fn(&Value) -> bool,
) -> Value {
    let start = Instant::now();
    loop {
        let s = status(slurm, store, study);
        if done(&s) || start.elapsed() > limit {
            return s;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The study's `slurm/` directory in `store`.
fn slurm_dir(store: &Path) -> PathBuf {
    let studies = store.join("studies");
    let study = std::fs::read_dir(&studies)
        .unwrap()
        .next()
        .expect("one study directory")
        .unwrap()
        .path();
    study.join("slurm")
}

fn submission(dir: &Path, n: u32) -> Value {
    let path = dir.join(format!("submissions/{n}/submission.json"));
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

fn submissions(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("submissions")).unwrap().count()
}

#[test]
fn a_study_on_slurm_matches_the_local_pool_and_status_follows_every_state() {
    let Some(slurm) = slurm() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let local = tmp.path().join("local");
    let cluster = tmp.path().join("cluster");
    let study = "experiments/calibrate-smoke/study.json";
    let started = Instant::now();

    // The reference: the local pool.
    expect_code(&repose(&slurm, &local, &["sample", study]), 0);
    expect_code(&repose(&slurm, &local, &["batch", study, "--jobs", "2"]), 0);

    // --dry-run writes the script, submits nothing, and every run is pending.
    expect_code(&repose(&slurm, &cluster, &["sample", study]), 0);
    let out = batch_on_slurm(&slurm, &cluster, study, &["--dry-run"]);
    expect_code(&out, 3);
    assert!(
        text(&out.stderr).contains("--dry-run"),
        "{}",
        text(&out.stderr)
    );
    let dir = slurm_dir(&cluster);
    let job = std::fs::read_to_string(dir.join("submissions/1/job.sh")).unwrap();
    assert!(job.contains("#SBATCH --array=0-11\n"), "{job}");
    let s = status(&slurm, &cluster, study);
    assert_eq!(count(&s, "pending"), 12, "{s}");
    assert_eq!(s["runs"].as_array().unwrap().len(), 12);

    // Submitted without waiting, one task at a time; task 0 sleeps so that it
    // is seen running while the others are queued.
    let bin = Path::new(env!("CARGO_BIN_EXE_repose")).parent().unwrap();
    let setup = format!(
        "export PATH='{}':\"$PATH\"; if [ \"$SLURM_ARRAY_TASK_ID\" = 0 ]; then sleep 4; fi",
        bin.display()
    );
    let out = batch_on_slurm(
        &slurm,
        &cluster,
        study,
        &["--max-running", "1", "--no-wait", "--setup", &setup],
    );
    expect_code(&out, 3);
    assert!(
        text(&out.stderr).contains("queued or running"),
        "{}",
        text(&out.stderr)
    );
    let s = status_until(&slurm, &cluster, study, Duration::from_secs(30), |s| {
        count(s, "running") == 1
    });
    assert_eq!(count(&s, "running"), 1, "{s}");
    assert_eq!(count(&s, "queued"), 11, "{s}");
    assert_eq!(
        count(&s, "done") + count(&s, "pending") + count(&s, "failed"),
        0
    );
    let job_id = submission(&dir, 2)["job_id"].as_str().unwrap().to_string();
    let runs = s["runs"].as_array().unwrap();
    assert!(runs
        .iter()
        .all(|r| r["job"] == job_id.as_str() && r["submission"] == 2));

    // Cancel the last task while it is queued: its run becomes pending.
    let last = runs.iter().find(|r| r["task"] == 11).unwrap();
    let cancelled = last["id"].as_str().unwrap().to_string();
    let scancel = Command::new("scancel")
        .arg(format!("{job_id}_11"))
        .env("SLURM_CONF", &slurm.conf)
        .output()
        .unwrap();
    expect_code(&scancel, 0);
    let s = status_until(&slurm, &cluster, study, Duration::from_secs(10), |s| {
        count(s, "pending") == 1
    });
    let row = |s: &Value, id: &str| {
        s["runs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["id"] == id)
            .unwrap()
            .clone()
    };
    assert_eq!(row(&s, &cancelled)["state"], "pending", "{s}");

    // The next batch waits for the queued runs and submits only the cancelled
    // one, which runs on the two CPUs it now asks for.
    let out = batch_on_slurm(
        &slurm,
        &cluster,
        study,
        &["--poll-seconds", "0.5", "--cpus-per-task", "2"],
    );
    expect_code(&out, 0);
    let third = submission(&dir, 3);
    assert_eq!(third["ids"], serde_json::json!([cancelled]), "{third}");
    let log = std::fs::read_to_string(
        dir.join("logs")
            .join(format!("{}_0.log", third["job_id"].as_str().unwrap())),
    )
    .unwrap();
    assert!(log.contains(", 2 thread(s)"), "{log}");
    assert!(log.contains("  threads: 2\n"), "{log}");
    assert_eq!(submissions(&dir), 3);
    let s = status(&slurm, &cluster, study);
    assert_eq!(count(&s, "done"), 12, "{s}");
    assert_eq!(row(&s, &cancelled)["submission"], 3);
    // Every run was computed exactly once (one log line each).
    let computed: usize = std::fs::read_dir(dir.join("logs"))
        .unwrap()
        .map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap())
        .map(|log| log.matches("(computed)").count())
        .sum();
    assert_eq!(computed, 12);

    // Byte-identical results, logs and table.
    for r in s["runs"].as_array().unwrap() {
        let id = r["id"].as_str().unwrap();
        for file in ["result.json", "run.mcap"] {
            let a = std::fs::read(local.join(id).join(file)).unwrap();
            let b = std::fs::read(cluster.join(id).join(file)).unwrap();
            assert!(
                a == b,
                "{id}/{file} differs between the local pool and Slurm"
            );
        }
    }
    let table = |store: &Path| std::fs::read(slurm_dir(store).with_file_name("batch/angles.csv"));
    assert_eq!(table(&local).unwrap(), table(&cluster).unwrap());
    // The whole study tree (every stage output and lineage record) is the
    // same whichever executor ran it; only the Slurm ledger is extra
    // (issue 40, item 5).
    let tree = |store: &Path| -> Vec<(PathBuf, Vec<u8>)> {
        common::snapshot(slurm_dir(store).parent().unwrap())
            .into_iter()
            .filter(|(p, _)| !p.starts_with("slurm"))
            .collect()
    };
    let (a, b) = (tree(&local), tree(&cluster));
    assert_eq!(
        a.iter().map(|(p, _)| p).collect::<Vec<_>>(),
        b.iter().map(|(p, _)| p).collect::<Vec<_>>()
    );
    for ((path, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{} differs between the local pool and Slurm",
            path.display()
        );
    }
    eprintln!(
        "smoke study: local pool + Slurm scenario in {:.1} s",
        started.elapsed().as_secs_f64()
    );

    // A run that fails on Slurm is reported with its error, shown as failed,
    // and submitted again only when asked.
    let mut failing: Value = common::example("calibrate-smoke/study.json");
    failing["name"] = "calibrate-smoke-failing".into();
    // A drum filled to 99 %: more spheres than its cross-section holds, so
    // the run fails when it places them (validation allows any fill < 1).
    failing["calibration"]["scene"]["fill_fraction"] = 0.99.into();
    failing["design"]["size"] = 2.into();
    let failing_path = tmp.path().join("failing.json");
    std::fs::write(&failing_path, failing.to_string()).unwrap();
    let failing_study = failing_path.to_str().unwrap();
    let store = tmp.path().join("failing-store");
    expect_code(&repose(&slurm, &store, &["sample", failing_study]), 0);
    let batch = [
        "batch",
        failing_study,
        "--executor",
        "slurm",
        "--poll-seconds",
        "0.5",
    ];
    let out = repose(&slurm, &store, &batch);
    expect_code(&out, 1);
    let report = text(&out.stdout);
    let failed_lines = report
        .lines()
        .filter(|l| l.contains("the region holds only"));
    assert_eq!(failed_lines.count(), 2, "{report}");
    assert!(report.contains("error.json"), "{report}");
    let s = status(&slurm, &store, failing_study);
    assert_eq!(count(&s, "failed"), 2, "{s}");
    for r in s["runs"].as_array().unwrap() {
        assert!(
            r["note"]
                .as_str()
                .unwrap()
                .contains("the region holds only"),
            "{r}"
        );
    }
    let dir = slurm_dir(&store);
    expect_code(&repose(&slurm, &store, &batch), 1);
    assert_eq!(
        submissions(&dir),
        1,
        "a failed run is not resubmitted unasked"
    );
    let mut again = batch.to_vec();
    again.push("--resubmit-failed");
    expect_code(&repose(&slurm, &store, &again), 1);
    assert_eq!(submissions(&dir), 2);
    assert_eq!(submission(&dir, 2)["ids"].as_array().unwrap().len(), 2);

    // A task that ends before repose runs (here its setup exits) leaves no
    // result and no error.json: the stage stops before its analysis (exit 1,
    // naming the task), and the next call submits that run again (issue 40,
    // item 4: the noise floor used to be computed from the other seeds).
    let store = tmp.path().join("lost-store");
    let manifest = "experiments/drum/smoke.json";
    let lose_task_0 = format!(
        "export PATH='{}':\"$PATH\"; if [ \"$SLURM_ARRAY_TASK_ID\" = 0 ]; then exit 7; fi",
        bin.display()
    );
    let noise = |extra: &[&str]| {
        let mut args = vec![
            "noise",
            manifest,
            "--seeds",
            "2",
            "--executor",
            "slurm",
            "--poll-seconds",
            "0.5",
        ];
        args.extend_from_slice(extra);
        repose(&slurm, &store, &args)
    };
    let out = noise(&["--setup", &lose_task_0]);
    expect_code(&out, 1);
    let err = text(&out.stderr);
    assert!(
        err.contains("1 Slurm task(s) ended without a result") && err.contains("_0 left the queue"),
        "{err}"
    );
    assert!(text(&out.stdout).is_empty(), "{}", text(&out.stdout));
    let out = noise(&[]);
    expect_code(&out, 0);
    let report = text(&out.stdout);
    assert!(
        report.contains("(2 runs, 0 failed)") && report.contains("| 2/2 |"),
        "{report}"
    );
    // `status MANIFEST` reads the noise floor's ledger (its exit-3 message
    // points there).
    let out = repose(&slurm, &store, &["status", manifest, "--json"]);
    expect_code(&out, 0);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["noise"]["counts"]["done"], 2, "{v}");
    assert!(v["tradeoff"].is_null(), "{v}");

    // Without squeue, `status` and a batch with nothing to run answer from
    // the store; a damaged run reads as such, not as lost.
    let no_slurm = |args: &[&str]| {
        repose_command(&cluster, args)
            .env("SLURM_CONF", tmp.path().join("no-such-slurm.conf"))
            .output()
            .unwrap()
    };
    expect_code(&no_slurm(&["batch", study, "--executor", "slurm"]), 0);
    let out = no_slurm(&["status", study, "--json"]);
    expect_code(&out, 0);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["counts"]["done"], 12, "{v}");
    assert!(v["squeue_error"].as_str().is_some(), "{v}");
    let damaged = v["runs"][0]["id"].as_str().unwrap().to_string();
    let result = cluster.join(&damaged).join("result.json");
    let mut bytes = std::fs::read(&result).unwrap();
    bytes.push(b' ');
    std::fs::write(&result, bytes).unwrap();
    let v = status(&slurm, &cluster, study);
    let row = v["runs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["id"] == damaged.as_str())
        .unwrap();
    assert_eq!(row["state"], "pending", "{row}");
    assert!(
        row["note"].as_str().unwrap().starts_with("damaged"),
        "{row}"
    );

    // sbatch refusing the options (a partition that does not exist) is an
    // error in the options (exit 2) and leaves no submission without a job.
    let store = tmp.path().join("refused-store");
    expect_code(&repose(&slurm, &store, &["sample", study]), 0);
    let out = batch_on_slurm(&slurm, &store, study, &["--partition", "nosuch"]);
    expect_code(&out, 2);
    assert!(
        text(&out.stderr).contains("sbatch refused"),
        "{}",
        text(&out.stderr)
    );
    assert_eq!(submissions(&slurm_dir(&store)), 0);

    // Two clients at once submit each run once: the second waits for the
    // first's submission and then waits for its tasks.
    let store = tmp.path().join("two-clients-store");
    expect_code(&repose(&slurm, &store, &["sample", study]), 0);
    let client = || {
        repose_command(
            &store,
            &[
                "batch",
                study,
                "--executor",
                "slurm",
                "--poll-seconds",
                "0.5",
            ],
        )
        .env("SLURM_CONF", &slurm.conf)
        .spawn()
        .unwrap()
    };
    let (a, b) = (client(), client());
    for c in [a, b] {
        expect_code(&c.wait_with_output().unwrap(), 0);
    }
    let dir = slurm_dir(&store);
    assert_eq!(submissions(&dir), 1, "the second client submitted again");

    // A request no node of the partition can hold (64 CPUs per task on this
    // 2-CPU node) pends with reason PartitionConfig: the client stops
    // waiting with that reason (it used to poll for ever), and `status`
    // shows it (issue 40, item 6).
    let store = tmp.path().join("unschedulable-store");
    expect_code(&repose(&slurm, &store, &["sample", study]), 0);
    let out = batch_on_slurm(
        &slurm,
        &store,
        study,
        &["--cpus-per-task", "64", "--poll-seconds", "0.5"],
    );
    expect_code(&out, 1);
    let err = text(&out.stderr);
    assert!(
        err.contains("can never start") && err.contains("PartitionConfig"),
        "{err}"
    );
    let s = status(&slurm, &store, study);
    assert_eq!(count(&s, "queued"), 12, "{s}");
    assert!(s["runs"][0]["note"]
        .as_str()
        .unwrap()
        .contains("PartitionConfig"));
    let job = submission(&slurm_dir(&store), 1)["job_id"]
        .as_str()
        .unwrap()
        .to_string();
    let scancel = Command::new("scancel")
        .arg(&job)
        .env("SLURM_CONF", &slurm.conf)
        .output()
        .unwrap();
    expect_code(&scancel, 0);
}

#[test]
fn slurm_options_need_the_slurm_executor() {
    let tmp = tempfile::tempdir().unwrap();
    let study = "experiments/calibrate-smoke/study.json";
    for (args, message) in [
        (
            vec!["--partition", "short"],
            "--partition is a Slurm option: add --executor slurm",
        ),
        (
            vec!["--executor", "slurm", "--cpus-per-task", "0", "--dry-run"],
            "--cpus-per-task = 0: must be >= 1",
        ),
        (
            vec!["--executor", "slurm", "--max-running", "0"],
            "--max-running = 0: must be >= 1",
        ),
        (
            vec!["--executor", "slurm", "--time-limit", "banana", "--dry-run"],
            "--time-limit `banana`: not a Slurm time",
        ),
        (
            vec!["--executor", "slurm", "--mem", "4.5G", "--dry-run"],
            "--mem `4.5G`: not a Slurm memory size",
        ),
    ] {
        let mut all = vec!["batch", study];
        all.extend(args);
        let out = repose_command(tmp.path(), &all).output().unwrap();
        expect_code(&out, 2);
        assert!(text(&out.stderr).contains(message), "{}", text(&out.stderr));
    }
}
