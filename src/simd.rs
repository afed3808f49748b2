//! Which instruction set the semi-Lagrangian kernel runs on
//! (`advection::kernel`): scalar (one lane), NEON (four), AVX2 (eight) or
//! AVX-512F (sixteen).
//!
//! The kernel is written once for any lane width and does the same
//! floating-point operations in the same order in every lane, so every
//! [`Isa`] gives the same bits; they differ only in speed. The widest one
//! the CPU has runs unless the environment variable `SMOKELAB_SIMD` names
//! another (`scalar`, `neon`, `avx2`, `avx512`), or a program chooses one
//! with [`Isa::select`]. Manifests record the one that ran
//! ([`Isa::selected`]).

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU8, Ordering};

use serde::{Deserialize, Serialize};

use crate::error::InputError;

/// The environment variable that overrides the widest [`Isa`].
pub const ENV: &str = "SMOKELAB_SIMD";

/// An instruction set of the semi-Lagrangian kernel, by lane width.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Isa {
    /// Plain `f32` arithmetic, one point at a time; runs everywhere.
    Scalar,
    /// Arm's Advanced SIMD, four lanes (every aarch64 CPU).
    Neon,
    /// x86-64 AVX2, eight lanes; corners through permuted row windows.
    Avx2,
    /// x86-64 AVX-512F, sixteen lanes; corners through permuted row windows.
    Avx512,
}

impl Isa {
    /// Every variant, narrowest first.
    pub const ALL: [Isa; 4] = [Isa::Scalar, Isa::Neon, Isa::Avx2, Isa::Avx512];

    /// The name `SMOKELAB_SIMD` takes and manifests record.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Neon => "neon",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// Points per vector.
    pub fn lanes(self) -> usize {
        match self {
            Isa::Scalar => 1,
            Isa::Neon => 4,
            Isa::Avx2 => 8,
            Isa::Avx512 => 16,
        }
    }

    /// Whether this CPU (and this build's target) can run it.
    pub fn is_available(self) -> bool {
        match self {
            Isa::Scalar => true,
            #[cfg(target_arch = "aarch64")]
            Isa::Neon => std::arch::is_aarch64_feature_detected!("neon"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => is_x86_feature_detected!("avx512f"),
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// The instruction sets this CPU can run, narrowest first.
    pub fn available() -> Vec<Isa> {
        Self::ALL.into_iter().filter(|i| i.is_available()).collect()
    }

    /// The widest this CPU can run.
    pub fn widest() -> Isa {
        *Self::available()
            .last()
            .expect("scalar is always available")
    }

    /// `name` as an available instruction set: the error names the valid
    /// values, and those this CPU has, for an unknown or unavailable one.
    ///
    /// # Errors
    /// An unknown name, or one this CPU cannot run.
    pub fn parse_available(name: &str) -> Result<Isa, InputError> {
        let isa: Isa = name.parse()?;
        if isa.is_available() {
            Ok(isa)
        } else {
            Err(InputError::new(format!(
                "{ENV}={name}: this CPU cannot run {name}; it has {}",
                names(&Self::available())
            )))
        }
    }

    /// The instruction set `SMOKELAB_SIMD` asks for, else the widest.
    ///
    /// # Errors
    /// As [`Self::parse_available`] for the variable's value.
    pub fn from_env() -> Result<Isa, InputError> {
        match std::env::var(ENV) {
            Ok(v) => Self::parse_available(v.trim()),
            Err(std::env::VarError::NotPresent) => Ok(Self::widest()),
            Err(e) => Err(InputError::new(format!("{ENV}: {e}"))),
        }
    }

    /// The instruction set the kernel runs on: the last [`Self::select`]ed,
    /// else [`Self::from_env`] (read once).
    ///
    /// # Panics
    /// If `SMOKELAB_SIMD` names an unknown or unavailable instruction set
    /// (the command line checks it first and exits with code 2).
    pub fn selected() -> Isa {
        match SELECTED.load(Ordering::Relaxed) {
            0 => {
                let isa = Self::from_env().unwrap_or_else(|e| panic!("{e}"));
                // A concurrent `select` wins.
                let _ =
                    SELECTED.compare_exchange(0, code(isa), Ordering::Relaxed, Ordering::Relaxed);
                Self::selected()
            }
            c => Self::ALL[usize::from(c - 1)],
        }
    }

    /// Make `self` the instruction set of every later sweep in this
    /// process (experiment P-1 times each in turn).
    ///
    /// # Errors
    /// If this CPU cannot run it.
    pub fn select(self) -> Result<(), InputError> {
        Self::parse_available(self.name())?;
        SELECTED.store(code(self), Ordering::Relaxed);
        Ok(())
    }
}

/// [`Isa::selected`]'s choice, `0` before the first.
static SELECTED: AtomicU8 = AtomicU8::new(0);

fn code(isa: Isa) -> u8 {
    Isa::ALL.iter().position(|&i| i == isa).expect("a variant") as u8 + 1
}

/// `a, b or c`.
fn names(isas: &[Isa]) -> String {
    let n: Vec<&str> = isas.iter().map(|i| i.name()).collect();
    match n.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => n.join(""),
    }
}

impl FromStr for Isa {
    type Err = InputError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|i| i.name() == s)
            .ok_or_else(|| {
                InputError::new(format!(
                    "{ENV}={s}: unknown instruction set; valid values are {}",
                    names(&Self::ALL)
                ))
            })
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_ones_name_the_valid_values() {
        for isa in Isa::ALL {
            assert_eq!(isa.name().parse::<Isa>().unwrap(), isa);
            assert_eq!(serde_json::to_string(&isa).unwrap(), format!("\"{isa}\""));
        }
        let e = "sse9".parse::<Isa>().unwrap_err().to_string();
        assert!(e.contains("scalar, neon, avx2 or avx512"), "{e}");
    }

    #[test]
    fn scalar_is_always_available_and_other_architectures_never() {
        assert!(Isa::Scalar.is_available());
        assert_eq!(Isa::available()[0], Isa::Scalar);
        #[cfg(target_arch = "x86_64")]
        assert!(!Isa::Neon.is_available());
        // Every aarch64 CPU has NEON, so the kernel's tests run it there.
        #[cfg(target_arch = "aarch64")]
        assert_eq!(Isa::available(), [Isa::Scalar, Isa::Neon]);
        let unavailable = Isa::ALL.into_iter().find(|i| !i.is_available()).unwrap();
        let e = Isa::parse_available(unavailable.name())
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot run") && e.contains("scalar"), "{e}");
        assert!(unavailable.select().is_err());
    }
}
