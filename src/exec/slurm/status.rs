//! `repose status`: where every run a study handed to Slurm stands.
//!
//! One row per experiment of the study's submissions (first submission
//! order), its state read from the store first and the queue second:
//!
//! | state | meaning |
//! |---|---|
//! | done | the store holds its sealed result |
//! | running | an array task of it is allocated (running, starting, completing) |
//! | queued | an array task of it waits in the queue; the note gives Slurm's pending reason (resources, throttle, hold, or one that never clears, e.g. `PartitionConfig`) |
//! | failed | not in the queue; its `error.json` says why (resubmitted only when asked) |
//! | pending | not in the queue and no sound outcome: never submitted (a `--dry-run` script), its task was cancelled or lost, or its files no longer match their seal (damaged); the next stage run submits it |
//!
//! When `squeue` cannot be asked, the report comes from the store alone and
//! says so (`squeue_error`): runs with no outcome read as pending.
//!
//! Nothing is written: a submission recorded without a job id (a killed
//! client, a script submitted by hand) is matched to the queue by its job
//! name for this report only.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use super::ledger::Ledger;
use super::queue::{self, QueueEntry, QueueState};
use super::{adopt_named_jobs, in_flight, last_task, ExecError};
use crate::manifest::{ContentId, Experiment};
use crate::store::{Depth, RunState, Store};

/// The state of one run (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TaskState {
    /// Not submitted, or its task left the queue without an outcome.
    Pending,
    /// Waiting in Slurm's queue.
    Queued,
    /// Allocated by Slurm.
    Running,
    /// Its result is in the store.
    Done,
    /// Its run failed; `error.json` says why.
    Failed,
}

impl TaskState {
    /// Every state, in the report's order.
    pub const ALL: [TaskState; 5] = [
        TaskState::Pending,
        TaskState::Queued,
        TaskState::Running,
        TaskState::Done,
        TaskState::Failed,
    ];

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            TaskState::Pending => "pending",
            TaskState::Queued => "queued",
            TaskState::Running => "running",
            TaskState::Done => "done",
            TaskState::Failed => "failed",
        }
    }
}

/// One run of the report.
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    /// The experiment id.
    pub id: ContentId,
    /// Its scene kind (from the submitted manifest).
    pub scene: String,
    /// Its state.
    pub state: TaskState,
    /// The Slurm job id of its last (or current) array, if submitted.
    pub job: Option<String>,
    /// Its array task index there.
    pub task: Option<usize>,
    /// The submission that holds that task.
    pub submission: u32,
    /// The error of a failed run; why a pending or queued one waits.
    pub note: Option<String>,
}

/// Every run a study handed to Slurm, with counts per state.
#[derive(Debug, Clone, Serialize)]
pub struct StatusReport {
    /// The study's `slurm/` directory.
    pub dir: PathBuf,
    /// How many sbatch submissions it made.
    pub submissions: usize,
    /// Why squeue could not be asked, when it could not (the states then
    /// come from the store alone).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub squeue_error: Option<String>,
    /// Runs per state (every state present, zeros included).
    pub counts: BTreeMap<&'static str, usize>,
    /// One row per run.
    pub runs: Vec<RunRow>,
}

/// The report for the ledger in `dir` against `store` and the queue now.
pub fn status(store: &Store, dir: PathBuf) -> Result<StatusReport, ExecError> {
    let ledger = Ledger::new(&dir);
    let mut submissions = ledger.submissions()?;
    // Without squeue (the controller down, or a machine without Slurm's
    // client) the store still answers: runs not done or failed read as
    // pending, and the report says why.
    let (queue, squeue) = if submissions.is_empty() {
        (Default::default(), None)
    } else {
        match queue::snapshot() {
            Ok(q) => (q, None),
            Err(e) => (Default::default(), Some(e.to_string())),
        }
    };
    adopt_named_jobs(&ledger, &mut submissions, &queue, false)?;
    let flying = in_flight(&submissions, &queue);
    let mut runs: Vec<RunRow> = Vec::new();
    let mut seen = BTreeMap::new();
    for s in &submissions {
        for id in &s.ids {
            if seen.insert(id.clone(), ()).is_some() {
                continue;
            }
            let scene = std::fs::read(ledger.manifest(id))
                .ok()
                .and_then(|b| serde_json::from_slice::<Experiment>(&b).ok())
                .map_or_else(|| "?".to_string(), |e| e.scene.kind().to_string());
            let last = last_task(&submissions, id);
            let (state, note) = match (store.check(id, Depth::Sizes), flying.get(id)) {
                (RunState::Complete(_), _) => (TaskState::Done, None),
                (_, Some(f)) if f.entry.state() == QueueState::Queued => {
                    (TaskState::Queued, Some(queued_note(&f.entry)))
                }
                (_, Some(_)) => (TaskState::Running, None),
                (RunState::Failed, _) => {
                    (TaskState::Failed, Some(super::failure_message(store, id)))
                }
                (RunState::Damaged(how), None) => (
                    TaskState::Pending,
                    Some(format!(
                        "damaged: {how}; the next stage run computes it again"
                    )),
                ),
                (_, None) => {
                    let note = match (&last, &squeue) {
                        (None, _) => "never submitted (a --dry-run script not yet submitted?)",
                        (Some(_), Some(_)) => {
                            "no result yet (squeue unreachable: queued, running or lost)"
                        }
                        (Some(_), None) => "left the queue without a result (cancelled or lost)",
                    };
                    (TaskState::Pending, Some(note.to_string()))
                }
            };
            // A queued or running run names the task in the queue; any other
            // the last task that held it.
            let (job, task) = match (state, flying.get(id)) {
                (TaskState::Queued | TaskState::Running, Some(f)) => {
                    (Some(f.job.clone()), Some(f.task))
                }
                _ => last.unzip(),
            };
            let submission = job
                .as_deref()
                .and_then(|j| submissions.iter().find(|x| x.job_id.as_deref() == Some(j)))
                .map_or(s.number, |x| x.number);
            runs.push(RunRow {
                id: id.clone(),
                scene,
                state,
                job,
                task,
                submission,
                note,
            });
        }
    }
    let mut counts: BTreeMap<&'static str, usize> =
        TaskState::ALL.iter().map(|s| (s.name(), 0)).collect();
    for r in &runs {
        *counts.entry(r.state.name()).or_default() += 1;
    }
    Ok(StatusReport {
        dir,
        submissions: submissions.len(),
        squeue_error: squeue,
        counts,
        runs,
    })
}

/// Why a queued run waits: Slurm's pending reason, and for one that waiting
/// does not clear, what it means.
fn queued_note(entry: &QueueEntry) -> String {
    match entry.never_starts() {
        Some(why) => format!(
            "Slurm: {} — can never start: {why}; `scancel {}` and submit again with a request \
             that fits",
            entry.reason, entry.job
        ),
        None => format!("Slurm: {}", entry.reason),
    }
}

impl StatusReport {
    /// The report as text: counts, then one line per run.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{}: {} runs in {} submissions\n ",
            self.dir.display(),
            self.runs.len(),
            self.submissions
        );
        for s in TaskState::ALL {
            out.push_str(&format!(" {} {}", s.name(), self.counts[s.name()]));
        }
        out.push('\n');
        if let Some(e) = &self.squeue_error {
            out.push_str(&format!("  (from the store only: {e})\n"));
        }
        if !self.runs.is_empty() {
            out.push_str(&format!(
                "\n{:<8} {:<12} {:<12} {:<14} {}\n",
                "state", "run", "scene", "slurm task", "note"
            ));
        }
        for r in &self.runs {
            let task = match (&r.job, r.task) {
                (Some(j), Some(t)) => format!("{j}_{t}"),
                _ => "-".to_string(),
            };
            out.push_str(&format!(
                "{:<8} {:<12} {:<12} {:<14} {}\n",
                r.state.name(),
                r.id.short(12),
                r.scene,
                task,
                r.note.as_deref().unwrap_or("")
            ));
        }
        out
    }
}
