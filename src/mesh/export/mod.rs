//! Export of layer meshes: binary PLY, OBJ, glTF 2.0 binary (`.glb`).
//!
//! Positions are world positions by default (the manifest's LocalToWorld applied); triangles whose
//! transform mirrors space (negative determinant) are re-wound so they stay counter-clockwise as seen
//! from the panorama centre. Texture coordinates are the vertex's pixel centre over the canvas size. A
//! triangle crossing the equirect seam gets its own copies of the vertices on the low side with `u + 1`
//! (the glTF sampler repeats), and each pole gets one copy per triangle at the mean `u` of the other two,
//! so no triangle smears the whole texture. The half-pixel strips joining cube faces are not remapped.

pub mod gltf;
pub mod obj;
pub mod ply;

use glam::{DMat4, DVec3};

use super::{is_pole, LayerMesh};

/// A mesh ready to write: per-corner attributes deduplicated into vertices.
#[derive(Clone, Debug, Default)]
pub struct ExportMesh {
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    /// Linear RGB of the vertex's pixel (0..1), for formats with vertex colours.
    pub colours: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Prepare `mesh` for writing. `colour(id)` gives a source pixel's linear RGB.
pub fn prepare(mesh: &LayerMesh, transform: DMat4, colour: &dyn Fn(u32) -> [f32; 3]) -> ExportMesh {
    let (w, h) = (mesh.width, mesh.height);
    let flip = transform.determinant() < 0.0;
    let base_uv = |id: u32| -> [f64; 2] {
        if is_pole(id, w, h) {
            let south = id as usize > w * h;
            [0.5, if south { 1.0 } else { 0.0 }]
        } else {
            [((id as usize % w) as f64 + 0.5) / w as f64, ((id as usize / w) as f64 + 0.5) / h as f64]
        }
    };
    let mut out = ExportMesh::default();
    let mut map = std::collections::HashMap::new();
    for t in &mesh.triangles {
        let ids = t.map(|v| mesh.sources[v as usize]);
        let mut uv = ids.map(base_uv);
        if w * 2 == h * 3 {
            cube_strip_uvs(mesh, t, &ids, &mut uv);
        }
        let real: Vec<usize> = (0..3).filter(|&k| !is_pole(ids[k], w, h)).collect();
        let us: Vec<f64> = real.iter().map(|&k| uv[k][0]).collect();
        let (mn, mx) = us.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &u| (a.0.min(u), a.1.max(u)));
        if mx - mn > 0.5 {
            for &k in &real {
                if uv[k][0] < 0.5 {
                    uv[k][0] += 1.0;
                }
            }
        }
        if real.len() < 3 && !real.is_empty() {
            let mean = real.iter().map(|&k| uv[k][0]).sum::<f64>() / real.len() as f64;
            for k in (0..3).filter(|k| !real.contains(k)) {
                uv[k][0] = mean;
            }
        }
        let mut tri = [0u32; 3];
        for k in 0..3 {
            let uvf = [uv[k][0] as f32, uv[k][1] as f32];
            let key = (t[k], uvf[0].to_bits(), uvf[1].to_bits());
            tri[k] = *map.entry(key).or_insert_with(|| {
                let p: DVec3 = transform.transform_point3(mesh.positions[t[k] as usize]);
                out.positions.push(p.as_vec3().to_array());
                out.uvs.push(uvf);
                out.colours.push(if is_pole(ids[k], w, h) { [0.5; 3] } else { colour(ids[k]) });
                (out.positions.len() - 1) as u32
            });
        }
        out.triangles.push(if flip { [tri[0], tri[2], tri[1]] } else { tri });
    }
    out
}

/// Cube-map strip triangles: texture coordinates of every vertex on the first vertex's face.
fn cube_strip_uvs(mesh: &LayerMesh, t: &[u32; 3], ids: &[u32; 3], uv: &mut [[f64; 2]; 3]) {
    let (w, h) = (mesh.width, mesh.height);
    let n = h / 2;
    let slot = |id: u32| ((id as usize % w) / n, (id as usize / w) / n);
    let (s0, t0) = slot(ids[0]);
    if ids.iter().all(|&id| slot(id) == (s0, t0)) {
        return;
    }
    let Some(face) = crate::mapping::CubeFace::from_index(3 * t0 + s0) else { return };
    let [c, r, d] = face.frame();
    let nf = n as f64;
    let lim = 1.0 - 1.0 / nf;
    for k in 1..3 {
        if slot(ids[k]) == (s0, t0) {
            continue;
        }
        let p = mesh.positions[t[k] as usize];
        let z = p.dot(c);
        if z <= 0.0 {
            continue;
        }
        let (s, tt) = ((p.dot(r) / z).clamp(-lim, lim), (p.dot(d) / z).clamp(-lim, lim));
        uv[k] = [(s0 as f64 + (s + 1.0) * 0.5) / 3.0, (t0 as f64 + (tt + 1.0) * 0.5) / 2.0];
    }
}

/// Linear → sRGB-encoded 8-bit.
pub fn srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Output formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ply,
    Obj,
    Glb,
}

impl Format {
    /// The format of `path`'s extension (`.ply`, `.obj`, `.glb`), case-insensitive.
    pub fn from_path(path: &std::path::Path) -> Result<Format, super::MeshError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Ok(Format::Ply),
            "obj" => Ok(Format::Obj),
            "glb" => Ok(Format::Glb),
            _ => Err(super::MeshError::Export(format!(
                "{}: unknown mesh format (use .ply, .obj or .glb)",
                path.display()
            ))),
        }
    }
}

/// 8-bit sRGB RGB of a layer's colour channels (black where a channel is missing).
pub fn colour_rgb8(image: &crate::layer::LayerImage) -> Vec<u8> {
    let n = image.width * image.height;
    let ch: Vec<Option<&[f32]>> =
        ["R", "G", "B"].iter().map(|c| image.channel(c).map(|c| c.data.as_slice())).collect();
    let mut out = vec![0u8; 3 * n];
    for (k, c) in ch.iter().enumerate() {
        if let Some(c) = c {
            for i in 0..n {
                out[3 * i + k] = srgb8(c[i]);
            }
        }
    }
    out
}

/// Encode `mesh` in `format`, in world coordinates when `local_to_world` is given (panorama-local
/// otherwise); glTF output is additionally converted to Y-up.
pub fn to_bytes(
    mesh: &LayerMesh,
    image: &crate::layer::LayerImage,
    local_to_world: Option<DMat4>,
    format: Format,
) -> Result<Vec<u8>, super::MeshError> {
    let local_to_world = local_to_world.unwrap_or(DMat4::IDENTITY);
    let channel = |name: &str| image.channel(name).map(|c| c.data.as_slice());
    let (r, g, b) = (channel("R"), channel("G"), channel("B"));
    let colour = |id: u32| -> [f32; 3] {
        let i = id as usize;
        [r, g, b].map(|c| c.and_then(|c| c.get(i).copied()).unwrap_or(0.0))
    };
    Ok(match format {
        Format::Ply => ply::to_bytes(&prepare(mesh, local_to_world, &colour)),
        Format::Obj => obj::to_string(&prepare(mesh, local_to_world, &colour)).into_bytes(),
        Format::Glb => {
            let m = prepare(mesh, gltf::z_up_to_y_up() * local_to_world, &colour);
            let png = gltf::png_rgb8(image.width as u32, image.height as u32, &colour_rgb8(image))?;
            gltf::to_glb(&m, &png)?
        }
    })
}
