//! Crack-free triangulation of a balanced quadtree's leaves (thesis 7.4.2.4).
//!
//! A vertex is *used* when it is a corner of a non-empty leaf. After balancing, the only vertex a side
//! of a leaf can carry besides its ends is the side's midpoint, and it does so exactly when that
//! midpoint is used (a corner of the finer neighbour). Then:
//! - no hanging vertex → two triangles along the diagonal `(x0,y0)-(x1,y1)`;
//! - hanging vertices, both sides ≥ 2 cells → fan from the split point `(xm, ym)` (strictly inside) to
//!   the corners and hanging midpoints;
//! - hanging vertices on a leaf one cell wide → the two long sides are zipped (no interior point exists);
//! - a single cell containing a border or jump → the diagonal keeping more continuous triangles, and
//!   only triangles whose three edges join valid, continuous samples.

use super::grid::Grid;
use super::quadtree::{NodeKind, Rect, Tree};
use super::stitch::{zip, ZipVertex};

type P = (u32, u32);

/// Used-vertex bitmap of a lattice.
pub fn used_vertices(tree: &Tree, grid: &Grid) -> Vec<bool> {
    let mut used = vec![false; grid.w * grid.h];
    for n in tree.nodes.iter().filter(|n| n.is_leaf() && n.kind != NodeKind::Empty) {
        let r = n.rect;
        for (x, y) in [(r.x0, r.y0), (r.x1, r.y0), (r.x1, r.y1), (r.x0, r.y1)] {
            used[y as usize * grid.w + x as usize] = true;
        }
    }
    used
}

/// Triangles (canvas pixel indices) of every leaf.
pub fn triangulate(tree: &Tree, grid: &Grid, used: &[bool]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for n in tree.leaves().into_iter().map(|i| &tree.nodes[i]).filter(|n| n.kind != NodeKind::Empty) {
        leaf_triangles(&n.rect, n.kind, grid, used, &mut out);
    }
    out
}

fn leaf_triangles(r: &Rect, kind: NodeKind, g: &Grid, used: &[bool], out: &mut Vec<[u32; 3]>) {
    let id = |p: P| g.pixel(p.0 as usize, p.1 as usize);
    let c = [(r.x0, r.y0), (r.x1, r.y0), (r.x1, r.y1), (r.x0, r.y1)];
    if kind != NodeKind::Full {
        if r.cw() == 1 && r.ch() == 1 {
            cell_triangles(c, g, out);
        }
        return;
    }
    let (xm, ym) = r.mid();
    let is_used = |p: P| used[p.1 as usize * g.w + p.0 as usize];
    let mids: [Option<P>; 4] = [
        (r.cw() >= 2).then_some((xm, r.y0)),
        (r.ch() >= 2).then_some((r.x1, ym)),
        (r.cw() >= 2).then_some((xm, r.y1)),
        (r.ch() >= 2).then_some((r.x0, ym)),
    ]
    .map(|m| m.filter(|&p| is_used(p)));
    if mids.iter().all(Option::is_none) {
        out.push([id(c[0]), id(c[1]), id(c[2])]);
        out.push([id(c[0]), id(c[2]), id(c[3])]);
    } else if r.cw() >= 2 && r.ch() >= 2 {
        let mut ring = Vec::with_capacity(8);
        for k in 0..4 {
            ring.push(c[k]);
            ring.extend(mids[k]);
        }
        let ctr = id((xm, ym));
        for k in 0..ring.len() {
            out.push([ctr, id(ring[k]), id(ring[(k + 1) % ring.len()])]);
        }
    } else {
        // One cell wide: zip the two long sides.
        let zv = |p: P, pos: u32| ZipVertex { pos, id: id(p), depth: g.depth_at(p.0 as usize, p.1 as usize) };
        let (a, b) = if r.cw() == 1 {
            let a: Vec<_> =
                [Some(c[0]), mids[3], Some(c[3])].into_iter().flatten().map(|p| zv(p, p.1)).collect();
            let b: Vec<_> =
                [Some(c[1]), mids[1], Some(c[2])].into_iter().flatten().map(|p| zv(p, p.1)).collect();
            (a, b)
        } else {
            let a: Vec<_> =
                [Some(c[0]), mids[0], Some(c[1])].into_iter().flatten().map(|p| zv(p, p.0)).collect();
            let b: Vec<_> =
                [Some(c[3]), mids[2], Some(c[2])].into_iter().flatten().map(|p| zv(p, p.0)).collect();
            (a, b)
        };
        zip(&a, &b, out);
    }
}

/// The triangles of a single cell whose edges all join valid, continuous samples.
fn cell_triangles(c: [P; 4], g: &Grid, out: &mut Vec<[u32; 3]>) {
    let u = |p: P| (p.0 as usize, p.1 as usize);
    let ok = |t: [usize; 3]| (0..3).all(|k| g.connected(u(c[t[k]]), u(c[t[(k + 1) % 3]])));
    let ac = [[0, 1, 2], [0, 2, 3]];
    let bd = [[0, 1, 3], [1, 2, 3]];
    let count = |ts: &[[usize; 3]; 2]| ts.iter().filter(|&&t| ok(t)).count();
    let chosen = if count(&ac) >= count(&bd) { ac } else { bd };
    for t in chosen.into_iter().filter(|&t| ok(t)) {
        out.push(t.map(|k| g.pixel(c[k].0 as usize, c[k].1 as usize)));
    }
}
