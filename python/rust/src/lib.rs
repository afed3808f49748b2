//! `smokelab._smokelab`: the solver as a Python extension module (PyO3,
//! abi3 for every CPython ≥ 3.9), a thin layer over the library and the
//! application's run driver. The Python package `smokelab` re-exports it
//! (`python/src/smokelab/__init__.py`, stubs in `_smokelab.pyi`).
//!
//! Everything goes through the command line's own paths, so a keyword means
//! what `--set KEY=VALUE` means and fails with its message: a configuration
//! is `smokelab run`'s [`RunArgs::resolve`] of the keywords given as `--set`
//! pairs (each Python value written as its TOML value), a simulation is the
//! scenario's [`Scenario::build`], a step is [`Simulation::try_step`] with
//! the run driver's finiteness check, a checkpoint is the application's
//! `checkpoint.bin` format, and `run` is `smokelab run` itself
//! ([`cli::execute`]).

use std::path::PathBuf;
use std::sync::Arc;

use clap::{CommandFactory, ValueEnum};
use ndarray::{Array3, Dimension};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};

use smokelab::boundary::ObstacleMethod;
use smokelab::density::{DensityMode, DensityModel};
use smokelab::error::InputError;
use smokelab::field::Scalar;
use smokelab::grid::ScalarGrid;
use smokelab::render::camera::check_image_size;
use smokelab::render::output::{preview, Display};
use smokelab::render::{look, render, RenderSettings};
use smokelab::scenario::{config, Scenario, ScenarioKind, SolverConfig};
use smokelab::simulation::{Simulation, StepError};
use smokelab_app::cli::process::{default_run_dir, init_threads};
use smokelab_app::cli::run::{scenario_keys, RunArgs};
use smokelab_app::cli::{self, Cli, Command};
use smokelab_app::run::checkpoint::{self, Checkpoint, RunRecord};
use smokelab_app::run::frames::simulation_scene;
use smokelab_app::run::output_dir;

/// Bad input as Python sees it: `ValueError` with the command line's message.
fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// An application error: `ValueError` for bad input ([`InputError`], the
/// command line's exit 2), `RuntimeError` with its causes otherwise.
fn app_error(e: anyhow::Error) -> PyErr {
    match e.downcast_ref::<InputError>() {
        Some(input) => value_error(input),
        None => PyRuntimeError::new_err(format!("{e:#}")),
    }
}

/// The scenario named `name` as on the command line (`hot-cold`, …).
fn scenario_kind(name: &str) -> PyResult<ScenarioKind> {
    ScenarioKind::from_str(name, false).map_err(|_| {
        value_error(format!(
            "unknown scenario '{name}'; the scenarios are {}",
            scenario_names().join(", ")
        ))
    })
}

/// Every scenario's command-line name.
fn scenario_names() -> Vec<String> {
    ScenarioKind::ALL
        .iter()
        .map(|k| scenario_name(*k))
        .collect()
}

fn scenario_name(kind: ScenarioKind) -> String {
    kind.to_possible_value()
        .expect("every scenario has a name")
        .get_name()
        .to_string()
}

/// A keyword's Python value as the TOML value `--set KEY=VALUE` would
/// give: bool, integer (anything with `__index__`), float, string or path,
/// and lists (or tuples, arrays) of them; `None` leaves the key at its
/// default.
fn toml_value(key: &str, value: &Bound<'_, PyAny>) -> PyResult<Option<toml::Value>> {
    let bad = || {
        value_error(format!(
            "{key}={}: a {} is not a configuration value; give a bool, a number, a string or a list",
            value.repr().map_or_else(|_| "?".into(), |r| r.to_string()),
            value
                .get_type()
                .name()
                .map_or_else(|_| "?".into(), |n| n.to_string())
        ))
    };
    if value.is_none() {
        return Ok(None);
    }
    let v = if value.is_instance_of::<PyBool>() {
        toml::Value::Boolean(value.extract()?)
    } else if value.is_instance_of::<PyString>() {
        toml::Value::String(value.extract()?)
    } else if value.hasattr("__fspath__")? {
        let os = value.py().import("os")?;
        toml::Value::String(os.call_method1("fspath", (value,))?.extract()?)
    } else if value.is_instance_of::<PyList>()
        || value.is_instance_of::<PyTuple>()
        || value.hasattr("tolist")? && value.getattr("ndim")?.extract::<usize>()? > 0
    {
        let list = if value.hasattr("tolist")? {
            value.call_method0("tolist")?
        } else {
            value.clone()
        };
        let mut items = Vec::new();
        for item in list.try_iter()? {
            items.push(toml_value(key, &item?)?.ok_or_else(bad)?);
        }
        toml::Value::Array(items)
    } else if value.hasattr("__index__")? {
        let n = value.call_method0("__index__")?;
        toml::Value::Integer(n.extract().map_err(|_| {
            value_error(format!(
                "{key}={n}: the integer is out of range (a configuration integer is 64-bit)"
            ))
        })?)
    } else if value.is_instance_of::<PyFloat>() || value.hasattr("__float__")? {
        toml::Value::Float(value.extract()?)
    } else {
        return Err(bad());
    };
    Ok(Some(v))
}

/// The keywords as `smokelab run`'s `--set KEY=VALUE` pairs.
fn set_pairs(keys: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let mut pairs = Vec::new();
    for (key, value) in keys.into_iter().flat_map(|k| k.iter()) {
        let key: String = key.extract()?;
        if let Some(v) = toml_value(&key, &value)? {
            pairs.push(format!("{key}={v}"));
        }
    }
    Ok(pairs)
}

/// The arguments of `smokelab run SCENARIO --set …` for these pairs.
fn run_args(kind: ScenarioKind, set: Vec<String>) -> RunArgs {
    RunArgs {
        scenario: kind,
        set,
        quiet: true,
        ..RunArgs::default()
    }
}

/// Refuse a `SMOKELAB_SIMD` naming an unknown or unavailable instruction
/// set, as the command line does before any work.
fn check_simd() -> PyResult<()> {
    smokelab::simd::Isa::from_env()
        .map(|_| ())
        .map_err(value_error)
}

/// A simulation of scenario `C` as `smokelab run` would build it from `args`.
fn build<C: Scenario>(args: &RunArgs) -> Result<Built, InputError> {
    let config: C = args.resolve()?;
    let s = config.solver();
    args.check_selma_remap(s)?;
    init_threads(s.threads)?;
    let sim = config.build()?;
    Built::new(args.scenario, &config, sim)
}

/// A built simulation and what it was built from.
struct Built {
    sim: Simulation,
    solver: SolverConfig,
    record: RunRecord,
    config_json: String,
}

impl Built {
    fn new<C: Scenario>(
        scenario: ScenarioKind,
        config: &C,
        sim: Simulation,
    ) -> Result<Self, InputError> {
        let text = |e: &dyn std::fmt::Display| InputError::new(format!("configuration: {e}"));
        Ok(Self {
            sim,
            solver: config.solver().clone(),
            record: RunRecord {
                scenario,
                config: toml::to_string(config).map_err(|e| text(&e))?,
                checkpoint_every: 0,
                vdb: false,
                vdb_frames: Default::default(),
                paraview: false,
                render: None,
            },
            config_json: serde_json::to_string(config).map_err(|e| text(&e))?,
        })
    }
}

/// A simulation of one scenario, stepped from Python.
///
/// `Simulation(scenario="hot-cold", **keys)`: the scenario as `smokelab run`
/// builds it, each keyword a configuration key set as `--set KEY=VALUE`
/// would (`res=64`, `density="gridless"`, `hot_center=[5, 2, 5]`); an
/// unknown key or a bad value raises `ValueError` with the command line's
/// message. See `smokelab.keys(scenario)` for every key and its default.
#[pyclass(module = "smokelab._smokelab", name = "Simulation")]
pub struct PySimulation {
    inner: Built,
}

/// One step as the run driver takes it: refused steps and a velocity that
/// became non-finite are errors naming the step.
fn step_once(sim: &mut Simulation) -> PyResult<()> {
    let n = sim.step_index + 1;
    sim.try_step().map_err(|e| match e {
        StepError::Cfl(_) | StepError::Params(_) => value_error(format!("step {n}: {e}")),
    })?;
    if !sim.velocity.is_finite() {
        return Err(PyRuntimeError::new_err(format!(
            "velocity became non-finite at step {n}"
        )));
    }
    Ok(())
}

#[pymethods]
impl PySimulation {
    #[new]
    #[pyo3(signature = (scenario = "hot-cold", **keys))]
    fn new(py: Python<'_>, scenario: &str, keys: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        check_simd()?;
        let args = run_args(scenario_kind(scenario)?, set_pairs(keys)?);
        let inner = py
            .detach(|| smokelab::with_scenario!(args.scenario, C => build::<C>(&args)))
            .map_err(value_error)?;
        Ok(Self { inner })
    }

    /// Continue from a checkpoint file that `Simulation.checkpoint` wrote:
    /// the scenario rebuilt from its recorded configuration and the state
    /// restored, so that stepping on reproduces the original bitwise.
    #[staticmethod]
    fn resume(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        check_simd()?;
        let inner = py
            .detach(|| -> Result<Built, InputError> {
                let checkpoint = Checkpoint::read_file(&path)?;
                let record = checkpoint.run().clone();
                let table: toml::Table = toml::from_str(&record.config).map_err(|e| {
                    InputError::new(format!(
                        "{} holds a configuration that does not parse: {e}",
                        path.display()
                    ))
                })?;
                let layers = [("checkpoint".to_string(), table)];
                smokelab::with_scenario!(record.scenario, C => {
                    let config: C = config::resolve(&layers, &scenario_keys())?;
                    init_threads(config.solver().threads)?;
                    let mut sim = config.build()?;
                    sim.restore(checkpoint.into_state())?;
                    Built::new(record.scenario, &config, sim)
                })
            })
            .map_err(value_error)?;
        Ok(Self { inner })
    }

    /// Take `n` steps (default 1). The GIL is released during each step,
    /// so other Python threads run; Ctrl-C (`KeyboardInterrupt`) stops
    /// between two steps, leaving the state after the last whole one.
    ///
    /// Raises `ValueError` if a step is refused (QUICK beyond its CFL bound
    /// with `substeps=False`; the state is unchanged) and `RuntimeError` if
    /// the velocity becomes non-finite.
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: usize) -> PyResult<()> {
        for _ in 0..n {
            let sim = &mut self.inner.sim;
            py.detach(|| step_once(sim))?;
            py.check_signals()?;
        }
        Ok(())
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> usize {
        self.inner.sim.step_index
    }

    /// Simulated time, steps × Δt (as the run's `metrics.csv` records it).
    #[getter]
    fn time(&self) -> f32 {
        self.inner.sim.time()
    }

    /// The scenario's name (`hot-cold`, …).
    #[getter]
    fn scenario(&self) -> String {
        scenario_name(self.inner.record.scenario)
    }

    /// The resolved configuration, every key (a new dict each call; as
    /// `smokelab run --print-config` and the run's `manifest.json`).
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (&self.inner.config_json,))
    }

    /// Wall seconds per stage of the last step (`advect`, `inject`,
    /// `density`, `force`, `project`, `boundary`; `output` and `metrics`
    /// stay 0 here), the `t_*` columns of the run's `metrics.csv`.
    #[getter]
    fn stage_seconds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = &self.inner.sim.times;
        let out = PyDict::new(py);
        for (name, seconds) in [
            ("advect", t.advect),
            ("inject", t.inject),
            ("density", t.density),
            ("force", t.force),
            ("project", t.project),
            ("boundary", t.boundary),
            ("output", t.output),
            ("metrics", t.metrics),
        ] {
            out.set_item(name, seconds)?;
        }
        Ok(out)
    }

    /// The gases' names, in the simulation's order.
    #[getter]
    fn gases(&self) -> Vec<String> {
        self.inner
            .sim
            .gases
            .iter()
            .map(|g| g.name.clone())
            .collect()
    }

    /// The fields now, as a dict of new float32 arrays indexed `[z][y][x]`:
    /// each gas at the cell centres, shape `(nz, ny, nx)` (gridless and
    /// SELMA densities evaluated there, as the run's `<gas>_NNNN.npy`), and
    /// the velocity components `"u"`, `"v"`, `"w"` on their faces (`n`
    /// faces per axis in a periodic box, `n + 1` in a closed one; face `i`
    /// is the low face of cell `i`, as the run's `u_NNNN.npy`).
    ///
    /// Each array is the solver's buffer copied once into memory NumPy then
    /// owns: the solver overwrites and swaps its buffers every step, with
    /// the GIL released, so a view into them would change under the
    /// caller, and might show another step's data.
    fn fields<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = &mut self.inner.sim;
        py.detach(|| sim.evaluate_densities());
        let out = PyDict::new(py);
        for g in &sim.gases {
            out.set_item(&g.name, g.density().data().clone().into_pyarray(py))?;
        }
        for (axis, name) in ["u", "v", "w"].into_iter().enumerate() {
            out.set_item(name, sim.velocity.component(axis).clone().into_pyarray(py))?;
        }
        Ok(out)
    }

    /// Replace gas `name`'s density by `array`, shape `(nz, ny, nx)` at the
    /// cell centres (any real dtype, converted to float32), every value
    /// finite. The gas then starts from it as `smokelab run --initial FILE`
    /// starts from the file (in every density mode; a gridless gas's walk
    /// and a SELMA gas's map start afresh from it). A SELMA gas can be set
    /// only before the first step (its gases share one map).
    fn set_density(&mut self, name: &str, array: &Bound<'_, PyAny>) -> PyResult<()> {
        let np = array.py().import("numpy")?;
        let array = np
            .call_method1("asarray", (array,))?
            .call_method1("astype", ("float32",))?;
        let array = array
            .cast::<PyArrayDyn<f32>>()
            .map_err(|_| value_error("set_density: the array did not convert to float32"))?;
        let built = &mut self.inner;
        let sim = &mut built.sim;
        let Some(index) = sim.gases.iter().position(|g| g.name == name) else {
            return Err(value_error(format!(
                "set_density: no gas '{name}'; this simulation's gases are {}",
                sim.gases
                    .iter()
                    .map(|g| g.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        let domain = *sim.domain();
        let [nx, ny, nz] = domain.dims;
        if array.shape() != [nz, ny, nx] {
            return Err(value_error(format!(
                "set_density('{name}'): the array has shape {:?}; this simulation's grid is (nz, ny, nx) = ({nz}, {ny}, {nx})",
                array.shape()
            )));
        }
        let readonly = array.readonly();
        let view = readonly.as_array();
        let bad = view.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            let first = view
                .indexed_iter()
                .find(|(_, v)| !v.is_finite())
                .map(|(i, _)| i.slice().to_vec())
                .unwrap_or_default();
            return Err(value_error(format!(
                "set_density('{name}'): {bad} values are not finite (the first at [z, y, x] = {first:?}); a density must be finite"
            )));
        }
        if sim.gases[index].model.mode() == DensityMode::Selma && sim.step_index > 0 {
            return Err(value_error(format!(
                "set_density('{name}'): a SELMA gas can be set only before the first step (step {} now); its gases share one map",
                sim.step_index
            )));
        }
        let data = Array3::from_shape_vec((nz, ny, nx), view.iter().copied().collect())
            .expect("the shape was checked");
        let kind = sim.velocity.kind();
        let start: Scalar = Arc::new(ScalarGrid::from_array(domain, data).with_wrap(kind.wrap()));
        let walls = (sim.boundary.as_ref())
            .filter(|b| b.options().method == ObstacleMethod::Exact)
            .map(|b| Arc::new(b.wall_stop()));
        let gas = &mut sim.gases[index];
        // As the scenarios build a gas: with its source field if it has one.
        let source = (gas.source.total() > 0.0).then(|| gas.source_field.clone());
        let mut model =
            DensityModel::new(&built.solver.density_options(), domain, Some(start), source);
        if let DensityModel::Gridded(g) = &mut model {
            g.set_wrap(kind.wrap());
        }
        if let Some(walls) = &walls {
            model.set_walls(walls);
        }
        gas.model = model;
        sim.evaluate_densities();
        Ok(())
    }

    /// Write the whole state to the file `path` (the format of the run's
    /// `checkpoint.bin`, atomically), for `Simulation.resume`.
    fn checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let built = &self.inner;
        py.detach(|| checkpoint::write_file(&path, &built.sim, &built.record))
            .map_err(app_error)
    }

    /// The appendix-A ray marcher's image of the gases now, as `smokelab
    /// run --render` makes it (default camera and look, march step one
    /// cell): an `(height, width, 3)` uint8 sRGB array, row 0 at the top.
    #[pyo3(signature = (width = 320, height = 240))]
    fn render<'py>(&self, py: Python<'py>, width: u32, height: u32) -> PyResult<Bound<'py, PyAny>> {
        check_image_size(width, height).map_err(value_error)?;
        let sim = &self.inner.sim;
        let rgb = py
            .detach(|| {
                let domain = *sim.domain();
                let settings = RenderSettings::new(look::camera(&domain, width, height));
                render(&simulation_scene(sim), &settings)
                    .map(|r| preview(&r.image, &Display::default()).into_raw())
            })
            .map_err(value_error)?;
        let image = Array3::from_shape_vec((height as usize, width as usize, 3), rgb)
            .expect("an RGB image has 3 bytes per pixel");
        Ok(image.into_pyarray(py).into_any())
    }

    fn __repr__(&self) -> String {
        let s = &self.inner.solver;
        format!(
            "<smokelab.Simulation {} at {}³, {} density, step {}, t = {}>",
            self.scenario(),
            s.res,
            s.density,
            self.inner.sim.step_index,
            self.inner.sim.time()
        )
    }
}

/// `smokelab run SCENARIO --set KEY=VALUE …` into `out` (default: a new
/// folder under `runs/`), the keywords as `Simulation`'s; returns the run
/// folder. The GIL is released during the run; Ctrl-C takes effect when it
/// returns.
#[pyfunction]
#[pyo3(signature = (scenario = "hot-cold", out = None, overwrite = false, progress = false, **keys))]
fn run(
    py: Python<'_>,
    scenario: &str,
    out: Option<PathBuf>,
    overwrite: bool,
    progress: bool,
    keys: Option<&Bound<'_, PyDict>>,
) -> PyResult<PathBuf> {
    check_simd()?;
    let kind = scenario_kind(scenario)?;
    // Without `out`, a new folder of its own (as the command line's run).
    let out = match out {
        Some(out) => out,
        None => {
            output_dir::create_fresh(&default_run_dir(&scenario_name(kind))).map_err(app_error)?
        }
    };
    let args = RunArgs {
        out: Some(out.clone()),
        overwrite,
        quiet: !progress,
        ..run_args(kind, set_pairs(keys)?)
    };
    py.detach(|| {
        cli::execute(Cli {
            command: Some(Command::Run(args)),
        })
    })
    .map_err(app_error)?;
    Ok(out)
}

/// A key, its default as TOML text and its flag's help.
type KeyDoc = (String, Option<String>, Option<String>);

/// Every configuration key of `scenario`: `(key, default, help)`, the
/// default as TOML text (`None` for an optional key that is unset) and the
/// help of its command-line flag (`None` for a key set only by `--set`).
#[pyfunction]
#[pyo3(signature = (scenario = "hot-cold"))]
fn keys(scenario: &str) -> PyResult<Vec<KeyDoc>> {
    let kind = scenario_kind(scenario)?;
    let (names, defaults) = smokelab::with_scenario!(kind, C => (
        config::keys::<C>(),
        toml::Table::try_from(C::default()).expect("a configuration is a table"),
    ));
    let command = Cli::command();
    let run = command
        .find_subcommand("run")
        .expect("smokelab has a run command");
    let help = |key: &str| {
        run.get_arguments()
            .find(|a| a.get_long().map(|l| l.replace('-', "_")).as_deref() == Some(key))
            .and_then(|a| a.get_help())
            .map(|h| h.to_string())
    };
    Ok(names
        .into_iter()
        .map(|k| {
            let default = defaults.get(&k).map(|v| v.to_string());
            let help = help(&k);
            (k, default, help)
        })
        .collect())
}

/// The scenarios `smokelab run` knows, by name.
#[pyfunction]
fn scenarios() -> Vec<String> {
    scenario_names()
}

/// The solver of smokelab (Navier–Stokes smoke with gridded, gridless and
/// SELMA density) from Python; see the package `smokelab`.
#[pymodule]
fn _smokelab(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(keys, m)?)?;
    m.add_function(wrap_pyfunction!(scenarios, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("BUILD_COMMIT", smokelab::io::manifest::BUILD_COMMIT)?;
    Ok(())
}
