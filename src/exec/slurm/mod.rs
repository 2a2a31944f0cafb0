//! The Slurm executor: a study's pending experiments as one job array.
//!
//! [`super::run_incomplete`] hands the experiments the store does not hold
//! complete to [`run`] when the executor has [`SlurmSettings`]. It
//!
//! 1. asks `squeue` which of them are already queued or running under an
//!    earlier submission of this study ([`ledger`]) and leaves those alone;
//! 2. leaves a run that failed (its `error.json`) alone too, unless
//!    [`SlurmSettings::resubmit_failed`], and reports its error;
//! 3. holding the ledger's claim (a second client waits, then finds these
//!    tasks queued), writes the rest — their manifests, a task list and a job script
//!    ([`script`]) — into the study's `slurm/` directory and submits one
//!    `sbatch --array=0-(K-1)%M` (or, with `dry_run`, stops there and says
//!    how to submit it by hand);
//! 4. polls `squeue` ([`queue`]) every [`SlurmSettings::poll`] until none of
//!    the study's runs is in the queue (unless `wait` is off: then it returns
//!    [`ExecError::Queued`] at once), showing Slurm's pending reasons on the
//!    progress line; a failed poll is retried, and only
//!    [`SQUEUE_ATTEMPTS`] failures in a row end the wait; a task pending for
//!    a reason that waiting does not clear ([`queue::NEVER_CLEARS`], e.g.
//!    `PartitionConfig` for more CPUs than a node has) ends it too, with
//!    [`ExecError::NeverStarts`] (the job stays queued for the user to
//!    cancel), and
//! 5. reads the outcome of each from the store: a sealed result, an
//!    `error.json` (a failed run, reported to the stage like a local
//!    failure), or neither: the task was cancelled, ran out of time or its
//!    script failed, and the call ends with [`ExecError::Lost`] quoting the
//!    end of each such task's log, so no stage analyses a design with runs
//!    missing that the next call would resubmit.
//!
//! Each task is `repose run` on one manifest against the same store, so it
//! writes that run's files only (atomically, under the run's claim) and the
//! results are byte-identical to the local pool's. The client writes nothing
//! into run directories; the stage that called it writes its tables after
//! collection. Killing the client loses nothing: finished runs are in the
//! store, queued ones stay queued and are found again by the next call.

pub mod ledger;
pub mod queue;
pub mod script;
pub mod status;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::progress::BatchProgress;
use super::{ExecError, Executor};
use crate::manifest::{canonical_json, ContentId, Experiment};
use crate::store::{Depth, RunState, Store};
use ledger::{Ledger, Submission};
use queue::{Queue, QueueEntry, QueueState};

/// How many polls in a row `squeue` may fail while the client waits before
/// the wait gives up with its error.
pub const SQUEUE_ATTEMPTS: u32 = 5;

/// How many tasks one job array holds at most: Slurm's default
/// `MaxArraySize` is 1001 (indices 0–1000); more runs become several arrays.
pub const MAX_ARRAY_TASKS: usize = 1000;

/// What users set on clusters, and how the client waits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlurmSettings {
    /// Where the job files go; `None`: `<store>/slurm`. Commands set it to the
    /// study's `slurm/` directory ([`Executor::in_study`]).
    pub dir: Option<PathBuf>,
    /// The program each task runs (found on the node's PATH after `setup`).
    pub program: String,
    /// Shell lines run before `repose` on the node (e.g. `module load repose`);
    /// `None`: put this client's own directory first on PATH (a binary on the
    /// shared file system).
    pub setup: Option<String>,
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time` (Slurm's formats, e.g. `2-00:00:00`).
    pub time_limit: Option<String>,
    /// `--mem` (e.g. `4G`).
    pub mem: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--cpus-per-task` (≥ 1); each task's simulation runs on this many threads.
    pub cpus_per_task: u32,
    /// Further `#SBATCH` lines, verbatim (`--qos=high`).
    pub extra: Vec<String>,
    /// The array throttle M of `--array=0-(K-1)%M`: tasks running at once.
    pub max_running: Option<u32>,
    /// Write the job script without submitting it.
    pub dry_run: bool,
    /// Wait for the runs to leave the queue (else return [`ExecError::Queued`]).
    pub wait: bool,
    /// Submit runs again whose last attempt failed (left an `error.json`).
    pub resubmit_failed: bool,
    /// How often `squeue` is asked while waiting.
    pub poll: Duration,
}

impl Default for SlurmSettings {
    fn default() -> SlurmSettings {
        SlurmSettings {
            dir: None,
            program: "repose".to_string(),
            setup: None,
            partition: None,
            time_limit: None,
            mem: None,
            account: None,
            cpus_per_task: 1,
            extra: Vec::new(),
            max_running: None,
            dry_run: false,
            wait: true,
            resubmit_failed: false,
            poll: Duration::from_secs(10),
        }
    }
}

impl SlurmSettings {
    /// The settings' errors, each naming its flag.
    pub fn check(&self) -> Result<(), ExecError> {
        let bad = |m: String| Err(ExecError::Settings(m));
        if self.cpus_per_task == 0 {
            return bad("--cpus-per-task = 0: must be >= 1".to_string());
        }
        if self.max_running == Some(0) {
            return bad("--max-running = 0: must be >= 1 (or absent: no throttle)".to_string());
        }
        if self.poll.is_zero() {
            return bad("--poll-seconds = 0: must be > 0".to_string());
        }
        if self.program.trim().is_empty() {
            return bad("--program is empty: name the repose binary tasks run".to_string());
        }
        if let Some(t) = &self.time_limit {
            if !valid_time_limit(t) {
                return bad(format!(
                    "--time-limit `{t}`: not a Slurm time (MINUTES, MINUTES:SECONDS, \
                     HOURS:MINUTES:SECONDS, DAYS-HOURS, DAYS-HOURS:MINUTES, \
                     DAYS-HOURS:MINUTES:SECONDS or UNLIMITED)"
                ));
            }
        }
        if let Some(m) = &self.mem {
            if !valid_memory(m) {
                return bad(format!(
                    "--mem `{m}`: not a Slurm memory size (a whole number with an optional \
                     unit K, M, G or T, e.g. 4G)"
                ));
            }
        }
        for line in &self.extra {
            if line.contains('\n') {
                return bad(format!("--sbatch `{line}`: one #SBATCH line per flag"));
            }
        }
        Ok(())
    }

    /// The shell lines run before `repose` (see [`SlurmSettings::setup`]).
    fn setup_lines(&self) -> Option<String> {
        self.setup.clone().or_else(|| {
            let exe = std::env::current_exe().ok()?;
            let dir = exe.parent()?.display().to_string();
            Some(format!("export PATH={}:\"$PATH\"", script::quote(&dir)))
        })
    }
}

/// Whether `t` is one of sbatch's `--time` formats: `M`, `M:S`, `H:M:S`,
/// `D-H`, `D-H:M`, `D-H:M:S` (whole numbers), or `UNLIMITED`/`INFINITE`.
fn valid_time_limit(t: &str) -> bool {
    let number = |p: &str| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit());
    if t.eq_ignore_ascii_case("unlimited") || t.eq_ignore_ascii_case("infinite") {
        return true;
    }
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    let parts: Vec<&str> = rest.split(':').collect();
    days.is_none_or(number) && parts.len() <= 3 && parts.iter().all(|p| number(p))
}

/// Whether `m` is a `--mem` size: a whole number with an optional unit
/// `K`, `M`, `G` or `T` (either case).
fn valid_memory(m: &str) -> bool {
    let digits = m.trim_end_matches(|c: char| "KMGTkmgt".contains(c));
    m.len() - digits.len() <= 1 && !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
}

/// The ledger of `settings` for a store.
pub fn ledger_of(settings: &SlurmSettings, store: &Store) -> Ledger {
    Ledger::new(
        settings
            .dir
            .clone()
            .unwrap_or_else(|| store.root().join("slurm")),
    )
}

/// The array task of a run in Slurm's queue.
#[derive(Debug, Clone)]
struct Flying {
    /// The array's job id.
    job: String,
    /// The task index.
    task: usize,
    /// Its line of `squeue` (state and pending reason).
    entry: QueueEntry,
}

/// Which array task each in-flight run is; a later submission's task wins
/// over an earlier one.
fn in_flight(submissions: &[Submission], queue: &Queue) -> BTreeMap<ContentId, Flying> {
    let mut out = BTreeMap::new();
    for s in submissions {
        let Some(job) = &s.job_id else { continue };
        for (t, id) in s.ids.iter().enumerate() {
            if let Some(e) = queue.task(job, t) {
                out.insert(
                    id.clone(),
                    Flying {
                        job: job.clone(),
                        task: t,
                        entry: e.clone(),
                    },
                );
            }
        }
    }
    out
}

/// The first waiting run whose task can never start (see
/// [`queue::NEVER_CLEARS`]), as the error that ends the wait.
fn never_starting(
    waiting: &BTreeSet<ContentId>,
    flying: &BTreeMap<ContentId, Flying>,
) -> Option<ExecError> {
    waiting.iter().find_map(|id| {
        let f = flying.get(id)?;
        let why = f.entry.never_starts()?;
        Some(ExecError::NeverStarts {
            task: format!("{}_{}", f.job, f.task),
            job: f.job.clone(),
            reason: f.entry.reason.clone(),
            why: why.to_string(),
        })
    })
}

/// What the queued runs among `waiting` wait for, for the progress line:
/// `queued: Resources 3, Priority 1` (most frequent first), or `None`.
fn pending_reasons(
    waiting: &BTreeSet<ContentId>,
    flying: &BTreeMap<ContentId, Flying>,
) -> Option<String> {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for f in waiting.iter().filter_map(|id| flying.get(id)) {
        if f.entry.state() == QueueState::Queued {
            *counts.entry(f.entry.reason.as_str()).or_default() += 1;
        }
    }
    let mut by_count: Vec<(&str, usize)> = counts.into_iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    (!by_count.is_empty()).then(|| {
        let parts: Vec<String> = by_count.iter().map(|(r, n)| format!("{r} {n}")).collect();
        format!("queued: {}", parts.join(", "))
    })
}

/// Fills in the job id of submissions recorded before sbatch returned (a
/// killed client, or a `--dry-run` script submitted by hand) from a job of
/// the same name in the queue; `persist` writes the found ids to the ledger.
fn adopt_named_jobs(
    ledger: &Ledger,
    submissions: &mut [Submission],
    queue: &Queue,
    persist: bool,
) -> Result<(), ExecError> {
    for s in submissions.iter_mut().filter(|s| s.job_id.is_none()) {
        if let Some(job) = queue.job_named(&s.job_name) {
            s.job_id = Some(job.to_string());
            if persist {
                ledger.record(s)?;
            }
        }
    }
    Ok(())
}

/// The last (job, task) that ran `id`, if any submission with a job id held it.
fn last_task(submissions: &[Submission], id: &ContentId) -> Option<(String, usize)> {
    submissions.iter().rev().find_map(|s| {
        let job = s.job_id.as_ref()?;
        let t = s.ids.iter().position(|x| x == id)?;
        Some((job.clone(), t))
    })
}

/// The stored error of a failed run, with its causes: the message a local
/// run of the same experiment reports ([`crate::errors::chain`] of the
/// runner's error), with no path, so stage tables that quote it are the same
/// whichever executor ran the run and wherever the store lies.
fn failure_message(store: &Store, id: &ContentId) -> String {
    match store.load_error(id) {
        Ok(Some(record)) => {
            let mut m = record.error;
            for c in &record.causes {
                if !m.contains(c.as_str()) {
                    m.push_str(": ");
                    m.push_str(c);
                }
            }
            m
        }
        Ok(None) => format!("run {id} has no error.json"),
        Err(e) => format!("its error.json cannot be read: {e}"),
    }
}

/// Why a run that left the queue has neither a result nor an error: the end
/// of its task's log.
fn lost_message(ledger: &Ledger, submissions: &[Submission], id: &ContentId) -> String {
    let Some((job, task)) = last_task(submissions, id) else {
        return "never submitted".to_string();
    };
    let log = ledger.log(&job, task);
    let tail = std::fs::read_to_string(&log)
        .map(|text| {
            let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
            lines[lines.len().saturating_sub(3)..].join(" | ")
        })
        .unwrap_or_else(|e| format!("(no log: {e})"));
    format!(
        "Slurm task {job}_{task} left the queue without a result or an error.json \
         (cancelled, out of time or memory, or its job script failed); log {}: {tail}",
        log.display()
    )
}

/// Runs the experiments at `pending` (positions in `experiments`) on Slurm
/// (see the module docs); returns the failures as (position, message), sorted.
pub(super) fn run(
    pending: &[usize],
    experiments: &[Experiment],
    store: &Store,
    exec: &Executor,
    settings: &SlurmSettings,
    progress: &mut BatchProgress,
) -> Result<Vec<(usize, String)>, ExecError> {
    settings.check()?;
    let ledger = ledger_of(settings, store);
    // One client at a time decides and submits for this ledger: a second
    // client waits here, then finds the first one's tasks in the queue (or
    // done) instead of submitting them again. The claim ends before the wait.
    let claim = claim_ledger(&ledger)?;
    let mut submissions = ledger.submissions()?;
    let queue = match queue::snapshot() {
        Ok(q) => q,
        // A script written for submission by hand needs no Slurm here.
        Err(_) if settings.dry_run => Queue::default(),
        Err(e) => return Err(e),
    };
    adopt_named_jobs(&ledger, &mut submissions, &queue, true)?;
    let flying = in_flight(&submissions, &queue);

    let mut positions: BTreeMap<ContentId, Vec<usize>> = BTreeMap::new();
    for &i in pending {
        positions.entry(experiments[i].id()).or_default().push(i);
    }
    let mut failures = Vec::new();
    let mut waiting = BTreeSet::new();
    let mut to_submit = Vec::new();
    for (id, at) in &positions {
        if flying.contains_key(id) {
            waiting.insert(id.clone());
            continue;
        }
        match store.check(id, Depth::Sizes) {
            // Finished since the caller looked (another client's task).
            RunState::Complete(_) => progress.finished_one(false),
            RunState::Failed if !settings.resubmit_failed => {
                progress.finished_one(true);
                let m = failure_message(store, id);
                failures.extend(at.iter().map(|&i| (i, m.clone())));
            }
            _ => to_submit.push(at[0]),
        }
    }
    for chunk in to_submit.chunks(MAX_ARRAY_TASKS) {
        let s = prepare_submission(&ledger, chunk, experiments, store, exec, settings)?;
        if settings.dry_run {
            return Err(ExecError::NotSubmitted {
                runs: to_submit.len(),
                script: ledger.submission_dir(s.number).join("job.sh"),
            });
        }
        let submitted = submit(&ledger, s)?;
        waiting.extend(submitted.ids.iter().cloned());
        submissions.push(submitted);
    }
    drop(claim);
    if !settings.wait && !waiting.is_empty() {
        let jobs: BTreeSet<String> = in_flight(&submissions, &queue::snapshot()?)
            .into_values()
            .map(|f| f.job)
            .collect();
        return Err(ExecError::Queued {
            runs: waiting.len(),
            jobs: jobs.into_iter().collect::<Vec<_>>().join(", "),
            dir: ledger.dir().to_path_buf(),
        });
    }
    let mut lost = Vec::new();
    wait(
        &ledger,
        &submissions,
        store,
        settings,
        waiting,
        progress,
        |id, left| match left {
            Left::Failed(m) => failures.extend(positions[id].iter().map(|&i| (i, m.clone()))),
            Left::Lost(m) => lost.push(m),
        },
    )?;
    if !lost.is_empty() {
        return Err(ExecError::Lost { messages: lost });
    }
    failures.sort();
    Ok(failures)
}

/// How a run without a result left the queue.
enum Left {
    /// The run failed: its `error.json` (the message a local run gives).
    Failed(String),
    /// The task ended without a result or an error (cancelled, out of time
    /// or memory, its script failed): the run is resubmitted next time.
    Lost(String),
}

/// Claims the ledger's directory (creating it) for the submission phase
/// of [`run`], saying on stderr when another client holds it.
fn claim_ledger(ledger: &Ledger) -> Result<crate::store::claim::Claim, ExecError> {
    let dir = ledger.dir();
    std::fs::create_dir_all(dir)
        .map_err(|e| ExecError::Slurm(format!("{}: {e}", dir.display())))?;
    crate::store::claim::claim(dir, || {
        eprintln!(
            "note: another repose is submitting from {}; waiting for it",
            dir.display()
        )
    })
    .map_err(|e| ExecError::Slurm(format!("{}: {e}", dir.display())))
}

/// Writes the manifests, task list, job script and record of a new
/// submission of the experiments at `chunk` (not yet submitted).
fn prepare_submission(
    ledger: &Ledger,
    chunk: &[usize],
    experiments: &[Experiment],
    store: &Store,
    exec: &Executor,
    settings: &SlurmSettings,
) -> Result<Submission, ExecError> {
    let number = ledger.claim_number()?;
    let dir = ledger.submission_dir(number);
    let store_root = absolute(store.root())?;
    let mut tasks = String::new();
    let mut ids = Vec::new();
    for &i in chunk {
        let id = experiments[i].id();
        let path = absolute(&ledger.manifest(&id))?;
        let bytes = canonical_json(&experiments[i]);
        if std::fs::read(&path).ok().as_deref() != Some(bytes.as_bytes()) {
            ledger::write(&path, bytes.as_bytes())?;
        }
        tasks.push_str(&format!("{}\n", path.display()));
        ids.push(id);
    }
    let tasks_file = absolute(&dir.join("tasks.txt"))?;
    ledger::write(&tasks_file, tasks.as_bytes())?;
    let logs = absolute(&ledger.logs())?;
    let job_name = job_name(ledger.dir(), number);
    let with_setup = SlurmSettings {
        setup: settings.setup_lines(),
        ..settings.clone()
    };
    let text = script::job_script(&script::ScriptInputs {
        settings: &with_setup,
        limits: &exec.limits,
        store: &store_root,
        tasks_file: &tasks_file,
        logs: &logs,
        job_name: &job_name,
        tasks: chunk.len(),
    });
    ledger::write(&dir.join("job.sh"), text.as_bytes())?;
    let submission = Submission {
        number,
        job_name,
        job_id: None,
        ids,
    };
    ledger.record(&submission)?;
    Ok(submission)
}

/// `path` made absolute (tasks start in Slurm's working directory, not the
/// client's); an error names the path.
fn absolute(path: &Path) -> Result<PathBuf, ExecError> {
    std::path::absolute(path).map_err(|e| ExecError::Slurm(format!("{}: {e}", path.display())))
}

/// `repose-<12 hex of the ledger directory's sha256>-<number>`: unique per
/// study and submission, so a job submitted by hand is found by its name.
fn job_name(dir: &Path, number: u32) -> String {
    let abs = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    let id = ContentId::of_bytes(abs.display().to_string().as_bytes());
    format!("repose-{}-{number}", id.short(12))
}

/// Submits a prepared submission and records its job id. When sbatch
/// refuses it (no job exists), the submission's directory is removed, so
/// no record without a job is left behind, and the refusal is an error in
/// the options (exit 2) quoting sbatch.
fn submit(ledger: &Ledger, mut s: Submission) -> Result<Submission, ExecError> {
    let dir = ledger.submission_dir(s.number);
    let job = match queue::submit(&dir.join("job.sh")) {
        Ok(job) => job,
        Err(queue::Submitted::Failed(e)) => return Err(e),
        Err(queue::Submitted::Refused(message)) => {
            std::fs::remove_dir_all(&dir)
                .map_err(|e| ExecError::Slurm(format!("{}: {e}", dir.display())))?;
            return Err(ExecError::Settings(format!(
                "sbatch refused the job (check --partition, --mem, --time-limit, --account, \
                 --cpus-per-task, --sbatch): {message}"
            )));
        }
    };
    s.job_id = Some(job);
    ledger.record(&s)?;
    Ok(s)
}

/// Polls the queue until none of `waiting` is in it; reports each run that
/// left without a result to `left` as it leaves, counting it on `progress`.
fn wait(
    ledger: &Ledger,
    submissions: &[Submission],
    store: &Store,
    settings: &SlurmSettings,
    mut waiting: BTreeSet<ContentId>,
    progress: &mut BatchProgress,
    mut left: impl FnMut(&ContentId, Left),
) -> Result<(), ExecError> {
    let mut next_poll = Instant::now();
    let mut squeue_failures = 0;
    while !waiting.is_empty() {
        let now = Instant::now();
        if now < next_poll {
            std::thread::sleep((next_poll - now).min(Duration::from_millis(500)));
            progress.tick();
            continue;
        }
        next_poll = now + settings.poll;
        // A busy controller times squeue out now and then; only a run of
        // failures ends the wait (the runs stay queued; the next call resumes).
        let queue = match queue::snapshot() {
            Ok(q) => {
                squeue_failures = 0;
                q
            }
            Err(e) => {
                squeue_failures += 1;
                if squeue_failures >= SQUEUE_ATTEMPTS {
                    return Err(e);
                }
                continue;
            }
        };
        let flying = in_flight(submissions, &queue);
        if let Some(e) = never_starting(&waiting, &flying) {
            progress.finish();
            return Err(e);
        }
        progress.set_note(pending_reasons(&waiting, &flying));
        let gone: Vec<ContentId> = waiting
            .iter()
            .filter(|id| !flying.contains_key(*id))
            .cloned()
            .collect();
        for id in gone {
            waiting.remove(&id);
            let outcome = match store.check(&id, Depth::Sizes) {
                RunState::Complete(_) => None,
                RunState::Failed => Some(Left::Failed(failure_message(store, &id))),
                _ => Some(Left::Lost(lost_message(ledger, submissions, &id))),
            };
            progress.finished_one(outcome.is_some());
            if let Some(l) = outcome {
                left(&id, l);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_experiment;
    use crate::store::{RunDir, RunResult};

    #[test]
    fn time_limits_and_memory_sizes_are_read_as_sbatch_reads_them() {
        for t in [
            "30",
            "30:00",
            "2:00:00",
            "2-0",
            "2-12:30",
            "2-12:30:00",
            "UNLIMITED",
        ] {
            assert!(valid_time_limit(t), "{t}");
        }
        for t in [
            "banana",
            "",
            "1:2:3:4",
            "2-",
            "-5",
            "1.5",
            "2-1:2:3:4",
            "1h",
        ] {
            assert!(!valid_time_limit(t), "{t}");
        }
        for m in ["4000", "4G", "512m", "1T"] {
            assert!(valid_memory(m), "{m}");
        }
        for m in ["", "G", "4GB", "4.5G", "lots", "-1G"] {
            assert!(!valid_memory(m), "{m}");
        }
        let bad = SlurmSettings {
            time_limit: Some("banana".to_string()),
            ..SlurmSettings::default()
        };
        assert!(bad
            .check()
            .unwrap_err()
            .to_string()
            .contains("--time-limit `banana`"));
    }

    /// The drum smoke experiment and an empty store in a temp directory.
    fn drum_in_a_fresh_store() -> (Experiment, tempfile::TempDir, Store) {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/drum/smoke.json"),
        )
        .unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::open(tmp.path()).unwrap();
        (parse_experiment(&text).unwrap(), tmp, store)
    }

    #[derive(Debug, thiserror::Error)]
    #[error("pile angle: not measurable")]
    struct Outer(#[source] std::io::Error);

    /// A failure read back from error.json (as the Slurm client does) is
    /// the message a local run gives, with no path of the store in it
    /// (issue 40, item 5).
    #[test]
    fn a_failure_reads_back_as_the_local_message_without_a_path() {
        let (e, tmp, store) = drum_in_a_fresh_store();
        let runner = |_: &Experiment, _: &RunDir| -> Result<RunResult, Outer> {
            Err(Outer(std::io::Error::other(
                "left flank has 2 surface points",
            )))
        };
        let local = crate::errors::chain(&store.run_cached(&e, runner).unwrap_err());
        let read_back = failure_message(&store, &e.id());
        assert_eq!(read_back, local);
        assert_eq!(
            read_back,
            "pile angle: not measurable: left flank has 2 surface points"
        );
        assert!(!read_back.contains(&tmp.path().display().to_string()));
    }

    /// A result the store cannot keep (a non-finite measurement) reads back
    /// from error.json as the local run reports it (issue 40, item 5).
    #[test]
    fn an_unusable_result_reads_back_as_the_local_message() {
        let (e, _tmp, store) = drum_in_a_fresh_store();
        let runner = |e: &Experiment, _: &RunDir| -> Result<RunResult, Outer> {
            let mut r = RunResult::new(e, "fake");
            r.measurements.insert("peak_force_n".into(), f64::NAN);
            Ok(r)
        };
        let local = crate::errors::chain(&store.run_cached(&e, runner).unwrap_err());
        assert_eq!(failure_message(&store, &e.id()), local);
        assert!(
            local.starts_with("the run produced an unusable result: measurement `peak_force_n`")
        );
    }
}
