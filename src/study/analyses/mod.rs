//! Analyses: read a finished study (or a table) and run nothing but
//! what they re-train.
//!
//! - [`learning_curve`]: the surrogate re-trained on nested prefixes of a
//!   design (`repose learning-curve`).
//! - [`holdout`]: a study's fine-level predictions against a pilot's
//!   held-out fine runs (`repose holdout`).
//! - [`verdict_table`]: the acceptance rule on any table (`repose verdict`).

pub mod holdout;
pub mod learning_curve;
pub mod verdict_table;
