//! `repose pilot STUDY --scene NAME`: does a two-level (coarse + fine)
//! calibration pay in this scene? The same design points at the study's
//! particle size and at a finer one, several packing seeds each, and the
//! two-level Gaussian process y_fine = ρ·y_coarse + δ fitted to them
//! ([`crate::stats::gp_two_level`]): ρ and the discrepancy δ (its mean β and
//! its spread) with their uncertainty.
//!
//! # The points and runs
//! `points` points of a Latin hypercube (random placement) over the study's
//! parameter ranges, drawn from the ChaCha stream ([`Stream::Pilot`]) of the
//! study's design seed, at sample indices [`PILOT_INDEX`] + i (disjoint from
//! every other stage's). Replicate r of point i at the coarse size is the
//! study's own experiment (`Study::replicate_experiment`, its packing-seed
//! rule); at the fine size it is that experiment with the particle scaled by
//! the fine factor and the surface energy by Γ ∝ R² (constant Bond number,
//! as `repose convergence`). Both levels run through the one executor,
//! cached by id.
//!
//! # Reading it
//! ρ near 1 with a small δ spread: the coarse runs carry most of what the
//! fine ones would say, and a two-level design can spend most of its runs
//! coarse. ρ near 0 (its interval covering 0), or δ's spread as large as
//! the fine response's own: the coarse level does not predict the fine one
//! and multi-fidelity does not pay. The correlation of the points' coarse
//! and fine means is given beside it as a model-free check.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::doe::lhs::{latin_hypercube, Placement};
use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::Executor;
use crate::manifest::{ContentId, Experiment, Study};
use crate::report::markdown::{Align, MarkdownTable};
use crate::scenes::run_logged;
use crate::stats::gp::GpSettings;
use crate::stats::gp_two_level::{LevelData, TwoLevelFit, TwoLevelGp};
use crate::stats::summary::{mean_ci, MeanCi};
use crate::store::{InputRef, Lineage, Store};
use crate::streams::{rng, Stream};
use crate::study::sweeps::convergence::plan::{scaled, SurfaceEnergyRule};
use crate::study::StudyError;

/// `sample_index` of the pilot's first point (no other stage reaches it).
pub const PILOT_INDEX: u64 = 4_000_000_000;

/// What the pilot runs.
#[derive(Debug, Clone)]
pub struct PilotSpec {
    /// The study's scene: `calibration` or a verification scene's name (or
    /// the calibration scene's own name).
    pub scene: String,
    /// Design points (≥ 3).
    pub points: usize,
    /// Packing seeds per point and level (≥ 2).
    pub seeds: u32,
    /// Fine particle radius / the study's, in (0, 1).
    pub fine_factor: f64,
}

/// One design point at both levels.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PilotPoint {
    /// Its `sample_index`.
    pub index: u64,
    /// Parameter values, physical units, in the study's parameter order.
    pub point: Vec<f64>,
    /// Coarse runs' values, in seed order.
    pub coarse: Vec<f64>,
    /// Fine runs' values, in seed order.
    pub fine: Vec<f64>,
}

/// What the pilot measured and the two-level fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Pilot {
    /// The id of the study the pilot ran (absent in pilots written before it
    /// was recorded; `repose holdout` refuses those). A holdout checks it
    /// against the `--pilot-study` it is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub study: Option<ContentId>,
    /// The scene's name in the study.
    pub scene: String,
    /// The response analysed.
    pub response: String,
    /// The study's parameter names.
    pub parameters: Vec<String>,
    /// Fine radius / coarse radius.
    pub fine_factor: f64,
    /// The points.
    pub points: Vec<PilotPoint>,
    /// Mean CPU-s per coarse run and per fine run.
    pub cpu_s: (Option<f64>, Option<f64>),
    /// Correlation of the points' coarse and fine means.
    pub correlation: Option<f64>,
    /// The two-level fit, or why there is none.
    pub fit: Result<TwoLevelFit, String>,
}

/// The target scene named `name` (`calibration` is the calibration scene).
fn target<'a>(study: &'a Study, name: &str) -> Result<&'a crate::manifest::TargetScene, String> {
    if name == "calibration" || name == study.calibration.name {
        return Ok(&study.calibration);
    }
    study
        .verification
        .iter()
        .find(|t| t.name == name)
        .ok_or_else(|| {
            let mut names = vec![study.calibration.name.clone()];
            names.extend(study.verification.iter().map(|t| t.name.clone()));
            format!(
                "--scene `{name}`: not a scene of the study; its scenes: {}",
                names.join(", ")
            )
        })
}

/// One point's experiments at both sizes.
#[derive(Debug, Clone)]
pub struct PlannedPoint {
    /// Its `sample_index`.
    pub index: u64,
    /// Parameter values, physical units.
    pub point: Vec<f64>,
    /// The coarse experiments, one per seed.
    pub coarse: Vec<Experiment>,
    /// The fine experiments, one per seed.
    pub fine: Vec<Experiment>,
}

/// The coarse and fine experiments of the pilot, point by point, replicate
/// by replicate (module docs).
pub fn experiments(study: &Study, spec: &PilotSpec) -> Result<Vec<PlannedPoint>, String> {
    if spec.points < 3 {
        return Err(format!("--points {}: at least 3 are needed", spec.points));
    }
    if spec.seeds < 2 {
        return Err(format!("--seeds {}: at least 2 are needed", spec.seeds));
    }
    if !(spec.fine_factor > 0.0 && spec.fine_factor < 1.0) {
        return Err(format!(
            "--fine-size {}: must be in (0, 1) (a radius factor below the study's)",
            spec.fine_factor
        ));
    }
    if study.coarse_graining.is_some() {
        return Err(
            "the study uses coarse_graining; the pilot scales studies that state \
                    their simulated particle directly"
                .into(),
        );
    }
    let scene = &target(study, &spec.scene)?.scene;
    let names = crate::study::plan::calibration::parameter_names(study);
    let mut r = rng(study.design.seed, Stream::Pilot, 0);
    let unit = latin_hypercube(spec.points, names.len(), Placement::Random, &mut r);
    let mut out = Vec::new();
    for (i, u) in unit.iter().enumerate() {
        let index = PILOT_INDEX + i as u64;
        let physical = crate::study::plan::calibration::to_physical(study, u);
        let values: BTreeMap<String, f64> = names
            .iter()
            .cloned()
            .zip(physical.iter().copied())
            .collect();
        let mut coarse = Vec::new();
        let mut fine = Vec::new();
        for rep in 0..spec.seeds {
            let e = study
                .replicate_experiment(scene, &values, index, rep)
                .map_err(|e| format!("point {index}: {e}"))?;
            let f = scaled(&e, spec.fine_factor, Some(SurfaceEnergyRule::ConstantBond))
                .map_err(|e| format!("point {index} at size {}: {e}", spec.fine_factor))?;
            coarse.push(e);
            fine.push(f);
        }
        out.push(PlannedPoint {
            index,
            point: physical,
            coarse,
            fine,
        });
    }
    Ok(out)
}

/// Runs the pilot and fits the two-level process; writes pilot.md and
/// pilot.json (with lineage) into `out_dir`.
pub fn pilot(
    study: &Study,
    study_path: &Path,
    spec: &PilotSpec,
    store: &Store,
    pool: &Executor,
    out_dir: &Path,
) -> Result<(Pilot, String), StudyError> {
    let planned = experiments(study, spec).map_err(StudyError::Settings)?;
    let target = target(study, &spec.scene).map_err(StudyError::Settings)?;
    crate::study::runs::replicated::check_response(target)?;
    let response_name = target
        .response
        .clone()
        .unwrap_or_else(|| "headline angle".into());
    let all: Vec<Experiment> = planned
        .iter()
        .flat_map(|p| p.coarse.iter().chain(&p.fine).cloned())
        .collect();
    eprintln!(
        "pilot: {} points x 2 sizes x {} seeds = {} runs in scene {}",
        planned.len(),
        spec.seeds,
        all.len(),
        target.name
    );
    let collected = run_collect(&all, store, pool, &run_logged, Retry::Failed)?;
    let value = |o: &RunOutcome| match o {
        RunOutcome::Complete(r) => crate::study::runs::replicated::response_of(r, target).ok(),
        _ => None,
    };
    let cpu = |e: &Experiment| store.timing(&e.id()).map(|t| t.cpu_s());
    let mut outcomes = collected.outcomes.iter();
    let mut points = Vec::new();
    for planned_point in &planned {
        let mut next =
            |n: usize| -> Vec<f64> { (0..n).filter_map(|_| value(outcomes.next()?)).collect() };
        let coarse = next(planned_point.coarse.len());
        let fine = next(planned_point.fine.len());
        points.push(PilotPoint {
            index: planned_point.index,
            point: planned_point.point.clone(),
            coarse,
            fine,
        });
    }
    let mean_cpu = |pick: fn(&PlannedPoint) -> &Vec<Experiment>| {
        let v: Vec<f64> = planned
            .iter()
            .flat_map(|p| pick(p).iter().filter_map(cpu))
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let cpu_s = (mean_cpu(|p| &p.coarse), mean_cpu(|p| &p.fine));
    let unit: Vec<Vec<f64>> = points
        .iter()
        .map(|p| crate::study::plan::calibration::to_unit(study, &p.point))
        .collect();
    let pilot = Pilot {
        study: Some(study.id()),
        scene: target.name.clone(),
        response: response_name,
        parameters: crate::study::plan::calibration::parameter_names(study),
        fine_factor: spec.fine_factor,
        correlation: correlation(&points),
        fit: fit(&unit, &points, study.design.seed),
        points,
        cpu_s,
    };
    let markdown = markdown(&pilot);
    let lineage = Lineage::new(
        "pilot",
        serde_json::json!({
            "scene": spec.scene,
            "points": spec.points,
            "seeds": spec.seeds,
            "fine_factor": spec.fine_factor,
        }),
    )
    .with_input(InputRef::file("study", study_path, Some(store.root()))?);
    let lineage = all.iter().fold(lineage, |l, e| {
        l.with_input(InputRef::id("run".to_string(), &e.id()))
    });
    let json = serde_json::to_string_pretty(&pilot).expect("pilot serialises") + "\n";
    for (name, text) in [("pilot.md", &markdown), ("pilot.json", &json)] {
        crate::study::dir::write_output(&out_dir.join(name), text.as_bytes(), &lineage)?;
    }
    Ok((pilot, markdown))
}

/// Where a pilot writes by default: `<store>/pilot/<first 12 hex of the
/// study id>-<scene>-<fine factor>`.
pub fn default_dir(store: &Store, study_id: &ContentId, spec: &PilotSpec) -> PathBuf {
    store.root().join("pilot").join(format!(
        "{}-{}-{}",
        study_id.short(12),
        spec.scene,
        spec.fine_factor
    ))
}

fn summary(v: &[f64]) -> Option<MeanCi> {
    mean_ci(v)
}

/// Pearson correlation of the points' coarse and fine means (points with
/// both).
fn correlation(points: &[PilotPoint]) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| Some((summary(&p.coarse)?.mean, summary(&p.fine)?.mean)))
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let (mx, my) = pairs
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxy: f64 = pairs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pairs.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let syy: f64 = pairs.iter().map(|(_, y)| (y - my).powi(2)).sum();
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// The two-level fit on the points' means, each with its mean's variance
/// s²/n as its known noise.
fn fit(unit: &[Vec<f64>], points: &[PilotPoint], seed: u64) -> Result<TwoLevelFit, String> {
    let level = |pick: fn(&PilotPoint) -> &Vec<f64>| {
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut var = Vec::new();
        for (u, p) in unit.iter().zip(points) {
            if let Some(m) = summary(pick(p)) {
                x.push(u.clone());
                y.push(m.mean);
                var.push(m.std * m.std / m.n as f64);
            }
        }
        (x, y, var)
    };
    let (cx, cy, cv) = level(|p| &p.coarse);
    let (fx, fy, fv) = level(|p| &p.fine);
    let settings = GpSettings {
        seed,
        ..GpSettings::default()
    };
    let gp = TwoLevelGp::fit(
        LevelData {
            x: &cx,
            y: &cy,
            noise_var: &cv,
        },
        LevelData {
            x: &fx,
            y: &fy,
            noise_var: &fv,
        },
        &settings,
    )
    .map_err(|e| e.to_string())?;
    Ok(gp.summary())
}

fn cell(v: &[f64]) -> String {
    match summary(v) {
        Some(m) => format!(
            "{:.2} ± {:.2} (σ {:.2}, n {})",
            m.mean, m.half_width, m.std, m.n
        ),
        None => format!("{} value(s)", v.len()),
    }
}

/// The pilot as Markdown.
pub fn markdown(p: &Pilot) -> String {
    let mut out = format!(
        "## Two-level pilot: {} ({}), fine size × {}\n\n",
        p.scene, p.response, p.fine_factor
    );
    let mut header: Vec<String> = vec!["point".into()];
    header.extend(p.parameters.iter().cloned());
    header.extend(["coarse".into(), "fine".into()]);
    let mut table = MarkdownTable::new(&header).align(0, Align::Right);
    for pt in &p.points {
        let mut row = vec![format!("{}", pt.index - PILOT_INDEX)];
        row.extend(pt.point.iter().map(|v| format!("{v:.4}")));
        row.extend([cell(&pt.coarse), cell(&pt.fine)]);
        table.row(&row);
    }
    out.push_str(&table.render());
    let fmt = |v: Option<f64>| v.map_or("—".to_string(), |x| format!("{x:.1}"));
    let _ = writeln!(
        out,
        "\nCPU-s per run: coarse {}, fine {}. Correlation of the points' coarse and fine \
         means: {}.",
        fmt(p.cpu_s.0),
        fmt(p.cpu_s.1),
        p.correlation.map_or("—".to_string(), |r| format!("{r:.3}"))
    );
    match &p.fit {
        Ok(f) => {
            let _ = writeln!(out, "\n{}", f.describe());
        }
        Err(why) => {
            let _ = writeln!(out, "\nNo two-level fit: {why}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study() -> Study {
        crate::manifest::parse_study(include_str!("../../../experiments/he2019-quick/study.json"))
            .unwrap()
    }

    fn spec(scene: &str) -> PilotSpec {
        PilotSpec {
            scene: scene.into(),
            points: 3,
            seeds: 2,
            fine_factor: 0.75,
        }
    }

    /// Each point's coarse runs are the study's own experiments at the
    /// pilot's indices; the fine runs are the same with the particle × 0.75
    /// and Γ × 0.75²; the plan is the same on every call.
    #[test]
    fn coarse_runs_are_the_studys_and_fine_runs_are_scaled() {
        let study = study();
        let planned = experiments(&study, &spec("drum")).unwrap();
        assert_eq!(planned.len(), 3);
        let names = crate::study::plan::calibration::parameter_names(&study);
        for (i, p) in planned.iter().enumerate() {
            assert_eq!(p.index, PILOT_INDEX + i as u64);
            let values = names.iter().cloned().zip(p.point.iter().copied()).collect();
            let own = study
                .replicate_experiment(&study.verification[1].scene, &values, p.index, 1)
                .unwrap();
            assert_eq!(p.coarse[1].id(), own.id());
            let (c, f) = (&p.coarse[0], &p.fine[0]);
            let r = |e: &Experiment| {
                crate::study::stages::sensitivity::parameters::nominal_radius_m(
                    &e.material.particle.size,
                )
            };
            assert!((r(f) - 0.75 * r(c)).abs() < 1e-15);
            let g = |e: &Experiment| e.contact.particle_particle.surface_energy_j_m2;
            assert!((g(f) - 0.5625 * g(c)).abs() < 1e-15);
            assert_eq!(f.seeds, c.seeds);
        }
        let again = experiments(&study, &spec("drum")).unwrap();
        assert_eq!(again[2].fine[1].id(), planned[2].fine[1].id());
        // The calibration scene by its name or `calibration`.
        let a = experiments(&study, &spec("funnel")).unwrap();
        let b = experiments(&study, &spec("calibration")).unwrap();
        assert_eq!(a[0].coarse[0].id(), b[0].coarse[0].id());
    }

    #[test]
    fn bad_settings_are_named() {
        let study = study();
        let err = experiments(&study, &spec("hopper")).unwrap_err();
        assert!(
            err.contains("--scene `hopper`") && err.contains("funnel, baffle, drum"),
            "{err}"
        );
        let mut s = spec("drum");
        s.fine_factor = 1.5;
        assert!(experiments(&study, &s)
            .unwrap_err()
            .contains("--fine-size 1.5"));
        s.fine_factor = 0.75;
        s.seeds = 1;
        assert!(experiments(&study, &s).unwrap_err().contains("--seeds 1"));
    }

    /// Perfectly related means correlate at 1; the numbers by hand.
    #[test]
    fn correlation_of_the_means() {
        let pt = |c: [f64; 2], f: [f64; 2]| PilotPoint {
            index: 0,
            point: vec![],
            coarse: c.to_vec(),
            fine: f.to_vec(),
        };
        let points = [
            pt([1.0, 3.0], [5.0, 5.0]),
            pt([3.0, 5.0], [9.0, 9.0]),
            pt([5.0, 7.0], [13.0, 13.0]),
        ];
        assert!((correlation(&points).unwrap() - 1.0).abs() < 1e-12);
        assert!(correlation(&points[..2]).is_none());
    }
}
