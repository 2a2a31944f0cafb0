//! Choosing, and refusing, the time step.
//!
//! The step is `min(f · T_R, t_c / 20)`: a fraction `f` (default 0.2) of the
//! Rayleigh time `T_R` of the smallest particle (yan2015 uses 10–20 %), and at
//! least 20 steps across the shortest Hertz contact at the fastest expected
//! impact speed (`design_speed`). What the resolution costs in accuracy,
//! measured with the pair scene at e = 0.1 (the hardest case): restitution error
//! 0.6 % at 50 steps per contact, below 0.1 % at 100 (the validation tests use
//! 100); `repose tradeoff` measures it for whole scenes.
//! A step is refused when it cannot be trusted: `f > 0.5` (wave propagation
//! through dense packings is no longer resolved; DEM practice stays well below),
//! or fewer than 10 steps per contact at the design speed (the explicit
//! integrator then misses the force peak and energy is no longer conserved).
//! The error says which limit failed and what step would be stable.
//!
//! The design speed is a promise the run may break: a manifest is free to
//! design for 1 mm/s and then tumble particles at 0.3 m/s. The engine
//! measures what it met instead (the largest relative normal approach speed
//! of any contact, [`StepStats::max_approach_speed_m_s`](crate::dem::simulation::StepStats::max_approach_speed_m_s)),
//! and [`TimeStepPlan::under_resolved`] holds it against the step after the
//! run: fewer than [`MIN_STEPS_PER_CONTACT`] steps across the stiffest
//! contact at that speed — the number a requested step is refused below at
//! the design speed — is reported, not refused (the run has happened; its
//! result may still be what the user wanted). Measured why it matters: the
//! drum smoke with Rayleigh fraction 0.5 and design speed 1e-3 m/s (20 steps
//! per contact at 1 mm/s, 5.7 at the 0.52 m/s its particles reach) moved the
//! dynamic angle from 31.4° to 41.2° and the static one from 35.6° to 11.5°
//! without a word (issue 24). The stiffest contact and the fastest approach
//! of any contact are paired, so the check errs on the side of warning (the
//! fastest approach may have been a softer contact's). A step so large that
//! contacts are skipped altogether stops the run instead (tunnelling, see
//! [`crate::dem::health`]).

use crate::dem::material::{hertz_contact_time_s, rayleigh_time_s, ElasticMaterial};

/// Largest Rayleigh fraction accepted.
pub const MAX_RAYLEIGH_FRACTION: f64 = 0.5;
/// Steps per contact the automatic step guarantees at the design speed.
pub const AUTO_STEPS_PER_CONTACT: f64 = 20.0;
/// Fewest steps per contact a requested step may leave at the design speed.
pub const MIN_STEPS_PER_CONTACT: f64 = 10.0;

/// The stiffest contact a run can see, for the contact-time limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffestContact {
    /// Effective modulus E*, Pa.
    pub e_star_pa: f64,
    /// Effective radius R*, m.
    pub r_star_m: f64,
    /// Effective mass m*, kg.
    pub m_star_kg: f64,
}

/// Inputs of the time-step rule.
#[derive(Clone, Copy, Debug)]
pub struct TimeStepRequest {
    /// Radius of the smallest particle, m.
    pub min_radius_m: f64,
    /// Particle density, kg/m³.
    pub density_kg_m3: f64,
    /// Particle material.
    pub material: ElasticMaterial,
    /// Fraction of the Rayleigh time, in (0, 0.5].
    pub rayleigh_fraction: f64,
    /// Fastest impact speed the run is designed for, m/s.
    pub design_speed_m_s: f64,
    /// Contacts to resolve (each pair type with its smallest particles).
    pub stiffest: StiffestContact,
    /// An explicit step, s, instead of the automatic choice (checked all the same).
    pub requested_dt_s: Option<f64>,
}

/// The chosen step and the numbers behind it (recorded in results).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeStepPlan {
    /// The step, s.
    pub dt_s: f64,
    /// Rayleigh time of the smallest particle, s.
    pub rayleigh_time_s: f64,
    /// Shortest Hertz contact time at the design speed, s.
    pub contact_time_s: f64,
    /// Which limit set the step: `rayleigh`, `contact_time` or `requested`.
    pub limited_by: &'static str,
    /// The design impact speed the step was chosen for, m/s.
    pub design_speed_m_s: f64,
    /// The contact whose duration limits the step.
    pub stiffest: StiffestContact,
}

impl TimeStepPlan {
    /// Steps of `dt_s` across a Hertz contact of the stiffest contact at the
    /// approach speed `speed_m_s` (m/s); infinite at speed 0.
    pub fn steps_per_contact_at(&self, speed_m_s: f64) -> f64 {
        self.contact_time_at(speed_m_s) / self.dt_s
    }

    /// Hertz contact time of the stiffest contact at `speed_m_s` (m/s), s.
    fn contact_time_at(&self, speed_m_s: f64) -> f64 {
        let s = &self.stiffest;
        hertz_contact_time_s(s.m_star_kg, s.r_star_m, s.e_star_pa, speed_m_s)
    }

    /// The report for a run whose fastest contact approached at `reached_m_s`
    /// (m/s) if the step resolved such a contact with fewer than
    /// [`MIN_STEPS_PER_CONTACT`] steps (see the module docs); `None` if it
    /// resolved it well enough.
    pub fn under_resolved(&self, reached_m_s: f64) -> Option<UnderResolved> {
        if !(reached_m_s > 0.0 && reached_m_s.is_finite()) {
            return None;
        }
        let steps = self.steps_per_contact_at(reached_m_s);
        (steps < MIN_STEPS_PER_CONTACT).then_some(UnderResolved {
            reached_m_s,
            design_speed_m_s: self.design_speed_m_s,
            contact_time_s: self.contact_time_at(reached_m_s),
            dt_s: self.dt_s,
            steps_per_contact: steps,
        })
    }
}

/// A run met contacts faster than its step resolves (see
/// [`TimeStepPlan::under_resolved`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("under-resolved contacts: the fastest contact approached at {reached_m_s:.3e} m/s, {factor:.1} times the design impact speed {design_speed_m_s} m/s; a Hertz contact at that speed lasts {contact_time_s:.3e} s, {steps_per_contact:.2} steps of {dt_s:.3e} s, fewer than the {MIN_STEPS_PER_CONTACT} a step must resolve, so the result may depend on the step", factor = reached_m_s / design_speed_m_s)]
pub struct UnderResolved {
    /// The fastest approach the run met, m/s.
    pub reached_m_s: f64,
    /// The design impact speed, m/s.
    pub design_speed_m_s: f64,
    /// Hertz contact time of the stiffest contact at `reached_m_s`, s.
    pub contact_time_s: f64,
    /// The step, s.
    pub dt_s: f64,
    /// `contact_time_s / dt_s`.
    pub steps_per_contact: f64,
}

/// Why a step was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TimeStepError {
    /// The Rayleigh fraction is outside (0, 0.5].
    #[error("rayleigh_fraction = {fraction}: must be in (0, {MAX_RAYLEIGH_FRACTION}]; above that the step no longer resolves elastic waves through touching particles (stable: dt <= {stable_dt_s:.4e} s)")]
    RayleighFraction {
        /// The fraction asked for.
        fraction: f64,
        /// The largest stable step, s.
        stable_dt_s: f64,
    },
    /// A requested step resolves a design-speed contact with too few steps.
    #[error("time step {dt_s:.4e} s is unstable: a Hertz contact at the design speed {speed_m_s} m/s lasts {contact_time_s:.4e} s, which needs at least {MIN_STEPS_PER_CONTACT} steps (dt <= {stable_dt_s:.4e} s)")]
    TooFewStepsPerContact {
        /// The step asked for, s.
        dt_s: f64,
        /// Design impact speed, m/s.
        speed_m_s: f64,
        /// Contact duration at that speed, s.
        contact_time_s: f64,
        /// The largest acceptable step, s.
        stable_dt_s: f64,
    },
    /// An input of the rule is not a positive finite number.
    #[error("{name} = {value}: must be finite and > 0")]
    Input {
        /// Which input.
        name: &'static str,
        /// Its value.
        value: f64,
    },
}

/// Applies the rule in the module docs.
pub fn choose_time_step(req: &TimeStepRequest) -> Result<TimeStepPlan, TimeStepError> {
    for (name, value) in [
        ("min_radius_m", req.min_radius_m),
        ("density_kg_m3", req.density_kg_m3),
        ("design_speed_m_s", req.design_speed_m_s),
        ("youngs_modulus_pa", req.material.youngs_modulus_pa),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(TimeStepError::Input { name, value });
        }
    }
    let t_r = rayleigh_time_s(req.min_radius_m, req.density_kg_m3, &req.material);
    let s = &req.stiffest;
    let t_c = hertz_contact_time_s(s.m_star_kg, s.r_star_m, s.e_star_pa, req.design_speed_m_s);
    let f = req.rayleigh_fraction;
    if !(f > 0.0 && f <= MAX_RAYLEIGH_FRACTION) {
        return Err(TimeStepError::RayleighFraction {
            fraction: f,
            stable_dt_s: (MAX_RAYLEIGH_FRACTION * t_r).min(t_c / MIN_STEPS_PER_CONTACT),
        });
    }
    let (dt, limited_by) = match req.requested_dt_s {
        Some(dt) => {
            if !(dt.is_finite() && dt > 0.0) {
                return Err(TimeStepError::Input {
                    name: "dt_s",
                    value: dt,
                });
            }
            if dt > MAX_RAYLEIGH_FRACTION * t_r {
                return Err(TimeStepError::RayleighFraction {
                    fraction: dt / t_r,
                    stable_dt_s: (MAX_RAYLEIGH_FRACTION * t_r).min(t_c / MIN_STEPS_PER_CONTACT),
                });
            }
            (dt, "requested")
        }
        None if f * t_r <= t_c / AUTO_STEPS_PER_CONTACT => (f * t_r, "rayleigh"),
        None => (t_c / AUTO_STEPS_PER_CONTACT, "contact_time"),
    };
    if dt > t_c / MIN_STEPS_PER_CONTACT {
        return Err(TimeStepError::TooFewStepsPerContact {
            dt_s: dt,
            speed_m_s: req.design_speed_m_s,
            contact_time_s: t_c,
            stable_dt_s: t_c / MIN_STEPS_PER_CONTACT,
        });
    }
    Ok(TimeStepPlan {
        dt_s: dt,
        rayleigh_time_s: t_r,
        contact_time_s: t_c,
        limited_by,
        design_speed_m_s: req.design_speed_m_s,
        stiffest: req.stiffest,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bench_request() -> TimeStepRequest {
        let material = ElasticMaterial {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
        };
        let m = 2500.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-9;
        TimeStepRequest {
            min_radius_m: 1e-3,
            density_kg_m3: 2500.0,
            material,
            rayleigh_fraction: 0.2,
            design_speed_m_s: 0.01,
            stiffest: StiffestContact {
                e_star_pa: 5e6 / (1.0 - 0.09),
                r_star_m: 1e-3,
                m_star_kg: m,
            },
            requested_dt_s: None,
        }
    }

    #[test]
    fn benchmark_step_is_a_fifth_of_the_rayleigh_time() {
        let plan = choose_time_step(&bench_request()).unwrap();
        assert_eq!(plan.limited_by, "rayleigh");
        assert!((plan.dt_s - 2.4477e-5).abs() < 1e-9);
    }

    #[test]
    fn fast_impacts_shorten_the_step() {
        let mut r = bench_request();
        r.design_speed_m_s = 1000.0;
        let plan = choose_time_step(&r).unwrap();
        assert_eq!(plan.limited_by, "contact_time");
        assert!((plan.dt_s * AUTO_STEPS_PER_CONTACT - plan.contact_time_s).abs() < 1e-18);
    }

    #[test]
    fn speeds_beyond_the_design_speed_are_reported_once_under_resolved() {
        // The automatic step resolves the design speed with 20 steps; t_c
        // falls as v^(-1/5), so 10 steps are left at 2^5 = 32 times it.
        let plan = choose_time_step(&bench_request()).unwrap();
        assert_eq!(plan.under_resolved(0.0), None);
        let design = plan.design_speed_m_s;
        assert!(plan.steps_per_contact_at(design) >= AUTO_STEPS_PER_CONTACT);
        let mut r = bench_request();
        r.rayleigh_fraction = 0.5;
        r.design_speed_m_s = 1e-3;
        let plan = choose_time_step(&r).unwrap();
        assert_eq!(plan.limited_by, "contact_time");
        assert_eq!(plan.under_resolved(31.0e-3), None);
        let w = plan
            .under_resolved(33.0e-3)
            .expect("33 times the design speed");
        assert!(w.steps_per_contact < MIN_STEPS_PER_CONTACT && w.steps_per_contact > 9.8);
        let text = w.to_string();
        assert!(
            text.contains("under-resolved contacts") && text.contains("3.300e-2 m/s"),
            "{text}"
        );
    }

    #[test]
    fn unstable_steps_are_refused_with_the_stable_value() {
        let mut r = bench_request();
        r.rayleigh_fraction = 0.8;
        let e = choose_time_step(&r).unwrap_err().to_string();
        assert!(
            e.contains("rayleigh_fraction = 0.8") && e.contains("dt <="),
            "{e}"
        );
        let mut r = bench_request();
        r.design_speed_m_s = 100.0;
        r.requested_dt_s = Some(5e-5);
        let e = choose_time_step(&r).unwrap_err();
        assert!(
            matches!(e, TimeStepError::TooFewStepsPerContact { .. }),
            "{e}"
        );
    }
}
