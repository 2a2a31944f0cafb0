//! Lineage records: every stage output names the stage, the repose version, the
//! stage's parameters and the id or sha256 of every input, so any output can be
//! traced back to manifests (a DAG, as DVC keeps).
//!
//! [`records_under`] finds the records of a study's outputs in one order (file
//! names, depth first) for everything that reads them back: `repose audit`
//! and the study report page.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::{Store, StoreError};
use crate::manifest::ContentId;

/// Suffix of lineage records: the record of output `F` is `F.lineage.json`.
pub const LINEAGE_SUFFIX: &str = ".lineage.json";

/// Where an output came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lineage {
    /// The stage that produced the output (e.g. `sample`, `train`).
    pub stage: String,
    /// Version of repose that ran the stage.
    pub repose_version: String,
    /// The stage's own settings.
    pub parameters: serde_json::Value,
    /// Every input, in the order the stage read them.
    pub inputs: Vec<InputRef>,
    /// sha256 (hex) of the output's bytes as the stage wrote them, so an
    /// output edited afterwards is caught by `repose audit` and by a stage
    /// that would reuse it. Absent in records written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_sha256: Option<String>,
}

/// One input of a stage.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputRef {
    /// What the input is to the stage (e.g. `study`, `training_run`).
    pub role: String,
    /// A run/study id, or the path of an input file.
    pub id_or_path: String,
    /// sha256 (hex) of the input's bytes; for a run, its id (the sha256 of its
    /// canonical manifest.json).
    pub sha256: String,
}

impl InputRef {
    /// A reference to a content-addressed manifest (run or study) by id.
    pub fn id(role: impl Into<String>, id: &ContentId) -> InputRef {
        InputRef {
            role: role.into(),
            id_or_path: id.to_string(),
            sha256: id.to_string(),
        }
    }

    /// The run this input names: by its id, or by its `<id>/result.json`.
    pub fn run(&self) -> Option<ContentId> {
        if self.id_or_path == self.sha256 {
            ContentId::parse(&self.sha256)
        } else {
            run_of_result_file(Path::new(&self.id_or_path))
        }
    }

    /// A reference to a file, hashing its current bytes. A file inside
    /// `store_root` is recorded by its path relative to the root, any other by
    /// its absolute path, so `repose audit` finds every input without guessing
    /// where the stage ran from (it looks up relative paths in the audited
    /// store only).
    pub fn file(
        role: impl Into<String>,
        path: &Path,
        store_root: Option<&Path>,
    ) -> Result<InputRef, StoreError> {
        let bytes = std::fs::read(path).map_err(StoreError::io(path))?;
        let shown = match store_root.and_then(|r| path.strip_prefix(r).ok()) {
            Some(inside) => inside.to_path_buf(),
            None => std::path::absolute(path).map_err(StoreError::io(path))?,
        };
        Ok(InputRef {
            role: role.into(),
            id_or_path: shown.display().to_string(),
            sha256: hex::encode(Sha256::digest(&bytes)),
        })
    }
}

impl Lineage {
    /// A record for `stage` with its parameters, no inputs yet, and this build's
    /// version.
    pub fn new(stage: impl Into<String>, parameters: serde_json::Value) -> Lineage {
        Lineage {
            stage: stage.into(),
            repose_version: env!("CARGO_PKG_VERSION").to_string(),
            parameters,
            inputs: Vec::new(),
            output_sha256: None,
        }
    }

    /// Records the sha256 of the output's `bytes`.
    pub fn with_output(mut self, bytes: &[u8]) -> Lineage {
        self.output_sha256 = Some(hex::encode(Sha256::digest(bytes)));
        self
    }

    /// Whether `bytes` are the output this record was written for: true when
    /// they hash to [`Lineage::output_sha256`] (or the record predates it).
    pub fn describes(&self, bytes: &[u8]) -> bool {
        self.output_sha256
            .as_ref()
            .is_none_or(|h| *h == hex::encode(Sha256::digest(bytes)))
    }

    /// Adds an input.
    pub fn with_input(mut self, input: InputRef) -> Lineage {
        self.inputs.push(input);
        self
    }

    /// The lineage file of an output: `<output>.lineage.json` beside it.
    pub fn path_beside(output: &Path) -> PathBuf {
        let mut name = output
            .file_name()
            .map(|n| n.to_os_string())
            .unwrap_or_default();
        name.push(LINEAGE_SUFFIX);
        output.with_file_name(name)
    }

    /// Writes this record atomically beside `output`; returns the path written.
    pub fn write_beside(&self, output: &Path) -> Result<PathBuf, StoreError> {
        let path = Self::path_beside(output);
        let mut bytes = serde_json::to_vec_pretty(self).map_err(|e| StoreError::Corrupt {
            path: path.clone(),
            message: e.to_string(),
        })?;
        bytes.push(b'\n');
        super::write_atomic(&path, &bytes).map_err(StoreError::io(&path))?;
        Ok(path)
    }

    /// Reads a lineage record written by [`Lineage::write_beside`].
    pub fn read_beside(output: &Path) -> Result<Lineage, StoreError> {
        Store::read_json(&Self::path_beside(output))
    }
}

/// Every lineage record under `path` (a directory, walked in name order,
/// depth first), or the record of `path` when it is a file (itself when it is
/// a record). An unreadable directory is an error naming it.
pub fn records_under(path: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let meta = std::fs::metadata(path).map_err(StoreError::io(path))?;
    if meta.is_file() {
        let beside = Lineage::path_beside(path);
        return Ok(if is_record(path) {
            vec![path.to_path_buf()]
        } else if beside.is_file() {
            vec![beside]
        } else {
            Vec::new()
        });
    }
    Ok(files_under(path)?
        .into_iter()
        .filter(|p| is_record(p))
        .collect())
}

/// Whether `path` names a lineage record.
pub fn is_record(path: &Path) -> bool {
    path.to_string_lossy().ends_with(LINEAGE_SUFFIX)
}

/// The output a lineage record describes (`F` for `F.lineage.json`).
pub fn output_of(record: &Path) -> PathBuf {
    let name = record.to_string_lossy();
    PathBuf::from(name.strip_suffix(LINEAGE_SUFFIX).unwrap_or(&name))
}

/// Every file under `dir`, in name order, depth first (a directory's files
/// where its name sorts among its siblings).
pub fn files_under(dir: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(StoreError::io(dir))?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()
        .map_err(StoreError::io(dir))?;
    entries.sort();
    let mut files = Vec::new();
    for entry in entries {
        if entry.is_dir() {
            files.extend(files_under(&entry)?);
        } else {
            files.push(entry);
        }
    }
    Ok(files)
}

/// The run whose result.json `path` is (`[...]/<id>/result.json`), if it is one.
pub fn run_of_result_file(path: &Path) -> Option<ContentId> {
    if path.file_name()? != super::RESULT_FILE {
        return None;
    }
    ContentId::parse(path.parent()?.file_name()?.to_str()?)
}
