//! The validator's stable codes as typed constants and as data ([`CODES`]: code, severity,
//! meaning, like glTF-Validator), with the one [`Severity`]. They sit below every module that
//! raises them (layer files, packing, panoramas, stored meshes, the validator); the manifest's
//! codes are [`crate::manifest::CODES`], and [`crate::validate::codes::all`] lists both.

use serde::Serialize;

/// Severity of a finding: an error makes a panorama invalid, a warning does not, an info is a note.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// The panorama is invalid (`error` in the report).
    Error,
    /// Suspicious but valid (`warning` in the report).
    Warning,
    /// A note only (`info` in the report).
    Info,
}

impl Severity {
    /// `error`, `warning` or `info`, as in the JSON report.
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
            Severity::Info => "info",
        }
    }
}

/// The manifest exists but cannot be read (permissions, not a regular file, an I/O error).
pub const MANIFEST_IO_ERROR: &str = "MANIFEST_IO_ERROR";
/// A layer file named in the manifest does not exist.
pub const LAYER_NOT_FOUND: &str = "LAYER_NOT_FOUND";
/// A layer file path leaves the panorama directory (absolute, `..`, or a symbolic link out).
pub const LAYER_PATH_ESCAPES: &str = "LAYER_PATH_ESCAPES";
/// A layer file exists but cannot be read (permissions, I/O error).
pub const LAYER_IO_ERROR: &str = "LAYER_IO_ERROR";
/// A layer file is not a readable single-part scanline or tiled OpenEXR (or image) file.
pub const LAYER_UNREADABLE: &str = "LAYER_UNREADABLE";
/// A layer file ends before its data does.
pub const LAYER_TRUNCATED: &str = "LAYER_TRUNCATED";
/// A layer file declares more pixels than the reader limits; refused before decoding.
pub const LAYER_TOO_LARGE: &str = "LAYER_TOO_LARGE";
/// A layer EXR has several parts; POMC 1 layers are single-part.
pub const LAYER_MULTIPART: &str = "LAYER_MULTIPART";
/// A layer EXR holds deep data.
pub const LAYER_DEEP: &str = "LAYER_DEEP";
/// A layer file uses a feature this reader does not support.
pub const LAYER_UNSUPPORTED: &str = "LAYER_UNSUPPORTED";
/// The layer file uses a lossy compression (PXR24, B44, B44A, DWAA, DWAB); spec §4 forbids it for depth.
pub const LAYER_DEPTH_LOSSY: &str = "LAYER_DEPTH_LOSSY";
/// A layer's stored size disagrees with the manifest (width/height or the packing atlas) or with its other files.
pub const LAYER_SIZE_MISMATCH: &str = "LAYER_SIZE_MISMATCH";
/// A layer has no depth channel.
pub const LAYER_NO_DEPTH: &str = "LAYER_NO_DEPTH";
/// A layer canvas does not fit the mapping (2:1 equirect; 3:2 cube with square faces).
pub const LAYER_DIMENSIONS_MAPPING: &str = "LAYER_DIMENSIONS_MAPPING";
/// A layer has no pixel inside its domain: it should not be in the file.
pub const LAYER_EMPTY: &str = "LAYER_EMPTY";
/// Only some of R,G,B or of N.X,N.Y,N.Z are present.
pub const CHANNELS_INCOMPLETE: &str = "CHANNELS_INCOMPLETE";
/// Negative depth at pixels the coverage channel A puts inside the domain.
pub const DEPTH_NEGATIVE_IN_DOMAIN: &str = "DEPTH_NEGATIVE_IN_DOMAIN";
/// Depth 0 inside the domain (no surface lies at the centre).
pub const DEPTH_ZERO_IN_DOMAIN: &str = "DEPTH_ZERO_IN_DOMAIN";
/// NaN (unknown) depth inside the domain.
pub const DEPTH_UNKNOWN_IN_DOMAIN: &str = "DEPTH_UNKNOWN_IN_DOMAIN";
/// Depths outside the layer's declared depth range.
pub const DEPTH_OUT_OF_RANGE: &str = "DEPTH_OUT_OF_RANGE";
/// Neighbouring pixels of one layer jump in depth by more than the threshold: a layer must be continuous.
pub const DEPTH_DISCONTINUITY: &str = "DEPTH_DISCONTINUITY";
/// Coverage A outside [0, 1] or NaN.
pub const MASK_OUT_OF_RANGE: &str = "MASK_OUT_OF_RANGE";
/// A = 0 (outside) but the depth is a non-negative distance.
pub const MASK_DEPTH_DISAGREE: &str = "MASK_DEPTH_DISAGREE";
/// NaN or infinite colour inside the domain.
pub const COLOUR_NOT_FINITE: &str = "COLOUR_NOT_FINITE";
/// Normals inside the domain whose length is not 1.
pub const NORMALS_NOT_UNIT: &str = "NORMALS_NOT_UNIT";
/// The union of the layer domains does not cover the whole sphere.
pub const COVERAGE_INCOMPLETE: &str = "COVERAGE_INCOMPLETE";
/// A patch has zero width or height.
pub const PATCH_EMPTY: &str = "PATCH_EMPTY";
/// A patch extends past the layer's full canvas.
pub const PATCH_OUT_OF_CANVAS: &str = "PATCH_OUT_OF_CANVAS";
/// A patch extends past the atlas.
pub const PATCH_OUT_OF_ATLAS: &str = "PATCH_OUT_OF_ATLAS";
/// Two patches overlap in the atlas.
pub const PATCH_OVERLAP_ATLAS: &str = "PATCH_OVERLAP_ATLAS";
/// Two patches overlap in the canvas.
pub const PATCH_OVERLAP_CANVAS: &str = "PATCH_OVERLAP_CANVAS";
/// A packed layer does not declare its full canvas width and height.
pub const PATCH_CANVAS_UNDECLARED: &str = "PATCH_CANVAS_UNDECLARED";
/// A stored mesh (`<Mesh file>`) does not exist; readers rebuild the mesh from the layer.
pub const MESH_NOT_FOUND: &str = "MESH_NOT_FOUND";
/// A stored mesh cannot be used: it leaves the panorama directory, is too large, or does not decode against its layer (spec §8.4); readers rebuild it.
pub const MESH_UNREADABLE: &str = "MESH_UNREADABLE";
/// A `<Mesh>` uses an encoding or version this reader does not know; it is kept and ignored.
pub const MESH_ENCODING_UNKNOWN: &str = "MESH_ENCODING_UNKNOWN";

/// Codes raised on layer files, pixels, patch tables and the panorama as a whole.
pub const CODES: &[(&str, Severity, &str)] = &[
    (MANIFEST_IO_ERROR, Severity::Error, "The manifest exists but cannot be read (permissions, not a regular file, an I/O error)."),
    (LAYER_NOT_FOUND, Severity::Error, "A layer file named in the manifest does not exist."),
    (LAYER_PATH_ESCAPES, Severity::Error, "A layer file path leaves the panorama directory (absolute, `..`, or a symbolic link out)."),
    (LAYER_IO_ERROR, Severity::Error, "A layer file exists but cannot be read (permissions, I/O error)."),
    (LAYER_UNREADABLE, Severity::Error, "A layer file is not a readable single-part scanline or tiled OpenEXR (or image) file."),
    (LAYER_TRUNCATED, Severity::Error, "A layer file ends before its data does."),
    (LAYER_TOO_LARGE, Severity::Error, "A layer file declares more pixels than the reader limits; refused before decoding."),
    (LAYER_MULTIPART, Severity::Error, "A layer EXR has several parts; POMC 1 layers are single-part."),
    (LAYER_DEEP, Severity::Error, "A layer EXR holds deep data."),
    (LAYER_UNSUPPORTED, Severity::Error, "A layer file uses a feature this reader does not support."),
    ("LAYER_DEPTH_NOT_FLOAT32", Severity::Error, "The depth channel Z is not stored as 32-bit float."),
    (LAYER_DEPTH_LOSSY, Severity::Error, "The layer file uses a lossy compression (PXR24, B44, B44A, DWAA, DWAB); spec §4 forbids it for depth."),
    (LAYER_SIZE_MISMATCH, Severity::Error, "A layer's stored size disagrees with the manifest (width/height or the packing atlas) or with its other files."),
    (LAYER_NO_DEPTH, Severity::Error, "A layer has no depth channel."),
    (LAYER_DIMENSIONS_MAPPING, Severity::Error, "A layer canvas does not fit the mapping (2:1 equirect; 3:2 cube with square faces)."),
    (LAYER_EMPTY, Severity::Warning, "A layer has no pixel inside its domain: it should not be in the file."),
    (CHANNELS_INCOMPLETE, Severity::Error, "Only some of R,G,B or of N.X,N.Y,N.Z are present."),
    (DEPTH_NEGATIVE_IN_DOMAIN, Severity::Error, "Negative depth at pixels the coverage channel A puts inside the domain."),
    (DEPTH_ZERO_IN_DOMAIN, Severity::Error, "Depth 0 inside the domain (no surface lies at the centre)."),
    (DEPTH_UNKNOWN_IN_DOMAIN, Severity::Warning, "NaN (unknown) depth inside the domain."),
    (DEPTH_OUT_OF_RANGE, Severity::Warning, "Depths outside the layer's declared depth range."),
    (DEPTH_DISCONTINUITY, Severity::Warning, "Neighbouring pixels of one layer jump in depth by more than the threshold: a layer must be continuous."),
    (MASK_OUT_OF_RANGE, Severity::Error, "Coverage A outside [0, 1] or NaN."),
    (MASK_DEPTH_DISAGREE, Severity::Warning, "A = 0 (outside) but the depth is a non-negative distance."),
    (COLOUR_NOT_FINITE, Severity::Warning, "NaN or infinite colour inside the domain."),
    (NORMALS_NOT_UNIT, Severity::Warning, "Normals inside the domain whose length is not 1."),
    (COVERAGE_INCOMPLETE, Severity::Error, "The union of the layer domains does not cover the whole sphere."),
    (PATCH_EMPTY, Severity::Error, "A patch has zero width or height."),
    (PATCH_OUT_OF_CANVAS, Severity::Error, "A patch extends past the layer's full canvas."),
    (PATCH_OUT_OF_ATLAS, Severity::Error, "A patch extends past the atlas."),
    (PATCH_OVERLAP_ATLAS, Severity::Error, "Two patches overlap in the atlas."),
    (PATCH_OVERLAP_CANVAS, Severity::Error, "Two patches overlap in the canvas."),
    (PATCH_CANVAS_UNDECLARED, Severity::Error, "A packed layer does not declare its full canvas width and height."),
    (MESH_NOT_FOUND, Severity::Warning, "A stored mesh (`<Mesh file>`) does not exist; readers rebuild the mesh from the layer."),
    (MESH_UNREADABLE, Severity::Warning, "A stored mesh cannot be used: it leaves the panorama directory, is too large, or does not decode against its layer (spec §8.4); readers rebuild it."),
    (MESH_ENCODING_UNKNOWN, Severity::Info, "A `<Mesh>` uses an encoding or version this reader does not know; it is kept and ignored."),
];
