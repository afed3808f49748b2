//! Observed order of accuracy — the one helper every convergence test uses.
//!
//! Given grid spacings `h_i` and errors `e_i`, the observed order is the
//! least-squares slope of `log e` against `log h`; the pairwise rates
//! `log(e_i/e_{i+1}) / log(h_i/h_{i+1})` show whether the asymptotic regime
//! has been reached (STYLE.md, after Oceananigans).
//!
//! [`cases`] holds the studies themselves, each against an exact solution and
//! refined at a fixed CFL number; the tests run them at small sizes and
//! experiment C-1 at larger ones.

pub mod cases;

use std::fmt;

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
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let rates = (1..x.len())
        .map(|i| (y[i - 1] - y[i]) / (x[i - 1] - x[i]))
        .collect();
    ObservedOrder {
        h: h.to_vec(),
        error: errors.to_vec(),
        order: sxy / sxx,
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
}
