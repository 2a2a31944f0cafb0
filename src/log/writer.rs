//! [`RunLog`]: the MCAP writer of one run.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

use foxglove::Encode;
use mcap::records::{MessageHeader, Metadata};
use mcap::{Attachment, Compression, WriteOptions};

use super::frames::{
    id_order, particle_cloud, particle_spheres, plane_half_size, wall_scene, FrameSchedule,
};
use super::schema::{
    time_ns, timestamp, AngleSample, ScalarMessage, Trace, ANGLE_SCHEMA, ANGLE_SCHEMA_JSON,
    ANGLE_TOPIC, CLOUD_TOPIC, LIBRARY, MANIFEST_ATTACHMENT, MANIFEST_MEDIA_TYPE, MANIFEST_METADATA,
    PARTICLES_TOPIC, SCALAR_SCHEMA, SCALAR_SCHEMA_JSON, WALLS_TOPIC,
};
use super::LogError;
use crate::dem::simulation::{Simulation, World};
use crate::manifest::{canonical_json, Experiment, PHYSICS_VERSION};
use crate::store::AtomicFile;

/// zstd level of every chunk (fixed: the level changes the bytes).
pub const ZSTD_LEVEL: u32 = 3;
/// Target uncompressed chunk size, bytes.
pub const CHUNK_SIZE: u64 = 1024 * 1024;
/// Above this many particles a frame is a point cloud instead of spheres
/// (see the module docs for the measured cost).
pub const SPHERE_LIMIT: usize = 20_000;

/// Settings of a run log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogOptions {
    /// Speed (m/s) drawn red; slower particles run blue → red.
    pub speed_scale_m_s: f64,
    /// Frames with more particles than this are written as a
    /// `foxglove.PointCloud` on `/particles/cloud` instead of spheres.
    pub sphere_limit: usize,
}

impl Default for LogOptions {
    fn default() -> Self {
        LogOptions {
            speed_scale_m_s: 1.0,
            sphere_limit: SPHERE_LIMIT,
        }
    }
}

/// What a finished log holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LogStats {
    /// Frames written (particles and, when any moves, walls).
    pub frames: u64,
    /// Particles summed over frames.
    pub particle_frames: u64,
    /// Messages on every topic.
    pub messages: u64,
    /// File size, bytes.
    pub bytes: u64,
}

/// An MCAP run log being written. Created beside its final path and renamed
/// there by [`RunLog::finish`]; dropped unfinished, it leaves nothing behind.
pub struct RunLog {
    writer: mcap::Writer<BufWriter<AtomicFile>>,
    options: LogOptions,
    /// Channel id of each topic, created on first use (so the order of first
    /// use fixes the ids).
    channels: BTreeMap<&'static str, u16>,
    /// Next sequence number of each channel.
    sequences: BTreeMap<u16, u32>,
    /// Half-size of drawn planes, fixed at the first frame.
    plane_half_m: Option<f64>,
    buffer: Vec<u8>,
    stats: LogStats,
}

impl std::fmt::Debug for RunLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunLog")
            .field("options", &self.options)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

/// Schema of a topic: name, encoding, data and the channel's message encoding.
struct TopicSchema {
    name: Cow<'static, str>,
    encoding: Cow<'static, str>,
    data: Cow<'static, [u8]>,
    message_encoding: Cow<'static, str>,
    unit: Option<&'static str>,
}

impl TopicSchema {
    fn foxglove<T: Encode>() -> TopicSchema {
        let s = T::get_schema().expect("foxglove messages have schemas");
        TopicSchema {
            name: s.name.into(),
            encoding: s.encoding.into(),
            data: s.data,
            message_encoding: T::get_message_encoding().into(),
            unit: None,
        }
    }

    fn json(name: &'static str, schema: &'static str, unit: Option<&'static str>) -> TopicSchema {
        TopicSchema {
            name: name.into(),
            encoding: "jsonschema".into(),
            data: schema.as_bytes().into(),
            message_encoding: "json".into(),
            unit,
        }
    }
}

impl RunLog {
    /// Starts the log of `experiment` for `path` (written to a temp file beside
    /// it): header, the manifest metadata record and attachment.
    pub fn create(
        path: &Path,
        experiment: &Experiment,
        options: LogOptions,
    ) -> Result<RunLog, LogError> {
        let file = AtomicFile::create(path).map_err(LogError::io(path))?;
        let mut writer = WriteOptions::new()
            .library(LIBRARY)
            .profile("")
            .compression(Some(Compression::Zstd))
            .compression_level(ZSTD_LEVEL)
            .compression_threads(0)
            .chunk_size(Some(CHUNK_SIZE))
            .create(BufWriter::new(file))?;
        let manifest = canonical_json(experiment);
        let metadata = BTreeMap::from([
            ("id".to_string(), experiment.id().to_string()),
            ("manifest".to_string(), manifest.clone()),
            (
                "repose_version".to_string(),
                env!("CARGO_PKG_VERSION").to_string(),
            ),
            ("physics_version".to_string(), PHYSICS_VERSION.to_string()),
        ]);
        writer.write_metadata(&Metadata {
            name: MANIFEST_METADATA.to_string(),
            metadata,
        })?;
        writer.attach(&Attachment {
            log_time: 0,
            create_time: 0,
            name: MANIFEST_ATTACHMENT.to_string(),
            media_type: MANIFEST_MEDIA_TYPE.to_string(),
            data: Cow::Owned(manifest.into_bytes()),
        })?;
        Ok(RunLog {
            writer,
            options,
            channels: BTreeMap::new(),
            sequences: BTreeMap::new(),
            plane_half_m: None,
            buffer: Vec::new(),
            stats: LogStats::default(),
        })
    }

    /// The channel of `topic`, created with `schema` on first use.
    fn channel(
        &mut self,
        topic: &'static str,
        schema: impl FnOnce() -> TopicSchema,
    ) -> Result<u16, LogError> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let s = schema();
        let schema_id = self.writer.add_schema(&s.name, &s.encoding, &s.data)?;
        let metadata = s
            .unit
            .map(|u| BTreeMap::from([("unit".to_string(), u.to_string())]))
            .unwrap_or_default();
        let id = self
            .writer
            .add_channel(schema_id, topic, &s.message_encoding, &metadata)?;
        self.channels.insert(topic, id);
        Ok(id)
    }

    /// Writes the bytes in `self.buffer` as a message on `channel` at `ns`.
    fn write_buffer(&mut self, channel: u16, ns: u64) -> Result<(), LogError> {
        let sequence = self.sequences.entry(channel).or_insert(0);
        let header = MessageHeader {
            channel_id: channel,
            sequence: *sequence,
            log_time: ns,
            publish_time: ns,
        };
        *sequence = sequence.wrapping_add(1);
        self.writer.write_to_known_channel(&header, &self.buffer)?;
        self.stats.messages += 1;
        Ok(())
    }

    /// Encodes a Foxglove message on `topic` at `ns`.
    fn write_foxglove<T: Encode>(
        &mut self,
        topic: &'static str,
        ns: u64,
        message: &T,
    ) -> Result<(), LogError> {
        let channel = self.channel(topic, TopicSchema::foxglove::<T>)?;
        self.buffer.clear();
        message
            .encode(&mut self.buffer)
            .map_err(|e| LogError::Encode(e.to_string()))?;
        self.write_buffer(channel, ns)
    }

    /// Logs a frame at simulation time `t_s`: every particle (spheres, or a
    /// point cloud above the sphere limit) and, at the first frame and whenever
    /// any wall moves, every wall at its pose.
    pub fn frame(&mut self, t_s: f64, world: &World) -> Result<(), LogError> {
        let ns = time_ns(t_s)?;
        let time = timestamp(ns);
        let p = &world.particles;
        let order = id_order(p);
        if p.len() > self.options.sphere_limit {
            self.write_foxglove(CLOUD_TOPIC, ns, &particle_cloud(time, p, &order))?;
        } else {
            let scene = particle_spheres(time, p, &order, self.options.speed_scale_m_s);
            self.write_foxglove(PARTICLES_TOPIC, ns, &scene)?;
        }
        let first = self.plane_half_m.is_none();
        let plane_half_m = *self
            .plane_half_m
            .get_or_insert_with(|| plane_half_size(p, &world.walls));
        let moving = world.walls.iter().any(|w| !w.motion().is_static());
        if !world.walls.is_empty() && (first || moving) {
            let scene = wall_scene(time, &world.walls, t_s, plane_half_m);
            self.write_foxglove(WALLS_TOPIC, ns, &scene)?;
        }
        self.stats.frames += 1;
        self.stats.particle_frames += p.len() as u64;
        Ok(())
    }

    /// Logs a scalar trace value at simulation time `t_s`.
    pub fn scalar(&mut self, trace: Trace, t_s: f64, value: f64) -> Result<(), LogError> {
        let ns = time_ns(t_s)?;
        let channel = self.channel(trace.topic(), || {
            TopicSchema::json(SCALAR_SCHEMA, SCALAR_SCHEMA_JSON, Some(trace.unit()))
        })?;
        let message = ScalarMessage {
            value: value.is_finite().then_some(value),
        };
        self.buffer.clear();
        serde_json::to_writer(&mut self.buffer, &message)
            .map_err(|e| LogError::Encode(e.to_string()))?;
        self.write_buffer(channel, ns)
    }

    /// Logs an angle-of-repose sample at simulation time `t_s`.
    pub fn angle(&mut self, t_s: f64, sample: &AngleSample) -> Result<(), LogError> {
        let ns = time_ns(t_s)?;
        let channel = self.channel(ANGLE_TOPIC, || {
            TopicSchema::json(ANGLE_SCHEMA, ANGLE_SCHEMA_JSON, Some("deg"))
        })?;
        self.buffer.clear();
        serde_json::to_writer(&mut self.buffer, sample)
            .map_err(|e| LogError::Encode(e.to_string()))?;
        self.write_buffer(channel, ns)
    }

    /// Logs a frame of the simulation at its current time with the engine's
    /// traces: kinetic energy, contacts and maximum overlap ratio.
    pub fn record(&mut self, sim: &Simulation) -> Result<(), LogError> {
        let world = sim.world();
        let t = world.time_s;
        let stats = sim.stats();
        self.frame(t, world)?;
        self.scalar(Trace::KineticEnergy, t, world.particles.kinetic_energy_j())?;
        self.scalar(
            Trace::Contacts,
            t,
            (stats.contacts + stats.wall_contacts) as f64,
        )?;
        self.scalar(Trace::MaxOverlapRatio, t, stats.max_overlap_ratio)
    }

    /// Writes the summary (schemas, channels, statistics, indexes, in the mcap
    /// crate's fixed order) and renames the file to its final path.
    pub fn finish(mut self) -> Result<LogStats, LogError> {
        self.writer.finish()?;
        let buffered = self.writer.into_inner();
        let file = buffered.into_inner().map_err(|e| {
            let (source, buffered) = e.into_parts();
            LogError::Io {
                path: buffered.get_ref().path().to_path_buf(),
                source,
            }
        })?;
        let path = file.path().to_path_buf();
        let mut stats = self.stats;
        stats.bytes = file.size().map_err(LogError::io(&path))?;
        file.commit().map_err(LogError::io(&path))?;
        Ok(stats)
    }
}

/// A [`RunLog`] fed from a running simulation on a [`FrameSchedule`].
#[derive(Debug)]
pub struct Recorder<'a> {
    log: &'a mut RunLog,
    schedule: FrameSchedule,
    last_step: Option<u64>,
}

impl<'a> Recorder<'a> {
    /// Records into `log` on `schedule`.
    pub fn new(log: &'a mut RunLog, schedule: FrameSchedule) -> Recorder<'a> {
        Recorder {
            log,
            schedule,
            last_step: None,
        }
    }

    /// Call after every step (and once before the first): records the
    /// simulation when its step is due.
    pub fn step(&mut self, sim: &Simulation) -> Result<(), LogError> {
        let step = sim.world().step;
        if self.last_step != Some(step) && self.schedule.due(step) {
            self.log.record(sim)?;
            self.last_step = Some(step);
        }
        Ok(())
    }

    /// Records the final state unless it was the last frame.
    pub fn finish(self, sim: &Simulation) -> Result<(), LogError> {
        if self.last_step != Some(sim.world().step) {
            self.log.record(sim)?;
        }
        Ok(())
    }
}
