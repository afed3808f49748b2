//! "Grows linearly" or "stays flat", decided from measured points.
//!
//! A series `(x_i, y_i)` is fitted by least squares, `y ≈ a + b x`; its
//! **relative growth** is the fitted change over the sampled range relative
//! to the mean level, `g = b (x_max − x_min) / |ȳ|`, and its **r²** is
//! `1 − Σ(y − a − b x)² / Σ(y − ȳ)²` (1 for a series that does not vary).
//! With [`Criteria`]:
//!
//! - **linear**: `g ≥ min_growth` and `r² ≥ min_r2` — it grows, and a line
//!   explains it;
//! - **flat**: `|g| ≤ max_flat` — whatever its shape, it changes by less
//!   than that fraction of its level;
//! - **unclear** otherwise (noisy, shrinking, or growing but not on a line).

use serde::Serialize;
use smokelab::fit::{linear_fit, LinearFit};

/// What a series does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Trend {
    /// Grows on a line.
    Linear,
    /// Changes by less than `max_flat` of its level.
    Flat,
    /// Neither.
    Unclear,
}

/// Thresholds of [`classify`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Criteria {
    /// Least relative growth over the range of a linear series.
    pub min_growth: f64,
    /// Least r² of a linear series.
    pub min_r2: f64,
    /// Largest |relative growth| of a flat series.
    pub max_flat: f64,
}

/// The fit of a series and what it says.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Growth {
    /// The least-squares line.
    pub fit: LinearFit,
    /// `b (x_max − x_min) / |ȳ|`.
    pub relative: f64,
    /// Coefficient of determination of the line.
    pub r2: f64,
    /// The verdict under the criteria used.
    pub trend: Trend,
}

/// Fit `points` and classify them; `None` if no line can be fitted (fewer
/// than two distinct x, a non-finite value) or the mean level is zero.
pub fn classify(points: &[(f64, f64)], c: &Criteria) -> Option<Growth> {
    let fit = linear_fit(points)?;
    let n = points.len() as f64;
    let mean = points.iter().map(|p| p.1).sum::<f64>() / n;
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
    if mean == 0.0 {
        return None;
    }
    let relative = fit.slope * (hi - lo) / mean.abs();
    let total: f64 = points.iter().map(|p| (p.1 - mean).powi(2)).sum();
    let residual: f64 = points
        .iter()
        .map(|p| (p.1 - fit.intercept - fit.slope * p.0).powi(2))
        .sum();
    let r2 = if total > 0.0 {
        1.0 - residual / total
    } else {
        1.0
    };
    let trend = if relative >= c.min_growth && r2 >= c.min_r2 {
        Trend::Linear
    } else if relative.abs() <= c.max_flat {
        Trend::Flat
    } else {
        Trend::Unclear
    };
    Some(Growth {
        fit,
        relative,
        r2,
        trend,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    const C: Criteria = Criteria {
        min_growth: 0.2,
        min_r2: 0.95,
        max_flat: 0.05,
    };

    fn series(f: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
        (0..=6).map(|i| (i as f64, f(i as f64))).collect()
    }

    #[test]
    fn synthetic_series_are_told_apart() {
        let mut rng = Pcg64::seed_from_u64(7);
        let mut noise = |amp: f64| amp * (2.0 * rng.random::<f64>() - 1.0);
        // A line from 10 to 16 with 1 % noise: linear, growth ≈ 6/13.
        let line: Vec<_> = series(|x| 10.0 + x)
            .into_iter()
            .map(|(x, y)| (x, y * (1.0 + noise(0.01))))
            .collect();
        let g = classify(&line, &C).unwrap();
        assert_eq!(g.trend, Trend::Linear, "{g:?}");
        assert!((g.fit.slope - 1.0).abs() < 0.1 && g.r2 > 0.99, "{g:?}");
        // A constant with 1 % noise: flat.
        let flat: Vec<_> = series(|_| 50.0)
            .into_iter()
            .map(|(x, y)| (x, y + noise(0.5)))
            .collect();
        assert_eq!(classify(&flat, &C).unwrap().trend, Trend::Flat);
        // Exactly constant: flat, r² = 1 by convention.
        let g = classify(&series(|_| 3.0), &C).unwrap();
        assert_eq!((g.trend, g.r2, g.relative), (Trend::Flat, 1.0, 0.0));
        // Noise of ±50 % around 10: neither.
        let noisy: Vec<_> = series(|_| 10.0)
            .into_iter()
            .map(|(x, y)| (x, y + noise(5.0)))
            .collect();
        let g = classify(&noisy, &C).unwrap();
        assert_ne!(g.trend, Trend::Linear, "{g:?}");
        // A step (flat, then a jump at the end): grows, but r² < 0.95.
        let g = classify(&series(|x| if x < 6.0 { 10.0 } else { 30.0 }), &C).unwrap();
        assert_eq!(g.trend, Trend::Unclear, "{g:?}");
        // Shrinking is not growth.
        assert_eq!(
            classify(&series(|x| 20.0 - x), &C).unwrap().trend,
            Trend::Unclear
        );
        // A line that grows by 3 % of its level over the range is flat.
        assert_eq!(
            classify(&series(|x| 100.0 + 0.5 * x), &C).unwrap().trend,
            Trend::Flat
        );
        // Undefined: one x, or a zero level.
        assert!(classify(&[(1.0, 2.0), (1.0, 3.0)], &C).is_none());
        assert!(classify(&series(|x| x - 3.0), &C).is_none());
    }
}
