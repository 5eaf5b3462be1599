//! What the mesh renderer draws of a layer: its mesh without the triangles that cross a depth
//! jump, plus footprint quads of the border pixels (spec §9.4b).

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::continuity::{continues_plane, PLANAR};
use crate::layer::Sample;
use crate::mapping::Neighbours;
use crate::mapping::{AnyMapping, Mapping};
use crate::mesh::{self, LayerMesh, MeshOptions};
use crate::panorama::Panorama;
use crate::render::{RenderError, RenderLayer};

use super::shade::Planes;
use super::{check_options, mesh_error, RasterOptions};
use crate::render::{check_layers, BORDER_FOOTPRINT};

/// Mesh every layer with `params` (layers in parallel; [`mesh::mesh_layer`]) and set up what the
/// rasteriser draws of it ([`LayerGeometry`], with `o.jump`).
pub fn mesh_layers(
    layers: &[RenderLayer],
    params: &MeshOptions,
    o: &RasterOptions,
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
    params: &MeshOptions,
    o: &RasterOptions,
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

/// What the rasteriser draws of one layer, in the panorama's local frame: the layer's mesh minus
/// the triangles that cross a depth discontinuity, plus a **footprint quad** for every border
/// pixel. A mesh joins pixel centres, so on its own it stops half a pixel short of the layer's
/// border; the splat method lets each pixel cover its footprint `[−½, ½]²` instead, so that layers
/// that abut without a jump (an object standing on the floor, build's fill meeting the object)
/// leave no crack. The footprint quad of a valid pixel with a neighbour that is outside the layer or
/// across a jump reproduces that: corners at `±BORDER_FOOTPRINT` pixel around its centre, on the corner
/// rays, at the pixel's depth extrapolated along the depth gradient of its continuous neighbours
/// (clamped within the jump), never reaching past a discontinuity by more than the footprint.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerGeometry {
    /// What is drawn: the mesh's vertices then four corners per border pixel, the mesh's kept
    /// triangles then two per border pixel.
    pub mesh: LayerMesh,
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
    /// discontinuity does not. Other edges within a face (the seam's stitch) walk a row and a
    /// column; edges to a pole or across cube faces are not walked.
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
        if steps == 0 {
            return false;
        }
        if dx != 0 && dy != 0 && dx.abs() != dy.abs() {
            // Not a lattice line (the seam's stitch joins rows of different quadtree leaves; a
            // leaf one cell wide): continuous when a row then a column (or a column then a row) are.
            let at = |x: i64, y: i64| (y * w as i64 + x.rem_euclid(w as i64)) as u32;
            let (row_end, col_end) = (at(ax + dx, ay), at(ax, by));
            let (a, b) = (a as u32, b as u32);
            return (self.continuous(a, row_end) && self.continuous(row_end, b))
                || (self.continuous(a, col_end) && self.continuous(col_end, b));
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
        let (dz, has_infinity) = finite_depth(&Planes::new(layer.image, layer.mapping, false), w, h);
        let LayerMesh { mut positions, mut sources, triangles, .. } = mesh;
        let mesh_triangles = triangles.len();
        let lattice = Lattice { mapping: m, depth: &dz, jump };
        let mut kept = continuous_triangles(&lattice, &positions, &sources, triangles);
        let jump_triangles = mesh_triangles - kept.len();
        let corners = border_quads(&lattice);
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
            mesh: LayerMesh { width: w, height: h, positions, sources, triangles: kept },
            mesh_triangles,
            jump_triangles,
            border_pixels: corners.len(),
        })
    }
}

/// Per pixel of a layer, its finite depth or NaN; and whether the layer has infinity samples.
fn finite_depth(planes: &Planes, w: usize, h: usize) -> (Vec<f32>, bool) {
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
    (dz, has_infinity)
}

/// The mesh's triangles less those with an edge across a depth jump that the lattice under it
/// does not bridge continuously.
fn continuous_triangles(
    lattice: &Lattice,
    positions: &[DVec3],
    sources: &[u32],
    triangles: Vec<[u32; 3]>,
) -> Vec<[u32; 3]> {
    let pa = pixel_angle(&lattice.mapping);
    let jump = lattice.jump;
    let vd: Vec<(f64, DVec3)> = positions.iter().map(|p| (p.length(), p.normalize_or_zero())).collect();
    triangles
        .into_par_iter()
        .filter(|t| {
            let v = t.map(|i| vd[i as usize]);
            !(0..3).any(|k| {
                crosses_jump(v[k], v[(k + 1) % 3], jump, pa)
                    && !lattice.continuous(sources[t[k] as usize], sources[t[(k + 1) % 3] as usize])
            })
        })
        .collect()
}

/// A quad (corners in order) for each pixel with a neighbour it is not joined to: the layer's
/// border drawn to its pixels' edges.
fn border_quads(lattice: &Lattice) -> Vec<(u32, [DVec3; 4])> {
    let m = lattice.mapping;
    let (w, h) = (m.width(), m.height());
    let nb = Neighbours::new(m);
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let nb = &nb;
            (0..w).filter_map(move |x| border_quad(lattice, nb, x, y))
        })
        .collect()
}

/// [`border_quads`]' quad of pixel `(x, y)`, if it has one.
fn border_quad(lattice: &Lattice, nb: &Neighbours, x: usize, y: usize) -> Option<(u32, [DVec3; 4])> {
    let (m, dz, jump) = (&lattice.mapping, lattice.depth, lattice.jump);
    let w = m.width();
    let depth = |p: usize| {
        let d = dz[p];
        (!d.is_nan()).then_some(d as f64)
    };
    let joined = |a: f64, b: f64| (a - b).abs() <= jump * a.min(b);
    let p = y * w + x;
    let d = depth(p)?;
    if nb.is_interior(x, y) {
        // Fast path for the common case, a pixel inside the layer: all 8 neighbours
        // present and joined (NaN compares false, so an invalid one fails here).
        let all = [p + 1, p - 1, p + w, p - w, p + w + 1, p + w - 1, p - w + 1, p - w - 1].iter().all(|&q| {
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
    // Across a line one pixel wide (both sides cut), the pixel's own footprint: there is no
    // neighbouring quad to overlap, and ¼ pixel more on each side would draw a thin pole or wire
    // half as wide again.
    let cut = |k: usize| nb.get_at(x, y, k).is_none_or(|q| !lattice.continuous(p as u32, q as u32));
    let half = |plus: usize, minus: usize| {
        if nd[plus].is_none() && nd[minus].is_none() && cut(plus) && cut(minus) {
            0.5
        } else {
            BORDER_FOOTPRINT
        }
    };
    let (fx, fy) = (half(0, 1), half(2, 3));
    let corner = |sx: f64, sy: f64| {
        let z = (d + fx * sx * gx + fy * sy * gy).clamp(d / (1.0 + jump), d * (1.0 + jump));
        corner_dir(m, x, y, sx * fx, sy * fy) * z
    };
    Some((p as u32, [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)]))
}
