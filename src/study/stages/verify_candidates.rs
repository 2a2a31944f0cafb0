//! `repose verify STUDY`: he2019 §3.6 — every candidate parameter set (a
//! cluster centre of the search) is simulated again, in the calibration scene
//! (so the surrogate's prediction meets the DEM it stands for) and in each of
//! the study's verification scenes (he2019: baffle lift and rotating drum),
//! with the packing seeds the acceptance record gives each scene. Every
//! candidate in every scene is judged by the project's one acceptance rule
//! ([`crate::study::acceptance`]: TOST against the scene's band; pass, fail,
//! or inconclusive with the seeds that would decide) — a single run (the
//! classic method's one seed per scene, he2019's Table 3) has no interval
//! and is never decided, and the table says so rather than passing a
//! candidate on one draw of a noisy test.
//!
//! # The acceptance record
//!
//! The rule, α, the seeds and every scene's target and band are written to
//! `verify/acceptance.json` — with its lineage record, before the first
//! verification run — from the study (whose id fixes them), the noise floor
//! and the number of candidates, so they cannot be chosen after the result
//! is seen; the verification table's lineage names that file.
//! - **Seeds.** Each scene runs [`crate::study::plan::calibration::verification_seeds`] (a noise-aware
//!   study's `verification_seeds`, 1 for the classic method). Where the
//!   noise floor has measured the calibration scene's σ, that scene's seeds
//!   are chosen by the power calculation instead: the fewest that give TOST
//!   power ≥ 0.8 at the band's centre, at least `verification_seeds` and at
//!   most `max_verification_seeds` (the record shows the power reached when
//!   the cap binds). The other scenes' noise is not measured, so no power
//!   can be computed for them.
//! - **α.** 0.05 divided by the candidates judged ([`crate::study::plan::calibration::comparisons`]: the
//!   search's `--candidates`, plus every round the adaptive budget allows
//!   when the adaptive stage ran), so a calibration that tries several
//!   candidates keeps a ≤ 5 % chance of passing any wrongly.
//!
//! A seed whose run could not measure the angle is a missing replicate
//! (its reason, recorded in the run's result, is listed under the table),
//! never a value and never an error. A run that failed (the engine's health
//! check, I/O) is a missing replicate too, and is counted in
//! [`VerifyOutcome::failed_runs`] by its store status, which `repose verify`
//! and `repose calibrate` exit with after writing the tables.
//!
//! A two-level study (`noise_aware.fidelity`) verifies at its fine size
//! (every scene's experiments with the fine particle, Γ ∝ R²,
//! [`crate::study::stages::fine`]), with `verification_seeds` in every scene: its noise
//! floor is the coarse level's and sets no fine seeds.
//!
//! Verification experiments are ordinary replicates of the study
//! ([`Study::replicate_experiment`]) whose `sample_index` is the cluster's
//! group number plus [`VERIFY_INDEX`], so a noise-aware study draws their
//! packing seeds apart from every training run's; cached by id in the store
//! like every run, a killed verify resumes.
//!
//! # Candidates
//!
//! The search's largest clusters' centres (`--candidates`, numbered by
//! cluster group) and, when `calibrate --adaptive` ended on one, the
//! adaptive candidate that passed in the calibration scene, under its sample
//! index (≥ [`crate::study::plan::calibration::ADAPTIVE_INDEX`]). Its calibration-scene runs
//! are the adaptive stage's own (the same manifests, so the store returns
//! them), and it is judged in every other scene like the search's.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::exec::Executor;
use crate::manifest::{Experiment, Study, TargetScene};
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter, Table};
use crate::scenes::resolution::unresolved_figures;
use crate::store::{RunDir, RunResult, RunStatus, Store};
use crate::study::acceptance::{Judgement, Record};
use crate::study::dir::json_bytes;
use crate::study::dir::write_output;
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::parameter_names;
use crate::study::plan::calibration::VERIFY_INDEX;
use crate::study::plan::calibration::{acceptance, comparisons};
use crate::study::records::{passing_candidate, read_noise};
use crate::study::runs::replicated::{replicates_csv, run_replicated_at, AtSize, Replicated};
use crate::study::StudyError;

/// One candidate in one scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerifyRow {
    /// Candidate (cluster group).
    pub group: usize,
    /// Scene name.
    pub scene: String,
    /// Seeds run.
    pub seeds: usize,
    /// Seeds measured.
    pub measured: usize,
    /// Mean of the measured seeds, degrees.
    pub mean_deg: Option<f64>,
    /// Their standard deviation, degrees.
    pub sd_deg: Option<f64>,
    /// Half-width of the 95 % interval of the mean, degrees.
    pub ci95_half_width_deg: Option<f64>,
    /// Measured (target) angle, degrees.
    pub target_deg: f64,
    /// |mean − target| / target.
    pub relative_error: Option<f64>,
    /// The acceptance rule's judgement of the measured seeds.
    pub judgement: Judgement,
    /// Why seeds have no angle (one line per failed seed).
    pub failures: Vec<String>,
    /// The scene's resolution figures outside their limits in these runs
    /// (`froude_number = 0.0906 above 0.01`, …): the scene is unresolved at
    /// this particle size ([`crate::scenes::resolution`]).
    #[serde(default)]
    pub unresolved: Vec<String>,
}

/// What verify did.
#[derive(Debug, Clone)]
pub struct VerifyOutcome {
    /// The rule.
    pub acceptance: Record,
    /// One row per candidate and scene.
    pub rows: Vec<VerifyRow>,
    /// The Markdown table (also verification.md).
    pub markdown: String,
    /// verification.csv.
    pub table: PathBuf,
    /// Runs that failed (store status), not counting runs that completed
    /// without the angle: the errors the commands exit with.
    pub failed_runs: usize,
    /// Runs in all.
    pub runs: usize,
}

/// Cluster centres to verify: (group, physical point in parameter order).
pub(crate) type Centres = Vec<(u64, Vec<f64>)>;

/// The centres of the first `candidates` clusters of `search/clusters.csv`:
/// (group, physical point in parameter order), with the file read.
pub(crate) fn read_candidates(
    dir: &StudyDir,
    study: &Study,
    candidates: usize,
) -> Result<(PathBuf, Centres), StudyError> {
    if candidates == 0 {
        return Err(StudyError::Settings(
            "--candidates = 0: must be >= 1".into(),
        ));
    }
    let clusters_file = dir.require(dir.clusters_path(), Stage::Search)?;
    let table = Table::read(&clusters_file)?;
    let groups = table.numbers(&clusters_file, "group")?;
    let columns = parameter_names(study)
        .iter()
        .map(|n| table.numbers(&clusters_file, n))
        .collect::<Result<Vec<_>, _>>()?;
    let points = groups
        .iter()
        .enumerate()
        .take(candidates)
        .map(|(row, g)| (*g as u64, columns.iter().map(|c| c[row]).collect()))
        .collect();
    Ok((clusters_file, points))
}

/// Runs the verification (see the module docs) on at most `candidates`
/// clusters, largest first.
pub fn verify<E, F>(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pool: &Executor,
    candidates: usize,
    runner: F,
) -> Result<VerifyOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    // A two-level study verifies at the fine size.
    let size = AtSize::verified(study);
    let rule = acceptance_rule(dir, study, candidates);
    let (clusters_file, centres) = read_candidates(dir, study, candidates)?;
    let mut points: Vec<(u64, Vec<f64>)> = centres
        .into_iter()
        .map(|(g, p)| (VERIFY_INDEX + g, p))
        .collect();
    let adaptive = passing_candidate(dir, study, &rule)?;
    if let Some(hit) = &adaptive {
        points.push((hit.index, hit.point.clone()));
    }

    // The rule goes on record before any verification run.
    write_rule(dir, study, &rule, &clusters_file, adaptive.is_some())?;
    let targets: Vec<&TargetScene> = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .collect();
    let mut per_scene: Vec<Vec<Replicated>> = Vec::new();
    for (target, accepted) in targets.iter().zip(&rule.targets) {
        per_scene.push(
            run_replicated_at(
                study,
                target,
                &points,
                accepted.seeds as u32,
                size,
                store,
                pool,
                &runner,
                false,
            )?
            .0,
        );
    }
    let rows = rows(store, &rule, &points, (&targets, &per_scene))?;
    let all_runs = || per_scene.iter().flatten().flat_map(|p| &p.runs);
    let failed_runs = all_runs()
        .filter(|r| store.status(&r.id) == RunStatus::Failed)
        .count();
    let outcome = VerifyOutcome {
        markdown: markdown(&rule, &rows),
        acceptance: rule,
        rows,
        table: dir.verification_path(),
        failed_runs,
        runs: all_runs().count(),
    };
    write_outputs(
        dir,
        study,
        store,
        (candidates, &clusters_file),
        (&targets, &per_scene),
        &outcome,
    )?;
    Ok(outcome)
}

/// The acceptance rule of a verification of `candidates` search candidates
/// (and the adaptive one, when the adaptive stage ran), with the noise
/// floor's sd when it describes the verified size.
fn acceptance_rule(dir: &StudyDir, study: &Study, candidates: usize) -> Record {
    // A two-level study verifies at the fine size, where the noise floor
    // (measured at the study's size) says nothing of the seeds needed.
    let noise_sd = if study.fidelity().is_none() {
        read_noise(dir).ok().and_then(|f| f.sd_deg)
    } else {
        None
    };
    let ran_adaptive = dir.adaptive_path().is_file();
    acceptance(
        study,
        noise_sd,
        comparisons(study, candidates, ran_adaptive),
    )
}

/// Writes the acceptance record `rule` with its lineage (the clusters file
/// and, when an adaptive candidate is verified, the adaptive table).
fn write_rule(
    dir: &StudyDir,
    study: &Study,
    rule: &Record,
    clusters_file: &Path,
    adaptive: bool,
) -> Result<(), StudyError> {
    dir.prepare_stage(study, Stage::Verify)?;
    let mut rule_lineage = dir
        .lineage(Stage::Verify, json!({ "record": "acceptance rule" }))
        .with_input(dir.input("clusters", clusters_file)?);
    if adaptive {
        rule_lineage = rule_lineage.with_input(dir.input("adaptive", &dir.adaptive_path())?);
    }
    write_output(&dir.acceptance_path(), &json_bytes(rule), &rule_lineage)
}

/// One row per verified point and scene: the measured seeds judged by
/// `rule` against the scene's target, with the failed seeds and the
/// unresolved resolution figures.
fn rows(
    store: &Store,
    rule: &Record,
    points: &[(u64, Vec<f64>)],
    (targets, per_scene): (&[&TargetScene], &[Vec<Replicated>]),
) -> Result<Vec<VerifyRow>, StudyError> {
    let mut rows = Vec::new();
    for (k, (index, _)) in points.iter().enumerate() {
        for (j, (target, runs)) in targets.iter().zip(per_scene).enumerate() {
            let r = &runs[k];
            let values = r.values();
            let judgement = rule.judge(j, &values);
            let mean = judgement.mean;
            rows.push(VerifyRow {
                group: group_of(*index) as usize,
                scene: target.name.clone(),
                seeds: r.runs.len(),
                measured: values.len(),
                mean_deg: mean,
                sd_deg: judgement.tost.map(|t| t.sd),
                ci95_half_width_deg: judgement.ci95_half_width(),
                target_deg: target.target_angle_deg,
                relative_error: mean
                    .map(|m| (m - target.target_angle_deg).abs() / target.target_angle_deg),
                judgement,
                failures: r
                    .runs
                    .iter()
                    .filter_map(|s| {
                        s.value
                            .as_ref()
                            .err()
                            .map(|m| format!("seed {}: {m}", s.replicate))
                    })
                    .collect(),
                unresolved: unresolved(store, r)?,
            });
        }
    }
    Ok(rows)
}

/// Writes the stage's outputs with their lineage (the number of
/// `candidates`, the clusters file, the acceptance record and every run's
/// result): `runs.csv` (every scene's runs), `verification.md` and
/// `verification.csv`.
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    (candidates, clusters_file): (usize, &Path),
    (targets, per_scene): (&[&TargetScene], &[Vec<Replicated>]),
    outcome: &VerifyOutcome,
) -> Result<(), StudyError> {
    let mut lineage = dir
        .lineage(Stage::Verify, json!({ "candidates": candidates }))
        .with_input(dir.input("clusters", clusters_file)?)
        .with_input(dir.input("acceptance", &dir.acceptance_path())?);
    for runs in per_scene {
        for r in runs.iter().flat_map(|p| &p.runs) {
            let file = store.run_dir(&r.id).result_path();
            if file.is_file() {
                lineage = lineage.with_input(dir.input("result", &file)?);
            }
        }
    }
    let out = dir.stage(Stage::Verify);
    let blocks: Vec<(&str, &[Replicated])> = targets
        .iter()
        .zip(per_scene)
        .map(|(t, runs)| (t.name.as_str(), runs.as_slice()))
        .collect();
    write_output(
        &dir.verify_runs_path(),
        replicates_csv(study, &blocks).as_bytes(),
        &lineage,
    )?;
    write_output(
        &out.join("verification.md"),
        outcome.markdown.as_bytes(),
        &lineage,
    )?;
    write_output(&outcome.table, csv(&outcome.rows).as_bytes(), &lineage)
}

/// The candidate number of a verified point: the cluster group of a search
/// candidate, the sample index of the adaptive one.
fn group_of(index: u64) -> u64 {
    if index >= VERIFY_INDEX {
        index - VERIFY_INDEX
    } else {
        index
    }
}

/// The resolution figures outside their limits in the runs of `r`
/// ([`unresolved_figures`]).
fn unresolved(store: &Store, r: &Replicated) -> Result<Vec<String>, StudyError> {
    let results = store.load_results(r.runs.iter().map(|run| &run.id))?;
    Ok(unresolved_figures(&results))
}

fn csv(rows: &[VerifyRow]) -> String {
    let mut csv = CsvWriter::new(&[
        "group",
        "scene",
        "seeds",
        "measured",
        "mean_deg",
        "sd_deg",
        "ci95_half_width_deg",
        "target_deg",
        "relative_error",
        "tost_p",
        "verdict",
        "seeds_to_decide",
        "unresolved",
    ]);
    for r in rows {
        csv.row(&[
            Cell::Integer(r.group as u64),
            Cell::Text(r.scene.clone()),
            Cell::Integer(r.seeds as u64),
            Cell::Integer(r.measured as u64),
            r.mean_deg.map_or(Cell::Empty, Cell::Number),
            r.sd_deg.map_or(Cell::Empty, Cell::Number),
            r.ci95_half_width_deg.map_or(Cell::Empty, Cell::Number),
            Cell::Number(r.target_deg),
            r.relative_error.map_or(Cell::Empty, Cell::Number),
            r.judgement.p().map_or(Cell::Empty, Cell::Number),
            Cell::Text(r.judgement.verdict.to_string()),
            r.judgement
                .seeds_to_decide
                .map_or(Cell::Empty, |n| Cell::Integer(n as u64)),
            Cell::Text(r.unresolved.join("; ")),
        ]);
    }
    csv.finish()
}

fn markdown(rule: &Record, rows: &[VerifyRow]) -> String {
    let mut t = MarkdownTable::new(&[
        "candidate",
        "scene",
        "seeds (measured)",
        "simulated mean ± 95 % CI (°)",
        "σ (°)",
        "measured (°)",
        "relative error",
        "TOST p",
        "verdict",
    ]);
    for r in rows {
        t.row(&[
            r.group.to_string(),
            r.scene.clone(),
            format!("{} ({})", r.seeds, r.measured),
            r.judgement.mean_text(),
            r.sd_deg.map_or("—".into(), |s| format!("{s:.2}")),
            format!("{:.2}", r.target_deg),
            r.relative_error
                .map_or("—".into(), |e| format!("{:.1} %", 100.0 * e)),
            r.judgement.p().map_or("—".into(), |p| format!("{p:.3}")),
            if r.unresolved.is_empty() {
                r.judgement.verdict_text()
            } else {
                format!(
                    "{} — unresolved at this particle size",
                    r.judgement.verdict_text()
                )
            },
        ]);
    }
    let mut out = rule.describe();
    out.push('\n');
    out.push_str(&t.render());
    let failures: Vec<_> = rows
        .iter()
        .flat_map(|r| r.failures.iter().map(move |f| (r, f)))
        .collect();
    if !failures.is_empty() {
        out.push_str("\nSeeds without an angle:\n\n");
        for (r, f) in failures {
            let _ = writeln!(out, "- candidate {} {}: {f}", r.group, r.scene);
        }
    }
    let mut unresolved: Vec<(&str, &[String])> = Vec::new();
    for r in rows.iter().filter(|r| !r.unresolved.is_empty()) {
        if !unresolved.iter().any(|(scene, _)| *scene == r.scene) {
            unresolved.push((&r.scene, &r.unresolved));
        }
    }
    if !unresolved.is_empty() {
        out.push_str(
            "\nScenes unresolved at this particle size (src/scenes/resolution.rs gives each \
             limit and its source); their verdicts say more about the particle size than the \
             parameters:\n\n",
        );
        for (scene, figures) in unresolved {
            let _ = writeln!(out, "- {scene}: {}", figures.join("; "));
        }
    }
    out
}
