//! Cutting a layer's domain into disjoint rectangles that waste little area (spec §5.5).
//!
//! Start from the tight bounding box of the domain and recursively make the guillotine cut (one
//! full row or column boundary) that most reduces the cost of the two tight boxes it leaves.
//! Cutting along empty rows or columns separates connected components for free (their boxes
//! shrink to nothing in between), and cutting *through* a thin diagonal or a ring is what makes
//! such shapes cheap, where a component's bounding box alone would be mostly empty.
//!
//! A box is split when the best cut lowers the cost (area with padding, plus a per-patch
//! overhead) by a significant fraction, and is always split (by a balanced cut) while less than
//! [`MIN_FILL`] of it is occupied. The work is O(area) per level of a recursion that stays
//! O(log area) deep (see `best_cut`), also on noise-like masks. Every leaf is
//! therefore at least `MIN_FILL` full, so the rectangles hold at most `occupied / MIN_FILL`
//! pixels: the slack left to the packer to stay within twice the occupied pixels.

/// A rectangle of the canvas: origin `(x, y)`, size `w × h` (all non-empty).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// Left column, pixels.
    pub x: u32,
    /// Top row, pixels.
    pub y: u32,
    /// Width, pixels.
    pub w: u32,
    /// Height, pixels.
    pub h: u32,
}

impl Rect {
    /// Area `w · h`, pixels (u64: never overflows).
    pub fn area(&self) -> u64 {
        u64::from(self.w) * u64::from(self.h)
    }
}

/// Boxes less full than this are always split (leaves waste at most 1/3 of their area).
pub const MIN_FILL: f64 = 0.75;
/// Cost of one more patch, in pixels (a table row, and the packer's loss around it).
const PATCH_COST: u64 = 8;
/// A cut is worth making for its own sake when it saves at least 1/128 of the box's cost.
const SIGNIFICANT: u64 = 128;

/// Disjoint rectangles covering every `true` pixel of `mask` (`width × height`, row-major).
pub fn cover(mask: &[bool], width: usize, height: usize, padding: u32) -> Vec<Rect> {
    let mut out = Vec::new();
    let Some(root) = tight(mask, width, Rect { x: 0, y: 0, w: width as u32, h: height as u32 }) else {
        return out;
    };
    let mut stack = vec![root];
    while let Some(r) = stack.pop() {
        match best_cut(mask, width, r, padding) {
            Some((a, b)) => {
                stack.push(a);
                stack.push(b);
            }
            None => out.push(r),
        }
    }
    out
}

/// Split rectangles longer than the side of a square holding them all into pieces no longer than
/// that side. One full-width ring (a ceiling lamp around a pole of an equirect canvas) would
/// otherwise force the atlas to the canvas width and leave most of it empty. Pieces of one
/// rectangle have near-equal lengths; with padding each extra piece costs its guard band.
pub fn limit_length(rects: Vec<Rect>, padding: u32) -> Vec<Rect> {
    let p = u64::from(2 * padding);
    let area: u64 = rects.iter().map(|r| (u64::from(r.w) + p) * (u64::from(r.h) + p)).sum();
    let side = ((area as f64).sqrt().ceil() as u64).max(1);
    let mut out = Vec::with_capacity(rects.len());
    for r in rects {
        let (long, wide) = if r.w >= r.h { (r.w, true) } else { (r.h, false) };
        let pieces = (u64::from(long) + p).div_ceil(side).max(1) as u32;
        if pieces == 1 {
            out.push(r);
            continue;
        }
        let mut start = 0;
        for k in 0..pieces {
            let end = ((u64::from(long) * u64::from(k + 1)) / u64::from(pieces)) as u32;
            let len = end - start;
            if len > 0 {
                out.push(if wide {
                    Rect { x: r.x + start, w: len, ..r }
                } else {
                    Rect { y: r.y + start, h: len, ..r }
                });
            }
            start = end;
        }
    }
    out
}

/// Cost of storing a box: its padded area plus the per-patch overhead.
fn cost(w: u32, h: u32, padding: u32) -> u64 {
    let p = 2 * u64::from(padding);
    (u64::from(w) + p) * (u64::from(h) + p) + PATCH_COST
}

/// Occupancy profile of a box along one axis: per line, the pixel count and the extent of the
/// occupied pixels across the line.
struct Profile {
    count: Vec<u64>,
    lo: Vec<u32>,
    hi: Vec<u32>,
}

impl Profile {
    fn new(n: usize) -> Self {
        Profile { count: vec![0; n], lo: vec![u32::MAX; n], hi: vec![0; n] }
    }

    fn add(&mut self, line: usize, across: u32) {
        self.count[line] += 1;
        self.lo[line] = self.lo[line].min(across);
        self.hi[line] = self.hi[line].max(across);
    }
}

/// Row and column profiles of box `r` (coordinates relative to `r`).
fn profiles(mask: &[bool], width: usize, r: Rect) -> (Profile, Profile) {
    let (mut rows, mut cols) = (Profile::new(r.h as usize), Profile::new(r.w as usize));
    for j in 0..r.h as usize {
        let start = (r.y as usize + j) * width + r.x as usize;
        for (i, _) in mask[start..start + r.w as usize].iter().enumerate().filter(|(_, &m)| m) {
            rows.add(j, i as u32);
            cols.add(i, j as u32);
        }
    }
    (rows, cols)
}

/// Tight box of the occupied pixels of `r`, if any.
fn tight(mask: &[bool], width: usize, r: Rect) -> Option<Rect> {
    let (rows, cols) = profiles(mask, width, r);
    let y0 = rows.count.iter().position(|&c| c > 0)?;
    let y1 = rows.count.iter().rposition(|&c| c > 0)?;
    let x0 = cols.count.iter().position(|&c| c > 0)?;
    let x1 = cols.count.iter().rposition(|&c| c > 0)?;
    Some(Rect { x: r.x + x0 as u32, y: r.y + y0 as u32, w: (x1 - x0 + 1) as u32, h: (y1 - y0 + 1) as u32 })
}

/// One side of a candidate cut: its tight box relative to the parent, and its pixel count.
#[derive(Clone, Copy)]
struct Side {
    /// First and last occupied line along the cut axis.
    first: u32,
    last: u32,
    /// Occupied extent across the cut axis.
    lo: u32,
    hi: u32,
    count: u64,
}

impl Side {
    fn extend(self, line: u32, p: &Profile) -> Side {
        let l = line as usize;
        if p.count[l] == 0 {
            return self;
        }
        if self.count == 0 {
            return Side { first: line, last: line, lo: p.lo[l], hi: p.hi[l], count: p.count[l] };
        }
        Side {
            first: self.first.min(line),
            last: self.last.max(line),
            lo: self.lo.min(p.lo[l]),
            hi: self.hi.max(p.hi[l]),
            count: self.count + p.count[l],
        }
    }

    /// Size along and across the cut axis.
    fn dims(&self) -> (u32, u32) {
        (self.last - self.first + 1, self.hi - self.lo + 1)
    }
}

/// A candidate cut: the cost of the two sides, how far from the middle it is, and the sides.
#[derive(Clone, Copy)]
struct Cut {
    total: u64,
    imbalance: u64,
    before: Side,
    after: Side,
    rows: bool,
}

impl Cut {
    fn key(&self) -> (u64, u64) {
        (self.total, self.imbalance)
    }
}

/// The cheapest cut of a profile, and the cheapest among the balanced ones (the cut line in the
/// middle half), ties going to the more central cut.
fn cuts_along(p: &Profile, padding: u32, rows: bool) -> (Option<Cut>, Option<Cut>) {
    let n = p.count.len();
    let empty = Side { first: 0, last: 0, lo: 0, hi: 0, count: 0 };
    let mut suffix = vec![empty; n + 1];
    for l in (0..n).rev() {
        suffix[l] = suffix[l + 1].extend(l as u32, p);
    }
    let side_cost = |s: &Side| {
        let (along, across) = s.dims();
        if rows {
            cost(across, along, padding)
        } else {
            cost(along, across, padding)
        }
    };
    let mut prefix = empty;
    let (mut best, mut balanced): (Option<Cut>, Option<Cut>) = (None, None);
    for (c, &after) in suffix.iter().enumerate().take(n).skip(1) {
        prefix = prefix.extend(c as u32 - 1, p);
        if prefix.count == 0 || after.count == 0 {
            continue;
        }
        let total = side_cost(&prefix) + side_cost(&after);
        let cut = Cut { total, imbalance: (2 * c).abs_diff(n) as u64, before: prefix, after, rows };
        best = cheaper(best, Some(cut));
        if 4 * c >= n && 4 * c <= 3 * n {
            balanced = cheaper(balanced, Some(cut));
        }
    }
    (best, balanced)
}

fn cheaper(a: Option<Cut>, b: Option<Cut>) -> Option<Cut> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.key() < x.key() { y } else { x }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// The two tight boxes of the cut chosen for `r`, if it is to be cut: the cheapest cut when it
/// saves at least 1/[`SIGNIFICANT`] of the cost, else, while the box is sparse, the cheapest
/// balanced cut. Small savings are ignored so that boxes are not peeled one line at a time,
/// which would cost O(area) per line; balanced forced cuts keep the recursion O(log) deep.
fn best_cut(mask: &[bool], width: usize, r: Rect, padding: u32) -> Option<(Rect, Rect)> {
    let (rows, cols) = profiles(mask, width, r);
    let occupied: u64 = rows.count.iter().sum();
    let (best_r, bal_r) = cuts_along(&rows, padding, true);
    let (best_c, bal_c) = cuts_along(&cols, padding, false);
    let parent = cost(r.w, r.h, padding);
    let sparse = (occupied as f64) < MIN_FILL * r.area() as f64;
    let cut = match cheaper(best_r, best_c) {
        Some(b) if parent.saturating_sub(b.total) * SIGNIFICANT >= parent => b,
        Some(b) if sparse => cheaper(bal_r, bal_c).unwrap_or(b),
        _ => return None,
    };
    let to_rect = |s: Side| {
        let (along, across) = s.dims();
        if cut.rows {
            Rect { x: r.x + s.lo, y: r.y + s.first, w: across, h: along }
        } else {
            Rect { x: r.x + s.first, y: r.y + s.lo, w: along, h: across }
        }
    };
    Some((to_rect(cut.before), to_rect(cut.after)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(mask: &[bool], w: usize, rects: &[Rect]) {
        let mut hit = vec![0u8; mask.len()];
        for r in rects {
            for y in r.y..r.y + r.h {
                for x in r.x..r.x + r.w {
                    hit[y as usize * w + x as usize] += 1;
                }
            }
        }
        assert!(hit.iter().all(|&c| c <= 1), "rectangles overlap");
        assert!(mask.iter().zip(&hit).all(|(&m, &c)| !m || c == 1), "a pixel is not covered");
    }

    #[test]
    fn diagonal_is_cut_into_small_boxes() {
        let (w, h) = (300, 200);
        let mut mask = vec![false; w * h];
        for i in 0..200 {
            mask[i * w + i + 50] = true;
        }
        let rects = cover(&mask, w, h, 0);
        check(&mask, w, &rects);
        let area: u64 = rects.iter().map(Rect::area).sum();
        assert!(area as f64 <= 200.0 / MIN_FILL, "area {area}");
    }

    #[test]
    fn long_rectangles_are_split_into_pieces_covering_the_same_pixels() {
        let rects = vec![Rect { x: 0, y: 0, w: 256, h: 9 }, Rect { x: 3, y: 20, w: 17, h: 22 }];
        let out = limit_length(rects.clone(), 0);
        let area = |v: &[Rect]| v.iter().map(Rect::area).sum::<u64>();
        assert_eq!(area(&out), area(&rects));
        let side = (area(&rects) as f64).sqrt().ceil() as u32;
        assert!(out.iter().all(|r| r.w.max(r.h) <= side), "{out:?}");
        // Pieces tile the original strip left to right.
        let strip: Vec<&Rect> = out.iter().filter(|r| r.y == 0).collect();
        assert_eq!(strip.first().unwrap().x, 0);
        for w in strip.windows(2) {
            assert_eq!(w[0].x + w[0].w, w[1].x);
        }
        assert_eq!(strip.last().map(|r| r.x + r.w), Some(256));
        // Nothing to do for compact sets.
        let square = vec![Rect { x: 0, y: 0, w: 10, h: 10 }];
        assert_eq!(limit_length(square.clone(), 1), square);
    }

    #[test]
    fn full_and_empty_masks() {
        assert!(cover(&[false; 12], 4, 3, 0).is_empty());
        assert_eq!(cover(&[true; 12], 4, 3, 0), vec![Rect { x: 0, y: 0, w: 4, h: 3 }]);
    }
}
