//! Run logs: one MCAP file per run (`runs/<id>/run.mcap`) that Foxglove opens
//! directly, byte-identical for identical manifests.
//!
//! # Format
//!
//! - Header: profile `""`, library `repose` (fixed; the version is in the
//!   manifest metadata). Chunked (1 MiB target), zstd level
//!   [`writer::ZSTD_LEVEL`] single-threaded, message indexes, chunk/attachment/
//!   metadata indexes, statistics, summary offsets, every CRC.
//! - Log time = publish time = simulation time in ns; every message in frame
//!   `world`; each channel's sequence counts from 0.
//! - Topics (created on first use, so channel ids follow the order a scene
//!   first writes them):
//!
//! | topic | schema (encoding) | content |
//! |---|---|---|
//! | `/particles` | `foxglove.SceneUpdate` (protobuf) | entity `particles`: a sphere per particle, size = diameter, colour by speed, stable-id order |
//! | `/particles/cloud` | `foxglove.PointCloud` (protobuf) | instead of spheres above [`LogOptions::sphere_limit`]: float32 x, y, z, radius, speed |
//! | `/walls` | `foxglove.SceneUpdate` (protobuf) | entity `wall/<i>` per wall: body-frame triangles + the wall's pose; at the first frame and every frame while any wall moves |
//! | `/trace/kinetic_energy`, `/trace/contacts`, `/trace/max_overlap_ratio`, `/trace/discharged`, `/trace/flow_rate` | `repose.Scalar` (jsonschema / json) | `{"value": v}`, unit in channel metadata `unit` |
//! | `/trace/angle` | `repose.Angle` (jsonschema / json) | `{"left_deg", "right_deg", "mean_deg", "fit_r2"}` |
//!
//! - Metadata `repose.manifest`: `id`, `manifest` (canonical JSON),
//!   `repose_version`, `physics_version`. Attachment `manifest.json`
//!   (`application/json`, log and create time 0) with the same manifest.
//!
//! # Cost
//!
//! A sphere is a `foxglove.SceneUpdate` primitive with position, identity
//! orientation, size and colour as doubles; a point-cloud point is five
//! float32 (20 bytes). A sphere therefore costs several times a cloud point
//! in bytes and in time to write, and Foxglove's 3D panel decodes and draws
//! one primitive per sphere, so above [`writer::SPHERE_LIMIT`] (20 000)
//! particles a frame is a cloud instead. Every log also pays a fixed cost
//! for its temp file, fsync, rename and directory fsync, and carries the
//! `foxglove.SceneUpdate` descriptor twice (data section and summary), which
//! is most of a short run's log.
//!
//! Measurements: docs/performance.md ("src/log/mod.rs").

pub mod frames;
pub mod inspect;
pub mod schema;
pub mod writer;

use std::path::{Path, PathBuf};

pub use frames::FrameSchedule;
pub use inspect::{inspect_bytes, inspect_file, InspectError, Inspection};
pub use schema::{AngleSample, Trace};
pub use writer::{LogOptions, LogStats, Recorder, RunLog};

/// Why a run log could not be written.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// A file operation failed.
    #[error("run log {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("run log: {0}")]
    Mcap(#[from] mcap::McapError),
    /// A message could not be encoded.
    #[error("run log: cannot encode a message: {0}")]
    Encode(String),
    /// A time cannot be a log time.
    #[error("run log: {0}")]
    Time(#[from] schema::BadTime),
}

impl LogError {
    fn io(path: &Path) -> impl FnOnce(std::io::Error) -> LogError + '_ {
        move |source| LogError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
