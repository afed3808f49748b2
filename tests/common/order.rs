//! The one convergence assertion of every test suite (the library's `tests/`
//! and the application's `experiments/tests/`, which includes this file by
//! path): fit the observed order by least squares
//! ([`smokelab::fit::observed_order`]), print the table, and assert the
//! order within a band around the scheme's.

use smokelab::fit::{observed_order, ObservedOrder};

/// Fit the observed order of `errors` against `h`, print the table under
/// `label`, and assert `|order − expected| ≤ band`.
pub fn assert_order(
    label: &str,
    h: &[f64],
    errors: &[f64],
    expected: f64,
    band: f64,
) -> ObservedOrder {
    let fit = observed_order(h, errors);
    println!("{label}:\n{fit}");
    assert!(
        (fit.order - expected).abs() <= band,
        "{label}: observed order {:.3}, expected {expected} ± {band}\n{fit}",
        fit.order
    );
    fit
}
