//! `repose rsm STUDY`: the design's runs, a full quadratic model per
//! response with its ANOVA, predicted vs actual and contour plots, and the
//! joint desirability optimum of the responses with targets.
//!
//! Every replicate enters the fit as its own observation, so replicated
//! points (the centre points, and every point when `replicates` ≥ 2) give
//! the pure error and the lack-of-fit test its meaning. The contour plot
//! shows the two factors with the largest summed term sums of squares, the
//! other factors held at the optimum (or the centre without targets).
//! [`analyse_table`] runs the same analysis on any CSV table.
//!
//! With `fit: "gp"` each response gets a Gaussian process instead
//! ([`gp_surface`]): no ANOVA, coefficients or contour, but gp.json
//! and a parity plot; the desirability optimum and the verification use the
//! GP's mean. A Latin hypercube design (`design.kind: "lhs"`) is coded from
//! the unit strata onto [−1, 1] and decoded through the factor ranges.

pub mod gp_surface;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::doe::Range;
use crate::exec::Executor;
use crate::manifest::Experiment;
use crate::report::plots::{contour, curves, predicted_vs_actual, ContourGrid, Curve};
use crate::report::table::{Cell, CsvWriter, Table};
use crate::search::desirability::{maximise, Goal, Model, Search};
use crate::stats::rsm::{fit_quadratic, AnovaRow, RsmFit};
use crate::store::{Lineage, RunDir, RunResult, Store};
use crate::study::dir::{json_bytes, write_output, StudyDir};
use crate::study::plan::design_study::{
    actual_design, coded_design, DesignStudy, FitChoice, SeedStage,
};
use crate::study::runs::{design_points, run_points, write_table, Runs};
use crate::study::StudyError;
use gp_surface::{analyse_gp, GpAnalysis};

/// Starts of the desirability search.
pub const OPTIMISER_STARTS: usize = 64;

/// One response's analysis.
#[derive(Debug, Clone, Serialize)]
pub struct ResponseAnalysis {
    /// Response name.
    pub response: String,
    /// Observations that entered the fit.
    pub observations: usize,
    /// Observations missing (failed or unmeasured runs).
    pub missing: usize,
    /// The fit and its ANOVA (coded units).
    pub fit: RsmFit,
    /// The model in actual units: (term, coefficient).
    pub actual_coefficients: Vec<(String, f64)>,
}

/// What `repose rsm` found.
#[derive(Debug, Clone, Serialize)]
pub struct RsmOutcome {
    /// Study name.
    pub study: String,
    /// Study id.
    pub study_id: String,
    /// Factor names and (label, address, min, max).
    pub factors: Vec<(String, String, String, f64, f64)>,
    /// Runs in the stage; how many the store already held.
    pub runs: usize,
    /// Runs cached before the stage.
    pub cached: usize,
    /// Replicates lacking a response (failed or unmeasurable runs).
    pub incomplete: usize,
    /// Per response, when the study fits quadratics.
    pub analyses: Vec<ResponseAnalysis>,
    /// Per response, when the study fits Gaussian processes.
    pub gp: Vec<GpAnalysis>,
    /// The desirability optimum (when the study has targets).
    pub optimum: Option<Search>,
    /// The optimum's factors in actual units (best optimum).
    pub optimum_actual: Option<Vec<f64>>,
    /// The output directory.
    pub dir: PathBuf,
}

/// Fits one response from coded rows and values.
pub fn analyse(
    response: &str,
    coded: &[Vec<f64>],
    y: &[f64],
    names: &[String],
    ranges: &[Range],
    missing: usize,
) -> Result<ResponseAnalysis, StudyError> {
    let fit = fit_quadratic(coded, y, names).map_err(|e| StudyError::Analysis {
        response: response.into(),
        message: e.to_string(),
    })?;
    let bounds: Vec<(f64, f64)> = ranges.iter().map(|r| (r.low, r.high)).collect();
    let actual_coefficients = fit.actual_coefficients(&bounds);
    Ok(ResponseAnalysis {
        response: response.into(),
        observations: y.len(),
        missing,
        fit,
        actual_coefficients,
    })
}

/// The coded rows and values of `response` over every replicate that
/// measured it, and how many did not.
fn observations(
    runs: &Runs,
    coded: &[Vec<f64>],
    response: &str,
) -> (Vec<Vec<f64>>, Vec<f64>, usize) {
    let (mut x, mut y, mut missing) = (Vec::new(), Vec::new(), 0);
    for r in &runs.replicates {
        match r.responses.get(response).copied().flatten() {
            Some(v) => {
                x.push(coded[r.point].clone());
                y.push(v);
            }
            None => missing += 1,
        }
    }
    (x, y, missing)
}

/// Runs the stage (see the module docs) and writes its outputs.
pub fn rsm<E, F>(
    dir: &StudyDir,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<RsmOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    if study.fit == FitChoice::Quadratic {
        study.check_quadratic()?;
    }
    let stage = dir.create_stage("rsm")?;
    let coded = coded_design(study)?;
    let names = study.factor_names();
    let runs = run_points(
        study,
        store,
        pool,
        runner,
        SeedStage::Design,
        names.clone(),
        design_points(study, &actual_design(study)?),
        study.replicates,
    )?;
    write_table(dir, "rsm", study, &runs, &stage.join("responses.csv"))?;
    let ranges = study.ranges();
    let (analyses, gp) = fit_responses(study, &runs, &coded)?;
    let optimum = joint_optimum(study, &analyses, &gp);
    let optimum_actual = optimum.as_ref().and_then(|s| {
        s.optima.first().map(|o| {
            o.coded
                .iter()
                .zip(&ranges)
                .map(|(x, r)| r.to_actual(*x))
                .collect()
        })
    });
    let outcome = RsmOutcome {
        study: study.name.clone(),
        study_id: study.id().to_string(),
        factors: study
            .factors
            .iter()
            .map(|(n, f)| (n.clone(), f.display_name(), f.address.clone(), f.min, f.max))
            .collect(),
        runs: runs.total,
        cached: runs.cached,
        incomplete: runs.incomplete(),
        analyses,
        gp,
        optimum,
        optimum_actual,
        dir: stage,
    };
    write_outputs(dir, study, &runs, &coded, &outcome)?;
    Ok(outcome)
}

/// Fits every response of the study over the design's runs: a quadratic
/// with its ANOVA, or a Gaussian process, as the study asks.
fn fit_responses(
    study: &DesignStudy,
    runs: &Runs,
    coded: &[Vec<f64>],
) -> Result<(Vec<ResponseAnalysis>, Vec<GpAnalysis>), StudyError> {
    let names = study.factor_names();
    let ranges = study.ranges();
    let (mut analyses, mut gp) = (Vec::new(), Vec::new());
    for response in study.responses.keys() {
        let (x, y, missing) = observations(runs, coded, response);
        match study.fit {
            FitChoice::Quadratic => {
                analyses.push(analyse(response, &x, &y, &names, &ranges, missing)?)
            }
            FitChoice::Gp => gp.push(analyse_gp(response, &x, &y, &names, missing, study.seed)?),
        }
    }
    Ok((analyses, gp))
}

/// Writes the stage's outputs into `outcome.dir`, each with its lineage (the
/// model, the output and the response table): per response its fit, ANOVA,
/// parity plot and contour or curve (quadratic) or its GP and parity plot;
/// `optimum.csv` when there is an optimum; `rsm.md`.
fn write_outputs(
    dir: &StudyDir,
    study: &DesignStudy,
    runs: &Runs,
    coded: &[Vec<f64>],
    outcome: &RsmOutcome,
) -> Result<(), StudyError> {
    let stage = &outcome.dir;
    // The response table is hashed once; every output's lineage names it.
    let table_input = dir.input("responses", &stage.join("responses.csv"))?;
    let lineage_of = |what: &str| {
        dir.lineage(
            "rsm",
            serde_json::json!({ "model": model_name(study.fit), "output": what, "optimiser_starts": OPTIMISER_STARTS }),
        )
        .with_input(table_input.clone())
    };
    let hold: Vec<f64> = outcome
        .optimum
        .as_ref()
        .and_then(|s| s.optima.first().map(|o| o.coded.clone()))
        .unwrap_or_else(|| vec![0.0; study.factors.len()]);
    let data = Data { study, runs, coded };
    for a in &outcome.analyses {
        write_quadratic(
            &stage.join(&a.response),
            &lineage_of(&a.response),
            &data,
            a,
            &hold,
        )?;
    }
    for g in &outcome.gp {
        let sub = stage.join(&g.response);
        let lineage = lineage_of(&g.response);
        write_output(&sub.join("gp.json"), &json_bytes(g), &lineage)?;
        let pairs: Vec<(f64, f64)> = y_of(runs, &g.response)
            .into_iter()
            .zip(g.fitted.iter().copied())
            .collect();
        let parity =
            predicted_vs_actual(&pairs, &format!("{}: GP mean vs simulated", g.response), "")
                .map_err(|e| StudyError::Plot(e.to_string()))?;
        write_output(&sub.join("parity.svg"), parity.as_bytes(), &lineage)?;
    }
    if let Some(search) = &outcome.optimum {
        let lineage = lineage_of("optimum");
        write_output(
            &stage.join("optimum.csv"),
            optimum_csv(study, search).as_bytes(),
            &lineage,
        )?;
    }
    write_output(
        &stage.join("rsm.md"),
        summary_markdown(outcome).as_bytes(),
        &lineage_of("summary"),
    )
}

/// What a response's plots are drawn from: the study, its runs and the
/// coded design.
struct Data<'a> {
    study: &'a DesignStudy,
    runs: &'a Runs,
    coded: &'a [Vec<f64>],
}

/// Writes one quadratic response's outputs into `sub`: `anova.csv`,
/// `coefficients.csv`, `fit.json`, `parity.svg`, a contour of the two
/// factors that matter most with the others at `hold` (coded) or, with one
/// factor, the fitted curve through the runs, and `anova.md`.
fn write_quadratic(
    sub: &Path,
    lineage: &Lineage,
    data: &Data<'_>,
    a: &ResponseAnalysis,
    hold: &[f64],
) -> Result<(), StudyError> {
    let Data { study, runs, coded } = *data;
    write_output(
        &sub.join("anova.csv"),
        anova_csv(&a.fit).as_bytes(),
        lineage,
    )?;
    write_output(
        &sub.join("coefficients.csv"),
        coefficients_csv(a).as_bytes(),
        lineage,
    )?;
    write_output(&sub.join("fit.json"), &json_bytes(a), lineage)?;
    let pairs: Vec<(f64, f64)> = y_of(runs, &a.response)
        .into_iter()
        .zip(a.fit.fitted.iter().copied())
        .collect();
    let parity = predicted_vs_actual(&pairs, &format!("{}: predicted vs actual", a.response), "")
        .map_err(|e| StudyError::Plot(e.to_string()))?;
    write_output(&sub.join("parity.svg"), parity.as_bytes(), lineage)?;
    // Two or more factors: a contour of the two that matter most; one
    // factor: the fitted curve through the runs.
    let (file, svg) = match contour_grid(study, a, hold) {
        Some(grid) => (
            "contour.svg",
            contour(
                &grid,
                &format!("{} (other factors at the optimum)", a.response),
            ),
        ),
        None => {
            let (x, y, _) = observations(runs, coded, &a.response);
            ("curve.svg", response_curve(study, a, &x, &y))
        }
    };
    let svg = svg.map_err(|e| StudyError::Plot(e.to_string()))?;
    write_output(&sub.join(file), svg.as_bytes(), lineage)?;
    write_output(
        &sub.join("anova.md"),
        anova_markdown(study, a).as_bytes(),
        lineage,
    )
}

fn y_of(runs: &Runs, response: &str) -> Vec<f64> {
    runs.replicates
        .iter()
        .filter_map(|r| r.responses.get(response).copied().flatten())
        .collect()
}

/// The lineage's name of the fitted model.
fn model_name(fit: FitChoice) -> &'static str {
    match fit {
        FitChoice::Quadratic => "full quadratic",
        FitChoice::Gp => "gaussian process (Matern 5/2, fitted nugget)",
    }
}

impl RsmOutcome {
    /// The analysed responses, in name order.
    pub fn responses(&self) -> Vec<String> {
        let quadratic = self.analyses.iter().map(|a| a.response.clone());
        quadratic
            .chain(self.gp.iter().map(|g| g.response.clone()))
            .collect()
    }

    /// The fitted model's prediction of `response` at a coded point.
    pub fn predict(&self, response: &str, coded: &[f64]) -> Option<f64> {
        let quadratic = self.analyses.iter().find(|a| a.response == response);
        match quadratic {
            Some(a) => Some(a.fit.predict(coded)),
            None => self
                .gp
                .iter()
                .find(|g| g.response == response)
                .map(|g| g.predict(coded)),
        }
    }
}

/// The desirability optimum over the responses with targets.
fn joint_optimum(
    study: &DesignStudy,
    analyses: &[ResponseAnalysis],
    gp: &[GpAnalysis],
) -> Option<Search> {
    let quadratic = analyses.iter().map(|a| {
        let fit = &a.fit;
        (
            &a.response,
            Box::new(move |x: &[f64]| fit.predict(x)) as Model,
        )
    });
    let gaussian = gp.iter().map(|g| {
        (
            &g.response,
            Box::new(move |x: &[f64]| g.predict(x)) as Model,
        )
    });
    let goals: Vec<Goal> = quadratic
        .chain(gaussian)
        .filter_map(|(response, predict)| {
            let t = study.targets.get(response)?;
            Some(Goal {
                response: response.clone(),
                predict,
                target: t.value,
                low: t.low,
                high: t.high,
            })
        })
        .collect();
    (!goals.is_empty()).then(|| maximise(&goals, study.factors.len(), OPTIMISER_STARTS, study.seed))
}

/// The one-factor study's plot: the runs' responses against the factor
/// (actual units) and the fitted quadratic through them on 41 points.
fn response_curve(
    study: &DesignStudy,
    a: &ResponseAnalysis,
    coded: &[Vec<f64>],
    y: &[f64],
) -> Result<String, crate::report::plots::PlotError> {
    let names = study.factor_names();
    let range = &study.ranges()[0];
    let n = 41;
    let fit = (0..n)
        .map(|k| {
            let c = -1.0 + 2.0 * k as f64 / (n - 1) as f64;
            (range.to_actual(c), a.fit.predict(&[c]))
        })
        .collect();
    let curve = Curve {
        label: a.response.clone(),
        points: coded
            .iter()
            .zip(y)
            .map(|(x, y)| (range.to_actual(x[0]), *y))
            .collect(),
        fit,
    };
    let f = &study.factors[&names[0]];
    curves(
        &[curve],
        &format!("{}: quadratic fit", a.response),
        &format!("{} = {}", names[0], f.display_name()),
        &a.response,
    )
}

/// The two factors with the largest summed sums of squares of the terms
/// they appear in, on a 41 × 41 grid, others at `hold`; `None` for a
/// one-factor study (no second axis).
fn contour_grid(study: &DesignStudy, a: &ResponseAnalysis, hold: &[f64]) -> Option<ContourGrid> {
    let names = study.factor_names();
    if names.len() < 2 {
        return None;
    }
    let mut weight: Vec<(f64, usize)> = names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let ss: f64 = a
                .fit
                .anova
                .terms
                .iter()
                .filter(|row| row.source.contains(n.as_str()))
                .map(|row| row.ss)
                .sum();
            (ss, i)
        })
        .collect();
    weight.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    let (i, j) = (weight[0].1.min(weight[1].1), weight[0].1.max(weight[1].1));
    let ranges = study.ranges();
    let n = 41;
    let axis = |r: &Range| -> Vec<f64> {
        (0..n)
            .map(|k| r.to_actual(-1.0 + 2.0 * k as f64 / (n - 1) as f64))
            .collect()
    };
    let mut z = Vec::with_capacity(n);
    for ky in 0..n {
        let mut row = Vec::with_capacity(n);
        for kx in 0..n {
            let mut x = hold.to_vec();
            x[i] = -1.0 + 2.0 * kx as f64 / (n - 1) as f64;
            x[j] = -1.0 + 2.0 * ky as f64 / (n - 1) as f64;
            row.push(a.fit.predict(&x));
        }
        z.push(row);
    }
    let factor = |k: usize| {
        let f = &study.factors[&names[k]];
        format!("{} = {}", names[k], f.display_name())
    };
    Some(ContourGrid {
        x_label: factor(i),
        y_label: factor(j),
        x: axis(&ranges[i]),
        y: axis(&ranges[j]),
        z,
        z_label: a.response.clone(),
        markers: vec![(
            ranges[i].to_actual(hold[i]),
            ranges[j].to_actual(hold[j]),
            "optimum".to_string(),
        )],
    })
}

fn opt(v: Option<f64>) -> Cell {
    v.map_or(Cell::Empty, Cell::Number)
}

fn anova_rows(fit: &RsmFit) -> Vec<&AnovaRow> {
    let a = &fit.anova;
    let mut rows = vec![&a.model];
    rows.extend(a.terms.iter());
    rows.push(&a.residual);
    rows.extend(a.lack_of_fit.iter());
    rows.extend(a.pure_error.iter());
    rows.push(&a.total);
    rows
}

/// The ANOVA table as CSV: source, SS, df, MS, F, p.
pub fn anova_csv(fit: &RsmFit) -> String {
    let mut csv = CsvWriter::new(
        &["source", "sum_of_squares", "df", "mean_square", "f", "p"].map(String::from),
    );
    for row in anova_rows(fit) {
        csv.row(&[
            Cell::Text(row.source.clone()),
            Cell::Number(row.ss),
            Cell::Integer(row.df as u64),
            Cell::Number(row.ms),
            opt(row.f),
            opt(row.p),
        ]);
    }
    csv.finish()
}

fn coefficients_csv(a: &ResponseAnalysis) -> String {
    let mut csv = CsvWriter::new(
        &[
            "term",
            "coded_estimate",
            "standard_error",
            "t",
            "p",
            "ci95_low",
            "ci95_high",
            "actual_coefficient",
        ]
        .map(String::from),
    );
    for (c, (_, actual)) in a.fit.coefficients.iter().zip(&a.actual_coefficients) {
        csv.row(&[
            Cell::Text(c.term.clone()),
            Cell::Number(c.estimate),
            Cell::Number(c.se),
            Cell::Number(c.t),
            Cell::Number(c.p),
            Cell::Number(c.ci95_low),
            Cell::Number(c.ci95_high),
            Cell::Number(*actual),
        ]);
    }
    csv.finish()
}

fn optimum_csv(study: &DesignStudy, search: &Search) -> String {
    let names = study.factor_names();
    let ranges = study.ranges();
    let mut header = vec!["rank".to_string()];
    header.extend(names.iter().map(|n| format!("{n}_coded")));
    header.extend(names.iter().cloned());
    header.push("desirability".into());
    if let Some(o) = search.optima.first() {
        for (r, _, _) in &o.responses {
            header.push(format!("{r}_predicted"));
            header.push(format!("{r}_desirability"));
        }
    }
    let mut csv = CsvWriter::new(&header);
    for (k, o) in search.optima.iter().enumerate() {
        let mut cells = vec![Cell::Integer(k as u64 + 1)];
        cells.extend(o.coded.iter().map(|x| Cell::Number(*x)));
        cells.extend(
            o.coded
                .iter()
                .zip(&ranges)
                .map(|(x, r)| Cell::Number(r.to_actual(*x))),
        );
        cells.push(Cell::Number(o.desirability));
        for (_, y, d) in &o.responses {
            cells.push(Cell::Number(*y));
            cells.push(Cell::Number(*d));
        }
        csv.row(&cells);
    }
    csv.finish()
}

fn f4(v: f64) -> String {
    format!("{v:.4}")
}

fn p_text(p: Option<f64>) -> String {
    match p {
        None => String::new(),
        Some(p) if p < 1e-4 => "< 0.0001".into(),
        Some(p) => format!("{p:.4}"),
    }
}

/// The ANOVA of one response as Design-Expert prints it, with the fit
/// statistics and the model in coded and actual units.
pub fn anova_markdown(study: &DesignStudy, a: &ResponseAnalysis) -> String {
    let mut md = format!(
        "# {}: {} — ANOVA of the full quadratic model\n\n{} observations ({} missing).\n\n",
        study.name, a.response, a.observations, a.missing
    );
    md.push_str(&anova_markdown_body(a));
    md
}

fn anova_markdown_body(a: &ResponseAnalysis) -> String {
    let fit = &a.fit;
    let mut md = String::from(
        "| Source | Sum of squares | df | Mean square | F | p |\n|---|---:|---:|---:|---:|---:|\n",
    );
    for row in anova_rows(fit) {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            row.source,
            f4(row.ss),
            row.df,
            f4(row.ms),
            row.f.map(f4).unwrap_or_default(),
            p_text(row.p)
        ));
    }
    md.push_str(&format!(
        "\n| Std. dev. | Mean | C.V. % | R² | Adjusted R² | Predicted R² | PRESS | Adeq. precision |\n|---:|---:|---:|---:|---:|---:|---:|---:|\n| {} | {} | {} | {} | {} | {} | {} | {} |\n",
        f4(fit.std_dev), f4(fit.mean), f4(fit.cv_percent), f4(fit.r2), f4(fit.adj_r2), f4(fit.pred_r2), f4(fit.press), f4(fit.adequate_precision)
    ));
    md.push_str("\n| Term | Coded estimate | SE | t | p | 95 % CI | Actual-unit coefficient |\n|---|---:|---:|---:|---:|---|---:|\n");
    for (c, (_, actual)) in fit.coefficients.iter().zip(&a.actual_coefficients) {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | [{}, {}] | {:.6e} |\n",
            c.term,
            f4(c.estimate),
            f4(c.se),
            f4(c.t),
            p_text(Some(c.p)),
            f4(c.ci95_low),
            f4(c.ci95_high),
            actual
        ));
    }
    md
}

/// The GPs' table: observations, length scale per factor (coded units),
/// the noise sd √nugget and the log marginal likelihood.
fn gp_markdown(o: &RsmOutcome) -> String {
    let names: Vec<&str> = o.factors.iter().map(|f| f.0.as_str()).collect();
    let mut md = format!(
        "\n## Gaussian processes (length scales in coded units; the range is 2 wide)\n\n| Response | n | {} | noise sd | log ML |\n|---|---:|{}---:|---:|\n",
        names.iter().map(|n| format!("ℓ {n}")).collect::<Vec<_>>().join(" | "),
        "---:|".repeat(names.len())
    );
    for g in &o.gp {
        let ls: Vec<String> = g.length_scales.iter().map(|l| f4(*l)).collect();
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            g.response,
            g.observations,
            ls.join(" | "),
            f4(g.nugget_var.sqrt()),
            f4(g.log_marginal_likelihood)
        ));
    }
    md
}

fn summary_markdown(o: &RsmOutcome) -> String {
    let mut md = format!(
        "# {} — response surface ({} runs)\n\nStudy id {}.{}\n\n| Factor | Label | Address | Low (−1) | High (+1) |\n|---|---|---|---:|---:|\n",
        o.study, o.runs, o.study_id, crate::study::runs::incomplete_note(o.incomplete)
    );
    for (n, l, a, lo, hi) in &o.factors {
        md.push_str(&format!("| {n} | {l} | `{a}` | {lo} | {hi} |\n"));
    }
    md.push_str("\n| Response | n | R² | Adj. R² | Pred. R² | C.V. % | Lack-of-fit p | Adeq. precision |\n|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for a in &o.analyses {
        let f = &a.fit;
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            a.response,
            a.observations,
            f4(f.r2),
            f4(f.adj_r2),
            f4(f.pred_r2),
            f4(f.cv_percent),
            p_text(f.anova.lack_of_fit.as_ref().and_then(|r| r.p)),
            f4(f.adequate_precision)
        ));
    }
    if !o.gp.is_empty() {
        md.push_str(&gp_markdown(o));
    }
    if let Some(s) = &o.optimum {
        md.push_str(&format!(
            "\n## Joint optimum (desirability, {} starts, best {} distinct optima)\n\n",
            s.starts,
            s.optima.len()
        ));
        for (k, opt) in s.optima.iter().enumerate() {
            let values: Vec<String> = opt
                .coded
                .iter()
                .zip(&o.factors)
                .map(|(x, (n, _, _, lo, hi))| {
                    format!("{n} = {:.4}", lo + (x + 1.0) * 0.5 * (hi - lo))
                })
                .collect();
            let preds: Vec<String> = opt
                .responses
                .iter()
                .map(|(r, y, d)| format!("{r} {y:.3} (d {d:.3})"))
                .collect();
            md.push_str(&format!(
                "{}. D = {:.4}: {} → {}\n",
                k + 1,
                opt.desirability,
                values.join(", "),
                preds.join(", ")
            ));
        }
    }
    md
}

/// Columns of a table analysed with [`analyse_table`].
#[derive(Debug, Clone)]
pub struct TableSpec {
    /// Factor columns.
    pub factors: Vec<String>,
    /// The response column.
    pub response: String,
    /// Actual-unit ranges per factor (`None`: the columns are coded).
    pub ranges: Option<Vec<Range>>,
}

/// `repose rsm --table`: the same analysis on any CSV table (rows with an
/// empty response are skipped and counted as missing).
///
/// The table is the user's input, so what makes it unanalysable — no data
/// rows, a constant response, too few rows for the model — is an error in
/// the input ([`StudyError::Settings`], exit 2) naming the file and column.
pub fn analyse_table(path: &Path, spec: &TableSpec) -> Result<ResponseAnalysis, StudyError> {
    let table = Table::read(path)?;
    if table.rows.is_empty() {
        return Err(StudyError::Settings(format!(
            "{}: no data rows (only a header)",
            path.display()
        )));
    }
    for (i, f) in spec.factors.iter().enumerate() {
        if spec.factors[..i].contains(f) {
            return Err(StudyError::Settings(format!(
                "--factors: `{f}` is listed twice; name each column once"
            )));
        }
        if *f == spec.response {
            return Err(StudyError::Settings(format!(
                "--response `{f}` is also among --factors: a response cannot explain itself"
            )));
        }
    }
    let columns = spec
        .factors
        .iter()
        .map(|f| table.numbers(path, f))
        .collect::<Result<Vec<_>, _>>()?;
    let response = table.optional_numbers(path, &spec.response)?;
    let ranges = spec.ranges.clone().unwrap_or_else(|| {
        vec![
            Range {
                low: -1.0,
                high: 1.0
            };
            spec.factors.len()
        ]
    });
    if ranges.len() != spec.factors.len() {
        return Err(StudyError::Settings(format!(
            "--ranges gives {} ranges for {} factors",
            ranges.len(),
            spec.factors.len()
        )));
    }
    let (mut x, mut y, mut missing) = (Vec::new(), Vec::new(), 0);
    for (i, cell) in response.iter().enumerate() {
        match *cell {
            Some(v) => {
                x.push(
                    columns
                        .iter()
                        .zip(&ranges)
                        .map(|(c, r)| r.to_coded(c[i]))
                        .collect(),
                );
                y.push(v);
            }
            None => missing += 1,
        }
    }
    if let Some(first) = y
        .first()
        .filter(|&&f| y.len() > 1 && y.iter().all(|&v| v == f))
    {
        return Err(StudyError::Settings(format!(
            "{}: column `{}` is {first} in every one of its {} measured rows: a constant \
             response has nothing for a model to fit",
            path.display(),
            spec.response,
            y.len()
        )));
    }
    analyse(&spec.response, &x, &y, &spec.factors, &ranges, missing).map_err(|e| match e {
        StudyError::Analysis { .. } => StudyError::Settings(format!("{}: {e}", path.display())),
        other => other,
    })
}

/// Markdown of a table analysis (the ANOVA, fit statistics and model).
pub fn table_markdown(path: &Path, a: &ResponseAnalysis) -> String {
    let mut md = format!(
        "# {}: {} — ANOVA of the full quadratic model\n\n{} observations ({} missing).\n\n",
        path.display(),
        a.response,
        a.observations,
        a.missing
    );
    md.push_str(&anova_markdown_body(a));
    md
}
