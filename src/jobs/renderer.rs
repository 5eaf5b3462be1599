//! Views of a panorama read (and meshed) once: the renderer the render job and Python call.

use std::time::Instant;

use glam::{DMat4, DVec3};

use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::manifest::Manifest;
use crate::mapping::{AnyMapping, Mapping};
use crate::mesh::MeshOptions;
use crate::panorama::Panorama;
use crate::render::stereo::{self, StereoCamera};
use crate::render::CubeCamera;
use crate::render::{rasterize, Camera, Frame, RasterOptions, RenderLayer, SplatOptions, Stage};

crate::choice::choices! {
    /// How [`Renderer`] draws a view (`pomc render --method`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum RenderMethod (default Splat) {
        /// Adaptive 8-neighbourhood point splatting (thesis Alg. 10).
        Splat = "splat",
        /// Z-buffered rasterisation of each layer's adaptive quadtree mesh (thesis 7.4); a mesh stored
        /// with `pomc mesh --store` is decoded instead of rebuilt.
        Mesh = "mesh",
    }
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
