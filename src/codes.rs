//! The validator's stable codes as typed constants and as data ([`CODES`]: code, severity,
//! meaning, like glTF-Validator), with the one [`Severity`]. They sit below every module that
//! raises them (layer files, packing, panoramas, stored meshes, the validator), with the
//! manifest's ([`manifest`]) and the jobs' errors and warnings; [`all`] lists every one.

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

/// Declares each code once: a constant per code (its meaning as the doc) and the table `$table`
/// of `(code, severity, meaning)`. `NAME = "CODE"` when the constant's name is not the code.
macro_rules! declare_codes {
    ($(#[$doc:meta])* $table:ident; $($name:ident $(= $code:literal)?, $sev:ident, $meaning:literal;)*) => {
        $( $crate::codes::declare_codes!(@const $name $(= $code)?, $meaning); )*
        $(#[$doc])*
        pub const $table: &[(&str, $crate::codes::Severity, &str)] =
            &[$(($name, $crate::codes::Severity::$sev, $meaning)),*];
    };
    (@const $name:ident = $code:literal, $meaning:literal) => {
        #[doc = $meaning]
        pub const $name: &str = $code;
    };
    (@const $name:ident, $meaning:literal) => {
        #[doc = $meaning]
        pub const $name: &str = stringify!($name);
    };
}
pub(crate) use declare_codes;

/// An error enum's `code()`, declared once: each variant's code (a constant of this module), and
/// after `; from` the variants that keep the code of the error in their field `0` or `source`.
macro_rules! error_codes {
    ($ty:ident: $($v:ident $code:ident),* $(; from $($dv:ident . $f:tt),*)?) => {
        impl $ty {
            /// Stable machine-readable code (declared in [`crate::codes`]).
            pub fn code(&self) -> &'static str {
                match self {
                    $( $ty::$v { .. } => $crate::codes::$code, )*
                    $($( $ty::$dv { $f: e, .. } => e.code(), )*)?
                }
            }
        }

        impl From<$ty> for $crate::Error {
            fn from(e: $ty) -> Self {
                $crate::Error::new(e.code(), e)
            }
        }
    };
}
pub(crate) use error_codes;

/// The manifest's codes (spec/02-manifest.md §2.9), re-exported as [`crate::manifest::CODES`].
pub mod manifest {
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
}

declare_codes! {
    /// Codes raised on layer files, pixels, patch tables and the panorama as a whole.
    CODES;
    MANIFEST_IO_ERROR, Error, "The manifest exists but cannot be read (permissions, not a regular file, an I/O error).";
    LAYER_NOT_FOUND, Error, "A layer file named in the manifest does not exist.";
    LAYER_PATH_ESCAPES, Error, "A layer file path leaves the panorama directory (absolute, `..`, or a symbolic link out).";
    LAYER_IO_ERROR, Error, "A layer file exists but cannot be read (permissions, I/O error).";
    LAYER_UNREADABLE, Error, "A layer file is not a readable single-part scanline or tiled OpenEXR (or image) file.";
    LAYER_TRUNCATED, Error, "A layer file ends before its data does.";
    LAYER_TOO_LARGE, Error, "A layer file declares more pixels than the reader limits; refused before decoding.";
    LAYER_MULTIPART, Error, "A layer EXR has several parts; POMC 1 layers are single-part.";
    LAYER_DEEP, Error, "A layer EXR holds deep data.";
    LAYER_UNSUPPORTED, Error, "A layer file uses a feature this reader does not support.";
    LAYER_DEPTH_NOT_FLOAT32, Error, "The depth channel Z is not stored as 32-bit float.";
    LAYER_DEPTH_LOSSY, Error, "The layer file uses a lossy compression (PXR24, B44, B44A, DWAA, DWAB); spec §4 forbids it for depth.";
    LAYER_SIZE_MISMATCH, Error, "A layer's stored size disagrees with the manifest (width/height or the packing atlas) or with its other files.";
    LAYER_NO_DEPTH, Error, "A layer has no depth channel.";
    LAYER_DIMENSIONS_MAPPING, Error, "A layer canvas does not fit the mapping (2:1 equirect; 3:2 cube with square faces).";
    LAYER_EMPTY, Warning, "A layer has no pixel inside its domain: it should not be in the file.";
    CHANNELS_INCOMPLETE, Error, "Only some of R,G,B or of N.X,N.Y,N.Z are present.";
    DEPTH_NEGATIVE_IN_DOMAIN, Error, "Negative depth at pixels the coverage channel A puts inside the domain.";
    DEPTH_ZERO_IN_DOMAIN, Error, "Depth 0 inside the domain (no surface lies at the centre).";
    DEPTH_UNKNOWN_IN_DOMAIN, Warning, "NaN (unknown) depth inside the domain.";
    DEPTH_OUT_OF_RANGE, Warning, "Depths outside the layer's declared depth range.";
    DEPTH_DISCONTINUITY, Warning, "Neighbouring pixels of one layer jump in depth by more than the threshold: a layer must be continuous.";
    MASK_OUT_OF_RANGE, Error, "Coverage A outside [0, 1] or NaN.";
    MASK_DEPTH_DISAGREE, Warning, "A = 0 (outside) but the depth is a non-negative distance.";
    COLOUR_NOT_FINITE, Warning, "NaN or infinite colour inside the domain.";
    NORMALS_NOT_UNIT, Warning, "Normals inside the domain whose length is not 1.";
    COVERAGE_INCOMPLETE, Error, "The union of the layer domains does not cover the whole sphere.";
    PATCH_EMPTY, Error, "A patch has zero width or height.";
    PATCH_OUT_OF_CANVAS, Error, "A patch extends past the layer's full canvas.";
    PATCH_OUT_OF_ATLAS, Error, "A patch extends past the atlas.";
    PATCH_OVERLAP_ATLAS, Error, "Two patches overlap in the atlas.";
    PATCH_OVERLAP_CANVAS, Error, "Two patches overlap in the canvas.";
    PATCH_CANVAS_UNDECLARED, Error, "A packed layer does not declare its full canvas width and height.";
    MESH_NOT_FOUND, Warning, "A stored mesh (`<Mesh file>`) does not exist; readers rebuild the mesh from the layer.";
    MESH_UNREADABLE, Warning, "A stored mesh cannot be used: it leaves the panorama directory, is too large, or does not decode against its layer (spec §8.4); readers rebuild it.";
    MESH_ENCODING_UNKNOWN, Info, "A `<Mesh>` uses an encoding or version this reader does not know; it is kept and ignored.";
}

declare_codes! {
    /// Codes of the errors a job returns ([`crate::Error::code`]) and the command line adds: the
    /// call failed and wrote nothing. Layer-file and patch errors use the validator's codes above.
    ERRORS;
    IO_ERROR, Error, "A file system operation failed (the message names the path).";
    OUTPUT_NOT_DIRECTORY, Error, "The output path exists and is not a directory.";
    PANORAMA_NOT_FOUND, Error, "The path is neither a manifest file nor a directory holding `panorama.xml`.";
    PANORAMA_NO_SUCH_LAYER, Error, "A layer index with no layer, or (writing) layer images and `<Layer>`s differ in number.";
    INPUT_UNREADABLE, Error, "A PNG/JPEG/HDR input cannot be opened or decoded (or a JPEG is truncated).";
    INPUT_TOO_LARGE, Error, "An input image declares more pixels than the read limits; refused before decoding.";
    INPUT_NOT_PANORAMA, Error, "The canvas is neither 2:1 (equirect) nor 3:2 with square faces (cube).";
    INPUT_NO_DEPTH, Error, "A depth EXR has none of `Z`, `Y`, `R`, `depth`, `D` and more than one channel.";
    INPUT_SIZE_MISMATCH, Error, "Colour, depth or normals differ in shape in a way that cannot be resampled (another mapping, another aspect).";
    INPUT_DEPTH_SCALE_NEEDED, Error, "Integer depth without a unit: give `--depth-scale`, `--preset`, `--known-distance` or `--camera-height`.";
    INPUT_Z_DEPTH_EQUIRECT, Error, "Planar z-depth was given for an equirect, which has no image plane.";
    INPUT_DEPTH_8BIT, Error, "8-bit or JPEG depth without an explicit `--depth-kind`: such maps are nearness, not distance.";
    INPUT_NOT_DEPTH, Error, "The file cannot be depth (a colour image, no variation, values no depth kind allows).";
    INPUT_DEPTH_RELATIVE, Error, "Relative depth (inverse, nearness) without a way to its scale: give a range, the camera height or a known distance.";
    INPUT_NO_FLOOR, Error, "`--camera-height` was given but no floor was found below the camera.";
    INPUT_PRESET_MISMATCH, Error, "The dataset preset does not match the file (a float EXR under an integer-unit preset).";
    INPUT_DEPTH_EMPTY, Error, "The depth has no valid pixel, or too few (under 0.1 %) to complete the rest from; `--unknown-depth sky` when the unknown depth is the sky.";
    INPUT_DEPTH_NOT_POSITIVE, Error, "Every metric depth value is zero or negative (depth stored negated, or another kind).";
    INPUT_BAD_OPTION, Error, "A build or preparation setting is out of its range, or settings contradict each other.";
    BUILD_BAD_RADIUS, Error, "The freedom radius is not positive and finite.";
    BUILD_SIZE_MISMATCH, Error, "A colour plane or the depth does not hold one sample per canvas pixel.";
    SCENE_UNREADABLE, Error, "A scene file (glTF, GLB, OBJ) or one of its textures cannot be read or parsed.";
    SCENE_UNSUPPORTED, Error, "The scene file's extension is not .gltf, .glb or .obj.";
    SCENE_EMPTY, Error, "The scene has no triangles.";
    SCENE_TOO_LARGE, Error, "The scene has more triangles than `--max-triangles`; refused before tracing.";
    SCENE_BAD_OPTION, Error, "A scene setting is out of its range (width, samples, freedom radius, centre, sky map shape).";
    PACK_PADDING_TOO_LARGE, Error, "The packing padding is above its maximum.";
    LAYOUT_UNKNOWN, Error, "A cube layout name no layout has.";
    LAYOUT_BAD_SIZE, Error, "An image size that is not a cube of the layout (3:2 with square faces, or the layout's shape).";
    RESAMPLE_BAD_SIZE, Error, "The target size is 0, or odd for an equirect.";
    RESAMPLE_CHANNEL_SIZE, Error, "A channel's sample count is not width × height.";
    RESAMPLE_NOT_EQUIRECT, Error, "A source read as equirect is not 2H × H.";
    RESAMPLE_NO_CHANNELS, Error, "The source image has no channels.";
    RESAMPLE_NO_SUCH_CHANNEL, Error, "The depth or coverage channel index is not below the channel count.";
    RESAMPLE_OUTPUT_LENGTH, Error, "The output slice's length differs from the channel count.";
    RESAMPLE_TOO_LARGE, Error, "An image has too many samples to allocate.";
    RESAMPLE_UNSUPPORTED, Error, "Internal: a buffer whose length does not match its canvas (not expected from public calls).";
    MESH_CANVAS_MISMATCH, Error, "A layer's size differs from the mapping's canvas size.";
    MESH_ENCODING_INVALID, Error, "A `.pomcmesh` file has a bad magic, version or payload, or was made for another canvas or layer.";
    MESH_EXPORT_FAILED, Error, "Writing PLY, OBJ or glTF failed: no triangles, unknown extension, too large, or encoding.";
    MESH_NO_DEPTH, Error, "The layer has no depth channel `Z` to mesh.";
    MESH_PARAMS_INVALID, Error, "A mesh parameter or the sky radius is non-finite or out of range.";
    RENDER_BAD_CAMERA, Error, "A camera input is non-finite, the field of view is outside (0, 180)°, the look-at point is the eye, the transform is not invertible, or stereo eyes sit beyond the freedom radius (`--ipd` over twice it).";
    RENDER_BAD_OPTIONS, Error, "A splat or mesh render option is out of range, or meshes and layers differ in number.";
    RENDER_BAD_SIZE, Error, "The output size is zero or too large, or an equirect output is not 2:1.";
    RENDER_CAMERA_PATH, Error, "A camera path cannot be read or has a malformed line or no frames, or an output name has no run of `#` for its frame numbers.";
    RENDER_LAYER_CHANNEL, Error, "A layer lacks one of the channels rendering needs (R, G, B, Z).";
    RENDER_LAYER_SIZE, Error, "A layer's size is not a valid canvas of the panorama's mapping.";
    RENDER_MESH, Error, "A layer could not be meshed, or a given mesh does not belong to its layer.";
    RENDER_NO_LAYERS, Error, "The panorama declares no layer.";
    RENDER_OUTPUT_FORMAT, Error, "The output file's extension is not one the writer supports.";
    IMAGE_IO, Error, "Opening, reading or writing a plain image failed (or it is not a regular file).";
    IMAGE_ENCODE, Error, "The encoder failed to produce an image's bytes.";
    IMAGE_TOO_LARGE, Error, "An image declares more pixels than the read limits; refused before decoding.";
    IMAGE_UNREADABLE, Error, "An image cannot be decoded (corrupt data, an EXR without parts or channels).";
    IMAGE_UNSUPPORTED, Error, "The decoder does not support the file's format or a feature of it.";
    IMAGE_UNKNOWN_FORMAT, Error, "An image output's extension is not .png, .jpg/.jpeg, .exr or .hdr.";
    CONVERT_TOO_LARGE, Error, "A conversion's output would have more pixels than readers accept; refused before resampling.";
    CONVERT_USAGE, Error, "A conversion was asked that cannot be made (an output extension, a mapping or options that do not fit).";
    CONVERT_NOT_FOUND, Error, "A file to convert does not exist.";
    CLI_USAGE, Error, "The command line could not be parsed, or a value is out of its range.";
    VIEW_SERVE_FAILED, Error, "The viewer's local web server could not start.";
    POMC_ERROR, Error, "Python batch: an item failed with an exception that carries no pomc code.";
    BATCH_ITEM_FAILED, Error, "Python batch: an item's worker returned a failure without a code.";
    BATCH_WORKER_LOST, Error, "Python batch: the Dask worker running an item was lost.";
}

declare_codes! {
    /// Codes of the warnings a job gives while it succeeds (printed as `warning[CODE]`, listed in
    /// the report): the input is suspicious and what was assumed is said.
    WARNINGS;
    INPUT_DEPTH_SENTINEL, Warning, "Float depth holds values of 1e7 m and more (a no-measurement sentinel): taken as unknown.";
    INPUT_DEPTH_MOSTLY_UNKNOWN, Warning, "Most pixels have no depth; what was made of them (sky, completion) is said.";
    INPUT_DEPTH_SOFT, Warning, "The depth's edges are spread over many pixels and stay so (`--refine off`, or depth soft everywhere, which `auto` leaves): objects stay joined to what is behind them.";
}

/// Every code pomc can give, with its severity and meaning: the manifest's and the validator's
/// findings ([`findings`]), then the errors ([`ERRORS`]) and warnings ([`WARNINGS`]) of jobs.
pub fn all() -> Vec<(&'static str, Severity, &'static str)> {
    manifest::CODES.iter().chain(CODES).chain(ERRORS).chain(WARNINGS).copied().collect()
}

/// Every code `validate` can report: the manifest's and the validator's own (`pomc validate
/// --list-codes`).
pub fn findings() -> Vec<(&'static str, Severity, &'static str)> {
    manifest::CODES.iter().chain(CODES).copied().collect()
}

/// Severity of a code; an unknown code is an error (a test keeps every emitted code declared).
pub fn severity(code: &str) -> Severity {
    [manifest::CODES, CODES, ERRORS, WARNINGS]
        .into_iter()
        .flatten()
        .find(|(c, _, _)| *c == code)
        .map_or(Severity::Error, |(_, s, _)| *s)
}

/// The table of [`all`] codes as Markdown (`pomc codes --markdown`; spec/10-codes.md is this text).
pub fn markdown() -> String {
    let mut s = String::from(
        "# 10. Codes\n\nEvery code pomc gives, generated from the one table in `src/codes.rs` \
         (`pomc codes --markdown > spec/10-codes.md`; a test keeps the two equal). Findings of \
         `validate` have the severity shown; then come the errors a command or library call returns \
         when it fails (exit status 2, nothing written) and the warnings it gives while it succeeds.\n",
    );
    for (title, table) in [
        ("Manifest findings (§2.9)", manifest::CODES),
        ("Layer, pixel, packing and mesh findings (§6)", CODES),
        ("Errors of jobs and commands", ERRORS),
        ("Warnings of jobs", WARNINGS),
    ] {
        s.push_str(&format!("\n## {title}\n\n| code | severity | meaning |\n|---|---|---|\n"));
        for (c, sev, m) in table {
            s.push_str(&format!("| `{c}` | {} | {} |\n", sev.as_str(), m.replace('|', "\\|")));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_is_declared_once() {
        let codes = all();
        for (i, (c, _, _)) in codes.iter().enumerate() {
            assert!(codes[i + 1..].iter().all(|(d, _, _)| d != c), "{c} declared twice");
        }
    }

    /// spec/10-codes.md is the generated table, so a declared code is documented.
    #[test]
    fn the_spec_lists_every_code() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/spec/10-codes.md");
        let spec = std::fs::read_to_string(path).unwrap_or_default();
        assert!(
            spec == markdown(),
            "spec/10-codes.md is stale: run `pomc codes --markdown > spec/10-codes.md`"
        );
    }

    /// No code is written as a string literal outside this table: a code is used only through
    /// its constant, so a code used is a code declared.
    #[test]
    fn codes_are_used_through_their_constants() {
        let root = env!("CARGO_MANIFEST_DIR");
        let declared: Vec<&str> = all().iter().map(|c| c.0).collect();
        let mut stack: Vec<std::path::PathBuf> =
            ["src", "cli/src", "cli/flags/src", "python/src", "python/pomc"]
                .iter()
                .map(|d| std::path::Path::new(root).join(d))
                .collect();
        while let Some(p) = stack.pop() {
            if p.is_dir() {
                stack.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
                continue;
            }
            if p.extension().is_some_and(|e| e == "py") {
                python_codes_are_declared(&p, &declared);
                continue;
            }
            if p.extension().is_none_or(|e| e != "rs") || p.ends_with("codes.rs") {
                continue;
            }
            let text = std::fs::read_to_string(&p).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.trim_start();
                if code.starts_with("//") || code.starts_with("assert") {
                    continue;
                }
                for lit in line.split('"').skip(1).step_by(2) {
                    assert!(
                        !declared.contains(&lit),
                        "{}:{}: code {lit} written as a literal; use pomc::codes::{lit}",
                        p.display(),
                        n + 1
                    );
                }
            }
        }
    }

    /// Python cannot use the constants: a code it names on a line about a code must be declared.
    fn python_codes_are_declared(path: &std::path::Path, declared: &[&str]) {
        let text = std::fs::read_to_string(path).unwrap();
        for (n, line) in text.lines().enumerate().filter(|(_, l)| l.contains("code")) {
            for lit in line.split('"').skip(1).step_by(2) {
                let code_like = lit.len() > 3
                    && lit.contains('_')
                    && lit.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
                assert!(
                    !code_like || declared.contains(&lit),
                    "{}:{}: code {lit} is not declared",
                    path.display(),
                    n + 1
                );
            }
        }
    }
}
