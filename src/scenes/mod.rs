//! Lab-test scenes: geometry, insertion, protocol and measurement.

pub mod pair;
