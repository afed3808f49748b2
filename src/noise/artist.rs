//! Artist control of simulation noise (`000_…` §5): flow along directed
//! splines, encoded as constrained lattice edge values.
//!
//! "The interpolation schemes used in simulation noises insure a
//! divergence-free field for any random data associated with lattice
//! corners", so edge values may be *chosen*. A spline is a polyline in
//! lattice units with a target speed; every lattice face it crosses asks for
//! the face flux `±speed` (the sign of the crossing direction). The solver is
//! the paper's greedy one: faces are visited in order along each spline; the
//! face's unlocked edges get equal shares of `target − (locked contribution)`
//! and are locked; a face whose four edges are all locked already is ignored
//! ("if no edge of a face is unlocked, then the face constraint is ignored").
//! Locked values are stored per corner in a hash map (the paper uses a
//! balanced tree, `O(lg N)`); every other corner is the seeded hash, scaled by
//! `random_scale`.
//!
//! The face flux of the fast noise is its normal velocity on the whole face,
//! so the field crosses each honoured face at exactly the spline's speed; the
//! smooth noise multiplies it by `bell·bell`, 1 at the face centre. Either
//! way the field stays divergence-free.
//!
//! Not done from §5: fractal stacks of constrained lattices and animated
//! splines.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Vec3;
use serde::Serialize;

use super::lattice::{keys, Corners, StaticCorners};
use super::simulation::{Fast, SimulationNoise, Smooth};
use crate::error::InputError;
use crate::field::Vector;

/// A directed polyline in lattice units and the speed of flow along it.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    /// Points, in order of flow.
    pub points: Vec<Vec3>,
    /// Target flux through each crossed face (speed across it).
    pub speed: f32,
}

/// A lattice edge: the corner it leaves and its axis (0 = +x, 1 = +y, 2 = +z).
type Edge = ([i32; 3], usize);

/// The four edges of the lower face normal to `axis` of cell `c` and the sign
/// with which each enters the face flux (the appendix's `face[0]`, `face[2]`,
/// `face[4]`; see [`super::simulation::faces`]).
pub fn face_edges(axis: usize, c: [i32; 3]) -> [(Edge, f32); 4] {
    let [i, j, k] = c;
    match axis {
        0 => [
            (([i, j, k + 1], 1), 1.0),
            (([i, j, k], 1), -1.0),
            (([i, j, k], 2), 1.0),
            (([i, j + 1, k], 2), -1.0),
        ],
        1 => [
            (([i, j, k + 1], 0), 1.0),
            (([i, j, k], 0), -1.0),
            (([i + 1, j, k], 2), 1.0),
            (([i, j, k], 2), -1.0),
        ],
        _ => [
            (([i, j, k], 1), 1.0),
            (([i + 1, j, k], 1), -1.0),
            (([i, j, k], 0), 1.0),
            (([i, j + 1, k], 0), -1.0),
        ],
    }
}

/// One crossing of a lattice face by a spline segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Normal axis of the face.
    pub axis: usize,
    /// The cell whose lower face it is.
    pub cell: [i32; 3],
    /// Where the spline crosses.
    pub point: Vec3,
    /// Target flux, `±speed`.
    pub target: f32,
}

/// The faces crossed by segment `a → b`, in order along it. A crossing at
/// `b` itself belongs to this segment, one at `a` to the previous one.
fn crossings(a: Vec3, b: Vec3, speed: f32, out: &mut Vec<(f32, Crossing)>) {
    let start = out.len();
    let d = b - a;
    for axis in 0..3 {
        if d[axis] == 0.0 {
            continue;
        }
        let (lo, hi) = if d[axis] > 0.0 {
            (a[axis].floor() + 1.0, b[axis])
        } else {
            (b[axis].ceil(), a[axis].ceil() - 1.0)
        };
        let mut m = lo;
        while m <= hi {
            let t = (m - a[axis]) / d[axis];
            let mut point = a + t * d;
            point[axis] = m;
            let mut cell = [0; 3];
            for (c, slot) in cell.iter_mut().enumerate() {
                *slot = point[c].floor() as i32;
            }
            cell[axis] = m as i32;
            out.push((
                t,
                Crossing {
                    axis,
                    cell,
                    point,
                    target: speed * d[axis].signum(),
                },
            ));
            m += 1.0;
        }
    }
    out[start..].sort_by(|x, y| x.0.total_cmp(&y.0));
}

/// Locked edge values, per corner.
#[derive(Clone, Debug, Default)]
pub struct EdgeMap {
    values: HashMap<[i32; 3], [Option<f32>; 3]>,
}

impl EdgeMap {
    /// The locked value of `edge`, if any.
    pub fn get(&self, edge: Edge) -> Option<f32> {
        self.values.get(&edge.0).and_then(|e| e[edge.1])
    }

    fn lock(&mut self, edge: Edge, value: f32) {
        self.values.entry(edge.0).or_default()[edge.1] = Some(value);
    }

    /// Number of corners with a locked edge.
    pub fn corners(&self) -> usize {
        self.values.len()
    }
}

/// What the greedy solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SolveReport {
    /// Face crossings visited.
    pub faces: usize,
    /// Crossings ignored because all four edges were already locked.
    pub ignored: usize,
}

/// The greedy solve (module docs): edge values for the crossings of
/// `splines`, visited spline by spline, in order along each.
pub fn solve(splines: &[Spline]) -> (EdgeMap, SolveReport, Vec<Crossing>) {
    let mut map = EdgeMap::default();
    let mut report = SolveReport::default();
    let mut honoured = Vec::new();
    let mut list = Vec::new();
    for s in splines {
        list.clear();
        for w in s.points.windows(2) {
            crossings(w[0], w[1], s.speed, &mut list);
        }
        for &(_, c) in &list {
            report.faces += 1;
            let edges = face_edges(c.axis, c.cell);
            let locked: f32 = edges
                .iter()
                .filter_map(|&(e, sign)| map.get(e).map(|v| sign * v))
                .sum();
            let free: Vec<_> = edges
                .iter()
                .filter(|(e, _)| map.get(*e).is_none())
                .collect();
            if free.is_empty() {
                report.ignored += 1;
                continue;
            }
            let share = (c.target - locked) / free.len() as f32;
            for &&(e, sign) in &free {
                map.lock(e, sign * share);
            }
            honoured.push(c);
        }
    }
    (map, report, honoured)
}

/// Corner lookup that consults the locked edges first, then the hash.
#[derive(Clone, Debug)]
pub struct ArtistCorners {
    random: StaticCorners,
    random_scale: f32,
    edges: Arc<EdgeMap>,
}

impl Corners for ArtistCorners {
    #[inline]
    fn corner(&self, i: i32, j: i32, k: i32) -> Vec3 {
        let mut v = self.random.corner(i, j, k) * self.random_scale;
        if let Some(e) = self.edges.values.get(&[i, j, k]) {
            for (a, locked) in e.iter().enumerate() {
                if let Some(x) = locked {
                    v[a] = *x;
                }
            }
        }
        v
    }
}

/// An artist-controlled simulation noise, its solve report and the face
/// crossings it honours.
pub struct ArtistNoise {
    /// The field (fast or smooth simulation noise on the constrained edges).
    pub field: Vector,
    /// What the solve did.
    pub report: SolveReport,
    /// The crossings whose flux was set.
    pub honoured: Vec<Crossing>,
}

/// Build the field for `splines` over seeded random edges scaled by
/// `random_scale` (0 for the splines' flow alone).
pub fn artist_noise(
    seed: u64,
    splines: &[Spline],
    random_scale: f32,
    smooth: bool,
) -> Result<ArtistNoise, InputError> {
    for (n, s) in splines.iter().enumerate() {
        if s.points.len() < 2
            || s.points
                .iter()
                .any(|p| !p.is_finite() || p.abs().max_element() > 1e6)
        {
            return Err(InputError::new(format!(
                "spline {n} needs at least two finite points within ±1e6 lattice units"
            )));
        }
        if !s.speed.is_finite() {
            return Err(InputError::new(format!("spline {n} has speed {}", s.speed)));
        }
    }
    if !(random_scale.is_finite() && random_scale >= 0.0) {
        return Err(InputError::new(format!(
            "random scale is {random_scale}; it must be a non-negative number"
        )));
    }
    let (map, report, honoured) = solve(splines);
    let corners = ArtistCorners {
        random: StaticCorners::new(keys::<1>(seed)[0]),
        random_scale,
        edges: Arc::new(map),
    };
    let field: Vector = if smooth {
        Arc::new(SimulationNoise::<_, Smooth>::new(corners))
    } else {
        Arc::new(SimulationNoise::<_, Fast>::new(corners))
    };
    Ok(ArtistNoise {
        field,
        report,
        honoured,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::simulation::faces;

    fn line(from: Vec3, to: Vec3, speed: f32) -> Spline {
        Spline {
            points: vec![from, to],
            speed,
        }
    }

    #[test]
    fn straight_spline_sets_the_crossed_fluxes() {
        let s = [line(
            Vec3::new(-0.5, 0.5, 0.5),
            Vec3::new(5.5, 0.5, 0.5),
            2.0,
        )];
        for smooth in [false, true] {
            let a = artist_noise(1, &s, 0.3, smooth).unwrap();
            assert_eq!(
                a.report,
                SolveReport {
                    faces: 6,
                    ignored: 0
                }
            );
            for c in &a.honoured {
                let v = a.field.eval(c.point);
                assert!(
                    (v.x - 2.0).abs() < 1e-5,
                    "smooth {smooth}: {v} at {}",
                    c.point
                );
            }
        }
    }

    #[test]
    fn constrained_fields_stay_divergence_free() {
        // A square loop in the xy plane plus a diagonal, over random edges.
        let square = Spline {
            points: vec![
                Vec3::new(0.5, 0.5, 0.5),
                Vec3::new(4.5, 0.5, 0.5),
                Vec3::new(4.5, 4.5, 0.5),
                Vec3::new(0.5, 4.5, 0.5),
                Vec3::new(0.5, 0.5, 0.5),
            ],
            speed: 1.5,
        };
        let diag = line(Vec3::new(0.2, 0.3, -1.7), Vec3::new(3.9, 4.2, 2.6), -1.0);
        let splines = [square, diag];
        let (map, report, honoured) = solve(&splines);
        assert!(report.faces > 20 && honoured.len() + report.ignored == report.faces);
        let corners = ArtistCorners {
            random: StaticCorners::new(5),
            random_scale: 1.0,
            edges: Arc::new(map),
        };
        for i in -1..6 {
            for j in -1..6 {
                for k in -2..3 {
                    let f = faces(&corners, i, j, k);
                    let net = (f[1] - f[0]) + (f[3] - f[2]) + (f[5] - f[4]);
                    let scale: f32 = f.iter().map(|x| x.abs()).sum();
                    assert!(
                        net.abs() <= 1e-6 * scale.max(1.0),
                        "cell {i},{j},{k}: {net}"
                    );
                }
            }
        }
        // Every honoured crossing of the square has the loop's flux.
        for c in honoured.iter().take(16) {
            let f = faces(&corners, c.cell[0], c.cell[1], c.cell[2]);
            assert!(
                (f[2 * c.axis] - c.target).abs() < 1e-5,
                "{c:?}: {}",
                f[2 * c.axis]
            );
        }
    }

    #[test]
    fn a_face_crossed_again_after_its_edges_are_locked_is_ignored() {
        let there = line(Vec3::new(0.5, 0.5, 0.5), Vec3::new(3.5, 0.5, 0.5), 1.0);
        let back = line(Vec3::new(3.5, 0.5, 0.5), Vec3::new(0.5, 0.5, 0.5), 1.0);
        let (_, report, _) = solve(&[there, back]);
        assert_eq!(
            report,
            SolveReport {
                faces: 6,
                ignored: 3
            }
        );
    }

    #[test]
    fn rejects_degenerate_splines() {
        assert!(artist_noise(0, &[line(Vec3::ZERO, Vec3::NAN, 1.0)], 1.0, true).is_err());
        let one = Spline {
            points: vec![Vec3::ZERO],
            speed: 1.0,
        };
        assert!(artist_noise(0, &[one], 1.0, true).is_err());
        assert!(artist_noise(0, &[], -1.0, true).is_err());
    }
}
