//! Patch-packed compression (spec §5; thesis eq. 6.16-6.17). INTERFACE STUB.
//!
//! A sparse layer's occupied pixels are cut into rectangles, packed into a compact atlas, and
//! recorded in a patch table: `canvas(u+s, v+t) = atlas(x+s, y+t)` for `(s,t) ∈ [0,w)×[0,h)`.

use crate::layer::LayerImage;

/// One row of the patch table: origin `(u, v)` in the full canvas, origin `(x, y)` in the atlas,
/// size `w × h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Patch {
    pub u: u32,
    pub v: u32,
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

/// Tuning of [`pack_layer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct PackOptions {
    /// Guard band copied around each patch in the atlas (pixels), for bilinear sampling.
    pub padding: u32,
}

/// A packed layer: atlas image plus patch table, and the full canvas size.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedLayer {
    pub canvas_width: u32,
    pub canvas_height: u32,
    pub atlas: LayerImage,
    pub patches: Vec<Patch>,
}

impl PackedLayer {
    /// Pixels in the atlas.
    pub fn atlas_area(&self) -> usize {
        self.atlas.width * self.atlas.height
    }
}

/// Errors of packing and unpacking.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("patch table is invalid: {0}")]
    BadTable(TableProblem),
    #[error("canvas {width}x{height} is too large to unpack (limit {limit} pixels)")]
    TooLarge { width: u32, height: u32, limit: u64 },
}

impl PackError {
    pub fn code(&self) -> &'static str {
        match self {
            PackError::BadTable(p) => p.code(),
            PackError::TooLarge { .. } => "LAYER_TOO_LARGE",
        }
    }
}

/// What is wrong with one patch of a table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TableProblemKind {
    Empty,
    OutOfCanvas,
    OutOfAtlas,
    OverlapAtlas { other: usize },
    OverlapCanvas { other: usize },
}

/// A problem with patch number `patch` of a table.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("patch {patch}: {kind:?}")]
pub struct TableProblem {
    pub patch: usize,
    pub kind: TableProblemKind,
}

impl TableProblem {
    pub fn code(&self) -> &'static str {
        match self.kind {
            TableProblemKind::Empty => "PATCH_EMPTY",
            TableProblemKind::OutOfCanvas => "PATCH_OUT_OF_CANVAS",
            TableProblemKind::OutOfAtlas => "PATCH_OUT_OF_ATLAS",
            TableProblemKind::OverlapAtlas { .. } => "PATCH_OVERLAP_ATLAS",
            TableProblemKind::OverlapCanvas { .. } => "PATCH_OVERLAP_CANVAS",
        }
    }
}

/// Every problem of a patch table against canvas `cw × ch` and atlas `aw × ah`.
pub fn check_table(_cw: u32, _ch: u32, _aw: u32, _ah: u32, _patches: &[Patch]) -> Vec<TableProblem> {
    todo!("pack::check_table")
}

/// Pack a layer's occupied pixels (its domain) into an atlas.
pub fn pack_layer(_image: &LayerImage, _options: &PackOptions) -> Result<PackedLayer, PackError> {
    todo!("pack::pack_layer")
}

/// Restore the full canvas; pixels in no patch are outside (`A = 0`, `Z = -1`, other channels 0).
pub fn unpack(_packed: &PackedLayer) -> Result<LayerImage, PackError> {
    todo!("pack::unpack")
}
