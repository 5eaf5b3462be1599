//! The crate's one error, at the bottom of the tree as `exrs`'s is: every module's typed error turns
//! into it with `?` (each module declares that conversion itself, so this file names no module),
//! keeping the module error's stable [`Error::code`], message and source chain.

use std::fmt;
use std::path::PathBuf;

/// Any error pomc can return: a stable code and the module's typed error behind it
/// ([`Error::downcast_ref`] gets it back, e.g. as a `ManifestError`).
pub struct Error {
    code: &'static str,
    inner: Box<dyn std::error::Error + Send + Sync + 'static>,
}

impl Error {
    /// `error` with its stable `code` (a constant of [`crate::codes`]).
    pub fn new<E: std::error::Error + Send + Sync + 'static>(code: &'static str, error: E) -> Error {
        Error { code, inner: Box::new(error) }
    }

    /// A file system operation on `path` failed (code `IO_ERROR`).
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Error {
        IoError { path: path.into(), source }.into()
    }

    /// Stable machine-readable code (declared in [`crate::codes`]).
    pub fn code(&self) -> &'static str {
        self.code
    }

    /// The module's error behind this one.
    pub fn get_ref(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.inner
    }

    /// The module's error behind this one, when it is an `E`.
    pub fn downcast_ref<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.inner.downcast_ref()
    }
}

impl fmt::Debug for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {:?}", self.code, self.inner)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.inner, f)
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.inner.source()
    }
}

/// A file system operation on `path` failed (code `IO_ERROR`).
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct IoError {
    /// The file or directory the operation was on.
    pub path: PathBuf,
    /// The underlying I/O error.
    #[source]
    pub source: std::io::Error,
}

impl From<IoError> for Error {
    fn from(e: IoError) -> Self {
        Error::new(crate::codes::IO_ERROR, e)
    }
}

/// `std::result::Result` with pomc's [`Error`] as the default error type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
