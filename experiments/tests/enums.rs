//! Every scheme enum's `ALL` (what the library's tests loop over) is exactly
//! the set the command line offers, in the same order, and every name parses
//! back to its variant.

use clap::ValueEnum;
use smokelab::advection::quick::Limiter;
use smokelab::advection::{Backtrace, Scheme};
use smokelab::boundary::BoundaryRule;
use smokelab::density::DensityMode;
use smokelab::noise::curl::FdScheme;
use smokelab::noise::NoiseKind;
use smokelab::render::output::ExrPrecision;
use smokelab::scenario::ScenarioKind;

fn check<T: ValueEnum + PartialEq + std::fmt::Debug + Clone>(all: &[T]) {
    assert_eq!(
        all,
        T::value_variants(),
        "ALL differs from the CLI's variants"
    );
    for v in all {
        let name = v.to_possible_value().expect("not hidden");
        assert_eq!(T::from_str(name.get_name(), false).as_ref(), Ok(v));
    }
}

#[test]
fn every_all_matches_the_command_line() {
    check(&Backtrace::ALL);
    check(&Scheme::ALL);
    check(&Limiter::ALL);
    check(&DensityMode::ALL);
    check(&BoundaryRule::ALL);
    check(NoiseKind::ALL);
    for k in NoiseKind::ALL {
        assert_eq!(k.to_possible_value().unwrap().get_name(), k.name());
    }
    check(&FdScheme::ALL);
    check(&ScenarioKind::ALL);
    check(&ExrPrecision::ALL);
}
