//! Rigid clumps in the engine: free rotation, rest on a plane, impacts,
//! bit-identical results on any thread count, and health failures that name
//! their clump and, for clumps placed overlapping, the placement.

mod dem_support;

use dem_support::*;
use nalgebra::UnitQuaternion;
use repose::dem::clump::bodies::ClumpInit;
use repose::dem::clump::template::{ClumpShape, ClumpTemplate, Member};
use repose::dem::domain::Domain;
use repose::dem::health::HealthCause;
use repose::dem::simulation::{NormalChoice, RollingChoice, SetupError, Simulation, World};
use repose::dem::vec3::Vec3;
use repose::dem::walls::Wall;

const RHO: f64 = 2500.0;
const R: f64 = 1e-3;

/// An asymmetric three-member clump (no two principal moments equal).
fn asymmetric() -> ClumpShape {
    let members = vec![
        Member {
            offset: Vec3::zeros(),
            radius_m: 1.0,
        },
        Member {
            offset: Vec3::new(1.2, 0.0, 0.0),
            radius_m: 1.0,
        },
        Member {
            offset: Vec3::new(0.0, 0.9, 0.0),
            radius_m: 0.8,
        },
    ];
    ClumpTemplate::new("asymmetric", members).unwrap().shape(R)
}

fn paired() -> ClumpShape {
    ClumpTemplate::paired_spheres(1.3).unwrap().shape(R)
}

fn clump_world(shapes: Vec<ClumpShape>, walls: Vec<Wall>, lo: Vec3, hi: Vec3) -> World {
    World::with_clumps(walls, Domain::new(lo, hi, [false; 3]).unwrap(), shapes)
}

fn init(position: Vec3, orientation: UnitQuaternion<f64>, v: Vec3, w: Vec3) -> ClumpInit {
    ClumpInit {
        shape: 0,
        position,
        orientation,
        velocity: v,
        angular_velocity: w,
    }
}

/// Adds a clump of shape 0 at `position` (see [`init`]) of density [`RHO`].
fn push(world: &mut World, position: Vec3, q: UnitQuaternion<f64>, v: Vec3, w: Vec3) {
    world.push_clump(&init(position, q, v, w), RHO).unwrap();
}

fn contact_setup(rolling: RollingChoice, mu_r: f64) -> repose::dem::simulation::ContactSetup {
    contact(
        NormalChoice::Hertz,
        rolling,
        material(1e7, 0.3),
        params(0.5, 0.5, mu_r, 0.0),
    )
}

#[test]
fn free_asymmetric_clump_keeps_its_angular_momentum_and_energy() {
    // Torque-free: L is untouched by the drift (bit for bit) and the
    // NO_SQUISH splitting keeps the kinetic energy within O((ω dt)²).
    let shape = asymmetric();
    let mut world = clump_world(
        vec![shape],
        Vec::new(),
        Vec3::from_element(-1.0),
        Vec3::from_element(1.0),
    );
    // Spin mostly about the intermediate (unstable) axis: it tumbles.
    let q0 = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.1);
    let w0 = q0.transform_vector(&Vec3::new(20.0, 300.0, 20.0));
    push(&mut world, Vec3::zeros(), q0, Vec3::new(0.1, 0.0, 0.0), w0);
    let c = contact_setup(RollingChoice::None, 0.0);
    let dt = 1e-5;
    let mut sim = Simulation::new(world, &setup(c, RHO, false, dt, 1e-4)).unwrap();
    let bodies = |s: &Simulation| s.world().bodies.clone().unwrap();
    let (l0, e0) = (
        bodies(&sim).angular_momentum[0],
        bodies(&sim).kinetic_energy_j(),
    );
    let mut e_err: f64 = 0.0;
    let mut flips = 0;
    let mut last = 1.0;
    for _ in 0..500 {
        sim.advance(100).unwrap();
        let b = bodies(&sim);
        e_err = e_err.max((b.kinetic_energy_j() / e0 - 1.0).abs());
        let along = b.orientation[0].inverse_transform_vector(&l0).y.signum();
        if along != last {
            flips += 1;
            last = along;
        }
        assert_eq!(
            b.angular_momentum[0], l0,
            "L must not change without torque"
        );
    }
    assert!(flips >= 4, "it should tumble: {flips} flips");
    assert!(e_err < 1e-5, "kinetic energy error {e_err}");
    let b = bodies(&sim);
    let t = sim.world().time_s;
    assert!((b.position[0].x - 0.1 * t).abs() < 1e-12);
    // The members move with the body: rigid distances kept.
    let p = &sim.world().particles;
    let d01 = (p.position[0] - p.position[1]).norm();
    let s = &b.shapes[0];
    let d01_shape = (s.members[0].offset - s.members[1].offset).norm();
    assert!((d01 / d01_shape - 1.0).abs() < 1e-12);
}

#[test]
fn a_paired_sphere_dropped_on_a_plane_comes_to_rest_lying_flat() {
    let shape = paired();
    let r_member = shape.members[0].radius_m;
    let floor = Wall::plane(Vec3::zeros(), Vec3::z(), 0).unwrap();
    let mut world = clump_world(
        vec![shape],
        vec![floor],
        Vec3::new(-0.02, -0.02, -0.001),
        Vec3::new(0.02, 0.02, 0.02),
    );
    // Tilted 50° about y, sliding sideways, dropped from 5 mm. (With a
    // spin about its long axis it can land upright and spin like a top.)
    let q = UnitQuaternion::from_euler_angles(0.0, 50f64.to_radians(), 0.2);
    push(
        &mut world,
        Vec3::new(0.0, 0.0, 0.005),
        q,
        Vec3::new(0.01, 0.0, 0.0),
        Vec3::zeros(),
    );
    let c = contact_setup(RollingChoice::Cdt, 0.1);
    let dt = auto_dt(&c, r_member, RHO, 1.0);
    let mut sim = Simulation::new(world, &setup(c, RHO, true, dt, 1e-4)).unwrap();
    let steps = (0.6 / dt) as u64;
    sim.advance(steps).unwrap();
    let b = sim.world().bodies.clone().unwrap();
    let speed = b.velocity[0].norm();
    let spin = b.angular_velocity(0).norm();
    assert!(speed < 1e-4, "still moving at {speed} m/s");
    assert!(spin < 0.1, "still turning at {spin} rad/s");
    // Lying flat: the long axis (principal x) horizontal, both members on
    // the floor (centres at one member radius, less the small overlap).
    let axis = b.orientation[0].transform_vector(&Vec3::x());
    assert!(axis.z.abs() < 0.01, "long axis {axis:?}");
    for z in sim.world().particles.position.iter().map(|x| x.z) {
        assert!((z / r_member - 1.0).abs() < 0.01, "member at z = {z}");
    }
}

/// Two paired-sphere clumps meet off-centre with spin and bounce apart.
fn impact(threads: usize) -> (World, Vec3, Vec3) {
    let shapes = vec![paired()];
    let mut world = clump_world(
        shapes,
        Vec::new(),
        Vec3::from_element(-0.05),
        Vec3::from_element(0.05),
    );
    let qa = UnitQuaternion::from_euler_angles(0.1, 0.4, -0.3);
    let qb = UnitQuaternion::from_euler_angles(-0.7, 0.2, 1.1);
    push(
        &mut world,
        Vec3::new(-0.003, 0.0004, 0.0),
        qa,
        Vec3::new(0.5, 0.0, 0.02),
        Vec3::new(0.0, 30.0, -10.0),
    );
    push(
        &mut world,
        Vec3::new(0.003, -0.0003, 0.0002),
        qb,
        Vec3::new(-0.4, 0.05, 0.0),
        Vec3::new(15.0, 0.0, 5.0),
    );
    let b0 = world.bodies.clone().unwrap();
    let (p0, l0) = (b0.momentum(), b0.angular_momentum_about_origin());
    let c = contact_setup(RollingChoice::Cdt, 0.05);
    let dt = auto_dt(&c, R, RHO, 1.0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let world = pool.install(|| {
        let mut sim = Simulation::new(world, &setup(c, RHO, false, dt, 1e-4)).unwrap();
        sim.advance((0.02 / dt) as u64).unwrap();
        sim.world().clone()
    });
    (world, p0, l0)
}

#[test]
fn clump_impacts_conserve_momentum_and_angular_momentum() {
    let (world, p0, l0) = impact(1);
    let b = world.bodies.unwrap();
    // They met: both velocities changed direction along x.
    assert!(
        b.velocity[0].x < 0.3 && b.velocity[1].x > -0.3,
        "{:?}",
        b.velocity
    );
    let (p1, l1) = (b.momentum(), b.angular_momentum_about_origin());
    // Pair forces are equal and opposite: momentum is kept to rounding.
    assert!((p1 - p0).norm() < 1e-12 * p0.norm(), "{p0:?} -> {p1:?}");
    // Contact forces act at one point and rolling torques are couples:
    // angular momentum about the origin is kept to rounding as well.
    assert!((l1 - l0).norm() < 1e-9 * l0.norm(), "{l0:?} -> {l1:?}");
}

#[test]
fn clump_runs_are_bit_identical_on_one_and_two_threads() {
    let (a, _, _) = impact(1);
    let (b, _, _) = impact(2);
    assert_eq!(a.particles.position, b.particles.position);
    assert_eq!(a.particles.velocity, b.particles.velocity);
    let (ba, bb) = (a.bodies.unwrap(), b.bodies.unwrap());
    assert_eq!(ba.orientation, bb.orientation);
    assert_eq!(ba.angular_momentum, bb.angular_momentum);
}

/// A heap of 150 clumps of two shapes (paired spheres and the three-member
/// asymmetric clump, alternating, so that the bodies' member counts differ)
/// thrown with random velocities and spins onto a floor, periodic sideways,
/// and run for 6,000 steps on `threads` threads; returns the world.
fn heap(threads: usize) -> World {
    // Bounding spheres 5 % apart on a cubic lattice, any orientation, five
    // by five in a box periodic along x and y.
    let shapes = vec![paired(), asymmetric()];
    let reach = shapes
        .iter()
        .map(|s| s.bounding_radius_m)
        .fold(0.0, f64::max);
    let spacing = 2.1 * reach;
    let floor = Wall::plane(Vec3::zeros(), Vec3::z(), 0).unwrap();
    let domain = Domain::new(
        Vec3::new(-2.5 * spacing, -2.5 * spacing, -reach),
        Vec3::new(2.5 * spacing, 2.5 * spacing, 12.0 * spacing),
        [true, true, false],
    )
    .unwrap();
    let mut world = World::with_clumps(vec![floor], domain, shapes);
    let mut rng = SplitMix(7);
    let mut jitter =
        |scale: f64| Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * scale;
    for k in 0..150 {
        let (i, j, l) = (k % 5, (k / 5) % 5, k / 25);
        let centre = Vec3::new(i as f64 - 2.0, j as f64 - 2.0, l as f64 + 0.55) * spacing;
        let init = ClumpInit {
            shape: k % 2,
            position: centre,
            orientation: UnitQuaternion::from_scaled_axis(jitter(6.0)),
            velocity: jitter(1.0),
            angular_velocity: jitter(500.0),
        };
        world.push_clump(&init, RHO).unwrap();
    }
    let c = contact_setup(RollingChoice::Cdt, 0.05);
    let dt = auto_dt(&c, R, RHO, 1.0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut sim = Simulation::new(world, &setup(c, RHO, true, dt, 2e-4)).unwrap();
        sim.advance(6_000).unwrap();
        // They collide and pile up on the floor.
        let stats = sim.stats();
        eprintln!("{threads} threads: dt {dt:.3e} s, {stats:?}");
        assert!(
            stats.contacts >= 10 && stats.wall_contacts >= 10,
            "{stats:?}"
        );
        sim.world().clone()
    })
}

#[test]
fn a_heap_of_clumps_is_bit_identical_on_one_two_and_three_threads() {
    // Three threads cut the 150 bodies and their members into three
    // shares each, two into two; the bodies' sums must not notice.
    let one = heap(1);
    for threads in [2, 3] {
        let other = heap(threads);
        let (p, q) = (&one.particles, &other.particles);
        assert!(p.id == q.id, "{threads} threads: particle order");
        for (name, a, b) in [
            ("position", &p.position, &q.position),
            ("velocity", &p.velocity, &q.velocity),
            ("angular velocity", &p.angular_velocity, &q.angular_velocity),
            ("force", &p.force, &q.force),
            ("torque", &p.torque, &q.torque),
        ] {
            assert!(a == b, "{threads} threads: member {name} differs");
        }
        let (a, b) = (one.bodies.as_ref().unwrap(), other.bodies.as_ref().unwrap());
        for (name, x, y) in [
            ("position", &a.position, &b.position),
            ("velocity", &a.velocity, &b.velocity),
            ("angular momentum", &a.angular_momentum, &b.angular_momentum),
            ("force", &a.force, &b.force),
            ("torque", &a.torque, &b.torque),
        ] {
            assert!(x == y, "{threads} threads: body {name} differs");
        }
        assert!(
            a.orientation == b.orientation,
            "{threads} threads: orientation"
        );
    }
}

#[test]
fn members_of_one_clump_never_touch_and_spheres_cannot_enter_a_clump_world() {
    let mut world = clump_world(
        vec![paired()],
        Vec::new(),
        Vec3::from_element(-0.01),
        Vec3::from_element(0.01),
    );
    push(
        &mut world,
        Vec3::zeros(),
        UnitQuaternion::identity(),
        Vec3::zeros(),
        Vec3::zeros(),
    );
    let c = contact_setup(RollingChoice::None, 0.0);
    let dt = auto_dt(&c, R, RHO, 1.0);
    let mut sim = Simulation::new(world, &setup(c, RHO, false, dt, 1e-4)).unwrap();
    sim.advance(10).unwrap();
    // The members overlap by 0.4 of a radius (aspect 1.3) yet carry no contact.
    assert_eq!(sim.stats().contacts, 0);
    let b = sim.world().bodies.clone().unwrap();
    assert_eq!(b.velocity[0], Vec3::zeros());
    let err = sim
        .insert(&[repose::dem::particles::ParticleInit {
            position: Vec3::new(0.005, 0.0, 0.0),
            velocity: Vec3::zeros(),
            angular_velocity: Vec3::zeros(),
            radius_m: R,
        }])
        .unwrap_err();
    assert!(err.to_string().contains("clumps"), "{err}");
    let err = sim
        .insert_clumps(&[ClumpInit {
            shape: 3,
            ..init(
                Vec3::zeros(),
                UnitQuaternion::identity(),
                Vec3::zeros(),
                Vec3::zeros(),
            )
        }])
        .unwrap_err();
    assert!(err.to_string().contains("shape = 3"), "{err}");
}

#[test]
fn a_health_failure_names_the_member_sphere_and_its_clump() {
    let mut world = clump_world(
        vec![paired()],
        Vec::new(),
        Vec3::from_element(-0.005),
        Vec3::from_element(0.005),
    );
    for x in [-0.002, 0.002] {
        push(
            &mut world,
            Vec3::new(x, 0.0, 0.0),
            UnitQuaternion::identity(),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::zeros(),
        );
    }
    let c = contact_setup(RollingChoice::None, 0.0);
    let dt = auto_dt(&c, R, RHO, 1.0);
    let mut sim = Simulation::new(world, &setup(c, RHO, false, dt, 1e-4)).unwrap();
    // Both clumps fly up out of the box; the lower-indexed member leaves first.
    let err = sim.advance((0.01 / dt) as u64).unwrap_err();
    let body = err.body_id.expect("a clump world names the body");
    let b = sim.world().bodies.clone().unwrap();
    assert!(b.member_ids(body as usize).contains(&err.particle_id));
    let text = err.to_string();
    assert!(
        text.contains(&format!("member sphere of clump {body}"))
            && text.contains("left the domain"),
        "{text}"
    );
}

#[test]
fn an_overlap_found_at_step_0_blames_the_placement_not_the_time_step() {
    // End to end along x, 1.8 mm apart: the facing members (radius 0.89 mm,
    // 0.27 mm off the centres) overlap by 0.57 of a radius, beyond the 0.3
    // bound, before anything moved.
    let mut world = clump_world(
        vec![paired()],
        Vec::new(),
        Vec3::from_element(-0.005),
        Vec3::from_element(0.005),
    );
    for x in [-0.0009, 0.0009] {
        push(
            &mut world,
            Vec3::new(x, 0.0, 0.0),
            UnitQuaternion::identity(),
            Vec3::zeros(),
            Vec3::zeros(),
        );
    }
    let c = contact_setup(RollingChoice::None, 0.0);
    let dt = auto_dt(&c, R, RHO, 1.0);
    let err = Simulation::new(world, &setup(c, RHO, false, dt, 1e-4)).unwrap_err();
    let SetupError::Health(e) = &err else {
        panic!("{err}")
    };
    assert_eq!(e.step, 0);
    assert!(
        matches!(e.cause, HealthCause::Overlap { ratio, .. } if ratio > 0.5),
        "{e}"
    );
    let text = err.to_string();
    assert!(
        text.contains("the initial placement put them overlapping")
            && !text.contains("time step too large"),
        "{text}"
    );
}
