//! Surface points from a projected snapshot: the highest particle top per bin.

use super::fit::{fit_line, LineFit};
use super::MeasureError;
use std::collections::BTreeMap;

/// Highest top per bin. `items` yields `(h, top)`: a particle's horizontal
/// coordinate (m) and the height of its top (m). Bin k covers
/// `[k·bin_width, (k+1)·bin_width)`. Returns one `(h, top)` per non-empty bin —
/// the h of the particle that is highest in that bin — sorted by h.
pub fn top_per_bin(
    items: impl IntoIterator<Item = (f64, f64)>,
    bin_width_m: f64,
) -> Vec<(f64, f64)> {
    let mut bins: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
    for (h, top) in items {
        let k = (h / bin_width_m).floor() as i64;
        let best = bins.entry(k).or_insert((h, top));
        if top > best.1 {
            *best = (h, top);
        }
    }
    bins.into_values().collect()
}

/// Left and right flank fits of a profile whose points have h measured from the
/// split (the pile axis or the crater centre): left is h < 0, right h > 0. Only
/// points with `top` inside `v_window` and |h| inside `abs_h_window` are used.
pub fn fit_flanks(
    points: &[(f64, f64)],
    v_window: (f64, f64),
    abs_h_window: (f64, f64),
) -> Result<(LineFit, LineFit), MeasureError> {
    let keep = |&&(h, v): &&(f64, f64)| {
        v >= v_window.0 && v <= v_window.1 && h.abs() >= abs_h_window.0 && h.abs() <= abs_h_window.1
    };
    let left: Vec<_> = points
        .iter()
        .filter(keep)
        .filter(|p| p.0 < 0.0)
        .copied()
        .collect();
    let right: Vec<_> = points
        .iter()
        .filter(keep)
        .filter(|p| p.0 > 0.0)
        .copied()
        .collect();
    Ok((
        fit_line(&left, "left flank")?,
        fit_line(&right, "right flank")?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_highest_per_bin_sorted() {
        let pts = top_per_bin([(0.15, 1.0), (0.12, 3.0), (-0.05, 2.0), (0.31, 0.5)], 0.1);
        assert_eq!(pts, vec![(-0.05, 2.0), (0.12, 3.0), (0.31, 0.5)]);
    }
}
