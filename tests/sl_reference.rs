//! The semi-Lagrangian sweeps against the implementation they replaced.
//!
//! `advect_faces` and `Departures::trace` take an unwrapped fast path for
//! stencils inside the lattice (`FaceSampler::component_of`,
//! `FaceSampler::at_face`). The reference below is the previous code: every
//! query through the general wrapping or clamping [`Stencil`], every face
//! velocity through the wrapping four-face average. Velocities large enough
//! that many departure points cross the periodic seam or the walls exercise
//! both paths. The face sweep (its vector kernels included) must give the
//! reference's bits; the departure points agree to 1e-6 of the largest speed.
//! With RK2 the faces are traced by the mean of their two cells' midpoint
//! displacements ([`Backtrace::Rk2`]), which the reference computes from
//! its own point queries.
//!
//! Each test runs on every kernel width the CPU has (`common::on_every_isa`:
//! scalar, then NEON or AVX2 and AVX-512F), on a box whose rows are shorter
//! than sixteen (the AVX2 kernels, eight lanes) and one whose rows are
//! longer (the sixteen-lane kernels: the velocities at faces and cells by
//! vector loads in every row, those at the box's faces from wrapped or
//! clamped neighbour rows; stencils near them wrapped or clamped in the
//! lanes).

use glam::Vec3;
use smokelab::advection::{
    advect_faces, advect_fused, advect_scalar, departure_point, Backtrace, Departures,
};
use smokelab::domain::Domain;
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid, Stencil};

mod common;
use common::on_every_isa;

/// A rough deterministic velocity: a hash of the face index, in `[−s, s]`.
fn rough(d: Domain, kind: BoxKind, s: f32) -> FaceGrid {
    let mut vel = FaceGrid::zeros(d, kind);
    for a in 0..3 {
        for (n, v) in vel.slice_mut(a).iter_mut().enumerate() {
            let h = (n as u64 + 1 + 1000 * a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
            *v = s * (2.0 * (h as f32 / (1u64 << 24) as f32) - 1.0);
        }
    }
    vel.zero_walls();
    vel
}

/// The previous `FaceSampler::component_of`: `data` on component `a`'s
/// lattice at cell-centre grid coordinates `g`, through the general stencil.
fn component_ref(vel: &FaceGrid, a: usize, data: &[f32], mut g: Vec3) -> f32 {
    g[a] += 0.5;
    Stencil::new(g, vel.face_dims(a), vel.kind().wrap()).apply(data)
}

/// The previous `FaceSampler::at`.
fn at_ref(vel: &FaceGrid, g: Vec3) -> Vec3 {
    Vec3::from_array(std::array::from_fn(|b| {
        component_ref(vel, b, vel.slice(b), g)
    }))
}

/// The previous `FaceSampler::at_face`: the face's own value, and each other
/// component the mean of its four faces around, wrapped or clamped.
fn at_face_ref(vel: &FaceGrid, a: usize, f: [usize; 3]) -> Vec3 {
    let index = |d: [usize; 3], c: [usize; 3]| (c[2] * d[1] + c[1]) * d[0] + c[0];
    Vec3::from_array(std::array::from_fn(|b| {
        if b == a {
            return vel.slice(a)[index(vel.face_dims(a), f)];
        }
        let d = vel.face_dims(b);
        let n = d[a];
        let (a0, a1) = match vel.kind() {
            BoxKind::Periodic => (if f[a] == 0 { n - 1 } else { f[a] - 1 }, f[a]),
            BoxKind::Closed => (f[a].saturating_sub(1).min(n - 1), f[a].min(n - 1)),
        };
        let b1 = if f[b] + 1 < d[b] { f[b] + 1 } else { 0 };
        let mut sum = 0.0;
        for pa in [a0, a1] {
            for pb in [f[b], b1] {
                let mut p = f;
                p[a] = pa;
                p[b] = pb;
                sum += vel.slice(b)[index(d, p)];
            }
        }
        0.25 * sum
    }))
}

/// The previous departure arithmetic.
fn departure_ref(vel: &FaceGrid, c: Vec3, u0: Vec3, dt: f32, bt: Backtrace) -> Vec3 {
    match bt {
        Backtrace::Euler => c - dt * u0,
        Backtrace::Rk2 => c - dt * at_ref(vel, c - 0.5 * dt * u0),
        Backtrace::Rk3 => {
            let k1 = -dt * u0;
            let k2 = -dt * at_ref(vel, c + 0.5 * k1);
            let k3 = -dt * at_ref(vel, c - k1 + 2.0 * k2);
            c + (k1 + 4.0 * k2 + k3) / 6.0
        }
        Backtrace::Exact => unreachable!("the exact path has its own tests (advection::pollock)"),
    }
}

/// The velocity at the centre of cell `c`: each component the mean of the
/// cell's two faces (the upper wrapping to the first in a periodic box).
fn at_cell_ref(vel: &FaceGrid, c: [usize; 3]) -> Vec3 {
    let index = |d: [usize; 3], c: [usize; 3]| (c[2] * d[1] + c[1]) * d[0] + c[0];
    Vec3::from_array(std::array::from_fn(|a| {
        let d = vel.face_dims(a);
        let mut hi = c;
        hi[a] = (c[a] + 1) % d[a];
        0.5 * (vel.slice(a)[index(d, c)] + vel.slice(a)[index(d, hi)])
    }))
}

/// Face `f` of component `a`'s departure point as the RK2 sweep defines
/// it: `x_f − ½(d_lo + d_hi)`, the displacements `d = Δt u(x − ½Δt u(x))`
/// of the two cells the face separates along `a` (periodic: the first
/// face's lower cell the last; a closed box's wall faces: the one cell
/// inside, twice).
fn shared_rk2_ref(vel: &FaceGrid, a: usize, f: [usize; 3], dt: f32) -> Vec3 {
    let n = vel.domain().dims[a];
    let (mut lo, mut hi) = (f, f);
    match vel.kind() {
        BoxKind::Periodic => lo[a] = (f[a] + n - 1) % n,
        BoxKind::Closed => {
            lo[a] = f[a].saturating_sub(1);
            hi[a] = f[a].min(n - 1);
        }
    }
    let disp = |c: [usize; 3]| {
        let x = Vec3::from_array(c.map(|x| x as f32));
        dt * at_ref(vel, x - 0.5 * dt * at_cell_ref(vel, c))
    };
    let mut x = Vec3::from_array(f.map(|x| x as f32));
    x[a] -= 0.5;
    x - 0.5 * (disp(lo) + disp(hi))
}

const CASES: [(BoxKind, f32); 4] = [
    (BoxKind::Periodic, 0.3),
    (BoxKind::Periodic, 4.0),
    (BoxKind::Closed, 0.3),
    (BoxKind::Closed, 4.0),
];

/// Every case on boxes of each of `dims` (unit cells).
fn boxes(dims: [[usize; 3]; 2]) -> impl Iterator<Item = (Domain, (BoxKind, f32))> {
    dims.into_iter().flat_map(|n| {
        let d = Domain::new(Vec3::ZERO, 1.0, n).unwrap();
        CASES.into_iter().map(move |case| (d, case))
    })
}

#[test]
fn face_advection_matches_the_general_stencil() {
    on_every_isa(|isa| {
        for (d, (kind, speed)) in boxes([[13, 9, 8], [37, 9, 8]]) {
            let vel = rough(d, kind, speed);
            let src = rough(d, kind, 1.0);
            for bt in Backtrace::INTEGRATORS {
                let mut dst = FaceGrid::zeros(d, kind);
                advect_faces(&src, &vel, 0.7, bt, &mut dst);
                for a in 0..3 {
                    let [mx, my, mz] = vel.face_dims(a);
                    let got = dst.slice(a);
                    let mut n = 0;
                    for k in 0..mz {
                        for j in 0..my {
                            for i in 0..mx {
                                let mut c = Vec3::new(i as f32, j as f32, k as f32);
                                c[a] -= 0.5;
                                let u0 = at_face_ref(&vel, a, [i, j, k]);
                                let g = match bt {
                                    Backtrace::Rk2 => shared_rk2_ref(&vel, a, [i, j, k], 0.7),
                                    _ => departure_ref(&vel, c, u0, 0.7, bt),
                                };
                                let wall = kind == BoxKind::Closed
                                    && ([i, j, k][a] == 0 || [i, j, k][a] == d.dims[a]);
                                let want = if wall {
                                    0.0
                                } else {
                                    component_ref(&vel, a, src.slice(a), g)
                                };
                                assert!(
                                    got[n].to_bits() == want.to_bits(),
                                    "{isa} {kind} {speed} {bt:?} component {a} face {:?}: {} vs {want}",
                                    [i, j, k],
                                    got[n]
                                );
                                n += 1;
                            }
                        }
                    }
                }
            }
        }
    });
}

#[test]
fn cell_departures_match_the_general_stencil() {
    on_every_isa(|isa| {
        for (d, (kind, speed)) in boxes([[10, 7, 9], [37, 7, 9]]) {
            let vel = rough(d, kind, speed);
            let sampler = vel.sampler();
            for bt in Backtrace::INTEGRATORS {
                let mut dep = Departures::new(d);
                dep.trace(&vel, 0.7, bt);
                for (n, got) in dep.points().iter().enumerate() {
                    let [nx, ny, _] = d.dims;
                    let c = [n % nx, n / nx % ny, n / (nx * ny)];
                    let u0 = sampler.at_cell(c);
                    let want =
                        departure_ref(&vel, Vec3::from_array(c.map(|x| x as f32)), u0, 0.7, bt);
                    assert!(
                        (*got - want).abs().max_element() <= 1e-6 * (1.0 + speed),
                        "{isa} {kind} {speed} {bt:?} cell {c:?}: {got} vs {want}"
                    );
                }
            }
        }
    });
}

/// The fused sweep and `advect_scalar` (departures traced and densities
/// sampled eight cells at a time by the AVX2 kernels where they apply)
/// against one cell at a time through the scalar public API
/// (`departure_point`, then a `Stencil`): the same bits for every density,
/// box kind, speed and backtrace. Rows of 12 and 37 cells exercise full
/// groups of eight or sixteen, the overlapping last group and the box's
/// edges; the fast speed sends many departure points across the seam or
/// into the walls. With sixteen lanes the two densities share each
/// group's corners where every stencil is inside, and fall back one by one
/// where not.
#[test]
fn fused_densities_match_the_scalar_sweep_to_the_bit() {
    on_every_isa(|isa| {
        for (d, (kind, speed)) in boxes([[12, 11, 10], [37, 11, 10]]) {
            let vel = rough(d, kind, speed);
            let densities: Vec<ScalarGrid> = (0..2)
                .map(|m| {
                    let mut g = ScalarGrid::zeros(d).with_wrap(kind.wrap());
                    let face = rough(d, kind, 1.0 + m as f32);
                    g.as_slice_mut().copy_from_slice(&face.slice(0)[..d.len()]);
                    g
                })
                .collect();
            for bt in Backtrace::INTEGRATORS {
                let srcs: Vec<&ScalarGrid> = densities.iter().collect();
                let mut fused: Vec<ScalarGrid> = densities.clone();
                let mut dsts: Vec<&mut ScalarGrid> = fused.iter_mut().collect();
                let mut vel_out = FaceGrid::zeros(d, kind);
                advect_fused(&vel, 0.7, bt, &srcs, &mut dsts, &mut vel_out);
                for (src, got) in densities.iter().zip(&fused) {
                    let mut unfused = src.clone();
                    advect_scalar(src, &vel, 0.7, bt, &mut unfused);
                    let [nx, ny, _] = d.dims;
                    let want = |n: usize| {
                        let c = Vec3::new(
                            (n % nx) as f32,
                            (n / nx % ny) as f32,
                            (n / (nx * ny)) as f32,
                        );
                        let g = departure_point(&vel, c, 0.7 / d.cell, bt);
                        Stencil::new(g, d.dims, src.wrap()).apply(src.as_slice())
                    };
                    for (name, got) in [("fused", got), ("unfused", &unfused)] {
                        let differ = (got.as_slice().iter().enumerate())
                            .filter(|&(n, v)| v.to_bits() != want(n).to_bits())
                            .count();
                        assert_eq!(
                            differ, 0,
                            "{isa} {name} {kind} {speed} {bt:?}: {differ} cells differ"
                        );
                    }
                }
            }
        }
    });
}
