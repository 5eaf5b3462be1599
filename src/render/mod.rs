//! Views of a POMC from a displaced camera (thesis 7.3; spec §9, informative).
//!
//! [`render`] reprojects every layer into a [`Camera`] by adaptive point splatting
//! ([`splat`], thesis Alg. 10 with the Alg. 9 filter), resolves visibility per output pixel with a
//! depth test ([`accum`]) — so the result does not depend on the layers' painter's order, which is
//! only valid from the centre — and returns a [`Frame`] (colour, camera distance, coverage) and
//! the figures of the run. [`rasterize::render_mesh`] is the other method: z-buffered rasterisation
//! of each layer's quadtree mesh. [`metrics`] compares frames for the evaluation harness.
//!
//! - [`camera`]: perspective and equirect output cameras;
//! - [`splat`]: reprojection, adaptive sub-sampling, tiling and threads;
//! - [`accum`]: per-pixel visibility and filter sums;
//! - [`rasterize`]: the mesh method (meshes, footprints, rasterisation, deferred colour);
//! - [`image`]: the frame and its files (EXR, tone-mapped PNG, mask);
//! - [`metrics`]: PSNR, WS-PSNR, depth error.

pub mod accum;
pub mod camera;
pub mod image;
pub mod metrics;
pub mod rasterize;
pub mod splat;

use std::path::PathBuf;
use std::time::Instant;

use glam::{DMat4, DVec3};
use rayon::prelude::*;
use serde::Serialize;

pub use camera::{Camera, EquirectCamera, Perspective};
pub use image::Frame;
pub use rasterize::{MeshOptions, MeshRenderStats, MeshRendered, RasterCounts};
pub use splat::{SplatCounts, SplatOptions};

use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::manifest::MappingKind as DeclKind;
use crate::mapping::{AnyMapping, Mapping, MappingKind};
use crate::panorama::Panorama;

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("bad camera: {0}")]
    BadCamera(String),
    #[error("bad output size {width}x{height}: sides 1..={max}, equirect outputs 2:1", max = camera::MAX_SIDE)]
    BadSize { width: usize, height: usize },
    #[error("bad render options: {0}")]
    BadOptions(String),
    #[error("nothing to render: the panorama has no layers")]
    NoLayers,
    #[error("layer {index} has no `{channel}` channel; rendering needs R, G, B and Z")]
    LayerChannel { index: usize, channel: &'static str },
    #[error("layer {index} is {width}x{height}, not a valid {kind:?} canvas")]
    LayerSize { index: usize, width: usize, height: usize, kind: MappingKind },
    #[error("mesh of layer {index}: {message}")]
    Mesh { index: usize, message: String },
    #[error("{path}: unsupported output file type; use {expected}")]
    OutputFormat { path: PathBuf, expected: &'static str },
}

impl RenderError {
    /// Stable machine-readable code.
    pub fn code(&self) -> &'static str {
        match self {
            RenderError::BadCamera(_) => "RENDER_BAD_CAMERA",
            RenderError::BadSize { .. } => "RENDER_BAD_SIZE",
            RenderError::BadOptions(_) => "RENDER_BAD_OPTIONS",
            RenderError::NoLayers => "RENDER_NO_LAYERS",
            RenderError::LayerChannel { .. } => "RENDER_LAYER_CHANNEL",
            RenderError::LayerSize { .. } => "RENDER_LAYER_SIZE",
            RenderError::Mesh { .. } => "RENDER_MESH",
            RenderError::OutputFormat { .. } => "RENDER_OUTPUT_FORMAT",
        }
    }
}

/// One layer to render: its full-canvas image and parametrisation.
#[derive(Clone, Copy, Debug)]
pub struct RenderLayer<'a> {
    pub image: &'a LayerImage,
    pub mapping: AnyMapping,
}

/// Wall-clock time of one stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stage {
    pub name: &'static str,
    pub seconds: f64,
}

/// Figures of one render: the work counters `C` and options `O` are those of the method (splat by
/// default; the mesh method's are [`MeshRenderStats`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderStats<C = SplatCounts, O = SplatOptions> {
    pub width: usize,
    pub height: usize,
    pub layers: usize,
    /// Output pixels no layer covers.
    pub holes: usize,
    pub hole_ratio: f64,
    pub counts: C,
    pub options: O,
    pub stages: Vec<Stage>,
}

/// A rendered view.
#[derive(Clone, Debug)]
pub struct Rendered<C = SplatCounts, O = SplatOptions> {
    pub frame: Frame,
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

/// Render `layers` (placed in the world by `local_to_world`) into `camera`.
pub fn render(
    layers: &[RenderLayer],
    local_to_world: DMat4,
    camera: &Camera,
    o: &SplatOptions,
) -> Result<Rendered, RenderError> {
    check_options(o)?;
    if !local_to_world.is_finite() || local_to_world.determinant() == 0.0 {
        return Err(RenderError::BadCamera("LocalToWorld is not an invertible finite transform".into()));
    }
    let planes = layers
        .iter()
        .enumerate()
        .map(|(index, l)| {
            if (l.image.width, l.image.height) != (l.mapping.width(), l.mapping.height()) {
                return Err(RenderError::LayerSize {
                    index,
                    width: l.image.width,
                    height: l.image.height,
                    kind: l.mapping.kind(),
                });
            }
            splat::LayerPlanes::new(l.image, l.mapping)
                .map_err(|channel| RenderError::LayerChannel { index, channel })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let t = Instant::now();
    let (acc, counts) = splat::splat_layers(&planes, local_to_world, camera, o);
    let splat_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let frame = Frame::from_accum(&acc);
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
    Ok(Rendered { frame, stats })
}

/// The mapping kind a manifest declares.
pub fn mapping_kind(decl: DeclKind) -> MappingKind {
    match decl {
        DeclKind::LatLong => MappingKind::Equirect,
        DeclKind::Cube => MappingKind::Cube3x2,
    }
}

/// Read every layer of a panorama as full canvases with their mappings, in manifest order.
pub fn read_layers(pano: &Panorama, limits: &ReadLimits) -> crate::Result<Vec<(LayerImage, AnyMapping)>> {
    let kind = mapping_kind(pano.manifest.mapping.kind);
    if pano.manifest.layers.is_empty() {
        return Err(RenderError::NoLayers.into());
    }
    // Layers decode in parallel (each EXR decode is sequential).
    (0..pano.manifest.layers.len())
        .into_par_iter()
        .map(|index| {
            let image = pano.read_layer(index, limits)?;
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

/// The panorama centre in the world: the default eye.
pub fn centre(local_to_world: DMat4) -> DVec3 {
    local_to_world.transform_point3(DVec3::ZERO)
}
