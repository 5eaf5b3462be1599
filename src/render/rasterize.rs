//! Mesh rasterisation: the `--method mesh` renderer (spec §9.4b).
//!
//! Each layer's adaptive quadtree mesh ([`crate::mesh`], thesis 7.4) is drawn with a software
//! z-buffer. Triangles are set up in camera space and tested against each output pixel's **ray**
//! (homogeneous rasterisation): a pixel is inside when its ray crosses the three planes through the
//! eye and the triangle's edges on the inner side, and its distance is the exact ray/plane
//! intersection. The same test serves the perspective and the equirect cameras — on the equirect,
//! triangles crossing the output seam or containing a pole need no special geometry, only a larger
//! candidate region — and it is watertight: the edge planes are computed once per edge from the
//! same two vertices (in a canonical order) for both triangles sharing it, and a pixel exactly on
//! an edge belongs to exactly one of them. For perspective cameras the candidate region is the
//! bounding box of the triangle **clipped against the near plane** `z = near`; pixels whose
//! intersection is nearer than `near` are rejected, so a triangle reaching behind the eye is cut
//! there, never dropped wholesale nor projected through infinity.
//!
//! Visibility is the splat method's rule without its blending: per output pixel the nearest
//! surface wins whatever the painter's order, ties to the later layer. The colour is
//! *deferred*: once the nearest triangle of each pixel is known, its exact surface point is mapped
//! back to the layer's canvas through the panorama centre (where the layer's colour was captured)
//! and the layer colour is sampled bilinearly there, over the taps of the same surface. Content at
//! infinity (`Z = +inf`, which has no mesh) is looked up by direction in every layer for pixels no
//! triangle covers, behind everything.
//!
//! Work is split in bands of output rows (rayon); triangles are binned to the bands they reach, and
//! each band owns its rows of the z-buffer, so the result does not depend on the thread count.

use std::f64::consts::{PI, TAU};
use std::time::Instant;

use glam::{DMat4, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::camera::Camera;
use super::image::Frame;
use super::{RenderError, RenderLayer, Stage};
use crate::continuity::{continues_plane, PLANAR};
use crate::layer::{classify, LayerImage, Sample, OUTSIDE_DEPTH};
use crate::mapping::Neighbours;
use crate::mapping::{AnyMapping, Mapping};
use crate::mesh::{self, LayerMesh, MeshParams};
use crate::panorama::Panorama;

/// Tuning of the mesh renderer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MeshOptions {
    /// Relative depth jump between two lattice-adjacent vertices above which a triangle edge crosses
    /// a discontinuity and the triangle is not drawn (the splat method's continuity test; the mesh
    /// itself only cuts at 0.5, spec §8.2). Longer edges of `k` pixels allow `(1 + jump)^k`.
    pub jump: f64,
    /// Near plane of perspective cameras, camera-space units (world units): nearer content is cut.
    pub near: f64,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions { jump: 0.1, near: 1e-6 }
    }
}

/// Rows of output per band (the unit of parallel work).
const BAND: usize = 8;

/// Work counters of one mesh render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RasterCounts {
    /// Triangles considered for drawing (kept mesh triangles and footprint quads' triangles).
    pub triangles: u64,
    /// Mesh triangles not drawn: an edge crosses a depth discontinuity (see [`MeshOptions::jump`]).
    pub triangles_jump: u64,
    /// Not drawn: outside the view (perspective frustum), behind the near plane, edge-on or
    /// non-finite.
    pub triangles_culled: u64,
    /// Drawn after clipping at the near plane.
    pub triangles_clipped: u64,
    /// Triangles set up for drawing.
    pub triangles_drawn: u64,
    /// Pixel/triangle tests.
    pub tests: u64,
    /// Tests that found the pixel inside the triangle.
    pub fragments: u64,
    /// Output pixels coloured from an infinity sample.
    pub infinity_pixels: u64,
}

impl RasterCounts {
    fn add(mut self, o: RasterCounts) -> RasterCounts {
        self.triangles += o.triangles;
        self.triangles_jump += o.triangles_jump;
        self.triangles_culled += o.triangles_culled;
        self.triangles_clipped += o.triangles_clipped;
        self.triangles_drawn += o.triangles_drawn;
        self.tests += o.tests;
        self.fragments += o.fragments;
        self.infinity_pixels += o.infinity_pixels;
        self
    }
}

/// Figures of one mesh render: stages `raster` (set-up, binning, z-buffer) and `compose` (colour,
/// infinity, frame).
pub type MeshRenderStats = super::RenderStats<RasterCounts, MeshOptions>;

/// A view rendered from meshes.
pub type MeshRendered = super::Rendered<RasterCounts, MeshOptions>;

fn check_options(o: &MeshOptions) -> Result<(), RenderError> {
    if !(o.jump > 0.0 && o.jump.is_finite()) {
        return Err(RenderError::BadOptions("jump must be a positive relative depth".into()));
    }
    if !(o.near > 0.0 && o.near.is_finite()) {
        return Err(RenderError::BadOptions("near must be a positive distance".into()));
    }
    Ok(())
}

fn check_layers(layers: &[RenderLayer]) -> Result<(), RenderError> {
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

fn mesh_error(index: usize, e: mesh::MeshError) -> RenderError {
    match e {
        mesh::MeshError::Params(m) => RenderError::BadOptions(format!("mesh parameters: {m}")),
        e => RenderError::Mesh { index, message: e.to_string() },
    }
}

/// Mesh every layer with `params` (layers in parallel; [`mesh::mesh_layer`]) and set up what the
/// rasteriser draws of it ([`LayerGeometry`], with `o.jump`).
pub fn mesh_layers(
    layers: &[RenderLayer],
    params: &MeshParams,
    o: &MeshOptions,
) -> Result<Vec<LayerGeometry>, RenderError> {
    check_options(o)?;
    check_layers(layers)?;
    params.check().map_err(|e| mesh_error(0, e))?;
    layers
        .par_iter()
        .enumerate()
        .map(|(index, l)| {
            let m = mesh::mesh_layer(l.image, &l.mapping, params).map_err(|e| mesh_error(index, e))?;
            LayerGeometry::new(index, m.mesh, l, o.jump)
        })
        .collect()
}

/// Where a layer's mesh came from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MeshSource {
    /// Decoded from the stored quadtree (`<Mesh …/>`, spec §8).
    Stored,
    /// Built from the layer ([`mesh::mesh_layer`]).
    Built,
}

/// Geometry of each layer, where its mesh came from, and the warnings about stored meshes ignored.
pub type PanoramaMeshes = (Vec<LayerGeometry>, Vec<MeshSource>, Vec<String>);

/// Meshes of a panorama's layers: the stored quadtree where the layer has a usable one, else built
/// with `params`. A stored mesh that cannot be read or decoded is ignored (spec §8.1) and reported
/// in the returned warnings.
pub fn panorama_meshes(
    pano: &Panorama,
    layers: &[RenderLayer],
    params: &MeshParams,
    o: &MeshOptions,
) -> Result<PanoramaMeshes, RenderError> {
    check_options(o)?;
    check_layers(layers)?;
    params.check().map_err(|e| mesh_error(0, e))?;
    type One = Result<(LayerGeometry, MeshSource, Option<String>), RenderError>;
    let results: Vec<One> = layers
        .par_iter()
        .enumerate()
        .map(|(index, l)| {
            let mut warning = None;
            match mesh::stored::read_stored(pano, index, l.image, &l.mapping) {
                Some(Ok(m)) => {
                    return Ok((LayerGeometry::new(index, m, l, o.jump)?, MeshSource::Stored, None))
                }
                Some(Err(e)) => warning = Some(format!("layer {index}: {e}")),
                None => {}
            }
            let m = mesh::mesh_layer(l.image, &l.mapping, params).map_err(|e| mesh_error(index, e))?;
            Ok((LayerGeometry::new(index, m.mesh, l, o.jump)?, MeshSource::Built, warning))
        })
        .collect();
    let (mut meshes, mut sources, mut warnings) = (Vec::new(), Vec::new(), Vec::new());
    for r in results {
        let (m, s, w) = r?;
        meshes.push(m);
        sources.push(s);
        warnings.extend(w);
    }
    Ok((meshes, sources, warnings))
}

/// Half-size of the footprint quads of border pixels, layer pixels: the splat's filter radius, over
/// ½ so that the quads of neighbouring border pixels (whose extrapolated corners need not
/// coincide) overlap, and silhouettes grow by ¼ pixel as with the splat's filter.
const FOOTPRINT: f64 = 0.75;

/// What the rasteriser draws of one layer, in the panorama's local frame: the layer's mesh minus
/// the triangles that cross a depth discontinuity, plus a **footprint quad** for every border
/// pixel. A mesh joins pixel centres, so on its own it stops half a pixel short of the layer's
/// border; the splat method lets each pixel cover its footprint `[−½, ½]²` instead, so that layers
/// that abut without a jump (an object standing on the floor, build's fill meeting the object)
/// leave no crack. The footprint quad of a valid pixel with a neighbour that is outside the layer or
/// across a jump reproduces that: corners at `±FOOTPRINT` pixel around its centre, on the corner
/// rays, at the pixel's depth extrapolated along the depth gradient of its continuous neighbours
/// (clamped within the jump), never reaching past a discontinuity by more than the footprint.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerGeometry {
    pub width: usize,
    pub height: usize,
    /// Mesh vertices, then four corners per border pixel.
    pub positions: Vec<DVec3>,
    /// Canvas pixel of each vertex (`≥ W·H` for the equirect poles).
    pub sources: Vec<u32>,
    /// Triangles to draw: the mesh's kept triangles, then two per border pixel.
    pub triangles: Vec<[u32; 3]>,
    /// Triangles of the mesh.
    pub mesh_triangles: usize,
    /// Mesh triangles not drawn: an edge crosses a depth discontinuity.
    pub jump_triangles: usize,
    /// Border pixels given a footprint quad.
    pub border_pixels: usize,
    /// The layer has infinity samples (looked up by direction behind everything).
    pub has_infinity: bool,
}

/// Angle between neighbouring pixel centres (along a row at the equator, or at a face centre).
fn pixel_angle(m: &AnyMapping) -> f64 {
    match m {
        AnyMapping::Equirect(_) => PI / m.height() as f64,
        AnyMapping::Cube(c) => PI / 2.0 / c.face_size() as f64,
    }
}

/// Whether the edge between two vertices (depth, unit direction) crosses a depth discontinuity:
/// the splat method's test `max/min > 1 + jump` between neighbours, `(1 + jump)^k` over `k` pixels.
#[inline]
fn crosses_jump((da, ua): (f64, DVec3), (db, ub): (f64, DVec3), jump: f64, pixel_angle: f64) -> bool {
    let (lo, hi) = (da.min(db), da.max(db));
    if hi <= (1.0 + jump) * lo {
        return false;
    }
    if lo.is_nan() || lo <= 0.0 {
        return true;
    }
    let angle = ua.dot(ub).clamp(-1.0, 1.0).acos();
    let k = (angle / (std::f64::consts::SQRT_2 * pixel_angle)).max(1.0);
    hi > (1.0 + jump).powf(k) * lo
}

/// The layer's depth samples, for walking a mesh edge pixel by pixel.
struct Lattice<'a> {
    mapping: AnyMapping,
    /// Finite depth or NaN per pixel.
    depth: &'a [f32],
    jump: f64,
}

impl Lattice<'_> {
    /// Whether the samples along the lattice line from pixel `a` to pixel `b` (a mesh edge along a
    /// row, a column or a diagonal, within one cube face, or across the equirect seam) run continuously
    /// by the splat's test: each step within `jump`, or on the plane through the pixels before or
    /// after it (inverse depth linear, spec §9.3). Ground seen at a grazing angle passes; a real
    /// discontinuity does not. Edges that are not such lines (stitching, poles) are not walked.
    fn continuous(&self, a: u32, b: u32) -> bool {
        let (w, h) = (self.mapping.width(), self.mapping.height());
        let (a, b) = (a as usize, b as usize);
        if a >= w * h || b >= w * h {
            return false;
        }
        let (ax, ay, bx, by) = ((a % w) as i64, (a / w) as i64, (b % w) as i64, (b / w) as i64);
        if let AnyMapping::Cube(c) = self.mapping {
            let n = c.face_size() as i64;
            if (ax / n, ay / n) != (bx / n, by / n) {
                return false;
            }
        }
        let (mut dx, dy) = (bx - ax, by - ay);
        let wraps = matches!(self.mapping, AnyMapping::Equirect(_));
        if wraps && dx.abs() > w as i64 / 2 {
            // Across the equirect seam: the short way round.
            dx -= dx.signum() * w as i64;
        }
        let steps = dx.abs().max(dy.abs());
        if steps == 0 || (dx != 0 && dy != 0 && dx.abs() != dy.abs()) {
            return false;
        }
        let (sx, sy) = (dx.signum(), dy.signum());
        let at = |k: i64| -> Option<f64> {
            let (mut x, y) = (ax + k * sx, ay + k * sy);
            if wraps {
                x = x.rem_euclid(w as i64);
            }
            // One pixel beyond either end is looked at too (the plane test of a one-pixel edge).
            if k < -1 || k > steps + 1 || x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                return None;
            }
            if let AnyMapping::Cube(c) = self.mapping {
                let n = c.face_size() as i64;
                if (x / n, y / n) != (ax / n, ay / n) {
                    return None;
                }
            }
            let d = self.depth[y as usize * w + x as usize];
            (!d.is_nan()).then_some(d as f64)
        };
        let planar = |mid: f64, one: f64, other: Option<f64>| {
            other.is_some_and(|o| continues_plane(mid, one, o, PLANAR))
        };
        for k in 0..steps {
            let (Some(p), Some(q)) = (at(k), at(k + 1)) else { return false };
            let step_ok = (p - q).abs() <= self.jump * p.min(q);
            if !(step_ok || planar(p, q, at(k - 1)) || planar(q, p, at(k + 2))) {
                return false;
            }
        }
        true
    }
}

/// Direction of the continuous canvas point `(i + ½ + ox, j + ½ + oy)`, continued past the
/// equirect's edges and past a cube face's edges on the face's plane.
fn corner_dir(m: &AnyMapping, i: usize, j: usize, ox: f64, oy: f64) -> DVec3 {
    match m {
        AnyMapping::Equirect(_) => {
            let phi = TAU * (i as f64 + 0.5 + ox) / m.width() as f64;
            let theta = PI * (j as f64 + 0.5 + oy) / m.height() as f64;
            let (st, ct) = theta.sin_cos();
            let (sp, cp) = phi.sin_cos();
            DVec3::new(st * cp, st * sp, ct)
        }
        AnyMapping::Cube(c) => {
            let n = c.face_size();
            let (fx, fy) = (i / n, j / n);
            let face =
                crate::mapping::CubeFace::from_index(3 * fy + fx).unwrap_or(crate::mapping::CubeFace::PosZ);
            let s = 2.0 * ((i - fx * n) as f64 + 0.5 + ox) / n as f64 - 1.0;
            let t = 2.0 * ((j - fy * n) as f64 + 0.5 + oy) / n as f64 - 1.0;
            face.cube_point(s, t).normalize()
        }
    }
}

impl LayerGeometry {
    /// The geometry of layer `index` from its `mesh`, with the continuity threshold `jump`.
    pub fn new(
        index: usize,
        mesh: LayerMesh,
        layer: &RenderLayer,
        jump: f64,
    ) -> Result<LayerGeometry, RenderError> {
        let m = layer.mapping;
        let (w, h) = (m.width(), m.height());
        let bad_vertex = mesh.triangles.iter().flatten().any(|&v| v as usize >= mesh.positions.len());
        if (mesh.width, mesh.height) != (w, h)
            || (layer.image.width, layer.image.height) != (w, h)
            || mesh.sources.len() != mesh.positions.len()
            || bad_vertex
        {
            return Err(RenderError::Mesh {
                index,
                message: "the mesh does not belong to this layer".into(),
            });
        }
        if !(jump > 0.0 && jump.is_finite()) {
            return Err(RenderError::BadOptions("jump must be a positive relative depth".into()));
        }
        let planes = Planes::new(layer.image, layer.mapping, false);
        // Finite depth or NaN, per pixel; and whether the layer has infinity samples.
        let mut dz = vec![f32::NAN; w * h];
        let has_infinity = dz
            .par_chunks_mut(w)
            .enumerate()
            .map(|(y, row)| {
                let mut infinite = false;
                for (x, d) in row.iter_mut().enumerate() {
                    match planes.sample(y * w + x) {
                        Sample::Surface(v) if v > 0.0 && v.is_finite() => *d = v,
                        Sample::Infinite => infinite = true,
                        _ => {}
                    }
                }
                infinite
            })
            .reduce(|| false, |a, b| a || b);
        let pa = pixel_angle(&m);
        let LayerMesh { positions, sources, triangles, .. } = mesh;
        let vd: Vec<(f64, DVec3)> = positions.iter().map(|p| (p.length(), p.normalize_or_zero())).collect();
        let mesh_triangles = triangles.len();
        let lattice = Lattice { mapping: m, depth: &dz, jump };
        let mut kept: Vec<[u32; 3]> = triangles
            .into_par_iter()
            .filter(|t| {
                let v = t.map(|i| vd[i as usize]);
                !(0..3).any(|k| {
                    crosses_jump(v[k], v[(k + 1) % 3], jump, pa)
                        && !lattice.continuous(sources[t[k] as usize], sources[t[(k + 1) % 3] as usize])
                })
            })
            .collect();
        let jump_triangles = mesh_triangles - kept.len();
        let nb = Neighbours::new(m);
        let depth = |p: usize| {
            let d = dz[p];
            (!d.is_nan()).then_some(d as f64)
        };
        let joined = |a: f64, b: f64| (a - b).abs() <= jump * a.min(b);
        let corners: Vec<(u32, [DVec3; 4])> = (0..h)
            .into_par_iter()
            .flat_map_iter(|y| {
                let (depth, nb, dz) = (&depth, &nb, &dz);
                (0..w).filter_map(move |x| {
                    let p = y * w + x;
                    let d = depth(p)?;
                    if nb.is_interior(x, y) {
                        // Fast path for the common case, a pixel inside the layer: all 8 neighbours
                        // present and joined (NaN compares false, so an invalid one fails here).
                        let all = [p + 1, p - 1, p + w, p - w, p + w + 1, p + w - 1, p - w + 1, p - w - 1]
                            .iter()
                            .all(|&q| {
                                let e = dz[q] as f64;
                                (d - e).abs() <= jump * d.min(e)
                            });
                        if all {
                            return None;
                        }
                    }
                    let nd: [Option<f64>; 8] =
                        std::array::from_fn(|k| nb.get_at(x, y, k).and_then(depth).filter(|&e| joined(d, e)));
                    if nd.iter().all(Option::is_some) {
                        return None;
                    }
                    // Depth gradient along canvas x and y from the continuous 4-neighbours.
                    let grad = |plus: usize, minus: usize| match (nd[plus], nd[minus]) {
                        (Some(a), Some(b)) => (a - b) / 2.0,
                        (Some(a), None) => a - d,
                        (None, Some(b)) => d - b,
                        (None, None) => 0.0,
                    };
                    let (gx, gy) = (grad(0, 1), grad(2, 3));
                    let f = FOOTPRINT;
                    let corner = |sx: f64, sy: f64| {
                        let z = (d + f * (sx * gx + sy * gy)).clamp(d / (1.0 + jump), d * (1.0 + jump));
                        corner_dir(&m, x, y, sx * f, sy * f) * z
                    };
                    Some((
                        p as u32,
                        [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)],
                    ))
                })
            })
            .collect();
        let mut positions = positions;
        let mut sources = sources;
        positions.reserve(4 * corners.len());
        for (p, c) in &corners {
            let base = positions.len() as u32;
            positions.extend_from_slice(c);
            sources.extend([*p; 4]);
            kept.push([base, base + 1, base + 2]);
            kept.push([base, base + 2, base + 3]);
        }
        Ok(LayerGeometry {
            has_infinity,
            width: w,
            height: h,
            positions,
            sources,
            triangles: kept,
            mesh_triangles,
            jump_triangles,
            border_pixels: corners.len(),
        })
    }
}

/// One layer's planes used for colour lookups.
struct Planes<'a> {
    mapping: AnyMapping,
    z: &'a [f32],
    coverage: Option<&'a [f32]>,
    rgb: [&'a [f32]; 3],
    /// The layer has infinity samples.
    has_infinity: bool,
}

impl<'a> Planes<'a> {
    fn new(image: &'a LayerImage, mapping: AnyMapping, has_infinity: bool) -> Planes<'a> {
        let get = |name: &str| image.channel(name).map(|c| c.data.as_slice()).unwrap_or(&[]);
        let z = get("Z");
        let coverage = image.coverage();
        Planes { mapping, z, coverage, rgb: [get("R"), get("G"), get("B")], has_infinity }
    }

    #[inline]
    fn sample(&self, p: usize) -> Sample {
        classify(self.z[p], self.coverage.map(|a| a[p]))
    }

    #[inline]
    fn rgb(&self, p: usize) -> [f32; 3] {
        [self.rgb[0][p], self.rgb[1][p], self.rgb[2][p]]
    }

    /// The four bilinear taps (pixel index, weight) of local direction `d`: across the seam on the
    /// equirect (clamped at the poles), clamped to the face of the nearest pixel on a cube map.
    fn taps(&self, d: DVec3) -> [(usize, f64); 4] {
        let m = &self.mapping;
        let (w, h) = (m.width(), m.height());
        let p = m.dir_to_pixel(d);
        let (ox, oy, fw, fh, wrap) = match m {
            AnyMapping::Equirect(_) => (0, 0, w, h, true),
            AnyMapping::Cube(c) => {
                let n = c.face_size();
                let fx = ((p.x / n as f64) as usize).min(2);
                let fy = ((p.y / n as f64) as usize).min(1);
                (fx * n, fy * n, n, n, false)
            }
        };
        let u = (p.x - ox as f64 - 0.5).clamp(if wrap { -0.5 } else { 0.0 }, fw as f64 - 1.0);
        let v = (p.y - oy as f64 - 0.5).clamp(0.0, fh as f64 - 1.0);
        let (i0, j0) = (u.floor(), v.floor());
        let (ax, ay) = (u - i0, v - j0);
        let col = |i: f64| -> usize {
            let i = i as i64;
            if wrap {
                i.rem_euclid(fw as i64) as usize
            } else {
                i.clamp(0, fw as i64 - 1) as usize
            }
        };
        let row = |j: f64| (j as i64).clamp(0, fh as i64 - 1) as usize;
        let (c0, c1, r0, r1) = (col(i0), col(i0 + 1.0), row(j0), row(j0 + 1.0));
        let at = |c: usize, r: usize| (oy + r) * w + ox + c;
        [
            (at(c0, r0), (1.0 - ax) * (1.0 - ay)),
            (at(c1, r0), ax * (1.0 - ay)),
            (at(c0, r1), (1.0 - ax) * ay),
            (at(c1, r1), ax * ay),
        ]
    }

    /// Colour of the surface point at local distance `dist` along local direction `d`: bilinear
    /// over the taps of the same surface (finite depth within `jump`); `None` when no tap is.
    fn surface_colour(&self, d: DVec3, dist: f64, jump: f64) -> Option<[f32; 3]> {
        let mut sum = [0.0f64; 3];
        let mut wsum = 0.0;
        for (p, wt) in self.taps(d) {
            if let Sample::Surface(z) = self.sample(p) {
                let z = z as f64;
                if z > 0.0 && z.is_finite() && (z - dist).abs() <= jump * z.min(dist) {
                    let c = self.rgb(p);
                    for k in 0..3 {
                        sum[k] += wt * c[k] as f64;
                    }
                    wsum += wt;
                }
            }
        }
        (wsum > 0.0).then(|| sum.map(|s| (s / wsum) as f32))
    }

    /// Colour of infinity content in local direction `d`: bilinear over the infinite taps; `None`
    /// when no tap is infinite.
    fn infinity_colour(&self, d: DVec3) -> Option<[f32; 3]> {
        let mut sum = [0.0f64; 3];
        let mut wsum = 0.0;
        let mut any = false;
        for (p, wt) in self.taps(d) {
            if matches!(self.sample(p), Sample::Infinite) {
                any = true;
                let c = self.rgb(p);
                for k in 0..3 {
                    sum[k] += wt * c[k] as f64;
                }
                wsum += wt;
            }
        }
        if !any {
            return None;
        }
        if wsum <= 0.0 {
            // Only zero-weight taps are infinite: the pixel is at the edge of the sky; use them.
            for (p, _) in self.taps(d) {
                if matches!(self.sample(p), Sample::Infinite) {
                    return Some(self.rgb(p));
                }
            }
        }
        Some(sum.map(|s| (s / wsum) as f32))
    }
}

/// A triangle set up for drawing.
#[derive(Clone, Copy, Debug)]
struct Prep {
    /// Inward edge planes through the eye (camera space): a ray `r` is inside when `e[i]·r > 0`,
    /// or `= 0` and `tie[i]`.
    e: [DVec3; 3],
    tie: [bool; 3],
    /// Plane of the triangle: `n·p = d` (camera space).
    n: DVec3,
    d: f64,
    layer: u32,
    tri: u32,
    /// Candidate pixel rows and columns (inclusive). Columns may exceed the width on a wrapping
    /// camera (taken modulo the width).
    y0: u32,
    y1: u32,
    x0: i64,
    x1: i64,
}

/// The output camera, reduced to what the rasteriser needs.
enum Cam {
    Persp {
        w: usize,
        h: usize,
        f: f64,
        cx: f64,
        cy: f64,
    },
    /// Per-row `(sin θ, cos θ)`, per-column `(cos φ, sin φ)` of pixel centres.
    Equi {
        w: usize,
        h: usize,
        rows: Vec<(f64, f64)>,
        cols: Vec<(f64, f64)>,
    },
}

impl Cam {
    fn new(camera: &Camera) -> Cam {
        match camera {
            Camera::Perspective(c) => Cam::Persp {
                w: c.width,
                h: c.height,
                f: c.focal,
                cx: c.width as f64 / 2.0,
                cy: c.height as f64 / 2.0,
            },
            Camera::Equirect(c) => {
                let (w, h) = (c.width, c.height);
                Cam::Equi {
                    w,
                    h,
                    rows: (0..h).map(|j| (PI * (j as f64 + 0.5) / h as f64).sin_cos()).collect(),
                    cols: (0..w)
                        .map(|i| {
                            let (s, c) = (TAU * (i as f64 + 0.5) / w as f64).sin_cos();
                            (c, s)
                        })
                        .collect(),
                }
            }
        }
    }

    fn size(&self) -> (usize, usize) {
        match self {
            Cam::Persp { w, h, .. } | Cam::Equi { w, h, .. } => (*w, *h),
        }
    }

    /// Camera-space ray through the centre of pixel `(x, y)`: `(x − cx, cy − y, f)` for a
    /// perspective camera (so `t·r` has `z = t·f`), unit for the equirect.
    #[inline]
    fn ray(&self, x: usize, y: usize) -> DVec3 {
        match self {
            Cam::Persp { f, cx, cy, .. } => DVec3::new(x as f64 + 0.5 - cx, cy - (y as f64 + 0.5), *f),
            Cam::Equi { rows, cols, .. } => {
                let ((st, ct), (cp, sp)) = (rows[y], cols[x]);
                DVec3::new(st * cp, st * sp, ct)
            }
        }
    }
}

/// Canonical edge plane: `a × b` with the vertices ordered by id, and whether that order was swapped.
#[inline]
fn edge_plane(ia: u32, a: DVec3, ib: u32, b: DVec3) -> (DVec3, bool) {
    if ia <= ib {
        (a.cross(b), false)
    } else {
        (b.cross(a), true)
    }
}

/// Whether ray `r` is inside a triangle's edge planes.
#[inline]
fn inside(p: &Prep, r: DVec3) -> bool {
    (0..3).all(|i| {
        let s = p.e[i].dot(r);
        s > 0.0 || (s == 0.0 && p.tie[i])
    })
}

struct Setup<'a> {
    cam: &'a Cam,
    o: MeshOptions,
    /// Frustum planes through the eye (perspective): a point is inside when all dot products ≥ 0.
    frustum: Option<[DVec3; 4]>,
}

impl Setup<'_> {
    /// Set up triangle `tri` of `layer`; `None` when it is not drawn (counted in `n`).
    fn prep(&self, layer: u32, tri: u32, v: [u32; 3], cam: &[DVec3], n: &mut RasterCounts) -> Option<Prep> {
        n.triangles += 1;
        let c = v.map(|i| cam[i as usize]);
        if !c.iter().all(|p| p.is_finite()) {
            n.triangles_culled += 1;
            return None;
        }
        let normal = (c[1] - c[0]).cross(c[2] - c[0]);
        let det = normal.dot(c[0]);
        if !(det.is_finite() && normal.is_finite()) || det == 0.0 {
            n.triangles_culled += 1;
            return None;
        }
        let sigma = det.signum();
        let mut e = [DVec3::ZERO; 3];
        let mut tie = [false; 3];
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            let (plane, swapped) = edge_plane(v[a], c[a], v[b], c[b]);
            // Inside is where (c[a] × c[b])·r has the sign of det.
            let s = if swapped { -sigma } else { sigma };
            e[k] = plane * s;
            tie[k] = s > 0.0;
        }
        let region = match self.cam {
            Cam::Persp { w, h, f, cx, cy } => {
                if let Some(planes) = &self.frustum {
                    if planes.iter().any(|pl| c.iter().all(|p| pl.dot(*p) < 0.0)) {
                        n.triangles_culled += 1;
                        return None;
                    }
                }
                let near = self.o.near;
                if c.iter().all(|p| p.z < near) {
                    n.triangles_culled += 1;
                    return None;
                }
                let poly = clip_near(&c, near);
                if poly.len() > 3 || c.iter().any(|p| p.z < near) {
                    n.triangles_clipped += 1;
                }
                let (mut xmin, mut xmax, mut ymin, mut ymax) =
                    (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
                for p in &poly {
                    let (x, y) = (cx + f * p.x / p.z, cy - f * p.y / p.z);
                    xmin = xmin.min(x);
                    xmax = xmax.max(x);
                    ymin = ymin.min(y);
                    ymax = ymax.max(y);
                }
                pixel_range(xmin, xmax, *w, false).zip(pixel_range(ymin, ymax, *h, false))
            }
            Cam::Equi { w, h, .. } => equirect_region(&c, &e, &tie, *w, *h),
        };
        let Some(((x0, x1), (y0, y1))) = region else {
            n.triangles_culled += 1;
            return None;
        };
        n.triangles_drawn += 1;
        Some(Prep { e, tie, n: normal, d: det, layer, tri, y0: y0 as u32, y1: y1 as u32, x0, x1 })
    }
}

/// Pixel indices whose centres `i + ½` lie in `[lo, hi]` (with a small margin), clamped to
/// `0..len` unless `wrap`; `None` when empty.
fn pixel_range(lo: f64, hi: f64, len: usize, wrap: bool) -> Option<(i64, i64)> {
    const MARGIN: f64 = 1e-3;
    if lo.is_nan() || hi.is_nan() {
        return None;
    }
    let a = (lo - 0.5 - MARGIN).ceil().max(-1e15) as i64;
    let b = (hi - 0.5 + MARGIN).floor().min(1e15) as i64;
    let (a, b) = if wrap { (a, b.min(a + len as i64 - 1)) } else { (a.max(0), b.min(len as i64 - 1)) };
    (a <= b).then_some((a, b))
}

/// Sutherland–Hodgman clip of a triangle against `z ≥ near`. Each new vertex is computed from its
/// edge's endpoints in a fixed order, so neighbouring triangles agree on it.
fn clip_near(c: &[DVec3; 3], near: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(4);
    for k in 0..3 {
        let (a, b) = (c[k], c[(k + 1) % 3]);
        let (ina, inb) = (a.z >= near, b.z >= near);
        if ina {
            out.push(a);
        }
        if ina != inb {
            let (p, q) = if a.z < b.z { (a, b) } else { (b, a) };
            let t = (near - p.z) / (q.z - p.z);
            let mut x = p + (q - p) * t;
            x.z = near;
            out.push(x);
        }
    }
    out
}

/// Candidate region of a triangle on an equirect output: its azimuth range (unwrapped, columns may
/// exceed the width) and polar range, the latter including the extremes of the great-circle arcs
/// of its edges; all columns from the pole when the triangle contains (or touches) a pole.
fn equirect_region(
    c: &[DVec3; 3],
    e: &[DVec3; 3],
    tie: &[bool; 3],
    w: usize,
    h: usize,
) -> Option<((i64, i64), (i64, i64))> {
    let d = c.map(|p| p.normalize());
    if !d.iter().all(|p| p.is_finite()) {
        return None;
    }
    let theta = |p: DVec3| p.x.hypot(p.y).atan2(p.z);
    let (mut tmin, mut tmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &d {
        tmin = tmin.min(theta(*p));
        tmax = tmax.max(theta(*p));
    }
    for k in 0..3 {
        let (a, b) = (d[k], d[(k + 1) % 3]);
        let m = a.cross(b);
        let Some(mn) = m.try_normalize() else { continue };
        let top = (DVec3::Z - mn * mn.z).try_normalize();
        if let Some(p) = top {
            for q in [p, -p] {
                if a.cross(q).dot(m) >= 0.0 && q.cross(b).dot(m) >= 0.0 {
                    tmin = tmin.min(theta(q));
                    tmax = tmax.max(theta(q));
                }
            }
        }
    }
    let contains = |r: DVec3| {
        (0..3).all(|i| {
            let s = e[i].dot(r);
            s > 0.0 || (s == 0.0 && tie[i])
        })
    };
    let fw = w as f64;
    let near_axis = d.iter().any(|p| p.x.hypot(p.y) < 1e-12);
    let u = d.map(|p| {
        let mut phi = p.y.atan2(p.x);
        if phi < 0.0 {
            phi += TAU;
        }
        phi / TAU * fw
    });
    let wrap = |x: f64| x - fw * (x / fw).round();
    let (w01, w12, w20) = (wrap(u[1] - u[0]), wrap(u[2] - u[1]), wrap(u[0] - u[2]));
    let winding = w01 + w12 + w20;
    let north = contains(DVec3::Z);
    let south = contains(DVec3::NEG_Z);
    let ys = |t0: f64, t1: f64| pixel_range(t0 / PI * h as f64, t1 / PI * h as f64, h, false);
    if north || south || near_axis || winding.abs() > fw / 2.0 {
        let (t0, t1) = if north || (!south && d.iter().map(|p| p.z).sum::<f64>() > 0.0) {
            (0.0, tmax)
        } else {
            (tmin, PI)
        };
        return Some(((0, w as i64 - 1), ys(t0, t1)?));
    }
    let us = [u[0], u[0] + w01, u[0] + w01 + w12];
    let lo = us.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = us.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Some((pixel_range(lo, hi, w, true)?, ys(tmin, tmax)?))
}

/// One output pixel of the z-buffer.
#[derive(Clone, Copy, Debug)]
struct Frag {
    /// Perspective: camera `z`; equirect: distance from the eye.
    z: f32,
    layer: u32,
    /// `u32::MAX`: no triangle.
    tri: u32,
}

const NO_FRAG: Frag = Frag { z: f32::INFINITY, layer: 0, tri: u32::MAX };

/// Rasterise the triangles binned to one band of rows into its slice of the z-buffer.
fn raster_band(
    cam: &Cam,
    preps: &[Prep],
    bin: &[u32],
    band: usize,
    near: f64,
    buf: &mut [Frag],
) -> (u64, u64) {
    let (w, h) = cam.size();
    let (r0, r1) = (band * BAND, ((band + 1) * BAND).min(h) - 1);
    let (mut tests, mut frags) = (0u64, 0u64);
    for &k in bin {
        let p = &preps[k as usize];
        let (ya, yb) = ((p.y0 as usize).max(r0), (p.y1 as usize).min(r1));
        for y in ya..=yb {
            let row = &mut buf[(y - r0) * w..(y - r0 + 1) * w];
            for xi in p.x0..=p.x1 {
                let x = xi.rem_euclid(w as i64) as usize;
                let r = cam.ray(x, y);
                tests += 1;
                if !inside(p, r) {
                    continue;
                }
                let nr = p.n.dot(r);
                let t = p.d / nr;
                let z = match cam {
                    Cam::Persp { f, .. } => t * f,
                    Cam::Equi { .. } => t,
                };
                let usable = z > 0.0 && z.is_finite();
                if !usable || (matches!(cam, Cam::Persp { .. }) && z < near) {
                    continue;
                }
                frags += 1;
                let z = z as f32;
                let cell = &mut row[x];
                if z < cell.z || (z == cell.z && p.layer > cell.layer) {
                    *cell = Frag { z, layer: p.layer, tri: p.tri };
                }
            }
        }
    }
    (tests, frags)
}

/// Render `layers` (placed in the world by `local_to_world`) into `camera` by rasterising their
/// geometry (`meshes[k]` is layer `k`'s, in its local frame, e.g. from [`mesh_layers`]).
pub fn render_mesh(
    layers: &[RenderLayer],
    meshes: &[LayerGeometry],
    local_to_world: DMat4,
    camera: &Camera,
    o: &MeshOptions,
) -> Result<MeshRendered, RenderError> {
    check_options(o)?;
    if !local_to_world.is_finite() || local_to_world.determinant() == 0.0 {
        return Err(RenderError::BadCamera("LocalToWorld is not an invertible finite transform".into()));
    }
    check_layers(layers)?;
    if meshes.len() != layers.len() {
        return Err(RenderError::BadOptions(format!(
            "{} meshes given for {} layers",
            meshes.len(),
            layers.len()
        )));
    }
    for (index, (m, l)) in meshes.iter().zip(layers).enumerate() {
        let (w, h) = (l.mapping.width(), l.mapping.height());
        let bad_vertex = m.triangles.iter().flatten().any(|&v| v as usize >= m.positions.len());
        if (m.width, m.height) != (w, h) || m.sources.len() != m.positions.len() || bad_vertex {
            return Err(RenderError::Mesh {
                index,
                message: "the mesh does not belong to this layer".into(),
            });
        }
    }
    let t_raster = Instant::now();
    let cam = Cam::new(camera);
    let (w, h) = cam.size();
    let to_cam = camera.to_camera() * local_to_world;
    let frustum = match &cam {
        Cam::Persp { f, cx, cy, .. } => Some([
            DVec3::new(*f, 0.0, *cx),
            DVec3::new(-*f, 0.0, *cx),
            DVec3::new(0.0, *f, *cy),
            DVec3::new(0.0, -*f, *cy),
        ]),
        Cam::Equi { .. } => None,
    };
    let setup = Setup { cam: &cam, o: *o, frustum };
    let mut counts = RasterCounts::default();
    let mut preps: Vec<Prep> = Vec::new();
    for (k, m) in meshes.iter().enumerate() {
        counts.triangles_jump += m.jump_triangles as u64;
        let lv: Vec<DVec3> = m.positions.par_iter().map(|&p| to_cam.transform_point3(p)).collect();
        let lv = &lv;
        let parts: Vec<(Vec<Prep>, RasterCounts)> = m
            .triangles
            .par_chunks(4096)
            .enumerate()
            .map(|(chunk, tris)| {
                let mut n = RasterCounts::default();
                let out = tris
                    .iter()
                    .enumerate()
                    .filter_map(|(i, &v)| setup.prep(k as u32, (chunk * 4096 + i) as u32, v, lv, &mut n))
                    .collect();
                (out, n)
            })
            .collect();
        for (p, n) in parts {
            preps.extend(p);
            counts = counts.add(n);
        }
    }
    let bands = h.div_ceil(BAND);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (i, p) in preps.iter().enumerate() {
        for bin in &mut bins[p.y0 as usize / BAND..=p.y1 as usize / BAND] {
            bin.push(i as u32);
        }
    }
    let mut zbuf = vec![NO_FRAG; w * h];
    let work: Vec<(u64, u64)> = zbuf
        .par_chunks_mut(BAND * w)
        .enumerate()
        .map(|(b, buf)| raster_band(&cam, &preps, &bins[b], b, o.near, buf))
        .collect();
    for (t, f) in work {
        counts.tests += t;
        counts.fragments += f;
    }
    drop(preps);
    drop(bins);
    let raster_s = t_raster.elapsed().as_secs_f64();

    let t_compose = Instant::now();
    let planes: Vec<Planes> =
        layers.iter().zip(meshes).map(|(l, g)| Planes::new(l.image, l.mapping, g.has_infinity)).collect();
    let cam_to_local = to_cam.inverse();
    let n = w * h;
    let mut frame = Frame {
        width: w,
        height: h,
        rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        depth: vec![OUTSIDE_DEPTH; n],
        covered: vec![false; n],
    };
    type Row = (Vec<[f32; 3]>, Vec<f32>, Vec<bool>, u64);
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut rgb = vec![[0.0f32; 3]; w];
            let mut depth = vec![OUTSIDE_DEPTH; w];
            let mut covered = vec![false; w];
            let mut inf = 0u64;
            for x in 0..w {
                let r = cam.ray(x, y);
                let f = zbuf[y * w + x];
                if f.tri != u32::MAX {
                    let k = f.layer as usize;
                    let dist = match &cam {
                        Cam::Persp { f: focal, .. } => f.z as f64 * r.length() / focal,
                        Cam::Equi { .. } => f.z as f64,
                    };
                    let pc = r.normalize() * dist;
                    let local = cam_to_local.transform_point3(pc);
                    let ld = local.length();
                    let c = planes[k]
                        .surface_colour(local, ld, o.jump)
                        .unwrap_or_else(|| nearest_vertex_colour(&planes[k], &meshes[k], f.tri, local));
                    rgb[x] = c.map(|v| if v.is_finite() { v } else { 0.0 });
                    // The world distance: camera space is rigid.
                    depth[x] = dist as f32;
                    covered[x] = true;
                    continue;
                }
                // Nothing finite: infinity content by direction, frontmost layer first.
                let local = cam_to_local.transform_vector3(r);
                for p in planes.iter().rev().filter(|p| p.has_infinity) {
                    if let Some(c) = p.infinity_colour(local) {
                        rgb[x] = c.map(|v| if v.is_finite() { v } else { 0.0 });
                        depth[x] = f32::INFINITY;
                        covered[x] = true;
                        inf += 1;
                        break;
                    }
                }
            }
            (rgb, depth, covered, inf)
        })
        .collect();
    for (y, (rgb, depth, covered, inf)) in rows.into_iter().enumerate() {
        for (x, c) in rgb.iter().enumerate() {
            for (plane, v) in frame.rgb.iter_mut().zip(c) {
                plane[y * w + x] = *v;
            }
        }
        frame.depth[y * w..(y + 1) * w].copy_from_slice(&depth);
        frame.covered[y * w..(y + 1) * w].copy_from_slice(&covered);
        counts.infinity_pixels += inf;
    }
    let compose_s = t_compose.elapsed().as_secs_f64();
    let stats = MeshRenderStats {
        width: w,
        height: h,
        layers: layers.len(),
        holes: frame.holes(),
        hole_ratio: frame.hole_ratio(),
        counts,
        options: *o,
        stages: vec![
            Stage { name: "raster", seconds: raster_s },
            Stage { name: "compose", seconds: compose_s },
        ],
    };
    Ok(MeshRendered { frame, stats })
}

/// Fallback colour of a fragment whose bilinear taps are all of another surface: the colour of the
/// triangle's vertex nearest in direction (pole vertices have no pixel).
fn nearest_vertex_colour(p: &Planes, m: &LayerGeometry, tri: u32, local: DVec3) -> [f32; 3] {
    let Some(t) = m.triangles.get(tri as usize) else { return [0.0; 3] };
    let d = local.normalize_or_zero();
    let mut best: Option<(f64, usize)> = None;
    for &v in t {
        let src = m.sources[v as usize] as usize;
        if src >= m.width * m.height {
            continue;
        }
        let cos = m.positions[v as usize].normalize_or_zero().dot(d);
        if best.map_or(true, |(b, _)| cos > b) {
            best = Some((cos, src));
        }
    }
    best.map_or([0.0; 3], |(_, src)| p.rgb(src))
}

/// Mesh then rasterise: [`mesh_layers`] with `params`, timed as the stage `mesh`, then
/// [`render_mesh`].
pub fn render_mesh_auto(
    layers: &[RenderLayer],
    params: &MeshParams,
    local_to_world: DMat4,
    camera: &Camera,
    o: &MeshOptions,
) -> Result<MeshRendered, RenderError> {
    let t = Instant::now();
    let meshes = mesh_layers(layers, params, o)?;
    let mesh_s = t.elapsed().as_secs_f64();
    let mut r = render_mesh(layers, &meshes, local_to_world, camera, o)?;
    r.stats.stages.insert(0, Stage { name: "mesh", seconds: mesh_s });
    Ok(r)
}

/// Whether a path names a panorama with at least one stored mesh (for reports).
pub fn has_stored_meshes(pano: &Panorama) -> bool {
    pano.manifest.layers.iter().any(|l| l.mesh.as_ref().is_some_and(|m| m.is_quadtree_v1()))
}
