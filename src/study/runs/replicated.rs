//! Points × packing seeds in one target scene, through the one executor: the
//! runs of every noise-aware stage (noise floor, design batch, adaptive
//! batches, verification).
//!
//! Replicate `r` of a point is [`Study::replicate_experiment`] with the
//! packing seed of [`Study::seed_rule`] (drawn per point in a noise-aware
//! study). Every experiment is handed to the runs adapter
//! [`crate::exec::outcomes::run_collect`] at once, so a killed stage resumes
//! and a run shared with another stage is simulated once. A run that failed
//! before is not run again unless asked (`retry_failed`).
//!
//! The value of a run is the target's response ([`response_of`]): the named
//! response of the scene when the target names one, else the headline
//! angle.

use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::Executor;
use crate::manifest::{ContentId, Experiment, Study, TargetScene};
use crate::report::table::{parse_number, Cell, CsvWriter, Table};
use crate::scenes::plan::{plan, Limits};
use crate::scenes::responses::response;
use crate::stats::summary::{mean_ci, MeanCi};
use crate::store::{ErrorRecord, RunDir, RunResult, RunState, Store, StoreError};
use crate::study::plan::calibration::{to_physical, verified_size};
use crate::study::sweeps::convergence::plan::{scaled, SurfaceEnergyRule};
use crate::study::StudyError;

/// One packing seed of a point.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedRun {
    /// Replicate number; its packing seed follows [`Study::seed_rule`].
    pub replicate: u32,
    /// The experiment.
    pub id: ContentId,
    /// The response, or why there is none (the run's error).
    pub value: Result<f64, String>,
}

/// A point and its replicate runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Replicated {
    /// The experiments' `sample_index`.
    pub index: u64,
    /// Parameter values, physical units, in the study's parameter order.
    pub point: Vec<f64>,
    /// One run per replicate, in replicate order.
    pub runs: Vec<SeedRun>,
}

impl Replicated {
    /// The measured values, in replicate order.
    pub fn values(&self) -> Vec<f64> {
        self.runs
            .iter()
            .filter_map(|r| r.value.as_ref().ok().copied())
            .collect()
    }

    /// Mean of the measured values (`None` when none was measured).
    pub fn mean(&self) -> Option<f64> {
        let v = self.values();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// Mean, standard deviation and 95 % interval (two or more values).
    pub fn summary(&self) -> Option<MeanCi> {
        mean_ci(&self.values())
    }
}

/// The value a run gives `target`: its named response, or the headline angle.
pub fn response_of(result: &RunResult, target: &TargetScene) -> Result<f64, String> {
    match &target.response {
        Some(name) => response(result, target.scene.kind(), name).map_err(|e| e.to_string()),
        None => result.headline_angle_deg.ok_or_else(|| {
            result
                .headline_reason()
                .unwrap_or("the run has no headline angle")
                .to_string()
        }),
    }
}

/// Checks that `target`'s response exists for its scene kind, before any run.
pub fn check_response(target: &TargetScene) -> Result<(), StudyError> {
    let Some(name) = &target.response else {
        return Ok(());
    };
    let table = crate::scenes::responses::catalogue(target.scene.kind()).unwrap_or(&[]);
    if table.iter().any(|s| s.name == name) {
        Ok(())
    } else {
        Err(StudyError::Settings(format!(
            "target `{}`: response `{name}` is not a response of {} (allowed: {})",
            target.name,
            target.scene.kind(),
            table.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
        )))
    }
}

/// How many of a [`run_replicated`] call's runs it simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tally {
    /// Runs not simulated: complete before, or failed before and not retried.
    pub not_simulated: usize,
    /// Runs simulated by this call that failed.
    pub failed_now: usize,
}

/// Runs `replicates` packing seeds of every point in `target`'s scene (see the
/// module docs) and reads their values back, with how many runs this call
/// simulated ([`Tally`]).
#[allow(clippy::too_many_arguments)]
pub fn run_replicated<E, F>(
    study: &Study,
    target: &TargetScene,
    points: &[(u64, Vec<f64>)],
    replicates: u32,
    store: &Store,
    pool: &Executor,
    runner: &F,
    retry_failed: bool,
) -> Result<(Vec<Replicated>, Tally), StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    run_replicated_at(
        study,
        target,
        points,
        replicates,
        AtSize::STUDY,
        store,
        pool,
        runner,
        retry_failed,
    )
}

/// A particle size relative to the study's and how every surface energy
/// follows it there ([`scaled`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtSize {
    /// Particle radius / the study's (1: the study's own experiments, same
    /// ids).
    pub factor: f64,
    /// Γ ∝ R^p.
    pub rule: SurfaceEnergyRule,
}

impl AtSize {
    /// The study's own size.
    pub const STUDY: AtSize = AtSize {
        factor: 1.0,
        rule: SurfaceEnergyRule::ConstantBond,
    };

    /// The size a study searches and verifies at: the fine level's, whose
    /// surface energies follow Γ ∝ R² ([`crate::manifest::Fidelity`]), or
    /// the study's own.
    pub fn verified(study: &Study) -> AtSize {
        AtSize {
            factor: verified_size(study),
            rule: SurfaceEnergyRule::ConstantBond,
        }
    }
}

/// Refuses a study any of whose stages would start a run beyond `limits`,
/// before the first run of any stage (issue 54: a fine size of 1e-9 once ran
/// the noise, design and training stages before the fine runs were refused).
/// A run's particle count and steps depend on its scene and particle size,
/// not on the calibrated contact values, so one experiment per scene and
/// size — at the centre of the ranges — stands for the stage's runs: the
/// calibration scene at the study's size and at the verified size (the
/// fine level's, when the study has one), and every verification scene at
/// the verified size and at each of `finer` (the transfer test's sizes).
pub fn check_limits(study: &Study, finer: &[AtSize], limits: &Limits) -> Result<(), StudyError> {
    let names = crate::study::plan::calibration::parameter_names(study);
    let centre = to_physical(study, &vec![0.5; names.len()]);
    let values = names.into_iter().zip(centre).collect();
    let verified = AtSize::verified(study);
    let mut cases = vec![(&study.calibration, AtSize::STUDY)];
    if verified.factor != 1.0 {
        cases.push((&study.calibration, verified));
    }
    for at in std::iter::once(&verified).chain(finer) {
        if at.factor != 1.0 && at != &verified {
            cases.push((&study.calibration, *at));
        }
        cases.extend(study.verification.iter().map(|t| (t, *at)));
    }
    for (target, at) in cases {
        let size = at.factor;
        let refuse = |why: String| {
            StudyError::Settings(format!(
                "scene {} at particle size x {size}: {why}; refused before the study's first \
                 run (change the study, or raise the limits: --max-particles, \
                 --max-particle-steps, --max-log-bytes)",
                target.name
            ))
        };
        let e = study
            .replicate_experiment(&target.scene, &values, 0, 0)
            .map_err(|errors| refuse(errors.to_string()))?;
        let e = scaled(&e, size, Some(at.rule)).map_err(|errors| refuse(errors.to_string()))?;
        plan(&e)
            .map_err(|errors| refuse(errors.to_string()))?
            .check(limits)
            .map_err(|excess| refuse(excess.to_string()))?;
    }
    Ok(())
}

/// [`run_replicated`] at particle size `at` (the fine level of a two-level
/// study, [`AtSize::verified`]; a transfer test's finer size).
#[allow(clippy::too_many_arguments)]
pub fn run_replicated_at<E, F>(
    study: &Study,
    target: &TargetScene,
    points: &[(u64, Vec<f64>)],
    replicates: u32,
    at: AtSize,
    store: &Store,
    pool: &Executor,
    runner: &F,
    retry_failed: bool,
) -> Result<(Vec<Replicated>, Tally), StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    check_response(target)?;
    let names = crate::study::plan::calibration::parameter_names(study);
    let mut experiments = Vec::new();
    for (index, point) in points {
        let values = names.iter().cloned().zip(point.iter().copied()).collect();
        for r in 0..replicates {
            let invalid = |errors| StudyError::InvalidPoint {
                point: *index,
                scene: target.name.clone(),
                errors,
            };
            let e = study
                .replicate_experiment(&target.scene, &values, *index, r)
                .map_err(invalid)?;
            // Size 1 leaves the experiment as it is (same id).
            experiments.push(scaled(&e, at.factor, Some(at.rule)).map_err(invalid)?);
        }
    }
    let retry = if retry_failed {
        Retry::Failed
    } else {
        Retry::NotFailed
    };
    let collected = run_collect(&experiments, store, pool, runner, retry)?;
    let mut outcomes = experiments.iter().zip(&collected.outcomes);
    let mut out = Vec::with_capacity(points.len());
    for (index, point) in points {
        let mut runs = Vec::with_capacity(replicates as usize);
        for r in 0..replicates {
            let (e, outcome) = outcomes.next().expect("one outcome per experiment");
            let id = e.id();
            runs.push(SeedRun {
                replicate: r,
                value: value_of(store, &id, outcome, target)?,
                id,
            });
        }
        out.push(Replicated {
            index: *index,
            point: point.clone(),
            runs,
        });
    }
    let tally = Tally {
        not_simulated: collected.cached + collected.skipped,
        failed_now: collected.failed_now(),
    };
    Ok((out, tally))
}

/// The value of run `id` from its `outcome`: its response when complete,
/// its error (now, or as recorded) when failed; a damaged run is an error.
fn value_of(
    store: &Store,
    id: &ContentId,
    outcome: &RunOutcome,
    target: &TargetScene,
) -> Result<Result<f64, String>, StudyError> {
    Ok(match outcome {
        RunOutcome::Complete(result) => response_of(result, target),
        RunOutcome::FailedNow(message) => Err(message.clone()),
        RunOutcome::Stored(RunState::Damaged(problem)) => {
            return Err(StoreError::Damaged {
                id: id.clone(),
                problem: problem.clone(),
            }
            .into())
        }
        RunOutcome::Stored(_) => Err(Store::read_json::<ErrorRecord>(
            &store.run_dir(id).error_path(),
        )
        .map(|e| e.error)
        .unwrap_or_else(|_| format!("run {} has no result", id.short(12)))),
    })
}

/// Columns of a replicates table: `scene`, `index`, the parameters,
/// `replicate`, `packing_seed`, `experiment_id`, `value_deg`, `failure`;
/// one block of rows per (scene name, points) of `scenes`. A failed or
/// unmeasurable seed has an empty value and its reason, so
/// `repose verdict --table` reads it as a missing replicate.
pub fn replicates_csv(study: &Study, scenes: &[(&str, &[Replicated])]) -> String {
    let names = crate::study::plan::calibration::parameter_names(study);
    let mut header = vec!["scene".to_string(), "index".to_string()];
    header.extend(names.iter().cloned());
    header.extend(
        [
            "replicate",
            "packing_seed",
            "experiment_id",
            "value_deg",
            "failure",
        ]
        .map(String::from),
    );
    let mut csv = CsvWriter::new(&header);
    for (scene, p) in scenes
        .iter()
        .flat_map(|(scene, points)| points.iter().map(move |p| (scene, p)))
    {
        for r in &p.runs {
            let mut cells = vec![Cell::Text(scene.to_string()), Cell::Integer(p.index)];
            cells.extend(p.point.iter().map(|v| Cell::Number(*v)));
            cells.push(Cell::Integer(u64::from(r.replicate)));
            let rule = study.seed_rule(p.index);
            cells.push(Cell::Integer(rule.packing_seed(u64::from(r.replicate))));
            cells.push(Cell::Text(r.id.to_string()));
            cells.push(r.value.as_ref().map_or(Cell::Empty, |v| Cell::Number(*v)));
            cells.push(Cell::Text(
                r.value
                    .as_ref()
                    .err()
                    .map_or(String::new(), |m| crate::report::table::csv_word(m)),
            ));
            csv.row(&cells);
        }
    }
    csv.finish()
}

/// Reads a table written by [`replicates_csv`] back into points (rows of one
/// index are one point, in file order).
pub fn read_replicates_csv(
    path: &std::path::Path,
    study: &Study,
) -> Result<Vec<Replicated>, StudyError> {
    let table = Table::read(path)?;
    let names = crate::study::plan::calibration::parameter_names(study);
    let index = table.numbers(path, "index")?;
    let columns = names
        .iter()
        .map(|n| table.numbers(path, n))
        .collect::<Result<Vec<_>, _>>()?;
    let replicate = table.numbers(path, "replicate")?;
    let id_col = table.require(path, "experiment_id")?;
    let value_col = table.require(path, "value_deg")?;
    let failure_col = table.require(path, "failure")?;
    let mut out: Vec<Replicated> = Vec::new();
    for (i, cells) in table.rows.iter().enumerate() {
        let id = ContentId::parse(&cells[id_col]).ok_or_else(|| StudyError::Inconsistent {
            path: path.to_path_buf(),
            message: format!(
                "line {}: `{}` is not an experiment id",
                i + 2,
                cells[id_col]
            ),
        })?;
        let value = parse_number(&cells[value_col]).ok_or_else(|| cells[failure_col].clone());
        let run = SeedRun {
            replicate: replicate[i] as u32,
            id,
            value,
        };
        let idx = index[i] as u64;
        match out.last_mut() {
            Some(last) if last.index == idx => last.runs.push(run),
            _ => out.push(Replicated {
                index: idx,
                point: columns.iter().map(|c| c[i]).collect(),
                runs: vec![run],
            }),
        }
    }
    Ok(out)
}

/// The seed-to-seed variance pooled over every point with two or more
/// measured values, Σ(nᵢ − 1)sᵢ² / Σ(nᵢ − 1), deg², with its degrees of
/// freedom (`None` without any replicated point).
pub fn pooled_variance(points: &[&Replicated]) -> Option<(f64, usize)> {
    let (mut ss, mut df) = (0.0, 0usize);
    for p in points {
        let v = p.values();
        if v.len() >= 2 {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            ss += v.iter().map(|x| (x - m) * (x - m)).sum::<f64>();
            df += v.len() - 1;
        }
    }
    (df > 0).then(|| (ss / df as f64, df))
}
