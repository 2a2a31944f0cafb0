//! Addresses: the one way a study turns a point into an experiment.
//!
//! Every study builds a skeleton experiment (its base, scene and seeds) and
//! writes each coordinate of the point into it by address, here. An address
//! is the dotted JSON path of a number in the experiment:
//! `contact.particle_particle.static_friction`,
//! `contact.particle_wall.stainless_steel.rolling_friction` (`*` in place of
//! a map key sets every entry: `contact.particle_wall.*.restitution`),
//! `material.particle.youngs_modulus_pa`, `coarse_graining.size_factor`,
//! `time_step.rayleigh_fraction`, `at_rest.hold_s`, `scene.rpm`. One address
//! is derived:
//! `material.particle.shear_modulus_pa` sets the Young's modulus
//! E = 2G(1 + ν) from the experiment's Poisson ratio (cai2024 varies G).
//!
//! The callers differ only in how they name what they set:
//! - a design study's factors are addresses as written;
//! - he2019's calibration study names pair parameters in a short form
//!   (`particle_wall.*.restitution`, where `*` means every wall the scene
//!   uses that has no entry of its own), lowered to addresses by
//!   [`crate::manifest::Study::resolve_address`];
//! - the tradeoff sweep's knobs are factors on one address each.
//!
//! Values pass through JSON exactly (`serde_json`'s `float_roundtrip`), so an
//! experiment built here hashes to the same id as one built field by field.

use serde_json::Value;

use super::Experiment;

/// An experiment opened for writing by address.
#[derive(Debug, Clone)]
pub struct ExperimentDoc(Value);

impl ExperimentDoc {
    /// Opens `experiment` for writing. The `at_rest` block, left out of the
    /// manifest (and the id) when it holds the defaults, is written out, so
    /// its fields are addressable too; it drops out again on hashing when
    /// nothing changed it.
    pub fn of(experiment: &Experiment) -> Self {
        let mut doc = serde_json::to_value(experiment).expect("experiments serialise");
        if let Value::Object(map) = &mut doc {
            map.entry("at_rest").or_insert_with(|| {
                serde_json::to_value(experiment.at_rest).expect("at_rest serialises")
            });
        }
        ExperimentDoc(doc)
    }

    /// Writes `value` at `address` (see the module docs); an error says why
    /// the address does not name a number.
    pub fn set(&mut self, address: &str, value: f64) -> Result<(), String> {
        if address == "material.particle.shear_modulus_pa" {
            let particle = &mut self.0["material"]["particle"];
            let nu = particle["poisson_ratio"].as_f64().unwrap_or(0.0);
            particle["youngs_modulus_pa"] = Value::from(2.0 * value * (1.0 + nu));
            return Ok(());
        }
        let parts: Vec<&str> = address.split('.').collect();
        if parts.iter().any(|p| p.is_empty()) {
            return Err(
                "must be a dotted path such as contact.particle_particle.static_friction".into(),
            );
        }
        set_at(&mut self.0, &parts, value, address)
    }

    /// The experiment as written (typed, not yet validated); an error says
    /// why the document no longer forms an experiment.
    pub fn into_experiment(self) -> Result<Experiment, String> {
        serde_json::from_value(self.0).map_err(|e| e.to_string())
    }
}

fn set_at(node: &mut Value, parts: &[&str], value: f64, address: &str) -> Result<(), String> {
    let Some((head, rest)) = parts.split_first() else {
        return if node.is_number() {
            *node = Value::from(value);
            Ok(())
        } else {
            Err(format!("`{address}` names {node}, not a number"))
        };
    };
    let Value::Object(map) = node else {
        return Err(format!(
            "`{address}`: `{head}` is below a value that has no fields"
        ));
    };
    if *head == "*" {
        if map.is_empty() {
            return Err(format!("`{address}`: `*` matches nothing"));
        }
        for child in map.values_mut() {
            set_at(child, rest, value, address)?;
        }
        return Ok(());
    }
    match map.get_mut(*head) {
        Some(child) => set_at(child, rest, value, address),
        None => Err(format!(
            "`{address}`: no field `{head}` here; fields: {}",
            map.keys().cloned().collect::<Vec<_>>().join(", ")
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::read_experiment;
    use std::path::Path;

    fn drum() -> Experiment {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/drum/smoke.json");
        read_experiment(&path).expect("the drum smoke manifest reads")
    }

    #[test]
    fn a_star_sets_every_wall_and_a_path_sets_one_number() {
        let e = drum();
        let mut doc = ExperimentDoc::of(&e);
        doc.set("contact.particle_wall.*.restitution", 0.123)
            .unwrap();
        doc.set("contact.particle_particle.static_friction", 0.456)
            .unwrap();
        let out = doc.into_experiment().unwrap();
        assert!(!out.contact.particle_wall.is_empty());
        assert!(out
            .contact
            .particle_wall
            .values()
            .all(|p| p.restitution == 0.123));
        assert_eq!(out.contact.particle_particle.static_friction, 0.456);
        // Nothing else moved: writing the old values back restores the id.
        let mut back = ExperimentDoc::of(&out);
        for (wall, p) in &e.contact.particle_wall {
            back.set(
                &format!("contact.particle_wall.{wall}.restitution"),
                p.restitution,
            )
            .unwrap();
        }
        back.set(
            "contact.particle_particle.static_friction",
            e.contact.particle_particle.static_friction,
        )
        .unwrap();
        assert_eq!(back.into_experiment().unwrap().id(), e.id());
    }

    #[test]
    fn the_shear_modulus_sets_youngs_modulus_from_poissons_ratio() {
        let e = drum();
        let nu = e.material.particle.poisson_ratio;
        let mut doc = ExperimentDoc::of(&e);
        doc.set("material.particle.shear_modulus_pa", 1.0e7)
            .unwrap();
        let out = doc.into_experiment().unwrap();
        assert_eq!(out.material.particle.youngs_modulus_pa, 2.0e7 * (1.0 + nu));
    }

    #[test]
    fn the_default_rest_criterion_is_addressable_and_leaves_the_id_alone() {
        let e = drum();
        assert!(e.at_rest.is_default());
        let unchanged = ExperimentDoc::of(&e).into_experiment().unwrap();
        assert_eq!(unchanged.id(), e.id());
        let mut doc = ExperimentDoc::of(&e);
        doc.set("at_rest.hold_s", 0.2).unwrap();
        let out = doc.into_experiment().unwrap();
        assert_eq!(out.at_rest.hold_s, 0.2);
        assert_ne!(out.id(), e.id());
    }

    #[test]
    fn an_address_that_names_no_number_says_why() {
        let mut doc = ExperimentDoc::of(&drum());
        let missing = doc
            .set("contact.particle_particle.colour", 1.0)
            .unwrap_err();
        assert!(missing.contains("no field `colour`"), "{missing}");
        assert!(missing.contains("static_friction"), "{missing}");
        let object = doc.set("contact.particle_particle", 1.0).unwrap_err();
        assert!(object.contains("not a number"), "{object}");
        let empty = doc.set("contact..restitution", 1.0).unwrap_err();
        assert!(empty.contains("dotted path"), "{empty}");
    }
}
