//! glTF 2.0 binary (`.glb`): one node and one mesh per layer, named after it, the nodes in painter's
//! order (farthest first) under one scene; each mesh has positions + `TEXCOORD_0` + `u32` indices and its
//! layer's colour as an embedded sRGB PNG base-colour texture, cropped ([`super::texture`]; unlit; double-sided, except a sky dome,
//! whose triangles face the centre). Node `extras`: `layer` (manifest index), `sky_radius` for a dome.
//!
//! glTF is Y-up; POMC world space is Z-up (the thesis translates the panorama to `z = 1.15`), so callers
//! compose [`z_up_to_y_up`] with LocalToWorld.

use glam::DMat4;
use serde_json::{json, Value};

use super::super::MeshError;
use super::{ExportMesh, SceneLayer};

/// `(x, y, z) ↦ (x, z, −y)`: Z-up right-handed to glTF's Y-up right-handed.
pub fn z_up_to_y_up() -> DMat4 {
    DMat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
}

/// PNG bytes of an 8-bit RGB image.
pub fn png_rgb8(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>, MeshError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| MeshError::Export(format!("PNG encoding: {e}")))?;
    Ok(out)
}

fn pad4(buf: &mut Vec<u8>, byte: u8) {
    while buf.len() % 4 != 0 {
        buf.push(byte);
    }
}

/// The `.glb` bytes of layers (in painter's order), each with its prepared mesh, PNG texture and
/// whether its texture coordinates wrap across `u = 1` (a repeating sampler; else clamped).
pub fn to_glb(layers: &[(&SceneLayer, &ExportMesh, &[u8], bool)]) -> Result<Vec<u8>, MeshError> {
    if layers.is_empty() || layers.iter().any(|l| l.1.triangles.is_empty()) {
        return Err(MeshError::Export("the mesh has no triangles (glTF accessors cannot be empty)".into()));
    }
    let mut g = Gltf::default();
    for (k, &(l, m, png, wraps)) in layers.iter().enumerate() {
        g.add_layer(k, l, m, png, wraps);
    }
    pad4(&mut g.bin, 0);
    let doc = json!({
        "asset": {"version": "2.0", "generator": "pomc mesh"},
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": (0..layers.len()).collect::<Vec<_>>()}],
        "nodes": g.nodes,
        "meshes": g.meshes,
        "materials": g.materials,
        "textures": g.textures,
        "samplers": [
            {"magFilter": 9729, "minFilter": 9729, "wrapS": 10497, "wrapT": 33071},
            {"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}
        ],
        "images": g.images,
        "accessors": g.accessors,
        "bufferViews": g.views,
        "buffers": [{"byteLength": g.bin.len()}]
    });
    let mut js = serde_json::to_vec(&doc).map_err(|e| MeshError::Export(e.to_string()))?;
    pad4(&mut js, b' ');
    container(&js, &g.bin)
}

/// A glTF document's arrays and binary buffer as layers are added.
#[derive(Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<Value>,
    nodes: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    textures: Vec<Value>,
    images: Vec<Value>,
    accessors: Vec<Value>,
}

impl Gltf {
    /// Append `data` to the buffer as a buffer view (`target`: vertex or index data); its index.
    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        pad4(&mut self.bin, 0);
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(data);
        self.views.push(v);
        self.views.len() - 1
    }

    /// Layer `k`: its node, mesh, unlit material, texture and image, accessors and views.
    fn add_layer(&mut self, k: usize, l: &SceneLayer, m: &ExportMesh, png: &[u8], wraps: bool) {
        let (mut mn, mut mx) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &m.positions {
            for c in 0..3 {
                mn[c] = mn[c].min(p[c]);
                mx[c] = mx[c].max(p[c]);
            }
        }
        let pos = self.view(&f32s(&m.positions), Some(34962));
        let uv = self.view(&f32s(&m.uvs), Some(34962));
        let canvas = (!m.canvas_uvs.is_empty()).then(|| self.view(&f32s(&m.canvas_uvs), Some(34962)));
        let idx: Vec<u8> = m.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        let idx = self.view(&idx, Some(34963));
        let img = self.view(png, None);
        let a = self.accessors.len();
        self.accessors.extend([
            json!({"bufferView": pos, "componentType": 5126, "count": m.positions.len(), "type": "VEC3", "min": mn, "max": mx}),
            json!({"bufferView": uv, "componentType": 5126, "count": m.uvs.len(), "type": "VEC2"}),
            json!({"bufferView": idx, "componentType": 5125, "count": m.triangles.len() * 3, "type": "SCALAR"}),
        ]);
        self.images.push(json!({"bufferView": img, "mimeType": "image/png"}));
        self.textures.push(json!({"sampler": if wraps { 0 } else { 1 }, "source": k}));
        self.materials.push(json!({
            "name": l.name,
            "pbrMetallicRoughness": {"baseColorTexture": {"index": k}, "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "doubleSided": l.sky_radius.is_none(),
            "extensions": {"KHR_materials_unlit": {}}
        }));
        let mut attributes = json!({"POSITION": a, "TEXCOORD_0": a + 1});
        if let Some(canvas) = canvas {
            attributes["TEXCOORD_1"] = json!(self.accessors.len());
            self.accessors.push(json!({"bufferView": canvas, "componentType": 5126, "count": m.canvas_uvs.len(), "type": "VEC2"}));
        }
        self.meshes.push(json!({"name": l.name, "primitives": [{
            "attributes": attributes, "indices": a + 2, "material": k, "mode": 4
        }]}));
        let mut extras = json!({"layer": l.index});
        if let Some(r) = l.sky_radius {
            extras["sky_radius"] = json!(r);
        }
        self.nodes.push(json!({"mesh": k, "name": l.name, "extras": extras}));
    }
}

/// Little-endian bytes of float vectors.
fn f32s<const N: usize>(v: &[[f32; N]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect()
}

/// The `.glb` container of a JSON chunk `js` (padded) and a binary chunk `bin`.
fn container(js: &[u8], bin: &[u8]) -> Result<Vec<u8>, MeshError> {
    let total = 12 + 8 + js.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| MeshError::Export("mesh too large for a .glb".into()))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(js);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    Ok(out)
}
