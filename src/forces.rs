//! Body forces on the staggered velocity: buoyancy, eq 6.5 of the notes,
//!
//! ```text
//! velocity = advect(velocity, velocity, dt) + dt*gravity*(cold − hot);
//! ```
//!
//! written for any number of gases as `u −= Δt g⃗ b` with `b = Σ lift·ρ`
//! (hot lift +1, cold −1). `b` lives at the cell centres and the velocity
//! on the faces ([`FaceGrid`]), so each face of component `a` gets the mean
//! of the two cells it separates,
//!
//! ```text
//! u_a[f] −= Δt g_a · ½ (b[f − e_a] + b[f])
//! ```
//!
//! (indices wrapped in a periodic box; in a closed box the faces on the
//! walls stay zero). Components along which gravity has no part are not
//! touched. The step ([`add_buoyancy`]) and the field-script engine's
//! `vector * scalarcache` ([`face_force`]) both go through the one stencil
//! here, so the notes' script is the built-in step to the bit.

use glam::Vec3;
use rayon::prelude::*;

use crate::grid::{BoxKind, FaceGrid, ScalarGrid};

/// One gas's share of `b = Σ lift·ρ`: its density at the cell centres and
/// its lift (+1 rises, −1 sinks).
pub type Lifted<'a> = (&'a ScalarGrid, f32);

/// Eq 6.5: `u_a[f] −= Δt g_a · ½ (b[f − e_a] + b[f])` on every face of
/// `velocity`, `b = Σ lift·ρ` over `gases` (module documentation).
///
/// # Panics
/// If a gas's density is on another domain than `velocity`.
pub fn add_buoyancy(velocity: &mut FaceGrid, dt: f32, gravity: Vec3, gases: &[Lifted]) {
    on_faces(velocity, gravity * dt, gases, |u, f| *u -= f);
}

/// The force itself on the faces of a fresh velocity grid: `k_a · ½ (c[f −
/// e_a] + c[f])` on the faces of component `a` — `k = Δt g⃗` and `c = cold −
/// hot` make it the notes' `dt*gravity*(cold − hot)` (the field scripts'
/// `vector * scalarcache`). The box is `c`'s: periodic, or closed (its
/// faces on the walls zero) when `c` is read clamped.
pub fn face_force(k: Vec3, c: &ScalarGrid) -> FaceGrid {
    let kind = match c.wrap() {
        crate::grid::Wrap::Periodic => BoxKind::Periodic,
        crate::grid::Wrap::Clamped => BoxKind::Closed,
    };
    let mut out = FaceGrid::zeros(*c.domain(), kind);
    on_faces(&mut out, k, &[(c, 1.0)], |o, f| *o = f);
    out
}

/// `apply(face, k_a · ½ (b[f − e_a] + b[f]))` on every face of component
/// `a` with `k_a ≠ 0`, then the closed box's wall faces zeroed. `b` is
/// `Σ lift·ρ` folded from −0.0 in gas order (as `Iterator::sum`), found
/// per face row where it is used — each cell row twice, the second time
/// from cache — rather than stored as a grid and read back.
fn on_faces(faces: &mut FaceGrid, k: Vec3, gases: &[Lifted], apply: impl Fn(&mut f32, f32) + Sync) {
    let d = *faces.domain();
    for (rho, _) in gases {
        assert_eq!(rho.domain(), &d, "buoyancy: a density on another domain");
    }
    let [nx, ny, _] = d.dims;
    // `b` along the cell row from linear index `start`, into `out`.
    let lift_row = |start: usize, out: &mut [f32]| {
        out.fill(-0.0);
        for (rho, lift) in gases {
            for (b, r) in out.iter_mut().zip(&rho.as_slice()[start..start + nx]) {
                *b += lift * r;
            }
        }
    };
    for a in 0..3 {
        let ka = k[a];
        if ka == 0.0 {
            continue;
        }
        let (dims, n) = (faces.face_dims(a), d.dims[a]);
        // Linear index of cell (0, j, k).
        let row = |j: usize, k: usize| (k * ny + j) * nx;
        faces
            .slice_mut(a)
            .par_chunks_mut(dims[0] * dims[1])
            .enumerate()
            .for_each_init(
                || (vec![0.0f32; nx], vec![0.0f32; nx]),
                |(lo, hi), (k, slab)| {
                    for (j, out) in slab.chunks_exact_mut(dims[0]).enumerate() {
                        // The cells below and above the faces of row (j, k)
                        // along a, wrapped (periodic); a closed box's wall
                        // faces read a clamped cell and are zeroed below.
                        let (mut below, mut above) = ([j, k], [j, k]);
                        if a > 0 {
                            let (b, c) = (&mut below[a - 1], &mut above[a - 1]);
                            *b = if *b == 0 { n - 1 } else { *b - 1 };
                            *c = (*c).min(n - 1);
                            lift_row(row(below[0], below[1]), lo);
                        }
                        lift_row(row(above[0], above[1]), hi);
                        if a > 0 {
                            for ((u, b), c) in out.iter_mut().zip(&*lo).zip(&*hi) {
                                apply(u, ka * 0.5 * (b + c));
                            }
                        } else {
                            for (i, u) in out.iter_mut().enumerate() {
                                let b = hi[if i == 0 { n - 1 } else { i - 1 }];
                                apply(u, ka * 0.5 * (b + hi[i.min(n - 1)]));
                            }
                        }
                    }
                },
            );
    }
    faces.zero_walls();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;

    /// A box of 6 × 5 × 4 cells of 0.25 at a non-zero origin; gravity on
    /// every axis, so every face component is forced.
    fn setup() -> (Domain, f32, Vec3) {
        let d = Domain::new(Vec3::new(-1.0, 0.5, 2.0), 0.25, [6, 5, 4]).unwrap();
        (d, 0.1, Vec3::new(0.3, -0.7, 1.1))
    }

    /// The density `α + β·x` at the cell centres of `d`, read `kind`'s way.
    fn linear(d: Domain, kind: BoxKind, alpha: f32, beta: Vec3) -> ScalarGrid {
        let mut g = ScalarGrid::zeros(d);
        g.set_wrap(kind.wrap());
        let [nx, ny, _] = d.dims;
        for (n, r) in g.as_slice_mut().iter_mut().enumerate() {
            *r = alpha + beta.dot(d.cell_center(n % nx, n / nx % ny, n / (nx * ny)));
        }
        g
    }

    /// Eq 6.5 by hand for `b = α + β·x`: the face of component `a` at
    /// index `f` lies half a cell below cell `f` along `a`, at `x_f`; an
    /// inner face's two cells average to `b(x_f)` (b is linear); a
    /// periodic seam face (index 0) averages the first and last cells,
    /// whose mean lies mid-box along `a`; a closed box's wall faces are 0.
    /// Returns `Δt g_a b` at the face, in f64 (`None`: a wall face).
    fn by_hand(
        d: Domain,
        kind: BoxKind,
        (alpha, beta): (f32, Vec3),
        (a, f): (usize, [usize; 3]),
        k: Vec3,
    ) -> Option<f64> {
        let n = d.dims[a];
        if kind == BoxKind::Closed && (f[a] == 0 || f[a] == n) {
            return None;
        }
        let h = d.cell as f64;
        let mut x: [f64; 3] = std::array::from_fn(|e| d.origin[e] as f64 + (f[e] as f64 + 0.5) * h);
        x[a] = if f[a] == 0 {
            d.origin[a] as f64 + n as f64 * h / 2.0
        } else {
            d.origin[a] as f64 + f[a] as f64 * h
        };
        let b = alpha as f64 + (0..3).map(|e| beta[e] as f64 * x[e]).sum::<f64>();
        Some(k[a] as f64 * b)
    }

    /// Every face of `faces` against `want(a, face index)`, to a few f32
    /// roundings of the values (the densities and the mean are f32).
    fn check(faces: &FaceGrid, want: impl Fn(usize, [usize; 3]) -> f64, what: &str) {
        for a in 0..3 {
            let l = faces.face_dims(a);
            for (n, &u) in faces.slice(a).iter().enumerate() {
                let f = [n % l[0], n / l[0] % l[1], n / (l[0] * l[1])];
                let w = want(a, f);
                assert!(
                    (u as f64 - w).abs() <= 1e-6 * (1.0 + w.abs()),
                    "{what}: component {a} face {f:?} is {u}, eq 6.5 gives {w}"
                );
            }
        }
    }

    /// A uniform hot gas (0.8, lift +1) and cold gas (0.3, lift −1) on a
    /// fluid at rest: every face gets `−Δt g_a (0.8 − 0.3)`, wall faces of
    /// a closed box 0.
    #[test]
    fn uniform_gases_give_a_uniform_face_force() {
        let (d, dt, g) = setup();
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            let hot = linear(d, kind, 0.8, Vec3::ZERO);
            let cold = linear(d, kind, 0.3, Vec3::ZERO);
            let mut u = FaceGrid::zeros(d, kind);
            add_buoyancy(&mut u, dt, g, &[(&hot, 1.0), (&cold, -1.0)]);
            let n = d.dims;
            check(
                &u,
                |a, f| {
                    let wall = kind == BoxKind::Closed && (f[a] == 0 || f[a] == n[a]);
                    if wall {
                        0.0
                    } else {
                        -(dt as f64) * g[a] as f64 * 0.5
                    }
                },
                &format!("{kind:?}"),
            );
        }
    }

    /// A linear density: each face carries the density at its centre
    /// (the seam's the mid-box value), by hand ([`by_hand`]) — through
    /// the step's `u −= …` on a moving fluid with two gases summing to the
    /// field, and through the scripts' force `k c` alone.
    #[test]
    fn a_linear_density_gives_its_value_at_each_face_centre() {
        let (d, dt, g) = setup();
        let (alpha, beta) = (0.4, Vec3::new(0.9, -0.6, 0.35));
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            // Two gases whose lifted sum is α + β·x: ½(α + β·x) lifting,
            // −½(α + β·x) sinking.
            let half = linear(d, kind, alpha / 2.0, beta / 2.0);
            let neg_half = linear(d, kind, -alpha / 2.0, -beta / 2.0);
            let mut u = FaceGrid::zeros(d, kind);
            for a in 0..3 {
                u.slice_mut(a).fill(1.5);
            }
            u.zero_walls();
            add_buoyancy(&mut u, dt, g, &[(&half, 1.0), (&neg_half, -1.0)]);
            let k = g * dt;
            check(
                &u,
                |a, f| by_hand(d, kind, (alpha, beta), (a, f), k).map_or(0.0, |b| 1.5 - b),
                &format!("step, {kind:?}"),
            );
            let c = linear(d, kind, alpha, beta);
            check(
                &face_force(k, &c),
                |a, f| by_hand(d, kind, (alpha, beta), (a, f), k).unwrap_or(0.0),
                &format!("script force, {kind:?}"),
            );
        }
    }

    /// No gravity along an axis: its faces are left as they were.
    #[test]
    fn an_axis_without_gravity_is_untouched() {
        let (d, dt, _) = setup();
        let rho = linear(d, BoxKind::Periodic, 1.0, Vec3::ONE);
        let mut u = FaceGrid::zeros(d, BoxKind::Periodic);
        u.slice_mut(0).fill(2.0);
        add_buoyancy(&mut u, dt, Vec3::new(0.0, -9.8, 0.0), &[(&rho, 1.0)]);
        assert!(u.slice(0).iter().all(|&v| v == 2.0));
        assert!(u.slice(2).iter().all(|&v| v == 0.0));
        assert!(u.slice(1).iter().all(|&v| v > 0.0));
    }
}
