//! Gridless density — §6.2 and eqs 7.1–7.4 of the notes.
//!
//! The density is never sampled onto a grid during the run. Each step keeps
//! its velocity grid `u_k` (shared between gases, [`Arc`]) and the density
//! after `n` steps is the procedural chain
//!
//! ```text
//! ρ_n(x) = ρ_{n−1}(B_n(x)) + S(x) Δt,        B_k = backtrace through u_k  (eq 7.4 + source)
//! ```
//!
//! evaluated by walking back (DESIGN.md, "Gridless density with sources"):
//!
//! ```text
//! acc = 0
//! for k = n … 1 { acc += S(x) Δt;  x = B_k(x) }
//! acc += ρ₀(x)
//! ```
//!
//! `B_k` is [`crate::advection::departure_point`] — the very backtrace the
//! gridded path uses — so gridless and gridded densities on the same velocity
//! history differ only by the gridded path's per-step resampling. Positions
//! are wrapped into the periodic box after every backtrace, and `S`, `ρ₀` are
//! evaluated at wrapped points (the box is periodic for every field).
//!
//! Cost: memory grows by one velocity grid per step, and so does the cost of
//! every query — including the buoyancy term, which evaluates the density at
//! every velocity cell centre every step, so a run of `n` steps costs
//! `O(n²)` backtraces per cell. Queries are batched: a whole slice of points
//! walks back one step at a time, so each stored grid is streamed once per
//! batch and the source costs one batched call per step.

use crate::density::BackwardMap;
use std::sync::Arc;

use glam::Vec3;

use super::{wrap_grid, Buffer, StepInput};
use crate::advection::{departure_point, Backtrace};
use crate::boundary::WallStop;
use crate::domain::Domain;
use crate::field::{Scalar, ScalarField};
use crate::grid::{FaceGrid, ScalarGrid};

/// One stored step of the velocity history.
#[derive(Clone)]
struct PastStep {
    velocity: Arc<FaceGrid>,
    dt: f32,
    backtrace: Backtrace,
}

impl PastStep {
    /// Move grid coordinates `g` back through this step (its backtrace),
    /// wrapped into the box.
    ///
    /// Eight points at a time go through the AVX2 kernel ([`walk8`]) when
    /// the CPU has it; the points of a group whose stencils leave the
    /// lattices, the remainder and RK3 take [`departure_point`] one by one.
    /// Both do the same floating-point operations in the same order, so the
    /// walk is the same to the bit on any CPU.
    fn walk_back(&self, d: &Domain, g: &mut [Vec3]) {
        let dt_cells = self.dt / d.cell;
        let u = &*self.velocity;
        let one = |p: &mut Vec3| {
            *p = wrap_grid(departure_point(u, *p, dt_cells, self.backtrace), d.dims);
        };
        #[cfg(target_arch = "x86_64")]
        if walk8::usable(u, self.backtrace) {
            let (data, dims) = u.sampler().lattices();
            let mut groups = g.chunks_exact_mut(8);
            for group in &mut groups {
                // SAFETY: `usable` checked AVX2 and the lattice sizes; the
                // slices are the lattices of `dims`.
                let (p, outside) =
                    unsafe { walk8::departures(data, dims, group, dt_cells, self.backtrace) };
                for (l, (gi, pi)) in group.iter_mut().zip(p).enumerate() {
                    if outside & (1 << l) == 0 {
                        *gi = wrap_grid(pi, d.dims);
                    } else {
                        one(gi);
                    }
                }
            }
            groups.into_remainder().iter_mut().for_each(one);
            return;
        }
        g.iter_mut().for_each(one);
    }
}

/// The gridless density as a field: the velocity history, the source and
/// the initial density. Cloning it is cheap (the grids are shared) and the
/// clone is an immutable snapshot.
#[derive(Clone)]
pub struct GridlessField {
    domain: Domain,
    steps: Vec<PastStep>,
    initial: Option<Scalar>,
    source: Option<Scalar>,
    /// Obstacles: the density is zero inside them.
    walls: Option<Arc<WallStop>>,
}

impl GridlessField {
    /// No steps yet: the field is `initial` (zero if `None`), wrapped
    /// periodically into `domain`, the velocity grid's box.
    pub fn new(domain: Domain, initial: Option<Scalar>, source: Option<Scalar>) -> Self {
        Self {
            domain,
            steps: Vec::new(),
            initial,
            source,
            walls: None,
        }
    }

    /// Read zero inside `walls`. Walks are *not* stopped at their surface:
    /// measured, stopping them loses more gas (slab-box 32³, SL, step 100:
    /// 62 % of the injected gas in the fluid cells with the stop, 94 %
    /// without) — a walk stopped on a wall stays in its stagnant flow for
    /// the rest of the history and never reaches the source again.
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        self.walls = Some(walls);
    }

    /// Append one step: advect with `velocity` over `dt`, then inject `S Δt`.
    ///
    /// # Panics
    /// If `velocity` is on another domain.
    pub fn push(&mut self, velocity: Arc<FaceGrid>, dt: f32, backtrace: Backtrace) {
        assert_eq!(
            velocity.domain(),
            &self.domain,
            "gridless: velocity on another domain"
        );
        self.steps.push(PastStep {
            velocity,
            dt,
            backtrace,
        });
    }

    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps.len()
    }

    /// The stored velocity grids, oldest first.
    pub fn velocities(&self) -> impl Iterator<Item = &Arc<FaceGrid>> {
        self.steps.iter().map(|s| &s.velocity)
    }
}

impl BackwardMap for GridlessField {
    /// The backward map of the whole chain, `X_n = B_1 ∘ B_2 ∘ … ∘ B_n`
    /// (eq 7.4 without the source): each world point walked back through
    /// every stored step, newest first, wrapped into the box. The
    /// source-free gridless density is `ρ₀ ∘ X_n`.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn map_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "map_batch: slice lengths differ");
        let d = &self.domain;
        for (o, &p) in out.iter_mut().zip(points) {
            *o = wrap_grid(d.grid_coords(p), d.dims);
        }
        for step in self.steps.iter().rev() {
            step.walk_back(d, out);
        }
        for o in out.iter_mut() {
            *o = d.world_of(*o);
        }
    }
}

impl ScalarField for GridlessField {
    fn eval(&self, p: Vec3) -> f32 {
        let mut out = [0.0];
        self.eval_batch(&[p], &mut out);
        out[0]
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let d = &self.domain;
        let mut g: Vec<Vec3> = points
            .iter()
            .map(|&p| wrap_grid(d.grid_coords(p), d.dims))
            .collect();
        let mut world = vec![Vec3::ZERO; points.len()];
        let mut values = vec![0.0f32; points.len()];
        out.fill(0.0);
        for step in self.steps.iter().rev() {
            if let Some(source) = &self.source {
                for (w, &gi) in world.iter_mut().zip(&g) {
                    *w = d.world_of(gi);
                }
                source.eval_batch(&world, &mut values);
                for (o, s) in out.iter_mut().zip(&values) {
                    *o += s * step.dt;
                }
            }
            step.walk_back(d, &mut g);
        }
        if let Some(initial) = &self.initial {
            for (w, &gi) in world.iter_mut().zip(&g) {
                *w = d.world_of(gi);
            }
            initial.eval_batch(&world, &mut values);
            for (o, r) in out.iter_mut().zip(&values) {
                *o += r;
            }
        }
        if let Some(w) = &self.walls {
            for (o, &p) in out.iter_mut().zip(points) {
                if w.inside_world(p) {
                    *o = 0.0;
                }
            }
        }
    }
}

/// A gridless density and its cache at the velocity grid's cell centres.
#[derive(Clone)]
pub struct Gridless {
    field: GridlessField,
    centres: ScalarGrid,
}

impl Gridless {
    /// A density starting at `initial`, injected at rate `source`, on the
    /// velocity grid `domain`.
    pub fn new(domain: Domain, initial: Option<Scalar>, source: Option<Scalar>) -> Self {
        let field = GridlessField::new(domain, initial, source);
        let centres = ScalarGrid::from_field(domain, &field);
        Self { field, centres }
    }

    /// Keep the step's velocity (no computation: the work is in every query).
    ///
    /// # Panics
    /// If the input has no velocity snapshot.
    pub fn step(&mut self, input: &StepInput<'_>) {
        let u = input
            .snapshot
            .expect("gridless density needs the step's velocity snapshot");
        self.field.push(Arc::clone(u), input.dt, input.backtrace);
    }

    /// Zero density inside `walls` ([`GridlessField::set_walls`]).
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        self.field.set_walls(walls);
    }

    /// Walk back from every cell centre (the buoyancy input).
    pub fn evaluate_centres(&mut self) {
        self.centres.write_field(&self.field);
    }

    /// The density at the cell centres as of the last [`Self::evaluate_centres`].
    pub fn density(&self) -> &ScalarGrid {
        &self.centres
    }

    /// The density as a field.
    pub fn field(&self) -> &GridlessField {
        &self.field
    }

    pub(super) fn buffers(&self, out: &mut Vec<Buffer>) {
        out.push(Buffer::of_scalar(&self.centres));
        out.extend(self.field.velocities().map(|u| Buffer::of_faces(u)));
    }
    /// The stored steps, oldest first, and the cell-centre cache: what a
    /// checkpoint keeps (the initial density, source and walls are rebuilt
    /// from the configuration).
    pub fn state(&self) -> (Vec<HistoryStep>, ScalarGrid) {
        let steps = self.field.steps.iter();
        let history = steps
            .map(|s| (Arc::clone(&s.velocity), s.dt, s.backtrace))
            .collect();
        (history, self.centres.clone())
    }

    /// Put back what [`Self::state`] returned (history and cache).
    ///
    /// # Panics
    /// If a grid is on another domain.
    pub fn restore(&mut self, history: Vec<HistoryStep>, centres: ScalarGrid) {
        assert_eq!(
            centres.domain(),
            self.centres.domain(),
            "gridless: cache domain"
        );
        self.field.steps.clear();
        for (velocity, dt, backtrace) in history {
            self.field.push(velocity, dt, backtrace);
        }
        self.centres = centres;
    }
}

/// One stored step of a gridless history: its velocity grid (shared between
/// gases), Δt and backtrace.
pub type HistoryStep = (Arc<FaceGrid>, f32, Backtrace);

/// AVX2 kernel of the gridless walk: eight departure points of one stored
/// step at once (eq 7.4's `B_k`, Euler or RK2), the trilinear corners of
/// each velocity component fetched by gathers. Every lane does
/// [`departure_point`]'s floating-point operations in the same order
/// (products and sums, no fused multiply-add), as the face sweep's kernel
/// does (`advection::face_simd`), so its points are the scalar path's to
/// the bit. Lanes with a stencil outside a lattice (it would wrap or clamp)
/// are flagged, computed at clamped indices and left to the scalar path.
#[cfg(target_arch = "x86_64")]
mod walk8 {
    use std::arch::x86_64::*;

    use glam::Vec3;

    use crate::advection::Backtrace;
    use crate::grid::FaceGrid;

    /// Whether [`departures`] runs for steps of `u` traced by `backtrace`:
    /// the CPU has AVX2, the backtrace is Euler or RK2, and the lattices
    /// are small enough for the gathers' 32-bit indices.
    pub(super) fn usable(u: &FaceGrid, backtrace: Backtrace) -> bool {
        backtrace != Backtrace::Rk3
            && is_x86_feature_detected!("avx2")
            && (0..3).all(|a| {
                let d = u.face_dims(a);
                d[0] * d[1] * d[2] < i32::MAX as usize / 2
            })
    }

    /// `⌊g⌋` per lane (0 where it is outside) and `g − ⌊g⌋`, and the lanes
    /// where `0 ≤ ⌊g⌋ ≤ n − 2` (all ones; the scalar `floor_inside`:
    /// truncation plus a correction).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn floor_inside8(g: __m256, n: usize) -> (__m256i, __m256, __m256i) {
        let t = _mm256_cvttps_epi32(g);
        // −1 where the truncation rounded up (negative non-integers).
        let up = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), g));
        let f = _mm256_add_epi32(t, up);
        let frac = _mm256_sub_ps(g, _mm256_cvtepi32_ps(f));
        let low = _mm256_cmpgt_epi32(f, _mm256_set1_epi32(-1));
        let high = _mm256_cmpgt_epi32(_mm256_set1_epi32(n as i32 - 1), f);
        let ok = _mm256_and_si256(low, high);
        (_mm256_and_si256(f, ok), frac, ok)
    }

    /// Trilinear interpolation of `data` (lattice `d`) at lattice
    /// coordinates `g` in eight lanes, and the lanes whose stencil stays
    /// inside the lattice (all ones; the others read the lattice at clamped
    /// indices). Corners, weights and sum in `trilinear_inside`'s order.
    ///
    /// # Safety
    /// `data.len() ≥ mx·my·mz < 2³⁰` ([`usable`]) and the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn trilinear8(data: &[f32], d: [usize; 3], g: [__m256; 3]) -> (__m256, __m256i) {
        let (x, tx, okx) = floor_inside8(g[0], d[0]);
        let (y, ty, oky) = floor_inside8(g[1], d[1]);
        let (z, tz, okz) = floor_inside8(g[2], d[2]);
        let ok = _mm256_and_si256(okx, _mm256_and_si256(oky, okz));
        let (nx, nxy) = (d[0] as i32, (d[0] * d[1]) as i32);
        let r = _mm256_add_epi32(
            _mm256_mullo_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(z, _mm256_set1_epi32(d[1] as i32)), y),
                _mm256_set1_epi32(nx),
            ),
            x,
        );
        let one = _mm256_set1_ps(1.0);
        let wx = [_mm256_sub_ps(one, tx), tx];
        let wy = [_mm256_sub_ps(one, ty), ty];
        let wz = [_mm256_sub_ps(one, tz), tz];
        let mut acc = _mm256_setzero_ps();
        for c in 0..8 {
            let (cx, cy, cz) = (c & 1, c >> 1 & 1, c >> 2);
            let weight = _mm256_mul_ps(_mm256_mul_ps(wx[cx], wy[cy]), wz[cz]);
            let at = _mm256_add_epi32(
                r,
                _mm256_set1_epi32(cx as i32 + cy as i32 * nx + cz as i32 * nxy),
            );
            // SAFETY: every lane has x ≤ mx − 2, y ≤ my − 2, z ≤ mz − 2
            // (outside lanes 0), so its index is at most ((z + 1)·my + y + 1)·mx + x + 1 <
            // mx·my·mz ≤ data.len(), and below 2³⁰ (no i32 overflow).
            let v = unsafe { _mm256_i32gather_ps::<4>(data.as_ptr(), at) };
            acc = _mm256_add_ps(acc, _mm256_mul_ps(weight, v));
        }
        (acc, ok)
    }

    /// The velocity at cell-centre grid coordinates `g`: component `a`
    /// trilinear on its lattice at `g + ½ e_a` (`FaceSampler::at`); with
    /// the lanes whose stencils stay inside every lattice (all ones).
    ///
    /// # Safety
    /// As [`trilinear8`], for every component.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn velocity8(
        data: [&[f32]; 3],
        dims: [[usize; 3]; 3],
        g: [__m256; 3],
    ) -> ([__m256; 3], __m256i) {
        let mut u = [_mm256_setzero_ps(); 3];
        let mut ok = _mm256_set1_epi32(-1);
        for (a, ua) in u.iter_mut().enumerate() {
            let mut p = g;
            p[a] = _mm256_add_ps(p[a], _mm256_set1_ps(0.5));
            // SAFETY: the caller's.
            let (v, inside) = unsafe { trilinear8(data[a], dims[a], p) };
            *ua = v;
            ok = _mm256_and_si256(ok, inside);
        }
        (u, ok)
    }

    /// The departure points (unwrapped grid coordinates) of the eight
    /// points `g` through the velocity lattices `data` over
    /// `dt_cells = Δt/Δx`, and a bit mask of the lanes (bit `l` for lane
    /// `l`) where a stencil would wrap or clamp: their points are not the
    /// scalar path's and must be recomputed by it.
    ///
    /// # Safety
    /// The CPU has AVX2, `data[a]` holds lattice `dims[a]` and the lattices
    /// pass [`usable`]'s size check; `backtrace` is Euler or RK2.
    ///
    /// # Panics
    /// If `g` does not hold eight points.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn departures(
        data: [&[f32]; 3],
        dims: [[usize; 3]; 3],
        g: &[Vec3],
        dt_cells: f32,
        backtrace: Backtrace,
    ) -> ([Vec3; 8], u32) {
        let g: &[Vec3; 8] = g.try_into().expect("departures: eight points");
        let c: [__m256; 3] = std::array::from_fn(|a| {
            let lanes: [f32; 8] = std::array::from_fn(|l| g[l][a]);
            // SAFETY: `lanes` holds eight f32.
            unsafe { _mm256_loadu_ps(lanes.as_ptr()) }
        });
        let step = |u: [__m256; 3], s: f32| -> [__m256; 3] {
            std::array::from_fn(|a| _mm256_sub_ps(c[a], _mm256_mul_ps(_mm256_set1_ps(s), u[a])))
        };
        // SAFETY (both calls): the caller's.
        let (u0, ok0) = unsafe { velocity8(data, dims, c) };
        let (p, ok) = match backtrace {
            Backtrace::Rk2 => {
                let (u1, ok1) = unsafe { velocity8(data, dims, step(u0, 0.5 * dt_cells)) };
                (step(u1, dt_cells), _mm256_and_si256(ok0, ok1))
            }
            Backtrace::Euler => (step(u0, dt_cells), ok0),
            // Not traced here: every lane to the scalar path.
            Backtrace::Rk3 => (c, _mm256_setzero_si256()),
        };
        let mut lanes = [[0.0f32; 8]; 3];
        for (l, pa) in lanes.iter_mut().zip(p) {
            // SAFETY: `l` holds eight f32.
            unsafe { _mm256_storeu_ps(l.as_mut_ptr(), pa) };
        }
        let outside = !_mm256_movemask_ps(_mm256_castsi256_ps(ok)) as u32 & 0xff;
        let points = std::array::from_fn(|l| Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]));
        (points, outside)
    }
}
