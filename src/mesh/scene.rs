//! A scene of meshed layers (spec §8.9), the job `pomc mesh` runs: every layer of a panorama (or
//! one) meshed in painter's order, the infinitely far samples of a layer on a sky dome, each
//! layer's quadtree encoding and its 3D error against the layer, with per-stage times. The
//! viewer's scene is another one: what the mesh renderer draws ([`crate::viewer`]).

use std::path::Path;
use std::time::Instant;

use glam::DMat4;
use rayon::prelude::*;

use super::accuracy::{self, ErrorStats};
use super::export::{self, Exported, SceneLayer};
use super::{encode, MeshError, MeshOptions, Meshed};
use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::manifest::Manifest;
use crate::mapping::{AnyMapping, MappingKind};
use crate::panorama::{Panorama, PanoramaError};

/// How [`mesh_panorama`] meshes; `Default` is `pomc mesh` without options.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSettings {
    /// The quadtree and simplification parameters of every layer (the sky dome's are loosened,
    /// [`super::sky_params`]).
    pub mesh: MeshOptions,
    /// Mesh only this layer (manifest index); the sky radius still comes from every layer.
    pub only: Option<usize>,
    /// Radius of the sky dome (`None`: [`super::default_sky_radius`] of every layer).
    pub sky_radius: Option<f64>,
    /// Encode every layer's quadtrees for storing them in the panorama ([`store`]), also where
    /// greedy insertion meshed a face (its quadtree is then built for the encoding alone).
    pub store: bool,
    /// Measure each mesh's 3D error against its layer ([`accuracy::measure`]).
    pub metric: bool,
}

impl Default for SceneSettings {
    fn default() -> Self {
        SceneSettings {
            mesh: MeshOptions::default(),
            only: None,
            sky_radius: None,
            store: false,
            metric: true,
        }
    }
}

/// One layer meshed for a scene.
#[derive(Clone, Debug)]
pub struct SceneMesh {
    /// Index in the manifest.
    pub index: usize,
    /// The layer's name in the manifest, or `layerK` when it has none.
    pub name: String,
    /// The layer's role in the manifest.
    pub role: Option<&'static str>,
    /// The meshed pixels: the layer, or for a layer with infinitely far samples its sky on the dome.
    pub image: LayerImage,
    /// The dome's radius when this is the sky.
    pub sky_radius: Option<f64>,
    /// The layer's mesh and the quadtrees it came from.
    pub meshed: Meshed,
    /// The quadtree encoding (spec §8.8): always with [`SceneSettings::store`], else when the
    /// quadtrees are at hand (no greedy face, no dome).
    pub encoded: Option<Vec<u8>>,
    /// The mesh's 3D error against the meshed pixels, with [`SceneSettings::metric`].
    pub error: Option<ErrorStats>,
    /// Reading the layer, ms (0 for layers given in memory).
    pub read_ms: f64,
    /// Encoding, ms.
    pub encode_ms: f64,
    /// Measuring the error, ms.
    pub metric_ms: Option<f64>,
}

/// The meshed layers in painter's order and the dome's radius.
#[derive(Clone, Debug)]
pub struct Scene {
    /// One per layer meshed, in painter's order.
    pub layers: Vec<SceneMesh>,
    /// The sky dome's radius (given, or the default of every layer).
    pub sky_radius: f64,
}

impl Scene {
    /// Whether some layer went on the sky dome.
    pub fn has_sky(&self) -> bool {
        self.layers.iter().any(|l| l.sky_radius.is_some())
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Read and mesh the layers of `pano` (in parallel) as `pomc mesh` does.
///
/// ```
/// use pomc::prelude::*;
/// let pano = Panorama::open("fixtures/data/room-equirect".as_ref())?;
/// let scene = mesh_panorama(&pano, &SceneSettings::default())?;
/// assert_eq!(scene.layers.len(), pano.manifest.layers.len());
/// assert!(scene.layers.iter().all(|m| !m.meshed.mesh.triangles.is_empty()));
/// let worst = scene.layers.iter().filter_map(|m| m.error.as_ref()).map(|e| e.p99_rel).fold(0.0, f64::max);
/// assert!(worst < 0.01, "99 % of pixels within 1 % of their depth");
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn mesh_panorama(pano: &Panorama, s: &SceneSettings) -> crate::Result<Scene> {
    s.mesh.check()?;
    let limits = ReadLimits::default();
    let order = order(&pano.manifest, &pano.manifest_path, pano.manifest.layers.len(), s.only)?;
    // Layers are read and meshed in parallel: one layer's stages do not keep both cores busy.
    let images = order
        .par_iter()
        .map(|&k| {
            let t = Instant::now();
            Ok((pano.read_layer(k, &limits)?, ms(t)))
        })
        .collect::<crate::Result<Vec<_>>>()?;
    // The default radius depends on every layer's depths, also when one layer is meshed.
    let sky_radius = match s.sky_radius {
        Some(r) => r,
        None if s.only.is_some() && images.iter().any(|(im, _)| super::has_sky(im)) => {
            let others = (0..pano.manifest.layers.len()).filter(|k| !order.contains(k));
            let others = others.map(|k| pano.read_layer(k, &limits)).collect::<Result<Vec<_>, _>>()?;
            super::default_sky_radius(images.iter().map(|i| &i.0).chain(&others))
        }
        None => super::default_sky_radius(images.iter().map(|i| &i.0)),
    };
    let layers = order
        .par_iter()
        .zip(images)
        .map(|(&k, (image, read_ms))| {
            let mut m = mesh_one(&pano.manifest, k, image, sky_radius, s)?;
            m.read_ms = read_ms;
            Ok(m)
        })
        .collect::<crate::Result<Vec<_>>>()?;
    Ok(Scene { layers, sky_radius })
}

/// [`mesh_panorama`] of a panorama held in memory: `images` in manifest order.
pub fn mesh_images(manifest: &Manifest, images: &[LayerImage], s: &SceneSettings) -> crate::Result<Scene> {
    s.mesh.check()?;
    let order = order(manifest, Path::new(crate::panorama::MANIFEST_NAME), images.len(), s.only)?;
    let sky_radius = s.sky_radius.unwrap_or_else(|| super::default_sky_radius(images));
    let layers = order
        .par_iter()
        .map(|&k| mesh_one(manifest, k, images[k].clone(), sky_radius, s))
        .collect::<crate::Result<Vec<_>>>()?;
    Ok(Scene { layers, sky_radius })
}

/// The layers to mesh, in painter's order.
fn order(manifest: &Manifest, path: &Path, count: usize, only: Option<usize>) -> crate::Result<Vec<usize>> {
    Ok(match only {
        Some(k) if k >= count => {
            return Err(PanoramaError::NoSuchLayer { manifest: path.to_path_buf(), index: k, count }.into());
        }
        Some(k) => vec![k],
        None => manifest.painter_order().into_iter().filter(|&k| k < count).collect(),
    })
}

fn mesh_one(
    manifest: &Manifest,
    index: usize,
    image: LayerImage,
    sky_radius: f64,
    s: &SceneSettings,
) -> crate::Result<SceneMesh> {
    let kind = manifest.mapping.kind;
    let (w, h) = (image.width, image.height);
    let want_h = if kind == MappingKind::Equirect { w / 2 } else { w * 2 / 3 };
    let mapping = AnyMapping::new(kind, w, h).map_err(|_| MeshError::CanvasMismatch {
        got_w: w,
        got_h: h,
        want_w: w,
        want_h,
    })?;
    let (meshed, dome) = super::mesh_scene_layer(&image, &mapping, &s.mesh, sky_radius)?;
    let t = Instant::now();
    // The encoding stores the quadtrees of the layer itself (the dome is not part of it); lattices
    // meshed by greedy insertion have none yet, so they are built only when the encoding is stored.
    let greedy = meshed.greedy.iter().any(Option::is_some);
    let encoded = if !greedy && dome.is_none() {
        Some(encode::encode(&meshed.trees, &mapping)?)
    } else if s.store {
        Some(encode::encode(&super::quadtrees(&image, &mapping, &s.mesh)?, &mapping)?)
    } else {
        None
    };
    let encode_ms = ms(t);
    let sky = dome.is_some();
    let image = dome.unwrap_or(image);
    let m = &meshed.mesh;
    let (error, metric_ms) = if s.metric {
        let t = Instant::now();
        let e = accuracy::measure(&m.positions, &m.triangles, &image, &mapping);
        (Some(e), Some(ms(t)))
    } else {
        (None, None)
    };
    Ok(SceneMesh {
        index,
        name: manifest.layer_name(index),
        role: manifest.layers.get(index).and_then(|d| d.role).map(|r| r.as_str()),
        image,
        sky_radius: sky.then_some(sky_radius),
        meshed,
        encoded,
        error,
        read_ms: 0.0,
        encode_ms,
        metric_ms,
    })
}

/// Write `layers` as one scene file (`.glb`, `.obj` + `.mtl` + textures, `.ply`, by extension),
/// in world coordinates when `local_to_world` is given. Layers without triangles are left out.
pub fn export_scene(
    path: &Path,
    layers: &[SceneMesh],
    local_to_world: Option<DMat4>,
) -> crate::Result<Exported> {
    let scene: Vec<SceneLayer> = layers
        .iter()
        .map(|m| SceneLayer {
            name: m.name.clone(),
            index: m.index,
            mesh: &m.meshed.mesh,
            image: &m.image,
            sky_radius: m.sky_radius,
        })
        .collect();
    export::export_scene(path, &scene, local_to_world)
}

/// Store the layers' encodings in `pano` (spec §8.8; `pomc mesh --store`).
pub fn store(pano: &Panorama, layers: &[SceneMesh]) -> crate::Result<()> {
    let encoded: Vec<(usize, &[u8])> =
        layers.iter().filter_map(|l| Some((l.index, l.encoded.as_deref()?))).collect();
    super::stored::store(pano, &encoded)
}
