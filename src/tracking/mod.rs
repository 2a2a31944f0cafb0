//! Experiment tracking: the questions a user asks of a store of runs and
//! studies, answered from what the store already holds (nothing is run).
//!
//! - [`fields`] — a run as named fields (manifest paths, responses, status),
//!   and the closest known names for a misspelt one.
//! - [`query`] — `--where` filters and `--sort` keys.
//! - [`group`] — replicates (runs that differ only in their packing seed)
//!   folded into one row with each response's mean and 95 % interval.
//! - [`listing`] — `repose runs list` with a query.
//! - [`render`] — a listing as text, CSV or JSON.
//! - [`diff`] — `repose diff A B` of two runs.
//! - [`study_files`] — what a study directory holds (its files, the run ids
//!   its tables name, its stages).
//! - [`study_diff`] — `repose diff A B` of two studies.
//! - [`studies`] — `repose studies`, every study of the store.
//!
//! Tracking sits above [`crate::study`] in the pipeline: it reads the store
//! and the study directories and writes nothing.

pub mod diff;
pub mod fields;
pub mod group;
pub mod listing;
pub mod query;
pub mod render;
pub mod studies;
pub mod study_diff;
pub mod study_files;

pub use listing::{list_runs, ListOptions, Listing};
pub use render::Format;

use crate::store::StoreError;

/// Why a tracking query could not be answered.
#[derive(Debug, thiserror::Error)]
pub enum TrackingError {
    /// A field no run of the store has.
    #[error("unknown field `{field}`; the closest known fields: {}", closest.join(", "))]
    UnknownField {
        /// The field as given.
        field: String,
        /// The closest known field names, closest first.
        closest: Vec<String>,
    },
    /// A `--where` or `--sort` expression that does not parse.
    #[error("`{text}`: {message}")]
    Expression {
        /// The expression as given.
        text: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// A study argument that names no study of the store.
    #[error("`{given}` is no study: not a study directory, nor a prefix of the id or directory name of one in {}", studies.display())]
    NoStudy {
        /// The argument.
        given: String,
        /// The store's studies directory.
        studies: std::path::PathBuf,
    },
    /// A study argument that names several studies.
    #[error("`{given}` is ambiguous; it matches:\n{}", candidates.iter().map(|c| format!("  {c}")).collect::<Vec<_>>().join("\n"))]
    AmbiguousStudy {
        /// The argument.
        given: String,
        /// Every matching study directory name.
        candidates: Vec<String>,
    },
    /// `repose diff` of a run and a study.
    #[error("`{a}` is a {a_kind} and `{b}` a {b_kind}; diff compares two runs or two studies")]
    MixedDiff {
        /// First argument.
        a: String,
        /// What it named.
        a_kind: &'static str,
        /// Second argument.
        b: String,
        /// What it named.
        b_kind: &'static str,
    },
    /// The store failed, or a run prefix did not resolve.
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl TrackingError {
    /// True when the user's input (a field, an expression, a prefix) is at fault.
    pub fn is_invalid_input(&self) -> bool {
        match self {
            TrackingError::Store(e) => e.is_invalid_input(),
            _ => true,
        }
    }
}
