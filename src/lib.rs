//! repose — reproducible calibration of discrete element method (DEM) particle
//! parameters against angle-of-repose tests.
//!
//! Module map (dependencies point downward only):
//! - [`dem`]: the soft-sphere DEM engine; knows nothing of studies, manifests or files.

pub mod dem;
pub mod scenes;
