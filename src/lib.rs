//! repose — reproducible calibration of discrete element method (DEM) particle
//! parameters against angle-of-repose tests.
//!
//! Module map (dependencies point downward only):
//! - [`commands`]: one function per CLI subcommand (the binary only parses arguments).
//! - [`tracking`]: queries over the store: runs filtered, sorted and grouped
//!   over seeds, the diff of two runs or two studies, the list of studies.
//! - [`study`]: studies as data — one study model whose methods are stage
//!   lists (he2019's sample, batch, train, search, verify; the design
//!   studies' screen, rsm, sensitivity, verify; the noise floor; the
//!   tradeoff sweep), each run through [`exec`] into a response table.
//! - [`exec`]: the one executor seam: runs experiments through the store, on
//!   this machine's worker pool or as Slurm job arrays (`--executor slurm`).
//! - [`mod@bench`]: the engine throughput benchmark (`repose bench`).
//! - [`doe`]: designs of experiments as pure functions (Latin hypercubes,
//!   Box–Behnken, full factorial, one-factor-at-a-time) and their diagnostics.
//! - [`scenes`]: runs an experiment's scene and produces its result; its
//!   [`scenes::plan`] checks and prices a run before it starts.
//! - [`log`]: MCAP run logs for Foxglove (writing, and `repose inspect`).
//! - [`report`]: the one report writer: CSV tables (`csv` crate), Markdown
//!   tables, the golden-pinned hand-written SVG plots and newer `plotters` plots.
//! - [`store`]: the content-addressed run store (`runs/<id>/`), atomic writes,
//!   caching, lineage records.
//! - [`manifest`]: the experiment model (experiments and studies), validation,
//!   canonical JSON and sha256 ids.
//! - [`measure`]: angles, profiles and flow rates as pure functions of particle
//!   snapshots (synthetic-pile tested).
//! - [`packing`]: size distributions, non-overlapping insertion, rate factories,
//!   coarse-graining rules.
//! - [`dem`]: the soft-sphere DEM engine; knows nothing of studies, manifests or files.
//! - [`stats`]: statistics as pure functions on slices (confidence intervals,
//!   least squares, response surfaces, ANOVA); knows nothing of runs or files.
//! - `huge_pages` (Linux): the binary's global allocator, huge pages for big arrays.

pub mod audit;
pub mod bench;
pub mod commands;
pub mod dem;
pub mod doe;
pub mod errors;
pub mod exec;
#[cfg(target_os = "linux")]
pub mod huge_pages;
pub mod log;
pub mod manifest;
pub mod measure;
pub mod packing;
pub mod report;
pub mod scenes;
pub mod search;
pub mod stats;
pub mod store;
pub mod streams;
pub mod study;
pub mod surrogate;
pub mod tracking;
