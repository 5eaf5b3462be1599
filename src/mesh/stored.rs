//! A layer's stored mesh (`<Mesh>`, spec §8.1): found, read and decoded against its layer. One
//! place for the renderer and the validator, so both ignore exactly the same meshes.

use super::{encode, LayerMesh};
use crate::layer::LayerImage;
use crate::mapping::{AnyMapping, Mapping};
use crate::panorama::Panorama;

/// Why a declared mesh cannot be used; readers then rebuild it from the layer (spec §8.1).
#[derive(Debug, thiserror::Error)]
#[error("stored mesh `{file}`: {reason}; it is ignored and rebuilt from the layer (store it again with `pomc mesh --store`)")]
pub struct StoredMeshError {
    /// The mesh file as the manifest declares it.
    pub file: String,
    /// `MESH_NOT_FOUND` or `MESH_UNREADABLE`.
    pub code: &'static str,
    /// Human-readable cause: the file is missing, unreadable, too large or fails to decode.
    pub reason: String,
}

/// Store encoded quadtree meshes (`(layer index, encode::encode bytes)`) as `NAME.pomcmesh` beside the
/// manifest and reference each from its layer (`<Mesh>`, replacing an older one), what `pomc mesh
/// --store` does. File names are the layer names made file-safe and unique over the manifest; each
/// file and then the manifest are written atomically, under the panorama's writer lock.
pub fn store(pano: &Panorama, meshes: &[(usize, &[u8])]) -> crate::Result<()> {
    let mut manifest = pano.manifest.clone();
    let names: Vec<String> = (0..manifest.layers.len()).map(|k| manifest.layer_name(k)).collect();
    let stems = super::export::safe_names(&names);
    // Not while another command rewrites the panorama (best effort: a read-only parent has no lock).
    let _lock = crate::fsutil::lock_dir(&pano.dir).ok();
    for &(index, bytes) in meshes {
        let Some(decl) = manifest.layers.get_mut(index) else { continue };
        let file = format!("{}.{}", stems[index], encode::EXTENSION);
        crate::fsutil::write_bytes_atomic(&pano.dir.join(&file), bytes)?;
        decl.mesh = Some(crate::manifest::MeshDecl::quadtree(&file));
    }
    Ok(crate::fsutil::write_bytes_atomic(&pano.manifest_path, manifest.to_xml().as_bytes())?)
}

/// The stored mesh of layer `index` when its declaration uses the encoding this reader knows
/// (`None` without one, or with another encoding), decoded against the layer's `image`.
pub fn read_stored(
    pano: &Panorama,
    index: usize,
    image: &LayerImage,
    mapping: &AnyMapping,
) -> Option<Result<LayerMesh, StoredMeshError>> {
    let decl = pano.manifest.layers.get(index)?.mesh.as_ref().filter(|m| m.is_quadtree_v1())?;
    let fail = |code, reason: String| StoredMeshError { file: decl.file.clone(), code, reason };
    Some((|| {
        let path =
            pano.resolve(&decl.file).map_err(|e| fail(crate::codes::MESH_UNREADABLE, e.to_string()))?;
        if !path.exists() {
            return Err(fail(crate::codes::MESH_NOT_FOUND, format!("{} does not exist", path.display())));
        }
        // The encoding is bounded by the canvas (spec §8.4); refuse anything much larger unread.
        let limit = 1024 + (mapping.width() * mapping.height()) as u64 / 4;
        let bytes = crate::fsutil::read_limited(&path, limit)
            .map_err(|e| fail(crate::codes::MESH_UNREADABLE, e.to_string()))?;
        encode::decode(&bytes, image, mapping).map_err(|e| fail(crate::codes::MESH_UNREADABLE, e.to_string()))
    })())
}
