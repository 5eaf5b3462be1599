//! Segments that occlude themselves (spec §7 step 5): a box joined to the floor by a crease
//! softened below the fold angle, a pole standing on the ground with no fold at its foot, a surface
//! curving behind itself, split into their near and far sides.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::{segment_count, Dsu, HALF, NO_SEGMENT};
use crate::layering::edges::Links;
use crate::mapping::{opposite, Neighbours};

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
pub(super) const SPLIT_ROUNDS: usize = 4;

/// Split every segment that occludes itself (at least `min_border` jumps between its own pixels
/// that it does not go round nearby, [`joined_nearby`]) into its near and far sides: a seeded
/// watershed over its smooth links, weighted by the angle between the normals. The near side's
/// seeds are the pixels nearer across its jumps, the far side's the pixels behind them; links are
/// joined from the flattest up (Kruskal) unless they would join the two sides, so the cut runs
/// where the surface turns most between them — a softened crease, a pole's foot. A segment whose
/// cut would run through flat surface is cut along its front pixels instead. `None` when no
/// segment occludes itself; else the new union-find.
pub(super) fn split_self_occluding(
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
    let through_flat = sides_cut_through_flat(nb, id.len(), &mut dsu, &seeded, &members, &angles);
    if !through_flat.iter().any(|&f| f) {
        return Some(dsu);
    }
    Some(cut_fronts(nb, masks, id, &mut dsu, &front, &|p| through_flat[p]))
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

/// Per pixel of a split segment, whether the side it was put on is bounded mostly by cuts through
/// flat surface away from every seed: not a crease but the order ties were joined in (near and far
/// seeds on one flat surface: the blurred limb of an object the centre almost touches merged with
/// the ground, ground cut into strips between spurious seeds). Such sides keep the old cut, their
/// front pixels; the other sides of the segment (an object standing on that ground, cut at its
/// foot) keep theirs.
fn sides_cut_through_flat(
    nb: &Neighbours,
    n: usize,
    dsu: &mut Dsu,
    seeded: &[bool],
    members: &[u32],
    angles: &[[u8; 4]],
) -> Vec<bool> {
    let mut side_of = vec![NO_SEGMENT; n];
    for &p in members {
        side_of[p as usize] = dsu.find(p);
    }
    // Per side (its root; few sides): cut links, and those through flat unseeded surface.
    let mut cuts: HashMap<u32, (u32, u32)> = HashMap::new();
    for (&p, a) in members.iter().zip(angles) {
        let p = p as usize;
        for (i, &angle) in a.iter().enumerate() {
            if angle == SKIP {
                continue;
            }
            let q = nb.get(p, HALF[i]).expect("link implies a neighbour");
            if side_of[p] != side_of[q] {
                let flat = (angle == 0 && !seeded[p] && !seeded[q]) as u32;
                for r in [side_of[p], side_of[q]] {
                    let c = cuts.entry(r).or_default();
                    (c.0, c.1) = (c.0 + 1, c.1 + flat);
                }
            }
        }
    }
    side_of.iter().map(|r| cuts.get(r).is_some_and(|&(cut, flat)| 4 * flat > cut)).collect()
}

/// The partition of `dsu` over segments `id`, except that the pixels marked `recut` are joined
/// again along the smooth links between them (inside a segment), `front` pixels apart from the rest.
pub(super) fn cut_fronts(
    nb: &Neighbours,
    masks: &[(u8, u8, u8)],
    id: &[u32],
    dsu: &mut Dsu,
    front: &[bool],
    recut: &dyn Fn(usize) -> bool,
) -> Dsu {
    let mut next = Dsu::new(id.len());
    for (p, &s) in id.iter().enumerate() {
        if s != NO_SEGMENT && !recut(p) {
            next.parent[p] = dsu.find(p as u32);
        }
    }
    for (p, &(smooth, _, _)) in masks.iter().enumerate() {
        if smooth == 0 || id[p] == NO_SEGMENT || !recut(p) {
            continue;
        }
        for (i, &k) in HALF.iter().enumerate() {
            if smooth >> i & 1 == 1 {
                let q = nb.get(p, k).expect("link implies a neighbour");
                if id[p] == id[q] && recut(q) && front[p] == front[q] {
                    next.union(p as u32, q as u32);
                }
            }
        }
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{AnyMapping, MappingKind};

    /// One segment cut by the watershed into three sides: a floor (left half), a strip of the same
    /// flat floor (upper right) cut from it across flat, unseeded links — the order ties were
    /// joined in —, and a box (lower right) cut from both at creases (links turning 30°). Most of
    /// the segment's cut is flat, but only the sides bounded by flat cuts lose their cut: the box
    /// keeps its own.
    #[test]
    fn only_the_sides_cut_through_flat_are_cut_again() {
        let (w, h) = (32usize, 16usize);
        let nb = Neighbours::new(AnyMapping::new(MappingKind::Equirect, w, h).unwrap());
        let n = w * h;
        let side = |p: usize| match (p % w < w / 2, p / w < 12) {
            (true, _) => 0u8,
            (false, true) => 1,
            (false, false) => 2,
        };
        let mut dsu = Dsu::new(n);
        for p in 0..n {
            for &k in &HALF {
                if let Some(q) = nb.get(p, k).filter(|&q| side(q) == side(p)) {
                    dsu.union(p as u32, q as u32);
                }
            }
        }
        let members: Vec<u32> = (0..n as u32).collect();
        let angles: Vec<[u8; 4]> = (0..n)
            .map(|p| {
                HALF.map(|k| match nb.get(p, k) {
                    None => SKIP,
                    Some(q) if side(p) == 2 || side(q) == 2 => 30,
                    Some(_) => 0,
                })
            })
            .collect();
        // Most of the segment's cut is flat: a rule per segment would cut the box again too.
        let (mut cut, mut flat_cut) = (0, 0);
        for (p, a) in angles.iter().enumerate() {
            for (i, &k) in HALF.iter().enumerate() {
                if nb.get(p, k).is_some_and(|q| side(q) != side(p)) {
                    (cut, flat_cut) = (cut + 1, flat_cut + (a[i] == 0) as u32);
                }
            }
        }
        assert!(4 * flat_cut > cut, "{flat_cut} of {cut}");
        let seeded = vec![false; n];
        let flat = sides_cut_through_flat(&nb, n, &mut dsu, &seeded, &members, &angles);
        let flagged = |s: u8| (0..n).filter(|&p| side(p) == s).all(|p| flat[p]);
        let kept = |s: u8| (0..n).filter(|&p| side(p) == s).all(|p| !flat[p]);
        assert!(flagged(1), "the strip cut through flat is cut again");
        assert!(kept(2), "the box keeps its cut");
    }
}
