//! Rolling resistance: a sphere rolling without slip on a rigid plane under
//! gravity, resisted by a torque of constant magnitude μ_r R F_n, decelerates at
//! a = (5/7) μ_r g (rigid-body dynamics: (m + I/R²) a = μ_r m g with I = 2/5 m R²)
//! and stops after s = v0² / (2a) = 7 v0² / (10 μ_r g). CDT applies that torque
//! from the first step; EPSD reaches it after an elastic rolling angle of
//! μ_r R F_n / k_r (microradians here), so both must stop at s.

mod dem_support;

use dem_support::*;
use repose::dem::particles::ParticleInit;
use repose::dem::simulation::{NormalChoice, RollingChoice, Simulation};
use repose::dem::vec3::Vec3;
use repose::dem::walls::Wall;

const R: f64 = 1e-3;
const RHO: f64 = 2500.0;
const G: f64 = 9.81;

/// A sphere resting at the Hertz equilibrium overlap δ = (3mg / (4E*√R))^{2/3}
/// on a rigid floor, rolling without slip along +x at `v0`.
fn rolling_sphere(rolling: RollingChoice, mu_r: f64, v0: f64) -> Simulation {
    let m = material(1e7, 0.3);
    let c = contact(NormalChoice::Hertz, rolling, m, params(0.5, 0.5, mu_r, 0.0));
    let dt = auto_dt(&c, R, RHO, 0.1);
    let mass = RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let e_star = 1e7 / (1.0 - 0.09);
    let delta = (3.0 * mass * G / (4.0 * e_star * R.sqrt())).powf(2.0 / 3.0);
    let p = [ParticleInit {
        position: Vec3::new(0.0, 0.0, R - delta),
        velocity: Vec3::new(v0, 0.0, 0.0),
        angular_velocity: Vec3::new(0.0, v0 / R, 0.0),
        radius_m: R,
    }];
    let floor = vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0).unwrap()];
    let w = world(
        &p,
        RHO,
        floor,
        Vec3::new(-0.1, -0.1, -0.01),
        Vec3::new(0.1, 0.1, 0.1),
    );
    Simulation::new(w, &setup(c, RHO, true, dt, 0.1 * R)).unwrap()
}

/// Distance rolled until the sphere first stops (m).
fn stopping_distance(rolling: RollingChoice, mu_r: f64, v0: f64) -> f64 {
    let mut sim = rolling_sphere(rolling, mu_r, v0);
    loop {
        sim.advance(1).unwrap();
        if sim.world().particles.velocity[0].x <= 0.0 {
            return sim.world().particles.position[0].x;
        }
        assert!(
            sim.world().time_s < 1.0,
            "{rolling:?}: still rolling after 1 s"
        );
    }
}

#[test]
fn rolling_sphere_stops_where_theory_says() {
    for rolling in [RollingChoice::Cdt, RollingChoice::Epsd] {
        for (mu_r, v0) in [(0.1, 0.05), (0.05, 0.1)] {
            let expected = 7.0 * v0 * v0 / (10.0 * mu_r * G);
            let s = stopping_distance(rolling, mu_r, v0);
            assert!(
                (s / expected - 1.0).abs() < 0.01,
                "{rolling:?} μ_r = {mu_r}: {s} m vs {expected} m"
            );
        }
    }
}

#[test]
fn without_rolling_resistance_the_sphere_keeps_rolling() {
    // The control: the same sphere with no rolling model loses (almost) no speed.
    let mut sim = rolling_sphere(RollingChoice::None, 0.0, 0.05);
    while sim.world().time_s < 0.1 {
        sim.advance(1000).unwrap();
    }
    let v = sim.world().particles.velocity[0].x;
    assert!((v / 0.05 - 1.0).abs() < 0.01, "{v}");
}
