//! `smokelab export vdb|paraview RUN_DIR`: the frames a run saved,
//! written afterwards as OpenVDB or ParaView files.
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
//! has obstacles ([`RunFolder`]); they write through the same
//! [`write_frame_formats`] as the run itself, numbered and laid out as
//! [`crate::run::export`] describes.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};
use serde::Deserialize;

use crate::run::export::{sequence_number, write_frame_formats, Exchange, FrameVolumes, VdbFlags};
use crate::run::output_dir;
use smokelab::error::InputError;
use smokelab::io::input::{read_npy3, read_npy4, read_text};
use smokelab::io::vdb::VolumeGeometry;
use smokelab::io::vtk::PvdCollection;

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
