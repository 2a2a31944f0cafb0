//! Scenes: turning an experiment into a DEM run and its result.
//!
//! [`run_experiment`] is the runner `repose run` hands to
//! [`crate::store::Store::run_cached`].
//! [`plan::plan`] checks an experiment's scene against its particles and
//! physics and estimates the run's cost before anything runs.
//! [`skeleton`] is the set-up and finish the five lab scenes share (and the
//! measurement keys they all report); [`responses`] names each scene kind's
//! scalar physics results and reads them from a run.

pub mod baffle;
pub mod drum;
pub mod funnel;
pub mod grains;
pub mod hopper;
pub mod pair;
pub mod physics;
pub mod plan;
pub mod protocol;
pub mod resolution;
pub mod responses;
pub mod skeleton;
pub mod static_pile;

use std::path::Path;

use crate::log::LogError;
use crate::manifest::{Experiment, Scene};
use crate::store::RunResult;

/// Why a scene could not be run.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// No stable time step exists for the manifest's settings.
    #[error("time_step: {0}")]
    TimeStep(#[from] crate::dem::timestep::TimeStepError),
    /// The particle shape is not a valid clump.
    #[error("material.particle.shape: {0}")]
    Shape(String),
    /// The pair scene failed.
    #[error(transparent)]
    Pair(#[from] pair::PairError),
    /// The drum scene failed.
    #[error(transparent)]
    Drum(#[from] drum::DrumError),
    /// The hopper scene failed.
    #[error(transparent)]
    Hopper(#[from] hopper::HopperError),
    /// The static pile scene failed.
    #[error(transparent)]
    StaticPile(#[from] static_pile::StaticPileError),
    /// The baffle-lift scene failed.
    #[error(transparent)]
    Baffle(#[from] baffle::BaffleError),
    /// The funnel_pile scene failed.
    #[error(transparent)]
    Funnel(#[from] funnel::FunnelError),
    /// The run log could not be written.
    #[error(transparent)]
    Log(#[from] LogError),
}

/// Runs the experiment with its log at the run directory's `run.mcap`: the
/// runner every command and stage hands to the store and the executor.
pub fn run_logged(
    exp: &Experiment,
    dir: &crate::store::RunDir,
) -> Result<crate::store::RunResult, SceneError> {
    run_experiment(exp, Some(&dir.mcap_path()))
}

/// Runs the experiment's scene and returns its result; with `log`, also writes
/// the run's MCAP log there (atomically: the file appears only complete, and
/// only when the run succeeds). A failed run's error is what the store records
/// in error.json.
pub fn run_experiment(
    experiment: &Experiment,
    log: Option<&Path>,
) -> Result<RunResult, SceneError> {
    let mut result = match &experiment.scene {
        Scene::Pair(scene) => pair::run(experiment, scene, log),
        Scene::Drum(scene) => drum::run(experiment, scene, log),
        Scene::Hopper(scene) => hopper::run(experiment, scene, log),
        Scene::StaticPile(scene) => static_pile::run(experiment, scene, log),
        Scene::BaffleLift(scene) => baffle::run(experiment, scene, log),
        Scene::FunnelPile(scene) => funnel::run(experiment, scene, log),
    }?;
    result.coarse_graining = physics::coarse_graining_report(experiment);
    Ok(result)
}
