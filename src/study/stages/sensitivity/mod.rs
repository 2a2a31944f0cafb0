//! `repose sensitivity STUDY`: yan2015's three levels of parameter
//! sensitivity on a design study (seeds/yan2015-dem-sensitivity.txt §2.2).
//!
//! - the design's runs (every point × replicate × scene, stage seeds
//!   [`SeedStage::Design`], so they are the runs `repose rsm` of the same
//!   study would make) → `responses.csv`;
//! - [`level1`]: power laws of every response by nonlinear least squares,
//!   with confidence intervals and lack of fit, and each run's flow-rate
//!   curve (Eq. 19–20);
//! - [`level2`]: PCA of the auto-scaled sensitivity matrices of the force
//!   and the torque with each bulk response (Eq. 13–16, 25–26);
//! - [`level3`]: norms and cross-correlations of the contact law's
//!   sensitivity matrix over 81 a-priori states (Eq. 17–18) — no simulation;
//! - the study's named points re-simulated with `verification.replicates`
//!   packing seeds (`noise/`): the seed-to-seed spread beside the power
//!   law's prediction and the measured value.
//!
//! ```text
//! <study dir>/sensitivity/
//!   responses.csv  sensitivity.md
//!   level1/  observations.csv estimates.csv fits.csv correlations.csv
//!            flow_curves.csv <response>.svg flow_curves.svg level1.json level1.md
//!   level2/  pca.csv level2.json level2.md
//!   level3/  norms.csv cross_correlation.csv level3.json level3.md
//!   noise/   responses.csv verification.csv verification.md
//! ```
//!
//! Each level is its own cached stage: its outputs carry a lineage (the
//! study, the tables and run results it read, by sha256), and a level whose
//! `<level>.json` lies beside an identical lineage is read back instead of
//! recomputed. A level that cannot be computed (too few observations, a JKR
//! study in level 3) says why in its report; the others still run.

pub mod level1;
pub mod level2;
pub mod level3;
pub mod parameters;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::exec::Executor;
use crate::manifest::Experiment;
use crate::scenes::responses::{flow_rate_curve, observations};
use crate::stats::nlls::{Model, PowerLaw};
use crate::store::{Depth, Lineage, RunDir, RunResult, RunState, Store, StoreError, TEMP_PREFIX};
use crate::study::dir::{json_bytes, write_output, StudyDir};
use crate::study::plan::design_study::actual_design;
use crate::study::plan::design_study::{DesignStudy, SeedStage};
use crate::study::runs::design_points;
use crate::study::runs::{needed_scenes, run_points, write_table, Runs};
use crate::study::stages::verify_optimum::{verify_points, Verification};
use crate::study::StudyError;
use level1::{CurveInput, Level1, Observation};
use level2::Level2;
use level3::Level3;

/// Which levels to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Levels {
    /// Level 1 (needs the design's runs).
    pub one: bool,
    /// Level 2 (needs the design's runs).
    pub two: bool,
    /// Level 3 (no runs).
    pub three: bool,
}

impl Levels {
    /// All three.
    pub const ALL: Levels = Levels {
        one: true,
        two: true,
        three: true,
    };
}

/// A stage and whether it was read back from the store.
#[derive(Debug, Clone, Serialize)]
pub struct StageState {
    /// `level1`, `level2`, `level3`.
    pub stage: String,
    /// True when its outputs were already there with the same lineage.
    pub cached: bool,
}

/// What `repose sensitivity` did.
#[derive(Debug, Clone, Serialize)]
pub struct SensitivityOutcome {
    /// Study name.
    pub study: String,
    /// Study id.
    pub study_id: String,
    /// The output directory.
    pub dir: PathBuf,
    /// Runs of the design (0 when only level 3 ran).
    pub runs: usize,
    /// Of those, already in the store.
    pub cached_runs: usize,
    /// Replicates lacking a response.
    pub incomplete: usize,
    /// Level 1.
    pub level1: Option<Level1>,
    /// Level 2.
    pub level2: Option<Level2>,
    /// Level 3, or why it could not be computed.
    pub level3: Option<Result<Level3, String>>,
    /// The named points' replicates.
    pub verification: Option<Verification>,
    /// Which level stages were cached.
    pub stages: Vec<StageState>,
}

/// A stage's JSON outcome `json` if its stage directory holds exactly what
/// the stage described by `lineage` (the same stage, the same inputs) wrote:
/// every file there has a lineage record equal to `lineage` and the bytes
/// that record hashed, and every record its file. A stage with an output
/// edited, deleted or added since, or a record deleted or predating output
/// hashes, is recomputed (rewriting every output), never served.
fn cached<T: DeserializeOwned>(json: &Path, lineage: &Lineage) -> Option<T> {
    let dir = json.parent()?;
    for entry in std::fs::read_dir(dir).ok()? {
        let path = entry.ok()?.path();
        let name = path.file_name()?.to_str()?;
        if name.starts_with(TEMP_PREFIX) {
            continue;
        }
        // A record needs its output; each output is checked (with its
        // record) once, when the loop reaches it.
        let intact = match name.strip_suffix(".lineage.json") {
            Some(output) => dir.join(output).is_file(),
            None => written_by(&path, lineage),
        };
        if !intact {
            return None;
        }
    }
    serde_json::from_slice(&std::fs::read(json).ok()?).ok()
}

/// Whether `output` holds the bytes its lineage record hashed and that
/// record describes the stage of `lineage`.
fn written_by(output: &Path, lineage: &Lineage) -> bool {
    let (Ok(stored), Ok(bytes)) = (Lineage::read_beside(output), std::fs::read(output)) else {
        return false;
    };
    let written = stored.output_sha256.is_some() && stored.describes(&bytes);
    written
        && Lineage {
            output_sha256: None,
            ..stored
        } == *lineage
}

/// Removes the files of the stage directory `stage` (not another client's
/// temporary files) before the stage is computed again, so that it then
/// holds only what this computation writes, which [`cached`] can serve.
fn clear_stage(stage: &Path) -> Result<(), StoreError> {
    for entry in std::fs::read_dir(stage).map_err(StoreError::io(stage))? {
        let path = entry.map_err(StoreError::io(stage))?.path();
        let temp = path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with(TEMP_PREFIX));
        if path.is_file() && !temp {
            std::fs::remove_file(&path).map_err(StoreError::io(&path))?;
        }
    }
    Ok(())
}

/// Runs the levels asked for (see the module docs) and writes the reports.
pub fn sensitivity<E, F>(
    dir: &StudyDir,
    study: &DesignStudy,
    store: &Store,
    pool: &Executor,
    runner: &F,
    levels: Levels,
) -> Result<SensitivityOutcome, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let announce = |what: &str| {
        if pool.progress {
            eprintln!("{}: {what}", study.name);
        }
    };
    let root = dir.create_stage("sensitivity")?;
    let factors = study.factor_names();
    let labels: Vec<(String, String)> = study
        .factors
        .iter()
        .map(|(n, f)| (n.clone(), f.display_name()))
        .collect();
    let actual = actual_design(study)?;
    let points = design_points(study, &actual);
    let scene = needed_scenes(study)
        .into_iter()
        .next()
        .expect("a validated study has a response, hence a scene");
    let experiment_at = |values: &[(String, f64)], index: u64| {
        let values: Vec<(&str, f64)> = values.iter().map(|(a, v)| (a.as_str(), *v)).collect();
        study
            .experiment(&scene, &values, index, 0)
            .map_err(|errors| StudyError::InvalidPoint {
                point: index,
                scene: scene.clone(),
                errors,
            })
    };
    let mut stages = Vec::new();
    let mut md = format!(
        "# {} — parameter sensitivity (yan2015, three levels)\n\n",
        study.name
    );

    let level3 = if levels.three {
        announce("level 3 (contact-law sensitivities, no runs)");
        let stage = dir.create_stage("sensitivity/level3")?;
        let lineage = dir.lineage(
            "sensitivity/level3",
            serde_json::json!({ "states": "yan2015 a priori (81)", "parameters": ["e", "μs", "μr", "E"] }),
        );
        let json = stage.join("level3.json");
        let (outcome, was_cached) = match cached::<Result<Level3, String>>(&json, &lineage) {
            Some(l) => (l, true),
            None => {
                clear_stage(&stage)?;
                let base = experiment_at(&[], 0)?;
                let experiments = points
                    .iter()
                    .map(|p| experiment_at(&p.values, p.index))
                    .collect::<Result<Vec<_>, _>>()?;
                let l = level3::level3(&base, &experiments);
                if let Ok(l) = &l {
                    write_output(
                        &stage.join("norms.csv"),
                        level3::norms_csv(l).as_bytes(),
                        &lineage,
                    )?;
                    write_output(
                        &stage.join("cross_correlation.csv"),
                        level3::cross_correlation_csv(l).as_bytes(),
                        &lineage,
                    )?;
                }
                let section = match &l {
                    Ok(l) => level3::markdown(l),
                    Err(why) => format!("## Level 3\n\nNot computed: {why}\n"),
                };
                write_output(&stage.join("level3.md"), section.as_bytes(), &lineage)?;
                write_output(&json, &json_bytes(&l), &lineage)?;
                (l, false)
            }
        };
        stages.push(StageState {
            stage: "level3".into(),
            cached: was_cached,
        });
        Some(outcome)
    } else {
        None
    };

    let (mut level1_out, mut level2_out, mut verification) = (None, None, None);
    let (mut runs_total, mut runs_cached, mut incomplete) = (0, 0, 0);
    if levels.one || levels.two {
        announce("design runs");
        let runs = run_points(
            study,
            store,
            pool,
            runner,
            SeedStage::Design,
            factors.clone(),
            points.clone(),
            study.replicates,
        )?;
        (runs_total, runs_cached, incomplete) = (runs.total, runs.cached, runs.incomplete());
        let table = root.join("responses.csv");
        write_table(dir, "sensitivity", study, &runs, &table)?;
        let table_input = dir.input("responses", &table)?;
        let (obs, missing, curves_in) = gather(study, store, &runs)?;

        if levels.one {
            announce("level 1 (power laws, flow-rate curves)");
            let stage = dir.create_stage("sensitivity/level1")?;
            let mut lineage = dir
                .lineage(
                    "sensitivity/level1",
                    serde_json::json!({ "model": "power law, Levenberg–Marquardt from the log-linear fit", "flow_curve": "Eq. 20" }),
                )
                .with_input(table_input.clone());
            for input in &runs.inputs {
                lineage = lineage.with_input(input.clone());
            }
            let json = stage.join("level1.json");
            let (l, was_cached) = match cached::<Level1>(&json, &lineage) {
                Some(l) => (l, true),
                None => {
                    clear_stage(&stage)?;
                    let l = level1::level1(&factors, &missing, &obs, &curves_in);
                    write_level1(&stage, &l, &obs, &curves_in, &factors, &lineage)?;
                    write_output(
                        &stage.join("level1.md"),
                        level1::markdown(&l, &labels).as_bytes(),
                        &lineage,
                    )?;
                    write_output(&json, &json_bytes(&l), &lineage)?;
                    (l, false)
                }
            };
            stages.push(StageState {
                stage: "level1".into(),
                cached: was_cached,
            });
            level1_out = Some(l);
        }

        if levels.two {
            announce("level 2 (PCA)");
            let stage = dir.create_stage("sensitivity/level2")?;
            let lineage = dir
                .lineage(
                    "sensitivity/level2",
                    serde_json::json!({ "state": "δn = δt = 1 % of d, vn = vt = 0.01 m/s, ω = 1 rad/s", "scaling": "auto (sample standard deviation)" }),
                )
                .with_input(table_input.clone());
            let json = stage.join("level2.json");
            let (l, was_cached) = match cached::<Level2>(&json, &lineage) {
                Some(l) => (l, true),
                None => {
                    clear_stage(&stage)?;
                    let l = compute_level2(study, &runs, &points, &experiment_at)?;
                    write_output(
                        &stage.join("pca.csv"),
                        level2::csv(&l, &factors).as_bytes(),
                        &lineage,
                    )?;
                    write_output(
                        &stage.join("level2.md"),
                        level2::markdown(&l, &labels).as_bytes(),
                        &lineage,
                    )?;
                    write_output(&json, &json_bytes(&l), &lineage)?;
                    (l, false)
                }
            };
            stages.push(StageState {
                stage: "level2".into(),
                cached: was_cached,
            });
            level2_out = Some(l);
        }

        if study.verification.is_some() {
            announce("named points with replicates");
            let fits = level1_out.as_ref();
            let predict = |response: &str, x: &[f64]| {
                let f = fits?
                    .fits
                    .iter()
                    .find(|r| r.response == response)?
                    .fit
                    .as_ref()?;
                Some(
                    PowerLaw {
                        factors: factors.clone(),
                    }
                    .value(&f.estimates, x),
                )
            };
            let responses: Vec<String> = study.responses.keys().cloned().collect();
            verification = verify_points(
                dir,
                "sensitivity/noise",
                study,
                None,
                &responses,
                &predict,
                store,
                pool,
                runner,
            )?;
        }
    }

    if let Some(l) = &level1_out {
        md.push_str(&level1::markdown(l, &labels));
        md.push('\n');
    }
    if let Some(l) = &level2_out {
        md.push_str(&level2::markdown(l, &labels));
        md.push('\n');
    }
    match &level3 {
        Some(Ok(l)) => md.push_str(&level3::markdown(l)),
        Some(Err(why)) => md.push_str(&format!("## Level 3\n\nNot computed: {why}\n")),
        None => {}
    }
    if verification.is_some() {
        md.push_str("\n## Named points with replicates\n\nSee `noise/verification.md`: each named point's mean ± 95 % CI over its packing seeds, beside the power law and the measured value.\n");
    }
    let lineage = dir.lineage("sensitivity", serde_json::json!({ "summary": true }));
    write_output(&root.join("sensitivity.md"), md.as_bytes(), &lineage)?;
    Ok(SensitivityOutcome {
        study: study.name.clone(),
        study_id: study.id().to_string(),
        dir: root,
        runs: runs_total,
        cached_runs: runs_cached,
        incomplete,
        level1: level1_out,
        level2: level2_out,
        level3,
        verification,
        stages,
    })
}

/// The stored result of a run that completed.
fn load(store: &Store, id: &crate::manifest::ContentId) -> Option<RunResult> {
    match store.check(id, Depth::Full) {
        RunState::Complete(r) => Some(*r),
        _ => None,
    }
}

/// Every observation of every response, how many runs lacked each response,
/// and each hopper run's flow-rate curve.
#[allow(clippy::type_complexity)]
fn gather(
    study: &DesignStudy,
    store: &Store,
    runs: &Runs,
) -> Result<(Vec<Observation>, Vec<(String, usize)>, Vec<CurveInput>), StudyError> {
    let mut obs = Vec::new();
    let mut missing: Vec<(String, usize)> =
        study.responses.keys().map(|r| (r.clone(), 0)).collect();
    let mut curves = Vec::new();
    for rep in &runs.replicates {
        let x = runs.points[rep.point].shown.clone();
        // Each run's result is read once, whatever number of responses it has.
        let results: BTreeMap<&String, Option<RunResult>> = rep
            .ids
            .iter()
            .map(|(scene, id)| (scene, load(store, id)))
            .collect();
        for (k, (name, rr)) in study.responses.iter().enumerate() {
            let kind = study.scenes[&rr.scene].kind();
            let values = results
                .get(&rr.scene)
                .and_then(Option::as_ref)
                .and_then(|res| observations(res, kind, &rr.response).ok());
            match values {
                Some(v) => obs.extend(v.into_iter().enumerate().map(|(part, value)| Observation {
                    point: rep.point,
                    replicate: rep.replicate,
                    x: x.clone(),
                    response: name.clone(),
                    part: part + 1,
                    value,
                })),
                None => missing[k].1 += 1,
            }
        }
        for (scene, result) in &results {
            if study.scenes[*scene].kind() != "hopper" {
                continue;
            }
            if let Some(samples) = result.as_ref().and_then(|r| flow_rate_curve(r).ok()) {
                curves.push(CurveInput {
                    point: rep.point,
                    replicate: rep.replicate,
                    x: x.clone(),
                    samples,
                });
            }
        }
    }
    Ok((obs, missing, curves))
}

fn write_level1(
    stage: &Path,
    l: &Level1,
    obs: &[Observation],
    curves_in: &[CurveInput],
    factors: &[String],
    lineage: &Lineage,
) -> Result<(), StudyError> {
    write_output(
        &stage.join("observations.csv"),
        level1::observations_csv(factors, obs).as_bytes(),
        lineage,
    )?;
    write_output(
        &stage.join("estimates.csv"),
        level1::estimates_csv(l).as_bytes(),
        lineage,
    )?;
    write_output(
        &stage.join("fits.csv"),
        level1::fits_csv(l).as_bytes(),
        lineage,
    )?;
    write_output(
        &stage.join("correlations.csv"),
        level1::correlations_csv(l).as_bytes(),
        lineage,
    )?;
    write_output(
        &stage.join("flow_curves.csv"),
        level1::flow_curves_csv(l).as_bytes(),
        lineage,
    )?;
    for r in &l.fits {
        let y: Vec<f64> = obs
            .iter()
            .filter(|o| o.response == r.response)
            .map(|o| o.value)
            .collect();
        if let Some(svg) = level1::parity_svg(r, &y)? {
            write_output(
                &stage.join(format!("{}.svg", r.response)),
                svg.as_bytes(),
                lineage,
            )?;
        }
    }
    if let Some(svg) = level1::flow_curves_svg(l, curves_in)? {
        write_output(&stage.join("flow_curves.svg"), svg.as_bytes(), lineage)?;
    }
    Ok(())
}

/// Builds the experiment of a design point from its (address, value) pairs
/// and index.
type ExperimentAt<'a> = dyn Fn(&[(String, f64)], u64) -> Result<Experiment, StudyError> + 'a;

fn compute_level2(
    study: &DesignStudy,
    runs: &Runs,
    points: &[crate::study::runs::Point],
    experiment_at: &ExperimentAt,
) -> Result<Level2, StudyError> {
    let mut pairs = Vec::new();
    for p in points {
        let e = experiment_at(&p.values, p.index)?;
        match parameters::pair_spec(&e) {
            Ok(s) => pairs.push(s),
            Err(why) => {
                return Ok(Level2 {
                    state: level2::reference_state(0.0),
                    analyses: Vec::new(),
                    problem: Some(why),
                })
            }
        }
    }
    let diameter_m = 2.0 * pairs.first().map_or(0.0, |p| p.radius_m);
    let responses = study
        .responses
        .keys()
        .map(|r| {
            let means = runs
                .by_point(r)
                .iter()
                .map(|v| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64))
                .collect();
            (r.clone(), means)
        })
        .collect();
    let factors = study
        .factors
        .iter()
        .map(|(n, f)| (n.clone(), f.address.clone()))
        .collect();
    Ok(level2::level2(&level2::Inputs {
        factors,
        pairs,
        responses,
        diameter_m,
    }))
}
