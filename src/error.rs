//! Errors, split by who must act on them.
//!
//! A [`Error::User`] is a mistake in the input (config, scene file, command
//! line): the binary prints its one-line message and exits with status 2. An
//! [`Error::Internal`] is a bug or an environment failure (disk full, ...) and
//! exits with status 1. Neither ever panics.

use std::path::Path;

/// The crate's error type.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user's input is wrong; the message names the file or field and the problem.
    #[error("{0}")]
    User(String),
    /// Something outside the user's control failed.
    #[error("{0}")]
    Internal(String),
}

impl Error {
    /// A user error about `file`: renders as `file: message`.
    pub fn user_file(file: &Path, message: impl std::fmt::Display) -> Self {
        Error::User(format!("{}: {}", file.display(), message))
    }

    /// An internal error about `file`: renders as `file: message`.
    pub fn io(file: &Path, err: impl std::fmt::Display) -> Self {
        Error::Internal(format!("{}: {}", file.display(), err))
    }

    /// Prefixes a user error with the file whose field it names (the config),
    /// so stage errors like `voxel_size: ...` read `run.ron: voxel_size: ...`.
    pub fn in_file(self, file: &Path) -> Self {
        match self {
            Error::User(m) => Error::user_file(file, m),
            other => other,
        }
    }

    /// Exit status the command line should use for this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::User(_) => 2,
            Error::Internal(_) => 1,
        }
    }
}

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
