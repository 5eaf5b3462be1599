//! The manifest's stable codes, kept as data: code, severity, meaning. The spec's table
//! (spec/02-manifest.md §2.9) is checked against [`CODES`] by a unit test, so the two cannot drift.
//! Codes never change meaning once published; new ones may be added.

use super::Severity;
use crate::codes::declare_codes;

declare_codes! {
    /// The manifest's validation codes: code, severity, meaning (spec/02-manifest.md lists them).
    CODES;
    XML_MALFORMED, Error, "The manifest is not well-formed XML.";
    XML_DTD_FORBIDDEN, Error, "The manifest has a DOCTYPE (DTD); DTDs and entity declarations are refused.";
    XML_ENCODING_UNSUPPORTED, Error, "The manifest declares or uses an encoding other than UTF-8 or ISO-8859-1 (e.g. UTF-16).";
    XML_ENCODING_INVALID, Error, "The manifest's bytes are not valid in its encoding (e.g. Latin-1 bytes in a file read as UTF-8).";
    XML_TOO_LARGE, Error, "The manifest file is larger than the 16 MiB readers accept; refused before parsing.";
    XML_LIMIT_EXCEEDED, Error, "An element has more than 256 attributes (refused before parsing: checking them costs quadratic time).";
    ROOT_NOT_PANORAMA = "MANIFEST_ROOT_NOT_PANORAMA", Error, "The root element is not `<Panorama>` (without namespace).";
    VERSION_UNSUPPORTED = "MANIFEST_VERSION_UNSUPPORTED", Error, "The `version` attribute of `<Panorama>` is not a POMC 1 version (`1` or `1.x`).";
    UNKNOWN_ELEMENT = "MANIFEST_UNKNOWN_ELEMENT", Warning, "An element this version does not define; it is ignored (forward compatibility).";
    UNKNOWN_ATTRIBUTE = "MANIFEST_UNKNOWN_ATTRIBUTE", Warning, "An attribute this version does not define; it is ignored (forward compatibility).";
    MISSING_ATTRIBUTE = "MANIFEST_MISSING_ATTRIBUTE", Error, "A required attribute is absent (or only one of a pair such as width/height is given).";
    NUMBER_INVALID = "MANIFEST_NUMBER_INVALID", Error, "A numeric attribute does not parse, is not finite, is out of range, or has the wrong number of components.";
    MAPPING_MISSING = "MANIFEST_MAPPING_MISSING", Error, "There is no `<Mapping>` element.";
    MAPPING_UNKNOWN = "MANIFEST_MAPPING_UNKNOWN", Error, "`<Mapping type>` names no known parametrisation.";
    DUPLICATE_ELEMENT = "MANIFEST_DUPLICATE_ELEMENT", Error, "An element allowed once (TransformGroup, Mapping, Freedom, Packing, Mesh) appears more than once.";
    ROTATE_AXIS_ZERO = "MANIFEST_ROTATE_AXIS_ZERO", Error, "A `<Rotate>` axis has zero length.";
    SCALE_ZERO = "MANIFEST_SCALE_ZERO", Error, "A `<Scale>` component is zero: LocalToWorld would not be invertible.";
    TRANSFORM_INVALID = "MANIFEST_TRANSFORM_INVALID", Error, "The composed LocalToWorld has an entry beyond ±1e150 (moving a point would overflow) or is not invertible, e.g. three `<Scale 1e300>` or `<Translate 1e308 0 0>`.";
    FREEDOM_INVALID = "MANIFEST_FREEDOM_INVALID", Error, "The freedom radius is not a finite number greater than 0.";
    FREEDOM_MISSING = "MANIFEST_FREEDOM_MISSING", Warning, "There is no `<Freedom>` element; the radius is taken as 0 (only the centre is guaranteed).";
    NO_LAYERS = "MANIFEST_NO_LAYERS", Error, "The panorama has no `<Layer>`.";
    TOO_MANY_LAYERS = "MANIFEST_TOO_MANY_LAYERS", Error, "The panorama has more than 1024 `<Layer>` elements; the rest are not read.";
    LAYER_NO_SOURCE = "MANIFEST_LAYER_NO_SOURCE", Error, "A `<Layer>` has neither `<Image>` nor `<Textures>`.";
    LAYER_MULTIPLE_SOURCES = "MANIFEST_LAYER_MULTIPLE_SOURCES", Error, "A `<Layer>` has more than one `<Image>`/`<Textures>`.";
    FILE_NAME_UNSAFE = "MANIFEST_FILE_NAME_UNSAFE", Error, "A file name is empty, absolute, leaves the panorama directory (`..`), or uses `\\`, `:` or control characters.";
    ROLE_UNKNOWN = "MANIFEST_ROLE_UNKNOWN", Warning, "A layer `role` is not one this version defines; the layer is read without a role.";
    DEPTH_RANGE_INVALID = "MANIFEST_DEPTH_RANGE_INVALID", Error, "A `depthrange` does not satisfy 0 < min <= max.";
    ORDER_DUPLICATE = "MANIFEST_ORDER_DUPLICATE", Warning, "Two layers declare the same `order`; their painter's order is undefined.";
    PACKING_INVALID = "MANIFEST_PACKING_INVALID", Error, "A `<Packing>` lacks `atlaswidth`/`atlasheight` or gives 0.";
    DIAGNOSTICS_TRUNCATED = "MANIFEST_DIAGNOSTICS_TRUNCATED", Info, "More findings than the reporting limit; the rest are not listed.";
}

/// Severity of a manifest code; unknown codes are errors (tests keep every emitted code in the table).
pub fn severity(code: &str) -> Severity {
    CODES.iter().find(|(c, _, _)| *c == code).map(|(_, s, _)| *s).unwrap_or(Severity::Error)
}
