//! PLACEHOLDER until the template module lands (replaced at merge).
use crate::dem::vec3::Vec3;

/// One sphere of a clump, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Member {
    /// Offset, m.
    pub offset: Vec3,
    /// Radius, m.
    pub radius_m: f64,
}

/// A shape.
#[derive(Clone, Debug, PartialEq)]
pub struct ClumpShape {
    /// Members.
    pub members: Vec<Member>,
    /// Volume.
    pub volume_m3: f64,
    /// Moments.
    pub principal_moments_m5: Vec3,
    /// Bounding.
    pub bounding_radius_m: f64,
}

impl ClumpShape {
    /// Mass.
    pub fn mass_kg(&self, density_kg_m3: f64) -> f64 {
        self.volume_m3 * density_kg_m3
    }
    /// Inertia.
    pub fn principal_inertia(&self, density_kg_m3: f64) -> Vec3 {
        self.principal_moments_m5 * density_kg_m3
    }
    /// The shape with every length multiplied by `factor` (volume by
    /// factor³, second moments by factor⁵): one size of a size distribution.
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
    /// Min radius.
    pub fn min_member_radius_m(&self) -> f64 {
        self.members
            .iter()
            .map(|m| m.radius_m)
            .fold(f64::INFINITY, f64::min)
    }
}

/// Placeholder template.
#[derive(Clone, Debug)]
pub struct ClumpTemplate {
    members: Vec<Member>,
}

impl ClumpTemplate {
    /// New.
    pub fn new(_name: &str, members: Vec<Member>) -> Result<Self, std::fmt::Error> {
        Ok(Self { members })
    }
    /// Paired.
    pub fn paired_spheres(ar: f64) -> Result<Self, std::fmt::Error> {
        let a = ar - 1.0;
        Self::new(
            "paired",
            vec![
                Member {
                    offset: Vec3::new(-a, 0.0, 0.0),
                    radius_m: 1.0,
                },
                Member {
                    offset: Vec3::new(a, 0.0, 0.0),
                    radius_m: 1.0,
                },
            ],
        )
    }
    /// Shape.
    pub fn shape(&self, req: f64) -> ClumpShape {
        let lo = self.members.iter().fold(Vec3::from_element(1e9), |a, m| {
            a.inf(&(m.offset - Vec3::from_element(m.radius_m)))
        });
        let hi = self.members.iter().fold(Vec3::from_element(-1e9), |a, m| {
            a.sup(&(m.offset + Vec3::from_element(m.radius_m)))
        });
        let n = 120;
        let h = (hi - lo) / n as f64;
        let dv = h.x * h.y * h.z;
        let (mut v, mut c, mut s2) = (0.0, Vec3::zeros(), nalgebra::Matrix3::<f64>::zeros());
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let x = lo
                        + Vec3::new(
                            (i as f64 + 0.5) * h.x,
                            (j as f64 + 0.5) * h.y,
                            (k as f64 + 0.5) * h.z,
                        );
                    if self
                        .members
                        .iter()
                        .any(|m| (x - m.offset).norm() < m.radius_m)
                    {
                        v += dv;
                        c += x * dv;
                        s2 += x * x.transpose() * dv;
                    }
                }
            }
        }
        c /= v;
        let cov = s2 - c * c.transpose() * v;
        let inertia = nalgebra::Matrix3::identity() * cov.trace() - cov;
        let eig = nalgebra::SymmetricEigen::new(inertia);
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let mut rot = nalgebra::Matrix3::from_columns(&[
            Vec3::from(eig.eigenvectors.column(idx[0])),
            Vec3::from(eig.eigenvectors.column(idx[1])),
            Vec3::from(eig.eigenvectors.column(idx[2])),
        ]);
        if rot.determinant() < 0.0 {
            let c2 = -rot.column(2);
            rot.set_column(2, &c2);
        }
        let scale = req / (3.0 * v / (4.0 * std::f64::consts::PI)).cbrt();
        let members: Vec<Member> = self
            .members
            .iter()
            .map(|m| Member {
                offset: rot.transpose() * (m.offset - c) * scale,
                radius_m: m.radius_m * scale,
            })
            .collect();
        let bounding = members
            .iter()
            .map(|m| m.offset.norm() + m.radius_m)
            .fold(0.0, f64::max);
        ClumpShape {
            members,
            volume_m3: v * scale.powi(3),
            principal_moments_m5: Vec3::new(
                eig.eigenvalues[idx[0]],
                eig.eigenvalues[idx[1]],
                eig.eigenvalues[idx[2]],
            ) * scale.powi(5),
            bounding_radius_m: bounding,
        }
    }
}
