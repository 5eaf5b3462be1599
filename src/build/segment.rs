//! From links to layers: pixels joined by smooth links form segments; jumps between segments say
//! which occludes which; the longest chain of occlusions gives each segment its level (0 =
//! background), which is the minimal layering: a chain of k occluders needs k + 1 layers.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::edges::{EdgeOptions, Link, Links};
use super::graph::Neighbours;

/// Union-find with path halving and union by size.
struct Dsu {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl Dsu {
    fn new(n: usize) -> Self {
        Dsu { parent: (0..n as u32).collect(), size: vec![1; n] }
    }
    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let g = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = g;
            x = g;
        }
        x
    }
    fn union(&mut self, a: u32, b: u32) {
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
    /// Occlusion relations kept (near, far, border length).
    pub occludes: Vec<(u32, u32, u32)>,
}

/// Tuning of the segmentation.
#[derive(Clone, Copy, Debug)]
pub struct SegmentOptions {
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
    // Each undirected pair once: right, down, down-right, down-left. Links are classified in
    // parallel (bit i of each mask = HALF[i]); the union-find that follows is a cheap serial pass.
    const HALF: [usize; 4] = [0, 2, 4, 5];
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
    let mean: Vec<f64> = depth_sum.iter().zip(&size).map(|(s, &c)| s / c as f64).collect();
    // Keep a relation only if it is long enough and dominant over its reverse.
    let mut occludes: Vec<(u32, u32, u32)> = jumps
        .iter()
        .filter(|(&(a, b), &c)| c >= o.min_border && c > jumps.get(&(b, a)).copied().unwrap_or(0))
        .map(|(&(a, b), &c)| (a, b, c))
        .collect();
    occludes.sort_unstable();
    let level = levels(count, &mean, &size, &occludes, &folds);
    Segments { id, level, size, occludes }
}

/// Longest occlusion chain per segment, processed far to near so cycles (which real data can
/// produce) are broken in favour of the mean depth. A segment that occludes nothing takes the
/// level of the larger segment it shares the longest fold with: a box face next to the rest of
/// the box stays with the box, while the floor a box stands on does not follow the box.
fn levels(
    count: usize,
    mean: &[f64],
    size: &[u32],
    occludes: &[(u32, u32, u32)],
    folds: &HashMap<(u32, u32), u32>,
) -> Vec<u32> {
    let mut order: Vec<u32> = (0..count as u32).collect();
    order.sort_by(|&a, &b| mean[b as usize].total_cmp(&mean[a as usize]).then(a.cmp(&b)));
    let mut rank = vec![0usize; count];
    for (r, &s) in order.iter().enumerate() {
        rank[s as usize] = r;
    }
    let mut behind: Vec<Vec<u32>> = vec![Vec::new(); count];
    for &(near, far, _) in occludes {
        behind[near as usize].push(far);
    }
    let mut level = vec![0u32; count];
    let mut occluder = vec![false; count];
    for &s in &order {
        for &f in &behind[s as usize] {
            if rank[f as usize] < rank[s as usize] {
                occluder[s as usize] = true;
                level[s as usize] = level[s as usize].max(level[f as usize] + 1);
            }
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
            if let Some(&(_, other)) = attached[s].first() {
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
