//! MacCormack advection (Selle, Fedkiw, Kim, Liu & Rossignac, "An
//! Unconditionally Stable MacCormack Method", J. Sci. Comput. 35, 2008),
//! built from the semi-Lagrangian operator `A` of [`super::semi_lagrangian`]:
//!
//! ```text
//! φ̂ⁿ⁺¹ = A(φⁿ)            forward step: the SL value
//! φ̂ⁿ   = A^R(φ̂ⁿ⁺¹)        backward step: A with −Δt, tracing forwards along u
//! φⁿ⁺¹ = φ̂ⁿ⁺¹ + ½(φⁿ − φ̂ⁿ)  half the round trip's error taken off
//! ```
//!
//! The forward and backward steps err alike, so `½(φⁿ − φ̂ⁿ)` estimates the
//! forward step's error and the corrected value is second order in smooth
//! flow where SL is first (C-1 measures both). The correction can overshoot
//! at discontinuities; as the paper (§4) and mantaflow's `MacCormackClamp`
//! (`clampMode = 2`) do, a corrected value outside `[min, max]` of `φⁿ` over
//! the eight corners of the forward step's trilinear stencil — the values
//! `A` interpolated — is replaced by the SL value `φ̂ⁿ⁺¹`, which lies in
//! that range. So the scheme makes no new extrema, is unconditionally stable
//! like SL, and is not conservative (neither is SL).
//!
//! The same three steps serve densities at the cell centres (the departure
//! points traced once per step for every density, forwards and backwards:
//! [`Departures`]) and each velocity component on its own faces
//! ([`advect_faces`]), with every [`Backtrace`]; the clamp is one scalar
//! pass over the departure points (rayon over rows). The forward and
//! backward steps run on the sweeps' vector kernels; a step costs about
//! twice SL's, plus the clamp's re-trace of the faces.

use glam::Vec3;
use rayon::prelude::*;

use super::semi_lagrangian::{advect_faces, departure_points, interpolate_scalar, Departures};
use super::Backtrace;
use crate::domain::Domain;
use crate::grid::{FaceGrid, ScalarGrid, Stencil, Wrap};

/// The MacCormack scheme's per-step scratch: the departure points of the
/// cell centres (forward and backward), the forward and backward
/// velocities and densities. Allocated on first use, then reused.
#[derive(Clone, Debug)]
pub struct MacCormack {
    backtrace: Backtrace,
    scratch: Option<Box<Scratch>>,
    reverted: usize,
    samples: usize,
}

#[derive(Clone, Debug)]
struct Scratch {
    forward: Departures,
    backward: Departures,
    fwd_faces: FaceGrid,
    bwd_faces: FaceGrid,
    fwd: ScalarGrid,
    bwd: ScalarGrid,
}

impl Scratch {
    fn new(vel: &FaceGrid) -> Self {
        let (d, kind) = (*vel.domain(), vel.kind());
        Self {
            forward: Departures::new(d),
            backward: Departures::new(d),
            fwd_faces: FaceGrid::zeros(d, kind),
            bwd_faces: FaceGrid::zeros(d, kind),
            fwd: ScalarGrid::zeros(d),
            bwd: ScalarGrid::zeros(d),
        }
    }

    fn fits(&self, vel: &FaceGrid) -> bool {
        self.fwd_faces.domain() == vel.domain() && self.fwd_faces.kind() == vel.kind()
    }
}

impl MacCormack {
    /// The scheme tracing departure points with `backtrace`.
    pub fn new(backtrace: Backtrace) -> Self {
        Self {
            backtrace,
            scratch: None,
            reverted: 0,
            samples: 0,
        }
    }

    /// How departure points are traced.
    pub fn backtrace(&self) -> Backtrace {
        self.backtrace
    }

    /// Of the last step's samples (faces and density cells), how many the
    /// clamp reverted to the semi-Lagrangian value, and how many there were.
    pub fn reverted(&self) -> (usize, usize) {
        (self.reverted, self.samples)
    }

    /// One step: `srcs[n]` into `dsts[n]` and `vel` into `vel_out`, all
    /// moved by `vel` over `dt` (eqs 6.4–6.5 without sources and forces).
    ///
    /// # Panics
    /// If a grid is on another domain, or `srcs` and `dsts` differ in length.
    pub fn advect(
        &mut self,
        vel: &FaceGrid,
        dt: f32,
        srcs: &[&ScalarGrid],
        dsts: &mut [&mut ScalarGrid],
        vel_out: &mut FaceGrid,
    ) {
        assert_eq!(
            srcs.len(),
            dsts.len(),
            "maccormack: {} sources but {} targets",
            srcs.len(),
            dsts.len()
        );
        let bt = self.backtrace;
        if !self.scratch.as_ref().is_some_and(|s| s.fits(vel)) {
            self.scratch = Some(Box::new(Scratch::new(vel)));
        }
        let s = self.scratch.as_mut().expect("allocated above");
        advect_faces(vel, vel, dt, bt, &mut s.fwd_faces);
        advect_faces(&s.fwd_faces, vel, -dt, bt, &mut s.bwd_faces);
        let mut reverted = correct_faces(vel, &s.fwd_faces, &s.bwd_faces, (vel, dt, bt), vel_out);
        let mut samples: usize = (0..3).map(|a| vel_out.slice(a).len()).sum();
        if !srcs.is_empty() {
            s.forward.trace(vel, dt, bt);
            s.backward.trace(vel, -dt, bt);
            for (src, dst) in srcs.iter().zip(dsts.iter_mut()) {
                assert_eq!(
                    src.domain(),
                    vel.domain(),
                    "maccormack: density on another domain"
                );
                s.fwd.set_wrap(src.wrap());
                s.bwd.set_wrap(src.wrap());
                interpolate_scalar(src, &s.forward, &mut s.fwd);
                interpolate_scalar(&s.fwd, &s.backward, &mut s.bwd);
                reverted += correct_scalar(src, &s.fwd, &s.bwd, &s.forward, dst);
                samples += src.as_slice().len();
            }
        }
        (self.reverted, self.samples) = (reverted, samples);
    }
}

/// `min` and `max` of `data` over a stencil's corners.
#[inline(always)]
fn corner_range(stencil: &Stencil, data: &[f32]) -> (f32, f32) {
    stencil
        .corners()
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &c| {
            (lo.min(data[c]), hi.max(data[c]))
        })
}

/// The corrected value `fwd + ½(src − bwd)`, or `fwd` where that leaves
/// `[lo, hi]`; whether it reverted.
#[inline(always)]
fn corrected(src: f32, fwd: f32, bwd: f32, (lo, hi): (f32, f32)) -> (f32, bool) {
    let c = fwd + 0.5 * (src - bwd);
    if c < lo || c > hi {
        (fwd, true)
    } else {
        (c, false)
    }
}

/// The correction and clamp at the cell centres: `dst = fwd + ½(src − bwd)`,
/// reverted to `fwd` outside the range of `src` over the corners around
/// each forward departure point. Returns the number of reverted cells.
fn correct_scalar(
    src: &ScalarGrid,
    fwd: &ScalarGrid,
    bwd: &ScalarGrid,
    forward: &Departures,
    dst: &mut ScalarGrid,
) -> usize {
    let d = *forward.domain();
    for g in [src.domain(), fwd.domain(), bwd.domain(), dst.domain()] {
        assert_eq!(g, &d, "maccormack: grid on another domain");
    }
    let (data, wrap, nx) = (src.as_slice(), src.wrap(), d.dims[0]);
    dst.as_slice_mut()
        .par_chunks_mut(nx)
        .zip(forward.points().par_chunks(nx))
        .enumerate()
        .map(|(r, (out, points))| {
            let at = r * nx;
            let mut reverted = 0;
            for (i, (o, &p)) in out.iter_mut().zip(points).enumerate() {
                let range = corner_range(&Stencil::new(p, d.dims, wrap), data);
                let m = at + i;
                let (v, back) = corrected(data[m], fwd.as_slice()[m], bwd.as_slice()[m], range);
                *o = v;
                reverted += back as usize;
            }
            reverted
        })
        .sum()
}

/// The correction and clamp on the faces of each component: as
/// [`correct_scalar`], the departure points of each row of faces traced
/// again through `(vel, dt, backtrace)` ([`departure_points`]) and the
/// range taken over the corners of the component's own lattice. In a
/// closed box the wall faces stay zero. Returns the number of reverted faces.
fn correct_faces(
    src: &FaceGrid,
    fwd: &FaceGrid,
    bwd: &FaceGrid,
    (vel, dt, backtrace): (&FaceGrid, f32, Backtrace),
    dst: &mut FaceGrid,
) -> usize {
    for g in [src, fwd, bwd, &*dst] {
        assert_eq!(
            g.domain(),
            vel.domain(),
            "maccormack: faces on another domain"
        );
        assert_eq!(g.kind(), vel.kind(), "maccormack: faces in another box");
    }
    let dt_cells = dt / vel.domain().cell;
    let wrap: Wrap = vel.kind().wrap();
    let mut reverted = 0;
    for a in 0..3 {
        let dims = dst.face_dims(a);
        let (data, f, b) = (src.slice(a), fwd.slice(a), bwd.slice(a));
        reverted += dst
            .slice_mut(a)
            .par_chunks_mut(dims[0])
            .enumerate()
            .map_init(
                || Vec::with_capacity(dims[0]),
                |row: &mut Vec<Vec3>, (r, out)| {
                    let (j, k) = (r % dims[1], r / dims[1]);
                    row.clear();
                    row.extend((0..dims[0]).map(|i| {
                        let mut g = Vec3::new(i as f32, j as f32, k as f32);
                        g[a] -= 0.5;
                        g
                    }));
                    departure_points(vel, row, dt_cells, backtrace);
                    let at = r * dims[0];
                    let mut reverted = 0;
                    for (i, (o, &p)) in out.iter_mut().zip(row.iter()).enumerate() {
                        // Component a's lattice: faces at integers once ½ is added along a.
                        let mut g = p;
                        g[a] += 0.5;
                        let range = corner_range(&Stencil::new(g, dims, wrap), data);
                        let m = at + i;
                        let (v, back) = corrected(data[m], f[m], b[m], range);
                        *o = v;
                        reverted += back as usize;
                    }
                    reverted
                },
            )
            .sum::<usize>();
    }
    dst.zero_walls();
    reverted
}

/// `dst = ` one MacCormack step of the cell-centred `src` through `vel`
/// over `dt` (allocating; a simulation's step uses [`MacCormack::advect`]).
pub fn maccormack_scalar(
    src: &ScalarGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    let d: Domain = *vel.domain();
    let (mut forward, mut backward) = (Departures::new(d), Departures::new(d));
    forward.trace(vel, dt, backtrace);
    backward.trace(vel, -dt, backtrace);
    let mut fwd = ScalarGrid::zeros(d).with_wrap(src.wrap());
    let mut bwd = ScalarGrid::zeros(d).with_wrap(src.wrap());
    interpolate_scalar(src, &forward, &mut fwd);
    interpolate_scalar(&fwd, &backward, &mut bwd);
    correct_scalar(src, &fwd, &bwd, &forward, dst);
}

/// `dst = ` one MacCormack step of the staggered `src` through `vel` over
/// `dt`, each component on its own faces (allocating).
pub fn maccormack_faces(
    src: &FaceGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut FaceGrid,
) {
    let (d, kind) = (*vel.domain(), vel.kind());
    let mut fwd = FaceGrid::zeros(d, kind);
    let mut bwd = FaceGrid::zeros(d, kind);
    advect_faces(src, vel, dt, backtrace, &mut fwd);
    advect_faces(&fwd, vel, -dt, backtrace, &mut bwd);
    correct_faces(src, &fwd, &bwd, (vel, dt, backtrace), dst);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::advection::{advect_scalar, departure_point};
    use crate::field::VectorField;
    use crate::grid::BoxKind;

    struct Swirl;
    impl VectorField for Swirl {
        fn eval(&self, p: Vec3) -> Vec3 {
            use std::f32::consts::TAU;
            let (x, y, z) = (TAU * p.x / 2.0, TAU * p.y / 2.0, TAU * p.z / 2.0);
            Vec3::new(
                x.sin() * y.cos() + 0.3,
                -x.cos() * y.sin() + 0.2 * z.cos(),
                0.4 * (x + y).sin(),
            )
        }
    }

    fn domain(n: usize) -> Domain {
        Domain::new(Vec3::ZERO, 2.0 / n as f32, [n, n + 3, n - 2]).unwrap()
    }

    fn blob(d: Domain) -> ScalarGrid {
        struct Blob;
        impl crate::field::ScalarField for Blob {
            fn eval(&self, p: Vec3) -> f32 {
                let r2 = (p - Vec3::new(1.0, 0.9, 1.1)).length_squared();
                (-r2 / 0.1).exp() + if r2 < 0.09 { 0.5 } else { 0.0 }
            }
        }
        ScalarGrid::from_field(d, &Blob)
    }

    /// The backward step traces with −Δt through the sweeps' vector
    /// kernels; they must agree with the scalar `departure_point` and
    /// stencil to the bit, as they do forwards.
    #[test]
    fn backward_steps_match_the_scalar_path_bit_for_bit() {
        for kind in BoxKind::ALL {
            let d = domain(24);
            let vel = FaceGrid::from_field(d, kind, &Swirl);
            let q = blob(d).with_wrap(kind.wrap());
            for bt in Backtrace::ALL {
                for dt in [0.05f32, -0.05] {
                    let mut out = ScalarGrid::zeros(d).with_wrap(kind.wrap());
                    advect_scalar(&q, &vel, dt, bt, &mut out);
                    let dep = Departures::new(d);
                    for (m, g) in dep.points().iter().enumerate() {
                        let x = departure_point(&vel, *g, dt / d.cell, bt);
                        let want = Stencil::new(x, d.dims, kind.wrap()).apply(q.as_slice());
                        assert_eq!(out.as_slice()[m], want, "{kind:?} {bt:?} dt {dt} cell {m}");
                    }
                }
            }
        }
    }

    /// No new extrema: every value lies in the range of the initial field,
    /// and a constant stays constant.
    #[test]
    fn the_clamp_makes_no_new_extrema() {
        for kind in BoxKind::ALL {
            let d = domain(20);
            let vel = FaceGrid::from_field(d, kind, &Swirl);
            let mut q = blob(d).with_wrap(kind.wrap());
            let (lo, hi) = q
                .as_slice()
                .iter()
                .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
            let mut tmp = ScalarGrid::zeros(d).with_wrap(kind.wrap());
            for _ in 0..10 {
                maccormack_scalar(&q, &vel, 0.08, Backtrace::Rk2, &mut tmp);
                std::mem::swap(&mut q, &mut tmp);
            }
            // Up to the rounding of the trilinear weights (an SL value is
            // a mean of its corners).
            let slack = 1e-6 * hi.abs().max(lo.abs());
            for &v in q.as_slice() {
                assert!(
                    (lo - slack..=hi + slack).contains(&v),
                    "{kind:?}: {v} outside [{lo}, {hi}]"
                );
            }
            let one =
                ScalarGrid::from_field(d, &crate::field::ops::Constant(1.5)).with_wrap(kind.wrap());
            maccormack_scalar(&one, &vel, 0.08, Backtrace::Rk3, &mut tmp);
            // Trilinear weights sum to one up to f32 rounding.
            let worst = tmp
                .as_slice()
                .iter()
                .fold(0f32, |m, &v| m.max((v - 1.5).abs()));
            assert!(worst <= 5e-7, "{kind:?}: a constant moved by {worst}");
        }
    }

    /// A step edge moving at Courant number `c` in uniform flow: beside the
    /// edge the corrected values overshoot (above 1 behind it, below 0
    /// ahead of it) and revert to SL's, which are 1 and 0 there; the first
    /// cell past the edge gets `c/2 + c²/2` where SL gives `c`. So a sharp
    /// edge moves about half as far as SL moves it in one step.
    #[test]
    fn a_sharp_edge_moves_half_as_far_at_small_courant_numbers() {
        let n = 32;
        let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, 4, 4]).unwrap();
        let c = 0.1f32;
        let vel = FaceGrid::from_field(
            d,
            BoxKind::Periodic,
            &crate::field::ops::ConstantVector(Vec3::X),
        );
        let mut q = ScalarGrid::zeros(d);
        for (m, v) in q.as_slice_mut().iter_mut().enumerate() {
            *v = ((m % n) < n / 2) as u8 as f32;
        }
        let mut out = ScalarGrid::zeros(d);
        maccormack_scalar(&q, &vel, c * d.cell, Backtrace::Rk2, &mut out);
        let row = &out.as_slice()[..n];
        let edge = n / 2;
        assert!(
            (row[edge] - (c / 2.0 + c * c / 2.0)).abs() < 1e-6,
            "{}",
            row[edge]
        );
        assert_eq!(row[edge - 1], 1.0);
        assert_eq!(row[edge + 1], 0.0);
        // The trailing edge (0 → 1 at cell 0) likewise: 1 − c/2 − c²/2.
        assert!(
            (row[0] - (1.0 - c / 2.0 - c * c / 2.0)).abs() < 1e-6,
            "{}",
            row[0]
        );
        assert_eq!(row[n - 1], 0.0);
    }

    /// The faces: a uniform velocity moves itself (every face equal up to
    /// the rounding of the trilinear weights), and the step through `MacCormack::advect` equals the
    /// allocating one; closed-box walls stay zero.
    #[test]
    fn faces_keep_a_uniform_flow_and_the_stepper_matches_the_functions() {
        let d = domain(16);
        let uniform = FaceGrid::from_field(
            d,
            BoxKind::Periodic,
            &crate::field::ops::ConstantVector(Vec3::new(0.7, -0.3, 0.2)),
        );
        let mut out = FaceGrid::zeros(d, BoxKind::Periodic);
        maccormack_faces(&uniform, &uniform, 0.1, Backtrace::Rk2, &mut out);
        for a in 0..3 {
            let worst = out
                .slice(a)
                .iter()
                .zip(uniform.slice(a))
                .fold(0f32, |m, (x, y)| m.max((x - y).abs()));
            assert!(worst <= 1e-7, "component {a}: off by {worst}");
        }
        for kind in BoxKind::ALL {
            let vel = FaceGrid::from_field(d, kind, &Swirl);
            let q = blob(d).with_wrap(kind.wrap());
            let mut mc = MacCormack::new(Backtrace::Rk3);
            let (mut v1, mut q1) = (FaceGrid::zeros(d, kind), ScalarGrid::zeros(d));
            mc.advect(&vel, 0.07, &[&q], &mut [&mut q1], &mut v1);
            let (mut v2, mut q2) = (FaceGrid::zeros(d, kind), ScalarGrid::zeros(d));
            maccormack_faces(&vel, &vel, 0.07, Backtrace::Rk3, &mut v2);
            maccormack_scalar(&q, &vel, 0.07, Backtrace::Rk3, &mut q2);
            assert_eq!(q1.as_slice(), q2.as_slice());
            for a in 0..3 {
                assert_eq!(v1.slice(a), v2.slice(a));
            }
            let mut walls = v1.clone();
            walls.zero_walls();
            for a in 0..3 {
                assert_eq!(walls.slice(a), v1.slice(a), "{kind:?}: a wall face moved");
            }
            let (reverted, samples) = mc.reverted();
            assert!(reverted < samples / 4, "{reverted} of {samples} reverted");
        }
    }
}
