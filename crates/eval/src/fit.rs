//! Growth exponents: a least-squares fit of `y = c · x^k` in log-log space
//! (`ln y = ln c + k ln x`), for the scaling sweeps of `gibake bench`.

/// A fitted power law `y = scale · x^exponent`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PowerFit {
    /// The growth exponent `k` (1 = linear, 0 = flat).
    pub exponent: f64,
    /// The factor `c`.
    pub scale: f64,
    /// Coefficient of determination of the fit in log-log space (1 = exact;
    /// 0 when every `ln y` is the same).
    pub r2: f64,
    /// Points used (those with finite, positive x and y).
    pub points: usize,
}

/// Fits `y = c · x^k` to the points with finite, positive `x` and `y` by
/// least squares on `(ln x, ln y)`. `None` when fewer than two such points
/// remain or every x is the same.
pub fn power_fit(points: &[(f64, f64)]) -> Option<PowerFit> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / nf;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = logs.iter().map(|p| (p.1 - my) * (p.1 - my)).sum();
    if sxx <= 1e-300 {
        return None;
    }
    let k = sxy / sxx;
    let a = my - k * mx;
    let sse: f64 = logs.iter().map(|p| (p.1 - (a + k * p.0)).powi(2)).sum();
    let r2 = if syy > 0.0 { 1.0 - sse / syy } else { 0.0 };
    Some(PowerFit {
        exponent: k,
        scale: a.exp(),
        r2,
        points: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_power_law() {
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 64.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(0.53)))
            .collect();
        let f = power_fit(&pts).unwrap();
        assert!((f.exponent - 0.53).abs() < 1e-9, "{f:?}");
        assert!((f.scale - 3.0).abs() < 1e-9, "{f:?}");
        assert!((f.r2 - 1.0).abs() < 1e-9, "{f:?}");
    }

    #[test]
    fn flat_and_degenerate_inputs() {
        let f = power_fit(&[(1.0, 5.0), (10.0, 5.0), (100.0, 5.0)]).unwrap();
        assert!(f.exponent.abs() < 1e-12);
        assert!(power_fit(&[(1.0, 1.0)]).is_none());
        assert!(power_fit(&[(2.0, 1.0), (2.0, 3.0)]).is_none());
        // Non-positive and non-finite points are skipped, not fitted.
        let f = power_fit(&[(1.0, 1.0), (0.0, 1.0), (2.0, f64::NAN), (4.0, 16.0)]).unwrap();
        assert_eq!(f.points, 2);
        assert!((f.exponent - 2.0).abs() < 1e-9);
    }
}
