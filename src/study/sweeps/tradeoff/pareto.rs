//! The Pareto front of (error, cost) for the tradeoff table.

/// Indices of the Pareto-optimal points minimising both coordinates: no other
/// point is at least as good in both and better in one. Sorted by cost.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&i, &j| {
        points[i]
            .1
            .total_cmp(&points[j].1)
            .then(points[i].0.total_cmp(&points[j].0))
    });
    let mut front = Vec::new();
    let mut best_error = f64::INFINITY;
    for i in order {
        if points[i].0 < best_error {
            best_error = points[i].0;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_drops_dominated_points() {
        // (error, cost): b is dominated by a (worse error, more cost).
        let pts = [(1.0, 10.0), (2.0, 20.0), (0.5, 30.0), (3.0, 1.0)];
        assert_eq!(pareto_front(&pts), vec![3, 0, 2]);
    }
}
