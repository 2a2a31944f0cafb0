//! Studies as data: a study is design → experiments (× replicates) → one
//! executor → a response table → an analysis → reports, each stage cached in
//! the store and recorded with lineage.
//!
//! - [`stages`]: the study model — a study file read once and lowered to
//!   its method and stage list ([`stages::StudySpec`]).
//! - [`spec`]: the design study manifest (factors by address, design,
//!   replicates, scenes, named responses, targets, screening, verification)
//!   and the experiments it generates.
//! - [`crate::exec`]: the one seam through which every stage runs experiments.
//! - [`runs`]: points × replicates × scenes → executor → response table.
//! - [`screen`], [`rsm`], [`verify`]: the design studies' stages (the joint
//!   desirability optimum is [`crate::search::desirability`]).
//! - he2019's calibration study ([`calibration`]: its stage directories and
//!   parameter scaling) and its stages: [`sample`], [`noise`] (the noise
//!   floor), [`batch`] and [`replicates`] (the design's runs), [`train`]
//!   (GA-BP) and [`gp_train`] (Gaussian process, screening),
//!   [`tolerance_search`] and [`probability_search`], [`adaptive`],
//!   [`verify_clusters`]; [`pipeline`] chains the noise-aware stages, and
//!   [`learning_curve`] re-trains on nested prefixes of a design.
//! - [`sensitivity`]: yan2015's three levels of parameter sensitivity.
//! - [`seed_noise`]: one experiment over packing seeds: each response's
//!   spread and its precision per cost (`repose noise MANIFEST`).
//! - [`tradeoff`]: what accuracy costs in time: fidelity knobs swept around
//!   one experiment with replicates (`repose tradeoff`).
//! - [`convergence`]: what resolution costs and buys: one scene swept over
//!   particle size with replicates, each response's trend read at the real
//!   particle size, and the cost per run (`repose convergence`).
//! - [`fidelity_pilot`]: does a two-level (coarse + fine particle)
//!   calibration pay in a scene: ρ and δ of the two-level process on a few
//!   points at both sizes (`repose pilot`).
//! - [`fine`]: the fine level of a two-level study (`noise_aware.fidelity`):
//!   design points re-run at a finer size, chosen by the two-level Gaussian
//!   process, which then carries the search and the verification.
//! - [`holdout`]: a study's fine-level predictions against a pilot's
//!   held-out fine runs, with the study's training CPU (`repose holdout`).
//! - [`acceptance`]: the one acceptance rule of a candidate in a scene.
//! - [`dir`]: where a study's outputs live and how they are written.
//!
//! The runs stay in the store (`<store>/<id>/`), so a run shared by two
//! stages or studies is simulated once, and a killed stage resumes.

pub mod acceptance;
pub mod adaptive;
pub mod batch;
pub mod calibration;
pub mod convergence;
pub mod dir;
pub mod fidelity_pilot;
pub mod fine;
pub mod gp_surface;
pub mod gp_train;
pub mod holdout;
pub mod learning_curve;
pub mod noise;
pub mod pipeline;
pub mod probability_search;
pub mod replicates;
pub mod rsm;
pub mod runs;
pub mod sample;
pub mod screen;
pub mod seed_noise;
pub mod sensitivity;
pub mod spec;
pub mod stages;
pub mod tolerance_search;
pub mod tradeoff;
pub mod train;
pub mod verdict_table;
pub mod verify;
pub mod verify_clusters;

use std::path::Path;

use crate::exec::{ExecError, Executor};
use crate::manifest::{Experiment, ValidationErrors};
use crate::store::{RunDir, RunResult, Store, StoreError};
use spec::DesignStudy;

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
    pub rsm: rsm::RsmOutcome,
    /// The verification, when the study has a verification block.
    pub verification: Option<verify::Verification>,
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
    let dir = dir::StudyDir::prepare(store_root, study)?;
    let announce = |what: &str| {
        if pool.progress {
            eprintln!("{}: {what}", study.name);
        }
    };
    announce("design runs");
    let outcome = rsm::rsm(&dir, study, store, pool, runner)?;
    announce("verification runs");
    let verification = verify::verify(&dir, study, &outcome, store, pool, runner)?;
    Ok(RsmReport {
        rsm: outcome,
        verification,
    })
}

/// `repose screen STUDY`.
pub fn run_screen<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<screen::Screen, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let dir = dir::StudyDir::prepare(store_root, study)?;
    screen::screen(&dir, study, store, pool, runner)
}

/// `repose sensitivity STUDY`: the levels asked for (see [`sensitivity`]).
pub fn run_sensitivity<E, F>(
    store_root: &Path,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
    levels: sensitivity::Levels,
) -> Result<sensitivity::SensitivityOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let dir = dir::StudyDir::prepare(store_root, study)?;
    sensitivity::sensitivity(&dir, study, store, pool, runner, levels)
}
