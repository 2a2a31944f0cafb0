//! The `repose` command line: parses arguments (clap) and calls one library
//! function per subcommand; prints one error report and exits 2 for invalid input,
//! 1 for a runtime failure.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use repose::bench::BenchOptions;
use repose::commands::{self, CommandError, ConvergenceOptions, KindArg, TradeoffOptions};
use repose::dem::simulation::{NormalChoice, RollingChoice};
use repose::doe::lhs::Placement;
use repose::exec::slurm::SlurmSettings;
use repose::exec::Executor;
use repose::scenes::plan::Limits;
use repose::search::meanshift::Kernel;
use repose::store::{DEFAULT_STORE, STORE_ENV};
use repose::study::plan::calibration::SearchSettings;
use repose::study::plan::Analysis;
use repose::study::stages::design::SampleSettings;
use repose::study::stages::fit_network::{TableSpec, TrainOptions};
use repose::study::stages::sensitivity::Levels;
use repose::study::sweeps::convergence::plan::{SurfaceEnergyRule, RULE_NAMES};
use repose::study::sweeps::convergence::SweepRequest;
use repose::study::sweeps::pilot::PilotSpec;
use repose::study::sweeps::tradeoff::plan::{Knob, KNOB_NAMES};
use repose::surrogate::ga_bp::genetic::GaSettings;
use repose::surrogate::ga_bp::levenberg::TrainlmSettings;
use repose::surrogate::ga_bp::TrainSettings;
use repose::surrogate::ga_bp::{Selection, DEFAULT_FOLDS, DEFAULT_TRAIN_FRACTION};
use repose::tracking::{Format, ListOptions};

/// Huge pages for the engine's large arrays (see `repose::huge_pages`).
#[cfg(target_os = "linux")]
#[global_allocator]
static ALLOCATOR: repose::huge_pages::HugePageAlloc = repose::huge_pages::HugePageAlloc;

/// Reproducible calibration of DEM particle parameters against angle-of-repose tests.
#[derive(Parser)]
#[command(name = "repose", version, about)]
struct Cli {
    /// Root of the run store.
    #[arg(long, global = true, env = STORE_ENV, default_value = DEFAULT_STORE)]
    store: PathBuf,
    /// No progress reports on stderr (they are also off when stderr is not a terminal).
    #[arg(long, global = true)]
    quiet: bool,
    /// Refuse a run whose estimated particle count exceeds this (see `repose plan`).
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::DEFAULT_MAX_PARTICLES)]
    max_particles: u64,
    /// Refuse a run whose estimated particles x steps exceed this.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::DEFAULT_MAX_PARTICLE_STEPS)]
    max_particle_steps: u64,
    /// Refuse a run whose estimated log (run.mcap) exceeds this many bytes.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::DEFAULT_MAX_LOG_BYTES)]
    max_log_bytes: u64,
    /// Refuse a study (or sweep, or noise floor) that may start more runs than
    /// this, before anything is built; `repose stages` shows a study's count.
    #[arg(long, global = true, value_name = "N", default_value_t = repose::exec::DEFAULT_MAX_RUNS)]
    max_runs: u64,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the content id (sha256 of the canonical JSON) of a valid manifest.
    Hash {
        /// Experiment or study manifest.
        file: PathBuf,
        /// What the file holds.
        #[arg(long, value_enum, default_value_t)]
        kind: KindArg,
    },
    /// Check experiment or study manifests; report every error with its field path.
    Validate {
        /// Manifests to check.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// What the files hold.
        #[arg(long, value_enum, default_value_t)]
        kind: KindArg,
    },
    /// Run an experiment (or reuse its cached result); refused when its
    /// estimated cost exceeds the limits (--max-particles, --max-particle-steps,
    /// --max-log-bytes).
    Run {
        /// Experiment manifest.
        manifest: PathBuf,
        /// Print the run plan (as `repose plan` does) instead of running.
        #[arg(long)]
        dry_run: bool,
        /// With --dry-run: print the plan as JSON.
        #[arg(long, requires = "dry_run")]
        json: bool,
    },
    /// Print what a run would cost without running it: particles, time step,
    /// steps, particle-steps, log size, and whether it is within the limits.
    Plan {
        /// Experiment manifest.
        manifest: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Check a run log (run.mcap) and list its channels, counts, times and manifest.
    Inspect {
        /// The MCAP file.
        file: PathBuf,
    },
    /// Time the engine on the dense-bed benchmark of ../shared/bench (settle, warm up,
    /// timed segments); progress on stderr.
    Bench(BenchArgs),
    /// One-factor-at-a-time screening of a design study: response means with
    /// 95 % CIs per level and a one-way ANOVA per factor (cai2024 §3.1).
    Screen {
        /// Design study manifest.
        study: PathBuf,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        /// Print the whole screening as JSON on stdout.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// Response-surface study: the design's runs (replicated), a full
    /// quadratic model and its ANOVA per response, the joint desirability
    /// optimum and its verification. With --table, the same analysis of any
    /// CSV table.
    Rsm(RsmArgs),
    /// The acceptance rule on a CSV table of replicates: per group n, mean,
    /// sd, 95 % interval, both one-sided t-tests, the TOST p-value, the
    /// verdict (pass, fail, inconclusive) and the seeds that would decide.
    Verdict(VerdictArgs),
    /// yan2015's three levels of parameter sensitivity on a design study: the
    /// design's runs, power laws by nonlinear least squares with confidence
    /// intervals (level 1), PCA of the contact-law sensitivity matrices with
    /// each response (level 2), norms and cross-correlations of the contact
    /// law's sensitivities over a-priori states (level 3, no runs). With
    /// --table, the level-1 power-law fit of any CSV table.
    Sensitivity(SensitivityArgs),
    /// Re-simulate the search's cluster centres in the calibration and
    /// verification scenes and compare with the measured angles (he2019 Table 3);
    /// for a design study, the optimum and named points (as the end of `rsm`).
    Verify {
        /// Study manifest.
        study: PathBuf,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        /// How many clusters (largest first) to verify.
        #[arg(long, default_value_t = 3)]
        candidates: usize,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// The transfer test: every verified candidate again at finer particle
    /// sizes, in every scene, with the verification's seeds, judged by its
    /// acceptance rule. Needs `verify` (or `calibrate`) first.
    Transfer {
        /// Study manifest [default: the embedded he2019-quick study].
        study: Option<PathBuf>,
        /// Particle radius / the verified one, each in (0, 1), comma-separated
        /// [default: the study's transfer block; required without one].
        #[arg(long, value_delimiter = ',')]
        sizes: Option<Vec<f64>>,
        /// How the surface energy follows the radius: constant_bond (Γ ∝ R²),
        /// proportional (Γ ∝ R) or cohesion_number (Γ ∝ R^0.4) [default: the
        /// study's transfer block, else proportional, the rule the
        /// convergence sweeps support].
        #[arg(long)]
        rule: Option<String>,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// The whole he2019 method: sample, batch, train, search, verify; for a
    /// noise-aware study, the noise floor first, replicates, a Gaussian-process
    /// search and multi-seed verification. Without a study, runs the embedded
    /// default (he2019 at the quick profile, experiments/he2019-quick/study.json).
    Calibrate {
        /// Study manifest [default: the embedded he2019-quick study].
        study: Option<PathBuf>,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        /// How many clusters (largest first) to verify [default: 3; 1 for a
        /// noise-aware study, whose candidate runs every scene with several seeds].
        #[arg(long)]
        candidates: Option<usize>,
        /// Noise-aware studies: after the initial design, add rounds of
        /// points chosen by the Gaussian process, each led by a candidate run
        /// with the verification's seeds, until a candidate's mean is inside
        /// the target band or the study's run budget is spent.
        #[arg(long)]
        adaptive: bool,
        /// Noise-aware studies: print the outcome (noise floor, surrogate
        /// metrics, candidates, verification) as JSON on stdout; stage reports
        /// go to stderr.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// The noise floor of a noise-aware study: its calibration scene at the
    /// centre of the ranges with the study's noise seeds; σ, the 95 % CI of
    /// the mean, the cost per run and σ² × CPU seconds. With an experiment
    /// manifest and --seeds N: every response of its scene over N packing
    /// seeds (its own and the next N − 1).
    Noise {
        /// Study manifest (with a `noise_aware` block), or an experiment
        /// manifest with --seeds.
        study: PathBuf,
        /// Experiment manifests: how many packing seeds to run.
        #[arg(long)]
        seeds: Option<usize>,
        /// Experiment manifests: print one JSON object.
        #[arg(long, requires = "seeds")]
        json: bool,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// The fine stage of a two-level study (`noise_aware.fidelity`): design
    /// points again at the finer particle size, chosen by the two-level
    /// Gaussian process's fine-level sd, and the two-level fit (ρ, β, δ)
    /// that the search and verification then use. Needs `repose train`.
    Fine {
        /// Study manifest with a `noise_aware.fidelity` block.
        study: PathBuf,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// How well a calibrated study predicts fine-size runs it never saw: its
    /// fine-level predictor (two-level GP, or the GP of a study at the fine
    /// size) at a pilot's held-out fine points; RMSE, mean z², coverage, and
    /// the study's training runs and CPU-s.
    Holdout {
        /// Study manifest (after `repose train`, and `repose fine` for a
        /// two-level study).
        study: PathBuf,
        /// The pilot's pilot.json (`repose pilot`).
        #[arg(long)]
        pilot: PathBuf,
        /// The study the pilot ran on.
        #[arg(long)]
        pilot_study: PathBuf,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Measure what accuracy costs in time: sweep fidelity knobs around a scene
    /// manifest (one at a time, R replicates each) and tabulate angle error vs the
    /// finest setting against wall time, with the Pareto front.
    Tradeoff(TradeoffArgs),
    /// Measure what resolution costs and buys: sweep a scene manifest over
    /// particle sizes (R replicates each), fit each angle against d/D, read
    /// it at the real particle size with its interval, and give the cost per
    /// run against size and the coarsest size within a tolerance.
    Convergence(ConvergenceArgs),
    /// Does a two-level calibration pay in a scene of a he2019 study? The
    /// same Latin-hypercube points at the study's particle size and at a
    /// finer one (--fine-size, Γ ∝ R²), several seeds each, and the
    /// two-level Gaussian process y_fine = ρ·y_coarse + δ: ρ and δ with
    /// their uncertainty.
    Pilot {
        /// he2019 study manifest (e.g. experiments/he2019-quick/study.json).
        study: PathBuf,
        /// The scene: `calibration` or a scene's name (funnel, baffle, drum).
        #[arg(long, default_value = "calibration")]
        scene: String,
        /// Fine particle radius / the study's, in (0, 1).
        #[arg(long, default_value_t = 0.75)]
        fine_size: f64,
        /// Design points (>= 3).
        #[arg(long, default_value_t = 8)]
        points: usize,
        /// Packing seeds per point and size (>= 2).
        #[arg(long, default_value_t = 5)]
        seeds: u32,
        /// Runs at once (default: the number of CPUs).
        #[arg(long)]
        jobs: Option<usize>,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// Accuracy vs number of DEM simulations for a study: train on nested
    /// prefixes of its design (fixed validation rows), with validation R², the
    /// calibrated parameters' spread and the DEM time of each size. Runs the
    /// sample (if missing) and batch stages first (cached, resumable).
    LearningCurve {
        /// Study manifest.
        study: PathBuf,
        /// Training-set sizes, increasing, comma-separated [default: a quarter,
        /// half, three quarters and all of the design's training rows].
        #[arg(long, value_delimiter = ',')]
        sizes: Option<Vec<usize>>,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// Walk a study's outputs back to their manifests through the lineage records,
    /// re-hash every input file and check every referenced run; optionally re-run
    /// some runs and check they reproduce byte for byte.
    Audit {
        /// A study output directory (or one output file).
        path: PathBuf,
        /// How many completed runs to re-run (chosen with --seed).
        #[arg(long, default_value_t = 0)]
        rerun: usize,
        /// Seed of the choice of runs to re-run.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Write a study's report page: one self-contained static HTML file (no
    /// server, network or scripts) with the study spec, every stage's tables and
    /// plots, the verdicts, resolution warnings, the lineage records and links
    /// to each run's run.mcap
    Report {
        /// The study file (as given to the stages that wrote its outputs).
        study: PathBuf,
        /// Directory to write report.html into [default: the study's
        /// directory in the store].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// List the named responses (scalar physics results with units) of one
    /// scene kind, or of every kind, that a calibration can target.
    Responses {
        /// Scene kind as written in manifests (e.g. drum, hopper) [default: all].
        scene: Option<String>,
        /// Print JSON: a list of {"scene", "responses"} objects.
        #[arg(long)]
        json: bool,
    },
    /// Inspect the run store.
    Runs {
        #[command(subcommand)]
        command: RunsCommand,
    },
    /// What differs between two runs (id prefixes: manifest fields, responses
    /// with the seed noise when both have replicates, warnings, sealed files)
    /// or two studies (directories, or prefixes of their ids or directory
    /// names: spec fields, and per stage the files, shared runs and changed
    /// table rows).
    Diff {
        /// The first run or study.
        a: String,
        /// The second run or study.
        b: String,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Every study of the store: name, id, method, stages done, run counts,
    /// verdicts and the time of its last change.
    Studies {
        /// Print a JSON list instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Latin hypercube over a study's calibrated parameters (he2019 §3.1): one
    /// experiment manifest per sample, design diagnostics; or, with --diagnose,
    /// the diagnostics of a CSV table.
    Sample(SampleArgs),
    /// Run every sampled experiment not yet complete (cached, resumable) and
    /// write the simulated-angle table. With --executor slurm, as one Slurm
    /// job array.
    Batch {
        /// Study manifest.
        study: PathBuf,
        /// Runs at once, each single-threaded [default: the number of CPUs].
        #[arg(long)]
        jobs: Option<usize>,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// A study's method and its stages, in the order they run, with what each
    /// uses (design, scenes, seeds, surrogates, search), before anything runs.
    Stages {
        /// Study manifest (he2019 or design study).
        study: PathBuf,
        /// How a design study is analysed: rsm (response surfaces) or
        /// sensitivity (yan2015) [default: the analysis the file's
        /// `stages` spell, else rsm].
        #[arg(long, value_enum)]
        analysis: Option<AnalysisArg>,
        /// Include the adaptive rounds of a noise-aware calibration.
        #[arg(long)]
        adaptive: bool,
        /// Print the spec as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Where every run a study handed to Slurm stands: pending, queued
    /// (with Slurm's reason), running, done or failed, with its Slurm job and
    /// array task (from squeue and the store; from the store alone when
    /// squeue cannot be asked). For an experiment manifest: its noise floor's
    /// and tradeoff sweep's runs.
    Status {
        /// Study manifest (he2019 or design study), or an experiment manifest.
        study: PathBuf,
        /// Print one JSON object (counts and one entry per run).
        #[arg(long)]
        json: bool,
    },
    /// Train the GA-BP network on the batch's angles (he2019 §3.2–3.4), sweeping
    /// the hidden size; or, with --table, on a CSV table.
    Train(TrainArgs),
    /// Predict resampled points, keep those within the target tolerance and
    /// cluster them by mean shift (he2019 §3.5, Table 2).
    Search(SearchArgs),
}

/// Where a stage's runs execute (every command that runs experiments).
#[derive(clap::Args)]
#[command(next_help_heading = "Executor (local pool or Slurm)")]
struct ExecArgs {
    /// Where runs execute: this machine's workers, or one Slurm job array per
    /// stage (each task `repose run` against the same store; see README,
    /// "Running on a cluster").
    #[arg(long, value_enum, default_value_t = ExecutorKind::Local)]
    executor: ExecutorKind,
    /// Slurm: the partition (sbatch --partition).
    #[arg(long, value_name = "NAME")]
    partition: Option<String>,
    /// Slurm: each task's time limit (sbatch --time, e.g. 2-00:00:00).
    #[arg(long, value_name = "TIME")]
    time_limit: Option<String>,
    /// Slurm: each task's memory (sbatch --mem, e.g. 4G).
    #[arg(long, value_name = "SIZE")]
    mem: Option<String>,
    /// Slurm: CPUs per task; the task's simulation runs on that many threads.
    #[arg(long, value_name = "N")]
    cpus_per_task: Option<u32>,
    /// Slurm: the account to charge (sbatch --account).
    #[arg(long, value_name = "NAME")]
    account: Option<String>,
    /// Slurm: a further #SBATCH line, verbatim (repeatable), e.g. --sbatch=--qos=high.
    #[arg(long, value_name = "LINE")]
    sbatch: Vec<String>,
    /// Slurm: shell commands that put `repose` on the node's PATH (e.g.
    /// "module load repose") [default: put this binary's directory first on PATH].
    #[arg(long, value_name = "COMMANDS")]
    setup: Option<String>,
    /// Slurm: the most array tasks running at once (--array=…%M).
    #[arg(long, value_name = "M")]
    max_running: Option<u32>,
    /// Slurm: write the job script and its task list, do not submit (exit 3).
    #[arg(long)]
    dry_run: bool,
    /// Slurm: submit and return (exit 3) instead of waiting for the runs.
    #[arg(long)]
    no_wait: bool,
    /// Slurm: submit again the runs whose last attempt failed (error.json).
    #[arg(long)]
    resubmit_failed: bool,
    /// Slurm: seconds between queue polls while waiting.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    poll_seconds: f64,
}

/// The executors `--executor` names.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ExecutorKind {
    /// Worker threads on this machine (--jobs of them).
    Local,
    /// A Slurm job array.
    Slurm,
}

impl ExecArgs {
    /// The executor these options describe; a Slurm option without
    /// `--executor slurm` is refused, naming it.
    fn executor(
        &self,
        jobs: usize,
        limits: Limits,
        max_runs: u64,
    ) -> Result<Executor, CommandError> {
        if jobs == 0 {
            return Err(CommandError::Usage(
                "--jobs = 0: must be >= 1 (runs at once)".to_string(),
            ));
        }
        let slurm_only = [
            ("--partition", self.partition.is_some()),
            ("--time-limit", self.time_limit.is_some()),
            ("--mem", self.mem.is_some()),
            ("--cpus-per-task", self.cpus_per_task.is_some()),
            ("--account", self.account.is_some()),
            ("--sbatch", !self.sbatch.is_empty()),
            ("--setup", self.setup.is_some()),
            ("--max-running", self.max_running.is_some()),
            ("--dry-run", self.dry_run),
            ("--no-wait", self.no_wait),
            ("--resubmit-failed", self.resubmit_failed),
        ];
        let slurm = match self.executor {
            ExecutorKind::Local => {
                if let Some((flag, _)) = slurm_only.iter().find(|(_, set)| *set) {
                    return Err(CommandError::Usage(format!(
                        "{flag} is a Slurm option: add --executor slurm"
                    )));
                }
                None
            }
            ExecutorKind::Slurm => {
                if !(self.poll_seconds >= MIN_POLL_SECONDS && self.poll_seconds <= MAX_POLL_SECONDS)
                {
                    return Err(CommandError::Usage(format!(
                        "--poll-seconds = {:?}: must lie in [{MIN_POLL_SECONDS}, \
                         {MAX_POLL_SECONDS}] (a millisecond to a day)",
                        self.poll_seconds
                    )));
                }
                let settings = SlurmSettings {
                    partition: self.partition.clone(),
                    time_limit: self.time_limit.clone(),
                    mem: self.mem.clone(),
                    cpus_per_task: self.cpus_per_task.unwrap_or(1),
                    account: self.account.clone(),
                    extra: self.sbatch.clone(),
                    setup: self.setup.clone(),
                    max_running: self.max_running,
                    dry_run: self.dry_run,
                    wait: !self.no_wait,
                    resubmit_failed: self.resubmit_failed,
                    poll: std::time::Duration::from_secs_f64(self.poll_seconds),
                    ..SlurmSettings::default()
                };
                settings.check()?;
                Some(settings)
            }
        };
        Ok(Executor {
            slurm,
            max_runs,
            ..Executor::local(jobs, limits)
        })
    }
}

/// Shortest `--poll-seconds`: a millisecond (a shorter wait rounds to no
/// wait at all).
const MIN_POLL_SECONDS: f64 = 0.001;

/// Longest `--poll-seconds`: a day (a longer wait between two looks at the
/// queue is no use, and 1e300 s does not fit a `Duration`).
const MAX_POLL_SECONDS: f64 = 86_400.0;

/// Options of `repose sample`.
#[derive(clap::Args)]
struct SampleArgs {
    /// Study manifest.
    #[arg(required_unless_present = "diagnose", conflicts_with = "diagnose")]
    study: Option<PathBuf>,
    /// Diagnose the points of this CSV table instead of sampling (each column
    /// scaled by its own min-max).
    #[arg(long, value_name = "TABLE")]
    diagnose: Option<PathBuf>,
    /// Table columns to diagnose, comma-separated [default: every numeric column].
    #[arg(long, value_delimiter = ',', requires = "diagnose")]
    columns: Option<Vec<String>>,
    /// Where a sample sits in its stratum: midpoint (he2019 §3.1 step 1) or
    /// random (Eq. 4).
    #[arg(long, value_enum, default_value = "midpoint")]
    placement: Placement,
    /// Exchanges tried by the lhs_optimised design.
    #[arg(long, default_value_t = 5000)]
    optimise_iterations: usize,
    /// Warn when two columns' |correlation| reaches this.
    #[arg(long, default_value_t = repose::doe::diagnostics::STRONG_CORRELATION)]
    max_correlation: f64,
}

/// Options of `repose train`.
#[derive(clap::Args)]
struct TrainArgs {
    /// Study manifest.
    #[arg(required_unless_present = "table", conflicts_with = "table")]
    study: Option<PathBuf>,
    /// Train on this CSV table instead of a study's batch.
    #[arg(long, requires_all = ["inputs", "target", "out"])]
    table: Option<PathBuf>,
    /// Input columns of the table, comma-separated.
    #[arg(long, value_delimiter = ',')]
    inputs: Option<Vec<String>>,
    /// Target column of the table (the angle, degrees).
    #[arg(long)]
    target: Option<String>,
    /// Column of printed predictions to score on the validation rows (Eq. 7).
    #[arg(long)]
    reference: Option<String>,
    /// Output directory for --table.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Fraction of the rows, in design order, that trains; the rest validates.
    #[arg(long, default_value_t = DEFAULT_TRAIN_FRACTION)]
    train_fraction: f64,
    /// Smallest hidden size of the sweep.
    #[arg(long, default_value_t = 3)]
    hidden_min: usize,
    /// Largest hidden size of the sweep.
    #[arg(long, default_value_t = 12)]
    hidden_max: usize,
    /// Seed of the genetic algorithm [default: the study's design seed; 0 for a table].
    #[arg(long)]
    seed: Option<u64>,
    /// Ridge penalty on weights and thresholds (scaled units).
    #[arg(long, default_value_t = 0.0)]
    weight_decay: f64,
    /// Genetic algorithm population.
    #[arg(long, default_value_t = GaSettings::default().population)]
    ga_population: usize,
    /// Genetic algorithm generations.
    #[arg(long, default_value_t = GaSettings::default().generations)]
    ga_generations: usize,
    /// Levenberg-Marquardt steps.
    #[arg(long, default_value_t = TrainlmSettings::default().epochs)]
    lm_epochs: usize,
    /// How the hidden size is chosen: `validation` (he2019: highest
    /// validation R2) or `cv` (k-fold cross-validation within the training
    /// rows) [default: cv for a noise-aware study, else validation].
    #[arg(long, value_enum)]
    selection: Option<SelectionArg>,
    /// Folds of --selection cv (capped at the training rows: leave-one-out);
    /// only with an explicit --selection.
    #[arg(long, default_value_t = DEFAULT_FOLDS, requires = "selection")]
    cv_folds: usize,
}

/// The hidden-size selection rule on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum SelectionArg {
    Validation,
    Cv,
}

impl TrainArgs {
    fn options(&self) -> TrainOptions {
        let mut settings = TrainSettings::with_seed(self.seed.unwrap_or(0));
        settings.hidden_min = self.hidden_min;
        settings.hidden_max = self.hidden_max;
        settings.weight_decay = self.weight_decay;
        settings.ga.population = self.ga_population;
        settings.ga.generations = self.ga_generations;
        settings.lm.epochs = self.lm_epochs;
        TrainOptions {
            settings,
            train_fraction: self.train_fraction,
        }
    }

    /// The rule asked for on the command line, if any.
    fn selection(&self) -> Option<Selection> {
        self.selection.map(|s| match s {
            SelectionArg::Validation => Selection::Validation,
            SelectionArg::Cv => Selection::CrossValidation {
                folds: self.cv_folds,
            },
        })
    }
}

/// Options of `repose search`.
#[derive(clap::Args)]
struct SearchArgs {
    /// Study manifest.
    study: PathBuf,
    /// Resampled points.
    #[arg(long, default_value_t = 300)]
    samples: usize,
    /// Seed of the resampling [default: the study's design seed].
    #[arg(long)]
    seed: Option<u64>,
    /// Where a resampled point sits in its stratum.
    #[arg(long, value_enum, default_value = "random")]
    placement: Placement,
    /// Mean-shift kernel.
    #[arg(long, value_enum, default_value = "flat")]
    kernel: Kernel,
    /// Bandwidth in unit-scaled parameters [default: estimated].
    #[arg(long)]
    bandwidth: Option<f64>,
    /// Quantile of the bandwidth estimate (k-th nearest neighbour, k = n * quantile).
    #[arg(long, default_value_t = 0.3)]
    quantile: f64,
}

/// Options of `repose verdict`.
#[derive(clap::Args)]
struct VerdictArgs {
    /// The CSV table of replicates.
    #[arg(long)]
    table: PathBuf,
    /// The column of replicate values (an empty cell is a missing replicate).
    #[arg(long)]
    value: String,
    /// A column whose values name a group (repeatable; none: one group).
    #[arg(long)]
    group: Vec<String>,
    /// The measured target, units of the values.
    #[arg(long, allow_hyphen_values = true)]
    target: f64,
    /// Accepted relative deviation of the mean, in (0, 1): the band is
    /// target x (1 -/+ tolerance).
    #[arg(long, allow_hyphen_values = true)]
    tolerance: f64,
    /// Print the verdicts as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Options of `repose rsm`.
#[derive(clap::Args)]
struct RsmArgs {
    /// Design study manifest (absent with --table).
    #[arg(required_unless_present = "table", conflicts_with = "table")]
    study: Option<PathBuf>,
    /// Analyse this CSV table instead of a study's runs.
    #[arg(long, requires_all = ["factors", "response"])]
    table: Option<PathBuf>,
    /// With --table: the factor columns, comma-separated.
    #[arg(long, value_delimiter = ',')]
    factors: Vec<String>,
    /// With --table: the response column.
    #[arg(long)]
    response: Option<String>,
    /// With --table: actual-unit ranges per factor as NAME=LOW:HIGH,...
    /// (absent: the factor columns are coded, -1..1).
    #[arg(long, value_delimiter = ',')]
    ranges: Vec<String>,
    /// Runs at once, each single-threaded [default: the number of CPUs].
    #[arg(long)]
    jobs: Option<usize>,
    /// Print the whole analysis as JSON on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    exec: ExecArgs,
}

#[derive(clap::Args)]
struct SensitivityArgs {
    /// Design study manifest (absent with --table).
    #[arg(required_unless_present = "table", conflicts_with = "table")]
    study: Option<PathBuf>,
    /// Fit the power law of one column of this CSV table instead.
    #[arg(long, requires_all = ["factors", "response"])]
    table: Option<PathBuf>,
    /// With --table: the factor columns (every value > 0), comma-separated.
    #[arg(long, value_delimiter = ',')]
    factors: Vec<String>,
    /// With --table: the response column (every value > 0).
    #[arg(long)]
    response: Option<String>,
    /// Which levels to compute: 1, 2, 3, comma-separated [default: all].
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u8).range(1..=3))]
    level: Vec<u8>,
    /// Runs at once, each single-threaded [default: the number of CPUs].
    #[arg(long)]
    jobs: Option<usize>,
    /// Print the whole analysis as JSON on stdout (full precision).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    exec: ExecArgs,
}

impl RsmArgs {
    /// The table analysis's columns and ranges.
    fn table_spec(&self) -> Result<repose::study::stages::rsm::TableSpec, String> {
        let ranges = if self.ranges.is_empty() {
            None
        } else {
            let mut by_name = std::collections::BTreeMap::new();
            for spec in &self.ranges {
                let parsed = spec.split_once('=').and_then(|(name, range)| {
                    let (lo, hi) = range.split_once(':')?;
                    Some((
                        name.to_string(),
                        lo.trim().parse::<f64>().ok()?,
                        hi.trim().parse::<f64>().ok()?,
                    ))
                });
                let Some((name, low, high)) =
                    parsed.filter(|(_, lo, hi)| lo.is_finite() && hi.is_finite() && lo < hi)
                else {
                    return Err(format!(
                        "--ranges `{spec}`: expected NAME=LOW:HIGH with finite LOW < HIGH"
                    ));
                };
                by_name.insert(name, repose::doe::Range { low, high });
            }
            let mut ranges = Vec::new();
            for f in &self.factors {
                ranges.push(
                    by_name
                        .remove(f)
                        .ok_or_else(|| format!("--ranges: no range for factor `{f}`"))?,
                );
            }
            if let Some(extra) = by_name.keys().next() {
                return Err(format!("--ranges: `{extra}` is not among --factors"));
            }
            Some(ranges)
        };
        Ok(repose::study::stages::rsm::TableSpec {
            factors: self.factors.clone(),
            response: self.response.clone().unwrap_or_default(),
            ranges,
        })
    }
}

/// Options of `repose tradeoff`.
#[derive(clap::Args)]
struct TradeoffArgs {
    /// Experiment manifest of the scene (a lab scene).
    manifest: PathBuf,
    /// Knobs to sweep (rayleigh_fraction, youngs_modulus_factor, size_factor,
    /// periodic_slices, stop_threshold, stop_hold), comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "rayleigh_fraction,youngs_modulus_factor,size_factor"
    )]
    knobs: Vec<String>,
    /// Values of one knob, finest first, as KNOB=V1,V2,... (repeatable); others
    /// use their presets.
    #[arg(long = "values")]
    values: Vec<String>,
    /// Replicates (packing seeds) per point, >= 2.
    #[arg(long, default_value_t = 3)]
    replicates: usize,
    /// Runs at once (default: the number of CPUs), as every command's
    /// --jobs; --threads is its old name.
    #[arg(long, alias = "threads")]
    jobs: Option<usize>,
    /// Output directory (default <store>/tradeoff/<base id prefix>).
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    exec: ExecArgs,
}

impl TradeoffArgs {
    fn options(&self) -> Result<TradeoffOptions, String> {
        let mut knobs = Vec::new();
        for name in &self.knobs {
            let knob = Knob::preset(name).ok_or_else(|| {
                format!(
                    "--knobs: `{name}` is not a knob; known: {}",
                    KNOB_NAMES.join(", ")
                )
            })?;
            knobs.push(knob);
        }
        for spec in &self.values {
            let (name, list) = spec
                .split_once('=')
                .ok_or_else(|| format!("--values `{spec}`: expected KNOB=V1,V2,..."))?;
            let values = list
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<Vec<f64>, _>>()
                .map_err(|e| format!("--values `{spec}`: {e}"))?;
            if values.len() < 2 {
                return Err(format!("--values `{spec}`: needs at least two values"));
            }
            let slot = knobs
                .iter_mut()
                .find(|k| k.name == name)
                .ok_or_else(|| format!("--values `{spec}`: `{name}` is not among --knobs"))?;
            *slot = slot.clone().with_values(values);
        }
        Ok(TradeoffOptions {
            knobs,
            replicates: self.replicates,
            out_dir: self.out.clone(),
        })
    }
}

/// Options of `repose convergence`.
#[derive(clap::Args)]
struct ConvergenceArgs {
    /// Experiment manifest of the scene (a lab scene): the coarsest level.
    manifest: PathBuf,
    /// Size factors relative to the manifest's particle, comma-separated
    /// (1 = the manifest's; 0.5 = half its radius).
    #[arg(long, value_delimiter = ',', default_value = "1,0.75,0.5")]
    sizes: Vec<f64>,
    /// Replicates (packing seeds) per size, >= 2.
    #[arg(long, default_value_t = 5)]
    replicates: usize,
    /// How the surface energy follows the radius when the manifest has no
    /// coarse_graining: constant_bond (Γ ∝ R², the default), proportional
    /// (Γ ∝ R), cohesion_number (Γ ∝ R^0.4) or fixed.
    #[arg(long)]
    rule: Option<String>,
    /// The real particle's radius, m, when the manifest states its simulated
    /// particle directly (with coarse_graining the manifest's radius is the
    /// real one); without it the trend is read at d/D -> 0.
    #[arg(long)]
    real_radius: Option<f64>,
    /// Responses to analyse, comma-separated (default: every angle response
    /// of the scene that a run measured).
    #[arg(long, value_delimiter = ',')]
    responses: Vec<String>,
    /// Tolerance of the responses (degrees): the standard size is the
    /// coarsest whose estimated bias is within half of it.
    #[arg(long)]
    tolerance: Option<f64>,
    /// Runs at once (default: the number of CPUs).
    #[arg(long)]
    jobs: Option<usize>,
    /// Output directory (default <store>/convergence/<base id prefix>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the analysis as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    exec: ExecArgs,
}

impl ConvergenceArgs {
    fn options(&self) -> Result<ConvergenceOptions, String> {
        let rule = match &self.rule {
            None => None,
            Some(name) => Some(SurfaceEnergyRule::parse(name).ok_or_else(|| {
                format!("--rule `{name}`: must be one of {}", RULE_NAMES.join(", "))
            })?),
        };
        if let Some(r) = self.real_radius.filter(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(format!("--real-radius {r:?}: must be a length in m, > 0"));
        }
        if let Some(t) = self.tolerance.filter(|t| !(t.is_finite() && *t > 0.0)) {
            return Err(format!("--tolerance {t}: must be a number > 0 (degrees)"));
        }
        Ok(ConvergenceOptions {
            request: SweepRequest {
                factors: self.sizes.clone(),
                replicates: self.replicates,
                rule,
                real_radius_m: self.real_radius,
                analysis: repose::study::sweeps::convergence::Analysis {
                    responses: self.responses.clone(),
                    tolerance: self.tolerance,
                },
                out_dir: self.out.clone(),
            },
            json: self.json,
        })
    }
}

/// Options of `repose bench`.
#[derive(clap::Args)]
struct BenchArgs {
    /// Lattice side: N = n*n*20 spheres (16, 32, 50 give 5,120, 20,480, 50,000).
    #[arg(long, default_value_t = 16)]
    n: usize,
    /// Thread counts to time, comma-separated (each in its own pool).
    #[arg(long, value_delimiter = ',', default_value = "1")]
    threads: Vec<usize>,
    /// Steps per timed segment [default: the deck's, 6000 / 2000 / 1000 for n = 16 / 32 / 50].
    #[arg(long)]
    steps: Option<u64>,
    /// Timed segments per variant.
    #[arg(long, default_value_t = 3)]
    segments: usize,
    /// Warm-up steps before timing.
    #[arg(long, default_value_t = 500)]
    warmup: u64,
    /// Settling steps [default: the deck's, 20000; 16000 for n >= 50].
    #[arg(long)]
    settle: Option<u64>,
    /// Rolling models to time, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "cdt")]
    rolling: Vec<RollingArg>,
    /// Normal models to time, comma-separated (JKR with zero surface energy).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "hertz")]
    normal: Vec<NormalArg>,
    /// Seed of the lattice jitter.
    #[arg(long, default_value_t = 15_485_863)]
    seed: u64,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// How a design study is analysed, on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum AnalysisArg {
    Rsm,
    Sensitivity,
}

impl From<AnalysisArg> for Analysis {
    fn from(arg: AnalysisArg) -> Analysis {
        match arg {
            AnalysisArg::Rsm => Analysis::ResponseSurface,
            AnalysisArg::Sensitivity => Analysis::Sensitivity,
        }
    }
}

/// Rolling-resistance model on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum RollingArg {
    None,
    Cdt,
    Epsd,
}

/// Normal model on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum NormalArg {
    Hertz,
    Jkr,
}

impl BenchArgs {
    fn options(&self) -> BenchOptions {
        BenchOptions {
            n: self.n,
            threads: self.threads.clone(),
            steps: self.steps,
            segments: self.segments,
            warmup: self.warmup,
            settle: self.settle,
            normals: self
                .normal
                .iter()
                .map(|m| match m {
                    NormalArg::Hertz => NormalChoice::Hertz,
                    NormalArg::Jkr => NormalChoice::Jkr,
                })
                .collect(),
            rollings: self
                .rolling
                .iter()
                .map(|m| match m {
                    RollingArg::None => RollingChoice::None,
                    RollingArg::Cdt => RollingChoice::Cdt,
                    RollingArg::Epsd => RollingChoice::Epsd,
                })
                .collect(),
            seed: self.seed,
        }
    }
}

#[derive(Subcommand)]
enum RunsCommand {
    /// Table of the runs: every run, or those a query selects, sorted,
    /// grouped over packing seeds, as text, CSV or JSON. Fields: `id`,
    /// `scene`, `profile`, `status`, `physics_version`, any manifest field by
    /// dotted path (`contact.particle_particle.static_friction`) and any
    /// response (`angle_deg`, `headline_angle_deg`).
    List(ListArgs),
    /// One run, by a unique id prefix.
    Show {
        /// Leading hex digits of the run id.
        prefix: String,
    },
}

#[derive(clap::Args)]
struct ListArgs {
    /// Keep the runs where FIELD OP VALUE holds (OP: = != < <= > >=; numbers
    /// compare as numbers); repeatable, every one must hold.
    #[arg(long = "where", value_name = "EXPR")]
    filters: Vec<String>,
    /// Order by FIELD, or FIELD:desc; repeatable or a comma list; stable.
    #[arg(long, value_name = "KEY[:desc]")]
    sort: Vec<String>,
    /// The columns to show, in order (`id` always first).
    #[arg(long, value_name = "a,b,c", value_delimiter = ',')]
    columns: Option<Vec<String>>,
    /// Only the fields whose values differ among the listed runs.
    #[arg(long)]
    only_changed: bool,
    /// Fold runs that differ only in their packing seed into one row: n and
    /// each response's mean ± 95 % interval (Student t).
    #[arg(long)]
    group_seeds: bool,
    /// Print a JSON list, one object per row.
    #[arg(long, conflicts_with = "csv")]
    json: bool,
    /// Print a CSV table.
    #[arg(long)]
    csv: bool,
}

impl ListArgs {
    fn format(&self) -> Format {
        match (self.json, self.csv) {
            (true, _) => Format::Json,
            (_, true) => Format::Csv,
            _ => Format::Text,
        }
    }

    fn options(self) -> ListOptions {
        ListOptions {
            filters: self.filters,
            sort: self.sort,
            columns: self.columns,
            only_changed: self.only_changed,
            group_seeds: self.group_seeds,
        }
    }
}

/// What every command shares: the run store, the limits of one run and
/// the most runs a command may start.
struct Ctx {
    store: PathBuf,
    limits: Limits,
    max_runs: u64,
}

impl Ctx {
    /// The executor of a command's `--executor`/`--jobs` options.
    fn exec(&self, exec: &ExecArgs, jobs: Option<usize>) -> Result<Executor, CommandError> {
        exec.executor(default_jobs(jobs), self.limits, self.max_runs)
    }
}

fn dispatch(cli: Cli) -> Result<(), CommandError> {
    repose::scenes::protocol::set_quiet(cli.quiet);
    let out = &mut io::stdout().lock();
    let c = Ctx {
        store: cli.store,
        limits: Limits {
            max_particles: cli.max_particles,
            max_particle_steps: cli.max_particle_steps,
            max_log_bytes: cli.max_log_bytes,
        },
        max_runs: cli.max_runs,
    };
    let s = c.store.as_path();
    match cli.command {
        Command::Hash { file, kind } => commands::hash(&file, kind, out),
        Command::Validate { files, kind } => {
            commands::validate(&files, kind, out, &mut io::stderr())
        }
        Command::Run {
            manifest,
            dry_run: true,
            json,
        }
        | Command::Plan { manifest, json } => commands::plan(&manifest, &c.limits, json, out),
        Command::Run { manifest, .. } => {
            commands::run(s, &manifest, &c.limits, out, &mut io::stderr())
        }
        Command::Inspect { file } => commands::inspect(s, &file, out),
        Command::Bench(args) => bench(args, cli.quiet, out),
        Command::Verdict(args) => verdict(args, out),
        Command::Holdout {
            study,
            pilot,
            pilot_study,
            json,
        } => commands::holdout(s, &study, &pilot, &pilot_study, json, out),
        Command::Audit { path, rerun, seed } => commands::audit(s, &path, rerun, seed, out),
        Command::Report { study, out: dir } => commands::report(s, &study, dir.as_deref(), out),
        Command::Responses { scene, json } => commands::responses(scene.as_deref(), json, out),
        Command::Stages {
            study,
            analysis,
            adaptive,
            json,
        } => commands::stages(&study, analysis.map(Analysis::from), adaptive, json, out),
        Command::Runs {
            command: RunsCommand::List(args),
        } => {
            let format = args.format();
            commands::runs_list(s, &args.options(), format, out)
        }
        Command::Diff { a, b, json } => commands::diff(s, &a, &b, json, out),
        Command::Studies { json } => commands::studies(s, json, out),
        Command::Runs {
            command: RunsCommand::Show { prefix },
        } => commands::runs_show(s, &prefix, out),
        Command::Status { study, json } => commands::status(s, &study, json, out),
        Command::Train(args) => train(s, args, out),
        Command::Search(args) => search(s, args, out),
        command @ (Command::Verify { .. }
        | Command::Transfer { .. }
        | Command::Calibrate { .. }
        | Command::Fine { .. }
        | Command::Noise { .. }
        | Command::LearningCurve { .. }
        | Command::Batch { .. }
        | Command::Sample(_)) => run_calibration(&c, command, out),
        command => run_design_or_sweep(&c, command, out),
    }
}

/// The commands of he2019's calibration study, each running experiments.
fn run_calibration(c: &Ctx, command: Command, out: &mut dyn io::Write) -> Result<(), CommandError> {
    let s = c.store.as_path();
    match command {
        Command::Verify {
            study,
            jobs,
            candidates,
            exec,
        } => commands::verify(s, &study, &c.exec(&exec, jobs)?, candidates, out),
        Command::Transfer {
            study,
            sizes,
            rule,
            jobs,
            exec,
        } => commands::transfer(
            s,
            study.as_deref(),
            &c.exec(&exec, jobs)?,
            sizes,
            rule.as_deref(),
            out,
        ),
        Command::Calibrate {
            study,
            jobs,
            candidates,
            adaptive,
            json,
            exec,
        } => {
            let flags = commands::CalibrateFlags { adaptive, json };
            commands::calibrate(
                s,
                study.as_deref(),
                &c.exec(&exec, jobs)?,
                candidates,
                flags,
                out,
            )
        }
        Command::Fine { study, jobs, exec } => {
            commands::fine(s, &study, &c.exec(&exec, jobs)?, out)
        }
        Command::Noise {
            study,
            seeds: Some(n),
            json,
            jobs,
            exec,
        } => commands::scene_noise(s, &study, n, &c.exec(&exec, jobs)?, json, out),
        Command::Noise {
            study, jobs, exec, ..
        } => commands::noise(s, &study, &c.exec(&exec, jobs)?, out),
        Command::LearningCurve {
            study,
            sizes,
            jobs,
            exec,
        } => commands::learning_curve(s, &study, sizes.as_deref(), &c.exec(&exec, jobs)?, out),
        Command::Sample(args) => sample(s, args, c.max_runs, out),
        Command::Batch { study, jobs, exec } => {
            commands::batch(s, &study, &c.exec(&exec, jobs)?, out)
        }
        _ => unreachable!("dispatch routes only these commands here"),
    }
}

/// The design studies' and the sweeps' commands, each running experiments.
fn run_design_or_sweep(
    c: &Ctx,
    command: Command,
    out: &mut dyn io::Write,
) -> Result<(), CommandError> {
    let s = c.store.as_path();
    match command {
        Command::Screen {
            study,
            jobs,
            json,
            exec,
        } => commands::screen(s, &study, &c.exec(&exec, jobs)?, json, out),
        Command::Rsm(args) => rsm(c, args, out),
        Command::Sensitivity(args) => sensitivity(c, args, out),
        Command::Tradeoff(args) => {
            let options = args.options().map_err(CommandError::Usage)?;
            commands::tradeoff(
                s,
                &args.manifest,
                &options,
                &c.exec(&args.exec, args.jobs)?,
                out,
            )
        }
        Command::Convergence(args) => {
            let options = args.options().map_err(CommandError::Usage)?;
            commands::convergence(
                s,
                &args.manifest,
                &options,
                &c.exec(&args.exec, args.jobs)?,
                out,
            )
        }
        Command::Pilot {
            study,
            scene,
            fine_size,
            points,
            seeds,
            jobs,
            json,
            exec,
        } => {
            let spec = PilotSpec {
                scene,
                points,
                seeds,
                fine_factor: fine_size,
            };
            commands::pilot(s, &study, &spec, &c.exec(&exec, jobs)?, json, out)
        }
        _ => unreachable!("dispatch routes only these commands here"),
    }
}

/// `repose bench`: progress on stderr unless `--quiet`.
fn bench(args: BenchArgs, quiet: bool, out: &mut dyn io::Write) -> Result<(), CommandError> {
    let mut progress: Box<dyn io::Write + Send> = if quiet {
        Box::new(io::sink())
    } else {
        Box::new(io::stderr())
    };
    commands::bench(&args.options(), args.json, out, &mut progress)
}

/// `repose verdict TABLE`.
fn verdict(args: VerdictArgs, out: &mut dyn io::Write) -> Result<(), CommandError> {
    let spec = repose::study::analyses::verdict_table::VerdictSpec {
        value: args.value,
        group: args.group,
        target: args.target,
        tolerance: args.tolerance,
    };
    commands::verdict_table(&args.table, &spec, args.json, out)
}

/// `repose rsm STUDY` or `repose rsm --table FILE`.
fn rsm(c: &Ctx, args: RsmArgs, out: &mut dyn io::Write) -> Result<(), CommandError> {
    match (&args.table, &args.study) {
        (Some(table), _) => {
            let spec = args.table_spec().map_err(CommandError::Usage)?;
            commands::rsm_table(table, &spec, args.json, out)
        }
        (None, Some(study)) => commands::rsm(
            &c.store,
            study,
            &c.exec(&args.exec, args.jobs)?,
            args.json,
            out,
        ),
        (None, None) => Err(CommandError::Usage(
            "rsm: give a study manifest or --table FILE".into(),
        )),
    }
}

/// `repose sensitivity STUDY` or `repose sensitivity --table FILE`.
fn sensitivity(
    c: &Ctx,
    args: SensitivityArgs,
    out: &mut dyn io::Write,
) -> Result<(), CommandError> {
    match (&args.table, &args.study) {
        (Some(table), _) => commands::sensitivity_table(
            table,
            args.response.as_deref().unwrap_or_default(),
            &args.factors,
            args.json,
            out,
        ),
        (None, Some(study)) => {
            let levels = if args.level.is_empty() {
                Levels::ALL
            } else {
                Levels {
                    one: args.level.contains(&1),
                    two: args.level.contains(&2),
                    three: args.level.contains(&3),
                }
            };
            let exec = c.exec(&args.exec, args.jobs)?;
            commands::sensitivity(&c.store, study, &exec, levels, args.json, out)
        }
        (None, None) => Err(CommandError::Usage(
            "sensitivity: give a study manifest or --table FILE".into(),
        )),
    }
}

/// `repose search STUDY`.
fn search(
    store: &std::path::Path,
    args: SearchArgs,
    out: &mut dyn io::Write,
) -> Result<(), CommandError> {
    let settings = SearchSettings {
        samples: args.samples,
        seed: 0,
        placement: args.placement,
        kernel: args.kernel,
        bandwidth: args.bandwidth,
        quantile: args.quantile,
    };
    commands::search(store, &args.study, &settings, args.seed, out)
}

fn sample(
    store: &std::path::Path,
    args: SampleArgs,
    max_runs: u64,
    out: &mut dyn io::Write,
) -> Result<(), CommandError> {
    let mut err = io::stderr();
    match (&args.diagnose, &args.study) {
        (Some(table), _) => commands::sample_diagnose(
            table,
            args.columns.as_deref(),
            args.max_correlation,
            out,
            &mut err,
        ),
        (None, Some(study)) => {
            let settings = SampleSettings {
                placement: args.placement,
                optimise_iterations: args.optimise_iterations,
                strong_correlation: args.max_correlation,
            };
            commands::sample(store, study, &settings, max_runs, out, &mut err)
        }
        (None, None) => unreachable!("clap requires STUDY or --diagnose"),
    }
}

fn train(
    store: &std::path::Path,
    args: TrainArgs,
    out: &mut dyn io::Write,
) -> Result<(), CommandError> {
    let mut options = args.options();
    match (&args.table, &args.study) {
        (Some(table), _) => {
            let inputs = args.inputs.clone().unwrap_or_default();
            let spec = TableSpec {
                path: table,
                inputs: &inputs,
                target: args.target.as_deref().unwrap_or_default(),
                reference: args.reference.as_deref(),
            };
            let out_dir = args.out.clone().unwrap_or_default();
            options.settings.selection = args.selection().unwrap_or(Selection::Validation);
            commands::train_on_table(&spec, &out_dir, &options, out)
        }
        (None, Some(study)) => {
            commands::train(store, study, &options, args.seed, args.selection(), out)
        }
        (None, None) => unreachable!("clap requires STUDY or --table"),
    }
}

/// `--jobs`, or the number of CPUs.
fn default_jobs(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Refuses to run a build for AVX2 (`.cargo/config.toml` asks for x86-64-v3)
/// on a processor without it, with a message instead of an illegal-instruction crash.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
fn processor_supports_build() -> bool {
    let ok = std::arch::is_x86_feature_detected!("avx2");
    if !ok {
        eprintln!(
            "error: this build of repose uses AVX2 (x86-64-v3, see .cargo/config.toml) and \
             this processor lacks it; delete the rustflags table in .cargo/config.toml and \
             rebuild (results are bit-identical, the engine is slower)"
        );
    }
    ok
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
fn processor_supports_build() -> bool {
    true
}

fn main() -> ExitCode {
    if !processor_supports_build() {
        return ExitCode::from(1);
    }
    match dispatch(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`repose inspect F | head`):
        // nothing failed that it wanted to know about.
        Err(e) if repose::errors::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            let code = e.exit_code();
            // The error and its causes on one report, each cause once, never a
            // backtrace.
            let _ = writeln!(io::stderr(), "error: {}", repose::errors::chain(&e));
            ExitCode::from(code)
        }
    }
}
