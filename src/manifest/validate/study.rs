//! Rules for studies: parameter addresses and ranges, every contact parameter given
//! exactly once, lab scenes with targets inside the angle range, a usable design.

use std::collections::BTreeMap;

use super::checker::{join, number, string, Checker, Interval};
use super::experiment::{
    check_coarse_graining, check_material, check_pair_field, check_schema_version, check_time_step,
};
use super::scene::check_scene;
use crate::manifest::experiment::{CoarseGrainingRule, PAIR_PARAM_FIELDS};
use crate::manifest::study::{
    DesignKind, Fidelity, NoiseAware, Slot, Study, TargetScene, Transfer,
};
use crate::manifest::Scene;

/// Checks every field of a study.
pub(crate) fn check_study(c: &mut Checker, s: &Study) {
    check_schema_version(c, "schema_version", s.schema_version);
    c.path_component("name", &s.name);
    check_material(c, "material", &s.material);
    check_parameters(c, s);
    check_target(c, "calibration", &s.calibration, s);
    for (i, v) in s.verification.iter().enumerate() {
        check_target(c, &format!("verification[{i}]"), v, s);
    }
    check_design(c, s);
    check_time_step(c, "time_step", &s.time_step);
    if let Some(cg) = &s.coarse_graining {
        check_coarse_graining(c, "coarse_graining", cg);
    }
    if let Some(n) = &s.noise_aware {
        check_noise_aware(c, n);
        if let Some(f) = &n.fidelity {
            check_fidelity(c, s, f);
        }
    }
    if let Some(t) = &s.transfer {
        check_transfer(c, s, t);
    }
}

/// The transfer block: finer sizes, each once, under the rule the study's
/// own size changes use.
fn check_transfer(c: &mut Checker, s: &Study, t: &Transfer) {
    if t.sizes.is_empty() {
        c.fail(
            "transfer.sizes",
            "[]".into(),
            "must list at least one size (particle radius / the verified one, in (0, 1))",
        );
    }
    for (i, size) in t.sizes.iter().enumerate() {
        let path = format!("transfer.sizes[{i}]");
        c.within(&path, *size, Interval::open(0.0, 1.0));
        if t.sizes[..i].contains(size) {
            c.fail(&path, number(*size), "is listed twice");
        }
    }
    let rule_name = |r: CoarseGrainingRule| {
        serde_json::to_value(r).map_or_else(|_| format!("{r:?}"), |v| v.to_string())
    };
    let own = match (&s.coarse_graining, s.fidelity()) {
        (Some(cg), _) => Some((cg.rule, "coarse_graining.rule")),
        (None, Some(_)) => Some((
            CoarseGrainingRule::ConstantBond,
            "the fine level (noise_aware.fidelity scales Γ ∝ R²)",
        )),
        (None, None) => None,
    };
    if let Some((rule, whose)) = own.filter(|(r, _)| *r != t.rule) {
        c.fail(
            "transfer.rule",
            rule_name(t.rule),
            format!(
                "must be {} here, the rule of {whose}: one study scales Γ one way",
                rule_name(rule)
            ),
        );
    }
}

/// Most seeds a calibration scene's power calculation may pre-register: a
/// study that needs more is better served by a finer test than by more
/// packings.
const MAX_VERIFICATION_SEEDS: u32 = 200;

fn check_noise_aware(c: &mut Checker, n: &NoiseAware) {
    let mut at_least = |field: &str, v: u32, min: u32, why: &str| {
        if v < min {
            c.fail(
                &join("noise_aware", field),
                v.to_string(),
                format!("must be at least {min} ({why})"),
            );
        }
    };
    at_least(
        "replicates",
        n.replicates,
        1,
        "packing seeds per design point",
    );
    at_least(
        "noise_seeds",
        n.noise_seeds,
        3,
        "a standard deviation from fewer seeds is no noise floor; 8 or more are recommended",
    );
    at_least(
        "verification_seeds",
        n.verification_seeds,
        5,
        "a verified mean needs its confidence interval",
    );
    at_least("adaptive.batch", n.adaptive.batch, 1, "points per batch");
    at_least(
        "adaptive.max_runs",
        n.adaptive.max_runs,
        1,
        "the run budget",
    );
    c.within(
        "noise_aware.min_probability",
        n.min_probability,
        Interval::open(0.0, 1.0),
    );
    if let Some(cap) = n.max_verification_seeds {
        if cap < n.verification_seeds || cap > MAX_VERIFICATION_SEEDS {
            c.fail(
                "noise_aware.max_verification_seeds",
                cap.to_string(),
                format!(
                    "must lie in [verification_seeds = {}, {MAX_VERIFICATION_SEEDS}] (the cap \
                     of the calibration scene's seeds)",
                    n.verification_seeds
                ),
            );
        }
    }
}

fn check_fidelity(c: &mut Checker, s: &Study, f: &Fidelity) {
    c.within(
        "noise_aware.fidelity.fine_size",
        f.fine_size,
        Interval::open(0.0, 1.0),
    );
    if f.fine_points < 3 || u64::from(f.fine_points) > s.design.size {
        c.fail(
            "noise_aware.fidelity.fine_points",
            f.fine_points.to_string(),
            format!(
                "must lie in [3, design.size = {}] (the fine points are design points; the \
                 fine level's regression on the coarse one needs 3)",
                s.design.size
            ),
        );
    }
    if f.fine_replicates < 2 {
        c.fail(
            "noise_aware.fidelity.fine_replicates",
            f.fine_replicates.to_string(),
            "must be at least 2 (a fine mean's noise is its replicates' variance)",
        );
    }
    if s.coarse_graining.is_some() {
        c.fail(
            "noise_aware.fidelity",
            "(present)".into(),
            "needs a study without coarse_graining (the fine level scales the stated particle)",
        );
    }
    if s.design.kind != DesignKind::Lhs && s.design.kind != DesignKind::LhsOptimised {
        c.fail(
            "noise_aware.fidelity",
            "(present)".into(),
            "needs a Latin-hypercube design (design.size is then its samples)",
        );
    }
}

fn check_parameters(c: &mut Checker, s: &Study) {
    if s.parameters.is_empty() {
        c.fail(
            "parameters",
            "{}".into(),
            "must calibrate at least one contact parameter",
        );
    }
    // slot -> the address that gave it a value
    let mut covered: BTreeMap<Slot, String> = BTreeMap::new();
    let mut cover = |c: &mut Checker, path: &str, address: &str, slots: Vec<Slot>| {
        if slots.is_empty() {
            // A wildcard whose every wall is named by its own address drives
            // nothing: its design column would be calibrated although no run
            // used it.
            c.fail(
                path,
                string(address),
                "sets no contact parameter: every wall material's field is set by its own \
                 particle_wall.<wall>.<field> address (remove the wildcard, or one of those)",
            );
        }
        for slot in slots {
            if let Some(first) = covered.get(&slot) {
                c.fail(
                    path,
                    string(address),
                    format!("sets {slot}, which {first} already sets"),
                );
            } else {
                covered.insert(slot, path.to_string());
            }
        }
    };
    for (address, range) in &s.parameters {
        let path = join("parameters", address);
        match s.resolve_address(address) {
            Err(rule) => c.fail(&path, string(address), rule),
            Ok(slots) => {
                let field = slots.first().map_or("", |s| s.field);
                check_pair_field(
                    c,
                    &join(&path, "min"),
                    field,
                    range.min,
                    &s.contact_model,
                    "contact_model",
                );
                check_pair_field(
                    c,
                    &join(&path, "max"),
                    field,
                    range.max,
                    &s.contact_model,
                    "contact_model",
                );
                if range.min.is_finite() && range.max.is_finite() && range.min >= range.max {
                    c.fail(
                        &join(&path, "min"),
                        number(range.min),
                        format!("must be < max = {}", number(range.max)),
                    );
                }
                cover(c, &path, address, slots);
            }
        }
    }
    for (address, value) in &s.fixed {
        let path = join("fixed", address);
        match s.resolve_address(address) {
            Err(rule) => c.fail(&path, string(address), rule),
            Ok(slots) => {
                let field = slots.first().map_or("", |s| s.field);
                check_pair_field(c, &path, field, *value, &s.contact_model, "contact_model");
                cover(c, &path, address, slots);
            }
        }
    }
    let walls = std::iter::once(None).chain(s.material.walls.keys().cloned().map(Some));
    let all_slots = walls.flat_map(|wall| {
        PAIR_PARAM_FIELDS.iter().map(move |field| Slot {
            wall: wall.clone(),
            field,
        })
    });
    for slot in all_slots {
        if !covered.contains_key(&slot) {
            c.fail(
                &join("fixed", &slot.to_string()),
                "(absent)".into(),
                "every contact parameter must be fixed here or calibrated in parameters",
            );
        }
    }
}

fn check_target(c: &mut Checker, path: &str, t: &TargetScene, s: &Study) {
    c.path_component(&join(path, "name"), &t.name);
    let scene_path = join(path, "scene");
    if let Scene::Pair(_) = t.scene {
        c.fail(
            &join(&scene_path, "kind"),
            string("pair"),
            "must be a lab scene (funnel_pile, baffle_lift, drum, hopper, static_pile); a pair has no angle of repose",
        );
    }
    check_scene(c, &scene_path, &t.scene, &s.material);
    c.within(
        &join(path, "target_angle_deg"),
        t.target_angle_deg,
        Interval::open(0.0, 90.0),
    );
    c.within(
        &join(path, "tolerance_fraction"),
        t.tolerance_fraction,
        Interval::open(0.0, 1.0),
    );
}

fn check_design(c: &mut Checker, s: &Study) {
    let d = &s.design;
    let (min_size, meaning) = match d.kind {
        DesignKind::Lhs | DesignKind::LhsOptimised => (2, "samples"),
        DesignKind::FullFactorial => (2, "levels per parameter"),
        DesignKind::BoxBehnken => (1, "centre points"),
    };
    if d.size < min_size {
        c.fail(
            "design.size",
            d.size.to_string(),
            format!("must be >= {min_size} ({meaning})"),
        );
    }
    if d.kind == DesignKind::BoxBehnken && s.parameters.len() < 3 {
        c.fail(
            "design.kind",
            string("box_behnken"),
            format!(
                "needs at least 3 calibrated parameters ({} given)",
                s.parameters.len()
            ),
        );
    }
}
