//! The camera ray march (eqs A.22–A.25 with the jittered sub-steps of A.29).
//!
//! Along each pixel ray, clipped to the render box, the march takes steps of
//! length `h` with the colour and density held constant over a step:
//!
//! ```text
//! ΔT = exp(−σ h),             σ = Σⱼ κⱼ ρⱼ(x)           (A.26)
//! L += T · (1 − ΔT)/σ · Σⱼ ρⱼ C^T_j(x)                   (A.24)
//! T *= ΔT                                                (A.25)
//! ```
//!
//! For one volume this is exactly the notes' `L += C^T T (1 − ΔT)/κ`; with
//! several volumes the extinctions add and each emits in proportion to its
//! density. The factor `(1 − ΔT)/σ` tends to `h` as `σh → 0` (the
//! optically-thin limit) and is evaluated in that form when `σh` is tiny.
//! `C^T = C^E + C^S ⊗ C^I` (A.3) with `C^I` from the light grids (A.7).
//!
//! Each step of `Δs` is split into `N_s` sub-steps sampled at their midpoint,
//! or, with jitter, at a uniformly random point inside each sub-step (the
//! stratified form of A.29). The random numbers come from a generator seeded
//! by the render seed and the *pixel index*, so an image is bit-identical for
//! any number of threads.
//!
//! Rays of one image row advance together: each round every live ray
//! contributes up to [`CHUNK`] sample points and every density is queried
//! once for the whole batch with `eval_batch`, which keeps expensive
//! (gridless) densities cheap per point. A ray retires when it leaves the box
//! or when `T < 10⁻⁴`.
//!
//! Empty space: when every volume has an [`Occupancy`], a sub-step whose
//! sample point lies where all of them are clear is not sampled — its
//! densities are `≤ 0`, so eqs A.24–A.25 would leave `L` and `T` as they
//! are. Its position and jitter are drawn exactly as without the bound
//! (same `t`, same random number), so the image is the same to the bit and
//! only the number of density queries changes; a ray keeps stepping until
//! it has [`CHUNK`] samples for the batch or leaves the box.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::camera::RayGen;
use super::lights::LitLight;
use super::phase::Phase;
use super::{ray_box, Volume};
use crate::density::occupancy::Occupancy;

/// Sample points each live ray contributes to one batch.
pub const CHUNK: usize = 16;

/// Transmittance below which a ray stops (its alpha is then > 0.9999).
pub const MIN_TRANSMITTANCE: f32 = 1e-4;

/// Scattering density `max(Σⱼ ρⱼ C^S_j)` below which a sample's in-scattered
/// light is not looked up: it would add less than 10⁻⁶ · C^I per unit path
/// length. Advected densities are tiny but non-zero almost everywhere, and
/// the light lookups are a third of the march's time.
pub const SCATTER_CUTOFF: f32 = 1e-6;

/// Everything a row march needs, shared by all threads.
pub struct Marcher<'a> {
    /// Pixel rays.
    pub rays: RayGen,
    /// Render box, lower corner.
    pub lo: Vec3,
    /// Render box, upper corner.
    pub hi: Vec3,
    /// The volumes.
    pub volumes: &'a [Volume],
    /// Lights with their transmissivity grids.
    pub lights: &'a [LitLight],
    /// Phase function.
    pub phase: Phase,
    /// Sub-step length `h = Δs / N_s`.
    pub substep: f32,
    /// Jitter sample positions inside each sub-step.
    pub jitter: bool,
    /// Render seed.
    pub seed: u64,
    /// Image width.
    pub width: u32,
    /// Skip sub-steps where all of these are clear (empty: no skipping).
    pub occupancy: &'a [&'a Occupancy],
}

/// Per-thread buffers, reused across rows.
#[derive(Default)]
pub struct RowScratch {
    rays: Vec<RayState>,
    points: Vec<Vec3>,
    owner: Vec<u32>,
    length: Vec<f32>,
    density: Vec<Vec<f32>>,
}

struct RayState {
    /// Column of the pixel.
    px: u32,
    dir: Vec3,
    /// Distance marched so far (start of the next sub-step).
    t: f32,
    t_end: f32,
    trans: f32,
    radiance: Vec3,
    rng: Pcg32,
}

impl RayState {
    fn finished(&self) -> bool {
        self.trans < MIN_TRANSMITTANCE || self.t >= self.t_end
    }
}

/// Counters of one row.
#[derive(Clone, Copy, Debug, Default)]
pub struct RowCounts {
    /// Rays that hit the box.
    pub rays: u64,
    /// Sample points at which the densities were queried.
    pub samples: u64,
    /// Sub-steps not sampled: every occupancy clear at their point.
    pub skipped: u64,
}

/// SplitMix64 finaliser: decorrelates consecutive pixel indices.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// `(1 − e^{−x})/x · h` for `x = σh ≥ 0`, stable as `x → 0`.
#[inline]
fn step_weight(sigma: f32, h: f32) -> f32 {
    let x = sigma * h;
    if x < 1e-3 {
        h * (1.0 - 0.5 * x + x * x / 6.0)
    } else {
        -(-x).exp_m1() / sigma
    }
}

impl Marcher<'_> {
    /// March the rays of row `py` and write premultiplied RGBA into `out`
    /// (`4 × width` floats).
    pub fn row(&self, py: u32, out: &mut [f32], s: &mut RowScratch) -> RowCounts {
        let origin = self.rays.origin();
        let mut counts = RowCounts::default();
        // Rays that miss the box stay transparent black.
        out.fill(0.0);
        s.rays.clear();
        for px in 0..self.width {
            let dir = self.rays.direction(px, py);
            if let Some((t0, t1)) = ray_box(origin, dir, self.lo, self.hi) {
                let t0 = t0.max(0.0);
                if t1 > t0 {
                    let pixel = py as u64 * self.width as u64 + px as u64;
                    s.rays.push(RayState {
                        px,
                        dir,
                        t: t0,
                        t_end: t1,
                        trans: 1.0,
                        radiance: Vec3::ZERO,
                        rng: Pcg32::seed_from_u64(mix(self.seed ^ mix(pixel))),
                    });
                }
            }
        }
        counts.rays = s.rays.len() as u64;
        s.density.resize_with(self.volumes.len(), Vec::new);
        // Sub-steps shorter than this at the exit face are dropped (round-off).
        let eps = 1e-6 * self.substep;
        while !s.rays.is_empty() {
            s.points.clear();
            s.owner.clear();
            s.length.clear();
            for (ri, r) in s.rays.iter_mut().enumerate() {
                let mut taken = 0;
                while taken < CHUNK {
                    let left = r.t_end - r.t;
                    if left <= eps {
                        r.t = r.t_end;
                        break;
                    }
                    let h = self.substep.min(left);
                    let u = if self.jitter {
                        r.rng.random::<f32>()
                    } else {
                        0.5
                    };
                    let x = origin + (r.t + u * h) * r.dir;
                    r.t += h;
                    if self.is_empty(x) {
                        counts.skipped += 1;
                        continue;
                    }
                    s.points.push(x);
                    s.owner.push(ri as u32);
                    s.length.push(h);
                    taken += 1;
                }
            }
            let n = s.points.len();
            counts.samples += n as u64;
            for (v, rho) in self.volumes.iter().zip(s.density.iter_mut()) {
                rho.resize(n, 0.0);
                v.density.eval_batch(&s.points, rho);
            }
            for i in 0..n {
                let r = &mut s.rays[s.owner[i] as usize];
                if r.trans < MIN_TRANSMITTANCE {
                    continue;
                }
                self.accumulate(r, s.points[i], s.length[i], &s.density, i);
            }
            s.rays.retain(|r| {
                if r.finished() {
                    let o = &mut out[4 * r.px as usize..4 * r.px as usize + 4];
                    o[..3].copy_from_slice(&r.radiance.to_array());
                    o[3] = 1.0 - r.trans;
                    false
                } else {
                    true
                }
            });
        }
        counts
    }

    /// Whether every volume is known to be `≤ 0` at `x`.
    #[inline]
    fn is_empty(&self, x: Vec3) -> bool {
        !self.occupancy.is_empty() && self.occupancy.iter().all(|o| !o.may_be_positive(x))
    }

    /// One sub-step of eqs A.24–A.25 at sample `x` of length `h`.
    #[inline]
    fn accumulate(&self, r: &mut RayState, x: Vec3, h: f32, density: &[Vec<f32>], i: usize) {
        let mut sigma = 0.0;
        let mut emit = Vec3::ZERO;
        let mut scatter = Vec3::ZERO;
        for (v, rho) in self.volumes.iter().zip(density) {
            let rho = rho[i].max(0.0);
            sigma += v.kappa * rho;
            emit += rho * v.emission;
            scatter += rho * v.scattering;
        }
        if sigma == 0.0 && emit == Vec3::ZERO && scatter == Vec3::ZERO {
            return;
        }
        // C^I, eq A.7.
        let mut color = emit;
        if scatter.max_element() >= SCATTER_CUTOFF {
            let mut incident = Vec3::ZERO;
            for l in self.lights {
                let to_light = (l.light.position - x).normalize_or_zero();
                let p = self.phase.relative(r.dir.dot(to_light));
                incident += l.transmissivity_at(x) * p * l.light.color;
            }
            color += scatter * incident;
        }
        let dt = (-sigma * h).exp();
        r.radiance += r.trans * step_weight(sigma, h) * color;
        r.trans *= dt;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_weight_is_continuous_at_the_switch() {
        let h = 0.1;
        let below = step_weight(0.999e-2, h);
        let above = step_weight(1.001e-2, h);
        assert!((below - above).abs() < 1e-7);
        assert_eq!(step_weight(0.0, h), h);
        // Opaque step: (1 − e^{−x})/σ → 1/σ.
        assert!((step_weight(1e4, h) - 1e-4).abs() < 1e-9);
    }
}
