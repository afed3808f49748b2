//! The exact backward path through the RT0 velocity, cell by cell
//! (Pollock 1988, *Ground Water* 26(6), "Semianalytical computation of path
//! lines for finite-difference models"): [`super::Backtrace::Exact`].
//!
//! Inside a cell the RT0 interpolant ([`crate::grid::Interpolant::Rt0`]) moves
//! each coordinate on its own: with `s ∈ [0, 1]` the position across the cell
//! along axis `a` and `u_lo`, `u_hi` the velocities of its two `a`-faces,
//!
//! ```text
//! u_a(s) = u_lo + G s,   G = u_hi − u_lo        (per cell: Δx = 1)
//! ```
//!
//! so the backward path `ds/dτ = v(s) = −u_a(s)` has the closed form
//!
//! ```text
//! v(τ) = v₀ e^{−Gτ},   s(τ) = s₀ + v₀ τ φ(−Gτ),   φ(y) = (e^y − 1)/y,
//! ```
//!
//! and it reaches the face `s = 1` (or `0`), where the velocity is `v₁`, at
//!
//! ```text
//! τ = (Δs / v₀) ψ((v₁ − v₀)/v₀),   ψ(x) = ln(1 + x)/x,   Δs = 1 − s₀ (or −s₀),
//! ```
//!
//! when `v₀` and `v₁` have the same sign, and never otherwise (the flow
//! stops before it). The path takes the earliest exit of the three axes,
//! steps into the neighbouring cell with that coordinate on the face, and
//! goes on until its time `Δt` is spent. It is the exact flow map of the
//! piecewise-linear velocity: volume-preserving wherever the cells'
//! compact divergences are zero, and no path crosses a face of zero flux —
//! a closed box's walls, an obstacle's closed faces — however long the step.
//!
//! Paths and exits are in `f64` with the `libm` crate's `expm1` and `log1p`
//! (the same bits on every CPU; the platform's `libm` differs between
//! systems). The path is data-dependent, so every instruction set takes
//! this scalar code for it (`super::kernel`).

use glam::{DVec3, Vec3};

use crate::grid::face::FaceSampler;
use crate::grid::Wrap;

/// Cell crossings one path may take before it stops where it is: far more
/// than a step at the solver's CFL numbers crosses (three per cell of
/// travel at most, one per axis); a bound, so that a degenerate velocity
/// (non-finite faces) cannot loop.
const MAX_CROSSINGS: usize = 1024;

/// `(e^y − 1)/y`, 1 at `y = 0`.
#[inline]
fn phi(y: f64) -> f64 {
    if y == 0.0 {
        1.0
    } else {
        libm::expm1(y) / y
    }
}

/// `ln(1 + x)/x`, 1 at `x = 0` (`x > −1`).
#[inline]
fn psi(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        libm::log1p(x) / x
    }
}

/// The departure point of cell-centre grid coordinates `g` after
/// `dt_cells = Δt/Δx`: `g` carried back along the exact path through the
/// RT0 velocity of `vel`'s faces (module documentation), unwrapped in a
/// periodic box. In a closed box a start outside the box is first moved to
/// its nearest point in it. A non-finite `g` or `dt_cells` comes back as
/// `g`.
pub(crate) fn departure(vel: FaceSampler, g: Vec3, dt_cells: f32) -> Vec3 {
    if !(g.is_finite() && dt_cells.is_finite()) {
        return g;
    }
    let (data, dims, cells, wrap) = vel.parts();
    let g = g.as_dvec3();
    // The cell holding g (its centre ⌊g + ½⌋) and the position across it.
    let mut c = [0i64; 3];
    let mut s = DVec3::ZERO;
    for a in 0..3 {
        let n = cells[a] as i64;
        let mut ca = (g[a] + 0.5).floor() as i64;
        if wrap == Wrap::Clamped {
            ca = ca.clamp(0, n - 1);
        }
        c[a] = ca;
        s[a] = (g[a] + 0.5 - ca as f64).clamp(0.0, 1.0);
    }
    let mut left = dt_cells as f64;
    for _ in 0..MAX_CROSSINGS {
        // The backward velocity v = −u at the cell's faces, and at s.
        let mut lo = DVec3::ZERO;
        let mut hi = DVec3::ZERO;
        let cell: [usize; 3] = std::array::from_fn(|b| c[b].rem_euclid(cells[b] as i64) as usize);
        for a in 0..3 {
            let d = dims[a];
            let at = |p: [usize; 3]| (p[2] * d[1] + p[1]) * d[0] + p[0];
            let mut up = cell;
            up[a] = if cell[a] + 1 < d[a] { cell[a] + 1 } else { 0 };
            lo[a] = -(data[a][at(cell)] as f64);
            hi[a] = -(data[a][at(up)] as f64);
        }
        let grad = hi - lo;
        let v = lo + grad * s;
        // The earliest face the path reaches within the time left.
        let mut exit: Option<(usize, bool)> = None;
        let mut t_exit = left;
        for a in 0..3 {
            let (towards, ds, up) = if v[a] > 0.0 && hi[a] > 0.0 {
                (hi[a], 1.0 - s[a], true)
            } else if v[a] < 0.0 && lo[a] < 0.0 {
                (lo[a], -s[a], false)
            } else {
                continue;
            };
            let t = ds / v[a] * psi((towards - v[a]) / v[a]);
            if t < t_exit {
                t_exit = t;
                exit = Some((a, up));
            }
        }
        for a in 0..3 {
            s[a] = (s[a] + v[a] * t_exit * phi(grad[a] * t_exit)).clamp(0.0, 1.0);
        }
        let Some((a, up)) = exit else { break };
        c[a] += if up { 1 } else { -1 };
        s[a] = if up { 0.0 } else { 1.0 };
        left -= t_exit;
    }
    (DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) - 0.5 + s).as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;
    use crate::grid::{BoxKind, FaceGrid, Interpolant};
    use glam::UVec3;

    fn grid(kind: BoxKind, n: usize, f: impl Fn(usize, Vec3) -> f32) -> FaceGrid {
        let d = Domain::cube(n, n as f32).unwrap();
        let mut vel = FaceGrid::zeros(d, kind).with_interpolant(Interpolant::Rt0);
        for a in 0..3 {
            let fd = vel.face_dims(a);
            for k in 0..fd[2] {
                for j in 0..fd[1] {
                    for i in 0..fd[0] {
                        let mut p = Vec3::new(i as f32, j as f32, k as f32);
                        p[a] -= 0.5;
                        vel.component_mut(a)[[k, j, i]] = f(a, p);
                    }
                }
            }
        }
        vel.zero_walls();
        vel
    }

    #[test]
    fn a_uniform_flow_moves_by_its_displacement_across_cells() {
        let vel = grid(BoxKind::Periodic, 8, |a, _| [1.5, -0.25, 0.5][a]);
        let g = Vec3::new(3.2, 4.1, 0.3);
        let p = departure(vel.sampler(), g, 2.0);
        let want = g - 2.0 * Vec3::new(1.5, -0.25, 0.5);
        assert!((p - want).abs().max_element() < 1e-5, "{p} vs {want}");
    }

    #[test]
    fn a_linear_strain_follows_its_exponential_path() {
        // u = α(x − x₀), v = −α(y − y₀): the path x(τ) = x₀ + (x − x₀) e^{−ατ}
        // backward; RT0 reproduces a component linear along its own axis.
        let (alpha, x0, y0) = (0.3f32, 4.0f32, 4.0f32);
        let vel = grid(BoxKind::Closed, 8, |a, p| match a {
            0 => alpha * (p.x - x0),
            1 => -alpha * (p.y - y0),
            _ => 0.0,
        });
        let g = Vec3::new(5.3, 2.2, 3.0);
        let t = 1.7f32;
        let p = departure(vel.sampler(), g, t);
        let want = Vec3::new(
            x0 + (g.x - x0) * (-alpha * t).exp(),
            y0 + (g.y - y0) * (alpha * t).exp(),
            g.z,
        );
        assert!((p - want).abs().max_element() < 1e-5, "{p} vs {want}");
    }

    #[test]
    fn no_path_leaves_a_closed_box_however_long_the_step() {
        // A swirl in the closed box whose wall faces are zero: every path
        // stays inside, where the midpoint rule's long steps leave it.
        let n = 12;
        let c = Vec3::splat(n as f32 / 2.0 - 0.5);
        let vel = grid(BoxKind::Closed, n, |a, p| {
            let r = p - c;
            match a {
                0 => -r.y,
                1 => r.x,
                _ => 0.3 * (r.x - r.y),
            }
        });
        let top = n as f32 - 0.5;
        for i in 0..200u32 {
            let q = UVec3::new(i % 7, (i / 7) % 11, i % 5).as_vec3() + Vec3::splat(0.37);
            for t in [0.5f32, 3.0, 20.0] {
                let p = departure(vel.sampler(), q, t);
                assert!(
                    p.min_element() >= -0.5 && p.max_element() <= top,
                    "{q} went to {p} over {t}"
                );
            }
        }
    }

    #[test]
    fn a_zero_step_and_a_resting_flow_leave_the_point() {
        let vel = grid(BoxKind::Periodic, 6, |_, _| 0.0);
        let g = Vec3::new(1.25, 2.5, 4.75);
        assert_eq!(departure(vel.sampler(), g, 3.0), g);
        let vel = grid(BoxKind::Periodic, 6, |a, _| [1.0, 2.0, 3.0][a]);
        assert_eq!(departure(vel.sampler(), g, 0.0), g);
    }
}
