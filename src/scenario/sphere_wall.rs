//! The sphere wall of §7.3 (figs 7.3–7.8, 8.1): "a density distribution
//! consisting of a wall of small spheres of density. Each row has a
//! different color. A fluid simulation unrelated to this density field" moves
//! it.
//!
//! - **The flow** ([`FlowHistory`]): a gridded hot/cold run (§6.1.1) that
//!   knows nothing of the wall. It runs for `warmup` simulated time so the
//!   plumes are moving, then its velocity grid at the start of each of the
//!   next `frames` frames (`steps_per_frame` solver steps each) is kept in
//!   memory (shared, [`Arc`]) and replayed.
//! - **The wall** ([`Wall`]): `rows × cols` balls of density 1 with a smooth
//!   edge, in the plane `z = L/2` through both plumes; each row is its own
//!   density (and its own volume and colour in the render).
//! - **Holding the wall** over `F` frames:
//!   - *k gridless* ([`GriddedWall`] then [`AdvectedWall::gridless`]): each
//!     row is advected on the velocity grid and resampled every frame
//!     (eq 6.4 without source) for the first `F − k` frames; the grids are
//!     then composed with the gridless backward map of the last `k` stored
//!     velocities, `ρ = ρ_{F−k} ∘ X_k` (eqs 7.1–7.4), and never resampled.
//!     `k = 0` is fig 7.4, `k = 1` fig 7.5, `k = 10` figs 7.6–7.7, `k = F`
//!     (the analytic balls composed with the whole chain) fig 7.8;
//!   - *SELMA* ([`SelmaWall`]): the backward map advected and resampled on
//!     its own grid every frame (eq 8.8, `τ = 0`: no re-anchoring, no
//!     source — the notes' SELMA) and composed with the analytic balls,
//!     fig 8.1; a map grid finer than the velocity's is SELMA^fine (fig 8.2).
//!
//! All rows share one map; the map is wrapped in [`memo::Memo`] so a batch
//! of march samples walks the chain once for all rows. The walk's work is
//! counted ([`AdvectedWall::walk_steps`]: points mapped × stored steps).
//!
//! Memory ([`AdvectedWall::bytes`]) counts the buffers the representation
//! holds when it is rendered: the row grids, the stored velocity grids of
//! the gridless chain, the SELMA model's grids — each allocation once.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::advection::{interpolate_scalar, Backtrace, Departures};
use crate::density::occupancy::{self, Occupancy, Support};
use crate::density::{total_bytes, Buffer, GridlessField, MapField, Selma, StepInput};
use crate::domain::Domain;
use crate::error::{check_non_negative, check_positive, InputError};
use crate::field::{memo, ops, Scalar, ScalarField, VectorField};
use crate::grid::{FaceGrid, ScalarGrid};
use crate::scenario::hot_cold::HotColdConfig;
use crate::scenario::{Scenario, SolverConfig};

/// Parameters of the sphere wall and of the flow that moves it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SphereWallConfig {
    /// Cells per axis of the hot/cold velocity grid (the notes' 50).
    pub res: usize,
    /// Edge length L of the periodic box.
    pub size: f32,
    /// Frames the wall is advected over (the notes' 60).
    pub frames: usize,
    /// Simulated time of those frames; Δt = duration / frames.
    pub duration: f32,
    /// Simulated time the flow runs before the wall is placed.
    pub warmup: f32,
    /// Solver steps per recorded frame, each of Δt / `steps_per_frame`: a
    /// frame is a film frame, the flow's solver may take several steps in
    /// it; the wall moves once per frame, by the velocity at its start.
    pub steps_per_frame: usize,
    /// Horizontal offset of the hot/cold sources along x, hot by `+offset`
    /// and cold by `−offset` ([`HotColdConfig::offset`], in the wall's
    /// plane): 0 the head-on flow, positive gases that pass each other.
    pub offset: f32,
    /// Rows of balls (one colour each).
    pub rows: usize,
    /// Balls per row.
    pub cols: usize,
    /// Radius of a ball (middle of its edge).
    pub radius: f32,
    /// Width of the balls' smooth edge.
    pub edge: f32,
    /// Distance between neighbouring ball centres.
    pub spacing: f32,
}

impl Default for SphereWallConfig {
    fn default() -> Self {
        Self {
            res: 50,
            size: 10.0,
            frames: 60,
            duration: 3.0,
            warmup: 1.5,
            steps_per_frame: 1,
            offset: 0.0,
            rows: 6,
            cols: 8,
            radius: 0.42,
            edge: 0.15,
            spacing: 1.05,
        }
    }
}

impl SphereWallConfig {
    /// Time step of the recorded frames.
    pub fn dt(&self) -> f32 {
        self.duration / self.frames.max(1) as f32
    }

    /// Check every parameter; the message names the bad value.
    pub fn validate(&self) -> Result<(), InputError> {
        let positive = |name: &str, v: f32| {
            check_positive(name, v).map_err(|e| InputError::new(format!("sphere wall: {e}")))
        };
        positive("size", self.size)?;
        positive("duration", self.duration)?;
        positive("radius", self.radius)?;
        positive("edge", self.edge)?;
        positive("spacing", self.spacing)?;
        check_non_negative("warmup", self.warmup)
            .map_err(|e| InputError::new(format!("sphere wall: {e}")))?;
        if self.frames == 0 || self.rows == 0 || self.cols == 0 || self.steps_per_frame == 0 {
            return Err(InputError::new(format!(
                "sphere wall: frames {}, rows {}, cols {}, steps per frame {}: each must be at least 1",
                self.frames, self.rows, self.cols, self.steps_per_frame
            )));
        }
        if self.spacing < 2.0 * self.radius + self.edge {
            return Err(InputError::new(format!(
                "sphere wall: spacing {} is less than a ball's diameter with its edge ({}); balls must not overlap",
                self.spacing,
                2.0 * self.radius + self.edge
            )));
        }
        let extent =
            (self.rows.max(self.cols) - 1) as f32 * self.spacing + 2.0 * self.radius + self.edge;
        if extent >= self.size {
            return Err(InputError::new(format!(
                "sphere wall: the wall spans {extent} but the box is only {}; use fewer rows or columns, or a smaller spacing",
                self.size
            )));
        }
        self.flow_config().validate()
    }

    /// The hot/cold run that makes the flow: gridded, the same box and
    /// resolution, its sources moved by ±`offset` along x, warmup plus
    /// the wall's frames at `steps_per_frame` solver steps each.
    pub fn flow_config(&self) -> HotColdConfig {
        HotColdConfig {
            solver: SolverConfig {
                res: self.res,
                size: self.size,
                dt: self.solver_dt(),
                frames: self.warmup_steps() + self.frames * self.steps_per_frame,
                save_every: 0,
                ..SolverConfig::default()
            },
            offset: self.offset,
            ..HotColdConfig::default()
        }
    }

    /// Solver steps before the first frame.
    fn warmup_steps(&self) -> usize {
        (self.warmup / self.solver_dt()).round() as usize
    }

    /// The solver's Δt: the frame's over its steps.
    fn solver_dt(&self) -> f32 {
        self.dt() / self.steps_per_frame.max(1) as f32
    }
}

/// The recorded velocity of a run the wall knows nothing about.
pub struct FlowHistory {
    /// The velocity grid's box.
    pub domain: Domain,
    /// Δt of every frame.
    pub dt: f32,
    /// Backtrace of every frame (the simulation's).
    pub backtrace: Backtrace,
    /// Velocity at the start of each frame, oldest first.
    pub velocities: Vec<Arc<FaceGrid>>,
}

impl FlowHistory {
    /// Run the hot/cold flow of `config` and keep its velocity grids.
    pub fn record(config: &SphereWallConfig) -> Result<Self, InputError> {
        config.validate()?;
        let flow = config.flow_config();
        let mut sim = flow.build()?;
        for _ in 0..config.warmup_steps() {
            sim.step();
        }
        let mut velocities = Vec::with_capacity(config.frames);
        for _ in 0..config.frames {
            velocities.push(Arc::new(sim.velocity.clone()));
            for _ in 0..config.steps_per_frame {
                sim.step();
            }
        }
        Ok(Self {
            domain: *sim.domain(),
            dt: config.dt(),
            backtrace: flow.solver.backtrace,
            velocities,
        })
    }

    /// Number of recorded frames.
    pub fn frames(&self) -> usize {
        self.velocities.len()
    }

    /// Largest |u| over the recorded frames.
    pub fn max_speed(&self) -> f32 {
        self.velocities
            .iter()
            .map(|u| u.max_norm())
            .fold(0.0, f32::max)
    }
}

/// One row of balls: centres `(x0 + j·spacing, y, z)`, `j < count`. Only the
/// nearest ball is evaluated (balls do not overlap).
struct BallRow {
    x0: f32,
    y: f32,
    z: f32,
    spacing: f32,
    count: usize,
    radius: f32,
    edge: f32,
}

impl ScalarField for BallRow {
    fn eval(&self, p: Vec3) -> f32 {
        let j = ((p.x - self.x0) / self.spacing)
            .round()
            .clamp(0.0, (self.count - 1) as f32);
        let c = Vec3::new(self.x0 + j * self.spacing, self.y, self.z);
        let t = ((self.radius + 0.5 * self.edge - (p - c).length()) / self.edge).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    }
}

/// The unadvected wall (fig 7.3): one analytic density per row, top row first.
pub struct Wall {
    /// Row densities.
    pub rows: Vec<Scalar>,
}

impl Wall {
    /// The wall of `config`, centred in the plane `z = L/2`.
    pub fn new(config: &SphereWallConfig) -> Self {
        let c = 0.5 * config.size;
        let half = |n: usize| 0.5 * (n - 1) as f32 * config.spacing;
        let rows = (0..config.rows)
            .map(|i| {
                Arc::new(BallRow {
                    x0: c - half(config.cols),
                    y: c + half(config.rows) - i as f32 * config.spacing,
                    z: c,
                    spacing: config.spacing,
                    count: config.cols,
                    radius: config.radius,
                    edge: config.edge,
                }) as Scalar
            })
            .collect();
        Self { rows }
    }
}

/// The wall advected on the velocity grid, one frame at a time (eq 6.4).
#[derive(Clone)]
pub struct GriddedWall {
    /// Row densities at the cell centres.
    pub grids: Vec<ScalarGrid>,
    scratch: ScalarGrid,
    departures: Departures,
    frame: usize,
}

impl GriddedWall {
    /// The wall sampled at the cell centres of `domain` (frame 0).
    pub fn new(wall: &Wall, domain: Domain) -> Self {
        Self {
            grids: wall
                .rows
                .iter()
                .map(|r| ScalarGrid::from_field(domain, &**r))
                .collect(),
            scratch: ScalarGrid::zeros(domain),
            departures: Departures::new(domain),
            frame: 0,
        }
    }

    /// Frames advected so far.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// Advect every row through the next recorded frame: `ρ ← ρ(x_d)`.
    ///
    /// # Panics
    /// If every recorded frame has been used.
    pub fn advance(&mut self, flow: &FlowHistory) {
        let u = &flow.velocities[self.frame];
        self.departures.trace(u, flow.dt, flow.backtrace);
        for g in &mut self.grids {
            interpolate_scalar(g, &self.departures, &mut self.scratch);
            std::mem::swap(g, &mut self.scratch);
        }
        self.frame += 1;
    }
}

/// The wall's map advected by SELMA, one frame at a time (eq 8.8).
pub struct SelmaWall {
    selma: Selma,
    frame: usize,
}

impl SelmaWall {
    /// The identity map on a grid of `map_res` cells per axis (`None`: the
    /// velocity grid's).
    pub fn new(flow: &FlowHistory, map_res: Option<usize>) -> Result<Self, InputError> {
        let map = match map_res {
            Some(r) => flow.domain.with_resolution(r)?,
            None => flow.domain,
        };
        Ok(Self {
            selma: Selma::new(flow.domain, map, None, None, 0.0),
            frame: 0,
        })
    }

    /// Advect the map through the next recorded frame.
    ///
    /// # Panics
    /// If every recorded frame has been used.
    pub fn advance(&mut self, flow: &FlowHistory) {
        let u = &flow.velocities[self.frame];
        self.selma.step(&StepInput {
            velocity: u,
            snapshot: None,
            dt: flow.dt,
            backtrace: flow.backtrace,
        });
        self.frame += 1;
    }

    /// Frames advected so far.
    pub fn frame(&self) -> usize {
        self.frame
    }
}

/// The wall as it is rendered: one density per row and what it holds.
pub struct AdvectedWall {
    /// Row densities.
    pub rows: Vec<Scalar>,
    /// Buffers held by the representation.
    pub buffers: Vec<Buffer>,
    /// Where any row may be positive (`density::occupancy`), when the rows
    /// are known grids, composed or not (`None`: the analytic wall, SELMA).
    pub occupancy: Option<Arc<Occupancy>>,
    /// Backward steps walked by the gridless chain so far (zero without one).
    walked: Arc<AtomicU64>,
}

/// The gridless chain's backward map, counting its work: each point mapped
/// is walked back through every stored step.
struct CountedWalk {
    map: MapField<GridlessField>,
    walked: Arc<AtomicU64>,
}

impl CountedWalk {
    fn count(&self, points: usize) {
        let steps = (points * self.map.0.steps()) as u64;
        self.walked.fetch_add(steps, Ordering::Relaxed);
    }
}

impl VectorField for CountedWalk {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.count(1);
        self.map.eval(p)
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.count(points.len());
        self.map.eval_batch(points, out);
    }
}

impl AdvectedWall {
    /// The row grids as they are (all frames gridded).
    pub fn gridded(gridded: &GriddedWall) -> Self {
        let grids: Vec<Arc<ScalarGrid>> = gridded.grids.iter().cloned().map(Arc::new).collect();
        let support = Support::of_grids(&gridded.grids.iter().collect::<Vec<_>>());
        let domain = *gridded.scratch.domain();
        Self {
            buffers: grids.iter().map(|g| Buffer::of_scalar(g)).collect(),
            rows: grids.into_iter().map(|g| g as Scalar).collect(),
            occupancy: Some(Arc::new(Occupancy::of_support(
                domain,
                &support,
                occupancy::BLOCK,
            ))),
            walked: Arc::default(),
        }
    }

    /// `ρ_m ∘ X` with `X` the gridless backward map through recorded frames
    /// `m … m + k − 1` (eqs 7.1–7.4), `ρ_m` the gridded rows at frame `m`
    /// (`None`: the analytic wall, `m = 0`).
    pub fn gridless(
        wall: &Wall,
        base: Option<&GriddedWall>,
        flow: &FlowHistory,
        k: usize,
    ) -> Result<Self, InputError> {
        let (from, mut this) = match base {
            Some(g) => (g.frame(), Self::gridded(g)),
            None => (
                0,
                Self {
                    rows: wall.rows.clone(),
                    buffers: vec![],
                    occupancy: None,
                    walked: Arc::default(),
                },
            ),
        };
        if from + k > flow.frames() {
            return Err(InputError::new(format!(
                "{k} gridless frames after {from} gridded exceed the {} recorded",
                flow.frames()
            )));
        }
        if k == 0 {
            return Ok(this);
        }
        let mut chain = GridlessField::new(flow.domain, None, None);
        for u in &flow.velocities[from..from + k] {
            chain.push(Arc::clone(u), flow.dt, flow.backtrace);
        }
        this.buffers
            .extend(chain.velocities().map(|u| Buffer::of_faces(u)));
        this.occupancy = base.map(|g| {
            let support = Support::of_grids(&g.grids.iter().collect::<Vec<_>>());
            Arc::new(Occupancy::gridless(
                &chain,
                &support,
                None,
                occupancy::BLOCK,
            ))
        });
        let map = memo::memo(Arc::new(CountedWalk {
            map: MapField(chain),
            walked: Arc::clone(&this.walked),
        }));
        this.rows = this
            .rows
            .into_iter()
            .map(|r| ops::compose(r, map.clone()))
            .collect();
        Ok(this)
    }

    /// The analytic wall composed with the SELMA map, `ρ₀ ∘ X` (eq 8.8).
    pub fn selma(wall: &Wall, selma: &SelmaWall) -> Self {
        let map = memo::memo(Arc::new(MapField(selma.selma.field().clone())));
        let mut buffers = vec![];
        selma.selma.buffers(&mut buffers);
        Self {
            rows: wall
                .rows
                .iter()
                .map(|r| ops::compose(r.clone(), map.clone()))
                .collect(),
            buffers,
            occupancy: None,
            walked: Arc::default(),
        }
    }

    /// Bytes held, each allocation once.
    pub fn bytes(&self) -> usize {
        total_bytes(self.buffers.iter().copied())
    }

    /// Backward steps the gridless chain has walked (points it mapped ×
    /// its stored steps; the memo's repeats are not walked), over every
    /// evaluation so far: the render work that grows with the chain.
    pub fn walk_steps(&self) -> u64 {
        self.walked.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> SphereWallConfig {
        SphereWallConfig {
            res: 16,
            frames: 4,
            duration: 0.8,
            warmup: 1.0,
            rows: 3,
            cols: 4,
            radius: 0.6,
            edge: 0.3,
            spacing: 1.6,
            ..SphereWallConfig::default()
        }
    }

    #[test]
    fn bad_walls_are_refused() {
        let overlap = SphereWallConfig {
            spacing: 0.5,
            ..tiny()
        };
        assert!(overlap.validate().unwrap_err().0.contains("overlap"));
        let wide = SphereWallConfig { cols: 9, ..tiny() };
        assert!(wide.validate().unwrap_err().0.contains("spans"));
        let none = SphereWallConfig { rows: 0, ..tiny() };
        assert!(none.validate().is_err());
    }

    #[test]
    fn all_gridded_equals_the_grid_and_zero_gridless_frames_add_nothing() {
        let config = tiny();
        let flow = FlowHistory::record(&config).unwrap();
        assert_eq!(flow.frames(), 4);
        assert!(flow.max_speed() > 0.0);
        let wall = Wall::new(&config);
        let mut g = GriddedWall::new(&wall, flow.domain);
        g.advance(&flow);
        g.advance(&flow);
        let a = AdvectedWall::gridded(&g);
        let b = AdvectedWall::gridless(&wall, Some(&g), &flow, 0).unwrap();
        let p = flow.domain.cell_center(7, 9, 8);
        assert_eq!(a.rows[1].eval(p), g.grids[1].eval(p));
        assert_eq!(b.rows[1].eval(p), a.rows[1].eval(p));
        // Two more gridless frames hold two more velocity grids.
        let c = AdvectedWall::gridless(&wall, Some(&g), &flow, 2).unwrap();
        assert_eq!(c.bytes() - a.bytes(), 2 * 12 * 16usize.pow(3));
        assert!(AdvectedWall::gridless(&wall, Some(&g), &flow, 3).is_err());
    }

    #[test]
    fn gridless_and_selma_maps_agree_after_one_frame() {
        // One step: both maps are the step's backtrace from the analytic
        // wall; SELMA's is its trilinear interpolant at the map nodes, so at
        // cell centres they agree to round-off.
        let config = tiny();
        let flow = FlowHistory::record(&config).unwrap();
        let wall = Wall::new(&config);
        let gl = AdvectedWall::gridless(&wall, None, &flow, 1).unwrap();
        let mut s = SelmaWall::new(&flow, None).unwrap();
        s.advance(&flow);
        let se = AdvectedWall::selma(&wall, &s);
        let pts: Vec<Vec3> = (0..16).map(|i| flow.domain.cell_center(i, 8, 8)).collect();
        for r in 0..config.rows {
            let (mut a, mut b) = (vec![0.0; 16], vec![0.0; 16]);
            gl.rows[r].eval_batch(&pts, &mut a);
            se.rows[r].eval_batch(&pts, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-4, "row {r}: {x} vs {y}");
            }
        }
    }
}
