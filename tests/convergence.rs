//! Convergence suite, CI subset: every study fits its observed order by least
//! squares and asserts it within ±0.25 of the expected value (the reason for
//! each expected value is in `smokelab::convergence::cases`). The long
//! versions run with `smokelab experiment C-1`.

use smokelab::advection::Backtrace;
use smokelab::convergence::cases::{self, Study};
use smokelab::projection::Operator;

fn assert_order(study: &Study) {
    let fit = study.fit();
    println!("{}:\n{fit}\n", study.name);
    assert!(
        (fit.order - study.expected).abs() <= 0.25,
        "{}: observed order {:.3}, expected {} ± 0.25",
        study.name,
        fit.order,
        study.expected
    );
}

#[test]
fn semi_lagrangian_uniform_flow_is_first_order() {
    for bt in Backtrace::ALL {
        assert_order(&cases::sl_uniform(bt, &[32, 64, 128, 256]));
    }
}

#[test]
fn semi_lagrangian_rotation_is_first_order() {
    for bt in Backtrace::ALL {
        assert_order(&cases::sl_rotation(bt, &[32, 64, 128]));
    }
}

#[test]
fn taylor_green_navier_stokes_sl_is_first_order() {
    assert_order(&cases::taylor_green_sl(&[16, 32, 64]));
}

#[test]
fn projection_with_discrete_wavenumbers_is_second_order() {
    assert_order(&cases::projection_discrete(&[16, 32, 64]));
}

#[test]
fn spectral_projection_is_exact_for_band_limited_data() {
    for n in [16, 32] {
        let e = cases::projection_error(n, Operator::Spectral);
        println!("spectral projection, n = {n}: rms error {e:.3e}");
        assert!(e <= 1e-5, "spectral projection error {e} at n = {n}");
    }
}
