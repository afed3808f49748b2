//! Cell counts and wrapped neighbour tables of a periodic grid, shared by
//! the finite-volume passes.

use crate::domain::Domain;

/// Wrapped neighbour indices along one periodic axis: `at(i, d)` is `(i + d) mod n`
/// for `d ∈ −2..=2`.
#[derive(Clone, Debug)]
pub(crate) struct Axis(Vec<usize>);

impl Axis {
    pub(crate) fn new(n: usize) -> Self {
        Self((0..n + 4).map(|m| (m + 2 * n - 2) % n).collect())
    }
    #[inline(always)]
    pub(crate) fn at(&self, i: usize, d: isize) -> usize {
        self.0[(i as isize + 2 + d) as usize]
    }
}

/// Cell counts and wrapped neighbour tables.
#[derive(Clone, Debug)]
pub(crate) struct Lattice {
    pub(crate) nx: usize,
    pub(crate) ny: usize,
    pub(crate) nz: usize,
    pub(crate) x: Axis,
    pub(crate) y: Axis,
    pub(crate) z: Axis,
}

impl Lattice {
    pub(crate) fn new(d: &Domain) -> Self {
        let [nx, ny, nz] = d.dims;
        Self {
            nx,
            ny,
            nz,
            x: Axis::new(nx),
            y: Axis::new(ny),
            z: Axis::new(nz),
        }
    }
    #[inline(always)]
    pub(crate) fn idx(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.ny + j) * self.nx + i
    }
    pub(crate) fn slab(&self) -> usize {
        self.nx * self.ny
    }
    /// Neighbour bases of row `(j, k)`.
    #[inline(always)]
    pub(crate) fn row(&self, j: usize, k: usize) -> Row {
        Row {
            base: self.idx(0, j, k),
            ym: self.idx(0, self.y.at(j, -1), k),
            yp: self.idx(0, self.y.at(j, 1), k),
            zm: self.idx(0, j, self.z.at(k, -1)),
            zp: self.idx(0, j, self.z.at(k, 1)),
        }
    }

    /// Per axis, the linear indices of the cells below and above `(i, j, k)`.
    #[inline(always)]
    pub(crate) fn around(&self, i: usize, j: usize, k: usize) -> [(usize, usize); 3] {
        [
            (
                self.idx(self.x.at(i, -1), j, k),
                self.idx(self.x.at(i, 1), j, k),
            ),
            (
                self.idx(i, self.y.at(j, -1), k),
                self.idx(i, self.y.at(j, 1), k),
            ),
            (
                self.idx(i, j, self.z.at(k, -1)),
                self.idx(i, j, self.z.at(k, 1)),
            ),
        ]
    }
}

/// Linear indices of the first cell of a row `(j, k)` and of its four
/// neighbouring rows, so that the neighbours of cell `i` cost one table
/// lookup along x and additions otherwise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Row {
    pub(crate) base: usize,
    ym: usize,
    yp: usize,
    zm: usize,
    zp: usize,
}

impl Row {
    /// Per axis, the cells below and above cell `i` of the row.
    #[inline(always)]
    pub(crate) fn around(&self, lat: &Lattice, i: usize) -> [(usize, usize); 3] {
        [
            (self.base + lat.x.at(i, -1), self.base + lat.x.at(i, 1)),
            (self.ym + i, self.yp + i),
            (self.zm + i, self.zp + i),
        ]
    }
}
