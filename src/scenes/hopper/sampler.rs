//! What the hopper scene does at every sample: remove the particles that fell
//! off the plate, count where the others are, follow the discharge, and
//! record traces, the speed near the orifice, the angles and log frames.

use super::angles::{bottom_angle, upper_angle};
use super::geometry::{Geometry, Location};
use super::HopperError;
use crate::dem::health::HealthError;
use crate::dem::simulation::Simulation;
use crate::log::{AngleSample, RunLog, Trace};
use crate::measure::flow::{window_mean_speed, DischargeSample, SpeedWindow};
use crate::measure::ortho::OrthoAngles;
use crate::scenes::protocol::{Sampler, Traces};

/// Simulated time between two particle frames of the run log, s (a 5 s
/// discharge gives 100 frames).
pub const LOG_FRAME_INTERVAL_S: f64 = 0.05;
/// yan2015's speed window: 20–30 mm above the orifice plane (Fig. 6a).
pub const SPEED_WINDOW_ABOVE_ORIFICE_M: (f64, f64) = (0.020, 0.030);

/// Counts of one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Census {
    /// Particles in the hopper (not yet fully below the orifice plane).
    pub hopper: usize,
    /// Particles below it: falling or on the plate.
    pub below: usize,
}

/// The hopper run's sampler (see the module docs).
pub struct DischargeSampler<'a> {
    geo: Geometry,
    traces: Traces,
    log: Option<&'a mut RunLog>,
    /// Particles removed so far (spilled at the opening, or fell off the plate).
    removed: usize,
    /// Index of the last logged frame (frame k is due at k · LOG_FRAME_INTERVAL_S).
    last_frame: Option<u64>,
    /// Particles removed before the lid opened (None while it is closed).
    removed_at_opening: Option<usize>,
    discharge: Vec<DischargeSample>,
    last_discharge_s: f64,
    now_s: f64,
    stop_after_s: f64,
    window: SpeedWindow,
}

impl<'a> DischargeSampler<'a> {
    /// A sampler whose discharge phase ends once no particle has left the
    /// hopper for `stop_after_s`.
    pub fn new(geo: Geometry, stop_after_s: f64, log: Option<&'a mut RunLog>) -> Self {
        let (lo, hi) = SPEED_WINDOW_ABOVE_ORIFICE_M;
        Self {
            geo,
            traces: Traces::default(),
            log,
            removed: 0,
            last_frame: None,
            removed_at_opening: None,
            discharge: Vec::new(),
            last_discharge_s: 0.0,
            now_s: 0.0,
            stop_after_s,
            window: SpeedWindow {
                z_window_m: (geo.bottom_z + lo, geo.bottom_z + hi),
                cylinder: Some(([0.0, 0.0], geo.orifice_radius)),
            },
        }
    }

    /// Marks the opening of the lid at the current time: removes the particles
    /// that ended up outside the hopper while the bed was poured (they would
    /// count as discharged) and returns how many there were. The discharge
    /// count starts at zero from here.
    pub fn open(&mut self, sim: &mut Simulation) -> Result<usize, HealthError> {
        let g = self.geo;
        let spilled = sim.retain(|p, i| g.inside_hopper(p.position[i], p.radius[i]))?;
        self.removed += spilled;
        self.removed_at_opening = Some(self.removed);
        self.last_discharge_s = sim.world().time_s;
        Ok(spilled)
    }

    /// Particles removed so far.
    pub fn removed(&self) -> usize {
        self.removed
    }

    /// The discharge trace: (time, particles that left since the opening).
    pub fn discharge(&self) -> &[DischargeSample] {
        &self.discharge
    }

    /// Time the last particle left the hopper, s (the opening if none has).
    pub fn last_discharge_s(&self) -> f64 {
        self.last_discharge_s
    }

    /// The collected traces.
    pub fn into_traces(self) -> Traces {
        self.traces
    }

    /// Where the particles of `sim` are now.
    pub fn census(&self, sim: &Simulation) -> Census {
        let (centres, radii) = sim.world().grain_centres();
        let mut c = Census::default();
        for (x, &r) in centres.iter().zip(&radii) {
            match self.geo.locate(*x, r) {
                Location::Hopper => c.hopper += 1,
                // Gone particles are removed before every census.
                Location::Below | Location::Gone => c.below += 1,
            }
        }
        c
    }

    /// Traces of the discharge phase: count, window speed and the two angles.
    fn sample_discharge(
        &mut self,
        sim: &Simulation,
        census: Census,
        removed_at_opening: usize,
    ) -> Result<(), HopperError> {
        let w = sim.world();
        let t = w.time_s;
        let left = census.below + self.removed - removed_at_opening;
        if self.discharge.last().is_some_and(|&(_, n)| left as u64 > n) {
            self.last_discharge_s = t;
        }
        self.discharge.push((t, left as u64));
        self.traces.push("discharged", "1", t, left as f64);
        let p = &w.particles;
        if let Ok(s) = window_mean_speed(&p.position, &p.velocity, &self.window) {
            self.traces.push("window_speed", "m/s", t, s.mean_speed_m_s);
        }
        if let Ok(a) = upper_angle(&p.position, &p.radius, &self.geo) {
            self.traces.push("upper_angle", "deg", t, a.mean_deg);
        }
        let theta = bottom_angle(&p.position, &p.radius, &self.geo).ok();
        if let Some(a) = theta {
            self.traces.push("bottom_angle", "deg", t, a.mean_deg);
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.scalar(Trace::Discharged, t, left as f64)?;
            if let Some(a) = theta {
                log.angle(t, &angle_sample(&a))?;
            }
        }
        Ok(())
    }
}

/// An ortho angle as the log's angle sample: left and right are the means of
/// the two slabs' left and right fits; the R² is the worst of the four.
fn angle_sample(a: &OrthoAngles) -> AngleSample {
    AngleSample {
        left_deg: 0.5 * (a.angles_deg[0] + a.angles_deg[2]),
        right_deg: 0.5 * (a.angles_deg[1] + a.angles_deg[3]),
        mean_deg: a.mean_deg,
        fit_r2: [a.xz.left.r2, a.xz.right.r2, a.yz.left.r2, a.yz.right.r2]
            .into_iter()
            .fold(f64::INFINITY, f64::min),
    }
}

impl Sampler for DischargeSampler<'_> {
    type Error = HopperError;

    fn sample(&mut self, _phase: &'static str, sim: &mut Simulation) -> Result<(), HopperError> {
        let g = self.geo;
        self.removed +=
            sim.retain(|p, i| g.locate(p.position[i], p.radius[i]) != Location::Gone)?;
        let census = self.census(sim);
        let t = sim.world().time_s;
        self.now_s = t;
        self.traces.push_engine_state(sim);
        self.traces.push("in_hopper", "1", t, census.hopper as f64);
        self.traces
            .push("below_hopper", "1", t, census.below as f64);
        self.traces.push("removed", "1", t, self.removed as f64);
        if let Some(before) = self.removed_at_opening {
            self.sample_discharge(sim, census, before)?;
        }
        if let Some(log) = self.log.as_deref_mut() {
            // Frame k is due from t = k · interval on (the tolerance absorbs
            // the rounding of the accumulated time; a late frame is harmless).
            let k = (t / LOG_FRAME_INTERVAL_S + 1e-6).floor() as u64;
            if self.last_frame.is_none_or(|last| k > last) {
                log.record(sim)?;
                self.last_frame = Some(k);
            }
        }
        Ok(())
    }

    fn stop_early(&self) -> bool {
        self.removed_at_opening.is_some() && self.now_s - self.last_discharge_s >= self.stop_after_s
    }
}
