//! `repose calibrate` on a noise-aware study: every stage in order, with the
//! outcome as one record.
//!
//! ```text
//! noise  ──▶ noise/noise.{csv,md,json}      σ at the centre, precision per cost
//! sample ──▶ sample/design.csv              the study's Latin hypercube
//! batch  ──▶ batch/replicates.csv, angles.csv  R seeds per sample, their means
//! train  ──▶ train/model.json (GA-BP, he2019), train/gp.json, surrogates.md
//! adaptive (--adaptive) ──▶ adaptive/replicates.csv (rounds until a GP candidate passes), then train again
//! fine (noise_aware.fidelity) ──▶ fine/runs.csv, two_level.json: design points at the fine size
//! search ──▶ search/points.csv, clusters.csv/.md, family.json
//! verify ──▶ verify/acceptance.json (first), verification.csv/.md, runs.csv
//! ```
//!
//! A two-level study (`noise_aware.fidelity`) runs the fine stage after
//! train and has no adaptive rounds; its search and verification are the
//! fine level's ([`super::stages::fine`]).
//!
//! The outcome ([`CalibrationOutcome`], also `outcome.json` in the study's
//! directory and what `repose calibrate --json` prints) gathers the noise
//! floor, the run counts per stage, the surrogates' validation metrics, the
//! candidates with the family report, the acceptance rule and every
//! candidate's verification. Its wall-time cells (the noise floor's cost)
//! are its only non-deterministic ones.

use serde::Serialize;
use serde_json::json;

use super::dir::json_bytes;
use super::dir::write_output;
use super::dir::Stage;
use super::dir::StudyDir;
use super::stages::adaptive::{adaptive, AdaptiveOutcome};
use super::stages::design::{sample, SampleSettings};
use super::stages::fine::{fine, TwoLevelRecord};
use super::stages::fit_gp::{train_gp, SurrogateMetrics};
use super::stages::fit_network::{train_study, TrainOptions};
use super::stages::noise::{noise, NoiseFloor};
use super::stages::search_probability::{gp_search, Candidate};
use super::stages::search_tolerance::{load_model, SearchSettings};
use super::stages::simulate::batch;
use super::stages::verify_candidates::{verify, VerifyRow};
use super::StudyError;
use crate::exec::Executor;
use crate::manifest::{Experiment, Study};
use crate::search::band::Family;
use crate::search::screen::MainEffect;
use crate::store::{RunDir, RunResult, Store};
use crate::study::acceptance::Record;
use crate::study::acceptance::Verdict;

/// Options of a noise-aware calibration.
#[derive(Debug, Clone, Copy)]
pub struct NoiseAwareOptions {
    /// Candidates (clusters, largest first) to verify.
    pub candidates: usize,
    /// Run the adaptive rounds after the initial design.
    pub adaptive: bool,
    /// The sample stage's settings.
    pub sample: SampleSettings,
    /// The network's training (he2019) and the validation split of both
    /// surrogates.
    pub train: TrainOptions,
    /// The search's resampling and clustering.
    pub search: SearchSettings,
}

impl NoiseAwareOptions {
    /// Every stage's defaults, seeded by the study's design seed: the sample
    /// stage's settings, the network's sweep with he2019's two-thirds split
    /// and the study's hidden-size selection ([`TrainOptions::defaults`]:
    /// cross-validation within the training rows), the search's resampling
    /// and clustering.
    pub fn defaults(study: &Study, candidates: usize, adaptive: bool) -> NoiseAwareOptions {
        NoiseAwareOptions {
            candidates,
            adaptive,
            sample: SampleSettings::default(),
            train: TrainOptions::defaults(study),
            search: SearchSettings::with_seed(study.design.seed),
        }
    }
}

/// DEM runs per stage.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunCounts {
    /// Noise floor.
    pub noise: usize,
    /// Initial design (samples × replicates).
    pub design: usize,
    /// Adaptive points × replicates.
    pub adaptive: usize,
    /// Fine points × fine replicates (a two-level study).
    #[serde(skip_serializing_if = "is_zero")]
    pub fine: usize,
    /// Verification (candidates × scenes × seeds, less the adaptive
    /// candidate's calibration-scene runs, which `adaptive` counts).
    pub verification: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The outcome of a noise-aware calibration (see the module docs).
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationOutcome {
    /// Study name.
    pub study: String,
    /// Study id.
    pub study_id: String,
    /// The calibration response's noise floor.
    pub noise_floor: NoiseFloor,
    /// DEM runs per stage.
    pub runs: RunCounts,
    /// The adaptive stage, when run.
    pub adaptive: Option<AdaptiveOutcome>,
    /// The fine level of a two-level study: its points, ρ, β and δ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fine: Option<TwoLevelRecord>,
    /// Validation metrics of the GP and of the network.
    pub surrogates: Vec<SurrogateMetrics>,
    /// The candidates, largest cluster first.
    pub candidates: Vec<Candidate>,
    /// The parameter sets consistent with the target.
    pub family: Family,
    /// Every parameter's main effect under the GP against the noise floor,
    /// and whether the search varied it or fixed it at the centre.
    pub screening: Vec<MainEffect>,
    /// The acceptance rule, recorded before verification.
    pub acceptance: Record,
    /// Every candidate in every scene.
    pub verification: Vec<VerifyRow>,
    /// Some candidate passes the calibration scene.
    pub calibrated: bool,
    /// Some candidate passes every scene.
    pub verified: bool,
}

impl CalibrationOutcome {
    /// Two lines for the end of `repose calibrate`: the runs per stage, the
    /// verdicts, and where `outcome_json` (the whole outcome) is.
    pub fn summary(&self, outcome_json: &std::path::Path) -> String {
        let yes = |b: bool| if b { "yes" } else { "no" };
        format!(
            "{}: {} noise + {} design + {} adaptive{} + {} verification runs; calibrated: {}, \
             verified in every scene: {}\n  outcome: {}",
            self.study,
            self.runs.noise,
            self.runs.design,
            self.runs.adaptive,
            match &self.fine {
                Some(f) => format!(
                    " + {} fine (size x {})",
                    self.runs.fine, f.fidelity.fine_size
                ),
                None => String::new(),
            },
            self.runs.verification,
            yes(self.calibrated),
            yes(self.verified),
            outcome_json.display()
        )
    }
}

/// Runs every stage (see the module docs); `log` gets one line per stage.
pub fn calibrate_noise_aware<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    options: &NoiseAwareOptions,
    runner: F,
    log: &mut dyn FnMut(&str),
) -> Result<CalibrationOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let spec = super::stages::noise::noise_aware(study)?;
    if spec.fidelity.is_some() && options.adaptive {
        return Err(StudyError::Settings(
            "--adaptive: the adaptive rounds are one-level; a study with noise_aware.fidelity \
             chooses its fine points in the fine stage instead"
                .into(),
        ));
    }
    super::runs::replicated::check_response(&study.calibration)?;
    for v in &study.verification {
        super::runs::replicated::check_response(v)?;
    }
    log(&format!(
        "== noise floor: centre of the ranges x {} seeds",
        spec.noise_seeds
    ));
    let floor = noise(dir, study, store, pool, &runner)?;
    log(&floor.markdown);
    log("== sample");
    let sampled = sample(dir, study, &options.sample)?;
    let design_points = sampled.points.len();
    log(&format!(
        "== batch: {design_points} samples x {} seeds",
        spec.replicates
    ));
    let b = batch(dir, study, store, pool, &runner)?;
    log(&format!(
        "{} runs, {} without an angle",
        b.total,
        b.failures.len()
    ));
    log("== train: GA-BP network (he2019) and Gaussian process");
    train_study(dir, study, &options.train)?;
    let seed = options.train.settings.seed;
    let fraction = options.train.train_fraction;
    let model = load_model(&dir.stage(Stage::Train).join("model.json"))?;
    let net = |x: &[f64]| model.predict(x);
    let mut gp = train_gp(dir, study, fraction, seed, Some(&net))?;
    log(&gp.markdown);
    let mut adaptive_outcome = None;
    if options.adaptive {
        log("== adaptive");
        let a = adaptive(
            dir,
            study,
            store,
            pool,
            seed,
            options.candidates,
            &runner,
            &mut |m| log(m),
        )?;
        log(&format!(
            "stopped ({:?}) after {} round(s), {} run(s){}",
            a.stop,
            a.rounds,
            a.runs,
            a.hit.as_ref().map_or(String::new(), |h| format!(
                "; candidate {} at {:.2}° ({} of {} seeds measured)",
                h.index, h.mean_deg, h.measured, h.seeds
            ))
        ));
        gp = train_gp(dir, study, fraction, seed, Some(&net))?;
        adaptive_outcome = Some(a);
    }
    let mut fine_outcome = None;
    if let Some(f) = spec.fidelity {
        log(&format!(
            "== fine: {} design points x {} seeds at particle size x {}",
            f.fine_points, f.fine_replicates, f.fine_size
        ));
        let o = fine(dir, study, store, pool, &runner, &mut |m| log(m))?;
        log(&o.markdown);
        fine_outcome = Some(o);
    }
    log("== search");
    let found = gp_search(dir, study, &options.search)?;
    log(&found.markdown);
    let adaptive_hit = adaptive_outcome.as_ref().and_then(|a| a.hit.as_ref());
    log(&format!(
        "== verify: {} candidate(s) x {} scene(s), seeds by the acceptance record",
        options.candidates.min(found.candidates.len()) + usize::from(adaptive_hit.is_some()),
        1 + study.verification.len(),
    ));
    let v = verify(dir, study, store, pool, options.candidates, &runner)?;
    log(&v.markdown);
    let calibrated = v
        .rows
        .iter()
        .any(|r| r.scene == study.calibration.name && r.judgement.verdict == Verdict::Pass);
    // Every verified candidate: the search's and the adaptive one.
    let verified = v.rows.iter().any(|c| {
        v.rows
            .iter()
            .filter(|r| r.group == c.group)
            .all(|r| r.judgement.verdict == Verdict::Pass)
    });
    let outcome = CalibrationOutcome {
        study: study.name.clone(),
        study_id: dir.id().to_string(),
        runs: RunCounts {
            noise: floor.floor.seeds,
            design: b.total,
            adaptive: adaptive_outcome.as_ref().map_or(0, |a| a.runs),
            fine: fine_outcome.as_ref().map_or(0, |f| f.runs),
            // The adaptive candidate's calibration-scene runs are the
            // adaptive stage's, counted there.
            verification: v
                .rows
                .iter()
                .filter(|r| {
                    !(adaptive_hit.is_some_and(|h| h.index as usize == r.group)
                        && r.scene == study.calibration.name)
                })
                .map(|r| r.seeds)
                .sum(),
        },
        noise_floor: floor.floor,
        adaptive: adaptive_outcome,
        fine: fine_outcome.map(|f| f.record),
        surrogates: gp.metrics,
        candidates: found.candidates,
        family: found.family,
        screening: found.screening,
        acceptance: v.acceptance,
        verification: v.rows,
        calibrated,
        verified,
    };
    let lineage = dir.lineage(
        Stage::Verify,
        json!({ "record": "calibration outcome", "adaptive": options.adaptive,
                "candidates": options.candidates }),
    );
    write_output(
        &dir.path().join("outcome.json"),
        &json_bytes(&outcome),
        &lineage,
    )?;
    Ok(outcome)
}
