//! The validator's codes, kept as data (like glTF-Validator): code, severity, meaning. The
//! manifest's own codes live in [`crate::manifest::CODES`]; [`all`] lists both, and the spec's
//! table (spec/06-validation.md) is checked against it by a test.

use super::report::Severity;

/// Codes raised on layer files, pixels, patch tables and the panorama as a whole.
pub const CODES: &[(&str, Severity, &str)] = &[
    ("MANIFEST_IO_ERROR", Severity::Error, "The manifest exists but cannot be read (permissions, not a regular file, an I/O error)."),
    ("LAYER_NOT_FOUND", Severity::Error, "A layer file named in the manifest does not exist."),
    ("LAYER_PATH_ESCAPES", Severity::Error, "A layer file path leaves the panorama directory (absolute, `..`, or a symbolic link out)."),
    ("LAYER_IO_ERROR", Severity::Error, "A layer file exists but cannot be read (permissions, I/O error)."),
    ("LAYER_UNREADABLE", Severity::Error, "A layer file is not a readable single-part scanline or tiled OpenEXR (or image) file."),
    ("LAYER_TRUNCATED", Severity::Error, "A layer file ends before its data does."),
    ("LAYER_TOO_LARGE", Severity::Error, "A layer file declares more pixels than the reader limits; refused before decoding."),
    ("LAYER_MULTIPART", Severity::Error, "A layer EXR has several parts; POMC 1 layers are single-part."),
    ("LAYER_DEEP", Severity::Error, "A layer EXR holds deep data."),
    ("LAYER_UNSUPPORTED", Severity::Error, "A layer file uses a feature this reader does not support."),
    ("LAYER_DEPTH_NOT_FLOAT32", Severity::Error, "The depth channel Z is not stored as 32-bit float."),
    ("LAYER_DEPTH_LOSSY", Severity::Error, "The layer file uses a lossy compression (PXR24, B44, B44A, DWAA, DWAB); spec §4 forbids it for depth."),
    ("LAYER_SIZE_MISMATCH", Severity::Error, "A layer's stored size disagrees with the manifest (width/height or the packing atlas) or with its other files."),
    ("LAYER_NO_DEPTH", Severity::Error, "A layer has no depth channel."),
    ("LAYER_DIMENSIONS_MAPPING", Severity::Error, "A layer canvas does not fit the mapping (2:1 equirect; 3:2 cube with square faces)."),
    ("LAYER_EMPTY", Severity::Warning, "A layer has no pixel inside its domain: it should not be in the file."),
    ("CHANNELS_INCOMPLETE", Severity::Error, "Only some of R,G,B or of N.X,N.Y,N.Z are present."),
    ("DEPTH_NEGATIVE_IN_DOMAIN", Severity::Error, "Negative depth at pixels the coverage channel A puts inside the domain."),
    ("DEPTH_ZERO_IN_DOMAIN", Severity::Error, "Depth 0 inside the domain (no surface lies at the centre)."),
    ("DEPTH_UNKNOWN_IN_DOMAIN", Severity::Warning, "NaN (unknown) depth inside the domain."),
    ("DEPTH_OUT_OF_RANGE", Severity::Warning, "Depths outside the layer's declared depth range."),
    ("DEPTH_DISCONTINUITY", Severity::Warning, "Neighbouring pixels of one layer jump in depth by more than the threshold: a layer must be continuous."),
    ("MASK_OUT_OF_RANGE", Severity::Error, "Coverage A outside [0, 1] or NaN."),
    ("MASK_DEPTH_DISAGREE", Severity::Warning, "A = 0 (outside) but the depth is a non-negative distance."),
    ("COLOUR_NOT_FINITE", Severity::Warning, "NaN or infinite colour inside the domain."),
    ("NORMALS_NOT_UNIT", Severity::Warning, "Normals inside the domain whose length is not 1."),
    ("COVERAGE_INCOMPLETE", Severity::Error, "The union of the layer domains does not cover the whole sphere."),
    ("PATCH_EMPTY", Severity::Error, "A patch has zero width or height."),
    ("PATCH_OUT_OF_CANVAS", Severity::Error, "A patch extends past the layer's full canvas."),
    ("PATCH_OUT_OF_ATLAS", Severity::Error, "A patch extends past the atlas."),
    ("PATCH_OVERLAP_ATLAS", Severity::Error, "Two patches overlap in the atlas."),
    ("PATCH_OVERLAP_CANVAS", Severity::Error, "Two patches overlap in the canvas."),
    ("PATCH_CANVAS_UNDECLARED", Severity::Error, "A packed layer does not declare its full canvas width and height."),
    ("MESH_NOT_FOUND", Severity::Warning, "A stored mesh (`<Mesh file>`) does not exist; readers rebuild the mesh from the layer."),
    ("MESH_UNREADABLE", Severity::Warning, "A stored mesh cannot be used: it leaves the panorama directory, is too large, or does not decode against its layer (spec §8.4); readers rebuild it."),
    ("MESH_ENCODING_UNKNOWN", Severity::Info, "A `<Mesh>` uses an encoding or version this reader does not know; it is kept and ignored."),
];

/// Every code the validator can report: the manifest's and its own.
pub fn all() -> Vec<(&'static str, Severity, &'static str)> {
    crate::manifest::CODES.iter().map(|&(c, s, d)| (c, s.into(), d)).chain(CODES.iter().copied()).collect()
}

/// Severity of a code; unknown codes are errors (a missing row is caught by the code-table test).
pub fn severity(code: &str) -> Severity {
    CODES
        .iter()
        .find(|(c, _, _)| *c == code)
        .map(|(_, s, _)| *s)
        .or_else(|| crate::manifest::CODES.iter().find(|(c, _, _)| *c == code).map(|(_, s, _)| (*s).into()))
        .unwrap_or(Severity::Error)
}
