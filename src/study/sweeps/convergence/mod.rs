//! `repose convergence`: what resolution costs and buys — one scene swept
//! over particle size with replicates, each response's trend against d/D
//! read at the real particle size, and the cost of getting there.
//!
//! [`plan`] builds the size levels (the base experiment with its particles
//! scaled, see [`plan::plan`]); [`sweep`] runs them through the one executor
//! (cached, resumable: a killed sweep resumes where it stopped), then
//! [`summarise`] reads per level every response's mean ± 95 % interval and
//! σ, the CPU-seconds per run, the particle count, the scene's resolution
//! figures and `repose plan`'s estimate of the particle-steps beside the
//! measured ones; [`analyse`] fits each response against d/D and the cost
//! against d/D; [`report`] writes convergence.csv, .md and .svg.
//!
//! # d/D and the real size
//! d/D is the particle diameter over the scene's device size, read from the
//! run's own resolution figure across the device (platform, disk, box
//! length, drum or orifice diameters: D/d, see [`DEVICE_FIGURES`]), so it is
//! the quantity the scene's resolution limits are written in. The real
//! particle's d/D is that of a level scaled by real radius / level radius.
//!
//! # The trend and the bias
//! Each response is fitted as a line in d/D over the individual runs,
//! weighted by one over its level's sample variance
//! ([`crate::stats::trend`]; equal weights when a level has no variance).
//! Its value at the real d/D, with a 95 % confidence interval, is the
//! extrapolated converged value. The bias of a level is the fitted line's
//! difference between that level and the real size, b·(x − x_real), with the
//! slope's interval. The standard size for a tolerance T is the coarsest
//! measured level whose estimated bias is within T/2; where none is, the d/D
//! at which the line reaches T/2 and its cost from the cost law are given.
//! With three or more sizes the line is tested for lack of fit against the
//! runs' pure error; a line the levels contradict (p < 0.05) is reported but
//! neither a standard size nor a needed size is read from it: the response
//! has not converged to any trend a line can carry to the real size.
//!
//! # Size effect
//! With a tolerance T, each response gets an equivalence test of "no size
//! effect over the swept sizes": the line's change across the measured d/D
//! range, b·(x_max − x_min), with its standard error on the fit's residual
//! degrees of freedom, judged by the acceptance rule against ±T/2
//! ([`SizeEffect`]). Size-independent means the 90 % interval of that
//! change lies inside ±T/2: a calibration at any swept size then carries to
//! the others within half the tolerance. This is the criterion a
//! coarse-graining rule is chosen by (issue 55): the rule under which the
//! scenes' angles are size-independent.
//!
//! # The cost law
//! CPU-seconds per run against d/D as a power law, a line in logs over the
//! individual runs (CPU time of the run's thread, `timing.json`; its wall
//! time where that is absent). With the particle count ∝ (d/D)⁻³ and the
//! time step ∝ d, the expected exponent is about −4.

pub mod plan;
pub mod report;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::exec::{ExecError, Executor};
use crate::manifest::{ContentId, Experiment};
use crate::scenes::responses::{catalogue, response};
use crate::stats::equivalence::{tost_estimate, EstimateTost};
use crate::stats::nlls::LackOfFit;
use crate::stats::summary::{mean_ci, MeanCi};
use crate::stats::trend::{weighted_line, LineFit, LinePrediction};
use crate::study::acceptance::{judge_estimate, Verdict, ALPHA};
use crate::study::plan::StudySpec;
use crate::study::sweeps::tradeoff::{self, Outcome};
use crate::study::StudyError;

/// Lack-of-fit p-value below which a line is not trusted to extrapolate:
/// its levels' means stray from it by more than their runs' scatter allows.
pub const LACK_OF_FIT_ALPHA: f64 = 0.05;
use crate::store::{InputRef, Lineage, Store};
pub use plan::{Level, SizePlan, SurfaceEnergyRule};

/// The resolution figures that measure the device across, in particle
/// diameters (D/d), one per scene kind that has one.
pub const DEVICE_FIGURES: [&str; 5] = [
    "platform_diameters",
    "disk_diameters",
    "box_length_diameters",
    "drum_diameters",
    "orifice_diameters",
];

/// What a sweep measured and concluded.
#[derive(Debug, Clone, Serialize)]
pub struct Convergence {
    /// The scene kind.
    pub scene: String,
    /// The base manifest as given.
    pub manifest: String,
    /// The surface-energy rule of the levels (`None`: the base's coarse
    /// graining).
    pub rule: Option<SurfaceEnergyRule>,
    /// Real particle radius, m, when known.
    pub real_radius_m: Option<f64>,
    /// The real particle's d/D, when known.
    pub real_x: Option<f64>,
    /// The tolerance the standard size is chosen for (units of the responses).
    pub tolerance: Option<f64>,
    /// One row per level, coarsest first.
    pub levels: Vec<LevelRow>,
    /// One trend per response, in name order.
    pub trends: Vec<Trend>,
    /// CPU-seconds per run against d/D.
    pub cost: Option<CostLaw>,
    /// The coarsest level every response's bias allows, if any.
    pub standard_factor: Option<f64>,
}

/// One size level's measurements.
#[derive(Debug, Clone, Serialize)]
pub struct LevelRow {
    /// Size factor relative to the base's particle.
    pub factor: f64,
    /// Nominal simulated particle radius, m.
    pub radius_m: f64,
    /// Particle diameter over the device size (from the first run that has a
    /// device figure).
    pub x: Option<f64>,
    /// Runs planned.
    pub replicates: usize,
    /// Runs that completed.
    pub completed: usize,
    /// Each response's values over the completed runs, in seed order.
    pub values: BTreeMap<String, Vec<f64>>,
    /// Each response's mean ± 95 % interval (two or more values).
    pub responses: BTreeMap<String, Option<MeanCi>>,
    /// Mean simulated particles per run.
    pub particles: Option<f64>,
    /// Mean measured particle-steps per run.
    pub particle_steps: Option<f64>,
    /// `repose plan`'s particle-steps estimate for the level.
    pub planned_particle_steps: Option<f64>,
    /// CPU-seconds per completed run (thread CPU, else wall time), in seed
    /// order.
    pub cpu_s: Vec<f64>,
    /// Mean wall time per run, s.
    pub wall_s: Option<f64>,
    /// Resolution figures of the first completed run.
    pub resolution: BTreeMap<String, f64>,
    /// Figures outside their limits (`name = value below/above limit`).
    pub unresolved: Vec<String>,
    /// Run ids in seed order.
    pub ids: Vec<ContentId>,
    /// The first failure, if a run failed.
    pub failure: Option<String>,
}

impl LevelRow {
    /// Mean CPU-seconds per completed run.
    pub fn mean_cpu_s(&self) -> Option<f64> {
        mean(&self.cpu_s)
    }
}

/// A response's trend against d/D.
#[derive(Debug, Clone, Serialize)]
pub struct Trend {
    /// The response name.
    pub response: String,
    /// The weighting used (`inverse level variance` or `equal`).
    pub weighting: &'static str,
    /// The fitted line, or why there is none.
    pub fit: Result<LineFit, String>,
    /// The line's lack of fit against the runs' pure error (three or more
    /// sizes with replicates).
    pub lack_of_fit: Option<LackOfFit>,
    /// The line at the real d/D with its interval (the extrapolated value).
    pub at_real: Option<LinePrediction>,
    /// Per level (coarsest first): the estimated bias b·(x − x_real) and its
    /// 95 % half-width.
    pub bias: Vec<Option<(f64, f64)>>,
    /// The coarsest measured level whose |bias| ≤ tolerance / 2.
    pub standard_factor: Option<f64>,
    /// The d/D at which |bias| reaches tolerance / 2 (when a tolerance and a
    /// non-zero slope are known), and the size factor it means.
    pub needed: Option<Needed>,
    /// Whether the response is size-independent over the swept sizes (when
    /// a tolerance is given).
    pub size_effect: Option<SizeEffect>,
}

/// The equivalence test of "no size effect": the line's change over the
/// swept d/D range against ± half the tolerance, by the acceptance rule
/// (TOST at α = 0.05: size-independent when the 90 % interval of the change
/// lies inside ±T/2; size-dependent when the 95 % interval lies wholly
/// outside it).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SizeEffect {
    /// The swept d/D range (largest − smallest measured d/D).
    pub span: f64,
    /// Half the tolerance, units of the response.
    pub margin: f64,
    /// The change b·span with its error, TOST p and intervals.
    pub test: EstimateTost,
    /// The verdict; `None` when the line misses the sizes (lack of fit
    /// p < [`LACK_OF_FIT_ALPHA`]): the levels differ by more than their
    /// scatter allows, so the change is not one number.
    pub verdict: Option<Verdict>,
}

/// The size at which a response's bias reaches half the tolerance.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Needed {
    /// d/D.
    pub x: f64,
    /// Size factor relative to the base's particle.
    pub factor: f64,
    /// CPU-seconds per run there, from the cost law.
    pub cpu_s: Option<f64>,
}

/// CPU-seconds per run = c · (d/D)^q, fitted in logs.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CostLaw {
    /// The exponent q and its 95 % half-width.
    pub exponent: (f64, f64),
    /// ln c.
    pub log_coefficient: f64,
}

impl CostLaw {
    /// CPU-seconds per run at d/D = `x`.
    pub fn at(&self, x: f64) -> f64 {
        (self.log_coefficient + self.exponent.0 * x.ln()).exp()
    }
}

/// Where a sweep of `base` writes by default:
/// `<store>/convergence/<first 12 hex of the base id>`.
pub fn default_dir(store: &Store, base: &Experiment) -> PathBuf {
    store.root().join("convergence").join(base.id().short(12))
}

/// What [`sweep`] is asked for besides the plan.
#[derive(Debug, Clone, Default)]
pub struct Analysis {
    /// Responses to analyse (empty: every angle response of the scene that
    /// a run measured).
    pub responses: Vec<String>,
    /// Tolerance for the standard size (units of the responses).
    pub tolerance: Option<f64>,
}

/// What `repose convergence` asks for.
#[derive(Debug, Clone)]
pub struct SweepRequest {
    /// Size factors relative to the base's particle (1 = the base).
    pub factors: Vec<f64>,
    /// Replicates (packing seeds) per size, ≥ 2.
    pub replicates: usize,
    /// How Γ follows the size for a base without coarse graining.
    pub rule: Option<SurfaceEnergyRule>,
    /// The real particle's radius, m, for a base without coarse graining.
    pub real_radius_m: Option<f64>,
    /// Responses and tolerance.
    pub analysis: Analysis,
    /// Output directory (default [`default_dir`]).
    pub out_dir: Option<PathBuf>,
}

/// Plans the sweep of `base` (the manifest at `manifest`), refuses one that
/// may start more than `exec.max_runs` runs before anything is built (the
/// one-stage study [`StudySpec::convergence`]), then [`sweep`]s it; returns
/// what it did and where it wrote.
pub fn plan_and_sweep(
    store: &Store,
    base: &Experiment,
    manifest: &Path,
    request: &SweepRequest,
    exec: &Executor,
) -> Result<(SizeSweep, PathBuf), StudyError> {
    // Counted before anything is planned: the plan holds every replicate's
    // experiment, so a billion replicates must be refused, not allocated.
    StudySpec::convergence(
        &manifest.display().to_string(),
        base.id(),
        request.factors.len() as u64,
        request.replicates as u64,
    )
    .check_runs(exec.max_runs)
    .map_err(StudyError::Settings)?;
    let plan = plan::plan(
        base,
        &request.factors,
        request.replicates,
        request.rule,
        request.real_radius_m,
    )
    .map_err(|e| StudyError::Settings(e.to_string()))?;
    let out_dir = request
        .out_dir
        .clone()
        .unwrap_or_else(|| default_dir(store, base));
    let pool = exec.in_study(&out_dir);
    let done = sweep(
        store,
        base,
        manifest,
        &plan,
        &request.analysis,
        &pool,
        &out_dir,
    )?;
    Ok((done, out_dir))
}

/// What [`sweep`] did.
#[derive(Debug, Clone)]
pub struct SizeSweep {
    /// The measurements and conclusions.
    pub convergence: Convergence,
    /// The Markdown report.
    pub markdown: String,
}

/// Runs the plan's levels, analyses them and writes convergence.csv, .md
/// and .svg with a lineage record into `out_dir`.
pub fn sweep(
    store: &Store,
    base: &Experiment,
    manifest: &Path,
    plan: &SizePlan,
    analysis: &Analysis,
    pool: &Executor,
    out_dir: &Path,
) -> Result<SizeSweep, StudyError> {
    let points: Vec<_> = plan.levels.iter().map(|l| l.point.clone()).collect();
    tradeoff::announce("convergence", "sizes", store, &points, pool);
    let outcomes = run(store, &points, pool)?;
    let rows = summarise(store, base, plan, &outcomes, &analysis.responses);
    let done = analyse(base, &manifest.display().to_string(), plan, rows, analysis);
    let title = format!(
        "Particle-size convergence: {} ({})",
        done.scene,
        manifest.display()
    );
    let svg = report::svg(&done, &title).map_err(|e| StudyError::Plot(e.to_string()))?;
    let markdown = report::markdown(&done, &title);
    let outputs = [
        (out_dir.join("convergence.csv"), report::csv(&done)),
        (out_dir.join("convergence.md"), markdown.clone()),
        (out_dir.join("convergence.svg"), svg),
    ];
    let mut lineage = Lineage::new(
        "convergence",
        serde_json::json!({
            "factors": plan.levels.iter().map(|l| l.factor).collect::<Vec<_>>(),
            "replicates": points.first().map_or(0, |p| p.replicates.len()),
            "rule": plan.rule,
            "real_radius_m": plan.real_radius_m,
            "responses": analysis.responses,
            "tolerance": analysis.tolerance,
        }),
    )
    .with_input(InputRef::file(
        "base_manifest",
        manifest,
        Some(store.root()),
    )?);
    for row in &done.levels {
        for id in &row.ids {
            lineage = lineage.with_input(InputRef::id(format!("size={}", row.factor), id));
        }
    }
    for (path, text) in &outputs {
        crate::study::dir::write_output(path, text.as_bytes(), &lineage)?;
    }
    Ok(SizeSweep {
        convergence: done,
        markdown,
    })
}

/// Runs every replicate of every level (the tradeoff sweep's runner: one
/// executor, cached by id, failures as outcomes).
pub fn run(
    store: &Store,
    points: &[tradeoff::plan::Point],
    pool: &Executor,
) -> Result<Vec<Vec<Outcome>>, ExecError> {
    tradeoff::run(store, points, pool)
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The per-level rows: responses, cost, resolution and the plan's estimate.
/// `responses` empty: every `deg` response of the scene that some run
/// measured.
pub fn summarise(
    store: &Store,
    base: &Experiment,
    plan: &SizePlan,
    outcomes: &[Vec<Outcome>],
    responses: &[String],
) -> Vec<LevelRow> {
    let kind = base.scene.kind();
    let names: Vec<String> = if responses.is_empty() {
        catalogue(kind)
            .unwrap_or(&[])
            .iter()
            .filter(|s| s.unit == "deg")
            .filter(|s| {
                outcomes
                    .iter()
                    .flatten()
                    .filter_map(|o| o.result.as_ref())
                    .any(|r| response(r, kind, s.name).is_ok())
            })
            .map(|s| s.name.to_string())
            .collect()
    } else {
        responses.to_vec()
    };
    plan.levels
        .iter()
        .zip(outcomes)
        .map(|(level, runs)| {
            let results: Vec<_> = runs.iter().filter_map(|o| o.result.as_ref()).collect();
            let values: BTreeMap<String, Vec<f64>> = names
                .iter()
                .map(|n| {
                    let v = results
                        .iter()
                        .filter_map(|r| response(r, kind, n).ok())
                        .collect();
                    (n.clone(), v)
                })
                .collect();
            let cpu_s = runs
                .iter()
                .filter(|o| o.result.is_some())
                .filter_map(|o| store.timing(&o.id).map(|t| t.cpu_s()))
                .collect();
            let first = results.first();
            let resolution: BTreeMap<String, f64> = first
                .map(|r| {
                    r.resolution
                        .iter()
                        .map(|(k, f)| (k.clone(), f.value))
                        .collect()
                })
                .unwrap_or_default();
            let x = DEVICE_FIGURES
                .iter()
                .find_map(|name| resolution.get(*name))
                .map(|across| 1.0 / across);
            let measured = |key: &str| -> Vec<f64> {
                results
                    .iter()
                    .filter_map(|r| r.measurements.get(key).copied())
                    .collect()
            };
            let steps: Vec<f64> = results
                .iter()
                .filter_map(|r| {
                    Some(r.measurements.get("particles")? * r.measurements.get("steps")?)
                })
                .collect();
            LevelRow {
                factor: level.factor,
                radius_m: level.radius_m,
                x,
                replicates: runs.len(),
                completed: results.len(),
                responses: values
                    .iter()
                    .map(|(k, v)| (k.clone(), mean_ci(v)))
                    .collect(),
                values,
                particles: mean(&measured("particles")),
                particle_steps: mean(&steps),
                planned_particle_steps: level
                    .point
                    .replicates
                    .first()
                    .and_then(|e| crate::scenes::plan::plan(e).ok())
                    .map(|p| p.particle_steps),
                cpu_s,
                wall_s: mean(
                    &runs
                        .iter()
                        .filter_map(|o| o.wall_time_s)
                        .collect::<Vec<_>>(),
                ),
                unresolved: crate::scenes::resolution::unresolved_figures(results.iter().copied()),
                resolution,
                ids: runs.iter().map(|o| o.id.clone()).collect(),
                failure: runs.iter().find_map(|o| o.failure.clone()),
            }
        })
        .collect()
}

/// Fits the trends and the cost law and picks the standard size (see the
/// module docs).
pub fn analyse(
    base: &Experiment,
    manifest: &str,
    plan: &SizePlan,
    levels: Vec<LevelRow>,
    analysis: &Analysis,
) -> Convergence {
    let real_x = plan
        .real_radius_m
        .and_then(|real| levels.iter().find_map(|l| Some(l.x? * real / l.radius_m)));
    let anchor = levels.iter().find_map(|l| Some((l.x?, l.factor)));
    let cost = cost_law(&levels);
    let names: Vec<String> = levels
        .first()
        .map(|l| l.values.keys().cloned().collect())
        .unwrap_or_default();
    let trends: Vec<Trend> = names
        .iter()
        .map(|name| {
            trend(
                name,
                &levels,
                real_x.unwrap_or(0.0),
                analysis.tolerance,
                anchor,
                cost,
            )
        })
        .collect();
    let standard_factor = if trends.is_empty() || analysis.tolerance.is_none() {
        None
    } else {
        trends
            .iter()
            .map(|t| t.standard_factor)
            .try_fold(f64::INFINITY, |m, f| f.map(|f| m.min(f)))
    };
    Convergence {
        scene: base.scene.kind().to_string(),
        manifest: manifest.to_string(),
        rule: plan.rule,
        real_radius_m: plan.real_radius_m,
        real_x,
        tolerance: analysis.tolerance,
        levels,
        trends,
        cost,
        standard_factor,
    }
}

/// One response's trend (see the module docs). `real_x` is where the line
/// is read (0 when the real size is unknown: the limit d/D → 0).
fn trend(
    name: &str,
    levels: &[LevelRow],
    real_x: f64,
    tolerance: Option<f64>,
    anchor: Option<(f64, f64)>,
    cost: Option<CostLaw>,
) -> Trend {
    let mut points = Vec::new();
    let mut variances = Vec::new();
    for level in levels {
        let (Some(x), Some(values)) = (level.x, level.values.get(name)) else {
            continue;
        };
        let v = level
            .responses
            .get(name)
            .copied()
            .flatten()
            .map(|m| m.std * m.std);
        variances.push(v);
        points.extend(values.iter().map(|&y| (x, y, v)));
    }
    let by_variance = !variances.is_empty() && variances.iter().all(|v| v.is_some_and(|v| v > 0.0));
    let weighting = if by_variance {
        "inverse level variance"
    } else {
        "equal"
    };
    let x: Vec<f64> = points.iter().map(|p| p.0).collect();
    let y: Vec<f64> = points.iter().map(|p| p.1).collect();
    let w: Vec<f64> = points
        .iter()
        .map(|p| {
            if by_variance {
                1.0 / p.2.unwrap_or(1.0)
            } else {
                1.0
            }
        })
        .collect();
    let fit = weighted_line(&x, &y, &w).map_err(|e| e.to_string());
    let Ok(line) = fit else {
        return Trend {
            response: name.to_string(),
            weighting,
            fit,
            lack_of_fit: None,
            at_real: None,
            bias: vec![None; levels.len()],
            standard_factor: None,
            needed: None,
            size_effect: None,
        };
    };
    let lack_of_fit = line.lack_of_fit(&x, &y, &w);
    let size_effect = tolerance.map(|t| size_effect(&line, &x, 0.5 * t, lack_of_fit.as_ref()));
    // A line the levels contradict says nothing about the real size: no
    // standard size and no needed size from it.
    let tolerance = tolerance.filter(|_| {
        lack_of_fit
            .as_ref()
            .is_none_or(|l| l.p_value >= LACK_OF_FIT_ALPHA)
    });
    let half = line.slope_half_width();
    let bias: Vec<Option<(f64, f64)>> = levels
        .iter()
        .map(|l| {
            let dx = l.x? - real_x;
            Some((line.slope * dx, half * dx.abs()))
        })
        .collect();
    let standard_factor = tolerance.and_then(|t| {
        levels
            .iter()
            .zip(&bias)
            .find(|(_, b)| b.is_some_and(|(b, _)| b.abs() <= 0.5 * t))
            .map(|(l, _)| l.factor)
    });
    let needed = tolerance.zip(anchor).map(|(t, (x0, f0))| {
        let x = if line.slope == 0.0 {
            f64::INFINITY
        } else {
            real_x + 0.5 * t / line.slope.abs()
        };
        Needed {
            x,
            factor: f0 * x / x0,
            cpu_s: cost.map(|c| c.at(x)),
        }
    });
    Trend {
        response: name.to_string(),
        weighting,
        lack_of_fit,
        at_real: Some(line.at(real_x)),
        fit: Ok(line),
        bias,
        standard_factor,
        needed,
        size_effect,
    }
}

/// The size-effect test of `line` over the d/D values `x` at ± `margin`
/// (see [`SizeEffect`]).
fn size_effect(line: &LineFit, x: &[f64], margin: f64, lof: Option<&LackOfFit>) -> SizeEffect {
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    let (change, std_error, df) = line.change(span);
    let band = (-margin, margin);
    let test = tost_estimate(change, std_error, df, band);
    let verdict = lof
        .is_none_or(|l| l.p_value >= LACK_OF_FIT_ALPHA)
        .then(|| judge_estimate(&test, band, ALPHA));
    SizeEffect {
        span,
        margin,
        test,
        verdict,
    }
}

/// The cost law over the individual runs' CPU-seconds (see the module docs).
fn cost_law(levels: &[LevelRow]) -> Option<CostLaw> {
    let mut x = Vec::new();
    let mut y = Vec::new();
    for level in levels {
        let Some(lx) = level.x else { continue };
        for &c in &level.cpu_s {
            if c > 0.0 {
                x.push(lx.ln());
                y.push(c.ln());
            }
        }
    }
    let fit = weighted_line(&x, &y, &vec![1.0; x.len()]).ok()?;
    Some(CostLaw {
        exponent: (fit.slope, fit.slope_half_width()),
        log_coefficient: fit.intercept,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against statsmodels 0.15.0 and scipy (scratch venv), on stats::trend's
    /// fixture (three sizes × five runs, weights one over each level's
    /// variance):
    /// ```python
    /// r = sm.WLS(y, sm.add_constant(x), weights=w).fit(); span = 0.064 - 0.032
    /// c, se, df = r.params[1]*span, r.bse[1]*span, r.df_resid
    /// p = max(stats.t.sf((c + m)/se, df), stats.t.cdf((c - m)/se, df))
    /// stats.t.ppf(0.95, df)*se, stats.t.ppf(0.975, df)*se
    /// r.t_test(([0, span], [-m]))   # the same change, its 95 % interval
    /// ```
    /// The change is −2.774 (95 % interval −4.975 … −0.572): inside ±5
    /// (p 0.0239, size-independent), wholly outside ±0.5 (size-dependent),
    /// neither at ±2 or ±1 (p 0.769, 0.947: inconclusive).
    #[test]
    fn the_size_effect_matches_scipy_and_follows_the_acceptance_rule() {
        let (x, y, w) = crate::stats::trend::tests::data();
        let line = weighted_line(&x, &y, &w).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1e-3);
        for (margin, p, verdict) in [
            (5.0, 0.023913313002018106, Verdict::Pass),
            (2.0, 0.769373844329569, Verdict::Inconclusive),
            (1.0, 0.9473178271532101, Verdict::Inconclusive),
            (0.5, 0.9780475825393826, Verdict::Fail),
        ] {
            let e = size_effect(&line, &x, margin, None);
            assert!(close(e.span, 0.032), "{}", e.span);
            assert!(close(e.test.estimate, -2.77371671216259));
            assert!(close(e.test.std_error, 1.0190613019957122));
            assert_eq!(e.test.df, 13.0);
            assert!(close(e.test.p, p), "±{margin}: p {} vs {p}", e.test.p);
            assert!(close(e.test.ci90_half_width, 1.8046896922620705));
            assert!(close(e.test.ci95_half_width, 2.2015480958456997));
            assert_eq!(e.verdict, Some(verdict), "±{margin}");
        }
        // A line the levels contradict gives no verdict.
        let lof = LackOfFit::from_sums(40.0, 12.0, 1, 12);
        assert!(lof.p_value < LACK_OF_FIT_ALPHA);
        assert_eq!(size_effect(&line, &x, 5.0, Some(&lof)).verdict, None);
    }
}
