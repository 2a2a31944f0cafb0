//! The hopper scene (yan2015) end to end: the smoke manifest runs healthy
//! with plausible angles, particles are conserved and the discharge count
//! never falls, rougher particles leave a steeper crater, a wider orifice discharges
//! faster (Beverloo), and a run is byte-identical on 1 and 2 threads.
//!
//! Runs are shared between tests (each is simulated once per test binary):
//! the smoke manifest, a rougher variant and a narrower-orifice variant.

mod common;

use repose::manifest::{parse_experiment, Experiment};
use repose::scenes::hopper::{beverloo_rate_per_s, BEVERLOO_K};
use repose::scenes::responses::{catalogue, response};
use repose::scenes::run_experiment;
use repose::store::RunResult;
use serde_json::{json, Value};
use std::sync::OnceLock;

const SMOKE: &str = include_str!("../experiments/hopper/smoke.json");

/// The smoke manifest with `edit` applied to its JSON.
fn variant(edit: impl FnOnce(&mut Value)) -> Experiment {
    let mut doc: Value = serde_json::from_str(SMOKE).unwrap();
    edit(&mut doc);
    parse_experiment(&doc.to_string()).unwrap()
}

fn run(exp: &Experiment) -> RunResult {
    run_experiment(exp, None).unwrap_or_else(|e| panic!("hopper run failed: {e}"))
}

/// The smoke manifest, run on a 2-thread pool.
fn smoke() -> &'static RunResult {
    static R: OnceLock<RunResult> = OnceLock::new();
    R.get_or_init(|| on_threads(2, || run(&variant(|_| {}))))
}

/// Sliding and rolling friction between particles raised from 0.25 / 0.25 to
/// 0.5 / 0.45 (yan2015's highest levels of both).
fn rough() -> &'static RunResult {
    static R: OnceLock<RunResult> = OnceLock::new();
    R.get_or_init(|| {
        run(&variant(|d| {
            d["contact"]["particle_particle"]["static_friction"] = json!(0.5);
            d["contact"]["particle_particle"]["rolling_friction"] = json!(0.45);
        }))
    })
}

/// The smoke's orifice narrowed from 18 to yan2015's 15 mm, on a 60 mm plate
/// (smaller than the heap, so particles fall off it and are removed; the
/// plate does not change the flow out of the hopper).
fn narrow() -> &'static RunResult {
    static R: OnceLock<RunResult> = OnceLock::new();
    R.get_or_init(|| {
        run(&variant(|d| {
            d["scene"]["orifice_diameter_m"] = json!(NARROW_ORIFICE_M);
            d["scene"]["plate_diameter_m"] = json!(0.06);
        }))
    })
}

const SMOKE_ORIFICE_M: f64 = 0.018;
const NARROW_ORIFICE_M: f64 = 0.015;
/// The smoke's simulated particle diameter (1 mm radius × size factor 1.5).
const SMOKE_DIAMETER_M: f64 = 0.003;

fn on_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

fn m(r: &RunResult, key: &str) -> f64 {
    *r.measurements
        .get(key)
        .unwrap_or_else(|| panic!("no measurement {key}"))
}

fn trace<'a>(r: &'a RunResult, name: &str) -> &'a repose::store::Trace {
    r.traces
        .get(name)
        .unwrap_or_else(|| panic!("no trace {name}"))
}

#[test]
fn smoke_manifest_runs_healthy_with_plausible_angles() {
    let r = smoke();
    // Resolution by hand: the 18 mm orifice is 6 diameters of the coarse
    // 3 mm spheres (1 mm × size factor 1.5 × 2), at the limit; Beverloo's
    // effective orifice 6 − 1.5 = 4.5.
    common::assert_figure(r, "orifice_diameters", 6.0, false);
    common::assert_figure(r, "beverloo_orifice_diameters", 6.0 - BEVERLOO_K, false);
    let (alpha, theta) = (m(r, "upper_angle_deg"), m(r, "bottom_angle_deg"));
    eprintln!(
        "smoke: alpha {alpha:.2}, theta {theta:.2}, {} particles, {} steps, discharged {}",
        m(r, "particles"),
        m(r, "steps"),
        m(r, "discharged")
    );
    assert!(
        r.kernel.starts_with("hertz+mindlin+epsd+gravity"),
        "{}",
        r.kernel
    );
    assert_eq!(r.headline_angle_deg, Some(theta));
    // yan2015's base case (the smoke's friction) stands at theta 28.9 and
    // alpha 31.1 deg; the quick profile measures 28 and 35. The smoke's heap
    // is ~940 coarse spheres, about four layers high under a falling stream,
    // which leaves it flatter, and its crater has only 3-4 surface points per
    // flank. A heap in 8-40 deg and a crater in 20-60 deg are what a working
    // scene gives; a spread layer is not measurable (the angle is left out) and a
    // broken contact law or window would give near 0 or near 90.
    assert!(theta > 8.0 && theta < 40.0, "theta {theta}");
    assert!(alpha > 20.0 && alpha < 60.0, "alpha {alpha}");
    assert_eq!(m(r, "upper_angle_measured"), 1.0);
    assert_eq!(m(r, "bottom_angle_measured"), 1.0);
    for name in ["upper_angle", "bottom_angle"] {
        for fit in ["xz_left", "xz_right", "yz_left", "yz_right"] {
            let a = m(r, &format!("{name}_{fit}_deg"));
            let r2 = m(r, &format!("{name}_{fit}_r2"));
            let n = m(r, &format!("{name}_{fit}_points"));
            assert!(a.is_finite() && r2.is_finite() && n >= 3.0, "{name} {fit}");
        }
    }
    // The bed came to rest before the lid opened, and most of it left.
    assert_eq!(m(r, "settled"), 1.0);
    assert!(m(r, "discharged") > 0.3 * m(r, "particles"));
    // A poured bed of spheres is between random loose (0.55) and random close
    // (0.64) packing.
    let phi = m(r, "settled_solid_fraction");
    assert!(phi > 0.54 && phi < 0.645, "solid fraction {phi}");
    let overlap = trace(r, "max_overlap_ratio");
    assert!(overlap.values.iter().all(|&v| v < 0.3));
}

#[test]
fn every_named_response_is_read_or_said_to_be_unmeasured() {
    let r = smoke();
    let read = |name: &str| response(r, "hopper", name);
    assert_eq!(read("alpha_deg").unwrap(), m(r, "upper_angle_deg"));
    assert_eq!(read("theta_deg").unwrap(), m(r, "bottom_angle_deg"));
    assert_eq!(r.headline_angle_deg, Some(read("theta_deg").unwrap()));
    assert_eq!(
        read("flow_rate_steady_per_s").unwrap(),
        m(r, "flow_rate_steady_per_s")
    );
    assert_eq!(
        read("window_speed_m_s").unwrap(),
        m(r, "window_speed_mean_m_s")
    );
    // FR(t) exists for the times inside the discharge and only for them.
    let covered = m(r, "flow_rate_times_covered") as usize;
    assert!(covered >= 1, "the smoke discharges for over 1 s");
    for (k, t) in [1, 2, 3, 4].into_iter().enumerate() {
        let name = format!("flow_rate_{t}s_per_s");
        if k < covered {
            let rate = read(&name).unwrap();
            assert_eq!(rate, m(r, &name));
            assert!(rate > 0.0, "{name} {rate}");
        } else {
            let err = read(&name).unwrap_err().to_string();
            assert!(err.contains("did not measure response"), "{err}");
        }
    }
    for spec in catalogue("hopper").unwrap() {
        let known = spec.name.starts_with("flow_rate_") && spec.name.ends_with("s_per_s");
        assert!(known || read(spec.name).is_ok(), "{}", spec.name);
    }
    let err = read("upper_angle_deg").unwrap_err().to_string();
    assert!(
        err.contains("its responses are: alpha_deg, theta_deg, flow_rate_1s_per_s"),
        "{err}"
    );
}

#[test]
fn particles_are_conserved_and_the_discharge_never_decreases() {
    for r in [smoke(), narrow()] {
        check_bookkeeping(r);
    }
    // The 60 mm plate holds a heap of ~650 spheres of 3 mm at 25-30 deg
    // (pi/3 R^3 tan(theta) at a bulk fraction of 0.6) and more than that leaves
    // the hopper: some fell off and were removed, and were counted.
    assert!(m(narrow(), "removed_off_plate") > 0.0);
}

/// Every sample: in the hopper + below it + removed = inserted; the discharge
/// count starts at 0, never falls, and ends at the reported total.
fn check_bookkeeping(r: &RunResult) {
    let inserted = m(r, "particles");
    let (hopper, below, removed) = (
        trace(r, "in_hopper"),
        trace(r, "below_hopper"),
        trace(r, "removed"),
    );
    assert!(hopper.values.len() > 100);
    for k in 0..hopper.values.len() {
        assert_eq!(hopper.time_s[k], below.time_s[k]);
        assert_eq!(
            hopper.values[k] + below.values[k] + removed.values[k],
            inserted,
            "sample {k} at t = {}",
            hopper.time_s[k]
        );
    }
    let discharged = trace(r, "discharged");
    assert_eq!(
        discharged.values[0], 0.0,
        "nothing left before the lid opened"
    );
    for w in discharged.values.windows(2) {
        assert!(w[1] >= w[0], "discharge count fell: {w:?}");
    }
    assert_eq!(*discharged.values.last().unwrap(), m(r, "discharged"));
    assert_eq!(
        m(r, "discharged"),
        m(r, "on_plate") + m(r, "removed_off_plate")
    );
    assert_eq!(
        m(r, "remaining_in_hopper") + m(r, "discharged") + m(r, "spilled_during_fill"),
        inserted
    );
}

#[test]
fn rougher_particles_stand_steeper_in_the_hopper() {
    // yan2015 Fig. 10 and Table 2: the angles grow with the sliding and the
    // rolling friction between particles (mu_s dominant, mu_r second); from
    // 0.25/0.25 to 0.5/0.45 the crater angle alpha must rise by more than 3
    // degrees. The smoke's heap on the plate does not resolve friction: it is
    // ~4 layers of coarse spheres flattened by the stream, and the rougher bed
    // sends fewer particles down (measured: theta 12.6 vs 13.3 deg), so theta
    // is compared only in the quick profile (experiments/hopper/README.md).
    let (base, rough) = (smoke(), rough());
    let name = "upper_angle_deg";
    eprintln!(
        "{name}: base {:.2}, rough {:.2}; bottom angle: base {:.2}, rough {:.2}",
        m(base, name),
        m(rough, name),
        m(base, "bottom_angle_deg"),
        m(rough, "bottom_angle_deg")
    );
    assert!(
        m(rough, name) > m(base, name) + 3.0,
        "{name}: rough {} vs base {}",
        m(rough, name),
        m(base, name)
    );
    // More friction also leaves more behind in the hopper (yan2015 §4.2.2:
    // the low-friction runs empty it further).
    assert!(m(rough, "remaining_in_hopper") > m(base, "remaining_in_hopper"));
}

#[test]
fn a_wider_orifice_discharges_faster_as_beverloo_predicts() {
    // Beverloo, Leniger & van de Velde (1961), Chem. Eng. Sci. 15:260:
    // W = C rho_b sqrt(g) (D_o - k d)^2.5 with C ~ 0.58, k ~ 1.5. The smoke's
    // 3 mm spheres through 15 and 18 mm.
    let (narrow, wide) = (narrow(), smoke());
    let rate = |r: &RunResult| m(r, "flow_rate_steady_per_s");
    eprintln!(
        "steady rate: 15 mm {:.0}/s (Beverloo {:.0}), 18 mm {:.0}/s (Beverloo {:.0})",
        rate(narrow),
        m(narrow, "beverloo_flow_rate_per_s"),
        rate(wide),
        m(wide, "beverloo_flow_rate_per_s")
    );
    assert!(rate(wide) > rate(narrow));
    // Order of magnitude: each measured rate within a factor 2 of Beverloo's
    // (C and k are fitted to orifices of tens of diameters; here D_o/d = 5-6).
    for r in [narrow, wide] {
        let ratio = rate(r) / m(r, "beverloo_flow_rate_per_s");
        assert!(ratio > 0.5 && ratio < 2.0, "measured / Beverloo = {ratio}");
    }
    // The prediction in the result is Beverloo's formula for the measured bed.
    let expected = beverloo_rate_per_s(
        m(wide, "settled_solid_fraction"),
        SMOKE_ORIFICE_M,
        SMOKE_DIAMETER_M,
    );
    assert!((m(wide, "beverloo_flow_rate_per_s") - expected).abs() < 1e-9 * expected);
    // The ratio of the two rates follows the 5/2 power of the free width
    // D_o - k d within 30 % (C cancels): ((18 - 4.5) / (15 - 4.5))^2.5 = 1.87.
    let free = |d_o: f64| d_o - BEVERLOO_K * SMOKE_DIAMETER_M;
    let predicted = (free(SMOKE_ORIFICE_M) / free(NARROW_ORIFICE_M)).powf(2.5);
    let measured = rate(wide) / rate(narrow);
    assert!(
        (measured / predicted - 1.0).abs() < 0.3,
        "rate ratio {measured} vs Beverloo {predicted}"
    );
}

#[test]
fn a_run_is_byte_identical_on_one_and_two_threads() {
    let one = on_threads(1, || run(&variant(|_| {})));
    let bytes = |r: &RunResult| serde_json::to_vec_pretty(r).unwrap();
    assert!(
        bytes(&one) == bytes(smoke()),
        "result.json differs between 1 and 2 threads"
    );
}
