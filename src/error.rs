//! The crate-level error: each module has its own typed error; this wraps them so callers can use
//! `?` across modules. Every error has a stable machine-readable [`Error::code`].

use std::path::PathBuf;

/// Any error pomc can return.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading, parsing or checking a manifest failed.
    #[error(transparent)]
    Manifest(#[from] crate::manifest::ManifestError),
    /// Reading or writing a layer file failed.
    #[error(transparent)]
    LayerIo(#[from] crate::layer_io::LayerIoError),
    /// Packing or unpacking layers into an atlas failed.
    #[error(transparent)]
    Pack(#[from] crate::pack::PackError),
    /// Resampling between mappings or sizes failed.
    #[error(transparent)]
    Resample(#[from] crate::resample::ResampleError),
    /// Converting a file or panorama between mappings failed.
    #[error(transparent)]
    Convert(#[from] crate::jobs::ConvertError),
    /// Opening, checking or saving a panorama failed.
    #[error(transparent)]
    Panorama(#[from] crate::panorama::PanoramaError),
    /// Building a layered panorama from inputs failed.
    #[error(transparent)]
    Build(#[from] crate::layering::BuildError),
    /// Loading or checking the build inputs failed.
    #[error(transparent)]
    Input(#[from] crate::layering::input::InputError),
    /// Preparing the input depth failed (what it is, its unit, its shape).
    #[error(transparent)]
    Prepare(#[from] crate::prepare::PrepareError),
    /// Meshing, or reading or writing a stored mesh, failed.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// Rendering a view failed.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Reading a 3D scene or making its layers failed.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// Reading or writing a plain image (PNG, JPEG, EXR, HDR) failed.
    #[error(transparent)]
    Image(#[from] crate::image_io::ImageIoError),
    /// A file system operation on `path` failed (code `IO_ERROR`).
    #[error("{path}: {source}")]
    Io {
        /// The file or directory the operation was on.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
}

crate::codes::error_codes! {
    Error:
        Io IO_ERROR;
        from Manifest.0, LayerIo.0, Pack.0, Resample.0, Convert.0, Panorama.0, Build.0, Input.0,
            Prepare.0, Mesh.0, Render.0, Image.0, Scene.0
}

impl From<crate::fsutil::IoError> for Error {
    fn from(e: crate::fsutil::IoError) -> Self {
        Error::Io { path: e.path, source: e.source }
    }
}

/// `std::result::Result` with pomc's [`Error`] as the default error type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
