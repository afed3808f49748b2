//! Vorticity confinement (Fedkiw, Stam & Jensen 2001, "Visual simulation of
//! smoke", §3, eqs 9–11): a body force that puts back the small-scale
//! rotation the grid's numerical dissipation takes out,
//!
//! ```text
//! ω = ∇ × u                                  (eq 9)
//! N = η / |η|,   η = ∇|ω|                    (eq 10)
//! f_conf = ε Δx (N × ω)                      (eq 11)
//! ```
//!
//! `N` points from lower towards higher vorticity concentration (towards
//! a vortex's core), so `N × ω` is perpendicular to both: around a vortex
//! tube it is azimuthal, in the sense of the rotation — the force spins
//! the vortex up about its core, which is what keeps it from smearing out.
//! `ε ≥ 0` sets its strength; `Δx` makes the force vanish as the grid is
//! refined (the scheme stays consistent).
//!
//! # Where ω lives
//! On the MAC grid the curl is natural on the cell edges, `ω_z = ∂v/∂x −
//! ∂u/∂y` from the staggered differences of the faces around each z-edge.
//! The force is wanted on the faces, the mean of two cell centres like the
//! buoyancy ([`crate::forces`]), so `ω`, `|ω|`, `N` and `N × ω` are all
//! taken at the cell centres: `ω` at a cell is the mean of the four edge
//! vorticities around it parallel to each axis. That mean telescopes to
//! the centred difference, over `2Δx`, of the cell-centred velocity (each
//! component the mean of the cell's two faces,
//! [`crate::grid::FaceSampler::at_cell`]) — the cell-centred form of
//! Fedkiw et al. exactly — and is computed so. `∇|ω|` is the centred
//! difference of `|ω|` between the neighbouring cells. Both are second
//! order; like any centred difference they do not see a velocity that
//! alternates cell by cell (the grid-scale checkerboard, which the
//! projection does not produce).
//!
//! Where `|∇|ω||` is below [`FLAT`] times `max|ω| / Δx` (uniform or zero
//! vorticity, or a vortex's very centre) `N` is undefined and the force is
//! zero there.
//!
//! # Boxes and obstacles
//! Periodic box: every difference wraps. Closed box: the cell-centred
//! velocity's neighbour across a wall is the wall cell itself (a one-sided
//! difference over `Δx`, the tangential velocity read clamped as
//! [`crate::grid::FaceGrid::sample`] does), and the wall faces get no force.
//! With obstacles the faces they close (`A = 0`,
//! [`crate::grid::open_faces`]) get no force: nothing pushes into a solid.

use glam::Vec3;
use rayon::prelude::*;

use crate::grid::{BoxKind, FaceGrid};

/// `N` is taken as zero where `|∇|ω||` is below `FLAT · max|ω| / Δx`: a
/// gradient that small is round-off of a uniform `|ω|`, and its direction
/// is noise.
pub const FLAT: f32 = 1e-6;

/// The buffers of one confinement force, kept between steps (allocated on
/// first use, at the grid's size).
#[derive(Clone, Debug, Default)]
pub struct Confinement {
    /// ω at the cell centres, then `ε Δx (N × ω)` in place.
    omega: Vec<Vec3>,
    /// `|ω|` at the cell centres.
    magnitude: Vec<f32>,
    /// The cell-centred velocity.
    centred: Vec<Vec3>,
}

impl Confinement {
    /// Eq 11 on the faces of `velocity`: `u_a[f] += Δt A[f] · ½ (f_a[f −
    /// e_a] + f_a[f])` with `f = ε Δx (N × ω)` at the cell centres and `A`
    /// the faces `open` leaves open (all, without obstacles); a closed
    /// box's wall faces are left at zero. `ε = 0` leaves the velocity
    /// untouched, bit for bit.
    ///
    /// # Panics
    /// If `open` is on another domain than `velocity`.
    pub fn add(
        &mut self,
        velocity: &mut FaceGrid,
        dt: f32,
        epsilon: f32,
        open: Option<[&[f32]; 3]>,
    ) {
        if epsilon == 0.0 {
            return;
        }
        self.force(velocity, epsilon);
        let d = *velocity.domain();
        if let Some(open) = open {
            assert!(
                open.iter().all(|o| o.len() == d.len()),
                "confinement: open faces of another domain"
            );
        }
        let kind = velocity.kind();
        let force = &self.omega;
        for a in 0..3 {
            let dims = velocity.face_dims(a);
            let n = d.dims[a];
            let open_a = open.map(|o| o[a]);
            velocity
                .slice_mut(a)
                .par_chunks_mut(dims[0] * dims[1])
                .enumerate()
                .for_each(|(k, slab)| {
                    for (m, u) in slab.iter_mut().enumerate() {
                        let f = [m % dims[0], m / dims[0], k];
                        if kind == BoxKind::Closed && (f[a] == 0 || f[a] == n) {
                            continue;
                        }
                        let mut below = f;
                        below[a] = if f[a] == 0 { n - 1 } else { f[a] - 1 };
                        let (lo, hi) = (
                            force[d.index(below[0], below[1], below[2])],
                            force[d.index(f[0], f[1], f[2])],
                        );
                        let push = dt * 0.5 * (lo[a] + hi[a]);
                        let weight = open_a.map_or(1.0, |o| o[k * dims[0] * dims[1] + m]);
                        *u += weight * push;
                    }
                });
        }
    }

    /// The force `ε Δx (N × ω)` at the cell centres of `velocity`'s grid,
    /// in [`Self::omega`]; its vorticity first ([`Self::vorticity`]).
    fn force(&mut self, velocity: &FaceGrid, epsilon: f32) {
        self.vorticity(velocity);
        let d = *velocity.domain();
        let h = d.cell;
        let closed = velocity.kind() == BoxKind::Closed;
        self.magnitude.resize(d.len(), 0.0);
        self.magnitude
            .par_iter_mut()
            .zip(&self.omega)
            .for_each(|(m, w)| *m = w.length());
        let peak = self.magnitude.par_iter().copied().reduce(|| 0.0, f32::max);
        let flat = FLAT * peak / h;
        let magnitude = &self.magnitude;
        let gradient = |c: [usize; 3]| -> Vec3 {
            let mut g = [0.0; 3];
            for (a, g) in g.iter_mut().enumerate() {
                let (lo, hi, span) = neighbours(d.dims, c, a, closed);
                let at = |i: usize| {
                    let mut e = c;
                    e[a] = i;
                    magnitude[d.index(e[0], e[1], e[2])]
                };
                *g = (at(hi) - at(lo)) / (span as f32 * h);
            }
            Vec3::from_array(g)
        };
        let scale = epsilon * h;
        d.par_for_each_cell(&mut self.omega, |_, c, w| {
            let eta = gradient(c);
            let norm = eta.length();
            *w = if norm > flat {
                scale * (eta / norm).cross(*w)
            } else {
                Vec3::ZERO
            };
        });
    }

    /// Eq 9: ω at the cell centres, the centred differences of the
    /// cell-centred velocity (module documentation: the mean of the
    /// staggered edge curls around the cell), into [`Self::omega`].
    fn vorticity(&mut self, velocity: &FaceGrid) {
        let d = *velocity.domain();
        let h = d.cell;
        let closed = velocity.kind() == BoxKind::Closed;
        let sampler = velocity.sampler();
        self.centred.resize(d.len(), Vec3::ZERO);
        d.par_for_each_cell(&mut self.centred, |_, c, u| *u = sampler.at_cell(c));
        self.omega.resize(d.len(), Vec3::ZERO);
        let centred = &self.centred;
        // ∂u_b/∂x_a at cell c.
        let derivative = |c: [usize; 3], a: usize, b: usize| {
            let (lo, hi, span) = neighbours(d.dims, c, a, closed);
            let at = |i: usize| {
                let mut e = c;
                e[a] = i;
                centred[d.index(e[0], e[1], e[2])][b]
            };
            (at(hi) - at(lo)) / (span as f32 * h)
        };
        d.par_for_each_cell(&mut self.omega, |_, c, w| {
            *w = Vec3::new(
                derivative(c, 1, 2) - derivative(c, 2, 1),
                derivative(c, 2, 0) - derivative(c, 0, 2),
                derivative(c, 0, 1) - derivative(c, 1, 0),
            );
        });
    }

    /// Vorticity `ω = ∇ × u` of `velocity` at its cell centres (eq 9 as the
    /// force reads it; module documentation), in `[z][y][x]` order.
    pub fn vorticity_of(velocity: &FaceGrid) -> Vec<Vec3> {
        let mut c = Self::default();
        c.vorticity(velocity);
        c.omega
    }

    /// The force `ε Δx (N × ω)` (eq 11) at the cell centres of `velocity`,
    /// in `[z][y][x]` order.
    pub fn force_of(velocity: &FaceGrid, epsilon: f32) -> Vec<Vec3> {
        let mut c = Self::default();
        c.force(velocity, epsilon);
        c.omega
    }
}

/// The neighbours of cell `c` along axis `a` a centred difference reads,
/// and the cells between them: `(c − 1, c + 1, 2)` wrapped in a periodic
/// box; in a closed box a neighbour beyond a wall is the cell itself
/// (then 1 cell apart).
fn neighbours(dims: [usize; 3], c: [usize; 3], a: usize, closed: bool) -> (usize, usize, usize) {
    let n = dims[a];
    let i = c[a];
    if closed {
        let lo = i.saturating_sub(1);
        let hi = (i + 1).min(n - 1);
        (lo, hi, hi - lo)
    } else {
        ((i + n - 1) % n, (i + 1) % n, 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;
    use crate::field::VectorField;
    use crate::fit::observed_order;
    use crate::grid::open_faces::OpenFaces;
    use crate::grid::ScalarGrid;

    /// A Lamb–Oseen vortex along z through `(x₀, y₀)`, circulation Γ and
    /// core radius `r_c`: `u_θ = Γ / (2πr) (1 − e^{−r²/r_c²})`, whose
    /// vorticity is `ω_z = Γ / (π r_c²) e^{−r²/r_c²}`.
    struct LambOseen {
        centre: Vec3,
        gamma: f32,
        core: f32,
    }

    impl LambOseen {
        fn omega(&self, r: f64) -> f64 {
            let rc = self.core as f64;
            self.gamma as f64 / (std::f64::consts::PI * rc * rc) * (-(r * r) / (rc * rc)).exp()
        }
    }

    impl VectorField for LambOseen {
        fn eval(&self, p: Vec3) -> Vec3 {
            let (x, y) = ((p.x - self.centre.x) as f64, (p.y - self.centre.y) as f64);
            let r2 = x * x + y * y;
            let rc2 = (self.core as f64).powi(2);
            // u_θ / r, finite at the axis (→ Γ / (2π r_c²)).
            let over_r = if r2 < 1e-12 {
                self.gamma as f64 / (2.0 * std::f64::consts::PI * rc2)
            } else {
                self.gamma as f64 / (2.0 * std::f64::consts::PI * r2) * (1.0 - (-r2 / rc2).exp())
            };
            Vec3::new((-y * over_r) as f32, (x * over_r) as f32, 0.0)
        }
    }

    /// The unit box, `n × n × 4` cells, the vortex at its centre.
    fn setup(n: usize) -> (Domain, LambOseen) {
        let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, n, 4]).unwrap();
        let vortex = LambOseen {
            centre: Vec3::new(0.5, 0.5, 0.0),
            gamma: 0.8,
            core: 0.15,
        };
        (d, vortex)
    }

    /// Eq 11 by hand for the vortex: `N = −r̂` (|ω| falls off from the
    /// axis), so `N × ω = −r̂ × ω_z ẑ = ω_z θ̂` — azimuthal, in the sense of
    /// the rotation, of size `ε Δx ω_z(r)`. Returns the largest error of the
    /// cell-centred force over the cells with `½ r_c ≤ r ≤ 1½ r_c` (the
    /// core's centre, where `N` turns over, and the periodic seam far off
    /// are left out), relative to the largest exact force there.
    fn force_error(n: usize, kind: BoxKind, epsilon: f32) -> f64 {
        let (d, vortex) = setup(n);
        let u = FaceGrid::from_field(d, kind, &vortex);
        let force = Confinement::force_of(&u, epsilon);
        let (mut err, mut scale) = (0.0f64, 0.0f64);
        let [nx, ny, _] = d.dims;
        for (m, f) in force.iter().enumerate() {
            let p = d.cell_center(m % nx, m / nx % ny, m / (nx * ny));
            let (x, y) = ((p.x - 0.5) as f64, (p.y - 0.5) as f64);
            let r = x.hypot(y);
            if r < 0.5 * vortex.core as f64 || r > 1.5 * vortex.core as f64 {
                continue;
            }
            let theta = [-y / r, x / r];
            let size = epsilon as f64 * d.cell as f64 * vortex.omega(r);
            let exact = [size * theta[0], size * theta[1], 0.0];
            // The direction first: along the rotation, not across it.
            assert!(
                (f.x as f64 * theta[0] + f.y as f64 * theta[1]) > 0.9 * size,
                "n {n}: force {f} at r {r:.3} is not along θ̂"
            );
            let e = (0..3)
                .map(|a| (f[a] as f64 - exact[a]).powi(2))
                .sum::<f64>()
                .sqrt();
            err = err.max(e);
            scale = scale.max(size);
        }
        err / scale
    }

    /// The force on a Lamb–Oseen vortex is `ε Δx ω_z θ̂` (eq 11 by hand,
    /// [`force_error`]) to a discretisation error that falls at the second
    /// order of the centred differences, in a periodic and a closed box
    /// alike (the points measured are far from the walls).
    #[test]
    fn a_lamb_oseen_vortex_is_spun_up_along_its_rotation() {
        let levels = [24, 48, 96];
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            let errors: Vec<f64> = levels.iter().map(|&n| force_error(n, kind, 0.3)).collect();
            let h: Vec<f64> = levels.iter().map(|&n| 1.0 / n as f64).collect();
            let fit = observed_order(&h, &errors);
            assert!(
                (1.8..2.3).contains(&fit.order),
                "{kind:?}: errors {errors:?}, observed order {}",
                fit.order
            );
            assert!(errors[2] < 0.01, "{kind:?}: errors {errors:?}");
        }
    }

    /// On the faces: `u_a += Δt ½ (f[f − e_a] + f[f])` from the cell forces;
    /// a closed box's walls, and the faces an obstacle closes, get nothing.
    #[test]
    fn the_faces_get_the_mean_of_their_cells_except_closed_ones() {
        let (d, vortex) = setup(16);
        let dt = 0.1;
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            let u0 = FaceGrid::from_field(d, kind, &vortex);
            let cells = Confinement::force_of(&u0, 0.5);
            let mut u = u0.clone();
            Confinement::default().add(&mut u, dt, 0.5, None);
            for a in 0..3 {
                let dims = u.face_dims(a);
                let n = d.dims[a];
                for (m, (&after, &before)) in u.slice(a).iter().zip(u0.slice(a)).enumerate() {
                    let f = [m % dims[0], m / dims[0] % dims[1], m / (dims[0] * dims[1])];
                    if kind == BoxKind::Closed && (f[a] == 0 || f[a] == n) {
                        assert_eq!(after, 0.0, "{kind:?} wall face {a} {f:?}");
                        continue;
                    }
                    let mut below = f;
                    below[a] = (f[a] + n - 1) % n;
                    let mean = 0.5
                        * (cells[d.index(below[0], below[1], below[2])][a]
                            + cells[d.index(f[0], f[1], f[2])][a]);
                    assert_eq!(after, before + dt * mean, "{kind:?} face {a} {f:?}");
                }
            }
        }
        // An obstacle: a slab of cells across the vortex; its closed faces
        // keep their velocity, the open ones are forced.
        let mut level = ScalarGrid::zeros(d);
        for (m, o) in level.as_slice_mut().iter_mut().enumerate() {
            *o = if (5..8).contains(&(m % 16)) {
                1.0
            } else {
                -1.0
            };
        }
        let open = OpenFaces::new(&level);
        let u0 = FaceGrid::from_field(d, BoxKind::Periodic, &vortex);
        let mut u = u0.clone();
        Confinement::default().add(
            &mut u,
            dt,
            0.5,
            Some([open.open(0), open.open(1), open.open(2)]),
        );
        let mut forced = 0;
        for a in 0..2 {
            for ((&after, &before), &o) in u.slice(a).iter().zip(u0.slice(a)).zip(open.open(a)) {
                if o == 0.0 {
                    assert_eq!(after, before, "a closed face of component {a} was forced");
                } else {
                    forced += usize::from(after != before);
                }
            }
        }
        assert!(forced > 0, "no open face was forced");
    }

    /// ε = 0 leaves every bit of the velocity as it was.
    #[test]
    fn zero_epsilon_leaves_the_velocity_bitwise() {
        let (d, vortex) = setup(16);
        let u0 = FaceGrid::from_field(d, BoxKind::Closed, &vortex);
        let mut u = u0.clone();
        Confinement::default().add(&mut u, 0.1, 0.0, None);
        for a in 0..3 {
            let same = u
                .slice(a)
                .iter()
                .zip(u0.slice(a))
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "component {a} changed with ε = 0");
        }
    }
}
