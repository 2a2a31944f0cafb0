//! Coarse graining is applied in one place (scenes::physics) and means exactly
//! what the manifest says: a coarse-grained experiment simulates the same
//! particles as an experiment that states the scaled particle directly, and
//! result.json reports the factors and the cohesion numbers.

use repose::manifest::{parse_experiment, Experiment};
use repose::scenes::run_experiment;
use repose::store::RunResult;

/// A tiny cohesive drum slice (a few hundred steps of rotation): radius,
/// Young's modulus and pp/pw surface energy as given, plus an optional
/// `coarse_graining` block.
fn drum(radius_m: f64, youngs_pa: f64, gamma: f64, coarse: &str) -> Experiment {
    let text = format!(
        r#"{{
  "schema_version": 1, "physics_version": 1, "profile": "smoke",
  "scene": {{ "kind": "drum", "inner_diameter_m": 0.03, "length_m": 0.1, "fill_fraction": 0.25,
             "rpm": 30, "rotation_time_s": 0.12, "standing_time_s": 0.02, "wall_material": "steel",
             "periodic_slice_m": 0.006, "settle_max_s": 0.05, "sample_interval_s": 0.02 }},
  "material": {{ "particle": {{ "density_kg_m3": 1000, "youngs_modulus_pa": {youngs_pa:e}, "poisson_ratio": 0.3,
                              "size": {{ "kind": "monodisperse", "radius_m": {radius_m:e} }} }},
                 "walls": {{ "steel": {{ "youngs_modulus_pa": 2e11, "poisson_ratio": 0.3, "density_kg_m3": 7850 }} }} }},
  "contact": {{ "model": {{ "normal": "jkr", "rolling": "cdt" }},
               "particle_particle": {{ "restitution": 0.5, "static_friction": 0.5, "rolling_friction": 0.1, "surface_energy_j_m2": {gamma:e} }},
               "particle_wall": {{ "steel": {{ "restitution": 0.5, "static_friction": 0.5, "rolling_friction": 0.1, "surface_energy_j_m2": {gamma:e} }} }} }},
  "seeds": {{ "design_seed": 0, "sample_index": 0, "packing_seed": 3 }},
  "time_step": {{ "rayleigh_fraction": 0.2, "design_impact_speed_m_s": 0.3 }}
  {coarse}
}}"#
    );
    parse_experiment(&text).unwrap()
}

/// Everything a run produced except what names the experiment.
fn physics_of(r: &RunResult) -> String {
    serde_json::to_string(&(&r.kernel, &r.measurements, &r.traces)).unwrap()
}

#[test]
fn cai2024_rule_simulates_the_scaled_particle() {
    // cai2024 §1.2: Γ' = k Γ. Real 0.5 mm particles with Γ = 0.05 J/m², k = 2,
    // are simulated as 1 mm particles with Γ = 0.1 J/m² (all factors exact in
    // binary, so the runs must agree bit for bit).
    let coarse = drum(
        0.5e-3,
        5e6,
        0.05,
        r#", "coarse_graining": { "size_factor": 2, "rule": "surface_energy_proportional" }"#,
    );
    let direct = drum(1e-3, 5e6, 0.1, "");
    assert_ne!(coarse.id(), direct.id());
    let (a, b) = (
        run_experiment(&coarse, None).unwrap(),
        run_experiment(&direct, None).unwrap(),
    );
    assert_eq!(physics_of(&a), physics_of(&b));
    assert!(b.coarse_graining.is_none());
    let report = a.coarse_graining.expect("coarse-grained run reports it");
    assert_eq!(report.rule, "surface_energy_proportional");
    assert_eq!(report.surface_energy_factor, 2.0);
    assert_eq!(report.simulated_radius_m, 1e-3);
    assert_eq!(report.simulated_surface_energy_j_m2, 0.1);
    // Under Γ ∝ k, Eq. 2's Coh ∝ (Γ⁵/R*²)^(1/3) grows by k^(5/3 − 2/3) = k.
    let ratio = report.simulated_cohesion_number / report.real_cohesion_number;
    assert!((ratio - 2.0).abs() < 1e-12, "{ratio}");
}

#[test]
fn cohesion_number_rule_keeps_coh_with_a_softer_particle() {
    // he2019 Eq. 1–3: Γ' = Γ (k m)^(2/5). With k = 2 and m = 1/2 the surface
    // energy is unchanged while the particle doubles and halves its modulus.
    let coarse = drum(
        0.5e-3,
        1e7,
        0.05,
        r#", "coarse_graining": { "size_factor": 2, "youngs_modulus_factor": 0.5, "rule": "cohesion_number" }"#,
    );
    let direct = drum(1e-3, 5e6, 0.05, "");
    let (a, b) = (
        run_experiment(&coarse, None).unwrap(),
        run_experiment(&direct, None).unwrap(),
    );
    assert_eq!(physics_of(&a), physics_of(&b));
    let report = a.coarse_graining.unwrap();
    assert_eq!(report.simulated_youngs_modulus_pa, 5e6);
    let ratio = report.simulated_cohesion_number / report.real_cohesion_number;
    assert!((ratio - 1.0).abs() < 1e-12, "{ratio}");
}
