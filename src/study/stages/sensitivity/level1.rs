//! Level 1 of yan2015 (§2.2.1, §4.2.1): empirical power laws fitted by
//! nonlinear least squares, and the flow-rate decay of each run.
//!
//! Each response y (α, θ, FR(t), …) is fitted as y = A·Π x_j^{b_j} over the
//! study's factors (yan2015 Eq. 19: A·e^b·μs^c·μr^d) by Levenberg–Marquardt
//! from the log-linear start ([`crate::stats::nlls::fit_power_law`]). Every
//! individual observation enters the fit: the four ortho-slice angles of
//! each run of each replicate, not their mean
//! ([`crate::scenes::responses::observations`]), so the design point's
//! replicate and slice scatter is the pure error of the lack-of-fit test
//! ([`crate::stats::nlls::lack_of_fit`]: the ratio of the lack-of-fit mean
//! square to the pure-error mean square, which yan2015 reports as 9.02 for
//! α and 122.3 for θ).
//!
//! Each run's flow-rate curve FR(t) = discharged by t / t (s after the
//! opening) is fitted by FR0 / (1 + (K t)^n) (Eq. 20). The curve starts at
//! zero (the first particles need time to fall clear of the orifice) and
//! rises to its plateau; Eq. 20 only decreases, so the fit starts at the
//! first sample where FR(t) reaches 95 % of its maximum (`fit_from_s`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::report::markdown::MarkdownTable;
use crate::report::plots::{curves, predicted_vs_actual, Curve};
use crate::report::table::{Cell, CsvWriter, Table};
use crate::stats::nlls::{
    fit_flow_decay, fit_power_law, lack_of_fit, FlowDecay, LackOfFit, Model, NllsFit,
};
use crate::study::StudyError;

/// Where the flow-curve fit starts: the first sample at this fraction of
/// the curve's maximum.
pub const FLOW_FIT_START_FRACTION: f64 = 0.95;

/// One observation of a response: a design point's replicate and one of its
/// parts (e.g. one of the four ortho-slice angles).
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Index of the design point.
    pub point: usize,
    /// Replicate number.
    pub replicate: u32,
    /// Factor values, study order, actual units.
    pub x: Vec<f64>,
    /// Response name.
    pub response: String,
    /// Part number within the run (1-based).
    pub part: usize,
    /// The value, in the response's unit.
    pub value: f64,
}

/// The power-law fit of one response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResponseFit {
    /// Response name.
    pub response: String,
    /// Observations that entered the fit.
    pub observations: usize,
    /// Runs that lacked the response (failed, unmeasurable, or a discharge
    /// shorter than the flow-rate time).
    pub missing: usize,
    /// The fit, when there was one.
    pub fit: Option<NllsFit>,
    /// Lack of fit against the pure error, when there are repeats.
    pub lack_of_fit: Option<LackOfFit>,
    /// Why there is no fit.
    pub problem: Option<String>,
}

/// One run's flow-rate curve input.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveInput {
    /// Design point index.
    pub point: usize,
    /// Replicate.
    pub replicate: u32,
    /// Factor values.
    pub x: Vec<f64>,
    /// (t after the opening in s, FR in 1/s).
    pub samples: Vec<(f64, f64)>,
}

/// One run's Eq. 20 fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlowCurve {
    /// Design point index.
    pub point: usize,
    /// Replicate.
    pub replicate: u32,
    /// Factor values.
    pub x: Vec<f64>,
    /// Samples fitted.
    pub samples: usize,
    /// Time of the first sample fitted, s after the opening.
    pub fit_from_s: f64,
    /// The fit (parameters FR0, K, n), when there was one.
    pub fit: Option<NllsFit>,
    /// Why there is no fit.
    pub problem: Option<String>,
}

/// What level 1 found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Level1 {
    /// Factor names, study order (the power law's exponents).
    pub factors: Vec<String>,
    /// One fit per response.
    pub fits: Vec<ResponseFit>,
    /// One Eq. 20 fit per run with a flow-rate curve.
    pub flow_curves: Vec<FlowCurve>,
}

/// Fits every response of `observations` (responses in `responses` order;
/// `missing[k]` runs lacked response k) and every flow curve.
pub fn level1(
    factors: &[String],
    responses: &[(String, usize)],
    observations: &[Observation],
    curves_in: &[CurveInput],
) -> Level1 {
    let fits = responses
        .iter()
        .map(|(response, missing)| {
            let (x, y): (Vec<Vec<f64>>, Vec<f64>) = observations
                .iter()
                .filter(|o| &o.response == response)
                .map(|o| (o.x.clone(), o.value))
                .unzip();
            let (fit, lof, problem) = if y.is_empty() {
                (None, None, Some("no run measured it".to_string()))
            } else {
                match fit_power_law(&x, &y, factors) {
                    Ok(f) => {
                        let lof = lack_of_fit(&f, &x, &y);
                        (Some(f), lof, None)
                    }
                    Err(e) => (None, None, Some(e.to_string())),
                }
            };
            ResponseFit {
                response: response.clone(),
                observations: y.len(),
                missing: *missing,
                fit,
                lack_of_fit: lof,
                problem,
            }
        })
        .collect();
    let flow_curves = curves_in.iter().map(flow_curve).collect();
    Level1 {
        factors: factors.to_vec(),
        fits,
        flow_curves,
    }
}

fn flow_curve(c: &CurveInput) -> FlowCurve {
    let peak = c.samples.iter().map(|s| s.1).fold(0.0, f64::max);
    let start = c
        .samples
        .iter()
        .position(|s| s.1 >= FLOW_FIT_START_FRACTION * peak)
        .unwrap_or(0);
    let kept = &c.samples[start..];
    let (t, fr): (Vec<f64>, Vec<f64>) = kept.iter().copied().unzip();
    let (fit, problem) = match fit_flow_decay(&t, &fr) {
        Ok(f) => (Some(f), None),
        Err(e) => (None, Some(e.to_string())),
    };
    FlowCurve {
        point: c.point,
        replicate: c.replicate,
        x: c.x.clone(),
        samples: kept.len(),
        fit_from_s: t.first().copied().unwrap_or(0.0),
        fit,
        problem,
    }
}

/// `observations.csv`: every observation that entered (or could enter) a fit.
pub fn observations_csv(factors: &[String], observations: &[Observation]) -> String {
    let mut header = vec!["point".to_string(), "replicate".into()];
    header.extend(factors.iter().cloned());
    header.extend(["response".to_string(), "part".into(), "value".into()]);
    let mut csv = CsvWriter::new(&header);
    for o in observations {
        let mut cells = vec![
            Cell::Integer(o.point as u64),
            Cell::Integer(u64::from(o.replicate)),
        ];
        cells.extend(o.x.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Text(o.response.clone()));
        cells.push(Cell::Integer(o.part as u64));
        cells.push(Cell::Number(o.value));
        csv.row(&cells);
    }
    csv.finish()
}

/// `estimates.csv`: per response and parameter, the estimate, its standard
/// error and 95 % confidence bounds.
pub fn estimates_csv(l: &Level1) -> String {
    let mut csv = CsvWriter::new(
        &[
            "response",
            "parameter",
            "estimate",
            "standard_error",
            "ci95_low",
            "ci95_high",
        ]
        .map(String::from),
    );
    for r in &l.fits {
        let Some(f) = &r.fit else { continue };
        for k in 0..f.names.len() {
            csv.row(&[
                Cell::Text(r.response.clone()),
                Cell::Text(f.names[k].clone()),
                Cell::Number(f.estimates[k]),
                Cell::Number(f.standard_errors[k]),
                Cell::Number(f.ci_low[k]),
                Cell::Number(f.ci_high[k]),
            ]);
        }
    }
    csv.finish()
}

/// `fits.csv`: one row per response with the fit's statistics and the
/// lack-of-fit test (or the problem).
pub fn fits_csv(l: &Level1) -> String {
    let mut csv = CsvWriter::new(
        &[
            "response",
            "observations",
            "missing_runs",
            "dof",
            "sse",
            "s2",
            "r2",
            "lack_of_fit_ratio",
            "df_lack_of_fit",
            "df_pure_error",
            "lack_of_fit_p",
            "problem",
        ]
        .map(String::from),
    );
    for r in &l.fits {
        let f = r.fit.as_ref();
        let lof = r.lack_of_fit.as_ref();
        let num = |v: Option<f64>| v.map_or(Cell::Empty, Cell::Number);
        let int = |v: Option<usize>| v.map_or(Cell::Empty, |v| Cell::Integer(v as u64));
        csv.row(&[
            Cell::Text(r.response.clone()),
            Cell::Integer(r.observations as u64),
            Cell::Integer(r.missing as u64),
            int(f.map(|f| f.dof)),
            num(f.map(|f| f.sse)),
            num(f.map(|f| f.s2)),
            num(f.map(|f| f.r2)),
            num(lof.map(|l| l.ratio)),
            int(lof.map(|l| l.df_lack_of_fit)),
            int(lof.map(|l| l.df_pure_error)),
            num(lof.map(|l| l.p_value)),
            Cell::Text(r.problem.clone().unwrap_or_default()),
        ]);
    }
    csv.finish()
}

/// `correlations.csv`: the parameter correlation matrix of each fit.
pub fn correlations_csv(l: &Level1) -> String {
    let mut header = vec!["response".to_string(), "parameter".into(), "A".into()];
    header.extend(l.factors.iter().cloned());
    let mut csv = CsvWriter::new(&header);
    for r in &l.fits {
        let Some(f) = &r.fit else { continue };
        for (name, row) in f.names.iter().zip(&f.correlation) {
            let mut cells = vec![Cell::Text(r.response.clone()), Cell::Text(name.clone())];
            cells.extend(row.iter().map(|v| Cell::Number(*v)));
            csv.row(&cells);
        }
    }
    csv.finish()
}

/// `flow_curves.csv`: one row per run with its Eq. 20 fit.
pub fn flow_curves_csv(l: &Level1) -> String {
    let mut header = vec!["point".to_string(), "replicate".into()];
    header.extend(l.factors.iter().cloned());
    header.extend(
        [
            "samples",
            "fit_from_s",
            "fr0_per_s",
            "fr0_se",
            "k_per_s",
            "k_se",
            "n",
            "n_se",
            "r2",
            "problem",
        ]
        .map(String::from),
    );
    let mut csv = CsvWriter::new(&header);
    for c in &l.flow_curves {
        let mut cells = vec![
            Cell::Integer(c.point as u64),
            Cell::Integer(u64::from(c.replicate)),
        ];
        cells.extend(c.x.iter().map(|v| Cell::Number(*v)));
        cells.push(Cell::Integer(c.samples as u64));
        cells.push(Cell::Number(c.fit_from_s));
        match &c.fit {
            Some(f) => {
                for k in 0..3 {
                    cells.push(Cell::Number(f.estimates[k]));
                    cells.push(Cell::Number(f.standard_errors[k]));
                }
                cells.push(Cell::Number(f.r2));
            }
            None => cells.extend(std::iter::repeat_n(Cell::Empty, 7)),
        }
        cells.push(Cell::Text(c.problem.clone().unwrap_or_default()));
        csv.row(&cells);
    }
    csv.finish()
}

/// Fitted against simulated values of one response (every observation).
pub fn parity_svg(r: &ResponseFit, y: &[f64]) -> Result<Option<String>, StudyError> {
    let Some(f) = &r.fit else { return Ok(None) };
    let pairs: Vec<(f64, f64)> = y.iter().copied().zip(f.fitted.iter().copied()).collect();
    predicted_vs_actual(
        &pairs,
        &format!("{}: power law vs simulated", r.response),
        "",
    )
    .map(Some)
    .map_err(|e| StudyError::Plot(e.to_string()))
}

/// FR(t) of up to five runs (the 0, 25, 50, 75 and 100 % quantiles of the
/// fitted FR0, as yan2015 Fig. 13 shows five) with their Eq. 20 fits.
pub fn flow_curves_svg(l: &Level1, inputs: &[CurveInput]) -> Result<Option<String>, StudyError> {
    let mut fitted: Vec<(usize, f64)> = l
        .flow_curves
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.fit.as_ref().map(|f| (i, f.estimates[0])))
        .collect();
    if fitted.is_empty() {
        return Ok(None);
    }
    fitted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut chosen: Vec<usize> = [0.0, 0.25, 0.5, 0.75, 1.0]
        .iter()
        .map(|q| fitted[((fitted.len() - 1) as f64 * q).round() as usize].0)
        .collect();
    chosen.dedup();
    let series: Vec<Curve> = chosen
        .iter()
        .map(|&i| {
            let c = &l.flow_curves[i];
            let f = c.fit.as_ref().expect("chosen among the fitted");
            let input = &inputs[i];
            let t_end = input.samples.last().map_or(c.fit_from_s, |s| s.0);
            let fit = (0..=60)
                .map(|k| {
                    let t = c.fit_from_s + (t_end - c.fit_from_s) * f64::from(k) / 60.0;
                    (t, FlowDecay.value(&f.estimates, &[t]))
                })
                .collect();
            let values: Vec<String> = l
                .factors
                .iter()
                .zip(&c.x)
                .map(|(n, v)| format!("{n} {v}"))
                .collect();
            Curve {
                label: format!("{} (FR0 {:.0}/s)", values.join(", "), f.estimates[0]),
                points: input.samples.clone(),
                fit,
            }
        })
        .collect();
    curves(
        &series,
        "Flow rate FR(t) = discharged / t with Eq. 20 fits",
        "t after opening (s)",
        "FR (1/s)",
    )
    .map(Some)
    .map_err(|e| StudyError::Plot(e.to_string()))
}

/// The level-1 section of the report.
pub fn markdown(l: &Level1, labels: &[(String, String)]) -> String {
    let label = |c: &str| {
        labels
            .iter()
            .find(|(n, _)| n == c)
            .map_or(c.to_string(), |(_, l)| l.clone())
    };
    let mut md = String::from(
        "## Level 1: power laws y = A·Π x^b (Eq. 19), nonlinear least squares\n\n\
         Estimates ± 95 % CI (t with n − p df); every observation enters (each \
         ortho-slice angle of each run). yan2015 (Table 2): μs dominates, μr second, e \
         insignificant; lack-of-fit ratios 9.02 (α) and 122.3 (θ).\n\n",
    );
    let mut header = vec!["Response".to_string(), "n".into(), "A".into()];
    header.extend(
        l.factors
            .iter()
            .map(|f| format!("exponent of {}", label(f))),
    );
    header.extend(["R²".to_string(), "lack of fit F (p)".into()]);
    let mut t = MarkdownTable::new(&header);
    for r in &l.fits {
        let mut row = vec![r.response.clone(), r.observations.to_string()];
        match &r.fit {
            Some(f) => {
                for k in 0..f.names.len() {
                    row.push(format!(
                        "{:.4} [{:.4}, {:.4}]",
                        f.estimates[k], f.ci_low[k], f.ci_high[k]
                    ));
                }
                row.push(format!("{:.3}", f.r2));
                row.push(r.lack_of_fit.as_ref().map_or("—".into(), |l| {
                    format!("{:.2} ({:.2e})", l.ratio, l.p_value)
                }));
            }
            None => {
                row.push(format!("no fit: {}", r.problem.clone().unwrap_or_default()));
                row.extend(std::iter::repeat_n(String::new(), l.factors.len() + 2));
            }
        }
        t.row(&row);
    }
    md.push_str(&t.render());
    let missing: Vec<String> = l
        .fits
        .iter()
        .filter(|r| r.missing > 0)
        .map(|r| format!("{} ({} runs)", r.response, r.missing))
        .collect();
    if !missing.is_empty() {
        md.push_str(&format!(
            "\nRuns that did not measure a response: {}.\n",
            missing.join(", ")
        ));
    }
    let fitted: Vec<&FlowCurve> = l.flow_curves.iter().filter(|c| c.fit.is_some()).collect();
    md.push_str(&format!(
        "\n### Flow-rate curves FR(t) = FR0 / (1 + (K t)^n) (Eq. 20)\n\n{} of {} runs fitted \
         (from the first sample at {:.0} % of the curve's maximum); every fit is in \
         `flow_curves.csv`.\n\n",
        fitted.len(),
        l.flow_curves.len(),
        100.0 * FLOW_FIT_START_FRACTION
    ));
    if !fitted.is_empty() {
        let mut header: Vec<String> = l.factors.iter().map(|f| label(f)).collect();
        header.extend(["FR0 (1/s)", "K (1/s)", "n", "R²"].map(String::from));
        let mut t = MarkdownTable::new(&header);
        let mut by_fr0 = fitted.clone();
        by_fr0.sort_by(|a, b| {
            a.fit.as_ref().unwrap().estimates[0].total_cmp(&b.fit.as_ref().unwrap().estimates[0])
        });
        let shown = [0, by_fr0.len() / 2, by_fr0.len() - 1];
        let mut last = usize::MAX;
        for &k in &shown {
            if k == last {
                continue;
            }
            last = k;
            let c = by_fr0[k];
            let f = c.fit.as_ref().expect("fitted");
            let mut row: Vec<String> = c.x.iter().map(|v| format!("{v}")).collect();
            for j in 0..3 {
                row.push(format!(
                    "{:.4} ± {:.4}",
                    f.estimates[j],
                    f.ci_high[j] - f.estimates[j]
                ));
            }
            row.push(format!("{:.4}", f.r2));
            t.row(&row);
        }
        md.push_str("Lowest, median and highest FR0 (± 95 % CI):\n\n");
        md.push_str(&t.render());
    }
    md
}

/// The level-1 fit of any table (`repose sensitivity --table`): the power
/// law of column `response` over the `factors` columns, every row an
/// observation, and the lack of fit against rows with equal factors.
#[derive(Debug, Clone, Serialize)]
pub struct TableFit {
    /// The table's path as given.
    pub table: String,
    /// The response column.
    pub response: String,
    /// The factor columns.
    pub factors: Vec<String>,
    /// Rows skipped for an empty or non-numeric response.
    pub skipped: usize,
    /// The fit.
    pub fit: NllsFit,
    /// Lack of fit, when rows repeat.
    pub lack_of_fit: Option<LackOfFit>,
}

/// Reads `path` and fits the power law of `response` over `factors` (see
/// [`TableFit`]). Rows whose response cell is empty or not a number are
/// skipped and counted; a factor cell that is not a number is an error
/// naming its line.
pub fn fit_table(path: &Path, response: &str, factors: &[String]) -> Result<TableFit, StudyError> {
    let table = Table::read(path)?;
    let columns = factors
        .iter()
        .map(|f| table.numbers(path, f))
        .collect::<Result<Vec<_>, _>>()?;
    let y_col = table.require(path, response)?;
    let (mut x, mut y, mut skipped) = (Vec::new(), Vec::new(), 0);
    for (i, row) in table.rows.iter().enumerate() {
        match crate::report::table::parse_number(&row[y_col]) {
            Some(v) => {
                x.push(columns.iter().map(|c| c[i]).collect::<Vec<f64>>());
                y.push(v);
            }
            None => skipped += 1,
        }
    }
    // The table is the user's input: a fit it cannot give is theirs to fix.
    let fit = fit_power_law(&x, &y, factors).map_err(|e| {
        StudyError::Settings(format!("{}: response '{response}': {e}", path.display()))
    })?;
    let lack_of_fit = lack_of_fit(&fit, &x, &y);
    Ok(TableFit {
        table: path.display().to_string(),
        response: response.into(),
        factors: factors.to_vec(),
        skipped,
        fit,
        lack_of_fit,
    })
}

/// The `--table` fit as Markdown: estimates with standard errors and 95 %
/// confidence bounds, the correlation matrix, R² and the lack of fit.
pub fn table_markdown(t: &TableFit) -> String {
    let f = &t.fit;
    let mut md = format!(
        "# {}: {} = A·Π x^b over {} ({} observations, {} skipped)\n\n",
        t.table,
        t.response,
        t.factors.join(", "),
        f.observations,
        t.skipped
    );
    let mut est = MarkdownTable::new(&["Parameter", "Estimate", "SE", "95 % CI"]);
    for k in 0..f.names.len() {
        est.row(&[
            f.names[k].clone(),
            format!("{:.6}", f.estimates[k]),
            format!("{:.6}", f.standard_errors[k]),
            format!("[{:.6}, {:.6}]", f.ci_low[k], f.ci_high[k]),
        ]);
    }
    md.push_str(&est.render());
    let mut header = vec![String::new()];
    header.extend(f.names.iter().cloned());
    let mut cc = MarkdownTable::new(&header);
    for (name, row) in f.names.iter().zip(&f.correlation) {
        let mut cells = vec![name.clone()];
        cells.extend(row.iter().map(|v| format!("{v:+.4}")));
        cc.row(&cells);
    }
    md.push_str(&format!("\nParameter correlations:\n\n{}", cc.render()));
    md.push_str(&format!(
        "\nSSE {:.6e}, s² {:.6e} ({} df), R² {:.6}\n",
        f.sse, f.s2, f.dof, f.r2
    ));
    if let Some(l) = &t.lack_of_fit {
        md.push_str(&format!(
            "Lack of fit: F = {:.4} ({} and {} df), p = {:.4e}\n",
            l.ratio, l.df_lack_of_fit, l.df_pure_error, l.p_value
        ));
    }
    md
}
