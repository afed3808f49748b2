//! Writing renders: OpenEXR for compositing, sRGB PNG for looking.
//!
//! The EXR holds the march's output as is: linear RGB radiance, already
//! premultiplied by coverage (a ray that stops early has accumulated only
//! what it saw), and alpha `1 − T` — ready to composite *over* a plate. The
//! PNG preview composites it over a flat background, applies an exposure
//! and encodes sRGB.

use std::path::Path;

use anyhow::Result;
use exr::prelude::{f16, Image as ExrImage, SpecificChannels, Vec2, WritableImage};
use image::{Rgb, RgbImage};
use serde::Serialize;

use super::Image;
use crate::io::write_atomic;

/// Sample precision of EXR channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ExrPrecision {
    /// 16-bit half floats (the usual choice for beauty renders).
    #[default]
    Half,
    /// 32-bit floats.
    F32,
}

impl ExrPrecision {
    /// Every precision.
    pub const ALL: [ExrPrecision; 2] = [ExrPrecision::Half, ExrPrecision::F32];
}

/// Write `img` as an RGBA OpenEXR file (linear, premultiplied), atomically.
pub fn write_exr(path: &Path, img: &Image, precision: ExrPrecision) -> Result<()> {
    let (w, h) = (img.width as usize, img.height as usize);
    let px = |x: usize, y: usize| {
        let o = 4 * (y * w + x);
        let p = &img.rgba[o..o + 4];
        (p[0], p[1], p[2], p[3])
    };
    write_atomic(path, |out| {
        match precision {
            ExrPrecision::F32 => {
                let channels = SpecificChannels::rgba(|Vec2(x, y)| px(x, y));
                ExrImage::from_channels((w, h), channels)
                    .write()
                    .to_buffered(out)?;
            }
            ExrPrecision::Half => {
                let channels = SpecificChannels::rgba(|Vec2(x, y)| {
                    let (r, g, b, a) = px(x, y);
                    (
                        f16::from_f32(r),
                        f16::from_f32(g),
                        f16::from_f32(b),
                        f16::from_f32(a),
                    )
                });
                ExrImage::from_channels((w, h), channels)
                    .write()
                    .to_buffered(out)?;
            }
        }
        Ok(())
    })
}

/// How a preview turns linear radiance into display pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Display {
    /// Multiplier on the radiance before encoding.
    pub exposure: f32,
    /// Linear background colour shown where alpha < 1.
    pub background: [f32; 3],
}

impl Default for Display {
    /// Exposure 1 over a dark blue-grey (sRGB ≈ 22, 23, 28).
    fn default() -> Self {
        Self {
            exposure: 1.0,
            background: [0.008, 0.009, 0.012],
        }
    }
}

/// The sRGB transfer function of a linear value in `[0, 1]`.
#[inline]
pub fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB preview: `exposure · rgb + (1 − α) · background`, clipped to 1.
pub fn preview(img: &Image, display: &Display) -> RgbImage {
    RgbImage::from_fn(img.width, img.height, |x, y| {
        let [r, g, b, a] = img.pixel(x, y);
        let bg = display.background;
        let encode = |v: f32, b: f32| {
            (srgb_encode(display.exposure * v + (1.0 - a) * b) * 255.0).round() as u8
        };
        let out = [encode(r, bg[0]), encode(g, bg[1]), encode(b, bg[2])];
        Rgb(out)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> Image {
        Image {
            width: 2,
            height: 1,
            rgba: vec![0.25, 0.5, 1.0, 0.75, 0.0, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn srgb_matches_reference_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
        assert_eq!(srgb_encode(2.0), srgb_encode(1.0));
    }

    #[test]
    fn preview_shows_background_where_empty() {
        let d = Display {
            exposure: 1.0,
            background: [1.0, 0.0, 0.0],
        };
        let p = preview(&tiny(), &d);
        assert_eq!(p.get_pixel(1, 0).0, [255, 0, 0]);
        // 0.25 + 0.25·1 = 0.5 linear → sRGB 188.
        assert_eq!(p.get_pixel(0, 0).0[0], 188);
    }

    #[test]
    fn exr_round_trips_in_both_precisions() {
        let dir = tempfile::tempdir().unwrap();
        for (prec, tol) in [(ExrPrecision::F32, 0.0), (ExrPrecision::Half, 1e-3)] {
            let path = dir.path().join("t.exr");
            write_exr(&path, &tiny(), prec).unwrap();
            let back = exr::prelude::read_first_rgba_layer_from_file(
                &path,
                |res, _| vec![[0.0f32; 4]; res.width() * res.height()],
                |buf, pos, (r, g, b, a): (f32, f32, f32, f32)| {
                    buf[pos.y() * 2 + pos.x()] = [r, g, b, a]
                },
            )
            .unwrap();
            let px = &back.layer_data.channel_data.pixels;
            for (got, want) in px.iter().flatten().zip(&tiny().rgba) {
                assert!((got - want).abs() <= tol, "{prec:?}: {got} vs {want}");
            }
        }
    }
}
