//! A sparse cell grid for overlap checks during insertion (O(1) per query for a
//! bounded size ratio).

use crate::dem::vec3::Vec3;
use std::collections::HashMap;

/// Spheres hashed by cell; the cell edge is at least the largest diameter that
/// will ever be queried or inserted, so overlapping spheres sit in neighbouring
/// cells.
pub(crate) struct Grid {
    cell_m: f64,
    cells: HashMap<[i64; 3], Vec<usize>>,
    spheres: Vec<(Vec3, f64)>,
}

impl Grid {
    /// An empty grid with cell edge `cell_m` (>= twice the largest radius).
    pub(crate) fn new(cell_m: f64) -> Self {
        Self {
            cell_m,
            cells: HashMap::new(),
            spheres: Vec::new(),
        }
    }

    fn key(&self, p: &Vec3) -> [i64; 3] {
        [0, 1, 2].map(|k| (p[k] / self.cell_m).floor() as i64)
    }

    /// Adds a sphere.
    pub(crate) fn insert(&mut self, p: Vec3, r: f64) {
        let key = self.key(&p);
        self.cells.entry(key).or_default().push(self.spheres.len());
        self.spheres.push((p, r));
    }

    /// The stored spheres in the cells around `p` (every sphere that can
    /// overlap a sphere at `p`).
    fn near(&self, p: &Vec3) -> impl Iterator<Item = &(Vec3, f64)> {
        let [i, j, k] = self.key(p);
        (-1..=1)
            .flat_map(move |di| (-1..=1).flat_map(move |dj| (-1..=1).map(move |dk| [di, dj, dk])))
            .filter_map(move |[di, dj, dk]| self.cells.get(&[i + di, j + dj, k + dk]))
            .flatten()
            .map(|&s| &self.spheres[s])
    }

    /// The deepest overlap, m, of a sphere at `p` with radius `r` with the
    /// stored spheres (sum of the radii less the centre distance; 0 when it
    /// touches none).
    pub(crate) fn deepest_overlap(&self, p: &Vec3, r: f64) -> f64 {
        self.near(p)
            .map(|(q, rq)| r + rq - (q - p).norm())
            .fold(0.0, f64::max)
    }

    /// True when a sphere at `p` with radius `r` would overlap a stored sphere
    /// (centre distance below the sum of the radii).
    pub(crate) fn overlaps(&self, p: &Vec3, r: f64) -> bool {
        self.near(p)
            .any(|(q, rq)| (q - p).norm_squared() < (r + rq) * (r + rq))
    }
}
