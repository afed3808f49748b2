//! Phase functions P(n·nᴸ): how a scatterer redistributes light over
//! directions (appendix A, eqs A.4, A.8–A.12).
//!
//! Every phase function here is normalised per steradian,
//! `∫ P dΩ = 2π ∫₋₁¹ P(c) dc = 1`. The argument is the cosine of the angle
//! between the view ray `n` (camera → sample) and `nᴸ` (sample → light,
//! eq A.6), so `cos θ = 1` is forward scattering: looking into the light.
//! The renderer multiplies by 4π (see [`Phase::relative`]) so that the
//! isotropic function is exactly the notes' `P = 1` choice.

use std::f64::consts::PI;

use serde::Serialize;

use crate::error::InputError;

/// A phase function, chosen per render.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Phase {
    /// `P = 1/(4π)`.
    Isotropic,
    /// Henyey–Greenstein (eq A.8) with asymmetry `g ∈ (−1, 1)`.
    HenyeyGreenstein {
        /// Mean cosine of the scattering angle.
        g: f32,
    },
    /// Fournier–Forand (eqs A.9–A.12): real refractive index `n > 1` of the
    /// particles relative to the medium and slope `μ ∈ (3, 5]` of their
    /// Junge size distribution.
    FournierForand {
        /// Relative refractive index.
        n: f32,
        /// Junge slope.
        mu: f32,
    },
}

/// Smallest `sin²(θ/2)` used by Fournier–Forand: the function has an
/// integrable singularity at θ = 0, and a render may look straight into a light.
const FF_MIN_SIN2: f64 = 1e-12;

impl Phase {
    /// Henyey–Greenstein with asymmetry `g`; fails unless `−1 < g < 1`.
    pub fn henyey_greenstein(g: f32) -> Result<Self, InputError> {
        if !(g.is_finite() && g.abs() < 1.0) {
            return Err(InputError::new(format!(
                "Henyey–Greenstein g is {g}; it must lie strictly between -1 and 1"
            )));
        }
        Ok(Phase::HenyeyGreenstein { g })
    }

    /// Fournier–Forand; fails unless `n > 1` and `3 < μ ≤ 5`.
    ///
    /// With `μ ≤ 3` the exponent `ν = (3 − μ)/2` of eq A.12 is ≥ 0 and eq A.9
    /// is negative at every angle (the notes' caption of fig A.2 prints
    /// μ = 0.35…0.5, which is in that range; the curves it shows are
    /// μ = 3.5…5, see experiment A-2).
    pub fn fournier_forand(n: f32, mu: f32) -> Result<Self, InputError> {
        if !(n.is_finite() && n > 1.0) {
            return Err(InputError::new(format!(
                "Fournier–Forand refractive index n is {n}; it must be greater than 1"
            )));
        }
        if !(mu.is_finite() && mu > 3.0 && mu <= 5.0) {
            return Err(InputError::new(format!(
                "Fournier–Forand slope mu is {mu}; it must satisfy 3 < mu <= 5"
            )));
        }
        Ok(Phase::FournierForand { n, mu })
    }

    /// Parse `iso`, `hg:G` or `ff:N:MU` (command-line form).
    pub fn parse(s: &str) -> Result<Self, InputError> {
        let parts: Vec<&str> = s.split(':').collect();
        let num = |t: &str| {
            t.trim()
                .parse::<f32>()
                .map_err(|_| InputError::new(format!("phase '{s}': '{t}' is not a number")))
        };
        match parts.as_slice() {
            ["iso"] | ["isotropic"] => Ok(Phase::Isotropic),
            ["hg", g] => Self::henyey_greenstein(num(g)?),
            ["ff", n, mu] => Self::fournier_forand(num(n)?, num(mu)?),
            _ => Err(InputError::new(format!(
                "phase '{s}' is not valid; use iso, hg:G (e.g. hg:0.5) or ff:N:MU (e.g. ff:1.05:3.5)"
            ))),
        }
    }

    /// `P(cos θ)` per steradian, in f64 (for plots and quadrature).
    pub fn eval_f64(&self, cos_theta: f64) -> f64 {
        let c = cos_theta.clamp(-1.0, 1.0);
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => {
                // Eq A.8.
                let g = g as f64;
                (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
            }
            Phase::FournierForand { n, mu } => {
                let s2 = ((1.0 - c) / 2.0).max(FF_MIN_SIN2);
                ff_terms(n as f64, mu as f64, s2, c)
            }
        }
    }

    /// `P` at scattering angle `θ` (radians) per steradian, in f64. Unlike
    /// [`Phase::eval_f64`] this keeps full precision for tiny angles, where
    /// `1 − cos θ` rounds away: Fournier–Forand's forward peak is only
    /// integrable, and the cone θ < 10⁻⁶ still holds ~0.1 % of its weight.
    pub fn eval_angle_f64(&self, theta: f64) -> f64 {
        match *self {
            Phase::FournierForand { n, mu } => fournier_forand(n as f64, mu as f64, theta),
            _ => self.eval_f64(theta.cos()),
        }
    }

    /// `P(cos θ)` per steradian.
    #[inline]
    pub fn eval(&self, cos_theta: f32) -> f32 {
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * std::f32::consts::PI),
            Phase::HenyeyGreenstein { g } => {
                let c = cos_theta.clamp(-1.0, 1.0);
                let d = 1.0 + g * g - 2.0 * g * c;
                (1.0 - g * g) / (4.0 * std::f32::consts::PI * d * d.sqrt())
            }
            Phase::FournierForand { .. } => self.eval_f64(cos_theta as f64) as f32,
        }
    }

    /// `∫ P dΩ = 2π ∫₀^π P(θ) sin θ dθ`, by the midpoint rule in `t = √θ`
    /// with `steps` intervals (the substitution makes Fournier–Forand's
    /// forward singularity bounded). Should be 1.
    pub fn sphere_integral(&self, steps: usize) -> f64 {
        let h = PI.sqrt() / steps as f64;
        (0..steps)
            .map(|i| {
                let t = (i as f64 + 0.5) * h;
                let th = t * t;
                2.0 * PI * self.eval_angle_f64(th) * th.sin() * 2.0 * t
            })
            .sum::<f64>()
            * h
    }

    /// `4π P(cos θ)`: 1 for the isotropic function, the notes' `P = 1`.
    #[inline]
    pub fn relative(&self, cos_theta: f32) -> f32 {
        4.0 * std::f32::consts::PI * self.eval(cos_theta)
    }
}

/// The Fournier–Forand formula (eqs A.9–A.12) at angle `θ` for any `n`,
/// `μ`, without the range checks of [`Phase::fournier_forand`] — experiment
/// A-2 uses it to show what the caption's literal μ values give.
pub fn fournier_forand(n: f64, mu: f64, theta: f64) -> f64 {
    let s = (0.5 * theta).sin();
    ff_terms(n, mu, s * s, theta.cos())
}

/// Eqs A.9–A.12 at `s2 = sin²(θ/2)`, `c = cos θ`.
fn ff_terms(n: f64, mu: f64, s2: f64, c: f64) -> f64 {
    let nu = (3.0 - mu) / 2.0; // A.12
    let d180 = 4.0 / (3.0 * (n - 1.0) * (n - 1.0)); // A.11
    let d = d180 * s2; // A.10
    let dn = d.powf(nu);
    let main = (nu * (1.0 - d) - (1.0 - dn) + (d * (1.0 - dn) - nu * (1.0 - d)) / s2)
        / (4.0 * PI * (1.0 - d) * (1.0 - d) * dn);
    let d180n = d180.powf(nu);
    let back = (1.0 - d180n) / (16.0 * PI * (d180 - 1.0) * d180n) * (3.0 * c * c - 1.0);
    main + back
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_phase_function_integrates_to_one() {
        let mut all = vec![Phase::Isotropic];
        for g in [-0.99, -0.5, 0.0, 0.5, 0.9, 0.99] {
            all.push(Phase::henyey_greenstein(g).unwrap());
        }
        for mu in [3.5, 4.0, 4.5, 5.0] {
            all.push(Phase::fournier_forand(1.05, mu).unwrap());
            all.push(Phase::fournier_forand(1.15, mu).unwrap());
        }
        for p in all {
            let i = p.sphere_integral(20_000);
            assert!((i - 1.0).abs() < 1e-3, "{p:?} integrates to {i}");
        }
    }

    #[test]
    fn henyey_greenstein_zero_is_isotropic() {
        let hg = Phase::henyey_greenstein(0.0).unwrap();
        for c in [-1.0, -0.3, 0.0, 0.7, 1.0] {
            assert_eq!(hg.eval_f64(c), Phase::Isotropic.eval_f64(c));
            assert!((hg.relative(c as f32) - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn henyey_greenstein_peaks_forward_for_positive_g() {
        let f = Phase::henyey_greenstein(0.5).unwrap();
        let b = Phase::henyey_greenstein(-0.5).unwrap();
        assert!(f.eval(1.0) > 10.0 * f.eval(-1.0));
        assert!((f.eval(0.3) - b.eval(-0.3)).abs() < 1e-6);
        // f32 and f64 paths agree.
        assert!((f.eval(0.25) as f64 - f.eval_f64(0.25)).abs() < 1e-6);
    }

    #[test]
    fn fournier_forand_is_positive_and_forward_peaked() {
        let p = Phase::fournier_forand(1.05, 3.5).unwrap();
        let mut prev = f64::INFINITY;
        // Monotone decreasing over the forward hemisphere.
        for deg in [0.1, 1.0, 10.0, 30.0, 60.0, 90.0] {
            let v = p.eval_f64(f64::to_radians(deg).cos());
            assert!(v > 0.0 && v < prev, "FF at {deg}° is {v}");
            prev = v;
        }
        assert!(p.eval(1.0).is_finite());
    }

    #[test]
    fn rejects_out_of_range_parameters() {
        assert!(Phase::henyey_greenstein(1.0).is_err());
        assert!(Phase::henyey_greenstein(f32::NAN).is_err());
        assert!(Phase::fournier_forand(1.05, 0.35).is_err());
        assert!(Phase::fournier_forand(1.0, 4.0).is_err());
        assert_eq!(
            Phase::parse("hg:0.5").unwrap(),
            Phase::HenyeyGreenstein { g: 0.5 }
        );
        assert_eq!(Phase::parse("iso").unwrap(), Phase::Isotropic);
        assert!(Phase::parse("ff:1.05").is_err());
        assert!(Phase::parse("mie").is_err());
    }
}
