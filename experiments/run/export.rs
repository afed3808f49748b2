//! OpenVDB and ParaView frames, the exchange formats a run writes as it
//! goes (`smokelab run --vdb/--paraview`) and `smokelab export` writes
//! afterwards from the frames a run saved ([`crate::cli::export`]): both
//! through [`write_frame_formats`], so an export equals what
//! `--vdb`/`--paraview` would have written.
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

use std::path::Path;

use anyhow::Result;
use clap::{Args, ValueEnum};

use ndarray::{ArrayView3, ArrayView4};

use serde::Serialize;
use smokelab::error::InputError;
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
