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

    /// Prefixes a user error with the config file whose field it names and,
    /// when `text` (the file's contents) writes that field, the line and
    /// column where it does, as parse errors have them: a stage's
    /// `placement.min_distance: ...` reads `run.ron:5:20:
    /// placement.min_distance: ...`. A field left at its default keeps
    /// `run.ron: field: ...`, since no line of the file is to blame.
    pub fn in_config(self, file: &Path, text: &str) -> Self {
        match self {
            Error::User(m) => {
                match message_field(&m).and_then(|f| crate::config::locate(text, f)) {
                    Some((line, col)) => {
                        Error::User(format!("{}:{line}:{col}: {m}", file.display()))
                    }
                    None => Error::user_file(file, m),
                }
            }
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

/// The field path a stage's message starts with (`refine.texel_size` of
/// `refine.texel_size: 1e-9 cuts ...`, `placement` of `placement
/// greedy:0.5: ...`), when it starts with one.
fn message_field(message: &str) -> Option<&str> {
    let end = message
        .find(|c: char| !(c.is_alphanumeric() || matches!(c, '_' | '.' | '[' | ']')))
        .unwrap_or(message.len());
    let follows = message[end..].chars().next();
    (end > 0 && matches!(follows, Some(':' | ' '))).then(|| &message[..end])
}

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str =
        "(\n    scene: \"a.obj\",\n    placement: SdfSkeleton((min_distance: 5)),\n)";

    fn in_config(message: &str) -> String {
        Error::User(message.into())
            .in_config(Path::new("run.ron"), TEXT)
            .to_string()
    }

    #[test]
    fn config_errors_get_the_line_of_the_field_they_name() {
        assert_eq!(
            in_config("placement.min_distance: 5 culls every free voxel"),
            "run.ron:3:29: placement.min_distance: 5 culls every free voxel"
        );
        assert_eq!(
            in_config("placement greedy:0.5: no candidate"),
            "run.ron:3:5: placement greedy:0.5: no candidate"
        );
        // Not written, so no line is to blame; and no field at all.
        assert_eq!(
            in_config("voxel_size: 0.001 gives 1e12 voxels"),
            "run.ron: voxel_size: 0.001 gives 1e12 voxels"
        );
        assert_eq!(in_config("scene: x"), "run.ron:2:5: scene: x");
        assert_eq!(in_config(": odd"), "run.ron: : odd");
        assert_eq!(in_config("placement"), "run.ron: placement");
        let internal = Error::Internal("disk full".into()).in_config(Path::new("run.ron"), TEXT);
        assert_eq!(internal.to_string(), "disk full");
        assert_eq!(internal.exit_code(), 1);
    }

    #[test]
    fn message_fields() {
        assert_eq!(message_field("lights[2]: x"), Some("lights[2]"));
        assert_eq!(
            message_field("refine.texel_size: x"),
            Some("refine.texel_size")
        );
        assert_eq!(
            message_field("placement relocated:2x2x2: x"),
            Some("placement")
        );
        assert_eq!(message_field("no-field here"), None);
        assert_eq!(message_field(""), None);
    }
}
