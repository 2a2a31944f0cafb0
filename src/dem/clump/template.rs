//! Clump templates: validated lists of member spheres, and the mass properties
//! of their union.
//!
//! A [`ClumpTemplate`] is a shape as given — any frame, any scale. It is
//! refused unless it is a sensible rigid body: 1 to [`MAX_MEMBERS`] members,
//! finite offsets, finite positive radii, a connected union (two members are
//! linked when their spheres overlap, centre distance < r_a + r_b; a body in
//! pieces is not one particle) and no member entirely inside another (it would
//! add nothing to the shape, only contact cost).
//!
//! # Mass properties of the union
//!
//! Members overlap, so summing sphere properties would count the overlaps twice
//! (for he2019's paired spheres at aspect ratio 1.3 by 39 % in volume). The
//! union's volume, centre of mass and inertia tensor per unit density are
//! computed instead:
//!
//! - **One or two members: exact closed form.** Two overlapping spheres (radii
//!   R₁, R₂, centre distance d) split at the radical plane, the plane of their
//!   intersection circle at h = (R₁² − R₂² + d²)/(2d) from centre 1 along the
//!   line of centres: on centre 1's side of it sphere 2's cross-section lies
//!   inside sphere 1's (r₁² − r₂² = 2d(h − z) > 0), and vice versa. The union
//!   is therefore sphere 1 cut at h plus sphere 2 cut at d − h. Each part is a
//!   truncated ball {|x| ≤ R, z ≤ c} whose volume and moments ∫z, ∫z², ∫(x²+y²)
//!   are polynomials in c (integrating disc slices of area π(R² − z²)); the two
//!   parts combine by the parallel-axis theorem. The cut is clamped to [−R, R],
//!   so a disjoint pair gives two whole spheres and a contained one nothing.
//! - **Three or more members: converged numerical integration.** Rays parallel
//!   to x on a midpoint grid of (y, z) cells over the union's bounding box: on
//!   each ray the members' chords are merged into disjoint intervals, whose ∫1,
//!   ∫x, ∫x² are exact. The grid is doubled from 32 × 32 cells until the
//!   volume, the centre (relative to the cube root of the volume) and every
//!   inertia component (relative to the largest) change by less than
//!   [`NUMERICAL_TOLERANCE`] at two successive doublings, at most up to
//!   [`MAX_RESOLUTION`] cells a side; the finest estimate is used. The chord
//!   length has a square-root edge at every silhouette, so the midpoint error
//!   falls only as about h^1.5 and oscillates in sign: one small change can be
//!   a coincidence (measured: a change of 6.9e-7 with an error of 4.5e-6),
//!   hence two. The error is therefore a few times the tolerance, not below
//!   it: measured against the exact two-sphere result (test
//!   `numerical_path_matches_exact_two_sphere_result`, he2019 pairs at aspect
//!   ratios 1.05 to 1.9 and an unequal pair on a skew axis) it is at most
//!   2.2e-6 relative, and [`NUMERICAL_ACCURACY`] (1e-5) is the bound the
//!   tests hold it to. Deterministic: no randomness, fixed summation order.
//!
//! # Principal frame
//!
//! [`ClumpTemplate::shape`] scales the template to a volume-equivalent size,
//! moves it to its centre of mass and rotates it into the principal frame of
//! the inertia tensor: moments ascending on body x, y, z, axes forming a proper
//! rotation R (det +1), member offsets Rᵀ(offset − centre). When the tensor is
//! already diagonal up to roundoff the template's own axes are kept (sorted by
//! ascending moment, ties in x, y, z order), so an axisymmetric template along
//! x — [`ClumpTemplate::paired_spheres`] — keeps its frame despite its two equal
//! transverse moments. Otherwise the eigenvectors of
//! [`nalgebra::SymmetricEigen`] are used, each signed so its largest component
//! is positive, the third negated if needed for det +1.

use nalgebra::{Matrix3, SymmetricEigen};

use crate::dem::vec3::Vec3;

/// Most members a clump may have: contact cost grows with the member count,
/// and DEM clumps rarely need more than a few dozen.
pub const MAX_MEMBERS: usize = 64;

/// Convergence threshold of the numerical integration (≥ 3 members): relative
/// change of volume, centre and inertia between two grid resolutions.
pub const NUMERICAL_TOLERANCE: f64 = 1e-6;

/// Finest (y, z) grid of the numerical integration, cells a side: bounds the
/// cost when the tolerance is not met earlier (16.8 million rays; measured on
/// one core, 0.3 s for two members).
pub const MAX_RESOLUTION: usize = 4096;

/// Relative accuracy of the numerical integration, measured against the exact
/// two-sphere result (volume and every inertia component relative to the
/// largest); the module docs say how.
pub const NUMERICAL_ACCURACY: f64 = 1e-5;

/// Grid resolution the numerical integration starts from, cells a side.
const START_RESOLUTION: usize = 32;

/// One sphere of a clump, m.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Member {
    /// Centre of the sphere in the clump's frame, m (serialised as `[x, y, z]`).
    #[serde(with = "vec3_as_array")]
    pub offset: Vec3,
    /// Radius of the sphere, m.
    pub radius_m: f64,
}

/// Serialises a [`Vec3`] as a plain `[x, y, z]` array (nalgebra's own serde
/// support is not enabled in this crate).
mod vec3_as_array {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use crate::dem::vec3::Vec3;

    pub fn serialize<S: Serializer>(v: &Vec3, s: S) -> Result<S::Ok, S::Error> {
        [v.x, v.y, v.z].serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
        let [x, y, z] = <[f64; 3]>::deserialize(d)?;
        Ok(Vec3::new(x, y, z))
    }
}

/// A clump shape as given (any frame, any scale): a named list of member
/// spheres, validated by [`ClumpTemplate::new`].
#[derive(Clone, Debug, PartialEq)]
pub struct ClumpTemplate {
    name: String,
    members: Vec<Member>,
}

/// Why a clump template was refused. Each message names the offending field
/// and value and says what is allowed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ClumpError {
    /// No members.
    #[error("members: none given: a clump needs 1 to {MAX_MEMBERS} member spheres")]
    NoMembers,
    /// More than [`MAX_MEMBERS`] members.
    #[error("members: {count} given: at most {MAX_MEMBERS} member spheres are allowed")]
    TooManyMembers {
        /// Number of members given.
        count: usize,
    },
    /// A member offset with a non-finite component.
    #[error(
        "members[{index}].offset = ({}, {}, {}): every component must be finite",
        offset.x, offset.y, offset.z
    )]
    NonFiniteOffset {
        /// Index of the member.
        index: usize,
        /// The offset given, m.
        offset: Vec3,
    },
    /// A member radius that is not finite and positive.
    #[error("members[{index}].radius_m = {radius_m}: must be finite and positive")]
    BadRadius {
        /// Index of the member.
        index: usize,
        /// The radius given, m.
        radius_m: f64,
    },
    /// The union is in pieces.
    #[error(
        "members[{index}] is not connected to members[0]: the union of the members must be \
         connected (two members connect when their centre distance is below the sum of their radii)"
    )]
    Disconnected {
        /// Lowest index of a member not reachable from member 0.
        index: usize,
    },
    /// A member lies entirely inside another.
    #[error(
        "members[{inner}] (radius_m = {inner_radius_m}) lies entirely inside members[{outer}] \
         (radius_m = {outer_radius_m}, centre distance {distance_m}): it would add nothing to the \
         shape; remove it"
    )]
    MemberInside {
        /// Index of the contained member.
        inner: usize,
        /// Its radius, m.
        inner_radius_m: f64,
        /// Index of the containing member.
        outer: usize,
        /// Its radius, m.
        outer_radius_m: f64,
        /// Distance between their centres, m.
        distance_m: f64,
    },
    /// A paired-spheres aspect ratio outside (1, 2).
    #[error(
        "aspect_ratio = {0}: must be finite and strictly between 1 and 2 \
         (1 would be a sphere, 2 two spheres touching at a point)"
    )]
    AspectRatio(f64),
}

impl ClumpTemplate {
    /// Validates and builds a template: 1..=[`MAX_MEMBERS`] members, finite
    /// offsets, finite positive radii, a connected union (members linked when
    /// their spheres overlap, distance < r_a + r_b) and no member entirely
    /// inside another (the error names both).
    pub fn new(name: impl Into<String>, members: Vec<Member>) -> Result<Self, ClumpError> {
        if members.is_empty() {
            return Err(ClumpError::NoMembers);
        }
        if members.len() > MAX_MEMBERS {
            return Err(ClumpError::TooManyMembers {
                count: members.len(),
            });
        }
        for (index, m) in members.iter().enumerate() {
            if !m.offset.iter().all(|c| c.is_finite()) {
                return Err(ClumpError::NonFiniteOffset {
                    index,
                    offset: m.offset,
                });
            }
            if !(m.radius_m.is_finite() && m.radius_m > 0.0) {
                return Err(ClumpError::BadRadius {
                    index,
                    radius_m: m.radius_m,
                });
            }
        }
        for (i, a) in members.iter().enumerate() {
            for (j, b) in members.iter().enumerate().skip(i + 1) {
                let d = (b.offset - a.offset).norm();
                let inside = |inner: usize, ri: f64, outer: usize, ro: f64| {
                    (d + ri <= ro).then_some(ClumpError::MemberInside {
                        inner,
                        inner_radius_m: ri,
                        outer,
                        outer_radius_m: ro,
                        distance_m: d,
                    })
                };
                if let Some(e) = inside(j, b.radius_m, i, a.radius_m)
                    .or_else(|| inside(i, a.radius_m, j, b.radius_m))
                {
                    return Err(e);
                }
            }
        }
        // Flood fill from member 0 over the overlap graph.
        let mut reached = vec![false; members.len()];
        let mut stack = vec![0];
        reached[0] = true;
        while let Some(i) = stack.pop() {
            for (j, b) in members.iter().enumerate() {
                let a = &members[i];
                if !reached[j] && (b.offset - a.offset).norm() < a.radius_m + b.radius_m {
                    reached[j] = true;
                    stack.push(j);
                }
            }
        }
        if let Some(index) = reached.iter().position(|&r| !r) {
            return Err(ClumpError::Disconnected { index });
        }
        Ok(Self {
            name: name.into(),
            members,
        })
    }

    /// he2019's paired spheres: two equal spheres whose union has
    /// length/width = `aspect_ratio` (1 < aspect_ratio < 2; 1 would be a
    /// sphere, 2 two spheres touching at a point). Unit member radius, centres
    /// at ±(aspect_ratio − 1) on x. Named `paired_spheres_<aspect_ratio>`.
    pub fn paired_spheres(aspect_ratio: f64) -> Result<Self, ClumpError> {
        if !(aspect_ratio > 1.0 && aspect_ratio < 2.0) {
            return Err(ClumpError::AspectRatio(aspect_ratio));
        }
        let half = aspect_ratio - 1.0;
        let member = |x: f64| Member {
            offset: Vec3::new(x, 0.0, 0.0),
            radius_m: 1.0,
        };
        Self::new(
            format!("paired_spheres_{aspect_ratio}"),
            vec![member(-half), member(half)],
        )
    }

    /// The template's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The member spheres as given, m.
    pub fn members(&self) -> &[Member] {
        &self.members
    }

    /// Volume (m³), centre of mass (uniform density, m) and inertia tensor per
    /// unit density about the centre of mass (m⁵; × density in kg/m³ gives
    /// kg·m²) of the union of the members, overlaps counted once. Exact for one
    /// or two members, numerical (see the module docs) for more.
    pub fn mass_properties(&self) -> MassProperties {
        union_mass_properties(&self.members)
    }

    /// The template scaled so the union's volume equals that of a sphere of
    /// radius `equivalent_radius_m` (volume-equivalent sizing: a particle of
    /// "radius R" becomes a clump of the same volume and mass), translated to
    /// its centre of mass and rotated into its principal frame (module docs).
    pub fn shape(&self, equivalent_radius_m: f64) -> ClumpShape {
        let props = self.mass_properties();
        let (rotation, moments) = principal_axes(&props.inertia_m5);
        let volume_m3 = sphere_volume(equivalent_radius_m);
        let scale = (volume_m3 / props.volume_m3).cbrt();
        let members: Vec<Member> = self
            .members
            .iter()
            .map(|m| Member {
                offset: scale * (rotation.transpose() * (m.offset - props.centre)),
                radius_m: scale * m.radius_m,
            })
            .collect();
        let principal_moments_m5 = moments * scale.powi(5);
        let bounding_radius_m = members
            .iter()
            .map(|m| m.offset.norm() + m.radius_m)
            .fold(0.0, f64::max);
        ClumpShape {
            members,
            volume_m3,
            principal_moments_m5,
            bounding_radius_m,
        }
    }
}

/// Volume, centre of mass and inertia tensor per unit density of a union of
/// spheres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    /// Volume, m³.
    pub volume_m3: f64,
    /// Centre of mass at uniform density, m, in the template's frame.
    pub centre: Vec3,
    /// Inertia tensor about the centre of mass per unit density, m⁵
    /// (× density in kg/m³ gives kg·m²), template axes.
    pub inertia_m5: Matrix3<f64>,
}

/// A template in its principal frame at a given size: what the engine
/// integrates.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClumpShape {
    /// Members: offsets from the centre of mass along the principal axes, radii, m.
    pub members: Vec<Member>,
    /// Union volume, m³.
    pub volume_m3: f64,
    /// Principal second moments of volume per unit density (I₁, I₂, I₃ about
    /// body x, y, z), m⁵, ascending (serialised as `[I₁, I₂, I₃]`).
    #[serde(with = "vec3_as_array")]
    pub principal_moments_m5: Vec3,
    /// Smallest radius about the centre of mass containing every member sphere, m
    /// (max |offset| + radius) — the scenes pack clumps by their bounding spheres.
    pub bounding_radius_m: f64,
}

impl ClumpShape {
    /// Mass, kg, at density `density_kg_m3` (kg/m³).
    pub fn mass_kg(&self, density_kg_m3: f64) -> f64 {
        self.volume_m3 * density_kg_m3
    }

    /// Principal moments of inertia about body x, y, z, kg·m², at density
    /// `density_kg_m3` (kg/m³).
    pub fn principal_inertia(&self, density_kg_m3: f64) -> Vec3 {
        self.principal_moments_m5 * density_kg_m3
    }

    /// The shape with every length multiplied by `factor` (volume by
    /// factor³, second moments by factor⁵): one size of a size distribution,
    /// without integrating the union again.
    pub fn scaled(&self, factor: f64) -> ClumpShape {
        ClumpShape {
            members: self
                .members
                .iter()
                .map(|m| Member {
                    offset: m.offset * factor,
                    radius_m: m.radius_m * factor,
                })
                .collect(),
            volume_m3: self.volume_m3 * factor.powi(3),
            principal_moments_m5: self.principal_moments_m5 * factor.powi(5),
            bounding_radius_m: self.bounding_radius_m * factor,
        }
    }

    /// Smallest member radius, m (sets the time step).
    pub fn min_member_radius_m(&self) -> f64 {
        self.members
            .iter()
            .map(|m| m.radius_m)
            .fold(f64::INFINITY, f64::min)
    }
}

fn sphere_volume(radius_m: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * radius_m.powi(3)
}

/// Mass properties of a union of validated members: exact for one or two,
/// numerical for more.
fn union_mass_properties(members: &[Member]) -> MassProperties {
    match members {
        [a] => MassProperties {
            volume_m3: sphere_volume(a.radius_m),
            centre: a.offset,
            inertia_m5: Matrix3::identity()
                * (0.4 * sphere_volume(a.radius_m) * a.radius_m * a.radius_m),
        },
        [a, b] => two_spheres(a, b),
        _ => numerical(members),
    }
}

/// Volume and moments of the truncated ball {|x| ≤ r, z ≤ c} (centre at the
/// origin, c clamped to [−r, r]): (∫1, ∫z, ∫z², ∫(x²+y²)) dV, from the disc
/// slices of area π(r² − z²) and polar moment π(r² − z²)²/2.
fn truncated_ball(r: f64, c: f64) -> [f64; 4] {
    use std::f64::consts::PI;
    let c = c.clamp(-r, r);
    let (r2, c2) = (r * r, c * c);
    let volume = PI * (r2 * c - c2 * c / 3.0 + 2.0 * r2 * r / 3.0);
    let first = PI * (r2 * c2 / 2.0 - c2 * c2 / 4.0 - r2 * r2 / 4.0);
    let second = PI * (r2 * c2 * c / 3.0 - c2 * c2 * c / 5.0 + 2.0 * r2 * r2 * r / 15.0);
    let polar = PI / 2.0
        * (r2 * r2 * c - 2.0 * r2 * c2 * c / 3.0 + c2 * c2 * c / 5.0 + 8.0 * r2 * r2 * r / 15.0);
    [volume, first, second, polar]
}

/// Exact mass properties of the union of two spheres (module docs).
fn two_spheres(a: &Member, b: &Member) -> MassProperties {
    let axis = b.offset - a.offset;
    let d = axis.norm();
    if d == 0.0 {
        let larger = if a.radius_m >= b.radius_m { a } else { b };
        return union_mass_properties(std::slice::from_ref(larger));
    }
    let u = axis / d;
    let (r1, r2) = (a.radius_m, b.radius_m);
    // Radical plane, distance from centre 1 along u.
    let h = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d);
    let [v1, m1, s1, p1] = truncated_ball(r1, h);
    // Sphere 2's part in its own coordinate z' = d − z (pointing back at centre 1).
    let [v2, m2, s2, p2] = truncated_ball(r2, d - h);
    let volume = v1 + v2;
    let first = m1 + (d * v2 - m2);
    let second = s1 + (d * d * v2 - 2.0 * d * m2 + s2);
    let polar = p1 + p2;
    let zc = first / volume;
    let axial = polar;
    let transverse = second - volume * zc * zc + polar / 2.0;
    let uu = u * u.transpose();
    MassProperties {
        volume_m3: volume,
        centre: a.offset + zc * u,
        inertia_m5: transverse * (Matrix3::identity() - uu) + axial * uu,
    }
}

/// Converged ray integration of the union (module docs).
fn numerical(members: &[Member]) -> MassProperties {
    let mut n = START_RESOLUTION;
    let mut coarse = integrate_rays(members, n);
    // The midpoint error oscillates in sign, so one small change can be a
    // coincidence: two successive ones are required.
    let mut small_changes = 0;
    loop {
        n *= 2;
        let fine = integrate_rays(members, n);
        if relative_change(&coarse, &fine) < NUMERICAL_TOLERANCE {
            small_changes += 1;
        } else {
            small_changes = 0;
        }
        if small_changes == 2 || n >= MAX_RESOLUTION {
            return fine;
        }
        coarse = fine;
    }
}

/// Largest relative change between two estimates: volume relative to itself,
/// centre relative to the cube root of the volume, inertia components relative
/// to the largest component.
fn relative_change(a: &MassProperties, b: &MassProperties) -> f64 {
    let volume = ((a.volume_m3 - b.volume_m3) / b.volume_m3).abs();
    let centre = (a.centre - b.centre).amax() / b.volume_m3.cbrt();
    let inertia = (a.inertia_m5 - b.inertia_m5).amax() / b.inertia_m5.amax();
    volume.max(centre).max(inertia)
}

/// Midpoint rule on an n × n grid of (y, z) cells over the union's bounding
/// box; exact integration along x on each ray.
fn integrate_rays(members: &[Member], n: usize) -> MassProperties {
    let lo = |k: usize| {
        members
            .iter()
            .map(|m| m.offset[k] - m.radius_m)
            .fold(f64::INFINITY, f64::min)
    };
    let hi = |k: usize| {
        members
            .iter()
            .map(|m| m.offset[k] + m.radius_m)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (y0, z0) = (lo(1), lo(2));
    let hy = (hi(1) - y0) / n as f64;
    let hz = (hi(2) - z0) / n as f64;
    // Sums of ∫1, ∫x, ∫y, ∫z, ∫x², ∫y², ∫z², ∫xy, ∫xz, ∫yz over the rays.
    let mut s = [0.0f64; 10];
    // Members cut by the current row: (x centre, y centre, r² − Δz²).
    let mut row_members: Vec<(f64, f64, f64)> = Vec::with_capacity(members.len());
    let mut intervals: Vec<(f64, f64)> = Vec::with_capacity(members.len());
    for k in 0..n {
        let z = z0 + (k as f64 + 0.5) * hz;
        row_members.clear();
        row_members.extend(members.iter().filter_map(|m| {
            let dz = z - m.offset.z;
            let rem = m.radius_m * m.radius_m - dz * dz;
            (rem > 0.0).then_some((m.offset.x, m.offset.y, rem))
        }));
        if row_members.is_empty() {
            continue;
        }
        // Row sums of ∫1, ∫x, ∫x², ∫y·1, ∫y·x, ∫y²·1.
        let mut r = [0.0f64; 6];
        for j in 0..n {
            let y = y0 + (j as f64 + 0.5) * hy;
            intervals.clear();
            intervals.extend(row_members.iter().filter_map(|&(cx, cy, rem)| {
                let dy = y - cy;
                let half2 = rem - dy * dy;
                (half2 > 0.0).then(|| {
                    let half = half2.sqrt();
                    (cx - half, cx + half)
                })
            }));
            if intervals.is_empty() {
                continue;
            }
            intervals.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let (mut l, mut lx, mut lxx) = (0.0, 0.0, 0.0);
            let (mut a, mut b) = intervals[0];
            let mut add = |a: f64, b: f64| {
                l += b - a;
                lx += (b * b - a * a) / 2.0;
                lxx += (b * b * b - a * a * a) / 3.0;
            };
            for &(na, nb) in &intervals[1..] {
                if na > b {
                    add(a, b);
                    (a, b) = (na, nb);
                } else {
                    b = b.max(nb);
                }
            }
            add(a, b);
            r[0] += l;
            r[1] += lx;
            r[2] += lxx;
            r[3] += y * l;
            r[4] += y * lx;
            r[5] += y * y * l;
        }
        s[0] += r[0];
        s[1] += r[1];
        s[2] += r[3];
        s[3] += z * r[0];
        s[4] += r[2];
        s[5] += r[5];
        s[6] += z * z * r[0];
        s[7] += r[4];
        s[8] += z * r[1];
        s[9] += z * r[3];
    }
    let cell = hy * hz;
    let s = s.map(|v| v * cell);
    let volume = s[0];
    let centre = Vec3::new(s[1], s[2], s[3]) / volume;
    // Central second moments C = ∫(r − c)(r − c)ᵀ; inertia = tr(C)·1 − C.
    let raw = Matrix3::new(s[4], s[7], s[8], s[7], s[5], s[9], s[8], s[9], s[6]);
    // c·cᵀ first (exactly symmetric), then the volume: a symmetric tensor.
    let central = raw - centre * centre.transpose() * volume;
    MassProperties {
        volume_m3: volume,
        centre,
        inertia_m5: Matrix3::identity() * central.trace() - central,
    }
}

/// Proper rotation whose columns are the principal axes of `inertia`, and the
/// principal moments, ascending (module docs: deterministic, template axes
/// kept when the tensor is already diagonal).
fn principal_axes(inertia: &Matrix3<f64>) -> (Matrix3<f64>, Vec3) {
    let scale = inertia.amax();
    let off_diagonal = inertia[(0, 1)]
        .abs()
        .max(inertia[(0, 2)].abs())
        .max(inertia[(1, 2)].abs());
    let (moments, vectors) = if off_diagonal <= 1e-12 * scale {
        (inertia.diagonal(), Matrix3::identity())
    } else {
        let eigen = SymmetricEigen::new(*inertia);
        let mut vectors = eigen.eigenvectors;
        for mut column in vectors.column_iter_mut() {
            let largest = column.iamax();
            if column[largest] < 0.0 {
                column.neg_mut();
            }
        }
        (eigen.eigenvalues, vectors)
    };
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| moments[i].total_cmp(&moments[j]));
    let mut rotation = Matrix3::from_columns(&[
        vectors.column(order[0]).into_owned(),
        vectors.column(order[1]).into_owned(),
        vectors.column(order[2]).into_owned(),
    ]);
    if rotation.determinant() < 0.0 {
        rotation.column_mut(2).neg_mut();
    }
    let sorted = Vec3::new(moments[order[0]], moments[order[1]], moments[order[2]]);
    (rotation, sorted)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    fn member(x: f64, y: f64, z: f64, radius_m: f64) -> Member {
        Member {
            offset: Vec3::new(x, y, z),
            radius_m,
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// Largest component difference relative to the largest component of `b`.
    fn rel_matrix(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        (a - b).amax() / b.amax()
    }

    /// Textbook volume of the lens common to two spheres (radii r1, r2, centre
    /// distance d).
    fn lens_volume(r1: f64, r2: f64, d: f64) -> f64 {
        PI * (r1 + r2 - d).powi(2)
            * (d * d + 2.0 * d * r2 - 3.0 * r2 * r2 + 2.0 * d * r1 + 6.0 * r1 * r2 - 3.0 * r1 * r1)
            / (12.0 * d)
    }

    /// Axial moment per unit density of a spherical cap of height t on a sphere
    /// of radius r, integrated in the depth w from the pole: the slice at depth
    /// w has radius² w(2r − w), so I = π/2 ∫₀ᵗ w²(2r − w)² dw
    /// = π t³ (20 r² − 15 r t + 3 t²) / 30.
    fn cap_axial_moment(r: f64, t: f64) -> f64 {
        PI * t.powi(3) * (20.0 * r * r - 15.0 * r * t + 3.0 * t * t) / 30.0
    }

    fn template(members: Vec<Member>) -> ClumpTemplate {
        ClumpTemplate::new("test", members).unwrap()
    }

    #[test]
    fn single_sphere_has_the_sphere_formulas() {
        let r = 0.3;
        let props = template(vec![member(1.0, 2.0, 3.0, r)]).mass_properties();
        let volume = 4.0 / 3.0 * PI * r.powi(3);
        assert!(rel(props.volume_m3, volume) < 1e-15);
        assert_eq!(props.centre, Vec3::new(1.0, 2.0, 3.0));
        // I = 2/5 V R² about every axis, no products.
        let expected = Matrix3::identity() * (0.4 * volume * r * r);
        assert!(rel_matrix(&props.inertia_m5, &expected) < 1e-15);
    }

    #[test]
    fn paired_spheres_near_aspect_one_approach_a_sphere() {
        // Centres ±δ, δ = 1e-9: the union exceeds the unit sphere by a
        // cylinder of length 2δ (volume 2πδ ≈ 6e-9, relative 1.5e-9) and the
        // moments change by the same order.
        let props = ClumpTemplate::paired_spheres(1.0 + 1e-9)
            .unwrap()
            .mass_properties();
        let volume = 4.0 / 3.0 * PI;
        assert!(rel(props.volume_m3, volume) < 1e-8);
        assert!(props.centre.norm() < 1e-15);
        let expected = Matrix3::identity() * (0.4 * volume);
        assert!(rel_matrix(&props.inertia_m5, &expected) < 1e-8);
    }

    #[test]
    fn nearly_touching_spheres_approach_two_spheres_with_parallel_axis_terms() {
        // R = 1, d = 2(1 − ε): the lens has height ε, volume ~ 2πε² (1e-12).
        let eps = 1e-6;
        let half = 1.0 - eps;
        let props = template(vec![
            member(-half, 0.0, 0.0, 1.0),
            member(half, 0.0, 0.0, 1.0),
        ])
        .mass_properties();
        let v = 4.0 / 3.0 * PI;
        assert!(rel(props.volume_m3, 2.0 * v) < 1e-11);
        assert!(props.centre.norm() < 1e-15);
        // Axial: two spheres' 2/5 V R², lens correction O(ε³).
        assert!(rel(props.inertia_m5[(0, 0)], 2.0 * 0.4 * v) < 1e-11);
        // Transverse: 2 (2/5 V R² + V half²), lens correction O(ε²).
        let transverse = 2.0 * (0.4 * v + v * half * half);
        assert!(rel(props.inertia_m5[(1, 1)], transverse) < 1e-11);
        assert!(rel(props.inertia_m5[(2, 2)], transverse) < 1e-11);
        assert_eq!(props.inertia_m5[(0, 1)], 0.0);
    }

    #[test]
    fn two_equal_spheres_match_the_lens_and_cap_formulas() {
        let (r, d) = (0.7, 0.9);
        let props =
            template(vec![member(0.0, 0.0, 0.0, r), member(d, 0.0, 0.0, r)]).mass_properties();
        let sphere = 4.0 / 3.0 * PI * r.powi(3);
        // Textbook lens of two equal spheres: π(4R + d)(2R − d)²/12.
        let volume = 2.0 * sphere - PI * (4.0 * r + d) * (2.0 * r - d).powi(2) / 12.0;
        assert!(rel(props.volume_m3, volume) < 1e-14);
        assert!((props.centre - Vec3::new(d / 2.0, 0.0, 0.0)).norm() < 1e-15);
        // Union = two spheres − lens; lens = two caps of height R − d/2.
        let axial = 2.0 * 0.4 * sphere * r * r - 2.0 * cap_axial_moment(r, r - d / 2.0);
        assert!(rel(props.inertia_m5[(0, 0)], axial) < 1e-14);
    }

    #[test]
    fn two_spheres_on_a_skew_axis_give_the_rotated_tensor() {
        // The same pair along x and along a skew unit axis u: I_skew = Q I_x Qᵀ
        // for any rotation Q taking x to u.
        let (r1, r2, d) = (0.5, 0.8, 1.0);
        let along_x =
            template(vec![member(0.0, 0.0, 0.0, r1), member(d, 0.0, 0.0, r2)]).mass_properties();
        let q = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let u = q * Vec3::x();
        let base = Vec3::new(0.2, -0.1, 0.4);
        let skew = template(vec![
            Member {
                offset: base,
                radius_m: r1,
            },
            Member {
                offset: base + d * u,
                radius_m: r2,
            },
        ])
        .mass_properties();
        assert!(rel(skew.volume_m3, along_x.volume_m3) < 1e-15);
        assert!((skew.centre - (base + q * along_x.centre)).norm() < 1e-15);
        let rotated = q * along_x.inertia_m5 * q.transpose();
        assert!(rel_matrix(&skew.inertia_m5, &rotated) < 1e-14);
        // And the textbook lens of unequal spheres.
        let volume = 4.0 / 3.0 * PI * (r1.powi(3) + r2.powi(3)) - lens_volume(r1, r2, d);
        assert!(rel(skew.volume_m3, volume) < 1e-14);
    }

    /// Worst relative deviation of the numerical path from the exact one.
    fn numerical_error(a: &Member, b: &Member) -> f64 {
        let exact = two_spheres(a, b);
        let numeric = numerical(&[*a, *b]);
        relative_change(&numeric, &exact)
    }

    #[test]
    fn numerical_path_matches_exact_two_sphere_result() {
        let u = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1) * Vec3::x();
        let cases = [
            // he2019 pairs at aspect ratios 1.05, 1.3, 1.9.
            (member(-0.05, 0.0, 0.0, 1.0), member(0.05, 0.0, 0.0, 1.0)),
            (member(-0.3, 0.0, 0.0, 1.0), member(0.3, 0.0, 0.0, 1.0)),
            (member(-0.9, 0.0, 0.0, 1.0), member(0.9, 0.0, 0.0, 1.0)),
            // Unequal radii on a skew axis (no grid alignment).
            (
                member(0.0, 0.0, 0.0, 0.5),
                Member {
                    offset: 1.0 * u,
                    radius_m: 0.8,
                },
            ),
        ];
        for (a, b) in cases {
            let error = numerical_error(&a, &b);
            eprintln!(
                "numerical vs exact, d = {:.3}: {error:.2e}",
                (b.offset - a.offset).norm()
            );
            assert!(error < NUMERICAL_ACCURACY, "{error:e}");
        }
    }

    #[test]
    fn three_collinear_spheres_are_symmetric_and_match_the_lens_formulas() {
        // Spacing d ≥ R: the end spheres do not meet, so the union is three
        // spheres minus two lenses (each two caps of height R − d/2).
        let (r, d) = (1.0, 1.2);
        let props = template(vec![
            member(-d, 0.0, 0.0, r),
            member(0.0, 0.0, 0.0, r),
            member(d, 0.0, 0.0, r),
        ])
        .mass_properties();
        let sphere = 4.0 / 3.0 * PI * r.powi(3);
        let volume = 3.0 * sphere - 2.0 * lens_volume(r, r, d);
        assert!(rel(props.volume_m3, volume) < NUMERICAL_ACCURACY);
        let axial = 3.0 * 0.4 * sphere * r * r - 4.0 * cap_axial_moment(r, r - d / 2.0);
        assert!(rel(props.inertia_m5[(0, 0)], axial) < NUMERICAL_ACCURACY);
        let i = props.inertia_m5;
        // The grid is symmetric about y = 0 and z = 0 and the same in y and z:
        // only roundoff separates the mirrored terms.
        assert!(props.centre.amax() < 1e-12);
        assert!(rel(i[(1, 1)], i[(2, 2)]) < 1e-12);
        for (j, k) in [(0, 1), (0, 2), (1, 2)] {
            assert!(i[(j, k)].abs() < 1e-12 * i.amax());
            assert_eq!(i[(j, k)], i[(k, j)]);
        }
    }

    /// Checks a shape is in its principal frame: the union of its members,
    /// integrated afresh, has its centre at the origin and a diagonal tensor
    /// equal to the principal moments, to `tolerance` relative.
    fn assert_principal(shape: &ClumpShape, tolerance: f64) {
        let props = union_mass_properties(&shape.members);
        assert!(rel(props.volume_m3, shape.volume_m3) < tolerance);
        assert!(props.centre.amax() < tolerance * shape.bounding_radius_m);
        let diagonal = Matrix3::from_diagonal(&shape.principal_moments_m5);
        let error = rel_matrix(&props.inertia_m5, &diagonal);
        assert!(error < tolerance, "{error:e}");
        let m = shape.principal_moments_m5;
        assert!(m.x <= m.y && m.y <= m.z, "{m:?}");
        // Bounding radius: the farthest member surface from the centre.
        let farthest = shape
            .members
            .iter()
            .map(|m| m.offset.norm() + m.radius_m)
            .fold(0.0, f64::max);
        assert_eq!(shape.bounding_radius_m, farthest);
    }

    #[test]
    fn paired_spheres_shape_is_volume_equivalent_and_keeps_the_x_axis() {
        let r_eq = 0.002;
        let shape = ClumpTemplate::paired_spheres(1.3).unwrap().shape(r_eq);
        let volume = 4.0 / 3.0 * PI * r_eq.powi(3);
        assert!(rel(shape.volume_m3, volume) < 1e-12);
        // Template volume: two unit spheres 0.6 apart minus their lens; the
        // scale s makes s³ times it the equivalent sphere's volume.
        let template_volume = 2.0 * 4.0 / 3.0 * PI - lens_volume(1.0, 1.0, 0.6);
        let s = (volume / template_volume).cbrt();
        for (m, sign) in shape.members.iter().zip([-1.0, 1.0]) {
            assert!(rel(m.offset.x, sign * 0.3 * s) < 1e-14);
            assert_eq!((m.offset.y, m.offset.z), (0.0, 0.0));
            assert!(rel(m.radius_m, s) < 1e-14);
        }
        // Length / width = the aspect ratio: half-length over member radius.
        assert!(rel(shape.bounding_radius_m / shape.min_member_radius_m(), 1.3) < 1e-14);
        // The long axis x has the smallest moment and the two transverse ones
        // are equal.
        let m = shape.principal_moments_m5;
        assert!(m.x < m.y);
        assert!(rel(m.y, m.z) < 1e-15);
        assert_principal(&shape, 1e-9);
    }

    #[test]
    fn skew_pair_shape_is_rotated_onto_x() {
        let u = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1) * Vec3::x();
        let template = template(vec![
            member(0.1, 0.2, 0.3, 0.5),
            Member {
                offset: Vec3::new(0.1, 0.2, 0.3) + u,
                radius_m: 0.8,
            },
        ]);
        let shape = template.shape(1.5);
        assert!(rel(shape.volume_m3, 4.0 / 3.0 * PI * 1.5f64.powi(3)) < 1e-12);
        for m in &shape.members {
            assert!(m.offset.y.abs().max(m.offset.z.abs()) < 1e-12 * shape.bounding_radius_m);
        }
        // The larger member is heavier, so it lies nearer the centre.
        assert!(shape.members[1].offset.norm() < shape.members[0].offset.norm());
        assert_principal(&shape, 1e-9);
    }

    #[test]
    fn chiral_shape_is_rotated_not_mirrored() {
        // Four members spanning a right-handed tetrahedron (numerical path).
        let members = vec![
            member(0.0, 0.0, 0.0, 0.6),
            member(1.0, 0.0, 0.0, 0.6),
            member(0.0, 0.8, 0.0, 0.6),
            member(0.0, 0.0, 0.6, 0.6),
        ];
        let triple = |m: &[Member]| {
            let e = |i: usize| m[i].offset - m[0].offset;
            e(1).cross(&e(2)).dot(&e(3))
        };
        let template = template(members.clone());
        let props = template.mass_properties();
        assert_eq!(props.inertia_m5, props.inertia_m5.transpose());
        let shape = template.shape(0.01);
        let s = shape.members[0].radius_m / 0.6;
        // A proper rotation keeps the signed volume (× s³); a mirror flips it.
        assert!(triple(&members) > 0.0);
        assert!(rel(triple(&shape.members), s.powi(3) * triple(&members)) < 1e-12);
        // Re-integrated on a grid aligned with the new axes: the numerical
        // error, not roundoff, separates the two.
        assert_principal(&shape, NUMERICAL_ACCURACY);
    }

    #[test]
    fn sphere_shape_gives_mass_inertia_and_radii() {
        let (r, density) = (0.004, 2500.0);
        let shape = template(vec![member(5.0, -1.0, 2.0, 1.0)]).shape(r);
        assert_eq!(shape.members.len(), 1);
        assert!(shape.members[0].offset.norm() < 1e-15);
        assert!(rel(shape.min_member_radius_m(), r) < 1e-14);
        assert!(rel(shape.bounding_radius_m, r) < 1e-14);
        let mass = density * 4.0 / 3.0 * PI * r.powi(3);
        assert!(rel(shape.mass_kg(density), mass) < 1e-14);
        let inertia = shape.principal_inertia(density);
        for k in 0..3 {
            // Solid sphere: 2/5 m r².
            assert!(rel(inertia[k], 0.4 * mass * r * r) < 1e-14);
        }
    }

    #[test]
    fn shape_round_trips_through_json_with_array_vectors() {
        let shape = ClumpTemplate::paired_spheres(1.5).unwrap().shape(0.5);
        let json = serde_json::to_string(&shape).unwrap();
        assert!(json.contains("\"offset\":[-"), "{json}");
        assert!(json.contains("\"principal_moments_m5\":["), "{json}");
        let back: ClumpShape = serde_json::from_str(&json).unwrap();
        assert_eq!(back, shape);
    }

    #[test]
    fn template_keeps_name_and_members() {
        let members = vec![member(0.0, 0.0, 0.0, 1.0), member(1.0, 0.0, 0.0, 0.5)];
        let template = ClumpTemplate::new("peanut", members.clone()).unwrap();
        assert_eq!(template.name(), "peanut");
        assert_eq!(template.members(), &members[..]);
        let paired = ClumpTemplate::paired_spheres(1.25).unwrap();
        assert_eq!(paired.name(), "paired_spheres_1.25");
        assert_eq!(
            paired.members(),
            &[member(-0.25, 0.0, 0.0, 1.0), member(0.25, 0.0, 0.0, 1.0)]
        );
    }

    fn error_message(members: Vec<Member>) -> String {
        ClumpTemplate::new("bad", members).unwrap_err().to_string()
    }

    #[test]
    fn invalid_templates_are_refused_naming_field_and_value() {
        assert_eq!(
            error_message(vec![]),
            "members: none given: a clump needs 1 to 64 member spheres"
        );
        let many = (0..65)
            .map(|i| member(0.5 * i as f64, 0.0, 0.0, 0.3))
            .collect();
        assert_eq!(
            error_message(many),
            "members: 65 given: at most 64 member spheres are allowed"
        );
        // 64 is allowed.
        let most: Vec<Member> = (0..64)
            .map(|i| member(0.5 * i as f64, 0.0, 0.0, 0.3))
            .collect();
        assert!(ClumpTemplate::new("most", most).is_ok());
        assert_eq!(
            error_message(vec![
                member(0.0, 0.0, 0.0, 1.0),
                member(0.0, f64::NAN, 0.0, 1.0)
            ]),
            "members[1].offset = (0, NaN, 0): every component must be finite"
        );
        for (radius, shown) in [(-1.0, "-1"), (0.0, "0"), (f64::INFINITY, "inf")] {
            assert_eq!(
                error_message(vec![
                    member(0.0, 0.0, 0.0, 1.0),
                    member(1.0, 0.0, 0.0, 1.0),
                    member(2.0, 0.0, 0.0, radius),
                ]),
                format!("members[2].radius_m = {shown}: must be finite and positive")
            );
        }
        // Touching at a point (d = r_a + r_b) does not connect.
        let expected = "members[1] is not connected to members[0]: the union of the members \
                        must be connected (two members connect when their centre distance is \
                        below the sum of their radii)";
        assert_eq!(
            error_message(vec![member(0.0, 0.0, 0.0, 1.0), member(2.0, 0.0, 0.0, 1.0)]),
            expected
        );
        assert_eq!(
            error_message(vec![
                member(0.0, 0.0, 0.0, 1.0),
                member(5.0, 0.0, 0.0, 1.0),
                member(1.0, 0.0, 0.0, 1.0),
            ]),
            expected
        );
        assert_eq!(
            error_message(vec![
                member(0.0, 0.0, 0.0, 1.0),
                member(0.25, 0.0, 0.0, 0.5)
            ]),
            "members[1] (radius_m = 0.5) lies entirely inside members[0] (radius_m = 1, centre \
             distance 0.25): it would add nothing to the shape; remove it"
        );
        assert_eq!(
            error_message(vec![
                member(0.0, 0.0, 0.0, 0.5),
                member(0.0, 0.0, 0.25, 1.0)
            ]),
            "members[0] (radius_m = 0.5) lies entirely inside members[1] (radius_m = 1, centre \
             distance 0.25): it would add nothing to the shape; remove it"
        );
        for (aspect, shown) in [(1.0, "1"), (2.0, "2"), (0.5, "0.5"), (f64::NAN, "NaN")] {
            assert_eq!(
                ClumpTemplate::paired_spheres(aspect)
                    .unwrap_err()
                    .to_string(),
                format!(
                    "aspect_ratio = {shown}: must be finite and strictly between 1 and 2 \
                     (1 would be a sphere, 2 two spheres touching at a point)"
                )
            );
        }
    }

    #[test]
    fn two_sphere_formula_clamps_the_cut_for_disjoint_contained_and_coincident_pairs() {
        // Not reachable through `new` (it refuses these), but the closed form
        // must not fail on them: the radical plane then lies outside a sphere.
        let (a, b) = (member(0.0, 0.0, 0.0, 1.0), member(0.0, 3.0, 0.0, 0.5));
        let disjoint = two_spheres(&a, &b);
        let (va, vb) = (4.0 / 3.0 * PI, 4.0 / 3.0 * PI * 0.125);
        assert!(rel(disjoint.volume_m3, va + vb) < 1e-14);
        // Centre of mass 3·vb/(va + vb) along y.
        assert!(rel(disjoint.centre.y, 3.0 * vb / (va + vb)) < 1e-14);
        for inner in [member(0.0, 0.2, 0.0, 0.5), member(0.0, 0.0, 0.0, 0.5)] {
            for (p, q) in [(&a, &inner), (&inner, &a)] {
                let props = two_spheres(p, q);
                assert!(rel(props.volume_m3, va) < 1e-14);
                assert!(props.centre.norm() < 1e-15);
                assert!(rel_matrix(&props.inertia_m5, &(Matrix3::identity() * 0.4 * va)) < 1e-14);
            }
        }
    }
}
