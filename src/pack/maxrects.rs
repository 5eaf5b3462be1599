//! Packing rectangles into a small atlas (spec §5.5): MaxRects strip packing.
//!
//! MaxRects (Jylänki, "A thousand ways to pack the bin", 2010) keeps the list of maximal free
//! rectangles of the bin; each item goes where its fit score is best, and the free rectangles it
//! overlaps are split into their maximal remainders. Here the bin has a fixed width and an
//! unbounded height (strip packing); the atlas height is where the items end. Two scores are
//! tried, best short side fit and bottom-left, over a few widths, and the smallest atlas wins.
//!
//! MaxRects costs O(n · free rectangles) per item; beyond [`MAXRECTS_LIMIT`] items a shelf packer
//! (O(n log n)) is used instead, which is also near-optimal for many small similar items.

/// Above this many items, shelf packing replaces MaxRects (quadratic).
pub const MAXRECTS_LIMIT: usize = 3000;

/// Placements (top-left corners, in item order) and the atlas size they need.
#[derive(Clone, Debug, PartialEq)]
pub struct Packing {
    /// Atlas width, pixels (0 when there are no items).
    pub width: u32,
    /// Atlas height, pixels: where the lowest item ends (0 when there are no items).
    pub height: u32,
    /// Top-left corner `(x, y)` of each item, pixels, in the order of the input sizes.
    pub positions: Vec<(u32, u32)>,
}

impl Packing {
    fn area(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

#[derive(Clone, Copy, Debug)]
enum Score {
    ShortSide,
    BottomLeft,
}

/// Pack items of sizes `(w, h)` (all non-zero) into the smallest atlas found.
pub fn pack(sizes: &[(u32, u32)]) -> Packing {
    if sizes.is_empty() {
        return Packing { width: 0, height: 0, positions: Vec::new() };
    }
    let area: u64 = sizes.iter().map(|&(w, h)| u64::from(w) * u64::from(h)).sum();
    let widest = sizes.iter().map(|s| s.0).max().unwrap_or(1);
    let side = (area as f64).sqrt();
    let mut best: Option<Packing> = None;
    for f in [0.9, 1.0, 1.1, 1.25, 1.5, 2.0] {
        let width = ((side * f).ceil() as u64).clamp(u64::from(widest), u64::from(u32::MAX)) as u32;
        let tries: Vec<Packing> = if sizes.len() <= MAXRECTS_LIMIT {
            vec![maxrects(sizes, width, Score::ShortSide), maxrects(sizes, width, Score::BottomLeft)]
        } else {
            vec![shelves(sizes, width)]
        };
        for p in tries {
            if best.as_ref().is_none_or(|b| p.area() < b.area()) {
                best = Some(p);
            }
        }
    }
    best.expect("at least one width tried")
}

/// A free rectangle, in u64 so that the unbounded strip never overflows.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Free {
    x: u64,
    y: u64,
    w: u64,
    h: u64,
}

impl Free {
    fn contains(&self, o: &Free) -> bool {
        o.x >= self.x && o.y >= self.y && o.x + o.w <= self.x + self.w && o.y + o.h <= self.y + self.h
    }

    fn intersects(&self, o: &Free) -> bool {
        o.x < self.x + self.w && self.x < o.x + o.w && o.y < self.y + self.h && self.y < o.y + o.h
    }

    /// Maximal parts of `self` outside `used` (which intersects it).
    fn split(&self, used: &Free, out: &mut Vec<Free>) {
        if used.x > self.x {
            out.push(Free { w: used.x - self.x, ..*self });
        }
        if used.x + used.w < self.x + self.w {
            out.push(Free { x: used.x + used.w, w: self.x + self.w - used.x - used.w, ..*self });
        }
        if used.y > self.y {
            out.push(Free { h: used.y - self.y, ..*self });
        }
        if used.y + used.h < self.y + self.h {
            out.push(Free { y: used.y + used.h, h: self.y + self.h - used.y - used.h, ..*self });
        }
    }
}

/// Items in decreasing order of their longer side, then area (big items first pack tighter).
fn order(sizes: &[(u32, u32)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..sizes.len()).collect();
    idx.sort_by_key(|&i| {
        let (w, h) = sizes[i];
        std::cmp::Reverse((w.max(h), u64::from(w) * u64::from(h)))
    });
    idx
}

fn maxrects(sizes: &[(u32, u32)], width: u32, score: Score) -> Packing {
    let strip: u64 = sizes.iter().map(|s| u64::from(s.1)).sum();
    let mut free = vec![Free { x: 0, y: 0, w: u64::from(width), h: strip }];
    let mut positions = vec![(0, 0); sizes.len()];
    let mut height = 0u64;
    for i in order(sizes) {
        let (w, h) = (u64::from(sizes[i].0), u64::from(sizes[i].1));
        let spot = free
            .iter()
            .filter(|f| f.w >= w && f.h >= h)
            .min_by_key(|f| match score {
                Score::ShortSide => ((f.w - w).min(f.h - h), (f.w - w).max(f.h - h), f.y, f.x),
                Score::BottomLeft => (f.y + h, f.x, 0, 0),
            })
            .copied()
            .expect("the strip is as tall as all items stacked");
        let used = Free { x: spot.x, y: spot.y, w, h };
        place(&mut free, &used);
        positions[i] = (spot.x as u32, spot.y as u32);
        height = height.max(spot.y + h);
    }
    Packing { width, height: height as u32, positions }
}

/// Remove `used` from the free list, keeping only maximal free rectangles.
fn place(free: &mut Vec<Free>, used: &Free) {
    let mut fresh = Vec::new();
    free.retain(|f| {
        if f.intersects(used) {
            f.split(used, &mut fresh);
            false
        } else {
            true
        }
    });
    // Old rectangles are already mutually maximal: only the fresh ones need pruning.
    let mut kept: Vec<Free> = Vec::with_capacity(fresh.len());
    for (k, n) in fresh.iter().enumerate() {
        let inside_old = free.iter().any(|f| f.contains(n));
        let inside_fresh =
            fresh.iter().enumerate().any(|(j, o)| j != k && o.contains(n) && (o != n || j < k));
        if !inside_old && !inside_fresh {
            kept.push(*n);
        }
    }
    free.retain(|f| !kept.iter().any(|n| n.contains(f)));
    free.extend(kept);
}

/// Shelf packing: items by decreasing height, left to right, a new shelf when the row is full.
fn shelves(sizes: &[(u32, u32)], width: u32) -> Packing {
    let mut idx: Vec<usize> = (0..sizes.len()).collect();
    idx.sort_by_key(|&i| std::cmp::Reverse((sizes[i].1, sizes[i].0)));
    let mut positions = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut shelf) = (0u64, 0u64, 0u64);
    for i in idx {
        let (w, h) = (u64::from(sizes[i].0), u64::from(sizes[i].1));
        if x + w > u64::from(width) {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        positions[i] = (x as u32, y as u32);
        x += w;
        shelf = shelf.max(h);
    }
    Packing { width, height: (y + shelf) as u32, positions }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_disjoint(sizes: &[(u32, u32)], p: &Packing) {
        for (i, (&(x, y), &(w, h))) in p.positions.iter().zip(sizes).enumerate() {
            assert!(x + w <= p.width && y + h <= p.height, "item {i} outside");
            for (j, (&(x2, y2), &(w2, h2))) in p.positions.iter().zip(sizes).enumerate().skip(i + 1) {
                let overlap = x < x2 + w2 && x2 < x + w && y < y2 + h2 && y2 < y + h;
                assert!(!overlap, "items {i} and {j} overlap");
            }
        }
    }

    #[test]
    fn packs_without_overlap_and_tightly() {
        let sizes: Vec<(u32, u32)> = (0..200).map(|i| (1 + (i * 7) % 23, 1 + (i * 13) % 17)).collect();
        let p = pack(&sizes);
        assert_disjoint(&sizes, &p);
        let area: u64 = sizes.iter().map(|&(w, h)| u64::from(w) * u64::from(h)).sum();
        assert!((p.area() as f64) < 1.3 * area as f64, "atlas {} for {area}", p.area());
    }

    #[test]
    fn shelves_are_disjoint() {
        let sizes: Vec<(u32, u32)> = (0..500).map(|i| (1 + i % 5, 1 + i % 3)).collect();
        let p = shelves(&sizes, 40);
        assert_disjoint(&sizes, &p);
    }
}
