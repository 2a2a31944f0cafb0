//! `repose noise MANIFEST --seeds N`: the seed-to-seed noise of every named
//! response of one experiment, and what a run of it costs.
//!
//! The experiment is run with packing seeds `p, p + 1, …, p + N − 1` (`p` its
//! own; the replicate convention of every study), everything else unchanged.
//! For each response of its scene kind ([`crate::scenes::responses`]) it
//! reports the seeds that measured it, the mean with its Student-t 95 %
//! interval, the standard deviation σ, and the precision per cost σ² × CPU
//! seconds per run: the variance one run leaves per second spent, the figure
//! of merit of a measurement protocol (halving σ is worth four times the
//! cost). CPU seconds are the runs' mean CPU time ([`TimingRecord::cpu_s`]:
//! each run's thread, which is the whole run on every executor).
//! The wall times are the only non-deterministic numbers; nothing is written
//! besides the runs themselves.

use crate::streams::SeedRule;
use std::fmt::Write as _;

use serde::Serialize;

use crate::exec::outcomes::{run_collect, Retry, RunOutcome};
use crate::exec::Executor;
use crate::manifest::{ContentId, Experiment};
use crate::scenes::responses::{catalogue, response};
use crate::stats::summary::mean_ci;
use crate::store::{RunDir, RunResult, RunState, Store, StoreError, TimingRecord};
use crate::study::StudyError;

/// The noise of one named response over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResponseNoise {
    /// The response's name.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// Seeds whose run measured it.
    pub measured: usize,
    /// Mean over those seeds.
    pub mean: Option<f64>,
    /// Seed-to-seed standard deviation σ (n − 1).
    pub sd: Option<f64>,
    /// Half-width of the mean's 95 % interval.
    pub ci95_half_width: Option<f64>,
    /// σ² × CPU seconds per run, unit² · s.
    pub precision_per_cost: Option<f64>,
}

/// The noise of one experiment's responses (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneNoise {
    /// The experiment asked about (its own packing seed is the first).
    pub experiment: ContentId,
    /// Its scene kind.
    pub scene: String,
    /// The packing seeds run, in order, with each run's id.
    pub runs: Vec<(u64, ContentId)>,
    /// Runs that failed: (packing seed, message).
    pub failures: Vec<(u64, String)>,
    /// Threads each run had.
    pub threads_per_run: usize,
    /// Mean wall time of the completed runs, s.
    pub wall_s_per_run: Option<f64>,
    /// Mean CPU time per run ([`TimingRecord::cpu_s`]), s.
    pub cpu_s_per_run: Option<f64>,
    /// Every response of the scene kind, in catalogue order.
    pub responses: Vec<ResponseNoise>,
}

/// What a set of runs cost: the mean wall and CPU time of those with a
/// timing record ([`TimingRecord::cpu_s`]), and the threads each run was
/// given (one on this machine's pool, `cpus_per_task` on Slurm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunCost {
    /// Threads each run had.
    pub threads_per_run: usize,
    /// Mean wall time per run, s (non-deterministic).
    pub wall_s_per_run: Option<f64>,
    /// Mean CPU time per run, s (non-deterministic).
    pub cpu_s_per_run: Option<f64>,
}

/// The cost of the runs `ids` in `store`, run by `exec`.
pub fn run_cost<'a>(
    store: &Store,
    exec: &Executor,
    ids: impl IntoIterator<Item = &'a ContentId>,
) -> RunCost {
    let timings: Vec<TimingRecord> = ids.into_iter().filter_map(|id| store.timing(id)).collect();
    let mean = |v: Vec<f64>| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    RunCost {
        threads_per_run: exec.slurm.as_ref().map_or(1, |s| s.cpus_per_task as usize),
        wall_s_per_run: mean(timings.iter().map(|t| t.wall_time_s).collect()),
        cpu_s_per_run: mean(timings.iter().map(TimingRecord::cpu_s).collect()),
    }
}

/// The noise of one response over the `values` its seeds measured: mean,
/// σ, the 95 % interval and σ² × `cpu_s_per_run` (the one noise-floor
/// computation: `repose noise MANIFEST --seeds N` and a study's noise
/// stage).
pub fn response_noise(
    name: &str,
    unit: &str,
    values: &[f64],
    cpu_s_per_run: Option<f64>,
) -> ResponseNoise {
    let summary = mean_ci(values);
    ResponseNoise {
        name: name.to_string(),
        unit: unit.to_string(),
        measured: values.len(),
        mean: summary.map(|s| s.mean).or(values.first().copied()),
        sd: summary.map(|s| s.std),
        ci95_half_width: summary.map(|s| s.half_width),
        precision_per_cost: summary.zip(cpu_s_per_run).map(|(s, c)| s.std * s.std * c),
    }
}

/// The experiment `base` with packing seed `base + r`.
pub fn with_packing_offset(base: &Experiment, r: u64) -> Experiment {
    let mut e = base.clone();
    e.seeds.packing_seed = SeedRule::Offset {
        base: base.seeds.packing_seed,
    }
    .packing_seed(r);
    e
}

/// Runs `base` with `seeds` packing seeds on `exec` (cached) and measures the
/// noise of every response of its scene.
pub fn scene_noise<E, F>(
    base: &Experiment,
    seeds: usize,
    store: &Store,
    exec: &Executor,
    runner: &F,
) -> Result<SceneNoise, StudyError>
where
    E: std::error::Error + 'static,
    F: Fn(&Experiment, &RunDir) -> Result<RunResult, E> + Sync,
{
    if seeds < 2 {
        return Err(StudyError::Settings(format!(
            "--seeds = {seeds}: at least 2 are needed for a spread (8 or more recommended)"
        )));
    }
    let first = base.seeds.packing_seed;
    if first.checked_add(seeds as u64 - 1).is_none() {
        return Err(StudyError::Settings(format!(
            "seeds.packing_seed = {first}: with --seeds {seeds} the packing seeds {first} + \
             0..{seeds} pass u64::MAX ({}) and would wrap to 0; use a packing_seed of at most {}",
            u64::MAX,
            u64::MAX - (seeds as u64 - 1)
        )));
    }
    let experiments: Vec<Experiment> = (0..seeds as u64)
        .map(|r| with_packing_offset(base, r))
        .collect();
    let collected = run_collect(&experiments, store, exec, runner, Retry::Failed)?;
    let mut failures = Vec::new();
    let mut results: Vec<Option<RunResult>> = Vec::new();
    for (e, outcome) in experiments.iter().zip(collected.outcomes) {
        results.push(match outcome {
            RunOutcome::Complete(result) => Some(*result),
            RunOutcome::FailedNow(message) => {
                failures.push((e.seeds.packing_seed, message));
                None
            }
            RunOutcome::Stored(RunState::Damaged(problem)) => {
                return Err(StoreError::Damaged {
                    id: e.id(),
                    problem,
                }
                .into())
            }
            RunOutcome::Stored(_) => None,
        });
    }
    let ids: Vec<ContentId> = experiments.iter().map(Experiment::id).collect();
    let cost = run_cost(store, exec, &ids);
    let kind = base.scene.kind();
    let responses = catalogue(kind)
        .unwrap_or_default()
        .iter()
        .map(|spec| {
            let values: Vec<f64> = results
                .iter()
                .flatten()
                .filter_map(|r| response(r, kind, spec.name).ok())
                .collect();
            response_noise(spec.name, spec.unit, &values, cost.cpu_s_per_run)
        })
        .collect();
    Ok(SceneNoise {
        experiment: base.id(),
        scene: kind.to_string(),
        runs: experiments
            .iter()
            .zip(ids)
            .map(|(e, id)| (e.seeds.packing_seed, id))
            .collect(),
        failures,
        threads_per_run: cost.threads_per_run,
        wall_s_per_run: cost.wall_s_per_run,
        cpu_s_per_run: cost.cpu_s_per_run,
        responses,
    })
}

/// The report as Markdown: one row per response.
pub fn markdown(n: &SceneNoise) -> String {
    let mut out = String::new();
    let seeds: Vec<u64> = n.runs.iter().map(|r| r.0).collect();
    let _ = writeln!(
        out,
        "Noise of {} ({}) over packing seeds {}–{} ({} runs, {} failed); \
         CPU s per run: {} ({} thread(s) × wall {})\n",
        n.experiment.short(12),
        n.scene,
        seeds.first().unwrap_or(&0),
        seeds.last().unwrap_or(&0),
        n.runs.len(),
        n.failures.len(),
        fmt(n.cpu_s_per_run, 1),
        n.threads_per_run,
        fmt(n.wall_s_per_run, 1),
    );
    let _ = writeln!(
        out,
        "| response | unit | measured | mean | ± 95 % CI | σ | σ² × CPU s per run |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for r in &n.responses {
        let _ = writeln!(
            out,
            "| {} | {} | {}/{} | {} | {} | {} | {} |",
            r.name,
            r.unit,
            r.measured,
            n.runs.len(),
            fmt(r.mean, 4),
            fmt(r.ci95_half_width, 4),
            fmt(r.sd, 4),
            fmt(r.precision_per_cost, 1)
        );
    }
    for (seed, m) in &n.failures {
        let _ = writeln!(out, "\npacking seed {seed} failed: {m}");
    }
    out
}

fn fmt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "—".to_string(), |v| format!("{v:.digits$}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_experiment;
    use crate::store::RunStatus;

    fn drum() -> Experiment {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/drum/smoke.json"),
        )
        .unwrap();
        parse_experiment(&text).unwrap()
    }

    #[test]
    fn replicates_differ_only_in_their_packing_seed() {
        let base = drum();
        let e = with_packing_offset(&base, 3);
        assert_eq!(e.seeds.packing_seed, base.seeds.packing_seed + 3);
        assert_ne!(e.id(), base.id());
        assert_eq!(with_packing_offset(&base, 0).id(), base.id());
    }

    /// Seeds that would pass u64::MAX are refused before any run, naming the
    /// field, its value and the largest allowed (issue 40, low item).
    #[test]
    fn packing_seeds_that_would_wrap_are_refused() {
        let mut base = drum();
        base.seeds.packing_seed = u64::MAX - 2;
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::open(tmp.path()).unwrap();
        let runner = |e: &Experiment, _: &RunDir| -> Result<RunResult, std::io::Error> {
            Ok(RunResult::new(e, "fake"))
        };
        let exec = Executor::local(1, Default::default());
        let err = scene_noise(&base, 4, &store, &exec, &runner)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("seeds.packing_seed = 18446744073709551613")
                && err.contains("at most 18446744073709551612"),
            "{err}"
        );
        let first = with_packing_offset(&base, 0);
        assert_eq!(store.status(&first.id()), RunStatus::Missing, "nothing ran");
        // Three seeds end exactly on u64::MAX: allowed.
        assert!(scene_noise(&base, 3, &store, &exec, &runner).is_ok());
    }

    #[test]
    fn the_spread_and_its_cost_are_those_of_the_injected_responses() {
        // A fake drum whose static angle is 30 + packing seed (deg): seeds
        // p..p+3 give 30+p, …, 33+p, so σ = sd(0,1,2,3) = √(5/3).
        let base = drum();
        let p = base.seeds.packing_seed as f64;
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::open(tmp.path()).unwrap();
        let runner = |e: &Experiment, _: &RunDir| -> Result<RunResult, std::io::Error> {
            let mut r = RunResult::new(e, "fake");
            r.measurements.insert(
                "static_angle_deg".into(),
                30.0 + e.seeds.packing_seed as f64,
            );
            Ok(r)
        };
        let exec = Executor::local(2, Default::default());
        let n = scene_noise(&base, 4, &store, &exec, &runner).unwrap();
        assert_eq!(n.runs.len(), 4);
        assert!(n.failures.is_empty());
        let r = n
            .responses
            .iter()
            .find(|r| r.name == "static_angle_deg")
            .unwrap();
        assert_eq!(r.measured, 4);
        assert!((r.mean.unwrap() - (31.5 + p)).abs() < 1e-12);
        let sd = (5.0f64 / 3.0).sqrt();
        assert!((r.sd.unwrap() - sd).abs() < 1e-12);
        // scipy.stats.t.ppf(0.975, 3) = 3.182446305284263
        assert!((r.ci95_half_width.unwrap() - 3.182446305284263 * sd / 2.0).abs() < 1e-9);
        let cpu = n.cpu_s_per_run.unwrap();
        assert!((r.precision_per_cost.unwrap() - sd * sd * cpu).abs() < 1e-12);
        assert!(markdown(&n).contains("| static_angle_deg | deg | 4/4 |"));
        let err = scene_noise(&base, 1, &store, &exec, &runner).unwrap_err();
        assert!(err.to_string().contains("--seeds = 1"), "{err}");
    }
}
