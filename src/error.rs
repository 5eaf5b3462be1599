//! The crate-level error: each module has its own typed error; this wraps them so callers can use
//! `?` across modules. Every error has a stable machine-readable [`Error::code`].

use std::path::PathBuf;

/// Any error pomc can return.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Manifest(#[from] crate::manifest::ManifestError),
    #[error(transparent)]
    LayerIo(#[from] crate::layer_io::LayerIoError),
    #[error(transparent)]
    Pack(#[from] crate::pack::PackError),
    #[error(transparent)]
    Resample(#[from] crate::resample::ResampleError),
    #[error(transparent)]
    Panorama(#[from] crate::panorama::PanoramaError),
    #[error(transparent)]
    Build(#[from] crate::build::BuildError),
    #[error(transparent)]
    Input(#[from] crate::build::input::InputError),
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    #[error(transparent)]
    Image(#[from] crate::image_io::ImageIoError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// Stable code, e.g. `IO_ERROR`, `MANIFEST_XML_MALFORMED`.
    pub fn code(&self) -> &'static str {
        match self {
            Error::Manifest(e) => e.code(),
            Error::LayerIo(e) => e.code(),
            Error::Pack(e) => e.code(),
            Error::Resample(e) => e.code(),
            Error::Panorama(e) => e.code(),
            Error::Build(e) => e.code(),
            Error::Input(e) => e.code(),
            Error::Mesh(e) => e.code(),
            Error::Render(e) => e.code(),
            Error::Image(e) => e.code(),
            Error::Io { .. } => "IO_ERROR",
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
