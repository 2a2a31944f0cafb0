//! The 3-vector type used throughout the engine (metres, m/s, newtons, ... as the
//! field using it says).

/// A 3-component f64 vector (nalgebra's `Vector3<f64>`).
pub type Vec3 = nalgebra::Vector3<f64>;
