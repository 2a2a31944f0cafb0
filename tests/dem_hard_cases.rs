//! Hard cases: each must stay numerically stable and keep a physical
//! invariant (bounded energy, no NaN, no escape). The engine's own health
//! checks (non-finite state, overlap bound, domain exit, energy growth in
//! closed undriven systems) run throughout; a test fails if any trips.

mod dem_support;

use dem_support::*;
use repose::dem::health::HealthCause;
use repose::dem::simulation::{NormalChoice, RollingChoice, Simulation, World};
use repose::dem::vec3::Vec3;
use repose::dem::walls::{Motion, Wall};

const R: f64 = 1e-3;

fn floor() -> Vec<Wall> {
    vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0).unwrap()]
}

/// Advances in chunks until `t_end` seconds, panicking with the health error.
fn run_until(sim: &mut Simulation, t_end: f64, dt: f64) {
    let steps = ((t_end - sim.world().time_s) / dt).ceil() as u64;
    if let Err(e) = sim.advance(steps) {
        panic!("{e}");
    }
    assert!(all_finite(sim.world()));
}

fn kinetic(w: &World) -> f64 {
    w.particles.kinetic_energy_j()
}

#[test]
fn stiff_glass_at_200_gpa_with_the_automatic_step() {
    // yan2015 ran E up to 200 GPa; the automatic step (0.2 T_R ≈ 1.2e-7 s) must
    // resolve it. A 4×4×4 lattice thrown at a rigid plate at 0.5 m/s.
    let m = material(200e9, 0.25);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::None,
        m,
        params(0.5, 0.5, 0.0, 0.0),
    );
    let dt = auto_dt(&c, R, 2500.0, 1.0);
    let bed = lattice(
        [4, 4, 4],
        2.2e-3,
        Vec3::new(0.0, 0.0, 1.2e-3),
        R,
        1e-4,
        Vec3::new(0.0, 0.0, -0.5),
    );
    let w = world(
        &bed,
        2500.0,
        floor(),
        Vec3::new(-0.05, -0.05, -2e-3),
        Vec3::new(0.05, 0.05, 0.05),
    );
    let mut sim = Simulation::new(w, &setup(c, 2500.0, false, dt, 0.1 * R)).unwrap();
    let e0 = kinetic(sim.world());
    run_until(&mut sim, 0.004, dt);
    assert!(
        kinetic(sim.world()) < e0,
        "impacts with e = 0.5 must lose energy"
    );
    assert!(sim.world().particles.position.iter().all(|x| x.z > 0.0));
}

#[test]
fn restitution_extremes_in_a_falling_bed() {
    // e = 0.01 (nearly critical damping) and e = 1 (no damping, energy kept by
    // the contacts; the closed-system energy check is active in both).
    for e in [0.01, 1.0] {
        let m = material(1e7, 0.3);
        let c = contact(
            NormalChoice::Hertz,
            RollingChoice::None,
            m,
            params(e, 0.3, 0.0, 0.0),
        );
        let dt = auto_dt(&c, R, 2500.0, 0.5);
        let bed = lattice(
            [5, 5, 4],
            2.3e-3,
            Vec3::new(-5e-3, -5e-3, 1.5e-3),
            R,
            1e-4,
            Vec3::zeros(),
        );
        let w = world(
            &bed,
            2500.0,
            floor(),
            Vec3::new(-0.05, -0.05, -2e-3),
            Vec3::new(0.05, 0.05, 0.05),
        );
        let mut sim = Simulation::new(w, &setup(c, 2500.0, true, dt, 0.1 * R)).unwrap();
        run_until(&mut sim, 0.1, dt);
        let p = &sim.world().particles;
        assert!(
            p.position.iter().all(|x| x.z > 0.0),
            "e = {e}: a particle went through the floor"
        );
    }
}

#[test]
fn strongly_cohesive_pu_agglomerate_settles_on_a_plate() {
    // he2019's PU: ρ = 60 kg/m³, E = 3.5e7 Pa, ν = 0.4, Γ = 8 J/m² (top of the
    // calibrated range). For R = 1 mm the Bond number 3πΓR*/(mg) ≈ 3e4.
    let gamma = 8.0;
    let rho = 60.0;
    let m = material(3.5e7, 0.4);
    let mut c = contact(
        NormalChoice::Jkr,
        RollingChoice::Cdt,
        m,
        params(0.3, 0.5, 0.001, gamma),
    );
    c.wall_materials = vec![(material(1e9, 0.3), params(0.3, 0.8, 0.001, 3.0))];
    let weight = rho * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3) * 9.81;
    let bond = 3.0 * std::f64::consts::PI * gamma * 0.5 * R / weight;
    assert!(bond > 1e4, "Bond number {bond}");
    let dt = auto_dt(&c, R, rho, 0.5);
    // Touching lattice (spacing 2R − 1 µm) so the JKR bonds exist from the start.
    let bed = lattice(
        [4, 4, 4],
        2.0 * R - 1e-6,
        Vec3::new(0.0, 0.0, 3e-3),
        R,
        0.0,
        Vec3::zeros(),
    );
    let w = world(
        &bed,
        rho,
        floor(),
        Vec3::new(-0.05, -0.05, -2e-3),
        Vec3::new(0.05, 0.05, 0.05),
    );
    let mut sim = Simulation::new(w, &setup(c, rho, true, dt, 0.1 * R)).unwrap();
    assert!(sim.kernel_name().starts_with("jkr+mindlin+cdt+gravity"));
    run_until(&mut sim, 0.05, dt);
    let p = &sim.world().particles;
    // Still one agglomerate: every particle within the original cube's reach.
    let centre: Vec3 = p.position.iter().sum::<Vec3>() / p.len() as f64;
    assert!(
        p.position.iter().all(|x| (x - centre).norm() < 8.0 * R),
        "the agglomerate broke apart"
    );
    assert!(p.position.iter().all(|x| x.z > 0.0));
    assert!(
        sim.stats().max_overlap_ratio < 0.05,
        "overlap {}",
        sim.stats().max_overlap_ratio
    );
}

#[test]
fn size_ratio_one_to_ten() {
    // A 5 mm sphere dropped on a layer of 0.5 mm spheres resting on a plate.
    let small = 0.5e-3;
    let m = material(1e7, 0.3);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::Cdt,
        m,
        params(0.5, 0.5, 0.05, 0.0),
    );
    let dt = auto_dt(&c, small, 2500.0, 0.5);
    let mut bed = lattice(
        [16, 16, 1],
        1.02e-3,
        Vec3::new(-7.7e-3, -7.7e-3, small),
        small,
        0.0,
        Vec3::zeros(),
    );
    bed.push(repose::dem::particles::ParticleInit {
        position: Vec3::new(0.0, 0.0, 8e-3),
        velocity: Vec3::new(0.0, 0.0, -0.3),
        angular_velocity: Vec3::zeros(),
        radius_m: 10.0 * small,
    });
    let w = world(
        &bed,
        2500.0,
        floor(),
        Vec3::new(-0.05, -0.05, -2e-3),
        Vec3::new(0.05, 0.05, 0.05),
    );
    let mut sim = Simulation::new(w, &setup(c, 2500.0, true, dt, 0.1 * small)).unwrap();
    run_until(&mut sim, 0.05, dt);
    let p = &sim.world().particles;
    let big = p.radius.iter().position(|&r| r > 1e-3).unwrap();
    assert!(
        p.position[big].z > small + 4.0e-3,
        "the big sphere sank into the layer: z = {}",
        p.position[big].z
    );
    assert!(p.position.iter().all(|x| x.z > 0.0));
}

/// One sphere (E = 10 MPa, e = 0.5, μ = 0.3, no gravity, step designed for
/// 1 m/s) among `walls` in the box `lo`..`hi`.
fn single_sphere(
    position: Vec3,
    velocity: Vec3,
    walls: Vec<Wall>,
    lo: Vec3,
    hi: Vec3,
) -> (Simulation, f64) {
    let m = material(1e7, 0.3);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::None,
        m,
        params(0.5, 0.3, 0.0, 0.0),
    );
    let dt = auto_dt(&c, R, 2500.0, 1.0);
    let p = [repose::dem::particles::ParticleInit {
        position,
        velocity,
        angular_velocity: Vec3::zeros(),
        radius_m: R,
    }];
    let w = world(&p, 2500.0, walls, lo, hi);
    (
        Simulation::new(w, &setup(c, 2500.0, false, dt, 0.1 * R)).unwrap(),
        dt,
    )
}

/// Drops one sphere (no gravity, 1 m/s down) at horizontal distance `rho`
/// from the axis onto a wall; returns its final velocity.
fn strike(wall: Wall, rho: f64, z0: f64) -> Vec3 {
    let (mut sim, dt) = single_sphere(
        Vec3::new(rho, 0.0, z0),
        Vec3::new(0.0, 0.0, -1.0),
        vec![wall],
        Vec3::new(-0.1, -0.1, -0.1),
        Vec3::new(0.1, 0.1, 0.1),
    );
    let e0 = kinetic(sim.world());
    run_until(&mut sim, 0.02, dt);
    assert!(
        kinetic(sim.world()) <= e0 * (1.0 + 1e-9),
        "a rim impact gained energy"
    );
    sim.world().particles.velocity[0]
}

#[test]
fn sphere_striking_a_cylinder_rim_and_a_cone_edge() {
    // Open cylinder of radius 10 mm, top rim at z = 20 mm; cone frustum with
    // its upper rim (radius 20 mm) at z = 20 mm. A sphere landing on a rim
    // within half a radius of it must bounce back up, never fall through; at
    // any offset it must not gain energy.
    let cylinder = || Wall::cylinder(Vec3::zeros(), Vec3::z(), 10e-3, 20e-3, 0).unwrap();
    let cone = || Wall::cone_frustum(Vec3::zeros(), Vec3::z(), 5e-3, 20e-3, 20e-3, 0).unwrap();
    for (name, rim) in [("cylinder", 10e-3), ("cone", 20e-3)] {
        for k in -6..=6 {
            let offset = k as f64 * 0.25 * R;
            let wall = if name == "cylinder" {
                cylinder()
            } else {
                cone()
            };
            let v = strike(wall, rim + offset, 20e-3 + 1.5 * R);
            if offset.abs() <= 0.5 * R {
                assert!(
                    v.z > 0.0,
                    "{name} rim, offset {offset}: went through (v = {v:?})"
                );
            }
        }
    }
}

#[test]
fn drum_at_200_rpm_keeps_every_particle_inside() {
    // A 40 mm drum (axis y, 10 mm deep, end caps) with 60 particles, spun
    // at 200 rpm for 0.3 s: particles stay inside the drum and finite.
    let spin = Motion::Rotate {
        axis_point: Vec3::zeros(),
        axis_dir: Vec3::y(),
        rpm: 200.0,
        start_s: 0.0,
        end_s: f64::INFINITY,
    };
    let walls = vec![
        Wall::cylinder(Vec3::new(0.0, -5e-3, 0.0), Vec3::y(), 20e-3, 10e-3, 0)
            .unwrap()
            .with_motion(spin)
            .unwrap(),
        Wall::disk(Vec3::new(0.0, -5e-3, 0.0), Vec3::y(), 20e-3, 0)
            .unwrap()
            .with_motion(spin)
            .unwrap(),
        Wall::disk(Vec3::new(0.0, 5e-3, 0.0), Vec3::y(), 20e-3, 0)
            .unwrap()
            .with_motion(spin)
            .unwrap(),
    ];
    let m = material(1e7, 0.3);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::Cdt,
        m,
        params(0.5, 0.5, 0.1, 0.0),
    );
    let dt = auto_dt(&c, R, 2500.0, 1.0);
    let bed = lattice(
        [5, 3, 4],
        2.4e-3,
        Vec3::new(-5e-3, -2.4e-3, -16e-3),
        R,
        1e-4,
        Vec3::zeros(),
    );
    let w = world(
        &bed,
        2500.0,
        walls,
        Vec3::new(-0.03, -0.01, -0.03),
        Vec3::new(0.03, 0.01, 0.03),
    );
    let mut sim = Simulation::new(w, &setup(c, 2500.0, true, dt, 0.1 * R)).unwrap();
    run_until(&mut sim, 0.3, dt);
    let p = &sim.world().particles;
    for x in &p.position {
        assert!(
            (x.x * x.x + x.z * x.z).sqrt() < 20e-3 && x.y.abs() < 5e-3,
            "escaped: {x:?}"
        );
    }
}

#[test]
fn impact_far_beyond_the_design_speed_is_refused_or_survives() {
    // The step is designed for 1 m/s; a 30 m/s impact either stays physical
    // (no energy gain) or is stopped by the overlap bound — never NaN.
    let (mut sim, dt) = single_sphere(
        Vec3::new(0.0, 0.0, 1.1 * R),
        Vec3::new(0.0, 0.0, -30.0),
        floor(),
        Vec3::new(-0.1, -0.1, -0.01),
        Vec3::new(0.1, 0.1, 0.1),
    );
    let e0 = kinetic(sim.world());
    match sim.advance((0.001 / dt) as u64) {
        Ok(()) => {
            assert!(all_finite(sim.world()));
            assert!(kinetic(sim.world()) < e0, "gained energy");
        }
        Err(e) => assert!(matches!(e.cause, HealthCause::Overlap { .. }), "{e}"),
    }
}

#[test]
fn a_step_that_carries_a_sphere_past_its_partner_is_tunnelling() {
    // The step is designed for 1 m/s (8.9e-6 s); at 200 m/s a sphere moves
    // 1.8 radii per step: from 0.1 mm above a resting sphere it would land
    // 1.7 mm deep in it, and a little faster it would pass through it
    // untouched. The first drift must stop the run and name the mover.
    let m = material(1e7, 0.3);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::None,
        m,
        params(0.5, 0.3, 0.0, 0.0),
    );
    let dt = auto_dt(&c, R, 2500.0, 1.0);
    let at = |z: f64, vz: f64| repose::dem::particles::ParticleInit {
        position: Vec3::new(0.0, 0.0, z),
        velocity: Vec3::new(0.0, 0.0, vz),
        angular_velocity: Vec3::zeros(),
        radius_m: R,
    };
    let w = world(
        &[at(0.0, 0.0), at(2.1 * R, -200.0)],
        2500.0,
        vec![],
        Vec3::new(-0.1, -0.1, -0.1),
        Vec3::new(0.1, 0.1, 0.1),
    );
    let mut sim = Simulation::new(w, &setup(c, 2500.0, false, dt, 0.1 * R)).unwrap();
    let e = sim.advance(100).unwrap_err();
    let HealthCause::Tunnelling {
        displacement_m,
        radius_m,
        limit,
    } = e.cause
    else {
        panic!("{e}");
    };
    assert_eq!((e.particle_id, e.step), (1, 1), "{e}");
    assert!((e.time_s / dt - 1.0).abs() < 1e-12, "{e}");
    assert!((displacement_m / (200.0 * dt) - 1.0).abs() < 1e-12, "{e}");
    assert_eq!((radius_m, limit), (R, 0.3));
    assert!(e.to_string().contains("tunnelling: moved"), "{e}");
}

#[test]
fn an_unstable_step_is_stopped_with_particle_step_and_cause() {
    // 50× the automatic step in an undamped bed: the health checks must stop
    // the run and name the particle, the step and the time.
    let m = material(1e7, 0.3);
    let c = contact(
        NormalChoice::Hertz,
        RollingChoice::None,
        m,
        params(1.0, 0.0, 0.0, 0.0),
    );
    let dt = 50.0 * auto_dt(&c, R, 2500.0, 1.0);
    let bed = lattice(
        [4, 4, 4],
        2.05e-3,
        Vec3::new(0.0, 0.0, 1.1e-3),
        R,
        2e-5,
        Vec3::zeros(),
    );
    let w = world(
        &bed,
        2500.0,
        floor(),
        Vec3::new(-0.05, -0.05, -2e-3),
        Vec3::new(0.05, 0.05, 0.05),
    );
    let mut sim = Simulation::new(w, &setup(c, 2500.0, true, dt, 0.1 * R)).unwrap();
    let e = sim.advance(100_000).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("particle") && text.contains("step") && text.contains("t ="),
        "{text}"
    );
}

#[test]
fn leaving_the_domain_is_reported() {
    let (mut sim, dt) = single_sphere(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        vec![],
        Vec3::new(-0.01, -0.01, -0.01),
        Vec3::new(0.01, 0.01, 0.01),
    );
    let e = sim.advance(1_000_000).unwrap_err();
    assert!(matches!(e.cause, HealthCause::LeftDomain { .. }), "{e}");
    assert_eq!(e.particle_id, 0);
    assert!(
        (e.time_s - 0.01).abs() < 2.0 * dt,
        "left at t = {}",
        e.time_s
    );
}
