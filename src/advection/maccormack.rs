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
//! BFECC (back and forth error compensation and correction: Dupont & Liu,
//! J. Comput. Phys. 190, 2003; Kim, Liu, Llamas & Rossignac, "FlowFixer",
//! 2005) takes the same round trip but corrects the *source* and steps
//! once more, `φⁿ⁺¹ = A(φⁿ + ½(φⁿ − φ̂ⁿ))`: three SL steps where MacCormack
//! takes two, also second order in smooth flow. [`Correction`] chooses
//! between them; the clamp (and the fallback to `φ̂ⁿ⁺¹`) is the same.
//!
//! The same steps serve densities at the cell centres (the departure
//! points traced once per step for every density, forwards and backwards:
//! [`Departures`]) and each velocity component on its own faces
//! ([`advect_faces`]), with every [`Backtrace`]; the clamp is one scalar
//! pass over the departure points (rayon over rows). The SL steps run on
//! the sweeps' vector kernels; a MacCormack step costs about twice SL's,
//! a BFECC step three times, plus the clamp's re-trace of the faces.

use rayon::prelude::*;

use super::semi_lagrangian::{advect_faces, interpolate_scalar, Departures, FaceTraces};
use super::Backtrace;
use crate::domain::Domain;
use crate::grid::{FaceGrid, ScalarGrid, Stencil, Wrap};

/// How the round trip's error estimate `½(φⁿ − φ̂ⁿ)` corrects the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Correction {
    /// Selle et al. 2008: added to the forward SL value.
    MacCormack,
    /// Dupont & Liu 2003: added to the source, which is then stepped once
    /// more.
    Bfecc,
}

/// The MacCormack (or BFECC) scheme's per-step scratch: the departure
/// points of the cell centres (forward and backward), the forward and
/// backward velocities and densities. Allocated on first use, then reused.
#[derive(Clone, Debug)]
pub struct MacCormack {
    correction: Correction,
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
    /// The cells' RK2 displacements, for the clamp's face traces.
    disp: Vec<f32>,
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
            disp: vec![],
        }
    }

    fn fits(&self, vel: &FaceGrid) -> bool {
        self.fwd_faces.domain() == vel.domain() && self.fwd_faces.kind() == vel.kind()
    }
}

impl MacCormack {
    /// MacCormack tracing departure points with `backtrace`.
    pub fn new(backtrace: Backtrace) -> Self {
        Self::with_correction(Correction::MacCormack, backtrace)
    }

    /// The scheme correcting by `correction`, tracing with `backtrace`.
    pub fn with_correction(correction: Correction, backtrace: Backtrace) -> Self {
        Self {
            correction,
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
        let mut reverted = step_faces(
            self.correction,
            vel,
            (vel, dt, bt),
            (&mut s.fwd_faces, &mut s.bwd_faces, &mut s.disp),
            vel_out,
        );
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
                reverted += step_scalar(
                    self.correction,
                    src,
                    (&s.forward, &s.backward),
                    (&mut s.fwd, &mut s.bwd),
                    dst,
                );
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

/// `cand`, or `fwd` where `cand` leaves `[lo, hi]`; whether it reverted.
#[inline(always)]
fn clamped(cand: f32, fwd: f32, (lo, hi): (f32, f32)) -> (f32, bool) {
    if cand < lo || cand > hi {
        (fwd, true)
    } else {
        (cand, false)
    }
}

/// `out = base + ½(src − bwd)`, element by element: half the round trip's
/// error added to the forward values (MacCormack) or to the source
/// (BFECC). `bwd` `None`: `out` holds the backward values, overwritten.
fn add_half_error(out: &mut [f32], base: &[f32], src: &[f32], bwd: Option<&[f32]>) {
    const CHUNK: usize = 1 << 14;
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
        let at = c * CHUNK;
        for (i, o) in out.iter_mut().enumerate() {
            let m = at + i;
            let b = bwd.map_or(*o, |b| b[m]);
            *o = base[m] + 0.5 * (src[m] - b);
        }
    });
}

/// One corrected step of the cell-centred `src` into `dst` along the
/// departure points `(forward, backward)`, with `(fwd, bwd)` as scratch:
/// the forward and backward SL steps, the candidate of `correction`, then
/// the clamp — a candidate outside the range of `src` over the corners
/// around its forward departure point reverts to the SL value `fwd`.
/// Returns the number of reverted cells.
fn step_scalar(
    correction: Correction,
    src: &ScalarGrid,
    (forward, backward): (&Departures, &Departures),
    (fwd, bwd): (&mut ScalarGrid, &mut ScalarGrid),
    dst: &mut ScalarGrid,
) -> usize {
    let d = *forward.domain();
    for g in [src.domain(), fwd.domain(), bwd.domain(), dst.domain()] {
        assert_eq!(g, &d, "maccormack: grid on another domain");
    }
    fwd.set_wrap(src.wrap());
    bwd.set_wrap(src.wrap());
    interpolate_scalar(src, forward, fwd);
    interpolate_scalar(fwd, backward, bwd);
    match correction {
        Correction::MacCormack => add_half_error(
            dst.as_slice_mut(),
            fwd.as_slice(),
            src.as_slice(),
            Some(bwd.as_slice()),
        ),
        Correction::Bfecc => {
            add_half_error(bwd.as_slice_mut(), src.as_slice(), src.as_slice(), None);
            interpolate_scalar(bwd, forward, dst);
        }
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
                let (v, back) = clamped(*o, fwd.as_slice()[at + i], range);
                *o = v;
                reverted += back as usize;
            }
            reverted
        })
        .sum()
}

/// One corrected step of the staggered `src` into `dst` through `(vel,
/// dt, backtrace)`, each component on its own faces, with `(fwd, bwd)` as
/// scratch (and `disp` for the cells' RK2 displacements): as
/// [`step_scalar`], the departure points of each row of faces traced again
/// for the clamp as the forward step traced them ([`FaceTraces`]) and the
/// range taken over the corners of the component's own lattice. In a
/// closed box the wall faces stay zero. Returns the number of reverted
/// faces.
fn step_faces(
    correction: Correction,
    src: &FaceGrid,
    (vel, dt, backtrace): (&FaceGrid, f32, Backtrace),
    (fwd, bwd, disp): (&mut FaceGrid, &mut FaceGrid, &mut Vec<f32>),
    dst: &mut FaceGrid,
) -> usize {
    for g in [src, &*fwd, &*bwd, &*dst] {
        assert_eq!(
            g.domain(),
            vel.domain(),
            "maccormack: faces on another domain"
        );
        assert_eq!(g.kind(), vel.kind(), "maccormack: faces in another box");
    }
    advect_faces(src, vel, dt, backtrace, fwd);
    advect_faces(fwd, vel, -dt, backtrace, bwd);
    match correction {
        Correction::MacCormack => {
            for a in 0..3 {
                let (f, s, b) = (fwd.slice(a), src.slice(a), bwd.slice(a));
                add_half_error(dst.slice_mut(a), f, s, Some(b));
            }
        }
        Correction::Bfecc => {
            for a in 0..3 {
                add_half_error(bwd.slice_mut(a), src.slice(a), src.slice(a), None);
            }
            advect_faces(bwd, vel, dt, backtrace, dst);
        }
    }
    let traces = FaceTraces::new(vel, (dt, backtrace), disp);
    let wrap: Wrap = vel.kind().wrap();
    let mut reverted = 0;
    for a in 0..3 {
        let dims = dst.face_dims(a);
        let (data, f) = (src.slice(a), fwd.slice(a));
        reverted += dst
            .slice_mut(a)
            .par_chunks_mut(dims[0])
            .enumerate()
            .map_init(
                || (Vec::with_capacity(dims[0]), [vec![], vec![], vec![]]),
                |(row, mean), (r, out)| {
                    let (j, k) = (r % dims[1], r / dims[1]);
                    traces.row(a, (j, k), row, mean);
                    let at = r * dims[0];
                    let mut reverted = 0;
                    for (i, (o, &p)) in out.iter_mut().zip(row.iter()).enumerate() {
                        // Component a's lattice: faces at integers once ½ is added along a.
                        let mut g = p;
                        g[a] += 0.5;
                        let range = corner_range(&Stencil::new(g, dims, wrap), data);
                        let (v, back) = clamped(*o, f[at + i], range);
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

/// `dst = ` one step of the cell-centred `src` through `vel` over `dt`,
/// corrected by `correction` (allocating; a simulation's step uses
/// [`MacCormack::advect`]).
pub fn corrected_scalar(
    correction: Correction,
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
    let (mut fwd, mut bwd) = (ScalarGrid::zeros(d), ScalarGrid::zeros(d));
    step_scalar(
        correction,
        src,
        (&forward, &backward),
        (&mut fwd, &mut bwd),
        dst,
    );
}

/// `dst = ` one MacCormack step of the cell-centred `src` through `vel`
/// over `dt` (allocating).
pub fn maccormack_scalar(
    src: &ScalarGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    corrected_scalar(Correction::MacCormack, src, vel, dt, backtrace, dst);
}

/// `dst = ` one BFECC step of the cell-centred `src` through `vel` over
/// `dt` (allocating).
pub fn bfecc_scalar(
    src: &ScalarGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    corrected_scalar(Correction::Bfecc, src, vel, dt, backtrace, dst);
}

/// `dst = ` one step of the staggered `src` through `vel` over `dt`, each
/// component on its own faces, corrected by `correction` (allocating).
pub fn corrected_faces(
    correction: Correction,
    src: &FaceGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut FaceGrid,
) {
    let (d, kind) = (*vel.domain(), vel.kind());
    let mut fwd = FaceGrid::zeros(d, kind);
    let mut bwd = FaceGrid::zeros(d, kind);
    step_faces(
        correction,
        src,
        (vel, dt, backtrace),
        (&mut fwd, &mut bwd, &mut vec![]),
        dst,
    );
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
    corrected_faces(Correction::MacCormack, src, vel, dt, backtrace, dst);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::advection::{advect_scalar, departure_point};
    use crate::field::VectorField;
    use crate::grid::BoxKind;
    use glam::Vec3;

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
