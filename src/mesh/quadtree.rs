//! The discrete quadtree (thesis 7.4.2, Alg. 15-16) over a vertex lattice.
//!
//! A node is a lattice rectangle `[x0, x1] × [y0, y1]` (inclusive vertex bounds). It splits at
//! `xm = ⌊(x0+x1)/2⌋`, `ym = ⌊(y0+y1)/2⌋`; when one side is a single cell it splits in two along the
//! other side only; a single cell never splits. Because every node of depth `d` is cut by the same
//! rule, the nodes of depth `d` tile the lattice as the product of two fixed 1D partitions: a node's
//! neighbour of equal depth shares its whole side, and a side of a depth-`d` leaf can only receive the
//! split point of depth `d+1` — its own midpoint. Balancing and triangulation rely on this.

/// A lattice rectangle with inclusive vertex bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rect {
    /// Left vertex column.
    pub x0: u32,
    /// Top vertex row.
    pub y0: u32,
    /// Right vertex column (inclusive).
    pub x1: u32,
    /// Bottom vertex row (inclusive).
    pub y1: u32,
}

impl Rect {
    /// The rectangle `[x0, x1] × [y0, y1]`.
    pub fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }
    /// Width in cells.
    pub fn cw(&self) -> u32 {
        self.x1 - self.x0
    }
    /// Height in cells.
    pub fn ch(&self) -> u32 {
        self.y1 - self.y0
    }
    /// Number of cells.
    pub fn cells(&self) -> u64 {
        self.cw() as u64 * self.ch() as u64
    }
    /// Whether the node may split: at least one side spans 2 cells or more.
    pub fn splittable(&self) -> bool {
        self.cw() >= 2 || self.ch() >= 2
    }
    /// Split point (meaningful along an axis of ≥ 2 cells).
    pub fn mid(&self) -> (u32, u32) {
        ((self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2)
    }
    /// Children in reading order: 4 when both sides have ≥ 2 cells, 2 when one has, none otherwise.
    pub fn children(&self) -> ([Rect; 4], usize) {
        let (xm, ym) = self.mid();
        let r = |a, b, c, d| Rect::new(a, b, c, d);
        let (sx, sy) = (self.cw() >= 2, self.ch() >= 2);
        let (x0, y0, x1, y1) = (self.x0, self.y0, self.x1, self.y1);
        match (sx, sy) {
            (true, true) => ([r(x0, y0, xm, ym), r(xm, y0, x1, ym), r(x0, ym, xm, y1), r(xm, ym, x1, y1)], 4),
            (true, false) => ([r(x0, y0, xm, y1), r(xm, y0, x1, y1), *self, *self], 2),
            (false, true) => ([r(x0, y0, x1, ym), r(x0, ym, x1, y1), *self, *self], 2),
            (false, false) => ([*self; 4], 0),
        }
    }
    /// Does the node contain cell `(cx, cy)` (the cell whose top-left vertex is `(cx, cy)`)?
    pub fn contains_cell(&self, cx: u32, cy: u32) -> bool {
        cx >= self.x0 && cx < self.x1 && cy >= self.y0 && cy < self.y1
    }
}

/// What a node holds, from the summed-area tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// No valid vertex: never triangulated, never split.
    Empty,
    /// Contains at least one bad cell (domain border or depth jump): split down to cells.
    Broken,
    /// Every cell is a continuous quad of valid samples.
    Full,
}

/// A quadtree node.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// The lattice rectangle it covers.
    pub rect: Rect,
    /// Depth in the tree (0 for the root).
    pub depth: u8,
    /// What it holds.
    pub kind: NodeKind,
    /// Index of the first child (children are contiguous); 0 for a leaf.
    pub first_child: u32,
    /// Number of children: 4, 2 (split along one axis) or 0 for a leaf.
    pub n_children: u8,
}

impl Node {
    /// Whether the node has no children.
    pub fn is_leaf(&self) -> bool {
        self.n_children == 0
    }
}

/// A quadtree; node 0 is the root.
#[derive(Clone, Debug, Default)]
pub struct Tree {
    /// All nodes, the root first, in the order they were created; each node's children are contiguous.
    pub nodes: Vec<Node>,
}

/// Decides, per node, its kind and whether to split it.
pub trait Subdivide {
    /// What node `r` holds (empty, broken or full).
    fn kind(&self, r: &Rect) -> NodeKind;
    /// Thesis `S(v)` for a splittable node: `true` to split.
    fn split(&self, r: &Rect, kind: NodeKind) -> bool;
}

impl Tree {
    /// An unsplit tree over a `w × h` vertex lattice (`None` when it has no cell).
    pub fn root(w: usize, h: usize, s: &impl Subdivide) -> Option<Tree> {
        if w < 2 || h < 2 {
            return None;
        }
        let rect = Rect::new(0, 0, w as u32 - 1, h as u32 - 1);
        let node = Node { rect, depth: 0, kind: s.kind(&rect), first_child: 0, n_children: 0 };
        Some(Tree { nodes: vec![node] })
    }

    /// Build top-down, breadth first, splitting wherever `S` says so. The decisions of one depth are
    /// taken in parallel; nodes are appended in the same breadth-first order as a sequential build.
    pub fn build(w: usize, h: usize, s: &(impl Subdivide + Sync)) -> Option<Tree> {
        use rayon::prelude::*;
        let mut tree = Tree::root(w, h, s)?;
        let mut level = vec![0usize];
        while !level.is_empty() {
            let nodes = &tree.nodes;
            let split: Vec<bool> = level
                .par_iter()
                .with_min_len(8)
                .map(|&j| {
                    let n = nodes[j];
                    n.rect.splittable() && n.kind != NodeKind::Empty && s.split(&n.rect, n.kind)
                })
                .collect();
            let mut next = Vec::new();
            for (&j, _) in level.iter().zip(&split).filter(|(_, &b)| b) {
                let first = tree.split(j, s);
                next.extend(first..first + tree.nodes[j].n_children as usize);
            }
            level = next;
        }
        Some(tree)
    }

    /// Split node `i` (a splittable leaf); returns the index of its first child.
    pub fn split(&mut self, i: usize, s: &impl Subdivide) -> usize {
        let node = self.nodes[i];
        let (rects, n) = node.rect.children();
        let first = self.nodes.len();
        for r in &rects[..n] {
            let kind = s.kind(r);
            self.nodes.push(Node { rect: *r, depth: node.depth + 1, kind, first_child: 0, n_children: 0 });
        }
        self.nodes[i].first_child = first as u32;
        self.nodes[i].n_children = n as u8;
        first
    }

    /// Refine the subtree of leaf `i` with `S`; `new_leaf` sees every leaf created (or kept).
    pub fn refine_from(&mut self, i: usize, s: &impl Subdivide, new_leaf: &mut impl FnMut(usize)) {
        let mut queue = std::collections::VecDeque::from([i]);
        while let Some(j) = queue.pop_front() {
            let node = self.nodes[j];
            if node.rect.splittable() && node.kind != NodeKind::Empty && s.split(&node.rect, node.kind) {
                let first = self.split(j, s);
                queue.extend(first..first + self.nodes[j].n_children as usize);
            } else {
                new_leaf(j);
            }
        }
    }

    /// Indices of all leaves in canonical (depth-first, children in reading order) order, which
    /// depends only on the tree's shape, not on the order its nodes were created in.
    pub fn leaves(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if n.is_leaf() {
                out.push(i);
            } else {
                let first = n.first_child as usize;
                stack.extend((first..first + n.n_children as usize).rev());
            }
        }
        out
    }

    /// Descend from the root to the deepest existing node containing cell `(cx, cy)`.
    pub fn leaf_at(&self, cx: u32, cy: u32) -> usize {
        let mut i = 0;
        loop {
            let n = &self.nodes[i];
            if n.is_leaf() {
                return i;
            }
            let first = n.first_child as usize;
            let next =
                (first..first + n.n_children as usize).find(|&c| self.nodes[c].rect.contains_cell(cx, cy));
            match next {
                Some(c) => i = c,
                None => return i,
            }
        }
    }

    /// Breadth-first split bits: one per splittable non-empty node, `1` = split. Cells and empty nodes
    /// carry no bit (the decoder knows them from the lattice and the layer).
    pub fn bits(&self) -> Vec<bool> {
        let mut out = Vec::new();
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(i) = queue.pop_front() {
            let n = &self.nodes[i];
            if !n.rect.splittable() || n.kind == NodeKind::Empty {
                continue;
            }
            out.push(!n.is_leaf());
            let first = n.first_child as usize;
            queue.extend(first..first + n.n_children as usize);
        }
        out
    }

    /// Rebuild a tree from its breadth-first bits. `None` when the bits run out or are left over.
    pub fn from_bits(w: usize, h: usize, s: &impl Subdivide, bits: &[bool]) -> Option<Tree> {
        let mut tree = Tree::root(w, h, s)?;
        let mut k = 0;
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(i) = queue.pop_front() {
            let n = tree.nodes[i];
            if !n.rect.splittable() || n.kind == NodeKind::Empty {
                continue;
            }
            let bit = *bits.get(k)?;
            k += 1;
            if bit {
                let first = tree.split(i, s);
                queue.extend(first..first + tree.nodes[i].n_children as usize);
            }
        }
        (k == bits.len()).then_some(tree)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Splits everything: a full tree.
    struct All;
    impl Subdivide for All {
        fn kind(&self, _: &Rect) -> NodeKind {
            NodeKind::Full
        }
        fn split(&self, r: &Rect, _: NodeKind) -> bool {
            r.splittable()
        }
    }

    #[test]
    fn degenerate_splits_are_two_way_and_cells_stop() {
        assert_eq!(Rect::new(0, 0, 3, 1).children().1, 2);
        assert_eq!(Rect::new(0, 0, 1, 5).children().1, 2);
        assert_eq!(Rect::new(0, 0, 1, 1).children().1, 0);
        let (c, n) = Rect::new(0, 0, 5, 3).children();
        assert_eq!(n, 4);
        assert_eq!(c[0], Rect::new(0, 0, 2, 1));
        assert_eq!(c[3], Rect::new(2, 1, 5, 3));
    }

    #[test]
    fn full_tree_leaves_are_every_cell_and_bits_round_trip() {
        // A 2:1 canvas with a non-power-of-two side, like the thesis's worst 3×1 cells.
        let tree = Tree::build(13, 7, &All).unwrap();
        let leaves = tree.leaves();
        assert_eq!(leaves.len(), 12 * 6);
        assert!(leaves.iter().all(|&i| tree.nodes[i].rect.cells() == 1));
        let bits = tree.bits();
        let back = Tree::from_bits(13, 7, &All, &bits).unwrap();
        assert_eq!(back.bits(), bits);
        assert!(Tree::from_bits(13, 7, &All, &bits[..bits.len() - 1]).is_none());
        let mut extra = bits.clone();
        extra.push(false);
        assert!(Tree::from_bits(13, 7, &All, &extra).is_none());
    }
}
