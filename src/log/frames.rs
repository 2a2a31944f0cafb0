//! Building the Foxglove messages of one frame: particles as spheres or a point
//! cloud, walls as triangle lists; and the schedule that decides which steps
//! become frames.

use foxglove::bytes::Bytes;
use foxglove::messages::packed_element_field::NumericType;
use foxglove::messages::{
    Color, PackedElementField, Point3, PointCloud, Pose, Quaternion, SceneEntity, SceneUpdate,
    SpherePrimitive, Timestamp, TriangleListPrimitive, Vector3,
};

use super::schema::FRAME_ID;
use crate::dem::particles::Particles;
use crate::dem::vec3::Vec3;
use crate::dem::walls::{perpendicular, Wall, WallPose, WallShape};

/// Segments around the axis when a disk, annulus, cylinder or cone is drawn.
pub const REVOLVED_SEGMENTS: u32 = 64;

/// Colour of walls (translucent grey, so particles inside a drum stay visible).
const WALL_COLOUR: Color = Color {
    r: 0.62,
    g: 0.64,
    b: 0.68,
    a: 0.45,
};

/// Colour of a particle moving at `speed` (m/s): a blue → cyan → green →
/// yellow → red ramp over `[0, scale]`, red beyond.
pub fn speed_colour(speed: f64, scale: f64) -> Color {
    const STOPS: [[f64; 3]; 5] = [
        [0.10, 0.25, 0.90],
        [0.00, 0.80, 0.90],
        [0.20, 0.80, 0.20],
        [0.95, 0.85, 0.10],
        [0.90, 0.15, 0.10],
    ];
    let x = if scale > 0.0 && speed.is_finite() {
        (speed / scale).clamp(0.0, 1.0) * (STOPS.len() - 1) as f64
    } else {
        0.0
    };
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mix = |k: usize| STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f;
    Color {
        r: mix(0),
        g: mix(1),
        b: mix(2),
        a: 1.0,
    }
}

fn vector3(v: Vec3) -> Vector3 {
    Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn point3(v: Vec3) -> Point3 {
    Point3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// The identity orientation (Foxglove reads an absent quaternion as all zeros).
const IDENTITY: Quaternion = Quaternion {
    x: 0.0,
    y: 0.0,
    z: 0.0,
    w: 1.0,
};

/// Particle indices in stable-id order (the engine re-sorts its arrays by cell,
/// the log keeps particle k at position k of every frame while none are removed).
pub(crate) fn id_order(p: &Particles) -> Vec<usize> {
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_unstable_by_key(|&i| p.id[i]);
    order
}

/// One `particles` entity holding a sphere per particle (diameter = size,
/// colour by speed), in stable-id order.
pub(crate) fn particle_spheres(
    time: Timestamp,
    p: &Particles,
    order: &[usize],
    speed_scale_m_s: f64,
) -> SceneUpdate {
    let spheres = order
        .iter()
        .map(|&i| {
            let d = 2.0 * p.radius[i];
            SpherePrimitive {
                pose: Some(Pose {
                    position: Some(vector3(p.position[i])),
                    orientation: Some(IDENTITY),
                }),
                size: Some(Vector3 { x: d, y: d, z: d }),
                color: Some(speed_colour(p.velocity[i].norm(), speed_scale_m_s)),
            }
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(time),
            frame_id: FRAME_ID.to_string(),
            id: "particles".to_string(),
            spheres,
            ..SceneEntity::default()
        }],
    }
}

/// Fields of the point cloud: name and byte offset, all float32.
pub const CLOUD_FIELDS: [(&str, u32); 5] =
    [("x", 0), ("y", 4), ("z", 8), ("radius", 12), ("speed", 16)];

/// Bytes per point of the cloud.
pub const CLOUD_STRIDE: u32 = 20;

/// A point per particle with x, y, z (m), radius (m) and speed (m/s) as
/// little-endian float32, in stable-id order.
pub(crate) fn particle_cloud(time: Timestamp, p: &Particles, order: &[usize]) -> PointCloud {
    let mut data = Vec::with_capacity(order.len() * CLOUD_STRIDE as usize);
    for &i in order {
        let x = p.position[i];
        for v in [x.x, x.y, x.z, p.radius[i], p.velocity[i].norm()] {
            data.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    PointCloud {
        timestamp: Some(time),
        frame_id: FRAME_ID.to_string(),
        pose: Some(Pose {
            position: Some(vector3(Vec3::zeros())),
            orientation: Some(IDENTITY),
        }),
        point_stride: CLOUD_STRIDE,
        fields: CLOUD_FIELDS
            .iter()
            .map(|&(name, offset)| PackedElementField {
                name: name.to_string(),
                offset,
                r#type: NumericType::Float32 as i32,
            })
            .collect(),
        data: Bytes::from(data),
    }
}

/// A wall's body-frame triangles: vertices and index triples.
fn wall_triangles(shape: &WallShape, plane_half_m: f64) -> (Vec<Vec3>, Vec<u32>) {
    match shape {
        WallShape::Plane(s) => {
            let n = s.normal();
            let u = perpendicular(n) * plane_half_m;
            let v = n.cross(&u);
            let c = s.point();
            quad(c, u, v)
        }
        WallShape::Rectangle(s) => quad(s.centre(), s.u() * s.half_u_m(), s.v() * s.half_v_m()),
        WallShape::Revolved(s) => {
            let (r0, z0, r1, z1) = s.segment();
            let (axis, e1) = (s.axis(), s.perp());
            let e2 = axis.cross(&e1);
            let n = REVOLVED_SEGMENTS;
            let ring = |r: f64, z: f64| {
                (0..n).map(move |k| {
                    let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
                    s.origin() + axis * z + (e1 * a.cos() + e2 * a.sin()) * r
                })
            };
            let points: Vec<Vec3> = ring(r0, z0).chain(ring(r1, z1)).collect();
            let mut indices = Vec::with_capacity(6 * n as usize);
            for k in 0..n {
                let (a, b) = (k, (k + 1) % n);
                // Quad a, b on ring 0 and a, b on ring 1; a ring of radius zero
                // is one point, and its half of the quad is skipped.
                if r0 > 0.0 {
                    indices.extend([a, b, n + b]);
                }
                if r1 > 0.0 {
                    indices.extend([a, n + b, n + a]);
                }
            }
            (points, indices)
        }
    }
}

/// The rectangle `c ± u ± v` as two triangles.
fn quad(c: Vec3, u: Vec3, v: Vec3) -> (Vec<Vec3>, Vec<u32>) {
    (
        vec![c - u - v, c + u - v, c + u + v, c - u + v],
        vec![0, 1, 2, 0, 2, 3],
    )
}

/// Every wall as an entity `wall/<index>`: its body-frame triangles placed by its
/// pose at `t_s`. Planes are drawn as squares of half-size `plane_half_m` (m)
/// about their reference point.
pub(crate) fn wall_scene(
    time: Timestamp,
    walls: &[Wall],
    t_s: f64,
    plane_half_m: f64,
) -> SceneUpdate {
    let entities = walls
        .iter()
        .enumerate()
        .map(|(i, wall)| {
            let (points, indices) = wall_triangles(wall.shape(), plane_half_m);
            SceneEntity {
                timestamp: Some(time),
                frame_id: FRAME_ID.to_string(),
                id: format!("wall/{i}"),
                triangles: vec![TriangleListPrimitive {
                    pose: Some(pose(&wall.pose_at(t_s))),
                    points: points.into_iter().map(point3).collect(),
                    color: Some(WALL_COLOUR),
                    colors: Vec::new(),
                    indices,
                }],
                ..SceneEntity::default()
            }
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// A wall pose as a Foxglove pose.
fn pose(p: &WallPose) -> Pose {
    let q = p.quaternion();
    Pose {
        position: Some(vector3(p.translation)),
        orientation: Some(Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }),
    }
}

/// Half-size (m) of the square that draws an infinite plane: 1.5 times the
/// largest distance of a particle surface or a bounded wall from the origin,
/// and at least ten largest radii (1 m when the scene is empty).
pub(crate) fn plane_half_size(p: &Particles, walls: &[Wall]) -> f64 {
    let mut reach: f64 = 0.0;
    let mut r_max: f64 = 0.0;
    for i in 0..p.len() {
        reach = reach.max(p.position[i].norm() + p.radius[i]);
        r_max = r_max.max(p.radius[i]);
    }
    for (lo, hi) in walls.iter().filter_map(|w| w.aabb(0.0)) {
        reach = reach.max(lo.norm()).max(hi.norm());
    }
    let half = (1.5 * reach).max(10.0 * r_max);
    if half > 0.0 && half.is_finite() {
        half
    } else {
        1.0
    }
}

/// Which steps become frames: every `stride` steps; after `2 × target` frames
/// the stride doubles every `target` frames, so a run that lasts far longer
/// than its scene expected still writes a bounded number of frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameSchedule {
    stride: u64,
    target: u64,
    frames: u64,
}

impl FrameSchedule {
    /// About `target` frames over `expected_steps` steps (both at least 1).
    pub fn new(expected_steps: u64, target: u64) -> FrameSchedule {
        let target = target.max(1);
        FrameSchedule {
            stride: (expected_steps / target).max(1),
            target,
            frames: 0,
        }
    }

    /// Current stride, in steps.
    pub fn stride(&self) -> u64 {
        self.stride
    }

    /// True when `step` is a frame; counts it.
    pub fn due(&mut self, step: u64) -> bool {
        if !step.is_multiple_of(self.stride) {
            return false;
        }
        self.frames += 1;
        if self.frames >= 2 * self.target && self.frames.is_multiple_of(self.target) {
            self.stride *= 2;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::walls::RevolvedSegment;

    #[test]
    fn colour_ramp_ends_blue_and_red() {
        let slow = speed_colour(0.0, 1.0);
        let fast = speed_colour(5.0, 1.0);
        assert!(slow.b > slow.r && fast.r > fast.b);
        assert_eq!(speed_colour(f64::NAN, 1.0), slow);
        assert_eq!(speed_colour(1.0, 0.0), slow);
    }

    #[test]
    fn schedule_strides_then_doubles() {
        let mut s = FrameSchedule::new(1000, 10);
        assert_eq!(s.stride(), 100);
        let frames: Vec<u64> = (0..=20_000).filter(|&k| s.due(k)).collect();
        assert_eq!(&frames[..3], &[0, 100, 200]);
        // 20 frames at 100, 10 at 200, 10 at 400, ... far fewer than 200.
        assert!(frames.len() < 60, "{}", frames.len());
    }

    #[test]
    fn cylinder_is_a_closed_band_and_disk_skips_the_centre() {
        let c = RevolvedSegment::cylinder(Vec3::zeros(), Vec3::z(), 0.5, 2.0).unwrap();
        let (p, i) = wall_triangles(&WallShape::Revolved(c), 1.0);
        assert_eq!(p.len(), 2 * REVOLVED_SEGMENTS as usize);
        assert_eq!(i.len(), 6 * REVOLVED_SEGMENTS as usize);
        for q in &p {
            assert!(((q.x * q.x + q.y * q.y).sqrt() - 0.5).abs() < 1e-12);
        }
        let d = RevolvedSegment::disk(Vec3::zeros(), Vec3::z(), 0.5).unwrap();
        let (_, i) = wall_triangles(&WallShape::Revolved(d), 1.0);
        assert_eq!(i.len(), 3 * REVOLVED_SEGMENTS as usize);
    }
}
