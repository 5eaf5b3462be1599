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

use std::time::Instant;

use glam::{DMat4, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::camera::Camera;
use super::frame::Frame;
use super::{check_layers, RenderError, RenderLayer, Stage};
use crate::layer::OUTSIDE_DEPTH;
use crate::mapping::Mapping;
use crate::mesh;

mod geometry;
mod setup;
mod shade;

pub use geometry::{mesh_layers, panorama_meshes, LayerGeometry, MeshSource, PanoramaMeshes};
use setup::{raster_band, Cam, Prep, Setup, NO_FRAG};
use shade::{nearest_vertex_colour, Planes};

/// Tuning of the mesh renderer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RasterOptions {
    /// Relative depth jump between two lattice-adjacent vertices above which a triangle edge crosses
    /// a discontinuity and the triangle is not drawn (the splat method's continuity test; the mesh
    /// itself only cuts at 0.5, spec §8.2). Longer edges of `k` pixels allow `(1 + jump)^k`.
    pub jump: f64,
    /// Near plane of perspective cameras, camera-space units (world units): nearer content is cut.
    pub near: f64,
    /// Sub-samples per output pixel along each axis (1–4): each pixel is the mean of the
    /// `supersample²` rays of a finer grid inside it that meet a surface. A camera integrates over
    /// its pixels, and the splat method's filter spreads each sample over half a pixel: one ray
    /// per pixel draws magnified texture and silhouettes sharper (and aliased) than either.
    pub supersample: usize,
}

impl Default for RasterOptions {
    fn default() -> Self {
        RasterOptions { jump: 0.1, near: 1e-6, supersample: 2 }
    }
}

/// Rows of output per band (the unit of parallel work).
const BAND: usize = 8;

/// Work counters of one mesh render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RasterCounts {
    /// Triangles considered for drawing (kept mesh triangles and footprint quads' triangles).
    pub triangles: u64,
    /// Mesh triangles not drawn: an edge crosses a depth discontinuity (see [`RasterOptions::jump`]).
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
    /// Sub-pixels coloured from an infinity sample (output pixels × `supersample²`).
    pub infinity_pixels: u64,
}

add_counts!(RasterCounts: triangles, triangles_jump, triangles_culled, triangles_clipped,
    triangles_drawn, tests, fragments, infinity_pixels);

/// Figures of one mesh render: stages `raster` (set-up, binning, z-buffer) and `compose` (colour,
/// infinity, frame).
pub type MeshRenderStats = super::RenderStats<RasterCounts, RasterOptions>;

/// A view rendered from meshes.
pub type MeshRendered = super::Rendered<RasterCounts, RasterOptions>;

fn check_options(o: &RasterOptions) -> Result<(), RenderError> {
    if !(o.jump > 0.0 && o.jump.is_finite()) {
        return Err(RenderError::BadOptions("jump must be a positive relative depth".into()));
    }
    if !(o.near > 0.0 && o.near.is_finite()) {
        return Err(RenderError::BadOptions("near must be a positive distance".into()));
    }
    if !(1..=4).contains(&o.supersample) {
        return Err(RenderError::BadOptions("supersample must be 1, 2, 3 or 4".into()));
    }
    Ok(())
}

fn mesh_error(index: usize, e: mesh::MeshError) -> RenderError {
    match e {
        mesh::MeshError::Params(m) => RenderError::BadOptions(format!("mesh parameters: {m}")),
        e => RenderError::Mesh { index, message: e.to_string() },
    }
}

/// Render `layers` (placed in the world by `local_to_world`) into `camera` by rasterising their
/// geometry (`meshes[k]` is layer `k`'s, in its local frame, e.g. from [`mesh_layers`]).
pub fn render_mesh(
    layers: &[RenderLayer],
    meshes: &[LayerGeometry],
    local_to_world: DMat4,
    camera: &Camera,
    o: &RasterOptions,
) -> Result<MeshRendered, RenderError> {
    check_options(o)?;
    super::check_local_to_world(local_to_world)?;
    check_layers(layers)?;
    check_meshes(layers, meshes)?;
    let t_raster = Instant::now();
    // Sub-samples are the pixels of a finer camera; past the size limits, one ray per pixel.
    let ss = o.supersample;
    let fine = if ss > 1 { camera.scaled(ss) } else { None };
    let (ss, camera) = match &fine {
        Some(c) => (ss, c),
        None => (1, camera),
    };
    let cam = Cam::new(camera);
    let (w, h) = cam.size();
    let to_cam = camera.to_camera() * local_to_world;
    let setup = Setup { cam: &cam, o: *o, frustum: frustum(&cam) };
    let (preps, mut counts) = prepare_triangles(meshes, &setup, to_cam, camera);
    let bins = bin_by_band(&preps, h);
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
    let (frame, infinity_pixels) = compose(&cam, camera, &zbuf, &planes, meshes, to_cam.inverse(), o);
    counts.infinity_pixels += infinity_pixels;
    // A half equirect was drawn as the middle half of a full one.
    let frame = match camera {
        Camera::HalfEquirect(c) => frame.columns(c.width / 2, c.width),
        _ => frame,
    };
    let frame = if ss > 1 { frame.downsampled(ss) } else { frame };
    let compose_s = t_compose.elapsed().as_secs_f64();
    let stats = MeshRenderStats {
        width: frame.width,
        height: frame.height,
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

/// The planes through the camera centre bounding a perspective view (normals pointing in).
fn frustum(cam: &Cam) -> Option<[DVec3; 4]> {
    match cam {
        Cam::Persp { f, cx, cy, .. } => Some([
            DVec3::new(*f, 0.0, *cx),
            DVec3::new(-*f, 0.0, *cx),
            DVec3::new(0.0, *f, *cy),
            DVec3::new(0.0, -*f, *cy),
        ]),
        Cam::Equi { .. } => None,
    }
}

/// The triangles of each band of [`BAND`] rows of an image `h` rows high.
fn bin_by_band(preps: &[Prep], h: usize) -> Vec<Vec<u32>> {
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); h.div_ceil(BAND)];
    for (i, p) in preps.iter().enumerate() {
        for bin in &mut bins[p.y0 as usize / BAND..=p.y1 as usize / BAND] {
            bin.push(i as u32);
        }
    }
    bins
}

/// Every mesh is a mesh of its layer: same canvas, sources for every vertex, triangles on them.
fn check_meshes(layers: &[RenderLayer], meshes: &[LayerGeometry]) -> Result<(), RenderError> {
    if meshes.len() != layers.len() {
        return Err(RenderError::BadOptions(format!(
            "{} meshes given for {} layers",
            meshes.len(),
            layers.len()
        )));
    }
    for (index, (m, l)) in meshes.iter().zip(layers).enumerate() {
        let m = &m.mesh;
        let (w, h) = (l.mapping.width(), l.mapping.height());
        let bad_vertex = m.triangles.iter().flatten().any(|&v| v as usize >= m.positions.len());
        if (m.width, m.height) != (w, h) || m.sources.len() != m.positions.len() || bad_vertex {
            return Err(RenderError::Mesh {
                index,
                message: "the mesh does not belong to this layer".into(),
            });
        }
    }
    Ok(())
}

/// Where camera-space point `p` is drawn: itself, but for an ODS eye the point along the ray that
/// sees it from the eye centre, at the distance from the ray's start (the vertex displacement of
/// ODS rasterisation; a vertex no ray sees is moved to the edge of what the eye sees, NaN and never
/// drawn only if not finite). Triangles between displaced vertices follow the eye's curved
/// projection to second order in their size.
fn placed(camera: &Camera, p: DVec3) -> DVec3 {
    match camera {
        Camera::Ods(c) => c.ray_to_or_edge(p).map_or(DVec3::NAN, |(d, t)| d * t),
        _ => p,
    }
}

/// The triangles of every mesh set up for the camera (`to_cam`: panorama-local to camera space),
/// with the counts of those culled and clipped.
fn prepare_triangles(
    meshes: &[LayerGeometry],
    setup: &Setup,
    to_cam: DMat4,
    camera: &Camera,
) -> (Vec<Prep>, RasterCounts) {
    let mut counts = RasterCounts::default();
    let mut preps: Vec<Prep> = Vec::new();
    for (k, m) in meshes.iter().enumerate() {
        counts.triangles_jump += m.jump_triangles as u64;
        let lv: Vec<DVec3> =
            m.mesh.positions.par_iter().map(|&p| placed(camera, to_cam.transform_point3(p))).collect();
        let lv = &lv;
        let parts: Vec<(Vec<Prep>, RasterCounts)> = m
            .mesh
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
    (preps, counts)
}

/// The frame from the z-buffer: each covered pixel's colour looked up on its layer, the others
/// from infinity content by direction. Returns the frame and the pixels infinity filled.
fn compose(
    cam: &Cam,
    camera: &Camera,
    zbuf: &[setup::Frag],
    planes: &[Planes],
    meshes: &[LayerGeometry],
    cam_to_local: DMat4,
    o: &RasterOptions,
) -> (Frame, u64) {
    let (w, h) = cam.size();
    let mut infinity_pixels = 0;
    let mut frame = Frame::holes_only(w, h);
    type Row = (Vec<[f32; 3]>, Vec<f32>, Vec<bool>, u64);
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut rgb = vec![[0.0f32; 3]; w];
            let mut depth = vec![OUTSIDE_DEPTH; w];
            let mut covered = vec![false; w];
            let mut inf = 0u64;
            // Where this row's rays start (ODS eyes), from their directions.
            let origin_scale = match camera {
                Camera::Ods(c) => c.row_origin_scale(y as f64 + 0.5),
                _ => 0.0,
            };
            for x in 0..w {
                let r = cam.ray(x, y);
                let f = zbuf[y * w + x];
                if f.tri != u32::MAX {
                    let k = f.layer as usize;
                    let dist = match &cam {
                        Cam::Persp { f: focal, .. } => f.z as f64 * r.length() / focal,
                        Cam::Equi { .. } => f.z as f64,
                    };
                    let mut pc = r.normalize() * dist;
                    if origin_scale != 0.0 {
                        pc += DVec3::new(-r.y, r.x, 0.0) * origin_scale;
                    }
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
        infinity_pixels += inf;
    }
    (frame, infinity_pixels)
}
