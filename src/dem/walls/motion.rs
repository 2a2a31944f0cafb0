//! Wall kinematics: how a wall moves in time, its rigid pose at a time, and the
//! velocity of its material.
//!
//! Conventions (all SI, world frame):
//! - A wall's geometry is given in its *body frame*, which coincides with the world
//!   frame at t = 0 (and whenever the motion has not started).
//! - The pose maps body to world: `x_world = rotation * x_body + translation`.
//! - The material velocity is a rigid-body field `v(p) = linear + angular × (p − pivot)`.
//!
//! One motion per wall: static, a translation at constant velocity inside a time
//! window, or a rotation at constant rpm about a fixed world axis from a start time on.

use super::{check_finite, check_finite_vec, check_unit, WallError};
use crate::dem::vec3::Vec3;
use nalgebra::{Rotation3, Unit, UnitQuaternion};

/// How a wall moves. Build walls with [`super::Wall::with_motion`], which validates
/// the motion (finite numbers, `end_s >= start_s`, a non-zero axis, normalised).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Motion {
    /// The wall never moves; its material velocity is zero.
    #[default]
    Static,
    /// Translation at a constant velocity inside the window `[start_s, end_s)`.
    ///
    /// Offset at time t: `velocity_m_s * clamp(t − start_s, 0, end_s − start_s)` (m);
    /// material velocity `velocity_m_s` for `start_s <= t < end_s`, else zero.
    /// `end_s` may be `f64::INFINITY` (moves forever once started).
    Translate {
        /// Translation velocity (m/s, world frame).
        velocity_m_s: Vec3,
        /// Time the motion starts (s).
        start_s: f64,
        /// Time the motion stops (s); `>= start_s`, may be infinite.
        end_s: f64,
    },
    /// Rotation about a fixed world axis at a constant rate inside the window
    /// `[start_s, end_s)` (a drum that turns, then stops and stands).
    ///
    /// Angle at time t: `ω · clamp(t − start_s, 0, end_s − start_s)` (rad),
    /// `ω = rpm · 2π / 60`, right-handed about `axis_dir`; material velocity
    /// `ω axis_dir × (p − axis_point)` for `start_s <= t < end_s`, else zero.
    /// `end_s` may be `f64::INFINITY`.
    Rotate {
        /// A point on the rotation axis (m, world frame).
        axis_point: Vec3,
        /// Direction of the rotation axis (unit after validation; any non-zero
        /// vector is accepted and normalised).
        axis_dir: Vec3,
        /// Rotation rate (revolutions per minute); negative turns the other way.
        rpm: f64,
        /// Time the rotation starts (s).
        start_s: f64,
        /// Time the rotation stops (s); `>= start_s`, may be infinite.
        end_s: f64,
    },
}

impl Motion {
    /// Checks every field and returns the motion with `axis_dir` normalised.
    /// Errors name the field as `motion.<field>`.
    pub fn validated(self) -> Result<Motion, WallError> {
        match self {
            Motion::Static => Ok(Motion::Static),
            Motion::Translate {
                velocity_m_s,
                start_s,
                end_s,
            } => {
                check_finite_vec("motion.velocity_m_s", velocity_m_s)?;
                check_finite("motion.start_s", start_s)?;
                check_end(start_s, end_s)?;
                Ok(self)
            }
            Motion::Rotate {
                axis_point,
                axis_dir,
                rpm,
                start_s,
                end_s,
            } => {
                check_finite_vec("motion.axis_point", axis_point)?;
                let axis_dir = check_unit("motion.axis_dir", axis_dir)?;
                check_finite("motion.rpm", rpm)?;
                check_finite("motion.start_s", start_s)?;
                check_end(start_s, end_s)?;
                Ok(Motion::Rotate {
                    axis_point,
                    axis_dir,
                    rpm,
                    start_s,
                    end_s,
                })
            }
        }
    }

    /// True for [`Motion::Static`].
    #[inline]
    pub fn is_static(&self) -> bool {
        matches!(self, Motion::Static)
    }

    /// Rigid pose (body → world) at time `t` (s). One sin/cos pair for rotations;
    /// call once per step, not per particle.
    pub fn pose_at(&self, t: f64) -> WallPose {
        match *self {
            Motion::Static => WallPose::identity(),
            Motion::Translate {
                velocity_m_s,
                start_s,
                end_s,
            } => {
                let dt = (t - start_s).clamp(0.0, end_s - start_s);
                WallPose {
                    rotation: Rotation3::identity(),
                    translation: velocity_m_s * dt,
                }
            }
            Motion::Rotate {
                axis_point,
                axis_dir,
                rpm,
                start_s,
                end_s,
            } => {
                let angle = rpm_to_rad_s(rpm) * (t - start_s).clamp(0.0, end_s - start_s);
                let rotation = Rotation3::from_axis_angle(&Unit::new_unchecked(axis_dir), angle);
                // x_w = a + R (x_b − a) = R x_b + (a − R a)
                WallPose {
                    rotation,
                    translation: axis_point - rotation * axis_point,
                }
            }
        }
    }

    /// Material velocity field at time `t` (s).
    pub fn velocity_at(&self, t: f64) -> WallVelocity {
        match *self {
            Motion::Static => WallVelocity::ZERO,
            Motion::Translate {
                velocity_m_s,
                start_s,
                end_s,
            } => {
                let moving = t >= start_s && t < end_s;
                WallVelocity {
                    linear_m_s: if moving { velocity_m_s } else { Vec3::zeros() },
                    ..WallVelocity::ZERO
                }
            }
            Motion::Rotate {
                axis_point,
                axis_dir,
                rpm,
                start_s,
                end_s,
            } => {
                let omega = if t >= start_s && t < end_s {
                    rpm_to_rad_s(rpm)
                } else {
                    0.0
                };
                WallVelocity {
                    linear_m_s: Vec3::zeros(),
                    angular_rad_s: axis_dir * omega,
                    pivot: axis_point,
                }
            }
        }
    }
}

/// `end_s` must not be NaN and not before `start_s` (it may be +∞).
fn check_end(start_s: f64, end_s: f64) -> Result<(), WallError> {
    if end_s.is_nan() || end_s < start_s {
        return Err(WallError::OutOfRange {
            field: "motion.end_s",
            value: end_s,
            allowed: ">= motion.start_s (may be +infinity)",
        });
    }
    Ok(())
}

/// Converts revolutions per minute to rad/s: `rpm · 2π / 60`.
#[inline]
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * (2.0 * std::f64::consts::PI / 60.0)
}

/// Rigid pose of a wall at one time: body → world, `x_world = rotation * x_body +
/// translation` (translation in m). A logger draws the body-frame shape with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallPose {
    /// Rotation body → world (a proper orthogonal 3×3 matrix).
    pub rotation: Rotation3<f64>,
    /// Translation body → world (m).
    pub translation: Vec3,
}

impl WallPose {
    /// The identity pose (body frame = world frame).
    pub fn identity() -> WallPose {
        WallPose {
            rotation: Rotation3::identity(),
            translation: Vec3::zeros(),
        }
    }

    /// Maps a body-frame point (m) to the world frame.
    #[inline]
    pub fn to_world(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// Maps a body-frame direction to the world frame (rotation only).
    #[inline]
    pub fn to_world_dir(&self, d: Vec3) -> Vec3 {
        self.rotation * d
    }

    /// Maps a world-frame point (m) to the body frame (the inverse pose).
    #[inline]
    pub fn to_body(&self, p: Vec3) -> Vec3 {
        self.rotation.inverse() * (p - self.translation)
    }

    /// Maps a world-frame direction to the body frame.
    #[inline]
    pub fn to_body_dir(&self, d: Vec3) -> Vec3 {
        self.rotation.inverse() * d
    }

    /// The rotation as a unit quaternion (the form Foxglove scene poses use).
    pub fn quaternion(&self) -> UnitQuaternion<f64> {
        UnitQuaternion::from_rotation_matrix(&self.rotation)
    }
}

/// Rigid-body velocity field of a wall's material at one time:
/// `v(p) = linear_m_s + angular_rad_s × (p − pivot)` (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallVelocity {
    /// Translational velocity (m/s).
    pub linear_m_s: Vec3,
    /// Angular velocity vector (rad/s, right-handed).
    pub angular_rad_s: Vec3,
    /// A point on the rotation axis (m).
    pub pivot: Vec3,
}

impl WallVelocity {
    /// No motion.
    pub const ZERO: WallVelocity = WallVelocity {
        linear_m_s: Vec3::new(0.0, 0.0, 0.0),
        angular_rad_s: Vec3::new(0.0, 0.0, 0.0),
        pivot: Vec3::new(0.0, 0.0, 0.0),
    };

    /// Velocity of the wall material at world point `p` (m) in m/s.
    #[inline]
    pub fn at(&self, p: Vec3) -> Vec3 {
        self.linear_m_s + self.angular_rad_s.cross(&(p - self.pivot))
    }
}
