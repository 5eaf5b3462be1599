//! Closing the gaps between lattices: cube face edges and corners, the equirect seam and poles.
//!
//! Vertices sit at pixel centres, so two faces sharing a cube edge leave a half-pixel-wide strip between
//! their edge rows (no pixel centre lies in it). Each face's *used* vertices along the edge are zipped
//! with the neighbour's: the strip gets triangles whose edges along each side are exactly that face's
//! own boundary edges, so no T-junction appears whatever the two subdivisions are. Each cube corner
//! gets one triangle joining the three faces' corner pixels. On the equirect, the seam column `W−1` is
//! zipped with column `0`, and each pole is one vertex (distance: mean of the row's valid samples) fanned
//! once around the used vertices of the first/last row — no duplicated pole point, no slivers.
//! Every stitching triangle is emitted only when its three edges join valid, continuous samples.

use glam::IVec3;

use super::grid::{is_jump, Grid, JUMP_THRESHOLD};
use crate::mapping::CubeFace;

/// A vertex on a side to zip: position along the side, canvas id, depth (`NaN` when invalid).
#[derive(Clone, Copy, Debug)]
pub struct ZipVertex {
    /// Index along the side, in lattice vertices (reversed sides count from the far end).
    pub pos: u32,
    /// Canvas pixel index (`≥ W·H` for an equirect pole, see [`pole_ids`]).
    pub id: u32,
    /// Depth, metres; `NaN` when the vertex is invalid.
    pub depth: f64,
}

/// Two stitched vertices join valid samples of one surface. Vertices `k` pixels apart along the
/// side (`k ≥ 1`) may differ by the jump ratio compounded `k` times: the quadtree already checked
/// every pixel step along its own side, and a surface seen at a grazing angle (ground near the
/// horizon) changes depth by a large ratio over a long cell edge, smoothly.
fn joined(a: &ZipVertex, b: &ZipVertex, along: bool) -> bool {
    if a.depth.is_nan() || b.depth.is_nan() {
        return false;
    }
    if !along {
        return !is_jump(a.depth, b.depth);
    }
    let k = a.pos.abs_diff(b.pos).max(1) as i32;
    let (lo, hi) = (a.depth.min(b.depth), a.depth.max(b.depth));
    hi <= (1.0 + JUMP_THRESHOLD).powi(k) * lo
}

/// Emit a stitching triangle when its three edges join; `along` when its vertices' `pos` are
/// positions along one side (a zip strip), not unrelated (a corner or a pole fan).
fn push_if_joined(t: [&ZipVertex; 3], along: bool, out: &mut Vec<[u32; 3]>) {
    if joined(t[0], t[1], along) && joined(t[1], t[2], along) && joined(t[2], t[0], along) {
        out.push([t[0].id, t[1].id, t[2].id]);
    }
}

/// Triangulate the strip between two polylines sorted by `pos` along the same direction.
pub fn zip(a: &[ZipVertex], b: &[ZipVertex], out: &mut Vec<[u32; 3]>) {
    if a.is_empty() || b.is_empty() {
        return;
    }
    let (mut i, mut j) = (0, 0);
    while i + 1 < a.len() || j + 1 < b.len() {
        let advance_a = if i + 1 >= a.len() {
            false
        } else if j + 1 >= b.len() {
            true
        } else {
            a[i + 1].pos <= b[j + 1].pos
        };
        if advance_a {
            push_if_joined([&a[i], &a[i + 1], &b[j]], true, out);
            i += 1;
        } else {
            push_if_joined([&a[i], &b[j + 1], &b[j]], true, out);
            j += 1;
        }
    }
}

/// Lattice points of side `k` (0 top, 1 right, 2 bottom, 3 left), in increasing `x` or `y`.
fn side_points(g: &Grid, k: usize) -> Vec<(usize, usize, u32)> {
    let (w, h) = (g.w, g.h);
    match k {
        0 => (0..w).map(|x| (x, 0, x as u32)).collect(),
        1 => (0..h).map(|y| (w - 1, y, y as u32)).collect(),
        2 => (0..w).map(|x| (x, h - 1, x as u32)).collect(),
        _ => (0..h).map(|y| (0, y, y as u32)).collect(),
    }
}

/// Used vertices of side `k`, as zip vertices; positions optionally reversed (`n − 1 − pos`).
pub fn side_vertices(g: &Grid, used: &[bool], k: usize, reversed: bool) -> Vec<ZipVertex> {
    let n = if k % 2 == 0 { g.w } else { g.h } as u32;
    let mut v: Vec<ZipVertex> = side_points(g, k)
        .into_iter()
        .filter(|&(x, y, _)| used[y * g.w + x])
        .map(|(x, y, pos)| ZipVertex {
            pos: if reversed { n - 1 - pos } else { pos },
            id: g.pixel(x, y),
            depth: if g.valid(x, y) { g.depth_at(x, y) } else { f64::NAN },
        })
        .collect();
    if reversed {
        v.reverse();
    }
    v
}

/// Face coordinates `(s, t)` of the two ends of side `k`.
fn side_ends(k: usize) -> [(f64, f64); 2] {
    match k {
        0 => [(-1.0, -1.0), (1.0, -1.0)],
        1 => [(1.0, -1.0), (1.0, 1.0)],
        2 => [(-1.0, 1.0), (1.0, 1.0)],
        _ => [(-1.0, -1.0), (-1.0, 1.0)],
    }
}

fn corner_key(face: CubeFace, s: f64, t: f64) -> IVec3 {
    face.cube_point(s, t).round().as_ivec3()
}

/// Stitch the six face lattices of a cube map (grids in face order).
pub fn stitch_cube(grids: &[Grid], used: &[Vec<bool>], out: &mut Vec<[u32; 3]>) {
    let mut sides = Vec::new();
    for (f, face) in CubeFace::ALL.iter().enumerate() {
        for k in 0..4 {
            let [e0, e1] = side_ends(k);
            sides.push((f, k, corner_key(*face, e0.0, e0.1), corner_key(*face, e1.0, e1.1)));
        }
    }
    for (i, &(f, k, a0, a1)) in sides.iter().enumerate() {
        for &(g, l, b0, b1) in &sides[i + 1..] {
            if f == g || !((a0 == b0 && a1 == b1) || (a0 == b1 && a1 == b0)) {
                continue;
            }
            let a = side_vertices(&grids[f], &used[f], k, false);
            let b = side_vertices(&grids[g], &used[g], l, a0 != b0);
            zip(&a, &b, out);
        }
    }
    stitch_cube_corners(grids, out);
}

fn stitch_cube_corners(grids: &[Grid], out: &mut Vec<[u32; 3]>) {
    let mut corners: Vec<(IVec3, ZipVertex)> = Vec::new();
    for (f, face) in CubeFace::ALL.iter().enumerate() {
        let g = &grids[f];
        for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let x = if s < 0.0 { 0 } else { g.w - 1 };
            let y = if t < 0.0 { 0 } else { g.h - 1 };
            let depth = if g.valid(x, y) { g.depth_at(x, y) } else { f64::NAN };
            corners.push((corner_key(*face, s, t), ZipVertex { pos: 0, id: g.pixel(x, y), depth }));
        }
    }
    corners.sort_by_key(|(k, _)| (k.x, k.y, k.z));
    for group in corners.chunk_by(|a, b| a.0 == b.0) {
        if let [a, b, c] = group {
            push_if_joined([&a.1, &b.1, &c.1], false, out);
        }
    }
}

/// Canvas id of the north (`+Z`) and south pole vertices of a `W × H` equirect.
pub fn pole_ids(w: usize, h: usize) -> [u32; 2] {
    [(w * h) as u32, (w * h + 1) as u32]
}

/// Stitch the equirect seam and poles. Returns the pole depths (`NaN` when a pole is unused).
pub fn stitch_equirect(g: &Grid, used: &[bool], out: &mut Vec<[u32; 3]>) -> [f64; 2] {
    let right = side_vertices(g, used, 1, false);
    let left = side_vertices(g, used, 3, false);
    zip(&right, &left, out);
    let ids = pole_ids(g.w, g.h);
    let mut depths = [f64::NAN; 2];
    for (p, (k, y)) in [(0usize, 0usize), (2, g.h - 1)].into_iter().enumerate() {
        let valid: Vec<f64> = (0..g.w).filter(|&x| g.valid(x, y)).map(|x| g.depth_at(x, y)).collect();
        if valid.is_empty() {
            continue;
        }
        let d = valid.iter().sum::<f64>() / valid.len() as f64;
        depths[p] = d;
        let pole = ZipVertex { pos: 0, id: ids[p], depth: d };
        let ring = side_vertices(g, used, k, false);
        if ring.len() < 2 {
            continue;
        }
        for i in 0..ring.len() {
            push_if_joined([&pole, &ring[i], &ring[(i + 1) % ring.len()]], false, out);
        }
    }
    depths
}
