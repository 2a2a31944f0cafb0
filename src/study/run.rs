//! The one driver: a study's plan is walked stage by stage, in the order of
//! its stage list ([`StudySpec`]), and each stage's typed outcome is handed
//! to the caller as it completes. Every method is data — a stage list — and
//! every study command is "run this list up to (or only) this stage":
//!
//! | command | [`Upto`] |
//! | --- | --- |
//! | `calibrate`, `rsm`, `sensitivity` | through the last stage |
//! | `noise`, `sample`, `batch`, `train`, `fine`, `search`, `verify`, `transfer` (he2019) | only that stage (`noise`, `design`, `simulate`, `fit`, `fine`, `search`, `verify`, `transfer`) |
//! | `screen` | only `screen` |
//! | `verify` (a design study) | the whole list (as `rsm`) |
//!
//! A stage command runs its stage alone on the outputs its predecessors
//! recorded (a missing one is refused, naming the command that writes it):
//! re-running the earlier stages first would retrain a network the user
//! trained with `--seed` or `--selection` before every search. `calibrate`
//! runs every stage in order; each stage is cached (runs in the store,
//! outputs rewritten with the same bytes), so a killed calibration resumes.
//!
//! Which function runs a stage depends on the method:
//!
//! | stage | he2019 | he2019 noise-aware | response surface | sensitivity |
//! | --- | --- | --- | --- | --- |
//! | noise | — | [`noise`] | — | — |
//! | screen | — | — | [`screen`] | — |
//! | design | [`sample`] | [`sample`] | part of `search` | part of `sensitivity` |
//! | simulate | [`batch`] | [`batch`] (replicates) | part of `search` | part of `sensitivity` |
//! | fit | [`train_study`] | [`train_study`], [`train_gp`] | part of `search` | part of `sensitivity` |
//! | adaptive | — | [`adaptive`], then [`train_gp`] again | — | — |
//! | fine | — | [`fine`] | — | — |
//! | search | [`tolerance_search`] | [`gp_search`] | [`rsm`] (design, runs, fits, desirability) | — |
//! | sensitivity | — | — | — | [`sensitivity`] (with its verification) |
//! | verify | [`verify_candidates`] | [`verify_candidates`] | [`verify_optimum`] | part of `sensitivity` |
//! | transfer | [`transfer_stage`] | [`transfer_stage`] | — | — |
//!
//! The design studies' response-surface and sensitivity functions still run
//! their design, runs and fits as one unit, so those stages of their lists
//! are carried out by the stage that ends the unit.

use crate::exec::Executor;
use crate::manifest::{Experiment, Study};
use crate::store::{RunDir, RunResult, Store};
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::{noise_aware, SearchSettings};
use crate::study::plan::design_study::DesignStudy;
use crate::study::plan::{Analysis, Method, Stage, StudySpec};
use crate::study::runs::replicated::{check_limits, check_response, AtSize};
use crate::study::stages::adaptive::{adaptive, AdaptiveOutcome};
use crate::study::stages::design::{sample, SampleOutcome, SampleSettings};
use crate::study::stages::fine::{fine, predictor, FineOutcome};
use crate::study::stages::fit_gp::{fit_model, read_gp, train_gp, GpOutcome};
use crate::study::stages::fit_network::{train_study, TrainOptions, TrainOutcome};
use crate::study::stages::noise::{noise, NoiseOutcome};
use crate::study::stages::rsm::{rsm, RsmOutcome};
use crate::study::stages::screen::{screen, Screen};
use crate::study::stages::search_probability::{gp_search, GpSearchOutcome};
use crate::study::stages::search_tolerance::{
    load_model, search as tolerance_search, SearchOutcome,
};
use crate::study::stages::sensitivity::{sensitivity, Levels, SensitivityOutcome};
use crate::study::stages::simulate::{batch, BatchOutcome};
use crate::study::stages::transfer::{
    transfer as transfer_stage, TransferOutcome, TransferSettings,
};
use crate::study::stages::verify_candidates::{verify as verify_candidates, VerifyOutcome};
use crate::study::stages::verify_optimum::{verify as verify_optimum, Surface, Verification};
use crate::study::StudyError;

/// Every stage's settings in a he2019 calibration, from the study and the
/// command line.
#[derive(Debug, Clone)]
pub struct CalibrationSettings {
    /// Candidates (clusters, largest first) to verify.
    pub candidates: usize,
    /// Run the adaptive rounds after the initial design (noise-aware).
    pub adaptive: bool,
    /// The design stage's settings.
    pub sample: SampleSettings,
    /// The network's training (he2019) and the validation split of both
    /// surrogates.
    pub train: TrainOptions,
    /// The search's resampling and clustering.
    pub search: SearchSettings,
    /// The transfer test after verification (the study's `transfer` block,
    /// or `repose transfer`'s flags); `None`: no transfer stage.
    pub transfer: Option<TransferSettings>,
}

impl CalibrationSettings {
    /// Every stage's defaults, seeded by the study's design seed: the
    /// design stage's settings, the network's sweep with he2019's
    /// two-thirds split and the study's hidden-size selection
    /// ([`TrainOptions::defaults`]), the search's resampling and clustering.
    pub fn defaults(study: &Study, candidates: usize, adaptive: bool) -> CalibrationSettings {
        CalibrationSettings {
            candidates,
            adaptive,
            sample: SampleSettings::default(),
            train: TrainOptions::defaults(study),
            search: SearchSettings::with_seed(study.design.seed),
            transfer: TransferSettings::of_study(study),
        }
    }

    /// The transfer test's sizes as factors of the study's particle (none
    /// without a transfer stage).
    pub fn transfer_sizes(&self, study: &Study) -> Vec<AtSize> {
        self.transfer
            .as_ref()
            .map_or_else(Vec::new, |t| t.at_sizes(study))
    }
}

/// A study resolved once: the document, its stage list and every stage's
/// settings.
// One plan is built per command: the size of its largest variant costs
// nothing, and boxing it would only add indirection to every stage.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum Plan {
    /// he2019's calibration study, classic or noise-aware.
    Calibration {
        /// The study.
        study: Study,
        /// Its stage list.
        spec: StudySpec,
        /// Every stage's settings.
        settings: CalibrationSettings,
    },
    /// A design study, analysed by response surfaces or sensitivity levels.
    Design {
        /// The study.
        study: DesignStudy,
        /// Its stage list.
        spec: StudySpec,
        /// yan2015's levels to compute (a sensitivity analysis).
        levels: Levels,
    },
}

impl Plan {
    /// he2019's plan with `settings`.
    pub fn calibration(study: Study, settings: CalibrationSettings) -> Plan {
        let sizes = settings.transfer.as_ref().map(|t| t.sizes.as_slice());
        let spec = StudySpec::calibration(&study, settings.adaptive, settings.candidates)
            .with_transfer(sizes);
        Plan::Calibration {
            study,
            spec,
            settings,
        }
    }

    /// A design study's plan for `analysis`.
    pub fn design(study: DesignStudy, analysis: Analysis, levels: Levels) -> Plan {
        let spec = StudySpec::design(&study, analysis);
        Plan::Design {
            study,
            spec,
            levels,
        }
    }

    /// The stage list.
    pub fn spec(&self) -> &StudySpec {
        match self {
            Plan::Calibration { spec, .. } | Plan::Design { spec, .. } => spec,
        }
    }
}

/// Which stages of the list a run takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Upto {
    /// This stage alone, on what its predecessors recorded.
    Only(&'static str),
    /// The whole list.
    All,
}

/// What one stage did: each stage's own typed outcome.
// A handful per run, kept in order: their sizes do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum StageOutcome {
    /// The noise floor at the centre of the ranges.
    Noise(NoiseOutcome),
    /// he2019's design.
    Design(SampleOutcome),
    /// he2019's runs of the design.
    Simulate(BatchOutcome),
    /// The network, and the Gaussian process of a noise-aware study.
    Fit {
        /// The GA-BP sweep.
        network: TrainOutcome,
        /// The GP (noise-aware).
        gp: Option<GpOutcome>,
    },
    /// The adaptive rounds and the GP retrained on their points.
    Adaptive {
        /// The rounds.
        rounds: AdaptiveOutcome,
        /// The GP afterwards.
        gp: GpOutcome,
    },
    /// The fine level of a two-level study.
    Fine(FineOutcome),
    /// he2019's tolerance search.
    ToleranceSearch(SearchOutcome),
    /// The noise-aware probability search.
    ProbabilitySearch(GpSearchOutcome),
    /// he2019's candidates in every scene.
    VerifyCandidates(VerifyOutcome),
    /// The verified candidates at finer particle sizes.
    Transfer(TransferOutcome),
    /// A design study's one-factor screening.
    Screen(Screen),
    /// A design study's runs, surfaces and desirability optimum.
    ResponseSurface(RsmOutcome),
    /// A design study's optimum and named points re-simulated.
    VerifyOptimum(Option<Verification>),
    /// yan2015's sensitivity levels (and their verification).
    Sensitivity(SensitivityOutcome),
}

/// What the stages need besides the plan: the study's directory, the store,
/// the executor, the runner of one experiment and a progress log.
pub struct Env<'a, F> {
    /// The study's output directory.
    pub dir: &'a StudyDir,
    /// The run store.
    pub store: &'a Store,
    /// The executor.
    pub pool: &'a Executor,
    /// Runs one experiment into its run directory.
    pub runner: &'a F,
    /// Progress lines (stage headings, rounds).
    pub log: &'a mut dyn FnMut(&str),
}

/// Runs the stages of `plan` that `upto` selects, in the list's order;
/// the log gets each stage's heading (when it runs more than one), its
/// progress and its report
/// ([`StageOutcome::report`]) as it completes. Returns every outcome, in
/// order.
pub fn run<E, F>(plan: &Plan, upto: Upto, env: Env<'_, F>) -> Result<Vec<StageOutcome>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let stages = &plan.spec().stages;
    let selected = select(stages, upto)?;
    let runs_experiments = stages[selected.clone()].iter().any(|s| s.runs() > 0);
    check_plan(plan, runs_experiments.then_some(env.pool))?;
    // A heading per stage when the run takes several: a stage command's
    // output is its stage's report alone.
    let several = selected.len() > 1;
    let mut outcomes: Vec<StageOutcome> = Vec::new();
    let Env {
        dir,
        store,
        pool,
        runner,
        log,
    } = env;
    for (i, stage) in stages
        .iter()
        .enumerate()
        .take(selected.end)
        .skip(selected.start)
    {
        if several {
            log(&format!(
                "\n== {}/{} {}",
                i + 1,
                stages.len(),
                heading(stage, pool)
            ));
        }
        let outcome = match plan {
            Plan::Calibration {
                study, settings, ..
            } => calibration_stage(study, settings, stage, (dir, store, pool, runner), log)?,
            Plan::Design { study, levels, .. } => design_stage(
                study,
                *levels,
                stage,
                &outcomes,
                (dir, store, pool, runner),
                log,
            )?,
        };
        if let Some(o) = outcome {
            let report = o.report(&plan.spec().name, dir);
            if !report.is_empty() {
                log(report.trim_end_matches('\n'));
            }
            outcomes.push(o);
        }
    }
    Ok(outcomes)
}

/// The positions of the list `upto` takes; a stage the list does not name
/// is refused, naming the list.
fn select(stages: &[Stage], upto: Upto) -> Result<std::ops::Range<usize>, StudyError> {
    let find = |name: &str| {
        stages.iter().position(|s| s.name() == name).ok_or_else(|| {
            let names: Vec<&str> = stages.iter().map(Stage::name).collect();
            StudyError::Settings(format!(
                "stage `{name}` is not in this study's list [{}]",
                names.join(", ")
            ))
        })
    };
    Ok(match upto {
        Upto::All => 0..stages.len(),
        Upto::Only(name) => {
            let k = find(name)?;
            k..k + 1
        }
    })
}

/// What a plan must hold before its first stage runs: when the selected
/// stages start runs (`pool` given), every stage's experiments within the
/// executor's limits ([`check_limits`]); a noise-aware study's responses
/// exist in their scenes, and the adaptive rounds are not asked of a
/// two-level study.
fn check_plan(plan: &Plan, pool: Option<&Executor>) -> Result<(), StudyError> {
    let Plan::Calibration {
        study, settings, ..
    } = plan
    else {
        return Ok(());
    };
    if let Some(pool) = pool {
        check_limits(study, &settings.transfer_sizes(study), &pool.limits)?;
    }
    if plan.spec().method != Method::He2019NoiseAware {
        return Ok(());
    }
    let spec = noise_aware(study)?;
    if spec.fidelity.is_some() && settings.adaptive {
        return Err(StudyError::Settings(
            "--adaptive: the adaptive rounds are one-level; a study with noise_aware.fidelity \
             chooses its fine points in the fine stage instead"
                .into(),
        ));
    }
    check_response(&study.calibration)?;
    study.verification.iter().try_for_each(check_response)
}

/// A stage's heading: its name, what it will do and, for a stage that
/// runs experiments, where (`N at a time` or `on Slurm`).
fn heading(stage: &Stage, pool: &Executor) -> String {
    let what = match stage {
        Stage::Noise { seeds } => format!(": centre of the ranges x {seeds} seeds"),
        Stage::Simulate {
            points, replicates, ..
        } => format!(": {points} points x {replicates} seed(s)"),
        Stage::Fine {
            points,
            replicates,
            size,
        } => format!(": {points} design points x {replicates} seeds at particle size x {size}"),
        Stage::Verify { points, scenes, .. } => {
            format!(": {points} candidate(s) x {} scene(s)", scenes.len())
        }
        Stage::Transfer { scenes, sizes, .. } => format!(
            ": the verified candidates x {} scene(s) at particle size(s) {sizes:?} of the verified",
            scenes.len()
        ),
        _ => String::new(),
    };
    let place = match &pool.slurm {
        _ if stage.runs() == 0 => String::new(),
        Some(_) => " (on Slurm)".to_string(),
        None => format!(" ({} at a time)", pool.jobs),
    };
    format!("{}{what}{place}", stage.name())
}

/// The directory, store, executor and runner a stage runs with.
type Running<'a, F> = (&'a StudyDir, &'a Store, &'a Executor, &'a F);

/// Runs one stage of a he2019 calibration (the module's table).
fn calibration_stage<E, F>(
    study: &Study,
    settings: &CalibrationSettings,
    stage: &Stage,
    (dir, store, pool, runner): Running<'_, F>,
    log: &mut dyn FnMut(&str),
) -> Result<Option<StageOutcome>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    let noise_aware = study.noise_aware.is_some();
    let train = &settings.train;
    let gp = |dir: &StudyDir| -> Result<GpOutcome, StudyError> {
        let model = load_model(
            &dir.stage(crate::study::dir::Stage::Train)
                .join("model.json"),
        )?;
        let net = |x: &[f64]| model.predict(x);
        train_gp(
            dir,
            study,
            train.train_fraction,
            train.settings.seed,
            Some(&net),
        )
    };
    Ok(Some(match stage {
        Stage::Noise { .. } => StageOutcome::Noise(noise(dir, study, store, pool, runner)?),
        Stage::Design { .. } => StageOutcome::Design(sample(dir, study, &settings.sample)?),
        Stage::Simulate { .. } => StageOutcome::Simulate(batch(dir, study, store, pool, runner)?),
        Stage::Fit { .. } => StageOutcome::Fit {
            network: train_study(dir, study, train)?,
            gp: if noise_aware { Some(gp(dir)?) } else { None },
        },
        Stage::Adaptive { .. } => {
            let rounds = adaptive(
                dir,
                study,
                store,
                pool,
                train.settings.seed,
                settings.candidates,
                &|| fit_model(dir, study, train.settings.seed)?.process(),
                runner,
                &mut |m| log(m),
            )?;
            StageOutcome::Adaptive {
                rounds,
                gp: gp(dir)?,
            }
        }
        Stage::Fine { .. } => {
            let coarse = read_gp(dir)?.process()?;
            StageOutcome::Fine(fine(dir, study, &coarse, store, pool, runner, &mut |m| {
                log(m)
            })?)
        }
        Stage::Search { .. } if noise_aware => {
            // Read here, so the search imports neither stage: the fit
            // stage's model (its screening) and the predictor over it.
            let model = read_gp(dir)?;
            let predictor = predictor(dir, study, model.process()?)?;
            StageOutcome::ProbabilitySearch(gp_search(
                dir,
                study,
                (&predictor, &model.screening),
                &settings.search,
            )?)
        }
        Stage::Search { .. } => {
            StageOutcome::ToleranceSearch(tolerance_search(dir, study, &settings.search)?)
        }
        Stage::Verify { .. } => StageOutcome::VerifyCandidates(verify_candidates(
            dir,
            study,
            store,
            pool,
            settings.candidates,
            runner,
        )?),
        Stage::Transfer { .. } => {
            let transfer = settings.transfer.as_ref().ok_or_else(|| {
                StudyError::Settings("the transfer stage needs its sizes and rule".into())
            })?;
            StageOutcome::Transfer(transfer_stage(dir, study, transfer, (store, pool), runner)?)
        }
        other => {
            return Err(StudyError::Unsupported(format!(
                "stage `{}` is not part of he2019's method",
                other.name()
            )));
        }
    }))
}

/// Runs one stage of a design study (the module's table) in the study's
/// directory, which its caller prepared (`study.json` written once):
/// `None` for a stage carried out by the one that ends its unit.
fn design_stage<E, F>(
    study: &DesignStudy,
    levels: Levels,
    stage: &Stage,
    earlier: &[StageOutcome],
    (dir, store, pool, runner): Running<'_, F>,
    log: &mut dyn FnMut(&str),
) -> Result<Option<StageOutcome>, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    Ok(match stage {
        Stage::Screen { .. } => Some(StageOutcome::Screen(screen(
            dir, study, store, pool, runner,
        )?)),
        Stage::Design { .. } | Stage::Simulate { .. } | Stage::Fit { .. } => None,
        Stage::Search { .. } => {
            log("design runs");
            Some(StageOutcome::ResponseSurface(rsm(
                dir, study, store, pool, runner,
            )?))
        }
        Stage::Sensitivity => Some(StageOutcome::Sensitivity(sensitivity(
            dir, study, store, pool, runner, levels,
        )?)),
        Stage::Verify { .. } => {
            let Some(surface) = earlier.iter().find_map(|o| match o {
                StageOutcome::ResponseSurface(r) => Some(r),
                _ => None,
            }) else {
                // A sensitivity analysis verifies its points itself.
                return Ok(None);
            };
            log("verification runs");
            let predict = |response: &str, coded: &[f64]| surface.predict(response, coded);
            let fitted = Surface {
                responses: surface.responses(),
                predict: &predict,
                optimum: surface.optimum_actual.as_deref(),
            };
            Some(StageOutcome::VerifyOptimum(verify_optimum(
                dir, study, &fitted, store, pool, runner,
            )?))
        }
        other => {
            return Err(StudyError::Unsupported(format!(
                "stage `{}` is not part of a design study's methods",
                other.name()
            )))
        }
    })
}

impl StageOutcome {
    /// The stage's report on the console (what its command prints), for
    /// the study named `study`.
    pub fn report(&self, study: &str, dir: &StudyDir) -> String {
        use crate::study::dir::Stage as Dir;
        match self {
            StageOutcome::Noise(o) => format!(
                "{}  outputs: {}\n",
                o.markdown,
                dir.stage(Dir::Noise).display()
            ),
            StageOutcome::Design(o) => design_report(o, study, dir),
            StageOutcome::Simulate(o) => o.text(),
            StageOutcome::Fit { network, gp } => match gp {
                Some(gp) => format!("{}\n{}", network.text(), gp.markdown),
                None => network.text(),
            },
            StageOutcome::Adaptive { rounds: a, gp } => format!(
                "stopped ({:?}) after {} round(s), {} run(s){}\n{}",
                a.stop,
                a.rounds,
                a.runs,
                a.hit.as_ref().map_or(String::new(), |h| format!(
                    "; candidate {} at {:.2}° ({} of {} seeds measured)",
                    h.index, h.mean_deg, h.measured, h.seeds
                )),
                gp.markdown
            ),
            StageOutcome::Fine(o) => format!(
                "{}  outputs: {}\n",
                o.markdown,
                dir.stage(Dir::Fine).display()
            ),
            StageOutcome::ToleranceSearch(o) => format!(
                "{}\n{} distinct modes merged into {} cluster(s); outputs: {}\n",
                o.markdown,
                o.modes,
                o.clusters.len(),
                o.out_dir.display()
            ),
            StageOutcome::ProbabilitySearch(o) => o.markdown.clone(),
            StageOutcome::VerifyCandidates(o) => {
                format!("{}  table: {}\n", o.markdown, o.table.display())
            }
            StageOutcome::Transfer(o) => {
                format!("{}  table: {}\n", o.markdown, o.table.display())
            }
            StageOutcome::Screen(_)
            | StageOutcome::ResponseSurface(_)
            | StageOutcome::VerifyOptimum(_)
            | StageOutcome::Sensitivity(_) => String::new(),
        }
    }
}

/// The design stage's report: the points, the optimisation and the
/// diagnostics (their warnings are [`SampleOutcome::diagnostics`]').
fn design_report(o: &SampleOutcome, study: &str, dir: &StudyDir) -> String {
    let mut text = format!(
        "sampled {} points of {} parameter(s) for study {} ({})\n",
        o.points.len(),
        o.parameters.len(),
        study,
        dir.id().short(12)
    );
    if let Some(p) = &o.optimisation {
        text.push_str(&format!(
            "  optimised: {} of {} exchanges kept, phi_p {:.4} -> {:.4}\n",
            p.accepted, p.iterations, p.initial_phi_p, p.final_phi_p
        ));
    }
    text.push_str(&o.diagnostics.text());
    text.push_str(&format!("  design: {}\n", o.design_file.display()));
    text
}
