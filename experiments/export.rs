//! OpenVDB and ParaView frames: written by `smokelab run --vdb/--paraview`
//! as a run goes, and by `smokelab export vdb|paraview RUN_DIR` afterwards
//! from the frames a run saved.
//!
//! ```text
//! smokelab export vdb runs/hot-cold-1700000000        # frame_NNNN.vdb
//! smokelab export vdb runs/hot-cold-1700000000 --up z --out blender/
//! smokelab export paraview runs/hot-cold-1700000000   # frame_NNNN.vti + run.pvd
//! ```
//!
//! Both read the run's `manifest.json` for the grid (origin, cell size,
//! counts), the gases, Δt and `save_every`, each saved frame's
//! `<gas>_NNNN.npy` and `vel_NNNN.npy`, and `obstacle.npy` when the run
//! has obstacles; they write through the same [`write_frame_formats`] as
//! the run itself, so an export equals what `--vdb`/`--paraview` would
//! have written.
//!
//! **Frame numbers.** The `.npy` files and previews are numbered by step;
//! the exchange files by *sequence number* ([`sequence_number`]): the
//! frame saved after step `N` of a run saving every `K` steps is
//! `frame_{⌈N/K⌉:04}`, so the files count 1, 2, 3… without gaps, as
//! Blender's and Houdini's sequence detection need (`frame_0010`,
//! `frame_0020`… is no sequence to them). With `--save-every 1` the
//! sequence number is the step. Each VDB file records its step and time
//! as file metadata (`step`, `time`), and `run.pvd` lists each `.vti` at
//! its time.
//!
//! **Grids.** A VDB frame holds a fog-volume grid per gas, the fog volume
//! `density` ([`DensityGrid`]: the sum of the gases, or one of them — the
//! grid Blender's default volume material and Houdini's volume shaders
//! read), the velocity `vel`, and with obstacles the level set `obstacle`
//! (class `level set`, negative inside, world units; `obstacle.npy` is
//! positive inside, as the solver holds it). A `.vti` frame holds the gases,
//! `obstacle` (negative inside) and `vel` as cell data.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};

use crate::output_dir;
use ndarray::{ArrayView3, ArrayView4};
use serde::Deserialize;

use serde::Serialize;
use smokelab::error::InputError;
use smokelab::io::input::{read_npy3, read_npy4, read_text};
use smokelab::io::vdb::{write_vdb_grids, MetaValue, UpAxis, VdbGrids, VdbOptions, VolumeGeometry};
use smokelab::io::vtk::PvdCollection;

/// The sequence number of the exchange files (`frame_NNNN.vdb`, `.vti`)
/// of the frame saved after `step` steps by a run saving every
/// `save_every` steps and at its last: `⌈step / save_every⌉`, so that
/// the saved frames count 1, 2, 3… without gaps (a last frame between two
/// multiples takes the next number).
pub fn sequence_number(step: usize, save_every: usize) -> usize {
    step.div_ceil(save_every.max(1))
}

/// The exchange file of sequence number `n`, `frame_NNNN.<ext>`.
pub fn sequence_file(n: usize, ext: &str) -> String {
    format!("frame_{n:04}.{ext}")
}

/// What a VDB frame's `density` grid holds.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub enum DensityGrid {
    /// The sum of the gases.
    #[default]
    Sum,
    /// One gas, by name.
    Gas(String),
}

impl DensityGrid {
    /// `sum`, or a gas name.
    pub fn parse(s: &str) -> Self {
        match s {
            "sum" => DensityGrid::Sum,
            gas => DensityGrid::Gas(gas.to_string()),
        }
    }

    /// Check that a named gas is one of `gases`.
    pub fn check(&self, gases: &[String]) -> Result<(), InputError> {
        match self {
            DensityGrid::Gas(g) if !gases.contains(g) => Err(InputError::new(format!(
                "--density-grid {g}: the run has no gas {g}; give sum or one of: {}",
                gases.join(", ")
            ))),
            _ => Ok(()),
        }
    }
}

/// The up axis of the VDB files (`--up`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Up {
    /// y up, as simulated (Houdini, Maya).
    #[default]
    Y,
    /// z up (Blender): the data rotated +90° about x, (x, y, z) ↦ (x, −z, y).
    Z,
}

impl From<Up> for UpAxis {
    fn from(u: Up) -> Self {
        match u {
            Up::Y => UpAxis::Y,
            Up::Z => UpAxis::Z,
        }
    }
}

/// The flags that shape the VDB frames, shared by `run --vdb` and `export vdb`.
#[derive(Clone, Debug, Default, Args)]
pub struct VdbFlags {
    /// What each VDB frame's `density` grid holds (the grid Blender's default
    /// volume material shows): `sum` of the gases (default) or one gas by name.
    #[arg(long, value_name = "sum|GAS")]
    pub density_grid: Option<String>,
    /// The VDB files' up axis: `y` as simulated (Houdini), `z` for Blender
    /// (the data rotated +90° about x).
    #[arg(long, value_enum)]
    pub up: Option<Up>,
}

impl VdbFlags {
    /// Whether any flag was given (they shape VDB files only).
    pub fn given(&self) -> bool {
        self.density_grid.is_some() || self.up.is_some()
    }

    /// The options these flags select, checked against the run's gases.
    pub fn resolve(&self, gases: &[String]) -> Result<VdbFrames, InputError> {
        let density = self
            .density_grid
            .as_deref()
            .map_or_else(DensityGrid::default, DensityGrid::parse);
        density.check(gases)?;
        Ok(VdbFrames {
            density,
            up: self.up.unwrap_or_default(),
        })
    }
}

/// How VDB frames are written ([`VdbFlags`] resolved).
#[derive(Clone, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct VdbFrames {
    /// The `density` grid.
    pub density: DensityGrid,
    /// The up axis.
    pub up: Up,
}

/// One saved frame's volumes and where they sit.
pub struct FrameVolumes<'a> {
    /// Frame number `N` (the state after `N` steps).
    pub frame: usize,
    /// The exchange files' sequence number ([`sequence_number`]).
    pub sequence: usize,
    /// Simulated time of the frame.
    pub time: f32,
    /// Where the arrays sit in the world.
    pub geometry: &'a VolumeGeometry,
    /// `(name, density)` per gas, shape `(nz, ny, nx)`.
    pub scalars: &'a [(&'a str, ArrayView3<'a, f32>)],
    /// `(name, vector)` volumes such as `vel`, shape `(nz, ny, nx, 3)`.
    pub vectors: &'a [(&'a str, ArrayView4<'a, f32>)],
    /// The obstacles' level set at the cell centres, **positive inside**
    /// as the solver holds it (`obstacle.npy`), if the run has obstacles.
    pub obstacle: Option<ArrayView3<'a, f32>>,
}

/// The formats [`write_frame_formats`] writes.
pub struct Exchange<'a> {
    /// OpenVDB, and how.
    pub vdb: Option<&'a VdbFrames>,
    /// VTK image data, listed in this collection.
    pub pvd: Option<&'a mut PvdCollection>,
}

/// Write one saved frame into `out` in the formats other tools open:
/// OpenVDB (`frame_NNNN.vdb`, Houdini, Blender), with a fog volume per gas,
/// the fog volume `density`, the level set `obstacle` and a vec3s grid per
/// vector volume, and VTK image data (`frame_NNNN.vti`, ParaView) listed at
/// its time in the collection. `NNNN` is the sequence number. Both place
/// cell `(i, j, k)` at its centre in world units (rotated with `--up z`).
pub fn write_frame_formats(out: &Path, volumes: &FrameVolumes, to: Exchange) -> Result<()> {
    let FrameVolumes {
        frame,
        sequence,
        time,
        geometry,
        scalars,
        vectors,
        obstacle,
    } = *volumes;
    // Negative inside, as OpenVDB and VTK's contour filters take a level set.
    let level = obstacle.map(|o| o.mapv(|v| -v));
    if let Some(vdb) = to.vdb {
        let density = density_grid(scalars, &vdb.density)?;
        let mut fog: Vec<(&str, ArrayView3<f32>)> = scalars.to_vec();
        if let Some(d) = &density {
            fog.push(("density", d.view()));
        }
        let level_sets: Vec<(&str, ArrayView3<f32>)> =
            level.iter().map(|l| ("obstacle", l.view())).collect();
        let metadata = [
            ("step", MetaValue::Int(frame as i64)),
            ("time", MetaValue::Float(time)),
        ];
        let grids = VdbGrids {
            fog: &fog,
            level_sets: &level_sets,
            vectors,
            metadata: &metadata,
        };
        let options = VdbOptions {
            up: vdb.up.into(),
            ..VdbOptions::default()
        };
        write_vdb_grids(
            &out.join(sequence_file(sequence, "vdb")),
            geometry,
            &grids,
            options,
        )?;
    }
    if let Some(pvd) = to.pvd {
        let file = sequence_file(sequence, "vti");
        // The f32 time as its shortest decimal (0.1, not 0.10000000149…).
        let time: f64 = time.to_string().parse()?;
        let mut cells: Vec<(&str, ArrayView3<f32>)> = scalars.to_vec();
        if let Some(l) = &level {
            cells.push(("obstacle", l.view()));
        }
        pvd.write_frame(time, &file, geometry, &cells, vectors)?;
    }
    Ok(())
}

/// The `density` grid of a frame: the sum of the gases or one of them;
/// `None` when a gas is itself named `density`.
fn density_grid(
    scalars: &[(&str, ArrayView3<f32>)],
    choice: &DensityGrid,
) -> Result<Option<ndarray::Array3<f32>>> {
    if scalars.iter().any(|(n, _)| *n == "density") || scalars.is_empty() {
        return Ok(None);
    }
    Ok(Some(match choice {
        DensityGrid::Sum => {
            let mut sum = scalars[0].1.to_owned();
            for (_, g) in &scalars[1..] {
                sum += g;
            }
            sum
        }
        DensityGrid::Gas(name) => scalars
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, g)| g.to_owned())
            .ok_or_else(|| anyhow::anyhow!("--density-grid {name}: no such gas"))?,
    }))
}

/// The formats `smokelab export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExportFormat {
    /// OpenVDB, `frame_NNNN.vdb` (Houdini, Blender).
    Vdb,
    /// VTK image data, `frame_NNNN.vti`, listed in `run.pvd` (ParaView).
    Paraview,
}

/// `smokelab export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The format to write.
    #[arg(value_enum)]
    pub format: ExportFormat,
    /// A folder `smokelab run` wrote (with `manifest.json` and saved frames).
    pub run_dir: PathBuf,
    /// Where to write the files (default: into RUN_DIR).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the frames of this format an earlier run or export wrote
    /// there (only `frame_NNNN.vdb`, or `frame_NNNN.vti` and `run.pvd`).
    #[arg(long)]
    pub overwrite: bool,
    /// Export a run that is not complete (still running, killed or
    /// failed): the frames it has saved.
    #[arg(long)]
    pub partial: bool,
    /// The VDB frames' `density` grid and up axis.
    #[command(flatten)]
    pub vdb: VdbFlags,
}

/// A run's folder as its manifest and saved frames describe it.
#[derive(Clone, Debug)]
pub struct RunFolder {
    /// The folder.
    pub dir: PathBuf,
    /// Where the arrays sit in the world.
    pub geometry: VolumeGeometry,
    /// The gases, in the run's order: each saved frame has `<gas>_NNNN.npy`.
    pub gases: Vec<String>,
    /// The time step Δt; frame `N` is at time `N Δt`.
    pub dt: f32,
    /// The run's `save_every` (`None`: not a run's configuration, e.g. a
    /// script's; the saved frames are then numbered in order).
    pub save_every: Option<usize>,
    /// The saved frames (those with a `vel_NNNN.npy`), ascending.
    pub frames: Vec<usize>,
}

/// The parts of a run's `manifest.json` read back.
#[derive(Deserialize)]
struct ManifestRecord {
    /// `complete`, `running` or `failed` (`None`: a manifest from before
    /// the status was recorded).
    #[serde(default)]
    status: Option<String>,
    config: ConfigRecord,
    extra: RunRecord,
}

/// The solver configuration's time step and save cadence.
#[derive(Deserialize)]
struct ConfigRecord {
    dt: f32,
    #[serde(default)]
    save_every: Option<usize>,
}

/// What `smokelab run` records about its grid and gases.
#[derive(Deserialize)]
struct RunRecord {
    grid: GridFields,
    gases: Vec<String>,
}

/// The grid's placement (see `run::GridRecord`).
#[derive(Deserialize)]
struct GridFields {
    origin: [f32; 3],
    cell: f32,
    dims: [usize; 3],
}

/// Whether `name` (a gas read from a manifest) can be part of a file name
/// in the run's folder and nothing else: not empty, no path separator,
/// not `..` or hidden, no control character.
fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && !name
            .chars()
            .any(|c| c == '/' || c == '\\' || c.is_control())
}

impl RunFolder {
    /// Read the manifest and list the saved frames of the run in `dir`.
    /// A missing folder, a folder without a run's manifest, one without
    /// saved frames, one whose manifest names a gas that is not a plain file
    /// name, or — unless `partial` — a run that is not complete (still
    /// running, killed or failed) is an [`InputError`] naming it.
    pub fn open(dir: &Path, partial: bool) -> Result<Self, InputError> {
        let not_a_run = |why: String| {
            InputError::new(format!(
                "run folder {} {why}; give a folder `smokelab run` wrote",
                dir.display()
            ))
        };
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => return Err(not_a_run("is not a folder".into())),
            Err(e) => return Err(not_a_run(format!("cannot be read ({e})"))),
        }
        let manifest = dir.join("manifest.json");
        if !manifest.exists() {
            return Err(not_a_run("has no manifest.json".into()));
        }
        let text = read_text(&manifest, "manifest")?;
        let record: ManifestRecord = serde_json::from_str(&text)
            .map_err(|e| not_a_run(format!("has a manifest.json that is not a run's ({e})")))?;
        match record.status.as_deref() {
            None | Some("complete") => {}
            Some(status) if !partial => {
                return Err(not_a_run(format!(
                    "is not complete (its manifest says {status}: the run is still going, was killed or failed); give --partial to use the frames it has"
                )))
            }
            Some(_) => {}
        }
        if let Some(g) = record.extra.gases.iter().find(|g| !is_plain_name(g)) {
            return Err(not_a_run(format!(
                "has a manifest.json naming the gas {g:?}, which is not a plain file name (no '/', '..' or leading '.')"
            )));
        }
        let grid = record.extra.grid;
        let geometry = VolumeGeometry::new(grid.origin.into(), grid.cell, grid.dims);
        geometry
            .validate()
            .map_err(|e| not_a_run(format!("has a manifest.json whose grid is invalid ({e})")))?;
        let mut frames: Vec<usize> = std::fs::read_dir(dir)
            .map_err(|e| not_a_run(format!("cannot be listed ({e})")))?
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().into_string().ok()?;
                let n = name.strip_prefix("vel_")?.strip_suffix(".npy")?;
                (n.len() == 4).then(|| n.parse().ok()).flatten()
            })
            .collect();
        frames.sort_unstable();
        if frames.is_empty() {
            return Err(not_a_run(
                "holds no saved frames (vel_NNNN.npy); runs save them every --save-every K ≥ 1 frames".into(),
            ));
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            geometry,
            gases: record.extra.gases,
            dt: record.config.dt,
            save_every: record.config.save_every.filter(|&k| k > 0),
            frames,
        })
    }

    /// The saved frames an uninterrupted run writes, with their sequence
    /// numbers: with `save_every` K, each multiple of K and the last,
    /// numbered `⌈N/K⌉` (a frame a resumed run saved as the last of a shorter
    /// run is left out); otherwise every saved frame, numbered in order.
    pub fn sequence(&self) -> Vec<(usize, usize)> {
        let last = self.frames.last().copied().unwrap_or(0);
        match self.save_every {
            Some(k) => self
                .frames
                .iter()
                .filter(|&&f| f.is_multiple_of(k) || f == last)
                .map(|&f| (f, sequence_number(f, k)))
                .collect(),
            None => self
                .frames
                .iter()
                .enumerate()
                .map(|(n, &f)| (f, n + 1))
                .collect(),
        }
    }

    /// The obstacles' level set (`obstacle.npy`, positive inside), if the
    /// run has obstacles.
    pub fn read_obstacle(&self) -> Result<Option<ndarray::Array3<f32>>, InputError> {
        let path = self.dir.join("obstacle.npy");
        if !path.exists() {
            return Ok(None);
        }
        let a = read_npy3(&path)?;
        self.check_shape(&path, a.shape())?;
        Ok(Some(a))
    }

    /// The file of `gas` at `frame`.
    pub fn gas_path(&self, gas: &str, frame: usize) -> PathBuf {
        self.dir.join(format!("{gas}_{frame:04}.npy"))
    }

    /// Read every gas of `frame`, checked against the manifest's grid.
    pub fn read_gases(&self, frame: usize) -> Result<Vec<ndarray::Array3<f32>>, InputError> {
        self.gases
            .iter()
            .map(|g| {
                let path = self.gas_path(g, frame);
                let a = read_npy3(&path)?;
                self.check_shape(&path, a.shape())?;
                Ok(a)
            })
            .collect()
    }

    /// Read the cell-centred velocity of `frame`, checked against the grid.
    pub fn read_velocity(&self, frame: usize) -> Result<ndarray::Array4<f32>, InputError> {
        let path = self.dir.join(format!("vel_{frame:04}.npy"));
        let v = read_npy4(&path)?;
        self.check_shape(&path, v.shape())?;
        Ok(v)
    }

    /// An array read from `path` must have the grid's `(nz, ny, nx)` shape
    /// (and 3 components if it has a fourth axis).
    fn check_shape(&self, path: &Path, shape: &[usize]) -> Result<(), InputError> {
        let (nz, ny, nx) = self.geometry.shape();
        let want: &[usize] = if shape.len() == 4 {
            &[nz, ny, nx, 3]
        } else {
            &[nz, ny, nx]
        };
        if shape != want {
            return Err(InputError::new(format!(
                "{} has shape {shape:?} but the run's manifest gives the grid {want:?}; the run folder is inconsistent",
                path.display()
            )));
        }
        Ok(())
    }
}

/// Run `smokelab export`: write every saved frame of the run in `format`
/// into the run's folder.
pub fn run(args: &ExportArgs) -> Result<()> {
    let start = std::time::Instant::now();
    // A run still writing its folder holds it: say so first.
    smokelab::io::folder::check_free(args.out.as_ref().unwrap_or(&args.run_dir))?;
    let run = RunFolder::open(&args.run_dir, args.partial)?;
    let is_vdb = args.format == ExportFormat::Vdb;
    if !is_vdb && args.vdb.given() {
        return Err(InputError::new(
            "--density-grid and --up shape VDB files; `export paraview` has none",
        )
        .into());
    }
    let vdb = args.vdb.resolve(&run.gases)?;
    let out = args.out.clone().unwrap_or_else(|| run.dir.clone());
    let rule = match args.format {
        ExportFormat::Vdb => &output_dir::EXPORT_VDB,
        ExportFormat::Paraview => &output_dir::EXPORT_PARAVIEW,
    };
    let obstacle = run.read_obstacle()?;
    let _folder = output_dir::prepare(&out, rule, args.overwrite)?;
    let mut pvd = (!is_vdb).then(|| PvdCollection::new(out.join("run.pvd")));
    let sequence = run.sequence();
    for &(frame, n) in &sequence {
        let gases = run.read_gases(frame)?;
        let velocity = run.read_velocity(frame)?;
        let scalars: Vec<(&str, _)> = run
            .gases
            .iter()
            .map(String::as_str)
            .zip(gases.iter().map(|g| g.view()))
            .collect();
        let volumes = FrameVolumes {
            frame,
            sequence: n,
            time: frame as f32 * run.dt,
            geometry: &run.geometry,
            scalars: &scalars,
            vectors: &[("vel", velocity.view())],
            obstacle: obstacle.as_ref().map(|o| o.view()),
        };
        let to = Exchange {
            vdb: is_vdb.then_some(&vdb),
            pvd: pvd.as_mut(),
        };
        write_frame_formats(&out, &volumes, to)?;
    }
    println!(
        "exported {} frames as {} in {:.1} s; wrote {}",
        sequence.len(),
        match args.format {
            ExportFormat::Vdb => "frame_NNNN.vdb",
            ExportFormat::Paraview => "frame_NNNN.vti and run.pvd",
        },
        start.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
