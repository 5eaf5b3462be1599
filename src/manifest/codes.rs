//! The manifest's stable codes, kept as data: code, severity, meaning. The spec's table
//! (spec/02-manifest.md §2.9) is checked against [`CODES`] by a unit test, so the two cannot drift.
//! Codes never change meaning once published; new ones may be added.

use super::Severity;

/// Error: the manifest is not well-formed XML.
pub const XML_MALFORMED: &str = "XML_MALFORMED";
/// Error: the manifest has a DOCTYPE; DTDs and entity declarations are refused.
pub const XML_DTD_FORBIDDEN: &str = "XML_DTD_FORBIDDEN";
/// Error: the manifest declares or uses an encoding other than UTF-8 or ISO-8859-1.
pub const XML_ENCODING_UNSUPPORTED: &str = "XML_ENCODING_UNSUPPORTED";
/// Error: the manifest's bytes are not valid in its encoding.
pub const XML_ENCODING_INVALID: &str = "XML_ENCODING_INVALID";
/// Error: the manifest file is larger than 16 MiB; refused before parsing.
pub const XML_TOO_LARGE: &str = "XML_TOO_LARGE";
/// Error: an element has more than 256 attributes; refused before parsing.
pub const XML_LIMIT_EXCEEDED: &str = "XML_LIMIT_EXCEEDED";
/// Error: the root element is not `<Panorama>` without namespace.
pub const ROOT_NOT_PANORAMA: &str = "MANIFEST_ROOT_NOT_PANORAMA";
/// Error: `<Panorama version>` is not `1` or `1.x`.
pub const VERSION_UNSUPPORTED: &str = "MANIFEST_VERSION_UNSUPPORTED";
/// Warning: an element POMC 1 does not define here; it is ignored.
pub const UNKNOWN_ELEMENT: &str = "MANIFEST_UNKNOWN_ELEMENT";
/// Warning: an attribute POMC 1 does not define on its element; it is ignored.
pub const UNKNOWN_ATTRIBUTE: &str = "MANIFEST_UNKNOWN_ATTRIBUTE";
/// Error: a required attribute is absent, or only one of a pair such as width/height is given.
pub const MISSING_ATTRIBUTE: &str = "MANIFEST_MISSING_ATTRIBUTE";
/// Error: a numeric attribute is unparsable, non-finite, out of range or has the wrong number of parts.
pub const NUMBER_INVALID: &str = "MANIFEST_NUMBER_INVALID";
/// Error: there is no `<Mapping>` element.
pub const MAPPING_MISSING: &str = "MANIFEST_MAPPING_MISSING";
/// Error: `<Mapping type>` names no known parametrisation.
pub const MAPPING_UNKNOWN: &str = "MANIFEST_MAPPING_UNKNOWN";
/// Error: an element allowed once (TransformGroup, Mapping, Freedom, Packing, Mesh) repeats.
pub const DUPLICATE_ELEMENT: &str = "MANIFEST_DUPLICATE_ELEMENT";
/// Error: a `<Rotate>` axis has zero length.
pub const ROTATE_AXIS_ZERO: &str = "MANIFEST_ROTATE_AXIS_ZERO";
/// Error: a `<Scale>` component is zero, so LocalToWorld would not be invertible.
pub const SCALE_ZERO: &str = "MANIFEST_SCALE_ZERO";
/// Error: the composed LocalToWorld has an entry beyond ±1e150 or is not invertible.
pub const TRANSFORM_INVALID: &str = "MANIFEST_TRANSFORM_INVALID";
/// Error: `<Freedom radius>` is not a finite number of metres greater than 0.
pub const FREEDOM_INVALID: &str = "MANIFEST_FREEDOM_INVALID";
/// Warning: there is no `<Freedom>` element; the radius is taken as 0.
pub const FREEDOM_MISSING: &str = "MANIFEST_FREEDOM_MISSING";
/// Error: the panorama has no `<Layer>`.
pub const NO_LAYERS: &str = "MANIFEST_NO_LAYERS";
/// Error: more than 1024 `<Layer>` elements; the rest are not read.
pub const TOO_MANY_LAYERS: &str = "MANIFEST_TOO_MANY_LAYERS";
/// Error: a `<Layer>` has neither `<Image>` nor `<Textures>`.
pub const LAYER_NO_SOURCE: &str = "MANIFEST_LAYER_NO_SOURCE";
/// Error: a `<Layer>` has more than one `<Image>`/`<Textures>`.
pub const LAYER_MULTIPLE_SOURCES: &str = "MANIFEST_LAYER_MULTIPLE_SOURCES";
/// Error: a file name is empty, absolute, leaves the directory via `..`, or uses `\`, `:` or control chars.
pub const FILE_NAME_UNSAFE: &str = "MANIFEST_FILE_NAME_UNSAFE";
/// Warning: a layer `role` POMC 1 does not define; the layer is read without a role.
pub const ROLE_UNKNOWN: &str = "MANIFEST_ROLE_UNKNOWN";
/// Error: a `depthrange` does not satisfy 0 < min <= max.
pub const DEPTH_RANGE_INVALID: &str = "MANIFEST_DEPTH_RANGE_INVALID";
/// Warning: two layers declare the same `order`; their painter's order is undefined.
pub const ORDER_DUPLICATE: &str = "MANIFEST_ORDER_DUPLICATE";
/// Error: a `<Packing>` lacks `atlaswidth`/`atlasheight` or gives 0.
pub const PACKING_INVALID: &str = "MANIFEST_PACKING_INVALID";
/// Info: more findings than the reporting limit; the rest are not listed.
pub const DIAGNOSTICS_TRUNCATED: &str = "MANIFEST_DIAGNOSTICS_TRUNCATED";

/// The manifest's validation codes: code, severity, meaning (spec/02-manifest.md lists them).
pub const CODES: &[(&str, Severity, &str)] = &[
    (XML_MALFORMED, Severity::Error, "The manifest is not well-formed XML."),
    (XML_DTD_FORBIDDEN, Severity::Error, "The manifest has a DOCTYPE (DTD); DTDs and entity declarations are refused."),
    (XML_ENCODING_UNSUPPORTED, Severity::Error, "The manifest declares or uses an encoding other than UTF-8 or ISO-8859-1 (e.g. UTF-16)."),
    (XML_ENCODING_INVALID, Severity::Error, "The manifest's bytes are not valid in its encoding (e.g. Latin-1 bytes in a file read as UTF-8)."),
    (XML_TOO_LARGE, Severity::Error, "The manifest file is larger than the 16 MiB readers accept; refused before parsing."),
    (XML_LIMIT_EXCEEDED, Severity::Error, "An element has more than 256 attributes (refused before parsing: checking them costs quadratic time)."),
    (ROOT_NOT_PANORAMA, Severity::Error, "The root element is not `<Panorama>` (without namespace)."),
    (VERSION_UNSUPPORTED, Severity::Error, "The `version` attribute of `<Panorama>` is not a POMC 1 version (`1` or `1.x`)."),
    (UNKNOWN_ELEMENT, Severity::Warning, "An element this version does not define; it is ignored (forward compatibility)."),
    (UNKNOWN_ATTRIBUTE, Severity::Warning, "An attribute this version does not define; it is ignored (forward compatibility)."),
    (MISSING_ATTRIBUTE, Severity::Error, "A required attribute is absent (or only one of a pair such as width/height is given)."),
    (NUMBER_INVALID, Severity::Error, "A numeric attribute does not parse, is not finite, is out of range, or has the wrong number of components."),
    (MAPPING_MISSING, Severity::Error, "There is no `<Mapping>` element."),
    (MAPPING_UNKNOWN, Severity::Error, "`<Mapping type>` names no known parametrisation."),
    (DUPLICATE_ELEMENT, Severity::Error, "An element allowed once (TransformGroup, Mapping, Freedom, Packing, Mesh) appears more than once."),
    (ROTATE_AXIS_ZERO, Severity::Error, "A `<Rotate>` axis has zero length."),
    (SCALE_ZERO, Severity::Error, "A `<Scale>` component is zero: LocalToWorld would not be invertible."),
    (TRANSFORM_INVALID, Severity::Error, "The composed LocalToWorld has an entry beyond ±1e150 (moving a point would overflow) or is not invertible, e.g. three `<Scale 1e300>` or `<Translate 1e308 0 0>`."),
    (FREEDOM_INVALID, Severity::Error, "The freedom radius is not a finite number greater than 0."),
    (FREEDOM_MISSING, Severity::Warning, "There is no `<Freedom>` element; the radius is taken as 0 (only the centre is guaranteed)."),
    (NO_LAYERS, Severity::Error, "The panorama has no `<Layer>`."),
    (TOO_MANY_LAYERS, Severity::Error, "The panorama has more than 1024 `<Layer>` elements; the rest are not read."),
    (LAYER_NO_SOURCE, Severity::Error, "A `<Layer>` has neither `<Image>` nor `<Textures>`."),
    (LAYER_MULTIPLE_SOURCES, Severity::Error, "A `<Layer>` has more than one `<Image>`/`<Textures>`."),
    (FILE_NAME_UNSAFE, Severity::Error, "A file name is empty, absolute, leaves the panorama directory (`..`), or uses `\\`, `:` or control characters."),
    (ROLE_UNKNOWN, Severity::Warning, "A layer `role` is not one this version defines; the layer is read without a role."),
    (DEPTH_RANGE_INVALID, Severity::Error, "A `depthrange` does not satisfy 0 < min <= max."),
    (ORDER_DUPLICATE, Severity::Warning, "Two layers declare the same `order`; their painter's order is undefined."),
    (PACKING_INVALID, Severity::Error, "A `<Packing>` lacks `atlaswidth`/`atlasheight` or gives 0."),
    (DIAGNOSTICS_TRUNCATED, Severity::Info, "More findings than the reporting limit; the rest are not listed."),
];

/// Severity of a manifest code; unknown codes are errors (tests keep every emitted code in the table).
pub fn severity(code: &str) -> Severity {
    CODES.iter().find(|(c, _, _)| *c == code).map(|(_, s, _)| *s).unwrap_or(Severity::Error)
}
