//! The browser viewer's site (`pomc view`): a static site of HTML, JavaScript (three.js, bundled),
//! the panorama's whole-scene `.glb` (every layer's adaptive mesh, the sky on a dome) and a small
//! `pano.json` (centre, freedom radius, layers). Nothing is fetched from elsewhere at run time.
//! The page's controls, URL parameters and tests are described in `docs/viewer.md`.

use std::path::Path;

use glam::DMat4;
use serde_json::json;

use crate::layer::{LayerImage, Sample};
use crate::manifest::Manifest;
use crate::mapping::{CubeFace, MappingKind};
use crate::mesh::export::{gltf, scene_files_with, Format, SceneLayer};
use crate::mesh::MeshOptions;
use crate::mesh::{self, LayerMesh};
use crate::panorama::Panorama;
use crate::render::rasterize::{self, LayerGeometry, RasterOptions};
use crate::render::RenderLayer;

/// The bundled files of the page, `(path in the site, bytes)`: the viewer and three.js r180 (MIT,
/// its licence beside it).
pub const ASSETS: &[(&str, &[u8])] = &[
    ("index.html", include_bytes!("../viewer/index.html")),
    ("pomc-viewer.js", include_bytes!("../viewer/pomc-viewer.js")),
    ("vendor/three/LICENSE", include_bytes!("../viewer/vendor/three/LICENSE")),
    (
        "vendor/three/build/three.module.min.js",
        include_bytes!("../viewer/vendor/three/build/three.module.min.js"),
    ),
    (
        "vendor/three/build/three.core.min.js",
        include_bytes!("../viewer/vendor/three/build/three.core.min.js"),
    ),
    (
        "vendor/three/examples/jsm/loaders/GLTFLoader.js",
        include_bytes!("../viewer/vendor/three/examples/jsm/loaders/GLTFLoader.js"),
    ),
    (
        "vendor/three/examples/jsm/utils/BufferGeometryUtils.js",
        include_bytes!("../viewer/vendor/three/examples/jsm/utils/BufferGeometryUtils.js"),
    ),
    (
        "vendor/three/examples/jsm/webxr/VRButton.js",
        include_bytes!("../viewer/vendor/three/examples/jsm/webxr/VRButton.js"),
    ),
];

/// Options of a site.
#[derive(Clone, Debug)]
pub struct SiteSettings {
    /// Mesh parameters of the layers without a stored mesh (default: `pomc render --method
    /// mesh`'s, so that the page shows what the renderer draws).
    pub mesh: MeshOptions,
    /// Radius of the sky dome (default: [`crate::mesh::default_sky_radius`]).
    pub sky_radius: Option<f64>,
    /// The page title (default: the panorama directory's name).
    pub title: Option<String>,
}

impl Default for SiteSettings {
    fn default() -> Self {
        SiteSettings { mesh: MeshOptions::quadtree(), sky_radius: None, title: None }
    }
}

/// A site ready to write or serve: `(path, bytes)`, `index.html` first.
#[derive(Clone, Debug, Default)]
pub struct Site {
    /// `(path relative to the site root, contents)`, `index.html` first.
    pub files: Vec<(String, Vec<u8>)>,
    /// Triangles per meshed layer, in painter's order: `(layer name, triangles)`.
    pub triangles: Vec<(String, usize)>,
}

impl Site {
    /// Total size in bytes.
    pub fn bytes(&self) -> usize {
        self.files.iter().map(|f| f.1.len()).sum()
    }

    /// The bytes of `path` (no leading `/`; empty or ending in `/` means its `index.html`) and
    /// their MIME type.
    pub fn get(&self, path: &str) -> Option<(&[u8], &'static str)> {
        let path = if path.is_empty() || path.ends_with('/') {
            format!("{path}index.html")
        } else {
            path.to_string()
        };
        self.files.iter().find(|f| f.0 == path).map(|f| (f.1.as_slice(), mime_type(&path)))
    }

    /// Write the site into directory `dir` as a whole: into a temporary sibling, then swapped in
    /// place of `dir` (which may exist), under the directory lock panoramas use.
    pub fn write(&self, dir: &Path) -> crate::Result<()> {
        let _lock = crate::fsutil::lock_dir(dir)?;
        let tmp = crate::fsutil::temp_sibling(dir)?;
        for (name, bytes) in &self.files {
            let path = tmp.path().join(name);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(|source| crate::Error::io(parent.to_path_buf(), source))?;
            }
            std::fs::write(&path, bytes).map_err(|source| crate::Error::io(path, source))?;
        }
        Ok(crate::fsutil::swap_in(tmp, dir)?)
    }
}

/// The MIME type the server gives a site file.
pub fn mime_type(path: &str) -> &'static str {
    match path.rsplit('.').next().unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript; charset=utf-8",
        "json" => "application/json",
        "glb" => "model/gltf-binary",
        _ => "text/plain; charset=utf-8",
    }
}

/// The site of panorama `pano`, its layers read (full canvases, manifest order) and meshed as
/// `pomc render --method mesh` meshes them (stored meshes decoded).
///
/// ```
/// use pomc::prelude::*;
/// let pano = Panorama::open("fixtures/data/room-equirect".as_ref())?;
/// let site = viewer::site(&pano, &SiteSettings::default())?;
/// assert_eq!(site.files[0].0, "index.html");
/// assert!(site.get("index.html").is_some());
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn site(pano: &Panorama, options: &SiteSettings) -> crate::Result<Site> {
    let layers = crate::render::read_layers(pano, &crate::layer_io::ReadLimits::default())?;
    let refs = RenderLayer::all(&layers);
    let (geometry, ..) = rasterize::panorama_meshes(pano, &refs, &options.mesh, &RasterOptions::default())?;
    let title = options.title.clone().unwrap_or_else(|| {
        pano.dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "panorama".into())
    });
    let images: Vec<LayerImage> = layers.into_iter().map(|l| l.0).collect();
    site_from(&pano.manifest, &images, geometry, &title, options)
}

/// One node of the viewer's scene.
struct Node {
    index: usize,
    name: String,
    mesh: LayerMesh,
    image: LayerImage,
    sky_radius: Option<f64>,
}

/// The scene is what the mesh renderer draws: each layer's [`LayerGeometry`] (its quadtree mesh
/// without the triangles across depth jumps, plus the footprint quads of its border pixels), and
/// for layers with infinitely far samples those samples alone on a dome that the page keeps
/// centred on the eye. Domes come first, then the layers, each group in painter's order. Colour
/// is padded into the pixels a layer does not cover, so that bilinear filtering at its border does
/// not pull in black.
fn site_from(
    manifest: &Manifest,
    images: &[LayerImage],
    geometry: Vec<LayerGeometry>,
    title: &str,
    options: &SiteSettings,
) -> crate::Result<Site> {
    let kind = manifest.mapping.kind;
    let radius = options.sky_radius.unwrap_or_else(|| mesh::default_sky_radius(images));
    let order: Vec<usize> = manifest.painter_order().into_iter().filter(|&k| k < images.len()).collect();
    let name_of = |k: usize| manifest.layer_name(k);
    let mut domes = Vec::new();
    for &k in &order {
        let Some(dome) = infinite_only(&images[k], radius)? else { continue };
        let mapping = crate::render::layer_mapping(kind, k, &dome)?;
        let meshed = mesh::mesh_layer(&dome, &mapping, &mesh::sky_params(&MeshOptions::default()))?;
        let image = padded(&dome, surface_pixels(&dome));
        domes.push(Node {
            index: k,
            name: format!("{}-sky", name_of(k)),
            mesh: meshed.mesh,
            image,
            sky_radius: Some(radius),
        });
    }
    let mut geometry: Vec<Option<LayerGeometry>> = geometry.into_iter().map(Some).collect();
    let mut nodes = domes;
    for &k in &order {
        let Some(g) = geometry.get_mut(k).and_then(Option::take) else { continue };
        if g.mesh.triangles.is_empty() {
            continue;
        }
        let image = &images[k];
        let keep = surface_pixels(image);
        let mesh = g.mesh;
        nodes.push(Node { index: k, name: name_of(k), mesh, image: padded(image, keep), sky_radius: None });
    }
    let to_world = manifest.local_to_world();
    let scene: Vec<SceneLayer> = nodes
        .iter()
        .map(|n| SceneLayer {
            name: n.name.clone(),
            index: n.index,
            mesh: &n.mesh,
            image: &n.image,
            sky_radius: n.sky_radius,
        })
        .collect();
    let (files, _) = scene_files_with(&scene, Some(to_world), Format::Glb, "scene", true)?;
    let glb = files.into_iter().next().map(|f| f.1).unwrap_or_default();
    let info = info_json(manifest, &nodes, title, to_world);
    let mut site = Site::default();
    for (name, bytes) in ASSETS {
        site.files.push((name.to_string(), bytes.to_vec()));
    }
    site.files.push(("pano.json".into(), serde_json::to_vec_pretty(&info).unwrap_or_default()));
    site.files.push(("scene.glb".into(), glb));
    site.triangles = nodes.iter().map(|n| (n.name.clone(), n.mesh.triangles.len())).collect();
    Ok(site)
}

/// Whether each pixel of `image` is a surface at a finite distance.
fn surface_pixels(image: &LayerImage) -> Vec<bool> {
    (0..image.width * image.height).map(|i| matches!(image.sample(i), Sample::Surface(_))).collect()
}

/// `image` with only its infinitely far samples, at distance `radius` (the rest outside the
/// domain); `None` when it has none.
fn infinite_only(image: &LayerImage, radius: f64) -> crate::Result<Option<LayerImage>> {
    let Some(mut dome) = mesh::sky_at(image, radius)? else { return Ok(None) };
    let infinite: Vec<bool> =
        (0..image.width * image.height).map(|i| image.sample(i) == Sample::Infinite).collect();
    if let Some(z) = dome.channel_mut("Z") {
        for (d, _) in z.data.iter_mut().zip(&infinite).filter(|(_, &inf)| !inf) {
            *d = -1.0;
        }
    }
    if let Some(a) = dome.channel_mut("A") {
        for (a, _) in a.data.iter_mut().zip(&infinite).filter(|(_, &inf)| !inf) {
            *a = 0.0;
        }
    }
    Ok(Some(dome))
}

/// Pixels of colour padding around the kept ones (bilinear filtering reaches one pixel; the
/// footprint quads and the direction lookup up to one more).
const PAD: usize = 3;

/// `image` with the colour of pixels not `keep` replaced by the mean of their kept (or already
/// padded) 8-neighbours, [`PAD`] rings deep; the equirect seam is not crossed (a one-pixel
/// difference at the seam's ends only).
fn padded(image: &LayerImage, mut keep: Vec<bool>) -> LayerImage {
    let (w, h) = (image.width, image.height);
    let mut out = image.clone();
    if keep.len() != w * h {
        return out;
    }
    let mut rgb: Vec<Vec<f32>> = ["R", "G", "B"]
        .iter()
        .map(|c| image.channel(c).map(|c| c.data.clone()).unwrap_or_default())
        .collect();
    if rgb.iter().any(|c| c.len() != w * h) {
        return out;
    }
    for _ in 0..PAD {
        let mut next = keep.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if keep[i] {
                    continue;
                }
                let (mut sum, mut n) = ([0.0f32; 3], 0);
                for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if keep[j] {
                        for c in 0..3 {
                            sum[c] += rgb[c][j];
                        }
                        n += 1;
                    }
                }
                if n > 0 {
                    for c in 0..3 {
                        rgb[c][i] = sum[c] / n as f32;
                    }
                    next[i] = true;
                }
            }
        }
        keep = next;
    }
    for (name, data) in ["R", "G", "B"].iter().zip(rgb) {
        if let Some(c) = out.channel_mut(name) {
            c.data = data;
        }
    }
    out
}

/// `pano.json`: what the page needs besides the scene, in POMC world coordinates (Z up; the page
/// converts to glTF's Y up with the same [`gltf::z_up_to_y_up`]).
fn info_json(manifest: &Manifest, nodes: &[Node], title: &str, to_world: DMat4) -> serde_json::Value {
    let centre = to_world.transform_point3(glam::DVec3::ZERO);
    // Farthest finite vertex from the centre, for the page's far plane.
    let extent = nodes
        .iter()
        .filter(|m| m.sky_radius.is_none())
        .flat_map(|m| m.mesh.positions.iter())
        .map(|p| to_world.transform_point3(*p).distance(centre))
        .filter(|d| d.is_finite())
        .fold(0.0f64, f64::max);
    let layers: Vec<_> = nodes
        .iter()
        .map(|m| {
            let decl = manifest.layers.get(m.index);
            json!({
                "index": m.index,
                "name": m.name,
                "role": decl.and_then(|d| d.role.as_ref()).map(|r| r.as_str()),
                "order": decl.and_then(|d| d.order),
                "sky": m.sky_radius.is_some(),
                "triangles": m.mesh.triangles.len(),
                "width": m.image.width,
                "height": m.image.height,
            })
        })
        .collect();
    // The canvas parametrisation, for sampling each layer by direction from the centre as the
    // renderer does (texture coordinates interpolated over a large triangle would bend the texture).
    let mapping = match manifest.mapping.kind {
        MappingKind::Equirect => json!({"kind": "equirect"}),
        MappingKind::Cube3x2 => {
            let faces: Vec<_> = CubeFace::ALL
                .iter()
                .map(|f| {
                    let [c, r, d] = f.frame();
                    json!({"centre": c.to_array(), "right": r.to_array(), "down": d.to_array(), "slot": f.grid()})
                })
                .collect();
            json!({"kind": "cube3x2", "faces": faces})
        }
    };
    json!({
        "pomc_view": 1,
        "mapping": mapping,
        "title": title,
        "scene": "scene.glb",
        "local_to_world": to_world.to_cols_array(),
        "world_to_gltf": gltf::z_up_to_y_up().to_cols_array(),
        "centre": centre.to_array(),
        "freedom_radius": manifest.freedom_radius,
        "extent": extent,
        "sky_radius": nodes.iter().find_map(|m| m.sky_radius),
        "layers": layers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layer::SampleType;

    #[test]
    fn padding_spreads_kept_colour_only_into_uncovered_pixels() {
        let (w, h) = (8, 4);
        let mut image = LayerImage::new(w, h);
        let red: Vec<f32> = (0..w * h).map(|i| if i % w < 3 { 0.5 } else { 0.0 }).collect();
        for c in ["R", "G", "B"] {
            image.set_channel(c, SampleType::F32, red.clone());
        }
        let keep: Vec<bool> = (0..w * h).map(|i| i % w < 3).collect();
        let out = padded(&image, keep);
        let r = &out.channel("R").unwrap().data;
        for y in 0..h {
            for x in 0..w {
                // Kept pixels unchanged; PAD columns past the edge take the colour; beyond, unchanged.
                let want = if x < 3 + PAD { 0.5 } else { 0.0 };
                assert_eq!(r[y * w + x], want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn a_site_serves_its_index_for_the_root_with_its_type() {
        let site = Site {
            files: vec![("index.html".into(), b"<html>".to_vec()), ("a/b.js".into(), b"x".to_vec())],
            triangles: Vec::new(),
        };
        assert_eq!(site.get(""), Some((&b"<html>"[..], "text/html; charset=utf-8")));
        assert_eq!(site.get("a/b.js").map(|f| f.1), Some("text/javascript; charset=utf-8"));
        assert_eq!(site.get("a/"), None);
        assert_eq!(site.get("../index.html"), None);
        assert_eq!(site.bytes(), 7);
        assert!(ASSETS.iter().all(|(_, bytes)| !bytes.is_empty()));
    }
}
