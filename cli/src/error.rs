//! The program's error: a message meant for a person, already naming the file,
//! the key and what was expected.

use std::fmt;

/// A failure of `corofem run` or `corofem info`. The message is complete: the
/// program prints it after `error: ` and exits with a non-zero status.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError(pub String);

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CliError {}

impl From<String> for CliError {
    fn from(message: String) -> Self {
        CliError(message)
    }
}

/// `Result` with a [`CliError`].
pub type CliResult<T> = Result<T, CliError>;
