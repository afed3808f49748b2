//! What a script writes, through the run driver's writers, only inside its
//! `--out` folder.
//!
//! - `save(frame, velocity, [gases…])` — the frame's volumes and preview as
//!   `smokelab run` writes them ([`crate::run::write_frame`]: `<gas>_NNNN.npy`,
//!   `u/v/w_NNNN.npy`, `vel_NNNN.npy`, `preview_NNNN.png`; the first gas is
//!   drawn red, the others blue);
//! - `record(frame, dt, velocity, [gases…])` — one row of `metrics.csv`
//!   with the columns of `smokelab run` that a script has the data for, by
//!   the same functions and in the run's order ([`columns`]): the velocity's
//!   measures every step; the fine measures ([`crate::run::FineMeasures`]:
//!   `div_interp_*`, `ke_top_octave` and `<g>_mass, <g>_max, <g>_grad,
//!   <g>_subgrid` at 2×) every [`FINE_EVERY`] steps, `NaN` between —
//!   `record(frame, dt, velocity, [gases…], fine)` says when instead (a
//!   script passes `frame == frames` to measure the last, as `run` does);
//!   then per gas `<g>_grid_mass` (`Σ ρ Δx³` on the grid, every step) and
//!   `t_step`, the wall seconds since the previous row. (The run's
//!   `injected`, `lost`, budget, `density_bytes`, `substeps` and stage
//!   times have no script counterpart.)
//! - `writenpy(name, cache)` or `writenpy(name, field, region)` — one
//!   `name.npy` (a field is sampled at the region's cell centres);
//! - `manifest.json` at the end ([`crate::script::run`]).
//!
//! Names are file names — letters, digits, `_` and `-` — so nothing is
//! written outside `--out` — and no name may collide with another output
//! of the script ([`output_name`]): a gas or array is not named after the
//! velocity (`u`, `v`, `w`, `vel`: [`RESERVED`]), an array's name is not a
//! frame's
//! (`hot_0001`), nor an array's written before. A name is checked when its
//! cache is made (`scalarcache`) or its array written; nothing is written
//! under a refused name.
//!
//! Every write checks its fields are finite: a non-finite velocity or gas
//! stops the script (exit 1) naming the step and the field, instead of
//! writing NaN frames and a "complete" manifest.

use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Instant;

use glam::Vec3;
use indicatif::ProgressBar;
use rhai::{Array, Engine, FLOAT, INT};
use serde::Serialize;
use smokelab::density::probe::DensityMeasures;
use smokelab::field::ops;
use smokelab::grid::ScalarGrid;
use smokelab::io;
use smokelab::simulation::{Gas, Simulation, StepParams};

use super::types::{Fallible, Region, ScalarCache, ScalarF, VectorCache};
use crate::figures::table::Log;
use crate::run::{FineProbes, StepMeasures};

/// The steps whose fine measures `record(frame, dt, velocity, gases)`
/// takes: those of `smokelab run --metrics-every 10`.
pub const FINE_EVERY: usize = 10;

/// One cell of a `metrics.csv` row: an integer or a number, written as
/// `smokelab run` writes its column.
#[derive(Serialize)]
#[serde(untagged)]
enum Cell {
    Int(usize),
    F32(f32),
    F64(f64),
}

/// The column names of a script's `metrics.csv` for `gases`: `smokelab
/// run`'s columns that a script has the data for, in the run's order
/// ([`crate::run::metric_columns`]), then the script's own: per gas
/// `<g>_grid_mass` (`Σ ρ Δx³` on the grid, every step) and `t_step`.
pub fn columns(gases: &[String]) -> Vec<String> {
    let mut c: Vec<String> = [
        "step",
        "time",
        "max_u",
        "cfl",
        "div_rms",
        "div_max",
        "div_interp_rms",
        "div_interp_max",
        "div_point_rms",
        "div_point_max",
        "ke_top_octave",
    ]
    .map(String::from)
    .to_vec();
    for g in gases {
        c.extend(["mass", "max", "grad", "subgrid"].map(|m| format!("{g}_{m}")));
    }
    if gases.len() == 2 {
        c.push("mirror_error".into());
    }
    c.push("vel_mirror_error".into());
    c.extend(gases.iter().map(|g| format!("{g}_grid_mass")));
    c.push("t_step".into());
    c
}

/// The output folder and what has been written to it.
pub struct Recorder {
    /// The folder, once [`Recorder::open`] gave it.
    out: PathBuf,
    /// Progress on stderr: the step recorded, of the script's `frames`.
    pub progress: ProgressBar,
    /// A simulation holding the script's state, for the run's writers.
    shell: Option<Simulation>,
    /// The fine measures' state, on the first recorded grid.
    probes: Option<FineProbes>,
    log: Option<Log>,
    last_row: Instant,
    /// Frames whose volumes were written.
    pub saved_frames: Vec<usize>,
    /// Other files written (`writenpy`).
    pub files: Vec<String>,
    /// Set when a write found a non-finite field: the step and the field
    /// (the script then fails with exit 1, not as the user's mistake).
    pub non_finite: Option<String>,
}

/// Names a gas may not take: the velocity's, whose frames `u_NNNN.npy`,
/// `v_…`, `w_…` and `vel_NNNN.npy` sit beside the gases' `<gas>_NNNN.npy`.
pub const RESERVED: [&str; 4] = ["u", "v", "w", "vel"];

/// What a name is given to: a gas (`scalarcache`) or an array (`writenpy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Named {
    /// A scalar cache, saved as `<name>_NNNN.npy` frames.
    Gas,
    /// An array written once as `<name>.npy`.
    Array,
}

/// `name` if it is a plain file name that collides with no other output
/// of the script (see the module documentation), else why not.
pub fn output_name(what: &str, name: &str, named: Named) -> Result<String, String> {
    let name = file_name(what, name)?;
    if named == Named::Gas && RESERVED.contains(&name.as_str()) {
        return Err(format!(
            "{what}: a gas named `{name}` would collide with the velocity's frames \
             ({name}_NNNN.npy); a gas may not be named {}",
            RESERVED.join(", ")
        ));
    }
    if named == Named::Array
        && crate::run::output_dir::is_frame_file(&format!("{name}.npy"), &["npy"])
    {
        return Err(format!(
            "{what}: `{name}` is named like a saved frame (<gas>_NNNN) and could replace one; \
             choose a name that does not end in _ and four or more digits"
        ));
    }
    Ok(name)
}

/// `name` if it is a plain file name, else the refusal.
fn file_name(what: &str, name: &str) -> Result<String, String> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(name.to_string())
    } else {
        Err(format!(
            "{what}: `{name}` is not a file name; a script writes only inside --out, \
             under names of letters, digits, `_` and `-`"
        ))
    }
}

/// The script's gases: an array of scalar caches with distinct file names.
fn gases(a: &Array, what: &str) -> Fallible<Vec<ScalarCache>> {
    let mut out: Vec<ScalarCache> = Vec::new();
    for (i, d) in a.iter().enumerate() {
        let c = d.clone().try_cast::<ScalarCache>().ok_or_else(|| {
            format!(
                "{what}: element {i} is a {}, expected a scalarcache",
                d.type_name()
            )
        })?;
        output_name(what, &c.name, Named::Gas)?;
        if out.iter().any(|o| o.name == c.name) {
            return Err(format!("{what}: two gases are named `{}`", c.name).into());
        }
        out.push(c);
    }
    Ok(out)
}

impl Default for Recorder {
    /// A recorder with no folder yet (the script is compiled first).
    fn default() -> Self {
        Self {
            out: PathBuf::new(),
            progress: ProgressBar::hidden(),
            shell: None,
            probes: None,
            log: None,
            last_row: Instant::now(),
            saved_frames: vec![],
            files: vec![],
            non_finite: None,
        }
    }
}

impl Recorder {
    /// Write into `out` (which exists), showing progress on `progress`.
    pub fn open(&mut self, out: PathBuf, progress: ProgressBar) {
        self.out = out;
        self.progress = progress;
        self.last_row = Instant::now();
    }

    /// Whether nothing was written yet: no frame, metrics row or array.
    pub fn wrote_nothing(&self) -> bool {
        self.saved_frames.is_empty() && self.files.is_empty() && self.log.is_none()
    }

    /// The names of the gases of the first `save`/`record`, in order.
    pub fn gas_names(&self) -> Vec<String> {
        self.shell.as_ref().map_or_else(Vec::new, |s| {
            s.gases.iter().map(|g| g.name.clone()).collect()
        })
    }

    /// The grid of the first `save`/`record`.
    pub fn grid(&self) -> Option<crate::run::GridRecord> {
        self.shell.as_ref().map(|s| {
            let d = s.domain();
            crate::run::GridRecord {
                origin: d.origin.to_array(),
                cell: d.cell,
                dims: d.dims,
                layout: "MAC: u, v, w on the x-, y-, z-faces; densities at cell centres",
                boundary: s.velocity.kind().name(),
            }
        })
    }

    /// The shell simulation holding `velocity` and `caches`, built on the
    /// first call; later calls must pass the same gases.
    fn load(
        &mut self,
        velocity: &VectorCache,
        caches: &[ScalarCache],
        what: &str,
        step: usize,
    ) -> Fallible<&Simulation> {
        let fields = std::iter::once(("the velocity".to_string(), velocity.0.is_finite())).chain(
            caches
                .iter()
                .map(|c| (format!("the gas `{}`", c.name), c.grid.is_finite())),
        );
        for (field, finite) in fields {
            if !finite {
                return Err(self.fail(format!(
                    "{what}: {field} became non-finite by step {step}; nothing of step {step} \
                     was written"
                )));
            }
        }
        let domain = *velocity.0.domain();
        if caches.iter().any(|c| c.grid.domain() != &domain) {
            return Err(format!("{what}: a gas is not on the velocity's domain").into());
        }
        let names: Vec<&str> = caches.iter().map(|c| c.name.as_str()).collect();
        match &self.shell {
            Some(s)
                if s.domain() != &domain
                    || s.gases
                        .iter()
                        .map(|g| g.name.as_str())
                        .ne(names.iter().copied()) =>
            {
                return Err(format!(
                    "{what}: the gases or domain differ from the first frame's ({})",
                    s.gases
                        .iter()
                        .map(|g| g.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
                .into());
            }
            Some(_) => {}
            None => {
                let none = ops::constant(0.0);
                let gases = caches
                    .iter()
                    .enumerate()
                    .map(|(i, c)| {
                        Gas::new(
                            c.name.clone(),
                            domain,
                            &none,
                            if i == 0 { 1.0 } else { -1.0 },
                        )
                    })
                    .collect();
                let params = StepParams {
                    dt: 0.0,
                    viscosity: 0.0,
                    gravity: Vec3::ZERO,
                    backtrace: Default::default(),
                    interpolant: Default::default(),
                    confinement: 0.0,
                };
                let kind = velocity.0.kind();
                self.shell = Some(Simulation::new(domain, params, gases).with_box(kind));
            }
        }
        let sim = self.shell.as_mut().expect("built above");
        if sim.velocity.kind() == velocity.0.kind() {
            // In place: no allocation per recorded step.
            for axis in 0..3 {
                sim.velocity
                    .slice_mut(axis)
                    .copy_from_slice(velocity.0.slice(axis));
            }
        } else {
            sim.velocity = (*velocity.0).clone();
        }
        for (g, c) in sim.gases.iter_mut().zip(caches) {
            let rho: &mut ScalarGrid = g.model.gridded_mut().expect("shell gases are gridded");
            rho.as_slice_mut().copy_from_slice(c.grid.as_slice());
        }
        Ok(sim)
    }

    fn save(&mut self, frame: INT, velocity: &VectorCache, g: &Array) -> Fallible<()> {
        let frame = usize::try_from(frame).map_err(|_| format!("save: frame is {frame}"))?;
        let caches = gases(g, "save")?;
        let out = self.out.clone();
        let sim = self.load(velocity, &caches, "save", frame)?;
        crate::run::write_frame(sim, &out, frame, None).map_err(|e| format!("save: {e:#}"))?;
        self.saved_frames.push(frame);
        self.progress.set_message(format!("frame {frame} saved"));
        Ok(())
    }

    fn record(
        &mut self,
        frame: INT,
        dt: FLOAT,
        velocity: &VectorCache,
        g: &Array,
        fine: bool,
    ) -> Fallible<()> {
        let step = usize::try_from(frame).map_err(|_| format!("record: frame is {frame}"))?;
        super::types::time_step("record", dt)?;
        let caches = gases(g, "record")?;
        let out = self.out.join("metrics.csv");
        let elapsed = self.last_row.elapsed().as_secs_f64();
        self.load(velocity, &caches, "record", step)?;
        let sim = self.shell.as_ref().expect("loaded above");
        let domain = *sim.domain();
        let probes = self.probes.get_or_insert_with(|| FineProbes::new(domain));
        let StepMeasures { velocity, mirror } = StepMeasures::take(sim);
        let (div, max_u) = (velocity.divergence, velocity.mirror.max_norm);
        let fine = fine.then(|| probes.measure(sim));
        let (div_interp, div_point) = (
            fine.as_ref().map(|f| f.div_interp),
            fine.as_ref().map(|f| f.div_point),
        );
        let mut row = vec![
            Cell::Int(step),
            Cell::F32(step as f32 * dt as f32),
            Cell::F32(max_u),
            Cell::F32(max_u * dt as f32 / domain.cell),
            Cell::F32(div.rms),
            Cell::F32(div.max),
            Cell::F32(div_interp.map_or(f32::NAN, |d| d.rms)),
            Cell::F32(div_interp.map_or(f32::NAN, |d| d.max)),
            Cell::F32(div_point.map_or(f32::NAN, |d| d.rms)),
            Cell::F32(div_point.map_or(f32::NAN, |d| d.max)),
            Cell::F64(fine.as_ref().map_or(f64::NAN, |f| f.ke_top_octave)),
        ];
        for n in 0..sim.gases.len() {
            let m = fine.as_ref().map(|f| f.densities[n]);
            let value = |f: fn(&DensityMeasures) -> f64| Cell::F64(m.as_ref().map_or(f64::NAN, f));
            row.extend([
                value(|m| m.mass),
                value(|m| m.max),
                value(|m| m.mean_gradient),
                value(|m| m.subgrid_fraction),
            ]);
        }
        row.extend(mirror.map(Cell::F32));
        row.push(Cell::F32(velocity.mirror.error));
        row.extend(sim.gases.iter().map(|g| Cell::F64(g.density().total())));
        row.push(Cell::F64(elapsed));
        if self.log.is_none() {
            let columns = columns(&self.gas_names());
            self.log = Some(Log::create(out, &columns).map_err(|e| format!("record: {e:#}"))?);
        }
        let log = self.log.as_mut().expect("created above");
        log.push(&row).map_err(|e| format!("record: {e:#}"))?;
        self.progress.set_position(step as u64);
        self.last_row = Instant::now();
        Ok(())
    }

    /// Record the non-finite failure `why`; the error that stops the script.
    fn fail(&mut self, why: String) -> Box<rhai::EvalAltResult> {
        self.non_finite = Some(why.clone());
        why.into()
    }

    fn write_npy(&mut self, name: &str, grid: &ScalarGrid) -> Fallible<()> {
        let name = output_name("writenpy", name, Named::Array)?;
        let file = format!("{name}.npy");
        if self.files.contains(&file) {
            return Err(format!(
                "writenpy: `{name}` was written before; each array needs a name of its own"
            )
            .into());
        }
        if !grid.is_finite() {
            return Err(self.fail(format!(
                "writenpy: the array `{name}` is not finite; {name}.npy was not written"
            )));
        }
        io::write_npy3(&self.out.join(&file), grid.data())
            .map_err(|e| format!("writenpy: {e:#}"))?;
        self.files.push(file);
        Ok(())
    }
}

/// Register `save`, `record` and `writenpy`, writing through `recorder`.
pub fn register(engine: &mut Engine, recorder: &Rc<RefCell<Recorder>>) {
    let r = recorder.clone();
    engine.register_fn("save", move |frame: INT, v: VectorCache, g: Array| {
        r.borrow_mut().save(frame, &v, &g)
    });
    let r = recorder.clone();
    engine.register_fn(
        "record",
        move |frame: INT, dt: FLOAT, v: VectorCache, g: Array| {
            r.borrow_mut()
                .record(frame, dt, &v, &g, frame % FINE_EVERY as INT == 0)
        },
    );
    let r = recorder.clone();
    engine.register_fn(
        "record",
        move |frame: INT, dt: FLOAT, v: VectorCache, g: Array, fine: bool| {
            r.borrow_mut().record(frame, dt, &v, &g, fine)
        },
    );
    let r = recorder.clone();
    engine.register_fn("writenpy", move |name: &str, c: ScalarCache| {
        r.borrow_mut().write_npy(name, &c.grid)
    });
    let r = recorder.clone();
    engine.register_fn("writenpy", move |name: &str, f: ScalarF, region: Region| {
        let grid = ScalarGrid::from_field(region.domain, &*f.field);
        r.borrow_mut().write_npy(name, &grid)
    });
}
