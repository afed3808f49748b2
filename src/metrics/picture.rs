//! Measures of a picture as it is shown (the 8-bit sRGB preview of a
//! render): how sharp it is, and how its error against a reference picture
//! is spread — coherent across neighbouring pixels (a pattern: banding,
//! stair-steps, a bias) or independent from pixel to pixel (noise).
//!
//! Both work on the luma `Y = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709
//! weights of the sRGB primaries) in grey levels 0–255.
//!
//! - **Sharpness** is the gradient energy, the mean squared finite
//!   difference of `Y` between neighbouring pixels, across and down:
//!   `G = mean (Y(x+1,y) − Y(x,y))² + mean (Y(x,y+1) − Y(x,y))²`. Softening
//!   an edge over `w` pixels spreads its step `ΔY` over `w` differences of
//!   `ΔY/w`, so its energy falls as `1/w`: the §7.3 gradient argument
//!   (eqs 7.5–7.7) seen in the picture.
//! - **Error spread** of `E = Y − Y_ref`: its mean square `⟨E²⟩` and its
//!   lag-1 autocovariance `C₁ = ½ (⟨E(x,y) E(x+1,y)⟩ + ⟨E(x,y) E(x,y+1)⟩)`.
//!   Noise drawn independently per pixel (a jittered march, eq A.29) has
//!   `C₁ → 0`; a pattern that varies slowly from pixel to pixel (the bands
//!   of a fixed-step march through detail finer than the step) has
//!   `C₁ ≈ ⟨E²⟩`. So `√max(C₁, 0)` is the rms of the error's coherent part,
//!   and `C₁ / ⟨E²⟩` the share of its energy that is coherent.

use image::RgbImage;

use crate::error::InputError;

/// Luma of every pixel of `img` in grey levels, rows top to bottom.
pub fn luma(img: &RgbImage) -> Vec<f64> {
    img.pixels()
        .map(|p| {
            let [r, g, b] = p.0.map(f64::from);
            0.2126 * r + 0.7152 * g + 0.0722 * b
        })
        .collect()
}

/// Mean over the neighbouring pairs `(a, b)` of `y` (width `w`, rows top to
/// bottom) of `f(a, b)`, across and down separately, added.
fn neighbour_means(y: &[f64], w: usize, f: impl Fn(f64, f64) -> f64) -> f64 {
    let h = y.len() / w;
    let mean = |sum: f64, n: usize| if n == 0 { 0.0 } else { sum / n as f64 };
    let across: f64 = y
        .chunks_exact(w)
        .flat_map(|r| r.windows(2))
        .map(|p| f(p[0], p[1]))
        .sum();
    let down: f64 = y
        .chunks_exact(w)
        .zip(y.chunks_exact(w).skip(1))
        .flat_map(|(a, b)| a.iter().zip(b))
        .map(|(&a, &b)| f(a, b))
        .sum();
    mean(across, (w - 1) * h) + mean(down, w * h.saturating_sub(1))
}

/// Gradient energy `G` of `img` (grey levels² per pixel; module doc).
pub fn gradient_energy(img: &RgbImage) -> f64 {
    let w = img.width() as usize;
    if w == 0 {
        return 0.0;
    }
    neighbour_means(&luma(img), w, |a, b| (b - a) * (b - a))
}

/// How the error of a picture against a reference is spread (module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorSpread {
    /// `√⟨E²⟩`, grey levels.
    pub rms: f64,
    /// `√max(C₁, 0)`: rms of the part coherent between neighbours.
    pub coherent: f64,
    /// `C₁ / ⟨E²⟩` (0 when there is no error).
    pub coherent_share: f64,
}

/// The spread of the error of `img` against `reference` (module doc).
///
/// # Errors
/// If the two pictures differ in size or are smaller than 2 × 2 pixels.
pub fn error_spread(img: &RgbImage, reference: &RgbImage) -> Result<ErrorSpread, InputError> {
    if img.dimensions() != reference.dimensions() || img.width() < 2 || img.height() < 2 {
        return Err(InputError::new(format!(
            "error spread: a {:?} picture against a {:?} reference; both must be the same size, at least 2 × 2",
            img.dimensions(),
            reference.dimensions()
        )));
    }
    let e: Vec<f64> = luma(img)
        .iter()
        .zip(luma(reference))
        .map(|(a, b)| a - b)
        .collect();
    let square = e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64;
    let c1 = 0.5 * neighbour_means(&e, img.width() as usize, |a, b| a * b);
    Ok(ErrorSpread {
        rms: square.sqrt(),
        coherent: c1.max(0.0).sqrt(),
        coherent_share: if square > 0.0 { c1 / square } else { 0.0 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    fn grey(w: u32, h: u32, mut f: impl FnMut(u32, u32) -> u8) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            let v = f(x, y);
            Rgb([v, v, v])
        })
    }

    #[test]
    fn gradient_energy_of_a_step_falls_as_its_width_grows() {
        // A step of 120 grey levels across 64 columns, sharp or as a ramp
        // over 4 pixels: per row 1 × 120² or 4 × 30², over 63 pairs.
        let sharp = grey(64, 8, |x, _| if x < 32 { 0 } else { 120 });
        let ramp = grey(64, 8, |x, _| (30 * (x as i32 - 30).clamp(0, 4)) as u8);
        let g = gradient_energy(&sharp);
        assert!((g - 120.0 * 120.0 / 63.0).abs() < 1e-9, "{g}");
        assert!((gradient_energy(&ramp) - g / 4.0).abs() < 1e-9);
        assert_eq!(gradient_energy(&grey(5, 5, |_, _| 77)), 0.0);
    }

    #[test]
    fn bands_are_coherent_and_independent_noise_is_not() {
        let reference = grey(200, 150, |_, _| 100);
        // Bands 8 pixels wide: each pair across a band edge differs.
        let bands = grey(200, 150, |x, _| if (x / 8) % 2 == 0 { 110 } else { 90 });
        let s = error_spread(&bands, &reference).unwrap();
        assert!((s.rms - 10.0).abs() < 1e-9);
        // Across: 7 of 8 pairs agree (+100), 1 differs (−100); down: all +100.
        let across = (100.0 * (199.0 - 2.0 * 24.0)) / 199.0;
        assert!((s.coherent_share - 0.5 * (across + 100.0) / 100.0).abs() < 1e-9);
        // Independent per-pixel noise of the same rms.
        let mut rng = Pcg32::seed_from_u64(7);
        let noise = grey(200, 150, |_, _| if rng.random::<bool>() { 110 } else { 90 });
        let n = error_spread(&noise, &reference).unwrap();
        assert!((n.rms - 10.0).abs() < 1e-9);
        assert!(n.coherent_share.abs() < 0.02, "{n:?}");
        assert!(error_spread(&noise, &grey(10, 10, |_, _| 0)).is_err());
    }
}
