//! The soft-sphere DEM engine.
//!
//! Knows nothing of studies, manifests or files: it takes particles, walls, a
//! contact-law choice and a time step, and steps. All quantities are SI.

pub mod domain;
pub mod neighbor;
pub mod vec3;
