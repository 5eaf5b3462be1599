//! From links to layers: pixels joined by smooth links form segments; jumps between segments say
//! which occludes which; the longest chain of occlusions gives each segment its level (0 =
//! background), which is the minimal layering: a chain of k occluders needs k + 1 layers.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::edges::{EdgeOptions, Link, Links};
use crate::continuity::LAYER_JUMP;
use crate::mapping::{opposite, Neighbours};

/// Union-find with path halving and union by size.
pub(super) struct Dsu {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl Dsu {
    pub(super) fn new(n: usize) -> Self {
        Dsu { parent: (0..n as u32).collect(), size: vec![1; n] }
    }
    pub(super) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let g = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = g;
            x = g;
        }
        x
    }
    pub(super) fn union(&mut self, a: u32, b: u32) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a as usize] < self.size[b as usize] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b as usize] = a;
        self.size[a as usize] += self.size[b as usize];
    }
}

/// Each undirected pair once: right, down, down-right, down-left (indices into `OFFSETS`).
const HALF: [usize; 4] = [0, 2, 4, 5];

/// Pixels not in any segment (unknown depth, or infinitely far content).
pub const NO_SEGMENT: u32 = u32::MAX;

/// Segmentation of the canvas and the level of every segment.
#[derive(Clone, Debug)]
pub struct Segments {
    /// Segment id per pixel, or [`NO_SEGMENT`].
    pub id: Vec<u32>,
    /// Level per segment (0 = background).
    pub level: Vec<u32>,
    /// Pixels per segment.
    pub size: Vec<u32>,
}

/// Tuning of the segmentation.
#[derive(Clone, Copy, Debug)]
pub struct SegmentOptions {
    /// Tests that split neighbours into different surfaces (default [`EdgeOptions::default`]).
    pub edges: EdgeOptions,
    /// An occlusion relation needs at least this many jump links along the border: shorter
    /// ones are spurs (noise, a single mixed pixel) and are dropped.
    pub min_border: u32,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        SegmentOptions { edges: EdgeOptions::default(), min_border: 3 }
    }
}

/// Segment the finite-depth pixels and order the segments into levels.
pub fn segment(
    nb: &Neighbours,
    depth: &[f32],
    links: &Links,
    normals: &[Vec3],
    o: &SegmentOptions,
) -> Segments {
    let n = nb.len();
    let finite = |i: usize| depth[i] > 0.0 && depth[i].is_finite();
    // Links are classified in parallel (bit i of each mask = HALF[i]); the union-find that follows
    // is a cheap serial pass.
    let masks: Vec<(u8, u8, u8)> = (0..n)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % nb.width(), p / nb.width());
            let (mut smooth, mut jump, mut fold) = (0u8, 0u8, 0u8);
            if finite(p) {
                for (i, &k) in HALF.iter().enumerate() {
                    match links.link(nb, normals, x, y, k) {
                        Some(Link::Smooth) => smooth |= 1 << i,
                        Some(Link::Jump) => jump |= 1 << i,
                        Some(Link::Fold) => fold |= 1 << i,
                        None => {}
                    }
                }
            }
            (smooth, jump, fold)
        })
        .collect();
    let mut dsu = Dsu::new(n);
    for (p, &(smooth, _, _)) in masks.iter().enumerate() {
        if smooth == 0 {
            continue;
        }
        for (i, &k) in HALF.iter().enumerate() {
            if smooth >> i & 1 == 1 {
                let q = nb.get(p, k).expect("link implies a neighbour");
                dsu.union(p as u32, q as u32);
            }
        }
    }
    let mut id = compact(&mut dsu, n, &finite);
    // A segment that occludes itself (a box joined to the floor by a crease softened below the fold
    // angle, a pole standing on the ground with no fold at its foot, a surface curving behind itself)
    // would put both sides of a jump in one layer: it is split where its surface turns most between
    // the two sides (spec §7 step 5). Nested cases (a cup on a box on the floor) take a round each.
    for _ in 0..SPLIT_ROUNDS {
        let Some(mut next) = split_self_occluding(nb, depth, links, normals, &masks, &id, o.min_border)
        else {
            break;
        };
        let next_id = compact(&mut next, n, &finite);
        // A round that cut nothing (its seeds were all slivers) would only repeat itself.
        let progress = segment_count(&next_id) > segment_count(&id);
        (dsu, id) = (next, next_id);
        if !progress {
            break;
        }
    }
    // What still holds a step `validate` would report (a jump the surface goes round nearby, left
    // whole above, that is also a step of over 50 %) is cut between its front pixels — nearer
    // across such a step than a pixel of the same segment — and the rest.
    let front: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|p| {
            id[p] != NO_SEGMENT
                && links.any_jump(p)
                && (0..8).any(|k| {
                    links.is_jump(p, k)
                        && nb.get(p, k).is_some_and(|q| {
                            id[q] == id[p] && depth[q] - depth[p] > LAYER_JUMP as f32 * depth[p]
                        })
                })
        })
        .collect();
    if front.iter().any(|&f| f) {
        // Only the segments with front pixels are joined again; the others keep their roots.
        let mut recut = vec![false; segment_count(&id)];
        for (p, &f) in front.iter().enumerate() {
            if f {
                recut[id[p] as usize] = true;
            }
        }
        dsu = cut_fronts(nb, &masks, &id, &mut dsu, &front, &recut);
    }
    // Compact ids.
    let mut id = vec![NO_SEGMENT; n];
    // Indexed by root pixel: a plain table beats hashing 8M pixels.
    let mut root_to_id = vec![NO_SEGMENT; n];
    let mut size: Vec<u32> = Vec::new();
    let mut depth_sum: Vec<f64> = Vec::new();
    for p in 0..n {
        if !finite(p) {
            continue;
        }
        let r = dsu.find(p as u32) as usize;
        if root_to_id[r] == NO_SEGMENT {
            root_to_id[r] = size.len() as u32;
            size.push(0);
            depth_sum.push(0.0);
        }
        let s = root_to_id[r];
        id[p] = s;
        size[s as usize] += 1;
        depth_sum[s as usize] += depth[p] as f64;
    }
    let count = size.len();
    // Relations between segments along their borders.
    let mut jumps: HashMap<(u32, u32), u32> = HashMap::new();
    let mut folds: HashMap<(u32, u32), u32> = HashMap::new();
    for (p, &(_, jump, fold)) in masks.iter().enumerate() {
        if jump | fold == 0 || id[p] == NO_SEGMENT {
            continue;
        }
        for (i, &k) in HALF.iter().enumerate() {
            let (is_jump, is_fold) = (jump >> i & 1 == 1, fold >> i & 1 == 1);
            if !is_jump && !is_fold {
                continue;
            }
            let q = nb.get(p, k).expect("link implies a neighbour");
            let (a, b) = (id[p], id[q]);
            if a == b || b == NO_SEGMENT {
                continue;
            }
            if is_jump {
                let (near, far) = if depth[p] < depth[q] { (a, b) } else { (b, a) };
                *jumps.entry((near, far)).or_default() += 1;
            } else {
                *folds.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
    }
    bridge_jumps(nb, depth, &id, &size, o.edges.jump, &mut jumps);
    let mean: Vec<f64> = depth_sum.iter().zip(&size).map(|(s, &c)| s / c as f64).collect();
    // Keep a relation only if it is long enough and dominant over its reverse.
    let mut occludes: Vec<(u32, u32, u32)> = jumps
        .iter()
        .filter(|(&(a, b), &c)| c >= o.min_border && c > jumps.get(&(b, a)).copied().unwrap_or(0))
        .map(|(&(a, b), &c)| (a, b, c))
        .collect();
    occludes.sort_unstable();
    let level = levels(count, &mean, &size, &occludes, &folds);
    Segments { id, level, size }
}

/// Occlusions across a rim of slivers: a soft or resampled edge leaves small segments of
/// in-between depth between an object and what is behind it, each joined to either side by too
/// few jumps to order anything, so the object would lie at the level of its background. A pixel
/// of a large segment whose neighbour is in a small one looks on across small segments (at most
/// [`BRIDGE`] pixels, depths in order) to the next large one: a step between the two of a jump per
/// pixel crossed, on average, counts as a border link.
fn bridge_jumps(
    nb: &Neighbours,
    depth: &[f32],
    id: &[u32],
    size: &[u32],
    jump: f64,
    jumps: &mut HashMap<(u32, u32), u32>,
) {
    let large = |p: usize| id[p] != NO_SEGMENT && size[id[p] as usize] >= SPECK_MAX;
    let step = (1.0 + jump) as f32;
    let found: Vec<(u32, u32)> = (0..id.len())
        .into_par_iter()
        .filter(|&p| large(p))
        .flat_map_iter(|p| {
            HALF.iter().filter_map(move |&k| {
                let mut r = nb.get(p, k)?;
                if large(r) || id[r] == NO_SEGMENT {
                    return None;
                }
                // The rim climbs from one side to the other: in-between depths, in order.
                let rising = depth[r] > depth[p];
                for steps in 2..=BRIDGE {
                    let prev = r;
                    r = nb.get(r, k)?;
                    if id[r] == id[p] || id[r] == NO_SEGMENT || (depth[r] > depth[prev]) != rising {
                        return None;
                    }
                    if large(r) {
                        let (a, b, need) = (depth[p], depth[r], step.powi(steps as i32));
                        return if b > a * need {
                            Some((id[p], id[r]))
                        } else if a > b * need {
                            Some((id[r], id[p]))
                        } else {
                            None
                        };
                    }
                }
                None
            })
        })
        .collect();
    for pair in found {
        *jumps.entry(pair).or_default() += 1;
    }
}

/// Widest rim of slivers [`bridge_jumps`] looks across, pixels.
const BRIDGE: usize = 4;

/// How many segment ids `id` uses (ids are compact: 0 to the largest).
fn segment_count(id: &[u32]) -> usize {
    id.iter().filter(|&&s| s != NO_SEGMENT).max().map_or(0, |&s| s as usize + 1)
}

/// Segment id per finite pixel from a union-find over the continuous links (ids in pixel order).
fn compact(dsu: &mut Dsu, n: usize, finite: &dyn Fn(usize) -> bool) -> Vec<u32> {
    let mut root_to_id = vec![NO_SEGMENT; n];
    let mut next = 0u32;
    (0..n)
        .map(|p| {
            if !finite(p) {
                return NO_SEGMENT;
            }
            let r = dsu.find(p as u32) as usize;
            if root_to_id[r] == NO_SEGMENT {
                root_to_id[r] = next;
                next += 1;
            }
            root_to_id[r]
        })
        .collect()
}

/// How far a seed of [`split_self_occluding`] runs on over a ramp of in-between depths (pixels).
const SEED_WALK: usize = 8;
/// The relative depth step per pixel that is still a ramp.
const RAMP_STEP: f32 = 0.02;

/// Whether pixels `p` and `q` of one segment are joined by a path of at most [`GO_ROUND`] depth-
/// continuous links inside it (breadth-first search; the pixels found are their own queue, at most
/// the 9 × 9 around `p`).
fn joined_nearby(nb: &Neighbours, links: &Links, id: &[u32], p: usize, q: usize) -> bool {
    const CAP: usize = (2 * GO_ROUND + 1) * (2 * GO_ROUND + 1);
    let mut seen = [p; CAP];
    let (mut start, mut end) = (0, 1);
    for _ in 0..GO_ROUND {
        let mut len = end;
        for i in start..end {
            let r = seen[i];
            for k in 0..8 {
                let Some(t) = nb.get(r, k).filter(|&t| id[t] == id[p] && links.continuous(r, k)) else {
                    continue;
                };
                if t == q {
                    return true;
                }
                if len < CAP && !seen[..len].contains(&t) {
                    seen[len] = t;
                    len += 1;
                }
            }
        }
        (start, end) = (end, len);
    }
    false
}

/// Steps within which [`joined_nearby`] looks for a way round a jump.
const GO_ROUND: usize = 4;

/// Rounds of [`split_self_occluding`]: one per nesting of occluders merged into one segment.
const SPLIT_ROUNDS: usize = 4;

/// Split every segment that occludes itself (at least `min_border` jumps between its own pixels
/// that it does not go round nearby, [`joined_nearby`]) into its near and far sides: a seeded
/// watershed over its smooth links, weighted by the angle between the normals. The near side's
/// seeds are the pixels nearer across its jumps, the far side's the pixels behind them; links are
/// joined from the flattest up (Kruskal) unless they would join the two sides, so the cut runs
/// where the surface turns most between them — a softened crease, a pole's foot. A segment whose
/// cut would run through flat surface is cut along its front pixels instead. `None` when no
/// segment occludes itself; else the new union-find.
fn split_self_occluding(
    nb: &Neighbours,
    depth: &[f32],
    links: &Links,
    normals: &[Vec3],
    masks: &[(u8, u8, u8)],
    id: &[u32],
    min_border: u32,
) -> Option<Dsu> {
    let count = segment_count(id);
    let Seeds { inner_jumps, mut label, front } = seed_sides(nb, depth, links, id, count, min_border);
    let split: Vec<bool> = inner_jumps.iter().map(|&c| c >= min_border).collect();
    if !split.iter().any(|&b| b) {
        return None;
    }
    // A pixel on both sides (a one-pixel sliver between two jumps) seeds neither; segments left
    // whole have no sides (only segment pixels carry labels).
    for (l, &s) in label.iter_mut().zip(id) {
        if *l == NEAR | FAR || (*l != 0 && !split[s as usize]) {
            *l = 0;
        }
    }
    let mut dsu = whole_segments(id, &split, count);
    let seeded: Vec<bool> = label.iter().map(|&l| l != 0).collect();
    let mut side: Vec<u8> = label;
    let (members, angles) = link_angles(nb, normals, masks, id, &split);
    join_flattest_first(nb, &mut dsu, &mut side, &members, &angles);
    let through_flat = cuts_through_flat(nb, id, count, &mut dsu, &seeded, &members, &angles);
    if !through_flat.iter().any(|&f| f) {
        return Some(dsu);
    }
    Some(cut_fronts(nb, masks, id, &mut dsu, &front, &through_flat))
}

/// Side labels of [`split_self_occluding`]: seeds nearer across a jump, and seeds behind one.
const NEAR: u8 = 1;
const FAR: u8 = 2;
/// A link [`link_angles`] leaves out: no link, or one across segments.
const SKIP: u8 = u8::MAX;
/// The angle of a link to a pixel without a normal: joined after every real angle.
const NO_NORMAL: u8 = 181;

/// What [`seed_sides`] finds in each segment.
struct Seeds {
    /// Jumps between a segment's own pixels not gone round nearby, counted up to what decides.
    inner_jumps: Vec<u32>,
    /// Per pixel: `NEAR`, `FAR`, both or neither.
    label: Vec<u8>,
    /// Pixels nearer across a jump inside their segment.
    front: Vec<bool>,
}

/// The jumps between pixels of one segment, and the seeds of its near and far sides.
fn seed_sides(
    nb: &Neighbours,
    depth: &[f32],
    links: &Links,
    id: &[u32],
    count: usize,
    min_border: u32,
) -> Seeds {
    let n = id.len();
    // Jumps between two pixels of one segment (found in parallel; few).
    let jumps: Vec<(usize, usize, usize)> = (0..n)
        .into_par_iter()
        .filter(|&p| id[p] != NO_SEGMENT && links.any_jump(p))
        .flat_map_iter(|p| {
            (0..8).filter(move |&k| links.is_jump(p, k)).filter_map(move |k| {
                let q = nb.get(p, k).filter(|&q| id[q] == id[p] && depth[q] > depth[p])?;
                Some((p, k, q))
            })
        })
        .collect();
    let mut inner_jumps = vec![0u32; count];
    let mut label = vec![0u8; n];
    let mut front = vec![false; n];
    for &(p, k, q) in &jumps {
        let s = id[p];
        // A jump the surface goes round within a few pixels (a mixed pixel at a grazing horizon, a
        // notch) is not the surface passing in front of itself; it still seeds when its segment
        // is split for other jumps. Counted only up to what decides.
        if inner_jumps[s as usize] < min_border && !joined_nearby(nb, links, id, p, q) {
            inner_jumps[s as usize] += 1;
        }
        label[p] |= NEAR;
        label[q] |= FAR;
        front[p] = true;
        // A jump spread over a few pixels (resized depth) leaves in-between pixels on either
        // side, joined to their side only across a steep, sharply turning link: the seeds run
        // on past them to the first pixel where the surface flattens.
        for (from, dir, side, nearer) in [(p, opposite(k), NEAR, true), (q, k, FAR, false)] {
            let mut r = from;
            for _ in 0..SEED_WALK {
                let Some(t) = nb.get(r, dir).filter(|&t| id[t] == s) else { break };
                label[t] |= side;
                let (a, b) = (depth[r], depth[t]);
                let steep = if nearer { b < a * (1.0 - RAMP_STEP) } else { b > a * (1.0 + RAMP_STEP) };
                if !steep {
                    break;
                }
                r = t;
            }
        }
    }
    Seeds { inner_jumps, label, front }
}

/// A union-find in which each segment not `split` is one set as it is (one root each) and every
/// other pixel is alone.
fn whole_segments(id: &[u32], split: &[bool], count: usize) -> Dsu {
    let mut dsu = Dsu::new(id.len());
    let mut root = vec![NO_SEGMENT; count];
    for (p, &s) in id.iter().enumerate() {
        if s == NO_SEGMENT || split[s as usize] {
            continue;
        }
        if root[s as usize] == NO_SEGMENT {
            root[s as usize] = p as u32;
        } else {
            dsu.parent[p] = root[s as usize];
            dsu.size[root[s as usize] as usize] += 1;
        }
    }
    dsu
}

/// The pixels of `split` segments and, per half-direction link, the angle between the normals
/// in whole degrees (0 when flat, [`SKIP`] where there is nothing to join, [`NO_NORMAL`]).
fn link_angles(
    nb: &Neighbours,
    normals: &[Vec3],
    masks: &[(u8, u8, u8)],
    id: &[u32],
    split: &[bool],
) -> (Vec<u32>, Vec<[u8; 4]>) {
    let flat_cos = 0.5f32.to_radians().cos();
    let members: Vec<u32> = (0..id.len() as u32)
        .into_par_iter()
        .filter(|&p| id[p as usize] != NO_SEGMENT && split[id[p as usize] as usize])
        .collect();
    let angles: Vec<[u8; 4]> = members
        .par_iter()
        .map(|&p| {
            let (p, smooth) = (p as usize, masks[p as usize].0);
            std::array::from_fn(|i| {
                if smooth >> i & 1 == 0 {
                    return SKIP;
                }
                let q = nb.get(p, HALF[i]).expect("link implies a neighbour");
                // Sides cut by an earlier round stay cut.
                if id[p] != id[q] {
                    return SKIP;
                }
                // A pixel without a normal (too few continuous neighbours: a sliver, a softened
                // crease) joins a side last.
                let (a, b) = (normals[p], normals[q]);
                if a == Vec3::ZERO || b == Vec3::ZERO {
                    return NO_NORMAL;
                }
                let cos = a.dot(b);
                if cos >= flat_cos {
                    0
                } else {
                    cos.clamp(-1.0, 1.0).acos().to_degrees().round() as u8
                }
            })
        })
        .collect();
    (members, angles)
}

/// Join `p` and `q` unless they are on two different sides; the joined set is on either's side.
fn join_sides(dsu: &mut Dsu, side: &mut [u8], p: usize, q: usize) {
    let (a, b) = (dsu.find(p as u32), dsu.find(q as u32));
    let (la, lb) = (side[a as usize], side[b as usize]);
    if a == b || (la != 0 && lb != 0 && la != lb) {
        return;
    }
    dsu.union(a, b);
    let r = dsu.find(a) as usize;
    side[r] = la | lb;
}

/// The seeded watershed: the flat links of split segments first (most of them), the rest by
/// angle, whole degrees (a counting sort).
fn join_flattest_first(nb: &Neighbours, dsu: &mut Dsu, side: &mut [u8], members: &[u32], angles: &[[u8; 4]]) {
    // Exact sizes: on a canvas that is one split, curved segment this is most of its links.
    let mut sizes = [0usize; NO_NORMAL as usize + 1];
    for a in angles.iter().flatten().filter(|&&a| a != SKIP && a != 0) {
        sizes[*a as usize] += 1;
    }
    let mut by_angle: Vec<Vec<(u32, u8)>> = sizes.iter().map(|&c| Vec::with_capacity(c)).collect();
    for (&p, a) in members.iter().zip(angles) {
        let p = p as usize;
        for (i, &angle) in a.iter().enumerate() {
            match angle {
                SKIP => {}
                0 => {
                    let q = nb.get(p, HALF[i]).expect("link implies a neighbour");
                    join_sides(dsu, side, p, q);
                }
                _ => by_angle[angle as usize].push((p as u32, i as u8)),
            }
        }
    }
    for list in &by_angle {
        for &(p, i) in list {
            let q = nb.get(p as usize, HALF[i as usize]).expect("link implies a neighbour");
            join_sides(dsu, side, p as usize, q);
        }
    }
}

/// Per segment, whether its cut runs mostly through flat surface away from every seed: not a
/// crease but the order ties were joined in (near and far seeds on one flat surface: the blurred
/// limb of an object the centre almost touches, merged with the ground). Such a segment keeps the
/// old cut: its front pixels.
fn cuts_through_flat(
    nb: &Neighbours,
    id: &[u32],
    count: usize,
    dsu: &mut Dsu,
    seeded: &[bool],
    members: &[u32],
    angles: &[[u8; 4]],
) -> Vec<bool> {
    let mut side_of = vec![NO_SEGMENT; id.len()];
    for &p in members {
        side_of[p as usize] = dsu.find(p);
    }
    let (mut cut, mut flat_cut) = (vec![0u32; count], vec![0u32; count]);
    for (&p, a) in members.iter().zip(angles) {
        let p = p as usize;
        for (i, &angle) in a.iter().enumerate() {
            if angle == SKIP {
                continue;
            }
            let q = nb.get(p, HALF[i]).expect("link implies a neighbour");
            if side_of[p] != side_of[q] {
                cut[id[p] as usize] += 1;
                flat_cut[id[p] as usize] += (angle == 0 && !seeded[p] && !seeded[q]) as u32;
            }
        }
    }
    (0..count).map(|s| 4 * flat_cut[s] > cut[s]).collect()
}

/// The partition of `dsu` over segments `id`, except that each segment marked in `recut` is joined
/// again along its smooth links with its `front` pixels apart from the rest.
fn cut_fronts(
    nb: &Neighbours,
    masks: &[(u8, u8, u8)],
    id: &[u32],
    dsu: &mut Dsu,
    front: &[bool],
    recut: &[bool],
) -> Dsu {
    let mut next = Dsu::new(id.len());
    for (p, &s) in id.iter().enumerate() {
        if s != NO_SEGMENT && !recut[s as usize] {
            next.parent[p] = dsu.find(p as u32);
        }
    }
    for (p, &(smooth, _, _)) in masks.iter().enumerate() {
        if smooth == 0 || id[p] == NO_SEGMENT || !recut[id[p] as usize] {
            continue;
        }
        for (i, &k) in HALF.iter().enumerate() {
            if smooth >> i & 1 == 1 {
                let q = nb.get(p, k).expect("link implies a neighbour");
                if id[p] == id[q] && front[p] == front[q] {
                    next.union(p as u32, q as u32);
                }
            }
        }
    }
    next
}

/// A segment behind another that is over `SPECK` times larger, and smaller than `SPECK_MAX` pixels,
/// is a speck: it does not count as occluded by it (the renderers' depth test keeps it behind all
/// the same; it goes to a layer of its own, a part, see `layering::parts`).
const SPECK: u64 = 100;
const SPECK_MAX: u32 = 256;

/// Longest occlusion chain per segment. Real data can produce cycles (A occludes B somewhere, B
/// occludes A elsewhere); only relations inside a cycle (a strongly connected component of the
/// occlusion graph) are ordered by mean depth, far to near, to break it. A relation between
/// components always counts, whatever the means: a distant building occludes the ground behind it
/// although the ground as a whole is nearer on average. A segment that occludes nothing takes the
/// level of the larger segment it shares the longest fold with, unless that would put it level with
/// (or above) a segment in front of it — then the next fold partner's: a box face next to the rest
/// of the box stays with the box, while the floor a box stands on does not follow the box.
fn levels(
    count: usize,
    mean: &[f64],
    size: &[u32],
    occludes: &[(u32, u32, u32)],
    folds: &HashMap<(u32, u32), u32>,
) -> Vec<u32> {
    let mut behind: Vec<Vec<u32>> = vec![Vec::new(); count];
    for &(near, far, _) in occludes {
        // A speck behind a surface (a few mixed or noisy pixels) does not lift the surface a level.
        if (size[far as usize] as u64) * SPECK < size[near as usize] as u64 && size[far as usize] < SPECK_MAX
        {
            continue;
        }
        behind[near as usize].push(far);
    }
    let comp = strong_components(&behind);
    // Farther mean first; ties by id: the order that breaks cycles.
    let farther = |a: u32, b: u32| {
        mean[a as usize] > mean[b as usize] || (mean[a as usize] == mean[b as usize] && a < b)
    };
    for (s, list) in behind.iter_mut().enumerate() {
        list.retain(|&f| comp[f as usize] != comp[s] || farther(f, s as u32));
    }
    // What is left is acyclic: longest path by memoised depth-first search (iterative).
    let mut level = vec![u32::MAX; count];
    let mut stack: Vec<(u32, usize)> = Vec::new();
    for root in 0..count as u32 {
        if level[root as usize] != u32::MAX {
            continue;
        }
        stack.push((root, 0));
        while let Some(&mut (s, ref mut next)) = stack.last_mut() {
            let list = &behind[s as usize];
            if let Some(&f) = list.get(*next) {
                *next += 1;
                if level[f as usize] == u32::MAX {
                    stack.push((f, 0));
                }
                continue;
            }
            level[s as usize] = list.iter().map(|&f| level[f as usize].saturating_add(1)).max().unwrap_or(0);
            stack.pop();
        }
    }
    let occluder: Vec<bool> = behind.iter().map(|l| !l.is_empty()).collect();
    // What occludes each segment: a free segment never joins the level of one in front of it
    // (the layer would hold both sides of their jump).
    let mut in_front: Vec<Vec<u32>> = vec![Vec::new(); count];
    for (near, list) in behind.iter().enumerate() {
        for &far in list {
            in_front[far as usize].push(near as u32);
        }
    }
    let mut attached: Vec<Vec<(u32, u32)>> = vec![Vec::new(); count];
    for (&(a, b), &c) in folds {
        if size[b as usize] > size[a as usize] {
            attached[a as usize].push((c, b));
        } else {
            attached[b as usize].push((c, a));
        }
    }
    for list in &mut attached {
        list.sort_unstable_by(|x, y| y.cmp(x));
    }
    // A few passes let levels flow along chains of fold-attached free segments.
    for _ in 0..4 {
        let mut changed = false;
        for s in 0..count {
            if occluder[s] {
                continue;
            }
            let below_front = |l: u32| in_front[s].iter().all(|&f| level[f as usize] > l);
            if let Some(&(_, other)) = attached[s].iter().find(|&&(_, o)| below_front(level[o as usize])) {
                let l = level[other as usize];
                if level[s] != l {
                    level[s] = l;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    level
}

/// Strongly connected component of every node of a directed graph (Tarjan, iterative: segment
/// graphs of noisy data can be deep).
fn strong_components(next: &[Vec<u32>]) -> Vec<u32> {
    const UNSEEN: u32 = u32::MAX;
    let n = next.len();
    let (mut index, mut low, mut comp) = (vec![UNSEEN; n], vec![0u32; n], vec![UNSEEN; n]);
    let mut on_stack = vec![false; n];
    let (mut stack, mut call): (Vec<u32>, Vec<(u32, usize)>) = (Vec::new(), Vec::new());
    let (mut counter, mut comps) = (0u32, 0u32);
    for root in 0..n as u32 {
        if index[root as usize] != UNSEEN {
            continue;
        }
        call.push((root, 0));
        index[root as usize] = counter;
        low[root as usize] = counter;
        counter += 1;
        stack.push(root);
        on_stack[root as usize] = true;
        while let Some(&mut (v, ref mut k)) = call.last_mut() {
            let vi = v as usize;
            if let Some(&w) = next[vi].get(*k) {
                *k += 1;
                let wi = w as usize;
                if index[wi] == UNSEEN {
                    index[wi] = counter;
                    low[wi] = counter;
                    counter += 1;
                    stack.push(w);
                    on_stack[wi] = true;
                    call.push((w, 0));
                } else if on_stack[wi] {
                    low[vi] = low[vi].min(index[wi]);
                }
                continue;
            }
            call.pop();
            if let Some(&(u, _)) = call.last() {
                low[u as usize] = low[u as usize].min(low[vi]);
            }
            if low[vi] == index[vi] {
                while let Some(w) = stack.pop() {
                    on_stack[w as usize] = false;
                    comp[w as usize] = comps;
                    if w == v {
                        break;
                    }
                }
                comps += 1;
            }
        }
    }
    comp
}

#[cfg(test)]
mod tests;
