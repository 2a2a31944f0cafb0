//! Topics, schemas and message encodings of the run log.
//!
//! Scene topics carry Foxglove's protobuf schemas (from the `foxglove` crate);
//! scalar traces carry small JSON-schema messages (`json` encoding) that
//! Foxglove's Plot panel reads as `/trace/<name>.value`.

use foxglove::messages::Timestamp;
use serde::Serialize;

/// `foxglove.SceneUpdate`: one entity `particles` of spheres per frame.
pub const PARTICLES_TOPIC: &str = "/particles";
/// `foxglove.PointCloud` with fields x, y, z, radius, speed (float32), used
/// instead of spheres above [`super::LogOptions::sphere_limit`] particles.
pub const CLOUD_TOPIC: &str = "/particles/cloud";
/// `foxglove.SceneUpdate`: one entity `wall/<index>` (a triangle list) per wall.
pub const WALLS_TOPIC: &str = "/walls";
/// `repose.Angle` (JSON): left, right and mean angle of repose, fit R².
pub const ANGLE_TOPIC: &str = "/trace/angle";

/// Frame of every message.
pub const FRAME_ID: &str = "world";

/// Name of the metadata record that holds the manifest.
pub const MANIFEST_METADATA: &str = "repose.manifest";
/// Name of the manifest attachment.
pub const MANIFEST_ATTACHMENT: &str = "manifest.json";
/// Media type of the manifest attachment.
pub const MANIFEST_MEDIA_TYPE: &str = "application/json";
/// Header `library` string: fixed, so files do not change with the repose version
/// (which the manifest metadata records instead).
pub const LIBRARY: &str = "repose";

/// Name of the JSON schema of scalar traces.
pub const SCALAR_SCHEMA: &str = "repose.Scalar";
/// Name of the JSON schema of angle traces.
pub const ANGLE_SCHEMA: &str = "repose.Angle";

/// JSON schema of a scalar trace message: `{"value": number}`.
pub const SCALAR_SCHEMA_JSON: &str = r#"{"title":"repose.Scalar","type":"object","properties":{"value":{"type":"number","description":"The traced quantity (unit in the channel metadata); null when not finite"}},"required":["value"]}"#;

/// JSON schema of an angle trace message.
pub const ANGLE_SCHEMA_JSON: &str = r#"{"title":"repose.Angle","type":"object","properties":{"left_deg":{"type":"number","description":"Angle of the left flank, degrees"},"right_deg":{"type":"number","description":"Angle of the right flank, degrees"},"mean_deg":{"type":"number","description":"Mean of left and right, degrees"},"fit_r2":{"type":"number","description":"Coefficient of determination of the flank line fits"}},"required":["left_deg","right_deg","mean_deg","fit_r2"]}"#;

/// A scalar trace: one topic each, message `{"value": v}` (JSON).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Trace {
    /// Translational plus rotational kinetic energy, J.
    KineticEnergy,
    /// Contacts carrying force (particle–particle plus particle–wall).
    Contacts,
    /// Largest overlap over the smaller radius.
    MaxOverlapRatio,
    /// Particles discharged so far.
    Discharged,
    /// Discharge mass flow rate, kg/s.
    FlowRate,
}

impl Trace {
    /// Every trace, in a fixed order.
    pub const ALL: [Trace; 5] = [
        Trace::KineticEnergy,
        Trace::Contacts,
        Trace::MaxOverlapRatio,
        Trace::Discharged,
        Trace::FlowRate,
    ];

    /// The trace's topic.
    pub fn topic(self) -> &'static str {
        match self {
            Trace::KineticEnergy => "/trace/kinetic_energy",
            Trace::Contacts => "/trace/contacts",
            Trace::MaxOverlapRatio => "/trace/max_overlap_ratio",
            Trace::Discharged => "/trace/discharged",
            Trace::FlowRate => "/trace/flow_rate",
        }
    }

    /// Unit of the value (channel metadata key `unit`; `1` for counts and ratios).
    pub fn unit(self) -> &'static str {
        match self {
            Trace::KineticEnergy => "J",
            Trace::FlowRate => "kg/s",
            Trace::Contacts | Trace::MaxOverlapRatio | Trace::Discharged => "1",
        }
    }
}

/// A scalar trace message.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ScalarMessage {
    /// The value (JSON `null` when not finite).
    pub value: Option<f64>,
}

/// An angle-of-repose sample (message of [`ANGLE_TOPIC`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct AngleSample {
    /// Angle of the left flank, degrees.
    pub left_deg: f64,
    /// Angle of the right flank, degrees.
    pub right_deg: f64,
    /// Mean of left and right, degrees.
    pub mean_deg: f64,
    /// Coefficient of determination of the flank line fits.
    pub fit_r2: f64,
}

/// Why a time cannot be a log time.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("simulation time {0} s is not a log time (finite, 0 to 4.29e9 s expected)")]
pub struct BadTime(pub f64);

/// Simulation time (s) as log time (ns, rounded).
pub fn time_ns(t_s: f64) -> Result<u64, BadTime> {
    let ns = (t_s * 1e9).round();
    if t_s.is_finite() && (0.0..=f64::from(u32::MAX) * 1e9).contains(&ns) {
        Ok(ns as u64)
    } else {
        Err(BadTime(t_s))
    }
}

/// Log time (ns) as a Foxglove timestamp.
pub fn timestamp(ns: u64) -> Timestamp {
    // time_ns keeps the seconds within u32.
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_round_to_nanoseconds() {
        assert_eq!(time_ns(0.0), Ok(0));
        assert_eq!(time_ns(1.5e-9), Ok(2));
        assert_eq!(time_ns(2.25), Ok(2_250_000_000));
        assert!(time_ns(-1.0).is_err());
        assert!(time_ns(f64::NAN).is_err());
        assert!(time_ns(1e12).is_err());
        let t = timestamp(2_250_000_001);
        assert_eq!((t.sec(), t.nsec()), (2, 250_000_001));
    }

    #[test]
    fn schemas_are_json() {
        for s in [SCALAR_SCHEMA_JSON, ANGLE_SCHEMA_JSON] {
            serde_json::from_str::<serde_json::Value>(s).unwrap();
        }
    }

    #[test]
    fn scalar_messages_encode_non_finite_as_null() {
        let m = ScalarMessage { value: None };
        assert_eq!(serde_json::to_string(&m).unwrap(), r#"{"value":null}"#);
    }
}
