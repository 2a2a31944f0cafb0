//! Talking to Slurm: `sbatch --parsable` to submit, `squeue` to see what is
//! queued or running. Never `sbatch --wait`: it polls with a back-off of up to
//! half a minute, and a client waiting inside it cannot report progress.
//!
//! `squeue` forgets a job once it has left the queue, so "not in squeue"
//! means "finished, one way or another"; the store then says which way
//! (a sealed result, an `error.json`, or neither: cancelled, out of time or
//! killed before `repose` could record anything).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use super::super::ExecError;

/// Where one array task stands in Slurm's queue.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum QueueState {
    /// Waiting for resources, a dependency, the array throttle or a hold.
    Queued,
    /// Allocated: starting, running or completing.
    Running,
}

/// One line of `squeue`: an array task (or a plain job, `task` = `None`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct QueueEntry {
    /// The array's job id (`%F`).
    pub job: String,
    /// The array task index (`%K`).
    pub task: Option<usize>,
    /// The job name (`%j`).
    pub name: String,
    /// Slurm's state name (`%T`), e.g. `PENDING`, `RUNNING`.
    pub slurm_state: String,
    /// Why a pending task waits (`%r`: `Resources`, `Priority`,
    /// `JobArrayTaskLimit`, `PartitionConfig`, …; `None` when running).
    pub reason: String,
}

impl QueueEntry {
    /// Queued or running: Slurm's pending-like states are queued, everything
    /// else still listed (running, configuring, completing, …) is running.
    pub fn state(&self) -> QueueState {
        match self.slurm_state.as_str() {
            "PENDING" | "REQUEUED" | "REQUEUE_HOLD" | "REQUEUE_FED" | "SUSPENDED"
            | "RESV_DEL_HOLD" => QueueState::Queued,
            _ => QueueState::Running,
        }
    }

    /// Why a queued task can never start, when Slurm's pending reason is
    /// one that waiting does not clear ([`NEVER_CLEARS`]); `None` otherwise.
    pub fn never_starts(&self) -> Option<&'static str> {
        if self.state() != QueueState::Queued {
            return None;
        }
        NEVER_CLEARS
            .iter()
            .find(|(reason, _)| self.reason.starts_with(reason))
            .map(|(_, why)| *why)
    }
}

/// Pending reasons that waiting does not clear, with what they mean: the
/// request does not fit the partition or the account as configured, so the
/// client stops waiting and says so instead of polling for ever (issue 40).
/// `ReqNodeNotAvail` (the nodes the job needs are down or drained) may clear
/// when an administrator brings them back; the job is left queued either way.
pub const NEVER_CLEARS: [(&str, &str); 8] = [
    (
        "PartitionConfig",
        "the request (CPUs, memory or nodes per task) exceeds what the partition's nodes have",
    ),
    (
        "PartitionNodeLimit",
        "the request needs more nodes than the partition allows",
    ),
    (
        "PartitionTimeLimit",
        "the time limit exceeds the partition's",
    ),
    ("BadConstraints", "no node satisfies the job's constraints"),
    (
        "ReqNodeNotAvail",
        "the nodes the job needs are down, drained or reserved",
    ),
    ("InvalidAccount", "the account is not valid"),
    ("InvalidQOS", "the QOS is not valid"),
    (
        "AccountNotAllowed",
        "the account may not use this partition",
    ),
];

/// The `squeue` output format [`Queue::parse`] reads.
pub const SQUEUE_FORMAT: &str = "%F|%K|%j|%T|%r";

/// A snapshot of this user's jobs in the queue, by (array job id, task).
#[derive(Debug, Clone, Default)]
pub struct Queue {
    entries: BTreeMap<(String, usize), QueueEntry>,
}

impl Queue {
    /// The entries parsed from `squeue -h -r -o` [`SQUEUE_FORMAT`] output.
    pub fn parse(text: &str) -> Result<Queue, String> {
        let mut entries = BTreeMap::new();
        for line in text.lines().filter(|l| !l.trim().is_empty()) {
            let parts: Vec<&str> = line.trim().splitn(5, '|').collect();
            let [job, task, name, state, reason] = parts[..] else {
                return Err(format!("unexpected squeue line `{line}`"));
            };
            let task = match task {
                "N/A" => None,
                t => Some(
                    t.parse::<usize>()
                        .map_err(|_| format!("unexpected array task `{t}` in `{line}`"))?,
                ),
            };
            let entry = QueueEntry {
                job: job.to_string(),
                task,
                name: name.to_string(),
                slurm_state: state.to_string(),
                reason: reason.to_string(),
            };
            if let Some(t) = task {
                entries.insert((entry.job.clone(), t), entry);
            }
        }
        Ok(Queue { entries })
    }

    /// The entry of task `task` of array job `job`, if it is in the queue.
    pub fn task(&self, job: &str, task: usize) -> Option<&QueueEntry> {
        self.entries.get(&(job.to_string(), task))
    }

    /// The array job id of a job named `name`, if one is in the queue.
    pub fn job_named(&self, name: &str) -> Option<&str> {
        self.entries
            .values()
            .find(|e| e.name == name)
            .map(|e| e.job.as_str())
    }
}

/// This user's array tasks now in the queue (`squeue --me -h -r`).
pub fn snapshot() -> Result<Queue, ExecError> {
    let text = command_output(
        "squeue",
        Command::new("squeue").args(["--me", "-h", "-r", "-o", SQUEUE_FORMAT]),
    )?;
    Queue::parse(&text).map_err(ExecError::Slurm)
}

/// Submits `script` with `sbatch --parsable`; returns the job id. sbatch
/// exiting non-zero is [`Submitted::Refused`] with its message: no job
/// exists then, so the caller may forget the submission.
pub fn submit(script: &Path) -> Result<String, Submitted> {
    let output = Command::new("sbatch")
        .arg("--parsable")
        .arg(script)
        .output()
        .map_err(|e| {
            Submitted::Failed(ExecError::Slurm(format!(
                "cannot run `sbatch` ({e}): is Slurm's client installed and on PATH? \
                 (scripts/slurm-local.sh up starts a one-node Slurm here)"
            )))
        })?;
    if !output.status.success() {
        return Err(Submitted::Refused(
            String::from_utf8_lossy(&output.stderr).trim().to_string(),
        ));
    }
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    // `--parsable` prints `<job id>` or `<job id>;<cluster>`.
    let id = text
        .trim()
        .split(';')
        .next()
        .unwrap_or_default()
        .to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(Submitted::Failed(ExecError::Slurm(format!(
            "sbatch printed `{}`, not a job id",
            text.trim()
        ))));
    }
    Ok(id)
}

/// Why [`submit`] has no job id.
#[derive(Debug)]
pub enum Submitted {
    /// sbatch exited non-zero (bad options, a partition that does not
    /// exist, more memory than a node has): no job was made. Its stderr.
    Refused(String),
    /// sbatch could not be run, or printed no job id (a job may exist).
    Failed(ExecError),
}

/// Runs `command` and returns its stdout; an error names the program and
/// carries its stderr.
fn command_output(program: &str, command: &mut Command) -> Result<String, ExecError> {
    let output = command.output().map_err(|e| {
        ExecError::Slurm(format!(
            "cannot run `{program}` ({e}): is Slurm's client installed and on PATH? \
             (scripts/slurm-local.sh up starts a one-node Slurm here)"
        ))
    })?;
    if !output.status.success() {
        return Err(ExecError::Slurm(format!(
            "`{program}` failed ({}): {}",
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&output.stdout).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_are_read_per_array_task() {
        let q = Queue::parse(
            "17|1|repose-ab|PENDING|Resources\n17|0|repose-ab|RUNNING|None\n\
             18|N/A|other|RUNNING|None\n\n19|3|repose-cd|COMPLETING|None\n",
        )
        .unwrap();
        assert_eq!(q.task("17", 0).unwrap().state(), QueueState::Running);
        assert_eq!(q.task("17", 1).unwrap().state(), QueueState::Queued);
        assert_eq!(q.task("19", 3).unwrap().state(), QueueState::Running);
        assert!(q.task("17", 2).is_none());
        assert!(q.task("18", 0).is_none(), "a plain job is no array task");
        assert_eq!(q.job_named("repose-cd"), Some("19"));
        assert_eq!(q.job_named("repose-zz"), None);
    }

    #[test]
    fn reasons_that_never_clear_are_told_from_waiting_ones() {
        let q = Queue::parse(
            "20|0|r|PENDING|PartitionConfig\n20|1|r|PENDING|Resources\n\
             20|2|r|PENDING|ReqNodeNotAvail, UnavailableNodes:n1\n20|3|r|RUNNING|None\n",
        )
        .unwrap();
        assert!(q
            .task("20", 0)
            .unwrap()
            .never_starts()
            .unwrap()
            .contains("partition"));
        assert_eq!(q.task("20", 1).unwrap().never_starts(), None);
        assert!(q.task("20", 2).unwrap().never_starts().is_some());
        assert_eq!(q.task("20", 3).unwrap().never_starts(), None);
    }

    #[test]
    fn unexpected_squeue_output_is_an_error() {
        assert!(Queue::parse("17|x|n|PENDING|None")
            .unwrap_err()
            .contains("`x`"));
        assert!(Queue::parse("17|1|n|PENDING")
            .unwrap_err()
            .contains("PENDING"));
        assert!(Queue::parse("garbage").unwrap_err().contains("garbage"));
    }
}
