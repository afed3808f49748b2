//! Cutting up models with level-set knives (ch. 5).
//!
//! A knife is any level set `K` that changes sign inside the geometry `ℓ₀`
//! (e.g. the flat blade of eq 5.1, [`super::shape::plane`]; a sphere or a
//! noisy plane cut as well). With `inside = mask(ℓ₀)` and
//! `outside = 1 − inside` (eq 5.3),
//!
//! ```text
//! cutInside  = (outside + inside·K) · ℓ₀     the part of ℓ₀ where K > 0
//! cutOutside = (outside − inside·K) · ℓ₀     the part of ℓ₀ where K < 0
//! ```
//!
//! N knives applied in turn give 2^N level sets (§5.3); those with no sample
//! inside on a given lattice are discarded as soon as they appear, so later
//! knives cut only what exists. Each remaining level set may hold several
//! disconnected pieces: [`label_pieces`] separates them by 26-connected
//! components of the positive cells (sharing a face, an edge or a corner), so
//! a sliver thinner than a cell along a knife stays one piece.

use std::collections::VecDeque;

use glam::Vec3;
use ndarray::Array3;
use serde::Serialize;

use crate::domain::Domain;
use crate::field::algebra::{add, mul, sub};
use crate::field::ops::{constant, mask};
use crate::field::Scalar;
use crate::grid::ScalarGrid;

/// `cutInside`: the part of `ℓ₀` on the positive side of the knife (§5.2).
pub fn cut_inside(l0: Scalar, knife: Scalar) -> Scalar {
    let inside = mask(l0.clone());
    let outside = sub(constant(1.0), inside.clone());
    mul(add(outside, mul(inside, knife)), l0)
}

/// `cutOutside`: the part of `ℓ₀` on the negative side of the knife (§5.2).
pub fn cut_outside(l0: Scalar, knife: Scalar) -> Scalar {
    let inside = mask(l0.clone());
    let outside = sub(constant(1.0), inside.clone());
    mul(sub(outside, mul(inside, knife)), l0)
}

/// One of the 2^N level sets of N cuts.
#[derive(Clone)]
pub struct PieceSet {
    /// For each knife in the order applied: `true` for its positive side.
    pub sides: Vec<bool>,
    /// The level set, positive inside this set's pieces.
    pub level_set: Scalar,
}

/// Whether a level set has a positive sample at some cell centre of `domain`.
fn non_empty(level_set: &Scalar, domain: Domain) -> bool {
    ScalarGrid::from_field(domain, &**level_set)
        .as_slice()
        .iter()
        .any(|&v| v > 0.0)
}

/// What N cuts produced: the non-empty level sets and how many were empty.
pub struct Cuts {
    /// The level sets with something inside, in the order of their sides.
    pub sets: Vec<PieceSet>,
    /// How many of the 2^N level sets were empty (including the descendants of
    /// those discarded early, which are never built).
    pub empty: usize,
}

/// Cut `l0` with every knife in turn (§5.3), discarding level sets with no
/// positive sample on `domain` after each cut.
pub fn cut_all(l0: Scalar, knives: &[Scalar], domain: Domain) -> Cuts {
    let mut sets = Vec::new();
    let mut empty = 0usize;
    if non_empty(&l0, domain) {
        sets.push(PieceSet {
            sides: Vec::new(),
            level_set: l0,
        });
    } else {
        empty = 1 << knives.len();
    }
    for (k, knife) in knives.iter().enumerate() {
        let remaining = knives.len() - k - 1;
        let mut next = Vec::with_capacity(2 * sets.len());
        for set in sets {
            for positive in [true, false] {
                let level_set = if positive {
                    cut_inside(set.level_set.clone(), knife.clone())
                } else {
                    cut_outside(set.level_set.clone(), knife.clone())
                };
                if non_empty(&level_set, domain) {
                    let mut sides = set.sides.clone();
                    sides.push(positive);
                    next.push(PieceSet { sides, level_set });
                } else {
                    empty += 1 << remaining;
                }
            }
        }
        sets = next;
    }
    Cuts { sets, empty }
}

/// One connected piece.
#[derive(Clone, Debug, Serialize)]
pub struct Piece {
    /// Its label in [`Labels::ids`] (1, 2, …; 0 is outside every piece).
    pub id: i32,
    /// Index of its level set in [`Cuts::sets`].
    pub set: usize,
    /// Number of cells.
    pub cells: usize,
    /// Volume, cells × Δx³.
    pub volume: f64,
    /// Centroid of its cell centres.
    pub centroid: Vec3,
}

/// Every cell's piece.
pub struct Labels {
    /// Piece id per cell, shape `(nz, ny, nx)`, 0 outside.
    pub ids: Array3<i32>,
    /// The pieces, by id.
    pub pieces: Vec<Piece>,
}

/// Sample each level set on `domain` and split its positive cells into
/// 26-connected pieces. A cell positive in two sets (impossible for the
/// disjoint sets of [`cut_all`]) keeps the first.
pub fn label_pieces(sets: &[PieceSet], domain: Domain) -> Labels {
    let (nz, ny, nx) = domain.shape();
    let mut ids = Array3::<i32>::zeros((nz, ny, nx));
    let mut pieces = Vec::new();
    let mut queue = VecDeque::new();
    for (s, set) in sets.iter().enumerate() {
        let grid = ScalarGrid::from_field(domain, &*set.level_set);
        let inside = grid.data().mapv(|v| v > 0.0);
        for start in ndarray::indices((nz, ny, nx)) {
            if !inside[start] || ids[start] != 0 {
                continue;
            }
            let id = pieces.len() as i32 + 1;
            ids[start] = id;
            queue.push_back(start);
            let (mut cells, mut sum) = (0usize, [0.0f64; 3]);
            while let Some((k, j, i)) = queue.pop_front() {
                cells += 1;
                let c = domain.cell_center(i, j, k);
                for (a, v) in sum.iter_mut().zip(c.to_array()) {
                    *a += v as f64;
                }
                for dk in -1i64..=1 {
                    for dj in -1i64..=1 {
                        for di in -1i64..=1 {
                            let n = (k as i64 + dk, j as i64 + dj, i as i64 + di);
                            if n.0 < 0 || n.1 < 0 || n.2 < 0 {
                                continue;
                            }
                            let n = (n.0 as usize, n.1 as usize, n.2 as usize);
                            if n.0 < nz && n.1 < ny && n.2 < nx && inside[n] && ids[n] == 0 {
                                ids[n] = id;
                                queue.push_back(n);
                            }
                        }
                    }
                }
            }
            let centroid = Vec3::from_array(sum.map(|v| (v / cells as f64) as f32));
            pieces.push(Piece {
                id,
                set: s,
                cells,
                volume: cells as f64 * domain.cell_volume() as f64,
                centroid,
            });
        }
    }
    Labels { ids, pieces }
}
