//! Particle insertion: size distributions, non-overlapping placement in a region,
//! rate factories and coarse-graining rules.
//!
//! Everything random draws from a `rand_chacha::ChaCha8Rng` seeded by the caller
//! (the manifest's packing seed), so the same seed gives the same particles, bit
//! for bit. Insertion never creates an overlap: every new sphere is checked against
//! the existing and the already inserted ones through a cell grid and lies
//! inside its region with the requested clearance ([`region`]).
//!
//! - [`distribution`]: monodisperse, weighted list, log-normal from d10/d50/d90.
//! - [`region`]: box, vertical cylinder, cone frustum (a funnel's inside).
//! - [`place`]: random sequential addition to a count, mass or fill fraction, and
//!   a jittered face-centred lattice for fills random addition cannot reach.
//! - [`factory`]: insertion at a rate (particles per second) into free space.
//! - [`coarse`]: cai2024's and he2019's coarse-graining rules, cohesion number.

pub mod coarse;
pub mod distribution;
pub mod factory;
pub(crate) mod grid;
pub mod place;
pub mod region;

/// Why particles could not be generated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackingError {
    /// A parameter is out of range.
    #[error("{name} = {value} is invalid: {allowed}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// The region cannot hold the target without overlaps.
    #[error(
        "the region holds only {placed} of {requested} particles (solid fraction reached \
         {fill_reached:.3}, asked {fill_requested:.3}); {hint}"
    )]
    RegionFull {
        /// Particles placed before giving up.
        placed: usize,
        /// Particles the target asked for.
        requested: usize,
        /// Solid volume fraction of the region reached.
        fill_reached: f64,
        /// Solid volume fraction the target asked for.
        fill_requested: f64,
        /// What to do about it.
        hint: &'static str,
    },
}

/// Checks that `value` is finite and > 0.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<(), PackingError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(PackingError::BadParameter {
            name,
            value,
            allowed: "a finite number > 0",
        })
    }
}

/// Checks that `value` is finite and >= 0.
pub(crate) fn check_non_negative(name: &'static str, value: f64) -> Result<(), PackingError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(PackingError::BadParameter {
            name,
            value,
            allowed: "a finite number >= 0",
        })
    }
}

/// Volume of a sphere of radius `r`, m³.
pub(crate) fn sphere_volume(r: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * r * r * r
}
