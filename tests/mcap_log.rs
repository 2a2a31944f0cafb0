//! Run logs: read back with the mcap crate (summary, indexes, zstd chunks,
//! manifest metadata and attachment), decoded messages equal to the
//! simulation's values, corrupt files reported by `repose inspect`, and
//! byte-identical files for identical inputs whatever the thread count.

mod common;

use std::path::{Path, PathBuf};

use foxglove::messages::{PointCloud, SceneUpdate};
use foxglove::Decode;
use mcap::records::Record;
use mcap::{MessageStream, Summary};
use repose::dem::contact::PairParameters;
use repose::dem::domain::Domain;
use repose::dem::health::HealthLimits;
use repose::dem::material::ElasticMaterial;
use repose::dem::particles::{ParticleInit, Particles};
use repose::dem::simulation::{
    ContactSetup, NormalChoice, RollingChoice, Simulation, SimulationSetup, World,
};
use repose::dem::vec3::Vec3;
use repose::dem::walls::{Motion, Wall};
use repose::log::schema::{ScalarMessage, ANGLE_TOPIC};
use repose::log::{inspect_bytes, AngleSample, LogOptions, RunLog, Trace};
use repose::manifest::{parse_experiment, Experiment, Scene};
use repose::scenes::run_experiment;
use repose::store::Store;
use sha2::{Digest, Sha256};

use common::{pair_jkr, pair_wall, repose};

fn experiment(v: serde_json::Value) -> Experiment {
    parse_experiment(&v.to_string()).unwrap()
}

/// Runs `exp` through a store at `store` (as `repose run` does); returns the log path.
fn run_logged(store: &Path, exp: &Experiment) -> PathBuf {
    let store = Store::open(store).unwrap();
    store
        .run_cached(exp, |e, dir| run_experiment(e, Some(&dir.mcap_path())))
        .unwrap();
    store.run_dir(&exp.id()).mcap_path()
}

fn sha256(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// Every message of a log as (topic, log time, data).
fn messages(bytes: &[u8]) -> Vec<(String, u64, Vec<u8>)> {
    MessageStream::new(bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.into_owned())
        })
        .collect()
}

#[test]
fn pair_log_has_summary_indexes_zstd_chunks_and_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(pair_wall());
    let path = run_logged(tmp.path(), &exp);
    let bytes = std::fs::read(&path).unwrap();

    let summary = Summary::read(&bytes).unwrap().expect("summary present");
    let stats = summary.stats.as_ref().expect("statistics present");
    assert!(stats.message_count > 0);
    assert!(!summary.chunk_indexes.is_empty());
    for chunk in &summary.chunk_indexes {
        assert_eq!(chunk.compression, "zstd");
        assert!(!chunk.message_index_offsets.is_empty(), "message indexes");
    }
    let mut topics: Vec<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    topics.sort_unstable();
    assert_eq!(
        topics,
        [
            "/particles",
            "/trace/contacts",
            "/trace/kinetic_energy",
            "/trace/max_overlap_ratio",
            "/walls"
        ]
    );

    match mcap::read::LinearReader::new(&bytes).unwrap().next() {
        Some(Ok(Record::Header(h))) => {
            assert_eq!(h.library, "repose");
            assert_eq!(h.profile, "");
        }
        other => panic!("first record {other:?}"),
    }

    let canonical = std::fs::read_to_string(path.with_file_name("manifest.json")).unwrap();
    let index = &summary.metadata_indexes[0];
    assert_eq!(index.name, "repose.manifest");
    let meta = mcap::read::metadata(&bytes, index).unwrap().metadata;
    assert_eq!(meta["id"], exp.id().to_string());
    assert_eq!(meta["manifest"], canonical);
    assert_eq!(meta["physics_version"], "1");
    assert_eq!(meta["repose_version"], env!("CARGO_PKG_VERSION"));
    let attachment = mcap::read::attachment(&bytes, &summary.attachment_indexes[0]).unwrap();
    assert_eq!(attachment.name, "manifest.json");
    assert_eq!(attachment.media_type, "application/json");
    assert_eq!((attachment.log_time, attachment.create_time), (0, 0));
    assert_eq!(&*attachment.data, canonical.as_bytes());

    // Every message is stamped in frame `world` with log time = publish time.
    for m in MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert_eq!(m.log_time, m.publish_time);
        if m.channel.topic == "/particles" {
            let scene = SceneUpdate::decode(&*m.data).unwrap();
            assert_eq!(scene.entities[0].frame_id, "world");
            let Scene::Pair(pair) = &exp.scene else {
                panic!("a pair experiment")
            };
            let r = pair.radius_m;
            assert_eq!(scene.entities[0].spheres[0].size.unwrap().x, 2.0 * r);
        }
    }
    assert!(inspect_bytes(&bytes).is_ok());
    // No temp file is left beside the log.
    let names: Vec<String> = std::fs::read_dir(path.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.starts_with(".tmp-")), "{names:?}");
}

const SPHERE: ElasticMaterial = ElasticMaterial {
    youngs_modulus_pa: 1e8,
    poisson_ratio: 0.3,
};

/// 64 particles settling in a drum (cylinder about y) that turns at 30 rpm.
fn drum_world() -> (World, SimulationSetup) {
    let mut particles = Particles::default();
    for k in 0..64u32 {
        let (i, j, l) = (f64::from(k % 4), f64::from(k / 4 % 4), f64::from(k / 16));
        particles.push(
            &ParticleInit {
                position: Vec3::new(
                    -3.75e-3 + 2.5e-3 * i,
                    -3.75e-3 + 2.5e-3 * j,
                    -6e-3 + 2.5e-3 * l,
                ),
                velocity: Vec3::new(0.01 * (i - 1.5), 0.0, -0.05),
                angular_velocity: Vec3::zeros(),
                radius_m: 1e-3 * (1.0 + 0.05 * f64::from(k % 3)),
            },
            2500.0,
        );
    }
    let drum = Wall::cylinder(Vec3::new(0.0, -10e-3, 0.0), Vec3::y(), 10e-3, 20e-3, 0)
        .unwrap()
        .with_motion(Motion::Rotate {
            axis_point: Vec3::zeros(),
            axis_dir: Vec3::y(),
            rpm: 30.0,
            start_s: 0.0,
            end_s: f64::INFINITY,
        })
        .unwrap();
    let params = PairParameters {
        restitution: 0.5,
        static_friction: 0.3,
        rolling_friction: 0.0,
        surface_energy_j_m2: 0.0,
    };
    let world = World::new(
        particles,
        vec![drum],
        Domain::new(
            Vec3::new(-0.02, -0.02, -0.02),
            Vec3::new(0.02, 0.02, 0.02),
            [false; 3],
        )
        .unwrap(),
    );
    let setup = SimulationSetup {
        contact: ContactSetup {
            normal: NormalChoice::Hertz,
            rolling: RollingChoice::None,
            clip_tensile: false,
            particle_material: SPHERE,
            particle_particle: params,
            wall_materials: vec![(ElasticMaterial::RIGID, params)],
        },
        density_kg_m3: 2500.0,
        gravity_m_s2: Some(Vec3::new(0.0, 0.0, -9.81)),
        dt_s: 2e-6,
        skin_m: 5e-5,
        health: HealthLimits::default(),
    };
    (world, setup)
}

/// What the simulation held at one logged frame.
struct Snapshot {
    time_s: f64,
    positions: Vec<(u32, Vec3, f64)>,
    kinetic_energy_j: f64,
    contacts: usize,
}

/// Simulates the drum for `frames` frames of 50 steps, logging each into
/// `path`; returns what the simulation held at every frame.
fn log_drum(path: &Path, options: LogOptions, frames: usize) -> Vec<Snapshot> {
    let (world, setup) = drum_world();
    let mut sim = Simulation::new(world, &setup).unwrap();
    let exp = experiment(pair_wall());
    let mut log = RunLog::create(path, &exp, options).unwrap();
    let mut snapshots = Vec::new();
    for _ in 0..frames {
        sim.advance(50).unwrap();
        log.record(&sim).unwrap();
        let p = &sim.world().particles;
        let mut positions: Vec<(u32, Vec3, f64)> = (0..p.len())
            .map(|i| (p.id[i], p.position[i], p.radius[i]))
            .collect();
        positions.sort_by_key(|x| x.0);
        let s = sim.stats();
        snapshots.push(Snapshot {
            time_s: sim.world().time_s,
            positions,
            kinetic_energy_j: p.kinetic_energy_j(),
            contacts: s.contacts + s.wall_contacts,
        });
    }
    let stats = log.finish().unwrap();
    assert_eq!(stats.frames, frames as u64);
    assert_eq!(stats.particle_frames, 64 * frames as u64);
    snapshots
}

fn ns(t_s: f64) -> u64 {
    (t_s * 1e9).round() as u64
}

#[test]
fn scene_and_trace_messages_decode_to_the_simulations_values() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("drum.mcap");
    let snapshots = log_drum(&path, LogOptions::default(), 4);
    let bytes = std::fs::read(&path).unwrap();
    let all = messages(&bytes);
    let last = snapshots.last().unwrap();
    let t = ns(last.time_s);
    let at = |topic: &str| {
        all.iter()
            .find(|(tp, time, _)| tp == topic && *time == t)
            .unwrap_or_else(|| panic!("{topic} at {t} ns"))
            .2
            .clone()
    };

    let scene = SceneUpdate::decode(&*at("/particles")).unwrap();
    let entity = &scene.entities[0];
    assert_eq!(entity.id, "particles");
    let stamp = entity.timestamp.unwrap();
    assert_eq!(
        u64::from(stamp.sec()) * 1_000_000_000 + u64::from(stamp.nsec()),
        t
    );
    assert_eq!(entity.spheres.len(), 64);
    for (sphere, &(_, x, r)) in entity.spheres.iter().zip(&last.positions) {
        let pose = sphere.pose.unwrap();
        let p = pose.position.unwrap();
        assert_eq!((p.x, p.y, p.z), (x.x, x.y, x.z));
        assert_eq!(pose.orientation.unwrap().w, 1.0);
        assert_eq!(sphere.size.unwrap().x, 2.0 * r);
    }

    let ke: ScalarMessage = serde_json::from_slice(&at(Trace::KineticEnergy.topic())).unwrap();
    assert_eq!(ke.value, Some(last.kinetic_energy_j));
    let contacts: ScalarMessage = serde_json::from_slice(&at(Trace::Contacts.topic())).unwrap();
    assert_eq!(contacts.value, Some(last.contacts as f64));

    // The turning drum is re-published at every frame with its pose.
    let walls: Vec<_> = all.iter().filter(|m| m.0 == "/walls").collect();
    assert_eq!(walls.len(), snapshots.len());
    let drum = SceneUpdate::decode(&*at("/walls")).unwrap();
    let (world, _) = drum_world();
    let q = world.walls[0].pose_at(last.time_s).quaternion();
    let o = drum.entities[0].triangles[0]
        .pose
        .unwrap()
        .orientation
        .unwrap();
    assert_eq!((o.x, o.y, o.z, o.w), (q.i, q.j, q.k, q.w));
    assert!(o.y.abs() > 0.0, "the drum has turned");
}

#[test]
fn large_frames_are_point_clouds() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("cloud.mcap");
    let options = LogOptions {
        sphere_limit: 10,
        ..LogOptions::default()
    };
    let snapshots = log_drum(&path, options, 2);
    let all = messages(&std::fs::read(&path).unwrap());
    assert!(all.iter().all(|m| m.0 != "/particles"));
    let data = &all
        .iter()
        .rev()
        .find(|m| m.0 == "/particles/cloud")
        .unwrap()
        .2;
    let cloud = PointCloud::decode(&**data).unwrap();
    assert_eq!(cloud.frame_id, "world");
    assert_eq!(cloud.point_stride, 20);
    let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "radius", "speed"]);
    assert_eq!(cloud.data.len(), 64 * 20);
    let f = |k: usize| f32::from_le_bytes(cloud.data[k * 4..k * 4 + 4].try_into().unwrap());
    let (_, x, r) = snapshots[1].positions[0];
    assert_eq!(
        (f(0), f(1), f(2), f(3)),
        (x.x as f32, x.y as f32, x.z as f32, r as f32)
    );
}

#[test]
fn angle_and_scalar_traces_round_trip() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("angle.mcap");
    let mut log = RunLog::create(&path, &experiment(pair_wall()), LogOptions::default()).unwrap();
    let sample = AngleSample {
        left_deg: 31.25,
        right_deg: 29.5,
        mean_deg: 30.375,
        fit_r2: 0.987,
    };
    log.angle(1.5, &sample).unwrap();
    log.scalar(Trace::FlowRate, 1.5, 0.125).unwrap();
    log.scalar(Trace::Discharged, 2.0, f64::NAN).unwrap();
    assert!(log.scalar(Trace::Discharged, -1.0, 0.0).is_err());
    log.finish().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let all = messages(&bytes);
    assert_eq!(all[0].0, ANGLE_TOPIC);
    assert_eq!(all[0].1, 1_500_000_000);
    let back: AngleSample = serde_json::from_slice(&all[0].2).unwrap();
    assert_eq!(back, sample);
    assert_eq!(all[1].2, br#"{"value":0.125}"#);
    assert_eq!(all[2].2, br#"{"value":null}"#);
    let summary = Summary::read(&bytes).unwrap().unwrap();
    let flow = summary
        .channels
        .values()
        .find(|c| c.topic == "/trace/flow_rate")
        .unwrap();
    assert_eq!(flow.metadata["unit"], "kg/s");
    assert_eq!(flow.schema.as_ref().unwrap().name, "repose.Scalar");
    assert_eq!(flow.message_encoding, "json");
}

#[test]
fn an_unfinished_log_leaves_no_file() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run.mcap");
    let log = RunLog::create(&path, &experiment(pair_wall()), LogOptions::default()).unwrap();
    drop(log);
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn inspect_reports_channels_and_checks_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(pair_jkr());
    let path = run_logged(tmp.path(), &exp);
    let out = repose(tmp.path(), &["inspect", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "/particles",
        "foxglove.SceneUpdate",
        "/trace/kinetic_energy",
        "repose.Scalar",
        "(zstd), 1 with message indexes",
        "time:     0.000000000 s ..",
        &format!("manifest: id {}", exp.id()),
        "hash:   ok",
        "store:  matches",
    ] {
        assert!(text.contains(needle), "{needle} missing from\n{text}");
    }

    // A different manifest.json in the store is a mismatch.
    let stored = path.with_file_name("manifest.json");
    let mut changed = std::fs::read_to_string(&stored).unwrap();
    changed.push(' ');
    std::fs::write(&stored, changed).unwrap();
    let out = repose(tmp.path(), &["inspect", path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("manifest check failed") && err.contains("differs"),
        "{err}"
    );
}

#[test]
fn truncated_and_bit_flipped_logs_are_reported_corrupt() {
    let tmp = tempfile::tempdir().unwrap();
    let path = run_logged(tmp.path(), &experiment(pair_wall()));
    let bytes = std::fs::read(&path).unwrap();

    let bad = tmp.path().join("bad.mcap");
    for (cut, word) in [
        (bytes.len() / 2, "truncated"),
        (bytes.len() - 1, "truncated"),
        (0, "not an MCAP file"),
    ] {
        std::fs::write(&bad, &bytes[..cut]).unwrap();
        let out = repose(tmp.path(), &["inspect", bad.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "cut {cut}: {err}");
        assert!(
            err.contains("corrupt run log") && err.contains(word),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }

    // One flipped bit anywhere is caught, never a panic.
    for pos in 0..bytes.len() {
        let mut flipped = bytes.clone();
        flipped[pos] ^= 1 << (pos % 8);
        assert!(
            inspect_bytes(&flipped).is_err(),
            "flip at byte {pos} not caught"
        );
    }
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 3] ^= 0x10;
    std::fs::write(&bad, &flipped).unwrap();
    let out = repose(tmp.path(), &["inspect", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("CRC mismatch"), "{err}");

    // A file that cannot be read is bad input, as for every command (exit 2).
    let out = repose(tmp.path(), &["inspect", "no/such/file.mcap"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn identical_manifests_give_byte_identical_logs() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(pair_jkr());
    let a = std::fs::read(run_logged(&tmp.path().join("a"), &exp)).unwrap();
    let b = std::fs::read(run_logged(&tmp.path().join("b"), &exp)).unwrap();
    assert_eq!(sha256(&a), sha256(&b));
}

#[test]
fn the_thread_count_does_not_change_the_log() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(pair_wall());
    let mut digests = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let dir = tmp.path().join(threads.to_string());
        std::fs::create_dir(&dir).unwrap();
        let drum = dir.join("drum.mcap");
        let pair = pool.install(|| {
            log_drum(&drum, LogOptions::default(), 3);
            run_logged(&dir.join("store"), &exp)
        });
        digests.push((
            sha256(&std::fs::read(&drum).unwrap()),
            sha256(&std::fs::read(pair).unwrap()),
        ));
    }
    assert_eq!(digests[0], digests[1]);
}
