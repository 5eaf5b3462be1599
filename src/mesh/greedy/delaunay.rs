//! The triangulation of the greedy mesher: exact integer predicates and the half-edge
//! operations (insertion, edge split, flips back to Delaunay).

use super::{Mesher, Scan, FLAT, P};

/// Edge function; positive for every triangle of the triangulation (its vertices `a, b, c` in order).
#[inline]
pub(super) fn edge(a: P, b: P, c: P) -> i64 {
    (b.0 - c.0) * (a.1 - c.1) - (b.1 - c.1) * (a.0 - c.0)
}

/// `p` strictly inside the circumcircle of `a, b, c` (orientation of [`edge`]); exact.
#[inline]
pub(super) fn in_circle(a: P, b: P, c: P, p: P) -> bool {
    let (dx, dy) = ((a.0 - p.0) as i128, (a.1 - p.1) as i128);
    let (ex, ey) = ((b.0 - p.0) as i128, (b.1 - p.1) as i128);
    let (fx, fy) = ((c.0 - p.0) as i128, (c.1 - p.1) as i128);
    let ap = dx * dx + dy * dy;
    let bp = ex * ex + ey * ey;
    let cp = fx * fx + fy * fy;
    dx * (ey * cp - bp * fy) - dy * (ex * cp - bp * fx) + ap * (ex * fy - ey * fx) < 0
}

impl Mesher<'_> {
    /// Add (or overwrite slot `at`, a half-edge index) a triangle, with its scan when known;
    /// returns its first half-edge.
    pub(super) fn add_triangle(
        &mut self,
        v: [u32; 3],
        h: [i32; 3],
        at: Option<usize>,
        scan: Option<Scan>,
    ) -> usize {
        let e = at.unwrap_or(self.tri.len());
        let t = e / 3;
        if e == self.tri.len() {
            self.tri.extend_from_slice(&v);
            self.half.extend_from_slice(&h);
            self.scans.push(scan.unwrap_or_default());
            self.fresh.push(scan.is_some());
            self.qpos.push(-1);
        } else {
            self.tri[e..e + 3].copy_from_slice(&v);
            self.half[e..e + 3].copy_from_slice(&h);
            self.scans[t] = scan.unwrap_or_default();
            self.fresh[t] = scan.is_some();
        }
        for (k, &o) in h.iter().enumerate() {
            if o >= 0 {
                self.half[o as usize] = (e + k) as i32;
            }
        }
        self.pending.push(t as u32);
        e
    }

    /// Flip half-edge `a` (with the new triangles' scans when known) when it has a twin and its quad
    /// is strictly convex; returns the new triangles' first half-edges. The new diagonal is half-edge
    /// 0 of the first, whose outer edges are 1 and 2 (likewise the second's).
    pub(super) fn flip(&mut self, a: usize, scans: Option<(Scan, Scan)>) -> Option<(usize, usize)> {
        let b = self.half[a];
        if b < 0 {
            return None;
        }
        let b = b as usize;
        let (a0, b0) = (a - a % 3, b - b % 3);
        let (al, ar) = (a0 + (a + 1) % 3, a0 + (a + 2) % 3);
        let (bl, br) = (b0 + (b + 2) % 3, b0 + (b + 1) % 3);
        let (p0, pr, pl, p1) = (self.tri[ar], self.tri[a], self.tri[al], self.tri[bl]);
        let q = |v: u32| self.pts[v as usize];
        if edge(q(p0), q(p1), q(pl)) <= 0 || edge(q(p1), q(p0), q(pr)) <= 0 {
            return None;
        }
        let (hal, har, hbl, hbr) = (self.half[al], self.half[ar], self.half[bl], self.half[br]);
        self.queue_remove(a0 / 3);
        self.queue_remove(b0 / 3);
        let (s0, s1) = (scans.map(|s| s.0), scans.map(|s| s.1));
        let t0 = self.add_triangle([p0, p1, pl], [-1, hbl, hal], Some(a0), s0);
        let t1 = self.add_triangle([p1, p0, pr], [t0 as i32, har, hbr], Some(b0), s1);
        Some((t0, t1))
    }

    /// The new point `pn` lies on half-edge `a` of the (popped) triangle: split it and its twin.
    pub(super) fn split_edge(&mut self, pn: u32, a: usize) {
        let a0 = a - a % 3;
        let (al, ar) = (a0 + (a + 1) % 3, a0 + (a + 2) % 3);
        let (p0, pr, pl) = (self.tri[ar], self.tri[a], self.tri[al]);
        let (hal, har) = (self.half[al], self.half[ar]);
        let b = self.half[a];
        if b < 0 {
            let t0 = self.add_triangle([pn, p0, pr], [-1, har, -1], Some(a0), None);
            let t1 = self.add_triangle([p0, pn, pl], [t0 as i32, -1, hal], None, None);
            self.legalize(t0 + 1);
            self.legalize(t1 + 2);
            return;
        }
        let b = b as usize;
        let b0 = b - b % 3;
        let (bl, br) = (b0 + (b + 2) % 3, b0 + (b + 1) % 3);
        let p1 = self.tri[bl];
        let (hbl, hbr) = (self.half[bl], self.half[br]);
        self.queue_remove(b0 / 3);
        let t0 = self.add_triangle([p0, pr, pn], [har, -1, -1], Some(a0), None);
        let t1 = self.add_triangle([pr, p1, pn], [hbr, -1, t0 as i32 + 1], Some(b0), None);
        let t2 = self.add_triangle([p1, pl, pn], [hbl, -1, t1 as i32 + 1], None, None);
        let t3 = self.add_triangle([pl, p0, pn], [hal, t0 as i32 + 2, t2 as i32 + 1], None, None);
        self.legalize(t0);
        self.legalize(t1);
        self.legalize(t2);
        self.legalize(t3);
    }

    /// Flip half-edge `a` when the other diagonal of its quad fits the data better, recursively.
    ///
    /// *Data-dependent* (Garland–Heckbert's variant, with the maximum error): flip when the flipped
    /// pair's larger error is smaller. Where both diagonals are well within the tolerance the Delaunay
    /// criterion decides, so flat regions keep well-shaped triangles. A quad that is not strictly
    /// convex is never flipped.
    pub(super) fn legalize(&mut self, a: usize) {
        // Depth-first like the recursive formulation, with an explicit stack (cascades can be long).
        let mut stack = vec![a];
        // Each flip improves its pair (error, then width), so cascades end; the budget is a backstop.
        let mut budget = 64 + 4 * self.tri.len();
        while let Some(a) = stack.pop() {
            if budget == 0 {
                break;
            }
            budget -= 1;
            self.legalize_one(a, &mut stack);
        }
    }

    /// One edge of [`Self::legalize`]; pushes the edges a flip exposes.
    pub(super) fn legalize_one(&mut self, a: usize, stack: &mut Vec<usize>) {
        let b = self.half[a];
        if b < 0 {
            return;
        }
        let b = b as usize;
        let (a0, b0) = (a - a % 3, b - b % 3);
        let (al, ar) = (a0 + (a + 1) % 3, a0 + (a + 2) % 3);
        let bl = b0 + (b + 2) % 3;
        let (p0, pr, pl, p1) = (self.tri[ar], self.tri[a], self.tri[al], self.tri[bl]);
        let q = |v: u32| self.pts[v as usize];
        let (n0, n1) = ([q(p0), q(p1), q(pl)], [q(p1), q(p0), q(pr)]);
        if edge(n0[0], n0[1], n0[2]) <= 0 || edge(n1[0], n1[1], n1[2]) <= 0 {
            return;
        }
        let delaunay = in_circle(q(p0), q(pr), q(pl), q(p1));
        let (qa, qb) = ([q(p0), q(pr), q(pl)], [q(p1), q(pl), q(pr)]);
        let old = self.ensure_scanned(a0 / 3).err.max(self.ensure_scanned(b0 / 3).err);
        let (e, floor) = (self.e, FLAT * self.e);
        // With an angle cap: the error rule may not flip into a pair wider than the cap unless it is
        // narrower than the current pair and splittable; a pair over the cap flips to a narrower one
        // whenever both new triangles stay within the tolerance; and a triangle over the cap that
        // holds no lattice point to split at (a sliver along a long edge) is flipped away whatever
        // the error — so no output triangle exceeds the cap while a flip can narrow it.
        let (mut err_rule, mut cap_rule) = (old > floor || delaunay, false);
        if let Some(cap) = self.cap {
            let wide = |t: [P; 3]| self.extent(t[0], t[1], t[2]);
            let was = wide(qa).max(wide(qb));
            let now = wide(n0).max(wide(n1));
            // A triangle over the cap with no lattice point to split at can only go by a flip.
            let stuck = |t: [P; 3]| wide(t) > cap && self.split_point(t[0], t[1], t[2]).is_none();
            if now < was && (stuck(qa) || stuck(qb)) {
                // Flipped regardless of the error: the new triangles are refined like any other.
                if let Some((t0, t1)) = self.flip(a, None) {
                    stack.push(t1 + 2);
                    stack.push(t0 + 1);
                }
                return;
            }
            err_rule &= now <= cap || (now <= was && !stuck(n0) && !stuck(n1));
            cap_rule = was > cap && now < was;
        }
        if !err_rule && !cap_rule {
            return;
        }
        // Scans stop as soon as they exceed what any applicable rule accepts.
        let err_limit = if old <= floor { floor } else { old };
        let limit = match (err_rule, cap_rule) {
            (true, true) => err_limit.max(e),
            (true, false) => err_limit,
            _ => e,
        };
        let by_err = |x: f64| err_rule && (x < err_limit || (old <= floor && x <= floor));
        let by_cap = |x: f64| cap_rule && x <= e;
        let s0 = self.scan(n0, limit);
        if !(by_err(s0.err) || by_cap(s0.err)) {
            return;
        }
        let s1 = self.scan(n1, limit);
        let both_err = by_err(s0.err) && by_err(s1.err);
        let both_cap = by_cap(s0.err) && by_cap(s1.err);
        if !(both_err || both_cap) {
            return;
        }
        let (t0, t1) = self.flip(a, Some((s0, s1))).expect("a convex quad with a twin");
        stack.push(t1 + 2);
        stack.push(t0 + 1);
    }
}
