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
use crate::store::{
    Depth, InputRef, Lineage, RunDir, RunResult, RunState, Store, StoreError, TEMP_PREFIX,
};
use crate::study::dir::{json_bytes, write_output, StudyDir};
use crate::study::plan::design_study::actual_design;
use crate::study::plan::design_study::{DesignStudy, SeedStage};
use crate::study::runs::design_points;
use crate::study::runs::{needed_scenes, run_points, write_table, Point, Runs};
use crate::study::verification::{verify_points, Checked, Verification};
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

/// The design the levels read: the study, its factors, its run points and
/// the scene whose experiments levels 2 and 3 build.
struct Design<'a> {
    /// The study.
    study: &'a DesignStudy,
    /// The factor names, in order.
    factors: Vec<String>,
    /// The factors' (name, label), for the reports.
    labels: Vec<(String, String)>,
    /// The design's points, actual units.
    points: Vec<Point>,
    /// The scene of the study's responses.
    scene: String,
}

impl<'a> Design<'a> {
    /// The design of `study`.
    fn of(study: &'a DesignStudy) -> Result<Self, StudyError> {
        let actual = actual_design(study)?;
        Ok(Design {
            study,
            factors: study.factor_names(),
            labels: study
                .factors
                .iter()
                .map(|(n, f)| (n.clone(), f.display_name()))
                .collect(),
            points: design_points(study, &actual),
            scene: needed_scenes(study)
                .into_iter()
                .next()
                .expect("a validated study has a response, hence a scene"),
        })
    }

    /// The experiment of a design point from its (address, value) pairs
    /// and index.
    fn experiment_at(
        &self,
        values: &[(String, f64)],
        index: u64,
    ) -> Result<Experiment, StudyError> {
        let values: Vec<(&str, f64)> = values.iter().map(|(a, v)| (a.as_str(), *v)).collect();
        self.study
            .experiment(&self.scene, &values, index, 0)
            .map_err(|errors| StudyError::InvalidPoint {
                point: index,
                scene: self.scene.clone(),
                errors,
            })
    }
}

/// What levels 1 and 2 and the verification of the named points give.
#[derive(Default)]
struct WithRuns {
    /// Runs of the design, of those cached, and replicates lacking a
    /// response.
    counts: (usize, usize, usize),
    /// Level 1.
    level1: Option<Level1>,
    /// Level 2.
    level2: Option<Level2>,
    /// The named points' replicates.
    verification: Option<Verification>,
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
    let root = dir.create_stage("sensitivity")?;
    let design = Design::of(study)?;
    let mut stages = Vec::new();
    let level3 = if levels.three {
        announce(pool, study, "level 3 (contact-law sensitivities, no runs)");
        Some(level3_stage(dir, &design, &mut stages)?)
    } else {
        None
    };
    let with_runs = if levels.one || levels.two {
        design_levels(dir, &design, levels, (store, pool, runner), &mut stages)?
    } else {
        WithRuns::default()
    };
    let WithRuns {
        counts: (runs, cached_runs, incomplete),
        level1,
        level2,
        verification,
    } = with_runs;
    let outcome = SensitivityOutcome {
        study: study.name.clone(),
        study_id: study.id().to_string(),
        dir: root,
        runs,
        cached_runs,
        incomplete,
        level1,
        level2,
        level3,
        verification,
        stages,
    };
    let lineage = dir.lineage("sensitivity", serde_json::json!({ "summary": true }));
    write_output(
        &outcome.dir.join("sensitivity.md"),
        summary_markdown(study, &design.labels, &outcome).as_bytes(),
        &lineage,
    )?;
    Ok(outcome)
}

/// Says on stderr which part of the analysis of `study` starts, when the
/// executor shows progress.
fn announce(pool: &Executor, study: &DesignStudy, what: &str) {
    if pool.progress {
        eprintln!("{}: {what}", study.name);
    }
}

/// The design's runs (`responses.csv`), then levels 1 and 2 as asked and
/// the named points' verification when the study has one.
fn design_levels<E, F>(
    dir: &StudyDir,
    design: &Design<'_>,
    levels: Levels,
    (store, pool, runner): (&Store, &Executor, &F),
    stages: &mut Vec<StageState>,
) -> Result<WithRuns, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let study = design.study;
    announce(pool, study, "design runs");
    let runs = run_points(
        study,
        store,
        pool,
        runner,
        SeedStage::Design,
        design.factors.clone(),
        design.points.clone(),
        study.replicates,
    )?;
    let table = dir.stage("sensitivity").join("responses.csv");
    write_table(dir, "sensitivity", study, &runs, &table)?;
    let table_input = dir.input("responses", &table)?;
    let mut out = WithRuns {
        counts: (runs.total, runs.cached, runs.incomplete()),
        ..WithRuns::default()
    };
    if levels.one {
        announce(pool, study, "level 1 (power laws, flow-rate curves)");
        let level1 = level1_stage(dir, store, design, (&runs, &table_input), stages)?;
        out.level1 = Some(level1);
    }
    if levels.two {
        announce(pool, study, "level 2 (PCA)");
        out.level2 = Some(level2_stage(dir, design, (&runs, &table_input), stages)?);
    }
    if study.verification.is_some() {
        announce(pool, study, "named points with replicates");
        let fits = out.level1.as_ref();
        out.verification = verify_named(dir, design, fits, store, pool, runner)?;
    }
    Ok(out)
}

/// A level's outcome: read back from `sensitivity/<level>/<level>.json`
/// when its stage directory holds what a computation with `lineage` wrote
/// ([`cached`]), else the stage directory cleared, `compute` run (it writes
/// the level's other outputs into the directory it is given) and its
/// outcome written as `<level>.json`; `stages` gets whether it was cached.
fn level_stage<T: Serialize + DeserializeOwned>(
    dir: &StudyDir,
    level: &str,
    lineage: &Lineage,
    stages: &mut Vec<StageState>,
    compute: impl FnOnce(&Path) -> Result<T, StudyError>,
) -> Result<T, StudyError> {
    let stage = dir.create_stage(format!("sensitivity/{level}").as_str())?;
    let json = stage.join(format!("{level}.json"));
    let (outcome, was_cached) = match cached::<T>(&json, lineage) {
        Some(l) => (l, true),
        None => {
            clear_stage(&stage)?;
            let l = compute(&stage)?;
            write_output(&json, &json_bytes(&l), lineage)?;
            (l, false)
        }
    };
    stages.push(StageState {
        stage: level.into(),
        cached: was_cached,
    });
    Ok(outcome)
}

/// Level 3 over the design's experiments (no runs), or why it could not be
/// computed; writes `norms.csv`, `cross_correlation.csv` (when computed)
/// and `level3.md`.
fn level3_stage(
    dir: &StudyDir,
    design: &Design<'_>,
    stages: &mut Vec<StageState>,
) -> Result<Result<Level3, String>, StudyError> {
    let lineage = dir.lineage(
        "sensitivity/level3",
        serde_json::json!({ "states": "yan2015 a priori (81)", "parameters": ["e", "μs", "μr", "E"] }),
    );
    level_stage(dir, "level3", &lineage, stages, |stage| {
        let base = design.experiment_at(&[], 0)?;
        let experiments = design
            .points
            .iter()
            .map(|p| design.experiment_at(&p.values, p.index))
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
        Ok(l)
    })
}

/// Level 1 over the design's runs (the response table `table_input` and
/// every run's result); writes its tables, plots and `level1.md`.
fn level1_stage(
    dir: &StudyDir,
    store: &Store,
    design: &Design<'_>,
    (runs, table_input): (&Runs, &InputRef),
    stages: &mut Vec<StageState>,
) -> Result<Level1, StudyError> {
    let mut lineage = dir
        .lineage(
            "sensitivity/level1",
            serde_json::json!({ "model": "power law, Levenberg–Marquardt from the log-linear fit", "flow_curve": "Eq. 20" }),
        )
        .with_input(table_input.clone());
    for input in &runs.inputs {
        lineage = lineage.with_input(input.clone());
    }
    level_stage(dir, "level1", &lineage, stages, |stage| {
        let (obs, missing, curves_in) = gather(design.study, store, runs)?;
        let l = level1::level1(&design.factors, &missing, &obs, &curves_in);
        write_level1(stage, &l, &obs, &curves_in, &design.factors, &lineage)?;
        write_output(
            &stage.join("level1.md"),
            level1::markdown(&l, &design.labels).as_bytes(),
            &lineage,
        )?;
        Ok(l)
    })
}

/// Level 2 over the design's runs (the response table `table_input`);
/// writes `pca.csv` and `level2.md`.
fn level2_stage(
    dir: &StudyDir,
    design: &Design<'_>,
    (runs, table_input): (&Runs, &InputRef),
    stages: &mut Vec<StageState>,
) -> Result<Level2, StudyError> {
    let lineage = dir
        .lineage(
            "sensitivity/level2",
            serde_json::json!({ "state": "δn = δt = 1 % of d, vn = vt = 0.01 m/s, ω = 1 rad/s", "scaling": "auto (sample standard deviation)" }),
        )
        .with_input(table_input.clone());
    level_stage(dir, "level2", &lineage, stages, |stage| {
        let l = compute_level2(design, runs)?;
        write_output(
            &stage.join("pca.csv"),
            level2::csv(&l, &design.factors).as_bytes(),
            &lineage,
        )?;
        write_output(
            &stage.join("level2.md"),
            level2::markdown(&l, &design.labels).as_bytes(),
            &lineage,
        )?;
        Ok(l)
    })
}

/// The study's named points re-simulated with replicates
/// ([`crate::study::verification`], stage `sensitivity/noise`), beside
/// level 1's power law of each response where it was fitted.
fn verify_named<E, F>(
    dir: &StudyDir,
    design: &Design<'_>,
    fits: Option<&Level1>,
    store: &Store,
    pool: &Executor,
    runner: &F,
) -> Result<Option<Verification>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let predict = |response: &str, x: &[f64]| {
        let f = fits?
            .fits
            .iter()
            .find(|r| r.response == response)?
            .fit
            .as_ref()?;
        Some(
            PowerLaw {
                factors: design.factors.clone(),
            }
            .value(&f.estimates, x),
        )
    };
    let responses: Vec<String> = design.study.responses.keys().cloned().collect();
    let checked = Checked {
        stage: "sensitivity/noise",
        optimum: None,
        responses: &responses,
        predict: &predict,
    };
    verify_points(dir, design.study, &checked, store, pool, runner)
}

/// `sensitivity.md`: the computed levels' sections and, when the named
/// points were verified, where their table is.
fn summary_markdown(
    study: &DesignStudy,
    labels: &[(String, String)],
    outcome: &SensitivityOutcome,
) -> String {
    let mut md = format!(
        "# {} — parameter sensitivity (yan2015, three levels)\n\n",
        study.name
    );
    if let Some(l) = &outcome.level1 {
        md.push_str(&level1::markdown(l, labels));
        md.push('\n');
    }
    if let Some(l) = &outcome.level2 {
        md.push_str(&level2::markdown(l, labels));
        md.push('\n');
    }
    match &outcome.level3 {
        Some(Ok(l)) => md.push_str(&level3::markdown(l)),
        Some(Err(why)) => md.push_str(&format!("## Level 3\n\nNot computed: {why}\n")),
        None => {}
    }
    if outcome.verification.is_some() {
        md.push_str("\n## Named points with replicates\n\nSee `noise/verification.md`: each named point's mean ± 95 % CI over its packing seeds, beside the power law and the measured value.\n");
    }
    md
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

/// Level 2 from the design's experiments (their contact pairs) and the
/// runs' per-point mean responses; a design whose pairs cannot be read
/// gives a level 2 that says why.
fn compute_level2(design: &Design<'_>, runs: &Runs) -> Result<Level2, StudyError> {
    let study = design.study;
    let mut pairs = Vec::new();
    for p in &design.points {
        let e = design.experiment_at(&p.values, p.index)?;
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
