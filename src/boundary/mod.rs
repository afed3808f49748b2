//! Obstacles in the flow: the reflecting (eq 6.6) and sticky (eq 6.7) rules
//! of the notes' §6.3, applied to the staggered velocity.
//!
//! An obstacle is a level set `O(x)`, positive inside ([`level_set`]). Where
//! the fluid is inside or on an obstacle and flows inward — `O ≥ 0` and
//! `u·∇O > 0`, the notes' `mask(normalU)*mask(object)` — the normal part of
//! the velocity is turned around:
//!
//! ```text
//! u_reflected = u − 2     (u·∇O)/|∇O|² ∇O      (6.6)
//! u_sticky    = u − (1+α) (u·∇O)/|∇O|² ∇O      (6.7), 0 ≤ α ≤ 1
//! ```
//!
//! so the inward normal component becomes `−α` times itself (reflect is
//! α = 1) and the tangential part is untouched. Elsewhere the velocity is
//! unchanged. On the MAC grid the rule acts face by face: at every face of
//! component `a` with `O ≥ 0`, `u` is the velocity's point query there (the
//! face's own component and the other two interpolated), and only `u_a` is
//! updated, `u_a −= (1+α)(u·n) n_a`. `O` and the unit normal `n = ∇O/|∇O|`
//! are sampled once at the cell centres and at those faces when a
//! [`Boundary`] is built (obstacles do not move).
//!
//! # Two methods
//! [`ObstacleMethod::Exact`] (the default) knows the obstacles in the
//! pressure solve: faces between fluid cells are open, the others closed
//! ([`open_faces`]), and the projection makes the fluxes through the faces of
//! every wet cell balance
//! ([`crate::pressure::obstacles`]), so no flow enters an obstacle. The rule
//! then has nothing to turn around; its α keeps a meaning for the
//! tangential flow: the closed faces inside an obstacle carry α times the
//! fluid's velocity beside them ([`OpenFaces::extend`]) — reflect (α = 1) is
//! a free-slip wall, sticky with α < 1 slows the flow along the wall,
//! α = 0 holds it at zero half a cell inside the wall.
//!
//! [`ObstacleMethod::Notes`] is the notes' method, kept to reproduce them:
//! the pressure solve is periodic and knows nothing of obstacles, so after a
//! projection the rule is broken, and after the rule the velocity is
//! divergent near obstacles. The simulation applies the rule and the
//! projection alternately [`Boundary::passes`] times and always ends with
//! the rule. It leaks (README, "Obstacles"): the projected jet runs into an
//! obstacle and the gas carried there is lost.
//!
//! Both methods report the same measures ([`Leak`]): the flux
//! divergence over the wet cells, the speed through closed faces, and the
//! mass in dry cells. QUICK in addition closes every face of an obstacle
//! cell and makes its advecting face velocities divergence-free around
//! them with a small Poisson solve ([`crate::advection::quick`]).

pub mod wall_stop;
pub mod level_set;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::domain::Domain;
use crate::error::InputError;
pub use crate::grid::OpenFaces;
use crate::grid::{FaceGrid, ScalarGrid};
use crate::metrics::{rms_max, RmsMax};
pub use level_set::{
    AsField, Cuboid, FieldLevelSet, LevelSet, Obstacle, Slab, Sphere, Union, Walls,
};
pub use wall_stop::WallStop;

/// What happens to fluid flowing into an obstacle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum BoundaryRule {
    /// Eq 6.6: the inward normal velocity is reversed.
    #[default]
    Reflect,
    /// Eq 6.7: the inward normal velocity is reversed and scaled by α.
    Sticky,
}

impl BoundaryRule {
    /// Every variant, for tests and listings.
    pub const ALL: [BoundaryRule; 2] = [BoundaryRule::Reflect, BoundaryRule::Sticky];
}

/// How the pressure solve treats obstacles (module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ObstacleMethod {
    /// Pressure solve over the fluid cells (conjugate gradients): no flux
    /// through closed faces.
    #[default]
    Exact,
    /// Eqs 6.6–6.7 alternated with the periodic projection (the notes).
    Notes,
}

impl ObstacleMethod {
    /// The name used in configurations and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ObstacleMethod::Exact => "exact",
            ObstacleMethod::Notes => "notes",
        }
    }
}

/// The method, the rule, its α and the number of rule/projection passes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoundaryOptions {
    /// Cut-cell projection or the notes' rule.
    pub method: ObstacleMethod,
    /// Reflect (6.6) or sticky (6.7).
    pub rule: BoundaryRule,
    /// Fraction α of the normal velocity a sticky boundary sends back (ignored by reflect).
    pub alpha: f32,
    /// Rule/projection pairs per step with the notes' method (at least 1;
    /// the step ends with the rule).
    pub passes: usize,
}

impl Default for BoundaryOptions {
    fn default() -> Self {
        Self {
            method: ObstacleMethod::Exact,
            rule: BoundaryRule::Reflect,
            alpha: 0.5,
            passes: 4,
        }
    }
}

impl BoundaryOptions {
    /// Check α and the pass count; the message names the bad value.
    pub fn validate(&self) -> Result<(), InputError> {
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(InputError::new(format!(
                "alpha is {}; it must be in [0, 1]",
                self.alpha
            )));
        }
        if self.passes == 0 {
            return Err(InputError::new(
                "boundary passes is 0; it must be at least 1",
            ));
        }
        Ok(())
    }

    /// The fraction α of inward normal velocity sent back (notes) or of
    /// tangential velocity carried into the wall (exact): 1 for reflect.
    pub fn retained(&self) -> f32 {
        match self.rule {
            BoundaryRule::Reflect => 1.0,
            BoundaryRule::Sticky => self.alpha,
        }
    }
}

/// Obstacles sampled on a domain, with the rule that keeps fluid out of them.
#[derive(Clone)]
pub struct Boundary {
    options: BoundaryOptions,
    /// `O` at the cell centres.
    level: ScalarGrid,
    /// Per velocity component, its faces with `O ≥ 0` (periodic box).
    faces: [Vec<SolidFace>; 3],
    /// Which faces are open.
    faces_open: OpenFaces,
}

/// A face inside or on an obstacle.
#[derive(Clone, Copy, Debug)]
struct SolidFace {
    /// Index into its component's array.
    index: usize,
    /// Position in cell-centre grid coordinates.
    at: Vec3,
    /// Unit `∇O/|∇O|` (zero where `∇O = 0`).
    normal: Vec3,
}

impl Boundary {
    /// Sample `obstacle` on `domain`.
    ///
    /// # Errors
    /// If the options are invalid.
    pub fn new(
        domain: Domain,
        obstacle: &Obstacle,
        options: BoundaryOptions,
    ) -> Result<Self, InputError> {
        options.validate()?;
        let level = ScalarGrid::from_field(domain, &AsField(obstacle.clone()));
        let faces = std::array::from_fn(|a| {
            let [nx, ny, nz] = domain.dims;
            (0..nz)
                .into_par_iter()
                .flat_map_iter(|k| (0..ny).flat_map(move |j| (0..nx).map(move |i| (i, j, k))))
                .filter_map(|(i, j, k)| {
                    let mut at = Vec3::new(i as f32, j as f32, k as f32);
                    at[a] -= 0.5;
                    let p = domain.world_of(at);
                    let level = obstacle.value(p);
                    (level >= 0.0).then(|| SolidFace {
                        index: domain.index(i, j, k),
                        at,
                        normal: obstacle.gradient(p).normalize_or_zero(),
                    })
                })
                .collect()
        });
        Ok(Self {
            options,
            faces_open: OpenFaces::new(&level),
            level,
            faces,
        })
    }

    /// The rule and pass count.
    pub fn options(&self) -> &BoundaryOptions {
        &self.options
    }

    /// The level set, for stopping tracers at the obstacles' surface.
    pub fn wall_stop(&self) -> WallStop {
        WallStop::new(self.level.clone())
    }

    /// Which faces are open, and the cells they make wet.
    pub fn open_faces(&self) -> &OpenFaces {
        &self.faces_open
    }

    /// Rule/projection pairs per step (notes' method).
    pub fn passes(&self) -> usize {
        self.options.passes
    }

    /// `O` at the cell centres (positive inside, world units).
    pub fn level(&self) -> &ScalarGrid {
        &self.level
    }

    /// Whether each cell is inside an obstacle (`O ≥ 0`), `[z][y][x]` order.
    pub fn solid(&self) -> Vec<bool> {
        self.level.as_slice().iter().map(|&o| o >= 0.0).collect()
    }

    /// Eqs 6.6/6.7 on every face with `O ≥ 0` and `u·∇O > 0`, `u` the
    /// velocity's point query at the face before the rule.
    ///
    /// # Panics
    /// If `vel` is on another domain or in a closed box.
    pub fn apply(&self, vel: &mut FaceGrid) {
        assert_eq!(
            vel.domain(),
            self.level.domain(),
            "boundary: velocity on another domain"
        );
        assert_eq!(
            vel.kind(),
            crate::grid::BoxKind::Periodic,
            "boundary: closed box"
        );
        let k = 1.0 + self.options.retained();
        let before = vel.clone();
        for (a, faces) in self.faces.iter().enumerate() {
            let updated: Vec<f32> = faces
                .par_iter()
                .map(|f| {
                    let u = before.sample_grid_coords(f.at);
                    let un = u.dot(f.normal);
                    let ua = before.slice(a)[f.index];
                    if un > 0.0 {
                        ua - k * un * f.normal[a]
                    } else {
                        ua
                    }
                })
                .collect();
            let comp = vel.slice_mut(a);
            for (f, v) in faces.iter().zip(updated) {
                comp[f.index] = v;
            }
        }
    }

    /// Every leak measure at once, for `metrics.csv` and tests.
    pub fn leak(&self, vel: &FaceGrid, densities: &[&ScalarGrid]) -> Leak {
        let inside: f64 = densities
            .iter()
            .map(|r| self.faces_open.mass_inside(r.as_slice()))
            .sum();
        let total: f64 = densities.iter().map(|r| r.total()).sum();
        Leak {
            div_fluid: rms_max(&self.faces_open.wet_flux_divergence(vel)),
            closed_flux_max: self.faces_open.closed_flux_max(vel),
            mass_fluid: total - inside,
            mass_inside: inside,
            mass_fraction: if total > 0.0 { inside / total } else { 0.0 },
        }
    }
}

/// How well obstacles hold after a step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Leak {
    /// Flux divergence `D_A u` over the wet cells ([`open_faces`]).
    pub div_fluid: RmsMax,
    /// Largest speed through a closed face beside the fluid.
    pub closed_flux_max: f32,
    /// Density mass `Σ ρ Δx³` in the wet cells (the fluid).
    pub mass_fluid: f64,
    /// Density mass in the dry cells (inside obstacles), at any depth.
    pub mass_inside: f64,
    /// `mass_inside` over the total mass (0 when there is none).
    pub mass_fraction: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn ball_in_box(rule: BoundaryRule, alpha: f32) -> Boundary {
        let d = Domain::cube(16, 4.0).unwrap();
        let o: Obstacle = Arc::new(Union(vec![
            Arc::new(Sphere {
                center: Vec3::splat(2.0),
                radius: 0.9,
            }),
            Arc::new(Walls {
                interior: Cuboid {
                    min: Vec3::splat(0.5),
                    max: Vec3::splat(3.5),
                },
            }),
        ]));
        Boundary::new(
            d,
            &o,
            BoundaryOptions {
                method: ObstacleMethod::Notes,
                rule,
                alpha,
                passes: 1,
            },
        )
        .unwrap()
    }

    fn random_velocity(d: Domain) -> FaceGrid {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut v = FaceGrid::zeros(d, crate::grid::BoxKind::Periodic);
        for a in 0..3 {
            for x in v.slice_mut(a) {
                *x = rng.random_range(-1.0..1.0);
            }
        }
        v
    }

    #[test]
    fn rejects_bad_alpha_and_passes() {
        for (alpha, passes) in [(1.5, 1), (-0.1, 1), (f32::NAN, 1), (0.5, 0)] {
            let o = BoundaryOptions {
                method: ObstacleMethod::Notes,
                rule: BoundaryRule::Sticky,
                alpha,
                passes,
            };
            assert!(o.validate().is_err(), "{o:?}");
        }
    }

    #[test]
    fn reflect_and_sticky_turn_the_inward_normal_component() {
        for (rule, alpha) in [
            (BoundaryRule::Reflect, 0.3),
            (BoundaryRule::Sticky, 0.5),
            (BoundaryRule::Sticky, 0.0),
        ] {
            let b = ball_in_box(rule, alpha);
            let kept = b.options().retained();
            let before = random_velocity(*b.level().domain());
            let mut after = before.clone();
            b.apply(&mut after);
            let mut touched = 0;
            for (a, faces) in b.faces.iter().enumerate() {
                let solid: std::collections::HashSet<usize> =
                    faces.iter().map(|f| f.index).collect();
                for f in faces {
                    let (u0, n) = (before.sample_grid_coords(f.at), f.normal);
                    let (un, old, new) =
                        (u0.dot(n), before.slice(a)[f.index], after.slice(a)[f.index]);
                    if un > 0.0 {
                        touched += 1;
                        // Eq 6.7 on the face's own component: the inward
                        // normal part of u becomes −α times itself.
                        let want = old - (1.0 + kept) * un * n[a];
                        assert!((new - want).abs() <= 1e-6, "{rule:?}: {new} vs {want}");
                    } else {
                        assert_eq!(old, new, "{rule:?}: outflowing face changed");
                    }
                }
                for (m, (x, y)) in before.slice(a).iter().zip(after.slice(a)).enumerate() {
                    if !solid.contains(&m) {
                        assert_eq!(x, y, "{rule:?}: fluid face changed");
                    }
                }
            }
            assert!(touched > 100, "only {touched} faces tested");
            // On a face whose own axis is the normal, the face's component
            // is the whole normal velocity: it now points outward (≤ 0).
            for (a, faces) in b.faces.iter().enumerate() {
                for f in faces.iter().filter(|f| f.normal[a].abs() > 0.999) {
                    assert!(after.slice(a)[f.index] * f.normal[a] <= 1e-6);
                }
            }
            assert!(b.open_faces().closed_flux_max(&before) > 0.5);
        }
    }

    #[test]
    fn measures_mass_in_dry_cells_at_any_depth() {
        let b = ball_in_box(BoundaryRule::Reflect, 1.0);
        let d = *b.level().domain();
        let mut rho = ScalarGrid::zeros(d);
        // One unit of density in each of: a cell just inside the ball
        // (O = 0.9 − 0.875 = 0.025, shallower than a cell), the ball's
        // centre, and the fluid cell just above the ball.
        let (rim, deep, fluid) = (d.index(8, 11, 8), d.index(8, 8, 8), d.index(8, 12, 8));
        let wet = b.open_faces().wet();
        assert!(!wet[rim] && !wet[deep] && wet[fluid]);
        for c in [rim, deep, fluid] {
            rho.as_slice_mut()[c] = 1.0;
        }
        let inside = b.open_faces().mass_inside(rho.as_slice());
        assert!((inside - 2.0 * d.cell_volume() as f64).abs() < 1e-9);
    }
}
