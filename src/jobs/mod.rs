//! The main jobs, one call each, with the command line's defaults: every settings struct's
//! `Default` is what the `pomc` command does without options. [`crate::prelude`] re-exports them.

mod pack;
#[cfg(feature = "clap")]
mod render;

pub use pack::{repack_panorama, RepackReport, RepackSettings, RepackTimings, RepackedLayer};
#[cfg(feature = "clap")]
pub use render::{
    read_camera_path, render_panorama, FrameReport, MeshReport, PathReport, PathStages, RenderReport,
    RenderSettings, Shot, ViewReport,
};

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{DMat4, DVec3};

use crate::colour::ColourSpace;
use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::layering::input::{self, Convention, DepthEncoding};
use crate::layering::{self, BuildOptions, BuildReport};
use crate::manifest::{Manifest, Transform};
use crate::mapping::{AnyMapping, Mapping};
use crate::mesh::MeshOptions;
use crate::panorama::{self, Panorama, SaveOptions};
use crate::prepare::{self, DepthSamples, PrepareOptions, PrepareReport, PreparedDepth, SampleFormat};
use crate::render::stereo::{self, StereoCamera};
use crate::render::CubeCamera;
use crate::render::{rasterize, Camera, Frame, RasterOptions, RenderLayer, SplatOptions, Stage};

/// Everything `pomc build` takes besides its input and output paths.
#[derive(Clone, Debug, Default)]
pub struct BuildSettings {
    /// Encoding of 8/16-bit colour (`--colour-space`).
    pub colour_space: ColourSpace,
    /// How depth is stored (`--preset`, `--depth-scale`, `--depth-invalid`, `--depth-kind`,
    /// `--depth-range`, `--camera-height`).
    pub depth: DepthEncoding,
    /// How the depth is prepared for layering (`--refine`, `--unknown-depth`).
    pub prepare: PrepareOptions,
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
    /// Per-layer figures of the build (its `stages` start with `prepare`).
    pub report: BuildReport,
    /// What the depth preparation found and did.
    pub prepare: PrepareReport,
    /// Seconds spent reading the input images (colour, depth, normals).
    pub read_s: f64,
    /// Seconds spent building the layers in memory.
    pub build_s: f64,
    /// Seconds spent writing the layer files and the manifest.
    pub write_s: f64,
}

/// Build a layered panorama from a colour and a depth image and write it into `output`, as
/// `pomc build` does.
///
/// ```
/// use pomc::prelude::*;
/// let (dir, out) = (std::path::Path::new("fixtures/data/room-rgbd"), std::env::temp_dir().join("pomc-doc-build"));
/// let mut settings = BuildSettings::default();
/// settings.options.freedom_radius = 0.5;
/// let built = build_panorama(&dir.join("colour.png"), &dir.join("depth.exr"), &out, &settings)?;
/// assert!(built.manifest.layers.len() >= 2, "background and objects");
/// assert!(validate(&out, &ValidateSettings::default())?.valid);
/// # std::fs::remove_dir_all(&out).ok();
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

/// The name of the depth preparation stage in progress and timings.
pub const PREPARE_STAGE: &str = "prepare";

/// Every stage [`build_panorama_with_progress`] names, in order: `prepare`, the build's
/// ([`layering::stages`]), `writing` (a progress bar's length).
pub fn build_stages(s: &BuildSettings) -> Vec<&'static str> {
    let mut v = vec![PREPARE_STAGE];
    v.extend(layering::stages(&s.options));
    v.push(WRITING_STAGE);
    v
}

/// The name of the writing stage in progress.
pub const WRITING_STAGE: &str = "writing";

/// [`build_panorama`], calling `progress` with each stage's name as it starts (`prepare`, the
/// build's stages, then `writing`).
pub fn build_panorama_with_progress(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuildSummary> {
    let t = Instant::now();
    let files = input::read(colour, s.colour_space, depth, s.normals_in.as_deref(), &s.limits)?;
    let read_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (rgbd, prepare, prepare_s) = prepare_stage(files, depth, s, progress)?;
    let kind = rgbd.mapping.kind();
    let layered = layering::layer(rgbd, &s.options, progress)?;
    let build_s = t.elapsed().as_secs_f64();
    progress(WRITING_STAGE);
    let t = Instant::now();
    // Each layer's image is made as it is written (its time counts in `write_s`): one full
    // canvas in memory at a time.
    let manifest = layered.manifest(kind, s.options.freedom_radius, transforms(s));
    let manifest = panorama::write_panorama_with(output, &manifest, &|k| Ok(layered.image(k)), &s.save)?;
    let write_s = t.elapsed().as_secs_f64();
    let mut report = layered.report;
    report.stages.insert(0, (PREPARE_STAGE, prepare_s));
    Ok(BuildSummary { manifest, report, prepare, read_s, build_s, write_s })
}

/// Read `colour` and `depth` and prepare the depth as `pomc build` does before layering
/// (`pomc prepare`): metres along the ray on the colour's grid, with what was found and done.
///
/// ```
/// use pomc::prelude::*;
/// let dir = std::path::Path::new("fixtures/data/room-rgbd");
/// let settings = BuildSettings::default();
/// let prepared = prepare_depth_files(&dir.join("colour.png"), &dir.join("depth.exr"), &settings)?;
/// assert_eq!(prepared.depth.len(), prepared.width * prepared.height);
/// assert!(!prepared.report.resized, "depth of the colour's size is not resampled");
/// // Estimator output instead: `settings.depth.kind = DepthKind::Inverse` with
/// // `settings.depth.camera_height = Some(1.6)` for its scale.
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn prepare_depth_files(colour: &Path, depth: &Path, s: &BuildSettings) -> crate::Result<PreparedDepth> {
    let files = input::read(colour, s.colour_space, depth, None, &s.limits)?;
    let prepared =
        prepare::prepare_depth(depth, &files.mapping, &files.rgb, &files.depth, &s.depth, &s.prepare)?;
    Ok(prepared)
}

/// Write prepared depth as a one-channel (`Z`, float) OpenEXR of the colour's size, atomically.
pub fn write_depth(path: &Path, width: usize, height: usize, depth: &[f32]) -> crate::Result<()> {
    let mut img = LayerImage::new(width, height);
    img.set_channel("Z", crate::layer::SampleType::F32, depth.to_vec());
    crate::layer_io::write_exr(path, &img, &crate::layer_io::WriteOptions::default())
}

/// A panorama built in memory: its manifest (without canvas sizes or packing yet) and full-canvas
/// layers, in manifest order.
#[derive(Clone, Debug)]
pub struct BuiltPanorama {
    /// The manifest, with no canvas sizes or packing filled in yet.
    pub manifest: Manifest,
    /// Full-canvas layer images, in manifest order.
    pub layers: Vec<LayerImage>,
    /// Per-layer figures of the build.
    pub report: BuildReport,
}

/// Build from an RGB-D panorama already read ([`build_panorama`] without the files).
pub fn build_rgbd(
    rgbd: layering::RgbdInput,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuiltPanorama> {
    let kind = rgbd.mapping.kind();
    let built = layering::build(rgbd, &s.options, progress)?;
    let manifest = layering::manifest(&built, kind, s.options.freedom_radius, transforms(s));
    let layers = built.layers.into_iter().map(|l| l.image).collect();
    Ok(BuiltPanorama { manifest, layers, report: built.report })
}

/// The manifest's transforms of a build: the centre (`--center`), then the input's convention.
fn transforms(s: &BuildSettings) -> Vec<Transform> {
    let mut transforms = Vec::new();
    if let Some(c) = s.center {
        transforms.push(Transform::Translate(c.to_array()));
    }
    transforms.extend(s.convention.transforms());
    transforms
}

/// Build from images in memory: `colour` interleaved RGB and `depth` (stored values, read with
/// `s.depth` as files are: float metres by default), both `width` × `height`.
pub fn build_arrays(
    width: usize,
    height: usize,
    colour: input::ColourSamples,
    depth: &[f32],
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuiltPanorama> {
    let name = Path::new("<array>");
    let n = width.saturating_mul(height);
    let colour_len = match colour {
        input::ColourSamples::U8(v) => v.len(),
        input::ColourSamples::U16(v) => v.len(),
        input::ColourSamples::F32(v) => v.len(),
    };
    if colour_len != n.saturating_mul(3) || depth.len() != n {
        return Err(input::InputError::SizeMismatch {
            colour: name.into(),
            cw: width,
            ch: colour_len / width.max(1) / 3,
            depth: name.into(),
            dw: width,
            dh: depth.len() / width.max(1),
        }
        .into());
    }
    s.limits.check(width as u64, height as u64, 4).map_err(|limit| input::InputError::TooLarge {
        path: name.into(),
        width: width as u64,
        height: height as u64,
        limit,
    })?;
    let mapping = input::mapping_for(name, width, height)?;
    let rgb = input::colour_planes(colour, s.colour_space);
    let normals = s
        .normals_in
        .as_deref()
        .map(|p| input::read_normals(p, name, width, height, &s.limits))
        .transpose()?;
    let samples = DepthSamples {
        width,
        height,
        values: depth.to_vec(),
        format: SampleFormat::F32,
        colour_channels: false,
    };
    let files = input::RgbdFiles { mapping, rgb, depth: samples, normals };
    let (rgbd, _, prepare_s) = prepare_stage(files, name, s, progress)?;
    let mut built = build_rgbd(rgbd, s, progress)?;
    built.report.stages.insert(0, (PREPARE_STAGE, prepare_s));
    Ok(built)
}

/// The `prepare` stage: the build's input, what preparing found, and its time (the report's
/// first stage).
fn prepare_stage(
    files: input::RgbdFiles,
    depth: &Path,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<(layering::RgbdInput, PrepareReport, f64)> {
    progress(PREPARE_STAGE);
    let t = Instant::now();
    let (rgbd, prepare) = files.prepare(depth, &s.depth, &s.prepare)?;
    Ok((rgbd, prepare, t.elapsed().as_secs_f64()))
}

/// What [`scene_panorama`] wrote and measured.
#[derive(Clone, Debug)]
pub struct SceneSummary {
    /// The manifest as written.
    pub manifest: Manifest,
    /// What making the layers did, stage by stage.
    pub report: crate::scene::BakeReport,
    /// Seconds spent reading the scene (geometry and textures).
    pub read_s: f64,
    /// Seconds spent writing the layer files and the manifest.
    pub write_s: f64,
}

/// Every stage [`scene_panorama`] names, in order: `reading`, the tracing's
/// ([`crate::scene::STAGES`]), `writing` (a progress bar's length).
pub fn scene_stages() -> Vec<&'static str> {
    let mut v = vec![READING_STAGE];
    v.extend(crate::scene::STAGES);
    v.push(WRITING_STAGE);
    v
}

/// The name of the scene reading stage in progress.
pub const READING_STAGE: &str = "reading";

/// Make a layered panorama from a 3D scene (`.gltf`, `.glb`, `.obj`) by tracing every hit from the
/// centre (thesis 6.3.2) and write it into `output`, as `pomc scene` does; `progress` is called
/// with each stage's name as it starts.
///
/// ```no_run
/// use pomc::prelude::*;
/// let mut settings = BakeSettings::default();
/// settings.center = glam::DVec3::new(0.0, 0.0, 1.6);
/// let made = scene_panorama("room.glb".as_ref(), "room-pomc".as_ref(), &settings, &|_| {})?;
/// println!("{} layers", made.manifest.layers.len());
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn scene_panorama(
    input: &Path,
    output: &Path,
    s: &crate::scene::BakeSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<SceneSummary> {
    s.mapping()?;
    progress(READING_STAGE);
    let t = Instant::now();
    let scene = crate::scene::load::read(input, s.center, s.max_triangles)?;
    let read_s = t.elapsed().as_secs_f64();
    let baked = crate::scene::bake(&scene, s, progress)?;
    drop(scene);
    progress(WRITING_STAGE);
    let t = Instant::now();
    let transforms =
        if s.center == DVec3::ZERO { vec![] } else { vec![Transform::Translate(s.center.to_array())] };
    let manifest = layering::layers_manifest(&baked.layers, s.mapping, s.freedom_radius, transforms);
    let images: Vec<LayerImage> = baked.layers.into_iter().map(|l| l.image).collect();
    let manifest = panorama::write_panorama(output, &manifest, &images, &s.save)?;
    Ok(SceneSummary { manifest, report: baked.report, read_s, write_s: t.elapsed().as_secs_f64() })
}

/// How [`Renderer`] draws a view (`pomc render --method`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum RenderMethod {
    /// Adaptive 8-neighbourhood point splatting (thesis Alg. 10).
    #[default]
    Splat,
    /// Z-buffered rasterisation of each layer's adaptive quadtree mesh (thesis 7.4); a mesh stored
    /// with `pomc mesh --store` is decoded instead of rebuilt.
    Mesh,
}

/// What a view is seen through: one camera, or a stereo pair whose eyes make one image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewCamera {
    /// One camera.
    Mono(Camera),
    /// Two eyes, stacked by their layout.
    Stereo(StereoCamera),
    /// A cube map, mono or stereo.
    Cube(CubeCamera),
}

impl ViewCamera {
    /// Width and height of the whole image.
    pub fn size(&self) -> (usize, usize) {
        match self {
            ViewCamera::Mono(c) => (c.width(), c.height()),
            ViewCamera::Stereo(s) => s.size(),
            ViewCamera::Cube(c) => c.size(),
        }
    }
}

/// One rendered view and its figures.
#[derive(Clone, Debug)]
pub struct View {
    /// The rendered colour, depth and coverage.
    pub frame: Frame,
    /// Output pixels no layer covers, and their share.
    pub holes: usize,
    /// Fraction of output pixels that are holes, in [0, 1].
    pub hole_ratio: f64,
    /// The method's work counters.
    pub counts: serde_json::Value,
    /// Wall-clock time of each stage of the render, in order.
    pub stages: Vec<Stage>,
}

/// A panorama read (and for [`RenderMethod::Mesh`] meshed) once, to render any number of views.
///
/// ```
/// use pomc::prelude::*;
/// let pano = Panorama::open("fixtures/data/room-equirect".as_ref())?;
/// let renderer = Renderer::new(&pano, RenderMethod::Mesh)?;
/// for x in [0.1, 0.2] {
///     let eye = renderer.centre() + DVec3::new(x, 0.0, 0.0);
///     let camera = Camera::Perspective(Perspective::new(eye, eye + DVec3::Y, DVec3::Z, 60.0, 160, 90)?);
///     let view = renderer.render(&camera)?;
///     assert!(view.hole_ratio < 0.01, "{:.3} % holes", 100.0 * view.hole_ratio);
/// }
/// # Ok::<(), pomc::Error>(())
/// ```
pub struct Renderer {
    layers: Vec<(LayerImage, AnyMapping)>,
    local_to_world: DMat4,
    freedom_radius: f64,
    meshes: Option<rasterize::PanoramaMeshes>,
    read_s: f64,
    mesh_s: Option<f64>,
}

impl Renderer {
    /// Read every layer of `pano` (and mesh them for [`RenderMethod::Mesh`], with the quadtree
    /// parameters `render --method mesh` uses).
    pub fn new(pano: &Panorama, method: RenderMethod) -> crate::Result<Renderer> {
        let t = Instant::now();
        let layers = crate::render::read_layers(pano, &ReadLimits::default())?;
        let read_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let meshes = match method {
            RenderMethod::Splat => None,
            RenderMethod::Mesh => {
                let refs = RenderLayer::all(&layers);
                Some(rasterize::panorama_meshes(
                    pano,
                    &refs,
                    &MeshOptions::quadtree(),
                    &RasterOptions::default(),
                )?)
            }
        };
        let mesh_s = meshes.is_some().then(|| t.elapsed().as_secs_f64());
        let (local_to_world, freedom_radius) = (pano.manifest.local_to_world(), pano.manifest.freedom_radius);
        Ok(Renderer { layers, local_to_world, freedom_radius, meshes, read_s, mesh_s })
    }

    /// A renderer over layers already in memory (full canvases, in manifest order) placed by
    /// `manifest`; the mesh method builds every layer's mesh (no stored ones to decode).
    pub fn from_layers(
        manifest: &Manifest,
        images: Vec<LayerImage>,
        method: RenderMethod,
    ) -> crate::Result<Renderer> {
        let kind = manifest.mapping.kind;
        if images.is_empty() {
            return Err(crate::render::RenderError::NoLayers.into());
        }
        let layers = images
            .into_iter()
            .enumerate()
            .map(|(index, image)| {
                let mapping = crate::render::layer_mapping(kind, index, &image)?;
                Ok((image, mapping))
            })
            .collect::<crate::Result<Vec<_>>>()?;
        let t = Instant::now();
        let meshes = match method {
            RenderMethod::Splat => None,
            RenderMethod::Mesh => {
                let geometry = rasterize::mesh_layers(
                    &RenderLayer::all(&layers),
                    &MeshOptions::quadtree(),
                    &RasterOptions::default(),
                )?;
                let sources = vec![rasterize::MeshSource::Built; geometry.len()];
                Some((geometry, sources, Vec::new()))
            }
        };
        let mesh_s = meshes.is_some().then(|| t.elapsed().as_secs_f64());
        let (local_to_world, freedom_radius) = (manifest.local_to_world(), manifest.freedom_radius);
        Ok(Renderer { layers, local_to_world, freedom_radius, meshes, read_s: 0.0, mesh_s })
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
        crate::manifest::centre(self.local_to_world)
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

    /// Width of an equirect with the layers' angular resolution (the canvas width, or 4 faces of a
    /// cube map): the default width of a panoramic output.
    pub fn panorama_width(&self) -> usize {
        match &self.layers[0].1 {
            AnyMapping::Equirect(m) => m.width(),
            AnyMapping::Cube(c) => 4 * c.face_size(),
        }
    }

    /// Render the view through `camera`, mono or stereo (the eyes rendered, then stacked;
    /// holes and counts are both eyes', stage times their sums).
    pub fn render_view(&self, camera: &ViewCamera) -> crate::Result<View> {
        let eyes = match camera {
            ViewCamera::Mono(_) | ViewCamera::Cube(CubeCamera { right: None, .. }) => None,
            ViewCamera::Stereo(s) => Some((&s.left, &s.right)),
            ViewCamera::Cube(CubeCamera { left, right: Some(right), .. }) => Some((left, right)),
        };
        if let Some((left, right)) = eyes {
            self.check_eyes(left, right)?;
        }
        match camera {
            ViewCamera::Mono(c) => self.render(c),
            ViewCamera::Cube(c) => {
                let Some(right) = &c.right else {
                    let mut l = self.render(&c.left)?;
                    l.frame = crate::render::cube::to_cube(&l.frame, c.face, c.layout)?;
                    l.holes = l.frame.holes();
                    l.hole_ratio = l.frame.hole_ratio();
                    return Ok(l);
                };
                let (mut l, mut r) = self.render_eyes(&c.left, right)?;
                l.frame = crate::render::cube::to_cube(&l.frame, c.face, c.layout)?;
                r.frame = crate::render::cube::to_cube(&r.frame, c.face, c.layout)?;
                Ok(stereo_view(l, r, |a, b| stereo::stack_eyes(a, b, c.stereo)))
            }
            ViewCamera::Stereo(s) => {
                let (l, r) = self.render_eyes(&s.left, &s.right)?;
                Ok(stereo_view(l, r, |a, b| stereo::stack(a, b, s)))
            }
        }
    }

    /// Stereo eyes must sit inside the freedom radius around their view's centre: beyond it nothing
    /// was kept for them to see, and an ODS viewing circle wider than the scene puts every surface
    /// inside the viewer's head, where the projection's solve and the splat's footprints grow
    /// without bound (an IPD of 100 m took minutes for a 256 × 256 image).
    fn check_eyes(&self, left: &Camera, right: &Camera) -> crate::Result<()> {
        let half = match left {
            Camera::Ods(e) => e.offset.abs(),
            _ => (left.eye() - right.eye()).length() / 2.0,
        };
        let r = self.freedom_radius;
        if half <= r * (1.0 + 1e-9) {
            return Ok(());
        }
        Err(crate::render::RenderError::BadCamera(format!(
            "--ipd {} m puts each eye {half} m from the view's centre, beyond the panorama's freedom radius \
             {r} m, where nothing was kept for it to see; give --ipd at most {} m",
            2.0 * half,
            2.0 * r
        ))
        .into())
    }

    /// Render both eyes: the splat renders them in one pass where they share a camera space
    /// ([`crate::render::render_views`]), the mesh one after the other.
    fn render_eyes(&self, left: &Camera, right: &Camera) -> crate::Result<(View, View)> {
        if self.meshes.is_some() {
            return Ok((self.render(left)?, self.render(right)?));
        }
        let refs = RenderLayer::all(&self.layers);
        let cameras = [*left, *right];
        // One view per camera.
        let [l, r]: [crate::render::Rendered; 2] =
            crate::render::render_views(&refs, self.local_to_world, &cameras, &SplatOptions::default())?
                .try_into()
                .map_err(|_| crate::render::RenderError::BadOptions("two eyes, two views".into()))?;
        Ok((view(l), view(r)))
    }

    /// Render the view from `camera`.
    pub fn render(&self, camera: &Camera) -> crate::Result<View> {
        let refs = RenderLayer::all(&self.layers);
        let to_world = self.local_to_world;
        Ok(match &self.meshes {
            None => view(crate::render::render(&refs, to_world, camera, &SplatOptions::default())?),
            Some((geometry, ..)) => {
                view(rasterize::render_mesh(&refs, geometry, to_world, camera, &RasterOptions::default())?)
            }
        })
    }
}

/// Two eyes' views as one: the frame `stack` makes of theirs, holes and counts of both, stage
/// times summed.
fn stereo_view(l: View, r: View, stack: impl Fn(&Frame, &Frame) -> Frame) -> View {
    let frame = stack(&l.frame, &r.frame);
    let mut stages = l.stages;
    for (a, b) in stages.iter_mut().zip(&r.stages) {
        a.seconds += b.seconds;
    }
    View {
        holes: frame.holes(),
        hole_ratio: frame.hole_ratio(),
        counts: serde_json::json!({"left": l.counts, "right": r.counts}),
        frame,
        stages,
    }
}

fn view<C: serde::Serialize, O>(r: crate::render::Rendered<C, O>) -> View {
    let s = r.stats;
    View {
        frame: r.frame,
        holes: s.holes,
        hole_ratio: s.hole_ratio,
        counts: serde_json::json!(s.counts),
        stages: s.stages,
    }
}
