//! The crate's error type: a kind that callers and tests can match, and one
//! human-readable message that names the file, the feature and what is
//! wrong, suitable for printing as a one-line error.

use std::fmt;

/// What went wrong, for matching. The message says the details.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ErrorKind {
    /// A setting is invalid; the name is the setting's (and its command-line
    /// flag's) name, e.g. `"eps"` or `"max-cell-edge"`.
    Setting(&'static str),
    /// A setting would make the work take more time or memory than the
    /// limits allow; the name is the setting to change.
    Limit(&'static str),
    /// An input city or region file is unreadable or invalid.
    Input,
    /// A `.pvs` file, shard file or checkpoint is invalid or truncated.
    Format,
    /// Files that do not belong together: shards of different bakes, a
    /// `.pvs` of another city, a checkpoint of other settings.
    Mismatch,
    /// Preparing the scene failed (no free space, too many vertices, ...).
    Scene,
    /// Reading or writing a file failed, or an output path is unusable.
    Io,
    /// A command-line request that cannot be served (no such cell, ...).
    Usage,
}

/// An error with its kind and a complete, user-facing message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    kind: ErrorKind,
    message: String,
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An error of the given kind.
    pub fn of(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error {
            kind,
            message: message.into(),
        }
    }

    /// An invalid input file.
    pub fn input(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Input, message)
    }

    /// An invalid `.pvs`, shard or checkpoint file.
    pub fn format(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Format, message)
    }

    /// Files that do not belong together.
    pub fn mismatch(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Mismatch, message)
    }

    /// Scene preparation failed.
    pub fn scene(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Scene, message)
    }

    /// A file could not be read or written.
    pub fn io(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Io, message)
    }

    /// A request that cannot be served.
    pub fn usage(message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Usage, message)
    }

    /// An invalid setting: `message` says what is wrong with it and is
    /// shown after the setting's name.
    pub fn setting(name: &'static str, message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Setting(name), message)
    }

    /// A setting that would exceed a limit on time or memory.
    pub fn limit(name: &'static str, message: impl Into<String>) -> Self {
        Error::of(ErrorKind::Limit(name), message)
    }

    /// Prefix the message with context, e.g. a file name: `"city.geojson: " + message`.
    pub fn context(self, prefix: impl fmt::Display) -> Self {
        Error {
            kind: self.kind,
            message: format!("{prefix}: {}", self.message),
        }
    }

    /// The kind, for matching.
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// The message (without the setting's name for setting errors).
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The one line the command line prints: setting errors name the flag.
    pub fn cli_message(&self) -> String {
        match self.kind {
            ErrorKind::Setting(name) => format!("--{name} {}", self.message),
            _ => self.to_string(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            ErrorKind::Setting(name) => write!(f, "{name} {}", self.message),
            _ => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for Error {}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::io(e.to_string())
    }
}
