//! glTF 2.0 binary (`.glb`): one mesh, positions + `TEXCOORD_0` + `u32` indices, the layer colour as an
//! embedded PNG base-colour texture (unlit, double-sided).
//!
//! glTF is Y-up; POMC world space is Z-up (the thesis translates the panorama to `z = 1.15`), so callers
//! compose [`z_up_to_y_up`] with LocalToWorld.

use glam::DMat4;
use serde_json::json;

use super::super::MeshError;
use super::ExportMesh;

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

/// The `.glb` bytes of a mesh with a PNG texture.
pub fn to_glb(m: &ExportMesh, png: &[u8]) -> Result<Vec<u8>, MeshError> {
    if m.triangles.is_empty() {
        return Err(MeshError::Export("the mesh has no triangles (glTF accessors cannot be empty)".into()));
    }
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut view = |bin: &mut Vec<u8>, data: &[u8], target: Option<u32>| {
        pad4(bin, 0);
        let mut v = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": data.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        bin.extend_from_slice(data);
        views.push(v);
    };
    let f32s = |it: &mut dyn Iterator<Item = f32>| it.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
    view(&mut bin, &f32s(&mut m.positions.iter().flatten().copied()), Some(34962));
    view(&mut bin, &f32s(&mut m.uvs.iter().flatten().copied()), Some(34962));
    let idx: Vec<u8> = m.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
    view(&mut bin, &idx, Some(34963));
    view(&mut bin, png, None);
    pad4(&mut bin, 0);
    let (mut mn, mut mx) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &m.positions {
        for k in 0..3 {
            mn[k] = mn[k].min(p[k]);
            mx[k] = mx[k].max(p[k]);
        }
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "pomc mesh"},
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "layer"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0, "mode": 4}]}],
        "materials": [{
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "doubleSided": true,
            "extensions": {"KHR_materials_unlit": {}}
        }],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 10497, "wrapT": 33071}],
        "images": [{"bufferView": 3, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": m.positions.len(), "type": "VEC3", "min": mn, "max": mx},
            {"bufferView": 1, "componentType": 5126, "count": m.uvs.len(), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": m.triangles.len() * 3, "type": "SCALAR"}
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}]
    });
    let mut js = serde_json::to_vec(&doc).map_err(|e| MeshError::Export(e.to_string()))?;
    pad4(&mut js, b' ');
    let total = 12 + 8 + js.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| MeshError::Export("mesh too large for a .glb".into()))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}
