//! The `repose` command line: parses arguments (clap) and calls one library
//! function per subcommand; prints one error report and exits 2 for invalid input,
//! 1 for a runtime failure.

use std::io;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use repose::commands::{self, CommandError, KindArg};
use repose::store::{DEFAULT_STORE, STORE_ENV};

/// Reproducible calibration of DEM particle parameters against angle-of-repose tests.
#[derive(Parser)]
#[command(name = "repose", version, about)]
struct Cli {
    /// Root of the run store.
    #[arg(long, global = true, env = STORE_ENV, default_value = DEFAULT_STORE)]
    store: PathBuf,
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
    /// Run an experiment (or reuse its cached result).
    Run {
        /// Experiment manifest.
        manifest: PathBuf,
    },
    /// Check a run log (run.mcap) and list its channels, counts, times and manifest.
    Inspect {
        /// The MCAP file.
        file: PathBuf,
    },
    /// Inspect the run store.
    Runs {
        #[command(subcommand)]
        command: RunsCommand,
    },
}

#[derive(Subcommand)]
enum RunsCommand {
    /// Table of every run.
    List,
    /// One run, by a unique id prefix.
    Show {
        /// Leading hex digits of the run id.
        prefix: String,
    },
}

fn dispatch(cli: Cli) -> Result<(), CommandError> {
    let mut out = io::stdout().lock();
    match cli.command {
        Command::Hash { file, kind } => commands::hash(&file, kind, &mut out),
        Command::Validate { files, kind } => {
            commands::validate(&files, kind, &mut out, &mut io::stderr())
        }
        Command::Run { manifest } => commands::run(&cli.store, &manifest, &mut out),
        Command::Inspect { file } => commands::inspect(&cli.store, &file, &mut out),
        Command::Runs {
            command: RunsCommand::List,
        } => commands::runs_list(&cli.store, &mut out),
        Command::Runs {
            command: RunsCommand::Show { prefix },
        } => commands::runs_show(&cli.store, &prefix, &mut out),
    }
}

fn main() -> ExitCode {
    match dispatch(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let code = e.exit_code();
            // `{:#}` prints the error and its causes on one report, never a backtrace.
            eprintln!("error: {:#}", anyhow::Error::new(e));
            ExitCode::from(code)
        }
    }
}
