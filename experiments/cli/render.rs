//! `smokelab render`: render saved `.npy` volumes.
//!
//! ```text
//! smokelab render --density hot_0100.npy --density cold_0100.npy --out renders/f100
//! ```
//!
//! Each `--density` is an f32 array of shape `(nz, ny, nx)` as `smokelab run`
//! writes them; all must have the same shape. The box is `[0, size]` along
//! its longest axis (default 10, the hot/cold box) with cubic cells.
//!
//! ```text
//! smokelab render runs/hot-cold-1700000000 [--frame 100] --out renders/f100
//! ```
//!
//! Given a run's folder (`render RUN_DIR` or `--from RUN_DIR`), the box is
//! the run's (origin and extent from its `manifest.json`) and, without
//! `--density`, the volumes are the run's gases at `--frame` (default: the
//! last saved frame), in the run's order; `--size` and `--density` still
//! override. Writes `render_NNNN.exr` (linear, premultiplied RGBA),
//! `render_NNNN.png` (sRGB preview) and `render_NNNN.json` (the manifest:
//! parameters and render statistics), NNNN the run's frame (or the frame
//! number all `--density` files end in, `hot_0100.npy`; `render.exr`… when
//! there is none), so the frames of a run go into one folder. Every input
//! is checked before anything is written.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Result;
use clap::Args;
use glam::Vec3;
use ndarray::Array3;
use serde::Serialize;

use crate::cli::export::RunFolder;
use crate::run::progress::{self, Counted};
use smokelab::domain::Domain;
use smokelab::error::InputError;
use smokelab::field::Scalar;
use smokelab::grid::{ScalarGrid, Wrap};
use smokelab::io::vdb::VolumeGeometry;
use smokelab::io::{self, manifest::Manifest};
use smokelab::render::camera::{parse_image_size, parse_vec3, Camera};
use smokelab::render::lights::PointLight;
use smokelab::render::output::{self, Display, ExrPrecision};
use smokelab::render::phase::Phase;
use smokelab::render::{look, ray_box, render, RenderSettings, Scene};

/// `smokelab render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// A folder `smokelab run` wrote: its box, and its gases at --frame unless --density is given.
    #[arg(value_name = "RUN_DIR")]
    pub run_dir: Option<PathBuf>,
    /// The same as the RUN_DIR argument.
    #[arg(long = "from", value_name = "RUN_DIR")]
    pub from: Option<PathBuf>,
    /// Render from a run that is not complete (still running, killed or
    /// failed): its frames saved so far.
    #[arg(long)]
    pub partial: bool,
    /// The saved frame of the run to render (default: its last).
    #[arg(long, allow_negative_numbers = true)]
    pub frame: Option<usize>,
    /// A density volume (.npy, f32, shape (nz, ny, nx)); repeat for several gases.
    #[arg(long = "density")]
    pub densities: Vec<PathBuf>,
    /// Display colour R,G,B of the matching --density (default: red, blue, green, white…).
    #[arg(long = "color", allow_hyphen_values = true)]
    pub colors: Vec<String>,
    /// Edge length of the box along its longest axis (default: the run's, else 10).
    #[arg(long, allow_negative_numbers = true)]
    pub size: Option<f32>,
    /// Camera position X,Y,Z (default: framing the box in three-quarter view).
    #[arg(long, allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Point the camera looks at, X,Y,Z (default: the box centre).
    #[arg(long, allow_hyphen_values = true)]
    pub look_at: Option<String>,
    /// Vertical field of view in degrees (the default framing keeps the box in view).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    pub fov: f32,
    /// Image size WxH.
    #[arg(long, default_value = "512x512")]
    pub image: String,
    /// Point light position X,Y,Z (repeatable; default: a key light above and in front).
    #[arg(long = "light", allow_hyphen_values = true)]
    pub lights: Vec<String>,
    /// March step Δs (default: the cell size; the notes' fine setting is cell/10).
    #[arg(long, allow_negative_numbers = true)]
    pub march_step: Option<f32>,
    /// Jittered sub-steps per march step (eq A.29).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub substeps: u32,
    /// Sample sub-steps at their midpoints instead of jittering.
    #[arg(long)]
    pub no_jitter: bool,
    /// Extinction κ per unit density.
    #[arg(long, default_value_t = look::KAPPA, allow_negative_numbers = true)]
    pub kappa: f32,
    /// Emission as a fraction of the scattering colour.
    #[arg(long, default_value_t = look::GLOW, allow_negative_numbers = true)]
    pub glow: f32,
    /// Phase function: iso, hg:G or ff:N:MU.
    #[arg(long, default_value = "iso")]
    pub phase: String,
    /// Exposure of the PNG preview.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// EXR sample precision.
    #[arg(long, value_enum, default_value = "half")]
    pub precision: ExrPrecision,
    /// Jitter seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output folder; several frames may share one (`render_NNNN.exr`,
    /// `.png`, `.json` for frame NNNN).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an earlier render of the same frame in --out; without it
    /// that is refused (other frames' files stay either way).
    #[arg(long)]
    pub overwrite: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Everything resolved from the arguments, recorded in the manifest.
#[derive(Serialize)]
struct RenderJob {
    densities: Vec<PathBuf>,
    /// The run's frame rendered (or the one the density files are named
    /// after), which names the files written.
    frame: Option<usize>,
    scene: Scene,
    settings: RenderSettings,
    display: Display,
    precision: ExrPrecision,
}

/// Run `smokelab render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    let start = std::time::Instant::now();
    let job = resolve(args)?;
    let stem = match job.frame {
        Some(frame) => format!("render_{frame:04}"),
        None => "render".to_owned(),
    };
    let files = ["exr", "png", "json"].map(|ext| format!("{stem}.{ext}"));
    let names = files.each_ref().map(String::as_str);
    let outputs = crate::run::output_dir::render(&names);
    crate::run::output_dir::check(&args.out, &outputs, args.overwrite)?;
    let bar = progress::bar(
        expected_queries(&job.scene, &job.settings),
        "density samples",
        !args.quiet,
    );
    let mut counted = job.scene.clone();
    for v in &mut counted.volumes {
        v.density = Arc::new(Counted::new(v.density.clone(), &bar));
    }
    let rendered = render(&counted, &job.settings)?;
    bar.finish_and_clear();
    let _folder = crate::run::output_dir::open(&args.out, &outputs, args.overwrite)?;
    let [exr, png, json] = files.map(|f| args.out.join(f));
    output::write_exr(&exr, &rendered.image, job.precision)?;
    io::write_png(&png, &output::preview(&rendered.image, &job.display))?;
    let wall = start.elapsed().as_secs_f64();
    let stats = rendered.stats;
    io::write_json(
        &json,
        &Manifest::new(&job, args.seed, wall, serde_json::to_value(stats)?),
    )?;
    println!(
        "rendered {}x{} ({} samples, {:.2e} samples/s) in {:.1} s; wrote {} and {}",
        stats.width,
        stats.height,
        stats.samples,
        stats.samples_per_second,
        wall,
        exr.display(),
        png.display()
    );
    Ok(())
}

/// How many density queries rendering `scene` makes at most, for the
/// progress bar: per volume, the light grids' cells (when a light meets
/// scattering smoke) and every sub-step of every ray across the box. Rays
/// that turn opaque stop early, so the bar may end before it fills.
fn expected_queries(scene: &Scene, settings: &RenderSettings) -> u64 {
    let bounds = &scene.bounds;
    let scatters = scene.volumes.iter().any(|v| v.scattering != Vec3::ZERO);
    let light = if scatters && !scene.lights.is_empty() {
        bounds.len() as u64
    } else {
        0
    };
    let cam = settings.camera;
    let rays = cam.rays();
    let substep = settings.step.unwrap_or(bounds.cell) / settings.substeps as f32;
    let (lo, hi) = (bounds.origin, bounds.max_corner());
    let march: u64 = (0..cam.height)
        .flat_map(|py| (0..cam.width).map(move |px| (px, py)))
        .filter_map(|(px, py)| ray_box(rays.origin(), rays.direction(px, py), lo, hi))
        .map(|(t0, t1)| ((t1 - t0.max(0.0)).max(0.0) / substep).ceil() as u64)
        .sum();
    scene.volumes.len() as u64 * (light + march)
}

/// Check every argument and load the volumes.
fn resolve(args: &RenderArgs) -> Result<RenderJob, InputError> {
    let (width, height) = parse_image_size(&args.image)?;
    if !(args.kappa.is_finite() && args.kappa > 0.0) {
        return Err(InputError::new(format!(
            "--kappa is {}; it must be a positive finite number",
            args.kappa
        )));
    }
    if !(args.glow.is_finite() && args.glow >= 0.0) {
        return Err(InputError::new(format!(
            "--glow is {}; it must be a finite number ≥ 0",
            args.glow
        )));
    }
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        return Err(InputError::new(format!(
            "--exposure is {}; it must be a positive finite number",
            args.exposure
        )));
    }
    if let Some(size) = args.size {
        if !(size.is_finite() && size > 0.0) {
            return Err(InputError::new(format!(
                "--size is {size}; it must be a positive finite number"
            )));
        }
    }
    let run = match (&args.run_dir, &args.from) {
        (Some(a), Some(b)) => {
            return Err(InputError::new(format!(
                "two run folders, {} and --from {}; give one",
                a.display(),
                b.display()
            )))
        }
        (Some(dir), None) | (None, Some(dir)) => Some(RunFolder::open(dir, args.partial)?),
        (None, None) => None,
    };
    let (densities, frame) = volume_paths(args, run.as_ref())?;
    if args.colors.len() > densities.len() {
        return Err(InputError::new(format!(
            "{} --color values for {} volumes; give at most one colour per volume",
            args.colors.len(),
            densities.len()
        )));
    }
    let phase = Phase::parse(&args.phase)?;
    let arrays = densities
        .iter()
        .map(|p| read_volume(p))
        .collect::<Result<Vec<_>, _>>()?;
    let shape = arrays[0].dim();
    for (a, p) in arrays.iter().zip(&densities).skip(1) {
        if a.dim() != shape {
            return Err(InputError::new(format!(
                "volume {} has shape {:?} but {} has {:?}; all volumes must have the same shape",
                p.display(),
                a.dim(),
                densities[0].display(),
                shape
            )));
        }
    }
    let bounds = render_box(shape, args.size, run.as_ref().map(|r| &r.geometry))?;
    let mut volumes = Vec::new();
    for (i, (a, p)) in arrays.into_iter().zip(&densities).enumerate() {
        let color = match args.colors.get(i) {
            Some(c) => parse_color(c)?,
            None => look::default_color(i),
        };
        let density: Scalar = Arc::new(ScalarGrid::from_array(bounds, a).with_wrap(Wrap::Clamped));
        let name = p
            .file_stem()
            .map_or_else(|| format!("volume{i}"), |s| s.to_string_lossy().into());
        volumes.push(look::smoke(name, density, color, args.kappa, args.glow));
    }
    let lights = if args.lights.is_empty() {
        vec![look::key_light(&bounds)]
    } else {
        args.lights
            .iter()
            .map(|l| {
                Ok(PointLight {
                    position: parse_vec3(l, "--light")?,
                    color: look::key_light(&bounds).color,
                })
            })
            .collect::<Result<_, InputError>>()?
    };
    let mut camera = Camera::framing_fov(&bounds, width, height, look::FILL, args.fov);
    if let Some(c) = &args.camera {
        camera.position = parse_vec3(c, "--camera")?;
    }
    if let Some(l) = &args.look_at {
        camera.look_at = parse_vec3(l, "--look-at")?;
    }
    let scene = Scene {
        bounds,
        volumes,
        lights,
        phase,
    };
    let settings = RenderSettings {
        camera,
        step: args.march_step,
        substeps: args.substeps,
        jitter: !args.no_jitter,
        seed: args.seed,
    };
    smokelab::render::validate(&scene, &settings)?;
    Ok(RenderJob {
        densities,
        frame,
        scene,
        settings,
        display: Display {
            exposure: args.exposure,
            ..Display::default()
        },
        precision: args.precision,
    })
}

/// The volumes to render and their frame: the `--density` files (and the
/// frame number they all end in, if any), or else the run's gases at
/// `--frame` (default: its last saved frame).
fn volume_paths(
    args: &RenderArgs,
    run: Option<&RunFolder>,
) -> Result<(Vec<PathBuf>, Option<usize>), InputError> {
    let given = || (args.densities.clone(), common_frame(&args.densities));
    let Some(run) = run else {
        if let Some(frame) = args.frame {
            return Err(InputError::new(format!(
                "--frame {frame} needs a run folder: render RUN_DIR --frame {frame}"
            )));
        }
        if args.densities.is_empty() {
            return Err(InputError::new(
                "nothing to render: give --density FILE.npy (repeatable) or a run folder, render RUN_DIR",
            ));
        }
        return Ok(given());
    };
    if !args.densities.is_empty() {
        if let Some(frame) = args.frame {
            return Err(InputError::new(format!(
                "--frame {frame} picks the run's gases, but --density names the volumes; give one of them"
            )));
        }
        return Ok(given());
    }
    let last = *run.frames.last().expect("a run folder has saved frames");
    let frame = args.frame.unwrap_or(last);
    if !run.frames.contains(&frame) {
        let saved: Vec<String> = run.frames.iter().map(|f| f.to_string()).collect();
        return Err(InputError::new(format!(
            "--frame {frame} was not saved in {}; its saved frames are {}",
            run.dir.display(),
            saved.join(", ")
        )));
    }
    let paths = run.gases.iter().map(|g| run.gas_path(g, frame)).collect();
    Ok((paths, Some(frame)))
}

/// The frame number every one of `paths` is named after (`hot_0100.npy`,
/// `cold_0100.npy`: 100), if they share one.
fn common_frame(paths: &[PathBuf]) -> Option<usize> {
    let frame = |p: &PathBuf| -> Option<usize> {
        let stem = p.file_stem()?.to_str()?;
        let (_, n) = stem.rsplit_once('_')?;
        (n.len() >= 4 && n.bytes().all(|b| b.is_ascii_digit()))
            .then(|| n.parse().ok())
            .flatten()
    };
    let first = frame(paths.first()?)?;
    paths
        .iter()
        .all(|p| frame(p) == Some(first))
        .then_some(first)
}

/// The box of volumes of `shape` `(nz, ny, nx)`: with a run, its origin and
/// extent (the cell scaled when the arrays have another resolution, e.g.
/// `<gas>_fine_NNNN.npy`); `size` overrides the extent along the longest
/// axis, which is 10 without a run.
fn render_box(
    shape: (usize, usize, usize),
    size: Option<f32>,
    run: Option<&VolumeGeometry>,
) -> Result<Domain, InputError> {
    let (nz, ny, nx) = shape;
    let cells = nx.max(ny).max(nz) as f32;
    let origin = run.map_or(Vec3::ZERO, |g| g.origin);
    let cell = match (size, run) {
        (Some(size), _) => size / cells,
        (None, Some(g)) => g.cell * (g.dims.into_iter().max().unwrap_or(1) as f32 / cells),
        (None, None) => DEFAULT_SIZE / cells,
    };
    let extent = cell * cells;
    if !(EXTENT.0..=EXTENT.1).contains(&extent) {
        return Err(InputError::new(format!(
            "the box is {extent:e} world units along its longest axis (--size or the run's); \
             it must lie between {:e} and {:e} for the renderer's f32 geometry",
            EXTENT.0, EXTENT.1
        )));
    }
    Domain::new(origin, cell, [nx, ny, nz])
}

/// The box extents the renderer's f32 geometry handles: squared distances
/// between the camera and the box stay far inside f32's range (a box of
/// 10³⁰ overflowed them to infinity, one of 10⁻³⁰ underflowed them to 0,
/// and both were refused as "camera and look-at coincide").
const EXTENT: (f32, f32) = (1e-3, 1e9);

/// Edge length of the box along its longest axis without a run or `--size`:
/// the hot/cold box.
const DEFAULT_SIZE: f32 = 10.0;

/// Read an f32 `(nz, ny, nx)` volume with finite values.
fn read_volume(path: &Path) -> Result<Array3<f32>, InputError> {
    let a = io::input::read_npy3(path)?;
    if let Some(bad) = a.iter().find(|v| !v.is_finite()) {
        return Err(InputError::new(format!(
            "volume {} contains the non-finite value {bad}; densities must be finite",
            path.display()
        )));
    }
    Ok(a)
}

/// Parse `R,G,B` into a finite non-negative colour.
fn parse_color(s: &str) -> Result<Vec3, InputError> {
    let c = parse_vec3(s, "--color")?;
    if c.min_element() < 0.0 {
        return Err(InputError::new(format!(
            "--color '{s}' has a negative component; colours must be ≥ 0"
        )));
    }
    Ok(c)
}
