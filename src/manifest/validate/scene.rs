//! Rules for scenes: positive geometry, consistent dimensions, fill below the packing
//! limit, wall materials defined.

use super::checker::{join, number, string, Checker, Interval};
use crate::manifest::experiment::Material;
use crate::manifest::scene::{
    BaffleLiftScene, DrumScene, EndWalls, FunnelPileScene, HopperScene, PairMode, PairScene,
    Partner, Scene, StaticPileScene,
};

/// Random close packing of monosized spheres: no poured bed is denser.
pub const PACKING_LIMIT: f64 = 0.64;

/// Checks a scene; `material` resolves wall names and the particle density.
pub(crate) fn check_scene(c: &mut Checker, path: &str, scene: &Scene, material: &Material) {
    for (field, name) in scene.wall_materials() {
        if !material.walls.contains_key(name) {
            c.fail(
                &join(path, field),
                string(name),
                "must name a wall material defined in material.walls",
            );
        }
    }
    match scene {
        Scene::Pair(s) => check_pair(c, path, s),
        Scene::FunnelPile(s) => check_funnel(c, path, s),
        Scene::BaffleLift(s) => check_baffle(c, path, s, material.particle.density_kg_m3),
        Scene::Drum(s) => check_drum(c, path, s),
        Scene::Hopper(s) => check_hopper(c, path, s),
        Scene::StaticPile(s) => check_static_pile(c, path, s),
    }
}

/// Requires `small < large` (both already checked positive), naming `small`.
fn smaller(
    c: &mut Checker,
    path: &str,
    small_field: &str,
    small: f64,
    large_field: &str,
    large: f64,
) {
    if small.is_finite() && large.is_finite() && small >= large {
        c.fail(
            &join(path, small_field),
            number(small),
            format!("must be < {large_field} = {}", number(large)),
        );
    }
}

fn check_pair(c: &mut Checker, path: &str, s: &PairScene) {
    c.positive(&join(path, "radius_m"), s.radius_m);
    if let Partner::Particle { radius_m } = s.partner {
        c.positive(&join(path, "partner.radius_m"), radius_m);
    }
    c.non_negative(&join(path, "normal_velocity_m_s"), s.normal_velocity_m_s);
    if s.mode == PairMode::Impact && s.normal_velocity_m_s == 0.0 {
        c.fail(
            &join(path, "normal_velocity_m_s"),
            number(0.0),
            "must be > 0 in impact mode (the bodies never meet)",
        );
    }
    c.non_negative(
        &join(path, "tangential_velocity_m_s"),
        s.tangential_velocity_m_s,
    );
    for (i, w) in s.angular_velocity_rad_s.iter().enumerate() {
        c.finite(
            &format!("{}[{i}]", join(path, "angular_velocity_rad_s")),
            *w,
        );
    }
    match s.pull_speed_m_s {
        Some(v) => c.positive(&join(path, "pull_speed_m_s"), v),
        None if s.mode == PairMode::Separation => c.fail(
            &join(path, "pull_speed_m_s"),
            "(absent)".into(),
            "is required in separation mode (a speed > 0 in m/s)",
        ),
        None => {}
    }
    c.positive(&join(path, "max_time_s"), s.max_time_s);
}

fn check_funnel(c: &mut Checker, path: &str, s: &FunnelPileScene) {
    c.positive(
        &join(path, "funnel_top_diameter_m"),
        s.funnel_top_diameter_m,
    );
    c.positive(
        &join(path, "funnel_outlet_diameter_m"),
        s.funnel_outlet_diameter_m,
    );
    smaller(
        c,
        path,
        "funnel_outlet_diameter_m",
        s.funnel_outlet_diameter_m,
        "funnel_top_diameter_m",
        s.funnel_top_diameter_m,
    );
    c.positive(&join(path, "funnel_height_m"), s.funnel_height_m);
    c.within(
        &join(path, "outlet_tilt_deg"),
        s.outlet_tilt_deg,
        Interval::closed_open(0.0, 90.0),
    );
    c.positive(&join(path, "outlet_height_m"), s.outlet_height_m);
    if let Some(l) = s.outlet_tube_length_m {
        c.positive(&join(path, "outlet_tube_length_m"), l);
    }
    let drop = s.outlet_tube_drop();
    if drop.is_finite() && s.outlet_height_m.is_finite() && drop >= s.outlet_height_m {
        c.fail(
            &join(path, "outlet_height_m"),
            number(s.outlet_height_m),
            format!(
                "must exceed the outlet tube's drop below the cone, length cos(tilt) + radius sin(tilt) = {} (the tube would reach the platform)",
                number(drop)
            ),
        );
    }
    c.positive(&join(path, "platform_diameter_m"), s.platform_diameter_m);
    if let Some(rpm) = s.brush_rpm {
        c.positive(&join(path, "brush_rpm"), rpm);
    }
    if let Some(n) = s.brush_blades {
        brush_only(c, path, "brush_blades", n.to_string(), s);
        if !(1..=8).contains(&n) {
            c.fail(&join(path, "brush_blades"), n.to_string(), "must be 1 to 8");
        }
    }
    if let Some(g) = s.brush_gap_m {
        brush_only(c, path, "brush_gap_m", number(g), s);
        c.non_negative(&join(path, "brush_gap_m"), g);
    }
    if let Some(m) = &s.brush_material {
        brush_only(c, path, "brush_material", m.clone(), s);
    }
    if let Some(w) = s.brush_width_m {
        brush_only(c, path, "brush_width_m", number(w), s);
        c.positive(&join(path, "brush_width_m"), w);
    }
    let reach = s.brush_gap() + s.brush_width();
    if s.brush_rpm.is_some() && reach.is_finite() && reach >= 0.5 * s.funnel_top_diameter_m {
        c.fail(
            &join(path, "brush_width_m"),
            number(s.brush_width()),
            format!(
                "must leave brush_gap_m + brush_width_m < funnel_top_diameter_m / 2 = {} (the blade would cross the axis at the top)",
                number(0.5 * s.funnel_top_diameter_m)
            ),
        );
    }
    c.within(
        &join(path, "fill_fraction"),
        s.fill_fraction,
        Interval::open(0.0, PACKING_LIMIT),
    );
    if let Some(h) = s.fill_height_m {
        c.within(
            &join(path, "fill_height_m"),
            h,
            Interval::open_closed(0.0, s.funnel_height_m),
        );
    }
    if let Some(dt) = s.sample_interval_s {
        c.positive(&join(path, "sample_interval_s"), dt);
    }
    c.positive(&join(path, "fill_time_s"), s.fill_time_s);
    c.non_negative(&join(path, "standing_time_s"), s.standing_time_s);
    c.positive(&join(path, "total_time_s"), s.total_time_s);
    c.non_negative(&join(path, "settle_time_s"), s.settle_time_s);
    let busy = s.fill_time_s + s.standing_time_s + s.settle_time_s;
    if busy.is_finite() && s.total_time_s.is_finite() && busy >= s.total_time_s {
        c.fail(
            &join(path, "total_time_s"),
            number(s.total_time_s),
            format!("must exceed fill_time_s + standing_time_s + settle_time_s = {} (no time left to discharge)", number(busy)),
        );
    }
}

/// A brush setting is refused when there is no brush (`brush_rpm` absent).
fn brush_only(c: &mut Checker, path: &str, field: &str, value: String, s: &FunnelPileScene) {
    if s.brush_rpm.is_none() {
        c.fail(
            &join(path, field),
            value,
            "requires brush_rpm (without it there is no brush)",
        );
    }
}

fn check_baffle(c: &mut Checker, path: &str, s: &BaffleLiftScene, density_kg_m3: f64) {
    c.positive(&join(path, "box_length_m"), s.box_length_m);
    c.positive(&join(path, "box_width_m"), s.box_width_m);
    c.positive(&join(path, "box_height_m"), s.box_height_m);
    c.positive(&join(path, "powder_mass_kg"), s.powder_mass_kg);
    c.positive(&join(path, "lift_speed_m_s"), s.lift_speed_m_s);
    c.non_negative(&join(path, "settle_time_s"), s.settle_time_s);
    if let Some(slice) = s.periodic_slice_m {
        c.positive(&join(path, "periodic_slice_m"), slice);
        if slice.is_finite() && s.box_width_m.is_finite() && slice > s.box_width_m {
            c.fail(
                &join(path, "periodic_slice_m"),
                number(slice),
                format!("must be <= box_width_m = {}", number(s.box_width_m)),
            );
        }
    }
    if let Some(v) = s.floor_overhang_m {
        c.positive(&join(path, "floor_overhang_m"), v);
    }
    if let Some(v) = s.settle_max_s {
        c.positive(&join(path, "settle_max_s"), v);
    }
    if let Some(v) = s.sample_interval_s {
        c.within(
            &join(path, "sample_interval_s"),
            v,
            Interval::open_closed(0.0, BaffleLiftScene::MAX_SAMPLE_INTERVAL_S),
        );
    }
    let box_volume = s.box_length_m * s.box_width_m * s.box_height_m;
    let max_mass = box_volume * PACKING_LIMIT * density_kg_m3;
    if max_mass.is_finite() && max_mass > 0.0 && s.powder_mass_kg > max_mass {
        c.fail(
            &join(path, "powder_mass_kg"),
            number(s.powder_mass_kg),
            format!(
                "must be <= {} (the box volume at the packing limit {PACKING_LIMIT} and particle density {} kg/m3)",
                number(max_mass),
                number(density_kg_m3)
            ),
        );
    }
}

fn check_drum(c: &mut Checker, path: &str, s: &DrumScene) {
    c.positive(&join(path, "inner_diameter_m"), s.inner_diameter_m);
    c.positive(&join(path, "length_m"), s.length_m);
    c.within(
        &join(path, "fill_fraction"),
        s.fill_fraction,
        Interval::open(0.0, 1.0),
    );
    c.positive(&join(path, "rpm"), s.rpm);
    c.positive(&join(path, "rotation_time_s"), s.rotation_time_s);
    c.non_negative(&join(path, "standing_time_s"), s.standing_time_s);
    if let Some(slice) = s.periodic_slice_m {
        c.positive(&join(path, "periodic_slice_m"), slice);
        if slice.is_finite() && s.length_m.is_finite() && slice > s.length_m {
            c.fail(
                &join(path, "periodic_slice_m"),
                number(slice),
                format!("must be <= length_m = {}", number(s.length_m)),
            );
        }
        // A spelled-out "rotating" is the default (same id as omitting it) and
        // is accepted like it; "fixed" caps would be silently absent.
        if s.end_walls == EndWalls::Fixed {
            c.fail(
                &join(path, "end_walls"),
                string(s.end_walls.as_str()),
                format!(
                    "must be left out (or \"rotating\", the default) with periodic_slice_m = {}: \
                     a periodic slice has no end walls; \"fixed\" needs the full drum \
                     (remove periodic_slice_m)",
                    number(slice)
                ),
            );
        }
    }
    c.positive(&join(path, "settle_max_s"), s.settle_max_s);
    c.positive(&join(path, "sample_interval_s"), s.sample_interval_s);
}

fn check_hopper(c: &mut Checker, path: &str, s: &HopperScene) {
    c.positive(&join(path, "diameter_m"), s.diameter_m);
    c.positive(&join(path, "height_m"), s.height_m);
    c.positive(&join(path, "orifice_diameter_m"), s.orifice_diameter_m);
    smaller(
        c,
        path,
        "orifice_diameter_m",
        s.orifice_diameter_m,
        "diameter_m",
        s.diameter_m,
    );
    c.positive(&join(path, "drop_height_m"), s.drop_height_m);
    c.positive(&join(path, "plate_diameter_m"), s.plate_diameter_m);
    smaller(
        c,
        path,
        "orifice_diameter_m",
        s.orifice_diameter_m,
        "plate_diameter_m",
        s.plate_diameter_m,
    );
    c.within(
        &join(path, "packing_fraction"),
        s.packing_fraction,
        Interval::open(0.0, PACKING_LIMIT),
    );
    c.positive(&join(path, "no_discharge_stop_s"), s.no_discharge_stop_s);
    c.positive(&join(path, "max_time_s"), s.max_time_s);
    if let Some(h) = s.fill_height_m {
        c.positive(&join(path, "fill_height_m"), h);
        if h.is_finite() && s.height_m.is_finite() && h > s.height_m {
            c.fail(
                &join(path, "fill_height_m"),
                number(h),
                format!(
                    "must be <= height_m = {} (the bed must fit the hopper)",
                    number(s.height_m)
                ),
            );
        }
    }
    if let Some(t) = s.settle_max_s {
        c.positive(&join(path, "settle_max_s"), t);
    }
    if let Some(dt) = s.sample_interval_s {
        c.within(
            &join(path, "sample_interval_s"),
            dt,
            Interval::open_closed(0.0, HOPPER_MAX_SAMPLE_INTERVAL_S),
        );
    }
}

/// Longest hopper sample interval, s: particles that fall off the plate are
/// removed at samples and must stay inside the simulation box until then.
pub const HOPPER_MAX_SAMPLE_INTERVAL_S: f64 = 0.05;

fn check_static_pile(c: &mut Checker, path: &str, s: &StaticPileScene) {
    c.within(
        &join(path, "cone_angle_deg"),
        s.cone_angle_deg,
        Interval::open(0.0, 180.0),
    );
    c.positive(
        &join(path, "funnel_top_diameter_m"),
        s.funnel_top_diameter_m,
    );
    c.positive(&join(path, "outlet_diameter_m"), s.outlet_diameter_m);
    smaller(
        c,
        path,
        "outlet_diameter_m",
        s.outlet_diameter_m,
        "funnel_top_diameter_m",
        s.funnel_top_diameter_m,
    );
    c.positive(&join(path, "outlet_height_m"), s.outlet_height_m);
    c.positive(&join(path, "disk_diameter_m"), s.disk_diameter_m);
    if s.particle_count == 0 {
        c.fail(&join(path, "particle_count"), "0".into(), "must be > 0");
    }
    c.positive(&join(path, "insertion_rate_per_s"), s.insertion_rate_per_s);
    c.non_negative(&join(path, "settle_time_s"), s.settle_time_s);
    c.positive(&join(path, "insertion_interval_s"), s.insertion_interval_s);
    if s.sample_interval_s.is_finite()
        && s.insertion_interval_s.is_finite()
        && s.sample_interval_s < s.insertion_interval_s
    {
        c.fail(
            &join(path, "sample_interval_s"),
            number(s.sample_interval_s),
            format!(
                "must be >= insertion_interval_s = {} (samples are taken at insertion windows)",
                number(s.insertion_interval_s)
            ),
        );
    } else {
        c.positive(&join(path, "sample_interval_s"), s.sample_interval_s);
    }
}
