//! Clumps: rigid bodies made of overlapping member spheres.
//!
//! A clump approximates a non-spherical particle by a few spheres fixed
//! relative to each other; contacts stay sphere–sphere while the body rolls
//! and interlocks like the shape it approximates. The shapes ([`template`]):
//! validated member lists, the exact mass properties of their union, and
//! their principal-frame, volume-equivalent form that the engine
//! integrates; the bodies' state ([`bodies`]); their free rotation
//! ([`rotation`]). The engine's stages for them are in
//! `dem::simulation`'s stepper (`rigid`).

pub mod bodies;
pub mod rotation;
pub mod template;
