//! The charge: he2019's particle factory fills the funnel to a solid fraction
//! over a generation time (0.56 in 0.01 s).
//!
//! The charge is the solid volume `fill_fraction` × (volume of the cone up to
//! the fill height). Random sequential addition saturates near a solid
//! fraction of 0.38, so it is laid out as a jittered face-centred lattice
//! ([`place_lattice`]) whose bulk solid fraction is `fill_fraction`
//! (nearest-site distance (0.7405 / fill_fraction)^(1/3) largest diameters).
//! Next to the walls a lattice loses sites, the more so the coarser the
//! particles against the outlet, so the layout rises above the fill height, one
//! mean diameter at a time, until it holds the charge; at the funnel's top
//! (he2019 fills the whole funnel) the lattice is made denser instead, down to
//! a spacing of 1.01 (the interior then exceeds `fill_fraction` to make up
//! for the walls); beyond that the charge does not fit and the run stops with
//! the packing error. Sites that touch
//! a wall (the brush blades cross the region) are dropped and counted. The
//! factory then releases the layout bottom-up, one layer of one mean diameter
//! at a time, evenly over the generation time; a site that an earlier particle
//! has meanwhile moved into is skipped and counted, never inserted
//! overlapping.

use crate::dem::particles::ParticleInit;
use crate::dem::vec3::Vec3;
use crate::dem::walls::Wall;
use crate::packing::distribution::SizeDistribution;
use crate::packing::grid::Grid;
use crate::packing::place::{place_lattice, FillTarget, PlacementSpec};
use crate::packing::region::Region;
use crate::packing::PackingError;

/// Solid fraction of a face-centred cubic packing of touching equal spheres,
/// π / (3√2).
const FCC_FRACTION: f64 = std::f64::consts::PI / (3.0 * std::f64::consts::SQRT_2);
/// Densest lattice tried when the charge does not fit the whole funnel at the
/// bulk fraction (nearest-site distance over the largest diameter).
const MIN_SPACING: f64 = 1.01;
/// Step by which the spacing shrinks towards [`MIN_SPACING`].
const SPACING_STEP: f64 = 0.01;
/// Gap kept between the charge and the region's surfaces, in mean diameters.
const CLEARANCE_DIAMETERS: f64 = 0.05;

/// The charge laid out in layers, released one layer at a time.
#[derive(Clone, Debug, PartialEq)]
pub struct Charge {
    /// Layers from the bottom up.
    pub layers: Vec<Vec<ParticleInit>>,
    /// Height above the outlet the layout reaches, m.
    pub height_m: f64,
    /// Lattice spacing used (nearest-site distance over the largest diameter).
    pub spacing: f64,
    /// Sites dropped because they touched a wall at t = 0.
    pub dropped_at_walls: usize,
}

/// Lays out the charge (see the module docs): `region_up_to(h)` is the
/// charge region up to height h above the outlet; the charge is
/// `fill_fraction` of its volume at `fill_height_m`, and the layout may rise
/// to `max_height_m`.
#[allow(clippy::too_many_arguments)]
pub fn lay_out(
    region_up_to: impl Fn(f64) -> Region,
    fill_height_m: f64,
    max_height_m: f64,
    sizes: &SizeDistribution,
    fill_fraction: f64,
    seed: u64,
    d_mean_m: f64,
    walls: &[Wall],
) -> Result<Charge, PackingError> {
    let solid_m3 = fill_fraction * region_up_to(fill_height_m).volume();
    let bulk_spacing = (FCC_FRACTION / fill_fraction).cbrt();
    let (mut height, mut spacing) = (fill_height_m, bulk_spacing);
    let placed = loop {
        let region = region_up_to(height);
        let spec = PlacementSpec {
            region,
            sizes: sizes.clone(),
            target: FillTarget::FillFraction(solid_m3 / region.volume()),
            seed,
            clearance_m: CLEARANCE_DIAMETERS * d_mean_m,
            velocity_m_s: Vec3::zeros(),
        };
        match place_lattice(&spec, spacing) {
            Err(PackingError::RegionFull { .. }) if height < max_height_m => {
                height = (height + d_mean_m).min(max_height_m);
            }
            Err(PackingError::RegionFull { .. }) if spacing > MIN_SPACING => {
                spacing = (spacing - SPACING_STEP).max(MIN_SPACING);
            }
            other => break other?,
        }
    };
    let mut particles = placed.particles;
    let before = particles.len();
    particles.retain(|p| {
        !walls
            .iter()
            .any(|w| w.contact_at(0.0, p.position, p.radius_m, 0.0).is_some())
    });
    let dropped_at_walls = before - particles.len();
    particles.sort_by(|a, b| a.position.z.total_cmp(&b.position.z));
    let z0 = particles.first().map_or(0.0, |p| p.position.z);
    let mut layers: Vec<Vec<ParticleInit>> = Vec::new();
    for p in particles {
        let k = ((p.position.z - z0) / d_mean_m).floor() as usize;
        if layers.len() <= k {
            layers.resize(k + 1, Vec::new());
        }
        layers[k].push(p);
    }
    layers.retain(|l| !l.is_empty());
    Ok(Charge {
        layers,
        height_m: height,
        spacing,
        dropped_at_walls,
    })
}

/// The particles of `layer` that overlap none of the current particles
/// (`positions`, `radii`, m); only particles that can reach the layer are
/// hashed.
pub fn free_sites(layer: &[ParticleInit], positions: &[Vec3], radii: &[f64]) -> Vec<ParticleInit> {
    let z_lo = layer
        .iter()
        .map(|p| p.position.z - p.radius_m)
        .fold(f64::INFINITY, f64::min);
    let r_max = radii
        .iter()
        .chain(layer.iter().map(|p| &p.radius_m))
        .copied()
        .fold(0.0, f64::max);
    let mut grid = Grid::new(2.0 * r_max);
    for (x, &r) in positions.iter().zip(radii) {
        if x.z + r_max >= z_lo {
            grid.insert(*x, r);
        }
    }
    layer
        .iter()
        .filter(|p| !grid.overlaps(&p.position, p.radius_m))
        .copied()
        .collect()
}
