//! Least-squares straight lines, for the cost-against-frames studies
//! (figs 7.10 and 8.2: how render time and memory grow per frame).

use serde::Serialize;

/// `y ≈ slope · x + intercept`, fitted by least squares.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LinearFit {
    /// dy/dx.
    pub slope: f64,
    /// y at x = 0.
    pub intercept: f64,
}

/// The least-squares line through `(x, y)` points; `None` with fewer than
/// two distinct x or any non-finite value.
pub fn linear_fit(points: &[(f64, f64)]) -> Option<LinearFit> {
    if points
        .iter()
        .any(|(x, y)| !(x.is_finite() && y.is_finite()))
    {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if points.len() < 2 || sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some(LinearFit {
        slope,
        intercept: my - slope * mx,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_known_lines() {
        for (a, b) in [(0.25, 3.0), (-2.0, 0.5), (0.0, 7.0), (1.5e6, 2e7)] {
            let pts: Vec<(f64, f64)> = (0..12)
                .map(|i| (i as f64 * 5.0, a * i as f64 * 5.0 + b))
                .collect();
            let f = linear_fit(&pts).unwrap();
            assert!((f.slope - a).abs() <= 1e-9 * a.abs().max(1.0), "{f:?}");
            assert!((f.intercept - b).abs() <= 1e-9 * b.abs().max(1.0), "{f:?}");
        }
    }

    #[test]
    fn alternating_noise_moves_the_slope_as_predicted() {
        // ±1 alternating about y = 3x + 1 at x = 0…9: the residuals sum to
        // zero but are not orthogonal to x, so the slope moves by exactly
        // Σ(x−x̄)e / Σ(x−x̄)² = −5/82.5.
        let pts: Vec<(f64, f64)> = (0..10)
            .map(|i| {
                let x = i as f64;
                (x, 3.0 * x + 1.0 + if i % 2 == 0 { 1.0 } else { -1.0 })
            })
            .collect();
        let f = linear_fit(&pts).unwrap();
        assert!((f.slope - (3.0 - 5.0 / 82.5)).abs() < 1e-12, "{f:?}");
    }

    #[test]
    fn degenerate_inputs_have_no_line() {
        assert!(linear_fit(&[]).is_none());
        assert!(linear_fit(&[(1.0, 2.0)]).is_none());
        assert!(linear_fit(&[(1.0, 2.0), (1.0, 3.0)]).is_none());
        assert!(linear_fit(&[(0.0, 1.0), (1.0, f64::NAN)]).is_none());
    }
}
