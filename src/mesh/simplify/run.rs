//! One greedy run of collapses over a set of triangles.

use std::collections::BinaryHeap;

use glam::DVec3;

use super::overlap::{LatticePts, LatticeTri};
use super::quadric::{Cand, Loc, Quadric};
use super::shared::Shared;
use super::{SimplifyStats, MIN_DET};

use crate::mesh::grid::is_jump;

/// Mutable state of one greedy run over a set of triangles.
pub(super) struct Run<'a, 'b> {
    pub(super) s: &'b Shared<'a>,
    pub(super) movable: Vec<bool>,
    pub(super) tris: Vec<[u32; 3]>,
    /// Upper bound of each triangle's relative error (exact after a scan).
    pub(super) terr: Vec<f64>,
    pub(super) alive: Vec<bool>,
    pub(super) vtris: Vec<Vec<u32>>,
    pub(super) quad: Vec<Quadric>,
    pub(super) stamp: Vec<u32>,
    pub(super) heap: BinaryHeap<Cand>,
    pub(super) stats: SimplifyStats,
    /// Vertices whose star was not one fan at the start (collapses keep the others manifold).
    pub(super) singular: Vec<bool>,
}

/// The fan around a vertex: `None` when its star is not one fan (non-manifold or empty).
pub(super) struct Star {
    /// Neighbours (sorted, unique).
    pub(super) nbrs: Vec<u32>,
    /// The two boundary neighbours when the vertex is on the mesh boundary.
    pub(super) border: Option<[u32; 2]>,
}

impl<'a, 'b> Run<'a, 'b> {
    pub(super) fn new(
        s: &'b Shared<'a>,
        tris: Vec<[u32; 3]>,
        terr: Option<Vec<f64>>,
        movable: Vec<bool>,
    ) -> Self {
        let terr = terr.unwrap_or_else(|| tris.iter().map(|&t| s.max_error(t, f64::INFINITY)).collect());
        let n = s.pos.len();
        let mut vtris = vec![Vec::new(); n];
        let mut quad = vec![Quadric::default(); n];
        for (i, t) in tris.iter().enumerate() {
            for &v in t {
                vtris[v as usize].push(i as u32);
            }
            let p = t.map(|v| s.pos[v as usize]);
            let nrm = (p[1] - p[0]).cross(p[2] - p[0]);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let (len, cl) = (nrm.length(), c.length());
            if len > 0.0 && cl > 0.0 && len.is_finite() {
                let nh = nrm / len;
                // Relative units: distances over the distance of the triangle; weight its solid angle.
                let q = Quadric::plane(nh / cl, -nh.dot(p[0]) / cl, 0.5 * len / (cl * cl));
                for &v in t {
                    quad[v as usize].add(&q);
                }
            }
        }
        let alive = vec![true; tris.len()];
        let mut run = Run {
            s,
            movable,
            tris,
            terr,
            alive,
            vtris,
            quad,
            stamp: vec![0; n],
            heap: BinaryHeap::new(),
            stats: SimplifyStats::default(),
            singular: Vec::new(),
        };
        run.singular = (0..n as u32).map(|v| run.star(v).is_none()).collect();
        run
    }

    pub(super) fn star(&self, v: u32) -> Option<Star> {
        let ts = &self.vtris[v as usize];
        if ts.is_empty() {
            return None;
        }
        // (a, b): the triangle's next two vertices after v, counter-clockwise; sorted by a.
        let mut pairs: Vec<(u32, u32)> = ts
            .iter()
            .map(|&t| {
                let t = self.tris[t as usize];
                let k = t.iter().position(|&w| w == v).unwrap_or(0);
                (t[(k + 1) % 3], t[(k + 2) % 3])
            })
            .collect();
        pairs.sort_unstable();
        let mut b_s: Vec<u32> = pairs.iter().map(|p| p.1).collect();
        b_s.sort_unstable();
        if pairs.windows(2).any(|w| w[0].0 == w[1].0) || b_s.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
        let has_a = |x: u32| pairs.binary_search_by_key(&x, |p| p.0).ok();
        let starts: Vec<u32> = pairs.iter().map(|p| p.0).filter(|a| b_s.binary_search(a).is_err()).collect();
        let ends: Vec<u32> = b_s.iter().copied().filter(|&b| has_a(b).is_none()).collect();
        let first = match (starts.as_slice(), ends.as_slice()) {
            ([], []) => pairs[0].0,
            ([s], [_]) => *s,
            _ => return None,
        };
        // Walk the fan: it must visit every triangle once.
        let mut at = first;
        for step in 0..pairs.len() {
            let k = has_a(at)?;
            at = pairs[k].1;
            if at == first && step + 1 < pairs.len() {
                return None;
            }
        }
        let mut nbrs: Vec<u32> = pairs.iter().map(|p| p.0).collect();
        nbrs.extend(b_s);
        nbrs.sort_unstable();
        nbrs.dedup();
        let border = (!starts.is_empty()).then(|| [starts[0], ends[0]]);
        Some(Star { nbrs, border })
    }

    pub(super) fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut n: Vec<u32> =
            self.vtris[v as usize].iter().flat_map(|&t| self.tris[t as usize]).filter(|&w| w != v).collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Static constraints: may `v` ever collapse onto `u`?
    pub(super) fn allowed(&self, v: u32, u: u32) -> bool {
        let s = self.s;
        let sv = s.sides[v as usize];
        if sv == 0 {
            return true;
        }
        match (s.loc[v as usize], s.loc[u as usize]) {
            (Loc::Lattice { g, .. }, Loc::Lattice { g: gu, .. }) => g == gu && s.sides[u as usize] & sv == sv,
            _ => false,
        }
    }

    pub(super) fn cost(&self, v: u32, u: u32) -> f64 {
        let (pv, pu) = (self.s.pos[v as usize], self.s.pos[u as usize]);
        let d = self.s.dist[v as usize];
        self.quad[v as usize].eval(pu).max(0.0) + 1e-9 * (pu - pv).length_squared() / (d * d)
    }

    /// Allowed targets of `v`, cheapest first (ties by index).
    pub(super) fn targets(&self, v: u32) -> Vec<(f64, u32)> {
        let mut t: Vec<(f64, u32)> = self
            .neighbours(v)
            .into_iter()
            .filter(|&u| self.allowed(v, u))
            .map(|u| (self.cost(v, u), u))
            .collect();
        t.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        t
    }

    /// (Re)queue `v` under its cheapest target; older entries of `v` become stale.
    pub(super) fn push(&mut self, v: u32) {
        let vi = v as usize;
        self.stamp[vi] = self.stamp[vi].wrapping_add(1);
        if !self.movable[vi] {
            return;
        }
        // The cheapest allowed neighbour (ties by index), without building the sorted list.
        let mut best: Option<(f64, u32)> = None;
        for &t in &self.vtris[vi] {
            for u in self.tris[t as usize] {
                if u == v || !self.allowed(v, u) {
                    continue;
                }
                let c = (self.cost(v, u), u);
                let better = match best {
                    None => true,
                    Some(b) => c.0.total_cmp(&b.0).then(c.1.cmp(&b.1)).is_lt(),
                };
                if better {
                    best = Some(c);
                }
            }
        }
        if let Some((cost, u)) = best {
            self.heap.push(Cand { cost, v, u, stamp: self.stamp[vi] });
        }
    }

    /// All checks of the collapse `v → u`; when acceptable, the error bounds of the triangles it
    /// changes (in the order of `v`'s star, removed triangles skipped).
    pub(super) fn check(&mut self, v: u32, u: u32) -> Option<Vec<f64>> {
        let sv = self.star(v)?;
        if self.singular[u as usize] {
            return None;
        }
        let su_nbrs = self.neighbours(u);
        if !sv.nbrs.contains(&u) {
            return None;
        }
        self.border_move(&sv, v, u)?;
        // Link condition.
        let star = &self.vtris[v as usize];
        let opposite = star.iter().filter(|&&t| self.tris[t as usize].contains(&u)).count();
        let common = sv.nbrs.iter().filter(|w| su_nbrs.binary_search(w).is_ok()).count();
        if common != opposite || opposite == 0 {
            return None;
        }
        let new: Vec<[u32; 3]> = star
            .iter()
            .map(|&t| self.tris[t as usize])
            .filter(|t| !t.contains(&u))
            .map(|t| t.map(|w| if w == v { u } else { w }))
            .collect();
        let plane = self.new_shapes(u, &new)?;
        if let Some(bound) = self.planar_bound(v, &sv, plane) {
            self.stats.planar += 1;
            return Some(vec![bound; new.len()]);
        }
        self.stats.tested += 1;
        self.check_pixels(v, &new)
    }

    /// Boundary vertices move only along a straight boundary: `None` when `v → u` would not.
    fn border_move(&self, sv: &Star, v: u32, u: u32) -> Option<()> {
        let s = self.s;
        let Some([p, q]) = sv.border else { return Some(()) };
        let w = if p == u {
            q
        } else if q == u {
            p
        } else {
            return None;
        };
        let (lv, lu, lw) = (s.lattice(v)?, s.lattice(u)?, s.lattice(w)?);
        if lv.0 != lu.0 || lv.0 != lw.0 {
            return None;
        }
        let (du, dw) = ((lu.1 - lv.1, lu.2 - lv.2), (lw.1 - lv.1, lw.2 - lv.2));
        let straight = if s.cube { du.0 * dw.1 - du.1 * dw.0 == 0 } else { du.0 == 0 && dw.0 == 0 };
        (straight && du.0 * dw.0 + du.1 * dw.1 < 0).then_some(())
    }

    /// The geometry of the new triangles around `u`: each counter-clockwise from the centre, not
    /// edge-on (three rays nearly in one plane through the centre: the hit distance would be
    /// ill-conditioned), without a depth jump and within the angle cap. Their largest triangle's
    /// plane `(n, n·p)`; `None` when one fails.
    fn new_shapes(&self, u: u32, new: &[[u32; 3]]) -> Option<(DVec3, f64)> {
        let s = self.s;
        let du = s.dist[u as usize];
        let mut plane = (DVec3::ZERO, 0.0);
        for t in new {
            let p = t.map(|w| s.pos[w as usize]);
            let d = t.map(|w| s.pos[w as usize] / s.dist[w as usize]);
            if !(d[0].dot(d[1].cross(d[2])) < -MIN_DET) {
                return None;
            }
            if t.iter().any(|&w| w != u && is_jump(du, s.dist[w as usize])) {
                return None;
            }
            if let Some(c) = s.cos_cap {
                if d[0].dot(d[1]) < c || d[1].dot(d[2]) < c || d[2].dot(d[0]) < c {
                    return None;
                }
            }
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.length_squared() > plane.0.length_squared() {
                plane = (n, n.dot(p[0]));
            }
        }
        Some(plane)
    }

    /// Planar shortcut: when the whole star of `v` lies within relative δ of one plane `n·x = k`
    /// (along the rays), the old and the new triangles are both within δ of it over the same
    /// region (the inverse hit distance is a positive combination of the vertices'), so every
    /// pixel's error grows by at most the factor (1+δ)/(1−δ) over the star's known bound: that
    /// bound, when within the tolerance.
    fn planar_bound(&self, v: u32, sv: &Star, (n, k): (DVec3, f64)) -> Option<f64> {
        let s = self.s;
        if !k.is_finite() || k == 0.0 {
            return None;
        }
        let delta = sv
            .nbrs
            .iter()
            .chain([&v])
            .map(|&w| (n.dot(s.pos[w as usize]) / k - 1.0).abs())
            .fold(0.0, f64::max);
        if delta > 1e-3 * s.e {
            return None;
        }
        let m = self.vtris[v as usize].iter().map(|&t| self.terr[t as usize]).fold(0.0, f64::max);
        let bound = (1.0 + m) * (1.0 + delta) / (1.0 - delta) - 1.0;
        (bound <= s.e).then_some(bound)
    }

    /// The pixel test of the triangles `new` that replace the star of `v`.
    pub(super) fn check_pixels(&self, v: u32, new: &[[u32; 3]]) -> Option<Vec<f64>> {
        let s = self.s;
        let star = &self.vtris[v as usize];
        // One cube face throughout: bound pairs of new and old triangles, scan only where needed.
        let same_face = |t: &[u32; 3]| -> Option<(usize, [(i64, i64); 3])> {
            let l = t.map(|w| s.lattice(w));
            match l {
                [Some(a), Some(b), Some(c)] if a.0 == b.0 && b.0 == c.0 => {
                    Some((a.0, [(a.1, a.2), (b.1, b.2), (c.1, c.2)]))
                }
                _ => None,
            }
        };
        if s.cube {
            let olds: Option<Vec<(usize, LatticePts, f64)>> = star
                .iter()
                .map(|&t| same_face(&self.tris[t as usize]).map(|(g, p)| (g, p, self.terr[t as usize])))
                .collect();
            if let Some(olds) = olds.filter(|o| o.iter().all(|x| x.0 == o[0].0)) {
                let g = &s.grids[olds[0].0];
                let old: Option<Vec<(LatticeTri, f64)>> =
                    olds.iter().map(|(_, p, m)| LatticeTri::new(g, *p).map(|t| (t, *m))).collect();
                let newt: Option<Vec<LatticeTri>> =
                    new.iter().map(|t| same_face(t).and_then(|(_, p)| LatticeTri::new(g, p))).collect();
                if let (Some(old), Some(newt)) = (old, newt) {
                    return s.pairwise_bound(g, &newt, &old);
                }
            }
        }
        let mut errs = Vec::with_capacity(new.len());
        for &t in new {
            let e = s.max_error(t, s.e);
            if !(e <= s.e) {
                return None;
            }
            errs.push(e);
        }
        Some(errs)
    }

    pub(super) fn collapse(&mut self, v: u32, u: u32, errs: &[f64]) {
        let star = std::mem::take(&mut self.vtris[v as usize]);
        let mut touched = vec![u];
        let mut errs = errs.iter();
        for t in star {
            let tri = self.tris[t as usize];
            touched.extend(tri.iter().copied().filter(|&w| w != v));
            if tri.contains(&u) {
                self.alive[t as usize] = false;
                for w in tri.into_iter().filter(|&w| w != v) {
                    let list = &mut self.vtris[w as usize];
                    if let Some(k) = list.iter().position(|&x| x == t) {
                        list.remove(k);
                    }
                }
            } else {
                self.tris[t as usize] = tri.map(|w| if w == v { u } else { w });
                self.terr[t as usize] = errs.next().copied().unwrap_or(f64::INFINITY);
                self.vtris[u as usize].push(t);
            }
        }
        let qv = self.quad[v as usize];
        self.quad[u as usize].add(&qv);
        self.movable[v as usize] = false;
        self.stats.collapses += 1;
        touched.sort_unstable();
        touched.dedup();
        for w in touched {
            self.push(w);
        }
    }

    pub(super) fn run(&mut self, seeds: impl Iterator<Item = u32>) {
        for v in seeds {
            self.push(v);
        }
        while let Some(c) = self.heap.pop() {
            if !self.movable[c.v as usize] || self.stamp[c.v as usize] != c.stamp {
                continue;
            }
            // The cheapest acceptable target (the queued one first: `v`'s star is unchanged since it
            // was queued, so it is still the cheapest); none: `v` waits until its star changes.
            if let Some(errs) = self.check(c.v, c.u) {
                self.collapse(c.v, c.u, &errs);
                continue;
            }
            for (_, u) in self.targets(c.v).into_iter().filter(|&(_, u)| u != c.u) {
                if let Some(errs) = self.check(c.v, u) {
                    self.collapse(c.v, u, &errs);
                    break;
                }
            }
        }
    }

    pub(super) fn alive_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.tris.iter().zip(&self.alive).filter(|(_, &a)| a).map(|(t, _)| *t)
    }
}
