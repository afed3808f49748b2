//! A small difference between two renders of the same scene, made visible:
//! the signed luma difference `D = Y_a − Y_b` (grey levels,
//! [`picture::luma`]) drawn amplified `K` times, and the crop window where
//! the difference is largest, so that a figure's zoomed crops look where
//! its panels differ rather than at a fixed middle.
//!
//! - **Image**: a pixel is black where `D = 0`, orange where `D > 0` and
//!   blue where `D < 0`, its brightness `min(1, K |D| / 255)`. `K` is the
//!   largest step of the 1–2–5 series (at most [`MAX_GAIN`]) that keeps the
//!   99th percentile of `|D|` within full brightness ([`gain`]); the figure
//!   states it in the row's label.
//! - **Crop**: the window of a given size whose coherent difference energy
//!   `Σ_window ½ (D(x,y) D(x+1,y) + D(x,y) D(x,y+1))` is largest — the
//!   lag-1 products of [`picture::error_spread`], summed over the window
//!   instead of the picture. A pattern (bands, sharpened edges) adds to it,
//!   independent per-pixel noise on average does not, so the crop goes to
//!   the structured difference, not to the grain.

use image::{Rgb, RgbImage};
use smokelab::metrics::picture;

/// The largest amplification [`gain`] chooses.
pub const MAX_GAIN: u32 = 100;

/// Colour of full-brightness positive and negative differences.
const POSITIVE: [f64; 3] = [255.0, 150.0, 30.0];
const NEGATIVE: [f64; 3] = [60.0, 140.0, 255.0];

/// The signed luma difference `Y_a − Y_b`, grey levels, rows top to bottom.
///
/// # Panics
/// If the two images differ in size (both are renders of one picture).
pub fn luma_difference(a: &RgbImage, b: &RgbImage) -> Vec<f64> {
    assert_eq!(a.dimensions(), b.dimensions(), "renders of different sizes");
    picture::luma(a)
        .iter()
        .zip(picture::luma(b))
        .map(|(x, y)| x - y)
        .collect()
}

/// The amplification `K` of the difference `d`: the largest of 1, 2, 5,
/// 10, 20, 50, 100 with `K · p99 ≤ 255`, `p99` the 99th percentile of
/// `|D|` (1 when even that is too bright; [`MAX_GAIN`] when all is 0).
pub fn gain(d: &[f64]) -> u32 {
    let mut all: Vec<f64> = d.iter().map(|v| v.abs()).collect();
    if all.is_empty() {
        return 1;
    }
    let i = (all.len() - 1) * 99 / 100;
    let p99 = *all.select_nth_unstable_by(i, f64::total_cmp).1;
    [1, 2, 5, 10, 20, 50, MAX_GAIN]
        .into_iter()
        .rev()
        .find(|&k| p99 <= 0.0 || f64::from(k) * p99 <= 255.0)
        .unwrap_or(1)
}

/// The difference `d` of a `width`-wide picture as an image amplified
/// `k` times (module doc).
pub fn image(d: &[f64], width: u32, k: u32) -> RgbImage {
    let height = d.len() as u32 / width.max(1);
    RgbImage::from_fn(width, height, |x, y| {
        let v = d[(y * width + x) as usize];
        let t = (f64::from(k) * v.abs() / 255.0).min(1.0);
        let c = if v >= 0.0 { POSITIVE } else { NEGATIVE };
        Rgb(c.map(|c| (c * t).round() as u8))
    })
}

/// Top-left corner of the `(cw, ch)` window of the `width`-wide difference
/// `d` with the largest coherent difference energy (module doc); the first
/// in reading order among equals. Windows larger than the picture are cut
/// to it.
pub fn busiest_window(d: &[f64], width: u32, (cw, ch): (u32, u32)) -> (u32, u32) {
    let (w, h) = (width as usize, d.len() / width.max(1) as usize);
    let (cw, ch) = ((cw as usize).min(w), (ch as usize).min(h));
    let at = |x: usize, y: usize| d[y * w + x];
    // Summed-area table of the per-pixel lag-1 products, one row and column
    // of zeros in front.
    let mut sat = vec![0.0; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            let right = if x + 1 < w { at(x + 1, y) } else { 0.0 };
            let down = if y + 1 < h { at(x, y + 1) } else { 0.0 };
            row += 0.5 * at(x, y) * (right + down);
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let sum = |x: usize, y: usize| {
        let s = |x, y| sat[y * (w + 1) + x];
        s(x + cw, y + ch) - s(x, y + ch) - s(x + cw, y) + s(x, y)
    };
    let mut best = (0, 0, f64::NEG_INFINITY);
    for y in 0..=h - ch {
        for x in 0..=w - cw {
            let e = sum(x, y);
            if e > best.2 {
                best = (x, y, e);
            }
        }
    }
    (best.0 as u32, best.1 as u32)
}

/// The `(cw, ch)` window of `img` at `(x0, y0)`, enlarged `factor` times by
/// repeating pixels (nearest neighbour, the picture's own pixels visible).
///
/// # Panics
/// If the window does not lie inside `img`.
pub fn zoom_window(
    img: &RgbImage,
    (x0, y0): (u32, u32),
    (cw, ch): (u32, u32),
    factor: u32,
) -> RgbImage {
    assert!(
        x0 + cw <= img.width() && y0 + ch <= img.height(),
        "crop window outside the picture"
    );
    RgbImage::from_fn(cw * factor, ch * factor, |x, y| {
        *img.get_pixel(x0 + x / factor, y0 + y / factor)
    })
}

/// Colour of the crop window's outline.
const OUTLINE: Rgb<u8> = Rgb([235, 235, 235]);

/// `img` with the `(cw, ch)` window at `(x0, y0)` outlined one pixel wide
/// just inside its edge, to show where a crop was taken.
pub fn outlined(img: &RgbImage, (x0, y0): (u32, u32), (cw, ch): (u32, u32)) -> RgbImage {
    let mut out = img.clone();
    let (x1, y1) = (x0 + cw.max(1) - 1, y0 + ch.max(1) - 1);
    for (x, y, p) in out.enumerate_pixels_mut() {
        let inside = (x0..=x1).contains(&x) && (y0..=y1).contains(&y);
        if inside && (x == x0 || x == x1 || y == y0 || y == y1) {
            *p = OUTLINE;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    #[test]
    fn the_crop_goes_to_structured_difference_not_to_stronger_noise() {
        // 80 × 60: bands of ±6 grey levels, 4 pixels wide, in a 20 × 15
        // patch whose corner is at (52, 38), off the middle; elsewhere
        // independent noise of ±10, stronger per pixel.
        let (w, h) = (80u32, 60u32);
        let mut rng = Pcg32::seed_from_u64(3);
        let d: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (52..72).contains(&x) && (38..53).contains(&y) {
                    if (x / 4) % 2 == 0 {
                        6.0
                    } else {
                        -6.0
                    }
                } else if rng.random::<bool>() {
                    10.0
                } else {
                    -10.0
                }
            })
            .collect();
        let (x0, y0) = busiest_window(&d, w, (20, 15));
        assert!(
            x0.abs_diff(52) <= 2 && y0.abs_diff(38) <= 2,
            "crop at ({x0}, {y0}), the bands at (52, 38)"
        );
        // (The squared difference, 36 a pixel in the bands against 100 in
        // the noise, would have put it anywhere but there.)
        // A window as large as the picture is the picture.
        assert_eq!(busiest_window(&d, w, (80, 60)), (0, 0));
        assert_eq!(busiest_window(&d, w, (500, 500)), (0, 0));
    }

    #[test]
    fn gain_keeps_the_99th_percentile_within_full_brightness() {
        // 1000 differences: 990 of 2 grey levels, 10 of 200 (outliers).
        let d: Vec<f64> = (0..1000)
            .map(|i| if i < 990 { 2.0 } else { -200.0 })
            .collect();
        // p99 = 2: 100 × 2 = 200 ≤ 255.
        assert_eq!(gain(&d), 100);
        let d3: Vec<f64> = d.iter().map(|v| v * 3.0).collect();
        // p99 = 6: 50 × 6 = 300 > 255, 20 × 6 = 120.
        assert_eq!(gain(&d3), 20);
        assert_eq!(gain(&[0.0; 10]), MAX_GAIN);
        assert_eq!(gain(&[300.0; 10]), 1);
    }

    #[test]
    fn the_image_is_signed_and_amplified() {
        let d = [0.0, 5.0, -5.0, 100.0];
        let img = image(&d, 2, 10);
        assert_eq!(*img.get_pixel(0, 0), Rgb([0, 0, 0]));
        // 10 × 5 / 255 of full orange, of full blue.
        let t = 50.0 / 255.0;
        assert_eq!(
            *img.get_pixel(1, 0),
            Rgb(POSITIVE.map(|c| (c * t).round() as u8))
        );
        assert_eq!(
            *img.get_pixel(0, 1),
            Rgb(NEGATIVE.map(|c| (c * t).round() as u8))
        );
        // Clipped at full brightness.
        assert_eq!(*img.get_pixel(1, 1), Rgb(POSITIVE.map(|c| c as u8)));
        let a = RgbImage::from_pixel(3, 2, Rgb([10, 10, 10]));
        let b = RgbImage::from_pixel(3, 2, Rgb([8, 8, 8]));
        assert!(luma_difference(&a, &b)
            .iter()
            .all(|v| (v - 2.0).abs() < 1e-9));
    }

    #[test]
    fn the_outline_marks_the_window_edge_only() {
        let img = RgbImage::from_pixel(10, 8, Rgb([1, 2, 3]));
        let o = outlined(&img, (2, 3), (4, 3));
        let marked: Vec<(u32, u32)> = o
            .enumerate_pixels()
            .filter(|(_, _, p)| **p == OUTLINE)
            .map(|(x, y, _)| (x, y))
            .collect();
        // A 4 × 3 rectangle's border: 2 × 4 + 2 × 1 pixels.
        assert_eq!(marked.len(), 10);
        assert!(marked.contains(&(2, 3)) && marked.contains(&(5, 5)));
        assert!(!marked.contains(&(3, 4)), "interior marked");
    }

    #[test]
    fn zoom_window_enlarges_the_window() {
        let img = RgbImage::from_fn(7, 6, |x, y| Rgb([x as u8, y as u8, 0]));
        let z = zoom_window(&img, (4, 1), (2, 3), 2);
        assert_eq!(z.dimensions(), (4, 6));
        assert_eq!(*z.get_pixel(0, 0), Rgb([4, 1, 0]));
        assert_eq!(*z.get_pixel(3, 5), Rgb([5, 3, 0]));
    }
}
