//! # P-1 — step time against resolution, threads, stages and the floor
//!
//! Issue 16's performance experiment. A hot/cold step (gridded, SL RK2,
//! inviscid, every default but the resolution) at 32³ … 256³:
//!
//! - **time and cells/s**: the median wall time of `Simulation::step` over
//!   a few steps after a warm-up, on a 2-thread rayon pool (`pool.install`),
//!   and the fitted exponent `b` of `time ∝ cells^b` (least squares on
//!   `log t` against `log cells`, `smokelab::fit`);
//! - **threads**: the same steps on a 1-thread pool, from the same state,
//!   and the speed-up `t₁ / t₂`. The two fields after the steps must be
//!   bitwise equal at every resolution (the experiment fails otherwise);
//! - **stages**: the median of each stage's wall seconds that the step
//!   records (`Simulation::times`: advect, inject, density, force, project, boundary);
//! - **the floor**: one real 3D FFT pair of the same size — the faster of a
//!   f32 pair (the solver's periodic pair `PeriodicFft` in f32: realfft r2c
//!   along x, rustfft along y and z, the inverse back, [`FftPair`]) and the
//!   solver's own planned f64 pair
//!   (`PressureSolver::solve_poisson`) — plus one bandwidth-bound pass over
//!   the fused advection's fields (five f32 arrays of the cells read and
//!   five written: the three velocity components and the two gases),
//!   measured as five parallel copies; and the ratio step ÷ floor (issue
//!   16's target ≤ 2 at 128³);
//! - **metrics**: what `smokelab run` measures after a step, on the same
//!   state: the step diagnostics of every `diagnostics_every` steps
//!   (`run::StepMeasures`: velocity mirror and max, compact divergence, the
//!   gases' mirror) and the fine measures of every `metrics_every` steps
//!   (`run::FineProbes::measure`: each gas at 2×, the top-octave share, the
//!   interpolant at 4096 points); the diagnostics ÷ step (were they taken
//!   every step) and the run's metrics at the default cadences
//!   (`SolverConfig::diagnostics_every`, 10, and `metrics_every`, 100) ÷
//!   step;
//! - **kernel widths**: the same rounds (RK2 and Euler steps on 2
//!   threads, their stage times) once per instruction set this CPU has
//!   (`smokelab::simd::Isa::available`: scalar, AVX2 and AVX-512 here; NEON
//!   on aarch64), each selected in turn as `SMOKELAB_SIMD` would, the
//!   widths interleaved round by round; and one step of each from one
//!   state, the fields' bits asserted equal across widths (the experiment
//!   fails otherwise). `widths.csv`, the second table of `table.md`;
//! - **pressure precision**: at each size, periodic
//!   and closed, the hot/cold `u*` of one step after the warm-up projected
//!   by the f32 and by the f64 solve, `max|D u| Δx / max|u_a|` before and
//!   after each; `pressure_precision.csv`, the third table of `table.md`;
//! - **peers** (`--peers PYTHON`): `taichi_advect.py N 2 f32` and
//!   `fft_py.py N 2` from `../shared/peers/` (or `$SMOKELAB_PEERS_DIR`) at
//!   the same sizes in the same run, each run once right before smokelab's
//!   rounds at that size and once right after (their own processes cannot
//!   be interleaved round by round), the mean of the two taken, so a load
//!   that drifts during the size's measurements weighs on both sides alike;
//!   the composite peer step is Taichi's
//!   fused advection of 5 fields (Euler backtrace) plus three pyFFTW f32
//!   pairs, compared with smokelab's step with the same Euler backtrace
//!   (also measured, 2 threads). Without the flag the peer columns are
//!   absent and the manifest says so;
//! - **the Python module** (when the `--peers` Python also imports
//!   smokelab's solver, `pip install ./python`): hot/cold stepped from a
//!   Python loop, one `sim.step()` at a time, the median of the same
//!   warm-up and timed steps, run before and after smokelab's rounds as
//!   the peers are, at 32³…128³ (each process sets its run up anew, a
//!   minute at 256³); `python_step_ms` and `python_over_step` (÷ the
//!   2-thread RK2 step) in `data.csv` and the table. Absent otherwise,
//!   the manifest saying why.
//!
//! Every measurement of one step round — 2-thread RK2, 1-thread RK2,
//! 2-thread Euler, FFT pairs, bandwidth pass — is interleaved, so a busy
//! machine slows all of them alike; the ratios are the result, the
//! absolute times depend on the load (`/proc/loadavg` before and after is
//! in the manifest). The step times are `Simulation::step` alone: the run
//! driver's metrics (timed apart, above) and outputs are not in them, and the setup of each
//! resolution (the sources' cell averages, the FFT plans; slow at 256³) is
//! timed apart as `setup_s`.
//!
//! Run: `smokelab experiment P-1 [--peers PYTHON]` (2 warm-up and 8 timed
//! steps per resolution — eight rounds, so that the medians outlast a slow
//! spell of a shared machine; with four, one run's 64³ Euler median came
//! out above its RK2 one — about 2–3 minutes on 2 busy cores, a minute of
//! it the 256³ setup; the peers add a minute; `--full` 10 and 15 steps;
//! `--smoke` 16³ and 32³, 1 and 3; the widths add the scalar kernel's
//! steps, about half a minute at 256³). Writes `results/perf/`: `data.csv`
//! (one row per resolution, the default kernel's), `widths.csv` (one row
//! per resolution and kernel), `pressure_precision.csv`, `time.png` (step time against cells, log-log,
//! with the fit, the floor and the peer), `threads.png` (speed-up),
//! `stages.png` (each stage's share of the step), `table.md` (the table
//! for the README and the paper), `manifest.json`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context as _, Result};
use rayon::prelude::*;

use crate::experiment::kit::{Context, Experiment, Size};
use crate::experiment::shared::python_step::PythonStep;
use crate::figures::plot::{Annotation, LegendPosition, Plot, Series, Style};
use crate::figures::table::write_columns;
use crate::run::{FineProbes, StepMeasures};
use smokelab::advection::Backtrace;
use smokelab::error::InputError;
use smokelab::fit::linear_fit;
use smokelab::grid::{BoxKind, ScalarGrid};
use smokelab::io;
use smokelab::metrics::velocity_stats;
use smokelab::pressure::periodic_fft::PeriodicFft;
use smokelab::pressure::{PressurePrecision, PressureSolver};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::{Scenario, SolverConfig};
use smokelab::simd::Isa;
use smokelab::simulation::Simulation;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "P-1",
    folder: "perf",
    reproduces: "performance",
    title: "hot/cold step time 32³…256³: cells/s, fitted exponent, 1 vs 2 threads, stages, FFT floor (--peers PYTHON: Taichi + pyFFTW)",
    cost: "~2 min",
    run,
};

/// The largest resolution the Python module's step is measured at.
const PYTHON_MAX_RES: usize = 128;

/// Resolutions, warm-up steps and timed steps of a run size.
fn plan(size: Size) -> (Vec<usize>, usize, usize) {
    size.pick(
        (vec![16, 32], 1, 3),
        (vec![32, 64, 128, 256], 2, 8),
        (vec![32, 64, 128, 256], 10, 15),
    )
}

/// The experiment, with the peers run by `ctx.peers` when given.
///
/// # Errors
/// A Python that cannot be run or lacks taichi or pyfftw, or peer
/// scripts that cannot be found ([`InputError`], exit 2); a 1- and a
/// 2-thread step that differ in a bit; failed writes.
fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let peers = ctx.peers.as_deref().map(Peers::new).transpose()?;
    let python = match ctx.peers.as_deref() {
        Some(p) => PythonStep::probe(p),
        None => Err("absent: run with --peers PYTHON, a Python that imports smokelab".into()),
    };
    let (sizes, warm, steps) = plan(ctx.size);
    let load_before = loadavg();
    let pools = [1usize, 2].map(|n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("a thread pool")
    });
    let mut bar = crate::run::progress::stage(
        "resolutions",
        sizes.len() as u64,
        crate::run::progress::Growth::Constant,
        ctx.progress,
    );
    let mut rows = vec![];
    let mut widths = vec![];
    let mut peer_rows = peers.as_ref().map(|_| vec![]);
    for &res in &sizes {
        // Each size's peers right before and right after smokelab's.
        let before = peers.as_ref().map(|p| p.measure(res)).transpose()?;
        let python_here = python.as_ref().ok().filter(|_| res <= PYTHON_MAX_RES);
        let python_before = python_here
            .map(|p| p.median_ms(res, warm, steps))
            .transpose()?;
        let (mut row, w) = measure(res, warm, steps, &pools)?;
        if let (Some(p), Some(before)) = (python_here, python_before) {
            row.python_ms = Some([before, p.median_ms(res, warm, steps)?]);
        }
        rows.push(row);
        widths.extend(w);
        if let (Some(p), Some(r), Some(before)) = (&peers, &mut peer_rows, before) {
            r.push(PeerRow {
                res,
                runs: [before, p.measure(res)?],
            });
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let mut precision = vec![];
    for &res in &sizes {
        for kind in BoxKind::ALL {
            precision.extend(pressure_precision(res, warm, kind, &pools[1])?);
        }
    }
    let load_after = loadavg();
    io::create_output_dir(&ctx.out)?;
    crate::figures::table::write_rows(&ctx.out.join("pressure_precision.csv"), &precision)?;
    let fit = linear_fit(
        &rows
            .iter()
            .map(|r| ((r.cells as f64).ln(), r.step_ms.ln()))
            .collect::<Vec<_>>(),
    );
    write_data(&ctx.out, &rows, peer_rows.as_deref(), python.is_ok())?;
    let widths = WidthRow::with_peers(widths, peer_rows.as_deref());
    crate::figures::table::write_rows(&ctx.out.join("widths.csv"), &widths)?;
    plot(&ctx.out, &rows, peer_rows.as_deref(), fit.map(|f| f.slope))?;
    let mut md = table(
        &rows,
        peer_rows.as_deref(),
        python.is_ok(),
        fit.map(|f| f.slope),
    );
    md.push_str(&widths_table(&widths));
    md.push_str(&precision_table(&precision));
    io::write_atomic(&ctx.out.join("table.md"), |w| {
        Ok(std::io::Write::write_all(w, md.as_bytes())?)
    })?;
    let extra = serde_json::json!({
        "resolutions": sizes,
        "warm_up_steps": warm,
        "timed_steps": steps,
        "threads": [1, 2],
        "time_exponent": fit.map(|f| f.slope),
        "load_before": load_before,
        "load_after": load_after,
        "bitwise_equal_1_vs_2_threads": rows.iter().all(|r| r.bitwise_equal),
        "simd": {
            "default": Isa::selected(),
            "available": Isa::available(),
            "bitwise_equal_across_widths": true,
            "widths": "each available instruction set selected in turn (Isa::select, as SMOKELAB_SIMD), its RK2 and Euler steps on 2 threads interleaved with the others' round by round, medians of `timed_steps`; one step of each from one state, the fields' bits equal (asserted); widths.csv",
        },
        "timed": "Simulation::step only (advect, density, force, project); the run driver's metrics (metrics_ms: run::StepMeasures, fine_metrics_ms: run::FineProbes::measure) are timed apart on the same state, outputs not at all; setup_s (sources' cell averages, plans) is timed apart",
        "default_metrics_every": SolverConfig::default().metrics_every,
        "default_diagnostics_every": SolverConfig::default().diagnostics_every,
        "pressure_precision": "hot/cold after the warm-up steps and one step's advection and force (u*), periodic and closed, projected by the f32 and the f64 solve: max|D u| Δx / max|u_a| (metrics::velocity_stats); pressure_precision.csv, the third table of table.md",
        "floor": "min(f32 realfft+rustfft pair, the solver's f64 pair) + five f32 array copies (the fused sweep's 5 fields read and written)",
        "peers": match (&peers, &peer_rows) {
            (Some(p), Some(r)) => serde_json::json!({
                "python": p.python,
                "scripts": p.dir,
                "composite": "taichi_advect.py advect5 (Euler) + 3 × pyfftw float32 pair; each size's peers run before and after smokelab's rounds, the mean of the two",
                "rows": r.iter().map(|x| serde_json::json!({
                    "res": x.res,
                    "runs": x.runs.map(|p| serde_json::json!({
                        "taichi_advect_ms": p.taichi_ms, "pyfftw_pair_ms": p.pyfftw_ms
                    })),
                })).collect::<Vec<_>>(),
            }),
            _ => serde_json::json!("absent: run with --peers PYTHON"),
        },
        "python_module": match &python {
            Ok(p) => serde_json::json!({
                "python": p.python,
                "loop": "smokelab.Simulation(\"hot-cold\", res=N); sim.step(warm); then sim.step() timed one at a time by time.perf_counter, the median; run before and after smokelab's rounds, the mean of the two",
                "resolutions": sizes.iter().filter(|&&r| r <= PYTHON_MAX_RES).collect::<Vec<_>>(),
                "runs_ms": rows.iter().filter_map(|r| r.python_ms.map(|m| serde_json::json!({"res": r.res, "before": m[0], "after": m[1]}))).collect::<Vec<_>>(),
            }),
            Err(why) => serde_json::json!(why),
        },
    });
    let config = config(*sizes.last().expect("at least one resolution"));
    ctx.write_manifest(config, 0, start, extra)
}

/// The hot/cold configuration at `res`, every other key its default.
fn config(res: usize) -> HotColdConfig {
    HotColdConfig {
        solver: SolverConfig {
            res,
            ..SolverConfig::default()
        },
        ..Default::default()
    }
}

/// `/proc/loadavg` (1, 5, 15 minutes, runnable/total, last pid), or a note.
fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unavailable".into())
}

/// What one resolution measured (times in ms, medians over the timed steps).
struct Row {
    res: usize,
    cells: usize,
    setup_s: f64,
    step_ms: f64,
    step_1t_ms: f64,
    step_euler_ms: f64,
    advect_ms: f64,
    inject_ms: f64,
    density_ms: f64,
    force_ms: f64,
    project_ms: f64,
    boundary_ms: f64,
    fft_f32_ms: f64,
    fft_solver_ms: f64,
    bandwidth_ms: f64,
    metrics_ms: f64,
    fine_ms: f64,
    bitwise_equal: bool,
    /// The Python loop's median step, before and after the rounds.
    python_ms: Option<[f64; 2]>,
}

impl Row {
    /// One FFT pair (the faster) plus the bandwidth pass.
    fn floor_ms(&self) -> f64 {
        self.fft_f32_ms.min(self.fft_solver_ms) + self.bandwidth_ms
    }

    fn mcells_per_s(&self) -> f64 {
        self.cells as f64 / (self.step_ms * 1e3)
    }

    fn speedup(&self) -> f64 {
        self.step_1t_ms / self.step_ms
    }

    /// The Python loop's step (mean of its two runs), NaN where not measured.
    fn python_step_ms(&self) -> f64 {
        self.python_ms.map_or(f64::NAN, |[a, b]| 0.5 * (a + b))
    }

    /// The diagnostics ÷ step, were they taken every step.
    fn metrics_share(&self) -> f64 {
        self.metrics_ms / self.step_ms
    }

    /// The run's metrics at the default cadences, per step, ÷ step: the
    /// diagnostics every `diagnostics_every` steps plus the fine measures
    /// every `metrics_every` steps.
    fn default_metrics_share(&self) -> f64 {
        let d = SolverConfig::default();
        let per_step = self.metrics_ms / d.diagnostics_every as f64;
        (per_step + self.fine_ms / d.metrics_every as f64) / self.step_ms
    }
}

/// Median of `v` (mean of the middle two for an even count).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Milliseconds `f` takes.
fn ms(f: impl FnOnce()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64() * 1e3
}

/// Whether two simulations hold the same velocity and densities, bit for bit.
fn same_bits(a: &Simulation, b: &Simulation) -> bool {
    let eq = |x: &[f32], y: &[f32]| {
        x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
    };
    (0..3).all(|ax| eq(a.velocity.slice(ax), b.velocity.slice(ax)))
        && a.gases.len() == b.gases.len()
        && a.gases
            .iter()
            .zip(&b.gases)
            .all(|(g, h)| eq(g.density().as_slice(), h.density().as_slice()))
}

/// Set up `res`³, warm up on 2 threads, then time `steps` interleaved
/// rounds: RK2 on 2 and on 1 thread, Euler on 2, both FFT pairs, the
/// bandwidth pass and the run's per-step and fine measures on 2; then the
/// same number of rounds of each kernel width ([`measure_widths`]).
fn measure(
    res: usize,
    warm: usize,
    steps: usize,
    pools: &[rayon::ThreadPool; 2],
) -> Result<(Row, Vec<WidthRow>)> {
    let [one, two] = pools;
    let cfg = config(res);
    let t = Instant::now();
    let mut base = cfg.build()?;
    let setup_s = t.elapsed().as_secs_f64();
    two.install(|| (0..warm).for_each(|_| base.step()));
    let mut euler = base.clone();
    euler.params.backtrace = Backtrace::Euler;
    let mut euler = euler.with_advection(&cfg.solver.advection_options());
    let mut single = base.clone();
    let mut double = base;
    let domain = *double.domain();
    let mut pair = FftPair::new(res);
    let mut solver = PressureSolver::new(domain, BoxKind::Periodic);
    let rhs = ScalarGrid::zeros(domain);
    let mut rhs = rhs;
    rhs.as_slice_mut()
        .iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v = ((i * 7919) % 1009) as f32 / 1009.0 - 0.5);
    let mut p = ScalarGrid::zeros(domain);
    let mut pass = Bandwidth::new(domain.len());
    let mut probes = FineProbes::new(domain);
    let mut t = [(); 8].map(|_| Vec::with_capacity(steps));
    let mut stages = [(); 6].map(|_| Vec::with_capacity(steps));
    for _ in 0..steps {
        t[0].push(ms(|| two.install(|| double.step())));
        let s = double.times;
        for (v, x) in stages.iter_mut().zip([
            s.advect, s.inject, s.density, s.force, s.project, s.boundary,
        ]) {
            v.push(x * 1e3);
        }
        t[1].push(ms(|| one.install(|| single.step())));
        t[2].push(ms(|| two.install(|| euler.step())));
        t[3].push(ms(|| two.install(|| pair.run())));
        t[4].push(ms(|| two.install(|| solver.solve_poisson(&rhs, &mut p))));
        t[5].push(ms(|| two.install(|| pass.run())));
        t[6].push(ms(|| {
            two.install(|| {
                StepMeasures::take(&double);
            })
        }));
        t[7].push(ms(|| {
            two.install(|| {
                probes.measure(&double);
            })
        }));
    }
    let bitwise_equal = same_bits(&single, &double);
    if !bitwise_equal {
        bail!(
            "{res}³: the 1-thread and 2-thread steps differ in some bit after {warm}+{steps} steps"
        );
    }
    let widths = measure_widths(res, steps, two, [&mut double, &mut euler])?;
    let [step, step_1t, step_euler, fft_f32, fft_solver, bandwidth, metrics, fine] = t.map(median);
    let [advect, inject, density, force, project, boundary] = stages.map(median);
    let row = Row {
        res,
        cells: domain.len(),
        setup_s,
        step_ms: step,
        step_1t_ms: step_1t,
        step_euler_ms: step_euler,
        advect_ms: advect,
        inject_ms: inject,
        density_ms: density,
        force_ms: force,
        project_ms: project,
        boundary_ms: boundary,
        fft_f32_ms: fft_f32,
        fft_solver_ms: fft_solver,
        bandwidth_ms: bandwidth,
        metrics_ms: metrics,
        fine_ms: fine,
        bitwise_equal,
        python_ms: None,
    };
    Ok((row, widths))
}

/// One kernel width's steps at one resolution: medians, ms, on 2 threads.
#[derive(Clone, Copy, Debug, serde::Serialize)]
struct WidthRow {
    res: usize,
    kernel: Isa,
    lanes: usize,
    step_ms: f64,
    advect_ms: f64,
    project_ms: f64,
    step_euler_ms: f64,
    advect_euler_ms: f64,
    rk2_over_euler: f64,
    /// The composite peer ÷ this Euler step (NaN without `--peers`).
    peer_over_step_euler: f64,
}

impl WidthRow {
    /// `rows` with their size's peer ratio, when there are peers.
    fn with_peers(rows: Vec<WidthRow>, peers: Option<&[PeerRow]>) -> Vec<WidthRow> {
        rows.into_iter()
            .map(|mut r| {
                if let Some(p) = peers.and_then(|p| p.iter().find(|p| p.res == r.res)) {
                    r.peer_over_step_euler = p.composite_ms() / r.step_euler_ms;
                }
                r
            })
            .collect()
    }
}

/// Every instruction set this CPU has, selected in turn: `steps` rounds,
/// each an RK2 step of `sims[0]` and an Euler step of `sims[1]` per width
/// (the widths interleaved, so a load that drifts weighs on all alike),
/// their medians and stage times; and one step of each width from one
/// state, whose fields must agree to the bit. The default width is
/// selected again at the end.
///
/// # Errors
/// Two widths whose fields differ in a bit.
fn measure_widths(
    res: usize,
    steps: usize,
    pool: &rayon::ThreadPool,
    sims: [&mut Simulation; 2],
) -> Result<Vec<WidthRow>> {
    let default = Isa::selected();
    let isas = Isa::available();
    let [rk2, euler] = sims;
    // One step from one state on each width: the same bits.
    let start = rk2.clone();
    let mut first: Option<(Isa, Simulation)> = None;
    for &isa in &isas {
        isa.select()?;
        let mut s = start.clone();
        pool.install(|| s.step());
        match &first {
            None => first = Some((isa, s)),
            Some((f, want)) if !same_bits(want, &s) => {
                default.select()?;
                bail!("{res}³: the {isa} and {f} kernels' steps differ in some bit");
            }
            Some(_) => {}
        }
    }
    drop((start, first));
    let mut t = vec![[(); 5].map(|_| Vec::with_capacity(steps)); isas.len()];
    for _ in 0..steps {
        for (t, &isa) in t.iter_mut().zip(&isas) {
            isa.select()?;
            t[0].push(ms(|| pool.install(|| rk2.step())));
            t[1].push(rk2.times.advect * 1e3);
            t[2].push(rk2.times.project * 1e3);
            t[3].push(ms(|| pool.install(|| euler.step())));
            t[4].push(euler.times.advect * 1e3);
        }
    }
    default.select()?;
    Ok(isas
        .iter()
        .zip(t)
        .map(|(&kernel, t)| {
            let [step, advect, project, step_euler, advect_euler] = t.map(median);
            WidthRow {
                res,
                kernel,
                lanes: kernel.lanes(),
                step_ms: step,
                advect_ms: advect,
                project_ms: project,
                step_euler_ms: step_euler,
                advect_euler_ms: advect_euler,
                rk2_over_euler: step / step_euler,
                peer_over_step_euler: f64::NAN,
            }
        })
        .collect())
}

/// The second table of `table.md`: each kernel width's steps.
fn widths_table(rows: &[WidthRow]) -> String {
    let peers = rows.iter().any(|r| r.peer_over_step_euler.is_finite());
    let mut s = String::from(
        "\nEach kernel width (`SMOKELAB_SIMD`), the same rounds on 2 threads; the fields agree to the bit:\n\n\
         | res | kernel | lanes | RK2 step ms | advect | Euler step ms | advect | RK2 ÷ Euler |",
    );
    s.push_str(if peers {
        " peer ÷ Euler step |\n"
    } else {
        "\n"
    });
    s.push_str("|---|---|---|---|---|---|---|---|");
    s.push_str(if peers { "---|\n" } else { "\n" });
    for r in rows {
        s.push_str(&format!(
            "| {}³ | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} |",
            r.res,
            r.kernel,
            r.lanes,
            r.step_ms,
            r.advect_ms,
            r.step_euler_ms,
            r.advect_euler_ms,
            r.rk2_over_euler
        ));
        if peers {
            s.push_str(&format!(" {:.2} |", r.peer_over_step_euler));
        }
        s.push('\n');
    }
    s
}

/// One row of `pressure_precision.csv`.
#[derive(Clone, Copy, Debug, serde::Serialize)]
struct PrecisionRow {
    res: usize,
    #[serde(rename = "box")]
    box_kind: BoxKind,
    precision: PressurePrecision,
    /// `max|D u*| Δx / max|u*|` before the projection.
    before: f64,
    /// `max|D u| Δx / max|u|` after it.
    after: f64,
}

/// The projection's round-off: hot/cold at `res` in a box of `kind`, `warm`
/// steps, then one step's advection and force — `u*`, as the projection
/// of a step sees it — projected once by the f32 and once by the f64
/// solve; `max|D u| Δx / max|u_a|` before and after each.
fn pressure_precision(
    res: usize,
    warm: usize,
    kind: BoxKind,
    pool: &rayon::ThreadPool,
) -> Result<Vec<PrecisionRow>> {
    let mut cfg = config(res);
    cfg.solver.box_kind = kind;
    let mut sim = cfg.build()?;
    pool.install(|| -> Result<()> {
        (0..warm).for_each(|_| sim.step());
        sim.advect()?;
        sim.inject();
        sim.clear_dry();
        sim.evaluate_densities();
        sim.add_buoyancy();
        Ok(())
    })?;
    let dx = sim.domain().cell as f64;
    let ratio = |u: &smokelab::grid::FaceGrid| {
        let s = pool.install(|| velocity_stats(u));
        s.divergence.max as f64 * dx / s.mirror.max_norm as f64
    };
    let before = ratio(&sim.velocity);
    Ok(PressurePrecision::ALL
        .map(|precision| {
            let mut u = sim.velocity.clone();
            let mut solver = PressureSolver::with_precision(*sim.domain(), kind, precision);
            pool.install(|| solver.project(&mut u));
            PrecisionRow {
                res,
                box_kind: kind,
                precision,
                before,
                after: ratio(&u),
            }
        })
        .to_vec())
}

/// The third table of `table.md`: the projection's round-off per precision.
fn precision_table(rows: &[PrecisionRow]) -> String {
    let mut s = String::from(
        "
The pressure solve's round-off: `max|D u| Δx / max|u|` after projecting one hot/cold step's `u*`:

\
         | res | box | before | f32 | f64 |\n|---|---|---|---|---|\n",
    );
    for r in rows
        .iter()
        .filter(|r| r.precision == PressurePrecision::F32)
    {
        let f64_row = rows.iter().find(|q| {
            q.res == r.res && q.box_kind == r.box_kind && q.precision == PressurePrecision::F64
        });
        s.push_str(&format!(
            "| {}³ | {} | {:.1e} | {:.1e} | {:.1e} |\n",
            r.res,
            r.box_kind,
            r.before,
            r.after,
            f64_row.map_or(f64::NAN, |q| q.after)
        ));
    }
    s
}

/// One forward and one inverse real 3D FFT of an `n³` f32 array: the
/// pressure solver's periodic pair ([`PeriodicFft`]) in f32, under a unit
/// gain; unnormalised, as the peers' pairs.
struct FftPair {
    fft: PeriodicFft<f32>,
    input: Vec<f32>,
    output: Vec<f32>,
}

impl FftPair {
    fn new(n: usize) -> Self {
        Self {
            fft: PeriodicFft::new([n; 3]),
            input: (0..n * n * n)
                .map(|i| ((i * 7919) % 1009) as f32 / 1009.0 - 0.5)
                .collect(),
            output: vec![0.0; n * n * n],
        }
    }

    fn run(&mut self) {
        self.fft.forward(&self.input, |v| v);
        self.fft.inverse(|_, _| {}, &mut self.output, |r| r);
    }
}

/// One bandwidth-bound pass over the fused advection's fields: five f32
/// arrays of the cells read, five written.
struct Bandwidth {
    src: [Vec<f32>; 5],
    dst: [Vec<f32>; 5],
}

/// Elements per task of the copies.
const COPY_CHUNK: usize = 1 << 16;

impl Bandwidth {
    fn new(cells: usize) -> Self {
        Self {
            src: [(); 5].map(|_| vec![1.0; cells]),
            dst: [(); 5].map(|_| vec![0.0; cells]),
        }
    }

    fn run(&mut self) {
        for (s, d) in self.src.iter().zip(self.dst.iter_mut()) {
            d.par_chunks_mut(COPY_CHUNK)
                .zip(s.par_chunks(COPY_CHUNK))
                .for_each(|(d, s)| d.copy_from_slice(s));
        }
    }
}

/// The peer scripts and the Python that runs them.
struct Peers {
    python: PathBuf,
    dir: PathBuf,
}

/// One run of the peer scripts at one resolution: their medians, ms.
#[derive(Clone, Copy)]
struct PeerRun {
    taichi_ms: f64,
    pyfftw_ms: f64,
}

impl PeerRun {
    /// Taichi's advection plus three pyFFTW pairs.
    fn composite_ms(&self) -> f64 {
        self.taichi_ms + 3.0 * self.pyfftw_ms
    }
}

/// The peers at one resolution, run before and after smokelab's rounds.
struct PeerRow {
    res: usize,
    runs: [PeerRun; 2],
}

impl PeerRow {
    /// The mean of the two runs of `part`.
    fn mean(&self, part: impl Fn(&PeerRun) -> f64) -> f64 {
        0.5 * (part(&self.runs[0]) + part(&self.runs[1]))
    }

    /// The composite peer step, the mean of the two runs'.
    fn composite_ms(&self) -> f64 {
        self.mean(PeerRun::composite_ms)
    }
}

impl Peers {
    /// Check that `python` runs and imports taichi and pyfftw, and find the
    /// scripts (`$SMOKELAB_PEERS_DIR`, else `../shared/peers` beside the
    /// repository).
    fn new(python: &Path) -> Result<Self> {
        let ok = Command::new(python)
            .args(["-c", "import taichi, pyfftw, scipy"])
            .output()
            .map_err(|e| {
                InputError::new(format!(
                    "--peers {}: cannot run it ({e}); give a Python with taichi, pyfftw and scipy",
                    python.display()
                ))
            })?;
        if !ok.status.success() {
            return Err(InputError::new(format!(
                "--peers {}: it cannot import taichi, pyfftw and scipy: {}",
                python.display(),
                String::from_utf8_lossy(&ok.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            ))
            .into());
        }
        let dir = match std::env::var_os("SMOKELAB_PEERS_DIR") {
            Some(d) => PathBuf::from(d),
            None => crate::run::output_dir::repository_root()?.join("../shared/peers"),
        };
        for script in ["taichi_advect.py", "fft_py.py"] {
            if !dir.join(script).is_file() {
                return Err(InputError::new(format!(
                    "--peers: no {script} in {} (set SMOKELAB_PEERS_DIR to the peers' folder)",
                    dir.display()
                ))
                .into());
            }
        }
        Ok(Self {
            python: python.to_path_buf(),
            dir,
        })
    }

    /// Run `script` with `args`; its CSV rows as fields.
    fn rows(&self, script: &str, args: &[&str]) -> Result<Vec<Vec<String>>> {
        let o = Command::new(&self.python)
            .arg(self.dir.join(script))
            .args(args)
            .output()
            .with_context(|| format!("cannot run {script}"))?;
        if !o.status.success() {
            bail!(
                "{script} {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&o.stderr)
            );
        }
        Ok(String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip_while(|l| !l.starts_with("impl,"))
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect())
    }

    /// Both scripts at `n`³, 2 threads, f32.
    fn measure(&self, n: usize) -> Result<PeerRun> {
        let size = n.to_string();
        let taichi = self.rows("taichi_advect.py", &[&size, "2", "f32"])?;
        let fft = self.rows("fft_py.py", &[&size, "2"])?;
        // Columns: impl, dtype, N, threads, what, median_ms, …
        let find = |rows: &[Vec<String>], imp: &str, dtype: &str, n: usize| -> Result<f64> {
            rows.iter()
                .find(|r| r.len() > 5 && r[0] == imp && r[1] == dtype && r[2] == n.to_string())
                .and_then(|r| r[5].parse().ok())
                .with_context(|| format!("no {imp} {dtype} row for N = {n} in the peers' output"))
        };
        Ok(PeerRun {
            taichi_ms: find(&taichi, "taichi_sl_advect_5fields", "float32", n)?,
            pyfftw_ms: find(&fft, "pyfftw", "float32", n)?,
        })
    }
}

/// Write `data.csv`: one row per resolution, the peer columns only with peers.
fn write_data(out: &Path, rows: &[Row], peers: Option<&[PeerRow]>, python: bool) -> Result<()> {
    let mut cols = vec![
        "res",
        "cells",
        "setup_s",
        "step_ms",
        "mcells_per_s",
        "step_1thread_ms",
        "speedup",
        "step_euler_ms",
        "advect_ms",
        "inject_ms",
        "density_ms",
        "force_ms",
        "project_ms",
        "boundary_ms",
        "fft_pair_f32_ms",
        "fft_pair_solver_f64_ms",
        "bandwidth_ms",
        "floor_ms",
        "step_over_floor",
        "metrics_ms",
        "fine_metrics_ms",
        "metrics_over_step",
        "default_metrics_over_step",
        "bitwise_equal",
    ];
    if peers.is_some() {
        cols.extend([
            "peer_taichi_advect_ms",
            "peer_pyfftw_pair_ms",
            "peer_ms_before",
            "peer_ms_after",
            "peer_ms",
            "peer_over_step_euler",
        ]);
    }
    if python {
        cols.extend(["python_step_ms", "python_over_step"]);
    }
    let table: Vec<Vec<f64>> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let mut v = vec![
                r.res as f64,
                r.cells as f64,
                r.setup_s,
                r.step_ms,
                r.mcells_per_s(),
                r.step_1t_ms,
                r.speedup(),
                r.step_euler_ms,
                r.advect_ms,
                r.inject_ms,
                r.density_ms,
                r.force_ms,
                r.project_ms,
                r.boundary_ms,
                r.fft_f32_ms,
                r.fft_solver_ms,
                r.bandwidth_ms,
                r.floor_ms(),
                r.step_ms / r.floor_ms(),
                r.metrics_ms,
                r.fine_ms,
                r.metrics_share(),
                r.default_metrics_share(),
                f64::from(u8::from(r.bitwise_equal)),
            ];
            if let Some(p) = peers.map(|p| &p[i]) {
                v.extend([
                    p.mean(|r| r.taichi_ms),
                    p.mean(|r| r.pyfftw_ms),
                    p.runs[0].composite_ms(),
                    p.runs[1].composite_ms(),
                    p.composite_ms(),
                    p.composite_ms() / r.step_euler_ms,
                ]);
            }
            if python {
                v.extend([r.python_step_ms(), r.python_step_ms() / r.step_ms]);
            }
            v
        })
        .collect();
    let cols: Vec<String> = cols.into_iter().map(String::from).collect();
    write_columns(&out.join("data.csv"), &cols, &table)
}

/// `time`, `threads` and `stages` plots (the `density` stage, empty for
/// gridded gases, only in `data.csv`).
fn plot(out: &Path, rows: &[Row], peers: Option<&[PeerRow]>, exponent: Option<f64>) -> Result<()> {
    let pts = |f: &dyn Fn(&Row) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r.cells as f64, f(r))).collect()
    };
    let mut time = Plot::new("hot/cold step time (P-1)", "cells", "ms per step")
        .log_x()
        .log_y()
        .legend(LegendPosition::UpperLeft)
        .series(
            Series::line("step, 2 threads (RK2)", pts(&|r| r.step_ms)).styled(Style::LineMarkers),
        )
        .series(
            Series::line("step, 1 thread (RK2)", pts(&|r| r.step_1t_ms)).styled(Style::LineMarkers),
        )
        .series(
            Series::line("step, 2 threads (Euler)", pts(&|r| r.step_euler_ms))
                .styled(Style::LineMarkers),
        )
        .series(
            Series::line("floor: FFT pair + bandwidth pass", pts(&|r| r.floor_ms()))
                .styled(Style::LineMarkers),
        );
    if let Some(p) = peers {
        let composite = rows
            .iter()
            .zip(p)
            .map(|(r, p)| (r.cells as f64, p.composite_ms()))
            .collect();
        time = time.series(
            Series::line("peer: Taichi advect (Euler) + 3 pyFFTW pairs", composite)
                .styled(Style::LineMarkers),
        );
    }
    if let (Some(b), Some(first)) = (exponent, rows.first()) {
        let fit = linear_fit(
            &rows
                .iter()
                .map(|r| ((r.cells as f64).ln(), r.step_ms.ln()))
                .collect::<Vec<_>>(),
        )
        .expect("fitted above");
        let line = rows
            .iter()
            .map(|r| {
                let x = r.cells as f64;
                (x, (fit.intercept + b * x.ln()).exp())
            })
            .collect();
        time = time
            .series(Series::line(format!("fit: t ∝ cells^{b:.2}"), line).styled(Style::Dashed))
            .annotate(Annotation::at_fraction(
                0.5,
                0.9,
                format!(
                    "exponent {b:.2}, {}³…{}³",
                    first.res,
                    rows[rows.len() - 1].res
                ),
            ));
    }
    time.write(&out.join("time"))?;
    Plot::new("2 threads against 1 (P-1)", "cells", "speed-up t₁ / t₂")
        .log_x()
        .y_range(0.0, 2.5)
        .legend(LegendPosition::LowerRight)
        .series(
            Series::line("hot/cold step (RK2)", pts(&|r| r.speedup())).styled(Style::LineMarkers),
        )
        .series(Series::line("ideal (2 cores)", pts(&|_| 2.0)).styled(Style::Dashed))
        .write(&out.join("threads"))?;
    let share = |f: fn(&Row) -> f64| pts(&move |r: &Row| f(r) / r.step_ms);
    Plot::new(
        "share of the step per stage, 2 threads (P-1)",
        "cells",
        "stage ms / step ms",
    )
    .log_x()
    .y_range(0.0, 1.0)
    .legend(LegendPosition::UpperRight)
    .series(Series::line("advect", share(|r| r.advect_ms)).styled(Style::LineMarkers))
    .series(Series::line("project", share(|r| r.project_ms)).styled(Style::LineMarkers))
    .series(Series::line("force", share(|r| r.force_ms)).styled(Style::LineMarkers))
    .write(&out.join("stages"))?;
    Ok(())
}

/// The Markdown table for the README and the paper.
fn table(rows: &[Row], peers: Option<&[PeerRow]>, python: bool, exponent: Option<f64>) -> String {
    let mut s = String::from(
        "| res | step ms | Mcells/s | 1 thread ms | speed-up | advect | force | project | floor ms | step ÷ floor | diagnostics ÷ step | default metrics ÷ step |",
    );
    if peers.is_some() {
        s.push_str(" Euler step ms | peer ms | peer ÷ Euler step |");
    }
    if python {
        s.push_str(" Python step ms | Python ÷ step |");
    }
    s.push_str("\n|---|---|---|---|---|---|---|---|---|---|---|---|");
    if peers.is_some() {
        s.push_str("---|---|---|");
    }
    if python {
        s.push_str("---|---|");
    }
    s.push('\n');
    for (i, r) in rows.iter().enumerate() {
        s.push_str(&format!(
            "| {}³ | {:.1} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} % | {:.0} % |",
            r.res,
            r.step_ms,
            r.mcells_per_s(),
            r.step_1t_ms,
            r.speedup(),
            r.advect_ms,
            r.force_ms,
            r.project_ms,
            r.floor_ms(),
            r.step_ms / r.floor_ms(),
            100.0 * r.metrics_share(),
            100.0 * r.default_metrics_share()
        ));
        if let Some(p) = peers.map(|p| &p[i]) {
            s.push_str(&format!(
                " {:.1} | {:.1} | {:.2} |",
                r.step_euler_ms,
                p.composite_ms(),
                p.composite_ms() / r.step_euler_ms
            ));
        }
        if python {
            s.push_str(&match r.python_ms {
                Some(_) => format!(
                    " {:.1} | {:.3} |",
                    r.python_step_ms(),
                    r.python_step_ms() / r.step_ms
                ),
                None => " – | – |".into(),
            });
        }
        s.push('\n');
    }
    if let Some(b) = exponent {
        s.push_str(&format!(
            "\nStep time ∝ cells^{b:.2} (least squares over the rows).\n"
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floor's pair is a real transform pair: back to the input times
    /// n³ (unnormalised). Measured max error 1.2e-7 at 8³, 1.8e-7 at 12³
    /// (f32 round-off); a wrong transpose or a missing axis gives O(1).
    #[test]
    fn fft_pair_returns_its_input_times_the_cell_count() {
        for n in [8, 12] {
            let mut pair = FftPair::new(n);
            pair.run();
            let scale = (n * n * n) as f32;
            let err = pair
                .input
                .iter()
                .zip(&pair.output)
                .map(|(a, b)| (a - b / scale).abs())
                .fold(0.0f32, f32::max);
            assert!(err < 2e-6, "{n}³: max error {err}");
        }
    }

    /// `same_bits` sees one ulp in one density cell and one velocity face.
    #[test]
    fn same_bits_sees_one_ulp() {
        let mut a = config(12).build().unwrap();
        a.step();
        let b = a.clone();
        assert!(same_bits(&a, &b));
        let mut c = b.clone();
        let v = &mut c.velocity.slice_mut(1)[100];
        *v = f32::from_bits(v.to_bits() + 1);
        assert!(!same_bits(&a, &c));
        let mut d = b.clone();
        let grid = d.gases[1].model.gridded_mut().expect("a gridded gas");
        let rho = &mut grid.as_slice_mut()[5];
        *rho = f32::from_bits(rho.to_bits() + 1);
        assert!(!same_bits(&a, &d));
    }
}
