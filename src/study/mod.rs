//! Studies as data: a study is design → experiments (× replicates) → one
//! executor → a response table → an analysis → reports, each stage cached in
//! the store and recorded with lineage.
//!
//! Where a thing lives says what it is:
//! - [`plan`]: what a study is — a study file read once ([`plan::StudyFile`])
//!   and lowered to its method and stage list ([`plan::StudySpec`]); the
//!   design-study manifest ([`plan::design_study`]) and what he2019's study
//!   shares ([`plan::calibration`]: parameter scaling, the acceptance record).
//! - [`stages`]: one file per stage of a method's list, named as `repose
//!   stages` prints it (noise, design, simulate, fit, fine, adaptive, search,
//!   screen, rsm, sensitivity, verify).
//! - [`sweeps`]: one experiment, no study file — the noise floor over
//!   packing seeds, the fidelity tradeoff, particle-size convergence and the
//!   two-level pilot.
//! - [`analyses`]: read a finished study or a table — learning curve,
//!   held-out fine runs, the verdict table.
//! - [`run`]: the one driver, walking a plan's stage list;
//!   [`records`]: what a stage wrote that a later one reads, read back
//!   through the layout.
//! - [`runs`]: points × replicates × scenes → [`crate::exec`] → a response
//!   table; [`acceptance`]: the one acceptance rule; [`verification`]: a
//!   design study's named points re-simulated and judged by it (the step
//!   `verify` and `sensitivity` share); [`dir`]: the one layout
//!   of a study's outputs and the stage-name vocabulary; [`pipeline`]: a
//!   he2019 calibration's whole list and its outcome record.
//!
//! The runs stay in the store (`<store>/<id>/`), so a run shared by two
//! stages or studies is simulated once, and a killed stage resumes.

pub mod acceptance;
pub mod analyses;
pub mod dir;
pub mod pipeline;
pub mod plan;
pub mod records;
pub mod run;
pub mod runs;
pub mod stages;
pub mod sweeps;
pub mod verification;

use std::path::Path;

use crate::exec::{ExecError, Executor};
use crate::manifest::{Experiment, ValidationErrors};
use crate::store::{RunDir, RunResult, Store, StoreError};
use plan::design_study::DesignStudy;
use plan::Analysis;
use run::{Env, Plan, StageOutcome, Upto};
use stages::sensitivity::Levels;

/// Why a study stage failed: the one error of every study stage (he2019's
/// calibration stages, the design studies, the tradeoff sweep).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The stage this one reads has not run.
    #[error("{} does not exist: run `repose {stage} {}` first", missing.display(), study.display())]
    MissingStage {
        /// The file that should exist.
        missing: std::path::PathBuf,
        /// The stage that writes it (its subcommand).
        stage: String,
        /// The study manifest, as given.
        study: std::path::PathBuf,
    },
    /// The study asks for something these stages do not do.
    #[error("{0}")]
    Unsupported(String),
    /// A stage file is inconsistent with the others (changed outside repose).
    #[error("{}: {message}", path.display())]
    Inconsistent {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A surrogate could not be trained (bad settings or too few rows).
    #[error(transparent)]
    Train(#[from] crate::surrogate::ga_bp::TrainError),
    /// The search kept no point.
    #[error("{0}")]
    NothingKept(String),
    /// A stage option or the study's content does not allow the stage.
    #[error("{0}")]
    Settings(String),
    /// A design point does not make a valid experiment.
    #[error(
        "design point {point}, scene {scene}: the point makes an invalid experiment:\n{errors}"
    )]
    InvalidPoint {
        /// The point's index in its stage.
        point: u64,
        /// The scene.
        scene: String,
        /// What is wrong.
        errors: ValidationErrors,
    },
    /// The design could not be built.
    #[error(transparent)]
    Design(#[from] crate::doe::DesignError),
    /// A response could not be analysed (too few observations, aliased terms).
    #[error("response {response}: {message}")]
    Analysis {
        /// The response.
        response: String,
        /// Why.
        message: String,
    },
    /// A plot could not be drawn.
    #[error("plot: {0}")]
    Plot(String),
    /// A table could not be read.
    #[error(transparent)]
    Table(#[from] crate::report::table::TableError),
    /// The executor refused the runs.
    #[error(transparent)]
    Exec(#[from] ExecError),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl StudyError {
    /// True when the user's input (options, study, tables) is at fault.
    pub fn is_invalid_input(&self) -> bool {
        match self {
            StudyError::Settings(_)
            | StudyError::InvalidPoint { .. }
            | StudyError::Design(_)
            | StudyError::MissingStage { .. }
            | StudyError::Unsupported(_)
            | StudyError::Train(_) => true,
            StudyError::Inconsistent { .. } | StudyError::NothingKept(_) => false,
            StudyError::Exec(e) => e.is_invalid_input(),
            StudyError::Analysis { .. } | StudyError::Plot(_) => false,
            // A file that is not there, a directory or not text is the
            // caller's (`--table FILE`); other read failures are the machine's.
            StudyError::Table(crate::report::table::TableError::Io { source, .. }) => matches!(
                source.kind(),
                std::io::ErrorKind::NotFound
                    | std::io::ErrorKind::IsADirectory
                    | std::io::ErrorKind::InvalidData
            ),
            StudyError::Table(_) => true,
            StudyError::Store(e) => e.is_invalid_input(),
        }
    }
}

/// What `repose rsm` (or `repose verify`) did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RsmReport {
    /// The response-surface analysis and optimum.
    pub rsm: stages::rsm::RsmOutcome,
    /// The verification, when the study has a verification block.
    pub verification: Option<stages::verify_optimum::Verification>,
}

/// Runs `upto` of a design study's stage list for `analysis` through the
/// one driver ([`run::run`]), its headings announced on stderr when the
/// executor shows progress.
fn run_design<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    (analysis, levels, upto): (Analysis, Levels, Upto),
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<Vec<StageOutcome>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let new = !dir::StudyDir::path_in(store_root, study).exists();
    let dir = dir::StudyDir::prepare(store_root, study)?;
    let plan = Plan::design(study.clone(), analysis, levels);
    let mut log = |line: &str| {
        if pool.progress {
            eprintln!("{}: {}", study.name, line.trim_start());
        }
    };
    let env = Env {
        dir: &dir,
        store,
        pool,
        runner,
        log: &mut log,
    };
    let outcome = run::run(&plan, upto, env);
    if outcome.is_err() && new {
        dir.remove_if_unused();
    }
    outcome
}

/// `repose rsm STUDY`: the design's runs, the analysis, the optimum, and the
/// verification of the optimum and the named points.
pub fn run_rsm<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<RsmReport, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let how = (Analysis::ResponseSurface, Levels::ALL, Upto::All);
    let (mut rsm, mut verification) = (None, None);
    for stage in run_design(store_root, study, how, store, pool, runner)? {
        match stage {
            StageOutcome::ResponseSurface(r) => rsm = Some(r),
            StageOutcome::VerifyOptimum(v) => verification = v,
            _ => {}
        }
    }
    let rsm = rsm.ok_or_else(|| StudyError::Unsupported("the study ran no search".into()))?;
    Ok(RsmReport { rsm, verification })
}

/// `repose screen STUDY`.
pub fn run_screen<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<stages::screen::Screen, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let how = (Analysis::ResponseSurface, Levels::ALL, Upto::Only("screen"));
    run_design(store_root, study, how, store, pool, runner)?
        .into_iter()
        .find_map(|s| match s {
            StageOutcome::Screen(s) => Some(s),
            _ => None,
        })
        .ok_or_else(|| StudyError::Unsupported("the study ran no screen".into()))
}

/// `repose sensitivity STUDY`: the levels asked for (see
/// [`stages::sensitivity`]).
pub fn run_sensitivity<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
    levels: Levels,
) -> Result<stages::sensitivity::SensitivityOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let how = (Analysis::Sensitivity, levels, Upto::All);
    run_design(store_root, study, how, store, pool, runner)?
        .into_iter()
        .find_map(|s| match s {
            StageOutcome::Sensitivity(s) => Some(s),
            _ => None,
        })
        .ok_or_else(|| StudyError::Unsupported("the study ran no sensitivity stage".into()))
}
