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
}

/// The `squeue` output format [`parse_squeue`] reads.
pub const SQUEUE_FORMAT: &str = "%F|%K|%j|%T";

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
            let parts: Vec<&str> = line.trim().splitn(4, '|').collect();
            let [job, task, name, state] = parts[..] else {
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

/// Submits `script` with `sbatch --parsable`; returns the job id.
pub fn submit(script: &Path) -> Result<String, ExecError> {
    let text = command_output(
        "sbatch",
        Command::new("sbatch").arg("--parsable").arg(script),
    )?;
    // `--parsable` prints `<job id>` or `<job id>;<cluster>`.
    let id = text
        .trim()
        .split(';')
        .next()
        .unwrap_or_default()
        .to_string();
    if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
        return Err(ExecError::Slurm(format!(
            "sbatch printed `{}`, not a job id",
            text.trim()
        )));
    }
    Ok(id)
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
            "17|1|repose-ab|PENDING\n17|0|repose-ab|RUNNING\n18|N/A|other|RUNNING\n\n\
             19|3|repose-cd|COMPLETING\n",
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
    fn unexpected_squeue_output_is_an_error() {
        assert!(Queue::parse("17|x|n|PENDING").unwrap_err().contains("`x`"));
        assert!(Queue::parse("garbage").unwrap_err().contains("garbage"));
    }
}
