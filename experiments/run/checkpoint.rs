//! `checkpoint.bin`: the whole state of a run, so `smokelab run --resume
//! RUN_DIR` continues a killed run to the bitwise-identical frames and
//! metrics of an uninterrupted one.
//!
//! What is stored is the [`RunRecord`] (scenario, resolved configuration
//! and the output flags) and [`Simulation::state`]: the step count, the
//! staggered velocity, per gas its mass budget and density state (gridded:
//! the grid; gridless: the history of velocity grids, each grid shared
//! between gases stored once; SELMA: reference density, whether `ρ₀` is
//! still composed, re-anchorings, and the map and tracked lattice with the
//! gas that owns them), and the obstacle solves' warm starts (the exact
//! projection's f64 pressure, QUICK's face potential). Sources, obstacles,
//! transform plans and scratch buffers are rebuilt from the configuration.
//! The step has no random numbers (the seed only places the initial
//! conditions, rebuilt from the configuration; the metrics' probe points
//! are drawn from a fixed seed), so there is no RNG state to keep.
//!
//! # Format 3
//!
//! In this order:
//!
//! ```text
//! "SMKCKPT\0"   8 bytes     the format's name
//! format        u32 LE      3 (FORMAT); other formats are refused
//! header size   u64 LE      bytes of the header
//! header        JSON        {"version": smokelab version, "commit": build commit,
//!                            "run": the RunRecord, "step": steps taken,
//!                            "time": simulated time, "gases": per gas its
//!                            "mode" and SELMA "restarts" (0 otherwise)}
//! state         postcard    the SimulationState, to the end but 8 bytes
//! checksum      u64 LE      FNV-1a 64 of every byte before it
//! ```
//!
//! The state is the library's serde serialization of
//! [`SimulationState`] in the postcard wire format (version 1): integers
//! as LEB128 varints, `f32`/`f64` as their 4/8 little-endian bytes, a
//! sequence as its length then its elements, an option as a byte 0/1 then
//! the value, an enum as its variant's index then its fields, a struct or
//! tuple as its fields in order. So every array is its length followed by
//! its raw little-endian values: `step_index`, `velocity` (`FaceGrid`:
//! domain `(origin, cell, dims)`, box kind, `[u, v, w]`), `gases`
//! (`smokelab::density::stored`: the distinct gridless velocity grids,
//! then per gas its budget `(advection, cleared)` and its state),
//! `obstacle_pressure` (f64), `face_potential` (f32). To read one: check
//! the name, the checksum and the format, parse the header, then
//! `postcard::from_bytes::<SimulationState>` of the state's bytes, with
//! the smokelab version the header names.
//!
//! The file is written through a uniquely named temporary file in the run
//! folder, synced and renamed ([`io::write_atomic`]), so the latest whole
//! checkpoint survives a kill at any moment; the temporary file is removed
//! on error and on Ctrl-C.

use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::Result;
use serde::{Deserialize, Serialize};
use smokelab::density::{DensityMode, DensityState};
use smokelab::error::InputError;
use smokelab::io::{self, manifest::BUILD_COMMIT};
use smokelab::scenario::ScenarioKind;
use smokelab::simulation::{Simulation, SimulationState};

/// The checkpoint's file name in the run folder.
pub const FILE: &str = "checkpoint.bin";

/// The format's name, the file's first bytes.
const MAGIC: &[u8; 8] = b"SMKCKPT\0";

/// The format this build writes and reads (3: the state through serde and
/// postcard).
pub const FORMAT: u32 = 3;

/// Bytes before the header: name, format and header size.
const PREAMBLE: usize = 20;

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
    /// `--density-grid` and `--up` of the VDB frames.
    pub vdb_frames: crate::run::export::VdbFrames,
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

/// The header: what the run was, for a reader of the file and for
/// `--resume`'s checks before the state is restored.
#[derive(Serialize, Deserialize)]
struct Header {
    /// smokelab version that wrote it.
    version: String,
    /// Its build commit.
    commit: String,
    run: RunRecord,
    /// Steps taken (the state's `step_index`).
    step: usize,
    /// Simulated time.
    time: f32,
    gases: Vec<GasSummary>,
}

/// A gas as the header lists it (its state holds the same).
#[derive(Serialize, Deserialize)]
struct GasSummary {
    mode: DensityMode,
    /// SELMA's re-anchorings so far (0 in the other modes).
    restarts: usize,
}

impl GasSummary {
    fn of(state: &DensityState) -> Self {
        let (mode, restarts) = match state {
            DensityState::Gridded(_) => (DensityMode::Gridded, 0),
            DensityState::Gridless { .. } => (DensityMode::Gridless, 0),
            DensityState::Selma(s) => (DensityMode::Selma, s.restarts),
        };
        Self { mode, restarts }
    }
}

/// FNV-1a, 64 bit, of everything written through it; keeps the first
/// error of the writer below, which postcard reports only as "The
/// serialize buffer is full".
struct Hashing<W> {
    inner: W,
    hash: u64,
    error: Option<std::io::Error>,
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0100_0000_01b3;

fn fnv(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash = (hash ^ b as u64).wrapping_mul(FNV_PRIME);
    }
    hash
}

impl<W> Hashing<W> {
    /// Keep (a copy of) the writer's first error and pass it on.
    fn keep(&mut self, e: std::io::Error) -> std::io::Error {
        let copy = match e.raw_os_error() {
            Some(code) => std::io::Error::from_raw_os_error(code),
            None => std::io::Error::new(e.kind(), e.to_string()),
        };
        self.error.get_or_insert(copy);
        e
    }
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.inner.write(buf) {
            Ok(n) => {
                self.hash = fnv(self.hash, &buf[..n]);
                Ok(n)
            }
            Err(e) => Err(self.keep(e)),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush().map_err(|e| self.keep(e))
    }
}

/// Write `dir/checkpoint.bin` for `sim` as it is now, atomically.
pub fn write(dir: &Path, sim: &Simulation, run: &RunRecord) -> Result<()> {
    write_file(&dir.join(FILE), sim, run)
}

/// Write the checkpoint of `sim` as it is now to the file `path`,
/// atomically (the Python module's `Simulation.checkpoint`).
pub fn write_file(path: &Path, sim: &Simulation, run: &RunRecord) -> Result<()> {
    let state = sim.state();
    let header = Header {
        version: env!("CARGO_PKG_VERSION").into(),
        commit: BUILD_COMMIT.into(),
        run: run.clone(),
        step: state.step_index,
        time: sim.time(),
        gases: state.gases.iter().map(|(_, d)| GasSummary::of(d)).collect(),
    };
    let json = serde_json::to_vec(&header)?;
    io::write_atomic(path, |w| write_to(w, &json, &state))
}

/// The checkpoint file's bytes after its header `json`: magic, format,
/// header, `state` and the checksum of all before it. An error of `w`
/// (a full disk) is returned as the I/O error it is.
fn write_to(w: &mut impl Write, json: &[u8], state: &SimulationState) -> Result<()> {
    // Buffered before the hash: postcard writes an f32 at a time.
    let hashing = Hashing {
        inner: &mut *w,
        hash: FNV_OFFSET,
        error: None,
    };
    let mut h = BufWriter::with_capacity(1 << 16, hashing);
    let body = (|| -> Result<u64> {
        h.write_all(MAGIC)?;
        h.write_all(&FORMAT.to_le_bytes())?;
        h.write_all(&(json.len() as u64).to_le_bytes())?;
        h.write_all(json)?;
        let h = postcard::to_io(state, &mut h)?;
        h.flush()?;
        Ok(h.get_ref().hash)
    })();
    let hash = match body {
        Ok(hash) => hash,
        Err(e) => return Err(h.get_mut().error.take().map_or(e, Into::into)),
    };
    drop(h);
    w.write_all(&hash.to_le_bytes())?;
    Ok(())
}

/// A checkpoint read and checked whole (name, checksum, format, version).
pub struct Checkpoint {
    header: Header,
    state: SimulationState,
}

impl Checkpoint {
    /// Read `dir/checkpoint.bin`.
    ///
    /// # Errors
    /// One line naming the problem: no checkpoint, not a checkpoint,
    /// truncated or corrupt, another format (naming it and the one read
    /// here) or smokelab version.
    pub fn read(dir: &Path) -> Result<Self, InputError> {
        let path = dir.join(FILE);
        if !path.is_file() {
            return Err(InputError::new(format!(
                "{} has no {FILE}; only a run started with --checkpoint-every K can be resumed",
                dir.display()
            )));
        }
        Self::read_file(&path)
    }

    /// Read the checkpoint file `path` (as [`Self::read`]; the Python
    /// module's `Simulation.resume`).
    ///
    /// # Errors
    /// As [`Self::read`], and if `path` is not a file.
    pub fn read_file(path: &Path) -> Result<Self, InputError> {
        let show = path.display();
        if !path.is_file() {
            return Err(InputError::new(format!("checkpoint {show} is not a file")));
        }
        let bytes =
            std::fs::read(path).map_err(|e| InputError::new(format!("cannot read {show}: {e}")))?;
        let corrupt = |why: &str| InputError::new(format!("{show} is {why}; it cannot be resumed"));
        if bytes.len() < MAGIC.len() && MAGIC.starts_with(&bytes) {
            return Err(corrupt("truncated"));
        }
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            return Err(corrupt("not a smokelab checkpoint"));
        }
        if bytes.len() < PREAMBLE + 8 {
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
        let len = u64::from_le_bytes(body[12..PREAMBLE].try_into().expect("8 bytes"));
        let json = usize::try_from(len)
            .ok()
            .and_then(|l| body.get(PREAMBLE..PREAMBLE.checked_add(l)?))
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
        let state: SimulationState = match postcard::take_from_bytes(&body[PREAMBLE + json.len()..])
        {
            Ok((state, [])) => state,
            Ok(_) => return Err(corrupt("corrupt (bytes after its state)")),
            Err(e) => return Err(corrupt(&format!("corrupt (state: {e})"))),
        };
        if state.step_index != header.step {
            return Err(corrupt("corrupt (its header and state differ in step)"));
        }
        Ok(Self { header, state })
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

    /// The stored state, to [`Simulation::restore`] into a simulation
    /// built from the recorded configuration.
    pub fn into_state(self) -> SimulationState {
        self.state
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

#[cfg(test)]
mod tests {
    use super::*;
    use smokelab::scenario::hot_cold::HotColdConfig;
    use smokelab::scenario::Scenario as _;

    /// A writer with room for `room` bytes, then a full disk.
    struct Full {
        room: usize,
    }

    impl Write for Full {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.room == 0 {
                return Err(std::io::Error::from_raw_os_error(libc::ENOSPC));
            }
            let n = buf.len().min(self.room);
            self.room -= n;
            Ok(n)
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_full_disk_reads_as_one_not_as_a_full_serialize_buffer() {
        let mut config = HotColdConfig::default();
        config.solver.res = 8;
        let sim = config.build().unwrap();
        let state = sim.state();
        let mut whole = Vec::new();
        write_to(&mut whole, b"{}", &state).unwrap();
        // Full in the header, in the state, and at the checksum.
        for room in [10, whole.len() / 2, whole.len() - 4] {
            let e = write_to(&mut Full { room }, b"{}", &state).unwrap_err();
            let e = format!("{e:#}");
            assert!(
                e.to_lowercase().contains("no space left on device"),
                "{room}: {e}"
            );
        }
    }
}
