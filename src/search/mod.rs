//! Searches over a fitted surrogate, as pure functions with no file I/O
//! (like [`crate::doe`]): which parameter sets reproduce a target, and how
//! they group.
//!
//! - [`band`]: the shared skeleton of he2019's search — resample the ranges
//!   by a Latin hypercube, keep the points a criterion accepts (the
//!   predicted mean within a tolerance of the target, or the probability of
//!   the band under a predictive sd), cluster the kept points — and the
//!   family report of the kept points;
//! - [`meanshift`]: mean-shift clustering and its bandwidth estimate;
//! - [`acquisition`]: probability of the band and expected improvement;
//! - [`desirability`]: Derringer–Suich desirability and its maximisation
//!   (cai2024's joint optimum of several responses);
//! - [`screen`]: main effects of a surrogate and which parameters move it by
//!   more than the noise (the noise-aware he2019 search's screening).

pub mod acquisition;
pub mod band;
pub mod desirability;
pub mod meanshift;
pub mod screen;
