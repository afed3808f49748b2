//! Least-squares straight lines: the cost-against-frames studies (figs 7.10
//! and 8.2: how render time and memory grow per frame) and the observed order
//! of accuracy of every convergence test.
//!
//! Given grid spacings `h_i` and errors `e_i`, the observed order is the
//! least-squares slope of `log e` against `log h`; the pairwise rates
//! `log(e_i/e_{i+1}) / log(h_i/h_{i+1})` show whether the asymptotic regime
//! has been reached (STYLE.md, after Oceananigans).

use std::fmt;

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

/// A convergence study's fit and table.
#[derive(Clone, Debug)]
pub struct ObservedOrder {
    /// Grid spacings (or time steps), coarse to fine.
    pub h: Vec<f64>,
    /// Errors at each spacing.
    pub error: Vec<f64>,
    /// Least-squares slope of log e against log h.
    pub order: f64,
    /// Rates between consecutive refinements.
    pub rates: Vec<f64>,
}

/// Fit the observed order of `errors` against `h`.
///
/// # Panics
/// If fewer than two points are given, the lengths differ, or a value is not
/// positive (a zero error has no logarithm: the study is then meaningless).
pub fn observed_order(h: &[f64], errors: &[f64]) -> ObservedOrder {
    assert!(
        h.len() >= 2,
        "observed_order needs at least two resolutions, got {}",
        h.len()
    );
    assert_eq!(
        h.len(),
        errors.len(),
        "observed_order: {} spacings but {} errors",
        h.len(),
        errors.len()
    );
    for (&hi, &ei) in h.iter().zip(errors) {
        assert!(
            hi > 0.0 && ei > 0.0,
            "observed_order: spacing {hi} and error {ei} must be positive"
        );
    }
    let x: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let y: Vec<f64> = errors.iter().map(|v| v.ln()).collect();
    let points: Vec<(f64, f64)> = x.iter().copied().zip(y.iter().copied()).collect();
    let line = linear_fit(&points).expect("observed_order: spacings must differ");
    let rates = (1..x.len())
        .map(|i| (y[i - 1] - y[i]) / (x[i - 1] - x[i]))
        .collect();
    ObservedOrder {
        h: h.to_vec(),
        error: errors.to_vec(),
        order: line.slope,
        rates,
    }
}

impl fmt::Display for ObservedOrder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{:>12} {:>12} {:>8}", "h", "error", "rate")?;
        for i in 0..self.h.len() {
            let rate = if i == 0 {
                "-".to_string()
            } else {
                format!("{:.3}", self.rates[i - 1])
            };
            writeln!(
                f,
                "{:>12.5e} {:>12.5e} {:>8}",
                self.h[i], self.error[i], rate
            )?;
        }
        write!(f, "least-squares order: {:.3}", self.order)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_power_law() {
        let h = [0.1, 0.05, 0.025, 0.0125];
        let e: Vec<f64> = h.iter().map(|h: &f64| 3.0 * h.powf(2.0)).collect();
        let o = observed_order(&h, &e);
        assert!((o.order - 2.0).abs() < 1e-12);
        assert!(o.rates.iter().all(|r| (r - 2.0).abs() < 1e-12));
        assert!(o.to_string().contains("least-squares order: 2.000"));
    }

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
