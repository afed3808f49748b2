//! Pictures of planar flow: line integral convolution (Cabral & Leedom 1993)
//! coloured by speed.
//!
//! Each pixel averages a white-noise texture along the streamline through it,
//! traced both ways in the normalised in-plane velocity with a Hann window, so
//! the streaks follow the flow; the hue is the speed (viridis), normalised by
//! the 99th percentile of the picture. Discontinuities of the field show as
//! broken streaks and sharp colour edges.

use glam::{Vec2, Vec3};
use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

use crate::field::VectorField;

/// The in-plane velocity `(v_x, v_y)` of `field` on a `w × h` raster over the
/// rectangle `lo..hi` of the plane `z`, one sample per pixel centre; row 0 is
/// the top (largest y).
pub fn slice(field: &dyn VectorField, lo: Vec2, hi: Vec2, z: f32, w: usize, h: usize) -> Vec<Vec2> {
    let mut out = vec![Vec2::ZERO; w * h];
    let px = (hi - lo) / Vec2::new(w as f32, h as f32);
    out.par_chunks_mut(w).enumerate().for_each_init(
        || (vec![Vec3::ZERO; w], vec![Vec3::ZERO; w]),
        |(points, values), (row, line)| {
            let y = hi.y - (row as f32 + 0.5) * px.y;
            for (i, p) in points.iter_mut().enumerate() {
                *p = Vec3::new(lo.x + (i as f32 + 0.5) * px.x, y, z);
            }
            field.eval_batch(points, values);
            for (o, v) in line.iter_mut().zip(values.iter()) {
                *o = v.truncate();
            }
        },
    );
    out
}

/// Bilinear sample of a `w × h` raster at continuous pixel coordinates
/// (pixel centres at integers), clamped at the border.
fn bilinear<T>(data: &[T], w: usize, h: usize, p: Vec2) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    let x = p.x.clamp(0.0, (w - 1) as f32);
    let y = p.y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (tx, ty) = (x - x0 as f32, y - y0 as f32);
    let at = |i: usize, j: usize| data[j * w + i];
    (at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx) * (1.0 - ty)
        + (at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx) * ty
}

/// Line integral convolution of white noise along `vel` (a raster from
/// [`slice`], y up), streamlines `length` pixels each way. Returns intensities
/// with mean ½ and a fixed contrast.
pub fn lic(vel: &[Vec2], w: usize, h: usize, length: f32, seed: u64) -> Vec<f32> {
    assert_eq!(vel.len(), w * h, "lic: raster size");
    let mut rng = Pcg64::seed_from_u64(seed);
    let noise: Vec<f32> = (0..w * h).map(|_| rng.random::<f32>()).collect();
    // Direction in pixel coordinates (row index grows downwards).
    let dir: Vec<Vec2> = vel
        .iter()
        .map(|v| Vec2::new(v.x, -v.y).normalize_or_zero())
        .collect();
    let ds = 0.5;
    let steps = (length / ds).ceil() as usize;
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(j, line)| {
        for (i, o) in line.iter_mut().enumerate() {
            let start = Vec2::new(i as f32, j as f32);
            let mut acc = noise[j * w + i];
            let mut weight = 1.0;
            for sign in [1.0f32, -1.0] {
                let mut p = start;
                for s in 1..=steps {
                    // Midpoint rule on the normalised direction field.
                    let d0 = bilinear(&dir, w, h, p) * sign;
                    let d1 = bilinear(&dir, w, h, p + d0 * (0.5 * ds)) * sign;
                    if d1 == Vec2::ZERO {
                        break;
                    }
                    p += d1.normalize() * ds;
                    if p.x < 0.0 || p.y < 0.0 || p.x > (w - 1) as f32 || p.y > (h - 1) as f32 {
                        break;
                    }
                    let hann =
                        0.5 + 0.5 * (std::f32::consts::PI * s as f32 / (steps + 1) as f32).cos();
                    acc += hann * bilinear(&noise, w, h, p);
                    weight += hann;
                }
            }
            *o = acc / weight;
        }
    });
    // Averaging shrinks the noise's spread; restore a fixed contrast.
    let n = out.len() as f64;
    let mean = out.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = out.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n;
    let k = 0.2 / var.sqrt().max(1e-9);
    out.iter_mut()
        .for_each(|v| *v = (0.5 + (*v as f64 - mean) * k).clamp(0.0, 1.0) as f32);
    out
}

/// The viridis colour map at `t ∈ [0, 1]`.
pub fn viridis(t: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    std::array::from_fn(|c| (STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f) / 255.0)
}

/// The 99th percentile of the speeds of a raster (0 if all vanish).
pub fn speed_scale(vel: &[Vec2]) -> f32 {
    let mut s: Vec<f32> = vel.iter().map(|v| v.length()).collect();
    let k = ((s.len() as f32 * 0.99) as usize).min(s.len().saturating_sub(1));
    s.select_nth_unstable_by(k, f32::total_cmp);
    s[k]
}

/// LIC streaks on the speed colour: `viridis(|v|/scale) · (0.35 + 1.3 · lic)`.
pub fn render(vel: &[Vec2], w: usize, h: usize, length: f32, seed: u64) -> RgbImage {
    let streaks = lic(vel, w, h, length, seed);
    let scale = speed_scale(vel).max(f32::MIN_POSITIVE);
    RgbImage::from_fn(w as u32, h as u32, |x, y| {
        let i = y as usize * w + x as usize;
        let c = viridis(vel[i].length() / scale);
        let k = 0.35 + 1.3 * streaks[i];
        Rgb(c.map(|v| ((v * k).clamp(0.0, 1.0) * 255.0).round() as u8))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    /// Uniform flow along x: streaks run along rows, so neighbours along a row
    /// are far more alike than neighbours along a column.
    #[test]
    fn streaks_follow_the_flow() {
        let (w, h) = (64, 64);
        let vel = slice(
            &*ops::constant_vector(Vec3::X),
            Vec2::ZERO,
            Vec2::ONE,
            0.0,
            w,
            h,
        );
        let img = lic(&vel, w, h, 10.0, 1);
        let diff = |dx: usize, dy: usize| {
            let mut s = 0.0;
            for j in 16..48 {
                for i in 16..48 {
                    s += (img[j * w + i] - img[(j + dy) * w + i + dx]).abs();
                }
            }
            s
        };
        assert!(
            diff(1, 0) < 0.3 * diff(0, 1),
            "{} vs {}",
            diff(1, 0),
            diff(0, 1)
        );
    }

    #[test]
    fn slice_rows_run_top_down() {
        let vel = slice(
            &*ops::identity(),
            Vec2::ZERO,
            Vec2::new(4.0, 2.0),
            0.0,
            4,
            2,
        );
        assert_eq!(vel[0], Vec2::new(0.5, 1.5));
        assert_eq!(vel[7], Vec2::new(3.5, 0.5));
    }
}
