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
use crate::mapping::{opposite, Neighbours, PixelDirs};

/// One filled pixel.
mod shadow;
mod surface;
#[cfg(test)]
mod tests;
pub(crate) mod texture;

pub(crate) use surface::SAME_PLANE_COS;
use surface::{
    continue_surface, interior_neighbour, planar_reach, plane_hit, same_surface, trusted_plane, Surfaces,
    SPECK,
};
pub use texture::FillColour;

#[derive(Clone, Copy, Debug)]
pub struct FillPixel {
    /// Row-major index of the filled pixel on the canvas.
    pub pixel: usize,
    /// Distance along its ray (m) on the continued surface; `+inf` in the infinity layer.
    pub depth: f32,
    /// Its linear RGB: the nearest visible pixel's, then as [`texture`] colours it.
    pub rgb: [f32; 3],
    /// The seed whose surface it continues (its plane and normal).
    pub surface: usize,
    /// Angle (radians) from the nearest seed of its layer that reached it: how far inside the
    /// occluder it lies from where its layer shows ([`yield_to_farther`]).
    pub angle: f32,
    /// On a level plane (a floor, the ground, a ceiling), which ends at its own horizon: it never
    /// yields to a farther layer.
    pub level: bool,
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
    pub dirs: &'a PixelDirs,
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
    /// The depth was soft ([`super::BuildOptions::soft_depth`]): seeds on small surfaces
    /// continue the plane of their layer a few pixels inside ([`surface::anchor`]).
    pub soft_depth: bool,
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

/// Cosine of the largest angle between a rival seed and the pixel that weighs it (45°). The
/// rivals that win lie within 30° of their pixel on the 4096 room and in all but one layer of a
/// 12-megapixel photo, while a search through the whole occluder flooded most of the canvas once
/// per surface (docs/benchmarks.md, eighteenth session).
const RIVAL_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Fill layer `k` behind its occluders.
///
/// Every hidden pixel within the parallax band takes the nearest seed (breadth-first). A second
/// search, not limited to the band (only to 45° from each seed), finds for every hidden pixel the
/// nearest seeds of up to `RIVALS` other surfaces around the same occluder: where a floor meets a
/// wall, or two walls meet, behind a box, the pixel takes the plane the crease puts it on
/// (`pick_surface`) even when that plane shows only far away (above the box).
pub fn fill_layer(cx: &FillContext, k: u32) -> Fill {
    // Seeds across a jump first; seeds along a fold only (the floor a box stands on) reach what
    // the former leave.
    // The seeds (in pixel order, found in parallel) beside the layer's surfaces (a serial sum).
    let (found, mut surfaces) = rayon::join(
        || -> Vec<(usize, bool)> {
            let w = cx.nb.width();
            (0..cx.nb.height())
                .into_par_iter()
                .flat_map_iter(|y| {
                    (0..w).filter_map(move |x| {
                        let p = y * w + x;
                        // NaN (unknown) depth never seeds a fill.
                        if cx.layer_of[p] != k || cx.depth[p].is_nan() || cx.depth[p] <= 0.0 {
                            return None;
                        }
                        let mut borders =
                            (0..8).filter(|&j| cx.nb.get_at(x, y, j).is_some_and(|q| hidden(cx, k, q)));
                        let first = borders.next()?;
                        if !trusted_plane(cx, p) {
                            return None;
                        }
                        Some((p, cx.links.is_jump(p, first) || borders.any(|j| cx.links.is_jump(p, j))))
                    })
                })
                .collect()
        },
        || Surfaces::of_layer(cx, k),
    );
    let (mut seeds, mut fold_seeds): (Vec<usize>, Vec<usize>) = (Vec::new(), Vec::new());
    for (p, jump) in found {
        if jump {
            seeds.push(p);
        } else {
            fold_seeds.push(p);
        }
    }
    surfaces.borrow_normals(cx, seeds.iter().chain(&fold_seeds).copied());
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
    // The band search and the rival search are independent. Their per-pixel tables go before
    // the continuity pass allocates its own.
    let mut fill = Fill::default();
    let mut own_plane: HashMap<usize, FillPixel> = HashMap::new();
    {
        let ((src, angle_of, order), (slot_of, rivals)) = rayon::join(
            || band(cx, k, &seeds, jump_seeds, &surfaces, &reach),
            || rivals(cx, k, &seeds[..jump_seeds]),
        );
        let mut colour_of_seed: HashMap<usize, usize> = HashMap::new();
        for q in order {
            let own = src[q] as usize;
            // Pixels only fold seeds reach have no rivals.
            let none = [NONE; RIVALS];
            let rival = rivals.get(slot_of[q] as usize).unwrap_or(&none);
            let Some((s, d)) = pick_surface(cx, &surfaces, own, rival, q) else { continue };
            let mut pixel = |s: usize, depth: f32| {
                let c = *colour_of_seed.entry(s).or_insert_with(|| interior_neighbour(cx, s, k));
                // A level plane continued behind an occluder stops at its horizon by itself; a
                // farther layer nearby must not take the pixels below it (the sky behind a sphere
                // on the ground).
                let level = surfaces.normal(cx, s).z.abs() > LEVEL_COS;
                FillPixel {
                    pixel: q,
                    depth,
                    rgb: cx.colour(c).to_array(),
                    surface: s,
                    angle: angle_of[q],
                    level,
                }
            };
            fill.pixels.push(pixel(s, d));
            if s != own {
                if let Some(d) = continue_surface(cx, &surfaces, own, q) {
                    own_plane.insert(q, pixel(own, d));
                }
            }
            fill.max_angle = fill.max_angle.max(f64::from(angle_of[q]));
        }
    }
    keep_continuous(cx, k, &mut fill, own_plane);
    fill
}

const NONE: u32 = u32::MAX;

/// `|n_z|` above which a plane is level (a floor, the ground, a ceiling): within 25° of horizontal
/// (45° cut the room's views more and mended none).
const LEVEL_COS: f32 = 0.906;

/// Pixel `q` belongs to a layer nearer than `k`: what layer `k` fills behind.
fn hidden(cx: &FillContext, k: u32, q: usize) -> bool {
    cx.layer_of[q] != NONE && cx.layer_of[q] > k && cx.depth[q] > 0.0
}

/// (1) The band of layer `k`: each hidden pixel's source seed (`NONE`: unfilled), its angle from
/// it, and the pixels in the order they were first reached. `seeds[..jump_seeds]` are across a
/// jump, the rest along a fold.
fn band(
    cx: &FillContext,
    k: u32,
    seeds: &[usize],
    jump_seeds: usize,
    surfaces: &Surfaces,
    reach: &HashMap<usize, f64>,
) -> (Vec<u32>, Vec<f32>, Vec<usize>) {
    let (n, w) = (cx.nb.len(), cx.nb.width());
    // (1) The band: nearest seed within the parallax a camera in the freedom radius can open.
    // Breadth-first from the seeds; a pixel already claimed switches to a nearer (in angle)
    // seed of the same kind reaching it later and passes the improvement on. Without that the
    // source drifts diagonally along a straight edge (the first seed to arrive wins) and the
    // band comes out up to √2 narrower than the parallax needs.
    let mut src = vec![NONE; n];
    // Angles are `f32` arccosines: stored as such, exactly.
    let mut angle_of = vec![0f32; n];
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
        // What a claim needs of the seed, looked up once for the 8 neighbours.
        let seed = (s, cx.dirs.at(s), reach[&s]);
        let (x, y) = (p % w, p / w);
        for j in 0..8 {
            let Some(q) = cx.nb.get_at(x, y, j) else { continue };
            if !hidden(cx, k, q)
                || (src[q] != NONE && (src[q] as usize == q || kind[src[q] as usize] != kind[s]))
            {
                continue;
            }
            let first = src[q] == NONE;
            let held = (!first).then(|| f64::from(angle_of[q]));
            let Some(angle) = claim_angle(cx, surfaces, seed, q, held) else {
                continue;
            };
            src[q] = s as u32;
            angle_of[q] = angle as f32;
            if first {
                order.push(q);
            }
            queue.push_back(q);
        }
    }
    (src, angle_of, order)
}

/// The angle from seed `s` to pixel `q` when `s` claims `q` (held at angle `held` by another seed,
/// if any): within the parallax band and `s`'s reach, where `s`'s surface continues. `s` comes
/// with its direction and reach.
fn claim_angle(
    cx: &FillContext,
    surfaces: &Surfaces,
    (s, dir, reach): (usize, Vec3, f64),
    q: usize,
    held: Option<f64>,
) -> Option<f64> {
    let angle = cx.dirs.at(q).dot(dir).clamp(-1.0, 1.0).acos() as f64;
    // Strictly nearer (beyond rounding) or no switch: every switch lowers a pixel's angle, so the
    // propagation ends.
    let refused = held.is_some_and(|h| angle >= h - 1e-9)
        || angle > parallax_band(cx.freedom_radius, cx.depth[q] as f64, cx.depth[s] as f64) + cx.margin
        // The reach is looked up only past its floor (most pixels stay within it).
        || (angle > 2.0 * cx.margin && angle > reach)
        // A seed claims only where its surface continues: one whose plane misses (the in-between
        // depths of a resized edge, whose plane runs along the ray) leaves the pixel to seeds
        // that can fill it.
        || continue_surface(cx, surfaces, s, q).is_none();
    (!refused).then_some(angle)
}

/// Behind an occluder, each hidden pixel goes to the layer that shows nearest to it: a pixel that a
/// farther layer's fill reaches from a seed nearer (in angle) than its own layer's leaves that
/// layer's fill. A wall seen beside a sky, both bordering a sphere in front, is continued behind the
/// sphere by its plane, which has no end: without this rule it would cover, out to its band, what
/// is sky beyond the wall's edge, and a camera moved aside would see the wall there. A level plane
/// is not cut (its horizon ends it where the truth does; the nearest seed would not). The farther
/// layer's fill keeps the pixel, so no hole opens. `fills[k]` is layer `k`'s (larger is nearer),
/// before [`add_borders`]. Returns, per layer, whether its fill lost pixels.
pub fn yield_to_farther(fills: &mut [Fill]) -> Vec<bool> {
    let before: Vec<usize> = fills.iter().map(|f| f.pixels.len()).collect();
    let mut nearest: HashMap<usize, f32> = HashMap::new();
    for i in 0..fills.len() {
        let (done, nearer) = fills.split_at_mut(i + 1);
        let fill = &mut done[i];
        if !nearest.is_empty() {
            fill.pixels.retain(|f| f.level || nearest.get(&f.pixel).is_none_or(|&a| a >= f.angle));
        }
        // Only nearer fills read the angles: none left, none to record (the nearest layer's
        // fill is often most of the pixels).
        if nearer.iter().all(|f| f.pixels.is_empty()) {
            break;
        }
        for f in &fill.pixels {
            let a = nearest.entry(f.pixel).or_insert(f32::INFINITY);
            *a = a.min(f.angle);
        }
    }
    fills.iter().zip(before).map(|(f, b)| f.pixels.len() < b).collect()
}

type Rivals = Vec<[u32; RIVALS]>;

/// (2) The rival surfaces of layer `k` from its jump seeds: for each hidden pixel's slot, the
/// nearest seeds of other surfaces through the occluder, within 45° ([`RIVAL_COS`]).
fn rivals(cx: &FillContext, k: u32, seeds: &[usize]) -> (Vec<u32>, Rivals) {
    let n = cx.nb.len();
    // Directions only (the infinity layer): there is no plane to continue, so no rival to
    // weigh; skipping the search spares a flood through everything finite.
    if !seeds.iter().any(|&p| cx.depth[p].is_finite()) {
        return (vec![NONE; n], Vec::new());
    }
    // (2) Rival surfaces: nearest seeds of other surfaces through the occluder. Slots are
    // kept for hidden pixels only (compact index), the seeds being their own first rival. While
    // searching, a pixel's slot also tells whether it is hidden (`OUT`: not), one lookup instead
    // of three, and the slots hold seed indices, whose surfaces and normals sit in a small table
    // (the canvas-wide ones miss the cache); both are put back as the result wants them after.
    const OUT: u32 = NONE - 1;
    let mut slot_of: Vec<u32> =
        (0..n).into_par_iter().map(|q| if hidden(cx, k, q) { NONE } else { OUT }).collect();
    let planes: Vec<(u32, Vec3)> = seeds.iter().map(|&p| (cx.surface[p], cx.normals[p])).collect();
    let mut rivals: Vec<[u32; RIVALS]> = Vec::with_capacity(seeds.len());
    // A pixel and the seed (index) it passes on, as `rivals[slot_of[pixel]]` holds it.
    let mut queue: VecDeque<(u32, u32)> = VecDeque::with_capacity(seeds.len());
    for (i, &p) in seeds.iter().enumerate() {
        let mut r = [NONE; RIVALS];
        r[0] = i as u32;
        rivals.push(r);
        queue.push_back((p as u32, i as u32));
    }
    let w = cx.nb.width();
    let seed_dirs: Vec<Vec3> = seeds.iter().map(|&p| cx.dirs.at(p)).collect();
    // A pixel whose rivals are all found takes no more: its slot is flagged `FULL` so that the
    // seeds spreading past it (most, once the fronts have passed) skip it on one lookup.
    const FULL: u32 = 1 << 31;
    while let Some((p, s)) = queue.pop_front() {
        let (x, y) = (p as usize % w, p as usize / w);
        let (surface, normal) = planes[s as usize];
        for j in 0..8 {
            let Some(q) = cx.nb.get_at(x, y, j) else { continue };
            // `OUT`, or `FULL`.
            if slot_of[q] != NONE && slot_of[q] >= FULL {
                continue;
            }
            if cx.dirs.at(q).dot(seed_dirs[s as usize]) < RIVAL_COS {
                continue;
            }
            if slot_of[q] == NONE {
                slot_of[q] = rivals.len() as u32;
                rivals.push([NONE; RIVALS]);
            }
            let r = &mut rivals[slot_of[q] as usize];
            // `same_surface(t, s)`, from the table.
            let same = |t: u32| {
                let (ts, tn) = planes[t as usize];
                ts == surface && tn.dot(normal) >= SAME_PLANE_COS
            };
            if r.iter().any(|&t| t != NONE && same(t)) {
                continue;
            }
            let Some(free) = r.iter().position(|&t| t == NONE) else { continue };
            r[free] = s;
            if free == RIVALS - 1 {
                slot_of[q] |= FULL;
            }
            queue.push_back((q as u32, s));
        }
    }
    slot_of.par_iter_mut().for_each(|s| {
        if *s == OUT {
            *s = NONE;
        } else if *s != NONE {
            *s &= !FULL;
        }
    });
    // Seeds are not hidden: their own slots, the last one where a pixel is listed twice.
    for (i, &p) in seeds.iter().enumerate() {
        slot_of[p] = i as u32;
    }
    rivals
        .par_iter_mut()
        .flat_map_iter(|r| r.iter_mut())
        .filter(|t| **t != NONE)
        .for_each(|t| *t = seeds[*t as usize] as u32);
    (slot_of, rivals)
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
            angle: 0.0,
            level: false,
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
    let mut c = Continuity::new(cx, k, fill, (cx.jump, cx.plane_tol));
    let mut dropped = c.drop_breaks(fill, &mut own_plane);
    if c.removed.is_empty() {
        return;
    }
    c.drop_unanchored(fill, &mut own_plane, &mut dropped);
    c.take_back(fill, dropped);
    c.close_cracks(fill);
}

/// Drop the fill pixels of layer `k` that leave it discontinuous by `validate`'s rule
/// ([`continuity::LAYER_JUMP`]), after [`yield_to_farther`] took some of its fill: a pair of
/// filled pixels the build's own pass found one surface only through a plane test through a
/// third pixel is a step once that pixel went to a farther layer. Of such a pair the nearer goes,
/// as in [`keep_continuous`]; a farther layer's fill or surface shows there.
pub fn keep_valid(cx: &FillContext, k: u32, fill: &mut Fill) {
    if fill.pixels.is_empty() {
        return;
    }
    let mut c = Continuity::new(cx, k, fill, (crate::continuity::LAYER_JUMP, crate::continuity::PLANAR));
    c.drop_breaks(fill, &mut HashMap::new());
}

/// The layer's depth as [`keep_continuous`] edits it: its own pixels and its fill (NaN
/// elsewhere), which pixels are filled, and the fill pixels removed so far.
struct Continuity<'a, 'b> {
    cx: &'a FillContext<'b>,
    /// The step and plane tolerance of [`continuous_with`] the layer is held to.
    rule: (f64, f64),
    d: Vec<f32>,
    filled: Vec<bool>,
    removed: Vec<FillPixel>,
}

impl Continuity<'_, '_> {
    fn new<'a, 'b>(cx: &'a FillContext<'b>, k: u32, fill: &Fill, rule: (f64, f64)) -> Continuity<'a, 'b> {
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
        Continuity { cx, rule, d, filled, removed: Vec::new() }
    }

    /// Move the pixels no longer filled out of `fill` (into `removed`).
    fn prune(&mut self, fill: &mut Fill) {
        let filled = &self.filled;
        self.removed.extend(fill.pixels.iter().filter(|f| !filled[f.pixel]));
        fill.pixels.retain(|f| filled[f.pixel]);
    }

    fn at(&self, i: Option<usize>) -> Option<f64> {
        i.map(|i| self.d[i] as f64).filter(|v| *v > 0.0)
    }

    /// Pixel `q` and its 4-neighbour `r` (in direction `j`) are one surface.
    fn link(&self, q: usize, j: usize, r: usize) -> bool {
        let w = self.cx.nb.width();
        let (x, y) = (q % w, q / w);
        let Some(b) = self.at(Some(r)) else { return false };
        continuous_with(
            self.d[q] as f64,
            b,
            || self.at(self.cx.nb.get_at(x, y, opposite(j))),
            || self.at(self.cx.nb.get2_at(x, y, j)),
            self.rule.0,
            self.rule.1,
        )
    }

    /// Remove the filled pixels across a break from a neighbour (the filled side of a break, or the
    /// nearer when both are filled) until none is left; the pixels of their own plane removed.
    fn drop_breaks(&mut self, fill: &mut Fill, own_plane: &mut HashMap<usize, FillPixel>) -> Vec<FillPixel> {
        let w = self.cx.nb.width();
        let mut dropped = Vec::new();
        // Each pass only removes pixels; one that removes none ends it. A removal can take away the
        // plane another pair was continued by, hence the passes (few: 1–3 on realistic scenes).
        for _ in 0..64 {
            let this = &*self;
            let mut drop: Vec<usize> = fill
                .pixels
                .par_iter()
                .flat_map_iter(|f| {
                    let q = f.pixel;
                    let (x, y) = (q % w, q / w);
                    // 4-neighbours, as validate checks: a diagonal step is judged by the steps around it.
                    (0..4).filter_map(move |j| {
                        let r = this.cx.nb.get_at(x, y, j)?;
                        let b = this.at(Some(r))?;
                        if this.link(q, j, r) {
                            return None;
                        }
                        Some(if b < this.d[q] as f64 && this.filled[r] { r } else { q })
                    })
                })
                .collect();
            if drop.is_empty() {
                break;
            }
            drop.sort_unstable();
            drop.dedup();
            for &p in &drop {
                self.d[p] = f32::NAN;
                self.filled[p] = false;
                dropped.extend(own_plane.remove(&p));
            }
            self.prune(fill);
        }
        dropped
    }

    /// A fill left with no continuous path to the layer's own pixels continues nothing seen: a
    /// remnant of a rival's plane whose surroundings went. It goes too.
    fn drop_unanchored(
        &mut self,
        fill: &mut Fill,
        own_plane: &mut HashMap<usize, FillPixel>,
        dropped: &mut Vec<FillPixel>,
    ) {
        let (w, nb) = (self.cx.nb.width(), self.cx.nb);
        let mut reached = vec![false; nb.len()];
        let mut queue: VecDeque<usize> = VecDeque::new();
        for f in &fill.pixels {
            let (x, y) = (f.pixel % w, f.pixel / w);
            let anchored = (0..4)
                .any(|j| nb.get_at(x, y, j).is_some_and(|r| !self.filled[r] && self.link(f.pixel, j, r)));
            if anchored {
                reached[f.pixel] = true;
                queue.push_back(f.pixel);
            }
        }
        while let Some(q) = queue.pop_front() {
            let (x, y) = (q % w, q / w);
            for j in 0..4 {
                if let Some(r) = nb.get_at(x, y, j) {
                    if self.filled[r] && !reached[r] && self.link(q, j, r) {
                        reached[r] = true;
                        queue.push_back(r);
                    }
                }
            }
        }
        for f in fill.pixels.iter().filter(|f| !reached[f.pixel]) {
            self.d[f.pixel] = f32::NAN;
            self.filled[f.pixel] = false;
            dropped.extend(own_plane.remove(&f.pixel));
        }
        self.prune(fill);
    }

    /// Close the cracks left where fronts from two seeds met with a step: a dropped pixel with two
    /// or more neighbours in the layer takes a depth within the step of every one (the geometric
    /// middle of what they allow), when there is one. Each pixel closed puts its open neighbours
    /// back in the queue, since it bounds them too.
    fn close_cracks(&mut self, fill: &mut Fill) {
        let (w, nb, jump) = (self.cx.nb.width(), self.cx.nb, 1.0 + self.cx.jump);
        // Taken back (`take_back` sets the depth only) or infinitely far: not open.
        let removed = std::mem::take(&mut self.removed);
        let mut open: HashMap<usize, FillPixel> = HashMap::with_capacity(removed.len());
        let mut queue: VecDeque<usize> = VecDeque::with_capacity(removed.len());
        for f in removed.into_iter().filter(|f| self.d[f.pixel].is_nan() && f.depth.is_finite()) {
            open.insert(f.pixel, f);
            queue.push_back(f.pixel);
        }
        while let Some(q) = queue.pop_front() {
            let Some(f) = open.get(&q).copied() else { continue };
            let (x, y) = (q % w, q / w);
            let (mut lo, mut hi, mut count) = (0f64, f64::INFINITY, 0);
            for j in 0..4 {
                if let Some(d) = self.at(nb.get_at(x, y, j)) {
                    (lo, hi, count) = (lo.max(d / jump), hi.min(d * jump), count + 1);
                }
            }
            if count < 2 || lo > hi || !hi.is_finite() {
                continue;
            }
            let depth = (lo * hi).sqrt() as f32;
            self.d[q] = depth;
            self.filled[q] = true;
            fill.pixels.push(FillPixel { depth, ..f });
            open.remove(&q);
            queue.extend((0..4).filter_map(|j| nb.get_at(x, y, j)).filter(|r| open.contains_key(r)));
        }
    }

    /// Take back the pixels of their own plane continuous with all their neighbours so far; one
    /// taken back gives its neighbours a value to be judged against, hence the passes.
    fn take_back(&mut self, fill: &mut Fill, mut dropped: Vec<FillPixel>) {
        let (w, nb) = (self.cx.nb.width(), self.cx.nb);
        loop {
            let before = dropped.len();
            dropped.retain(|f| {
                let q = f.pixel;
                let (x, y) = (q % w, q / w);
                self.d[q] = f.depth;
                let mut any = false;
                let ok = (0..4).all(|j| match nb.get_at(x, y, j) {
                    Some(r) if self.at(Some(r)).is_some() => {
                        any = true;
                        self.link(q, j, r)
                    }
                    _ => true,
                });
                if any && ok {
                    fill.pixels.push(*f);
                    return false;
                }
                self.d[q] = f32::NAN;
                true
            });
            if dropped.len() == before {
                break;
            }
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
        let (pa, pb) = (cx.dirs.at(a) * cx.depth[a], cx.dirs.at(b) * cx.depth[b]);
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
