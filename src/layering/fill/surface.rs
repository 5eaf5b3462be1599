//! Which surface a fill continues, and how far: seeds' planes, normals borrowed from inside a
//! surface, and where the ray meets the plane.

use std::collections::HashMap;

use glam::Vec3;

use super::FillContext;

/// Cosine of the angle under which two seeds' normals are taken for one plane.
pub(crate) const SAME_PLANE_COS: f32 = 0.94; // 20°

/// Seeds `a` and `b` continue the same surface: one segment, and normals that agree (a segment
/// can run round a rounded-off crease; its faces still compete).
pub(super) fn same_surface(cx: &FillContext, a: usize, b: usize) -> bool {
    cx.surface[a] == cx.surface[b] && cx.normals[a].dot(cx.normals[b]) >= SAME_PLANE_COS
}

/// Is the tangent plane at `p` worth continuing? Its normal must agree with those of its
/// continuous neighbours on the same surface: a pixel on a crease, or at the corner of three
/// planes, has a normal blended between them that belongs to none.
pub(super) fn trusted_plane(cx: &FillContext, p: usize) -> bool {
    let n = cx.normals[p];
    if n == Vec3::ZERO {
        return true; // no plane: the seed's depth is kept, which needs no normal
    }
    (0..8).all(|j| {
        cx.nb.get(p, j).is_none_or(|q| {
            !cx.links.continuous(p, j)
                || cx.surface[q] != cx.surface[p]
                || cx.normals[q] == Vec3::ZERO
                || cx.normals[q].dot(n) >= SAME_PLANE_COS
        })
    })
}

/// Share of the plane tolerance within which [`planar_reach`] takes a turned normal for noise.
const TURN_FIT: f32 = 0.25;

/// Steps along each of the 8 directions within which [`planar_reach`] looks.
pub(super) const REACH_STEPS: usize = 48;

/// How far (an angle) the tangent plane at seed `s` may be continued behind an occluder: as far
/// as it fits the seed's own visible surface (within the plane tolerance, relative, and with
/// normals within 20° of its own: two turned in a row, where the depth leaves the plane by a
/// quarter of the tolerance, end it), looking along the 8 directions over the layer's pixels of
/// the same segment. A wall fits its plane all the way; the tangent plane of a sphere or of a
/// table leg leaves the surface within a few pixels, and continued far beyond (along a thin pole
/// in front of it) it draws a sliver of the object where there is none. A seed without a normal
/// walks with the one it borrows, else its neighbours' mean; unlimited when there is none either
/// or nothing contradicts it.
pub(super) fn planar_reach(cx: &FillContext, surfaces: &Surfaces, k: u32, s: usize) -> f64 {
    let ds = cx.depth[s];
    if !ds.is_finite() {
        return f64::INFINITY;
    }
    // Without a normal of its own or a borrowed one (the normals around disagree: a curved
    // surface), the mean of its neighbours' stands in.
    let n = match surfaces.normal(cx, s) {
        n if n != Vec3::ZERO => n,
        _ => (0..8)
            .filter_map(|j| {
                cx.nb.get(s, j).filter(|&q| cx.surface[q] == cx.surface[s] && cx.links.continuous(s, j))
            })
            .map(|q| cx.normals[q])
            .sum::<Vec3>()
            .normalize_or_zero(),
    };
    if n == Vec3::ZERO {
        return f64::INFINITY;
    }
    let mut reach = f64::INFINITY;
    for j in 0..8 {
        let mut p = s;
        let mut turned_at: Option<f64> = None;
        for _ in 0..REACH_STEPS {
            let Some(q) = cx.nb.get(p, j) else { break };
            if cx.layer_of[q] != k || cx.surface[q] != cx.surface[s] || !cx.links.continuous(p, j) {
                break;
            }
            let dq = cx.depth[q];
            let t = plane_depth(cx, s, n, q);
            let angle = || cx.dirs.at(q).dot(cx.dirs.at(s)).clamp(-1.0, 1.0).acos() as f64;
            let fits =
                n.dot(cx.dirs.at(q)) < 0.0 && t.is_finite() && (t - dq).abs() <= cx.plane_tol as f32 * dq;
            // A normal turned where the depth still fits the plane closely, or at one pixel only,
            // is noise (real depth's normals scatter by 20° and more); a curved surface's stay
            // turned and leave the plane.
            let nq = surfaces.normal(cx, q);
            let turned = nq != Vec3::ZERO
                && nq.dot(n) < SAME_PLANE_COS
                && (t - dq).abs() > TURN_FIT * cx.plane_tol as f32 * dq;
            if !fits || (turned && turned_at.is_some()) {
                reach = reach.min(if fits { turned_at.unwrap_or_else(angle) } else { angle() });
                break;
            }
            turned_at = turned.then(angle);
            p = q;
        }
    }
    reach
}

/// Per surface (segment) of a layer, the centroid of its points; per seed without a normal of
/// its own, the normal its neighbourhood gives it.
pub(super) struct Surfaces {
    pub(super) centroid: Vec<Vec3>,
    /// Farthest depth each surface is seen at.
    pub(super) far: Vec<f32>,
    /// Pixels of each surface (finite depths).
    pub(super) size: Vec<u32>,
    pub(super) borrowed: HashMap<usize, Vec3>,
    /// Per seed that continues the plane of another pixel of its layer ([`anchor`]), that pixel.
    pub(super) anchor: HashMap<usize, usize>,
}

/// Surfaces of fewer pixels are specks: without a plane of their own they seed no fill.
pub(super) const SPECK: u32 = 32;

/// How much farther than its surface is seen anywhere the fill may continue it.
pub(super) const FAR_SEEN: f32 = 1.5;

/// Steps around a seed within which its surface's normals stand in for its missing one.
pub(super) const BORROW_STEPS: usize = 3;
/// Normals that must agree for a seed to borrow their plane.
pub(super) const BORROW_MIN: usize = 3;

/// Steps a seed on a small surface walks into its layer for the plane it continues ([`anchor`]).
pub(super) const ANCHOR_STEPS: usize = 8;
/// Surfaces under this many pixels are small pieces of an outline ([`anchor`]).
pub(super) const ANCHOR_SMALL: u32 = 256;
/// How far (relative) a seed lies off the plane of the pixel it walks to before it takes that
/// pixel's plane ([`anchor`]).
pub(super) const ANCHOR_OFF: f32 = 0.01;

impl Surfaces {
    /// Pixels of the surface of `s` in its layer.
    pub(super) fn size(&self, cx: &FillContext, s: usize) -> u32 {
        self.size.get(cx.surface[s] as usize).copied().unwrap_or(0)
    }

    /// The normal of seed `s`: its own, else the one it borrows, else zero.
    pub(super) fn normal(&self, cx: &FillContext, s: usize) -> Vec3 {
        match cx.normals[s] {
            n if n != Vec3::ZERO => n,
            _ => self.borrowed.get(&s).copied().unwrap_or(Vec3::ZERO),
        }
    }

    /// The surfaces of layer `k` (finite depths only) and the normals `seeds` borrow.
    #[cfg(test)]
    pub(super) fn new(cx: &FillContext, k: u32, seeds: impl Iterator<Item = usize> + Clone) -> Surfaces {
        let mut surfaces = Surfaces::of_layer(cx, k);
        surfaces.borrow_normals(cx, seeds);
        surfaces
    }

    /// [`Surfaces::new`] before any seed borrows a normal: needs no seeds, so it runs beside
    /// their search.
    pub(super) fn of_layer(cx: &FillContext, k: u32) -> Surfaces {
        let mut sums: Vec<(Vec3, u32)> = Vec::new();
        let mut far: Vec<f32> = Vec::new();
        for p in 0..cx.nb.len() {
            let (d, id) = (cx.depth[p], cx.surface[p] as usize);
            if cx.layer_of[p] == k && d.is_finite() && d > 0.0 && cx.surface[p] != u32::MAX {
                if id >= sums.len() {
                    sums.resize(id + 1, (Vec3::ZERO, 0));
                    far.resize(id + 1, 0.0);
                }
                far[id] = far[id].max(d);
                sums[id].0 += cx.dirs.at(p) * d;
                sums[id].1 += 1;
            }
        }
        let centroid = sums.iter().map(|&(sum, c)| if c > 0 { sum / c as f32 } else { Vec3::NAN }).collect();
        let size = sums.iter().map(|&(_, c)| c).collect();
        Surfaces { centroid, far, size, borrowed: HashMap::new(), anchor: HashMap::new() }
    }

    /// The normals `seeds` without one of their own borrow ([`borrow_normal`]) and, from soft
    /// depth, the pixels whose planes seeds on small surfaces continue ([`anchor`]).
    pub(super) fn borrow_normals(&mut self, cx: &FillContext, seeds: impl Iterator<Item = usize> + Clone) {
        self.borrowed.extend(
            seeds
                .clone()
                .filter(|&s| cx.normals[s] == Vec3::ZERO && cx.depth[s].is_finite())
                .filter_map(|s| Some((s, borrow_normal(cx, s)?))),
        );
        if cx.soft_depth {
            let anchors: Vec<(usize, usize)> =
                seeds.filter_map(|s| Some((s, anchor(cx, self, s)?))).collect();
            self.anchor.extend(anchors);
        }
    }
}

/// The pixel whose plane seed `s` continues instead of its own, if any. Soft depth leaves a
/// cone of in-between depths around an object that the layering cuts into small surfaces of the
/// layer behind it, their normals turned outwards; continued, each tilts the fill behind the
/// object away from the wall it hides (docs/build.md, "Tried on 2026-11-30"). A seed on a
/// surface under [`ANCHOR_SMALL`] pixels walks up to [`ANCHOR_STEPS`] steps into its layer,
/// over links that are not jumps, always to the neighbour most inside the layer; when it
/// reaches a surface of at least [`ANCHOR_SMALL`] pixels and lies more than [`ANCHOR_OFF`] off
/// that pixel's plane, it continues that plane.
pub(super) fn anchor(cx: &FillContext, surfaces: &Surfaces, s: usize) -> Option<usize> {
    if !cx.depth[s].is_finite() || surfaces.size(cx, s) >= ANCHOR_SMALL {
        return None;
    }
    let k = cx.layer_of[s];
    let inside = |p: usize| (0..8).filter(|&j| cx.nb.get(p, j).is_some_and(|q| cx.layer_of[q] == k)).count();
    let mut seen = vec![s];
    let mut p = s;
    for _ in 0..ANCHOR_STEPS {
        let step = (0..8)
            .filter(|&j| cx.links.continuous(p, j))
            .filter_map(|j| cx.nb.get(p, j))
            .filter(|&q| cx.layer_of[q] == k && cx.depth[q].is_finite() && !seen.contains(&q))
            // The first of the most inside, as the neighbours are ordered.
            .fold(None, |best: Option<(usize, usize)>, q| {
                let c = inside(q);
                if best.is_none_or(|(bc, _)| c > bc) {
                    Some((c, q))
                } else {
                    best
                }
            });
        let Some((_, q)) = step else { break };
        seen.push(q);
        p = q;
    }
    let n = cx.normals[p];
    if p == s || n == Vec3::ZERO || n.dot(cx.dirs.at(s)) > -1e-3 || surfaces.size(cx, p) < ANCHOR_SMALL {
        return None;
    }
    let t = plane_depth(cx, p, n, s);
    ((t - cx.depth[s]).abs() > ANCHOR_OFF * cx.depth[s]).then_some(p)
}

/// The normal of the plane around seed `s`, which has none of its own (the ground seen at a
/// grazing angle): of its surface's normals a few steps around it, the mean of the largest set
/// that agree (within [`SAME_PLANE_COS`]), when that is at least half of them. Pixels at the
/// foot of an object carry normals blended with the object's; the majority is the plane.
pub(super) fn borrow_normal(cx: &FillContext, s: usize) -> Option<Vec3> {
    let mut seen = vec![s];
    let mut front = vec![s];
    let mut normals = Vec::new();
    for _ in 0..BORROW_STEPS {
        let mut next = Vec::new();
        for &p in &front {
            for j in 0..8 {
                let Some(q) = cx.nb.get(p, j) else { continue };
                if seen.contains(&q) || cx.surface[q] != cx.surface[s] || !cx.links.continuous(p, j) {
                    continue;
                }
                seen.push(q);
                next.push(q);
                if cx.normals[q] != Vec3::ZERO {
                    normals.push(cx.normals[q]);
                }
            }
        }
        front = next;
    }
    let agreeing = |n: Vec3| normals.iter().filter(move |m| m.dot(n) >= SAME_PLANE_COS);
    let best = normals.iter().copied().max_by_key(|&n| agreeing(n).count())?;
    let count = agreeing(best).count();
    (count >= BORROW_MIN && 2 * count >= normals.len()).then(|| agreeing(best).sum::<Vec3>().normalize())
}

/// Depth at pixel `q` of the surface of source pixel `s` continued behind the occluder: the ray
/// through `q` meets the tangent plane at `s`. A ray that misses the plane, or meets it only far
/// beyond `s` (the ground near its horizon, seen from a seed below), does not continue the
/// surface: `None`, another surface or a farther layer shows there. A seed without a normal of
/// its own (the ground seen at a grazing angle) borrows its neighbourhood's ([`borrow_normal`]) —
/// else the far ground at the horizon would stand up as a wall of constant depth into the sky —
/// and otherwise keeps its depth.
pub(super) fn continue_surface(cx: &FillContext, surfaces: &Surfaces, s: usize, q: usize) -> Option<f32> {
    let ds = cx.depth[s];
    if ds.is_infinite() {
        return Some(f32::INFINITY);
    }
    match surfaces.normal(cx, s) {
        Vec3::ZERO => Some(ds.max(cx.depth[q] * 1.0001)),
        nrm => plane_hit_with(cx, surfaces, s, nrm, q),
    }
}

/// Where the ray through `q` meets the tangent plane at `s`, if it does so plausibly: behind
/// the occluder at `q`, not much farther than `s` (a plane seen nearly edge-on), nor than its
/// surface is seen anywhere (ground that ends short of the horizon is not continued up to it).
pub(super) fn plane_hit(cx: &FillContext, surfaces: &Surfaces, s: usize, q: usize) -> Option<f32> {
    plane_hit_with(cx, surfaces, s, cx.normals[s], q)
}

/// [`plane_hit`] for the plane through `s` with normal `nrm`.
pub(super) fn plane_hit_with(
    cx: &FillContext,
    surfaces: &Surfaces,
    s: usize,
    nrm: Vec3,
    q: usize,
) -> Option<f32> {
    let ds = cx.depth[s];
    if !ds.is_finite() || nrm == Vec3::ZERO {
        return None;
    }
    if nrm.dot(cx.dirs.at(q)) > -1e-3 {
        return None;
    }
    let t = match surfaces.anchor.get(&s) {
        Some(&a) => plane_depth(cx, a, cx.normals[a], q),
        None => plane_depth(cx, s, nrm, q),
    };
    let seen = surfaces.far.get(cx.surface[s] as usize).map_or(f32::INFINITY, |&f| FAR_SEEN * f);
    (t.is_finite() && t > cx.depth[q] && t < 8.0 * ds && t <= seen).then_some(t)
}

/// Distance along the ray through `q` to the plane through seed `s` with normal `nrm`.
#[inline]
pub(super) fn plane_depth(cx: &FillContext, s: usize, nrm: Vec3, q: usize) -> f32 {
    nrm.dot(cx.dirs.at(s) * cx.depth[s]) / nrm.dot(cx.dirs.at(q))
}

/// The neighbour of a border pixel `s` that is deepest inside its layer (most neighbours in the
/// same layer): its colour is free of any mixing with the occluder at the border.
pub(super) fn interior_neighbour(cx: &FillContext, s: usize, k: u32) -> usize {
    let inside = |p: usize| (0..8).filter(|&j| cx.nb.get(p, j).is_some_and(|q| cx.layer_of[q] == k)).count();
    let mut best = (inside(s), s);
    for j in 0..8 {
        if let Some(q) = cx.nb.get(s, j) {
            if cx.layer_of[q] == k && cx.depth[q] > 0.0 {
                let c = inside(q);
                if c > best.0 {
                    best = (c, q);
                }
            }
        }
    }
    best.1
}
