//! What a script writes, through the run driver's writers, only inside its
//! `--out` folder.
//!
//! - `save(frame, velocity, [gases…])` — the frame's volumes and preview as
//!   `smokelab run` writes them ([`crate::run::write_frame`]: `<gas>_NNNN.npy`,
//!   `u/v/w_NNNN.npy`, `vel_NNNN.npy`, `preview_NNNN.png`; the first gas is
//!   drawn red, the others blue);
//! - `record(frame, dt, velocity, [gases…])` — one row of `metrics.csv`:
//!   `step, time, max_u, cfl, div_rms, div_max` as the run's columns, per
//!   gas `<g>_grid_mass` (`Σ ρ Δx³` on the grid; the run's `<g>_mass` is
//!   measured at 2× and is not computed here), `mirror_error` with two gases,
//!   and `t_step`, the wall seconds since the previous row;
//! - `writenpy(name, cache)` or `writenpy(name, field, region)` — one
//!   `name.npy` (a field is sampled at the region's cell centres);
//! - `manifest.json` at the end ([`crate::script::run`]).
//!
//! Names are file names — letters, digits, `_` and `-` — so nothing is
//! written outside `--out`.

use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Instant;

use glam::Vec3;
use rhai::{Array, Engine, FLOAT, INT};
use smokelab::field::ops;
use smokelab::grid::ScalarGrid;
use smokelab::io;
use smokelab::metrics;
use smokelab::simulation::{Gas, Simulation, StepParams};

use super::types::{Fallible, Region, ScalarCache, ScalarF, VectorCache};
use crate::table::Log;

/// The output folder and what has been written to it.
pub struct Recorder {
    out: PathBuf,
    /// A simulation holding the script's state, for the run's writers.
    shell: Option<Simulation>,
    log: Option<Log>,
    last_row: Instant,
    /// Frames whose volumes were written.
    pub saved_frames: Vec<usize>,
    /// Other files written (`writenpy`).
    pub files: Vec<String>,
}

/// `name` if it is a plain file name, else the refusal.
pub fn file_name(what: &str, name: &str) -> Fallible<String> {
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
        )
        .into())
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
        file_name(what, &c.name)?;
        if out.iter().any(|o| o.name == c.name) {
            return Err(format!("{what}: two gases are named `{}`", c.name).into());
        }
        out.push(c);
    }
    Ok(out)
}

impl Recorder {
    /// Write into `out` (which exists).
    pub fn new(out: PathBuf) -> Self {
        Self {
            out,
            shell: None,
            log: None,
            last_row: Instant::now(),
            saved_frames: vec![],
            files: vec![],
        }
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
    ) -> Fallible<&Simulation> {
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
                };
                self.shell = Some(Simulation::new(domain, params, gases));
            }
        }
        let sim = self.shell.as_mut().expect("built above");
        sim.velocity = (*velocity.0).clone();
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
        let sim = self.load(velocity, &caches, "save")?;
        crate::run::write_frame(sim, &out, frame, None).map_err(|e| format!("save: {e:#}"))?;
        self.saved_frames.push(frame);
        Ok(())
    }

    fn record(&mut self, frame: INT, dt: FLOAT, velocity: &VectorCache, g: &Array) -> Fallible<()> {
        let caches = gases(g, "record")?;
        let out = self.out.join("metrics.csv");
        let elapsed = self.last_row.elapsed().as_secs_f64();
        let sim = self.load(velocity, &caches, "record")?;
        let v = &sim.velocity;
        let max_u = v.max_norm();
        let div = metrics::divergence_stats(v);
        let cell = sim.domain().cell;
        let mut row = vec![
            frame as f64,
            frame as f64 * dt,
            max_u as f64,
            (max_u as f64) * dt / cell as f64,
            div.rms as f64,
            div.max as f64,
        ];
        row.extend(sim.gases.iter().map(|g| g.density().total()));
        let mut columns: Vec<String> = ["step", "time", "max_u", "cfl", "div_rms", "div_max"]
            .map(String::from)
            .to_vec();
        columns.extend(sim.gases.iter().map(|g| format!("{}_grid_mass", g.name)));
        if let [a, b] = &sim.gases[..] {
            row.push(metrics::mirror_error(a.density(), b.density()) as f64);
            columns.push("mirror_error".into());
        }
        row.push(elapsed);
        columns.push("t_step".into());
        if self.log.is_none() {
            self.log = Some(Log::create(out, &columns).map_err(|e| format!("record: {e:#}"))?);
        }
        let log = self.log.as_mut().expect("created above");
        log.push(&row).map_err(|e| format!("record: {e:#}"))?;
        self.last_row = Instant::now();
        Ok(())
    }

    fn write_npy(&mut self, name: &str, grid: &ScalarGrid) -> Fallible<()> {
        let name = file_name("writenpy", name)?;
        let path = self.out.join(format!("{name}.npy"));
        io::write_npy3(&path, grid.data()).map_err(|e| format!("writenpy: {e:#}"))?;
        self.files.push(format!("{name}.npy"));
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
            r.borrow_mut().record(frame, dt, &v, &g)
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
