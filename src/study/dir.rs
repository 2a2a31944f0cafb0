//! A study's output directory in the store and how stages write it: one
//! type for every study document (he2019's calibration study and the design
//! studies), whose stages are named by a [`StageName`].
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

use serde::Serialize;

use super::plan::design_study::DesignStudy;
use super::StudyError;
use crate::manifest::{canonical_json, ContentId, Study};
use crate::store::{write_atomic, InputRef, Lineage, StoreError};

/// The study document's file in its directory: the canonical JSON whose
/// sha256 is the study id.
pub const STUDY_FILE: &str = "study.json";
/// A study document: what names its directory and what `study.json` holds.
pub trait StudyDocument: Serialize {
    /// Its short name (the directory's prefix).
    fn name(&self) -> &str;
    /// Its id: sha256 of its canonical JSON.
    fn id(&self) -> ContentId;
}

impl StudyDocument for Study {
    fn name(&self) -> &str {
        &self.name
    }
    fn id(&self) -> ContentId {
        Study::id(self)
    }
}

impl StudyDocument for DesignStudy {
    fn name(&self) -> &str {
        &self.name
    }
    fn id(&self) -> ContentId {
        DesignStudy::id(self)
    }
}

/// The fields of a study's JSON outputs that hold measured times (wall or
/// CPU seconds, or a cost derived from them): `noise/noise.json`,
/// `fine/cost.json` and `outcome.json` carry them, so two runs of one study
/// differ there and nowhere else. `repose diff` compares those files without
/// these fields; the Markdown reports that print them (`noise/noise.md`,
/// the learning curve's) are named in the README.
pub const MEASURED_TIME_FIELDS: [&str; 5] = [
    "wall_s_per_run",
    "precision_per_cost_deg2_s",
    "coarse_cpu_s",
    "fine_cpu_s",
    "design_at_fine_size_cpu_s",
];

/// A stage's name: its directory under the study's.
pub trait StageName {
    /// The directory name (`sample`, `rsm`, …).
    fn stage_name(&self) -> &str;
}

impl StageName for &str {
    fn stage_name(&self) -> &str {
        self
    }
}

/// A study's directory (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StudyDir {
    store_root: PathBuf,
    path: PathBuf,
    id: ContentId,
    source: PathBuf,
}

impl StudyDir {
    /// The directory of `study` in the store at `store_root`, created by
    /// nothing yet; `source` is the study file as the user gave it (for
    /// messages).
    pub fn new<S: StudyDocument>(store_root: &Path, study: &S, source: &Path) -> StudyDir {
        StudyDir {
            store_root: store_root.to_path_buf(),
            path: StudyDir::path_in(store_root, study),
            id: study.id(),
            source: source.to_path_buf(),
        }
    }

    /// The directory of a design study, created, with its `study.json`.
    pub fn prepare(store_root: &Path, study: &DesignStudy) -> Result<StudyDir, StudyError> {
        let dir = StudyDir::new(store_root, study, Path::new(&study.name));
        dir.write_study(study)?;
        Ok(dir)
    }

    /// Where `study`'s directory is in the store at `store_root`
    /// (`studies/<name>-<first 12 hex of its id>`), without creating it.
    pub fn path_in<S: StudyDocument>(store_root: &Path, study: &S) -> PathBuf {
        crate::store::study_dir_path(store_root, study.name(), &study.id())
    }

    /// Removes the directory when it holds nothing but its `study.json`: a
    /// study refused before any stage wrote leaves no empty directory in
    /// the store. Best effort (a failure leaves the directory as it was).
    pub fn remove_if_unused(&self) {
        let only_study = std::fs::read_dir(&self.path).is_ok_and(|entries| {
            entries
                .map(|e| e.map(|e| e.file_name()))
                .collect::<Result<Vec<_>, _>>()
                .is_ok_and(|names| names.iter().all(|n| *n == *STUDY_FILE))
        });
        if only_study {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The study id.
    pub fn id(&self) -> &ContentId {
        &self.id
    }

    /// The store root.
    pub fn store_root(&self) -> &Path {
        &self.store_root
    }

    /// The study file as the user gave it.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// `study.json` in the directory.
    pub fn study_file(&self) -> PathBuf {
        self.path.join(STUDY_FILE)
    }

    /// A stage's directory (not created).
    pub fn stage(&self, stage: impl StageName) -> PathBuf {
        self.path.join(stage.stage_name())
    }

    /// A stage's directory, created.
    pub fn create_stage(&self, stage: impl StageName) -> Result<PathBuf, StoreError> {
        let p = self.stage(stage);
        create_dir(&p)?;
        Ok(p)
    }

    /// Creates the directory and writes the study's canonical JSON (the same
    /// bytes are not rewritten).
    pub fn write_study<S: StudyDocument>(&self, study: &S) -> Result<(), StoreError> {
        create_dir(&self.path)?;
        let bytes = canonical_json(study);
        let file = self.study_file();
        if std::fs::read(&file).ok().as_deref() != Some(bytes.as_bytes()) {
            write_atomic(&file, bytes.as_bytes()).map_err(StoreError::io(&file))?;
        }
        Ok(())
    }

    /// [`write_study`](Self::write_study) and the stage's directory.
    pub fn prepare_stage<S: StudyDocument>(
        &self,
        study: &S,
        stage: impl StageName,
    ) -> Result<(), StoreError> {
        self.create_stage(stage)?;
        self.write_study(study)
    }

    /// A lineage record of `stage` with the study as its first input.
    pub fn lineage(&self, stage: impl StageName, parameters: serde_json::Value) -> Lineage {
        Lineage::new(stage.stage_name(), parameters).with_input(InputRef::id("study", &self.id))
    }

    /// An input reference to a file of the store (path relative to the store
    /// root, sha256 of its bytes).
    pub fn input(&self, role: &str, path: &Path) -> Result<InputRef, StoreError> {
        InputRef::file(role, path, Some(&self.store_root))
    }
}

/// The stages, in pipeline order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// `repose sample`.
    Sample,
    /// `repose batch`.
    Batch,
    /// `repose train`.
    Train,
    /// `repose search`.
    Search,
    /// `repose verify`.
    Verify,
    /// `repose learning-curve` (reads the batch; not part of `calibrate`).
    LearningCurve,
    /// `repose noise`: the noise floor of a noise-aware study.
    Noise,
    /// The adaptive rounds of `repose calibrate --adaptive`.
    Adaptive,
    /// `repose fine`: the fine level of a two-level study.
    Fine,
    /// `repose transfer`: the verified candidates at finer sizes.
    Transfer,
}

impl Stage {
    /// The stage's name (its subcommand and its directory).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Sample => "sample",
            Stage::Batch => "batch",
            Stage::Train => "train",
            Stage::Search => "search",
            Stage::Verify => "verify",
            Stage::LearningCurve => "learning-curve",
            Stage::Noise => "noise",
            Stage::Adaptive => "adaptive",
            Stage::Fine => "fine",
            Stage::Transfer => "transfer",
        }
    }
}

impl StageName for Stage {
    fn stage_name(&self) -> &str {
        self.name()
    }
}

impl StudyDir {
    /// `path` if it exists with the bytes its stage wrote (the sha256 in its
    /// lineage record, when the record has one), else the error telling which
    /// stage to run: an output edited since its stage ran is never read.
    pub(crate) fn require(&self, path: PathBuf, stage: Stage) -> Result<PathBuf, StudyError> {
        if path.is_file() {
            let bytes = std::fs::read(&path).map_err(StoreError::io(&path))?;
            if let Ok(lineage) = crate::store::Lineage::read_beside(&path) {
                if !lineage.describes(&bytes) {
                    return Err(StudyError::Inconsistent {
                        path,
                        message: format!(
                            "changed since its stage wrote it (sha256 in its lineage record): \
                             rerun `repose {}`",
                            stage.name()
                        ),
                    });
                }
            }
            Ok(path)
        } else {
            Err(StudyError::MissingStage {
                missing: path,
                stage: stage.name().to_string(),
                study: self.source().to_path_buf(),
            })
        }
    }
}

/// Every he2019 stage output that another stage or command reads: the one
/// place a file's path is decided, so a reader never imports its writer.
impl StudyDir {
    /// `sample/experiments/<index>.json`: one sample's experiment manifest.
    pub fn experiment_path(&self, index: usize) -> PathBuf {
        self.stage(Stage::Sample)
            .join("experiments")
            .join(format!("{index:04}.json"))
    }

    /// `sample/design.csv`: the sampled parameter sets.
    pub fn design_path(&self) -> PathBuf {
        self.stage(Stage::Sample).join("design.csv")
    }

    /// `noise/noise.csv`: the noise floor's runs.
    pub fn noise_runs_path(&self) -> PathBuf {
        self.stage(Stage::Noise).join("noise.csv")
    }

    /// `noise/noise.json`: the noise floor.
    pub fn noise_path(&self) -> PathBuf {
        self.stage(Stage::Noise).join("noise.json")
    }

    /// `batch/angles.csv`: each design point's (replicate-mean) angle.
    pub fn angles_path(&self) -> PathBuf {
        self.stage(Stage::Batch).join("angles.csv")
    }

    /// `batch/replicates.csv`: every replicate run of the design.
    pub fn replicates_path(&self) -> PathBuf {
        self.stage(Stage::Batch).join("replicates.csv")
    }

    /// `train/gp.json`: the trained Gaussian process.
    pub fn gp_path(&self) -> PathBuf {
        self.stage(Stage::Train).join("gp.json")
    }

    /// `adaptive/replicates.csv`: the points the adaptive rounds ran.
    pub fn adaptive_path(&self) -> PathBuf {
        self.stage(Stage::Adaptive).join("replicates.csv")
    }

    /// `fine/two_level.json`: the two-level Gaussian process.
    pub fn two_level_path(&self) -> PathBuf {
        self.stage(Stage::Fine).join("two_level.json")
    }

    /// `search/clusters.csv`: the search's candidates.
    pub fn clusters_path(&self) -> PathBuf {
        self.stage(Stage::Search).join("clusters.csv")
    }

    /// `verify/verification.csv`: each candidate's verdict in every scene.
    pub fn verification_path(&self) -> PathBuf {
        self.stage(Stage::Verify).join("verification.csv")
    }

    /// `verify/acceptance.json`: the acceptance record, written before the runs.
    pub fn acceptance_path(&self) -> PathBuf {
        self.stage(Stage::Verify).join("acceptance.json")
    }

    /// `verify/runs.csv`: every verified candidate's runs in every scene.
    pub fn verify_runs_path(&self) -> PathBuf {
        self.stage(Stage::Verify).join("runs.csv")
    }

    /// `transfer/plan.json`: the transfer test's sizes, rule and candidates,
    /// written before its runs.
    pub fn transfer_plan_path(&self) -> PathBuf {
        self.stage(Stage::Transfer).join("plan.json")
    }

    /// `transfer/transfer.csv`: each candidate's verdict per scene and size.
    pub fn transfer_path(&self) -> PathBuf {
        self.stage(Stage::Transfer).join("transfer.csv")
    }
}

pub(crate) fn create_dir(path: &Path) -> Result<(), StoreError> {
    std::fs::create_dir_all(path).map_err(StoreError::io(path))
}

/// Writes an output atomically, then its lineage record beside it with the
/// output's sha256.
pub fn write_output(path: &Path, bytes: &[u8], lineage: &Lineage) -> Result<(), StudyError> {
    if let Some(parent) = path.parent() {
        create_dir(parent)?;
    }
    write_atomic(path, bytes).map_err(StoreError::io(path))?;
    lineage.clone().with_output(bytes).write_beside(path)?;
    Ok(())
}

/// `value` as pretty JSON with a final newline: the bytes of every JSON stage
/// output.
pub fn json_bytes<T: Serialize>(value: &T) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(value).expect("stage outputs serialise");
    bytes.push(b'\n');
    bytes
}
