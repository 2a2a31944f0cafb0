//! Sweeps: one experiment (no study file) run over one axis with
//! replicates, each answering what a choice of protocol costs and buys.
//!
//! - [`noise_floor`]: over packing seeds — each response's spread and its
//!   precision per CPU second (`repose noise MANIFEST`).
//! - [`tradeoff`]: over fidelity knobs — what accuracy costs in time
//!   (`repose tradeoff`).
//! - [`convergence`]: over particle size — each response's trend read at
//!   the real particle size, and the cost per run (`repose convergence`).
//! - [`pilot`]: a few points at two particle sizes — whether a two-level
//!   calibration pays in a scene (`repose pilot`).

pub mod convergence;
pub mod noise_floor;
pub mod pilot;
pub mod tradeoff;
