//! Filling what nearer layers hide, in the band a camera inside the freedom radius can see.
//!
//! From every pixel of a layer that borders an occluder (a nearer layer, across a depth jump or a
//! fold: the floor a box stands on is hidden beside the box's bottom corner too), a
//! breadth-first front grows into the occluder's pixels while the angle to its source stays
//! within the largest parallax a camera within the freedom radius can open between the two
//! depths. Depth continues the background surface (the ray meets the source's tangent plane:
//! a wall stays planar behind a box); colour is copied from the background side only, from an
//! interior pixel, so foreground colour never bleeds into the fill.

use std::collections::{HashMap, VecDeque};

use glam::Vec3;

use super::edges::Links;
use rayon::prelude::*;

use crate::continuity::continuous_with;
use crate::mapping::{opposite, Neighbours};

/// One filled pixel.
#[derive(Clone, Copy, Debug)]
pub struct FillPixel {
    /// Row-major index of the filled pixel on the canvas.
    pub pixel: usize,
    /// Distance along its ray (m) on the continued surface; `+inf` in the infinity layer.
    pub depth: f32,
    /// Its linear RGB: the nearest visible pixel's, then as [`super::texture`] colours it.
    pub rgb: [f32; 3],
    /// The seed whose surface it continues (its plane and normal).
    pub surface: usize,
}

/// The fill of one layer: extra pixels, in breadth-first order from the occluders' borders.
#[derive(Clone, Debug, Default)]
pub struct Fill {
    /// The filled pixels, each once, in breadth-first order.
    pub pixels: Vec<FillPixel>,
    /// Widest angle (radians) between a filled pixel and its source.
    pub max_angle: f64,
    /// How many of `pixels`, at the end, are the layer's own border pixels, there for their
    /// colour only ([`add_borders`]).
    pub border: usize,
}

/// Inputs shared by the fills of all layers.
pub struct FillContext<'a> {
    /// 8-neighbours of every pixel on the canvas (across the seam, poles and cube-face edges).
    pub nb: &'a Neighbours,
    /// Pixel-centre unit directions.
    pub dirs: &'a [Vec3],
    /// Input depth (+inf for infinitely far content).
    pub depth: &'a [f32],
    /// Unit normals facing the centre (zero = unknown).
    pub normals: &'a [Vec3],
    /// Layer index per pixel (larger = nearer), `u32::MAX` for none.
    pub layer_of: &'a [u32],
    /// Freedom radius (m): the fill covers what a camera within it can see.
    pub freedom_radius: f64,
    /// Extra band, radians (a couple of pixels: reconstruction filters reach that far).
    pub margin: f64,
    /// Link (smooth, fold or jump) between each pixel and each of its 8 neighbours.
    pub links: &'a Links,
    /// Surface (segment) id per pixel: seeds on different surfaces compete behind an occluder.
    pub surface: &'a [u32],
    /// The continuity rule's relative step and plane tolerance ([`crate::continuity::continuous`]):
    /// a fill never leaves its layer discontinuous by it.
    pub jump: f64,
    /// The continuity rule's plane tolerance (the build's [`super::edges::EdgeOptions::extrapolation`]).
    pub plane_tol: f64,
    /// Input linear RGB, planar.
    pub rgb: &'a [Vec<f32>; 3],
}

/// Largest angle (radians) a camera within `r` of the centre can open between an occluding
/// edge at distance `near` and the surface behind it at `far` (`+inf` allowed): each point's
/// direction moves by at most `asin(r/d)`, and both move the same way. `π` when the occluder is
/// within the radius (the camera can walk around it).
pub fn parallax_band(r: f64, near: f64, far: f64) -> f64 {
    if near <= r {
        return std::f64::consts::PI;
    }
    let shift = |d: f64| if d.is_finite() { (r / d).min(1.0).asin() } else { 0.0 };
    (shift(near) - shift(far)).max(0.0)
}

/// Surfaces a hidden pixel weighs besides its own: the corner of a room (two walls and the
/// floor), with room to spare for the faces a rounded-off crease adds.
const RIVALS: usize = 5;

/// Fill layer `k` behind its occluders.
///
/// Every hidden pixel within the parallax band takes the nearest seed (breadth-first). A second
/// search, not limited to the band, finds for every hidden pixel the nearest seeds of up to
/// `RIVALS` other surfaces around the same occluder: where a floor meets a wall, or two walls
/// meet, behind a box, the pixel takes the plane the crease puts it on (`pick_surface`) even
/// when that plane shows only far away (above the box).
pub fn fill_layer(cx: &FillContext, k: u32) -> Fill {
    const NONE: u32 = u32::MAX;
    let n = cx.nb.len();
    let hidden = |q: usize| cx.layer_of[q] != NONE && cx.layer_of[q] > k && cx.depth[q] > 0.0;
    // Seeds across a jump first; seeds along a fold only (the floor a box stands on) reach what
    // the former leave.
    let (mut seeds, mut fold_seeds) = (Vec::new(), Vec::new());
    for p in 0..n {
        // NaN (unknown) depth never seeds a fill.
        if cx.layer_of[p] != k || cx.depth[p].is_nan() || cx.depth[p] <= 0.0 {
            continue;
        }
        let mut borders = (0..8).filter(|&j| cx.nb.get(p, j).is_some_and(hidden));
        let Some(first) = borders.next() else { continue };
        if !trusted_plane(cx, p) {
            continue;
        }
        if cx.links.is_jump(p, first) || borders.any(|j| cx.links.is_jump(p, j)) {
            seeds.push(p);
        } else {
            fold_seeds.push(p);
        }
    }
    let surfaces = Surfaces::new(cx, k, seeds.iter().chain(&fold_seeds).copied());
    // A speck without a plane (a few in-between depths on a resized edge) is no surface to
    // continue: kept, its depth would stand as a wall behind the occluder.
    // Pixels of unknown depth (given their neighbour's depth, on no segment) are not specks.
    let surface_seed = |&s: &usize| {
        cx.surface[s] == u32::MAX
            || !cx.depth[s].is_finite()
            || surfaces.normal(cx, s) != Vec3::ZERO
            || surfaces.size(cx, s) >= SPECK
    };
    seeds.retain(surface_seed);
    fold_seeds.retain(surface_seed);
    let jump_seeds = seeds.len();
    seeds.extend(fold_seeds);
    let reach: HashMap<usize, f64> =
        seeds.par_iter().map(|&s| (s, planar_reach(cx, &surfaces, k, s))).collect();
    // The band search and the rival search are independent.
    let ((src, angle_of, order), (slot_of, rivals)) = rayon::join(
        || {
            // (1) The band: nearest seed within the parallax a camera in the freedom radius can open.
            // Breadth-first from the seeds; a pixel already claimed switches to a nearer (in angle)
            // seed of the same kind reaching it later and passes the improvement on. Without that the
            // source drifts diagonally along a straight edge (the first seed to arrive wins) and the
            // band comes out up to √2 narrower than the parallax needs.
            let mut src = vec![NONE; n];
            let mut angle_of = vec![0f64; n];
            let mut order = Vec::new();
            let mut queue: VecDeque<usize> = seeds[..jump_seeds].iter().copied().collect();
            // 1: jump seed, 2: fold seed.
            let mut kind = vec![0u8; n];
            for (i, &p) in seeds.iter().enumerate() {
                src[p] = p as u32;
                kind[p] = if i < jump_seeds { 1 } else { 2 };
            }
            let mut folds_queued = false;
            loop {
                let Some(p) = queue.pop_front() else {
                    if folds_queued {
                        break;
                    }
                    folds_queued = true;
                    queue.extend(seeds[jump_seeds..].iter().copied());
                    continue;
                };
                let s = src[p] as usize;
                for j in 0..8 {
                    let Some(q) = cx.nb.get(p, j) else { continue };
                    if !hidden(q)
                        || (src[q] != NONE && (src[q] as usize == q || kind[src[q] as usize] != kind[s]))
                    {
                        continue;
                    }
                    let angle = cx.dirs[q].dot(cx.dirs[s]).clamp(-1.0, 1.0).acos() as f64;
                    let first = src[q] == NONE;
                    // Strictly nearer (beyond rounding) or no switch: every switch lowers a pixel's angle,
                    // so the propagation ends.
                    if (!first && angle >= angle_of[q] - 1e-9)
                        || angle
                            > parallax_band(cx.freedom_radius, cx.depth[q] as f64, cx.depth[s] as f64)
                                + cx.margin
                        // The reach is looked up only past its floor (most pixels stay within it).
                        || (angle > 2.0 * cx.margin && angle > reach[&s])
                        // A seed claims only where its surface continues: one whose plane misses
                        // (the in-between depths of a resized edge, whose plane runs along the
                        // ray) leaves the pixel to seeds that can fill it.
                        || continue_surface(cx, &surfaces, s, q).is_none()
                    {
                        continue;
                    }
                    src[q] = s as u32;
                    angle_of[q] = angle;
                    if first {
                        order.push(q);
                    }
                    queue.push_back(q);
                }
            }
            (src, angle_of, order)
        },
        || {
            // (2) Rival surfaces: nearest seeds of other surfaces through the whole occluder. Slots are
            // kept for hidden pixels only (compact index), the seeds being their own first rival.
            let mut slot_of = vec![NONE; n];
            let mut rivals: Vec<[u32; RIVALS]> = Vec::new();
            let mut queue: VecDeque<(u32, u8)> = VecDeque::new();
            // Directions only (the infinity layer): there is no plane to continue, so no rival to
            // weigh; skipping the search spares a flood through everything finite.
            let planes = seeds[..jump_seeds].iter().any(|&p| cx.depth[p].is_finite());
            for &p in seeds[..jump_seeds].iter().filter(|_| planes) {
                slot_of[p] = rivals.len() as u32;
                let mut r = [NONE; RIVALS];
                r[0] = p as u32;
                rivals.push(r);
                queue.push_back((p as u32, 0));
            }
            while let Some((p, slot)) = queue.pop_front() {
                let s = rivals[slot_of[p as usize] as usize][slot as usize];
                for j in 0..8 {
                    let Some(q) = cx.nb.get(p as usize, j) else { continue };
                    if !hidden(q) {
                        continue;
                    }
                    if slot_of[q] == NONE {
                        slot_of[q] = rivals.len() as u32;
                        rivals.push([NONE; RIVALS]);
                    }
                    let r = &mut rivals[slot_of[q] as usize];
                    if r.iter().any(|&t| t != NONE && same_surface(cx, t as usize, s as usize)) {
                        continue;
                    }
                    let Some(free) = r.iter().position(|&t| t == NONE) else { continue };
                    r[free] = s;
                    queue.push_back((q as u32, free as u8));
                }
            }
            (slot_of, rivals)
        },
    );
    let mut fill = Fill::default();
    let mut colour_of_seed: HashMap<usize, usize> = HashMap::new();
    let mut own_plane: HashMap<usize, FillPixel> = HashMap::new();
    for q in order {
        let own = src[q] as usize;
        // Pixels only fold seeds reach have no rivals.
        let none = [NONE; RIVALS];
        let rival = rivals.get(slot_of[q] as usize).unwrap_or(&none);
        let Some((s, d)) = pick_surface(cx, &surfaces, own, rival, q) else { continue };
        let mut pixel = |s: usize, depth: f32| {
            let c = *colour_of_seed.entry(s).or_insert_with(|| interior_neighbour(cx, s, k));
            FillPixel { pixel: q, depth, rgb: cx.colour(c).to_array(), surface: s }
        };
        fill.pixels.push(pixel(s, d));
        if s != own {
            if let Some(d) = continue_surface(cx, &surfaces, own, q) {
                own_plane.insert(q, pixel(own, d));
            }
        }
        fill.max_angle = fill.max_angle.max(angle_of[q]);
    }
    keep_continuous(cx, k, &mut fill, own_plane);
    fill
}

/// Each layer's own pixels next to a nearer layer join its fill for their colour only (their
/// depth is kept): an anti-aliased render mixes the occluder's colour into them, and a camera
/// moved aside sees them apart from it, as a line of the occluder's colour on the surface
/// behind. They start with the colour of their most interior neighbour and are coloured with
/// the rest of the fill. `fills[k]` is layer `k`'s fill; one pass over the canvas serves every
/// layer.
pub fn add_borders(cx: &FillContext, fills: &mut [Fill]) {
    const NONE: u32 = u32::MAX;
    // From the nearer side: the pixels above the farthest layer are few, a scan of every pixel's
    // neighbours is not.
    let lowest = cx.layer_of.par_iter().copied().min().unwrap_or(NONE);
    let mut border: Vec<usize> = (0..cx.nb.len())
        .into_par_iter()
        .filter(|&q| cx.layer_of[q] != NONE && cx.layer_of[q] > lowest)
        .flat_map_iter(|q| {
            let k = cx.layer_of[q];
            (0..8).filter_map(move |j| cx.nb.get(q, j)).filter(move |&p| {
                // Finite surfaces only: recolouring the sky's border as well lifted one view of
                // the realistic corpus and lowered three (docs/build.md).
                let d = cx.depth[p];
                cx.layer_of[p] < k && d > 0.0 && d.is_finite()
            })
        })
        .collect();
    border.par_sort_unstable();
    border.dedup();
    for p in border {
        let k = cx.layer_of[p];
        let Some(fill) = fills.get_mut(k as usize) else { continue };
        let c = interior_neighbour(cx, p, k);
        fill.pixels.push(FillPixel {
            pixel: p,
            depth: cx.depth[p],
            rgb: cx.colour(c).to_array(),
            surface: p,
        });
        fill.border += 1;
    }
}

/// Drop the fill pixels that would leave layer `k` discontinuous: where the fills of two surfaces
/// meet behind an occluder with a step between them (a far building's edge and the ground behind
/// it, both hidden by a tree), or a fill runs into another surface of the layer. Of a pair that is
/// not one surface, the nearer pixel goes when it is filled — the farther surface then shows
/// through where the nearer stops, so no hole opens — else the filled one. A layer is continuous
/// inside its domain (spec §1); every step lies on its border.
///
/// A dropped pixel that had taken a rival's plane ([`pick_surface`]) then gets its nearest seed's
/// plane (`own_plane`) back if that is continuous with every neighbour left: a rival's plane can
/// be a thin object's (a table leg's) continued far beyond it, and dropping all it claimed left
/// a hole in the layer where the nearest seed's surface continues.
fn keep_continuous(cx: &FillContext, k: u32, fill: &mut Fill, mut own_plane: HashMap<usize, FillPixel>) {
    let n = cx.nb.len();
    let mut d: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|p| if cx.layer_of[p] == k && cx.depth[p] > 0.0 { cx.depth[p] } else { f32::NAN })
        .collect();
    let mut filled = vec![false; n];
    for f in &fill.pixels {
        d[f.pixel] = f.depth;
        filled[f.pixel] = true;
    }
    let w = cx.nb.width();
    let at = |d: &[f32], i: Option<usize>| i.map(|i| d[i] as f64).filter(|v| *v > 0.0);
    let mut dropped = Vec::new();
    let at_start = fill.pixels.len();
    // Pixel `q` and its 4-neighbour `r` (in direction `j`) are one surface.
    let link = |d: &[f32], q: usize, j: usize, r: usize| {
        let (x, y) = (q % w, q / w);
        let Some(b) = at(d, Some(r)) else { return false };
        continuous_with(
            d[q] as f64,
            b,
            || at(d, cx.nb.get_at(x, y, opposite(j))),
            || at(d, cx.nb.get2_at(x, y, j)),
            cx.jump,
            cx.plane_tol,
        )
    };
    // Each pass only removes pixels; one that removes none ends it. A removal can take away the
    // plane another pair was continued by, hence the passes (few: 1–3 on realistic scenes).
    for _ in 0..64 {
        let mut drop: Vec<usize> = fill
            .pixels
            .par_iter()
            .flat_map_iter(|f| {
                let q = f.pixel;
                let (x, y) = (q % w, q / w);
                let (d, filled) = (&d, &filled);
                // 4-neighbours, as validate checks: a diagonal step is judged by the steps around it.
                (0..4).filter_map(move |j| {
                    let r = cx.nb.get_at(x, y, j)?;
                    let b = at(d, Some(r))?;
                    if link(d, q, j, r) {
                        return None;
                    }
                    Some(if b < d[q] as f64 && filled[r] { r } else { q })
                })
            })
            .collect();
        if drop.is_empty() {
            break;
        }
        drop.sort_unstable();
        drop.dedup();
        for &p in &drop {
            d[p] = f32::NAN;
            filled[p] = false;
            dropped.extend(own_plane.remove(&p));
        }
        fill.pixels.retain(|f| filled[f.pixel]);
    }
    if fill.pixels.len() == at_start {
        return;
    }
    // A fill left with no continuous path to the layer's own pixels continues nothing seen: a
    // remnant of a rival's plane whose surroundings went. It goes too.
    let mut reached = vec![false; n];
    let mut queue: VecDeque<usize> = VecDeque::new();
    for f in &fill.pixels {
        let (x, y) = (f.pixel % w, f.pixel / w);
        let anchored =
            (0..4).any(|j| cx.nb.get_at(x, y, j).is_some_and(|r| !filled[r] && link(&d, f.pixel, j, r)));
        if anchored {
            reached[f.pixel] = true;
            queue.push_back(f.pixel);
        }
    }
    while let Some(q) = queue.pop_front() {
        let (x, y) = (q % w, q / w);
        for j in 0..4 {
            if let Some(r) = cx.nb.get_at(x, y, j) {
                if filled[r] && !reached[r] && link(&d, q, j, r) {
                    reached[r] = true;
                    queue.push_back(r);
                }
            }
        }
    }
    for f in fill.pixels.iter().filter(|f| !reached[f.pixel]) {
        d[f.pixel] = f32::NAN;
        filled[f.pixel] = false;
        dropped.extend(own_plane.remove(&f.pixel));
    }
    fill.pixels.retain(|f| filled[f.pixel]);
    // Each pass takes back the pixels continuous with all their neighbours so far; one taken
    // back gives its neighbours a value to be judged against, hence the passes.
    loop {
        let before = dropped.len();
        dropped.retain(|f| {
            let q = f.pixel;
            let (x, y) = (q % w, q / w);
            d[q] = f.depth;
            let mut any = false;
            let ok = (0..4).all(|j| match cx.nb.get_at(x, y, j) {
                Some(r) if at(&d, Some(r)).is_some() => {
                    any = true;
                    link(&d, q, j, r)
                }
                _ => true,
            });
            if any && ok {
                fill.pixels.push(*f);
                return false;
            }
            d[q] = f32::NAN;
            true
        });
        if dropped.len() == before {
            break;
        }
    }
}

/// The surface the ray through `q` meets, starting from the nearest seed `own` and weighing each
/// rival seed's plane in turn. Where two planes meet in a crease, a concave crease (a room's
/// floor and wall: each surface in front of the other's plane) hides the farther plane, so the
/// nearer hit is the surface; a convex one (a pillar's corner: each surface behind the other's
/// plane) shows the farther hit. Planes the seeds do not relate (they disagree, or a seed lies
/// on the other's plane) leave the current choice.
fn pick_surface(
    cx: &FillContext,
    surfaces: &Surfaces,
    own: usize,
    rivals: &[u32],
    q: usize,
) -> Option<(usize, f32)> {
    let mut best = continue_surface(cx, surfaces, own, q).map(|d| (own, d));
    for &r in rivals {
        let b = r as usize;
        if r == u32::MAX {
            continue;
        }
        let Some(cur) = best else {
            // The nearest seed's plane misses the ray: the first rival whose plane it meets.
            best = plane_hit(cx, surfaces, b, q).map(|d| (b, d));
            continue;
        };
        if same_surface(cx, b, cur.0) {
            continue;
        }
        let a = cur.0;
        let (na, nb) = (cx.normals[a], cx.normals[b]);
        let (pa, pb) = (cx.dirs[a] * cx.depth[a], cx.dirs[b] * cx.depth[b]);
        // One segment's two faces (a segment can leak round a crease) share one centroid,
        // which tells nothing: their seeds stand in.
        let (ca, cb) = if cx.surface[a] == cx.surface[b] {
            (pa, pb)
        } else {
            // Pixels outside every segment (infinitely far) have no centroid.
            let at = |p: usize| surfaces.centroid.get(cx.surface[p] as usize).copied().unwrap_or(Vec3::NAN);
            (at(a), at(b))
        };
        if na == Vec3::ZERO || nb == Vec3::ZERO || !(pa + pb + ca + cb).is_finite() {
            continue;
        }
        // Signed distances of each surface's centroid to the other's plane (seeds often lie
        // on the crease itself), against a tolerance that scales with the depths.
        let (sa, sb) = (nb.dot(ca - pb), na.dot(cb - pa));
        let tol = 1e-3 * cx.depth[a].min(cx.depth[b]);
        let Some(db) = plane_hit(cx, surfaces, b, q) else { continue };
        let concave = sa > tol && sb > tol;
        let convex = sa < -tol && sb < -tol;
        if (concave && db < cur.1) || (convex && db > cur.1) {
            best = Some((b, db));
        }
    }
    best
}

/// Cosine of the angle under which two seeds' normals are taken for one plane.
pub(super) const SAME_PLANE_COS: f32 = 0.94; // 20°

/// Seeds `a` and `b` continue the same surface: one segment, and normals that agree (a segment
/// can run round a rounded-off crease; its faces still compete).
fn same_surface(cx: &FillContext, a: usize, b: usize) -> bool {
    cx.surface[a] == cx.surface[b] && cx.normals[a].dot(cx.normals[b]) >= SAME_PLANE_COS
}

/// Is the tangent plane at `p` worth continuing? Its normal must agree with those of its
/// continuous neighbours on the same surface: a pixel on a crease, or at the corner of three
/// planes, has a normal blended between them that belongs to none.
fn trusted_plane(cx: &FillContext, p: usize) -> bool {
    let n = cx.normals[p];
    if n == Vec3::ZERO {
        return true; // no plane: the seed's depth is kept, which needs no normal
    }
    (0..8).all(|j| {
        cx.nb.get(p, j).map_or(true, |q| {
            !cx.links.continuous(p, j)
                || cx.surface[q] != cx.surface[p]
                || cx.normals[q] == Vec3::ZERO
                || cx.normals[q].dot(n) >= SAME_PLANE_COS
        })
    })
}

/// Steps along each of the 8 directions within which [`planar_reach`] looks.
const REACH_STEPS: usize = 48;

/// How far (an angle) the tangent plane at seed `s` may be continued behind an occluder: as far
/// as it fits the seed's own visible surface (within the plane tolerance, relative, and with
/// normals within 20° of its own), looking along the 8 directions over the layer's pixels of the
/// same segment. A wall fits its plane all the way; the tangent plane of a sphere or of a table
/// leg leaves the surface within a few pixels, and continued far beyond (along a thin pole in
/// front of it) it draws a sliver of the object where there is none. A seed without a normal
/// walks with the one it borrows, else its neighbours' mean; unlimited when there is none either
/// or nothing contradicts it.
fn planar_reach(cx: &FillContext, surfaces: &Surfaces, k: u32, s: usize) -> f64 {
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
        for _ in 0..REACH_STEPS {
            let Some(q) = cx.nb.get(p, j) else { break };
            if cx.layer_of[q] != k || cx.surface[q] != cx.surface[s] || !cx.links.continuous(p, j) {
                break;
            }
            let dq = cx.depth[q];
            let t = plane_depth(cx, s, n, q);
            let turned = cx.normals[q] != Vec3::ZERO && cx.normals[q].dot(n) < SAME_PLANE_COS;
            if turned
                || !(n.dot(cx.dirs[q]) < 0.0 && t.is_finite() && (t - dq).abs() <= cx.plane_tol as f32 * dq)
            {
                let angle = cx.dirs[q].dot(cx.dirs[s]).clamp(-1.0, 1.0).acos() as f64;
                reach = reach.min(angle);
                break;
            }
            p = q;
        }
    }
    reach
}

/// Per surface (segment) of a layer, the centroid of its points; per seed without a normal of
/// its own, the normal its neighbourhood gives it.
struct Surfaces {
    centroid: Vec<Vec3>,
    /// Farthest depth each surface is seen at.
    far: Vec<f32>,
    /// Pixels of each surface (finite depths).
    size: Vec<u32>,
    borrowed: HashMap<usize, Vec3>,
}

/// Surfaces of fewer pixels are specks: without a plane of their own they seed no fill.
const SPECK: u32 = 32;

/// How much farther than its surface is seen anywhere the fill may continue it.
const FAR_SEEN: f32 = 1.5;

/// Steps around a seed within which its surface's normals stand in for its missing one.
const BORROW_STEPS: usize = 3;
/// Normals that must agree for a seed to borrow their plane.
const BORROW_MIN: usize = 3;

impl Surfaces {
    /// Pixels of the surface of `s` in its layer.
    fn size(&self, cx: &FillContext, s: usize) -> u32 {
        self.size.get(cx.surface[s] as usize).copied().unwrap_or(0)
    }

    /// The normal of seed `s`: its own, else the one it borrows, else zero.
    fn normal(&self, cx: &FillContext, s: usize) -> Vec3 {
        match cx.normals[s] {
            n if n != Vec3::ZERO => n,
            _ => self.borrowed.get(&s).copied().unwrap_or(Vec3::ZERO),
        }
    }

    /// The surfaces of layer `k` (finite depths only) and the normals `seeds` borrow.
    fn new(cx: &FillContext, k: u32, seeds: impl Iterator<Item = usize>) -> Surfaces {
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
                sums[id].0 += cx.dirs[p] * d;
                sums[id].1 += 1;
            }
        }
        let centroid = sums.iter().map(|&(sum, c)| if c > 0 { sum / c as f32 } else { Vec3::NAN }).collect();
        let borrowed = seeds
            .filter(|&s| cx.normals[s] == Vec3::ZERO && cx.depth[s].is_finite())
            .filter_map(|s| Some((s, borrow_normal(cx, s)?)))
            .collect();
        let size = sums.iter().map(|&(_, c)| c).collect();
        Surfaces { centroid, far, size, borrowed }
    }
}

/// The normal of the plane around seed `s`, which has none of its own (the ground seen at a
/// grazing angle): of its surface's normals a few steps around it, the mean of the largest set
/// that agree (within [`SAME_PLANE_COS`]), when that is at least half of them. Pixels at the
/// foot of an object carry normals blended with the object's; the majority is the plane.
fn borrow_normal(cx: &FillContext, s: usize) -> Option<Vec3> {
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
fn continue_surface(cx: &FillContext, surfaces: &Surfaces, s: usize, q: usize) -> Option<f32> {
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
fn plane_hit(cx: &FillContext, surfaces: &Surfaces, s: usize, q: usize) -> Option<f32> {
    plane_hit_with(cx, surfaces, s, cx.normals[s], q)
}

/// [`plane_hit`] for the plane through `s` with normal `nrm`.
fn plane_hit_with(cx: &FillContext, surfaces: &Surfaces, s: usize, nrm: Vec3, q: usize) -> Option<f32> {
    let ds = cx.depth[s];
    if !ds.is_finite() || nrm == Vec3::ZERO {
        return None;
    }
    if nrm.dot(cx.dirs[q]) > -1e-3 {
        return None;
    }
    let t = plane_depth(cx, s, nrm, q);
    let seen = surfaces.far.get(cx.surface[s] as usize).map_or(f32::INFINITY, |&f| FAR_SEEN * f);
    (t.is_finite() && t > cx.depth[q] && t < 8.0 * ds && t <= seen).then_some(t)
}

/// Distance along the ray through `q` to the plane through seed `s` with normal `nrm`.
#[inline]
fn plane_depth(cx: &FillContext, s: usize, nrm: Vec3, q: usize) -> f32 {
    nrm.dot(cx.dirs[s] * cx.depth[s]) / nrm.dot(cx.dirs[q])
}

/// The neighbour of a border pixel `s` that is deepest inside its layer (most neighbours in the
/// same layer): its colour is free of any mixing with the occluder at the border.
fn interior_neighbour(cx: &FillContext, s: usize, k: u32) -> usize {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layering::edges::EdgeOptions;
    use crate::mapping::{AnyMapping, Mapping, MappingKind};

    /// A fill context over the given planes with the build's default rules (freedom radius
    /// 0.5 m, no margin).
    #[allow(clippy::too_many_arguments)]
    fn context<'a>(
        nb: &'a Neighbours,
        dirs: &'a [Vec3],
        depth: &'a [f32],
        normals: &'a [Vec3],
        layer_of: &'a [u32],
        links: &'a Links,
        surface: &'a [u32],
        rgb: &'a [Vec<f32>; 3],
    ) -> FillContext<'a> {
        FillContext {
            nb,
            dirs,
            depth,
            normals,
            layer_of,
            freedom_radius: 0.5,
            margin: 0.0,
            links,
            surface,
            jump: crate::continuity::JUMP,
            plane_tol: EdgeOptions::default().extrapolation,
            rgb,
        }
    }

    /// [`planar_reach`] in pixels of seeds on a wall at x = `wall` and on a sphere of 0.5 m radius
    /// centred `dist` away along +x, on a `w` × `w/2` equirect canvas: the sphere seed `az`° off
    /// the sphere's centre direction (with its own normal, then without), the wall seed 40° off.
    fn sphere_and_wall_reach(w: usize, dist: f32, wall: f32, az: f64) -> (f64, f64, f64) {
        let m = AnyMapping::new(MappingKind::Equirect, w, w / 2).unwrap();
        let n = w * w / 2;
        let nb = Neighbours::new(m);
        let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let centre = Vec3::new(dist, 0.0, 0.0);
        // The sphere where the ray meets it, else the wall.
        let hit = |d: Vec3| {
            let b = d.dot(centre);
            let disc = b * b - centre.length_squared() + 0.25;
            (disc > 0.0 && b > 0.0).then(|| b - disc.sqrt())
        };
        let (mut depth, mut normals, mut surface) = (vec![0f32; n], vec![Vec3::ZERO; n], vec![0u32; n]);
        for p in 0..n {
            let d = dirs[p];
            (depth[p], normals[p], surface[p]) = match hit(d) {
                Some(t) => (t, (d * t - centre).normalize(), 1),
                None if d.x > 0.05 => (wall / d.x, Vec3::new(-1.0, 0.0, 0.0), 0),
                None => (f32::NAN, Vec3::ZERO, u32::MAX),
            };
        }
        let layer_of = vec![0u32; n];
        let links = Links::compute(&nb, &depth, &EdgeOptions::default());
        let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
        let pixel = std::f64::consts::TAU / w as f64;
        let at = |az: f64| (w / 4 * w) + ((az.to_radians() / pixel) as usize);
        let (on_sphere, on_wall) = (at(az), at(40.0));
        assert_eq!((surface[on_sphere], surface[on_wall]), (1, 0));
        let cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        let surfaces = Surfaces::new(&cx, 0, [on_sphere, on_wall].into_iter());
        let sphere = planar_reach(&cx, &surfaces, 0, on_sphere) / pixel;
        let wall = planar_reach(&cx, &surfaces, 0, on_wall) / pixel;
        // A seed without a normal of its own (at an object's outline) is limited by the one it borrows.
        normals[on_sphere] = Vec3::ZERO;
        let cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        let surfaces = Surfaces::new(&cx, 0, [on_sphere].into_iter());
        let borrowed = planar_reach(&cx, &surfaces, 0, on_sphere) / pixel;
        eprintln!("{dist} m: sphere reach {sphere:.1} px, without a normal {borrowed:.1} px; wall {wall} px");
        (sphere, borrowed, wall)
    }

    /// The tangent plane of a wall may be continued without limit; a sphere's only about as far
    /// as it fits the sphere: within the plane tolerance (0.5 m radius, 2 m away: the plane
    /// leaves it within a few pixels) and while the normals stay within 20° (6 m away, 7 pixels
    /// in radius: the plane stays within 5 % of the depth for 7 pixels, so the tolerance alone
    /// let the fill draw the sphere up to twice as wide; the normals turn 20° within 3).
    #[test]
    fn a_curved_surface_is_continued_only_as_far_as_its_plane_fits() {
        for (w, dist, wall, az, most) in [(256, 2.0, 4.0, 5.0, 8.0), (512, 6.0, 8.0, 2.0, 4.0)] {
            let (sphere, borrowed, wall) = sphere_and_wall_reach(w, dist, wall, az);
            assert!(sphere > 1.0 && sphere < most, "{dist} m: sphere reach {sphere} px");
            assert!(borrowed > 1.0 && borrowed < most, "{dist} m: borrowed reach {borrowed} px");
            assert_eq!(wall, f64::INFINITY);
        }
    }

    /// A wall at 3 m with a nearer layer (1 m) in front of a block of it. Its fill continues the
    /// wall, except for a rival plane at 2 m claimed in two places: a band touching the wall's
    /// fill, and an island cut off from everything (the fill pixels around it went).
    #[test]
    fn a_rival_plane_dropped_gives_back_the_nearest_seeds_plane_and_leaves_no_remnant() {
        let m = AnyMapping::new(MappingKind::Equirect, 64, 32).unwrap();
        let (w, n) = (64, 64 * 32);
        let nb = Neighbours::new(m);
        let hidden = |p: usize| (20..44).contains(&(p % w)) && (8..24).contains(&(p / w));
        let depth: Vec<f32> = (0..n).map(|p| if hidden(p) { 1.0 } else { 3.0 }).collect();
        let layer_of: Vec<u32> = (0..n).map(|p| hidden(p) as u32).collect();
        let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let links = Links::compute(&nb, &depth, &EdgeOptions::default());
        let (normals, surface) = (vec![Vec3::ZERO; n], vec![0u32; n]);
        let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
        let cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        let band = |p: usize| (24..32).contains(&(p % w)) && (10..12).contains(&(p / w));
        let island = |p: usize| (36..40).contains(&(p % w)) && (18..20).contains(&(p / w));
        let moat = |p: usize| (35..41).contains(&(p % w)) && (17..21).contains(&(p / w)) && !island(p);
        let px = |p: usize, depth: f32| FillPixel { pixel: p, depth, rgb: [0.5; 3], surface: 0 };
        let mut fill = Fill::default();
        let mut own_plane = HashMap::new();
        for p in (0..n).filter(|&p| hidden(p) && !moat(p)) {
            if band(p) || island(p) {
                fill.pixels.push(px(p, 2.0));
                own_plane.insert(p, px(p, 3.0));
            } else {
                fill.pixels.push(px(p, 3.0));
            }
        }
        keep_continuous(&cx, 0, &mut fill, own_plane);
        let got: HashMap<usize, f32> = fill.pixels.iter().map(|f| (f.pixel, f.depth)).collect();
        assert!(
            (0..n).filter(|&p| band(p)).all(|p| got.get(&p) == Some(&3.0)),
            "the band takes the wall back"
        );
        assert!(got.values().all(|&d| d == 3.0), "no pixel keeps the rival's plane");
        let holes = (0..n).filter(|&p| hidden(p) && !moat(p) && !island(p) && !got.contains_key(&p)).count();
        assert_eq!(holes, 0, "the wall's fill has no hole");
    }

    /// A box at 1 m before a wall at 3 m, its top edge lined with in-between depths (1.3 m, as a
    /// resized depth edge leaves them): one-pixel surfaces without a normal, in the wall's layer.
    /// They seed no fill; the wall's fill behind the box is at the wall's depth, not a screen at
    /// 1.3 m (which a camera moved aside saw as a ghost of the box).
    #[test]
    fn specks_without_a_plane_seed_no_fill() {
        let m = AnyMapping::new(MappingKind::Equirect, 128, 64).unwrap();
        let (w, n) = (128, 128 * 64);
        let nb = Neighbours::new(m);
        let hidden = |p: usize| (52..76).contains(&(p % w)) && (24..40).contains(&(p / w));
        let speck = |p: usize| (52..76).contains(&(p % w)) && p / w == 23;
        let depth: Vec<f32> = (0..n)
            .map(|p| {
                if hidden(p) {
                    1.0
                } else if speck(p) {
                    1.3
                } else {
                    3.0
                }
            })
            .collect();
        let layer_of: Vec<u32> = (0..n).map(|p| hidden(p) as u32).collect();
        let surface: Vec<u32> =
            (0..n).map(|p| if speck(p) { 10 + p as u32 % w as u32 } else { hidden(p) as u32 }).collect();
        let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let links = Links::compute(&nb, &depth, &EdgeOptions::default());
        let normals = vec![Vec3::ZERO; n];
        let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
        let cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        let fill = fill_layer(&cx, 0);
        let screen = fill.pixels.iter().filter(|f| f.depth < 2.0).count();
        eprintln!("{} filled, {screen} at the specks' depth", fill.pixels.len());
        assert!(fill.pixels.len() > 100, "the wall is continued behind the box");
        assert_eq!(screen, 0, "filled pixels in front of the wall");
        // Pixels of unknown depth given the wall's (a depth sensor's shadow beside the box) are on
        // no segment and have no normal: not specks. Ringing the box, they are its only seeds.
        let ring = |p: usize| (51..77).contains(&(p % w)) && (23..41).contains(&(p / w)) && !hidden(p);
        let depth: Vec<f32> = (0..n).map(|p| if hidden(p) { 1.0 } else { 3.0 }).collect();
        let surface: Vec<u32> = (0..n).map(|p| if ring(p) { u32::MAX } else { hidden(p) as u32 }).collect();
        let links = Links::compute(&nb, &depth, &EdgeOptions::default());
        let cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        let unknown = fill_layer(&cx, 0);
        eprintln!("{} filled from a ring of unknown depth", unknown.pixels.len());
        assert!(unknown.pixels.len() > 100, "the ring of unknown depth seeds the fill");
    }

    /// A block hides part of a wall at x = 3 m. Its right edge meets the wall without a jump (fold
    /// seeds); the wall pixels along its other edges carry a plane the rays behind the block miss
    /// (as the in-between depths of a resized edge do). Those seeds claim nothing, so the fold
    /// seeds fill the whole block at the wall's depth; claimed by them, 8 of its 64 pixels stayed
    /// empty.
    #[test]
    fn a_seed_whose_plane_misses_leaves_the_pixel_to_one_whose_plane_meets_it() {
        let m = AnyMapping::new(MappingKind::Equirect, 128, 64).unwrap();
        let (w, n) = (128, 128 * 64);
        let nb = Neighbours::new(m);
        let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let (x, y) = (|p: usize| p % w, |p: usize| p / w);
        let block = |p: usize| (4..12).contains(&x(p)) && (28..36).contains(&y(p));
        let wall = |p: usize| 3.0 / dirs[p].x;
        let bad = |p: usize| !block(p) && (3..12).contains(&x(p)) && (27..37).contains(&y(p));
        let mut depth = vec![f32::NAN; n];
        let (mut normals, mut surface) = (vec![Vec3::ZERO; n], vec![u32::MAX; n]);
        let mut layer_of = vec![u32::MAX; n];
        for p in (0..n).filter(|&p| dirs[p].x > 0.05) {
            (depth[p], layer_of[p], surface[p], normals[p]) = if block(p) {
                // 1 m at its left edge, at the wall's depth (less 1 %) at its right.
                let t = (x(p) - 4) as f32 / 7.0;
                (1.0 + t * (0.99 * wall(p) - 1.0), 1, 1, Vec3::new(-1.0, 0.0, 0.0))
            } else if bad(p) {
                (wall(p), 0, 5, Vec3::new(1.0, 0.0, 0.0))
            } else {
                (wall(p), 0, 0, Vec3::new(-1.0, 0.0, 0.0))
            };
        }
        let links = Links::compute(&nb, &depth, &EdgeOptions::default());
        let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
        let mut cx = context(&nb, &dirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
        // Every part of the block is within the radius: the whole of it may be filled.
        cx.freedom_radius = 2.95;
        let fill = fill_layer(&cx, 0);
        let got: HashMap<usize, f32> = fill.pixels.iter().map(|f| (f.pixel, f.depth)).collect();
        let hidden: Vec<usize> = (0..n).filter(|&p| block(p)).collect();
        let filled = hidden
            .iter()
            .filter(|&&p| got.get(&p).is_some_and(|&d| (d / wall(p) - 1.0).abs() < 0.01))
            .count();
        eprintln!("{filled} of {} hidden pixels filled at the wall", hidden.len());
        assert_eq!(filled, hidden.len());
    }

    #[test]
    fn band_is_the_parallax_difference() {
        // r = 0.5, occluder at 1 m, wall at 2 m: asin(0.5) − asin(0.25).
        let b = parallax_band(0.5, 1.0, 2.0);
        assert!((b - (0.5f64.asin() - 0.25f64.asin())).abs() < 1e-12);
        assert_eq!(parallax_band(0.5, 0.05, 2.0), std::f64::consts::PI);
        assert!((parallax_band(0.5, 1.0, f64::INFINITY) - 0.5f64.asin()).abs() < 1e-12);
        assert_eq!(parallax_band(0.5, 3.0, 3.0), 0.0);
    }
}
