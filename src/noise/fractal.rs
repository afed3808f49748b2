//! Fractal sums of any noise (`000_…` §4–5, fig 3; the notes' eq 3.5 layers).
//!
//! ```text
//! F(p) = Σ_{o=0}^{octaves−1} gain^o · N_o(lacunarity^o · p + δ_o)
//! ```
//!
//! Each octave `N_o` is a fresh basis noise with its own seed (drawn from the
//! sum's seed with PCG), and octaves after the first are shifted by a random
//! `δ_o ∈ [0, 1)³` lattice units so their lattices do not share an origin.
//! A sum of divergence-free fields, each composed with a uniform scaling and a
//! shift, is divergence-free, so the sum keeps its basis's guarantee.
//!
//! `000_…` parameterises octave amplitudes by a fractal *dimension* (fig 3:
//! "dimension 0.2, lacunarity 1.77, 3 octaves"); we read it as Musgrave's
//! spectral exponent H (*Texturing & Modeling*, `fBm(p, H, lacunarity,
//! octaves)`), `gain = lacunarity^{−H}` ([`Fractal::from_dimension`]).
//! Small dimensions keep high octaves strong; an irregular lacunarity such
//! as 1.77 keeps the smooth simulation noise's dead spots of different octaves
//! apart (§4).

use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::error::InputError;
use crate::field::{Vector, VectorField};

/// Octave count, frequency ratio and amplitude ratio of a fractal sum.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Fractal {
    /// Number of octaves (1 = the basis alone).
    pub octaves: usize,
    /// Frequency ratio between consecutive octaves.
    pub lacunarity: f32,
    /// Amplitude ratio between consecutive octaves.
    pub gain: f32,
}

impl Default for Fractal {
    fn default() -> Self {
        Self {
            octaves: 1,
            lacunarity: 2.0,
            gain: 0.5,
        }
    }
}

impl Fractal {
    /// Most octaves accepted.
    pub const MAX_OCTAVES: usize = 16;

    /// A sum with `gain = lacunarity^{−dimension}` (module docs).
    pub fn from_dimension(octaves: usize, lacunarity: f32, dimension: f32) -> Self {
        Self {
            octaves,
            lacunarity,
            gain: lacunarity.powf(-dimension),
        }
    }

    /// Largest ratio between the last and the first octave's frequency.
    pub const MAX_FREQUENCY_RATIO: f64 = 1e5;

    /// Check the parameters, naming the bad value.
    pub fn validate(&self) -> Result<(), InputError> {
        if !(1..=Self::MAX_OCTAVES).contains(&self.octaves) {
            return Err(InputError::new(format!(
                "octaves is {}; it must be in 1..={}",
                self.octaves,
                Self::MAX_OCTAVES
            )));
        }
        if !(self.lacunarity.is_finite() && self.lacunarity > 1.0) {
            return Err(InputError::new(format!(
                "lacunarity is {}; it must be a finite number greater than 1",
                self.lacunarity
            )));
        }
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(InputError::new(format!(
                "gain is {}; it must be a positive finite number",
                self.gain
            )));
        }
        // The last octave's frequency and amplitude must stay well inside f32:
        // lattice coordinates lose their fraction past 2^23.
        let last = (self.octaves - 1) as f64;
        let frequency = (self.lacunarity as f64).powf(last);
        let amplitude = (self.gain as f64).powf(last);
        if !(frequency <= Self::MAX_FREQUENCY_RATIO
            && amplitude.is_finite()
            && amplitude as f32 > 0.0
            && amplitude <= f32::MAX as f64)
        {
            return Err(InputError::new(format!(
                "octaves {}, lacunarity {} and gain {} give a last octave of frequency ×{frequency:.3e} and amplitude ×{amplitude:.3e}; the frequency ratio must be at most {:.0e} and the amplitude a finite, non-zero f32: use fewer octaves or a smaller lacunarity",
                self.octaves,
                self.lacunarity,
                self.gain,
                Self::MAX_FREQUENCY_RATIO
            )));
        }
        Ok(())
    }

    /// The sum over octaves of `basis(octave_seed)`; with one octave, the
    /// basis itself, seeded with `seed`.
    pub fn build(
        &self,
        seed: u64,
        mut basis: impl FnMut(u64) -> Result<Vector, InputError>,
    ) -> Result<Vector, InputError> {
        self.validate()?;
        if self.octaves == 1 {
            return basis(seed);
        }
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut octaves = Vec::with_capacity(self.octaves);
        for o in 0..self.octaves {
            let octave_seed = if o == 0 { seed } else { rng.random() };
            let offset = if o == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(rng.random(), rng.random(), rng.random())
            };
            octaves.push(Octave {
                field: basis(octave_seed)?,
                frequency: self.lacunarity.powi(o as i32),
                amplitude: self.gain.powi(o as i32),
                offset,
            });
        }
        Ok(Arc::new(FractalSum { octaves }))
    }
}

struct Octave {
    field: Vector,
    frequency: f32,
    amplitude: f32,
    offset: Vec3,
}

/// `Σ a_o N_o(f_o p + δ_o)`.
pub struct FractalSum {
    octaves: Vec<Octave>,
}

impl VectorField for FractalSum {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.octaves
            .iter()
            .map(|o| o.amplitude * o.field.eval(o.frequency * p + o.offset))
            .sum()
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        out.fill(Vec3::ZERO);
        let mut mapped = vec![Vec3::ZERO; points.len()];
        let mut values = vec![Vec3::ZERO; points.len()];
        for o in &self.octaves {
            for (m, &p) in mapped.iter_mut().zip(points) {
                *m = o.frequency * p + o.offset;
            }
            o.field.eval_batch(&mapped, &mut values);
            for (acc, &v) in out.iter_mut().zip(&values) {
                *acc += o.amplitude * v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::lattice::{keys, StaticCorners};
    use crate::noise::value::ValueNoise;

    fn value(seed: u64) -> Result<Vector, InputError> {
        Ok(Arc::new(ValueNoise::new(StaticCorners::new(
            keys::<1>(seed)[0],
        ))))
    }

    /// Octaves, lacunarity or gain whose last octave overflows f32 used to
    /// write all-NaN volumes and exit 0.
    #[test]
    fn octaves_that_overflow_are_refused() {
        let bad = |octaves, lacunarity, gain| {
            let f = Fractal {
                octaves,
                lacunarity,
                gain,
            };
            f.validate().unwrap_err().to_string()
        };
        assert!(bad(Fractal::MAX_OCTAVES, 1e4, 0.5).contains("frequency"));
        assert!(bad(Fractal::MAX_OCTAVES, 2.0, 1e-30).contains("amplitude"));
        assert!(bad(Fractal::MAX_OCTAVES, 2.0, 1e30).contains("amplitude"));
        let fine = Fractal {
            octaves: 8,
            lacunarity: 2.0,
            gain: 0.5,
        };
        assert!(fine.validate().is_ok());
    }

    #[test]
    fn one_octave_is_the_basis_and_batches_match() {
        let p = Vec3::new(0.3, 1.7, -2.2);
        let one = Fractal {
            octaves: 1,
            ..Default::default()
        }
        .build(3, value)
        .unwrap();
        assert_eq!(one.eval(p), value(3).unwrap().eval(p));
        let sum = Fractal::from_dimension(3, 1.77, 0.2)
            .build(3, value)
            .unwrap();
        let points: Vec<Vec3> = (0..20).map(|i| p + Vec3::splat(i as f32 * 0.13)).collect();
        let mut out = vec![Vec3::ZERO; points.len()];
        sum.eval_batch(&points, &mut out);
        for (q, o) in points.iter().zip(&out) {
            assert!((sum.eval(*q) - *o).length() < 1e-6);
        }
    }

    #[test]
    fn gain_from_dimension() {
        let f = Fractal::from_dimension(3, 1.77, 0.2);
        assert!((f.gain - 1.77f32.powf(-0.2)).abs() < 1e-7);
        assert!((f.gain - 0.8921).abs() < 1e-3);
    }

    #[test]
    fn rejects_bad_parameters() {
        for f in [
            Fractal {
                octaves: 0,
                ..Default::default()
            },
            Fractal {
                octaves: 17,
                ..Default::default()
            },
            Fractal {
                lacunarity: 1.0,
                ..Default::default()
            },
            Fractal {
                lacunarity: f32::INFINITY,
                ..Default::default()
            },
            Fractal {
                gain: 0.0,
                ..Default::default()
            },
        ] {
            assert!(f.validate().is_err(), "{f:?} accepted");
        }
    }
}
