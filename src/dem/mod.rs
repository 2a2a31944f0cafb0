//! The soft-sphere DEM engine.
//!
//! Knows nothing of studies, manifests or files: it takes particles, walls, a
//! contact-law choice and a time step, and steps. All quantities are SI.
//!
//! Pipeline of one step ([`simulation`]): kick and drift, neighbour update
//! ([`neighbor`]), pair forces ([`contact`]), gather with walls ([`walls`]),
//! body force and second kick, health checks ([`health`]); inside a run of
//! steps the gather also performs the next kick and drift.

pub mod clump;
pub mod contact;
pub mod domain;
pub mod effects;
pub mod health;
pub mod lanes;
pub mod material;
pub mod neighbor;
pub mod particles;
pub mod simulation;
pub mod timestep;
pub mod vec3;
pub mod walls;
