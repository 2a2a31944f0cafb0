//! Named responses: the scalar physics results of each scene kind that a
//! calibration can target, with their units.
//!
//! A run's result.json holds many measurements (fit diagnostics, counts,
//! protocol times) under keys each scene chose; a study or a table needs a
//! short, stable list of the quantities that describe the powder: an angle,
//! a flow rate, a restitution. [`catalogue`] is that list for every scene
//! kind (as written in manifests, [`crate::manifest::Scene::kind`]) and
//! [`response`] reads one of them from a finished run, saying clearly when
//! the name is not one of the scene's or the run did not measure it.
//! Run costs (CPU time, steps) are not responses: they describe the
//! simulation, not the material.

use serde::Serialize;

use crate::store::RunResult;

/// One named response of a scene kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ResponseSpec {
    /// The name a study or `repose responses` uses (ends in its unit where
    /// that helps, e.g. `_deg`, `_per_s`).
    pub name: &'static str,
    /// Unit: `deg`, `1/s` (particles per second), `m/s`, `s`, `m`, `N`, or `1`
    /// for a dimensionless number.
    pub unit: &'static str,
    /// What it is, how it is measured and when a run may lack it.
    pub description: &'static str,
}

/// Why a response could not be read from a run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResponseError {
    /// The scene kind is not one of [`kinds`].
    #[error("unknown scene kind '{kind}'; the kinds are: {}", KINDS.join(", "))]
    UnknownScene {
        /// The kind asked for.
        kind: String,
    },
    /// The name is not in the scene kind's [`catalogue`].
    #[error("'{name}' is not a response of the {kind} scene; its responses are: {allowed}")]
    UnknownResponse {
        /// The scene kind.
        kind: String,
        /// The name asked for.
        name: String,
        /// The kind's response names, comma-separated.
        allowed: String,
    },
    /// The run is of another scene kind than the one asked for.
    #[error("run {run} is a {actual} run, not a {kind} run: it has no response '{name}'")]
    SceneMismatch {
        /// The run's id (12 hex digits).
        run: String,
        /// The run's scene kind.
        actual: String,
        /// The scene kind asked for.
        kind: String,
        /// The response asked for.
        name: String,
    },
    /// The run did not measure the response (e.g. a drum without a dynamic
    /// window, a hopper whose discharge ended before the flow-rate time).
    #[error("run {run} ({kind}) did not measure response '{name}' (no '{key}' in its measurements): {why}")]
    NotMeasured {
        /// The run's id (12 hex digits).
        run: String,
        /// The scene kind.
        kind: String,
        /// The response asked for.
        name: String,
        /// The measurement key that is absent.
        key: &'static str,
        /// Why: the reason the run recorded ([`RunResult::unmeasured`]), or
        /// else the response's description, which says when it is measured.
        why: String,
    },
}

/// The reason `result` recorded for not measuring `key`, or `description`.
fn why_unmeasured(result: &RunResult, key: &str, description: &str) -> String {
    result
        .unmeasured
        .get(key)
        .map_or_else(|| description.to_string(), Clone::clone)
}

/// Every scene kind, in the order `repose responses` lists them.
const KINDS: [&str; 6] = [
    "pair",
    "funnel_pile",
    "baffle_lift",
    "drum",
    "hopper",
    "static_pile",
];

/// How a response is read from a run's measurements.
#[derive(Clone, Copy, Debug)]
enum Read {
    /// The measurement of that key.
    Key(&'static str),
    /// The first measurement over the second.
    Ratio(&'static str, &'static str),
}

/// Shorthand for the catalogue tables.
const fn spec(name: &'static str, unit: &'static str, description: &'static str) -> ResponseSpec {
    ResponseSpec {
        name,
        unit,
        description,
    }
}

const PAIR: &[ResponseSpec] = &[
    spec(
        "restitution",
        "1",
        "normal coefficient of restitution: minus the relative normal velocity after the \
         contact over the one before (impact mode only)",
    ),
    spec(
        "contact_duration_s",
        "s",
        "duration of the first contact (impact mode; in separation mode, the time to pull-off)",
    ),
    spec("max_overlap_m", "m", "largest overlap during the contact"),
    spec(
        "pull_off_force_n",
        "N",
        "largest tensile contact force while the pair is pulled apart (separation mode only)",
    ),
    spec(
        "pull_off_ratio",
        "1",
        "measured pull-off force over JKR's 3πΓR* for the same pair (separation mode only)",
    ),
];

const FUNNEL_PILE: &[ResponseSpec] = &[
    spec(
        "angle_deg",
        "deg",
        "pile angle of repose on the platform: mean of the flank fits of the fitted side views \
         (he2019 §2.2), the headline angle",
    ),
    spec(
        "angle_cone_deg",
        "deg",
        "pile angle of repose on the platform from its whole surface: one cone with a free \
         axis fitted to the top particle of every column (10-90 % of the height)",
    ),
    spec(
        "angle_2h_d_deg",
        "deg",
        "height angle atan(2H/D), H the pile's height above the platform and D the \
         platform's diameter (the fixed-base method of the static pile)",
    ),
];

const BAFFLE_LIFT: &[ResponseSpec] = &[spec(
    "angle_deg",
    "deg",
    "static angle of repose of the slope left in the box after the baffle lift (he2019 \
     §3.6.1), the headline angle",
)];

const DRUM: &[ResponseSpec] = &[
    spec(
        "dynamic_angle_deg",
        "deg",
        "mean free-surface angle over the second half of the rotation; measured only when \
         that window held a measurable surface",
    ),
    spec(
        "static_angle_deg",
        "deg",
        "free-surface angle at the end of standing",
    ),
];

const HOPPER: &[ResponseSpec] = &[
    spec(
        "alpha_deg",
        "deg",
        "upper angle α: the crater left in the hopper, mean of the four ortho-slice fits \
         (yan2015 §3.2)",
    ),
    spec(
        "theta_deg",
        "deg",
        "bottom angle θ: the heap on the plate, mean of the four ortho-slice fits (yan2015 \
         §3.2), the headline angle",
    ),
    spec(
        "flow_rate_1s_per_s",
        "1/s",
        "particles discharged by 1 s after the opening over 1 s (yan2015's FR(1)); measured \
         only when the discharge lasted 1 s",
    ),
    spec(
        "flow_rate_2s_per_s",
        "1/s",
        "particles discharged by 2 s after the opening over 2 s (FR(2)); measured only when \
         the discharge lasted 2 s",
    ),
    spec(
        "flow_rate_3s_per_s",
        "1/s",
        "particles discharged by 3 s after the opening over 3 s (FR(3)); measured only when \
         the discharge lasted 3 s",
    ),
    spec(
        "flow_rate_4s_per_s",
        "1/s",
        "particles discharged by 4 s after the opening over 4 s (FR(4)); measured only when \
         the discharge lasted 4 s",
    ),
    spec(
        "flow_rate_steady_per_s",
        "1/s",
        "steady discharge rate over 10–50 % of the discharge duration; measured only when \
         something was discharged",
    ),
    spec(
        "window_speed_m_s",
        "m/s",
        "mean particle speed in the window 20–30 mm above the orifice during the discharge \
         (yan2015 Fig. 6a); measured only when the window held particles then",
    ),
];

const STATIC_PILE: &[ResponseSpec] = &[
    spec(
        "angle_2h_d_deg",
        "deg",
        "height angle atan(2H/D), H the pile's height and D the disk's diameter (cai2024, \
         GB/T 16913), the headline angle",
    ),
    spec(
        "angle_profile_deg",
        "deg",
        "profile angle: mean of the eight flank fits of the four side views",
    ),
];

/// Where each response of a kind is read from.
fn read(kind: &str, name: &str) -> Option<Read> {
    use Read::{Key, Ratio};
    Some(match (kind, name) {
        ("pair", "restitution" | "contact_duration_s" | "max_overlap_m" | "pull_off_force_n") => {
            Key(known(PAIR, name)?)
        }
        ("pair", "pull_off_ratio") => Ratio("pull_off_force_n", "theory_pull_off_force_n"),
        ("funnel_pile", "angle_deg") => Key("angle_deg"),
        ("funnel_pile", "angle_cone_deg") => Key("angle_cone_deg"),
        ("funnel_pile", "angle_2h_d_deg") => Key("angle_2h_d_deg"),
        ("baffle_lift", "angle_deg") => Key("static_angle_deg"),
        ("drum", "dynamic_angle_deg" | "static_angle_deg") => Key(known(DRUM, name)?),
        ("hopper", "alpha_deg") => Key("upper_angle_deg"),
        ("hopper", "theta_deg") => Key("bottom_angle_deg"),
        (
            "hopper",
            "flow_rate_1s_per_s"
            | "flow_rate_2s_per_s"
            | "flow_rate_3s_per_s"
            | "flow_rate_4s_per_s"
            | "flow_rate_steady_per_s",
        ) => Key(known(HOPPER, name)?),
        ("hopper", "window_speed_m_s") => Key("window_speed_mean_m_s"),
        ("static_pile", "angle_2h_d_deg") => Key("height_angle_deg"),
        ("static_pile", "angle_profile_deg") => Key("profile_angle_deg"),
        _ => return None,
    })
}

/// The catalogue's own `'static` spelling of `name` (the measurement key of a
/// response named as its key).
fn known(table: &'static [ResponseSpec], name: &str) -> Option<&'static str> {
    table.iter().find(|s| s.name == name).map(|s| s.name)
}

/// Every scene kind, as written in manifests.
pub fn kinds() -> &'static [&'static str] {
    &KINDS
}

/// The responses of a scene kind (as written in manifests), or None for an
/// unknown kind.
pub fn catalogue(kind: &str) -> Option<&'static [ResponseSpec]> {
    match kind {
        "pair" => Some(PAIR),
        "funnel_pile" => Some(FUNNEL_PILE),
        "baffle_lift" => Some(BAFFLE_LIFT),
        "drum" => Some(DRUM),
        "hopper" => Some(HOPPER),
        "static_pile" => Some(STATIC_PILE),
        _ => None,
    }
}

/// The catalogues `repose responses` lists: one kind's, or every kind's
/// (in [`kinds`] order) without one. Fails for an unknown kind.
pub fn listing(
    kind: Option<&str>,
) -> Result<Vec<(&'static str, &'static [ResponseSpec])>, ResponseError> {
    match kind {
        None => Ok(KINDS
            .iter()
            .filter_map(|&k| Some((k, catalogue(k)?)))
            .collect()),
        Some(k) => {
            let known = KINDS.iter().find(|&&n| n == k);
            match known.and_then(|&n| Some((n, catalogue(n)?))) {
                Some(entry) => Ok(vec![entry]),
                None => Err(ResponseError::UnknownScene {
                    kind: k.to_string(),
                }),
            }
        }
    }
}

/// The response `name` of a `kind` run from its result (its `measurements`),
/// in the catalogue's unit. Fails when the kind is unknown, the name is not
/// in the kind's [`catalogue`] (the message lists the allowed names), the
/// run is of another kind, or the run did not measure it.
pub fn response(result: &RunResult, kind: &str, name: &str) -> Result<f64, ResponseError> {
    let table = catalogue(kind).ok_or_else(|| ResponseError::UnknownScene {
        kind: kind.to_string(),
    })?;
    let Some((spec, read)) = table
        .iter()
        .find(|s| s.name == name)
        .and_then(|s| Some((s, read(kind, name)?)))
    else {
        return Err(ResponseError::UnknownResponse {
            kind: kind.to_string(),
            name: name.to_string(),
            allowed: table.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
        });
    };
    let run = result.id.short(12).to_string();
    if result.scene != kind {
        return Err(ResponseError::SceneMismatch {
            run,
            actual: result.scene.clone(),
            kind: kind.to_string(),
            name: name.to_string(),
        });
    }
    let get = |key: &'static str| {
        result
            .measurements
            .get(key)
            .copied()
            .ok_or_else(|| ResponseError::NotMeasured {
                run: run.clone(),
                kind: kind.to_string(),
                name: name.to_string(),
                key,
                why: why_unmeasured(result, key, spec.description),
            })
    };
    match read {
        Read::Key(key) => get(key),
        Read::Ratio(over, under) => Ok(get(over)? / get(under)?),
    }
}

/// The measurement keys of the individual observations whose mean a
/// response is, when it is one: the hopper's α and θ are each the mean of
/// four ortho-slice fits (xz and yz slices, left and right flanks), and
/// yan2015 fits every one of them, not the mean.
fn part_keys(kind: &str, name: &str) -> Option<[&'static str; 4]> {
    match (kind, name) {
        ("hopper", "alpha_deg") => Some([
            "upper_angle_xz_left_deg",
            "upper_angle_xz_right_deg",
            "upper_angle_yz_left_deg",
            "upper_angle_yz_right_deg",
        ]),
        ("hopper", "theta_deg") => Some([
            "bottom_angle_xz_left_deg",
            "bottom_angle_xz_right_deg",
            "bottom_angle_yz_left_deg",
            "bottom_angle_yz_right_deg",
        ]),
        _ => None,
    }
}

/// The individual observations of response `name` in a run: the four
/// ortho-slice angles of a hopper's α or θ (see [`part_keys`]), or the
/// response itself (one value) for every other response. Fails as
/// [`response`] does.
pub fn observations(result: &RunResult, kind: &str, name: &str) -> Result<Vec<f64>, ResponseError> {
    let mean = response(result, kind, name)?;
    let Some(keys) = part_keys(kind, name) else {
        return Ok(vec![mean]);
    };
    keys.iter()
        .map(|&key| {
            result
                .measurements
                .get(key)
                .copied()
                .ok_or_else(|| ResponseError::NotMeasured {
                    run: result.id.short(12).to_string(),
                    kind: kind.to_string(),
                    name: name.to_string(),
                    key,
                    why: why_unmeasured(result, key, "one of the four ortho-slice fits"),
                })
        })
        .collect()
}

/// A hopper run's flow-rate curve: FR(t) = particles discharged by t / t, s
/// after the opening, at every sample of the `discharged` trace inside the
/// discharge (0 < t ≤ `discharge_duration_s`), as (t, FR in 1/s). yan2015
/// Eq. 20 is fitted to it. Fails for another kind or a run without a
/// discharge.
pub fn flow_rate_curve(result: &RunResult) -> Result<Vec<(f64, f64)>, ResponseError> {
    let run = result.id.short(12).to_string();
    if result.scene != "hopper" {
        return Err(ResponseError::SceneMismatch {
            run,
            actual: result.scene.clone(),
            kind: "hopper".into(),
            name: "flow-rate curve".into(),
        });
    }
    let missing = |key: &'static str| ResponseError::NotMeasured {
        run: run.clone(),
        kind: "hopper".into(),
        name: "flow-rate curve".into(),
        key,
        why: why_unmeasured(
            result,
            key,
            "the discharged count against time, from the opening to the last particle out",
        ),
    };
    let opened = *result
        .measurements
        .get("lid_open_s")
        .ok_or_else(|| missing("lid_open_s"))?;
    let duration = *result
        .measurements
        .get("discharge_duration_s")
        .ok_or_else(|| missing("discharge_duration_s"))?;
    let trace = result
        .traces
        .get("discharged")
        .ok_or_else(|| missing("discharged"))?;
    Ok(trace
        .time_s
        .iter()
        .zip(&trace.values)
        .map(|(t, n)| (t - opened, *n))
        .filter(|(t, _)| *t > 0.0 && *t <= duration)
        .map(|(t, n)| (t, n / t))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_a_catalogue_and_every_entry_a_source() {
        for &kind in kinds() {
            let table = catalogue(kind).unwrap();
            assert!(!table.is_empty(), "{kind}");
            for s in table {
                assert!(read(kind, s.name).is_some(), "{kind}/{}", s.name);
                assert!(!s.unit.is_empty() && !s.description.is_empty());
            }
            let mut names: Vec<_> = table.iter().map(|s| s.name).collect();
            names.sort_unstable();
            names.dedup();
            assert_eq!(names.len(), table.len(), "{kind}: duplicate names");
        }
        assert!(catalogue("tumbler").is_none());
    }

    #[test]
    fn every_manifest_kind_is_listed() {
        let listed = listing(None).unwrap();
        assert_eq!(listed.len(), kinds().len());
        let err = listing(Some("tumbler")).unwrap_err().to_string();
        assert!(
            err.contains("tumbler") && err.contains("static_pile"),
            "{err}"
        );
    }
}
