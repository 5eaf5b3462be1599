//! 2:1 balancing (thesis Alg. 14): neighbouring leaves differ by at most one depth.
//!
//! For every non-empty leaf of depth `d`, the node across each side must exist down to depth `d − 1`.
//! Since equal-depth nodes tile the lattice as a product of partitions, the region across a side of a
//! depth-`d` leaf is a single depth-`(d−1)` node, so one point query per side suffices ([`Tree::leaf_at`]
//! replaces the pointer-chasing neighbour search of Alg. 12-13/15 and handles the 2-way splits for free).
//! A forced split re-runs `S` on the children, so a node split for balance still meets the error bound
//! of the triangulation it will finally receive.

use super::quadtree::{NodeKind, Subdivide, Tree};

/// Balance `tree` in place.
pub fn balance(tree: &mut Tree, s: &impl Subdivide) {
    let mut work: Vec<usize> =
        tree.leaves().into_iter().filter(|&i| tree.nodes[i].kind != NodeKind::Empty).collect();
    let (cw, ch) = (tree.nodes[0].rect.x1, tree.nodes[0].rect.y1);
    while let Some(i) = work.pop() {
        let n = tree.nodes[i];
        if !n.is_leaf() || n.kind == NodeKind::Empty || n.depth < 2 {
            continue;
        }
        let r = n.rect;
        let mut across = Vec::with_capacity(4);
        if r.x0 > 0 {
            across.push((r.x0 - 1, r.y0));
        }
        if r.x1 < cw {
            across.push((r.x1, r.y0));
        }
        if r.y0 > 0 {
            across.push((r.x0, r.y0 - 1));
        }
        if r.y1 < ch {
            across.push((r.x0, r.y1));
        }
        for (cx, cy) in across {
            ensure_depth(tree, cx, cy, n.depth - 1, s, &mut work);
        }
    }
}

/// Split (and re-refine) the leaf containing cell `(cx, cy)` until it is at least `target` deep.
fn ensure_depth(tree: &mut Tree, cx: u32, cy: u32, target: u8, s: &impl Subdivide, work: &mut Vec<usize>) {
    loop {
        let j = tree.leaf_at(cx, cy);
        let n = tree.nodes[j];
        if n.depth >= target || !n.rect.splittable() || n.kind == NodeKind::Empty {
            return;
        }
        let first = tree.split(j, s);
        for c in first..first + tree.nodes[j].n_children as usize {
            tree.refine_from(c, s, &mut |leaf| work.push(leaf));
        }
    }
}

/// `true` when no two side-adjacent non-empty leaves differ by more than one depth (for tests).
pub fn is_balanced(tree: &Tree) -> bool {
    let (cw, ch) = (tree.nodes[0].rect.x1, tree.nodes[0].rect.y1);
    tree.leaves().into_iter().all(|i| {
        let n = tree.nodes[i];
        if n.kind == NodeKind::Empty {
            return true;
        }
        let r = n.rect;
        let mut cells = Vec::new();
        for x in r.x0..r.x1 {
            if r.y0 > 0 {
                cells.push((x, r.y0 - 1));
            }
            if r.y1 < ch {
                cells.push((x, r.y1));
            }
        }
        for y in r.y0..r.y1 {
            if r.x0 > 0 {
                cells.push((r.x0 - 1, y));
            }
            if r.x1 < cw {
                cells.push((r.x1, y));
            }
        }
        cells.into_iter().all(|(x, y)| {
            let m = tree.nodes[tree.leaf_at(x, y)];
            m.kind == NodeKind::Empty || m.depth <= n.depth + 1
        })
    })
}
