//! Every instruction set this CPU has against the scalar build, bit for
//! bit, and the scalar build against the reference point by point.

use glam::Vec3;

use super::*;
use crate::advection::{departure_point, Backtrace};
use crate::domain::Domain;
use crate::grid::face::BoxKind;
use crate::grid::{FaceGrid, Interpolant, ScalarGrid};

/// A rough deterministic velocity (a hash of the face index in `[−s, s]`):
/// at `s` of a few cells per step many departure points cross the
/// periodic seam or the walls, and at tens of cells some lie more than a
/// period outside.
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

/// A smooth swirl plus a drift, `s` cells per unit time at most.
fn smooth(d: Domain, kind: BoxKind, s: f32) -> FaceGrid {
    struct Swirl(f32);
    impl crate::field::VectorField for Swirl {
        fn eval(&self, p: Vec3) -> Vec3 {
            self.0
                * Vec3::new(
                    (2.0 * p.y).sin() + 0.3,
                    (1.5 * p.z).cos(),
                    (p.x + p.y).sin(),
                )
        }
    }
    FaceGrid::from_field(d, kind, &Swirl(s))
}

/// Gases with values from a hash of the cell index.
fn gases(d: Domain, n: usize) -> Vec<ScalarGrid> {
    (0..n)
        .map(|g| {
            let mut s = ScalarGrid::zeros(d);
            for (i, v) in s.as_slice_mut().iter_mut().enumerate() {
                let h = ((i * 7 + g * 131) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
                *v = h as f32 / (1u64 << 24) as f32;
            }
            s
        })
        .collect()
}

/// The bits of `x`, every NaN as one: Rust leaves the sign and payload of
/// an arithmetic NaN unspecified (LLVM may move a negation onto one), and
/// ARM's default NaN is positive where x86's is negative, so only numbers
/// are compared to the bit.
fn key(x: f32) -> u32 {
    if x.is_nan() {
        f32::NAN.to_bits()
    } else {
        x.to_bits()
    }
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|&x| key(x)).collect()
}

fn vec_bits(v: &[Vec3]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.to_array().map(key)).collect()
}

/// Boxes whose rows are as long as four lanes, shorter than eight and sixteen, not
/// a multiple of them, and longer; each velocity read through every
/// interpolant.
fn cases() -> Vec<(Domain, BoxKind, FaceGrid)> {
    let mut out = vec![];
    for dims in [[4, 4, 4], [5, 6, 4], [12, 7, 5], [21, 9, 6], [37, 5, 4]] {
        for kind in BoxKind::ALL {
            let d = Domain::new(Vec3::ZERO, 0.5, dims).unwrap();
            out.push((d, kind, rough(d, kind, 0.8)));
            out.push((d, kind, smooth(d, kind, 1.5)));
        }
    }
    // Departure points more than a period outside (the reference's lanes).
    let d = Domain::new(Vec3::ZERO, 0.5, [17, 5, 4]).unwrap();
    out.push((d, BoxKind::Periodic, rough(d, BoxKind::Periodic, 60.0)));
    out.into_iter()
        .flat_map(|(d, kind, vel)| {
            Interpolant::ALL.map(|i| (d, kind, vel.clone().with_interpolant(i)))
        })
        .collect()
}

#[test]
fn every_width_gives_the_scalar_bits_for_every_sweep_backtrace_and_gas_count() {
    let isas = Isa::available();
    assert!(isas.len() > 1 || cfg!(not(any(target_arch = "x86_64", target_arch = "aarch64"))));
    for (d, kind, vel) in cases() {
        let dt = 0.2;
        for bt in Backtrace::ALL {
            let what = format!("{:?} {kind} {} {bt:?}", d.dims, vel.interpolant());
            // advect_faces
            let faces: Vec<_> = isas
                .iter()
                .map(|isa| {
                    let mut out = FaceGrid::zeros(d, kind);
                    isa.advect_faces(&vel, &vel, dt, bt, &mut out);
                    (0..3).map(|a| bits(out.slice(a))).collect::<Vec<_>>()
                })
                .collect();
            for (isa, f) in isas.iter().zip(&faces) {
                assert!(f == &faces[0], "{what}: advect_faces on {isa}");
            }
            // advect_fused with 1, 2, 3 and 5 gases
            for n in [1, 2, 3, 5] {
                let src = gases(d, n);
                let srcs: Vec<&ScalarGrid> = src.iter().collect();
                let runs: Vec<_> = isas
                    .iter()
                    .map(|isa| {
                        let mut dst = gases(d, n);
                        let mut dsts: Vec<&mut ScalarGrid> = dst.iter_mut().collect();
                        let mut out = FaceGrid::zeros(d, kind);
                        isa.advect_fused(&vel, dt, bt, &srcs, &mut dsts, &mut out);
                        let v: Vec<_> = (0..3).map(|a| bits(out.slice(a))).collect();
                        let g: Vec<_> = dst.iter().map(|g| bits(g.as_slice())).collect();
                        (v, g)
                    })
                    .collect();
                for (isa, r) in isas.iter().zip(&runs) {
                    assert!(r == &runs[0], "{what}, {n} gases: advect_fused on {isa}");
                }
                // The fused faces are advect_faces'.
                assert!(runs[0].0 == faces[0], "{what}: fused faces");
            }
            // advect_scalar and the departures
            let src = &gases(d, 1)[0];
            let runs: Vec<_> = isas
                .iter()
                .map(|isa| {
                    let mut dst = ScalarGrid::zeros(d);
                    isa.advect_scalar(src, &vel, dt, bt, &mut dst);
                    let mut dep = crate::advection::Departures::new(d);
                    isa.trace_departures(&mut dep, &vel, dt, bt);
                    (bits(dst.as_slice()), vec_bits(dep.points()))
                })
                .collect();
            for (isa, r) in isas.iter().zip(&runs) {
                assert!(r == &runs[0], "{what}: advect_scalar / departures on {isa}");
            }
            // Arbitrary points: departure_points, wrapped or not.
            let pts = points(d.dims);
            for into_box in [None, Some(d.dims)] {
                let runs: Vec<_> = isas
                    .iter()
                    .map(|isa| {
                        let mut g = pts.clone();
                        let v = Vel::new(vel.sampler());
                        super::points(*isa, (&v, dt / d.cell, bt), &mut g, into_box);
                        vec_bits(&g)
                    })
                    .collect();
                for (isa, r) in isas.iter().zip(&runs) {
                    assert!(
                        r == &runs[0],
                        "{what}: departure points ({into_box:?}) on {isa}"
                    );
                }
            }
        }
    }
}

/// Points over the box and a cell beyond, its edges, −0, far outside, NaN.
fn points(n: [usize; 3]) -> Vec<Vec3> {
    let mut s = 7u32;
    let mut next = || {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (s >> 8) as f32 / (1 << 24) as f32
    };
    let span = Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32) + 2.0;
    let mut p: Vec<Vec3> = (0..333)
        .map(|_| Vec3::new(next(), next(), next()) * span - 1.0)
        .collect();
    let edges = [-0.5, -0.0, 0.0, n[0] as f32 - 1.0, n[0] as f32 - 0.5];
    for (i, &x) in edges.iter().enumerate() {
        for &y in &edges {
            p.push(Vec3::new(x, y, edges[(i + 2) % edges.len()]));
        }
    }
    p.extend([
        Vec3::new(-40.0, 1.0, 1.0),
        Vec3::new(1.0, 3e9, 1.0),
        Vec3::new(1.0, 1.0, f32::NAN),
        Vec3::splat(f32::INFINITY),
    ]);
    p
}

#[test]
fn the_scalar_build_is_the_reference_point_by_point() {
    for (d, kind, vel) in cases() {
        for bt in Backtrace::ALL {
            let pts = points(d.dims);
            let mut g = pts.clone();
            let dt = 0.3;
            Isa::Scalar.departure_points(&vel, &mut g, dt, bt);
            for (p, q) in pts.iter().zip(&g) {
                let want = departure_point(&vel, *p, dt, bt);
                assert_eq!(
                    want.to_array().map(key),
                    q.to_array().map(key),
                    "{:?} {kind} {bt:?} at {p}",
                    d.dims
                );
            }
        }
    }
}

#[test]
fn sampled_points_and_velocities_agree_on_every_width() {
    for (d, kind, vel) in cases() {
        let pts = points(d.dims);
        let v = Vel::new(vel.sampler());
        let runs: Vec<_> = Isa::available()
            .into_iter()
            .map(|isa| {
                let mut u = vec![Vec3::ZERO; pts.len()];
                velocities(isa, &v, &pts, &mut u);
                let lanes: [Vec<f32>; 3] =
                    std::array::from_fn(|a| pts.iter().map(|p| p[a]).collect());
                let g = &gases(d, 2);
                let mut outs = [vec![0.0; pts.len()], vec![0.0; pts.len()]];
                let [o0, o1] = &mut outs;
                sample(
                    isa,
                    &[g[0].as_slice(), g[1].as_slice()],
                    (d.dims, kind.wrap()),
                    [&lanes[0], &lanes[1], &lanes[2]],
                    &mut [&mut o0[..], &mut o1[..]],
                );
                (vec_bits(&u), bits(&outs[0]), bits(&outs[1]))
            })
            .collect();
        for r in &runs {
            assert!(r == &runs[0], "{:?} {kind}", d.dims);
        }
        // The scalar build's velocities are the point query's.
        for (p, u) in pts.iter().zip(&runs[0].0) {
            let want = vel.sampler().at(*p).to_array().map(key);
            assert_eq!(&want, u, "{:?} {kind} at {p}", d.dims);
        }
    }
}

#[test]
#[allow(clippy::needless_range_loop)] // (i, j, k) index the query and the rows alike
fn row_start_velocities_are_the_point_query_at_faces_and_cells() {
    for (d, kind, vel) in cases() {
        let v = Vel::new(vel.sampler());
        let s = vel.sampler();
        let mut u0: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; 64]);
        for k in 0..d.dims[2] {
            for j in 0..d.dims[1] {
                cell_row_velocities(&v, (j, k), &mut u0);
                for i in 0..d.dims[0] {
                    let want = s.at_cell([i, j, k]).to_array().map(f32::to_bits);
                    let got = [0, 1, 2].map(|a| u0[a][i].to_bits());
                    assert_eq!(want, got, "{:?} {kind} cell {i} {j} {k}", d.dims);
                }
            }
        }
        fn faces<const A: usize>(v: &Vel, u0: &mut [Vec<f32>; 3]) {
            let l = v.dims[A];
            for k in 0..l[2] {
                for j in 0..l[1] {
                    face_row_velocities::<A>(v, (j, k), u0);
                    for i in 0..l[0] {
                        let want = v.sampler.at_face(A, [i, j, k]).to_array().map(f32::to_bits);
                        let got = [0, 1, 2].map(|a| u0[a][i].to_bits());
                        assert_eq!(want, got, "component {A}, face {i} {j} {k}");
                    }
                }
            }
        }
        faces::<0>(&v, &mut u0);
        faces::<1>(&v, &mut u0);
        faces::<2>(&v, &mut u0);
    }
}

#[test]
fn an_unavailable_instruction_set_panics_with_its_name() {
    let Some(isa) = Isa::ALL.into_iter().find(|i| !i.is_available()) else {
        return;
    };
    let d = Domain::cube(4, 1.0).unwrap();
    let vel = FaceGrid::zeros(d, BoxKind::Periodic);
    let err = std::panic::catch_unwind(|| {
        let mut g = vec![Vec3::ZERO; 3];
        isa.departure_points(&vel, &mut g, 0.1, Backtrace::Euler);
    })
    .unwrap_err();
    let msg = err
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| err.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default();
    assert!(
        msg.contains("AVX") || msg.contains("neon") || msg.contains("architecture"),
        "{msg}"
    );
}
