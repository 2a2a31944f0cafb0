//! Numerical health: what stops a run, and the error naming particle, step,
//! time and cause.
//!
//! Checked every step: non-finite state, overlap beyond a bound relative to
//! the smaller radius, particles leaving the (non-periodic) domain. Checked
//! every [`ENERGY_CHECK_INTERVAL`] steps in a closed, undriven, non-cohesive
//! system (no moving walls, no insertion or removal since the reference was
//! taken, no JKR): the mechanical energy (kinetic + gravitational + Hertz
//! elastic) must not grow by more than [`HealthLimits::energy_growth`]. A
//! cohesive system is excluded because adhesion legitimately converts surface
//! energy into kinetic energy.

use crate::dem::vec3::Vec3;

/// Steps between two energy checks.
pub const ENERGY_CHECK_INTERVAL: u64 = 100;

/// Thresholds of the health checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthLimits {
    /// Largest allowed overlap / smaller radius of the contact (dimensionless).
    pub max_overlap_ratio: f64,
    /// Largest allowed relative growth of the mechanical energy of a closed,
    /// undriven system over its reference (dimensionless).
    pub energy_growth: f64,
}

impl Default for HealthLimits {
    /// 0.3 (a 30 % overlap is far outside Hertz theory; healthy packings stay
    /// below 1–5 %) and 1 % energy growth.
    fn default() -> Self {
        Self {
            max_overlap_ratio: 0.3,
            energy_growth: 0.01,
        }
    }
}

/// What went wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum HealthCause {
    /// Position, velocity or angular velocity became NaN or infinite.
    NonFinite,
    /// An overlap exceeded the bound; `partner` names the other particle id or
    /// wall index.
    Overlap {
        /// Overlap / smaller radius.
        ratio: f64,
        /// The bound.
        limit: f64,
        /// The other body.
        partner: String,
    },
    /// The particle left the domain through a non-periodic face.
    LeftDomain {
        /// Where it was, m.
        position: Vec3,
    },
    /// The neighbour search failed (e.g. a periodic box too small for the cutoff).
    NeighborSearch(String),
    /// Mechanical energy of a closed, undriven system grew.
    EnergyGrowth {
        /// Energy now, J.
        energy_j: f64,
        /// Reference energy, J.
        reference_j: f64,
    },
}

/// A run stopped by a health check.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("unhealthy simulation at step {step} (t = {time_s:.6e} s), particle {particle_id}: {}", describe(.cause))]
pub struct HealthError {
    /// Stable id of the (first) offending particle (lowest index for ties).
    pub particle_id: u32,
    /// Step number at which the check failed.
    pub step: u64,
    /// Simulated time, s.
    pub time_s: f64,
    /// The cause.
    pub cause: HealthCause,
}

fn describe(c: &HealthCause) -> String {
    match c {
        HealthCause::NonFinite => "position or velocity is not finite".into(),
        HealthCause::Overlap { ratio, limit, partner } => format!(
            "overlap {ratio:.3} of the radius with {partner} exceeds the bound {limit} (time step too large for the impact speed, or stiffness too low)"
        ),
        HealthCause::LeftDomain { position } => format!(
            "left the domain at ({:.6}, {:.6}, {:.6}) m",
            position.x, position.y, position.z
        ),
        HealthCause::NeighborSearch(e) => format!("neighbour search failed: {e}"),
        HealthCause::EnergyGrowth { energy_j, reference_j } => format!(
            "mechanical energy of a closed, undriven system grew from {reference_j:.6e} J to {energy_j:.6e} J"
        ),
    }
}
