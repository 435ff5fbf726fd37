//! The Pareto front of error against time: the settings for which no other
//! setting is at least as fast and at least as accurate, and strictly better
//! in one of the two.

/// Whether `a` dominates `b`, both `(time, error)`, smaller is better in
/// both: `a` is no worse in either and strictly better in one.
pub fn dominates(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1)
}

/// For each `(time, error)` point, whether it is on the Pareto front: finite
/// and dominated by no other finite point. Non-finite points are never on
/// the front. O(n²), for the few hundred points of a benchmark.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|p| ok(p) && !points.iter().any(|q| ok(q) && dominates(*q, *p)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_exactly_the_undominated_points() {
        let pts = [
            (1.0, 10.0),     // fastest: front
            (2.0, 5.0),      // front
            (3.0, 6.0),      // dominated by (2, 5)
            (4.0, 1.0),      // most accurate: front
            (4.0, 1.0),      // a tie with the previous one: both on the front
            (5.0, 1.0),      // dominated by (4, 1)
            (f64::NAN, 0.1), // not finite: never on the front
        ];
        let f = pareto_front(&pts);
        assert_eq!(f, vec![true, true, false, true, true, false, false]);
        for (i, p) in pts.iter().enumerate().filter(|(i, _)| f[*i]) {
            for q in &pts {
                assert!(!dominates(*q, *p), "front point {i} dominated by {q:?}");
            }
        }
    }
}
