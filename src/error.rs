//! Errors that are the user's to fix.
//!
//! An [`InputError`] names the bad value and what would be valid. The binary
//! maps it to exit code 2 (like clap's own usage errors) and guarantees that
//! nothing was written to the output folder before it was raised.

use std::fmt;

/// A bad parameter, file or identifier supplied by the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError(pub String);

impl InputError {
    /// Build an error from anything printable.
    pub fn new(msg: impl Into<String>) -> Self {
        Self(msg.into())
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

/// Return early with an [`InputError`] built by `format!`.
#[macro_export]
macro_rules! input_bail {
    ($($arg:tt)*) => {
        return Err($crate::error::InputError::new(format!($($arg)*)).into())
    };
}

/// `Ok` when `value` is a positive finite number, else an error naming
/// `name` and its value.
pub fn check_positive(name: &str, value: f32) -> Result<(), InputError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InputError::new(format!(
            "{name} is {value}; it must be a positive finite number"
        )))
    }
}

/// `Ok` when `value` is a finite number ≥ 0, else an error naming `name`
/// and its value.
pub fn check_non_negative(name: &str, value: f32) -> Result<(), InputError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(InputError::new(format!(
            "{name} is {value}; it must be a finite number ≥ 0"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_value() {
        assert!(check_positive("dt", 0.1).is_ok());
        for v in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let e = check_positive("dt", v).unwrap_err().to_string();
            assert!(e.starts_with(&format!("dt is {v};")), "{e}");
        }
        assert!(check_non_negative("nu", 0.0).is_ok());
        for v in [-1e-9, f32::NAN, f32::NEG_INFINITY] {
            assert!(check_non_negative("nu", v).is_err(), "{v}");
        }
    }
}
