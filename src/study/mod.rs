//! Studies as data: a study is design → experiments (× replicates) → one
//! executor → a response table → an analysis → reports, each stage cached in
//! the store and recorded with lineage.
//!
//! - [`executor`]: the one seam through which every stage runs experiments.
//! - [`progress`]: the progress bar of a batch of runs.

pub mod executor;
pub mod progress;
