//! Measurements: angles, profiles and flow rates as pure functions of particle
//! snapshots (positions in m, radii in m, velocities in m/s; z is up).
//!
//! Every function takes plain slices, so it is tested on synthetic packings with a
//! known geometry, and returns either a number with its fit diagnostics (R², points
//! used) or a [`MeasureError`] saying why the snapshot is not measurable — never a
//! NaN and never a panic.
//!
//! Surface points are always extracted the same way ([`profile`]): the particles are
//! projected on a vertical plane, the horizontal coordinate is cut into bins, and the
//! highest particle top (centre height + radius) in each bin is one surface point
//! (its horizontal coordinate is the particle centre's). This is what a side image
//! shows (he2019 §2.2, Fig. 4): the silhouette of the pile.
//!
//! - [`fit`]: least-squares lines, R², angle of a slope.
//! - [`pile`]: he2019 pile profile angle (left, right, mean) and cai2024's
//!   tan(angle) = 2H/D.
//! - [`cone`]: the whole pile surface, seen from above, fitted as one cone
//!   with a free axis (every surface particle at every azimuth).
//! - [`ortho`]: yan2015 ortho-slice angles (xz and yz slabs, four angles).
//! - [`drum`]: rotating-drum free-surface angle.
//! - [`baffle`]: he2019 §3.6.1 baffle-lift slope.
//! - [`flow`]: yan2015 discharge flow rate and mean speed in a window.
//! - [`series`]: mean and standard deviation of an angle trace.

pub mod baffle;
pub mod cone;
pub mod drum;
pub mod fit;
pub mod flow;
pub mod ortho;
pub mod pile;
pub mod profile;
pub mod series;
#[cfg(test)]
mod synthetic;

use crate::dem::vec3::Vec3;

/// Why a snapshot (or a series) cannot be measured. Every message starts with
/// "not measurable" so a result file can show it as the value of the measurement.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasureError {
    /// The snapshot (or the selected part of it) holds no particles.
    #[error("not measurable: no particles in {what}")]
    NoParticles {
        /// What was empty (the snapshot, a slab, a window).
        what: &'static str,
    },
    /// Positions and radii (or velocities) have different lengths.
    #[error("not measurable: {what} has {found} entries but there are {expected} positions")]
    LengthMismatch {
        /// Which slice is off.
        what: &'static str,
        /// Its length.
        found: usize,
        /// The number of positions.
        expected: usize,
    },
    /// A particle has a non-finite coordinate or a radius that is not positive.
    #[error("not measurable: particle {index} has a non-finite position or a radius that is not a positive number")]
    BadParticle {
        /// Index of the offending particle.
        index: usize,
    },
    /// A parameter of the measurement is out of range.
    #[error("not measurable: parameter {name} = {value} is invalid ({allowed})")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// The pile is too low to have flanks (no pile, a single layer, a flat bed).
    #[error("not measurable: height {height_m:.3e} m is below the minimum {min_m:.3e} m (no pile, or a flat bed)")]
    TooFlat {
        /// Height found, m.
        height_m: f64,
        /// Minimum height, m.
        min_m: f64,
    },
    /// A fit has too few surface points.
    #[error("not measurable: {what} has {found} surface points, at least {needed} are needed")]
    TooFewPoints {
        /// The fitted profile (e.g. "left flank").
        what: &'static str,
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
    /// All points of a fit share one horizontal coordinate (a vertical line).
    #[error("not measurable: the {what} points all have the same horizontal coordinate")]
    VerticalLine {
        /// The fitted profile.
        what: &'static str,
    },
    /// A time series is empty, unsorted, or does not cover the requested time.
    #[error("not measurable: {0}")]
    Series(String),
}

/// Checks a snapshot: same lengths, at least one particle, finite positions,
/// positive finite radii.
pub(crate) fn check_snapshot(positions: &[Vec3], radii: &[f64]) -> Result<(), MeasureError> {
    if radii.len() != positions.len() {
        return Err(MeasureError::LengthMismatch {
            what: "radii",
            found: radii.len(),
            expected: positions.len(),
        });
    }
    if positions.is_empty() {
        return Err(MeasureError::NoParticles {
            what: "the snapshot",
        });
    }
    for (index, (p, &r)) in positions.iter().zip(radii).enumerate() {
        let finite = p.iter().all(|c| c.is_finite());
        if !finite || !r.is_finite() || r <= 0.0 {
            return Err(MeasureError::BadParticle { index });
        }
    }
    Ok(())
}

/// Checks that a parameter is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<(), MeasureError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(MeasureError::BadParameter {
            name,
            value,
            allowed: "a finite number > 0",
        })
    }
}

/// Checks that a parameter is finite.
pub(crate) fn check_finite(name: &'static str, value: f64) -> Result<(), MeasureError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(MeasureError::BadParameter {
            name,
            value,
            allowed: "a finite number",
        })
    }
}

/// Checks a window `(lo, hi)`: both finite and `lo < hi`.
pub(crate) fn check_window(name: &'static str, (lo, hi): (f64, f64)) -> Result<(), MeasureError> {
    check_finite(name, lo)?;
    check_finite(name, hi)?;
    if lo < hi {
        Ok(())
    } else {
        Err(MeasureError::BadParameter {
            name,
            value: hi,
            allowed: "a window whose upper end exceeds its lower end",
        })
    }
}

/// Mean particle diameter of a (checked, non-empty) snapshot, m.
pub(crate) fn mean_diameter(radii: &[f64]) -> f64 {
    2.0 * radii.iter().sum::<f64>() / radii.len() as f64
}
