//! Hits to layers (thesis 6.3.2): a hit joins the piece of surface it continues in a neighbouring
//! pixel (same mesh, on its plane within a tolerance); pieces that overlap in a pixel, or meet
//! without continuing each other, go to different layers (greedy colouring, largest first).

use std::collections::VecDeque;

use glam::Vec3;
use rayon::prelude::*;

use super::trace::{Hit, Tracer};
use super::HitGrid;
use crate::continuity::{steps_apart, LAYER_JUMP};
use crate::mapping::Neighbours;

/// Distance of one hit's point from the other's plane, relative to the nearer distance, under
/// which two neighbouring hits are one surface.
pub const PLANE_TOL: f32 = 0.02;

/// Cosine of the angle under which two triangles' normals are one plane's.
const SAME_PLANE_COS: f32 = 0.9999;

/// Whether hit `a` (on the ray along unit `da`) and hit `b` (along `db`) lie on one surface:
/// either point within [`PLANE_TOL`] of the other's plane. With `same_mesh`, only hits of one mesh
/// that face the centre alike join: a surface seen from the centre and its part folded away
/// behind a silhouette are two pieces (they overlap in the image).
pub fn continuous(tr: &Tracer, (da, a): (Vec3, &Hit), (db, b): (Vec3, &Hit), same_mesh: bool) -> bool {
    let surface = &tr.scene().surface;
    if same_mesh
        && (surface[a.tri as usize] != surface[b.tri as usize]
            || (tr.normal(a.tri).dot(da) < 0.0) != (tr.normal(b.tri).dot(db) < 0.0))
    {
        return false;
    }
    let (pa, pb) = (da * a.t, db * b.t);
    let (na, nb) = (tr.normal(a.tri), tr.normal(b.tri));
    let limit = PLANE_TOL * a.t.min(b.t);
    let on_plane = na.dot(pb - pa).abs() <= limit || nb.dot(pa - pb).abs() <= limit;
    // A crease seen at a grazing angle (a floor meeting a far wall near the horizon) steps further
    // than a layer may ([`LAYER_JUMP`]); one plane continues however far it steps.
    on_plane && (!steps_apart(a.t as f64, b.t as f64, LAYER_JUMP) || na.dot(nb).abs() > SAME_PLANE_COS)
}

/// Pieces of surface: each kept hit's piece, and each piece's pixel count.
pub struct Pieces {
    /// Piece of each hit (`u32::MAX`: not kept).
    pub label: Vec<u32>,
    /// Pixels of each piece.
    pub size: Vec<usize>,
}

/// Grow pieces over the kept hits: breadth first over 4-neighbours, a piece taking at most one
/// hit per pixel (a surface that folds back over itself is split where it would overlap).
pub fn grow(tr: &Tracer, grid: &HitGrid, nb: &Neighbours, kept: &[bool]) -> Pieces {
    let mut label = vec![u32::MAX; grid.hits.len()];
    let mut claimed = vec![u32::MAX; nb.len()];
    let mut size = Vec::new();
    let mut queue = VecDeque::new();
    for p in 0..nb.len() {
        // Farthest first: the background grows before what stands in front of it.
        for h in grid.range(p).rev() {
            if !kept[h] || label[h] != u32::MAX {
                continue;
            }
            let id = size.len() as u32;
            let mut count = 0usize;
            label[h] = id;
            claimed[p] = id;
            queue.push_back((p, h));
            while let Some((p, h)) = queue.pop_front() {
                count += 1;
                let (dp, hit) = (grid.dir(p), grid.hits[h]);
                for k in 0..4 {
                    let Some(q) = nb.get(p, k) else { continue };
                    if claimed[q] == id {
                        continue;
                    }
                    let dq = grid.dir(q);
                    let best = grid
                        .range(q)
                        .filter(|&j| kept[j] && label[j] == u32::MAX)
                        .filter(|&j| continuous(tr, (dp, &hit), (dq, &grid.hits[j]), true))
                        .min_by(|&i, &j| {
                            let d = |x: usize| (grid.hits[x].t - hit.t).abs();
                            d(i).total_cmp(&d(j))
                        });
                    if let Some(j) = best {
                        label[j] = id;
                        claimed[q] = id;
                        queue.push_back((q, j));
                    }
                }
            }
            size.push(count);
        }
    }
    Pieces { label, size }
}

/// Each piece's layer (greedy colouring of the conflict graph, largest piece first) and the
/// number of layers. Two pieces conflict when both hold a hit of one pixel, or when they meet in
/// neighbouring pixels without continuing each other (one layer would jump there).
pub fn layers(tr: &Tracer, grid: &HitGrid, nb: &Neighbours, pieces: &Pieces) -> (Vec<u32>, usize) {
    let label = &pieces.label;
    let mut pairs: Vec<(u32, u32)> = (0..nb.len())
        .into_par_iter()
        .fold(Vec::new, |mut out, p| {
            let here: Vec<usize> = grid.range(p).filter(|&h| label[h] != u32::MAX).collect();
            for (i, &a) in here.iter().enumerate() {
                for &b in &here[i + 1..] {
                    out.push(ordered(label[a], label[b]));
                }
            }
            // Every 4-neighbour pair once, from its lower index (over the poles and cube-face
            // edges "right" and "down" are not the only directions a pair is seen from).
            for k in 0..4 {
                let Some(q) = nb.get(p, k).filter(|&q| q > p) else { continue };
                let (dp, dq) = (grid.dir(p), grid.dir(q));
                for &a in &here {
                    for b in grid.range(q).filter(|&b| label[b] != u32::MAX && label[b] != label[a]) {
                        if !continuous(tr, (dp, &grid.hits[a]), (dq, &grid.hits[b]), false) {
                            out.push(ordered(label[a], label[b]));
                        }
                    }
                }
            }
            out
        })
        .reduce(Vec::new, |mut a, b| {
            a.extend(b);
            a
        });
    pairs.par_sort_unstable();
    pairs.dedup();
    let n = pieces.size.len();
    let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(a, b) in &pairs {
        adjacent[a as usize].push(b);
        adjacent[b as usize].push(a);
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(pieces.size[i]));
    let mut layer = vec![u32::MAX; n];
    let mut layer_count = 0usize;
    let mut taken = Vec::new();
    for i in order {
        taken.clear();
        taken.extend(adjacent[i].iter().map(|&j| layer[j as usize]).filter(|&l| l != u32::MAX));
        taken.sort_unstable();
        taken.dedup();
        let free = (0u32..).find(|l| taken.binary_search(l).is_err()).unwrap_or(0);
        layer[i] = free;
        layer_count = layer_count.max(free as usize + 1);
    }
    (layer, layer_count)
}

fn ordered(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Pixels within `radius` 8-neighbour steps of a `seed` pixel (the seeds included).
pub fn dilate(nb: &Neighbours, seed: &[bool], radius: usize) -> Vec<bool> {
    let mut out = seed.to_vec();
    let mut front: Vec<usize> = (0..seed.len()).filter(|&p| seed[p]).collect();
    for _ in 0..radius {
        let mut next = Vec::new();
        for &p in &front {
            for q in nb.all(p) {
                if !out[q] {
                    out[q] = true;
                    next.push(q);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        front = next;
    }
    out
}
