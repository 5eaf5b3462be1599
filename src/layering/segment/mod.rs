//! From links to layers: pixels joined by smooth links form segments; jumps between segments say
//! which occludes which; the longest chain of occlusions gives each segment its level (0 =
//! background), which is the minimal layering: a chain of k occluders needs k + 1 layers.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::edges::{EdgeOptions, Link, Links};
use crate::continuity::LAYER_JUMP;
use crate::mapping::Neighbours;
use split::{cut_fronts, split_self_occluding, SPLIT_ROUNDS};

mod split;

/// Union-find with path halving, the smaller index the root (no size table: 4 bytes a pixel, and
/// the sets and their ids come out the same).
pub(super) struct Dsu {
    parent: Vec<u32>,
}

impl Dsu {
    pub(super) fn new(n: usize) -> Self {
        Dsu { parent: (0..n as u32).collect() }
    }
    pub(super) fn find(&mut self, x: u32) -> u32 {
        find_in(&mut self.parent, 0, x)
    }
    pub(super) fn union(&mut self, a: u32, b: u32) {
        union_in(&mut self.parent, 0, a, b);
    }

    /// Every element pointed straight at its root, in one forward pass: a parent never comes after
    /// its child (roots are the smallest index; `split` links to a segment's first pixel or a
    /// root). The sets and roots stay; a walk over all pixels then needs no search.
    fn flatten(&mut self) {
        for p in 0..self.parent.len() {
            let q = self.parent[p] as usize;
            debug_assert!(q <= p, "parent {q} after {p}");
            self.parent[p] = self.parent[q];
        }
    }

    /// The sets of `nb`'s pixels joined by their smooth links (bit i of `masks[p].0`: `p` and its
    /// neighbour along `HALF[i]`). Bands of rows are joined in parallel, each in its own slice of
    /// the table (a set's root, its smallest pixel, lies in its band until bands meet); the links
    /// between bands then serially. The sets and roots are those of joining every link in order.
    fn of_smooth_links(nb: &Neighbours, masks: &[(u8, u8, u8)]) -> Dsu {
        let (n, w) = (nb.len(), nb.width());
        let mut parent: Vec<u32> = (0..n as u32).collect();
        let band = (nb.height() / (4 * rayon::current_num_threads())).max(1) * w;
        let across: Vec<(u32, u32)> = parent
            .par_chunks_mut(band)
            .enumerate()
            .flat_map_iter(|(b, table)| {
                let start = b * band;
                let inside = start..start + table.len();
                let mut across = Vec::new();
                for p in inside.clone() {
                    let smooth = masks[p].0;
                    if smooth == 0 {
                        continue;
                    }
                    let (x, y) = (p % w, p / w);
                    for (i, &k) in HALF.iter().enumerate() {
                        if smooth >> i & 1 == 1 {
                            let q = nb.get_at(x, y, k).expect("link implies a neighbour");
                            if inside.contains(&q) {
                                union_in(table, start as u32, p as u32, q as u32);
                            } else {
                                across.push((p as u32, q as u32));
                            }
                        }
                    }
                }
                across
            })
            .collect();
        let mut dsu = Dsu { parent };
        for (p, q) in across {
            dsu.union(p, q);
        }
        dsu
    }
}

/// [`Dsu::find`] in a table of the pixels from `offset` on.
fn find_in(parent: &mut [u32], offset: u32, mut x: u32) -> u32 {
    let at = |x: u32| (x - offset) as usize;
    while parent[at(x)] != x {
        let g = parent[at(parent[at(x)])];
        parent[at(x)] = g;
        x = g;
    }
    x
}

/// [`Dsu::union`] in a table of the pixels from `offset` on.
fn union_in(parent: &mut [u32], offset: u32, a: u32, b: u32) {
    let (a, b) = (find_in(parent, offset, a), find_in(parent, offset, b));
    if a != b {
        parent[(a.max(b) - offset) as usize] = a.min(b);
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
    let masks = classify_links(nb, depth, links, normals);
    let mut dsu = Dsu::of_smooth_links(nb, &masks);
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
    cut_steps(nb, depth, links, &masks, &id, &mut dsu);
    let (id, size, depth_sum) = sized_ids(&mut dsu, depth, &finite);
    let count = size.len();
    let (mut jumps, folds) = border_relations(nb, depth, &masks, &id);
    // Each segment's border with others, jumps and folds, before bridges add links across rims.
    let mut border = vec![0u32; count];
    for (&(a, b), &c) in jumps.iter().chain(&folds) {
        border[a as usize] += c;
        border[b as usize] += c;
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
    let level = levels(count, &mean, &size, &occludes, &folds, &border);
    Segments { id, level, size }
}

/// Each finite pixel's links along [`HALF`] as bit masks: smooth, jump, fold (bit i = `HALF[i]`).
/// Classified in parallel; the union-find that follows is a cheap serial pass.
fn classify_links(nb: &Neighbours, depth: &[f32], links: &Links, normals: &[Vec3]) -> Vec<(u8, u8, u8)> {
    let finite = |i: usize| depth[i] > 0.0 && depth[i].is_finite();
    (0..nb.len())
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
        .collect()
}

/// What still holds a step `validate` would report (a jump the surface goes round nearby, left
/// whole by [`split_self_occluding`], that is also a step of over 50 %) is cut between its front
/// pixels — nearer across such a step than a pixel of the same segment — and the rest.
fn cut_steps(
    nb: &Neighbours,
    depth: &[f32],
    links: &Links,
    masks: &[(u8, u8, u8)],
    id: &[u32],
    dsu: &mut Dsu,
) {
    let front: Vec<bool> = (0..nb.len())
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
        let mut recut = vec![false; segment_count(id)];
        for (p, &f) in front.iter().enumerate() {
            if f {
                recut[id[p] as usize] = true;
            }
        }
        *dsu = cut_fronts(nb, masks, id, dsu, &front, &|p| recut[id[p] as usize]);
    }
}

/// Compact segment ids of the finite pixels (in pixel order), and each segment's size and depth sum.
fn sized_ids(dsu: &mut Dsu, depth: &[f32], finite: &dyn Fn(usize) -> bool) -> (Vec<u32>, Vec<u32>, Vec<f64>) {
    let n = depth.len();
    let mut id = vec![NO_SEGMENT; n];
    // Indexed by root pixel: a plain table beats hashing 8M pixels.
    let mut root_to_id = vec![NO_SEGMENT; n];
    let mut size: Vec<u32> = Vec::new();
    let mut depth_sum: Vec<f64> = Vec::new();
    dsu.flatten();
    for p in 0..n {
        if !finite(p) {
            continue;
        }
        let r = dsu.parent[p] as usize;
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
    (id, size, depth_sum)
}

/// Links between segments along their borders: jumps (near, far) and folds (either way).
type Relations = HashMap<(u32, u32), u32>;

/// The jump and fold links along the borders between segments, counted per pair.
fn border_relations(
    nb: &Neighbours,
    depth: &[f32],
    masks: &[(u8, u8, u8)],
    id: &[u32],
) -> (Relations, Relations) {
    let mut jumps: Relations = HashMap::new();
    let mut folds: Relations = HashMap::new();
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
    (jumps, folds)
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
            let (x, y) = (p % nb.width(), p / nb.width());
            HALF.iter().filter_map(move |&k| {
                let mut r = nb.get_at(x, y, k)?;
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
    dsu.flatten();
    (0..n)
        .map(|p| {
            if !finite(p) {
                return NO_SEGMENT;
            }
            let r = dsu.parent[p] as usize;
            if root_to_id[r] == NO_SEGMENT {
                root_to_id[r] = next;
                next += 1;
            }
            root_to_id[r]
        })
        .collect()
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
    border: &[u32],
) -> Vec<u32> {
    let behind = acyclic_behind(count, mean, size, occludes);
    let mut level = longest_chains(&behind);
    attach_free(&mut level, &behind, size, folds, border);
    level
}

/// What each segment occludes, specks left out and cycles broken inside strongly connected
/// components (far to near by mean depth, ties by id).
fn acyclic_behind(count: usize, mean: &[f64], size: &[u32], occludes: &[(u32, u32, u32)]) -> Vec<Vec<u32>> {
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
    behind
}

/// The longest occlusion chain from each node of an acyclic graph, by memoised depth-first search
/// (iterative).
fn longest_chains(behind: &[Vec<u32>]) -> Vec<u32> {
    let count = behind.len();
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
    level
}

/// Segments that occlude nothing take the level of the larger segment they share the longest
/// fold with, unless that puts them level with (or above) one in front of them. A segment ringed
/// by folds to occluders of one level (at least [`RINGED`] of its border) takes that level
/// whatever their size: a lamp's face inside its rim (kept at the face's depth by the settle, cut
/// from the face by a fold) goes up with the rim.
fn attach_free(
    level: &mut [u32],
    behind: &[Vec<u32>],
    size: &[u32],
    folds: &HashMap<(u32, u32), u32>,
    border: &[u32],
) {
    let count = behind.len();
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
    let mut partners: Vec<Vec<(u32, u32)>> = vec![Vec::new(); count];
    for (&(a, b), &c) in folds {
        let (small, large) = if size[b as usize] > size[a as usize] { (a, b) } else { (b, a) };
        attached[small as usize].push((c, large));
        partners[a as usize].push((c, b));
        partners[b as usize].push((c, a));
    }
    for list in attached.iter_mut().chain(&mut partners) {
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
            let ringed = ringing_level(&partners[s], level, &occluder, border[s]).filter(|&l| below_front(l));
            let attach = || attached[s].iter().find(|&&(_, o)| below_front(level[o as usize]));
            if let Some(l) = ringed.or_else(|| attach().map(|&(_, o)| level[o as usize])) {
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
}

/// Share of a free segment's border (jumps and folds) that folds to segments of one level must
/// reach for [`attach_free`] to count it as ringed by them.
const RINGED: f64 = 0.75;

/// The level whose occluders hold at least [`RINGED`] of `border` in fold links (`partners`: fold
/// count and segment, in a fixed order), if any. Free partners do not count: their levels are
/// not settled yet (noise leaves fields of small free pieces, each ringed by the others).
fn ringing_level(partners: &[(u32, u32)], level: &[u32], occluder: &[bool], border: u32) -> Option<u32> {
    let mut by_level: Vec<(u32, u32)> = Vec::new();
    for &(c, o) in partners.iter().filter(|&&(_, o)| occluder[o as usize]) {
        let l = level[o as usize];
        match by_level.iter_mut().find(|(m, _)| *m == l) {
            Some((_, sum)) => *sum += c,
            None => by_level.push((l, c)),
        }
    }
    by_level.into_iter().find(|&(_, sum)| sum > 0 && sum as f64 >= RINGED * border as f64).map(|(l, _)| l)
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
