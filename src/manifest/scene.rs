//! Scenes as data: the two-body `pair` check and the five lab tests of the papers.
//!
//! Numbers in the doc comments come from shared/METHODS.md. Where a paper is silent
//! (an outlet diameter, a drop height) the example manifests choose a value and the
//! field's doc says so; nothing here is hard-coded into the engine. The lab scenes are
//! validated data only until their protocol is simulated (issue 4).

use serde::{Deserialize, Serialize};

/// What an experiment simulates, tagged by `kind`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Scene {
    /// Two bodies in contact: an impact or a quasi-static separation (physics checks).
    Pair(PairScene),
    /// he2019's modified FBS-104 funnel flow meter (calibration test).
    FunnelPile(FunnelPileScene),
    /// he2019's baffle lift box (static angle verification).
    BaffleLift(BaffleLiftScene),
    /// Rotating drum (he2019 and cai2024 dynamic angle).
    Drum(DrumScene),
    /// yan2015's flat-bottomed cylindrical hopper discharging onto a plate.
    Hopper(HopperScene),
    /// cai2024's fixed-base funnel (GB/T 16913-2008) static pile.
    StaticPile(StaticPileScene),
}

impl Scene {
    /// The scene's `kind` tag as written in manifests.
    pub fn kind(&self) -> &'static str {
        match self {
            Scene::Pair(_) => "pair",
            Scene::FunnelPile(_) => "funnel_pile",
            Scene::BaffleLift(_) => "baffle_lift",
            Scene::Drum(_) => "drum",
            Scene::Hopper(_) => "hopper",
            Scene::StaticPile(_) => "static_pile",
        }
    }

    /// Every wall material the scene uses, as (field name, material name) pairs, so
    /// validation can check each is defined and has particle–wall parameters.
    pub fn wall_materials(&self) -> Vec<(&'static str, &str)> {
        match self {
            Scene::Pair(s) => match &s.partner {
                Partner::Wall { material } => vec![("partner.material", material.as_str())],
                Partner::Particle { .. } => Vec::new(),
            },
            Scene::FunnelPile(s) => {
                let mut walls = vec![
                    ("funnel_material", s.funnel_material.as_str()),
                    ("platform_material", s.platform_material.as_str()),
                ];
                if let Some(brush) = &s.brush_material {
                    walls.push(("brush_material", brush.as_str()));
                }
                walls
            }
            Scene::BaffleLift(s) => vec![
                ("box_material", s.box_material.as_str()),
                ("floor_material", s.floor_material.as_str()),
            ],
            Scene::Drum(s) => vec![("wall_material", s.wall_material.as_str())],
            Scene::Hopper(s) => vec![
                ("hopper_material", s.hopper_material.as_str()),
                ("plate_material", s.plate_material.as_str()),
            ],
            Scene::StaticPile(s) => vec![
                ("funnel_material", s.funnel_material.as_str()),
                ("disk_material", s.disk_material.as_str()),
            ],
        }
    }
}

/// Two bodies: particle against particle or against a flat wall. Body 1 (radius
/// `radius_m`) moves towards the partner along the contact normal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairScene {
    /// Impact (approach and rebound) or separation (JKR pull-off).
    pub mode: PairMode,
    /// Radius of the moving particle, m.
    pub radius_m: f64,
    /// The body it meets.
    pub partner: Partner,
    /// Approach speed along the normal, m/s, ≥ 0 (> 0 in impact mode).
    pub normal_velocity_m_s: f64,
    /// Tangential speed at first contact, m/s, ≥ 0 (oblique impacts).
    pub tangential_velocity_m_s: f64,
    /// Initial angular velocity of the moving particle, rad/s, (x, y, z).
    pub angular_velocity_rad_s: [f64; 3],
    /// Whether gravity (9.81 m/s², −z) acts; default false.
    #[serde(default)]
    pub gravity: bool,
    /// Separation mode: quasi-static pull speed, m/s, > 0 (required there; optional
    /// in impact mode).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pull_speed_m_s: Option<f64>,
    /// Simulated time limit, s, > 0.
    pub max_time_s: f64,
}

/// What a pair scene measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PairMode {
    /// Approach, collide and rebound: restitution, contact time, peak force.
    Impact,
    /// Pull a contact apart quasi-statically: pull-off force.
    Separation,
}

/// The partner body of a pair scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Partner {
    /// A second particle of the same material, initially at rest.
    Particle {
        /// Radius, m.
        radius_m: f64,
    },
    /// A fixed flat wall of the named wall material.
    Wall {
        /// Wall material name (a key of `material.walls`).
        material: String,
    },
}

/// he2019 §2.1/§2.3.2: modified FBS-104 funnel flow meter. A factory fills the funnel,
/// the powder stands, then the brush turns and pushes it down onto the platform.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FunnelPileScene {
    /// Funnel top (inlet) diameter, m (he2019: 0.120).
    pub funnel_top_diameter_m: f64,
    /// Funnel outlet diameter, m (paper silent; the examples choose 0.010).
    pub funnel_outlet_diameter_m: f64,
    /// Height of the conical part, m (paper silent; the examples choose 0.095,
    /// a 60° cone).
    pub funnel_height_m: f64,
    /// Tilt of the outlet, degrees, in [0, 90) (he2019: 7).
    pub outlet_tilt_deg: f64,
    /// Height of the outlet above the platform, m (paper silent; examples 0.060):
    /// the height of the cone's lower rim, where the outlet tube starts.
    pub outlet_height_m: f64,
    /// Length of the straight outlet tube below the cone, along its tilted axis, m,
    /// positive; its lower end (tube length · cos tilt + outlet radius · sin tilt
    /// below the rim) must stay above the platform. Paper silent; absent: one
    /// outlet diameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outlet_tube_length_m: Option<f64>,
    /// Receiving platform diameter, m (he2019: 0.094).
    pub platform_diameter_m: f64,
    /// Brush speed, rpm, > 0; absent means no brush (the effect is not simulated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brush_rpm: Option<f64>,
    /// Number of brush blades, evenly spaced in azimuth, 1 to 8 (paper silent;
    /// absent: 2). Only with `brush_rpm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brush_blades: Option<u32>,
    /// Gap between each blade's outer edge and the funnel wall, m, >= 0 (paper
    /// silent; absent: 0.001, a stirrer's clearance; keep it above one particle
    /// diameter so that no single particle can be trapped between the moving
    /// edge and the wall). Only with `brush_rpm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brush_gap_m: Option<f64>,
    /// Width of each blade, m, measured from its outer edge inwards across the
    /// wall's slope, > 0, with gap + width < the funnel top radius (paper silent;
    /// absent: the width at which a blade reaches the axis at the outlet, outlet
    /// radius / cos of the cone half-angle, less the gap, and at least one gap).
    /// Only with `brush_rpm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brush_width_m: Option<f64>,
    /// Wall material of the brush blades (absent: `funnel_material`). A blade
    /// is kinematic: with the funnel's friction it can wedge a non-spherical
    /// grain against the wall and crush it (measured with paired spheres and
    /// he2019's wall friction 1.5: overlap bound reached within 0.07 s of
    /// brushing at 2 of 4 packing seeds, none with a frictionless blade), so
    /// a study can give the blades their own material — a stand-in for
    /// bristles that bend instead of gripping. Only with `brush_rpm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brush_material: Option<String>,
    /// Solid volume fraction the factory fills the funnel to, below the random close
    /// packing limit 0.64 (he2019's "filling rate 0.56").
    pub fill_fraction: f64,
    /// Height above the outlet up to which the funnel is filled, m, in
    /// (0, funnel_height_m]; absent: the whole cone (he2019). A lower fill is a
    /// smaller charge: fewer particles, for the cheaper profiles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fill_height_m: Option<f64>,
    /// Factory generation time, s (he2019: 0.01).
    pub fill_time_s: f64,
    /// Standing time after filling, before the brush starts, s (he2019: 3).
    pub standing_time_s: f64,
    /// Total simulated time, s (he2019: 20): fill, stand, discharge (the brush
    /// turning) and settle; the discharge lasts what the other phases leave.
    pub total_time_s: f64,
    /// Final settling time inside the total, s (he2019: 2); the brush stands still
    /// during it, and it ends early once the pile is at rest.
    pub settle_time_s: f64,
    /// Interval between angle samples, log frames and the removal of particles
    /// that fell off the platform, s, > 0 (absent: 0.02).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_interval_s: Option<f64>,
    /// Funnel (and, without `brush_material`, brush) wall material name.
    pub funnel_material: String,
    /// Platform wall material name.
    pub platform_material: String,
}

impl FunnelPileScene {
    /// Blades when `brush_blades` is absent.
    pub const DEFAULT_BRUSH_BLADES: u32 = 2;
    /// Blade-to-wall gap when `brush_gap_m` is absent, m.
    pub const DEFAULT_BRUSH_GAP_M: f64 = 0.001;
    /// Sample interval when `sample_interval_s` is absent, s.
    pub const DEFAULT_SAMPLE_INTERVAL_S: f64 = 0.02;

    /// Half-angle of the cone (between the wall and the axis), radians.
    pub fn cone_half_angle_rad(&self) -> f64 {
        (0.5 * (self.funnel_top_diameter_m - self.funnel_outlet_diameter_m) / self.funnel_height_m)
            .atan()
    }

    /// Length of the outlet tube, m (`outlet_tube_length_m`, or one outlet diameter).
    pub fn outlet_tube_length(&self) -> f64 {
        self.outlet_tube_length_m
            .unwrap_or(self.funnel_outlet_diameter_m)
    }

    /// How far the tube's lowest point lies below the cone's lower rim, m: the
    /// tube's length along its tilted axis plus its radius times the sine of the tilt.
    pub fn outlet_tube_drop(&self) -> f64 {
        let tilt = self.outlet_tilt_deg.to_radians();
        self.outlet_tube_length() * tilt.cos() + 0.5 * self.funnel_outlet_diameter_m * tilt.sin()
    }

    /// Number of brush blades (0 without a brush).
    pub fn brush_blade_count(&self) -> u32 {
        match self.brush_rpm {
            Some(_) => self.brush_blades.unwrap_or(Self::DEFAULT_BRUSH_BLADES),
            None => 0,
        }
    }

    /// Gap between blade and wall, m (`brush_gap_m`, or [`Self::DEFAULT_BRUSH_GAP_M`]).
    pub fn brush_gap(&self) -> f64 {
        self.brush_gap_m.unwrap_or(Self::DEFAULT_BRUSH_GAP_M)
    }

    /// Blade width, m (`brush_width_m`, or what reaches the axis at the outlet:
    /// outlet radius / cos of the half-angle less the gap, at least one gap).
    pub fn brush_width(&self) -> f64 {
        self.brush_width_m.unwrap_or_else(|| {
            let gap = self.brush_gap();
            (0.5 * self.funnel_outlet_diameter_m / self.cone_half_angle_rad().cos() - gap).max(gap)
        })
    }

    /// Height of the charge above the outlet, m (`fill_height_m`, or the whole cone).
    pub fn fill_height(&self) -> f64 {
        self.fill_height_m.unwrap_or(self.funnel_height_m)
    }

    /// Interval between samples, s.
    pub fn sample_interval(&self) -> f64 {
        self.sample_interval_s
            .unwrap_or(Self::DEFAULT_SAMPLE_INTERVAL_S)
    }

    /// How long the brush turns: the total time less fill, standing and settling, s.
    pub fn discharge_time(&self) -> f64 {
        self.total_time_s - self.fill_time_s - self.standing_time_s - self.settle_time_s
    }
}

/// he2019 §3.6.1: a box holds the powder; one side (the baffle) is lifted at a
/// constant speed and the remaining slope's angle is the static angle of repose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaffleLiftScene {
    /// Box length along the flow direction, m (he2019: 0.060).
    pub box_length_m: f64,
    /// Box width, m (he2019: 0.060).
    pub box_width_m: f64,
    /// Box height, m (he2019: 0.080).
    pub box_height_m: f64,
    /// Powder mass, kg; its bulk volume at random close packing must fit the box.
    pub powder_mass_kg: f64,
    /// Baffle lift speed, m/s (he2019: 0.1).
    pub lift_speed_m_s: f64,
    /// Settling time after the baffle is clear, s (it ends earlier once the
    /// powder is at rest).
    pub settle_time_s: f64,
    /// Box and baffle wall material name (he2019: Plexiglas).
    pub box_material: String,
    /// Floor wall material name.
    pub floor_material: String,
    /// Thickness of a slice across the box width simulated instead of the whole
    /// box, periodic along the width (y), m, in (0, box_width_m]; absent: the
    /// whole box with its two side walls. A slice has no side walls, so it
    /// leaves out their friction (which steepens a real slope near them) and
    /// its run-out heap is a ridge rather than a fan; it costs box_width_m /
    /// slice times fewer particles. The powder mass placed is
    /// `powder_mass_kg` · slice / box_width_m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periodic_slice_m: Option<f64>,
    /// How far the floor reaches past the opening and past each side wall, m, must
    /// be > 0 (he2019 is silent: the box stands on a bench); powder that runs off
    /// its edge is removed. Absent: `box_height_m`, which holds the run-out heap
    /// of a full box at angles down to ~25° (see `scenes::baffle`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub floor_overhang_m: Option<f64>,
    /// Longest time the placed powder may take to come to rest before the baffle
    /// is lifted, s, > 0 (it lifts earlier once the mean kinetic energy per
    /// particle stays below the rest threshold). Absent: 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_max_s: Option<f64>,
    /// Interval between samples (angle, traces, log frames, removal of powder
    /// that left the floor), s, in (0, 0.05]. Absent: 0.02.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_interval_s: Option<f64>,
}

impl BaffleLiftScene {
    /// Default of [`Self::settle_max_s`], s.
    pub const DEFAULT_SETTLE_MAX_S: f64 = 1.0;
    /// Default of [`Self::sample_interval_s`], s.
    pub const DEFAULT_SAMPLE_INTERVAL_S: f64 = 0.02;
    /// Largest [`Self::sample_interval_s`], s: powder leaving the floor must be
    /// removed before it falls out of the simulated domain (see `scenes::baffle`).
    pub const MAX_SAMPLE_INTERVAL_S: f64 = 0.05;

    /// The floor's reach past the opening and the side walls, m.
    pub fn floor_overhang(&self) -> f64 {
        self.floor_overhang_m.unwrap_or(self.box_height_m)
    }

    /// Longest pre-lift settling time, s.
    pub fn settle_max(&self) -> f64 {
        self.settle_max_s.unwrap_or(Self::DEFAULT_SETTLE_MAX_S)
    }

    /// Sampling interval, s.
    pub fn sample_interval(&self) -> f64 {
        self.sample_interval_s
            .unwrap_or(Self::DEFAULT_SAMPLE_INTERVAL_S)
    }
}

/// Rotating drum: fill, rotate at constant speed, stop and stand (he2019 §3.6.2:
/// ID 45 mm, length 100 mm, 30 % fill, 60 rpm for 5 s, stand 2 s; cai2024: 100 × 100 mm,
/// 25 %, 50 rpm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrumScene {
    /// Inner diameter, m.
    pub inner_diameter_m: f64,
    /// Inner length along the axis, m.
    pub length_m: f64,
    /// Fraction of the drum volume occupied by the bed (bulk, not solid), in (0, 1).
    pub fill_fraction: f64,
    /// Rotation speed, revolutions per minute, > 0.
    pub rpm: f64,
    /// Rotation duration, s.
    pub rotation_time_s: f64,
    /// Standing time after the drum stops, s, ≥ 0.
    pub standing_time_s: f64,
    /// Thickness of an axially periodic slice simulated instead of the whole
    /// drum, m, in (0, length_m]; absent: the full drum with its two end caps
    /// (turning with it or at rest, see `end_walls`). A slice has no end walls,
    /// so it leaves out their friction, which in a real drum steepens the
    /// surface near the caps; it costs length / slice times fewer particles.
    /// `repose tradeoff` measures the angle difference.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periodic_slice_m: Option<f64>,
    /// Whether the full drum's two end caps turn with the cylinder
    /// (`"rotating"`, the default) or stand still while it turns (`"fixed"`,
    /// e.g. glass end plates), as drum testers differ. Either way the caps
    /// are of `wall_material` with its contact parameters; only their
    /// velocity differs. `"fixed"` needs the full drum: a `periodic_slice_m`
    /// has no end walls. The default is left out of the canonical form, so
    /// manifests without the field keep their ids.
    #[serde(default, skip_serializing_if = "EndWalls::is_rotating")]
    pub end_walls: EndWalls,
    /// Longest time the poured bed may take to come to rest before the drum
    /// starts, s, > 0 (it starts earlier once the mean kinetic energy per
    /// particle stays below the experiment's `at_rest` threshold, by default
    /// 1e-6 of m g d for 0.05 s); default 1.
    #[serde(default = "default_drum_settle_max_s")]
    pub settle_max_s: f64,
    /// Interval between angle samples and log frames, s, > 0; default 0.02.
    #[serde(default = "default_drum_sample_interval_s")]
    pub sample_interval_s: f64,
    /// Drum wall material name.
    pub wall_material: String,
}

/// How the end caps of a full drum move while the cylinder turns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndWalls {
    /// The caps turn with the cylinder, at its rpm about its axis (a drum
    /// closed by plates fixed to it).
    #[default]
    Rotating,
    /// The caps stand still (zero wall velocity) while the cylinder turns (a
    /// drum turning between stationary end plates).
    Fixed,
}

impl EndWalls {
    /// True for the default, [`EndWalls::Rotating`] (then the field is left
    /// out of the canonical JSON, keeping the ids of manifests that omit it).
    pub fn is_rotating(&self) -> bool {
        *self == EndWalls::Rotating
    }

    /// The value as written in manifests (`"rotating"` or `"fixed"`).
    pub fn as_str(&self) -> &'static str {
        match self {
            EndWalls::Rotating => "rotating",
            EndWalls::Fixed => "fixed",
        }
    }
}

/// yan2015: flat-bottomed cylindrical hopper with a central orifice above a plate.
/// Particles are poured in, the lid opens, and the run stops when no particle has
/// left for `no_discharge_stop_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HopperScene {
    /// Hopper inner diameter, m (yan2015: 0.050).
    pub diameter_m: f64,
    /// Hopper height, m (yan2015: 0.070).
    pub height_m: f64,
    /// Central orifice diameter, m (yan2015: 0.015).
    pub orifice_diameter_m: f64,
    /// Height of the orifice above the plate, m (yan2015: 0.070).
    pub drop_height_m: f64,
    /// Plate diameter, m (paper silent; the examples choose 0.200).
    pub plate_diameter_m: f64,
    /// Solid volume fraction of the poured bed, below 0.64 (yan2015: 0.567).
    pub packing_fraction: f64,
    /// Stop once no particle has left the hopper for this long, s.
    pub no_discharge_stop_s: f64,
    /// Longest discharge, s: simulated time from the opening of the lid to the
    /// end of the run when particles keep leaving.
    pub max_time_s: f64,
    /// Hopper wall material name.
    pub hopper_material: String,
    /// Plate wall material name.
    pub plate_material: String,
    /// Height of the poured bed, m, in (0, height_m]; absent: the bed fills the
    /// hopper to `height_m`. The particle count is `packing_fraction` × the bed
    /// volume / the mean particle volume (yan2015: ~14 700 spheres R = 1 mm at
    /// 56.7 % in D = 50 mm make a 55 mm bed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fill_height_m: Option<f64>,
    /// Longest time the poured bed may take to come to rest before the lid
    /// opens, s, > 0 (it opens earlier once the bed is at rest by the
    /// experiment's `at_rest` criterion); absent: 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_max_s: Option<f64>,
    /// Interval between discharge counts (the flow-rate trace), removals of
    /// particles that fell off the plate and angle samples, s, in (0, 0.05];
    /// absent: 0.01.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_interval_s: Option<f64>,
}

/// cai2024 fixed-base funnel (GB/T 16913-2008): particles generated at the funnel top
/// at a rate flow out onto a disk; angle from the profile and from tan(a) = 2H/D.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticPileScene {
    /// Included angle of the funnel cone, degrees, in (0, 180) (cai2024: 60).
    pub cone_angle_deg: f64,
    /// Funnel top diameter, m (paper silent; the examples choose 0.060).
    pub funnel_top_diameter_m: f64,
    /// Funnel outlet diameter, m (cai2024: 0.005).
    pub outlet_diameter_m: f64,
    /// Height of the outlet above the disk, m (cai2024: 0.080).
    pub outlet_height_m: f64,
    /// Disk diameter, m (cai2024: 0.080).
    pub disk_diameter_m: f64,
    /// Number of particles generated, > 0 (cai2024: 20 000).
    pub particle_count: u64,
    /// Generation rate, particles per second, > 0 (cai2024: 5000).
    pub insertion_rate_per_s: f64,
    /// Longest settling time after the last particle is generated, s, ≥ 0 (it
    /// ends earlier once the pile is at rest: the mean kinetic energy per
    /// particle below the experiment's `at_rest` threshold, by default 1e-6 of
    /// m g d for 0.05 s).
    pub settle_time_s: f64,
    /// Window of the rate factory, s, > 0: the particles due in each window
    /// appear together at its end (paper silent; default 0.01, he2019's
    /// generation interval).
    #[serde(
        default = "default_static_pile_insertion_interval_s",
        skip_serializing_if = "is_default_static_pile_insertion_interval_s"
    )]
    pub insertion_interval_s: f64,
    /// Interval between trace samples and log frames, s, ≥ `insertion_interval_s`
    /// (rounded to a whole number of insertion windows); default 0.02.
    #[serde(
        default = "default_static_pile_sample_interval_s",
        skip_serializing_if = "is_default_static_pile_sample_interval_s"
    )]
    pub sample_interval_s: f64,
    /// Funnel wall material name.
    pub funnel_material: String,
    /// Disk wall material name.
    pub disk_material: String,
}

fn default_static_pile_insertion_interval_s() -> f64 {
    0.01
}

fn is_default_static_pile_insertion_interval_s(v: &f64) -> bool {
    *v == default_static_pile_insertion_interval_s()
}

fn default_static_pile_sample_interval_s() -> f64 {
    0.02
}

fn is_default_static_pile_sample_interval_s(v: &f64) -> bool {
    *v == default_static_pile_sample_interval_s()
}

fn default_drum_settle_max_s() -> f64 {
    1.0
}

fn default_drum_sample_interval_s() -> f64 {
    0.02
}
