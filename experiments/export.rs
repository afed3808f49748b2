//! OpenVDB and ParaView frames: written by `smokelab run --vdb/--paraview`
//! as a run goes, and by `smokelab export vdb|paraview RUN_DIR` afterwards
//! from the frames a run saved.
//!
//! ```text
//! smokelab export vdb runs/hot-cold-1700000000        # frame_NNNN.vdb
//! smokelab export paraview runs/hot-cold-1700000000   # frame_NNNN.vti + run.pvd
//! ```
//!
//! Both read the run's `manifest.json` for the grid (origin, cell size,
//! counts), the gases and Δt, and each saved frame's `<gas>_NNNN.npy` and
//! `vel_NNNN.npy`; they write through the same [`write_frame_formats`] as
//! the run itself, so an export equals what `--vdb`/`--paraview` would
//! have written.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};
use ndarray::{ArrayView3, ArrayView4};
use serde::Deserialize;

use smokelab::error::InputError;
use smokelab::io::input::{read_npy3, read_npy4, read_text};
use smokelab::io::vdb::{write_vdb, VdbOptions, VolumeGeometry};
use smokelab::io::vtk::PvdCollection;

/// One saved frame's volumes and where they sit.
pub struct FrameVolumes<'a> {
    /// Frame number `N` (the state after `N` steps).
    pub frame: usize,
    /// Simulated time of the frame.
    pub time: f32,
    /// Where the arrays sit in the world.
    pub geometry: &'a VolumeGeometry,
    /// `(name, density)` per gas, shape `(nz, ny, nx)`.
    pub scalars: &'a [(&'a str, ArrayView3<'a, f32>)],
    /// `(name, vector)` volumes such as `vel`, shape `(nz, ny, nx, 3)`.
    pub vectors: &'a [(&'a str, ArrayView4<'a, f32>)],
}

/// Write one saved frame into `out` in the formats other tools open:
/// OpenVDB (`frame_NNNN.vdb`, Houdini, Blender) when `vdb`, with one float
/// grid per gas and a vec3s grid per vector volume, and VTK image data
/// (`frame_NNNN.vti`, ParaView) listed at its time in `pvd` when given.
/// Both place cell `(i, j, k)` at its centre in world units.
pub fn write_frame_formats(
    out: &Path,
    volumes: &FrameVolumes,
    vdb: bool,
    pvd: Option<&mut PvdCollection>,
) -> Result<()> {
    let FrameVolumes {
        frame,
        time,
        geometry,
        scalars,
        vectors,
    } = *volumes;
    if vdb {
        write_vdb(
            &out.join(format!("frame_{frame:04}.vdb")),
            geometry,
            scalars,
            vectors,
            VdbOptions::default(),
        )?;
    }
    if let Some(pvd) = pvd {
        let file = format!("frame_{frame:04}.vti");
        // The f32 time as its shortest decimal (0.1, not 0.10000000149…).
        let time: f64 = time.to_string().parse()?;
        pvd.write_frame(time, &file, geometry, scalars, vectors)?;
    }
    Ok(())
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
    /// A folder `smokelab run` wrote (with `manifest.json` and saved frames);
    /// the files are written into it.
    pub run_dir: PathBuf,
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
    /// The saved frames (those with a `vel_NNNN.npy`), ascending.
    pub frames: Vec<usize>,
}

/// The parts of a run's `manifest.json` read back.
#[derive(Deserialize)]
struct ManifestRecord {
    config: ConfigRecord,
    extra: RunRecord,
}

/// The solver configuration's time step.
#[derive(Deserialize)]
struct ConfigRecord {
    dt: f32,
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

impl RunFolder {
    /// Read the manifest and list the saved frames of the run in `dir`.
    /// A missing folder, a folder without a run's manifest, or one without
    /// saved frames is an [`InputError`] naming it.
    pub fn open(dir: &Path) -> Result<Self, InputError> {
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
            frames,
        })
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
    let run = RunFolder::open(&args.run_dir)?;
    let vdb = args.format == ExportFormat::Vdb;
    let mut pvd = (args.format == ExportFormat::Paraview)
        .then(|| PvdCollection::new(run.dir.join("run.pvd")));
    for &frame in &run.frames {
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
            time: frame as f32 * run.dt,
            geometry: &run.geometry,
            scalars: &scalars,
            vectors: &[("vel", velocity.view())],
        };
        write_frame_formats(&run.dir, &volumes, vdb, pvd.as_mut())?;
    }
    println!(
        "exported {} frames as {} in {:.1} s; wrote {}",
        run.frames.len(),
        match args.format {
            ExportFormat::Vdb => "frame_NNNN.vdb",
            ExportFormat::Paraview => "frame_NNNN.vti and run.pvd",
        },
        start.elapsed().as_secs_f64(),
        run.dir.display()
    );
    Ok(())
}
