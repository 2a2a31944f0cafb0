//! Designs of experiments: which parameter points to simulate, as pure
//! functions of their settings.
//!
//! - [`lhs`]: Latin hypercubes on the unit cube and their optimisation.
//! - [`diagnostics`]: how well a design fills its unit cube.

pub mod diagnostics;
pub mod lhs;
