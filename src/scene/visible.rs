//! What an eye inside the freedom radius can see (leave out what the scene does not need): a hit
//! behind the first is kept when a shadow ray from one of a set of eyes on the freedom sphere
//! reaches it, then kept hits grow by a margin along their surface (the eyes are samples); the
//! sky is kept where the centre sees it and where an eye sees past the geometry.

use glam::Vec3;
use rayon::prelude::*;

use super::pieces::{continuous, dilate};
use super::trace::{Hit, Tracer};
use super::HitGrid;
use crate::mapping::Neighbours;

/// Pixels of surface kept around what the sampled eyes see, along the surface.
pub const MARGIN_PX: usize = 1;

/// Eyes (offsets from the centre, `r` away at most) that look past what hides a point along unit
/// `d`: eight on the circle of radius `r` across `d` (the widest parallax), four on the circle of
/// half of it (through gaps a wide step steps over).
pub fn eyes(d: Vec3, r: f32) -> [Vec3; 12] {
    let (u, v) = d.any_orthonormal_pair();
    let ring = |a: f32| u * a.cos() + v * a.sin();
    let q = std::f32::consts::FRAC_PI_4;
    std::array::from_fn(|i| match i {
        0..=7 => ring(q * i as f32) * r,
        _ => ring(q * (2 * (i - 8)) as f32 + q / 2.0) * (0.5 * r),
    })
}

/// Which hits some eye within `r` of the centre sees: every first hit, and each hit behind it a
/// sampled eye (the two facing it squarely, then [`eyes`]) reaches (a single-sided surface only from its front; not the inside of a solid,
/// a mesh's back right behind its front that faces away from every eye), then [`MARGIN_PX`]
/// pixels more along the surface.
pub fn kept(tr: &Tracer, grid: &HitGrid, nb: &Neighbours, r: f32) -> Vec<bool> {
    let scene = tr.scene();
    let mut kept: Vec<bool> = (0..nb.len())
        .into_par_iter()
        .flat_map_iter(|p| {
            let d = grid.dir(p);
            let hits = &grid.hits[grid.range(p)];
            let eyes = eyes(d, r);
            hits.iter()
                .enumerate()
                .map(move |(k, h)| {
                    if k == 0 {
                        return true;
                    }
                    let point = d * h.t;
                    let n = tr.normal(h.tri);
                    // Seen from its back right behind the same mesh seen from its front, and
                    // its front faces away from every eye (its plane is more than `r` from the
                    // centre): the inside of a solid, which no eye outside it sees.
                    if n.dot(point) >= r && behind_own_front(tr, hits, k, d) {
                        return false;
                    }
                    let two_sided = scene.materials[scene.material[h.tri as usize] as usize].double_sided;
                    // First the eyes that face the surface most squarely (`±r·n`: a face turned
                    // away from the centre is seen only from a cap of the ball), then the rings.
                    let facing = [n * r, -n * r];
                    let sides = if two_sided { &facing[..] } else { &facing[..1] };
                    sides
                        .iter()
                        .chain(eyes.iter())
                        .any(|&e| (two_sided || n.dot(e - point) > 0.0) && !tr.blocked(e, point))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    for _ in 0..MARGIN_PX {
        let grown: Vec<bool> = (0..nb.len())
            .into_par_iter()
            .flat_map_iter(|p| {
                let dp = grid.dir(p);
                let kept = &kept;
                grid.range(p).map(move |h| {
                    kept[h]
                        || nb.all(p).any(|q| {
                            let dq = grid.dir(q);
                            grid.range(q).any(|j| {
                                kept[j] && continuous(tr, (dq, &grid.hits[j]), (dp, &grid.hits[h]), true)
                            })
                        })
                })
            })
            .collect();
        kept = grown;
    }
    kept
}

/// Whether hit `k` of a ray along `d` is a mesh's back right behind the same mesh's front: the
/// ray reaches it through the inside of a solid.
pub fn behind_own_front(tr: &Tracer, hits: &[Hit], k: usize, d: Vec3) -> bool {
    if k == 0 {
        return false;
    }
    let scene = tr.scene();
    let (h, before) = (&hits[k], &hits[k - 1]);
    tr.normal(h.tri).dot(d) > 0.0
        && tr.normal(before.tri).dot(d) < 0.0
        && scene.surface[before.tri as usize] == scene.surface[h.tri as usize]
}

/// Pixels of the infinity layer: where the centre's ray meets nothing, and near them where an
/// eye's parallel ray does (within the parallax of the nearest surface beside the sky). `None`
/// when the centre sees no sky at all (a closed scene has no infinity layer).
pub fn sky(tr: &Tracer, grid: &HitGrid, nb: &Neighbours, r: f32, pixel_angle: f64) -> Option<Vec<bool>> {
    let open: Vec<bool> = (0..nb.len()).into_par_iter().map(|p| grid.range(p).is_empty()).collect();
    if !open.contains(&true) {
        return None;
    }
    // The nearest surface beside the sky bounds how far an eye sees past silhouettes.
    let nearest = (0..nb.len())
        .into_par_iter()
        .filter(|&p| !open[p] && nb.all(p).any(|q| open[q]))
        .map(|p| grid.hits[grid.start[p]].t)
        .reduce(|| f32::INFINITY, f32::min);
    let angle = ((r / nearest).min(1.0) as f64).asin();
    let radius = ((angle / pixel_angle).ceil() as usize + MARGIN_PX).min(nb.height());
    let near = dilate(nb, &open, radius);
    let sky = (0..nb.len())
        .into_par_iter()
        .map(|p| {
            open[p]
                || (near[p] && {
                    let d = grid.dir(p);
                    eyes(d, r).iter().any(|&e| tr.escapes(e, d))
                })
        })
        .collect();
    Some(sky)
}
