//! Numerical health: what stops a run, and the error naming particle, step,
//! time and cause.
//!
//! Checked every step: non-finite state, overlap beyond a bound relative to
//! the smaller radius, particles leaving the (non-periodic) domain, and
//! tunnelling. Checked every [`ENERGY_CHECK_INTERVAL`] steps in a closed,
//! undriven, non-cohesive system (no moving walls, no particles with prescribed
//! kinematics
//! ([`Simulation::prescribe`](crate::dem::simulation::Simulation::prescribe)), no insertion or removal
//! since the reference was taken, no JKR): the mechanical energy (kinetic +
//! gravitational + Hertz elastic) must not grow by more than
//! [`HealthLimits::energy_growth`]. A cohesive system is excluded because
//! adhesion legitimately converts surface energy into kinetic energy.
//!
//! An overlap beyond the bound at step 0 — found by the force evaluation of
//! [`Simulation::new`](crate::dem::simulation::Simulation::new), before any
//! step moved a particle — was placed, not reached: no time step caused it,
//! so its message names the initial placement instead.
//!
//! Tunnelling: a particle that moves farther in one step than the overlap
//! bound times its radius ([`HealthLimits::max_overlap_ratio`], the same
//! bound) stops the run. At that speed the step no longer resolves a contact:
//! a contact entered during the step can start deeper than the overlap bound
//! (against a wall or a particle at rest), and once the relative displacement
//! per step exceeds the sum of the diameters the bodies pass through each
//! other without a single step in contact. The overlap check alone would
//! catch the first only when a step happens to land in the overlap, and
//! never the second: two particles met at 1,000 m/s with a step designed
//! for 0.5 m/s (4.7 radii per step) passed through each other and the run
//! ended with an unrelated complaint (`the contact did not end`, or a
//! particle leaving the domain long after). The test is per particle and
//! per step, inside the drift (a product and a comparison per particle),
//! not per contact, so a particle in free flight is stopped too: whatever it
//! meets next would be under-resolved. A healthy run stays far below: a
//! contact resolved in 10 steps moves each body by about a third of the
//! largest overlap per step, under 0.1 of a radius at the overlap bound;
//! so with a step that resolves the speed, the check fires only where a
//! resolved contact would overlap by more than a radius (the overlap bound
//! would stop such a run a few steps later), and the message says so.

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
    /// wall index. At step 0 the particles were placed overlapping (see the
    /// module docs), which the message says.
    Overlap {
        /// Overlap / smaller radius.
        ratio: f64,
        /// The bound.
        limit: f64,
        /// The other body.
        partner: String,
        /// Where the particle was, m (to find the jam: a wall, a brush, a
        /// funnel throat).
        position: Vec3,
    },
    /// The particle left the domain through a non-periodic face.
    LeftDomain {
        /// Where it was, m.
        position: Vec3,
    },
    /// The neighbour search failed (e.g. a periodic box too small for the cutoff).
    NeighborSearch(String),
    /// The particle moved farther in one step than the overlap bound times
    /// its radius (see the module docs).
    Tunnelling {
        /// Its displacement in that step, m.
        displacement_m: f64,
        /// Its radius, m.
        radius_m: f64,
        /// The bound on displacement / radius.
        limit: f64,
    },
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
#[error("unhealthy simulation at step {step} (t = {time_s:.6e} s), particle {particle_id}{}: {}", member_of(.body_id), describe(.cause, *.step))]
pub struct HealthError {
    /// Stable id of the (first) offending particle (lowest index for ties).
    pub particle_id: u32,
    /// In a world of clumps, the stable id of the body that particle is a
    /// member of (the checks run on every member sphere; the message names
    /// both).
    pub body_id: Option<u32>,
    /// Step number at which the check failed.
    pub step: u64,
    /// Simulated time, s.
    pub time_s: f64,
    /// The cause.
    pub cause: HealthCause,
}

fn member_of(body: &Option<u32>) -> String {
    body.map(|b| format!(" (a member sphere of clump {b})"))
        .unwrap_or_default()
}

/// The cause's message; `step` is the step the check failed at (at step 0
/// nothing has moved yet).
fn describe(c: &HealthCause, step: u64) -> String {
    match c {
        HealthCause::NonFinite => "position or velocity is not finite".into(),
        HealthCause::Overlap {
            ratio,
            limit,
            partner,
            position,
        } => format!(
            "overlap {ratio:.3} of the radius with {partner} at ({:.6}, {:.6}, {:.6}) m exceeds the bound {limit} ({})",
            position.x,
            position.y,
            position.z,
            if step == 0 {
                "before any step moved a particle: the initial placement put them \
                 overlapping, not the time step (a layout too dense for the particles' \
                 shape or size)"
            } else {
                "time step too large for the impact speed, or stiffness too low"
            }
        ),
        HealthCause::LeftDomain { position } => format!(
            "left the domain at ({:.6}, {:.6}, {:.6}) m",
            position.x, position.y, position.z
        ),
        HealthCause::Tunnelling { displacement_m, radius_m, limit } => format!(
            "tunnelling: moved {displacement_m:.4e} m in one step (radius {radius_m:.4e} m, bound {limit} of it), so a contact can be stepped over or entered deeper than the overlap bound — the step is too large for the speed reached: lower the Rayleigh fraction of the time step or raise its design impact speed (if the step already resolves contacts at this speed, the particles are too soft for it)"
        ),
        HealthCause::NeighborSearch(e) => format!("neighbour search failed: {e}"),
        HealthCause::EnergyGrowth { energy_j, reference_j } => format!(
            "mechanical energy of a closed, undriven system grew from {reference_j:.6e} J to {energy_j:.6e} J"
        ),
    }
}
