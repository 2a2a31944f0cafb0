//! The study's record of what it handed to Slurm, in its `slurm/` directory:
//!
//! ```text
//! slurm/
//!   manifests/<id>.json        canonical manifest of every experiment submitted
//!   logs/<job>_<task>.log      each task's stdout and stderr
//!   submissions/<n>/           one per sbatch call, n = 1, 2, …
//!     job.sh                   the job script (sbatch it by hand after --dry-run)
//!     tasks.txt                manifest path of array task i on line i + 1
//!     submission.json          job name, Slurm job id (null until submitted), ids
//! ```
//!
//! `submission.json` is written before `sbatch` runs and again with the job id
//! after it returns, so a client killed in between — or a user who submitted
//! a `--dry-run` script by hand — leaves a submission whose job is found by
//! its unique name in `squeue`. Every file is written atomically; a
//! submission number is claimed by creating its directory, so two clients
//! never share one.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::super::ExecError;
use crate::manifest::ContentId;
use crate::store::write_atomic;

/// One `sbatch` call: an array of K tasks, task i running `ids[i]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Submission {
    /// Its number in the study (1, 2, …).
    pub number: u32,
    /// The job name (`repose-<study dir>-<number>`), unique per submission.
    pub job_name: String,
    /// Slurm's job id of the array; `None` until sbatch returned it.
    pub job_id: Option<String>,
    /// The experiment of each array task.
    pub ids: Vec<ContentId>,
}

/// The `slurm/` directory of one study (see the module docs).
#[derive(Debug, Clone)]
pub struct Ledger {
    dir: PathBuf,
}

impl Ledger {
    /// The ledger in `dir` (created on first write).
    pub fn new(dir: impl Into<PathBuf>) -> Ledger {
        Ledger { dir: dir.into() }
    }

    /// Its directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where the tasks' logs go.
    pub fn logs(&self) -> PathBuf {
        self.dir.join("logs")
    }

    /// The log of task `task` of array job `job`.
    pub fn log(&self, job: &str, task: usize) -> PathBuf {
        self.logs().join(format!("{job}_{task}.log"))
    }

    /// Where experiment `id`'s manifest is written for the tasks.
    pub fn manifest(&self, id: &ContentId) -> PathBuf {
        self.dir
            .join("manifests")
            .join(format!("{}.json", id.as_str()))
    }

    /// The directory of submission `number`.
    pub fn submission_dir(&self, number: u32) -> PathBuf {
        self.dir.join("submissions").join(number.to_string())
    }

    /// Every submission, in order; none when the directory does not exist.
    pub fn submissions(&self) -> Result<Vec<Submission>, ExecError> {
        let root = self.dir.join("submissions");
        let entries = match std::fs::read_dir(&root) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(io_error(&root, e)),
        };
        let mut out = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| io_error(&root, e))?;
            let file = entry.path().join("submission.json");
            if entry.file_name().to_string_lossy().parse::<u32>().is_err() || !file.is_file() {
                continue;
            }
            let bytes = std::fs::read(&file).map_err(|e| io_error(&file, e))?;
            let s: Submission = serde_json::from_slice(&bytes).map_err(|e| {
                ExecError::Slurm(format!("{}: not a submission record: {e}", file.display()))
            })?;
            out.push(s);
        }
        out.sort_by_key(|s| s.number);
        Ok(out)
    }

    /// Claims the next submission number by creating its directory (a
    /// concurrent client that took the same number makes this one try the
    /// next).
    pub fn claim_number(&self) -> Result<u32, ExecError> {
        let root = self.dir.join("submissions");
        for dir in [&self.dir, &root, &self.logs(), &self.dir.join("manifests")] {
            std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
        }
        let mut number = self.submissions()?.last().map_or(1, |s| s.number + 1);
        loop {
            let dir = self.submission_dir(number);
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(number),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => number += 1,
                Err(e) => return Err(io_error(&dir, e)),
            }
        }
    }

    /// Writes `submission.json` of `s` (atomically).
    pub fn record(&self, s: &Submission) -> Result<(), ExecError> {
        let path = self.submission_dir(s.number).join("submission.json");
        let mut bytes = serde_json::to_vec_pretty(s).expect("a submission serialises");
        bytes.push(b'\n');
        write(&path, &bytes)
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), ExecError> {
    write_atomic(path, bytes).map_err(|e| io_error(path, e))
}

fn io_error(path: &Path, e: std::io::Error) -> ExecError {
    ExecError::Slurm(format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(c: char) -> ContentId {
        ContentId::parse(&c.to_string().repeat(64)).unwrap()
    }

    #[test]
    fn submissions_are_numbered_recorded_and_read_back_in_order() {
        let tmp = tempfile::tempdir().unwrap();
        let ledger = Ledger::new(tmp.path().join("slurm"));
        assert!(ledger.submissions().unwrap().is_empty());
        for k in 0..11u32 {
            let n = ledger.claim_number().unwrap();
            assert_eq!(n, k + 1);
            ledger
                .record(&Submission {
                    number: n,
                    job_name: format!("repose-x-{n}"),
                    job_id: n.is_multiple_of(2).then(|| (100 + n).to_string()),
                    ids: vec![id('a'), id('b')],
                })
                .unwrap();
        }
        let all = ledger.submissions().unwrap();
        let numbers: Vec<u32> = all.iter().map(|s| s.number).collect();
        assert_eq!(
            numbers,
            (1..=11).collect::<Vec<_>>(),
            "numeric, not lexical"
        );
        assert_eq!(all[1].job_id.as_deref(), Some("102"));
        assert_eq!(all[0].job_id, None);
        // A number whose directory exists but has no record yet (a client
        // between claim and record) is skipped, not reused.
        std::fs::create_dir(ledger.submission_dir(12)).unwrap();
        assert_eq!(ledger.claim_number().unwrap(), 13);
    }
}
