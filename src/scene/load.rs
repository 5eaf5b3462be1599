//! Triangle scenes read from glTF 2.0 (`.gltf`, `.glb`, with the `gltf` crate) and Wavefront OBJ
//! (with `tobj`), in pomc's world frame: glTF and OBJ are +Y up, pomc +Z up, mapped as Blender
//! imports them (world `x, y, z` = file `x, −z, y`).

use std::path::Path;

use glam::{DMat4, DVec3, Mat3, Mat4, Vec2, Vec3, Vec4};

use super::material::{Material, Texture, TextureRef, Wrap};
use super::SceneError;

/// The triangles of a scene with what shading needs, positions relative to the panorama centre.
#[derive(Clone, Debug, Default)]
pub struct TriangleScene {
    /// Corners, metres, pomc world frame minus the centre (counter-clockwise seen from the front).
    pub positions: Vec<[Vec3; 3]>,
    /// Corner normals (unit); zero where the file gives none (the face normal is used).
    pub normals: Vec<[Vec3; 3]>,
    /// Corner texture coordinates (set 0), image convention: `v` down.
    pub uvs: Vec<[Vec2; 3]>,
    /// Corner colours, linear RGBA (white without vertex colours).
    pub colours: Vec<[Vec4; 3]>,
    /// Material of each triangle (index into `materials`).
    pub material: Vec<u32>,
    /// Which mesh (glTF node primitive, OBJ object) each triangle belongs to: surfaces of
    /// different meshes never join one piece of layer.
    pub surface: Vec<u32>,
    /// The materials.
    pub materials: Vec<Material>,
    /// The textures the materials use.
    pub textures: Vec<Texture>,
    /// Primitives left out because they are not triangles (points, lines), and degenerate or
    /// non-finite triangles.
    pub skipped: usize,
}

impl TriangleScene {
    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no triangle.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Add one triangle (corners in the world frame, f64), skipping degenerate and non-finite
    /// ones; `centre` is subtracted in f64 before rounding, so far-off scenes keep their detail.
    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        corners: [DVec3; 3],
        normals: [Vec3; 3],
        uvs: [Vec2; 3],
        colours: [Vec4; 3],
        material: u32,
        surface: u32,
        centre: DVec3,
    ) {
        let p = corners.map(|c| (c - centre).as_vec3());
        let area = (p[1] - p[0]).cross(p[2] - p[0]).length();
        if !(area > 0.0 && area.is_finite()) {
            self.skipped += 1;
            return;
        }
        self.positions.push(p);
        self.normals.push(normals.map(|n| if n.is_finite() { n.normalize_or_zero() } else { Vec3::ZERO }));
        self.uvs.push(uvs.map(|t| if t.is_finite() { t } else { Vec2::ZERO }));
        self.colours.push(colours);
        self.material.push(material);
        self.surface.push(surface);
    }
}

/// glTF / OBJ (+Y up) to pomc's world (+Z up): `(x, y, z) → (x, −z, y)`.
fn to_world(v: DVec3) -> DVec3 {
    DVec3::new(v.x, -v.z, v.y)
}

/// Read a scene file (`.gltf`, `.glb` or `.obj`, by extension), positions relative to `centre`
/// (given in pomc's world frame); refused beyond `max_triangles`.
pub fn read(path: &Path, centre: DVec3, max_triangles: usize) -> Result<TriangleScene, SceneError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    // A FIFO or a device would block or never end.
    crate::fsutil::check_regular(path).map_err(|e| unreadable(path, e))?;
    let scene = match ext.as_str() {
        "gltf" | "glb" => read_gltf(path, centre, max_triangles)?,
        "obj" => read_obj(path, centre, max_triangles)?,
        _ => return Err(SceneError::Unsupported { path: path.into(), extension: ext }),
    };
    if scene.is_empty() {
        return Err(SceneError::Empty { path: path.into() });
    }
    Ok(scene)
}

fn unreadable(path: &Path, why: impl std::fmt::Display) -> SceneError {
    SceneError::Unreadable { path: path.into(), why: why.to_string() }
}

fn too_large(path: &Path, count: usize, limit: usize) -> SceneError {
    SceneError::TooLarge { path: path.into(), triangles: count, limit }
}

/// The `gltf` crate indexes and slices unchecked on some malformed files (an accessor index out of
/// range, a stride shorter than its element): a panic there is a malformed file, not a crash.
fn read_gltf(path: &Path, centre: DVec3, max_triangles: usize) -> Result<TriangleScene, SceneError> {
    let read = std::panic::AssertUnwindSafe(|| read_gltf_unchecked(path, centre, max_triangles));
    std::panic::catch_unwind(read).unwrap_or_else(|_| {
        Err(unreadable(path, "malformed glTF (an accessor, buffer view or index out of range)"))
    })
}

fn read_gltf_unchecked(
    path: &Path,
    centre: DVec3,
    max_triangles: usize,
) -> Result<TriangleScene, SceneError> {
    let (doc, buffers, images) = gltf::import(path).map_err(|e| unreadable(path, e))?;
    let mut out =
        TriangleScene { textures: images.iter().map(texture_of_gltf).collect(), ..Default::default() };
    let texture_ref = |info: Option<gltf::texture::Info>| {
        info.map(|i| {
            let s = i.texture().sampler();
            let wrap = |w: gltf::texture::WrappingMode| match w {
                gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
                gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
                gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            };
            TextureRef {
                texture: i.texture().source().index() as u32,
                wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
                uv_set: i.tex_coord(),
            }
        })
    };
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let strength = m.emissive_strength().unwrap_or(1.0);
        out.materials.push(Material {
            base: Vec4::from_array(pbr.base_color_factor()),
            base_texture: texture_ref(pbr.base_color_texture()),
            emissive: Vec3::from_array(m.emissive_factor()) * strength,
            emissive_texture: texture_ref(m.emissive_texture()),
            double_sided: m.double_sided(),
        });
    }
    // glTF's default material: white, single-sided.
    let default_material = out.materials.len() as u32;
    out.materials.push(Material::default());
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let Some(scene) = scene else { return Ok(out) };
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    let mut surface = 0u32;
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            return Err(unreadable(path, "more than a million nodes (a cycle in the node tree?)"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        stack.extend(node.children().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        let normal_matrix = Mat3::from_mat4(world.as_mat4()).inverse().transpose();
        // A mirroring transform turns counter-clockwise into clockwise: the front stays the front.
        let mirrored = world.determinant() < 0.0;
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                out.skipped += 1;
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(positions) = reader.read_positions() else { continue };
            let positions: Vec<DVec3> =
                positions.map(|p| to_world(world.transform_point3(Vec3::from_array(p).as_dvec3()))).collect();
            let normals: Vec<Vec3> = reader
                .read_normals()
                .map(|it| {
                    it.map(|n| to_world((normal_matrix * Vec3::from_array(n)).as_dvec3()).as_vec3()).collect()
                })
                .unwrap_or_default();
            let material = prim.material().index().map_or(default_material, |i| i as u32);
            let uv_set = out.materials[material as usize].uv_set();
            let uvs: Vec<Vec2> = reader
                .read_tex_coords(uv_set)
                .map(|t| t.into_f32().map(Vec2::from_array).collect())
                .unwrap_or_default();
            let colours: Vec<Vec4> = reader
                .read_colors(0)
                .map(|c| c.into_rgba_f32().map(Vec4::from_array).collect())
                .unwrap_or_default();
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            let count = out.len() + indices.len() / 3;
            if count > max_triangles {
                return Err(too_large(path, count, max_triangles));
            }
            for tri in indices.chunks_exact(3) {
                let (b, c) = if mirrored { (tri[2], tri[1]) } else { (tri[1], tri[2]) };
                let idx = [tri[0] as usize, b as usize, c as usize];
                if idx.iter().any(|&i| i >= positions.len()) {
                    out.skipped += 1;
                    continue;
                }
                out.push(
                    idx.map(|i| positions[i]),
                    idx.map(|i| normals.get(i).copied().unwrap_or(Vec3::ZERO)),
                    idx.map(|i| uvs.get(i).copied().unwrap_or(Vec2::ZERO)),
                    idx.map(|i| colours.get(i).copied().unwrap_or(Vec4::ONE)),
                    material,
                    surface,
                    centre,
                );
            }
            surface += 1;
        }
    }
    Ok(out)
}

/// A glTF image as 8-bit RGBA (16-bit and float images are rounded to 8 bits).
fn texture_of_gltf(img: &gltf::image::Data) -> Texture {
    use gltf::image::Format;
    let (channels, bytes) = match img.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let value = |px: &[u8], c: usize| -> u8 {
        let s = &px[c * bytes..(c + 1) * bytes];
        match bytes {
            1 => s[0],
            2 => s[1],
            _ => {
                let f = f32::from_le_bytes([s[0], s[1], s[2], s[3]]);
                (f.clamp(0.0, 1.0) * 255.0).round() as u8
            }
        }
    };
    let texels = img
        .pixels
        .chunks_exact(channels * bytes)
        .map(|px| match channels {
            1 => [value(px, 0), value(px, 0), value(px, 0), 255],
            2 => [value(px, 0), value(px, 0), value(px, 0), value(px, 1)],
            3 => [value(px, 0), value(px, 1), value(px, 2), 255],
            _ => [value(px, 0), value(px, 1), value(px, 2), value(px, 3)],
        })
        .collect();
    Texture::new(img.width as usize, img.height as usize, texels)
}

fn read_obj(path: &Path, centre: DVec3, max_triangles: usize) -> Result<TriangleScene, SceneError> {
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, materials) = tobj::load_obj(path, &options).map_err(|e| unreadable(path, e))?;
    // A missing or broken .mtl leaves the scene white, as viewers show it.
    let materials = materials.unwrap_or_default();
    let mut out = TriangleScene::default();
    let dir = path.parent().unwrap_or(Path::new("."));
    for m in &materials {
        let mut texture = |name: &Option<String>| -> Result<Option<TextureRef>, SceneError> {
            let Some(name) = name.as_deref().filter(|n| !n.trim().is_empty()) else { return Ok(None) };
            let file = dir.join(name.trim());
            let img = image::open(&file).map_err(|e| unreadable(&file, e))?.to_rgba8();
            let (w, h) = (img.width() as usize, img.height() as usize);
            let texels = img.pixels().map(|p| p.0).collect();
            out.textures.push(Texture::new(w, h, texels));
            Ok(Some(TextureRef {
                texture: out.textures.len() as u32 - 1,
                wrap: [Wrap::Repeat; 2],
                uv_set: 0,
            }))
        };
        let base_texture = texture(&m.diffuse_texture)?;
        let emissive_texture = texture(&m.unknown_param.get("map_Ke").cloned())?;
        let kd = m.diffuse.unwrap_or([1.0; 3]);
        let ke = m.emissive.unwrap_or([0.0; 3]);
        out.materials.push(Material {
            base: Vec4::new(kd[0], kd[1], kd[2], 1.0),
            base_texture,
            emissive: Vec3::from_array(ke),
            emissive_texture,
            // OBJ has no culling flag; viewers draw both sides.
            double_sided: true,
        });
    }
    let default_material = out.materials.len() as u32;
    out.materials.push(Material { double_sided: true, ..Material::default() });
    let total: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    if total > max_triangles {
        return Err(too_large(path, total, max_triangles));
    }
    for (surface, model) in models.iter().enumerate() {
        let mesh = &model.mesh;
        let vertex = |i: usize| -> Option<DVec3> {
            let p = mesh.positions.get(3 * i..3 * i + 3)?;
            Some(to_world(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)))
        };
        let normal = |i: usize| {
            mesh.normals
                .get(3 * i..3 * i + 3)
                .map_or(Vec3::ZERO, |n| to_world(Vec3::new(n[0], n[1], n[2]).as_dvec3()).as_vec3())
        };
        // OBJ's v runs up the image.
        let uv = |i: usize| {
            mesh.texcoords.get(2 * i..2 * i + 2).map_or(Vec2::ZERO, |t| Vec2::new(t[0], 1.0 - t[1]))
        };
        let colour = |i: usize| {
            mesh.vertex_color.get(3 * i..3 * i + 3).map_or(Vec4::ONE, |c| Vec4::new(c[0], c[1], c[2], 1.0))
        };
        let material =
            mesh.material_id.filter(|&m| m < materials.len()).map_or(default_material, |m| m as u32);
        for tri in mesh.indices.chunks_exact(3) {
            let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let (Some(a), Some(b), Some(c)) = (vertex(idx[0]), vertex(idx[1]), vertex(idx[2])) else {
                out.skipped += 1;
                continue;
            };
            out.push(
                [a, b, c],
                idx.map(normal),
                idx.map(uv),
                idx.map(colour),
                material,
                surface as u32,
                centre,
            );
        }
    }
    Ok(out)
}

/// Linear colour of triangle `tri` at barycentric `(u, v)` (weights `1−u−v`, `u`, `v` of its
/// corners).
pub fn colour_at(scene: &TriangleScene, tri: usize, u: f32, v: f32) -> Vec3 {
    let w = [1.0 - u - v, u, v];
    let m = &scene.materials[scene.material[tri] as usize];
    let uv = scene.uvs[tri][0] * w[0] + scene.uvs[tri][1] * w[1] + scene.uvs[tri][2] * w[2];
    let vc = scene.colours[tri][0] * w[0] + scene.colours[tri][1] * w[1] + scene.colours[tri][2] * w[2];
    let tex = |t: Option<TextureRef>| {
        t.and_then(|t| scene.textures.get(t.texture as usize).map(|tx| tx.sample(uv, t.wrap)))
    };
    let base = m.base * vc * tex(m.base_texture).unwrap_or(Vec4::ONE);
    let emission = m.emissive * tex(m.emissive_texture).map_or(Vec3::ONE, |e| e.truncate());
    (base.truncate() + emission).max(Vec3::ZERO)
}
