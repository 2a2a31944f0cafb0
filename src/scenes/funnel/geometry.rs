//! The funnel flow meter's geometry: walls, the simulation box, the charge
//! region, and the zones the protocol and the measurement use.
//!
//! Frame: the platform's top face is the plane z = 0, centred on the z axis,
//! which is also the funnel's axis; the outlet tube leans towards +x.

use crate::dem::domain::{Domain, DomainError};
use crate::dem::vec3::Vec3;
use crate::dem::walls::{rpm_to_rad_s, Motion, Wall, WallError};
use crate::manifest::scene::FunnelPileScene;
use crate::packing::region::Region;

/// Gravitational acceleration, m/s² (−z): the one every lab scene uses.
pub const G_M_S2: f64 = crate::scenes::physics::STANDARD_GRAVITY_M_S2;
/// Particles whose centre sinks this many mean diameters below the platform's
/// top face have fallen off it and are removed.
pub const REMOVAL_DEPTH_DIAMETERS: f64 = 2.0;
/// Clearance between the keep zone and the walls or the simulation box, in
/// mean diameters.
const MARGIN_DIAMETERS: f64 = 2.0;

/// Wall-material index of the funnel and its tube.
pub const FUNNEL_MATERIAL: usize = 0;
/// Wall-material index of the platform.
pub const PLATFORM_MATERIAL: usize = 1;
/// Wall-material index of the brush blades (`brush_material`, by default the
/// funnel's material again).
pub const BRUSH_MATERIAL: usize = 2;

/// Everything the scene derives from the manifest's dimensions, m.
#[derive(Clone, Debug, PartialEq)]
pub struct FunnelGeometry {
    /// Radius of the outlet (cone bottom and tube), m.
    pub outlet_radius_m: f64,
    /// Radius of the funnel's top rim, m.
    pub top_radius_m: f64,
    /// Height of the cone's lower rim above the platform, m.
    pub rim_z_m: f64,
    /// Height of the funnel's top rim above the platform, m.
    pub top_z_m: f64,
    /// Cone half-angle (wall to axis), rad.
    pub half_angle_rad: f64,
    /// Unit direction of the outlet tube's axis, from the cone rim downwards.
    pub tube_axis: Vec3,
    /// Tube length along its axis, m.
    pub tube_length_m: f64,
    /// Height of the tube's lowest point above the platform, m: a particle whose
    /// centre is below it has left the funnel.
    pub exit_z_m: f64,
    /// Platform radius, m.
    pub platform_radius_m: f64,
    /// Mean particle diameter, m.
    pub d_mean_m: f64,
    /// Free fall from the funnel top to the removal depth plus the brush tip
    /// speed, m/s: the speed of a particle that falls or is carried by the
    /// brush, the log's colour scale. A particle squeezed out of a contact can
    /// be faster ([`FunnelGeometry::domain`] adds that).
    pub speed_bound_m_s: f64,
    /// Particles whose centre is below this height are removed, m.
    pub removal_z_m: f64,
    /// Particles farther than this from the axis along x or y are removed, m.
    pub keep_half_width_m: f64,
    /// Interval at which particles are removed, s.
    pub sample_interval_s: f64,
}

impl FunnelGeometry {
    /// The geometry of a (validated) scene for particles of mean diameter
    /// `d_mean_m`.
    pub fn new(scene: &FunnelPileScene, d_mean_m: f64) -> FunnelGeometry {
        let tilt = scene.outlet_tilt_deg.to_radians();
        let outlet_radius_m = 0.5 * scene.funnel_outlet_diameter_m;
        let top_radius_m = 0.5 * scene.funnel_top_diameter_m;
        let rim_z_m = scene.outlet_height_m;
        let top_z_m = rim_z_m + scene.funnel_height_m;
        let platform_radius_m = 0.5 * scene.platform_diameter_m;
        let removal_z_m = -REMOVAL_DEPTH_DIAMETERS * d_mean_m;
        let tip_speed = scene.brush_rpm.map_or(0.0, |rpm| rpm_to_rad_s(rpm).abs()) * top_radius_m;
        let speed_bound_m_s = (2.0 * G_M_S2 * (top_z_m - removal_z_m)).sqrt() + tip_speed;
        let tube_axis = Vec3::new(tilt.sin(), 0.0, -tilt.cos());
        let tube_length_m = scene.outlet_tube_length();
        let tube_end_x = tube_length_m * tilt.sin() + outlet_radius_m;
        let keep_half_width_m =
            top_radius_m.max(platform_radius_m).max(tube_end_x) + MARGIN_DIAMETERS * d_mean_m;
        FunnelGeometry {
            outlet_radius_m,
            top_radius_m,
            rim_z_m,
            top_z_m,
            half_angle_rad: scene.cone_half_angle_rad(),
            tube_axis,
            tube_length_m,
            exit_z_m: rim_z_m - scene.outlet_tube_drop(),
            platform_radius_m,
            d_mean_m,
            speed_bound_m_s,
            removal_z_m,
            keep_half_width_m,
            sample_interval_s: scene.sample_interval(),
        }
    }

    /// The simulation box: the keep zone widened on every side by how far a
    /// particle at the throw speed bound travels in one sample interval (so a
    /// particle leaving the keep zone is removed before it leaves the box), and
    /// reaching up to where such a particle thrown upwards from the funnel's top
    /// rim turns back, plus that interval's travel. The throw speed bound is
    /// [`FunnelGeometry::speed_bound_m_s`] plus `spring_out_m_s`, the fastest a
    /// particle leaves a squeezed contact ([`spring_out_speed_m_s`]).
    ///
    /// The box only bounds where particles may be (the neighbour grid covers
    /// the particles, not the box), so its size changes no trajectory; above
    /// the funnel nothing removes a thrown particle: it falls back into the
    /// funnel or past the keep zone's side.
    pub fn domain(&self, spring_out_m_s: f64) -> Result<Domain, DomainError> {
        let v = self.speed_bound_m_s + spring_out_m_s;
        let dt = self.sample_interval_s;
        let m = v * dt + 0.5 * G_M_S2 * dt * dt + MARGIN_DIAMETERS * self.d_mean_m;
        let half = self.keep_half_width_m + m;
        let rise = v * v / (2.0 * G_M_S2);
        Domain::new(
            Vec3::new(-half, -half, self.removal_z_m - m),
            Vec3::new(half, half, self.top_z_m + rise + m),
            [false; 3],
        )
    }

    /// True while a particle at `p` is inside the keep zone (above the removal
    /// depth and within the keep half-width along x and y).
    pub fn keeps(&self, p: &Vec3) -> bool {
        p.z >= self.removal_z_m
            && p.x.abs() <= self.keep_half_width_m
            && p.y.abs() <= self.keep_half_width_m
    }

    /// True when a particle centre at `p` lies on the platform: between the
    /// platform's face and the tube's exit, within the platform's radius.
    pub fn on_platform(&self, p: &Vec3) -> bool {
        p.z >= 0.0 && p.z < self.exit_z_m && p.x.hypot(p.y) <= self.platform_radius_m
    }

    /// The charge region: the inside of the cone from the outlet up to
    /// `fill_height_m` above it.
    pub fn charge_region(&self, fill_height_m: f64) -> Region {
        Region::Frustum {
            axis_xy_m: [0.0, 0.0],
            z_bottom_m: self.rim_z_m,
            radius_bottom_m: self.outlet_radius_m,
            z_top_m: self.rim_z_m + fill_height_m,
            radius_top_m: self.outlet_radius_m + fill_height_m * self.half_angle_rad.tan(),
        }
    }
}

/// The fastest a particle can leave a squeezed contact, m/s: the speed its
/// mass reaches when the elastic (Hertz) energy of one contact at the
/// `overlap_ratio` bound of the health check turns into its kinetic energy.
///
/// `e_star_pa` is the contact's effective Young's modulus, `r_star_ratio` its
/// effective radius over the particle's radius (1 against a wall, ½ against
/// an equal particle), `density_kg_m3` the particle's density. With
/// U = 8/15 E* √R* δ^{5/2}, R* = c r, δ = λ r and m = ρ 4π/3 r³ the radius
/// cancels: v = √(4 E* √c λ^{5/2} / (5π ρ)).
///
/// Why the funnel needs it: the brush's edge is kinematic, so a particle
/// wedged between it and a particle lying on the cone is pressed into both
/// until it squirts out, faster than the brush moves (measured on
/// he2019-quick sample 42: 2.2 m/s with the blade at 0.25 m/s there). It
/// bounds the energy of one contact at the limit, not every throw: a particle
/// pressed by several contacts at once could leave faster, and would then
/// still stop the run with `left the domain`.
pub fn spring_out_speed_m_s(
    e_star_pa: f64,
    r_star_ratio: f64,
    overlap_ratio: f64,
    density_kg_m3: f64,
) -> f64 {
    (4.0 * e_star_pa * r_star_ratio.sqrt() * overlap_ratio.powf(2.5)
        / (5.0 * std::f64::consts::PI * density_kg_m3))
        .sqrt()
}

/// The walls in order: the cone (0), the outlet tube (1), the platform (2), then
/// the brush blades (none without a brush), each blade turning about the z axis
/// at `brush_rpm` from `brush_start_s` to `brush_end_s`.
pub fn walls(
    scene: &FunnelPileScene,
    geom: &FunnelGeometry,
    brush_start_s: f64,
    brush_end_s: f64,
) -> Result<Vec<Wall>, WallError> {
    let rim = Vec3::new(0.0, 0.0, geom.rim_z_m);
    let mut walls = vec![
        Wall::cone_frustum(
            rim,
            Vec3::z(),
            geom.outlet_radius_m,
            geom.top_radius_m,
            scene.funnel_height_m,
            FUNNEL_MATERIAL,
        )?,
        Wall::cylinder(
            rim,
            geom.tube_axis,
            geom.outlet_radius_m,
            geom.tube_length_m,
            FUNNEL_MATERIAL,
        )?,
        Wall::disk(
            Vec3::zeros(),
            Vec3::z(),
            geom.platform_radius_m,
            PLATFORM_MATERIAL,
        )?,
    ];
    if let Some(rpm) = scene.brush_rpm {
        let spin = Motion::Rotate {
            axis_point: Vec3::zeros(),
            axis_dir: Vec3::z(),
            rpm,
            start_s: brush_start_s,
            end_s: brush_end_s,
        };
        let n = scene.brush_blade_count();
        for k in 0..n {
            let azimuth = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
            walls.push(blade(scene, geom, azimuth)?.with_motion(spin)?);
        }
    }
    Ok(walls)
}

/// One brush blade at `azimuth_rad` (from +x): a rectangle in the meridian
/// plane, its outer long edge parallel to the cone wall at `brush_gap()` from
/// it, reaching `brush_width()` further inwards perpendicular to the wall's
/// slope. Along the slope it runs from the top rim's height down into the
/// throat until its inner lower corner is level with the outlet rim, so it
/// sweeps the region where a cohesive powder arches over the outlet (a
/// stirrer reaches down to the nozzle).
fn blade(
    scene: &FunnelPileScene,
    geom: &FunnelGeometry,
    azimuth_rad: f64,
) -> Result<Wall, WallError> {
    let (s, c) = azimuth_rad.sin_cos();
    let radial = Vec3::new(c, s, 0.0);
    let tangential = Vec3::new(-s, c, 0.0);
    let (sb, cb) = geom.half_angle_rad.sin_cos();
    // Up the wall's slope, and inwards perpendicular to it in the meridian plane.
    let up_slope = radial * sb + Vec3::z() * cb;
    let inwards = Vec3::z() * sb - radial * cb;
    let (gap, width) = (scene.brush_gap(), scene.brush_width());
    // Slant coordinates along the wall from the outlet rim: the top rim is at
    // H / cos β; the inner lower corner is level with the rim at −(g + w) tan β.
    let (s0, s1) = (-(gap + width) * sb / cb, scene.funnel_height_m / cb);
    let rim = Vec3::new(0.0, 0.0, geom.rim_z_m) + radial * geom.outlet_radius_m;
    let centre = rim + up_slope * (0.5 * (s0 + s1)) + inwards * (gap + 0.5 * width);
    Wall::rectangle(
        centre,
        tangential,
        up_slope,
        0.5 * (s1 - s0),
        0.5 * width,
        BRUSH_MATERIAL,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::parse_experiment;
    use crate::manifest::scene::Scene;

    /// he2019-quick's funnel (`experiments/funnel_pile/quick.json`), 6 mm spheres.
    fn quick() -> FunnelGeometry {
        let text = include_str!("../../../experiments/funnel_pile/quick.json");
        let exp = parse_experiment(text).unwrap();
        let Scene::FunnelPile(scene) = &exp.scene else {
            unreachable!()
        };
        FunnelGeometry::new(scene, 0.006)
    }

    #[test]
    fn spring_out_speed_turns_the_contact_energy_into_kinetic_energy() {
        // E* of the PU sphere (0.35 MPa, ν 0.4) on steel (1 GPa, ν 0.3), r = 3 mm.
        let e_star = 1.0 / ((1.0 - 0.16) / 0.35e6 + (1.0 - 0.09) / 1.0e9);
        let (r, rho, lambda): (f64, f64, f64) = (0.003, 60.0, 0.3);
        let energy = 8.0 / 15.0 * e_star * r.sqrt() * (lambda * r).powf(2.5);
        let mass = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        let v = spring_out_speed_m_s(e_star, 1.0, lambda, rho);
        assert!((0.5 * mass * v * v / energy - 1.0).abs() < 1e-12);
        // Against an equal particle, R* = r / 2: a factor 2^{-1/4} in speed.
        let pair = spring_out_speed_m_s(e_star, 0.5, lambda, rho);
        assert!((pair / v - 0.5f64.powf(0.25)).abs() < 1e-12);
    }

    #[test]
    fn the_box_holds_a_throw_at_the_bound_from_the_rim() {
        let g = quick();
        let spring = 9.3;
        let b = g.domain(spring).unwrap();
        let v = g.speed_bound_m_s + spring;
        // Straight up from the top rim: the apex is inside.
        let apex = g.top_z_m + v * v / (2.0 * G_M_S2);
        assert!(b.contains(Vec3::new(0.0, 0.0, apex)));
        // Sideways: one sample interval's flight beyond the keep zone is inside.
        let edge = g.keep_half_width_m + v * g.sample_interval_s;
        assert!(b.contains(Vec3::new(edge, edge, 0.5 * g.top_z_m)));
        // Where he2019-quick sample 42's thrown particle left the old box.
        assert!(b.contains(Vec3::new(0.060372, 0.011534, 0.216045)));
        // Without a squeeze the box ends where free fall and the brush reach.
        let old = g.domain(0.0).unwrap();
        assert!(!old.contains(Vec3::new(0.0, 0.0, apex)));
    }
}
