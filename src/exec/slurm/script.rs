//! The job script of one submission: a bash script with `#SBATCH` lines that
//! runs array task `i` as `repose run` on the `i`-th manifest of the
//! submission's task list, against the shared store.
//!
//! The array range and its throttle are in the script itself (`#SBATCH
//! --array=0-(K-1)%M`), so a script written with `--dry-run` is submitted by
//! hand with a bare `sbatch job.sh`. The task runs `repose run` with the
//! client's limits, so a task refuses exactly what the client would have
//! refused, and with `RAYON_NUM_THREADS` set from `SLURM_CPUS_PER_TASK`, so the
//! simulation uses the CPUs Slurm gave the task (the results do not depend on
//! the thread count). Paths are absolute: tasks start in Slurm's working
//! directory, not the client's.

use std::fmt::Write as _;
use std::path::Path;

use super::SlurmSettings;
use crate::scenes::plan::Limits;

/// Everything one job script names.
pub struct ScriptInputs<'a> {
    /// Cluster options (partition, time, memory, CPUs, account, extra lines, setup).
    pub settings: &'a SlurmSettings,
    /// The limits every task's `repose run` enforces.
    pub limits: &'a Limits,
    /// The store's root (absolute).
    pub store: &'a Path,
    /// The task list: one manifest path per line, line `i + 1` for task `i`.
    pub tasks_file: &'a Path,
    /// Directory of the tasks' logs (`<job>_<task>.log`).
    pub logs: &'a Path,
    /// The job's name (unique per submission: it finds a job submitted by hand).
    pub job_name: &'a str,
    /// Array tasks (K ≥ 1).
    pub tasks: usize,
}

/// The text of the job script.
pub fn job_script(i: &ScriptInputs) -> String {
    let s = i.settings;
    let mut text = String::from("#!/bin/bash\n");
    let _ = writeln!(
        text,
        "# Written by repose {}: array task i runs `repose run` on line i+1 of the task list.",
        env!("CARGO_PKG_VERSION")
    );
    let mut sbatch = |line: String| {
        let _ = writeln!(text, "#SBATCH {line}");
    };
    sbatch(format!("--job-name={}", i.job_name));
    let throttle = s.max_running.map(|m| format!("%{m}")).unwrap_or_default();
    sbatch(format!("--array=0-{}{throttle}", i.tasks - 1));
    sbatch(format!("--output={}/%A_%a.log", i.logs.display()));
    sbatch(format!("--cpus-per-task={}", s.cpus_per_task));
    for (flag, value) in [
        ("partition", &s.partition),
        ("time", &s.time_limit),
        ("mem", &s.mem),
        ("account", &s.account),
    ] {
        if let Some(v) = value {
            sbatch(format!("--{flag}={v}"));
        }
    }
    for line in &s.extra {
        sbatch(line.trim_start_matches("#SBATCH").trim().to_string());
    }
    text.push_str("set -euo pipefail\n");
    if let Some(setup) = &s.setup {
        let _ = writeln!(text, "{setup}");
    }
    let _ = writeln!(
        text,
        "manifest=\"$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" {})\"",
        quote(&i.tasks_file.display().to_string())
    );
    text.push_str("export RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\"\n");
    text.push_str(
        "echo \"task ${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID} on $(hostname): $manifest, \
         ${RAYON_NUM_THREADS} thread(s)\"\n",
    );
    let _ = writeln!(
        text,
        "exec {} --quiet --store {} --max-particles {} --max-particle-steps {} \
         --max-log-bytes {} run \"$manifest\"",
        quote(&s.program),
        quote(&i.store.display().to_string()),
        i.limits.max_particles,
        i.limits.max_particle_steps,
        i.limits.max_log_bytes
    );
    text
}

/// `word` quoted for bash: in single quotes, each `'` as `'\''`.
pub fn quote(word: &str) -> String {
    format!("'{}'", word.replace('\'', r"'\''"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn settings() -> SlurmSettings {
        SlurmSettings {
            program: "repose".into(),
            ..SlurmSettings::default()
        }
    }

    fn script(s: &SlurmSettings, tasks: usize) -> String {
        job_script(&ScriptInputs {
            settings: s,
            limits: &Limits::default(),
            store: Path::new("/shared/store"),
            tasks_file: &PathBuf::from("/shared/store/studies/x/slurm/submissions/1/tasks.txt"),
            logs: Path::new("/shared/store/studies/x/slurm/logs"),
            job_name: "repose-abc",
            tasks,
        })
    }

    #[test]
    fn the_array_and_the_options_are_sbatch_lines() {
        let mut s = settings();
        s.max_running = Some(4);
        s.partition = Some("short".into());
        s.time_limit = Some("02:00:00".into());
        s.mem = Some("4G".into());
        s.account = Some("proj7".into());
        s.cpus_per_task = 8;
        s.extra = vec!["--qos=high".into(), "#SBATCH --exclusive".into()];
        s.setup = Some("module load repose/1.0".into());
        let text = script(&s, 12);
        for line in [
            "#SBATCH --job-name=repose-abc",
            "#SBATCH --array=0-11%4",
            "#SBATCH --output=/shared/store/studies/x/slurm/logs/%A_%a.log",
            "#SBATCH --cpus-per-task=8",
            "#SBATCH --partition=short",
            "#SBATCH --time=02:00:00",
            "#SBATCH --mem=4G",
            "#SBATCH --account=proj7",
            "#SBATCH --qos=high",
            "#SBATCH --exclusive",
            "module load repose/1.0",
        ] {
            assert!(text.lines().any(|l| l == line), "{line} missing:\n{text}");
        }
        // Every #SBATCH line comes before the first command (sbatch stops
        // reading them there).
        let lines: Vec<&str> = text.lines().collect();
        let first_command = lines.iter().position(|l| *l == "set -euo pipefail");
        let last_sbatch = lines.iter().rposition(|l| l.starts_with("#SBATCH"));
        assert!(last_sbatch.unwrap() < first_command.unwrap());
        let last = text.lines().last().unwrap();
        assert!(
            last.starts_with("exec 'repose' --quiet --store '/shared/store' --max-particles "),
            "{last}"
        );
        assert!(last.ends_with(" run \"$manifest\""), "{last}");
    }

    #[test]
    fn unset_options_write_no_line_and_no_throttle() {
        let text = script(&settings(), 1);
        assert!(text.contains("#SBATCH --array=0-0\n"), "{text}");
        for flag in ["--partition", "--time", "--mem", "--account"] {
            assert!(!text.contains(flag), "{flag} in\n{text}");
        }
        assert!(text.contains("#SBATCH --cpus-per-task=1\n"));
        assert!(text.contains("RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\""));
    }

    #[test]
    fn the_script_runs_with_the_clients_limits() {
        let limits = Limits {
            max_particles: 123,
            max_particle_steps: 456,
            max_log_bytes: 789,
        };
        let s = settings();
        let text = job_script(&ScriptInputs {
            settings: &s,
            limits: &limits,
            store: Path::new("/s"),
            tasks_file: Path::new("/s/t.txt"),
            logs: Path::new("/s/logs"),
            job_name: "n",
            tasks: 2,
        });
        assert!(text.contains(
            "--store '/s' --max-particles 123 --max-particle-steps 456 --max-log-bytes 789 run"
        ));
    }

    #[test]
    fn quoting_survives_quotes_and_spaces() {
        assert_eq!(quote("a b"), "'a b'");
        assert_eq!(quote("it's"), r"'it'\''s'");
    }
}
