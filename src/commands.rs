//! One library function per CLI subcommand; `main.rs` only parses arguments and
//! calls these. Each writes its report to the given writer and returns a typed
//! error whose [`CommandError::exit_code`] is 3 while runs wait on Slurm, 2 for invalid input and 1 for a
//! runtime failure.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::audit::{self, AuditError};
use crate::bench::{self, BenchError, BenchOptions};
use crate::doe::diagnostics::Diagnostics;
use crate::exec::slurm::status::StatusReport;
use crate::exec::Executor;
use crate::log::{inspect, InspectError};
use crate::manifest::{
    read_document, read_experiment, ContentId, Document, DocumentKind, Experiment, ManifestError,
    Study,
};
use crate::scenes::plan::{plan as plan_run, Limits, OverLimit, RunPlan};
use crate::scenes::protocol::set_quiet;
use crate::scenes::responses::listing;
use crate::scenes::run_logged;
use crate::store::{
    write_atomic, CacheOutcome, Depth, RunError, RunState, RunStatus, Store, StoreError,
};
use crate::study::analyses::holdout;
use crate::study::analyses::learning_curve;
use crate::study::dir::StudyDir;
use crate::study::plan::calibration::SearchSettings;
use crate::study::plan::design_study::{is_design_study, DesignStudy};
use crate::study::plan::{
    default_candidates, names_adaptive, Analysis, Method, StudyFile, StudySpec,
};
use crate::study::run::{CalibrationSettings, Env, Plan, StageOutcome, Upto};
use crate::study::stages::design::{diagnose_table, SampleSettings};
use crate::study::stages::fit_network::{train_table, TableSpec, TrainOptions};
use crate::study::stages::transfer::TransferSettings;
use crate::study::sweeps::convergence;
use crate::study::sweeps::convergence::plan::{SurfaceEnergyRule, RULE_NAMES};
use crate::study::sweeps::pilot::{self, PilotSpec};
use crate::study::sweeps::tradeoff as tradeoff_sweep;
use crate::study::sweeps::tradeoff::plan::{plan as plan_sweep, study_spec, Knob, PlanError};
use crate::study::{self, StudyError};
use crate::surrogate::ga_bp::Selection;
use crate::tracking::{self, Format, ListOptions, TrackingError};

/// Which kind of manifest a file holds, as chosen on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum KindArg {
    /// Decide by content: an object with `scene` is an experiment, one with
    /// `calibration` a study.
    #[default]
    Auto,
    /// An experiment (one DEM run).
    Experiment,
    /// A calibration study.
    Study,
}

impl KindArg {
    fn kind(self) -> Option<DocumentKind> {
        match self {
            KindArg::Auto => None,
            KindArg::Experiment => Some(DocumentKind::Experiment),
            KindArg::Study => Some(DocumentKind::Study),
        }
    }
}

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// A manifest could not be read, parsed or validated.
    #[error("{}", describe(path, error))]
    Manifest {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        error: ManifestError,
    },
    /// `validate` found invalid files (each was reported as found).
    #[error("{failed} of {total} file(s) failed validation")]
    ValidationFailed {
        /// How many failed.
        failed: usize,
        /// How many were checked.
        total: usize,
    },
    /// The run store failed, or a prefix did not resolve.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// An experiment's estimated cost exceeds the limits (nothing was run).
    #[error("{}: refused: {error}", path.display())]
    OverLimit {
        /// The manifest.
        path: PathBuf,
        /// The estimates above their limits.
        error: OverLimit,
    },
    /// The run itself failed; its error.json says why.
    #[error("run {id} failed: {message}\n(recorded in {})", error_path.display())]
    RunFailed {
        /// The experiment id.
        id: ContentId,
        /// The failure.
        message: String,
        /// Where it is recorded.
        error_path: PathBuf,
    },
    /// `inspect` found a corrupt or mismatched log, or could not read it.
    #[error(transparent)]
    Inspect(#[from] InspectError),
    /// Writing the report failed (e.g. a closed pipe).
    #[error("cannot write output: {0}")]
    Output(#[from] io::Error),
    /// The benchmark failed or its options are invalid.
    #[error("bench: {0}")]
    Bench(#[from] BenchError),
    /// The tradeoff sweep could not be planned (a knob does not apply or makes an
    /// invalid experiment: refused before anything runs).
    #[error("tradeoff: {0}")]
    TradeoffPlan(#[from] PlanError),
    /// A command-line option is malformed (the message names it).
    #[error("{0}")]
    Usage(String),
    /// The audit could not run.
    #[error("audit: {0}")]
    Audit(#[from] AuditError),
    /// The audit ran and found broken links or irreproducible runs.
    #[error("audit found {broken} broken link(s) and {differing} re-run(s) that differ")]
    AuditFailed {
        /// Broken lineage links.
        broken: usize,
        /// Re-runs that did not reproduce their stored outputs.
        differing: usize,
    },
    /// A study stage failed or its options are invalid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// The report page could not be written.
    #[error("report: {0}")]
    Page(#[from] crate::report::page::PageError),
    /// The executor refused the runs (inconsistent plans or over the limits).
    #[error(transparent)]
    Exec(#[from] crate::exec::ExecError),
    /// Runs whose files no longer match their seals (each was named above).
    #[error("{count} damaged run(s); run them again to recompute them")]
    Damaged {
        /// How many.
        count: usize,
    },
    /// A tracking query (`runs list`, `diff`, `studies`) could not be answered.
    #[error(transparent)]
    Tracking(#[from] TrackingError),
    /// Some runs of a batch failed (each recorded in its error.json; the
    /// table was written with their status).
    #[error("{failed} of {total} run(s) failed; rerun `repose batch` to retry them")]
    BatchIncomplete {
        /// Failed runs.
        failed: usize,
        /// Runs in the design.
        total: usize,
    },
}

impl CommandError {
    /// Process exit code: 3 when the runs are on their way on Slurm (queued
    /// with `--no-wait`, or a `--dry-run` script to submit), 2 when the user's
    /// input is at fault, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        let exec = match self {
            CommandError::Exec(e) => Some(e),
            CommandError::Study(StudyError::Exec(e)) => Some(e),
            _ => None,
        };
        if exec.is_some_and(crate::exec::ExecError::is_waiting) {
            return 3;
        }
        let invalid = match self {
            CommandError::Manifest { error, .. } => error.is_invalid_input(),
            CommandError::ValidationFailed { .. } => true,
            CommandError::Store(e) => e.is_invalid_input(),
            CommandError::Inspect(e) => e.is_invalid_input(),
            CommandError::Bench(e) => e.is_invalid_input(),
            CommandError::TradeoffPlan(_)
            | CommandError::Usage(_)
            | CommandError::OverLimit { .. } => true,
            CommandError::Audit(AuditError::Path { .. } | AuditError::NothingToAudit(_)) => true,
            CommandError::Audit(AuditError::Store(e)) => e.is_invalid_input(),
            CommandError::Exec(e) => e.is_invalid_input(),
            CommandError::Study(e) => e.is_invalid_input(),
            CommandError::Page(e) => e.is_invalid_input(),
            CommandError::Tracking(e) => e.is_invalid_input(),
            CommandError::RunFailed { .. }
            | CommandError::Output(_)
            | CommandError::BatchIncomplete { .. }
            | CommandError::Damaged { .. }
            | CommandError::AuditFailed { .. } => false,
        };
        if invalid {
            2
        } else {
            1
        }
    }
}

/// Opens the store at `root` with its notices (a damaged run being
/// recomputed, a wait for another process's claim) printed on stderr.
fn open_store(root: &Path) -> Result<Store, StoreError> {
    Ok(Store::open(root)?.with_notices(Arc::new(|text: &str| eprintln!("note: {text}"))))
}

/// A file-prefixed report of a manifest error: `file:line:column: message` for
/// syntax errors, one indented line per field error for validation errors.
fn describe(path: &Path, error: &ManifestError) -> String {
    let file = path.display();
    match error {
        ManifestError::Syntax {
            line,
            column,
            message,
        } => format!("{file}:{line}:{column}: {message}"),
        ManifestError::Invalid(errors) => {
            let mut s = format!("{file}: {} invalid field(s):", errors.0.len());
            for e in &errors.0 {
                s.push_str("\n  ");
                s.push_str(&e.to_string());
            }
            s
        }
        other => format!("{file}: {other}"),
    }
}

fn manifest_error(path: &Path) -> impl FnOnce(ManifestError) -> CommandError + '_ {
    move |error| CommandError::Manifest {
        path: path.to_path_buf(),
        error,
    }
}

/// Reads and validates a manifest; an experiment must also make a run plan
/// (the scene-and-physics rules of [`crate::scenes::plan`]).
fn read_checked(path: &Path, kind: KindArg) -> Result<Document, ManifestError> {
    let doc = read_document(path, kind.kind())?;
    match &doc {
        Document::Experiment(e) => {
            plan_run(e).map_err(ManifestError::Invalid)?;
        }
        Document::Study(s) => {
            StudyFile::Calibration(s.clone()).spec(None, false)?;
        }
    }
    Ok(doc)
}

/// Reads and validates an experiment and makes its run plan.
fn read_planned(path: &Path) -> Result<(Experiment, RunPlan), CommandError> {
    let experiment = read_experiment(path).map_err(manifest_error(path))?;
    let plan = plan_run(&experiment)
        .map_err(|errors| manifest_error(path)(ManifestError::Invalid(errors)))?;
    Ok((experiment, plan))
}

/// `repose hash FILE`: prints the content id of a valid manifest.
pub fn hash(path: &Path, kind: KindArg, out: &mut dyn Write) -> Result<(), CommandError> {
    if kind != KindArg::Experiment && is_design_study_file(path) {
        let study = StudyFile::read(path).map_err(manifest_error(path))?;
        writeln!(out, "{}", study.id())?;
        return Ok(());
    }
    let doc = read_checked(path, kind).map_err(manifest_error(path))?;
    writeln!(out, "{}", doc.id())?;
    Ok(())
}

/// `repose validate FILE...`: checks every file, reporting each invalid one to
/// `err` as found and each valid one to `out` (`ok <kind> <id> <file>`).
pub fn validate(
    paths: &[PathBuf],
    kind: KindArg,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), CommandError> {
    let mut failed = 0;
    for path in paths {
        match validate_one(path, kind) {
            Ok(line) => writeln!(out, "{line}")?,
            Err(why) => {
                failed += 1;
                writeln!(err, "{why}")?;
            }
        }
    }
    if failed > 0 {
        return Err(CommandError::ValidationFailed {
            failed,
            total: paths.len(),
        });
    }
    Ok(())
}

/// One file of `repose validate`: its `ok <kind> <id> <file>` line, or why
/// it is invalid.
fn validate_one(path: &Path, kind: KindArg) -> Result<String, String> {
    let ok = |kind: &str, id: ContentId| format!("ok {kind} {id} {}", path.display());
    if kind != KindArg::Experiment && is_design_study_file(path) {
        return StudyFile::read(path)
            .map(|study| ok("design-study", study.id()))
            .map_err(|error| describe(path, &error));
    }
    let doc = read_checked(path, kind).map_err(|error| describe(path, &error))?;
    Ok(match doc.kind() {
        DocumentKind::Experiment => ok("experiment", doc.id()),
        DocumentKind::Study => ok("study", doc.id()),
    })
}

/// `repose plan MANIFEST` (and `repose run --dry-run`): validates the
/// experiment and prints its run plan — particles, time step, steps,
/// particle-steps, log size — and whether it is within `limits`, as text or
/// (with `json`) one JSON object. Nothing is run; an estimate above a limit is
/// reported, not an error.
pub fn plan(
    manifest: &Path,
    limits: &Limits,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (experiment, plan) = read_planned(manifest)?;
    let (id, name) = (experiment.id(), manifest.display().to_string());
    if json {
        writeln!(out, "{}", pretty(&plan.json(&id, &name, limits)))?;
    } else {
        write!(out, "{}", plan.text(&id, &name, limits))?;
    }
    Ok(())
}

/// The command's error for a run that could not complete.
fn run_error<E: std::error::Error + 'static>(
    error: RunError<E>,
    manifest: &Path,
    id: &ContentId,
    error_path: &Path,
) -> CommandError {
    let failed = |message: String| CommandError::RunFailed {
        id: id.clone(),
        message,
        error_path: error_path.to_path_buf(),
    };
    match error {
        RunError::Invalid(errors) => CommandError::Manifest {
            path: manifest.to_path_buf(),
            error: ManifestError::Invalid(errors),
        },
        RunError::Store(e) => e.into(),
        RunError::Runner {
            error,
            record_failure,
        } => {
            let mut message = crate::errors::chain(&error);
            if let Some(f) = record_failure {
                message.push_str(&format!(" (and error.json could not be written: {f})"));
            }
            failed(message)
        }
        RunError::BadResult(message) => failed(message),
    }
}

/// `repose run MANIFEST`: validates the experiment, refuses it when it is not
/// complete in the store and its plan exceeds `limits`, and runs it through
/// the store cache (a complete run with the same id is reused). The summary
/// goes to `out`; the result's warnings (computed now or stored with a reused
/// run) go to `err`, one `warning: ...` line each.
pub fn run(
    store_root: &Path,
    manifest: &Path,
    limits: &Limits,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), CommandError> {
    let (experiment, plan) = read_planned(manifest)?;
    let store = open_store(store_root)?;
    let id = experiment.id();
    // A complete run is served from the cache whatever it cost.
    if store.status(&id) != RunStatus::Complete {
        plan.check(limits)
            .map_err(|error| CommandError::OverLimit {
                path: manifest.to_path_buf(),
                error,
            })?;
    }
    let dir = store.run_dir(&id);
    let (result, outcome) = store
        .run_cached(&experiment, run_logged)
        .map_err(|e| run_error(e, manifest, &id, &dir.error_path()))?;
    // The engine's pool: RAYON_NUM_THREADS (a Slurm task sets it from
    // SLURM_CPUS_PER_TASK), else the machine's CPUs.
    let threads = (outcome == CacheOutcome::Computed).then(rayon::current_num_threads);
    write!(out, "{}", result.summary(&id, dir.path(), threads))?;
    for warning in &result.warnings {
        writeln!(err, "warning: run {id}: {warning}")?;
    }
    Ok(())
}

/// `repose bench`: settles the benchmark bed and times each variant; the table
/// (or JSON with `json`) goes to `out`, progress to `progress`.
pub fn bench(
    options: &BenchOptions,
    json: bool,
    out: &mut dyn Write,
    progress: &mut (dyn Write + Send),
) -> Result<(), CommandError> {
    let report = bench::run(options, progress)?;
    if json {
        writeln!(out, "{}", pretty(&report))?;
    } else {
        report.write_table(out)?;
    }
    Ok(())
}

/// `repose responses [SCENE] [--json]`: the named responses of one scene kind
/// (or of all) from [`crate::scenes::responses::listing`], as text (name,
/// unit, description per line under each kind) or JSON (a list of
/// `{"scene", "responses"}` objects). An unknown kind is a usage error.
pub fn responses(scene: Option<&str>, json: bool, out: &mut dyn Write) -> Result<(), CommandError> {
    let listed = listing(scene).map_err(|e| CommandError::Usage(e.to_string()))?;
    if json {
        let doc: Vec<_> = listed
            .iter()
            .map(|(kind, specs)| serde_json::json!({ "scene": kind, "responses": specs }))
            .collect();
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&doc).map_err(io::Error::from)?
        )?;
        return Ok(());
    }
    for (kind, specs) in listed {
        writeln!(out, "{kind}")?;
        for s in specs {
            writeln!(out, "  {:<24} {:<4} {}", s.name, s.unit, s.description)?;
        }
    }
    Ok(())
}

/// `repose runs list`: the runs of the store that `options` select, as a
/// table (by default the classic one: id prefix, scene, profile, the
/// particle–particle restitution, friction and surface energy, status,
/// headline angle), CSV or JSON ([`crate::tracking::listing`]); damaged runs
/// listed make it fail.
pub fn runs_list(
    store_root: &Path,
    options: &ListOptions,
    format: Format,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let listing = tracking::list_runs(&open_store(store_root)?, options)?;
    out.write_all(listing.render(format).as_bytes())?;
    match listing.damaged().len() {
        0 => Ok(()),
        count => Err(CommandError::Damaged { count }),
    }
}

/// `repose diff A B`: what differs between two runs or two studies
/// ([`crate::tracking::diff`]), as text or JSON.
pub fn diff(
    store_root: &Path,
    a: &str,
    b: &str,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let diff = tracking::diff::diff(&open_store(store_root)?, a, b)?;
    print_as(&diff, json, |d| d.text(), out)?;
    // As `runs show`: a damaged run is shown, then reported (exit 1).
    let damaged = match &diff {
        tracking::diff::Diff::Runs(r) => r.status.iter().filter(|s| *s == "damaged").count(),
        tracking::diff::Diff::Studies(_) => 0,
    };
    if damaged > 0 {
        return Err(CommandError::Damaged { count: damaged });
    }
    Ok(())
}

/// `repose studies`: every study of the store with its method, stages, run
/// counts, verdicts and last change ([`crate::tracking::studies`]).
pub fn studies(store_root: &Path, json: bool, out: &mut dyn Write) -> Result<(), CommandError> {
    let entries = tracking::studies::list_studies(&open_store(store_root)?)?;
    print_as(
        &entries,
        json,
        |e| tracking::studies::studies_text(e, store_root),
        out,
    )
}

/// `repose runs show PREFIX`: the run whose id starts with PREFIX (which must be
/// unique): status, directory, manifest, and result or error.
pub fn runs_show(store_root: &Path, prefix: &str, out: &mut dyn Write) -> Result<(), CommandError> {
    let store = open_store(store_root)?;
    let id = store.resolve_prefix(prefix)?;
    let dir = store.run_dir(&id);
    let state = store.check(&id, Depth::Full);
    writeln!(out, "id:        {id}")?;
    writeln!(out, "status:    {}", state.status())?;
    if let RunState::Damaged(problem) = &state {
        writeln!(out, "damage:    {problem}")?;
    }
    writeln!(out, "directory: {}", dir.path().display())?;
    let manifest = std::fs::read_to_string(dir.manifest_path()).ok();
    if let Some(text) = manifest
        .as_deref()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(t).ok())
    {
        writeln!(out, "manifest:\n{}", pretty(&text))?;
    }
    match state {
        RunState::Complete(result) => writeln!(out, "result:\n{}", pretty(&result))?,
        RunState::Damaged(_) => return Err(CommandError::Damaged { count: 1 }),
        _ => {
            if let Some(error) = store.load_error(&id)? {
                writeln!(out, "error:\n{}", pretty(&error))?;
            }
        }
    }
    Ok(())
}

fn pretty<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string_pretty(value).unwrap_or_else(|e| format!("(cannot display: {e})"))
}

/// `repose inspect FILE`: checks a run log (every byte, the embedded manifest
/// against its id and against `<store>/<id>/manifest.json`) and reports its
/// channels, message counts and time range.
pub fn inspect(store_root: &Path, file: &Path, out: &mut dyn Write) -> Result<(), CommandError> {
    Ok(inspect::report(file, store_root, out)?)
}

/// `repose audit PATH`: checks every lineage record under `path` (see
/// [`crate::audit`]) and re-runs `rerun` stored runs chosen with `seed`; fails
/// (exit 1) on any broken link or irreproducible run.
pub fn audit(
    store_root: &Path,
    path: &Path,
    rerun: usize,
    seed: u64,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let store = open_store(store_root)?;
    let report = audit::audit(&store, path, rerun, seed)?;
    write!(out, "{}", report.text())?;
    if report.is_clean() {
        Ok(())
    } else {
        Err(CommandError::AuditFailed {
            broken: report.broken.len(),
            differing: report.reruns.iter().filter(|r| !r.identical()).count(),
        })
    }
}

/// `repose report STUDY`: writes the study's report page
/// ([`crate::report::page`]) into its directory in the store, or into
/// `out_dir`, and prints the page's path.
pub fn report(
    store_root: &Path,
    study_path: &Path,
    out_dir: Option<&Path>,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let dir = match StudyFile::read(study_path).map_err(manifest_error(study_path))? {
        StudyFile::Calibration(study) => StudyDir::path_in(store_root, &study),
        StudyFile::Design(study) => StudyDir::path_in(store_root, &study),
    };
    let page = crate::report::page::write_page(store_root, &dir, out_dir)?;
    writeln!(out, "{}", page.display())?;
    Ok(())
}

/// Options of `repose tradeoff`.
#[derive(Debug, Clone)]
pub struct TradeoffOptions {
    /// Knobs to sweep, each with its values (finest first).
    pub knobs: Vec<Knob>,
    /// Replicates per point (packing seeds), ≥ 2.
    pub replicates: usize,
    /// Output directory (default `<store>/tradeoff/<first 12 hex of the base id>`).
    pub out_dir: Option<PathBuf>,
}

/// `repose tradeoff MANIFEST`: sweeps fidelity knobs around the manifest's
/// scene (see [`crate::study::sweeps::tradeoff`]), writes tradeoff.csv / .md / .svg with a
/// lineage record, and prints the Markdown table.
pub fn tradeoff(
    store_root: &Path,
    manifest: &Path,
    options: &TradeoffOptions,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let base = read_experiment(manifest).map_err(manifest_error(manifest))?;
    let name = manifest.display().to_string();
    study_spec(&name, &base, &options.knobs, options.replicates)
        .check_runs(exec.max_runs)
        .map_err(CommandError::Usage)?;
    let points = plan_sweep(&base, &options.knobs, options.replicates)?;
    let store = open_store(store_root)?;
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| tradeoff_sweep::default_dir(&store, &base));
    let pool = exec.in_study(&out_dir);
    let done = tradeoff_sweep::sweep(
        &store,
        &base,
        manifest,
        &points,
        &options.knobs,
        &pool,
        Some(out_dir),
    )?;
    write!(out, "{}", done.markdown)?;
    writeln!(out, "\nwritten: {}", done.dir.display())?;
    Ok(())
}

/// Options of `repose convergence`.
#[derive(Debug, Clone)]
pub struct ConvergenceOptions {
    /// The sweep.
    pub request: convergence::SweepRequest,
    /// Print the analysis as JSON instead of Markdown.
    pub json: bool,
}

/// `repose convergence MANIFEST`: sweeps the scene over particle sizes with
/// replicates (see [`crate::study::sweeps::convergence`]), writes convergence.csv /
/// .md / .svg with a lineage record, and prints the report.
pub fn convergence(
    store_root: &Path,
    manifest: &Path,
    options: &ConvergenceOptions,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let base = read_experiment(manifest).map_err(manifest_error(manifest))?;
    let store = open_store(store_root)?;
    let (done, out_dir) =
        convergence::plan_and_sweep(&store, &base, manifest, &options.request, exec)?;
    if options.json {
        return print_json(&done.convergence, out);
    }
    write!(out, "{}", done.markdown)?;
    writeln!(out, "\nwritten: {}", out_dir.display())?;
    Ok(())
}

/// `repose pilot STUDY --scene NAME`: the two-level pilot (see
/// [`crate::study::sweeps::pilot`]); writes pilot.md / pilot.json and
/// prints the report (or the JSON).
pub fn pilot(
    store_root: &Path,
    study_path: &Path,
    spec: &PilotSpec,
    exec: &Executor,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let study = read_study(study_path)?;
    let runs = (spec.points as u64)
        .saturating_mul(2)
        .saturating_mul(u64::from(spec.seeds));
    if runs > exec.max_runs {
        return Err(CommandError::Usage(format!(
            "pilot: {runs} runs, more than --max-runs {}",
            exec.max_runs
        )));
    }
    let store = open_store(store_root)?;
    let out_dir = pilot::default_dir(&store, &study.id(), spec);
    let pool = exec.in_study(&out_dir);
    let (done, markdown) = pilot::pilot(&study, study_path, spec, &store, &pool, &out_dir)?;
    if json {
        return print_json(&done, out);
    }
    write!(out, "{markdown}")?;
    writeln!(out, "\nwritten: {}", out_dir.display())?;
    Ok(())
}

/// `repose learning-curve STUDY`: samples the study if it has no design yet,
/// runs the batch (cached, resumable; failed runs are left out), then trains
/// and searches on nested prefixes of the design (see
/// [`crate::study::analyses::learning_curve`]); prints the table.
pub fn learning_curve(
    store_root: &Path,
    study_path: &Path,
    sizes: Option<&[usize]>,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, dir) = open_sized_study(store_root, study_path, exec.max_runs)?;
    learning_curve::check_sizes_of(&study, sizes)?;
    let settings = CalibrationSettings::defaults(&study, default_candidates(&study), false);
    if !dir.design_path().is_file() {
        let design = run_stages(
            store_root,
            &study,
            &dir,
            settings.clone(),
            exec,
            Upto::Only("design"),
            out,
        )?;
        design_warnings(&design, &mut io::stderr())?;
    }
    let runs = run_stages(
        store_root,
        &study,
        &dir,
        settings,
        exec,
        Upto::Only("simulate"),
        out,
    )?;
    failures(&runs, true, out)?;
    let store = open_store(store_root)?;
    let outcome = learning_curve::learning_curve(&dir, &study, &store, sizes)?;
    write!(out, "\n{}", outcome.markdown)?;
    writeln!(out, "\noutputs: {}", outcome.out_dir.display())?;
    Ok(())
}

/// Reads and validates a calibration study manifest, with the stages it
/// spells ([`StudyFile::read`]).
fn read_study(path: &Path) -> Result<Study, CommandError> {
    match StudyFile::read(path).map_err(manifest_error(path))? {
        StudyFile::Calibration(study) => Ok(study),
        StudyFile::Design(_) => Err(CommandError::Usage(format!(
            "{}: a design study (it has a `factors` object); it runs with `repose rsm`, \
             `repose sensitivity` or `repose screen`, not as a calibration study",
            path.display()
        ))),
    }
}

/// [`open_study`] for a command that builds the design or starts runs: a
/// study whose stages may start more than `max_runs` runs is refused first
/// ([`StudySpec::check_runs`]).
fn open_sized_study(
    store_root: &Path,
    path: &Path,
    max_runs: u64,
) -> Result<(Study, StudyDir), CommandError> {
    let (study, dir) = open_study(store_root, path)?;
    let spec = StudySpec::calibration(&study, false, default_candidates(&study));
    spec.check_runs(max_runs).map_err(CommandError::Usage)?;
    Ok((study, dir))
}

/// The store and the executor for a study's runs (their Slurm ledger in
/// `study_dir`), with the runs' own progress lines silenced for the bar.
fn runs_in(
    store_root: &Path,
    study_dir: &Path,
    exec: &Executor,
) -> Result<(Store, Executor), CommandError> {
    let store = open_store(store_root)?;
    set_quiet(true);
    Ok((store, exec.in_study(study_dir)))
}

/// The study and its output directory in the store (its killed writers'
/// leftover temp files removed, [`sweep_old_temps`]).
fn open_study(store_root: &Path, path: &Path) -> Result<(Study, StudyDir), CommandError> {
    let study = read_study(path)?;
    let dir = study_dir(store_root, &study, path)?;
    Ok((study, dir))
}

/// The output directory of `study` (read from `path`), its killed writers'
/// leftover temp files removed.
fn study_dir(store_root: &Path, study: &Study, path: &Path) -> Result<StudyDir, CommandError> {
    let dir = StudyDir::new(store_root, study, path);
    sweep_old_temps(dir.path())?;
    Ok(dir)
}

/// Removes the temp files a killed process left in a study's tree (older
/// than [`crate::store::STALE_TEMP_AGE`]: a fresh one may be another
/// client's write in progress), saying how many on stderr.
fn sweep_old_temps(dir: &Path) -> Result<(), CommandError> {
    let removed = crate::store::remove_old_temps(dir, crate::store::STALE_TEMP_AGE)
        .map_err(StoreError::io(dir))?;
    if removed > 0 {
        eprintln!(
            "note: removed {removed} temp file(s) a killed run left in {}",
            dir.display()
        );
    }
    Ok(())
}

/// Prints design diagnostics to `out` and their warnings to `err`.
fn write_diagnostics(
    d: &Diagnostics,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), CommandError> {
    write!(out, "{}", d.text())?;
    for w in &d.warnings {
        writeln!(err, "warning: {w}")?;
    }
    Ok(())
}

/// `repose sample STUDY`: the study's Latin hypercube, one experiment manifest
/// per sample, and the design's diagnostics (their warnings on `err`).
/// A study that may start more than `max_runs` runs is refused before its
/// design is built.
pub fn sample(
    store_root: &Path,
    study_path: &Path,
    settings: &SampleSettings,
    max_runs: u64,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), CommandError> {
    let local = Executor {
        max_runs,
        ..Executor::local(1, Limits::default())
    };
    let set = |_: &Study, s: &mut CalibrationSettings| s.sample = *settings;
    let stages = run_one_stage(store_root, study_path, &local, "design", set, out)?;
    design_warnings(&stages, err)
}

/// Prints the design stage's diagnostics warnings on `err`.
fn design_warnings(stages: &[StageOutcome], err: &mut dyn Write) -> Result<(), CommandError> {
    for stage in stages {
        if let StageOutcome::Design(o) = stage {
            for w in &o.diagnostics.warnings {
                writeln!(err, "warning: {w}")?;
            }
        }
    }
    Ok(())
}

/// A he2019 stage command: `stage` alone on the study at `study_path`
/// (refused first when its stages may start more than `exec.max_runs`
/// runs), every stage's defaults changed by `adjust`, the stage's report
/// on `out`.
fn run_one_stage(
    store_root: &Path,
    study_path: &Path,
    exec: &Executor,
    stage: &'static str,
    adjust: impl FnOnce(&Study, &mut CalibrationSettings),
    out: &mut dyn Write,
) -> Result<Vec<StageOutcome>, CommandError> {
    let (study, dir) = open_sized_study(store_root, study_path, exec.max_runs)?;
    let mut settings = CalibrationSettings::defaults(&study, default_candidates(&study), false);
    adjust(&study, &mut settings);
    run_stages(
        store_root,
        &study,
        &dir,
        settings,
        exec,
        Upto::Only(stage),
        out,
    )
}

/// Runs `upto` of a he2019 study's stage list with `settings` through the
/// one driver ([`crate::study::run`]), each stage's heading and report on
/// `out`.
fn run_stages(
    store_root: &Path,
    study: &Study,
    dir: &StudyDir,
    settings: CalibrationSettings,
    exec: &Executor,
    upto: Upto,
    out: &mut dyn Write,
) -> Result<Vec<StageOutcome>, CommandError> {
    let (store, pool) = runs_in(store_root, dir.path(), exec)?;
    let plan = Plan::calibration(study.clone(), settings);
    let mut log = |line: &str| {
        let _ = writeln!(out, "{line}");
    };
    let env = Env {
        dir,
        store: &store,
        pool: &pool,
        runner: &run_logged,
        log: &mut log,
    };
    Ok(study::run::run(&plan, upto, env)?)
}

/// `repose sample --diagnose TABLE`: design diagnostics of a CSV table.
pub fn sample_diagnose(
    table: &Path,
    columns: Option<&[String]>,
    strong_correlation: f64,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), CommandError> {
    let d = diagnose_table(table, columns, strong_correlation)?;
    writeln!(
        out,
        "diagnostics of {} (each column scaled by its own min-max)",
        table.display()
    )?;
    write_diagnostics(&d, out, err)?;
    if d.degenerate {
        writeln!(out, "  DEGENERATE: columns with rank correlation ±1")?;
    }
    Ok(())
}

/// Switches of `repose calibrate`.
#[derive(Debug, Clone, Copy, Default)]
pub struct CalibrateFlags {
    /// Adaptive rounds after the initial design (noise-aware studies).
    pub adaptive: bool,
    /// Print the outcome as JSON on stdout (stage reports go to stderr).
    pub json: bool,
}

/// `repose calibrate` on a he2019 study ([`crate::study::pipeline`]): stage
/// reports on `out` (stderr with `--json`, which then prints the outcome
/// as JSON on `out`). Failed design runs are noted and left out of
/// training; a failed verification run fails the command after the table.
fn calibrate_study(
    store_root: &Path,
    path: &Path,
    study: &Study,
    exec: &Executor,
    settings: CalibrationSettings,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let dir = study_dir(store_root, study, path)?;
    let (store, pool) = runs_in(store_root, dir.path(), exec)?;
    let plan = Plan::calibration(study.clone(), settings);
    let done = {
        let mut err = io::stderr();
        let sink: &mut dyn Write = if json { &mut err } else { &mut *out };
        let mut log = |line: &str| {
            let _ = writeln!(sink, "{line}");
        };
        let env = Env {
            dir: &dir,
            store: &store,
            pool: &pool,
            runner: &run_logged,
            log: &mut log,
        };
        study::pipeline::calibrate(&plan, env)?
    };
    match &done.outcome {
        Some(outcome) if json => return print_json(outcome, out),
        Some(outcome) => writeln!(
            out,
            "\n{}",
            outcome.summary(&dir.path().join("outcome.json"))
        )?,
        None => {}
    }
    failures(&done.stages, true, out)
}

/// The failed runs of finished `stages`: a design run is noted (training
/// leaves it out and the next run retries it) when `calibrating`, else an
/// error like a failed verification run.
fn failures(
    stages: &[StageOutcome],
    calibrating: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    for stage in stages {
        match stage {
            StageOutcome::Simulate(b) if !b.failures.is_empty() && calibrating => writeln!(
                out,
                "note: {} of {} runs failed (listed above); training leaves them out \
                 and the next calibrate or batch retries them",
                b.failures.len(),
                b.total
            )?,
            StageOutcome::Simulate(b) if !b.failures.is_empty() => {
                return Err(CommandError::BatchIncomplete {
                    failed: b.failures.len(),
                    total: b.total,
                })
            }
            StageOutcome::VerifyCandidates(v) if v.failed_runs > 0 => {
                return Err(CommandError::BatchIncomplete {
                    failed: v.failed_runs,
                    total: v.runs,
                })
            }
            StageOutcome::Transfer(t) if t.failed_runs > 0 => {
                return Err(CommandError::BatchIncomplete {
                    failed: t.failed_runs,
                    total: t.runs,
                })
            }
            _ => {}
        }
    }
    Ok(())
}

/// `repose noise STUDY`: the noise floor of a noise-aware study's
/// calibration response ([`crate::study::stages::noise`]).
pub fn noise(
    store_root: &Path,
    study_path: &Path,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    if let Ok(Document::Experiment(base)) = read_document(study_path, None) {
        return Err(CommandError::Usage(format!(
            "{}: an experiment manifest: give --seeds N to measure its noise over N packing seeds \
             (experiment {})",
            study_path.display(),
            base.id().short(12)
        )));
    }
    run_one_stage(store_root, study_path, exec, "noise", |_, _| {}, out)?;
    Ok(())
}

/// `repose fine STUDY`: the fine stage of a two-level study
/// ([`crate::study::stages::fine`]).
pub fn fine(
    store_root: &Path,
    study_path: &Path,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    run_one_stage(store_root, study_path, exec, "fine", |_, _| {}, out)?;
    Ok(())
}

/// `repose holdout STUDY --pilot FILE --pilot-study FILE`
/// ([`crate::study::analyses::holdout`]); Markdown, or with `json` one object.
pub fn holdout(
    store_root: &Path,
    study_path: &Path,
    pilot: &Path,
    pilot_study: &Path,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, dir) = open_study(store_root, study_path)?;
    let reference = read_study(pilot_study)?;
    let store = open_store(store_root)?;
    let pilot = holdout::read_pilot(pilot)?;
    let h = holdout::holdout(&dir, &study, &store, &pilot, &reference)?;
    if json {
        writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&h).expect("serialises")
        )?;
    } else {
        write!(out, "{}", holdout::markdown(&h))?;
    }
    Ok(())
}

/// `repose noise MANIFEST --seeds N`: one experiment over `seeds` packing
/// seeds, each response's spread and precision per cost
/// ([`crate::study::sweeps::noise_floor`]); Markdown, or with `json` one object.
pub fn scene_noise(
    store_root: &Path,
    manifest: &Path,
    seeds: usize,
    exec: &Executor,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let base = read_experiment(manifest).map_err(manifest_error(manifest))?;
    let name = manifest.display().to_string();
    StudySpec::noise_floor(&name, base.id(), seeds as u64)
        .check_runs(exec.max_runs)
        .map_err(CommandError::Usage)?;
    let store = open_store(store_root)?;
    let exec = exec.in_study(&store_root.join("noise").join(base.id().short(12)));
    set_quiet(true);
    let noise = study::sweeps::noise_floor::scene_noise(&base, seeds, &store, &exec, &run_logged)?;
    print_as(&noise, json, study::sweeps::noise_floor::markdown, out)
}

/// `repose batch STUDY`: runs every sampled experiment not yet complete
/// (`jobs` at a time, each single-threaded) and writes the angle table. The
/// progress bar replaces the runs' own progress lines, which are silenced.
/// Fails with [`CommandError::BatchIncomplete`] when any run failed (after
/// every other run has finished and the table is written).
pub fn batch(
    store_root: &Path,
    study_path: &Path,
    exec: &Executor,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let stages = run_one_stage(store_root, study_path, exec, "simulate", |_, _| {}, out)?;
    failures(&stages, false, out)
}

/// `repose train STUDY`: the GA-BP hidden-size sweep on the batch's angles;
/// without `seed`, the genetic algorithm is seeded by the study's design seed,
/// and without `selection` the hidden size is chosen by the study's rule
/// ([`TrainOptions::selection`]).
pub fn train(
    store_root: &Path,
    study_path: &Path,
    options: &TrainOptions,
    seed: Option<u64>,
    selection: Option<Selection>,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, dir) = open_study(store_root, study_path)?;
    let mut settings = CalibrationSettings::defaults(&study, default_candidates(&study), false);
    settings.train = *options;
    settings.train.settings.seed = seed.unwrap_or(study.design.seed);
    settings.train.settings.selection =
        selection.unwrap_or_else(|| TrainOptions::selection(&study));
    let local = Executor::local(1, Limits::default());
    run_stages(
        store_root,
        &study,
        &dir,
        settings,
        &local,
        Upto::Only("fit"),
        out,
    )?;
    Ok(())
}

/// `repose train --table FILE`: the same sweep on a CSV table.
pub fn train_on_table(
    spec: &TableSpec,
    out_dir: &Path,
    options: &TrainOptions,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let outcome = train_table(spec, out_dir, options)?;
    write!(out, "{}", outcome.text())?;
    Ok(())
}

/// `repose search STUDY`: tolerance search over the trained network and
/// mean-shift clusters of the kept points (the Table 2 equivalent); without
/// `seed`, the resampling is seeded by the study's design seed.
pub fn search(
    store_root: &Path,
    study_path: &Path,
    settings: &SearchSettings,
    seed: Option<u64>,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, dir) = open_study(store_root, study_path)?;
    let mut plan = CalibrationSettings::defaults(&study, default_candidates(&study), false);
    plan.search = *settings;
    plan.search.seed = seed.unwrap_or(study.design.seed);
    let local = Executor::local(1, Limits::default());
    run_stages(
        store_root,
        &study,
        &dir,
        plan,
        &local,
        Upto::Only("search"),
        out,
    )?;
    Ok(())
}

/// `repose verify STUDY`: re-simulates the `candidates` largest clusters'
/// centres in the calibration scene and every verification scene (he2019
/// Table 3); prints the table. A candidate outside tolerance, or whose scene
/// cannot measure an angle, is a finding, not an error; any other failed run
/// makes the command fail after the table.
pub fn verify(
    store_root: &Path,
    study_path: &Path,
    exec: &Executor,
    candidates: usize,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    if is_design_study_file(study_path) {
        return rsm(store_root, study_path, exec, false, out);
    }
    let set = |_: &Study, s: &mut CalibrationSettings| s.candidates = candidates;
    let stages = run_one_stage(store_root, study_path, exec, "verify", set, out)?;
    failures(&stages, false, out)
}

/// `repose transfer [STUDY]`: the verified candidates again at finer
/// particle sizes, in every scene, judged by the verification's rule
/// ([`crate::study::stages::transfer`]). `sizes` and `rule` replace the
/// study's `transfer` block; without either, the block's (a study without
/// one needs `--sizes`; its rule is then the measured default,
/// [`SurfaceEnergyRule::MEASURED`]). Without a study, the embedded default.
pub fn transfer(
    store_root: &Path,
    study_path: Option<&Path>,
    exec: &Executor,
    sizes: Option<Vec<f64>>,
    rule: Option<&str>,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let path = match study_path {
        Some(p) => p.to_path_buf(),
        None => write_default_study(store_root, false, out)?,
    };
    let rule = rule
        .map(|name| {
            SurfaceEnergyRule::parse(name).ok_or_else(|| {
                CommandError::Usage(format!(
                    "--rule {name}: allowed rules are {}",
                    RULE_NAMES[..3].join(", ")
                ))
            })
        })
        .transpose()?;
    let study = read_study(&path)?;
    let own = TransferSettings::of_study(&study);
    let Some(sizes) = sizes.or_else(|| own.as_ref().map(|t| t.sizes.clone())) else {
        return Err(CommandError::Usage(format!(
            "{} has no transfer block: give the sizes, e.g. --sizes 0.75,0.5",
            path.display()
        )));
    };
    let rule = rule
        .or(own.map(|t| t.rule))
        .unwrap_or(SurfaceEnergyRule::MEASURED);
    let transfer = TransferSettings { sizes, rule };
    transfer.check(&study)?;
    let set = move |_: &Study, s: &mut CalibrationSettings| s.transfer = Some(transfer);
    let stages = run_one_stage(store_root, &path, exec, "transfer", set, out)?;
    failures(&stages, false, out)
}

/// Whether `path` holds a design study (a `factors` object); unreadable
/// files are not, and fail later with the study reader's error.
fn is_design_study_file(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| is_design_study(&t))
}

/// `repose stages STUDY`: the study's method and stage list
/// ([`crate::study::plan::StudySpec`]), as text or JSON.
pub fn stages(
    path: &Path,
    analysis: Option<Analysis>,
    adaptive: bool,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let document = StudyFile::read(path).map_err(manifest_error(path))?;
    let spec = document
        .spec(analysis, adaptive)
        .map_err(manifest_error(path))?;
    print_as(&spec, json, StudySpec::describe, out)
}

/// `repose status STUDY`: where every run the study handed to Slurm stands
/// (see [`crate::exec::slurm::status`]); a table, or with `json` one object.
/// For an experiment manifest, the same for its noise floor (`repose noise
/// MANIFEST --seeds N`) and its tradeoff sweep (default output directory),
/// each that has a ledger (JSON: `{"noise": …, "tradeoff": …}`).
pub fn status(
    store_root: &Path,
    study_path: &Path,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    if let Ok(Document::Experiment(base)) = read_document(study_path, None) {
        return status_of_manifest(store_root, &base, json, out);
    }
    let dir = if is_design_study_file(study_path) {
        let (study, _) = open_design_study(store_root, study_path)?;
        study::dir::StudyDir::path_in(store_root, &study)
    } else {
        open_study(store_root, study_path)?.1.path().to_path_buf()
    };
    let store = open_store(store_root)?;
    let report = crate::exec::slurm::status::status(&store, dir.join("slurm"))?;
    if json {
        return print_json(&report, out);
    }
    write_status(&report, out)
}

/// `repose status MANIFEST`: the Slurm ledgers of the manifest's noise floor
/// and tradeoff sweep.
fn status_of_manifest(
    store_root: &Path,
    base: &Experiment,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let reports = manifest_ledgers(store_root, base)?;
    if json {
        let map: serde_json::Map<String, serde_json::Value> = reports
            .iter()
            .map(|(what, r)| Ok((what.to_string(), serde_json::to_value(r)?)))
            .collect::<Result<_, serde_json::Error>>()
            .map_err(io::Error::from)?;
        return print_json(&map, out);
    }
    for (what, report) in &reports {
        writeln!(out, "{what} of experiment {}:", base.id().short(12))?;
        match report {
            Some(r) => write_status(r, out)?,
            None => writeln!(out, "  (nothing submitted to Slurm)")?,
        }
    }
    Ok(())
}

/// The Slurm status of `base`'s noise floor and tradeoff sweep, each `None`
/// when nothing of it was submitted to Slurm.
fn manifest_ledgers(
    store_root: &Path,
    base: &Experiment,
) -> Result<Vec<(&'static str, Option<StatusReport>)>, CommandError> {
    let store = open_store(store_root)?;
    let ledgers = [
        ("noise", store_root.join("noise").join(base.id().short(12))),
        ("tradeoff", tradeoff_sweep::default_dir(&store, base)),
    ];
    let mut reports = Vec::new();
    for (what, dir) in ledgers {
        let slurm = dir.join("slurm");
        let report = slurm
            .is_dir()
            .then(|| crate::exec::slurm::status::status(&store, slurm))
            .transpose()?;
        reports.push((what, report));
    }
    Ok(reports)
}

/// A status report as text.
fn write_status(report: &StatusReport, out: &mut dyn Write) -> Result<(), CommandError> {
    write!(out, "{}", report.text())?;
    if report.runs.is_empty() {
        writeln!(
            out,
            "(nothing submitted to Slurm yet: run a stage with --executor slurm)"
        )?;
    }
    Ok(())
}

/// The design study at `path` and the store; a readable JSON file without a
/// `factors` object is refused with what the stage needs (an unreadable or
/// malformed one gets the reader's error).
/// [`open_design_study`] for a command that starts runs, with `exec` set to
/// keep its Slurm files in the study's directory: a study whose `analysis`
/// stages may start more than `exec.max_runs` runs is refused before
/// anything is built ([`StudySpec::check_runs`]).
fn open_design_run(
    store_root: &Path,
    path: &Path,
    analysis: Analysis,
    exec: &Executor,
) -> Result<(DesignStudy, Store, Executor), CommandError> {
    let (study, store) = open_design_study(store_root, path)?;
    StudyFile::Design(study.clone())
        .spec(Some(analysis), false)
        .map_err(manifest_error(path))?
        .check_runs(exec.max_runs)
        .map_err(CommandError::Usage)?;
    let exec = exec.in_study(&study::dir::StudyDir::path_in(store_root, &study));
    Ok((study, store, exec))
}

fn open_design_study(store_root: &Path, path: &Path) -> Result<(DesignStudy, Store), CommandError> {
    let not_design = || {
        CommandError::Usage(format!(
            "{}: not a design study (it has no `factors` object); screen, rsm and \
             design-study verify need one (see experiments/cai2024-quick/study.json); \
             he2019 calibration studies run with `repose calibrate`",
            path.display()
        ))
    };
    let text = std::fs::read_to_string(path).map_err(|source| {
        manifest_error(path)(ManifestError::Io {
            path: path.to_path_buf(),
            source,
        })
    })?;
    // Said before any validation error of the other format.
    if serde_json::from_str::<serde_json::Value>(&text).is_ok() && !is_design_study(&text) {
        return Err(not_design());
    }
    let StudyFile::Design(study) = StudyFile::parse(&text).map_err(manifest_error(path))? else {
        return Err(not_design());
    };
    let store = open_store(store_root)?;
    sweep_old_temps(&study::dir::StudyDir::path_in(store_root, &study))?;
    set_quiet(true);
    Ok((study, store))
}

/// Prints `value` as pretty JSON with `json`, else the text `text` makes
/// of it.
fn print_as<T: serde::Serialize>(
    value: &T,
    json: bool,
    text: impl FnOnce(&T) -> String,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    if json {
        print_json(value, out)
    } else {
        Ok(out.write_all(text(value).as_bytes())?)
    }
}

fn print_json<T: serde::Serialize>(value: &T, out: &mut dyn Write) -> Result<(), CommandError> {
    // Buffered: standard output flushes at every line, and pretty JSON of a
    // million verdicts has tens of millions of lines.
    let mut buffered = io::BufWriter::new(&mut *out);
    serde_json::to_writer_pretty(&mut buffered, value).map_err(io::Error::from)?;
    writeln!(buffered)?;
    buffered.flush()?;
    Ok(())
}

/// `repose rsm STUDY`: the design's runs, the response-surface analysis with
/// ANOVA, the joint optimum and its verification (see [`crate::study`]);
/// prints the summary (or the whole analysis as JSON) and fails when a
/// verification run failed.
pub fn rsm(
    store_root: &Path,
    study_path: &Path,
    pool: &Executor,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, store, pool) =
        open_design_run(store_root, study_path, Analysis::ResponseSurface, pool)?;
    let report = study::run_rsm(store_root, &study, &store, &pool, &run_logged)?;
    if json {
        print_json(&report, out)?;
    } else {
        let summary = std::fs::read_to_string(report.rsm.dir.join("rsm.md"))
            .map_err(StoreError::io(&report.rsm.dir))?;
        write!(out, "{summary}")?;
        if let Some(v) = &report.verification {
            writeln!(out)?;
            write!(
                out,
                "{}",
                study::stages::verify_optimum::markdown(&study, v)
            )?;
        }
        writeln!(
            out,
            "\nwritten: {}",
            report.rsm.dir.parent().unwrap_or(&report.rsm.dir).display()
        )?;
    }
    Ok(())
}

/// `repose verdict --table FILE`: the acceptance rule on any CSV table of
/// replicates.
pub fn verdict_table(
    path: &Path,
    spec: &study::analyses::verdict_table::VerdictSpec,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let verdicts = study::analyses::verdict_table::judge_table(path, spec)?;
    print_as(
        &verdicts,
        json,
        study::analyses::verdict_table::markdown,
        out,
    )
}

/// `repose rsm --table FILE`: the response-surface analysis of any CSV table.
pub fn rsm_table(
    path: &Path,
    spec: &study::stages::rsm::TableSpec,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let analysis = study::stages::rsm::analyse_table(path, spec)?;
    if json {
        print_json(&analysis, out)
    } else {
        write!(
            out,
            "{}",
            study::stages::rsm::table_markdown(path, &analysis)
        )?;
        Ok(())
    }
}

/// `repose sensitivity STUDY`: yan2015's three levels (see
/// [`crate::study::stages::sensitivity`]); prints the summary (or everything as
/// JSON) and fails when a run of the named points failed.
pub fn sensitivity(
    store_root: &Path,
    study_path: &Path,
    pool: &Executor,
    levels: study::stages::sensitivity::Levels,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, store, pool) =
        open_design_run(store_root, study_path, Analysis::Sensitivity, pool)?;
    let outcome = study::run_sensitivity(store_root, &study, &store, &pool, &run_logged, levels)?;
    if json {
        print_json(&outcome, out)?;
    } else {
        let summary = std::fs::read_to_string(outcome.dir.join("sensitivity.md"))
            .map_err(StoreError::io(&outcome.dir))?;
        write!(out, "{summary}")?;
        if let Some(v) = &outcome.verification {
            writeln!(out)?;
            write!(
                out,
                "{}",
                study::stages::verify_optimum::markdown(&study, v)
            )?;
        }
        writeln!(out, "\nwritten: {}", outcome.dir.display())?;
    }
    Ok(())
}

/// `repose sensitivity --table FILE`: the level-1 power-law fit of one
/// column of any CSV table; `--json` prints the whole fit at full precision.
pub fn sensitivity_table(
    path: &Path,
    response: &str,
    factors: &[String],
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let fit = study::stages::sensitivity::level1::fit_table(path, response, factors)?;
    if json {
        print_json(&fit, out)
    } else {
        write!(
            out,
            "{}",
            study::stages::sensitivity::level1::table_markdown(&fit)
        )?;
        Ok(())
    }
}

/// `repose screen STUDY`: the one-factor tests (see [`crate::study::stages::screen`]).
pub fn screen(
    store_root: &Path,
    study_path: &Path,
    pool: &Executor,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let (study, store, pool) =
        open_design_run(store_root, study_path, Analysis::ResponseSurface, pool)?;
    let outcome = study::run_screen(store_root, &study, &store, &pool, &run_logged)?;
    if json {
        print_json(&outcome, out)
    } else {
        write!(out, "{}", study::stages::screen::markdown(&study, &outcome))?;
        Ok(())
    }
}

/// The study `repose calibrate` runs without an argument: he2019's PU powder,
/// ranges, targets and tolerance at the quick profile (funnel calibration,
/// baffle and drum verification, 45 samples), sized to finish in under 30
/// minutes on 2 cores; what it gives up against the paper is in its
/// description and experiments/he2019-quick/README.md.
pub const DEFAULT_STUDY: &str = include_str!("../experiments/he2019-quick/study.json");

/// `repose calibrate [STUDY]`: sample → batch → train → search → verify with
/// each stage's defaults; without a study, the embedded default is written to
/// `<store>/default-study.json` and calibrated. Failed batch runs (e.g. a pile
/// whose angle is not measurable) are reported and left out of training
/// rather than stopping the chain; a verification run whose angle is not
/// measurable is a failed candidate in the verification table, any other
/// failed verification run fails the command (after the table is written).
pub fn calibrate(
    store_root: &Path,
    study_path: Option<&Path>,
    exec: &Executor,
    candidates: Option<usize>,
    flags: CalibrateFlags,
    out: &mut dyn Write,
) -> Result<(), CommandError> {
    let path = match study_path {
        Some(p) => p.to_path_buf(),
        None => write_default_study(store_root, flags.json, out)?,
    };
    let study = read_study(&path)?;
    let adaptive = flags.adaptive || names_adaptive(&study.stages);
    let flags = CalibrateFlags { adaptive, ..flags };
    let candidates = candidates.unwrap_or_else(|| default_candidates(&study));
    StudySpec::calibration(&study, adaptive, candidates)
        .check_runs(exec.max_runs)
        .map_err(CommandError::Usage)?;
    match Method::of_calibration(&study) {
        Method::He2019 if adaptive || flags.json => Err(CommandError::Usage(format!(
            "--adaptive and --json need a noise-aware study (a `noise_aware` block); {} has none",
            path.display()
        ))),
        _ => {
            let settings = CalibrationSettings::defaults(&study, candidates, adaptive);
            calibrate_study(store_root, &path, &study, exec, settings, flags.json, out)
        }
    }
}

/// Writes the embedded default study to `<store>/default-study.json` and
/// says so (on stderr with `--json`, whose stdout is the outcome).
fn write_default_study(
    store_root: &Path,
    json: bool,
    out: &mut dyn Write,
) -> Result<PathBuf, CommandError> {
    std::fs::create_dir_all(store_root).map_err(StoreError::io(store_root))?;
    let p = store_root.join("default-study.json");
    write_atomic(&p, DEFAULT_STUDY.as_bytes()).map_err(StoreError::io(&p))?;
    let note = format!("calibrating the embedded default study ({})", p.display());
    if json {
        eprintln!("{note}");
    } else {
        writeln!(out, "{note}")?;
    }
    Ok(p)
}
