//! The main jobs, one call each, with the command line's defaults: every settings struct's
//! `Default` is what the `pomc` command does without options. [`crate::prelude`] re-exports them.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{DMat4, DVec3};

use crate::build::input::{self, Convention, DepthEncoding};
use crate::build::{self, BuildOptions, BuildReport};
use crate::colour::ColourSpace;
use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::manifest::{Manifest, Transform};
use crate::mapping::AnyMapping;
use crate::mesh::MeshParams;
use crate::panorama::{self, Panorama, SaveOptions};
use crate::render::{self, rasterize, Camera, Frame, MeshOptions, RenderLayer, SplatOptions, Stage};

/// Everything `pomc build` takes besides its input and output paths.
#[derive(Clone, Debug, Default)]
pub struct BuildSettings {
    /// Encoding of 8/16-bit colour (`--colour-space`).
    pub colour_space: ColourSpace,
    /// How depth is stored (`--preset`, `--depth-scale`, `--depth-invalid`, `--depth-kind`).
    pub depth: DepthEncoding,
    /// Normals image (`--normals-in`).
    pub normals_in: Option<PathBuf>,
    /// Azimuth convention of the input (`--convention`).
    pub convention: Convention,
    /// Panorama centre in the world (`--center`).
    pub center: Option<DVec3>,
    /// The build itself: freedom radius, edges, fill (the other `build` options).
    pub options: BuildOptions,
    /// How layers are stored (`--no-pack`).
    pub save: SaveOptions,
    /// Input size limits (`--max-pixels`).
    pub limits: ReadLimits,
}

/// What [`build_panorama`] wrote and measured.
#[derive(Clone, Debug)]
pub struct BuildSummary {
    /// The manifest as written (canvas sizes and packing filled in).
    pub manifest: Manifest,
    /// Per-layer figures of the build.
    pub report: BuildReport,
    /// Seconds spent reading the inputs, building and writing.
    pub read_s: f64,
    pub build_s: f64,
    pub write_s: f64,
}

/// Build a layered panorama from a colour and a depth image and write it into `output`, as
/// `pomc build` does.
///
/// ```no_run
/// use pomc::prelude::*;
/// let mut settings = BuildSettings::default();
/// settings.options.freedom_radius = 0.9;
/// let built = build_panorama("colour.png".as_ref(), "depth.exr".as_ref(), "out".as_ref(), &settings)?;
/// println!("{} layers", built.manifest.layers.len());
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn build_panorama(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
) -> crate::Result<BuildSummary> {
    build_panorama_with_progress(colour, depth, output, s, &|_| {})
}

/// [`build_panorama`], calling `progress` with each stage's name as it starts (the build's
/// stages, then `writing`).
pub fn build_panorama_with_progress(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuildSummary> {
    let t = Instant::now();
    let rgbd = input::load(colour, s.colour_space, depth, s.normals_in.as_deref(), &s.depth, &s.limits)?;
    let read_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let built = build::build(&rgbd, &s.options, progress)?;
    let build_s = t.elapsed().as_secs_f64();
    progress("writing");
    let t = Instant::now();
    let mut transforms = Vec::new();
    if let Some(c) = s.center {
        transforms.push(Transform::Translate(c.to_array()));
    }
    transforms.extend(s.convention.transforms());
    let manifest = build::manifest(&built, rgbd.mapping.kind(), s.options.freedom_radius, transforms);
    let images: Vec<LayerImage> = built.layers.into_iter().map(|l| l.image).collect();
    let manifest = panorama::write_panorama(output, &manifest, &images, &s.save)?;
    let write_s = t.elapsed().as_secs_f64();
    Ok(BuildSummary { manifest, report: built.report, read_s, build_s, write_s })
}

/// How [`Renderer`] draws a view (`pomc render --method`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RenderMethod {
    /// Adaptive point splatting (thesis Alg. 9-10).
    #[default]
    Splat,
    /// Z-buffered rasterisation of each layer's quadtree mesh (stored meshes decoded).
    Mesh,
}

/// One rendered view and its figures.
#[derive(Clone, Debug)]
pub struct View {
    pub frame: Frame,
    /// Output pixels no layer covers, and their share.
    pub holes: usize,
    pub hole_ratio: f64,
    /// The method's work counters.
    pub counts: serde_json::Value,
    pub stages: Vec<Stage>,
}

/// A panorama read (and for [`RenderMethod::Mesh`] meshed) once, to render any number of views.
///
/// ```no_run
/// use pomc::prelude::*;
/// let pano = Panorama::open("room-pomc".as_ref())?;
/// let renderer = Renderer::new(&pano, RenderMethod::Splat)?;
/// let eye = renderer.centre() + DVec3::new(0.2, 0.0, 0.0);
/// let camera = Camera::Perspective(Perspective::new(eye, eye + DVec3::Y, DVec3::Z, 60.0, 960, 540)?);
/// let view = renderer.render(&camera)?;
/// println!("{:.3} % holes", 100.0 * view.hole_ratio);
/// # Ok::<(), pomc::Error>(())
/// ```
pub struct Renderer {
    layers: Vec<(LayerImage, AnyMapping)>,
    local_to_world: DMat4,
    meshes: Option<rasterize::PanoramaMeshes>,
    read_s: f64,
    mesh_s: Option<f64>,
}

impl Renderer {
    /// Read every layer of `pano` (and mesh them for [`RenderMethod::Mesh`], with the quadtree
    /// parameters `render --method mesh` uses).
    pub fn new(pano: &Panorama, method: RenderMethod) -> crate::Result<Renderer> {
        let t = Instant::now();
        let layers = render::read_layers(pano, &ReadLimits::default())?;
        let read_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let meshes = match method {
            RenderMethod::Splat => None,
            RenderMethod::Mesh => {
                let refs = refs(&layers);
                Some(rasterize::panorama_meshes(
                    pano,
                    &refs,
                    &MeshParams::quadtree(),
                    &MeshOptions::default(),
                )?)
            }
        };
        let mesh_s = meshes.is_some().then(|| t.elapsed().as_secs_f64());
        Ok(Renderer { layers, local_to_world: pano.manifest.local_to_world(), meshes, read_s, mesh_s })
    }

    /// Number of layers drawn.
    pub fn layer_count(&self) -> usize {
        self.layers.len()
    }

    /// Seconds [`Renderer::new`] spent reading the layers and (mesh method) meshing them.
    pub fn setup_seconds(&self) -> (f64, Option<f64>) {
        (self.read_s, self.mesh_s)
    }

    /// The panorama centre in the world (the default eye).
    pub fn centre(&self) -> DVec3 {
        render::centre(self.local_to_world)
    }

    /// For the mesh method: each layer's mesh source (stored or built), the warnings about stored
    /// meshes that could not be used, and the triangle and border-pixel counts.
    pub fn mesh_info(&self) -> Option<(&[rasterize::MeshSource], &[String], usize, usize)> {
        self.meshes.as_ref().map(|(geometry, sources, warnings)| {
            let triangles = geometry.iter().map(|m| m.mesh_triangles).sum();
            let border = geometry.iter().map(|m| m.border_pixels).sum();
            (sources.as_slice(), warnings.as_slice(), triangles, border)
        })
    }

    /// Render the view from `camera`.
    pub fn render(&self, camera: &Camera) -> crate::Result<View> {
        let refs = refs(&self.layers);
        let to_world = self.local_to_world;
        Ok(match &self.meshes {
            None => view(render::render(&refs, to_world, camera, &SplatOptions::default())?),
            Some((geometry, ..)) => {
                view(rasterize::render_mesh(&refs, geometry, to_world, camera, &MeshOptions::default())?)
            }
        })
    }
}

fn refs(layers: &[(LayerImage, AnyMapping)]) -> Vec<RenderLayer<'_>> {
    layers.iter().map(|(image, mapping)| RenderLayer { image, mapping: *mapping }).collect()
}

fn view<C: serde::Serialize, O>(r: render::Rendered<C, O>) -> View {
    let s = r.stats;
    View {
        frame: r.frame,
        holes: s.holes,
        hole_ratio: s.hole_ratio,
        counts: serde_json::json!(s.counts),
        stages: s.stages,
    }
}
