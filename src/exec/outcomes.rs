//! The one runs adapter: experiments in, one typed outcome per experiment
//! out, in the experiments' order. Every stage that runs experiments calls
//! [`run_collect`] and builds its own table from the outcomes, so no stage
//! gathers results its own way or tells failures apart by their message.
//!
//! A run that failed before is not handed to the executor again unless the
//! caller asks ([`Retry::Failed`]): its `error.json` already says why (a pile
//! that is not measurable stays so), and the noise-aware stages re-read many
//! points on every batch. A damaged run (its seal no longer matches its
//! files) is run again by the store, as any run that is not complete.

use super::{run_incomplete, ExecError, Executor, Ran};
use crate::manifest::Experiment;
use crate::store::{RunDir, RunResult, RunState, RunStatus, Store};

/// Whether runs that failed before are run again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Retry {
    /// Every run not complete is run (a failed run is retried).
    Failed,
    /// Runs that failed before are left as they are (their `error.json`
    /// stands); the rest are run.
    NotFailed,
}

/// What became of one experiment handed to [`run_collect`].
#[derive(Debug, Clone)]
pub enum RunOutcome {
    /// Complete (now or before), its seal checked against every file.
    Complete(Box<RunResult>),
    /// The runner failed in this call: its message (`error.json` holds the
    /// whole record).
    FailedNow(String),
    /// Not complete, and not run by this call or not found complete after
    /// it: the store's state (failed before and not retried, damaged,
    /// incomplete or missing).
    Stored(RunState),
}

impl RunOutcome {
    /// The result of a complete run.
    pub fn result(&self) -> Option<&RunResult> {
        match self {
            RunOutcome::Complete(r) => Some(r),
            _ => None,
        }
    }

    /// The run's status (a run that failed now is failed).
    pub fn status(&self) -> RunStatus {
        match self {
            RunOutcome::Complete(_) => RunStatus::Complete,
            RunOutcome::FailedNow(_) => RunStatus::Failed,
            RunOutcome::Stored(state) => state.status(),
        }
    }
}

/// What [`run_collect`] did.
#[derive(Debug, Clone)]
pub struct Collected {
    /// One outcome per experiment, in their order.
    pub outcomes: Vec<RunOutcome>,
    /// Experiments the store held complete before the call.
    pub cached: usize,
    /// Experiments left as failed before ([`Retry::NotFailed`]).
    pub skipped: usize,
}

impl Collected {
    /// Runs this call simulated that failed.
    pub fn failed_now(&self) -> usize {
        self.outcomes
            .iter()
            .filter(|o| matches!(o, RunOutcome::FailedNow(_)))
            .count()
    }
}

/// Runs the `experiments` the store does not hold complete (all but those
/// that failed before, with [`Retry::NotFailed`]) through the executor
/// ([`run_incomplete`]) and reads every one's outcome back from the store.
pub fn run_collect<E, F>(
    experiments: &[Experiment],
    store: &Store,
    pool: &Executor,
    runner: &F,
    retry: Retry,
) -> Result<Collected, ExecError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let handed: Vec<usize> = (0..experiments.len())
        .filter(|&i| {
            retry == Retry::Failed || store.status(&experiments[i].id()) != RunStatus::Failed
        })
        .collect();
    let pending: Vec<Experiment> = handed.iter().map(|&i| experiments[i].clone()).collect();
    let Ran { cached, failures } = run_incomplete(&pending, store, pool, runner)?;
    let mut failed_now: Vec<Option<String>> = vec![None; experiments.len()];
    for (k, message) in failures {
        failed_now[handed[k]] = Some(message);
    }
    let outcomes = experiments
        .iter()
        .zip(failed_now)
        .map(|(e, failed)| match failed {
            Some(message) => RunOutcome::FailedNow(message),
            None => match store.check(&e.id(), crate::store::Depth::Full) {
                RunState::Complete(result) => RunOutcome::Complete(result),
                other => RunOutcome::Stored(other),
            },
        })
        .collect();
    Ok(Collected {
        outcomes,
        cached,
        skipped: experiments.len() - handed.len(),
    })
}
