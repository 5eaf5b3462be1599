//! Views of a POMC from a displaced camera (thesis 7.3; spec §9, informative).
//!
//! [`render`] reprojects every layer into a [`Camera`] by adaptive point splatting
//! (`splat`, thesis Alg. 10 with the Alg. 9 filter), resolves visibility per output pixel with a
//! depth test (`accum`) — so the result does not depend on the layers' painter's order, which is
//! only valid from the centre — and returns a [`Frame`] (colour, camera distance, coverage) and
//! the figures of the run. [`rasterize::render_mesh`] is the other method: z-buffered rasterisation
//! of each layer's quadtree mesh. [`metrics`] compares frames for the evaluation harness.
//!
//! - [`camera`]: perspective and equirect output cameras;
//! - [`ods`]: one eye of an omnidirectional stereo panorama;
//! - [`stereo`]: stereo cameras and layouts;
//! - [`cube`]: cube-map outputs, mono and stereo;
//! - `splat`: reprojection, adaptive sub-sampling, tiling and threads;
//! - `accum`: per-pixel visibility and filter sums;
//! - [`rasterize`]: the mesh method (meshes, footprints, rasterisation, deferred colour);
//! - [`image`]: the frame and its files (EXR, tone-mapped PNG, mask);
//! - [`metrics`]: PSNR, WS-PSNR, depth error.

/// `add` of a struct of counters: the sum, field by field.
macro_rules! add_counts {
    ($ty:ident: $($f:ident),*) => {
        impl $ty {
            fn add(self, o: $ty) -> $ty {
                $ty { $($f: self.$f + o.$f),* }
            }
        }
    };
}

pub(crate) mod accum;
pub mod camera;
mod checks;
pub mod cube;
pub mod frame;
pub mod metrics;
pub mod ods;
pub mod rasterize;
pub(crate) mod splat;
pub mod stereo;

use std::path::PathBuf;
use std::time::Instant;

use glam::DMat4;
use serde::Serialize;

pub use camera::{Camera, EquirectCamera, HalfEquirect, OdsEye, Perspective, PoleMerge};
pub use cube::CubeCamera;
pub use frame::Frame;
pub use rasterize::{MeshRenderStats, MeshRendered, RasterCounts, RasterOptions};
pub use splat::{SplatCounts, SplatOptions};
pub use stereo::{StereoCamera, StereoLayout};

use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::mapping::{AnyMapping, Mapping, MappingKind};
use crate::panorama::Panorama;

/// Half-size of a border pixel's footprint towards the border, layer pixels (a valid pixel cut
/// from a neighbour: outside the layer or across a jump): over ½, so that the edges of two layers
/// that meet (each sampled at pixel centres, extrapolated) overlap rather than leave a crack;
/// silhouettes grow by ¼ layer pixel. Both methods (spec §9.3, §9.4).
pub(crate) const BORDER_FOOTPRINT: f64 = 0.75;

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A camera input is non-finite, the field of view is outside (0, 180) degrees, the look-at
    /// point is the eye, or LocalToWorld is not an invertible finite transform.
    #[error("bad camera: {0}")]
    BadCamera(String),
    /// The output size is zero, over [`camera::MAX_SIDE`] or [`camera::MAX_PIXELS`], or not the
    /// shape the camera makes (`need` says which).
    #[error("bad output size {width}x{height}: {need}")]
    BadSize {
        /// Requested width, pixels (the whole image).
        width: usize,
        /// Requested height, pixels.
        height: usize,
        /// What the camera needs.
        need: &'static str,
    },
    /// A splat or mesh render option or mesh parameter is out of range, or meshes and layers differ
    /// in number.
    #[error("bad render options: {0}")]
    BadOptions(String),
    /// The panorama declares no layer.
    #[error("nothing to render: the panorama has no layers")]
    NoLayers,
    /// A layer lacks one of the channels rendering needs (R, G, B, Z).
    #[error("layer {index} has no `{channel}` channel; rendering needs R, G, B and Z")]
    LayerChannel {
        /// The layer's position in the list rendered (manifest order from [`read_layers`]).
        index: usize,
        /// Name of the missing channel.
        channel: &'static str,
    },
    /// A layer's size is not a valid canvas of the panorama's mapping.
    #[error("layer {index} is {width}x{height}, not a valid {kind:?} canvas")]
    LayerSize {
        /// The layer's position in the list rendered.
        index: usize,
        /// Layer width, pixels.
        width: usize,
        /// Layer height, pixels.
        height: usize,
        /// The mapping the canvas should fit.
        kind: MappingKind,
    },
    /// A layer could not be meshed, or a given mesh does not belong to its layer.
    #[error("mesh of layer {index}: {message}")]
    Mesh {
        /// The layer's position in the list rendered.
        index: usize,
        /// What went wrong.
        message: String,
    },
    /// The output file's extension is not one the writer supports.
    #[error("{path}: unsupported output file type; use {expected}")]
    OutputFormat {
        /// The output path given.
        path: PathBuf,
        /// The extensions accepted, for the message (e.g. `"png or exr"`).
        expected: &'static str,
    },
    /// A camera path cannot be read or has a malformed line or no frames, or an output name has
    /// no run of `#` for a path's frame numbers.
    #[error("{0}")]
    CameraPath(String),
}

crate::codes::error_codes! {
    RenderError:
        BadCamera RENDER_BAD_CAMERA,
        BadSize RENDER_BAD_SIZE,
        BadOptions RENDER_BAD_OPTIONS,
        NoLayers RENDER_NO_LAYERS,
        LayerChannel RENDER_LAYER_CHANNEL,
        LayerSize RENDER_LAYER_SIZE,
        Mesh RENDER_MESH,
        OutputFormat RENDER_OUTPUT_FORMAT,
        CameraPath RENDER_CAMERA_PATH
}

/// One layer to render: its full-canvas image and parametrisation.
#[derive(Clone, Copy, Debug)]
pub struct RenderLayer<'a> {
    /// The layer's pixels: R, G, B and Z are required, A (coverage) is optional.
    pub image: &'a LayerImage,
    /// The layer's canvas mapping; its size must equal the image's.
    pub mapping: AnyMapping,
}

impl<'a> RenderLayer<'a> {
    /// The layers as [`read_layers`] gives them (image and mapping pairs), ready to render.
    pub fn all(layers: &'a [(LayerImage, AnyMapping)]) -> Vec<RenderLayer<'a>> {
        layers.iter().map(|(image, mapping)| RenderLayer { image, mapping: *mapping }).collect()
    }
}

/// Wall-clock time of one stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stage {
    /// Stage name, e.g. `"splat"` or `"resolve"`.
    pub name: &'static str,
    /// Wall-clock duration, seconds.
    pub seconds: f64,
}

/// Figures of one render: the work counters `C` and options `O` are those of the method (splat by
/// default; the mesh method's are [`MeshRenderStats`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderStats<C = SplatCounts, O = SplatOptions> {
    /// Output width, pixels.
    pub width: usize,
    /// Output height, pixels.
    pub height: usize,
    /// Number of layers rendered.
    pub layers: usize,
    /// Output pixels no layer covers.
    pub holes: usize,
    /// `holes` over the output pixel count, in [0, 1].
    pub hole_ratio: f64,
    /// The method's work counters.
    pub counts: C,
    /// The options the method ran with.
    pub options: O,
    /// Wall-clock time of each stage, in order.
    pub stages: Vec<Stage>,
}

/// A rendered view.
#[derive(Clone, Debug)]
pub struct Rendered<C = SplatCounts, O = SplatOptions> {
    /// The output image: colour, camera distance and coverage.
    pub frame: Frame,
    /// Figures of the run.
    pub stats: RenderStats<C, O>,
}

fn check_options(o: &SplatOptions) -> Result<(), RenderError> {
    let bad = |what: &str| Err(RenderError::BadOptions(what.to_string()));
    if !(o.radius > 0.0 && o.radius <= 8.0) {
        return bad("radius must lie in (0, 8] pixels");
    }
    if !(o.spacing > 0.0 && o.spacing <= 2.0 * o.radius) {
        return bad("spacing must lie in (0, 2 × radius]");
    }
    if !(o.jump > 0.0 && o.jump.is_finite()) {
        return bad("jump must be a positive relative depth");
    }
    if !(0.0..1.0).contains(&o.tolerance) {
        return bad("tolerance must lie in [0, 1)");
    }
    if !(1..=256).contains(&o.max_subsamples) {
        return bad("max_subsamples must lie in 1..=256");
    }
    Ok(())
}

/// Every layer's canvas matches its mapping and holds R, G, B and Z (both methods).
pub(crate) fn check_layers(layers: &[RenderLayer]) -> Result<(), RenderError> {
    for (index, l) in layers.iter().enumerate() {
        if (l.image.width, l.image.height) != (l.mapping.width(), l.mapping.height()) {
            return Err(RenderError::LayerSize {
                index,
                width: l.image.width,
                height: l.image.height,
                kind: l.mapping.kind(),
            });
        }
        for channel in ["R", "G", "B", "Z"] {
            if l.image.channel(channel).is_none() {
                return Err(RenderError::LayerChannel { index, channel });
            }
        }
    }
    Ok(())
}

/// Both methods render through a LocalToWorld that must be finite and invertible.
fn check_local_to_world(local_to_world: DMat4) -> Result<(), RenderError> {
    if !local_to_world.is_finite() || local_to_world.determinant() == 0.0 {
        return Err(RenderError::BadCamera("LocalToWorld is not an invertible finite transform".into()));
    }
    Ok(())
}

/// Render `layers` (placed in the world by `local_to_world`) into `camera`.
pub fn render(
    layers: &[RenderLayer],
    local_to_world: DMat4,
    camera: &Camera,
    o: &SplatOptions,
) -> Result<Rendered, RenderError> {
    let mut views = render_views(layers, local_to_world, std::slice::from_ref(camera), o)?;
    Ok(views.remove(0))
}

/// Render `layers` into each of `cameras`, as [`render`] does one. Cameras next to each other that
/// share a camera space (the two eyes of an ODS camera) are splatted in one pass, which finds each
/// layer pixel's surface and sub-samples once for both (and, for ODS eyes, solves each projection
/// once); a shared pass's time is split evenly between its views.
pub fn render_views(
    layers: &[RenderLayer],
    local_to_world: DMat4,
    cameras: &[Camera],
    o: &SplatOptions,
) -> Result<Vec<Rendered>, RenderError> {
    check_options(o)?;
    check_local_to_world(local_to_world)?;
    check_layers(layers)?;
    let planes = layers
        .iter()
        .enumerate()
        .map(|(index, l)| {
            splat::LayerPlanes::new(l.image, l.mapping)
                .map_err(|channel| RenderError::LayerChannel { index, channel })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut out = Vec::with_capacity(cameras.len());
    let mut rest = cameras;
    while let Some(first) = rest.first() {
        // The first camera always makes a pass (a NaN transform equals nothing, not even itself).
        let shared = 1 + rest[1..]
            .iter()
            .take(splat::MAX_VIEWS - 1)
            .take_while(|c| c.to_camera() == first.to_camera())
            .count();
        let (pass, tail) = rest.split_at(shared);
        rest = tail;
        let t = Instant::now();
        let (accs, counts) = splat::splat_layers(&planes, local_to_world, pass, o);
        let splat_s = t.elapsed().as_secs_f64() / pass.len() as f64;
        for (acc, counts) in accs.iter().zip(counts) {
            let t = Instant::now();
            let frame = Frame::from_accum(acc);
            let holes = frame.holes();
            let stats = RenderStats {
                width: frame.width,
                height: frame.height,
                layers: layers.len(),
                holes,
                hole_ratio: frame.hole_ratio(),
                counts,
                options: *o,
                stages: vec![
                    Stage { name: "splat", seconds: splat_s },
                    Stage { name: "resolve", seconds: t.elapsed().as_secs_f64() },
                ],
            };
            out.push(Rendered { frame, stats });
        }
    }
    Ok(out)
}

/// Read every layer of a panorama as full canvases with their mappings, in manifest order.
pub fn read_layers(pano: &Panorama, limits: &ReadLimits) -> crate::Result<Vec<(LayerImage, AnyMapping)>> {
    let kind = pano.manifest.mapping.kind;
    if pano.manifest.layers.is_empty() {
        return Err(RenderError::NoLayers.into());
    }
    let layers = pano.read_layers(limits)?;
    layers
        .into_iter()
        .enumerate()
        .map(|(index, image)| {
            let mapping = layer_mapping(kind, index, &image)?;
            Ok((image, mapping))
        })
        .collect()
}

/// The mapping of layer `index`'s canvas, or the error naming the layer whose size does not fit it.
pub fn layer_mapping(kind: MappingKind, index: usize, image: &LayerImage) -> Result<AnyMapping, RenderError> {
    AnyMapping::new(kind, image.width, image.height).map_err(|_| RenderError::LayerSize {
        index,
        width: image.width,
        height: image.height,
        kind,
    })
}
