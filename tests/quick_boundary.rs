//! QUICK advection (order, stability, limiter) and level-set obstacles with
//! the reflecting (eq 6.6) and sticky (eq 6.7) rules, up to the slab-box run.

use glam::Vec3;
use smokelab::advection::{self, quick, Backtrace, Limiter, QuickOptions};
use smokelab::convergence::observed_order;
use smokelab::domain::Domain;
use smokelab::field::{ops, ScalarField};
use smokelab::grid::{ScalarGrid, VectorGrid};

/// A smooth periodic profile on the unit square (constant along z).
struct Smooth(Vec3);

impl ScalarField for Smooth {
    fn eval(&self, p: Vec3) -> f32 {
        let tau = std::f32::consts::TAU;
        let q = p - self.0;
        ((tau * q.x).sin() + 0.5 * (tau * q.y).cos()).exp()
    }
}

/// Max-norm error after advecting `Smooth` once around the unit square in x
/// (half-way in y) at Courant number `cfl` (per unit speed), with QUICK or SL.
fn smooth_error(n: usize, cfl: f32, scheme: advection::Scheme) -> (f64, f64) {
    let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, n, 4]).unwrap();
    let u = Vec3::new(1.0, 0.5, 0.0);
    let dt = cfl * d.cell;
    let steps = (1.0 / dt).round() as usize;
    let vel = VectorGrid::from_field(d, &*ops::constant_vector(u));
    let mut q = ScalarGrid::from_field(d, &Smooth(Vec3::ZERO));
    let exact = ScalarGrid::from_field(d, &Smooth(u * (steps as f32 * dt)));
    let mut tmp = ScalarGrid::zeros(d);
    let mut quick = quick::Quick::new(d, QuickOptions::default());
    let mut dep = advection::Departures::new(d);
    quick.prepare(&vel, dt).unwrap();
    dep.trace(&vel, dt, Backtrace::Rk2);
    for _ in 0..steps {
        match scheme {
            advection::Scheme::Quick => quick.advect_scalar(&q, &mut tmp, Limiter::None),
            advection::Scheme::Sl => advection::interpolate_scalar(&q, &dep, &mut tmp),
        }
        std::mem::swap(&mut q, &mut tmp);
    }
    let e = q
        .as_slice()
        .iter()
        .zip(exact.as_slice())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    (d.cell as f64, e as f64)
}

/// QUICK's phase error is θ³/24 per cell for a mode θ = kΔx, its damping θ⁴/16,
/// and SSP-RK3 is third order: at a fixed Courant number the error of a
/// smooth profile falls as Δx².
#[test]
fn quick_converges_at_second_order_and_beats_sl() {
    let cfl = 0.5;
    let (mut h, mut err) = (vec![], vec![]);
    println!("{:>5} {:>12} {:>12}", "n", "QUICK", "SL");
    for n in [16usize, 32, 64, 128] {
        let (hq, eq) = smooth_error(n, cfl, advection::Scheme::Quick);
        let (_, es) = smooth_error(n, cfl, advection::Scheme::Sl);
        println!("{n:>5} {eq:>12.4e} {es:>12.4e}");
        assert!(eq < 0.5 * es, "n = {n}: QUICK error {eq} vs SL {es}");
        h.push(hq);
        err.push(eq);
    }
    let fit = observed_order(&h, &err);
    println!("QUICK, Courant number {cfl} per unit speed:\n{fit}");
    assert!(
        (1.8..=2.3).contains(&fit.order),
        "observed order {}",
        fit.order
    );
}
