//! Staggered (MAC) velocity: one component per face lattice.
//!
//! `u` lives on the x-faces, `v` on the y-faces, `w` on the z-faces of the
//! cells of a [`Domain`]; scalars (pressure, divergence) live at the cell
//! centres. Component `a` at lattice index `(i, j, k)` sits at
//!
//! ```text
//! origin + ((i, j, k) + ½ − ½ e_a) Δx          (the low-a face of cell (i, j, k))
//! ```
//!
//! so in the cell-centre grid coordinates of [`Domain::grid_coords`] its
//! lattice is shifted by `−½ e_a`.
//!
//! Two kinds of box ([`BoxKind`]):
//! - **periodic**: every component has the cell shape `(nz, ny, nx)`; face
//!   `i = 0` is both the low face of cell 0 and the high face of cell `n − 1`;
//! - **closed** (walls with no normal flow): the normal component has one more
//!   face along its own axis — `u` is `(nz, ny, nx + 1)`, `v` is
//!   `(nz, ny + 1, nx)`, `w` is `(nz + 1, ny, nx)` — and the wall faces
//!   (`i = 0` and `i = nx` for `u`, etc.) are held at `0.0` by every operation
//!   here that writes faces.
//!
//! The compact operators, with `Δx` the cell size:
//!
//! ```text
//! (D u)[c]   = Σ_a (u_a[c + e_a] − u_a[c]) / Δx      face → cell
//! (G p)_a[f] = (p[f] − p[f − e_a]) / Δx              cell → face
//! L = D G                                            the 7-point Laplacian
//! ```
//!
//! (closed box: `G p` is not defined on wall faces, which stay zero, so `L`
//! carries homogeneous Neumann conditions). Sweeps run in parallel over
//! z-slabs and allocate nothing per cell.

use std::fmt;

use glam::Vec3;
use ndarray::Array3;
use rayon::prelude::*;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::interpolant::cell_centre;
use super::{Interpolant, ScalarGrid, Stencil, VectorGrid, Wrap};
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::VectorField;

/// Boundary conditions of the box the velocity lives in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BoxKind {
    /// The box tiles space; the pressure solve uses FFTs.
    #[default]
    Periodic,
    /// Six impermeable walls (zero normal velocity); the pressure solve uses
    /// cosine transforms (homogeneous Neumann pressure).
    Closed,
}

impl BoxKind {
    /// Every kind, in a fixed order (for tests and sweeps).
    pub const ALL: [BoxKind; 2] = [BoxKind::Periodic, BoxKind::Closed];

    /// Lower-case name, as serialised.
    pub fn name(self) -> &'static str {
        match self {
            BoxKind::Periodic => "periodic",
            BoxKind::Closed => "closed",
        }
    }

    /// How point queries treat positions outside the lattice: periodic wrap,
    /// or clamping to the lattice of each component (closed box).
    pub fn wrap(self) -> Wrap {
        match self {
            BoxKind::Periodic => Wrap::Periodic,
            BoxKind::Closed => Wrap::Clamped,
        }
    }

    /// Lattice size `[mx, my, mz]` of velocity component `axis` on `domain`:
    /// the cell counts, plus one along `axis` in a closed box.
    ///
    /// # Panics
    /// If `axis > 2`.
    pub fn face_dims(self, domain: &Domain, axis: usize) -> [usize; 3] {
        assert!(axis < 3, "axis {axis} is not 0, 1 or 2");
        let mut d = domain.dims;
        if self == BoxKind::Closed {
            d[axis] += 1;
        }
        d
    }
}

impl fmt::Display for BoxKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// [`FaceGrid`]'s point query for hot loops ([`FaceGrid::sampler`]), with
/// the component slices and layouts hoisted; its samples at a cell centre or
/// at a face are the exact averages of the neighbouring faces.
#[derive(Clone, Copy)]
pub struct FaceSampler<'a> {
    data: [&'a [f32]; 3],
    dims: [[usize; 3]; 3],
    /// Cells of the domain along each axis.
    cells: [usize; 3],
    wrap: Wrap,
    interpolant: Interpolant,
}

impl<'a> FaceSampler<'a> {
    /// The component slices `[u, v, w]` (flat `[z][y][x]`), their lattice
    /// sizes `[mx, my, mz]`, the domain's cells and the wrap, for kernels
    /// that index the lattices themselves.
    pub(crate) fn parts(&self) -> SamplerParts<'a> {
        (self.data, self.dims, self.cells, self.wrap)
    }

    /// How [`Self::at`] interpolates between the faces.
    pub fn interpolant(&self) -> Interpolant {
        self.interpolant
    }

    /// The velocity at cell-centre grid coordinates `g`, as
    /// [`FaceGrid::sample_grid_coords`]: each component trilinear on its own
    /// lattice at `g` ([`Interpolant::Trilinear`]), or at `g` with its
    /// coordinates across the component's axis moved to the centre of the
    /// cell holding `g` ([`Interpolant::Rt0`], [`Self::across`]).
    #[inline(always)]
    pub fn at(&self, g: Vec3) -> Vec3 {
        let c = self.across(g);
        Vec3::new(
            self.component_of(0, self.data[0], Vec3::new(g.x, c.y, c.z)),
            self.component_of(1, self.data[1], Vec3::new(c.x, g.y, c.z)),
            self.component_of(2, self.data[2], Vec3::new(c.x, c.y, g.z)),
        )
    }

    /// The coordinates [`Self::at`] reads each component at across its own
    /// axis: `g` itself (trilinear), or the centre of the cell holding `g`
    /// (RT0, [`crate::grid::interpolant`]).
    #[inline(always)]
    fn across(&self, g: Vec3) -> Vec3 {
        match self.interpolant {
            Interpolant::Trilinear => g,
            Interpolant::Rt0 => Vec3::new(cell_centre(g.x), cell_centre(g.y), cell_centre(g.z)),
        }
    }

    /// The divergence `∂u/∂x + ∂v/∂y + ∂w/∂z` of [`Self::at`]'s
    /// interpolant at cell-centre grid coordinates `g`, per cell (divide by
    /// Δx for world units): each component's interpolant differentiated
    /// along its own axis ([`Stencil::derivative`]). Trilinear: zero at
    /// cell centres of a projected velocity, not between them. RT0: the
    /// compact divergence `D u` of the cell holding `g` (times Δx),
    /// everywhere in it.
    pub fn divergence_at(&self, g: Vec3) -> f32 {
        let c = self.across(g);
        (0..3)
            .map(|a| {
                let mut p = c;
                p[a] = g[a] + 0.5;
                Stencil::derivative(p, self.dims[a], self.wrap, a).apply(self.data[a])
            })
            .sum()
    }

    /// `data`, laid out like component `a`'s lattice, interpolated at
    /// cell-centre grid coordinates `g`.
    ///
    /// A point whose stencil lies inside the lattice takes [`trilinear_inside`]
    /// (no wrap or clamp, one length check); others the general [`Stencil`].
    /// Both do the same floating-point operations in the same order, so the
    /// value is the same to the bit.
    #[inline(always)]
    pub fn component_of(&self, a: usize, data: &[f32], mut g: Vec3) -> f32 {
        g[a] += 0.5;
        let d = self.dims[a];
        match trilinear_inside(data, d, g) {
            Some(v) => v,
            None => Stencil::new(g, d, self.wrap).apply(data),
        }
    }

    /// The velocity at the centre of cell `c`: each component the mean of
    /// the cell's two faces (exactly what [`Self::at`] returns there).
    #[inline(always)]
    pub fn at_cell(&self, c: [usize; 3]) -> Vec3 {
        // Loops, not `array::from_fn`: its closure was not inlined (3.6 %
        // of a 128³ Euler step's profile, through `at_face`'s).
        let mut u = [0.0; 3];
        for (a, u) in u.iter_mut().enumerate() {
            let [lo, hi] = self.cell_faces(a, c);
            *u = 0.5 * (self.data[a][lo] + self.data[a][hi]);
        }
        Vec3::from_array(u)
    }

    /// Where [`Self::at_cell`] reads component `a` of cell `c`: the linear
    /// indices, in `a`'s lattice, of the cell's lower and upper `a`-faces
    /// (the upper wrapping to 0 past the lattice), in the order it adds them.
    #[inline(always)]
    pub(crate) fn cell_faces(&self, a: usize, c: [usize; 3]) -> [usize; 2] {
        let d = self.dims[a];
        let mut hi = c;
        hi[a] = if c[a] + 1 < d[a] { c[a] + 1 } else { 0 };
        [index(d, c), index(d, hi)]
    }

    /// The velocity at face `f` of component `a`: its own value, and each
    /// other component `b` the mean of the four b-faces around it (below and
    /// at `f` along `a`, at and above `f` along `b`), wrapped or clamped as
    /// [`Self::at`] does — its value there.
    ///
    /// A face at least one face from every edge of the box
    /// (`1 ≤ f ≤ n − 2` along each axis, `n` the cell count) needs no wrap
    /// or clamp; it sums the same four faces in the same order.
    #[inline(always)]
    pub fn at_face(&self, a: usize, f: [usize; 3]) -> Vec3 {
        // Loops, not `array::from_fn`: its closure was not inlined.
        let mut u = [0.0; 3];
        let inside = (0..3).all(|x| f[x] >= 1 && f[x] + 2 <= self.cells[x]);
        for (b, u) in u.iter_mut().enumerate() {
            let d = self.dims[b];
            if b == a {
                *u = self.data[a][index(d, f)];
                continue;
            }
            let neighbours = match inside {
                // In b's lattice: the face below along a, and the next along b.
                true => {
                    let (here, sa, sb) = (index(d, f), stride(d, a), stride(d, b));
                    [here - sa, here - sa + sb, here, here + sb]
                }
                false => self.face_neighbours(a, b, f),
            };
            let mut sum = 0.0;
            for p in neighbours {
                sum += self.data[b][p];
            }
            *u = 0.25 * sum;
        }
        Vec3::from_array(u)
    }

    /// Where [`Self::at_face`] reads component `b ≠ a` at face `f` of
    /// component `a`: the linear indices, in `b`'s lattice, of the four
    /// `b`-faces it averages, in the order it adds them — below and at `f`
    /// along `a` (wrapped periodically, clamped in a closed box), each at
    /// and above `f` along `b` (the upper wrapping to 0 past the lattice).
    #[inline(always)]
    pub(crate) fn face_neighbours(&self, a: usize, b: usize, f: [usize; 3]) -> [usize; 4] {
        let d = self.dims[b];
        let n = d[a];
        let (a0, a1) = match self.wrap {
            Wrap::Periodic => (if f[a] == 0 { n - 1 } else { f[a] - 1 }, f[a]),
            Wrap::Clamped => (f[a].saturating_sub(1).min(n - 1), f[a].min(n - 1)),
        };
        // Periodic: wrap; closed: f[b] + 1 ≤ n_b, inside b's lattice.
        let b1 = if f[b] + 1 < d[b] { f[b] + 1 } else { 0 };
        let at = |pa: usize, pb: usize| {
            let mut p = f;
            p[a] = pa;
            p[b] = pb;
            index(d, p)
        };
        [at(a0, f[b]), at(a0, b1), at(a1, f[b]), at(a1, b1)]
    }
}

/// [`FaceSampler::parts`]: component slices, lattice sizes, cells, wrap.
pub(crate) type SamplerParts<'a> = ([&'a [f32]; 3], [[usize; 3]; 3], [usize; 3], Wrap);

/// Linear index of `(i, j, k)` in a lattice `[mx, my, mz]`.
#[inline(always)]
fn index(d: [usize; 3], c: [usize; 3]) -> usize {
    (c[2] * d[1] + c[1]) * d[0] + c[0]
}

/// Linear distance between neighbours along `axis` in a lattice `[mx, my, mz]`.
#[inline(always)]
fn stride(d: [usize; 3], axis: usize) -> usize {
    match axis {
        0 => 1,
        1 => d[0],
        _ => d[0] * d[1],
    }
}

/// `⌊g⌋` and the fraction `g − ⌊g⌋` along an axis of `n` lattice points
/// when both stencil points `⌊g⌋` and `⌊g⌋ + 1` lie inside `0..n`
/// (`0 ≤ ⌊g⌋ ≤ n − 2`), else `None`. The floor is the truncation plus a
/// correction of [`Stencil`]'s, with the same fraction.
#[inline(always)]
fn floor_inside(g: f32, n: usize) -> Option<(usize, f32)> {
    let t = g as i32;
    let f = if (t as f32) > g { t - 1 } else { t };
    let inside = usize::try_from(f).is_ok_and(|i| i + 1 < n);
    inside.then_some((f as usize, g - f as f32))
}

/// Trilinear interpolation of `data` (laid out like a lattice `d = [mx, my,
/// mz]`) at lattice coordinates `g`, when its whole stencil lies inside the
/// lattice; `None` when it would wrap or clamp. The corners, weights and
/// sum are [`Stencil::new`] and [`Stencil::apply`]'s, in the same order, so
/// where both apply the value is identical to the bit.
///
/// # Panics
/// If `data` is shorter than the lattice.
#[inline(always)]
fn trilinear_inside(data: &[f32], d: [usize; 3], g: Vec3) -> Option<f32> {
    let (x, tx) = floor_inside(g.x, d[0])?;
    let (y, ty) = floor_inside(g.y, d[1])?;
    let (z, tz) = floor_inside(g.z, d[2])?;
    let (nx, nxy) = (d[0], d[0] * d[1]);
    assert!(
        data.len() >= nxy * d[2],
        "trilinear: data shorter than its lattice"
    );
    let r = (z * d[1] + y) * nx + x;
    let (wx, wy, wz) = ([1.0 - tx, tx], [1.0 - ty, ty], [1.0 - tz, tz]);
    let mut acc = 0.0;
    // Corner c = (c & 1, c >> 1 & 1, c >> 2) along (x, y, z).
    for c in 0..8 {
        let (cx, cy, cz) = (c & 1, c >> 1 & 1, c >> 2);
        let weight = wx[cx] * wy[cy] * wz[cz];
        // SAFETY: x ≤ mx − 2, y ≤ my − 2, z ≤ mz − 2 (floor_inside), so the
        // largest index, r + nxy + nx + 1 = ((z + 1)·my + y + 1)·mx + x + 1,
        // is below mx·my·mz ≤ data.len() (asserted above).
        acc += weight * unsafe { *data.get_unchecked(r + cx + cy * nx + cz * nxy) };
    }
    Some(acc)
}

/// ndarray shape `(mz, my, mx)` of a lattice `[mx, my, mz]`.
fn shape_of(d: [usize; 3]) -> (usize, usize, usize) {
    (d[2], d[1], d[0])
}

/// MAC velocity on a [`Domain`]: `u`, `v`, `w` on the x-, y- and z-faces.
///
/// See the [module documentation](self) for positions, shapes and operators.
/// As a [`VectorField`] it interpolates each component on its own lattice
/// through its [`Interpolant`] (trilinear unless set,
/// [`FaceGrid::sample`]). Serialized (serde) as the tuple
/// `(domain, kind, interpolant, [u, v, w])`, each component a flat sequence of f32 in
/// `[z][y][x]` order; reading checks the lattice sizes and, in a closed
/// box, the zero wall faces ([`FaceGrid::from_components`]).
#[derive(Clone, Debug)]
pub struct FaceGrid {
    domain: Domain,
    kind: BoxKind,
    /// How point queries interpolate between the faces.
    interpolant: Interpolant,
    /// Lattice size `[mx, my, mz]` of each component.
    dims: [[usize; 3]; 3],
    comps: [Array3<f32>; 3],
}

impl Serialize for FaceGrid {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let comps = [0, 1, 2].map(|a| self.slice(a));
        (&self.domain, self.kind, self.interpolant, comps).serialize(s)
    }
}

impl<'de> Deserialize<'de> for FaceGrid {
    /// # Errors
    /// If a component's lattice is not [`BoxKind::face_dims`], or a closed
    /// box's wall face is not zero.
    fn deserialize<D: Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        let (domain, kind, interpolant, comps): (Domain, BoxKind, Interpolant, [Vec<f32>; 3]) =
            Deserialize::deserialize(de)?;
        let shaped = |a: usize, c: Vec<f32>| {
            let (count, shape) = (c.len(), shape_of(kind.face_dims(&domain, a)));
            Array3::from_shape_vec(shape, c).map_err(|_| {
                D::Error::custom(format!(
                    "velocity component {a} of {count} samples in a {kind} box of {:?} cells",
                    domain.dims
                ))
            })
        };
        let [u, v, w] = comps;
        let comps = [shaped(0, u)?, shaped(1, v)?, shaped(2, w)?];
        Self::from_components(domain, kind, comps)
            .map(|g| g.with_interpolant(interpolant))
            .map_err(D::Error::custom)
    }
}

impl FaceGrid {
    /// Zero velocity.
    pub fn zeros(domain: Domain, kind: BoxKind) -> Self {
        let dims = std::array::from_fn(|a| kind.face_dims(&domain, a));
        Self {
            domain,
            kind,
            interpolant: Interpolant::default(),
            dims,
            comps: dims.map(|d| Array3::zeros(shape_of(d))),
        }
    }

    /// The same faces read through `interpolant` ([`FaceGrid::sample`],
    /// [`FaceGrid::sampler`] and every trace through them).
    pub fn with_interpolant(mut self, interpolant: Interpolant) -> Self {
        self.interpolant = interpolant;
        self
    }

    /// Read the faces through `interpolant` from now on.
    pub fn set_interpolant(&mut self, interpolant: Interpolant) {
        self.interpolant = interpolant;
    }

    /// How point queries interpolate between the faces.
    pub fn interpolant(&self) -> Interpolant {
        self.interpolant
    }

    /// Wrap three component arrays `[u, v, w]`.
    ///
    /// Fails if a shape is not `(mz, my, mx)` of [`BoxKind::face_dims`], or,
    /// in a closed box, if a wall face is not exactly zero.
    pub fn from_components(
        domain: Domain,
        kind: BoxKind,
        comps: [Array3<f32>; 3],
    ) -> Result<Self, InputError> {
        let mut grid = Self::zeros(domain, kind);
        for (a, c) in comps.into_iter().enumerate() {
            let want = shape_of(grid.dims[a]);
            if c.dim() != want {
                crate::input_bail!(
                    "velocity component {a} has shape {:?}; a {kind} box of {:?} cells needs {want:?}",
                    c.dim(),
                    domain.dims
                );
            }
            grid.comps[a] = c.as_standard_layout().into_owned();
        }
        if kind == BoxKind::Closed {
            for a in 0..3 {
                let n = domain.dims[a];
                let walls = grid.comps[a]
                    .indexed_iter()
                    .filter(|&((k, j, i), _)| {
                        let f = [i, j, k][a];
                        f == 0 || f == n
                    })
                    .all(|(_, &v)| v == 0.0);
                if !walls {
                    crate::input_bail!(
                        "velocity component {a} is not zero on the walls of a closed box"
                    );
                }
            }
        }
        Ok(grid)
    }

    /// Sample a vector field at the face centres: component `a` of `field`
    /// at the centres of the a-faces (parallel batches of one z-slab). In a
    /// closed box the wall faces are then set to zero.
    pub fn from_field(domain: Domain, kind: BoxKind, field: &dyn VectorField) -> Self {
        let mut grid = Self::zeros(domain, kind);
        grid.write_field(field);
        grid
    }

    /// Overwrite the faces with `field` as in [`FaceGrid::from_field`].
    pub fn write_field(&mut self, field: &dyn VectorField) {
        for a in 0..3 {
            let d = self.dims[a];
            let domain = self.domain;
            self.slice_mut(a)
                .par_chunks_mut(d[0] * d[1])
                .enumerate()
                .for_each_init(
                    || (Vec::new(), Vec::new()),
                    |(points, values), (k, out)| {
                        points.clear();
                        for j in 0..d[1] {
                            for i in 0..d[0] {
                                points.push(face_position(&domain, a, i, j, k));
                            }
                        }
                        values.resize(points.len(), Vec3::ZERO);
                        field.eval_batch(points, values);
                        for (o, v) in out.iter_mut().zip(values.iter()) {
                            *o = v[a];
                        }
                    },
                );
        }
        self.zero_walls();
    }

    /// The domain the faces belong to.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Periodic or closed.
    pub fn kind(&self) -> BoxKind {
        self.kind
    }

    /// Lattice size `[mx, my, mz]` of component `axis`.
    pub fn face_dims(&self, axis: usize) -> [usize; 3] {
        self.dims[axis]
    }

    /// World position of face `(i, j, k)` of component `axis`:
    /// `origin + ((i, j, k) + ½ − ½ e_axis) Δx`.
    pub fn face_position(&self, axis: usize, i: usize, j: usize, k: usize) -> Vec3 {
        face_position(&self.domain, axis, i, j, k)
    }

    /// Component `axis` (0 = u, 1 = v, 2 = w), shape `(mz, my, mx)`.
    pub fn component(&self, axis: usize) -> &Array3<f32> {
        &self.comps[axis]
    }

    /// Component `axis`, mutable. In a closed box the caller must keep the
    /// wall faces at zero (or call [`FaceGrid::zero_walls`]).
    pub fn component_mut(&mut self, axis: usize) -> &mut Array3<f32> {
        &mut self.comps[axis]
    }

    /// x-velocity on the x-faces.
    pub fn u(&self) -> &Array3<f32> {
        &self.comps[0]
    }

    /// y-velocity on the y-faces.
    pub fn v(&self) -> &Array3<f32> {
        &self.comps[1]
    }

    /// z-velocity on the z-faces.
    pub fn w(&self) -> &Array3<f32> {
        &self.comps[2]
    }

    /// Take the components `[u, v, w]`.
    pub fn into_components(self) -> [Array3<f32>; 3] {
        self.comps
    }

    /// Component `axis` as a flat `[z][y][x]` slice.
    pub fn slice(&self, axis: usize) -> &[f32] {
        self.comps[axis]
            .as_slice()
            .expect("face arrays are in standard layout")
    }

    /// Component `axis` as a flat mutable slice (see [`FaceGrid::component_mut`]).
    pub fn slice_mut(&mut self, axis: usize) -> &mut [f32] {
        self.comps[axis]
            .as_slice_mut()
            .expect("face arrays are in standard layout")
    }

    /// The three components `[u, v, w]` as flat mutable slices at once.
    pub fn slices_mut(&mut self) -> [&mut [f32]; 3] {
        self.comps.each_mut().map(|c| {
            c.as_slice_mut()
                .expect("face arrays are in standard layout")
        })
    }

    /// Closed box: set the wall faces to zero (no flow through a wall).
    /// Periodic box: nothing to do.
    pub fn zero_walls(&mut self) {
        if self.kind != BoxKind::Closed {
            return;
        }
        let [nx, ny, nz] = self.domain.dims;
        // u: first and last entry of every x-row.
        for row in self.slice_mut(0).chunks_exact_mut(nx + 1) {
            row[0] = 0.0;
            row[nx] = 0.0;
        }
        // v: first and last row of every z-slab.
        for slab in self.slice_mut(1).chunks_exact_mut(nx * (ny + 1)) {
            slab[..nx].fill(0.0);
            slab[ny * nx..].fill(0.0);
        }
        // w: first and last z-slab.
        let w = self.slice_mut(2);
        w[..nx * ny].fill(0.0);
        w[nz * nx * ny..].fill(0.0);
    }

    /// Point query at world point `p` through the grid's [`Interpolant`]:
    /// each component interpolated on its own face lattice, trilinear at `p`
    /// or (RT0) linear along its axis in the cell holding `p`.
    ///
    /// Outside the lattice:
    /// - periodic box: the lattice wraps, so any point (however far outside
    ///   the box) samples the periodic extension;
    /// - closed box: each lattice coordinate is clamped to the lattice's own
    ///   extent ([`Wrap::Clamped`]). The normal component's lattice spans
    ///   wall to wall, so beyond a wall it reads the wall's value, `0`. A
    ///   tangential component's lattice spans the outermost face centres,
    ///   half a cell inside each wall; in that half-cell strip and beyond the
    ///   wall it is held constant along the wall normal (the value on the
    ///   outermost face row). Points outside the box therefore see the
    ///   velocity of the nearest boundary point, with the normal component
    ///   set to zero.
    #[inline]
    pub fn sample(&self, p: Vec3) -> Vec3 {
        self.sample_grid_coords(self.domain.grid_coords(p))
    }

    /// [`FaceGrid::sample`] at continuous cell-centre grid coordinates
    /// (cell centres at integers, see [`Domain::grid_coords`]).
    #[inline]
    pub fn sample_grid_coords(&self, g: Vec3) -> Vec3 {
        self.sampler().at(g)
    }

    /// The point query with the component slices and layouts hoisted, for
    /// loops that sample many points.
    pub fn sampler(&self) -> FaceSampler<'_> {
        FaceSampler {
            data: [self.slice(0), self.slice(1), self.slice(2)],
            dims: self.dims,
            cells: self.domain.dims,
            wrap: self.kind.wrap(),
            interpolant: self.interpolant,
        }
    }

    /// Cell-centred velocity: each component the mean of its two faces of the
    /// cell, `(u_a[c] + u_a[c + e_a]) / 2`. The grid wraps periodically in a
    /// periodic box and is clamped in a closed one.
    pub fn to_cell_centres(&self) -> VectorGrid {
        let [nx, ny, _] = self.domain.dims;
        let mut out = VectorGrid::zeros(self.domain).with_wrap(self.kind.wrap());
        let sampler = self.sampler();
        out.as_vec3_mut()
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slab)| {
                for (n, o) in slab.iter_mut().enumerate() {
                    *o = sampler.at_cell([n % nx, n / nx, k]);
                }
            });
        out
    }

    /// Compact divergence `D u` into `out` (cell centres):
    /// `Σ_a (u_a[c + e_a] − u_a[c]) / Δx`, the upper face wrapping in a
    /// periodic box. Accumulated in f64 (the differences of f32 faces are
    /// then exact) and rounded once.
    ///
    /// # Panics
    /// If `out` is not on this grid's domain.
    pub fn divergence(&self, out: &mut ScalarGrid) {
        assert_eq!(out.domain(), &self.domain, "divergence: another domain");
        self.divergence_into(out.as_slice_mut());
    }

    /// [`FaceGrid::divergence`] in f64, into a `[z][y][x]` cell array (the
    /// pressure solver's right-hand side).
    ///
    /// # Panics
    /// If `out` does not have one value per cell.
    pub fn divergence_f64(&self, out: &mut [f64]) {
        self.divergence_into(out);
    }

    fn divergence_into<T: Real>(&self, out: &mut [T]) {
        assert_eq!(
            out.len(),
            self.domain.len(),
            "divergence: one value per cell"
        );
        let [nx, ny, _] = self.domain.dims;
        out.par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slab)| self.divergence_slab(k, slab));
    }

    /// [`FaceGrid::divergence`] of the cells of z-slab `k` into `slab`
    /// (`[y][x]`, one value per cell of the slab), each value the one the
    /// whole-grid divergence writes there.
    ///
    /// # Panics
    /// If `slab` does not have one value per cell of a slab, or `k` is not a
    /// slab of the domain.
    #[inline(always)]
    pub(crate) fn divergence_slab<T: Real>(&self, k: usize, slab: &mut [T]) {
        let [nx, ny, nz] = self.domain.dims;
        assert!(
            slab.len() == nx * ny && k < nz,
            "divergence_slab: slab {k} of {nz}, {} values for {nx}×{ny} cells",
            slab.len()
        );
        let inv = 1.0 / self.domain.cell as f64;
        let [du, dv, dw] = self.dims;
        let (u, v, w) = (self.slice(0), self.slice(1), self.slice(2));
        let k1 = if k + 1 < dw[2] { k + 1 } else { 0 };
        for j in 0..ny {
            let j1 = if j + 1 < dv[1] { j + 1 } else { 0 };
            let ur = &u[(k * du[1] + j) * du[0]..][..du[0]];
            let (v0, v1) = (
                &v[(k * dv[1] + j) * nx..][..nx],
                &v[(k * dv[1] + j1) * nx..][..nx],
            );
            let (w0, w1) = (
                &w[(k * dw[1] + j) * nx..][..nx],
                &w[(k1 * dw[1] + j) * nx..][..nx],
            );
            let o = &mut slab[j * nx..(j + 1) * nx];
            let d = |u0: f32, u1: f32, v0: f32, v1: f32, w0: f32, w1: f32| {
                T::from_f64(compact_divergence([u0, u1], [v0, v1], [w0, w1], inv))
            };
            // Every cell but the last reads its upper x-face at i + 1 (a
            // branch-free loop); the last reads face nx, or face 0 wrapped.
            for i in 0..nx - 1 {
                o[i] = d(ur[i], ur[i + 1], v0[i], v1[i], w0[i], w1[i]);
            }
            let (l, up) = (nx - 1, if nx < du[0] { nx } else { 0 });
            o[l] = d(ur[l], ur[up], v0[l], v1[l], w0[l], w1[l]);
        }
    }

    /// `u −= scale · G p` with the compact gradient
    /// `(G p)_a[f] = (p[f] − p[f − e_a]) / Δx` (periodic: the lower cell
    /// wraps). Closed box: the wall faces are not touched. Computed in f64,
    /// rounded once per face.
    ///
    /// # Panics
    /// If `p` is not on this grid's domain.
    pub fn subtract_gradient(&mut self, p: &ScalarGrid, scale: f32) {
        assert_eq!(
            p.domain(),
            &self.domain,
            "subtract_gradient: another domain"
        );
        self.subtract_gradient_of(p.as_slice(), scale as f64);
    }

    /// [`FaceGrid::subtract_gradient`] of an f64 `[z][y][x]` cell array.
    ///
    /// # Panics
    /// If `p` does not have one value per cell.
    pub fn subtract_gradient_f64(&mut self, p: &[f64], scale: f64) {
        self.subtract_gradient_of(p, scale);
    }

    fn subtract_gradient_of<T: Real>(&mut self, p: &[T], scale: f64) {
        assert_eq!(p.len(), self.domain.len(), "gradient: one value per cell");
        let [nx, ny, nz] = self.domain.dims;
        let s = scale / self.domain.cell as f64;
        let closed = self.kind == BoxKind::Closed;
        let slab = nx * ny;
        // u: along each x-row.
        let mx = self.dims[0][0];
        self.slice_mut(0)
            .par_chunks_mut(mx * ny)
            .zip(p.par_chunks(slab))
            .for_each(|(us, ps)| {
                for (ur, pr) in us.chunks_exact_mut(mx).zip(ps.chunks_exact(nx)) {
                    if !closed {
                        subtract_difference(&mut ur[..1], &pr[..1], &pr[nx - 1..], s);
                    }
                    subtract_difference(&mut ur[1..nx], &pr[1..], pr, s);
                }
            });
        // v: row j against row j − 1 within each z-slab.
        let my = self.dims[1][1];
        self.slice_mut(1)
            .par_chunks_mut(nx * my)
            .zip(p.par_chunks(slab))
            .for_each(|(vs, ps)| {
                for j in 0..ny {
                    if closed && j == 0 {
                        continue;
                    }
                    let jl = if j == 0 { ny - 1 } else { j - 1 };
                    let (hi, lo) = (&ps[j * nx..][..nx], &ps[jl * nx..][..nx]);
                    subtract_difference(&mut vs[j * nx..][..nx], hi, lo, s);
                }
            });
        // w: slab k against slab k − 1.
        self.slice_mut(2)
            .par_chunks_mut(slab)
            .enumerate()
            .for_each(|(k, ws)| {
                if closed && (k == 0 || k == nz) {
                    return;
                }
                let kl = if k == 0 { nz - 1 } else { k - 1 };
                subtract_difference(ws, &p[k * slab..][..slab], &p[kl * slab..][..slab], s);
            });
    }

    /// Largest absolute face value over all three components, `max_a max |u_a|`.
    pub fn max_norm(&self) -> f32 {
        (0..3)
            .map(|a| {
                self.slice(a)
                    .par_iter()
                    .map(|v| v.abs())
                    .reduce(|| 0.0, f32::max)
            })
            .fold(0.0, f32::max)
    }

    /// `Σ_a Σ_faces u_a²`, in f64: fixed chunks summed in parallel, their
    /// sums added in order, so the same bits at any thread count.
    fn sum_squares(&self) -> f64 {
        (0..3)
            .map(|a| {
                let sums: Vec<f64> = (self.slice(a).par_chunks(4096))
                    .map(|c| c.iter().map(|&v| (v as f64) * (v as f64)).sum::<f64>())
                    .collect();
                sums.iter().sum::<f64>()
            })
            .sum()
    }

    /// Root-mean-square speed `sqrt(Σ_a Σ_faces u_a² / cells)`: every face
    /// carries a control volume of one cell (closed box: the zero wall faces
    /// add nothing), so this is `sqrt(2 E / V)` with `E` the
    /// [kinetic energy](FaceGrid::kinetic_energy) and `V` the box volume.
    pub fn rms(&self) -> f32 {
        (self.sum_squares() / self.domain.len() as f64).sqrt() as f32
    }

    /// Kinetic energy (unit density) `½ Σ_a Σ_faces u_a² Δx³`, in f64.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.sum_squares() * self.domain.cell_volume() as f64
    }

    /// Whether every face value is finite.
    pub fn is_finite(&self) -> bool {
        (0..3).all(|a| self.slice(a).par_iter().all(|v| v.is_finite()))
    }
}

/// The compact divergence of one cell from its faces' values `[lower,
/// upper]` on each axis and `inv = 1/Δx`:
/// `((u1 − u0) + (v1 − v0) + (w1 − w0)) / Δx` in f64, where the
/// differences of f32 values are exact ([`FaceGrid::divergence`]).
#[inline(always)]
pub(crate) fn compact_divergence(u: [f32; 2], v: [f32; 2], w: [f32; 2], inv: f64) -> f64 {
    ((u[1] as f64 - u[0] as f64) + (v[1] as f64 - v[0] as f64) + (w[1] as f64 - w[0] as f64)) * inv
}

/// `o_i −= s (hi_i − lo_i)` in f64, rounded once per value (over the
/// shortest of the three): a row of the compact gradient's subtraction,
/// `u −= s G p` ([`FaceGrid::subtract_gradient`], and the periodic
/// projection's slab kernel in [`crate::pressure`]).
#[inline]
pub(crate) fn subtract_difference<T: Real>(o: &mut [f32], hi: &[T], lo: &[T], s: f64) {
    for ((o, &a), &b) in o.iter_mut().zip(hi).zip(lo) {
        *o = (*o as f64 - s * (a.to_f64() - b.to_f64())) as f32;
    }
}

/// f32 or f64 cell data for the operators (arithmetic is done in f64).
pub(crate) trait Real: Copy + Send + Sync {
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

/// World position of face `(i, j, k)` of component `axis` on `domain`.
#[inline]
fn face_position(domain: &Domain, axis: usize, i: usize, j: usize, k: usize) -> Vec3 {
    let mut g = Vec3::new(i as f32, j as f32, k as f32) + 0.5;
    g[axis] -= 0.5;
    domain.origin + g * domain.cell
}

impl VectorField for FaceGrid {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let wrap = self.kind.wrap();
        let data = [self.slice(0), self.slice(1), self.slice(2)];
        let s = self.sampler();
        // One component at a time: each pass streams one lattice.
        for (a, data) in data.into_iter().enumerate() {
            let dims = self.dims[a];
            for (o, &p) in out.iter_mut().zip(points) {
                let g = self.domain.grid_coords(p);
                let mut q = s.across(g);
                q[a] = g[a] + 0.5;
                o[a] = Stencil::new(q, dims, wrap).apply(data);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_and_walls() {
        let d = Domain::new(Vec3::ZERO, 0.5, [5, 4, 6]).unwrap();
        let g = FaceGrid::zeros(d, BoxKind::Closed);
        assert_eq!(g.u().dim(), (6, 4, 6));
        assert_eq!(g.v().dim(), (6, 5, 5));
        assert_eq!(g.w().dim(), (7, 4, 5));
        let p = FaceGrid::zeros(d, BoxKind::Periodic);
        assert!((0..3).all(|a| p.component(a).dim() == (6, 4, 5)));
        assert_eq!(g.face_position(0, 0, 0, 0), Vec3::new(0.0, 0.25, 0.25));
        assert_eq!(g.face_position(2, 1, 2, 3), Vec3::new(0.75, 1.25, 1.5));
    }

    #[test]
    fn divergence_at_differentiates_the_interpolant() {
        // u = (x(1 + y), y, 0): trilinear reproduces each component on its
        // lattice, so the interpolant's divergence is exactly
        // (1 + y) + 1 per unit length, Δx times that per cell.
        struct Field;
        impl VectorField for Field {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new(p.x * (1.0 + p.y), p.y, 0.0)
            }
        }
        let d = Domain::new(Vec3::ZERO, 0.5, [8, 8, 8]).unwrap();
        let g = FaceGrid::from_field(d, BoxKind::Closed, &Field);
        let s = g.sampler();
        for p in [
            Vec3::new(2.3, 4.7, 3.1),
            Vec3::new(5.5, 1.25, 6.0),
            Vec3::new(3.0, 3.0, 3.0),
        ] {
            let want = d.cell * (2.0 + d.world_of(p).y);
            let got = s.divergence_at(p);
            assert!((got - want).abs() < 1e-5, "at {p}: {got} against {want}");
        }
    }

    #[test]
    fn box_kind_serialises_lower_case() {
        let s = serde_json::to_string(&BoxKind::ALL).unwrap();
        assert_eq!(s, r#"["periodic","closed"]"#);
    }
}
