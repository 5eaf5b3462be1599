//! Step 7 of [`build`](super::build): names, roles, painter's order and depth ranges of the
//! layers, and their images, made one at a time on demand (spec §7).

use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

use super::fill;
use super::{BuildReport, Built, BuiltLayer, LayerKey, RgbdInput, SurfaceClass};
use crate::layer::{LayerImage, SampleType, OUTSIDE_DEPTH};
use crate::manifest::{LayerDecl, Manifest, MappingDecl, Role, Transform};
use crate::mapping::{Mapping, MappingKind};

/// Layers decided and filled, their images not made yet: [`Layered::image`] makes one at a time
/// (a writer then holds one full canvas, not all of them; see docs/benchmarks.md).
pub struct Layered {
    /// The input, its depth and normals let go.
    pub(super) input: RgbdInput,
    pub(super) depth: Vec<f32>,
    /// Empty without [`BuildOptions::normals_out`].
    pub(super) normals: Vec<Vec3>,
    pub(super) layer_of: Vec<u32>,
    /// The kept layers, painter's order: their heads (no images yet) and fills.
    pub(super) heads: Vec<BuiltLayer>,
    pub(super) fills: Vec<fill::Fill>,
    /// Each kept layer's index in `layer_of` (layers with no pixel are left out).
    pub(super) index: Vec<u32>,
    /// Figures of the build; its last stage, `images`, grows as [`Layered::into_built`] makes the
    /// images (made one by one with [`Layered::image`], their time is the caller's: `pomc build`
    /// counts it in writing).
    pub report: BuildReport,
}

impl Layered {
    /// Number of layers (empty ones left out).
    pub fn len(&self) -> usize {
        self.heads.len()
    }

    /// Whether there is no layer.
    pub fn is_empty(&self) -> bool {
        self.heads.is_empty()
    }

    /// The full-canvas image of layer `k` (painter's order); panics if `k >= len()`.
    pub fn image(&self, k: usize) -> LayerImage {
        let own = (&self.depth[..], &self.layer_of[..], self.index[k]);
        let normals = (!self.normals.is_empty()).then_some(&self.normals[..]);
        layer_image(&self.input, own, &self.fills[k], normals)
    }

    /// A manifest for these layers: one native EXR per layer named after it, painter's order,
    /// roles and depth ranges.
    pub fn manifest(&self, kind: MappingKind, freedom_radius: f64, transforms: Vec<Transform>) -> Manifest {
        layers_manifest(&self.heads, kind, freedom_radius, transforms)
    }

    /// Every layer's image made: the [`Built`] of [`build`].
    pub fn into_built(self) -> Built {
        let t = Instant::now();
        let images: Vec<LayerImage> = (0..self.len()).map(|k| self.image(k)).collect();
        let Layered { mut heads, mut layer_of, index, mut report, .. } = self;
        for (h, image) in heads.iter_mut().zip(images) {
            h.image = image;
        }
        // Pixels index the kept layers.
        let mut renumber = vec![u32::MAX; index.iter().map(|&k| k as usize + 1).max().unwrap_or(0)];
        for (kept, &k) in index.iter().enumerate() {
            renumber[k as usize] = kept as u32;
        }
        layer_of.par_iter_mut().for_each(|l| *l = renumber.get(*l as usize).copied().unwrap_or(u32::MAX));
        if let Some(s) = report.stages.iter_mut().find(|s| s.0 == "images") {
            s.1 += t.elapsed().as_secs_f64();
        }
        Built { layers: heads, layer_of, report }
    }
}

/// Step 7: each layer's name, role and figures, farthest first (images empty), its fill, and its
/// index in `fills` and `layer_of`; layers with no pixel left out.
pub(super) fn layer_heads(
    keys: &[LayerKey],
    first: u32,
    fills: Vec<fill::Fill>,
    depth: &[f32],
    layer_of: &[u32],
) -> (Vec<BuiltLayer>, Vec<fill::Fill>, Vec<u32>) {
    // Counts and depth ranges per layer, in parallel over the canvas (a minimum and maximum come
    // out the same in any order).
    let count = fills.len();
    let (own, mut range) = layer_of
        .par_iter()
        .zip(depth)
        .fold(
            || (vec![0usize; count], vec![None; count]),
            |(mut own, mut range): (Vec<usize>, Vec<Option<(f32, f32)>>), (&l, &d)| {
                if let (Some(c), Some(r)) = (own.get_mut(l as usize), range.get_mut(l as usize)) {
                    *c += 1;
                    widen(r, d);
                }
                (own, range)
            },
        )
        .reduce(
            || (vec![0usize; count], vec![None; count]),
            |(mut own, mut range), (own_b, range_b)| {
                for (c, b) in own.iter_mut().zip(own_b) {
                    *c += b;
                }
                for (r, b) in range.iter_mut().zip(range_b) {
                    if let Some((lo, hi)) = b {
                        widen(r, lo);
                        widen(r, hi);
                    }
                }
                (own, range)
            },
        );
    let (mut heads, mut kept, mut index) = (Vec::new(), Vec::new(), Vec::new());
    let mut name_count = std::collections::BTreeMap::<String, u32>::new();
    for (k, f) in fills.into_iter().enumerate() {
        let (base, role) = if first == 1 && k == 0 {
            ("infinity".to_string(), Role::Infinity)
        } else {
            let key = keys[k - first as usize];
            match (key.level, key.class) {
                (0, SurfaceClass::Floor) => ("floor".to_string(), Role::Floor),
                (0, SurfaceClass::Ceiling) => ("ceiling".to_string(), Role::Ceiling),
                (0, SurfaceClass::Wall) => ("walls".to_string(), Role::Wall),
                (0, SurfaceClass::Any) => ("background".to_string(), Role::Background),
                (level, _) => (format!("objects-{level}"), Role::Object),
            }
        };
        // Depth bands give several layers of one kind: number them.
        let idx = name_count.entry(base.clone()).or_default();
        *idx += 1;
        let name = if *idx > 1 { format!("{base}-{idx}") } else { base };
        let filled_pixels = f.pixels.len() - f.border;
        // Leave out what the scene does not need: a layer with no pixel is dropped.
        if own[k] + filled_pixels == 0 {
            continue;
        }
        for p in &f.pixels {
            widen(&mut range[k], p.depth);
        }
        heads.push(BuiltLayer {
            name,
            role,
            order: heads.len() as u32,
            own_pixels: own[k],
            filled_pixels,
            depth_range: range[k],
            image: LayerImage::new(0, 0),
        });
        kept.push(f);
        index.push(k as u32);
    }
    (heads, kept, index)
}

/// `r` widened to finite depth `d` (others leave it).
fn widen(r: &mut Option<(f32, f32)>, d: f32) {
    if d > 0.0 && d.is_finite() {
        *r = Some(match *r {
            Some((lo, hi)) => (lo.min(d), hi.max(d)),
            None => (d, d),
        });
    }
}

/// The image of layer `k` (`own`: the depths, each pixel's layer, and `k`): its own pixels (as
/// seen from the centre) plus its fill; normals with `normals`.
fn layer_image(
    input: &RgbdInput,
    (depth, layer_of, k): (&[f32], &[u32], u32),
    fill: &fill::Fill,
    normals: Option<&[Vec3]>,
) -> LayerImage {
    let m = input.mapping;
    let half = |v: f32| half::f16::from_f32(v).to_f32();
    let own = |p: usize| layer_of[p] == k;
    let mut img = LayerImage::new(m.width(), m.height());
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let plane = &input.rgb[c];
        let mut data: Vec<f32> =
            (0..plane.len()).into_par_iter().map(|p| if own(p) { half(plane[p]) } else { 0.0 }).collect();
        for f in &fill.pixels {
            data[f.pixel] = half(f.rgb[c]);
        }
        img.set_channel(name, SampleType::F16, data);
    }
    let mut z: Vec<f32> =
        (0..depth.len()).into_par_iter().map(|p| if own(p) { depth[p] } else { OUTSIDE_DEPTH }).collect();
    for f in &fill.pixels {
        z[f.pixel] = f.depth;
    }
    img.set_channel("Z", SampleType::F32, z);
    if let Some(normals) = normals {
        // The continued surface's normal, not the colour source's (elsewhere on the surface).
        let mut src: Vec<u32> =
            (0..normals.len()).into_par_iter().map(|p| if own(p) { p as u32 } else { u32::MAX }).collect();
        for f in &fill.pixels {
            src[f.pixel] = f.surface as u32;
        }
        for (c, name) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
            let data = src
                .par_iter()
                .map(|&s| if s == u32::MAX { 0.0 } else { half(normals[s as usize].to_array()[c]) })
                .collect();
            img.set_channel(name, SampleType::F16, data);
        }
    }
    img
}

/// A manifest for built layers: one native EXR per layer named after it, painter's order,
/// roles and depth ranges.
pub fn manifest(
    built: &Built,
    kind: MappingKind,
    freedom_radius: f64,
    transforms: Vec<Transform>,
) -> Manifest {
    layers_manifest(&built.layers, kind, freedom_radius, transforms)
}

/// A manifest for layers in painter's order: one native EXR per layer named after it, roles,
/// orders and depth ranges (`pomc build` and `pomc scene`).
pub fn layers_manifest(
    layers: &[BuiltLayer],
    kind: MappingKind,
    freedom_radius: f64,
    transforms: Vec<Transform>,
) -> Manifest {
    let layers = layers
        .iter()
        .map(|l| {
            let mut d = LayerDecl::native(&format!("{}.exr", l.name));
            d.name = Some(l.name.clone());
            d.role = Some(l.role);
            d.order = Some(l.order);
            d.depth_range = l.depth_range;
            d
        })
        .collect();
    Manifest { version: "1".into(), transforms, mapping: MappingDecl { kind }, freedom_radius, layers }
}
