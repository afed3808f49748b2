//! `checkpoint.bin`: the whole state of a run, so `smokelab run --resume
//! RUN_DIR` continues a killed run to the bitwise-identical frames and
//! metrics of an uninterrupted one.
//!
//! What is stored is [`Simulation::state`] — the step count, the staggered
//! velocity, and per gas its mass budget and density state (gridded: the
//! grid; gridless: the history of velocity grids, each grid shared between
//! gases stored once; SELMA: reference density, whether `ρ₀` is still
//! composed, and the map and tracked lattice stored with the gas that owns
//! them — the first of the gases sharing them), and the obstacle solves' warm starts
//! (the exact projection's f64 pressure, QUICK's face potential) — and the
//! [`RunRecord`]: scenario,
//! resolved configuration and the output flags. Sources, obstacles,
//! transform plans and scratch buffers are rebuilt from the configuration.
//! The step has no random numbers (the seed only places the initial
//! conditions, rebuilt from the configuration; the metrics' probe points
//! are drawn from a fixed seed), so there is no RNG state to keep.
//!
//! Layout, little-endian:
//!
//! ```text
//! "SMKCKPT\0" | format u32 | header length u64 | header (JSON)
//!   | arrays (f32, or f64 as two words; in the header's order, sizes in
//!     4-byte words) | FNV-1a 64 of all before
//! ```
//!
//! The file is written through a uniquely named temporary file in the run
//! folder, synced and renamed ([`io::write_atomic`]), so the latest whole
//! checkpoint survives a kill at any moment; the temporary file is removed
//! on error and on Ctrl-C.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Result;
use serde::{Deserialize, Serialize};
use smokelab::advection::Backtrace;
use smokelab::density::{DensityMode, DensityState, MapState};
use smokelab::error::InputError;
use smokelab::grid::{FaceGrid, VectorGrid};
use smokelab::io::{self, manifest::BUILD_COMMIT};
use smokelab::scenario::ScenarioKind;
use smokelab::simulation::{MassBudget, Simulation, SimulationState};

/// The checkpoint's file name in the run folder.
pub const FILE: &str = "checkpoint.bin";

const MAGIC: &[u8; 8] = b"SMKCKPT\0";

/// The layout version this build writes and reads (2: SELMA gases share
/// one map, stored once).
pub const FORMAT: u32 = 2;

/// What a run needs besides its state to go on as it started.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The scenario.
    pub scenario: ScenarioKind,
    /// Its resolved configuration, TOML (as `--print-config`).
    pub config: String,
    /// Checkpoint every this many steps.
    pub checkpoint_every: usize,
    /// `--vdb`.
    pub vdb: bool,
    /// `--density-grid` and `--up` of the VDB frames (absent in checkpoints
    /// written before they existed: the defaults).
    #[serde(default)]
    pub vdb_frames: crate::export::VdbFrames,
    /// `--paraview`.
    pub paraview: bool,
    /// `--render` and its options, if given.
    pub render: Option<RenderFlags>,
}

/// The `--render` options of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderFlags {
    /// `--render-every`.
    pub every: Option<usize>,
    /// `--image`.
    pub image: Option<String>,
    /// `--march-step`.
    pub march_step: Option<f32>,
}

/// The header: everything but the arrays.
#[derive(Serialize, Deserialize)]
struct Header {
    /// smokelab version that wrote it.
    version: String,
    /// Its build commit.
    commit: String,
    run: RunRecord,
    /// Steps taken.
    step: usize,
    gases: Vec<GasHeader>,
    /// Distinct gridless velocity grids stored.
    history: usize,
    /// Every array's name and size in 4-byte words (an f64 is two), in file order.
    arrays: Vec<(String, usize)>,
}

/// One gas: its mode, budget (f64 bits: exact), and the non-array state.
#[derive(Serialize, Deserialize)]
struct GasHeader {
    mode: DensityMode,
    budget_bits: [u64; 2],
    /// Gridless: per step, the index of its velocity grid, Δt's bits and the backtrace.
    steps: Vec<(usize, u32, Backtrace)>,
    /// SELMA: `ρ₀` still composed, and re-anchorings so far.
    composes_initial: bool,
    restarts: usize,
    /// SELMA: the gas shares the map of the SELMA gas before it (its map
    /// and lattice are not stored).
    shares_map: bool,
}

/// FNV-1a, 64 bit, of everything written through it.
struct Hashing<W> {
    inner: W,
    hash: u64,
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0100_0000_01b3;

fn fnv(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash = (hash ^ b as u64).wrapping_mul(FNV_PRIME);
    }
    hash
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash = fnv(self.hash, &buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// A state as the file lays it out.
struct Layout<'a> {
    gases: Vec<GasHeader>,
    /// Every array's name and values, in file order.
    arrays: Vec<(String, Values<'a>)>,
    /// Distinct gridless velocity grids.
    history: usize,
}

/// An array's values, f32 or f64.
#[derive(Clone, Copy)]
enum Values<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
}

impl Values<'_> {
    /// Length in 4-byte words.
    fn words(&self) -> usize {
        match self {
            Values::F32(a) => a.len(),
            Values::F64(a) => 2 * a.len(),
        }
    }

    /// Write the values' little-endian bytes to `w`, in chunks.
    fn write_to(&self, w: &mut impl Write) -> std::io::Result<()> {
        let mut buf = Vec::with_capacity(1 << 16);
        match self {
            Values::F32(a) => {
                for chunk in a.chunks(1 << 14) {
                    buf.clear();
                    buf.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
                    w.write_all(&buf)?;
                }
            }
            Values::F64(a) => {
                for chunk in a.chunks(1 << 13) {
                    buf.clear();
                    buf.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
                    w.write_all(&buf)?;
                }
            }
        }
        Ok(())
    }
}

/// The arrays of a state in file order, with the gases' headers; gridless
/// velocity grids shared between gases are listed once.
fn layout(state: &SimulationState) -> Layout<'_> {
    let mut arrays: Vec<(String, Values)> = Vec::new();
    for (a, c) in ["u", "v", "w"].iter().enumerate() {
        arrays.push((
            format!("velocity.{c}"),
            Values::F32(state.velocity.slice(a)),
        ));
    }
    if let Some(p) = &state.obstacle_pressure {
        arrays.push(("obstacle_pressure".into(), Values::F64(p)));
    }
    if let Some(p) = &state.face_potential {
        arrays.push(("face_potential".into(), Values::F32(p)));
    }
    let mut grids: Vec<&Arc<FaceGrid>> = Vec::new();
    let mut gases = Vec::new();
    for (n, (budget, density)) in state.gases.iter().enumerate() {
        let mut gas = GasHeader {
            mode: DensityMode::Gridded,
            budget_bits: [budget.advection.to_bits(), budget.cleared.to_bits()],
            steps: vec![],
            composes_initial: false,
            restarts: 0,
            shares_map: false,
        };
        match density {
            DensityState::Gridded(d) => {
                arrays.push((format!("gas{n}.density"), Values::F32(d.as_slice())))
            }
            DensityState::Gridless { history, centres } => {
                gas.mode = DensityMode::Gridless;
                for (u, dt, bt) in history {
                    let k = grids.iter().position(|g| Arc::ptr_eq(g, u));
                    let k = k.unwrap_or_else(|| {
                        grids.push(u);
                        grids.len() - 1
                    });
                    gas.steps.push((k, dt.to_bits(), *bt));
                }
                arrays.push((format!("gas{n}.centres"), Values::F32(centres.as_slice())));
            }
            DensityState::Selma(s) => {
                gas.mode = DensityMode::Selma;
                gas.composes_initial = s.composes_initial;
                gas.restarts = s.restarts;
                gas.shares_map = s.map.is_none();
                if let Some(m) = &s.map {
                    arrays.push((format!("gas{n}.disp"), Values::F32(m.disp.as_slice())));
                    arrays.push((format!("gas{n}.lattice"), Values::F32(m.lattice.as_slice())));
                }
                arrays.push((
                    format!("gas{n}.reference"),
                    Values::F32(s.reference.as_slice()),
                ));
                arrays.push((format!("gas{n}.centres"), Values::F32(s.centres.as_slice())));
            }
        }
        gases.push(gas);
    }
    for (k, g) in grids.iter().enumerate() {
        for (a, c) in ["u", "v", "w"].iter().enumerate() {
            arrays.push((format!("history{k}.{c}"), Values::F32(g.slice(a))));
        }
    }
    Layout {
        gases,
        arrays,
        history: grids.len(),
    }
}

/// Write `dir/checkpoint.bin` for `sim` as it is now, atomically.
pub fn write(dir: &Path, sim: &Simulation, run: &RunRecord) -> Result<()> {
    let state = sim.state();
    let Layout {
        gases,
        arrays,
        history,
    } = layout(&state);
    let header = Header {
        version: env!("CARGO_PKG_VERSION").into(),
        commit: BUILD_COMMIT.into(),
        run: run.clone(),
        step: state.step_index,
        gases,
        history,
        arrays: arrays.iter().map(|(n, a)| (n.clone(), a.words())).collect(),
    };
    let json = serde_json::to_vec(&header)?;
    io::write_atomic(&dir.join(FILE), |w| {
        let mut h = Hashing {
            inner: &mut *w,
            hash: FNV_OFFSET,
        };
        h.write_all(MAGIC)?;
        h.write_all(&FORMAT.to_le_bytes())?;
        h.write_all(&(json.len() as u64).to_le_bytes())?;
        h.write_all(&json)?;
        for (_, a) in &arrays {
            a.write_to(&mut h)?;
        }
        let hash = h.hash;
        w.write_all(&hash.to_le_bytes())?;
        Ok(())
    })
}

/// A checkpoint read and checked whole (magic, checksum, format, version).
pub struct Checkpoint {
    path: PathBuf,
    header: Header,
    /// The arrays' bytes.
    data: Vec<u8>,
}

impl Checkpoint {
    /// Read `dir/checkpoint.bin`.
    ///
    /// # Errors
    /// One line naming the problem: no checkpoint, not a checkpoint,
    /// truncated or corrupt, another format or smokelab version.
    pub fn read(dir: &Path) -> Result<Self, InputError> {
        let path = dir.join(FILE);
        let show = path.display();
        if !path.is_file() {
            return Err(InputError::new(format!(
                "{} has no {FILE}; only a run started with --checkpoint-every K can be resumed",
                dir.display()
            )));
        }
        let bytes = std::fs::read(&path)
            .map_err(|e| InputError::new(format!("cannot read {show}: {e}")))?;
        let corrupt = |why: &str| InputError::new(format!("{show} is {why}; it cannot be resumed"));
        if bytes.len() < 8 && MAGIC.starts_with(&bytes) {
            return Err(corrupt("truncated"));
        }
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(corrupt("not a smokelab checkpoint"));
        }
        if bytes.len() < 28 {
            return Err(corrupt("truncated"));
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let stored = u64::from_le_bytes(tail.try_into().expect("8 bytes"));
        if fnv(FNV_OFFSET, body) != stored {
            return Err(corrupt(
                "truncated or corrupt (its checksum does not match)",
            ));
        }
        let format = u32::from_le_bytes(body[8..12].try_into().expect("4 bytes"));
        if format != FORMAT {
            return Err(InputError::new(format!(
                "{show} has checkpoint format {format}; this smokelab {} reads format {FORMAT}",
                env!("CARGO_PKG_VERSION")
            )));
        }
        let len = u64::from_le_bytes(body[12..20].try_into().expect("8 bytes"));
        let json = usize::try_from(len)
            .ok()
            .and_then(|l| body.get(20..20usize.checked_add(l)?))
            .ok_or_else(|| corrupt("corrupt (its header overruns the file)"))?;
        let header: Header =
            serde_json::from_slice(json).map_err(|e| corrupt(&format!("corrupt (header: {e})")))?;
        if header.version != env!("CARGO_PKG_VERSION") {
            return Err(InputError::new(format!(
                "{show} was written by smokelab {}; this is smokelab {}, whose step may differ",
                header.version,
                env!("CARGO_PKG_VERSION")
            )));
        }
        let data = body[20 + json.len()..].to_vec();
        let want = (header.arrays.iter())
            .try_fold(0usize, |sum, (_, n)| sum.checked_add(n.checked_mul(4)?));
        if want != Some(data.len()) {
            return Err(corrupt("corrupt (its arrays do not fill the file)"));
        }
        Ok(Self { path, header, data })
    }

    /// The step the checkpoint was taken after.
    pub fn step(&self) -> usize {
        self.header.step
    }

    /// What the run recorded to continue.
    pub fn run(&self) -> &RunRecord {
        &self.header.run
    }

    /// The commit of the build that wrote it.
    pub fn commit(&self) -> &str {
        &self.header.commit
    }

    /// The stored state, shaped after `sim` (a simulation freshly built
    /// from the recorded configuration), to [`Simulation::restore`].
    ///
    /// # Errors
    /// If the stored arrays do not fit `sim`'s grids, gases or modes.
    pub fn state_for(&self, sim: &Simulation) -> Result<SimulationState, InputError> {
        let h = &self.header;
        let misfit = || {
            InputError::new(format!(
                "{} does not fit the simulation its configuration builds (grid sizes, gases or density modes differ)",
                self.path.display()
            ))
        };
        let template = sim.state();
        if h.gases.len() != template.gases.len() {
            return Err(misfit());
        }
        // The history grids: zeros on the velocity's domain, filled below.
        let (domain, kind) = (*sim.domain(), sim.velocity.kind());
        let grids: Vec<FaceGrid> = (0..h.history)
            .map(|_| FaceGrid::zeros(domain, kind))
            .collect();
        let mut state = SimulationState {
            step_index: h.step,
            velocity: template.velocity,
            gases: vec![],
            obstacle_pressure: template.obstacle_pressure,
            face_potential: template.face_potential,
        };
        let mut gases = Vec::new();
        for (g, (_, density)) in h.gases.iter().zip(template.gases) {
            let budget = MassBudget {
                advection: f64::from_bits(g.budget_bits[0]),
                cleared: f64::from_bits(g.budget_bits[1]),
            };
            let density = match (g.mode, density) {
                (DensityMode::Gridded, d @ DensityState::Gridded(_)) => d,
                (DensityMode::Gridless, DensityState::Gridless { centres, .. }) => {
                    DensityState::Gridless {
                        history: vec![],
                        centres,
                    }
                }
                (DensityMode::Selma, DensityState::Selma(mut s)) => {
                    s.composes_initial = g.composes_initial;
                    s.restarts = g.restarts;
                    let md = *s.reference.domain();
                    s.map = (!g.shares_map).then(|| MapState {
                        disp: VectorGrid::zeros(md),
                        lattice: VectorGrid::zeros(md),
                    });
                    DensityState::Selma(s)
                }
                _ => return Err(misfit()),
            };
            gases.push((budget, density));
        }
        state.gases = gases;
        // Fill every array in file order, checking each length.
        let mut arrays = Arrays {
            data: &self.data,
            at: 0,
            sizes: h.arrays.iter().map(|(_, n)| *n),
        };
        let mut grids = grids;
        for a in 0..3 {
            arrays
                .fill(state.velocity.slice_mut(a))
                .ok_or_else(misfit)?;
        }
        if let Some(p) = &mut state.obstacle_pressure {
            arrays.fill_f64(p).ok_or_else(misfit)?;
        }
        if let Some(p) = &mut state.face_potential {
            arrays.fill(p).ok_or_else(misfit)?;
        }
        for (_, density) in state.gases.iter_mut() {
            let filled = match density {
                DensityState::Gridded(d) => arrays.fill(d.as_slice_mut()),
                DensityState::Gridless { centres, .. } => arrays.fill(centres.as_slice_mut()),
                DensityState::Selma(s) => match &mut s.map {
                    Some(m) => arrays
                        .fill(m.disp.as_slice_mut())
                        .and_then(|()| arrays.fill(m.lattice.as_slice_mut())),
                    None => Some(()),
                }
                .and_then(|()| arrays.fill(s.reference.as_slice_mut()))
                .and_then(|()| arrays.fill(s.centres.as_slice_mut())),
            };
            filled.ok_or_else(misfit)?;
        }
        for g in grids.iter_mut() {
            for a in 0..3 {
                arrays.fill(g.slice_mut(a)).ok_or_else(misfit)?;
            }
        }
        if arrays.sizes.next().is_some() {
            return Err(misfit());
        }
        let grids: Vec<Arc<FaceGrid>> = grids.into_iter().map(Arc::new).collect();
        for ((_, density), g) in state.gases.iter_mut().zip(&h.gases) {
            if let DensityState::Gridless { history, .. } = density {
                for &(k, dt, bt) in &g.steps {
                    let grid = grids.get(k).ok_or_else(misfit)?;
                    history.push((Arc::clone(grid), f32::from_bits(dt), bt));
                }
            }
        }
        Ok(state)
    }
}

/// The stored arrays, read in file order.
struct Arrays<'a, I> {
    data: &'a [u8],
    at: usize,
    sizes: I,
}

impl<I: Iterator<Item = usize>> Arrays<'_, I> {
    /// Fill `out` with the next array; `None` if it has another length.
    fn fill(&mut self, out: &mut [f32]) -> Option<()> {
        let n = self.sizes.next().filter(|&n| n == out.len())?;
        let bytes = self.data.get(self.at..self.at + 4 * n)?;
        for (v, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
            *v = f32::from_le_bytes(b.try_into().expect("4 bytes"));
        }
        self.at += 4 * n;
        Some(())
    }

    /// Fill `out` with the next array, f64 as two words each; `None` if it
    /// has another length.
    fn fill_f64(&mut self, out: &mut [f64]) -> Option<()> {
        let n = self.sizes.next().filter(|&n| n == 2 * out.len())?;
        let bytes = self.data.get(self.at..self.at + 4 * n)?;
        for (v, b) in out.iter_mut().zip(bytes.chunks_exact(8)) {
            *v = f64::from_le_bytes(b.try_into().expect("8 bytes"));
        }
        self.at += 4 * n;
        Some(())
    }
}

/// `metrics.csv` of `dir` cut after the row of `step`: the header (which
/// must be `columns`) and rows `1..=step`, as text to write back. A killed
/// run may have written rows after its last checkpoint (the last one perhaps
/// cut short); the resumed run writes them again.
///
/// # Errors
/// If the file is missing, has another header, or lacks a row up to `step`.
pub fn metrics_upto(dir: &Path, step: usize, columns: &[String]) -> Result<String, InputError> {
    let path = dir.join("metrics.csv");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| InputError::new(format!("cannot read {} to resume: {e}", path.display())))?;
    let mut lines = text.split_inclusive('\n');
    let header = lines.next().unwrap_or("");
    if header.trim_end() != columns.join(",") {
        return Err(InputError::new(format!(
            "{} has other columns than this run writes; it is not this run's",
            path.display()
        )));
    }
    let mut kept = header.to_string();
    for n in 1..=step {
        let row = lines
            .next()
            .filter(|l| l.ends_with('\n') && l.split(',').next() == Some(&n.to_string()));
        let Some(row) = row else {
            return Err(InputError::new(format!(
                "{} has no whole row for step {n}, before the checkpoint's step {step}",
                path.display()
            )));
        };
        kept.push_str(row);
    }
    Ok(kept)
}
