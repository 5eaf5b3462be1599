//! Pixels and pieces between segmentation and layers: mixed edge samples, unknown depth given to a
//! layer, and layers cut where their surface breaks (spec §7, steps 1 and 4).

use rayon::prelude::*;

use super::edges;
use super::segment::{self, NO_SEGMENT};
use crate::continuity;
use crate::mapping::{opposite, Neighbours};

/// Pixels whose depth lies strictly between a nearer neighbour and a farther neighbour, each across a
/// jump (the mixed samples of an anti-aliased depth edge, spec §7 step 1), with the depth of their
/// farthest such neighbour.
pub(super) fn mixed_pixels_of(nb: &Neighbours, depth: &[f32], links: &edges::Links) -> Vec<(usize, f32)> {
    (0..nb.len())
        .into_par_iter()
        .filter_map(|p| {
            let d = depth[p];
            if !(d.is_finite() && d > 0.0) {
                return None;
            }
            let (x, y) = (p % nb.width(), p / nb.width());
            let (mut nearer, mut farthest) = (false, d);
            for k in 0..8 {
                if !links.is_jump(p, k) {
                    continue;
                }
                let Some(q) = nb.get_at(x, y, k) else { continue };
                let e = depth[q];
                nearer |= e < d;
                // Infinity (sky) is not a depth to take: such a pixel stays as it is.
                if e > farthest && e.is_finite() {
                    farthest = e;
                }
            }
            (nearer && farthest > d).then_some((p, farthest))
        })
        .collect()
}

/// Unknown-depth pixels join the layer of the farthest known neighbour and take its depth,
/// growing inwards from the hole's rim (a hole in a wall stays on the wall, at the wall's
/// distance; no surface appears at distance 0 and no NaN reaches the output). With no known
/// depth anywhere, pixels become direction-only (+inf) in the first finite layer.
pub(super) fn assign_unknown(nb: &Neighbours, depth: &mut [f32], layer_of: &mut [u32], first_finite: u32) {
    let n = layer_of.len();
    let known = &*layer_of;
    let mut frontier: Vec<usize> = (0..n)
        .into_par_iter()
        .filter(|&p| known[p] == u32::MAX && nb.all(p).any(|q| known[q] != u32::MAX))
        .collect();
    while !frontier.is_empty() {
        let mut next = Vec::new();
        let updates: Vec<(usize, usize)> = frontier
            .iter()
            .filter(|&&p| layer_of[p] == u32::MAX)
            .filter_map(|&p| {
                nb.all(p)
                    .filter(|&q| layer_of[q] != u32::MAX)
                    .max_by(|&a, &b| depth[a].total_cmp(&depth[b]).then(b.cmp(&a)))
                    .map(|q| (p, q))
            })
            .collect();
        for &(p, q) in &updates {
            layer_of[p] = layer_of[q];
            depth[p] = depth[q];
        }
        for &(p, _) in &updates {
            next.extend(nb.all(p).filter(|&q| layer_of[q] == u32::MAX));
        }
        next.sort_unstable();
        next.dedup();
        frontier = next;
    }
    for (l, d) in layer_of.iter_mut().zip(depth.iter_mut()) {
        if *l == u32::MAX {
            *l = first_finite;
            *d = f32::INFINITY;
        }
    }
}

/// The 4-neighbour pairs `(p, q)`, `p < q`, of one group (`group` is `None` outside every group)
/// that are not one surface by `validate`'s rule ([`continuity::LAYER_JUMP`]; the plane test
/// through pixels of the same group), across the seam, poles and cube-face edges.
pub(super) fn breaks<G: PartialEq + Copy>(
    nb: &Neighbours,
    depth: &[f32],
    group: impl Fn(usize) -> Option<G> + Sync,
) -> Vec<(usize, usize)> {
    let w = nb.width();
    (0..nb.height())
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut found = Vec::new();
            for x in 0..w {
                let p = y * w + x;
                let Some(g) = group(p) else { continue };
                let at = |r: usize| (group(r) == Some(g)).then(|| f64::from(depth[r])).filter(|d| *d > 0.0);
                let Some(a) = at(p) else { continue };
                for k in 0..4 {
                    let Some(q) = nb.get_at(x, y, k).filter(|&q| q > p) else { continue };
                    let Some(b) = at(q) else { continue };
                    // The plane test's pixels only when the step alone does not decide (most pairs).
                    if !continuity::continuous_with(
                        a,
                        b,
                        || nb.get_at(x, y, opposite(k)).and_then(at),
                        || nb.get2_at(x, y, k).and_then(at),
                        continuity::LAYER_JUMP,
                        continuity::PLANAR,
                    ) {
                        found.push((p, q));
                    }
                }
            }
            found
        })
        .collect()
}

/// Pieces of segments: pixels of one segment joined by `validate`'s rule with the plane test
/// through pixels of the same segment ([`continuity::LAYER_JUMP`]). A segment is one piece unless
/// a plane test through pixels that went elsewhere linked it (a soft ramp cut in pieces). Returns
/// each pixel's piece (`u32::MAX` outside segments) and each piece's size.
pub(super) fn pieces(nb: &Neighbours, depth: &[f32], id: &[u32], sizes: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let broken = breaks(nb, depth, |p| (id[p] != NO_SEGMENT).then_some(id[p]));
    // Most builds: every segment one piece.
    if broken.is_empty() {
        return (id.to_vec(), sizes.to_vec());
    }
    let broken: std::collections::HashSet<(usize, usize)> = broken.into_iter().collect();
    let mut dsu = segment::Dsu::new(id.len());
    for p in 0..id.len() {
        if id[p] == NO_SEGMENT {
            continue;
        }
        for k in 0..4 {
            if let Some(q) = nb.get(p, k).filter(|&q| q > p && id[q] == id[p] && !broken.contains(&(p, q))) {
                dsu.union(p as u32, q as u32);
            }
        }
    }
    let mut label = vec![u32::MAX; id.len()];
    let mut size = Vec::new();
    for p in 0..id.len() {
        if id[p] == NO_SEGMENT {
            continue;
        }
        let root = dsu.find(p as u32) as usize;
        if label[root] == u32::MAX {
            label[root] = size.len() as u32;
            size.push(0);
        }
        label[p] = label[root];
        size[label[p] as usize] += 1;
    }
    (label, size)
}

/// The part of each piece of segment ([`pieces`]): segments that would share a layer (one key) but meet across a
/// discontinuity by `validate`'s rule ([`continuity::LAYER_JUMP`], the plane test through pixels
/// of the same key) — a far speck the surface in front does not rise above, two ends of a soft ramp
/// — get different parts, larger segments first (greedy colouring), so each layer stays continuous.
pub(super) fn parts(
    nb: &Neighbours,
    depth: &[f32],
    piece: &[u32],
    size: &[u32],
    key: impl Fn(usize) -> Option<u32> + Sync,
) -> Vec<u32> {
    let mut conflicts: Vec<(u32, u32)> = breaks(nb, depth, key)
        .into_iter()
        .filter(|&(p, q)| piece[p] != piece[q])
        .map(|(p, q)| (piece[p].min(piece[q]), piece[p].max(piece[q])))
        .collect();
    let mut part = vec![0u32; size.len()];
    if conflicts.is_empty() {
        return part;
    }
    conflicts.sort_unstable();
    conflicts.dedup();
    let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); size.len()];
    for &(s, t) in &conflicts {
        adjacent[s as usize].push(t);
        adjacent[t as usize].push(s);
    }
    let mut order: Vec<usize> = (0..size.len()).filter(|&s| !adjacent[s].is_empty()).collect();
    order.sort_by_key(|&s| (std::cmp::Reverse(size[s]), s));
    let mut coloured = vec![false; size.len()];
    for s in order {
        let used: Vec<u32> =
            adjacent[s].iter().filter(|&&t| coloured[t as usize]).map(|&t| part[t as usize]).collect();
        part[s] = (0..).find(|c| !used.contains(c)).unwrap_or(0);
        coloured[s] = true;
    }
    part
}

/// Pixels of one layer that `validate` would find discontinuous (a step over
/// [`continuity::LAYER_JUMP`] that no plane through pixels of the same layer continues): segments
/// can be linked through a plane test whose third pixel went to another layer (a ramp of soft depth
/// cut in pieces). The looser pixel of each such pair moves to a neighbouring layer it is
/// continuous with, if there is one; a sliver pixel with no such layer (joined to its own by one
/// link at most: an in-between depth a soft edge left beside an object) takes the layer and depth of
/// its farthest finite neighbour beyond it, as a mixed pixel does ([`mixed_pixels_of`]). Passes until
/// none moves (at most a few). A break left after them (a pixel tied to its layer on two sides
/// across a step: 8-bit depth's in-between codes) has its loose pixel taken to the far side all the
/// same: the layer must validate.
pub(super) fn repair_breaks(nb: &Neighbours, depth: &mut [f32], layer_of: &mut [u32]) {
    let mut forced = false;
    for pass in 0..REPAIR_PASSES + FORCED_PASSES {
        forced |= pass >= REPAIR_PASSES;
        let layer = &*layer_of;
        let breaks = breaks(nb, depth, |p| (layer[p] != u32::MAX).then_some(layer[p]));
        if breaks.is_empty() {
            return;
        }
        let joined = |p: usize, q: usize| {
            continuity::continuous(
                f64::from(depth[p]),
                f64::from(depth[q]),
                None,
                None,
                continuity::LAYER_JUMP,
                0.0,
            )
        };
        // Per break, the loose pixel, the layer it moves to and, for a sliver, the depth it takes.
        let plan = |forced: bool| -> Vec<(usize, u32, Option<f32>)> {
            breaks
                .iter()
                .filter_map(|&(p, q)| {
                    let l = layer[p];
                    let ties = |r: usize| nb.all(r).filter(|&s| layer[s] == l && joined(r, s)).count();
                    let (tp, tq) = (ties(p), ties(q));
                    let (loose, loose_ties) = if tp <= tq { (p, tp) } else { (q, tq) };
                    let other = |s: &usize| layer[*s] != l && layer[*s] != u32::MAX;
                    // The neighbour in another layer nearest in depth among those `keep` accepts.
                    let nearest = |keep: &dyn Fn(usize) -> bool| {
                        nb.all(loose).filter(|s| other(s) && keep(*s)).min_by(|&a, &b| {
                            (depth[a] - depth[loose]).abs().total_cmp(&(depth[b] - depth[loose]).abs())
                        })
                    };
                    let to = nearest(&|s| joined(loose, s)).map(|s| (loose, layer[s], None));
                    let far_side = || {
                        nb.all(loose)
                            .filter(|s| other(s) && depth[*s].is_finite() && depth[*s] > depth[loose])
                            .max_by(|&a, &b| depth[a].total_cmp(&depth[b]).then(b.cmp(&a)))
                            .map(|s| (loose, layer[s], Some(depth[s])))
                    };
                    // Forced, with nothing farther: the nearest other layer, at its depth.
                    let any_side = || nearest(&|s| depth[s] > 0.0).map(|s| (loose, layer[s], Some(depth[s])));
                    to.or_else(|| match (loose_ties <= 1, forced) {
                        (true, _) => far_side(),
                        (false, true) => far_side().or_else(any_side),
                        (false, false) => None,
                    })
                })
                .collect()
        };
        let mut moves = plan(forced);
        if moves.is_empty() && !forced {
            // Nothing the gentle rule moves: the forced passes take what is left.
            forced = true;
            moves = plan(true);
        }
        if moves.is_empty() {
            return;
        }
        for (p, l, d) in moves {
            layer_of[p] = l;
            if let Some(d) = d {
                depth[p] = d;
            }
        }
    }
}

/// Passes of [`repair_breaks`]'s gentle rule, then of its forced one.
const REPAIR_PASSES: usize = 4;
const FORCED_PASSES: usize = 2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{AnyMapping, MappingKind};

    /// A 32 × 16 canvas: a wall 4 m away (layer 0) and a 6 × 6 object 1 m away (layer 1) at
    /// columns 10–15, rows 5–10. Returns the width, the neighbours, the depths and the layers.
    fn object_on_wall() -> (usize, Neighbours, Vec<f32>, Vec<u32>) {
        let (w, h) = (32, 16);
        let nb = Neighbours::new(AnyMapping::new(MappingKind::Equirect, w, h).unwrap());
        let mut depth = vec![4.0f32; w * h];
        let mut layer_of = vec![0u32; w * h];
        for y in 5..11 {
            for x in 10..16 {
                depth[y * w + x] = 1.0;
                layer_of[y * w + x] = 1;
            }
        }
        (w, nb, depth, layer_of)
    }

    /// A sliver of in-between depth beside an object (a soft edge's remnant), in the object's layer
    /// and continuous with no layer around it: it goes to the far side, as a mixed pixel does, and
    /// the layer has no break left.
    #[test]
    fn a_sliver_with_no_layer_to_join_goes_to_the_far_side() {
        let (w, nb, mut depth, mut layer_of) = object_on_wall();
        let sliver = 8 * w + 16;
        (depth[sliver], layer_of[sliver]) = (1.6, 1);
        let layer = |l: &[u32]| -> Vec<(usize, usize)> { breaks(&nb, &depth, |p| Some(l[p])) };
        assert_eq!(layer(&layer_of), vec![(sliver - 1, sliver)]);
        repair_breaks(&nb, &mut depth, &mut layer_of);
        assert_eq!((layer_of[sliver], depth[sliver]), (0, 4.0));
        assert!(breaks(&nb, &depth, |p| Some(layer_of[p])).is_empty());
        // The object is untouched.
        assert_eq!(layer_of.iter().filter(|&&l| l == 1).count(), 36);
    }

    /// A 2 × 2 block of in-between depth beside an object (8-bit depth's codes between its two
    /// sides), in the object's layer: each pixel is tied to the block on three sides, so the gentle
    /// rule moves none of it; the forced passes take the pixels at the step to the far side, and
    /// the layer validates.
    #[test]
    fn a_block_tied_to_its_layer_across_a_step_still_leaves_no_break() {
        let (w, nb, mut depth, mut layer_of) = object_on_wall();
        for y in 7..9 {
            for x in 16..18 {
                (depth[y * w + x], layer_of[y * w + x]) = (1.6, 1);
            }
        }
        let layer = |l: &[u32], d: &[f32]| breaks(&nb, d, |p| Some(l[p]));
        assert_eq!(layer(&layer_of, &depth).len(), 2);
        repair_breaks(&nb, &mut depth, &mut layer_of);
        assert!(layer(&layer_of, &depth).is_empty());
        for p in [7 * w + 16, 8 * w + 16] {
            assert_eq!((layer_of[p], depth[p]), (0, 4.0));
        }
        assert_eq!(layer_of.iter().filter(|&&l| l == 1).count(), 38);
    }
}
