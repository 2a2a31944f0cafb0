//! The fine stage of a two-level (multi-fidelity) calibration
//! (`noise_aware.fidelity`, [`Fidelity`]): a few of the design's points run
//! again at a finer particle size, and the two-level Gaussian process
//! y_fine = ρ·y_coarse + δ ([`crate::stats::gp_two_level`]) predicts the
//! fine level for the search and the verification, which are then the fine
//! level's.
//!
//! ```text
//! train/gp.json + batch/replicates.csv ──▶ fine/runs.csv        the fine points' replicates
//!                                      ──▶ fine/two_level.json  ρ, β, δ's hyperparameters, the fine data
//!                                      ──▶ fine/fine.md         the same, for a reader
//!                                      ──▶ fine/cost.json       CPU-s per level (not deterministic)
//! ```
//!
//! # Levels
//! The coarse level is the study's trained Gaussian process (`train/gp.json`:
//! every design row, with its noise variances), used as fitted. A fine
//! experiment is the study's experiment of the same design point and
//! replicate with the particle radius × `fine_size` and the surface energies
//! × `fine_size`² (Γ ∝ R², constant Bond number: `repose convergence`'s and
//! `repose pilot`'s rule); replicate r keeps the coarse replicate's packing
//! seed. Each fine point runs `fine_replicates` seeds; its mean's noise
//! variance is s²/nᵢ with s² pooled over every fine point so far: with 3
//! seeds a point's own s² has 2 degrees of freedom (its 95 % range spans a
//! factor of 40), and a point whose seeds happened to agree would carry the
//! fine level alone; the seed-to-seed noise of one scene at one size is
//! taken as the same across the ranges, as the coarse GP's pooled noise.
//!
//! # Which points run fine
//! The fine points are design points (a nested design, the case the
//! recursive two-level model is exact for). The first three are chosen by
//! space filling alone — the design point nearest the centre of the ranges,
//! then each time the point farthest (in the unit cube) from those chosen —
//! because ρ and β are global coefficients that three clustered points would
//! not identify. Every further point is chosen by the model: the two-level
//! process is fitted to the fine points so far and the design point where
//! its fine-level predictive sd is largest runs next (a round of one point;
//! if the fit fails, the space-filling rule picks instead, and fine.md says
//! so). Ties go to the earlier design point. Every choice is deterministic,
//! and every run is cached in the store, so a killed stage resumes.
//!
//! # Fit
//! δ's hyperparameters are fitted by [`TwoLevelGp::fit_on`] (profiled over
//! ρ and β, a fitted nugget, 8 restarts drawn from the study's design seed);
//! `two_level.json` records them with the fine data so the search and
//! `repose audit` rebuild the very model ([`load_two_level`]).
//!
//! # Cost
//! `cost.json` gives the CPU-s of the coarse design's runs and of the fine
//! runs (each run's `thread_cpu_s`), and what the same design would have
//! cost at the fine size (its runs × the fine runs' mean CPU-s per run).
//! Wall and CPU times vary between machines, so they live in their own file;
//! every other output of the stage is the same bytes on any executor.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::exec::Executor;
use crate::manifest::ContentId;
use crate::manifest::{Experiment, Fidelity, Study};
use crate::report::markdown::{Align, MarkdownTable};
use crate::stats::gp::{GaussianProcess, GpHyper, GpSettings};
use crate::stats::gp_two_level::{LevelData, Predictor, TwoLevelFit, TwoLevelGp};
use crate::stats::summary::mean_ci;
use crate::store::{RunDir, RunResult, Store};
use crate::study::dir::Stage;
use crate::study::dir::{json_bytes, write_output, StudyDir};
use crate::study::plan::calibration::{parameter_names, to_unit};
use crate::study::runs::replicated::{
    pooled_variance, read_replicates_csv, replicates_csv, run_replicated_at, AtSize, Replicated,
};
use crate::study::StudyError;

/// Points chosen by space filling before the model chooses.
pub const SPACE_FILLING_POINTS: usize = 3;

/// How a fine point was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Choice {
    /// Nearest the centre, or farthest from the points chosen.
    SpaceFilling,
    /// Largest fine-level predictive sd under the two-level process.
    FineSd,
    /// The model was asked but could not be fitted; space filling chose.
    SpaceFillingFallback,
}

/// One fine point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FinePoint {
    /// Its design `sample_index`.
    pub index: u64,
    /// The point in the unit cube of the ranges.
    pub x_unit: Vec<f64>,
    /// How it was chosen.
    pub chosen_by: Choice,
    /// The model's fine-level sd there when it chose (degrees).
    pub predicted_sd_deg: Option<f64>,
    /// The coarse design's mean there (degrees).
    pub coarse_mean_deg: Option<f64>,
    /// Fine seeds run.
    pub seeds: usize,
    /// Fine seeds measured.
    pub measured: usize,
    /// Fine mean (degrees), with two or more measured seeds.
    pub mean_deg: Option<f64>,
    /// Its noise variance s²/n (deg²), s² pooled over the fine points.
    pub noise_var: Option<f64>,
}

/// δ's hyperparameters (the record of a [`GpHyper`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeltaHyper {
    /// σ_f² (deg²).
    pub signal_var: f64,
    /// Length scales in the unit cube.
    pub length_scales: Vec<f64>,
    /// Nugget (deg²).
    pub nugget_var: f64,
}

/// `fine/two_level.json`: the fine level and its fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwoLevelRecord {
    /// The study's fidelity block.
    pub fidelity: Fidelity,
    /// The calibrated parameters, in order.
    pub parameters: Vec<String>,
    /// The fine points in the order they were chosen.
    pub points: Vec<FinePoint>,
    /// ρ, β (degrees) and the levels' prior sd (degrees).
    #[serde(flatten)]
    pub fit: TwoLevelFit,
    /// δ's hyperparameters.
    pub delta: DeltaHyper,
}

/// `fine/cost.json`: CPU-s per level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelCost {
    /// Coarse design runs, and their CPU-s (runs with a timing record).
    pub coarse_runs: usize,
    /// CPU-s of the coarse design runs.
    pub coarse_cpu_s: f64,
    /// Fine runs.
    pub fine_runs: usize,
    /// CPU-s of the fine runs.
    pub fine_cpu_s: f64,
    /// The coarse design's runs × the fine runs' mean CPU-s: what the same
    /// design would have cost at the fine size.
    pub design_at_fine_size_cpu_s: Option<f64>,
}

/// What the stage did.
#[derive(Debug, Clone)]
pub struct FineOutcome {
    /// The fit and its data.
    pub record: TwoLevelRecord,
    /// CPU-s per level.
    pub cost: LevelCost,
    /// Fine runs (all seeds of all fine points).
    pub runs: usize,
    /// fine.md.
    pub markdown: String,
}

/// The study's fidelity block, or why the stage cannot run.
pub fn fidelity(study: &Study) -> Result<Fidelity, StudyError> {
    study.fidelity().ok_or_else(|| {
        StudyError::Settings(
            "the study has no noise_aware.fidelity block: the fine stage is for two-level \
                 studies"
                .into(),
        )
    })
}

/// The two-level process the fine stage fitted, rebuilt from `coarse` (the
/// trained GP of `train/gp.json`, which the caller reads) and
/// `two_level.json` (δ and the fine data).
pub fn load_two_level(dir: &StudyDir, coarse: GaussianProcess) -> Result<TwoLevelGp, StudyError> {
    let path = dir.require(dir.two_level_path(), Stage::Fine)?;
    let record: TwoLevelRecord = Store::read_json(&path).map_err(|e| StudyError::Inconsistent {
        path: path.clone(),
        message: format!("{e}: rerun `repose fine`"),
    })?;
    let (x, y, v) = fine_data(&record.points);
    let hyper = GpHyper {
        signal_var: record.delta.signal_var,
        length_scales: record.delta.length_scales.clone(),
        nugget_var: record.delta.nugget_var,
        mean: 0.0,
    };
    TwoLevelGp::with_delta(
        coarse,
        LevelData {
            x: &x,
            y: &y,
            noise_var: &v,
        },
        &hyper,
    )
    .map_err(|e| StudyError::Inconsistent {
        path,
        message: e.to_string(),
    })
}

/// The surrogate a study's search and verification answer to: the
/// two-level process's fine level in a two-level study (read from the fine
/// stage's record over `coarse`), the trained GP `coarse` otherwise.
pub fn predictor(
    dir: &StudyDir,
    study: &Study,
    coarse: GaussianProcess,
) -> Result<Predictor, StudyError> {
    Ok(if study.fidelity().is_some() {
        Predictor::TwoLevel(Box::new(load_two_level(dir, coarse)?))
    } else {
        Predictor::OneLevel(coarse)
    })
}

/// The fine points with a mean, as the fine level's data.
fn fine_data(points: &[FinePoint]) -> (Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
    let mut x = Vec::new();
    let mut y = Vec::new();
    let mut v = Vec::new();
    for p in points {
        if let (Some(m), Some(nv)) = (p.mean_deg, p.noise_var) {
            x.push(p.x_unit.clone());
            y.push(m);
            v.push(nv);
        }
    }
    (x, y, v)
}

fn fit_on(coarse: &GaussianProcess, points: &[FinePoint], seed: u64) -> Result<TwoLevelGp, String> {
    let (x, y, v) = fine_data(points);
    let settings = GpSettings {
        seed,
        ..GpSettings::default()
    };
    TwoLevelGp::fit_on(
        coarse.clone(),
        LevelData {
            x: &x,
            y: &y,
            noise_var: &v,
        },
        &settings,
    )
    .map_err(|e| e.to_string())
}

/// The unchosen row farthest from the chosen ones (nearest the centre when
/// none is chosen); ties to the earlier row.
fn space_filling(unit: &[Vec<f64>], chosen: &[usize]) -> Option<usize> {
    let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum::<f64>();
    let score = |i: usize| -> f64 {
        if chosen.is_empty() {
            -d2(&unit[i], &vec![0.5; unit[i].len()])
        } else {
            chosen
                .iter()
                .map(|&c| d2(&unit[i], &unit[c]))
                .fold(f64::INFINITY, f64::min)
        }
    };
    let mut best: Option<(usize, f64)> = None;
    for i in (0..unit.len()).filter(|i| !chosen.contains(i)) {
        let s = score(i);
        if best.is_none_or(|(_, b)| s > b) {
            best = Some((i, s));
        }
    }
    best.map(|(i, _)| i)
}

/// The unchosen row where `model`'s fine-level sd is largest, with that sd.
fn largest_sd(model: &TwoLevelGp, unit: &[Vec<f64>], chosen: &[usize]) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for i in (0..unit.len()).filter(|i| !chosen.contains(i)) {
        let sd = model.predict(&unit[i]).sd;
        if best.is_none_or(|(_, b)| sd > b) {
            best = Some((i, sd));
        }
    }
    best
}

/// A round's picks: the design row, how it was chosen and the model's
/// fine-level sd there (degrees) when the model chose.
type Pick = (usize, Choice, Option<f64>);

/// The fine points chosen so far, in order, and their runs.
#[derive(Default)]
struct Chosen {
    /// Their design rows.
    rows: Vec<usize>,
    /// The fine points.
    points: Vec<FinePoint>,
    /// Their fine runs.
    runs: Vec<Replicated>,
}

/// Runs the fine stage (module docs) over `coarse`, the trained GP of the
/// fit stage (the driver reads it); `log` gets one line per round.
pub fn fine<E, F>(
    dir: &StudyDir,
    study: &Study,
    coarse: &GaussianProcess,
    store: &Store,
    pool: &Executor,
    runner: &F,
    log: &mut dyn FnMut(&str),
) -> Result<FineOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let spec = fidelity(study)?;
    let design_file = dir.require(dir.replicates_path(), Stage::Batch)?;
    let design: Vec<Replicated> = read_replicates_csv(&design_file, study)?;
    let unit: Vec<Vec<f64>> = design.iter().map(|r| to_unit(study, &r.point)).collect();
    let wanted = (spec.fine_points as usize).min(design.len());
    let seed = study.design.seed;
    let mut chosen = Chosen::default();
    while chosen.rows.len() < wanted {
        let round = next_round(coarse, &unit, &chosen, wanted, seed, log);
        if round.is_empty() {
            break;
        }
        let batch: Vec<(u64, Vec<f64>)> = round
            .iter()
            .map(|(i, ..)| (design[*i].index, design[*i].point.clone()))
            .collect();
        let (done, _) = run_replicated_at(
            study,
            &study.calibration,
            &batch,
            spec.fine_replicates,
            AtSize::verified(study),
            store,
            pool,
            runner,
            false,
        )?;
        for (pick, r) in round.into_iter().zip(done) {
            add_point(&mut chosen, pick, r, (&design, &unit), log);
        }
        pool_noise(&mut chosen.points, &chosen.runs);
    }
    let Chosen { points, runs, .. } = chosen;
    let fitted = fit_on(coarse, &points, seed).map_err(|why| {
        StudyError::Settings(format!(
            "the two-level process could not be fitted to the {} fine points: {why}",
            points.len()
        ))
    })?;
    let delta_hyper = fitted.hyper().1;
    let record = TwoLevelRecord {
        fidelity: spec,
        parameters: parameter_names(study),
        points,
        fit: fitted.summary(),
        delta: DeltaHyper {
            signal_var: delta_hyper.signal_var,
            length_scales: delta_hyper.length_scales.clone(),
            nugget_var: delta_hyper.nugget_var,
        },
    };
    let cost = level_cost(store, &design, &runs);
    let outcome = FineOutcome {
        runs: runs.iter().map(|r| r.runs.len()).sum(),
        markdown: markdown(&record, cost.coarse_runs),
        record,
        cost,
    };
    write_outputs(dir, study, store, (&design_file, &runs), &outcome)?;
    Ok(outcome)
}

/// The next round's picks: the space-filling start together, then one
/// point at a time by the model (space filling again, logged, when the
/// two-level fit fails); empty when no row is left.
fn next_round(
    coarse: &GaussianProcess,
    unit: &[Vec<f64>],
    chosen: &Chosen,
    wanted: usize,
    seed: u64,
    log: &mut dyn FnMut(&str),
) -> Vec<Pick> {
    let mut round: Vec<Pick> = Vec::new();
    if chosen.rows.len() < SPACE_FILLING_POINTS {
        let mut picked = chosen.rows.clone();
        while picked.len() < SPACE_FILLING_POINTS.min(wanted) {
            let Some(i) = space_filling(unit, &picked) else {
                break;
            };
            picked.push(i);
            round.push((i, Choice::SpaceFilling, None));
        }
    } else {
        match fit_on(coarse, &chosen.points, seed) {
            Ok(m) => {
                if let Some((i, sd)) = largest_sd(&m, unit, &chosen.rows) {
                    round.push((i, Choice::FineSd, Some(sd)));
                }
            }
            Err(why) => {
                log(&format!(
                    "fine: the two-level fit failed ({why}); space filling picks"
                ));
                if let Some(i) = space_filling(unit, &chosen.rows) {
                    round.push((i, Choice::SpaceFillingFallback, None));
                }
            }
        }
    }
    round
}

/// Adds the fine point `pick` of the coarse `design` (its rows in the unit
/// cube `unit`) with its fine runs `r` to `chosen`, logging its mean.
fn add_point(
    chosen: &mut Chosen,
    (i, choice, sd): Pick,
    r: Replicated,
    (design, unit): (&[Replicated], &[Vec<f64>]),
    log: &mut dyn FnMut(&str),
) {
    let values = r.values();
    let summary = mean_ci(&values);
    log(&format!(
        "fine: design point {} ({choice:?}{}): {}",
        r.index,
        sd.map_or(String::new(), |s| format!(", predicted sd {s:.2} deg")),
        summary
            .as_ref()
            .map_or("fewer than 2 seeds measured".into(), |m| {
                format!("{:.2} ± {:.2} deg", m.mean, m.half_width)
            })
    ));
    chosen.points.push(FinePoint {
        index: r.index,
        x_unit: unit[i].clone(),
        chosen_by: choice,
        predicted_sd_deg: sd,
        coarse_mean_deg: design[i].mean(),
        seeds: r.runs.len(),
        mean_deg: summary.as_ref().map(|m| m.mean),
        measured: values.len(),
        noise_var: None,
    });
    chosen.rows.push(i);
    chosen.runs.push(r);
}

/// Writes the stage's outputs with their lineage (the fidelity block, the
/// GP, the coarse design file and every fine run's result): `runs.csv`,
/// `two_level.json`, `fine.md` and `cost.json`.
fn write_outputs(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    (design_file, runs): (&Path, &[Replicated]),
    outcome: &FineOutcome,
) -> Result<(), StudyError> {
    dir.prepare_stage(study, Stage::Fine)?;
    let mut lineage = dir
        .lineage(Stage::Fine, json!({ "fidelity": outcome.record.fidelity }))
        .with_input(dir.input("gp", &dir.gp_path())?)
        .with_input(dir.input("design", design_file)?);
    for r in runs.iter().flat_map(|p| &p.runs) {
        let file = store.run_dir(&r.id).result_path();
        if file.is_file() {
            lineage = lineage.with_input(dir.input("result", &file)?);
        }
    }
    let out = dir.stage(Stage::Fine);
    let scene = study.calibration.name.as_str();
    write_output(
        &out.join("runs.csv"),
        replicates_csv(study, &[(scene, runs)]).as_bytes(),
        &lineage,
    )?;
    write_output(
        &dir.two_level_path(),
        &json_bytes(&outcome.record),
        &lineage,
    )?;
    write_output(&out.join("fine.md"), outcome.markdown.as_bytes(), &lineage)?;
    write_output(&out.join("cost.json"), &json_bytes(&outcome.cost), &lineage)
}

/// Sets every fine mean's noise variance to the fine points' pooled
/// seed-to-seed variance over its measured seeds (module docs).
fn pool_noise(points: &mut [FinePoint], runs: &[Replicated]) {
    let pooled = pooled_variance(&runs.iter().collect::<Vec<_>>()).map(|(v, _)| v);
    for p in points {
        p.noise_var = match (pooled, p.mean_deg) {
            (Some(v), Some(_)) => Some(v / p.measured as f64),
            _ => None,
        };
    }
}

fn level_cost(store: &Store, design: &[Replicated], fine: &[Replicated]) -> LevelCost {
    let sum = |rows: &[Replicated]| -> (usize, f64, usize) {
        let ids: Vec<&ContentId> = rows
            .iter()
            .flat_map(|r| r.runs.iter().map(|s| &s.id))
            .collect();
        let timed: Vec<f64> = ids
            .iter()
            .filter_map(|id| store.timing(id).map(|t| t.cpu_s()))
            .collect();
        (ids.len(), timed.iter().sum(), timed.len())
    };
    let (coarse_runs, coarse_cpu_s, _) = sum(design);
    let (fine_runs, fine_cpu_s, fine_timed) = sum(fine);
    LevelCost {
        coarse_runs,
        coarse_cpu_s,
        fine_runs,
        fine_cpu_s,
        design_at_fine_size_cpu_s: (fine_timed > 0)
            .then(|| coarse_runs as f64 * fine_cpu_s / fine_timed as f64),
    }
}

fn markdown(r: &TwoLevelRecord, design_runs: usize) -> String {
    let f = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}"));
    let mut s = format!(
        "# Fine level: particle size × {}, {} seeds per point\n\n",
        r.fidelity.fine_size, r.fidelity.fine_replicates
    );
    let mut t = MarkdownTable::new(&[
        "index",
        "chosen by",
        "predicted sd (°)",
        "coarse mean (°)",
        "fine mean (°)",
        "seeds",
    ]);
    for c in [0, 2, 3, 4, 5] {
        t = t.align(c, Align::Right);
    }
    for p in &r.points {
        t.row(&[
            p.index.to_string(),
            match p.chosen_by {
                Choice::SpaceFilling => "space filling".into(),
                Choice::FineSd => "largest fine sd".into(),
                Choice::SpaceFillingFallback => "space filling (fit failed)".into(),
            },
            f(p.predicted_sd_deg),
            f(p.coarse_mean_deg),
            f(p.mean_deg),
            p.seeds.to_string(),
        ]);
    }
    s.push_str(&t.render());
    let fine_runs: usize = r.points.iter().map(|p| p.seeds).sum();
    let _ = write!(
        s,
        "\n{}\n\nRuns: {design_runs} coarse (the design), {fine_runs} fine; their CPU-s are in \
         cost.json.\n",
        r.fit.describe()
    );
    s
}
