//! The drum scene end to end on a small periodic slice: a physical ordering
//! that a broken scene, measurement or contact law would violate, and the
//! result's bookkeeping.

mod common;

use repose::manifest::{parse_experiment, Experiment};
use repose::scenes::responses::{catalogue, response};
use repose::scenes::run_experiment;

/// A 30 mm drum slice of 1 mm glass-like spheres (soft: E = 5 MPa), 30 rpm.
fn drum(mu: f64, mu_r: f64) -> Experiment {
    let text = format!(
        r#"{{
  "schema_version": 1, "physics_version": 1, "profile": "smoke",
  "scene": {{ "kind": "drum", "inner_diameter_m": 0.03, "length_m": 0.1, "fill_fraction": 0.3,
             "rpm": 30, "rotation_time_s": 1.0, "standing_time_s": 0.2, "wall_material": "steel",
             "periodic_slice_m": 0.006, "settle_max_s": 0.3, "sample_interval_s": 0.02 }},
  "material": {{ "particle": {{ "density_kg_m3": 2500, "youngs_modulus_pa": 5e6, "poisson_ratio": 0.3,
                              "size": {{ "kind": "monodisperse", "radius_m": 0.001 }} }},
                 "walls": {{ "steel": {{ "youngs_modulus_pa": 2e11, "poisson_ratio": 0.3, "density_kg_m3": 7850 }} }} }},
  "contact": {{ "model": {{ "normal": "hertz", "rolling": "cdt" }},
               "particle_particle": {{ "restitution": 0.5, "static_friction": {mu}, "rolling_friction": {mu_r}, "surface_energy_j_m2": 0 }},
               "particle_wall": {{ "steel": {{ "restitution": 0.5, "static_friction": 0.8, "rolling_friction": 0.1, "surface_energy_j_m2": 0 }} }} }},
  "seeds": {{ "design_seed": 0, "sample_index": 0, "packing_seed": 7 }},
  "time_step": {{ "rayleigh_fraction": 0.2, "design_impact_speed_m_s": 0.3 }}
}}"#
    );
    parse_experiment(&text).unwrap()
}

#[test]
fn rougher_particles_stand_steeper_in_the_drum() {
    // Every angle-of-repose study (yan2015 Fig. 10, cai2024 Table 1) finds the
    // angle growing with sliding and rolling friction; 0.1/0.0 against 0.8/0.3
    // must differ by several degrees.
    let smooth = run_experiment(&drum(0.1, 0.0), None).unwrap();
    let rough = run_experiment(&drum(0.8, 0.3), None).unwrap();
    let angle = |r: &repose::store::RunResult| r.measurements["dynamic_angle_deg"];
    eprintln!(
        "dynamic angle: smooth {:.2}, rough {:.2}",
        angle(&smooth),
        angle(&rough)
    );
    assert!(
        angle(&rough) > angle(&smooth) + 5.0,
        "rough {} vs smooth {}",
        angle(&rough),
        angle(&smooth)
    );
    for r in [&smooth, &rough] {
        // Resolution by hand: the 30 mm drum is 15 diameters of 2 mm across;
        // a 30 % fill of radius 15 mm is a segment of central angle θ with
        // θ − sin θ = 0.6π, 15 (1 − cos θ/2) mm = 5.1023 diameters deep
        // (scipy: `th = brentq(lambda t: t - sin(t) - 0.6*pi, 0, 2*pi)`,
        // `7.5*(1 - cos(th/2))`); at 30 rpm Fr = π² · 0.015 / 9.81 = 0.01509,
        // above the rolling regime.
        common::assert_figure(r, "drum_diameters", 15.0, true);
        common::assert_figure(r, "bed_depth_diameters", 5.10231367657122, true);
        common::assert_figure(r, "froude_number", 0.01509113822796538, true);
        assert!(
            r.kernel.starts_with("hertz+mindlin+cdt+gravity+periodic"),
            "{}",
            r.kernel
        );
        assert!(r.measurements["dynamic_angle_samples"] >= 20.0);
        assert!(r.measurements["particles"] > 100.0);
        assert!(r.traces.contains_key("angle") && r.traces.contains_key("kinetic_energy"));
        let a = angle(r);
        assert!(a > 5.0 && a < 70.0, "implausible dynamic angle {a}");
        // Both named responses read from the run, as the measurements they name.
        for name in ["dynamic_angle_deg", "static_angle_deg"] {
            assert_eq!(response(r, "drum", name).unwrap(), r.measurements[name]);
        }
        let names: Vec<_> = catalogue("drum").unwrap().iter().map(|s| s.name).collect();
        assert_eq!(names, ["dynamic_angle_deg", "static_angle_deg"]);
        let err = response(r, "drum", "angle_deg").unwrap_err().to_string();
        assert!(
            err.contains("its responses are: dynamic_angle_deg, static_angle_deg"),
            "{err}"
        );
    }
    // A run without a dynamic window says so, naming the response and the run.
    let mut windowless = smooth.clone();
    windowless.measurements.remove("dynamic_angle_deg");
    let err = response(&windowless, "drum", "dynamic_angle_deg")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("did not measure response 'dynamic_angle_deg'")
            && err.contains(smooth.id.short(12)),
        "{err}"
    );
}

#[test]
fn a_looser_at_rest_criterion_ends_the_settle_sooner() {
    // Measured with repose run on this slice with settle_max_s = 0.5 s: the
    // default criterion (1e-6 m g d for 0.05 s) is not met within 0.5 s, while
    // 1e-3 m g d is met after about 0.2 s. The drum must start at the moment
    // the manifest's criterion says, not at a hard-wired one.
    let settle = |fraction: f64| {
        let mut e = drum(0.5, 0.1);
        e.scene = match e.scene {
            repose::manifest::Scene::Drum(mut d) => {
                d.settle_max_s = 0.5;
                d.rotation_time_s = 0.1;
                d.standing_time_s = 0.02;
                repose::manifest::Scene::Drum(d)
            }
            _ => unreachable!(),
        };
        e.at_rest.kinetic_energy_fraction = fraction;
        let r = run_experiment(&e, None).unwrap();
        (
            r.measurements["settled"],
            r.measurements["rotation_start_s"],
        )
    };
    let (strict_settled, strict_start) = settle(1e-6);
    let (loose_settled, loose_start) = settle(1e-3);
    assert_eq!(loose_settled, 1.0);
    assert!(
        loose_start < strict_start - 0.05,
        "loose {loose_start} s, strict {strict_start} s (settled {strict_settled})"
    );
}
