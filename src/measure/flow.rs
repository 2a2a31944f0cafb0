//! yan2015 discharge measurements: flow rate and the mean speed near the orifice.
//!
//! Flow rate follows yan2015: FR(t) = (particles discharged by time t) / t, with t
//! counted from the opening of the orifice — a cumulative average over [0, t], not
//! an instantaneous rate. [`interval_rate`] gives the rate over a window
//! [t1, t2] for callers who want the local one.

use super::{check_window, MeasureError};
use crate::dem::vec3::Vec3;

/// One sample of the discharge trace: simulation time (s) and the cumulative
/// number of particles that have left through the orifice by then.
pub type DischargeSample = (f64, u64);

/// A flow rate at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowRate {
    /// Discharging time (since the opening), s.
    pub t_s: f64,
    /// Particles discharged by then.
    pub discharged: u64,
    /// discharged / t, particles per second.
    pub rate_per_s: f64,
}

/// Cumulative count at absolute time `t`: the last sample at or before `t`
/// (the trace is a step function; no interpolation).
fn count_at(samples: &[DischargeSample], t: f64) -> Result<u64, MeasureError> {
    check_trace(samples)?;
    let (first, last) = (samples[0].0, samples[samples.len() - 1].0);
    if !(t >= first && t <= last) {
        return Err(MeasureError::Series(format!(
            "time {t} s is outside the discharge trace [{first}, {last}] s"
        )));
    }
    let k = samples.partition_point(|s| s.0 <= t);
    Ok(samples[k - 1].1)
}

fn check_trace(samples: &[DischargeSample]) -> Result<(), MeasureError> {
    if samples.is_empty() {
        return Err(MeasureError::Series("the discharge trace is empty".into()));
    }
    for (i, w) in samples.windows(2).enumerate() {
        if !(w[0].0.is_finite() && w[1].0 >= w[0].0) || w[1].1 < w[0].1 {
            return Err(MeasureError::Series(format!(
                "discharge samples {i} and {} are out of order (time and count must not decrease)",
                i + 1
            )));
        }
    }
    if !samples[samples.len() - 1].0.is_finite() {
        return Err(MeasureError::Series("a sample time is not finite".into()));
    }
    Ok(())
}

/// yan2015's FR at each discharging time in `times_s` (s after `t_open_s`, all
/// positive): discharged count / time. The count is taken from the sample at or before
/// `t_open_s + t` and should be zero at the opening; the trace must cover every
/// requested time.
pub fn flow_rates(
    samples: &[DischargeSample],
    t_open_s: f64,
    times_s: &[f64],
) -> Result<Vec<FlowRate>, MeasureError> {
    times_s
        .iter()
        .map(|&t| {
            if !(t.is_finite() && t > 0.0) {
                return Err(MeasureError::BadParameter {
                    name: "times_s",
                    value: t,
                    allowed: "discharging times > 0",
                });
            }
            let discharged = count_at(samples, t_open_s + t)?;
            Ok(FlowRate {
                t_s: t,
                discharged,
                rate_per_s: discharged as f64 / t,
            })
        })
        .collect()
}

/// Particles per second discharged between absolute times `window_s.0` and
/// `window_s.1`.
pub fn interval_rate(
    samples: &[DischargeSample],
    window_s: (f64, f64),
) -> Result<f64, MeasureError> {
    check_window("window_s", window_s)?;
    let (n0, n1) = (
        count_at(samples, window_s.0)?,
        count_at(samples, window_s.1)?,
    );
    Ok((n1 - n0) as f64 / (window_s.1 - window_s.0))
}

/// Mean speed of the particles in a window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowSpeed {
    /// Mean of |v| over the particles in the window, m/s.
    pub mean_speed_m_s: f64,
    /// Particles in the window.
    pub particles: usize,
}

/// Where to average speeds: a height band and, optionally, a vertical cylinder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedWindow {
    /// Centre heights included, m (yan2015: 20–30 mm above the orifice plane).
    pub z_window_m: (f64, f64),
    /// Optional cylinder (axis x, y in m; radius in m) the centres must lie in,
    /// e.g. the orifice radius to leave out the static corners of the hopper.
    pub cylinder: Option<([f64; 2], f64)>,
}

/// Mean speed (magnitude of the velocity) of the particles whose centre is inside
/// the window; an error when none is.
pub fn window_mean_speed(
    positions: &[Vec3],
    velocities: &[Vec3],
    window: &SpeedWindow,
) -> Result<WindowSpeed, MeasureError> {
    if velocities.len() != positions.len() {
        return Err(MeasureError::LengthMismatch {
            what: "velocities",
            found: velocities.len(),
            expected: positions.len(),
        });
    }
    check_window("z_window_m", window.z_window_m)?;
    let (zlo, zhi) = window.z_window_m;
    let mut sum = 0.0;
    let mut n = 0usize;
    for (index, (p, v)) in positions.iter().zip(velocities).enumerate() {
        if !(p.iter().chain(v.iter()).all(|c| c.is_finite())) {
            return Err(MeasureError::BadParticle { index });
        }
        let in_z = p.z >= zlo && p.z <= zhi;
        let in_cyl = window
            .cylinder
            .is_none_or(|([cx, cy], r)| (p.x - cx).hypot(p.y - cy) <= r);
        if in_z && in_cyl {
            sum += v.norm();
            n += 1;
        }
    }
    if n == 0 {
        return Err(MeasureError::NoParticles {
            what: "the speed window",
        });
    }
    Ok(WindowSpeed {
        mean_speed_m_s: sum / n as f64,
        particles: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant 1000 particles/s from the opening at t = 0.5 s, sampled every
    /// 0.01 s: FR(t) = 1000 /s at every t; the step trace reads the count at the
    /// sample at or before the time, so FR is exact at sample times.
    #[test]
    fn constant_discharge() {
        let trace: Vec<DischargeSample> = (0..=500)
            .map(|k| {
                let t = 0.5 + 0.01 * k as f64;
                (t, (1000.0 * (t - 0.5) + 1e-9).floor() as u64)
            })
            .collect();
        let fr = flow_rates(&trace, 0.5, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        for f in &fr {
            assert!((f.rate_per_s - 1000.0).abs() < 1.0, "{f:?}");
        }
        assert_eq!(fr[3].discharged, 4000);
        let r = interval_rate(&trace, (1.5, 2.5)).unwrap();
        assert!((r - 1000.0).abs() < 1.0);
        assert!(flow_rates(&trace, 0.5, &[10.0]).is_err());
        assert!(flow_rates(&trace, 0.5, &[0.0]).is_err());
        assert!(flow_rates(&[], 0.5, &[1.0]).is_err());
        let unsorted = [(1.0, 5), (0.5, 6)];
        assert!(flow_rates(&unsorted, 0.0, &[0.7]).is_err());
    }

    #[test]
    fn mean_speed_in_window() {
        let p = [
            Vec3::new(0.0, 0.0, 0.025),
            Vec3::new(0.001, 0.0, 0.021),
            Vec3::new(0.0, 0.0, 0.035),
            Vec3::new(0.02, 0.0, 0.025),
        ];
        let v = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 3.0, -4.0),
            Vec3::new(0.0, 0.0, -9.0),
            Vec3::new(0.0, 0.0, -9.0),
        ];
        let w = SpeedWindow {
            z_window_m: (0.02, 0.03),
            cylinder: Some(([0.0, 0.0], 0.0075)),
        };
        let s = window_mean_speed(&p, &v, &w).unwrap();
        assert_eq!(s.particles, 2);
        assert!((s.mean_speed_m_s - 3.0).abs() < 1e-12);
        let all = SpeedWindow {
            cylinder: None,
            ..w
        };
        assert_eq!(window_mean_speed(&p, &v, &all).unwrap().particles, 3);
        let empty = SpeedWindow {
            z_window_m: (1.0, 2.0),
            cylinder: None,
        };
        assert!(window_mean_speed(&p, &v, &empty).is_err());
        assert!(window_mean_speed(&p, &v[..1], &w).is_err());
    }
}
