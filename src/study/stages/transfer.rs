//! The transfer test (issue 55): do the verified candidates still pass when
//! the particle is finer? A calibration at a coarse particle is worth
//! something only if its parameters keep the lab scenes' angles at the
//! particle sizes a user's equipment simulation will use; this stage
//! re-simulates every candidate the verification judged, in every scene,
//! at each of the study's transfer sizes, and judges it there by the same
//! rule.
//!
//! - **Sizes and rule.** A size is the particle radius over the verified
//!   one (a two-level study's fine size, else the study's), in (0, 1); every
//!   surface energy follows the stated rule (Γ ∝ R^p,
//!   [`crate::study::sweeps::convergence::plan::scaled`]). The study's
//!   `transfer` block states both (part of its id); `repose transfer
//!   --sizes --rule` gives them for a study without one.
//! - **Pre-registration.** The stage reads the verification's acceptance
//!   record (`verify/acceptance.json`: α, each scene's band and seeds) and
//!   writes `transfer/plan.json` — the sizes, the rule, the candidates and
//!   the record's sha256 — before its first run. Each candidate runs its
//!   verification's sample index and replicate numbers, so its packing
//!   seeds are the verification's: fixed before any result.
//! - **Verdicts.** Each candidate, scene and size is judged by the record's
//!   rule at the record's α ([`crate::study::acceptance`]). A candidate
//!   "transfers to size s" in a scene when it passes at the verified size
//!   and at every listed size down to s, and transfers to s overall when it
//!   does so in every scene. Claiming the conjunction only when every test
//!   passes is an intersection–union test: its chance of a wrong claim is
//!   at most each test's α, so the sizes need no further correction.
//! - The verified size's column is the verification's own runs (same
//!   experiments, returned by the store), so the table reads left to right
//!   from the verdict the calibration reported.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::json;

use crate::exec::Executor;
use crate::manifest::{Experiment, Study, TargetScene};
use crate::report::markdown::MarkdownTable;
use crate::report::table::{Cell, CsvWriter};
use crate::store::{RunDir, RunResult, RunStatus, Store};
use crate::study::acceptance::{Judgement, Record, Verdict};
use crate::study::dir::{json_bytes, write_output, Stage, StudyDir};
use crate::study::plan::calibration::VERIFY_INDEX;
use crate::study::records::{read_acceptance, read_verified};
use crate::study::runs::replicated::{replicates_csv, run_replicated_at, AtSize, Replicated};
use crate::study::sweeps::convergence::plan::SurfaceEnergyRule;
use crate::study::StudyError;

/// One size's runs: per scene, one entry per candidate.
type BySize = Vec<Vec<Replicated>>;

/// The transfer test's settings: the study's `transfer` block, or the
/// command line's.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferSettings {
    /// Particle radius / the verified one, each in (0, 1).
    pub sizes: Vec<f64>,
    /// How every surface energy follows the radius.
    pub rule: SurfaceEnergyRule,
}

impl TransferSettings {
    /// The study's own `transfer` block, if it has one.
    pub fn of_study(study: &Study) -> Option<TransferSettings> {
        study.transfer.as_ref().map(|t| TransferSettings {
            sizes: t.sizes.clone(),
            rule: SurfaceEnergyRule::of_manifest(t.rule),
        })
    }

    /// The sizes as factors of the study's particle, coarsest first.
    pub fn at_sizes(&self, study: &Study) -> Vec<AtSize> {
        let verified = AtSize::verified(study).factor;
        let mut sizes = self.sizes.clone();
        sizes.sort_by(|a, b| b.total_cmp(a));
        sizes
            .into_iter()
            .map(|s| AtSize {
                factor: verified * s,
                rule: self.rule,
            })
            .collect()
    }

    /// Refuses sizes outside (0, 1) or listed twice, and a rule other than
    /// the one the study's own size changes use (its `coarse_graining`
    /// block's, or a two-level study's Γ ∝ R²): the same checks as a
    /// study's `transfer` block.
    pub fn check(&self, study: &Study) -> Result<(), StudyError> {
        if self.sizes.is_empty() {
            return Err(StudyError::Settings(
                "--sizes: at least one size is needed (particle radius / the verified one, \
                 in (0, 1))"
                    .into(),
            ));
        }
        for (i, s) in self.sizes.iter().enumerate() {
            if !(*s > 0.0 && *s < 1.0) {
                return Err(StudyError::Settings(format!(
                    "--sizes: {s} must be in (0, 1) (particle radius / the verified one)"
                )));
            }
            if self.sizes[..i].contains(s) {
                return Err(StudyError::Settings(format!(
                    "--sizes: {s} is listed twice"
                )));
            }
        }
        let own = match (&study.coarse_graining, study.fidelity()) {
            (Some(cg), _) => Some(SurfaceEnergyRule::of_manifest(cg.rule)),
            (None, Some(_)) => Some(AtSize::verified(study).rule),
            (None, None) => None,
        };
        match own {
            Some(rule) if rule != self.rule => Err(StudyError::Settings(format!(
                "--rule {}: this study scales Γ by {} (its coarse_graining block or its fine \
                 level); its transfer test must use the same rule",
                self.rule.name(),
                rule.name()
            ))),
            _ => Ok(()),
        }
    }
}

/// What the stage puts on record before its first run.
#[derive(Debug, Clone, Serialize)]
pub struct TransferPlan {
    /// The sizes, radius / the verified one, coarsest first.
    pub sizes: Vec<f64>,
    /// The verified size, radius / the study's.
    pub verified_size: f64,
    /// The rule's name ([`SurfaceEnergyRule::name`]).
    pub rule: &'static str,
    /// Its exponent p of Γ ∝ R^p.
    pub rule_exponent: f64,
    /// The candidates' sample indices, in the verification's order.
    pub candidates: Vec<u64>,
    /// The acceptance record the verdicts use.
    pub acceptance: Record,
}

/// One candidate in one scene at one size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SizeCell {
    /// Radius / the verified one (1: the verification's runs).
    pub size: f64,
    /// Seeds run.
    pub seeds: usize,
    /// The rule's judgement of the measured seeds.
    pub judgement: Judgement,
    /// Why seeds have no value (one line per seed).
    pub failures: Vec<String>,
}

/// One candidate in one scene at every size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransferRow {
    /// Candidate (cluster group, or the adaptive candidate's sample index).
    pub group: u64,
    /// Scene name.
    pub scene: String,
    /// Measured (target) angle, degrees.
    pub target_deg: f64,
    /// The verified size, then each transfer size, coarsest first.
    pub cells: Vec<SizeCell>,
    /// The finest size down to which every size passes (`None`: not even
    /// the verified size).
    pub transfers_to: Option<f64>,
}

/// One candidate over every scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CandidateTransfer {
    /// Candidate.
    pub group: u64,
    /// The finest size down to which it passes at every size in every
    /// scene (`None`: it does not pass everywhere at the verified size).
    pub transfers_to: Option<f64>,
    /// Whether that is the finest size listed.
    pub every_size: bool,
}

/// The transfer test in a calibration's outcome record.
#[derive(Debug, Clone, Serialize)]
pub struct TransferRecord {
    /// Sizes (radius / the verified one), coarsest first.
    pub sizes: Vec<f64>,
    /// The rule's name.
    pub rule: &'static str,
    /// One row per candidate and scene.
    pub rows: Vec<TransferRow>,
    /// One entry per candidate.
    pub candidates: Vec<CandidateTransfer>,
    /// Runs at the finer sizes (the verified size's are verification's).
    pub finer_runs: usize,
}

/// What the transfer test did.
#[derive(Debug, Clone)]
pub struct TransferOutcome {
    /// The pre-registered plan.
    pub plan: TransferPlan,
    /// One row per candidate and scene.
    pub rows: Vec<TransferRow>,
    /// One line per candidate.
    pub candidates: Vec<CandidateTransfer>,
    /// transfer.md.
    pub markdown: String,
    /// transfer.csv.
    pub table: PathBuf,
    /// Runs that failed (store status), which the command exits with.
    pub failed_runs: usize,
    /// Runs in all (the verified size's included).
    pub runs: usize,
}

impl TransferOutcome {
    /// The outcome record's part.
    pub fn record(&self) -> TransferRecord {
        let candidates = self.plan.candidates.len();
        let per_size: usize = self.plan.acceptance.targets.iter().map(|t| t.seeds).sum();
        TransferRecord {
            sizes: self.plan.sizes.clone(),
            rule: self.plan.rule,
            rows: self.rows.clone(),
            candidates: self.candidates.clone(),
            finer_runs: per_size * candidates * self.plan.sizes.len(),
        }
    }
}

/// Runs the transfer test (module docs) with `settings`.
pub fn transfer<E, F>(
    dir: &StudyDir,
    study: &Study,
    settings: &TransferSettings,
    (store, pool): (&Store, &Executor),
    runner: F,
) -> Result<TransferOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    settings.check(study)?;
    let (record_file, record) = read_acceptance(dir)?;
    let (verified_file, points) = read_verified(dir, study)?;
    let verified = AtSize::verified(study);
    let sizes: Vec<AtSize> = std::iter::once(verified)
        .chain(settings.at_sizes(study))
        .collect();
    let plan = TransferPlan {
        sizes: sizes[1..]
            .iter()
            .map(|a| a.factor / verified.factor)
            .collect(),
        verified_size: verified.factor,
        rule: settings.rule.name(),
        rule_exponent: settings.rule.exponent(),
        candidates: points.iter().map(|(i, _)| *i).collect(),
        acceptance: record,
    };
    write_plan(dir, study, &plan, (&record_file, &verified_file))?;

    let targets: Vec<&TargetScene> = std::iter::once(&study.calibration)
        .chain(&study.verification)
        .collect();
    // runs[s][j]: size s, scene j, one entry per candidate.
    let mut runs: Vec<BySize> = Vec::new();
    for at in &sizes {
        let mut per_scene = Vec::new();
        for (target, accepted) in targets.iter().zip(&plan.acceptance.targets) {
            let seeds = accepted.seeds as u32;
            let (done, _) = run_replicated_at(
                study, target, &points, seeds, *at, store, pool, &runner, false,
            )?;
            per_scene.push(done);
        }
        runs.push(per_scene);
    }
    let relative: Vec<f64> = std::iter::once(1.0).chain(plan.sizes.clone()).collect();
    let rows = rows(&plan, &targets, &relative, &runs);
    let candidates = candidates(&plan, &rows, &relative);
    let all = || runs.iter().flatten().flatten().flat_map(|p| &p.runs);
    let outcome = TransferOutcome {
        markdown: markdown(&plan, &rows, &candidates),
        failed_runs: all()
            .filter(|r| store.status(&r.id) == RunStatus::Failed)
            .count(),
        runs: all().count(),
        table: dir.transfer_path(),
        plan,
        rows,
        candidates,
    };
    write_outputs(dir, study, store, (&targets, &relative, &runs), &outcome)?;
    Ok(outcome)
}

/// Writes `transfer/plan.json` with its lineage (the acceptance record and
/// the verified candidates' runs).
fn write_plan(
    dir: &StudyDir,
    study: &Study,
    plan: &TransferPlan,
    (record_file, verified_file): (&Path, &Path),
) -> Result<(), StudyError> {
    dir.prepare_stage(study, Stage::Transfer)?;
    let lineage = dir
        .lineage(Stage::Transfer, json!({ "record": "transfer plan" }))
        .with_input(dir.input("acceptance", record_file)?)
        .with_input(dir.input("verified", verified_file)?);
    write_output(&dir.transfer_plan_path(), &json_bytes(plan), &lineage)
}

/// One row per candidate and scene, each size judged by the plan's record.
fn rows(
    plan: &TransferPlan,
    targets: &[&TargetScene],
    relative: &[f64],
    runs: &[BySize],
) -> Vec<TransferRow> {
    let mut rows = Vec::new();
    for (k, index) in plan.candidates.iter().enumerate() {
        for (j, target) in targets.iter().enumerate() {
            let cells: Vec<SizeCell> = relative
                .iter()
                .zip(runs)
                .map(|(size, at)| {
                    let r = &at[j][k];
                    SizeCell {
                        size: *size,
                        seeds: r.runs.len(),
                        judgement: plan.acceptance.judge(j, &r.values()),
                        failures: r
                            .runs
                            .iter()
                            .filter_map(|s| {
                                let why = s.value.as_ref().err()?;
                                Some(format!("seed {}: {why}", s.replicate))
                            })
                            .collect(),
                    }
                })
                .collect();
            let passed = passing_prefix(&cells);
            rows.push(TransferRow {
                group: group_of(*index),
                scene: target.name.clone(),
                target_deg: target.target_angle_deg,
                transfers_to: passed.checked_sub(1).map(|i| relative[i]),
                cells,
            });
        }
    }
    rows
}

/// How many leading sizes (the verified one first) pass.
fn passing_prefix(cells: &[SizeCell]) -> usize {
    cells
        .iter()
        .take_while(|c| c.judgement.verdict == Verdict::Pass)
        .count()
}

/// Each candidate over every scene: the sizes passed in all of them.
fn candidates(
    plan: &TransferPlan,
    rows: &[TransferRow],
    relative: &[f64],
) -> Vec<CandidateTransfer> {
    plan.candidates
        .iter()
        .map(|index| {
            let group = group_of(*index);
            let passed = rows
                .iter()
                .filter(|r| r.group == group)
                .map(|r| passing_prefix(&r.cells))
                .min()
                .unwrap_or(0);
            CandidateTransfer {
                group,
                transfers_to: passed.checked_sub(1).map(|i| relative[i]),
                every_size: passed == relative.len(),
            }
        })
        .collect()
}

/// The candidate number of a verified point, as the verification numbers
/// it: the cluster group of a search candidate, the adaptive candidate's
/// sample index.
fn group_of(index: u64) -> u64 {
    index.checked_sub(VERIFY_INDEX).unwrap_or(index)
}

/// Writes `runs.csv` (every size's runs, the scene named with its size),
/// `transfer.md` and `transfer.csv`, with their lineage (the plan and every
/// run's result).
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    (targets, relative, runs): (&[&TargetScene], &[f64], &[BySize]),
    outcome: &TransferOutcome,
) -> Result<(), StudyError> {
    let mut lineage = dir
        .lineage(
            Stage::Transfer,
            json!({ "sizes": outcome.plan.sizes, "rule": outcome.plan.rule }),
        )
        .with_input(dir.input("plan", &dir.transfer_plan_path())?);
    for r in runs.iter().flatten().flatten().flat_map(|p| &p.runs) {
        let file = store.run_dir(&r.id).result_path();
        if file.is_file() {
            lineage = lineage.with_input(dir.input("result", &file)?);
        }
    }
    let names: Vec<Vec<String>> = relative
        .iter()
        .map(|s| targets.iter().map(|t| format!("{} x{s}", t.name)).collect())
        .collect();
    let blocks: Vec<(&str, &[Replicated])> = names
        .iter()
        .zip(runs)
        .flat_map(|(n, at)| n.iter().zip(at))
        .map(|(name, points)| (name.as_str(), points.as_slice()))
        .collect();
    let out = dir.stage(Stage::Transfer);
    write_output(
        &out.join("runs.csv"),
        replicates_csv(study, &blocks).as_bytes(),
        &lineage,
    )?;
    write_output(
        &out.join("transfer.md"),
        outcome.markdown.as_bytes(),
        &lineage,
    )?;
    write_output(&outcome.table, csv(&outcome.rows).as_bytes(), &lineage)
}

fn csv(rows: &[TransferRow]) -> String {
    let mut csv = CsvWriter::new(&[
        "group",
        "scene",
        "size",
        "seeds",
        "measured",
        "mean_deg",
        "sd_deg",
        "ci95_half_width_deg",
        "target_deg",
        "tost_p",
        "verdict",
        "seeds_to_decide",
    ]);
    for r in rows {
        for c in &r.cells {
            let j = &c.judgement;
            csv.row(&[
                Cell::Integer(r.group),
                Cell::Text(r.scene.clone()),
                Cell::Number(c.size),
                Cell::Integer(c.seeds as u64),
                Cell::Integer(j.n as u64),
                j.mean.map_or(Cell::Empty, Cell::Number),
                j.tost.map_or(Cell::Empty, |t| Cell::Number(t.sd)),
                j.ci95_half_width().map_or(Cell::Empty, Cell::Number),
                Cell::Number(r.target_deg),
                j.p().map_or(Cell::Empty, Cell::Number),
                Cell::Text(j.verdict.to_string()),
                j.seeds_to_decide
                    .map_or(Cell::Empty, |n| Cell::Integer(n as u64)),
            ]);
        }
    }
    csv.finish()
}

/// A size as a column heading and in sentences.
fn size_label(size: f64) -> String {
    format!("×{size}")
}

/// One cell of the Markdown table: mean ± 95 % CI, verdict, TOST p.
fn cell_text(c: &SizeCell) -> String {
    let j = &c.judgement;
    let value = j.mean_text();
    match j.p() {
        Some(p) => format!("{value}: {} (p {p:.3})", j.verdict_text()),
        None => format!("{value}: {}", j.verdict_text()),
    }
}

/// transfer.md: the record, the plan, the table and one line per candidate.
fn markdown(plan: &TransferPlan, rows: &[TransferRow], candidates: &[CandidateTransfer]) -> String {
    let mut out = plan.acceptance.describe();
    let sizes: Vec<String> = plan.sizes.iter().map(|s| size_label(*s)).collect();
    let _ = writeln!(
        out,
        "\nTransfer test: every verified candidate at particle radius {} of the verified one \
         ({}× the study's), surface energy by `{}` (Γ ∝ R^{}), with the verification's \
         seeds and rule. Each cell: simulated mean ± 95 % CI (°), verdict, TOST p.\n",
        sizes.join(", "),
        plan.verified_size,
        plan.rule,
        plan.rule_exponent
    );
    let mut header = vec![
        "candidate".to_string(),
        "scene".into(),
        "measured (°)".into(),
        "×1 (verified)".into(),
    ];
    header.extend(sizes.iter().cloned());
    header.push("transfers to".into());
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut t = MarkdownTable::new(&header);
    for r in rows {
        let mut cells = vec![
            r.group.to_string(),
            r.scene.clone(),
            format!("{:.2}", r.target_deg),
        ];
        cells.extend(r.cells.iter().map(cell_text));
        cells.push(r.transfers_to.map_or("—".into(), size_label));
        t.row(&cells);
    }
    out.push_str(&t.render());
    out.push('\n');
    for c in candidates {
        let line = match (c.transfers_to, c.every_size) {
            (None, _) => format!(
                "Candidate {}: does not pass in every scene at the verified size; nothing to \
                 transfer.",
                c.group
            ),
            (Some(_), true) => format!(
                "Candidate {}: **transfers** to every listed size ({}) in every scene.",
                c.group,
                sizes.join(", ")
            ),
            (Some(1.0), false) => format!(
                "Candidate {}: passes in every scene at the verified size only; does not \
                 transfer to {}.",
                c.group, sizes[0]
            ),
            (Some(s), false) => format!(
                "Candidate {}: transfers down to {} in every scene, not further.",
                c.group,
                size_label(s)
            ),
        };
        let _ = writeln!(out, "- {line}");
    }
    let failures: Vec<String> = rows
        .iter()
        .flat_map(|r| {
            r.cells.iter().flat_map(move |c| {
                c.failures.iter().map(move |f| {
                    format!(
                        "- candidate {} {} {}: {f}",
                        r.group,
                        r.scene,
                        size_label(c.size)
                    )
                })
            })
        })
        .collect();
    if !failures.is_empty() {
        out.push_str("\nSeeds without an angle:\n\n");
        out.push_str(&failures.join("\n"));
        out.push('\n');
    }
    out
}
