//! repose — reproducible calibration of discrete element method (DEM) particle
//! parameters against angle-of-repose tests.
//!
//! Module map (dependencies point downward only):
//! - [`commands`]: one function per CLI subcommand (the binary only parses arguments).
//! - [`mod@bench`]: the engine throughput benchmark (`repose bench`).
//! - [`scenes`]: runs an experiment's scene and produces its result.
//! - [`store`]: the content-addressed run store (`runs/<id>/`), atomic writes,
//!   caching, lineage records.
//! - [`manifest`]: the experiment model (experiments and studies), validation,
//!   canonical JSON and sha256 ids.
//! - [`dem`]: the soft-sphere DEM engine; knows nothing of studies, manifests or files.

pub mod bench;
pub mod commands;
pub mod dem;
pub mod manifest;
pub mod scenes;
pub mod store;
