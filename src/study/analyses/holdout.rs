//! `repose holdout STUDY --pilot PILOT_JSON --pilot-study PILOT_STUDY`: how
//! well a calibrated study's surrogate predicts fine-size runs it never saw.
//!
//! The held-out points are a pilot's ([`crate::study::sweeps::pilot`]): Latin-
//! hypercube points of the pilot study's ranges run at the pilot's fine size
//! with several packing seeds each (their own sample indices, so no study
//! trained on them). The model is the study's fine-level predictor: the
//! two-level process of a two-level study (`noise_aware.fidelity`, whose
//! fine size must be the pilot's), or the Gaussian process of a one-level
//! study whose particle *is* the pilot's fine particle (a fine-only study).
//! Either way the model answers in the unit cube of its ranges, and a fine
//! study's surface-energy ranges are the pilot study's × (r_fine / r)² (Γ ∝
//! R², the rule of every fine level here), so the pilot's points are mapped
//! to the unit cube by the pilot study's ranges; the command checks that the
//! two studies' ranges correspond that way and refuses otherwise.
//!
//! Per point: the observed fine mean and its standard error, the predicted
//! mean and latent sd, the error and z = error / √(sd² + se²). Over the
//! points: the RMSE, the mean z² (≈ 1 when the model's sd is honest) and
//! how many observed means lie in the 95 % prediction interval. Beside them,
//! the study's training runs and their CPU-s (the noise floor, the design
//! and the fine points; each run's `thread_cpu_s`), so two studies can be
//! compared at equal CPU.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::manifest::{SizeDistribution, Study};
use crate::report::markdown::{Align, MarkdownTable};
use crate::stats::gp::GpPrediction;
use crate::stats::summary::{mean_ci, Z95};
use crate::store::{Lineage, Store};
use crate::study::dir::Stage;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::{parameter_names, to_unit};
use crate::study::runs::replicated::read_replicates_csv;
use crate::study::stages::fine::predictor;
use crate::study::stages::fit_gp::read_gp;
use crate::study::sweeps::pilot::Pilot;
use crate::study::StudyError;

/// One held-out point.
#[derive(Debug, Clone, Serialize)]
pub struct HeldOut {
    /// The pilot point's sample index.
    pub index: u64,
    /// Observed fine mean (degrees) and its standard error.
    pub observed: (f64, f64),
    /// Predicted mean and latent sd (degrees).
    pub predicted: (f64, f64),
    /// Predicted − observed (degrees).
    pub error: f64,
    /// error / √(sd² + se²).
    pub z: f64,
}

/// The held-out comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Holdout {
    /// The study's name and id.
    pub study: String,
    /// `two_level` or `gp`.
    pub model: String,
    /// The points with two or more measured fine seeds.
    pub points: Vec<HeldOut>,
    /// Root-mean-square error (degrees).
    pub rmse: f64,
    /// Mean z².
    pub mean_z2: f64,
    /// Observed means inside the 95 % prediction interval.
    pub covered: usize,
    /// The study's training runs (noise floor, design, fine points).
    pub training_runs: usize,
    /// Their CPU-s (runs with a timing record).
    pub training_cpu_s: f64,
}

/// The mean particle radius of a study's material (m), or why not.
fn radius(study: &Study) -> Result<f64, StudyError> {
    match &study.material.particle.size {
        SizeDistribution::Monodisperse { radius_m } => Ok(*radius_m),
        SizeDistribution::D10D50D90 { d50_m, .. } => Ok(d50_m / 2.0),
        SizeDistribution::List { .. } => Err(StudyError::Settings(format!(
            "{}: holdout compares studies of one particle size (monodisperse or d50)",
            study.name
        ))),
    }
}

/// Checks that `model`'s ranges are `pilot_study`'s with every surface
/// energy × `gamma` (same names, same order).
fn check_ranges(model: &Study, pilot_study: &Study, gamma: f64) -> Result<(), StudyError> {
    let names = parameter_names(model);
    if names != parameter_names(pilot_study) {
        return Err(StudyError::Settings(format!(
            "{} calibrates {names:?}, the pilot's study {:?}",
            model.name,
            parameter_names(pilot_study)
        )));
    }
    for (name, (m, p)) in names.iter().zip(
        model
            .parameters
            .values()
            .zip(pilot_study.parameters.values()),
    ) {
        let f = if name.contains("surface_energy") {
            gamma
        } else {
            1.0
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300);
        if !(close(m.min, p.min * f) && close(m.max, p.max * f)) {
            return Err(StudyError::Settings(format!(
                "parameter {name}: {}'s range [{}, {}] is not the pilot study's [{}, {}] x {f}",
                model.name, m.min, m.max, p.min, p.max
            )));
        }
    }
    Ok(())
}

/// Compares `study`'s fine-level predictions with `pilot`'s fine runs
/// (module docs).
pub fn holdout(
    dir: &StudyDir,
    study: &Study,
    store: &Store,
    pilot: &Pilot,
    pilot_study: &Study,
) -> Result<Holdout, StudyError> {
    check_pilot_study(pilot, pilot_study)?;
    let (r_model, r_pilot) = (radius(study)?, radius(pilot_study)?);
    // The model study's stated particle relative to the pilot study's.
    let own = r_model / r_pilot;
    if let Some(f) = study.fidelity() {
        if (own - 1.0).abs() > 1e-9 || (f.fine_size - pilot.fine_factor).abs() > 1e-9 {
            return Err(StudyError::Settings(format!(
                "{}: a two-level study is compared at the pilot's sizes: its particle must be \
                 the pilot study's and its fine_size the pilot's {} (it has {} and {})",
                study.name, pilot.fine_factor, own, f.fine_size
            )));
        }
    } else if (own - pilot.fine_factor).abs() > 1e-9 {
        return Err(StudyError::Settings(format!(
            "{}: a one-level study is compared when its particle is the pilot's fine one: \
             radius / the pilot study's = {own}, the pilot's fine size {}",
            study.name, pilot.fine_factor
        )));
    }
    check_ranges(study, pilot_study, own * own)?;
    let model = predictor(dir, study, read_gp(dir)?.process()?)?;
    let mut points = Vec::new();
    for p in &pilot.points {
        let Some(s) = mean_ci(&p.fine) else {
            continue;
        };
        let se = s.std / (s.n as f64).sqrt();
        let GpPrediction { mean, sd } = model.predict(&to_unit(pilot_study, &p.point));
        let error = mean - s.mean;
        points.push(HeldOut {
            index: p.index,
            observed: (s.mean, se),
            predicted: (mean, sd),
            error,
            z: error / (sd * sd + se * se).sqrt(),
        });
    }
    if points.is_empty() {
        return Err(StudyError::Settings(
            "the pilot has no point with two or more measured fine seeds".into(),
        ));
    }
    let n = points.len() as f64;
    let rmse = (points.iter().map(|p| p.error * p.error).sum::<f64>() / n).sqrt();
    let mean_z2 = points.iter().map(|p| p.z * p.z).sum::<f64>() / n;
    let covered = points.iter().filter(|p| p.z.abs() <= Z95).count();
    let (training_runs, training_cpu_s) = training_cost(dir, study, store)?;
    Ok(Holdout {
        study: format!("{} ({})", study.name, dir.id().short(12)),
        model: if model.is_two_level() {
            "two_level"
        } else {
            "gp"
        }
        .into(),
        points,
        rmse,
        mean_z2,
        covered,
        training_runs,
        training_cpu_s,
    })
}

/// The study's training runs (noise floor, design, fine points) and their
/// CPU-s.
fn training_cost(dir: &StudyDir, study: &Study, store: &Store) -> Result<(usize, f64), StudyError> {
    let mut runs = 0;
    let mut cpu = 0.0;
    for path in [
        dir.noise_runs_path(),
        dir.require(dir.replicates_path(), Stage::Batch)?,
        dir.stage(Stage::Fine).join("runs.csv"),
    ] {
        if !path.is_file() {
            continue;
        }
        for r in read_replicates_csv(&path, study)?
            .iter()
            .flat_map(|p| &p.runs)
        {
            runs += 1;
            cpu += store.timing(&r.id).map_or(0.0, |t| t.cpu_s());
        }
    }
    Ok((runs, cpu))
}

/// The comparison as Markdown.
pub fn markdown(h: &Holdout) -> String {
    let mut t = MarkdownTable::new(&[
        "pilot point",
        "observed (°)",
        "predicted (°)",
        "error (°)",
        "z",
    ]);
    for c in 0..5 {
        t = t.align(c, Align::Right);
    }
    for p in &h.points {
        t.row(&[
            p.index.to_string(),
            format!("{:.2} ± {:.2}", p.observed.0, p.observed.1),
            format!("{:.2} ± {:.2}", p.predicted.0, p.predicted.1),
            format!("{:+.2}", p.error),
            format!("{:+.2}", p.z),
        ]);
    }
    let mut s = format!(
        "# Held-out fine runs: {} ({} model)\n\n{}",
        h.study,
        h.model,
        t.render()
    );
    let _ = writeln!(
        s,
        "\nRMSE {:.2}°, mean z² {:.2}, {} of {} observed means inside the 95 % prediction \
         interval; trained on {} runs, {:.0} CPU-s.",
        h.rmse,
        h.mean_z2,
        h.covered,
        h.points.len(),
        h.training_runs,
        h.training_cpu_s
    );
    s
}

/// Reads a pilot's `pilot.json`, refusing one that its lineage record (the
/// `pilot.json.lineage.json` `repose pilot` writes beside it, which `repose
/// audit` checks) does not describe: edited, or moved without its record.
/// Every refusal is the caller's input (exit 2) and names the file once.
pub fn read_pilot(path: &Path) -> Result<Pilot, StudyError> {
    let refuse = |why: String| StudyError::Settings(format!("--pilot {}: {why}", path.display()));
    let bytes = std::fs::read(path).map_err(|e| refuse(format!("cannot read it ({e})")))?;
    let record = Lineage::path_beside(path);
    let lineage = Lineage::read_beside(path).map_err(|_| {
        refuse(format!(
            "no readable lineage record {} beside it: give the pilot.json that `repose pilot` \
             wrote (copy its record with it)",
            record.display()
        ))
    })?;
    if lineage.stage != "pilot" || !lineage.describes(&bytes) {
        return Err(refuse(format!(
            "it is not the file `repose pilot` wrote (its lineage record {} holds another \
             hash or stage: edited after it was written?); run `repose pilot` again",
            record.display()
        )));
    }
    serde_json::from_slice(&bytes)
        .map_err(|e| refuse(format!("not a pilot.json of `repose pilot` ({e})")))
}

/// Refuses a pilot that did not run `pilot_study` (by the study id it
/// records).
fn check_pilot_study(pilot: &Pilot, pilot_study: &Study) -> Result<(), StudyError> {
    match &pilot.study {
        Some(id) if *id == pilot_study.id() => Ok(()),
        Some(id) => Err(StudyError::Settings(format!(
            "--pilot-study {} (id {}) is not the study the pilot ran (id {}): the pilot's \
             fine runs are the physics of that study",
            pilot_study.name,
            pilot_study.id().short(12),
            id.short(12)
        ))),
        None => Err(StudyError::Settings(
            "the pilot records no study id (written before pilots recorded it): run \
             `repose pilot` again"
                .into(),
        )),
    }
}
