//! The outcome of a he2019 calibration: [`calibrate`] runs the plan's
//! whole stage list through the one driver ([`super::run`]) and, for a
//! noise-aware study, gathers the stages' outcomes into one record.
//!
//! ```text
//! noise  ──▶ noise/noise.{csv,md,json}      σ at the centre, precision per cost
//! design ──▶ sample/design.csv              the study's Latin hypercube
//! simulate ──▶ batch/replicates.csv, angles.csv  R seeds per sample, their means
//! fit    ──▶ train/model.json (GA-BP, he2019), train/gp.json, surrogates.md
//! adaptive (--adaptive) ──▶ adaptive/replicates.csv (rounds until a GP candidate passes), then the GP again
//! fine (noise_aware.fidelity) ──▶ fine/runs.csv, two_level.json: design points at the fine size
//! search ──▶ search/points.csv, clusters.csv/.md, family.json
//! verify ──▶ verify/acceptance.json (first), verification.csv/.md, runs.csv
//! ```
//!
//! A two-level study (`noise_aware.fidelity`) runs the fine stage after
//! fit and has no adaptive rounds; its search and verification are the
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
use super::records::NoiseFloor;
use super::run::{run, CalibrationSettings, Env, Plan, StageOutcome, Upto};
use super::stages::adaptive::AdaptiveOutcome;
use super::stages::fine::TwoLevelRecord;
use super::stages::fit_gp::SurrogateMetrics;
use super::stages::search_probability::Candidate;
use super::stages::transfer::TransferRecord;
use super::stages::verify_candidates::VerifyRow;
use super::StudyError;
use crate::exec::Executor;
use crate::manifest::{Experiment, Study};
use crate::search::band::Family;
use crate::search::screen::MainEffect;
use crate::store::{RunDir, RunResult, Store};
use crate::study::acceptance::Record;
use crate::study::acceptance::Verdict;

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
    /// The transfer test's finer sizes (the verified size's runs are
    /// verification's).
    #[serde(skip_serializing_if = "is_zero")]
    pub transfer: usize,
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
    /// The transfer test, when the study has one: every candidate's verdict
    /// per scene and size, and the size each transfers to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<TransferRecord>,
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
        ) + &self.transfer.as_ref().map_or(String::new(), |t| {
            let each: Vec<String> = t
                .candidates
                .iter()
                .map(|c| match c.transfers_to {
                    Some(s) if c.every_size => format!("candidate {}: every size (x {s})", c.group),
                    Some(1.0) => format!("candidate {}: verified size only", c.group),
                    Some(s) => format!("candidate {}: down to x {s}", c.group),
                    None => format!("candidate {}: none", c.group),
                })
                .collect();
            format!(
                "\n  transfer ({} runs, sizes {:?} of the verified, rule {}): {}",
                self.runs.transfer,
                t.sizes,
                t.rule,
                each.join("; ")
            )
        })
    }
}

/// What a calibration did: every stage's outcome and, for a noise-aware
/// study, the whole outcome record (also `outcome.json`).
#[derive(Debug, Clone)]
pub struct Calibrated {
    /// Each stage's outcome, in the list's order.
    pub stages: Vec<StageOutcome>,
    /// The noise-aware outcome record.
    pub outcome: Option<CalibrationOutcome>,
}

/// Runs every stage of a he2019 `plan` (see the module docs) and, for a
/// noise-aware study, writes `outcome.json`.
pub fn calibrate<E, F>(plan: &Plan, env: Env<'_, F>) -> Result<Calibrated, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let dir = env.dir;
    let stages = run(plan, Upto::All, env)?;
    let outcome = match plan {
        Plan::Calibration {
            study, settings, ..
        } if study.noise_aware.is_some() => {
            let outcome = CalibrationOutcome::of(study, dir, &stages)?;
            let lineage = dir.lineage(
                Stage::Verify,
                json!({ "record": "calibration outcome", "adaptive": settings.adaptive,
                        "candidates": settings.candidates }),
            );
            write_output(
                &dir.path().join("outcome.json"),
                &json_bytes(&outcome),
                &lineage,
            )?;
            Some(outcome)
        }
        _ => None,
    };
    Ok(Calibrated { stages, outcome })
}

/// Runs a noise-aware study's stages with `settings` ([`calibrate`]);
/// `log` gets each stage's heading and report.
pub fn calibrate_noise_aware<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    settings: &CalibrationSettings,
    runner: F,
    log: &mut dyn FnMut(&str),
) -> Result<CalibrationOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let plan = Plan::calibration(study.clone(), settings.clone());
    let env = Env {
        dir,
        store,
        pool,
        runner: &runner,
        log,
    };
    calibrate(&plan, env)?.outcome.ok_or_else(|| {
        StudyError::Unsupported(format!(
            "study {}: no `noise_aware` block (a classic he2019 study has no outcome record)",
            study.name
        ))
    })
}

impl CalibrationOutcome {
    /// The record of a noise-aware study's finished `stages`.
    pub fn of(
        study: &Study,
        dir: &StudyDir,
        stages: &[StageOutcome],
    ) -> Result<CalibrationOutcome, StudyError> {
        let missing =
            |what: &str| StudyError::Unsupported(format!("the calibration ran no {what} stage"));
        let mut floor = None;
        let mut design = 0;
        let mut gp = None;
        let mut adaptive = None;
        let mut fine = None;
        let mut found = None;
        let mut verified = None;
        let mut transfer = None;
        for stage in stages {
            match stage {
                StageOutcome::Noise(o) => floor = Some(o),
                StageOutcome::Simulate(b) => design = b.total,
                StageOutcome::Fit { gp: Some(g), .. } => gp = Some(g),
                StageOutcome::Adaptive { rounds, gp: g } => {
                    adaptive = Some(rounds);
                    gp = Some(g);
                }
                StageOutcome::Fine(f) => fine = Some(f),
                StageOutcome::ProbabilitySearch(f) => found = Some(f),
                StageOutcome::VerifyCandidates(v) => verified = Some(v),
                StageOutcome::Transfer(t) => transfer = Some(t.record()),
                _ => {}
            }
        }
        let floor = floor.ok_or_else(|| missing("noise"))?;
        let gp = gp.ok_or_else(|| missing("fit"))?;
        let found = found.ok_or_else(|| missing("search"))?;
        let v = verified.ok_or_else(|| missing("verify"))?;
        let adaptive_hit = adaptive.and_then(|a| a.hit.as_ref());
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
        Ok(CalibrationOutcome {
            study: study.name.clone(),
            study_id: dir.id().to_string(),
            runs: RunCounts {
                noise: floor.floor.seeds,
                design,
                adaptive: adaptive.map_or(0, |a| a.runs),
                fine: fine.map_or(0, |f| f.runs),
                transfer: transfer.as_ref().map_or(0, |t| t.finer_runs),
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
            noise_floor: floor.floor.clone(),
            adaptive: adaptive.cloned(),
            fine: fine.map(|f| f.record.clone()),
            surrogates: gp.metrics.clone(),
            candidates: found.candidates.clone(),
            family: found.family.clone(),
            screening: found.screening.clone(),
            acceptance: v.acceptance.clone(),
            verification: v.rows.clone(),
            calibrated,
            verified,
            transfer,
        })
    }
}
