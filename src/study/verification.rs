//! The re-simulation of a design study's named points (and a model's
//! optimum) with `verification.replicates` packing seeds each, judged by
//! the project's one acceptance rule: the shared step of `repose verify`
//! (the response surface's optimum,
//! [`crate::study::stages::verify_optimum`]) and `repose sensitivity` (the
//! power laws' named points, [`crate::study::stages::sensitivity`]).
//!
//! Per point and response: the simulated mean ± 95 % CI (Student t, n − 1
//! df), the model's prediction there, the measured target, the relative
//! error of the mean, and the verdict of the acceptance rule
//! ([`crate::study::acceptance`]: TOST against target × (1 ∓ tolerance);
//! pass, fail, or inconclusive with the seeds that would decide). The
//! acceptance record (`<stage>/acceptance.json`: the rule, the replicates,
//! every target's band) is written with its lineage before the first run.
//! The verification runs draw their own packing seeds (stage `verify`), never
//! those of the design; a replicate that could not measure a response is
//! missing from that response's n, not a value.

use std::path::Path;

use serde::Serialize;

use crate::exec::Executor;
use crate::manifest::Experiment;
use crate::report::table::{Cell, CsvWriter};
use crate::scenes::resolution::unresolved_figures;
use crate::stats::summary::mean_ci;
use crate::store::{RunDir, RunResult, Store};
use crate::study::acceptance::{judge_at, AcceptedTarget, Judgement, Record};
use crate::study::dir::{json_bytes, write_output, StudyDir};
use crate::study::plan::design_study::{DesignStudy, SeedStage, Verification as VerificationPlan};
use crate::study::runs::{run_points, write_table, Point, Runs};
use crate::study::StudyError;

/// One response at one verified point.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    /// Point name (`optimum` or a key of `verification.points`).
    pub point: String,
    /// Response name.
    pub response: String,
    /// Replicates that measured it.
    pub n: usize,
    /// Simulated mean.
    pub mean: Option<f64>,
    /// 95 % CI half-width of the mean (n ≥ 2).
    pub ci95_half_width: Option<f64>,
    /// The model's prediction at the point (None where the model has none).
    pub predicted: Option<f64>,
    /// The measured target, if any.
    pub target: Option<f64>,
    /// (mean − target) / target.
    pub relative_error: Option<f64>,
    /// The acceptance rule's judgement (None without a target).
    pub judgement: Option<Judgement>,
    /// The response's scene's resolution figures outside their limits in
    /// these runs ([`crate::scenes::resolution`]): unresolved at this
    /// particle size.
    pub unresolved: Vec<String>,
}

/// What verification found.
#[derive(Debug, Clone, Serialize)]
pub struct Verification {
    /// The points in actual units: (name, factor values).
    pub points: Vec<(String, Vec<f64>)>,
    /// One check per point and response.
    pub checks: Vec<Check>,
    /// Runs, and how many were in the store.
    pub runs: usize,
    /// Runs cached before the stage.
    pub cached: usize,
    /// Replicates lacking a response (failed or unmeasurable runs).
    pub incomplete: usize,
}

/// What one verification checks: where it writes, the model's optimum (if
/// any), the responses it judges and the model's prediction of each.
pub struct Checked<'a> {
    /// The stage directory, relative to the study's (`verify`,
    /// `sensitivity/noise`), also the stage name of its lineage.
    pub stage: &'a str,
    /// The model's optimum, (name, actual factor values), verified at
    /// index 0 before the named points.
    pub optimum: Option<(&'a str, &'a [f64])>,
    /// The responses to judge, in the order of the checks.
    pub responses: &'a [String],
    /// The model's prediction of a response at actual factor values (None
    /// where the model has none).
    pub predict: &'a dyn Fn(&str, &[f64]) -> Option<f64>,
}

/// A verified point: its name, its index among the verification's points
/// (which draws its packing seeds) and its factor values, actual units.
type Named = (String, u64, Vec<f64>);

/// The points a verification re-simulates: `optimum` (if any) at index 0,
/// then the study's named points at indices 1, 2, … in name order, whether
/// or not there is an optimum — so a named point draws the same packing
/// seeds in every stage that verifies it, and its runs are shared.
fn named_points(study: &DesignStudy, optimum: Option<(&str, &[f64])>) -> Vec<Named> {
    let names = study.factor_names();
    let mut named = Vec::new();
    if let Some((name, best)) = optimum {
        named.push((name.to_string(), 0, best.to_vec()));
    }
    if let Some(plan) = &study.verification {
        for (k, (name, values)) in plan.points.iter().enumerate() {
            named.push((
                name.clone(),
                k as u64 + 1,
                names.iter().map(|f| values[f]).collect(),
            ));
        }
    }
    named
}

/// Re-simulates `checked.optimum` and the study's named points with
/// `verification.replicates` packing seeds (stage [`SeedStage::Verify`]) and
/// checks each of `checked.responses` against its target, beside the
/// model's prediction; writes `<stage>/acceptance.json`, `responses.csv`,
/// `verification.csv` and `verification.md`. `None` when the study has no
/// verification block.
pub fn verify_points<E, F>(
    dir: &StudyDir,
    study: &DesignStudy,
    checked: &Checked<'_>,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<Option<Verification>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let Some(plan) = &study.verification else {
        return Ok(None);
    };
    let named = named_points(study, checked.optimum);
    let points: Vec<Point> = named
        .iter()
        .map(|(_, index, actual)| Point {
            index: *index,
            values: study
                .factors
                .values()
                .zip(actual)
                .map(|(f, v)| (f.address.clone(), *v))
                .collect(),
            shown: actual.clone(),
        })
        .collect();
    let stage = dir.create_stage(checked.stage)?;
    let record = acceptance_record(study, plan, checked.responses);
    write_output(
        &stage.join("acceptance.json"),
        &json_bytes(&record),
        &dir.lineage(
            checked.stage,
            serde_json::json!({ "record": "acceptance rule" }),
        ),
    )?;
    let runs = run_points(
        study,
        store,
        pool,
        runner,
        SeedStage::Verify,
        study.factor_names(),
        points,
        plan.replicates,
    )?;
    write_table(
        dir,
        checked.stage,
        study,
        &runs,
        &stage.join("responses.csv"),
    )?;
    let checks = checks(store, study, (&runs, &named), &record, checked)?;
    let outcome = Verification {
        points: named.into_iter().map(|(n, _, v)| (n, v)).collect(),
        checks,
        runs: runs.total,
        cached: runs.cached,
        incomplete: runs.incomplete(),
    };
    write_outputs(dir, &stage, (checked.stage, plan), study, &outcome)?;
    Ok(Some(outcome))
}

/// The acceptance record of a verification: one band per judged response
/// with a target, at the plan's replicates.
fn acceptance_record(study: &DesignStudy, plan: &VerificationPlan, responses: &[String]) -> Record {
    Record::new(
        1,
        responses
            .iter()
            .filter_map(|r| {
                study.targets.get(r).map(|t| {
                    AcceptedTarget::new(
                        r,
                        r,
                        t.value,
                        t.tolerance_fraction,
                        plan.replicates as usize,
                    )
                })
            })
            .collect(),
    )
}

/// One check per judged response and verified point (`named`, in the order
/// of `runs`' points): the replicates' mean ± 95 % CI, the prediction, the
/// target and the rule's judgement.
fn checks(
    store: &Store,
    study: &DesignStudy,
    (runs, named): (&Runs, &[Named]),
    record: &Record,
    checked: &Checked<'_>,
) -> Result<Vec<Check>, StudyError> {
    let mut checks = Vec::new();
    for response in checked.responses {
        let values = runs.by_point(response);
        for (k, (name, _, actual)) in named.iter().enumerate() {
            let summary = mean_ci(&values[k]);
            let mean = summary
                .map(|s| s.mean)
                .or_else(|| values[k].first().copied());
            let target = study.targets.get(response);
            let relative_error = mean.zip(target).map(|(m, t)| (m - t.value) / t.value);
            checks.push(Check {
                point: name.clone(),
                response: response.clone(),
                n: values[k].len(),
                mean,
                ci95_half_width: summary.map(|s| s.half_width),
                predicted: (checked.predict)(response, actual),
                target: target.map(|t| t.value),
                relative_error,
                judgement: record
                    .targets
                    .iter()
                    .find(|t| t.response == *response)
                    .map(|t| judge_at(&values[k], t.band, record.alpha)),
                unresolved: unresolved(store, study, runs, k, response)?,
            });
        }
    }
    Ok(checks)
}

/// Writes `verification.csv` and `verification.md` into `stage` with their
/// lineage (the stage `stage_name`, the plan's replicates and the response
/// table).
fn write_outputs(
    dir: &StudyDir,
    stage: &Path,
    (stage_name, plan): (&str, &VerificationPlan),
    study: &DesignStudy,
    outcome: &Verification,
) -> Result<(), StudyError> {
    let lineage = dir
        .lineage(
            stage_name,
            serde_json::json!({ "replicates": plan.replicates }),
        )
        .with_input(dir.input("responses", &stage.join("responses.csv"))?);
    write_output(
        &stage.join("verification.csv"),
        csv(outcome).as_bytes(),
        &lineage,
    )?;
    write_output(
        &stage.join("verification.md"),
        markdown(study, outcome).as_bytes(),
        &lineage,
    )
}

/// The resolution figures outside their limits in point `k`'s runs of the
/// scene that measures `response`.
fn unresolved(
    store: &Store,
    study: &DesignStudy,
    runs: &Runs,
    k: usize,
    response: &str,
) -> Result<Vec<String>, StudyError> {
    let Some(scene) = study.responses.get(response).map(|r| &r.scene) else {
        return Ok(Vec::new());
    };
    let ids = runs
        .replicates
        .iter()
        .filter(|r| r.point == k)
        .filter_map(|r| r.ids.get(scene));
    Ok(unresolved_figures(&store.load_results(ids)?))
}

fn csv(v: &Verification) -> String {
    let mut csv = CsvWriter::new(
        &[
            "point",
            "response",
            "n",
            "mean",
            "ci95_half_width",
            "predicted",
            "target",
            "relative_error",
            "tost_p",
            "verdict",
            "seeds_to_decide",
            "unresolved",
        ]
        .map(String::from),
    );
    let num = |x: Option<f64>| x.map_or(Cell::Empty, Cell::Number);
    for c in &v.checks {
        csv.row(&[
            Cell::Text(c.point.clone()),
            Cell::Text(c.response.clone()),
            Cell::Integer(c.n as u64),
            num(c.mean),
            num(c.ci95_half_width),
            num(c.predicted),
            num(c.target),
            num(c.relative_error),
            num(c.judgement.and_then(|j| j.p())),
            Cell::Text(c.judgement.map_or(String::new(), |j| j.verdict.to_string())),
            c.judgement
                .and_then(|j| j.seeds_to_decide)
                .map_or(Cell::Empty, |n| Cell::Integer(n as u64)),
            Cell::Text(c.unresolved.join("; ")),
        ]);
    }
    csv.finish()
}

/// The verification table in Markdown.
pub fn markdown(study: &DesignStudy, v: &Verification) -> String {
    let names = study.factor_names();
    let mut md = format!(
        "# {} — verification ({} runs).{}\n\n| Point | {} |\n|---|{}\n",
        study.name,
        v.runs,
        crate::study::runs::incomplete_note(v.incomplete),
        names.join(" | "),
        "---:|".repeat(names.len())
    );
    for (name, values) in &v.points {
        let cells: Vec<String> = values.iter().map(|x| format!("{x:.4}")).collect();
        md.push_str(&format!("| {name} | {} |\n", cells.join(" | ")));
    }
    md.push_str("\n| Point | Response | n | Simulated mean ± 95 % CI | Model | Measured | Error | TOST p | Verdict |\n|---|---|---:|---|---:|---:|---:|---:|---|\n");
    for c in &v.checks {
        let sim = match (c.mean, c.ci95_half_width) {
            (Some(m), Some(h)) => format!("{m:.2} ± {h:.2}"),
            (Some(m), None) => format!("{m:.2}"),
            _ => "not measured".into(),
        };
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            c.point,
            c.response,
            c.n,
            sim,
            c.predicted.map_or(String::new(), |p| format!("{p:.2}")),
            c.target.map_or(String::new(), |t| format!("{t}")),
            c.relative_error
                .map_or(String::new(), |e| format!("{:+.2} %", 100.0 * e)),
            c.judgement
                .and_then(|j| j.p())
                .map_or(String::new(), |p| format!("{p:.3}")),
            c.judgement
                .map_or(String::new(), |j| if c.unresolved.is_empty() {
                    j.verdict_text()
                } else {
                    format!(
                        "{} — unresolved at this particle size ({})",
                        j.verdict_text(),
                        c.unresolved.join("; ")
                    )
                })
        ));
    }
    md
}
