//! A design study's output directory in the store and how stages write it.
//!
//! ```text
//! <store>/studies/<name>-<id12>/
//!   study.json              canonical JSON of the study (sha256 = study id)
//!   screen/                 `repose screen`: responses.csv, levels.csv, anova.csv,
//!                           screen.md, <response>.svg
//!   rsm/                    `repose rsm`: responses.csv, <response>/ (anova.csv,
//!                           anova.md, coefficients.csv, fit.json, parity.svg,
//!                           contour.svg), optimum.csv, optimum.md, rsm.md
//!   verify/                 `repose verify`: verification.csv, verification.md
//! ```
//!
//! Beside every output `F` lies `F.lineage.json` ([`Lineage`]): the stage, its
//! settings, the study by id and every run result it read by path and
//! sha256. Files are written atomically; a stage writes its summary table
//! last. Outputs hold no times, hosts or thread counts, so a stage re-run
//! on the same store writes the same bytes.

use std::path::{Path, PathBuf};

use super::spec::DesignStudy;
use super::StudyError;
use crate::manifest::{canonical_json, ContentId};
use crate::store::{write_atomic, InputRef, Lineage, StoreError};

/// A design study's directory (see the module docs).
#[derive(Debug, Clone)]
pub struct StudyDir {
    store_root: PathBuf,
    path: PathBuf,
    id: ContentId,
}

impl StudyDir {
    /// The directory of `study` in the store at `store_root`; creates it and
    /// writes `study.json` (unchanged bytes if already there).
    pub fn prepare(store_root: &Path, study: &DesignStudy) -> Result<StudyDir, StudyError> {
        let id = study.id();
        let path = StudyDir::path_in(store_root, study);
        let dir = StudyDir {
            store_root: store_root.to_path_buf(),
            path,
            id,
        };
        create_dir(&dir.path)?;
        let bytes = canonical_json(study);
        let file = dir.path.join("study.json");
        if std::fs::read(&file).ok().as_deref() != Some(bytes.as_bytes()) {
            write_atomic(&file, bytes.as_bytes()).map_err(StoreError::io(&file))?;
        }
        Ok(dir)
    }

    /// Where `study`'s directory is in the store at `store_root`
    /// (`studies/<name>-<first 12 hex of its id>`), without creating it.
    pub fn path_in(store_root: &Path, study: &DesignStudy) -> PathBuf {
        crate::store::study_dir_path(store_root, &study.name, &study.id())
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A stage's directory (created).
    pub fn stage(&self, stage: &str) -> Result<PathBuf, StudyError> {
        let p = self.path.join(stage);
        create_dir(&p)?;
        Ok(p)
    }

    /// A lineage record of `stage` with the study as its first input.
    pub fn lineage(&self, stage: &str, parameters: serde_json::Value) -> Lineage {
        Lineage::new(stage, parameters).with_input(InputRef::id("study", &self.id))
    }

    /// An input reference to a file of the store (path relative to the store
    /// root, sha256 of its bytes).
    pub fn input(&self, role: &str, path: &Path) -> Result<InputRef, StudyError> {
        Ok(InputRef::file(role, path, Some(&self.store_root))?)
    }
}

pub(crate) fn create_dir(path: &Path) -> Result<(), StudyError> {
    std::fs::create_dir_all(path).map_err(StoreError::io(path))?;
    Ok(())
}

/// Writes an output atomically, then its lineage record beside it.
pub fn write_output(path: &Path, bytes: &[u8], lineage: &Lineage) -> Result<(), StudyError> {
    if let Some(parent) = path.parent() {
        create_dir(parent)?;
    }
    write_atomic(path, bytes).map_err(StoreError::io(path))?;
    lineage.write_beside(path)?;
    Ok(())
}
