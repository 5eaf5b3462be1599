//! A panorama on disk: a directory holding `panorama.xml` and its layer files (spec §1.3).
//!
//! [`Panorama::open`] takes the directory or the manifest's path. Layer files are resolved
//! relative to the directory and must stay inside it ([`Panorama::resolve`]). Reading a layer
//! gives its full canvas whatever the storage (native EXR, thesis PNG+EXR, patch-packed atlas).

mod save;

use std::path::{Component, Path, PathBuf};

use crate::error::Error;
use crate::layer::LayerImage;
use crate::layer_io::{self, ReadLimits};
use crate::manifest::{self, LayerDecl, LayerSource, Manifest};
use crate::pack::{self, PackedLayer};

pub use save::{write_panorama, write_panorama_with, SaveOptions};

/// File name of the manifest inside a panorama directory.
pub const MANIFEST_NAME: &str = "panorama.xml";

/// Largest manifest accepted, in bytes (bounded before reading).
pub const MAX_MANIFEST_BYTES: u64 = 16 << 20;

/// Errors specific to panorama directories.
#[derive(Debug, thiserror::Error)]
pub enum PanoramaError {
    #[error("{path}: no panorama here; give a directory holding {MANIFEST_NAME} or the manifest's path")]
    /// [`manifest_path`]: the path is neither a file nor a directory holding [`MANIFEST_NAME`].
    NotFound {
        /// The path given.
        path: PathBuf,
    },
    #[error("{manifest}: layer file `{file}` resolves outside the panorama directory {dir}; use a path relative to the directory without `..`")]
    /// A file name is empty, absolute or resolves outside the directory (`..`, symbolic links).
    PathEscapes {
        /// The manifest naming the file.
        manifest: PathBuf,
        /// The file name as written in the manifest.
        file: String,
        /// The panorama directory it must stay in.
        dir: PathBuf,
    },
    #[error("{manifest}: layer {index} does not exist (the manifest has {count} layers)")]
    /// A layer index with no layer, or (writing) layer images and `<Layer>`s differ in number.
    NoSuchLayer {
        /// The manifest concerned (when writing, the one to be written).
        manifest: PathBuf,
        /// The missing layer's index, from 0.
        index: usize,
        /// How many layers there are.
        count: usize,
    },
    #[error("{file}: stored image is {found:?} but the manifest declares {declared:?} for layer {index}; fix the manifest's width/height (or <Packing atlas>) or re-export the file")]
    /// The stored image's size differs from the declared canvas (unpacked) or atlas (packed) size.
    SizeMismatch {
        /// The stored file (the colour file for the thesis form).
        file: PathBuf,
        /// The layer's index, from 0.
        index: usize,
        /// `(width, height)` declared in the manifest, pixels.
        declared: (usize, usize),
        /// `(width, height)` of the stored image, pixels.
        found: (usize, usize),
    },
    #[error("{file}: layer {index} is packed but its canvas size is not declared; add width and height to the <Layer>")]
    /// A layer has `<Packing>` but no `width`/`height` for its full canvas.
    PackedWithoutCanvas {
        /// The stored atlas file.
        file: PathBuf,
        /// The layer's index, from 0.
        index: usize,
    },
    #[error("{path}: the output exists and is not a directory; give a directory for the panorama")]
    /// Writing: the output path exists and is not a directory.
    OutputNotDirectory {
        /// The output path given.
        path: PathBuf,
    },
}

crate::codes::error_codes! {
    PanoramaError:
        NotFound PANORAMA_NOT_FOUND,
        PathEscapes LAYER_PATH_ESCAPES,
        NoSuchLayer PANORAMA_NO_SUCH_LAYER,
        SizeMismatch LAYER_SIZE_MISMATCH,
        PackedWithoutCanvas PATCH_CANVAS_UNDECLARED,
        OutputNotDirectory OUTPUT_NOT_DIRECTORY
}

/// An opened panorama: where it is and what its manifest says.
#[derive(Clone, Debug)]
pub struct Panorama {
    /// The directory layer paths are relative to.
    pub dir: PathBuf,
    /// The manifest file.
    pub manifest_path: PathBuf,
    /// The parsed manifest.
    pub manifest: Manifest,
}

/// Locate the manifest for a directory or manifest path.
pub fn manifest_path(path: &Path) -> Result<PathBuf, PanoramaError> {
    if path.is_dir() {
        let m = path.join(MANIFEST_NAME);
        if m.is_file() {
            return Ok(m);
        }
    } else if path.is_file() {
        return Ok(path.to_path_buf());
    }
    Err(PanoramaError::NotFound { path: path.to_path_buf() })
}

impl Panorama {
    /// Open a panorama from its directory or its manifest's path (first fatal manifest error).
    pub fn open(path: &Path) -> Result<Panorama, Error> {
        let manifest_path = manifest_path(path)?;
        let bytes = crate::fsutil::read_limited(&manifest_path, MAX_MANIFEST_BYTES)?;
        let manifest = manifest::parse(&bytes, &manifest_path.display().to_string())?;
        let dir = manifest_path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(Panorama { dir, manifest_path, manifest })
    }

    /// Resolve a file named in the manifest, refusing absolute paths and paths that leave the
    /// panorama directory (lexically, and through symbolic links when the file exists).
    pub fn resolve(&self, file: &str) -> Result<PathBuf, PanoramaError> {
        resolve_inside(&self.dir, file).ok_or_else(|| PanoramaError::PathEscapes {
            manifest: self.manifest_path.clone(),
            file: file.to_string(),
            dir: self.dir.clone(),
        })
    }

    /// The layer declaration `index`.
    pub fn layer(&self, index: usize) -> Result<&LayerDecl, PanoramaError> {
        self.manifest.layers.get(index).ok_or(PanoramaError::NoSuchLayer {
            manifest: self.manifest_path.clone(),
            index,
            count: self.manifest.layers.len(),
        })
    }

    /// The image file as stored (an atlas for packed layers), without unpacking.
    pub fn read_stored(&self, index: usize, limits: &ReadLimits) -> Result<LayerImage, Error> {
        let decl = self.layer(index)?;
        Ok(match &decl.source {
            LayerSource::Native { file } => layer_io::read_exr(&self.resolve(file)?, limits)?,
            LayerSource::Thesis { mapname, depthname, normals } => {
                let map = self.resolve(mapname)?;
                let depth = self.resolve(depthname)?;
                let normals = normals.as_deref().map(|n| self.resolve(n)).transpose()?;
                layer_io::read_thesis_layer(&map, &depth, normals.as_deref(), limits)?
            }
        })
    }

    /// The layer's full canvas: unpacked when packed, size-checked against the manifest.
    pub fn read_layer(&self, index: usize, limits: &ReadLimits) -> Result<LayerImage, Error> {
        let decl = self.layer(index)?;
        let stored = self.read_stored(index, limits)?;
        let file = self.stored_file(decl);
        let found = (stored.width, stored.height);
        match &decl.packing {
            None => {
                if let Some((w, h)) = decl.size() {
                    let declared = (w as usize, h as usize);
                    if declared != found {
                        return Err(PanoramaError::SizeMismatch { file, index, declared, found }.into());
                    }
                }
                Ok(stored)
            }
            Some(packing) => {
                let declared = (packing.atlas_width as usize, packing.atlas_height as usize);
                if declared != found {
                    return Err(PanoramaError::SizeMismatch { file, index, declared, found }.into());
                }
                let (cw, ch) = decl.size().ok_or(PanoramaError::PackedWithoutCanvas { file, index })?;
                let packed = PackedLayer {
                    canvas_width: cw,
                    canvas_height: ch,
                    atlas: stored,
                    patches: packing.patches.clone(),
                };
                Ok(pack::unpack(&packed)?)
            }
        }
    }

    /// Every layer's full canvas ([`Panorama::read_layer`]) in manifest order, the layers read in
    /// parallel (and each file's chunks too).
    pub fn read_layers(&self, limits: &ReadLimits) -> Result<Vec<LayerImage>, Error> {
        use rayon::prelude::*;
        let read: Vec<_> =
            (0..self.manifest.layers.len()).into_par_iter().map(|k| self.read_layer(k, limits)).collect();
        // The first bad layer's error, whichever thread met it first.
        read.into_iter().collect()
    }

    /// Path of the file holding a layer's pixels (the colour file for the thesis form).
    pub fn stored_file(&self, decl: &LayerDecl) -> PathBuf {
        let name = match &decl.source {
            LayerSource::Native { file } => file,
            LayerSource::Thesis { mapname, .. } => mapname,
        };
        self.dir.join(name)
    }
}

/// Lexical and physical containment check of `file` inside `dir`.
pub(crate) fn resolve_inside(dir: &Path, file: &str) -> Option<PathBuf> {
    let rel = Path::new(file);
    if file.is_empty() || rel.is_absolute() {
        return None;
    }
    let mut depth = 0i32;
    for c in rel.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir => {
                depth -= 1;
                if depth < 0 {
                    return None;
                }
            }
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    let joined = dir.join(rel);
    // A symbolic link inside the directory may still point outside it.
    if let (Ok(real_dir), Ok(real_file)) = (dir.canonicalize(), joined.canonicalize()) {
        if !real_file.starts_with(&real_dir) {
            return None;
        }
    }
    Some(joined)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_refuses_escapes() {
        let d = tempfile::tempdir().unwrap();
        assert!(resolve_inside(d.path(), "a.exr").is_some());
        assert!(resolve_inside(d.path(), "sub/../a.exr").is_some());
        assert!(resolve_inside(d.path(), "../a.exr").is_none());
        assert!(resolve_inside(d.path(), "sub/../../a.exr").is_none());
        assert!(resolve_inside(d.path(), "/etc/passwd").is_none());
        assert!(resolve_inside(d.path(), "").is_none());
    }

    #[cfg(unix)]
    #[test]
    fn resolve_refuses_symlink_escape() {
        let d = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::fs::write(outside.path().join("x.exr"), b"x").unwrap();
        std::os::unix::fs::symlink(outside.path().join("x.exr"), d.path().join("link.exr")).unwrap();
        assert!(resolve_inside(d.path(), "link.exr").is_none());
    }
}
