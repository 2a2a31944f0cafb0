//! Scenes: turning an experiment into a DEM run and its result.
//!
//! [`run_experiment`] is the runner `repose run` hands to
//! [`crate::store::Store::run_cached`].

pub mod pair;

use crate::manifest::Experiment;
use crate::store::RunResult;

/// Why a scene could not be run.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene kind has no simulation yet.
    #[error("scene kind `{kind}` is not simulated yet")]
    NotYetSimulated {
        /// The scene's `kind` tag.
        kind: &'static str,
    },
}

/// Runs the experiment's scene and returns its result.
///
/// Placeholder, deliberately: no scene is simulated yet, so every kind returns
/// [`SceneError::NotYetSimulated`] (the `pair` scene is implemented next, the lab
/// scenes in issue 4). The store records the failure in error.json.
pub fn run_experiment(experiment: &Experiment) -> Result<RunResult, SceneError> {
    Err(SceneError::NotYetSimulated {
        kind: experiment.scene.kind(),
    })
}
