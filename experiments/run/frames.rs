//! A run's frames: which ones it saves ([`SaveFrames`]), and rendering
//! them, `render_NNNN.exr` and `render_NNNN.png` beside the volumes a run
//! writes (`smokelab run … --render`, experiment 06-1).

use std::path::{Path, PathBuf};

use anyhow::Result;
use serde::Serialize;

use smokelab::domain::Domain;
use smokelab::error::InputError;
use smokelab::field::Scalar;
use smokelab::io;
use smokelab::render::camera::check_image_size;
use smokelab::render::output::{self, Display, ExrPrecision};
use smokelab::render::phase::Phase;
use smokelab::render::{check_step, look, render, RenderSettings, RenderStats, Scene};
use smokelab::simulation::Simulation;

/// The frames whose volumes and previews are written.
#[derive(Clone, Debug)]
pub enum SaveFrames {
    /// Every K-th frame and the last (K = 0: none).
    Every(usize),
    /// Exactly these frames.
    List(Vec<usize>),
}

impl SaveFrames {
    /// Whether `frame` of a run of `last` frames is selected.
    pub fn contains(&self, frame: usize, last: usize) -> bool {
        match self {
            SaveFrames::Every(0) => false,
            SaveFrames::Every(k) => frame.is_multiple_of(*k) || frame == last,
            SaveFrames::List(l) => l.contains(&frame),
        }
    }

    /// The sequence number of the exchange files (`frame_NNNN.vdb`,
    /// `.vti`) of saved `frame`: `⌈frame/K⌉` ([`crate::run::export::sequence_number`]),
    /// or its place in the list (from 1).
    pub fn sequence(&self, frame: usize) -> usize {
        match self {
            SaveFrames::Every(k) => crate::run::export::sequence_number(frame, *k),
            SaveFrames::List(l) => l.iter().filter(|&&f| f <= frame).count(),
        }
    }
}

/// Which frames of a run to render, and how.
#[derive(Clone, Debug)]
pub struct FrameRender {
    /// The frames to render.
    pub frames: SaveFrames,
    /// Image width and height in pixels.
    pub image: (u32, u32),
    /// March step Δs (`None`: the cell size).
    pub step: Option<f32>,
    /// EXR sample precision.
    pub precision: ExrPrecision,
}

impl FrameRender {
    /// Render `frames` of a simulation on `domain` at `image` pixels with
    /// march step `step`; checks the image size and the step.
    pub fn new(
        frames: SaveFrames,
        image: (u32, u32),
        step: Option<f32>,
        domain: &Domain,
    ) -> Result<Self, InputError> {
        check_image_size(image.0, image.1)?;
        if let Some(s) = step {
            check_step(s, domain)?;
        }
        Ok(Self {
            frames,
            image,
            step,
            precision: ExrPrecision::Half,
        })
    }

    /// Whether frame `frame` of a run of `last` frames is rendered.
    pub fn wants(&self, frame: usize, last: usize) -> bool {
        self.frames.contains(frame, last)
    }

    /// Render the gases of `sim` into `out/render_NNNN.{exr,png}`.
    pub fn render_frame(&self, sim: &Simulation, out: &Path, frame: usize) -> Result<FrameRecord> {
        let domain = *sim.domain();
        let scene = simulation_scene(sim);
        let settings = RenderSettings {
            step: self.step,
            ..RenderSettings::new(look::camera(&domain, self.image.0, self.image.1))
        };
        let r = render(&scene, &settings)?;
        let exr = out.join(format!("render_{frame:04}.exr"));
        let png = out.join(format!("render_{frame:04}.png"));
        output::write_exr(&exr, &r.image, self.precision)?;
        io::write_png(&png, &output::preview(&r.image, &Display::default()))?;
        Ok(FrameRecord {
            frame,
            png,
            exr,
            stats: r.stats,
        })
    }
}

/// The default scene of a simulation frame: every gas as smoke in the
/// default look (lift ≥ 0 hot red, else cold blue), one key light,
/// isotropic scattering, inside the simulation box.
pub fn simulation_scene(sim: &Simulation) -> Scene {
    let domain = *sim.domain();
    let volumes = sim
        .gases
        .iter()
        .map(|g| {
            let color = if g.lift >= 0.0 { look::HOT } else { look::COLD };
            // The density in its own representation: gridless and SELMA renders
            // query the procedural field (§6.2, ch. 8).
            let density: Scalar = g.model.field();
            look::smoke(&g.name, density, color, look::KAPPA, look::GLOW)
        })
        .collect();
    Scene {
        bounds: domain,
        volumes,
        lights: vec![look::key_light(&domain)],
        phase: Phase::Isotropic,
    }
}

/// One rendered frame, for the run's manifest.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    /// Frame number.
    pub frame: usize,
    /// The sRGB preview.
    pub png: PathBuf,
    /// The linear EXR.
    pub exr: PathBuf,
    /// Render statistics.
    pub stats: RenderStats,
}
