//! The one executor seam: every stage that runs experiments (the he2019
//! batch and verify stages, the design studies' screen, rsm and verify
//! stages, `repose tradeoff`) hands them to [`outcomes::run_collect`], which
//! runs what the store does not hold complete through [`run_incomplete`] and
//! reads one typed outcome per experiment back from the store.
//!
//! Without Slurm settings, [`Executor`] runs on this machine: `jobs` worker threads take
//! runs from a shared queue; each runs its experiment inside its own
//! one-thread rayon pool, so a run is single-threaded inside (the engine's
//! results do not depend on its thread count anyway) and never steals another
//! run's work — an outer rayon pool would let a worker waiting on an inner
//! pool pick up further runs. Runs go through [`Store::run_cached`], so a
//! complete run is never repeated and a batch killed midway resumes where it
//! stopped. A failed run is recorded in its `error.json` by the store,
//! reported to the caller, and does not stop the others.
//!
//! Before any run starts, every pending experiment's run plan is made
//! ([`crate::scenes::plan`]): one whose scene and physics are inconsistent, or
//! whose estimated cost exceeds [`Executor::limits`], refuses the whole call
//! ([`ExecError::Refused`]), so a study never starts a run that cannot finish
//! or would exhaust the machine.
//!
//! The runner is a parameter so tests can inject a fast fake; commands pass
//! [`crate::scenes::run_experiment`] with the run's MCAP log, as `repose run`
//! does. With [`Executor::slurm`] set, the same pending experiments go to a
//! Slurm job array instead ([`slurm`]): each task is `repose run` on the same
//! store, so ids, results and the stages above are unchanged (the runner is
//! then not called).

pub mod outcomes;
pub mod progress;
pub mod slurm;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use crate::manifest::{ContentId, Experiment};
use crate::scenes::plan::{plan, Limits};
use crate::store::{RunDir, RunResult, RunStatus, Store};
use progress::BatchProgress;
use slurm::SlurmSettings;

/// Why experiments could not be handed to the executor.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// An executor option is invalid.
    #[error("{0}")]
    Settings(String),
    /// A pending run would not run: its scene and physics are inconsistent or
    /// its estimated cost exceeds the limits (see [`crate::scenes::plan`]);
    /// refused before any run starts.
    #[error("run {id}: refused: {reason}")]
    Refused {
        /// The experiment id.
        id: ContentId,
        /// The rules it breaks, or the estimates above their limits.
        reason: String,
    },
    /// More runs are pending than [`Executor::max_runs`] allows; refused
    /// before any run starts.
    #[error("{runs} runs to start, more than --max-runs {max_runs}; raise --max-runs to run them")]
    TooManyRuns {
        /// Pending runs.
        runs: usize,
        /// The limit.
        max_runs: u64,
    },
    /// Slurm refused or failed a request (sbatch, squeue) or its files could
    /// not be written.
    #[error("slurm: {0}")]
    Slurm(String),
    /// Slurm tasks ended without a result or an error.json (cancelled, out
    /// of time or memory, or their job script failed): the stage stops
    /// before its analysis; the next call submits those runs again.
    #[error(
        "{} Slurm task(s) ended without a result or an error.json; the stage stops \
         here and the next call submits them again:\n  {}",
        messages.len(),
        list_lost(messages)
    )]
    Lost {
        /// Why, per lost run (the task and the end of its log).
        messages: Vec<String>,
    },
    /// A task waits in Slurm's queue for a reason that waiting does not
    /// clear (e.g. `PartitionConfig`); the job is left queued.
    #[error(
        "Slurm task {task} can never start: pending reason {reason} ({why}); it stays queued: \
         cancel it with `scancel {job}` and run again with a request that fits (--cpus-per-task, \
         --mem, --time-limit, --partition, --account)"
    )]
    NeverStarts {
        /// The task (`job_task`).
        task: String,
        /// Its array job id.
        job: String,
        /// Slurm's pending reason.
        reason: String,
        /// What the reason means.
        why: String,
    },
    /// `--dry-run`: the job script is written, nothing was submitted.
    #[error(
        "wrote the job script {} for {runs} runs (--dry-run: not submitted); submit it with \
         `sbatch {}`, then run this command again to collect the results \
         (`repose status` shows where they stand)",
        script.display(),
        script.display()
    )]
    NotSubmitted {
        /// Runs the script would run.
        runs: usize,
        /// The job script.
        script: PathBuf,
    },
    /// `--no-wait`: runs are queued or running on Slurm.
    #[error(
        "{runs} runs are queued or running on Slurm (job {jobs}; files in {}); \
         `repose status` shows where they stand; run this command again once they \
         have left the queue (finished runs are never run again)",
        dir.display()
    )]
    Queued {
        /// Runs in the queue.
        runs: usize,
        /// Their Slurm job ids, comma-separated.
        jobs: String,
        /// The study's slurm directory.
        dir: PathBuf,
    },
}

/// The first five of `messages`, one per line, and how many more.
fn list_lost(messages: &[String]) -> String {
    let mut lines: Vec<String> = messages.iter().take(5).cloned().collect();
    if messages.len() > 5 {
        lines.push(format!("... and {} more", messages.len() - 5));
    }
    lines.join("\n  ")
}

impl ExecError {
    /// The runs are on their way (queued, or a script waits to be submitted):
    /// not a failure, but the stage has no results yet (exit code 3).
    pub fn is_waiting(&self) -> bool {
        matches!(
            self,
            ExecError::NotSubmitted { .. } | ExecError::Queued { .. }
        )
    }

    /// The error is in what the caller asked for (exit code 2).
    pub fn is_invalid_input(&self) -> bool {
        matches!(
            self,
            ExecError::Settings(_) | ExecError::Refused { .. } | ExecError::TooManyRuns { .. }
        )
    }
}

/// The executor: worker threads on this machine, or Slurm job arrays when
/// `slurm` is set (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Executor {
    /// Runs simulated at once (≥ 1).
    pub jobs: usize,
    /// Draw the progress bar on stderr.
    pub progress: bool,
    /// Resource limits every pending run's plan must stay within; a run beyond
    /// them refuses the whole call before anything runs.
    pub limits: Limits,
    /// Most runs one call may start (`--max-runs`): a study checks its stages'
    /// counts against it before it builds anything
    /// ([`crate::study::plan::StudySpec::check_runs`]), and
    /// [`run_incomplete`] refuses more pending runs than this.
    pub max_runs: u64,
    /// Run on Slurm instead of this machine's workers (`--executor slurm`).
    pub slurm: Option<SlurmSettings>,
}

impl Executor {
    /// This machine's pool of `jobs` workers within `limits`, with the
    /// progress bar when stderr is a terminal.
    pub fn local(jobs: usize, limits: Limits) -> Executor {
        Executor {
            jobs,
            progress: crate::scenes::protocol::progress_enabled(),
            limits,
            max_runs: DEFAULT_MAX_RUNS,
            slurm: None,
        }
    }

    /// The same executor with its Slurm files in `<study_dir>/slurm` (unless a
    /// directory was set already); a local executor is returned unchanged.
    pub fn in_study(&self, study_dir: &Path) -> Executor {
        let mut e = self.clone();
        if let Some(s) = &mut e.slurm {
            s.dir.get_or_insert_with(|| study_dir.join("slurm"));
        }
        e
    }
}

/// Default of [`Executor::max_runs`]: 10,000 runs, 44 times the largest
/// committed study (cai2024-quick, at most 226 runs by `repose stages`) and
/// a day or more of two cores at the quick profiles' cost per run;
/// `--max-runs` raises it.
pub const DEFAULT_MAX_RUNS: u64 = 10_000;

/// What [`run_incomplete`] did.
pub(crate) struct Ran {
    /// Experiments the store already held complete (not run again).
    pub cached: usize,
    /// The runs that failed: (position in the experiments, message), sorted.
    pub failures: Vec<(usize, String)>,
}

/// Runs every one of `experiments` the store does not hold complete, on
/// `settings.jobs` workers with the progress bar (when `settings.progress`)
/// counting the cached ones as done. Callers then read the results from the store.
pub(crate) fn run_incomplete<E, F>(
    experiments: &[Experiment],
    store: &Store,
    settings: &Executor,
    runner: &F,
) -> Result<Ran, ExecError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    if settings.jobs == 0 {
        return Err(ExecError::Settings("--jobs = 0: must be >= 1".to_string()));
    }
    let pending: Vec<usize> = (0..experiments.len())
        .filter(|&i| store.status(&experiments[i].id()) != RunStatus::Complete)
        .collect();
    if pending.len() as u64 > settings.max_runs {
        return Err(ExecError::TooManyRuns {
            runs: pending.len(),
            max_runs: settings.max_runs,
        });
    }
    for &i in &pending {
        let refuse = |reason: String| ExecError::Refused {
            id: experiments[i].id(),
            reason,
        };
        plan(&experiments[i])
            .map_err(|errors| refuse(errors.to_string()))?
            .check(&settings.limits)
            .map_err(|excess| refuse(excess.to_string()))?;
    }
    let cached = experiments.len() - pending.len();
    let mut progress = BatchProgress::new(settings.progress, experiments.len(), cached);
    let failures = match &settings.slurm {
        // Nothing to run: no executor is asked (a batch whose runs are all
        // stored answers from the store even when squeue is unreachable).
        _ if pending.is_empty() => Vec::new(),
        Some(slurm) => slurm::run(&pending, experiments, store, settings, slurm, &mut progress)?,
        None => run_pending(
            &pending,
            experiments,
            store,
            settings.jobs,
            runner,
            &mut progress,
        )?,
    };
    progress.finish();
    Ok(Ran { cached, failures })
}

/// Runs the pending experiments on `jobs` workers; returns the failures as
/// (position in the experiments, message), sorted.
fn run_pending<E, F>(
    pending: &[usize],
    experiments: &[Experiment],
    store: &Store,
    jobs: usize,
    runner: &F,
    progress: &mut BatchProgress,
) -> Result<Vec<(usize, String)>, ExecError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let next = AtomicUsize::new(0);
    let (sender, receiver) = mpsc::channel::<(usize, Result<(), String>)>();
    let mut failures = Vec::new();
    std::thread::scope(|scope| -> Result<(), ExecError> {
        let mut workers = Vec::new();
        for _ in 0..jobs.min(pending.len()) {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .map_err(|e| ExecError::Settings(format!("cannot start a worker: {e}")))?;
            let sender = sender.clone();
            let next = &next;
            workers.push(scope.spawn(move || loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&i) = pending.get(k) else { break };
                let outcome = pool.install(|| {
                    store
                        .run_cached(&experiments[i], runner)
                        .map(|_| ())
                        .map_err(|e| crate::errors::chain(&e))
                });
                if sender.send((i, outcome)).is_err() {
                    break;
                }
            }));
        }
        drop(sender);
        loop {
            match receiver.recv_timeout(Duration::from_millis(500)) {
                Ok((i, outcome)) => {
                    progress.finished_one(outcome.is_err());
                    if let Err(message) = outcome {
                        failures.push((i, message));
                    }
                }
                Err(RecvTimeoutError::Timeout) => progress.tick(),
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        Ok(())
    })?;
    failures.sort();
    Ok(failures)
}
