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
