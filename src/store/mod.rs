//! The content-addressed run store.
//!
//! Layout under the root (default `./runs`, set by `--store` or `REPOSE_STORE`):
//!
//! ```text
//! runs/<id>/manifest.json   the experiment's canonical JSON (sha256 of the file = id)
//! runs/<id>/result.json     the result
//! runs/<id>/run.mcap        the run's log (written by the engine side)
//! runs/<id>/seal.json       sizes and sha256 of the three files above, written last
//! runs/<id>/error.json      why the run failed (a failed run never has a seal)
//! runs/<id>/timing.json     wall-clock time of the run (non-deterministic, not sealed)
//! runs/<id>/.claim          the lock a computing process holds (see [`claim`])
//! ```
//!
//! Every file is written atomically ([`write_atomic`]), so an interrupted run never
//! leaves anything that looks complete. A run is complete exactly when its seal
//! exists and its files still match it ([`seal`]); a complete run is a cache
//! hit, a run whose files no longer match is *damaged*: reported as such and
//! recomputed when it is run again, never reused. Only the process holding a
//! run's claim computes it, so two processes asking for one run simulate it
//! once.

mod atomic;
pub mod claim;
pub mod cpu_time;
pub mod lineage;
mod lookup;
pub mod result;
pub mod seal;

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::de::DeserializeOwned;

pub use atomic::{
    remove_old_temps, remove_stale_temps, write_atomic, AtomicFile, STALE_TEMP_AGE, TEMP_PREFIX,
};
pub use lineage::{InputRef, Lineage};
pub use lookup::{runs_line, RunSummary};
pub use result::{
    CoarseGrainingReport, ErrorRecord, ResolutionFigure, RunResult, TimingRecord, Trace,
    HEADLINE_KEY,
};
pub use seal::{Depth, Seal, SEAL_FILE};

use crate::manifest::{
    canonical_json, validate_experiment, ContentId, Experiment, ValidationErrors,
};

/// File names inside a run directory.
pub const MANIFEST_FILE: &str = "manifest.json";
/// See [`MANIFEST_FILE`].
pub const RESULT_FILE: &str = "result.json";
/// See [`MANIFEST_FILE`].
pub const MCAP_FILE: &str = "run.mcap";
/// See [`MANIFEST_FILE`].
pub const ERROR_FILE: &str = "error.json";
/// See [`MANIFEST_FILE`].
pub const TIMING_FILE: &str = "timing.json";

/// Environment variable naming the store root.
pub const STORE_ENV: &str = "REPOSE_STORE";
/// Store root used when neither `--store` nor [`STORE_ENV`] is given.
pub const DEFAULT_STORE: &str = "runs";

/// Errors of the store.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// A stored JSON file does not parse (it was changed outside repose).
    #[error("{}: corrupt store file: {message}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// The parse error.
        message: String,
    },
    /// A run's files no longer match its seal (edited, truncated or deleted
    /// outside repose).
    #[error("run {id} is damaged: {problem} (run it again to recompute it)")]
    Damaged {
        /// The run.
        id: ContentId,
        /// What does not match, naming the file.
        problem: String,
    },
    /// A runner returned a result for another experiment.
    #[error("the runner returned a result for {found}, expected {expected}")]
    ResultMismatch {
        /// The experiment being run.
        expected: ContentId,
        /// The id inside the returned result.
        found: ContentId,
    },
    /// An id prefix is empty or not lowercase hex.
    #[error("`{prefix}` is not an id prefix (lowercase hex digits expected)")]
    BadPrefix {
        /// The prefix given.
        prefix: String,
    },
    /// No run id starts with the prefix.
    #[error("no run in {} has an id starting with `{prefix}`", root.display())]
    NoMatch {
        /// The prefix given.
        prefix: String,
        /// The store root searched.
        root: PathBuf,
    },
    /// Several run ids start with the prefix.
    #[error(
        "`{prefix}` is ambiguous; it matches:\n{}",
        candidates.iter().map(|c| format!("  {c}")).collect::<Vec<_>>().join("\n")
    )]
    Ambiguous {
        /// The prefix given.
        prefix: String,
        /// Every matching id.
        candidates: Vec<ContentId>,
    },
}

impl StoreError {
    /// True when the user's input (a prefix) is at fault rather than the store.
    pub fn is_invalid_input(&self) -> bool {
        matches!(
            self,
            StoreError::BadPrefix { .. }
                | StoreError::NoMatch { .. }
                | StoreError::Ambiguous { .. }
        )
    }

    /// Wraps an I/O error on `path` (for `map_err`).
    pub fn io(path: &Path) -> impl FnOnce(io::Error) -> StoreError + '_ {
        move |source| StoreError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Errors of [`Store::run_cached`].
#[derive(Debug, thiserror::Error)]
pub enum RunError<E: std::error::Error + 'static> {
    /// The experiment failed validation; nothing was written.
    #[error("invalid experiment:\n{0}")]
    Invalid(ValidationErrors),
    /// The store itself failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The runner failed; error.json records why.
    #[error("{error}")]
    Runner {
        /// The runner's error.
        #[source]
        error: E,
        /// Set when even error.json could not be written.
        record_failure: Option<StoreError>,
    },
    /// The runner returned a result that cannot be stored; error.json records why.
    #[error("the run produced an unusable result: {0}")]
    BadResult(String),
}

/// Where a run's result came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CacheOutcome {
    /// A complete run already existed; the runner was not called.
    Hit,
    /// The runner was called and its result stored.
    Computed,
}

/// State of a run directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum RunStatus {
    /// No directory for this id.
    Missing,
    /// A directory without seal or error: running, or interrupted.
    Incomplete,
    /// error.json and no seal.
    Failed,
    /// A seal whose files no longer match it.
    Damaged,
    /// A seal that every file matches.
    Complete,
}

impl fmt::Display for RunStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RunStatus::Missing => "missing",
            RunStatus::Incomplete => "incomplete",
            RunStatus::Failed => "failed",
            RunStatus::Damaged => "damaged",
            RunStatus::Complete => "complete",
        })
    }
}

/// The directory of one run and the paths of its files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunDir {
    id: ContentId,
    path: PathBuf,
}

impl RunDir {
    /// The run's experiment id.
    pub fn id(&self) -> &ContentId {
        &self.id
    }
    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }
    /// `manifest.json`.
    pub fn manifest_path(&self) -> PathBuf {
        self.path.join(MANIFEST_FILE)
    }
    /// `result.json`.
    pub fn result_path(&self) -> PathBuf {
        self.path.join(RESULT_FILE)
    }
    /// `run.mcap`.
    pub fn mcap_path(&self) -> PathBuf {
        self.path.join(MCAP_FILE)
    }
    /// `error.json`.
    pub fn error_path(&self) -> PathBuf {
        self.path.join(ERROR_FILE)
    }
    /// `timing.json`.
    pub fn timing_path(&self) -> PathBuf {
        self.path.join(TIMING_FILE)
    }
    /// `seal.json`.
    pub fn seal_path(&self) -> PathBuf {
        self.path.join(SEAL_FILE)
    }
}

/// What [`Store::check`] found in a run directory.
#[derive(Debug, Clone, PartialEq)]
pub enum RunState {
    /// No directory for this id.
    Missing,
    /// A directory without seal or error: running, or interrupted.
    Incomplete,
    /// The run failed (error.json, no seal).
    Failed,
    /// The seal does not match the files; the text says how, naming the file.
    Damaged(String),
    /// Sealed and intact, with its result.
    Complete(Box<RunResult>),
}

impl RunState {
    /// The state without its data.
    pub fn status(&self) -> RunStatus {
        match self {
            RunState::Missing => RunStatus::Missing,
            RunState::Incomplete => RunStatus::Incomplete,
            RunState::Failed => RunStatus::Failed,
            RunState::Damaged(_) => RunStatus::Damaged,
            RunState::Complete(_) => RunStatus::Complete,
        }
    }
}

/// Receives the store's notices to the user (a run found damaged, a wait for
/// another process's claim); the CLI prints them on stderr.
pub type Notices = Arc<dyn Fn(&str) + Send + Sync>;

/// The directory of study `name` with id `id` in the store at `root`:
/// `studies/<name>-<first 12 hex of the id>` (he2019 and design studies alike).
pub fn study_dir_path(root: &Path, name: &str, id: &ContentId) -> PathBuf {
    root.join("studies")
        .join(format!("{name}-{}", id.short(12)))
}

/// Test-only fault injection: called between temp write and rename of every file.
#[cfg(test)]
type FaultHook = Box<dyn Fn(&Path) -> io::Result<()> + Send + Sync>;

/// A run store rooted at a directory.
pub struct Store {
    root: PathBuf,
    notices: Option<Notices>,
    #[cfg(test)]
    fault: Option<FaultHook>,
}

impl fmt::Debug for Store {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Store").field("root", &self.root).finish()
    }
}

impl Store {
    /// Opens (creating if needed) the store at `root`.
    pub fn open(root: impl Into<PathBuf>) -> Result<Store, StoreError> {
        let root = root.into();
        std::fs::create_dir_all(&root).map_err(StoreError::io(&root))?;
        Ok(Store {
            root,
            notices: None,
            #[cfg(test)]
            fault: None,
        })
    }

    /// The same store, sending its notices to `notices`.
    pub fn with_notices(mut self, notices: Notices) -> Store {
        self.notices = Some(notices);
        self
    }

    fn notice(&self, text: &str) {
        if let Some(n) = &self.notices {
            n(text);
        }
    }

    /// The store's root directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Run `id`'s `timing.json` ([`TimingRecord`]), if it has a readable
    /// one (a run computed here; failed, foreign and damaged runs may not):
    /// the one reader of what a run cost.
    pub fn timing(&self, id: &ContentId) -> Option<TimingRecord> {
        Store::read_json(&self.run_dir(id).timing_path()).ok()
    }

    /// The directory of run `id` (whether or not it exists).
    pub fn run_dir(&self, id: &ContentId) -> RunDir {
        RunDir {
            id: id.clone(),
            path: self.root.join(id.as_str()),
        }
    }

    /// The state of run `id`, checking its files against its seal to `depth`.
    pub fn check(&self, id: &ContentId, depth: Depth) -> RunState {
        let dir = self.run_dir(id);
        let seal_path = dir.seal_path();
        if seal_path.is_file() {
            let checked = Self::read_json::<Seal>(&seal_path)
                .map_err(|e| e.to_string())
                .and_then(|s| seal::check(&dir, &s, depth));
            match checked {
                Ok(result) => RunState::Complete(Box::new(result)),
                Err(problem) => RunState::Damaged(problem),
            }
        } else if dir.error_path().is_file() {
            RunState::Failed
        } else if dir.path().is_dir() {
            RunState::Incomplete
        } else {
            RunState::Missing
        }
    }

    /// The state of run `id`, every sealed file hashed ([`Depth::Full`]).
    pub fn status(&self, id: &ContentId) -> RunStatus {
        self.check(id, Depth::Full).status()
    }

    /// Writes a file atomically (see [`write_atomic`]).
    pub fn write_atomic(&self, path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
        #[cfg(test)]
        let written = match &self.fault {
            Some(hook) => atomic::write_atomic_with(path, bytes, hook),
            None => write_atomic(path, bytes),
        };
        #[cfg(not(test))]
        let written = write_atomic(path, bytes);
        written.map_err(StoreError::io(path))
    }

    fn write_json<T: serde::Serialize>(&self, path: &Path, value: &T) -> Result<(), StoreError> {
        let mut bytes = serde_json::to_vec_pretty(value).map_err(|e| StoreError::Corrupt {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        bytes.push(b'\n');
        self.write_atomic(path, &bytes)
    }

    /// Reads and parses a JSON file of the store.
    pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T, StoreError> {
        let bytes = std::fs::read(path).map_err(StoreError::io(path))?;
        serde_json::from_slice(&bytes).map_err(|e| StoreError::Corrupt {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }

    /// Reads and parses a JSON file of the store, if it exists.
    fn read_json_if_present<T: DeserializeOwned>(path: &Path) -> Result<Option<T>, StoreError> {
        if path.is_file() {
            Self::read_json(path).map(Some)
        } else {
            Ok(None)
        }
    }

    /// The stored result of run `id` if it is complete (its files checked
    /// against its seal), `None` if it is not; an error if it is damaged.
    pub fn load_result(&self, id: &ContentId) -> Result<Option<RunResult>, StoreError> {
        match self.check(id, Depth::Full) {
            RunState::Complete(result) => Ok(Some(*result)),
            RunState::Damaged(problem) => Err(StoreError::Damaged {
                id: id.clone(),
                problem,
            }),
            _ => Ok(None),
        }
    }

    /// The results of the completed runs among `ids` (an incomplete or failed
    /// run has none); fails on a damaged one, as [`Store::load_result`].
    pub fn load_results<'a>(
        &self,
        ids: impl IntoIterator<Item = &'a ContentId>,
    ) -> Result<Vec<RunResult>, StoreError> {
        let mut results = Vec::new();
        for id in ids {
            results.extend(self.load_result(id)?);
        }
        Ok(results)
    }

    /// The stored manifest of run `id` (parsed, not re-validated: a manifest of an
    /// older physics version still loads for listing).
    pub fn load_manifest(&self, id: &ContentId) -> Result<Experiment, StoreError> {
        Self::read_json(&self.run_dir(id).manifest_path())
    }

    /// The stored error record of run `id`, if it failed.
    pub fn load_error(&self, id: &ContentId) -> Result<Option<ErrorRecord>, StoreError> {
        Self::read_json_if_present(&self.run_dir(id).error_path())
    }

    /// Runs `experiment` unless a complete run with its id exists.
    ///
    /// On a cache hit (a seal that every file matches) the stored result is
    /// returned and `runner` is not called. Else the run is claimed (waiting
    /// while another process holds the claim, then reusing its result if it
    /// finished), a damaged run's seal is removed with a notice, temp files
    /// left by killed writers are removed, the canonical manifest is written,
    /// `runner` is called with the run directory (where it may write
    /// run.mcap), and its result is stored (timing.json, result.json, then
    /// seal.json last, all atomic). If the runner fails, error.json records why
    /// and no seal is written. The experiment is validated first.
    pub fn run_cached<E, F>(
        &self,
        experiment: &Experiment,
        runner: F,
    ) -> Result<(RunResult, CacheOutcome), RunError<E>>
    where
        E: std::error::Error + 'static,
        F: FnOnce(&Experiment, &RunDir) -> Result<RunResult, E>,
    {
        validate_experiment(experiment).map_err(RunError::Invalid)?;
        let id = experiment.id();
        let dir = self.run_dir(&id);
        if let RunState::Complete(result) = self.check(&id, Depth::Full) {
            return Ok((*result, CacheOutcome::Hit));
        }
        std::fs::create_dir_all(dir.path()).map_err(StoreError::io(dir.path()))?;
        let _claim = claim::claim(dir.path(), || {
            self.notice(&format!(
                "run {}: another process is computing it; waiting for its result",
                id.short(12)
            ))
        })
        .map_err(StoreError::io(&dir.path().join(claim::CLAIM_FILE)))?;
        match self.check(&id, Depth::Full) {
            RunState::Complete(result) => return Ok((*result, CacheOutcome::Hit)),
            RunState::Damaged(problem) => {
                self.notice(&format!(
                    "run {} is damaged ({problem}); recomputing it",
                    id.short(12)
                ));
                remove_if_present(&dir.seal_path())?;
                remove_if_present(&dir.result_path())?;
            }
            _ => {}
        }
        remove_stale_temps(dir.path()).map_err(StoreError::io(dir.path()))?;
        self.write_atomic(&dir.manifest_path(), canonical_json(experiment).as_bytes())?;
        remove_if_present(&dir.error_path())?;

        let started = Instant::now();
        let cpu_started = cpu_time::thread_cpu_s();
        let outcome = runner(experiment, &dir);
        let wall_time_s = started.elapsed().as_secs_f64();
        let thread_cpu_s = cpu_time::thread_cpu_s()
            .zip(cpu_started)
            .map(|(end, start)| end - start);
        match outcome {
            Ok(result) => {
                if result.id != id {
                    return Err(StoreError::ResultMismatch {
                        expected: id,
                        found: result.id,
                    }
                    .into());
                }
                if let Some(defect) = result.defect() {
                    // error.json holds the message a local caller sees, so a
                    // Slurm client reading it back reports the same words.
                    let error = RunError::BadResult(defect);
                    self.record_error(&id, &error.to_string(), Vec::new())?;
                    return Err(error);
                }
                self.write_json(
                    &dir.timing_path(),
                    &TimingRecord {
                        wall_time_s,
                        thread_cpu_s,
                    },
                )?;
                self.write_json(&dir.result_path(), &result)?;
                let seal = seal::seal_of(&dir).map_err(StoreError::io(dir.path()))?;
                self.write_json(&dir.seal_path(), &seal)?;
                Ok((result, CacheOutcome::Computed))
            }
            Err(error) => {
                let mut causes = Vec::new();
                let mut source = std::error::Error::source(&error);
                while let Some(s) = source {
                    causes.push(s.to_string());
                    source = s.source();
                }
                let record_failure = self.record_error(&id, &error.to_string(), causes).err();
                Err(RunError::Runner {
                    error,
                    record_failure,
                })
            }
        }
    }

    fn record_error(
        &self,
        id: &ContentId,
        error: &str,
        causes: Vec<String>,
    ) -> Result<(), StoreError> {
        let record = ErrorRecord {
            id: id.clone(),
            error: error.to_string(),
            causes,
        };
        self.write_json(&self.run_dir(id).error_path(), &record)
    }
}

fn remove_if_present(path: &Path) -> Result<(), StoreError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(StoreError::io(path)(e)),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests;
