//! Clumps: rigid bodies made of overlapping member spheres.
pub mod bodies;
pub mod rotation;
pub mod template;
