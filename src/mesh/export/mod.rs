//! Export of layer meshes: binary PLY, OBJ (+ MTL + PNG textures), glTF 2.0 binary (`.glb`).
//!
//! A *scene* is a list of layer meshes in painter's order (farthest first), each named after its layer;
//! layers without triangles are left out, and a scene with none is an error. One layer is the scene of
//! one layer ([`to_bytes`]). The layout of each format is in spec §8.9.
//!
//! Positions are world positions by default (the manifest's LocalToWorld applied); triangles whose
//! transform mirrors space (negative determinant) are re-wound so they stay counter-clockwise as seen
//! from the panorama centre. Texture coordinates are the vertex's pixel centre over the canvas size. A
//! triangle crossing the equirect seam gets its own copies of the vertices on the low side with `u + 1`
//! (the glTF sampler repeats), and each pole gets one copy per triangle at the mean `u` of the other two,
//! so no triangle smears the whole texture. The half-pixel strips joining cube faces are not remapped.

pub(crate) mod gltf;
pub(crate) mod obj;
pub(crate) mod ply;
pub mod texture;

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};

use super::{is_pole, LayerMesh, MeshError};
use crate::layer::LayerImage;

/// One layer of a scene.
#[derive(Clone, Debug)]
pub struct SceneLayer<'a> {
    /// The layer's name: the glTF node and mesh, the OBJ object, group and material.
    pub name: String,
    /// The layer's index in the manifest (glTF node `extras.layer`, PLY `layer` property).
    pub index: usize,
    /// The layer's mesh, panorama-local; a mesh without triangles leaves the layer out.
    pub mesh: &'a LayerMesh,
    /// The layer's pixels, for the colour.
    pub image: &'a LayerImage,
    /// Set when the mesh is a sky dome of this radius ([`super::sky_at`]).
    pub sky_radius: Option<f64>,
}

/// A mesh ready to write: per-corner attributes deduplicated into vertices.
#[derive(Clone, Debug, Default)]
pub struct ExportMesh {
    /// Vertex positions after the export transform (world and/or Y-up as asked), metres.
    pub positions: Vec<[f32; 3]>,
    /// Texture coordinates, `v` downwards: canvas coordinates ([`canvas_uv`], `u` past 1 for seam
    /// copies), moved into the packed texture by [`texture::crop`].
    pub uvs: Vec<[f32; 2]>,
    /// Linear RGB of the vertex's pixel (0..1), for formats with vertex colours.
    pub colours: Vec<[f32; 3]>,
    /// Vertex indices of each triangle, counter-clockwise as seen from the panorama centre.
    pub triangles: Vec<[u32; 3]>,
    /// Canvas coordinates of each vertex before [`texture::crop`] moves `uvs` into the packed
    /// texture (seam and pole copies as in `uvs`); written as glTF `TEXCOORD_1` when asked for.
    pub canvas_uvs: Vec<[f32; 2]>,
}

/// Canvas coordinates in `[0, 1]²` of source pixel `id` of a `w` × `h` layer: its pixel centre, or
/// the middle of the top (north) or bottom (south) edge for the equirect pole vertices.
pub fn canvas_uv(id: u32, w: usize, h: usize) -> [f64; 2] {
    if is_pole(id, w, h) {
        let south = id as usize > w * h;
        [0.5, if south { 1.0 } else { 0.0 }]
    } else {
        [((id as usize % w) as f64 + 0.5) / w as f64, ((id as usize / w) as f64 + 0.5) / h as f64]
    }
}

/// Prepare `mesh` for writing. `colour(id)` gives a source pixel's linear RGB.
pub fn prepare(mesh: &LayerMesh, transform: DMat4, colour: &dyn Fn(u32) -> [f32; 3]) -> ExportMesh {
    let (w, h) = (mesh.width, mesh.height);
    let flip = transform.determinant() < 0.0;
    let base_uv = |id: u32| canvas_uv(id, w, h);
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
                out.canvas_uvs.push(uvf);
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

pub use crate::colour::srgb8;

/// Output formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Binary little-endian PLY with vertex colours (`.ply`), Z-up.
    Ply,
    /// Wavefront OBJ with an MTL material library and PNG textures (`.obj`), Y-up.
    Obj,
    /// glTF 2.0 binary with embedded PNG textures (`.glb`), Y-up.
    Glb,
}

impl Format {
    /// The format of `path`'s extension (`.ply`, `.obj`, `.glb`), case-insensitive.
    pub fn from_path(path: &std::path::Path) -> Result<Format, MeshError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Ok(Format::Ply),
            "obj" => Ok(Format::Obj),
            "glb" => Ok(Format::Glb),
            _ => Err(MeshError::Export(format!(
                "{}: unknown mesh format (use .ply, .obj or .glb)",
                path.display()
            ))),
        }
    }
}

/// 8-bit sRGB RGB of a layer's colour channels (black where a channel is missing).
pub fn colour_rgb8(image: &LayerImage) -> Vec<u8> {
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

/// `names` made safe for file names and OBJ statements (ASCII letters, digits, `-` and `_`; anything
/// else becomes `_`, an empty name `layerK`) and unique (a repeated one gets `_K`), K the position.
pub fn safe_names<S: AsRef<str>>(names: &[S]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(names.len());
    for (k, n) in names.iter().enumerate() {
        let mut s: String = n
            .as_ref()
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
            .collect();
        if s.is_empty() {
            s = format!("layer{k}");
        }
        while out.contains(&s) {
            s = format!("{s}_{k}");
        }
        out.push(s);
    }
    out
}

/// A scene's files, `(file name, bytes)`, the main file first.
pub type Files = Vec<(String, Vec<u8>)>;

/// The files of `layers` as a scene in `format` — the main file `STEM.EXT` first (then, for OBJ,
/// `STEM.mtl` and one `STEM_NAME.png` texture per layer) — and the number of vertices written for each
/// layer (0 when left out; seam and pole copies included). Positions are in world
/// coordinates when `local_to_world` is given (panorama-local otherwise); glTF and OBJ output is
/// additionally converted to Y-up (what their importers expect; PLY stays Z-up).
pub fn scene_files(
    layers: &[SceneLayer],
    local_to_world: Option<DMat4>,
    format: Format,
    stem: &str,
) -> Result<(Files, Vec<usize>), MeshError> {
    scene_files_with(layers, local_to_world, format, stem, false)
}

/// [`scene_files`], with each vertex's canvas coordinates as glTF `TEXCOORD_1` when `canvas_uv`
/// (what the viewer needs to sample the layer by direction, as the renderer does).
pub fn scene_files_with(
    layers: &[SceneLayer],
    local_to_world: Option<DMat4>,
    format: Format,
    stem: &str,
    canvas_uv: bool,
) -> Result<(Files, Vec<usize>), MeshError> {
    let all = layers;
    let layers: Vec<&SceneLayer> = all.iter().filter(|l| !l.mesh.triangles.is_empty()).collect();
    if layers.is_empty() {
        return Err(MeshError::Export("the mesh has no triangles (no layer has any)".into()));
    }
    let mut transform = local_to_world.unwrap_or(DMat4::IDENTITY);
    if matches!(format, Format::Glb | Format::Obj) {
        transform = gltf::z_up_to_y_up() * transform;
    }
    let mut meshes: Vec<ExportMesh> = layers.iter().map(|l| prepare_layer(l, transform)).collect();
    if !(canvas_uv && format == Format::Glb) {
        meshes.iter_mut().for_each(|m| m.canvas_uvs = Vec::new());
    }
    let mut counts = meshes.iter().map(|m| m.positions.len());
    let vertices =
        all.iter().map(|l| if l.mesh.triangles.is_empty() { 0 } else { counts.next().unwrap_or(0) });
    let vertices = vertices.collect();
    // Textured formats get each layer's colour cropped to what its mesh uses (PLY has vertex colours).
    let mut textures = || -> Result<Vec<(Vec<u8>, bool)>, MeshError> {
        let crops = layers.iter().zip(meshes.iter_mut()).map(|(l, m)| texture::crop(l.image, m));
        crops.map(|t| Ok((gltf::png_rgb8(t.width, t.height, &t.rgb)?, t.wraps))).collect()
    };
    let files = match format {
        Format::Ply => {
            let parts: Vec<_> =
                layers.iter().zip(&meshes).map(|(l, m)| (l.index, l.name.as_str(), m)).collect();
            vec![(format!("{stem}.ply"), ply::to_bytes(&parts))]
        }
        Format::Glb => {
            let pngs = textures()?;
            let parts: Vec<_> = layers
                .iter()
                .zip(&meshes)
                .zip(&pngs)
                .map(|((l, m), (png, wraps))| (*l, m, png.as_slice(), *wraps))
                .collect();
            vec![(format!("{stem}.glb"), gltf::to_glb(&parts)?)]
        }
        Format::Obj => {
            let pngs = textures()?;
            let names = safe_names(&layers.iter().map(|l| &l.name).collect::<Vec<_>>());
            let files_of: Vec<String> = names.iter().map(|n| format!("{stem}_{n}.png")).collect();
            let parts: Vec<_> = names.iter().map(String::as_str).zip(&meshes).collect();
            let mtl = format!("{stem}.mtl");
            let mut files = vec![
                (format!("{stem}.obj"), obj::to_string(&parts, &mtl).into_bytes()),
                (mtl, obj::mtl(&names, &files_of).into_bytes()),
            ];
            files.extend(files_of.into_iter().zip(pngs.into_iter().map(|(png, _)| png)));
            files
        }
    };
    Ok((files, vertices))
}

/// What [`export_scene`] wrote.
#[derive(Clone, Debug, Default)]
pub struct Exported {
    /// The paths written, the main file first.
    pub files: Vec<PathBuf>,
    /// Vertices written for each layer (0 when left out; seam and pole copies included).
    pub vertices: Vec<usize>,
}

/// Write the scene of `layers` to `path` (its format from its extension), and the OBJ's material
/// library and textures beside it, each atomically.
pub fn export_scene(
    path: &Path,
    layers: &[SceneLayer],
    local_to_world: Option<DMat4>,
) -> Result<Exported, crate::Error> {
    let format = Format::from_path(path)?;
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    let dir = path.parent().unwrap_or(Path::new(""));
    let (files, vertices) = scene_files(layers, local_to_world, format, stem)?;
    let mut out = Exported { files: Vec::new(), vertices };
    for (name, bytes) in files {
        let p = if out.files.is_empty() { path.to_path_buf() } else { dir.join(name) };
        crate::fsutil::write_bytes_atomic(&p, &bytes)?;
        out.files.push(p);
    }
    Ok(out)
}

/// Encode one layer's `mesh` in `format`: the main file of the scene of that layer alone (named
/// `layer`; an OBJ's material library and texture are not returned).
pub fn to_bytes(
    mesh: &LayerMesh,
    image: &LayerImage,
    local_to_world: Option<DMat4>,
    format: Format,
) -> Result<Vec<u8>, MeshError> {
    let layer = SceneLayer { name: "layer".into(), index: 0, mesh, image, sky_radius: None };
    Ok(scene_files(&[layer], local_to_world, format, "mesh")?.0.swap_remove(0).1)
}

/// [`prepare`] with the layer's colour channels.
fn prepare_layer(l: &SceneLayer, transform: DMat4) -> ExportMesh {
    let channel = |name: &str| l.image.channel(name).map(|c| c.data.as_slice());
    let (r, g, b) = (channel("R"), channel("G"), channel("B"));
    let colour = |id: u32| -> [f32; 3] {
        let i = id as usize;
        [r, g, b].map(|c| c.and_then(|c| c.get(i).copied()).unwrap_or(0.0))
    };
    prepare(l.mesh, transform, &colour)
}
