//! The experiment model: serde types for experiments and studies, their validation,
//! canonical JSON and sha256 content ids.
//!
//! Reading a manifest is two steps, both here: serde parses the text into typed
//! values (malformed JSON, unknown fields and wrong types are reported with line and
//! column), then [`validate`] checks every physical field and reports all violations
//! together. Only validated manifests get an id.

pub mod address;
pub mod canonical;
pub mod experiment;
pub mod scene;
pub mod study;
pub mod validate;

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde_json::Value;

pub use address::ExperimentDoc;
pub use canonical::{canonical_json, content_id, ContentId};
pub use experiment::{
    AtRest, ClumpMember, CoarseGraining, CoarseGrainingRule, Contact, ContactModel, Experiment,
    Material, NormalModel, PairParams, ParticleMaterial, ParticleShape, Profile, RollingModel,
    Seeds, SizeDistribution, TimeStep, WallMaterial, WallStiffness, PAIR_PARAM_FIELDS,
};
pub use scene::{PairMode, PairScene, Partner, Scene};
pub use study::{
    Adaptive, Design, DesignKind, Fidelity, NoiseAware, ParameterRange, Slot, Study, TargetScene,
    Transfer,
};
pub use validate::{validate_experiment, validate_study, FieldError, ValidationErrors};

/// Version of the manifest format this build reads and writes.
pub const SCHEMA_VERSION: u32 = 1;

/// Version of the engine's physics. It is a hashed field of every experiment, so
/// bump it whenever any result could change: old ids then stop matching and nothing
/// stale is served from the cache.
pub const PHYSICS_VERSION: u32 = 1;

/// Why a manifest could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Malformed JSON, an unknown field, a missing field or a wrong type.
    #[error("line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Neither an experiment nor a study could be recognised.
    #[error(
        "cannot tell what this document is: an experiment has a `scene` field, a study a \
         `calibration` field (or pass --kind)"
    )]
    UnknownKind,
    /// A document of another kind than the command reads (an experiment
    /// given where a study is needed, or the reverse).
    #[error("this is {found}; the command needs {needed}")]
    WrongKind {
        /// What the document is, in words.
        found: &'static str,
        /// What the command reads, in words.
        needed: &'static str,
    },
    /// Well-formed but violates one or more rules.
    #[error("{0}")]
    Invalid(ValidationErrors),
}

/// The experiment, as [`ManifestError::WrongKind`] names it.
pub const AN_EXPERIMENT: &str = "an experiment manifest (it has `scene`)";
/// The calibration study, as [`ManifestError::WrongKind`] names it.
pub const A_CALIBRATION_STUDY: &str = "a calibration study (it has `calibration`)";
/// The design study, as [`ManifestError::WrongKind`] names it.
pub const A_DESIGN_STUDY: &str = "a design study (it has `factors`)";

/// What a JSON document is by its top-level fields, in words, if it is one
/// of the three kinds.
fn kind_in_words(text: &str) -> Option<&'static str> {
    let value: Value = serde_json::from_str(text).ok()?;
    let object = value.as_object()?;
    if object.get("factors").is_some_and(Value::is_object) {
        Some(A_DESIGN_STUDY)
    } else if object.contains_key("calibration") {
        Some(A_CALIBRATION_STUDY)
    } else if object.contains_key("scene") {
        Some(AN_EXPERIMENT)
    } else {
        None
    }
}

/// `text` parsed as `needed`'s type; when that fails on a document of
/// another kind, the error says which kind it is instead of serde's first
/// unknown field.
pub(crate) fn parse_kind<T: DeserializeOwned>(
    text: &str,
    needed: &'static str,
) -> Result<T, ManifestError> {
    parse_typed(text).map_err(|error| match kind_in_words(text) {
        Some(found) if found != needed => ManifestError::WrongKind { found, needed },
        _ => error,
    })
}

impl ManifestError {
    /// True when the input is at fault: always, since a manifest the user
    /// names that cannot be read (missing, a directory, not UTF-8) is bad
    /// input just as a malformed one is (exit 2 from every command).
    pub fn is_invalid_input(&self) -> bool {
        true
    }
}

impl From<serde_json::Error> for ManifestError {
    fn from(e: serde_json::Error) -> ManifestError {
        let (line, column) = (e.line(), e.column());
        let full = e.to_string();
        let suffix = format!(" at line {line} column {column}");
        let message = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
        ManifestError::Syntax {
            line,
            column,
            message,
        }
    }
}

/// The two kinds of manifest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DocumentKind {
    /// One DEM run.
    Experiment,
    /// A calibration study.
    Study,
}

/// A parsed and validated manifest of either kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Document {
    /// An experiment.
    Experiment(Experiment),
    /// A study.
    Study(Study),
}

impl Document {
    /// Which kind it is.
    pub fn kind(&self) -> DocumentKind {
        match self {
            Document::Experiment(_) => DocumentKind::Experiment,
            Document::Study(_) => DocumentKind::Study,
        }
    }

    /// Its content id.
    pub fn id(&self) -> ContentId {
        match self {
            Document::Experiment(e) => e.id(),
            Document::Study(s) => s.id(),
        }
    }

    /// Its canonical JSON.
    pub fn canonical_json(&self) -> String {
        match self {
            Document::Experiment(e) => canonical_json(e),
            Document::Study(s) => canonical_json(s),
        }
    }
}

impl Experiment {
    /// The experiment id: sha256 of its canonical JSON (covers the physics version).
    pub fn id(&self) -> ContentId {
        content_id(self)
    }
}

impl Study {
    /// The study id: sha256 of its canonical JSON.
    pub fn id(&self) -> ContentId {
        content_id(self)
    }
}

fn parse_typed<T: DeserializeOwned>(text: &str) -> Result<T, ManifestError> {
    serde_json::from_str(text).map_err(|e| syntax_error(text, e))
}

/// A JSON error of `text` as a [`ManifestError`], saying what a bare `NaN` or
/// `Infinity` at the error's position is (serde_json says only "expected
/// value"): other JSON writers emit them, and the fix is not obvious.
fn syntax_error(text: &str, error: serde_json::Error) -> ManifestError {
    let mut error = ManifestError::from(error);
    if let ManifestError::Syntax {
        line,
        column,
        message,
    } = &mut error
    {
        let at = text
            .lines()
            .nth(line.saturating_sub(1))
            .and_then(|l| l.get(column.saturating_sub(1)..))
            .unwrap_or("");
        let at = at.trim_start_matches('-');
        if ["NaN", "Infinity", "inf", "nan"]
            .iter()
            .any(|w| at.starts_with(w))
        {
            message.push_str(
                ": JSON has no NaN or Infinity; every number must be finite \
                 (write the value you mean, e.g. 1e30)",
            );
        }
    }
    error
}

/// Parses and validates an experiment manifest.
pub fn parse_experiment(text: &str) -> Result<Experiment, ManifestError> {
    let e: Experiment = parse_kind(text, AN_EXPERIMENT)?;
    validate_experiment(&e).map_err(ManifestError::Invalid)?;
    Ok(e)
}

/// Parses and validates a study manifest.
pub fn parse_study(text: &str) -> Result<Study, ManifestError> {
    let s: Study = parse_kind(text, A_CALIBRATION_STUDY)?;
    validate_study(&s).map_err(ManifestError::Invalid)?;
    Ok(s)
}

/// Parses and validates a manifest of the given kind, or of the kind its content
/// shows when `kind` is `None`: an object with `scene` is an experiment, one with
/// `calibration` a study.
pub fn parse_document(text: &str, kind: Option<DocumentKind>) -> Result<Document, ManifestError> {
    let kind = match kind {
        Some(k) => k,
        None => detect_kind(text)?,
    };
    match kind {
        DocumentKind::Experiment => parse_experiment(text).map(Document::Experiment),
        DocumentKind::Study => parse_study(text).map(Document::Study),
    }
}

fn detect_kind(text: &str) -> Result<DocumentKind, ManifestError> {
    let value: Value = serde_json::from_str(text).map_err(|e| syntax_error(text, e))?;
    let object = value.as_object().ok_or(ManifestError::UnknownKind)?;
    match (
        object.contains_key("scene"),
        object.contains_key("calibration"),
    ) {
        (true, false) => Ok(DocumentKind::Experiment),
        (false, true) => Ok(DocumentKind::Study),
        _ => Err(ManifestError::UnknownKind),
    }
}

fn read_text(path: &Path) -> Result<String, ManifestError> {
    std::fs::read_to_string(path).map_err(|source| ManifestError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads, parses and validates a manifest file (see [`parse_document`]).
pub fn read_document(path: &Path, kind: Option<DocumentKind>) -> Result<Document, ManifestError> {
    parse_document(&read_text(path)?, kind)
}

/// Reads, parses and validates an experiment manifest file.
pub fn read_experiment(path: &Path) -> Result<Experiment, ManifestError> {
    parse_experiment(&read_text(path)?)
}
