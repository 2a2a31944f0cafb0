//! `repose screen STUDY`: one-factor-at-a-time tests. Each screened factor
//! is set to each of its levels with everything else at the base (design
//! factors at the centres of their ranges), `screening.replicates` packing
//! seeds per level. Per factor and response: the mean ± 95 % CI per level,
//! and a one-way ANOVA across the levels; a factor is marked significant
//! for a response when its p-value is below `screening.alpha`.

use std::path::Path;

use serde::Serialize;

use crate::doe::ofat::{one_factor_at_a_time, OfatRun};
use crate::exec::Executor;
use crate::manifest::Experiment;
use crate::report::plots::{level_means, LevelPanel};
use crate::report::table::{Cell, CsvWriter};
use crate::stats::oneway::one_way_anova;
use crate::stats::summary::mean_ci;
use crate::store::{RunDir, RunResult, Store};
use crate::study::dir::{write_output, StudyDir};
use crate::study::plan::design_study::{DesignStudy, ScreenFactor, SeedStage};
use crate::study::runs::{run_points, write_table, Point, Runs};
use crate::study::StudyError;

/// One level of one screened factor, for one response.
#[derive(Debug, Clone, Serialize)]
pub struct Level {
    /// The level, actual units.
    pub value: f64,
    /// Replicates that measured the response.
    pub n: usize,
    /// Mean.
    pub mean: Option<f64>,
    /// 95 % CI half-width of the mean.
    pub ci95_half_width: Option<f64>,
}

/// One screened factor's effect on one response.
#[derive(Debug, Clone, Serialize)]
pub struct Effect {
    /// Factor name.
    pub factor: String,
    /// Its label (or address).
    pub label: String,
    /// Response name.
    pub response: String,
    /// Per level.
    pub levels: Vec<Level>,
    /// One-way ANOVA F across the levels.
    pub f: Option<f64>,
    /// Its p-value.
    pub p: Option<f64>,
    /// p < alpha.
    pub significant: bool,
}

/// What screening found.
#[derive(Debug, Clone, Serialize)]
pub struct Screen {
    /// Significance level used.
    pub alpha: f64,
    /// Per factor and response.
    pub effects: Vec<Effect>,
    /// Runs, and how many were in the store.
    pub runs: usize,
    /// Runs cached before the stage.
    pub cached: usize,
    /// Replicates lacking a response (failed or unmeasurable runs).
    pub incomplete: usize,
}

/// A screened factor: its name and its screening settings.
type Screened<'a> = (&'a String, &'a ScreenFactor);

/// Runs the screening (see the module docs) and writes its outputs.
pub fn screen<E, F>(
    dir: &StudyDir,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<Screen, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let Some(plan) = &study.screening else {
        return Err(StudyError::Settings(format!(
            "study {} has no `screening` block: nothing to screen",
            study.name
        )));
    };
    let factors: Vec<Screened> = plan.factors.iter().collect();
    let levels: Vec<Vec<f64>> = factors.iter().map(|(_, f)| f.levels.clone()).collect();
    let base: Vec<f64> = levels.iter().map(|l| l[0]).collect();
    let design = one_factor_at_a_time(&base, &levels)?;
    let points = screen_points(study, &factors, &design);
    let stage = dir.create_stage("screen")?;
    let runs = run_points(
        study,
        store,
        pool,
        runner,
        SeedStage::Screen,
        vec!["factor_index".into(), "level".into()],
        points,
        plan.replicates,
    )?;
    write_table(dir, "screen", study, &runs, &stage.join("responses.csv"))?;
    let outcome = Screen {
        alpha: plan.alpha,
        effects: effects(study, plan.alpha, &factors, &design, &runs),
        runs: runs.total,
        cached: runs.cached,
        incomplete: runs.incomplete(),
    };
    write_outputs(dir, &stage, study, plan.replicates, &outcome)?;
    Ok(outcome)
}

/// The screening's run points: each design run's screened factor at its
/// level, every other design factor at the centre of its range. A point is
/// shown as (factor index, level).
fn screen_points(study: &DesignStudy, factors: &[Screened], design: &[OfatRun]) -> Vec<Point> {
    let centre: Vec<(String, f64)> = study
        .factors
        .values()
        .map(|f| (f.address.clone(), 0.5 * (f.min + f.max)))
        .collect();
    // The base value of a screened address is not needed: each run sets it.
    design
        .iter()
        .enumerate()
        .map(|(i, run)| {
            let (_, f) = factors[run.factor];
            let mut values: Vec<(String, f64)> = centre
                .iter()
                .filter(|(a, _)| *a != f.address)
                .cloned()
                .collect();
            values.push((f.address.clone(), run.point[run.factor]));
            Point {
                index: i as u64,
                values,
                shown: vec![run.factor as f64, run.point[run.factor]],
            }
        })
        .collect()
}

/// Per response and screened factor: the mean ± 95 % CI per level and the
/// one-way ANOVA across the measured levels, significant below `alpha`.
fn effects(
    study: &DesignStudy,
    alpha: f64,
    factors: &[Screened],
    design: &[OfatRun],
    runs: &Runs,
) -> Vec<Effect> {
    let mut effects = Vec::new();
    for response in study.responses.keys() {
        let values = runs.by_point(response);
        for (k, (name, f)) in factors.iter().enumerate() {
            let groups: Vec<Vec<f64>> = design
                .iter()
                .zip(&values)
                .filter(|(run, _)| run.factor == k)
                .map(|(_, v)| v.clone())
                .collect();
            let levels: Vec<Level> = f
                .levels
                .iter()
                .zip(&groups)
                .map(|(value, g)| {
                    let s = mean_ci(g);
                    Level {
                        value: *value,
                        n: g.len(),
                        mean: s.map(|s| s.mean).or_else(|| g.first().copied()),
                        ci95_half_width: s.map(|s| s.half_width),
                    }
                })
                .collect();
            // Levels whose runs all failed drop out of the test (the table
            // shows them with n = 0 and their runs' errors).
            let measured: Vec<Vec<f64>> =
                groups.iter().filter(|g| !g.is_empty()).cloned().collect();
            let anova = one_way_anova(&measured).ok();
            let p = anova.as_ref().map(|a| a.p);
            effects.push(Effect {
                factor: (*name).clone(),
                label: f.display_name(),
                response: response.clone(),
                levels,
                f: anova.as_ref().map(|a| a.f),
                p,
                significant: p.is_some_and(|p| p < alpha),
            });
        }
    }
    effects
}

/// Writes the screening's outputs with their lineage (the settings and the
/// response table): one level-means plot per response, `levels.csv` and
/// `screen.md`.
fn write_outputs(
    dir: &StudyDir,
    stage: &Path,
    study: &DesignStudy,
    replicates: u32,
    outcome: &Screen,
) -> Result<(), StudyError> {
    let lineage = dir
        .lineage(
            "screen",
            serde_json::json!({ "replicates": replicates, "alpha": outcome.alpha }),
        )
        .with_input(dir.input("responses", &stage.join("responses.csv"))?);
    for response in study.responses.keys() {
        let svg = level_means(
            &panels(outcome, response),
            &format!("{}: {response} by factor level", study.name),
        )
        .map_err(|e| StudyError::Plot(e.to_string()))?;
        write_output(
            &stage.join(format!("{response}.svg")),
            svg.as_bytes(),
            &lineage,
        )?;
    }
    write_output(
        &stage.join("levels.csv"),
        levels_csv(outcome).as_bytes(),
        &lineage,
    )?;
    write_output(
        &stage.join("screen.md"),
        markdown(study, outcome).as_bytes(),
        &lineage,
    )
}

/// The level-means panels of `response`: one per factor with a measured
/// level, its unmeasured levels left out and counted in the note.
fn panels(outcome: &Screen, response: &str) -> Vec<LevelPanel> {
    outcome
        .effects
        .iter()
        .filter(|e| e.response == response)
        .filter(|e| e.levels.iter().any(|l| l.mean.is_some()))
        .map(|e| {
            let shown: Vec<&Level> = e.levels.iter().filter(|l| l.mean.is_some()).collect();
            let missing = e.levels.len() - shown.len();
            let p =
                e.p.map_or("ANOVA: n/a".into(), |p| format!("one-way ANOVA p = {p:.3}"));
            LevelPanel {
                factor: e.factor.clone(),
                unit: String::new(),
                response: response.to_string(),
                levels: shown.iter().map(|l| l.value).collect(),
                means: shown.iter().filter_map(|l| l.mean).collect(),
                ci_half: shown
                    .iter()
                    .map(|l| l.ci95_half_width.unwrap_or(0.0))
                    .collect(),
                note: if missing > 0 {
                    format!("{p}; {missing} level(s) unmeasured")
                } else {
                    p
                },
            }
        })
        .collect()
}

fn levels_csv(s: &Screen) -> String {
    let mut csv = CsvWriter::new(
        &[
            "factor",
            "response",
            "level",
            "n",
            "mean",
            "ci95_half_width",
            "anova_f",
            "anova_p",
            "significant",
        ]
        .map(String::from),
    );
    let num = |x: Option<f64>| x.map_or(Cell::Empty, Cell::Number);
    for e in &s.effects {
        for l in &e.levels {
            csv.row(&[
                Cell::Text(e.factor.clone()),
                Cell::Text(e.response.clone()),
                Cell::Number(l.value),
                Cell::Integer(l.n as u64),
                num(l.mean),
                num(l.ci95_half_width),
                num(e.f),
                num(e.p),
                Cell::Text(e.significant.to_string()),
            ]);
        }
    }
    csv.finish()
}

/// The screening summary in Markdown.
pub fn markdown(study: &DesignStudy, s: &Screen) -> String {
    let mut md = format!(
        "# {} — one-factor screening ({} runs; α = {}).{}\n\n",
        study.name,
        s.runs,
        s.alpha,
        crate::study::runs::incomplete_note(s.incomplete)
    );
    md.push_str("| Factor | Response | Level means ± 95 % CI | F | p | Significant |\n|---|---|---|---:|---:|---|\n");
    for e in &s.effects {
        let levels: Vec<String> = e
            .levels
            .iter()
            .map(|l| match (l.mean, l.ci95_half_width) {
                (Some(m), Some(h)) => format!("{}: {m:.2} ± {h:.2}", l.value),
                (Some(m), None) => format!("{}: {m:.2}", l.value),
                _ => format!("{}: –", l.value),
            })
            .collect();
        md.push_str(&format!(
            "| {} ({}) | {} | {} | {} | {} | {} |\n",
            e.factor,
            e.label,
            e.response,
            levels.join("; "),
            e.f.map_or(String::new(), |f| format!("{f:.3}")),
            e.p.map_or(String::new(), |p| format!("{p:.4}")),
            if e.significant { "yes" } else { "no" }
        ));
    }
    md
}
