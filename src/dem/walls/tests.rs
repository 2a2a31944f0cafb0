//! Geometry tests. Every expected number is hand-computed; the comment beside each
//! says how (mostly 3-4-5 right triangles so distances are exact).

use super::*;
use std::f64::consts::PI;

const TOL: f64 = 1e-12;

fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}

#[track_caller]
fn close(a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
}

#[track_caller]
fn vclose(a: Vec3, b: Vec3, tol: f64) {
    assert!((a - b).norm() <= tol, "{a:?} vs {b:?} (tol {tol})");
}

#[track_caller]
fn finite(k: &WallContact) {
    assert!(
        k.normal
            .iter()
            .chain(k.point.iter())
            .chain(k.velocity.iter())
            .all(|x| x.is_finite())
            && k.overlap_m.is_finite(),
        "non-finite contact {k:?}"
    );
    close(k.normal.norm(), 1.0, 1e-12);
}

fn still(shape: WallShape) -> PlacedWall {
    Wall::new(shape, 0, Motion::Static).unwrap().placed_at(0.0)
}

// ---------------------------------------------------------------- plane

#[test]
fn plane_distance_and_sign() {
    // Plane z = 1, normal given unnormalised as (0, 0, 2).
    let w = Wall::plane(v(0.0, 0.0, 1.0), v(0.0, 0.0, 2.0), 3).unwrap();
    assert_eq!(w.material, 3);
    let p = w.placed_at(0.0);
    // Centre 0.2 above the plane, r = 0.25: overlap 0.25 − 0.2 = 0.05.
    let k = p.contact(v(3.0, 4.0, 1.2), 0.25, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
    vclose(k.point, v(3.0, 4.0, 1.0), TOL);
    vclose(k.velocity, Vec3::zeros(), 0.0);
    // Gap of 0.05 (centre 0.3 above, r 0.25): reported within range 0.1 only.
    let k = p.contact(v(0.0, 0.0, 1.3), 0.25, 0.1).unwrap();
    close(k.overlap_m, -0.05, TOL);
    assert!(p.contact(v(0.0, 0.0, 1.3), 0.25, 0.01).is_none());
    assert!(p.contact(v(0.0, 0.0, 1.3), 0.25, 0.0).is_none());
    // Crossed: centre 0.1 below the plane: overlap 0.25 + 0.1 = 0.35, no side flip.
    let k = p.contact(v(0.0, 0.0, 0.9), 0.25, 0.0).unwrap();
    close(k.overlap_m, 0.35, TOL);
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
    assert!(p.aabb().is_none());
    assert!(w.aabb(1.0).is_none());
}

// ---------------------------------------------------------------- rectangle

fn flat_rect() -> Wall {
    // Centre 0, normal z, u = x, half-extents 1 (x) and 0.5 (y; v = z × x = y).
    Wall::rectangle(
        Vec3::zeros(),
        v(0.0, 0.0, 1.0),
        v(1.0, 0.0, 0.0),
        1.0,
        0.5,
        0,
    )
    .unwrap()
}

#[test]
fn rectangle_face_edge_corner() {
    let p = flat_rect().placed_at(0.0);
    // Face, 0.1 above, r 0.15: overlap 0.05, normal +z.
    let k = p.contact(v(0.3, -0.2, 0.1), 0.15, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
    vclose(k.point, v(0.3, -0.2, 0.0), TOL);
    // Two-sided: 0.1 below gives the same overlap with normal −z.
    let k = p.contact(v(0.3, -0.2, -0.1), 0.15, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 0.0, -1.0), TOL);
    // Edge x = 1: offset (0.3, 0, 0.4) from (1, 0.2, 0), distance 0.5 (3-4-5), r 0.6.
    let k = p.contact(v(1.3, 0.2, 0.4), 0.6, 0.0).unwrap();
    close(k.overlap_m, 0.1, TOL);
    vclose(k.normal, v(0.6, 0.0, 0.8), TOL);
    vclose(k.point, v(1.0, 0.2, 0.0), TOL);
    // Edge hit edge-on (in the plane): 0.2 beyond x = 1, r 0.25: overlap 0.05, normal +x.
    let k = p.contact(v(1.2, 0.0, 0.0), 0.25, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(1.0, 0.0, 0.0), TOL);
    // Corner (1, 0.5, 0): offset (0.3, 0.4, 1.2), distance 1.3 (3-4-12-13), r 1.4.
    let k = p.contact(v(1.3, 0.9, 1.2), 1.4, 0.0).unwrap();
    close(k.overlap_m, 0.1, TOL);
    vclose(k.normal, v(3.0, 4.0, 12.0) / 13.0, TOL);
    vclose(k.point, v(1.0, 0.5, 0.0), TOL);
    // Beside the rectangle but close to its plane: no contact (bounded).
    assert!(p.contact(v(2.0, 0.0, 0.05), 0.1, 0.0).is_none());
    // AABB: flat in z.
    let (lo, hi) = p.aabb().unwrap();
    vclose(lo, v(-1.0, -0.5, 0.0), TOL);
    vclose(hi, v(1.0, 0.5, 0.0), TOL);
}

// ---------------------------------------------------------------- disk, annulus

#[test]
fn disk_face_and_rim() {
    let p = Wall::disk(Vec3::zeros(), v(0.0, 0.0, 1.0), 1.0, 0)
        .unwrap()
        .placed_at(0.0);
    // Face 0.1 above, r 0.2: overlap 0.1, normal +z; below: normal −z.
    let k = p.contact(v(0.5, 0.2, 0.1), 0.2, 0.0).unwrap();
    close(k.overlap_m, 0.1, TOL);
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
    vclose(k.point, v(0.5, 0.2, 0.0), TOL);
    let k = p.contact(v(0.5, 0.2, -0.1), 0.2, 0.0).unwrap();
    vclose(k.normal, v(0.0, 0.0, -1.0), TOL);
    // Rim circle R = 1: (ρ, z) = (1.3, 0.4), offset (0.3, 0.4) → distance 0.5, r 0.55.
    let k = p.contact(v(1.3, 0.0, 0.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.6, 0.0, 0.8), TOL);
    vclose(k.point, v(1.0, 0.0, 0.0), TOL);
    // The same at azimuth 90°: the rim point is (0, 1, 0).
    let k = p.contact(v(0.0, 1.3, 0.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 0.6, 0.8), TOL);
    vclose(k.point, v(0.0, 1.0, 0.0), TOL);
    // Centre on the axis touching the face: normal +z exactly.
    let k = p.contact(v(0.0, 0.0, 0.1), 0.2, 0.0).unwrap();
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
    vclose(k.point, Vec3::zeros(), TOL);
}

#[test]
fn annulus_hole_face_and_inner_rim() {
    let p = Wall::annulus(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.5, 1.0, 0)
        .unwrap()
        .placed_at(0.0);
    // In the hole: nearest wall point is the inner rim at distance 0.5 > r = 0.2.
    assert!(p.contact(v(0.0, 0.0, 0.0), 0.2, 0.0).is_none());
    assert!(p.contact(v(0.1, 0.0, 0.0), 0.3, 0.0).is_none()); // distance 0.4
                                                              // Inner rim: (ρ, z) = (0.2, 0.4), rim (0.5, 0), offset (−0.3, 0.4) → 0.5; r 0.55.
    let k = p.contact(v(0.2, 0.0, 0.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(-0.6, 0.0, 0.8), TOL);
    vclose(k.point, v(0.5, 0.0, 0.0), TOL);
    // Face from below: 0.1 below, r 0.15 → overlap 0.05, normal −z.
    let k = p.contact(v(0.75, 0.0, -0.1), 0.15, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 0.0, -1.0), TOL);
    assert_eq!(
        match p.shape() {
            WallShape::Revolved(s) => s.kind(),
            _ => unreachable!(),
        },
        RevolvedKind::Annulus
    );
}

// ---------------------------------------------------------------- cylinder

fn drum_cylinder() -> Wall {
    // Axis z through the origin, R = 0.5, z from 0 to 1.
    Wall::cylinder(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.5, 1.0, 0).unwrap()
}

#[test]
fn cylinder_inner_outer_and_rims() {
    let p = drum_cylinder().placed_at(0.0);
    // Inner surface: ρ = 0.4, gap 0.1 to R = 0.5, r 0.15 → overlap 0.05, normal −ρ̂.
    let k = p.contact(v(0.0, 0.4, 0.5), 0.15, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, -1.0, 0.0), TOL);
    vclose(k.point, v(0.0, 0.5, 0.5), TOL);
    // Outer surface: ρ = 0.6 → normal +ρ̂.
    let k = p.contact(v(0.0, 0.6, 0.5), 0.15, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, 1.0, 0.0), TOL);
    // Bottom rim (0.5, 0): (ρ, z) = (0.2, −0.4), offset (−0.3, −0.4) → 0.5; r 0.55.
    let k = p.contact(v(0.2, 0.0, -0.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(-0.6, 0.0, -0.8), TOL);
    vclose(k.point, v(0.5, 0.0, 0.0), TOL);
    // Top rim (0.5, 1): (ρ, z) = (0.8, 1.4), offset (0.3, 0.4) → 0.5; r 0.55.
    let k = p.contact(v(0.8, 0.0, 1.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.6, 0.0, 0.8), TOL);
    vclose(k.point, v(0.5, 0.0, 1.0), TOL);
    // Open ends: a sphere on the axis beyond the end does not touch.
    assert!(p.contact(v(0.0, 0.0, 1.2), 0.4, 0.0).is_none());
    let (lo, hi) = p.aabb().unwrap();
    vclose(lo, v(-0.5, -0.5, 0.0), TOL);
    vclose(hi, v(0.5, 0.5, 1.0), TOL);
}

#[test]
fn cylinder_on_axis_particle_is_deterministic() {
    let p = drum_cylinder().placed_at(0.0);
    // On the axis: every rim point is 0.5 away; r 0.6 → overlap 0.1. The fixed
    // perpendicular for axis z is z × x = +y (x is the least aligned world axis).
    let k = p.contact(v(0.0, 0.0, 0.5), 0.6, 0.0).unwrap();
    finite(&k);
    close(k.overlap_m, 0.1, TOL);
    vclose(k.point, v(0.0, 0.5, 0.5), TOL);
    vclose(k.normal, v(0.0, -1.0, 0.0), TOL);
    assert_eq!(Some(k), p.contact(v(0.0, 0.0, 0.5), 0.6, 0.0));
}

#[test]
fn sweeping_across_a_rim_never_jumps() {
    // The distance to a set is 1-Lipschitz: a sphere moved by |Δc| changes its
    // overlap by at most |Δc|, so passing a rim can neither fall through nor jump.
    let walls = [
        drum_cylinder(),
        Wall::cone_frustum(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.1, 0.6, 1.0, 0).unwrap(),
        Wall::annulus(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.3, 0.6, 0).unwrap(),
        flat_rect(),
    ];
    for w in walls {
        let p = w.placed_at(0.0);
        let (a, b) = (v(-0.9, 0.05, 1.3), v(0.9, 0.05, -0.3));
        let n = 4000;
        let step = (b - a).norm() / n as f64;
        let mut prev: Option<f64> = None;
        let mut touched = 0;
        for i in 0..=n {
            let c = a + (b - a) * (i as f64 / n as f64);
            let k = p.contact(c, 0.1, 10.0).unwrap();
            finite(&k);
            if k.overlap_m > 0.0 {
                touched += 1;
            }
            if let Some(o) = prev {
                assert!((k.overlap_m - o).abs() <= step * (1.0 + 1e-9));
            }
            prev = Some(k.overlap_m);
        }
        assert!(touched > 0);
    }
}

// ---------------------------------------------------------------- cone frustum

#[test]
fn cone_frustum_inner_surface_at_known_slant() {
    // Funnel: outlet radius 0.1 at z = 0, top radius 0.6 at z = 1: the wall line in
    // the meridian plane is ρ = 0.1 + 0.5 z, i.e. ρ − 0.5 z − 0.1 = 0, with unit
    // normal (1, −0.5)/√1.25.
    let p = Wall::cone_frustum(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.1, 0.6, 1.0, 0)
        .unwrap()
        .placed_at(0.0);
    let line_distance = |rho: f64, z: f64| (rho - 0.5 * z - 0.1).abs() / 1.25f64.sqrt();
    // (ρ, z) = (0.2, 0.6): distance |0.2 − 0.3 − 0.1|/√1.25 = 0.2/√1.25 = 0.178885...
    let d = line_distance(0.2, 0.6);
    close(d, 0.2 / 1.25f64.sqrt(), 1e-15);
    // Foot of the perpendicular: (0.2, 0.6) + d (1, −0.5)/√1.25 = (0.36, 0.52).
    let n_in = v(-1.0, 0.0, 0.5) / 1.25f64.sqrt();
    for az in [0.0, 0.61, 2.0, -2.9] {
        let (s, c) = f64::sin_cos(az);
        let rot = |p: Vec3| v(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
        let k = p.contact(rot(v(0.2, 0.0, 0.6)), 0.2, 0.0).unwrap();
        close(k.overlap_m, 0.2 - d, TOL);
        vclose(k.normal, rot(n_in), TOL);
        vclose(k.point, rot(v(0.36, 0.0, 0.52)), TOL);
    }
    // Outside the funnel wall: (ρ, z) = (0.5, 0.6), distance |0.5 − 0.4|/√1.25.
    let k = p.contact(v(0.5, 0.0, 0.6), 0.2, 0.0).unwrap();
    close(k.overlap_m, 0.2 - line_distance(0.5, 0.6), TOL);
    vclose(k.normal, -n_in, TOL);
}

#[test]
fn cone_frustum_rims_and_outlet() {
    let p = Wall::cone_frustum(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.1, 0.6, 1.0, 0)
        .unwrap()
        .placed_at(0.0);
    // Outlet rim (0.1, 0): (ρ, z) = (0.4, −0.4); projection parameter
    // (0.3·0.5 − 0.4·1)/1.25 < 0 → rim; offset (0.3, −0.4) → 0.5; r 0.55.
    let k = p.contact(v(0.4, 0.0, -0.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.6, 0.0, -0.8), TOL);
    vclose(k.point, v(0.1, 0.0, 0.0), TOL);
    // Top rim (0.6, 1): (ρ, z) = (0.9, 1.4); parameter (0.8·0.5 + 1.4)/1.25 > 1 →
    // rim; offset (0.3, 0.4) → 0.5.
    let k = p.contact(v(0.0, -0.9, 1.4), 0.55, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    vclose(k.normal, v(0.0, -0.6, 0.8), TOL);
    vclose(k.point, v(0.0, -0.6, 1.0), TOL);
    // A particle smaller than the outlet passes on the axis: rim distance
    // √(0.1² + 0.05²) = 0.1118 > r = 0.05.
    assert!(p.contact(v(0.0, 0.0, -0.05), 0.05, 0.0).is_none());
    // A larger one sits in the outlet: r 0.2 at z = 0 touches the rim at 0.1.
    let k = p.contact(v(0.0, 0.0, 0.0), 0.2, 0.0).unwrap();
    finite(&k);
    close(k.overlap_m, 0.1, TOL);
}

// ---------------------------------------------------------------- motion

#[test]
fn translating_wall_offset_and_velocity_in_and_out_of_window() {
    let motion = Motion::Translate {
        velocity_m_s: v(0.0, 0.0, 0.1),
        start_s: 1.0,
        end_s: 3.0,
    };
    let w = Wall::plane(Vec3::zeros(), v(0.0, 0.0, 1.0), 0)
        .unwrap()
        .with_motion(motion)
        .unwrap();
    // (t, offset = 0.1·clamp(t − 1, 0, 2), velocity): before, inside, after.
    for (t, off, vel) in [
        (0.5, 0.0, 0.0),
        (1.0, 0.0, 0.1),
        (2.0, 0.1, 0.1),
        (5.0, 0.2, 0.0),
    ] {
        vclose(w.pose_at(t).translation, v(0.0, 0.0, off), TOL);
        let k = w.contact_at(t, v(0.0, 0.0, off + 0.05), 0.1, 0.0).unwrap();
        close(k.overlap_m, 0.05, TOL);
        vclose(k.point, v(0.0, 0.0, off), TOL);
        vclose(k.velocity, v(0.0, 0.0, vel), TOL);
    }
    // A translating rectangle's AABB moves with it: offset 0.1·2 = 0.2 in z at t = 4.
    let r = flat_rect().with_motion(motion).unwrap();
    let (lo, hi) = r.aabb(4.0).unwrap();
    vclose(lo, v(-1.0, -0.5, 0.2), TOL);
    vclose(hi, v(1.0, 0.5, 0.2), TOL);
}

#[test]
fn rotating_drum_keeps_geometry_and_has_surface_velocity() {
    // 30 rpm → ω = 30·2π/60 = π rad/s; R = 0.5 → surface speed ωR = π/2 m/s.
    let motion = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: v(0.0, 0.0, 3.0),
        rpm: 30.0,
        start_s: 0.1,
        end_s: f64::INFINITY,
    };
    close(rpm_to_rad_s(30.0), PI, 1e-15);
    let w = drum_cylinder().with_motion(motion).unwrap();
    let fixed = drum_cylinder().placed_at(0.0);
    let p = w.placed_at(0.37);
    // Point (0.45, 0, 0.5): inner wall at (0.5, 0, 0.5), velocity ω ẑ × (0.5, 0, 0).
    let k = p.contact(v(0.45, 0.0, 0.5), 0.1, 0.0).unwrap();
    let k0 = fixed.contact(v(0.45, 0.0, 0.5), 0.1, 0.0).unwrap();
    close(k.overlap_m, 0.05, TOL);
    close(k.overlap_m, k0.overlap_m, TOL);
    vclose(k.normal, k0.normal, TOL);
    vclose(k.point, k0.point, TOL);
    vclose(k.velocity, v(0.0, PI / 2.0, 0.0), TOL);
    // At azimuth 90°: velocity ω ẑ × (0, 0.5, 0) = (−π/2, 0, 0); tangent ⟂ normal.
    let k = p.contact(v(0.0, 0.45, 0.5), 0.1, 0.0).unwrap();
    vclose(k.velocity, v(-PI / 2.0, 0.0, 0.0), TOL);
    close(k.velocity.dot(&k.normal), 0.0, TOL);
    // Before the start: no velocity, no rotation.
    let k = w.contact_at(0.05, v(0.45, 0.0, 0.5), 0.1, 0.0).unwrap();
    vclose(k.velocity, Vec3::zeros(), 0.0);
    vclose(w.aabb(0.37).unwrap().0, v(-0.5, -0.5, 0.0), TOL);
}

#[test]
fn rotating_rectangle_after_a_quarter_turn() {
    // A brush: rectangle at (1, 0, 0) facing +x, u = y, v = x × y = z; rotating about
    // the z axis through the origin at 15 rpm → ω = π/2 rad/s → a quarter turn at
    // t = 1 s: centre (0, 1, 0), normal +y, u = −x.
    let w = Wall::rectangle(
        v(1.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
        0.2,
        0.3,
        0,
    )
    .unwrap()
    .with_motion(Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: v(0.0, 0.0, 1.0),
        rpm: 15.0,
        start_s: 0.0,
        end_s: f64::INFINITY,
    })
    .unwrap();
    let pose = w.pose_at(1.0);
    vclose(pose.to_world(v(1.0, 0.0, 0.0)), v(0.0, 1.0, 0.0), TOL);
    vclose(pose.to_body(v(0.0, 1.0, 0.0)), v(1.0, 0.0, 0.0), TOL);
    // Quaternion of a 90° turn about z: (cos 45°, 0, 0, sin 45°).
    close(pose.quaternion().w, 0.5f64.sqrt(), TOL);
    close(pose.quaternion().k, 0.5f64.sqrt(), TOL);
    let p = w.placed_at(1.0);
    // Sphere at (0, 1.5, 0), r 0.6: 0.5 in front of the face → overlap 0.1.
    let k = p.contact(v(0.0, 1.5, 0.0), 0.6, 0.0).unwrap();
    close(k.overlap_m, 0.1, TOL);
    vclose(k.normal, v(0.0, 1.0, 0.0), TOL);
    vclose(k.point, v(0.0, 1.0, 0.0), TOL);
    // Velocity ω ẑ × (0, 1, 0) = (−π/2, 0, 0).
    vclose(k.velocity, v(-PI / 2.0, 0.0, 0.0), TOL);
    // The old place is empty.
    assert!(p.contact(v(1.5, 0.0, 0.0), 0.6, 0.0).is_none());
    // AABB: half-extent 0.2 along x (u = −x), 0.3 along z, flat in y.
    let (lo, hi) = p.aabb().unwrap();
    vclose(lo, v(-0.2, 1.0, -0.3), TOL);
    vclose(hi, v(0.2, 1.0, 0.3), TOL);
}

#[test]
fn placed_wall_equals_body_frame_computation() {
    // Contact of a moving wall = move the centre into the body frame, compute there,
    // move point and normal back (velocity from the motion at the world point).
    let motion = Motion::Rotate {
        axis_point: v(0.3, -0.2, 0.1),
        axis_dir: v(1.0, 2.0, 0.5),
        rpm: 47.0,
        start_s: 0.2,
        end_s: f64::INFINITY,
    };
    let shapes = [
        *Wall::cone_frustum(v(0.1, 0.0, 0.2), v(0.2, 0.3, 1.0), 0.1, 0.7, 0.9, 0)
            .unwrap()
            .shape(),
        *Wall::rectangle(
            v(0.0, 0.5, 0.0),
            v(0.0, 1.0, 1.0),
            v(1.0, 0.0, 0.0),
            0.4,
            0.2,
            0,
        )
        .unwrap()
        .shape(),
        *Wall::plane(v(0.0, 0.0, -0.3), v(0.1, 0.0, 1.0), 0)
            .unwrap()
            .shape(),
    ];
    let mut rng = Rng(7);
    for shape in shapes {
        let w = Wall::new(shape, 0, motion).unwrap();
        for &t in &[0.0, 0.9, 2.3] {
            let placed = w.placed_at(t);
            let pose = w.pose_at(t);
            let vel = w.motion().velocity_at(t);
            for _ in 0..200 {
                let c = v(
                    rng.uniform(-1.5, 1.5),
                    rng.uniform(-1.5, 1.5),
                    rng.uniform(-1.5, 1.5),
                );
                let kb = shape.contact(pose.to_body(c), 0.3, 0.5);
                let kw = placed.contact(c, 0.3, 0.5);
                match (kb, kw) {
                    (None, None) => {}
                    (Some(kb), Some(kw)) => {
                        close(kw.overlap_m, kb.overlap_m, 1e-12);
                        vclose(kw.point, pose.to_world(kb.point), 1e-12);
                        vclose(kw.normal, pose.to_world_dir(kb.normal), 1e-12);
                        vclose(kw.velocity, vel.at(kw.point), 1e-12);
                    }
                    // A gap at the range boundary may round either way.
                    (a, b) => {
                        let o = a.or(b).unwrap().overlap_m;
                        close(o, -0.5, 1e-12);
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------- degenerate input

#[test]
fn no_nan_on_degenerate_inputs() {
    let shapes = [
        *flat_rect().shape(),
        *Wall::disk(Vec3::zeros(), v(0.0, 0.0, 1.0), 1.0, 0)
            .unwrap()
            .shape(),
        *drum_cylinder().shape(),
        // A true cone (apex radius 0) and a thin sliver rectangle (half_v = 0).
        *Wall::cone_frustum(Vec3::zeros(), v(0.0, 0.0, 1.0), 0.0, 0.5, 1.0, 0)
            .unwrap()
            .shape(),
        *Wall::rectangle(
            Vec3::zeros(),
            v(0.0, 0.0, 1.0),
            v(1.0, 0.0, 0.0),
            1.0,
            0.0,
            0,
        )
        .unwrap()
        .shape(),
    ];
    // Centres exactly on the surface, on the axis, at the apex, at rims; radius 0.
    let centres = [
        Vec3::zeros(),
        v(0.0, 0.0, 1.0),
        v(0.5, 0.0, 0.5),
        v(0.5, 0.0, 1.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 0.5, 0.0),
        v(0.0, 0.0, 1e-300),
        v(1e-300, 0.0, 0.0),
        v(1.0 + 1e-170, 0.0, 0.0),
    ];
    for s in shapes {
        let p = still(s);
        for c in centres {
            for r in [0.0, 0.1] {
                if let Some(k) = p.contact(c, r, 0.0) {
                    finite(&k);
                }
                let k = p.contact(c, r, 10.0).unwrap();
                finite(&k);
            }
        }
    }
    // Exactly on a disk: normal +axis, zero distance.
    let k = still(shapes[1])
        .contact(v(0.2, 0.0, 0.0), 0.1, 0.0)
        .unwrap();
    close(k.overlap_m, 0.1, 0.0);
    vclose(k.normal, v(0.0, 0.0, 1.0), TOL);
}

#[test]
fn constructors_reject_bad_input_naming_the_field() {
    let z = v(0.0, 0.0, 1.0);
    let o = Vec3::zeros();
    let field = |e: Result<Wall, WallError>| e.unwrap_err().field();
    assert_eq!(field(Wall::plane(o, o, 0)), "normal");
    assert_eq!(field(Wall::plane(v(f64::NAN, 0.0, 0.0), z, 0)), "point");
    assert_eq!(field(Wall::rectangle(o, z, z, 1.0, 1.0, 0)), "u");
    assert_eq!(field(Wall::rectangle(o, z, o, 1.0, 1.0, 0)), "u");
    assert_eq!(
        field(Wall::rectangle(o, z, Vec3::x(), -1.0, 1.0, 0)),
        "half_u_m"
    );
    assert_eq!(
        field(Wall::rectangle(o, z, Vec3::x(), 1.0, f64::INFINITY, 0)),
        "half_v_m"
    );
    assert_eq!(
        field(Wall::rectangle(o, z, Vec3::x(), 0.0, 0.0, 0)),
        "half_u_m"
    );
    assert_eq!(field(Wall::disk(o, o, 1.0, 0)), "normal");
    assert_eq!(field(Wall::disk(o, z, 0.0, 0)), "radius_m");
    assert_eq!(field(Wall::annulus(o, z, 1.0, 0.5, 0)), "outer_radius_m");
    assert_eq!(field(Wall::annulus(o, z, -0.1, 0.5, 0)), "inner_radius_m");
    assert_eq!(field(Wall::cylinder(o, z, -0.5, 1.0, 0)), "radius_m");
    assert_eq!(field(Wall::cylinder(o, z, 0.5, 0.0, 0)), "length_m");
    assert_eq!(field(Wall::cylinder(o, o, 0.5, 1.0, 0)), "axis");
    assert_eq!(
        field(Wall::cylinder(v(0.0, f64::NAN, 0.0), z, 0.5, 1.0, 0)),
        "base_centre"
    );
    assert_eq!(
        field(Wall::cone_frustum(o, z, 0.0, 0.0, 1.0, 0)),
        "radius1_m"
    );
    assert_eq!(
        field(Wall::cone_frustum(o, z, -0.1, 0.3, 1.0, 0)),
        "radius0_m"
    );
    let seg = |r0, z0, r1, z1| {
        RevolvedSegment::new(o, z, r0, z0, r1, z1)
            .unwrap_err()
            .field()
    };
    assert_eq!(seg(0.0, 0.0, 0.0, 1.0), "r1_m");
    assert_eq!(seg(0.5, 1.0, 0.5, 1.0), "z1_m");
    assert_eq!(seg(0.5, f64::NAN, 0.5, 1.0), "z0_m");
    let plane = Wall::plane(o, z, 0).unwrap();
    let motion_field = |m| plane.with_motion(m).unwrap_err().field();
    assert_eq!(
        motion_field(Motion::Translate {
            velocity_m_s: z,
            start_s: 2.0,
            end_s: 1.0
        }),
        "motion.end_s"
    );
    assert_eq!(
        motion_field(Motion::Translate {
            velocity_m_s: z * f64::NAN,
            start_s: 0.0,
            end_s: 1.0
        }),
        "motion.velocity_m_s"
    );
    let rot = |axis_dir, rpm| Motion::Rotate {
        axis_point: o,
        axis_dir,
        rpm,
        start_s: 0.0,
        end_s: f64::INFINITY,
    };
    assert_eq!(motion_field(rot(o, 10.0)), "motion.axis_dir");
    assert_eq!(motion_field(rot(z, f64::NAN)), "motion.rpm");
    // Open-ended translation is allowed; the message names the field.
    assert!(plane
        .with_motion(Motion::Translate {
            velocity_m_s: z,
            start_s: 0.0,
            end_s: f64::INFINITY
        })
        .is_ok());
    let msg = Wall::cylinder(o, z, -0.5, 1.0, 0).unwrap_err().to_string();
    assert!(msg.contains("radius_m") && msg.contains("-0.5"), "{msg}");
}

// ---------------------------------------------------------------- property test

/// splitmix64: a tiny deterministic generator (no crate needed).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// Surface samples and the largest distance from any surface point to its nearest
/// sample (a bound on how much the brute-force minimum can overestimate).
fn sample_surface(shape: &WallShape) -> (Vec<Vec3>, f64) {
    let mut pts = Vec::new();
    match shape {
        WallShape::Rectangle(s) => {
            let n = 300;
            for i in 0..=n {
                for j in 0..=n {
                    let a = s.half_u_m() * (2.0 * i as f64 / n as f64 - 1.0);
                    let b = s.half_v_m() * (2.0 * j as f64 / n as f64 - 1.0);
                    pts.push(s.centre() + s.u() * a + s.v() * b);
                }
            }
            let (du, dv) = (2.0 * s.half_u_m() / n as f64, 2.0 * s.half_v_m() / n as f64);
            (pts, 0.5 * (du * du + dv * dv).sqrt())
        }
        WallShape::Revolved(s) => {
            let (r0, z0, r1, z1) = s.segment();
            let (e1, e2) = (s.perp(), s.axis().cross(&s.perp()));
            let (n, m) = (200, 720);
            for i in 0..=n {
                let f = i as f64 / n as f64;
                let (rho, z) = (r0 + f * (r1 - r0), z0 + f * (z1 - z0));
                for j in 0..m {
                    let (sn, cs) = (2.0 * PI * j as f64 / m as f64).sin_cos();
                    pts.push(s.origin() + s.axis() * z + (e1 * cs + e2 * sn) * rho);
                }
            }
            let along = ((r1 - r0).hypot(z1 - z0)) / n as f64;
            let around = r0.max(r1) * 2.0 * PI / m as f64;
            (pts, 0.5 * (along + around))
        }
        WallShape::Plane(_) => unreachable!(),
    }
}

/// True if `p` lies on the shape's surface (to 1e-12 m).
fn on_surface(shape: &WallShape, p: Vec3) -> bool {
    let eps = 1e-12;
    match shape {
        WallShape::Rectangle(s) => {
            let d = p - s.centre();
            d.dot(&s.normal()).abs() < eps
                && d.dot(&s.u()).abs() <= s.half_u_m() + eps
                && d.dot(&s.v()).abs() <= s.half_v_m() + eps
        }
        WallShape::Revolved(s) => {
            let (r0, z0, r1, z1) = s.segment();
            let w = p - s.origin();
            let z = w.dot(&s.axis());
            let rho = (w - s.axis() * z).norm();
            let (dr, dz) = (r1 - r0, z1 - z0);
            let len = dr.hypot(dz);
            let off_line = ((rho - r0) * dz - (z - z0) * dr).abs() / len;
            let t = ((rho - r0) * dr + (z - z0) * dz) / (len * len);
            off_line < eps && t > -eps && t < 1.0 + eps
        }
        WallShape::Plane(s) => s.signed_distance(p).abs() < eps,
    }
}

#[test]
fn closest_point_is_on_surface_and_is_the_true_minimum() {
    let tilt = v(0.3, -0.4, 1.0);
    let shapes = [
        *Wall::rectangle(v(0.1, 0.2, 0.3), tilt, v(1.0, 0.0, -0.3), 0.6, 0.35, 0)
            .unwrap()
            .shape(),
        *Wall::disk(v(0.0, 0.1, 0.0), tilt, 0.7, 0).unwrap().shape(),
        *Wall::annulus(v(0.0, 0.1, 0.0), v(1.0, 1.0, 0.0), 0.25, 0.7, 0)
            .unwrap()
            .shape(),
        *Wall::cylinder(v(0.0, 0.0, -0.5), tilt, 0.5, 1.0, 0)
            .unwrap()
            .shape(),
        *Wall::cone_frustum(v(0.0, 0.0, -0.5), tilt, 0.15, 0.6, 0.8, 0)
            .unwrap()
            .shape(),
        *Wall::cone_frustum(v(0.0, 0.0, -0.5), -tilt, 0.6, 0.0, 0.8, 0)
            .unwrap()
            .shape(),
    ];
    let mut rng = Rng(2024);
    let r = 5.0; // large enough that every point is reported
    for shape in shapes {
        let p = still(shape);
        let (samples, slack) = sample_surface(&shape);
        let (lo, hi) = p.aabb().unwrap();
        for q in &samples {
            assert!(q.iter().zip(lo.iter()).all(|(a, b)| a >= &(b - 1e-12)));
            assert!(q.iter().zip(hi.iter()).all(|(a, b)| a <= &(b + 1e-12)));
        }
        for i in 0..150 {
            // Some points on the axis of revolved shapes, the rest in a box.
            let c = if i % 25 == 0 {
                match shape {
                    WallShape::Revolved(s) => s.origin() + s.axis() * rng.uniform(-1.0, 1.0),
                    _ => v(0.1, 0.2, 0.3),
                }
            } else {
                v(
                    rng.uniform(-1.2, 1.2),
                    rng.uniform(-1.2, 1.2),
                    rng.uniform(-1.2, 1.2),
                )
            };
            let k = p.contact(c, r, 0.0).unwrap();
            finite(&k);
            assert!(on_surface(&shape, k.point), "{shape:?} {c:?} {k:?}");
            let dist = r - k.overlap_m;
            close((c - k.point).norm(), dist, 1e-12);
            if dist > 1e-9 {
                vclose(k.point + k.normal * dist, c, 1e-12);
            }
            let brute = samples
                .iter()
                .map(|q| (c - q).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(dist <= brute + 1e-12, "not minimal: {dist} > {brute}");
            assert!(
                brute - dist <= slack + 1e-12,
                "too close: {dist} vs {brute}"
            );
        }
    }
}

#[test]
fn rotation_stops_at_the_end_of_its_window() {
    // 60 rpm = 2π rad/s from t = 1 s to t = 1.25 s: a quarter turn, then rest.
    let motion = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: Vec3::y(),
        rpm: 60.0,
        start_s: 1.0,
        end_s: 1.25,
    }
    .validated()
    .unwrap();
    let quarter = motion.pose_at(1.25).to_world(Vec3::x());
    let later = motion.pose_at(9.0).to_world(Vec3::x());
    assert!((quarter - later).norm() < 1e-12);
    assert!(
        (quarter - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-12,
        "{quarter:?}"
    );
    assert!((motion.velocity_at(1.1).angular_rad_s.norm() - std::f64::consts::TAU).abs() < 1e-12);
    assert_eq!(motion.velocity_at(1.25).angular_rad_s, Vec3::zeros());
    assert_eq!(motion.velocity_at(0.5).angular_rad_s, Vec3::zeros());
    let bad = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: Vec3::y(),
        rpm: 60.0,
        start_s: 1.0,
        end_s: 0.5,
    };
    assert_eq!(bad.validated().unwrap_err().field(), "motion.end_s");
}
