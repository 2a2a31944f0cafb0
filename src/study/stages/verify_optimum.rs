//! `repose verify STUDY` (and the last step of `repose rsm`): the
//! desirability optimum of the fitted response surface and the study's
//! named points re-simulated in every scene with
//! `verification.replicates` packing seeds each, judged by the acceptance
//! rule ([`crate::study::verification`], the step this stage shares with
//! the sensitivity analysis).

use crate::exec::Executor;
use crate::manifest::Experiment;
use crate::store::{RunDir, RunResult, Store};
use crate::study::dir::StudyDir;
use crate::study::plan::design_study::DesignStudy;
use crate::study::verification::{verify_points, Checked};
use crate::study::StudyError;

/// The stage's outcome and its Markdown report, as the verification of
/// [`crate::study::verification`] gives them.
pub use crate::study::verification::{markdown, Verification};

/// What the verification needs of the fitted surface (the response-surface
/// stage's outcome, which the driver hands over): the responses it models,
/// its prediction of a response at a coded point, and its optimum in actual
/// units, if one was found.
pub struct Surface<'a> {
    /// The modelled responses, in the stage's order.
    pub responses: Vec<String>,
    /// The prediction of `response` at a coded point.
    pub predict: &'a dyn Fn(&str, &[f64]) -> Option<f64>,
    /// The desirability optimum, actual units.
    pub optimum: Option<&'a [f64]>,
}

/// Verifies the optimum of `surface` and the study's named points (see the
/// module docs); `None` when the study has no verification block.
pub fn verify<E, F>(
    dir: &StudyDir,
    study: &DesignStudy,
    surface: &Surface<'_>,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<Option<Verification>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let ranges = study.ranges();
    let predict = |response: &str, actual: &[f64]| {
        let coded: Vec<f64> = actual
            .iter()
            .zip(&ranges)
            .map(|(x, r)| r.to_coded(*x))
            .collect();
        (surface.predict)(response, &coded)
    };
    let checked = Checked {
        stage: "verify",
        optimum: surface.optimum.map(|best| ("optimum", best)),
        responses: &surface.responses,
        predict: &predict,
    };
    verify_points(dir, study, &checked, store, pool, runner)
}
