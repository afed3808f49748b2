//! Slice previews: a mid-plane cut through density grids, on black.

use glam::Vec3;
use image::{Rgb, RgbImage};
use rayon::prelude::*;

use crate::domain::Domain;
use crate::field::ScalarField;
use crate::grid::ScalarGrid;

/// One gas in a preview: its grid and its colour (linear 0..1 per channel).
pub struct Layer<'a> {
    /// Density samples.
    pub grid: &'a ScalarGrid,
    /// Display colour.
    pub color: [f32; 3],
}

/// Hot gas red.
pub const RED: [f32; 3] = [1.0, 0.25, 0.1];
/// Cold gas blue.
pub const BLUE: [f32; 3] = [0.15, 0.35, 1.0];
/// Buoyant gas green (fig 6.6).
pub const GREEN: [f32; 3] = [0.2, 1.0, 0.3];
/// Obstacles in previews.
pub const GREY: [f32; 3] = [0.45, 0.45, 0.45];

/// The slice `z = nz/2` of the layers, x to the right and y up, each pixel
/// `Σ colour · (1 − exp(−gain ρ))`, upscaled by nearest neighbour so the
/// shorter side is at least `min_side` pixels.
///
/// # Panics
/// If `layers` is empty or the grids differ in shape.
pub fn mid_slice(layers: &[Layer], gain: f32, min_side: u32) -> RgbImage {
    let d = *layers[0].grid.domain();
    let [nx, ny, nz] = d.dims;
    let k = nz / 2;
    let scale = (min_side as usize).div_ceil(nx.min(ny)).max(1) as u32;
    RgbImage::from_fn(nx as u32 * scale, ny as u32 * scale, |px, py| {
        let i = (px / scale) as usize;
        let j = ny - 1 - (py / scale) as usize;
        let mut c = [0.0f32; 3];
        for l in layers {
            assert_eq!(
                l.grid.domain().dims,
                d.dims,
                "preview layers differ in shape"
            );
            let rho = l.grid.data()[[k, j, i]].max(0.0);
            let a = 1.0 - (-gain * rho).exp();
            for (ch, col) in c.iter_mut().zip(l.color) {
                *ch += col * a;
            }
        }
        Rgb(c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
    })
}

/// One field in a [`field_slice`]: the density and its display colour.
pub struct FieldLayer<'a> {
    /// Any density representation, queried at the pixel centres.
    pub field: &'a dyn ScalarField,
    /// Display colour.
    pub color: [f32; 3],
}

/// The plane `z = ` mid-box of the box of `domain`, sampled at `width`
/// pixels across x (square pixels, y up), each pixel
/// `Σ colour · (1 − exp(−gain ρ))`. Unlike [`mid_slice`] this queries the
/// fields themselves, so detail finer than any grid shows; each row of
/// pixels is one batched query, rows in parallel.
pub fn field_slice(layers: &[FieldLayer], domain: &Domain, width: u32, gain: f32) -> RgbImage {
    let size = domain.size();
    let px = size.x / width as f32;
    let height = ((size.y / px).round() as u32).max(1);
    let z = domain.origin.z + 0.5 * size.z;
    let mut rgb = vec![[0.0f32; 3]; (width * height) as usize];
    rgb.par_chunks_mut(width as usize)
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new()),
            |(points, values), (row, out)| {
                let y = domain.origin.y + size.y - (row as f32 + 0.5) * px;
                points.clear();
                points.extend(
                    (0..width).map(|i| Vec3::new(domain.origin.x + (i as f32 + 0.5) * px, y, z)),
                );
                values.resize(points.len(), 0.0);
                for l in layers {
                    l.field.eval_batch(points, values);
                    for (c, &rho) in out.iter_mut().zip(values.iter()) {
                        let a = 1.0 - (-gain * rho.max(0.0)).exp();
                        for (ch, col) in c.iter_mut().zip(l.color) {
                            *ch += col * a;
                        }
                    }
                }
            },
        );
    RgbImage::from_fn(width, height, |x, y| {
        Rgb(rgb[(y * width + x) as usize].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
    })
}

/// Images side by side with a `gap`-pixel dark separator.
///
/// # Panics
/// If `images` is empty.
pub fn side_by_side(images: &[RgbImage], gap: u32) -> RgbImage {
    let h = images.iter().map(|i| i.height()).max().expect("no images");
    let w: u32 = images.iter().map(|i| i.width()).sum::<u32>() + gap * (images.len() as u32 - 1);
    let mut out = RgbImage::from_pixel(w, h, Rgb([40, 40, 40]));
    let mut x0 = 0;
    for img in images {
        image::imageops::replace(&mut out, img, x0 as i64, 0);
        x0 += img.width() + gap;
    }
    out
}

/// Images one above another with a `gap`-pixel dark separator.
///
/// # Panics
/// If `images` is empty.
pub fn stacked(images: &[RgbImage], gap: u32) -> RgbImage {
    let w = images.iter().map(|i| i.width()).max().expect("no images");
    let h: u32 = images.iter().map(|i| i.height()).sum::<u32>() + gap * (images.len() as u32 - 1);
    let mut out = RgbImage::from_pixel(w, h, Rgb([40, 40, 40]));
    let mut y0 = 0;
    for img in images {
        image::imageops::replace(&mut out, img, 0, y0 as i64);
        y0 += img.height() + gap;
    }
    out
}
