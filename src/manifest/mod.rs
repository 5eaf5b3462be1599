//! The XML manifest `panorama.xml` (spec/02-manifest.md).
//!
//! Two entry points: [`parse`] (first fatal error, for readers) and [`diagnose`] (every problem
//! with line:col and element path, for the validator). [`Manifest::to_xml`] writes it back.
//! One concept per submodule (codes in [`crate::codes::manifest`]): `decode` (bytes to text), `read` and
//! `read_layer` (the tree walk), `number`, `file_name`, `transform` (LocalToWorld), `write`.

mod decode;
mod diag;
mod element;
mod file_name;
mod number;
mod read;
mod read_layer;
mod transform;
mod write;

use glam::{DMat4, DVec3};

use crate::codes::manifest as codes;
use crate::pack::Patch;

pub use crate::codes::manifest::CODES;
pub use diag::MAX_DIAGNOSTICS;
pub use transform::centre;
pub(crate) use transform::compose;
pub use write::escape_attr;

pub use crate::codes::Severity;

/// A position in the manifest source: 1-based line and column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pos {
    /// Line number, from 1; lines end at LF.
    pub line: u32,
    /// Column in characters (not bytes), from 1.
    pub col: u32,
}

/// Where an element came from: its position and element path such as `/Panorama/Layer[2]/Textures`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Origin {
    /// Where the element's start tag begins.
    pub pos: Pos,
    /// Element path, with `[k]` (1-based) only where a name repeats among siblings.
    pub path: String,
}

/// Source origins of a layer's parts (for diagnostics that come after parsing).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LayerOrigin {
    /// The `<Layer>` element itself.
    pub layer: Origin,
    /// One per patch of the packing table, in order.
    pub patches: Vec<Origin>,
}

/// The parametrisation declared by `<Mapping type=…>`: the canvas's own kind (one enum for the
/// declaration and the maths).
pub use crate::mapping::MappingKind;

impl MappingKind {
    /// The name written by [`Manifest::to_xml`]: `LatLongMapping` (also read: `Equirect`,
    /// `EquirectMapping`) or `CubeMapping` (also read: `Cube`, `Cube3x2`).
    pub fn primary_name(self) -> &'static str {
        match self {
            MappingKind::Equirect => "LatLongMapping",
            MappingKind::Cube3x2 => "CubeMapping",
        }
    }
}

/// `<Mapping>`.
#[derive(Clone, Debug, PartialEq)]
pub struct MappingDecl {
    /// The parametrisation named by the `type` attribute.
    pub kind: MappingKind,
}

/// One operation of `<TransformGroup>`, in document order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Transform {
    /// `<Translate vector>`: translation by (x, y, z), metres.
    Translate([f64; 3]),
    /// Axis (need not be unit) and angle in degrees, right-handed.
    Rotate {
        /// `axis` attribute: the rotation axis, not all zero.
        axis: [f64; 3],
        /// `angle` attribute, degrees.
        angle_deg: f64,
    },
    /// `<Scale vector>`: per-axis factors, none zero; negative factors mirror.
    Scale([f64; 3]),
}

/// What a layer holds (spec §2, `role` attribute).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// `background`: the scene's enclosing background.
    Background,
    /// `object`: a foreground object.
    Object,
    /// `floor`: a floor surface.
    Floor,
    /// `ceiling`: a ceiling surface.
    Ceiling,
    /// `wall`: a wall surface.
    Wall,
    /// `infinity`: direction-only content beyond d_dirmin (sky, far scenery).
    Infinity,
    /// `light`: a light source.
    Light,
}

impl Role {
    /// The `role` attribute value, e.g. `"background"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Background => "background",
            Role::Object => "object",
            Role::Floor => "floor",
            Role::Ceiling => "ceiling",
            Role::Wall => "wall",
            Role::Infinity => "infinity",
            Role::Light => "light",
        }
    }
}

/// Where a layer's pixels are stored.
#[derive(Clone, Debug, PartialEq)]
pub enum LayerSource {
    /// POMC 1 native: one EXR (`<Image file=…>`).
    Native {
        /// `file` attribute: the EXR's path relative to the panorama directory.
        file: String,
    },
    /// The thesis form: `<Textures mapname depthname normals>`; `normals=""` means none.
    Thesis {
        /// `mapname` attribute: the colour image (PNG, JPEG, …), relative path.
        mapname: String,
        /// `depthname` attribute: the floating-point depth image, relative path.
        depthname: String,
        /// `normals` attribute: the normals image; `None` when absent or empty.
        normals: Option<String>,
    },
}

/// `<Packing>`: the atlas size and the patch table (spec §5).
#[derive(Clone, Debug, PartialEq)]
pub struct Packing {
    /// `atlaswidth`: the stored atlas image's width, pixels (≥ 1; 0 only after an error).
    pub atlas_width: u32,
    /// `atlasheight`: the stored atlas image's height, pixels (≥ 1; 0 only after an error).
    pub atlas_height: u32,
    /// The `<Patch>` rows, in document order.
    pub patches: Vec<Patch>,
}

/// `<Mesh file encoding version>`: a layer's stored mesh (spec §8.1). Kept whatever its encoding;
/// readers use it only when [`MeshDecl::is_quadtree_v1`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshDecl {
    /// `file` attribute: the mesh file, relative to the panorama directory.
    pub file: String,
    /// `encoding` attribute, e.g. [`MeshDecl::QUADTREE_ENCODING`]; unknown ones are kept.
    pub encoding: String,
    /// `version` attribute of the encoding, as written (e.g. `"1"`).
    pub version: String,
}

impl MeshDecl {
    /// The encoding of spec §8.4.
    pub const QUADTREE_ENCODING: &'static str = "quadtree-bfs-zstd";

    /// A quadtree mesh (spec §8.4, version 1) stored in `file`.
    pub fn quadtree(file: &str) -> Self {
        MeshDecl {
            file: file.to_string(),
            encoding: Self::QUADTREE_ENCODING.to_string(),
            version: "1".to_string(),
        }
    }

    /// Whether this is the encoding this reader knows.
    pub fn is_quadtree_v1(&self) -> bool {
        self.encoding == Self::QUADTREE_ENCODING && self.version == "1"
    }
}

/// One `<Layer>`.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerDecl {
    /// `name` attribute: a label for people and tools; `None` when absent.
    pub name: Option<String>,
    /// `role` attribute; `None` when absent or not a POMC 1 role.
    pub role: Option<Role>,
    /// Painter's order from the centre: smaller is drawn first (farther).
    pub order: Option<u32>,
    /// The `<Image>` or `<Textures>` child holding the pixels.
    pub source: LayerSource,
    /// `width`: full canvas width, pixels (required when packed); `None` when absent.
    pub width: Option<u32>,
    /// `height`: full canvas height, pixels; given together with `width`.
    pub height: Option<u32>,
    /// Declared `[min, max]` of finite depths, metres.
    pub depth_range: Option<(f32, f32)>,
    /// `miplevels` (≥ 1): MIP levels a renderer may build or the file holds; advisory.
    pub mip_levels: Option<u32>,
    /// `<Packing>`: the stored image is an atlas of patches; `None` when stored whole.
    pub packing: Option<Packing>,
    /// `<Mesh>`: a stored mesh of the layer (spec §8.1).
    pub mesh: Option<MeshDecl>,
    /// Child elements this reader does not know, kept verbatim (their source text, entities
    /// unexpanded) and written back by [`Manifest::to_xml`]; each must be well-formed element text.
    pub extra: Vec<String>,
    /// Source positions of the layer and its patches (default when built in code).
    pub origin: LayerOrigin,
}

impl LayerDecl {
    /// A native layer stored in `file`, nothing else declared.
    pub fn native(file: &str) -> Self {
        LayerDecl {
            name: None,
            role: None,
            order: None,
            source: LayerSource::Native { file: file.to_string() },
            width: None,
            height: None,
            depth_range: None,
            mip_levels: None,
            packing: None,
            mesh: None,
            extra: Vec::new(),
            origin: LayerOrigin::default(),
        }
    }

    /// The declared canvas size, when both width and height are given.
    pub fn size(&self) -> Option<(u32, u32)> {
        Some((self.width?, self.height?))
    }
}

/// A parsed manifest.
#[derive(Clone, Debug, PartialEq)]
pub struct Manifest {
    /// `version` attribute of `<Panorama>`; "1" when absent (the thesis form).
    pub version: String,
    /// `<TransformGroup>` operations in document order; empty means identity.
    pub transforms: Vec<Transform>,
    /// `<Mapping>`: the parametrisation shared by all layers.
    pub mapping: MappingDecl,
    /// Freedom radius, metres.
    pub freedom_radius: f64,
    /// The `<Layer>` elements in document order (index = layer number).
    pub layers: Vec<LayerDecl>,
}

impl Manifest {
    /// Layer `k`'s `name`, or `layer{k}` when it has none (or there is no layer `k`): what reports,
    /// exports and the viewer call it.
    pub fn layer_name(&self, k: usize) -> String {
        self.layers.get(k).and_then(|d| d.name.clone()).unwrap_or_else(|| format!("layer{k}"))
    }

    /// The 4×4 LocalToWorld matrix: `Op1 · Op2 · … · Opn` in document order, so the operation
    /// listed last is applied to points first (spec §2.4).
    pub fn local_to_world(&self) -> DMat4 {
        transform::compose(&self.transforms)
    }

    /// The panorama centre in the world: the default eye.
    pub fn centre(&self) -> DVec3 {
        transform::centre(self.local_to_world())
    }

    /// How far `eye` (world) is from the centre, in the panorama's own frame, where the freedom
    /// radius is measured.
    pub fn eye_offset(&self, eye: DVec3) -> f64 {
        self.local_to_world().inverse().transform_point3(eye).length()
    }

    /// Whether views from `eye` (world) are inside the freedom radius, where the layers promise
    /// no holes (with a relative tolerance of 1e-9 for eyes placed exactly on it).
    pub fn inside_freedom(&self, eye: DVec3) -> bool {
        self.eye_offset(eye) <= self.freedom_radius * (1.0 + 1e-9)
    }

    /// The world direction of the centre of the panorama image (azimuth 180°, local −X), where
    /// `render` and the viewer look by default; +X, azimuth 0, is the image's left/right seam.
    pub fn default_look(&self) -> DVec3 {
        self.local_to_world().transform_vector3(DVec3::NEG_X).normalize_or(DVec3::NEG_X)
    }

    /// Layer indices in painter's order (spec §2: smaller `order` first, i.e. farthest first; layers
    /// without `order` after those with one, in document order).
    pub fn painter_order(&self) -> Vec<usize> {
        let mut k: Vec<usize> = (0..self.layers.len()).collect();
        k.sort_by_key(|&i| self.layers[i].order.unwrap_or(u32::MAX));
        k
    }

    /// Serialise as POMC 1 XML (UTF-8, `version="1"`); thesis-form layers stay `<Textures>`.
    pub fn to_xml(&self) -> String {
        write::to_xml(self)
    }

    /// Forget where each part came from, e.g. to compare a manifest with a re-parsed copy.
    pub fn clear_origins(&mut self) {
        for l in &mut self.layers {
            l.origin = LayerOrigin::default();
        }
    }
}

/// One finding of [`diagnose`].
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Stable code from [`CODES`], e.g. `MANIFEST_NUMBER_INVALID`.
    pub code: &'static str,
    /// The code's severity.
    pub severity: Severity,
    /// What is wrong and how to fix it, for people.
    pub message: String,
    /// Source line, from 1.
    pub line: u32,
    /// Source column in characters, from 1.
    pub col: u32,
    /// Element path, e.g. `/Panorama/Layer[2]/Textures`.
    pub path: String,
}

/// Every diagnostic, plus the manifest when it has no error.
#[derive(Clone, Debug, Default)]
pub struct Diagnosed {
    /// Findings in the order found: at most [`MAX_DIAGNOSTICS`], then a `DIAGNOSTICS_TRUNCATED` note.
    pub diagnostics: Vec<Diagnostic>,
    /// The parsed manifest; `None` when any diagnostic is an error.
    pub manifest: Option<Manifest>,
}

/// The first error of [`diagnose`], as an error value.
#[derive(Debug, thiserror::Error)]
#[error("{file}:{line}:{col} {path}: {message}")]
pub struct ManifestError {
    /// Stable code from [`CODES`] (`XML_MALFORMED` when no error diagnostic was produced).
    pub code: &'static str,
    /// The file name given to [`parse`], for the message.
    pub file: String,
    /// Source line, from 1.
    pub line: u32,
    /// Source column in characters, from 1.
    pub col: u32,
    /// Element path, e.g. `/Panorama/Layer[2]/Textures`.
    pub path: String,
    /// What is wrong and how to fix it.
    pub message: String,
}

impl From<ManifestError> for crate::Error {
    fn from(e: ManifestError) -> Self {
        crate::Error::new(e.code(), e)
    }
}

impl ManifestError {
    /// The stable code of the error, as in [`CODES`].
    pub fn code(&self) -> &'static str {
        self.code
    }
}

/// Check a manifest's bytes, collecting every problem (at most [`MAX_DIAGNOSTICS`] listed).
/// Never panics, whatever the bytes. `file` is accepted for symmetry with [`parse`]; the
/// diagnostics carry positions and paths, and callers prefix the file name.
pub fn diagnose(bytes: &[u8], _file: &str) -> Diagnosed {
    read::diagnose(bytes)
}

/// Parse a manifest, failing on its first error.
pub fn parse(bytes: &[u8], file: &str) -> Result<Manifest, ManifestError> {
    let d = diagnose(bytes, file);
    match d.manifest {
        Some(m) => Ok(m),
        None => {
            let first = d.diagnostics.into_iter().find(|x| x.severity == Severity::Error);
            let first = first.unwrap_or(Diagnostic {
                code: codes::XML_MALFORMED,
                severity: Severity::Error,
                message: "the manifest could not be read".into(),
                line: 1,
                col: 1,
                path: String::new(),
            });
            Err(ManifestError {
                code: first.code,
                file: file.to_string(),
                line: first.line,
                col: first.col,
                path: first.path,
                message: first.message,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn severity_name(s: Severity) -> &'static str {
        s.as_str()
    }

    /// spec/02-manifest.md §2.9 lists exactly [`CODES`], row for row.
    #[test]
    fn spec_code_table_matches_codes() {
        let spec = include_str!("../../spec/02-manifest.md");
        let table = spec.split("## 2.9 Codes").nth(1).expect("spec has a §2.9 Codes section");
        let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("| `")).collect();
        let expected: Vec<String> =
            CODES.iter().map(|(c, s, m)| format!("| `{c}` | {} | {m} |", severity_name(*s))).collect();
        for e in &expected {
            assert!(rows.contains(&e.as_str()), "spec/02-manifest.md §2.9 lacks or differs for:\n{e}");
        }
        for r in &rows {
            assert!(expected.iter().any(|e| e == r), "spec/02-manifest.md §2.9 row not in CODES:\n{r}");
        }
    }

    #[test]
    fn codes_are_unique_and_named_by_their_prefix() {
        for (i, (c, _, _)) in CODES.iter().enumerate() {
            assert!(c.starts_with("XML_") || c.starts_with("MANIFEST_"), "{c}");
            assert!(CODES[i + 1..].iter().all(|(d, _, _)| d != c), "{c} twice");
        }
    }
}
