//! Named responses (`repose::scenes::responses`) read from real pair runs:
//! an impact gives the restitution but no pull-off, a JKR separation gives the
//! pull-off force and its ratio to JKR's 3πΓR*; unknown names and runs of
//! another scene are refused with the allowed names. The lab scenes' responses
//! are checked on the runs of their own scene tests (tests/scene_*.rs).

mod common;

use common::{pair_jkr, pair_wall};
use repose::manifest::parse_experiment;
use repose::scenes::responses::{catalogue, response, ResponseError};
use repose::scenes::run_experiment;
use repose::store::RunResult;

fn run(doc: &serde_json::Value) -> RunResult {
    run_experiment(&parse_experiment(&doc.to_string()).unwrap(), None).unwrap()
}

#[test]
fn pair_responses_come_from_the_run_that_measured_them() {
    let impact = run(&pair_wall());
    let separation = run(&pair_jkr());
    let names: Vec<&str> = catalogue("pair").unwrap().iter().map(|s| s.name).collect();
    assert_eq!(
        names,
        [
            "restitution",
            "contact_duration_s",
            "max_overlap_m",
            "pull_off_force_n",
            "pull_off_ratio"
        ]
    );
    for key in ["restitution", "contact_duration_s", "max_overlap_m"] {
        assert_eq!(
            response(&impact, "pair", key).unwrap(),
            impact.measurements[key]
        );
    }
    let e = response(&impact, "pair", "restitution").unwrap();
    assert!(e > 0.0 && e <= 1.0, "restitution {e}");
    for name in ["pull_off_force_n", "pull_off_ratio"] {
        let err = response(&impact, "pair", name).unwrap_err();
        assert!(
            matches!(err, ResponseError::NotMeasured { .. }),
            "{name}: {err}"
        );
        let msg = err.to_string();
        assert!(
            msg.contains(&impact.id.short(12).to_string()) && msg.contains(name),
            "{msg}"
        );
    }

    let force = response(&separation, "pair", "pull_off_force_n").unwrap();
    assert_eq!(force, separation.measurements["pull_off_force_n"]);
    let ratio = response(&separation, "pair", "pull_off_ratio").unwrap();
    assert!((ratio - 1.0).abs() < 0.05, "pull-off ratio {ratio}");
    assert!(response(&separation, "pair", "restitution").is_err());

    let err = response(&impact, "pair", "angle_deg")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'angle_deg' is not a response of the pair scene")
            && err.contains("restitution, contact_duration_s"),
        "{err}"
    );
    let err = response(&impact, "drum", "static_angle_deg")
        .unwrap_err()
        .to_string();
    assert!(err.contains("is a pair run, not a drum run"), "{err}");
    let err = response(&impact, "tumbler", "x").unwrap_err().to_string();
    assert!(err.contains("unknown scene kind 'tumbler'"), "{err}");
}
