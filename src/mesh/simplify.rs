//! Second stage (not part of the `.pomcmesh` encoding): greedy half-edge collapses `v → u` of the
//! stitched quadtree mesh, ordered by relative Garland–Heckbert quadrics, each accepted only when every
//! pixel its new triangles cover stays within the tolerance along its ray, nothing flips or crosses a
//! jump, and the mesh stays a watertight 2-manifold. Constraints, error bounds and parallel parts:
//! `docs/mesh.md`, "Simplification".

// `!(x <= limit)` is deliberate throughout: a NaN (an invalid pixel, a degenerate plane) must fail.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use super::accuracy::{candidates, ray_hit};
use super::grid::{is_jump, Grid, PlaneDot};
use super::{is_pole, LayerMesh};
use crate::mapping::{AnyMapping, DirTable};

/// Tolerances of the simplification stage.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifyOptions {
    /// Maximum relative distance along each pixel's ray between the simplified mesh and the sample.
    pub max_error: f64,
    /// Cap on the angle between the rays of two vertices of a triangle (texture distortion), degrees.
    pub max_angle_deg: Option<f64>,
    /// Mesh clean cube faces (every pixel valid, no depth jump) by greedy insertion
    /// (`super::greedy`) instead of quadtree + collapses: faster and fewer triangles there.
    pub greedy: bool,
}

/// Counters of one run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SimplifyStats {
    /// Half-edge collapses performed (one vertex removed each).
    pub collapses: usize,
    /// Collapses that reached the pixel test.
    pub tested: usize,
    /// Collapses accepted by the planar shortcut (no pixel scan).
    pub planar: usize,
    /// Wall-clock milliseconds of the per-lattice phase and of the whole-mesh phase.
    pub lattice_ms: f64,
    /// Milliseconds of the whole-mesh phase (vertices whose stars span lattices or stitching).
    pub stitch_ms: f64,
}

/// Smallest `|det[d0, d1, d2]|` (unit rays) of a created triangle: twice its solid angle, about. A
/// half-pixel stitching strip one pixel long on a 6×16384² cube is ~5e-9; an edge-on triangle is ~1e-16.
const MIN_DET: f64 = 1e-12;

/// A pair (new, old) of triangles is bounded without a scan when their hit distances differ by at
/// most this fraction of the tolerance over their intersection.
const PAIR_SKIP: f64 = 0.05;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Loc {
    Pole,
    Lattice { g: u8, x: u32, y: u32 },
}

#[derive(Clone, Copy, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    fn plane(n: DVec3, d: f64, w: f64) -> Quadric {
        let (a, b, c) = (n.x, n.y, n.z);
        Quadric([a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d].map(|v| v * w))
    }
    fn add(&mut self, o: &Quadric) {
        for k in 0..10 {
            self.0[k] += o.0[k];
        }
    }
    /// `Σ w (n·p − d)²` with the planes stored as `(n, −d)`.
    fn eval(&self, p: DVec3) -> f64 {
        let q = &self.0;
        let (x, y, z) = (p.x, p.y, p.z);
        q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9]
    }
}

#[derive(Clone, Copy, Debug)]
struct Cand {
    cost: f64,
    v: u32,
    u: u32,
    stamp: u32,
}

impl PartialEq for Cand {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Cand {}
impl PartialOrd for Cand {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cand {
    /// Reversed: `BinaryHeap` pops the cheapest, then the lowest `(v, u)`.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then(o.v.cmp(&self.v))
            .then(o.u.cmp(&self.u))
            .then(o.stamp.cmp(&self.stamp))
    }
}

/// Read-only description of the vertices shared by all runs.
struct Shared<'a> {
    grids: &'a [Grid],
    mapping: &'a AnyMapping,
    dirs: DirTable,
    cube: bool,
    e: f64,
    cos_cap: Option<f64>,
    pos: Vec<DVec3>,
    dist: Vec<f64>,
    loc: Vec<Loc>,
    /// Lattice sides the vertex lies on (bit k: side k; 0 top, 1 right, 2 bottom, 3 left).
    sides: Vec<u8>,
}

impl Shared<'_> {
    /// Lattice point of canvas pixel `(x, y)`.
    fn grid_of(&self, x: usize, y: usize) -> Option<(usize, usize, usize)> {
        self.grids.iter().enumerate().find_map(|(k, g)| {
            (x >= g.ox && x < g.ox + g.w && y >= g.oy && y < g.oy + g.h).then(|| (k, x - g.ox, y - g.oy))
        })
    }

    fn lattice(&self, v: u32) -> Option<(usize, i64, i64)> {
        match self.loc[v as usize] {
            Loc::Lattice { g, x, y } => Some((g as usize, x as i64, y as i64)),
            Loc::Pole => None,
        }
    }

    /// Largest relative error over the pixels triangle `t` covers (`∞` when it covers an invalid
    /// pixel); the scan stops as soon as it exceeds `limit`.
    fn max_error(&self, t: [u32; 3], limit: f64) -> f64 {
        let l = t.map(|v| self.lattice(v));
        if let (true, [Some(a), Some(b), Some(c)]) = (self.cube, l) {
            if a.0 == b.0 && b.0 == c.0 {
                return self.lattice_max(&self.grids[a.0], (a.1, a.2), (b.1, b.2), (c.1, c.2), limit);
            }
        }
        self.raycast_max(t.map(|v| self.pos[v as usize]), limit)
    }

    /// Exact scan of a triangle of one cube-face lattice: its lattice points, against its plane.
    fn lattice_max(&self, g: &Grid, a: (i64, i64), b: (i64, i64), c: (i64, i64), limit: f64) -> f64 {
        let Some(lt) = LatticeTri::new(g, [a, b, c]) else { return f64::INFINITY };
        // A sparse pass first: a failing triangle usually fails somewhere on a coarse sub-lattice.
        if lt.area > 512 {
            let m = self.raster(g, &lt, &[], 4, limit);
            if m > limit {
                return m;
            }
        }
        self.raster(g, &lt, &[], 1, limit)
    }

    /// Largest error, against the plane of `t`, over the lattice points inside `t` and inside every
    /// triangle of `clip` (all counter-clockwise in lattice coordinates), on every `stride`-th row and
    /// column; stops above `limit` (an invalid pixel counts as `∞`).
    fn raster(&self, g: &Grid, t: &LatticeTri, clip: &[&LatticeTri], stride: i64, limit: f64) -> f64 {
        let (mut x0, mut y0, mut x1, mut y1) = t.bbox();
        for c in clip {
            let b = c.bbox();
            (x0, y0, x1, y1) = (x0.max(b.0), y0.max(b.1), x1.min(b.2), y1.min(b.3));
        }
        let PlaneDot::Affine { a: da, bx, by } = t.dot else { return f64::INFINITY };
        let k = t.k;
        // Each edge as A·x + B(y) ≥ 0 with B(y) = B0 + C·y; row intervals by a float estimate
        // corrected with exact integer arithmetic.
        let mut edges: Vec<(i64, i64, i64, f64)> = Vec::with_capacity(3 + 3 * clip.len());
        for p in std::iter::once(&t.p).chain(clip.iter().map(|c| &c.p)) {
            for i in 0..3 {
                let (a, b) = (p[i], p[(i + 1) % 3]);
                // (b − a) × (q − a) = (b.0 − a.0)(y − a.1) − (b.1 − a.1)(x − a.0).
                let aa = a.1 - b.1;
                let c = b.0 - a.0;
                let b0 = -c * a.1 + (b.1 - a.1) * a.0;
                edges.push((aa, b0, c, if aa != 0 { 1.0 / aa as f64 } else { 0.0 }));
            }
        }
        let mut worst = 0.0f64;
        let mut y = y0;
        while y <= y1 {
            let (mut lo, mut hi) = (x0, x1);
            for &(aa, b0, c, inv) in &edges {
                let bb = b0 + c * y;
                if aa > 0 {
                    let mut x = (-(bb as f64) * inv).ceil() as i64;
                    while aa * x + bb < 0 {
                        x += 1;
                    }
                    while aa * (x - 1) + bb >= 0 {
                        x -= 1;
                    }
                    lo = lo.max(x);
                } else if aa < 0 {
                    let mut x = (-(bb as f64) * inv).floor() as i64;
                    while aa * x + bb < 0 {
                        x -= 1;
                    }
                    while aa * (x + 1) + bb >= 0 {
                        x += 1;
                    }
                    hi = hi.min(x);
                } else if bb < 0 {
                    lo = hi + 1;
                }
                if lo > hi {
                    break;
                }
            }
            if stride > 1 {
                lo += (stride - lo.rem_euclid(stride)) % stride;
            }
            let row = y as usize * g.w;
            let dy = da + by * y as f64;
            if lo <= hi {
                // Branch-free over the row (vectorises): with `dot = n·r`, the plane's λ is `k/dot`
                // and the relative error `|k − λ·dot| / (λ·dot)` (the plane must be in front: k/dot > 0).
                let lams = &g.lambda[row + lo as usize..=row + hi as usize];
                let (mut rmax, mut bad) = (0.0f64, false);
                for (i, &l) in lams.iter().enumerate().step_by(stride as usize) {
                    let lam = l as f64;
                    let dot = dy + bx * (lo + i as i64) as f64;
                    let e = (k - lam * dot).abs() / (lam * dot.abs());
                    // NaN (an invalid pixel) fails too.
                    bad |= !(e <= limit) | !(k * dot > 0.0);
                    rmax = rmax.max(e);
                }
                if bad {
                    return f64::INFINITY;
                }
                worst = worst.max(rmax);
            }
            y += stride;
        }
        worst
    }

    /// Error bound of the new lattice triangles `new` replacing `old` (same lattice, same region), or
    /// `None` when some pixel exceeds the tolerance. Each pair (new `T`, old `O`) is bounded without
    /// scanning when `O`'s bound `M` and the ratio `q = t_T/t_O` of hit distances over `T ∩ O` (a
    /// linear-fractional function of the lattice position: extreme at the polygon's vertices) give
    /// `(1+M)·q − 1 ≤ E` and `1 − (1−M)·q ≥ −E` with `q` within 1e-3·E of 1; otherwise `T ∩ O` is scanned.
    fn pairwise_bound(&self, g: &Grid, new: &[LatticeTri], old: &[(LatticeTri, f64)]) -> Option<Vec<f64>> {
        let e = self.e;
        let mut out = Vec::with_capacity(new.len());
        for t in new {
            let mut bound = 0.0f64;
            for (o, m) in old {
                // Interiors disjoint: every pixel of `T` on `O` is also on an old triangle that
                // overlaps `T` with positive area, and is checked there.
                if disjoint(t, o) {
                    continue;
                }
                let poly = clip(t, o);
                if poly.len() >= 3 {
                    let (mut qmin, mut qmax) = (f64::INFINITY, f64::NEG_INFINITY);
                    for &(x, y) in &poly {
                        // t_T / t_O = (k_T / dot_T) / (k_O / dot_O).
                        let q = (t.k * o.dot_at(x, y)) / (o.k * t.dot_at(x, y));
                        qmin = qmin.min(q);
                        qmax = qmax.max(q);
                    }
                    let b = ((1.0 + m) * qmax - 1.0).max(1.0 - (1.0 - m) * qmin);
                    if b <= e && (qmax - 1.0).max(1.0 - qmin) <= PAIR_SKIP * e {
                        bound = bound.max(b);
                        continue;
                    }
                }
                let s = self.raster(g, t, &[o], 1, e);
                if !(s <= e) {
                    return None;
                }
                bound = bound.max(s);
            }
            out.push(bound);
        }
        Some(out)
    }

    /// Ray-cast scan over the canvas candidates of a triangle (any mapping); stops above `limit`.
    fn raycast_max(&self, p: [DVec3; 3], limit: f64) -> f64 {
        let mut worst = 0.0f64;
        for [x0, y0, x1, y1] in candidates(self.mapping, p) {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let Some(t) = ray_hit(self.dirs.get(x, y), p) else { continue };
                    let Some((k, lx, ly)) = self.grid_of(x, y) else { return f64::INFINITY };
                    let d = self.grids[k].depth_at(lx, ly);
                    let e = (t - d).abs() / d;
                    if !(e <= limit) {
                        return if e.is_nan() { f64::INFINITY } else { e };
                    }
                    worst = worst.max(e);
                }
            }
        }
        worst
    }
}

/// Three lattice points.
type LatticePts = [(i64, i64); 3];

/// A triangle of one lattice, counter-clockwise in lattice coordinates, with its plane.
struct LatticeTri {
    p: [(i64, i64); 3],
    area: i64,
    dot: PlaneDot<'static>,
    k: f64,
}

impl LatticeTri {
    fn new(g: &Grid, p: [(i64, i64); 3]) -> Option<LatticeTri> {
        let [a, b, c] = p;
        let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if area == 0 {
            return None;
        }
        let p = if area > 0 { [a, b, c] } else { [a, c, b] };
        let pt = |q: (i64, i64)| g.point(q.0 as usize, q.1 as usize);
        let (pa, pb, pc) = (pt(p[0]), pt(p[1]), pt(p[2]));
        let n = (pb - pa).cross(pc - pa);
        let k = n.dot(pa);
        if !(n.length_squared() > 0.0 && k.is_finite() && k != 0.0) {
            return None;
        }
        let dot = match g.rays.plane_dot(n) {
            PlaneDot::Affine { a, bx, by } => PlaneDot::Affine { a, bx, by },
            PlaneDot::Rays { .. } => return None,
        };
        Some(LatticeTri { p, area: area.abs(), dot, k })
    }

    fn bbox(&self) -> (i64, i64, i64, i64) {
        let p = &self.p;
        (
            p[0].0.min(p[1].0).min(p[2].0),
            p[0].1.min(p[1].1).min(p[2].1),
            p[0].0.max(p[1].0).max(p[2].0),
            p[0].1.max(p[1].1).max(p[2].1),
        )
    }

    /// `n·r` at a continuous lattice position.
    fn dot_at(&self, x: f64, y: f64) -> f64 {
        match self.dot {
            PlaneDot::Affine { a, bx, by } => a + bx * x + by * y,
            PlaneDot::Rays { .. } => f64::NAN,
        }
    }
}

/// Exact: do the interiors of two counter-clockwise lattice triangles not overlap (a separating edge)?
fn disjoint(a: &LatticeTri, b: &LatticeTri) -> bool {
    let sep = |p: &[(i64, i64); 3], q: &[(i64, i64); 3]| {
        (0..3).any(|i| {
            let (u, v) = (p[i], p[(i + 1) % 3]);
            q.iter().all(|w| (v.0 - u.0) * (w.1 - u.1) - (v.1 - u.1) * (w.0 - u.0) <= 0)
        })
    };
    sep(&a.p, &b.p) || sep(&b.p, &a.p)
}

/// `a ∩ b` as a convex polygon in lattice coordinates (Sutherland–Hodgman).
fn clip(a: &LatticeTri, b: &LatticeTri) -> Vec<(f64, f64)> {
    let mut poly: Vec<(f64, f64)> = a.p.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
    for i in 0..3 {
        let (p, q) = (b.p[i], b.p[(i + 1) % 3]);
        let (px, py, qx, qy) = (p.0 as f64, p.1 as f64, q.0 as f64, q.1 as f64);
        let side = |v: (f64, f64)| (qx - px) * (v.1 - py) - (qy - py) * (v.0 - px);
        let mut out = Vec::with_capacity(poly.len() + 1);
        for j in 0..poly.len() {
            let (c, d) = (poly[j], poly[(j + 1) % poly.len()]);
            let (sc, sd) = (side(c), side(d));
            if sc >= 0.0 {
                out.push(c);
            }
            if (sc >= 0.0) != (sd >= 0.0) {
                let t = sc / (sc - sd);
                out.push((c.0 + t * (d.0 - c.0), c.1 + t * (d.1 - c.1)));
            }
        }
        poly = out;
        if poly.is_empty() {
            break;
        }
    }
    poly
}

/// Mutable state of one greedy run over a set of triangles.
struct Run<'a, 'b> {
    s: &'b Shared<'a>,
    movable: Vec<bool>,
    tris: Vec<[u32; 3]>,
    /// Upper bound of each triangle's relative error (exact after a scan).
    terr: Vec<f64>,
    alive: Vec<bool>,
    vtris: Vec<Vec<u32>>,
    quad: Vec<Quadric>,
    stamp: Vec<u32>,
    heap: BinaryHeap<Cand>,
    stats: SimplifyStats,
    /// Vertices whose star was not one fan at the start (collapses keep the others manifold).
    singular: Vec<bool>,
}

/// The fan around a vertex: `None` when its star is not one fan (non-manifold or empty).
struct Star {
    /// Neighbours (sorted, unique).
    nbrs: Vec<u32>,
    /// The two boundary neighbours when the vertex is on the mesh boundary.
    border: Option<[u32; 2]>,
}

impl<'a, 'b> Run<'a, 'b> {
    fn new(s: &'b Shared<'a>, tris: Vec<[u32; 3]>, terr: Option<Vec<f64>>, movable: Vec<bool>) -> Self {
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

    fn star(&self, v: u32) -> Option<Star> {
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

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut n: Vec<u32> =
            self.vtris[v as usize].iter().flat_map(|&t| self.tris[t as usize]).filter(|&w| w != v).collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// Static constraints: may `v` ever collapse onto `u`?
    fn allowed(&self, v: u32, u: u32) -> bool {
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

    fn cost(&self, v: u32, u: u32) -> f64 {
        let (pv, pu) = (self.s.pos[v as usize], self.s.pos[u as usize]);
        let d = self.s.dist[v as usize];
        self.quad[v as usize].eval(pu).max(0.0) + 1e-9 * (pu - pv).length_squared() / (d * d)
    }

    /// Allowed targets of `v`, cheapest first (ties by index).
    fn targets(&self, v: u32) -> Vec<(f64, u32)> {
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
    fn push(&mut self, v: u32) {
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
    fn check(&mut self, v: u32, u: u32) -> Option<Vec<f64>> {
        let s = self.s;
        let sv = self.star(v)?;
        if self.singular[u as usize] {
            return None;
        }
        let su_nbrs = self.neighbours(u);
        if !sv.nbrs.contains(&u) {
            return None;
        }
        // Boundary vertices move only along a straight boundary.
        if let Some([p, q]) = sv.border {
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
            if !straight || du.0 * dw.0 + du.1 * dw.1 >= 0 {
                return None;
            }
        }
        // Link condition.
        let star = &self.vtris[v as usize];
        let opposite = star.iter().filter(|&&t| self.tris[t as usize].contains(&u)).count();
        let common = sv.nbrs.iter().filter(|w| su_nbrs.binary_search(w).is_ok()).count();
        if common != opposite || opposite == 0 {
            return None;
        }
        // Geometry of the new triangles.
        let new: Vec<[u32; 3]> = star
            .iter()
            .map(|&t| self.tris[t as usize])
            .filter(|t| !t.contains(&u))
            .map(|t| t.map(|w| if w == v { u } else { w }))
            .collect();
        let du = s.dist[u as usize];
        let mut plane = (DVec3::ZERO, 0.0);
        for t in &new {
            let p = t.map(|w| s.pos[w as usize]);
            // Counter-clockwise from the centre, and not edge-on (three rays nearly in one plane
            // through the centre: the hit distance would be ill-conditioned).
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
        // Planar shortcut: when the whole star lies within relative δ of one plane `n·x = k` (along
        // the rays), the old and the new triangles are both within δ of it over the same region (the
        // inverse hit distance is a positive combination of the vertices'), so every pixel's error
        // grows by at most the factor (1+δ)/(1−δ) over the star's known bound.
        let (n, k) = plane;
        if k.is_finite() && k != 0.0 {
            let delta = sv
                .nbrs
                .iter()
                .chain([&v])
                .map(|&w| (n.dot(s.pos[w as usize]) / k - 1.0).abs())
                .fold(0.0, f64::max);
            if delta <= 1e-3 * s.e {
                let m = star.iter().map(|&t| self.terr[t as usize]).fold(0.0, f64::max);
                let bound = (1.0 + m) * (1.0 + delta) / (1.0 - delta) - 1.0;
                if bound <= s.e {
                    self.stats.planar += 1;
                    return Some(vec![bound; new.len()]);
                }
            }
        }
        self.stats.tested += 1;
        self.check_pixels(v, &new)
    }

    /// The pixel test of the triangles `new` that replace the star of `v`.
    fn check_pixels(&self, v: u32, new: &[[u32; 3]]) -> Option<Vec<f64>> {
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

    fn collapse(&mut self, v: u32, u: u32, errs: &[f64]) {
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

    fn run(&mut self, seeds: impl Iterator<Item = u32>) {
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

    fn alive_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.tris.iter().zip(&self.alive).filter(|(_, &a)| a).map(|(t, _)| *t)
    }
}

/// A part of phase 1: lattice `g`, columns `x0..=x1`; its interior vertices (strictly between) are
/// simplified independently of the other parts'.
struct PhasePart {
    g: u8,
    x0: u32,
    x1: u32,
}

/// Vertical bands of the equirect simplified in parallel (at most).
const EQUIRECT_BANDS: usize = 4;

/// Phase-1 parts: each lattice whole, except a lone lattice (the equirect), which is cut into up to
/// [`EQUIRECT_BANDS`] vertical bands at columns no lattice triangle crosses (the quadtree's split columns
/// usually are such), chosen nearest to even spacing.
fn phase_parts(mesh: &LayerMesh, shared: &Shared, grids: &[Grid]) -> Vec<PhasePart> {
    let whole = |g: usize| PhasePart { g: g as u8, x0: 0, x1: grids[g].w as u32 - 1 };
    if grids.len() != 1 || grids[0].w < 64 {
        return (0..grids.len()).map(whole).collect();
    }
    let w = grids[0].w;
    // crossed[c] > 0 when some lattice triangle has vertices strictly on both sides of column c.
    // Triangles joining the first and last columns (the equirect seam strip) and pole fans are not
    // lattice triangles of any band.
    let mut diff = vec![0i64; w + 1];
    for t in &mesh.triangles {
        let xs = t.map(|v| match shared.loc[v as usize] {
            Loc::Lattice { x, .. } => Some(x as usize),
            Loc::Pole => None,
        });
        let [Some(a), Some(b), Some(c)] = xs else { continue };
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        if lo == 0 && hi == w - 1 {
            continue;
        }
        if hi > lo + 1 {
            diff[lo + 1] += 1;
            diff[hi] -= 1;
        }
    }
    let mut crossed = vec![false; w];
    let mut run = 0i64;
    for c in 0..w {
        run += diff[c];
        crossed[c] = run > 0;
    }
    // A fixed count, not the thread count: the output must not depend on the machine.
    let k = EQUIRECT_BANDS;
    let mut cuts = vec![0usize];
    for i in 1..k {
        let ideal = i * (w - 1) / k;
        let window = w / (4 * k);
        let found = (0..=window)
            .flat_map(|d| [ideal.saturating_sub(d), ideal + d])
            .find(|&c| c > *cuts.last().expect("non-empty") + 1 && c + 1 < w - 1 && !crossed[c]);
        if let Some(c) = found {
            cuts.push(c);
        }
    }
    cuts.push(w - 1);
    cuts.windows(2).map(|p| PhasePart { g: 0, x0: p[0] as u32, x1: p[1] as u32 }).collect()
}

/// Simplify a mesh made by [`super::mesh_layer`] from `grids` (its lattices) on `mapping`. `done[g]`,
/// when set, holds the exact error of each of lattice `g`'s own triangles, in mesh order (a lattice
/// meshed by `super::greedy`), which spares their first scans.
pub fn simplify(
    mesh: &LayerMesh,
    grids: &[Grid],
    mapping: &AnyMapping,
    params: &SimplifyOptions,
    done: &[Option<Vec<f64>>],
) -> (LayerMesh, SimplifyStats) {
    let (w, h) = (mesh.width, mesh.height);
    let cube = matches!(mapping, AnyMapping::Cube(_));
    let mut shared = Shared {
        grids,
        mapping,
        dirs: DirTable::new(*mapping),
        cube,
        e: params.max_error,
        cos_cap: params.max_angle_deg.map(|d| d.to_radians().cos()),
        pos: mesh.positions.clone(),
        dist: mesh.positions.iter().map(|p| p.length()).collect(),
        loc: Vec::with_capacity(mesh.sources.len()),
        sides: Vec::with_capacity(mesh.sources.len()),
    };
    for &id in &mesh.sources {
        if is_pole(id, w, h) {
            shared.loc.push(Loc::Pole);
            shared.sides.push(0);
            continue;
        }
        let (x, y) = (id as usize % w, id as usize / w);
        match shared.grid_of(x, y) {
            Some((g, lx, ly)) => {
                let gr = &grids[g];
                let sides = (ly == 0) as u8
                    | ((lx == gr.w - 1) as u8) << 1
                    | ((ly == gr.h - 1) as u8) << 2
                    | ((lx == 0) as u8) << 3;
                shared.loc.push(Loc::Lattice { g: g as u8, x: lx as u32, y: ly as u32 });
                shared.sides.push(sides);
            }
            None => {
                shared.loc.push(Loc::Pole);
                shared.sides.push(0);
            }
        }
    }
    let n = mesh.positions.len();
    // Poles, lattice corners and anything not on a lattice never move.
    let fixed: Vec<bool> = (0..n)
        .map(|v| {
            shared.loc[v] == Loc::Pole || shared.sides[v].count_ones() >= 2 || !shared.pos[v].is_finite()
        })
        .collect();
    let mut stats = SimplifyStats::default();
    let clock = std::time::Instant::now();

    // Phase 1: interior vertices of independent parts, in parallel — each cube face; the equirect in
    // vertical bands split at columns that no lattice triangle crosses (so a band's interior stars never
    // leave it). A part's run holds every triangle touching the part; only its interior stars change.
    let parts = phase_parts(mesh, &shared, grids);
    let lattice_x = |v: u32| match shared.loc[v as usize] {
        Loc::Lattice { g, x, .. } => Some((g, x)),
        Loc::Pole => None,
    };
    let part_of_tri = |t: &[u32; 3]| -> Option<usize> {
        let l = t.map(lattice_x);
        let [Some(a), Some(b), Some(c)] = l else { return None };
        parts.iter().position(|p| [a, b, c].iter().all(|&(g, x)| g == p.g && x >= p.x0 && x <= p.x1))
    };
    let touches = |t: &[u32; 3], p: &PhasePart| {
        t.iter().any(|&v| lattice_x(v).is_some_and(|(g, x)| g == p.g && x >= p.x0 && x <= p.x1))
    };
    let interior = |v: usize, p: &PhasePart| {
        !fixed[v]
            && shared.sides[v] == 0
            && lattice_x(v as u32).is_some_and(|(g, x)| g == p.g && x > p.x0 && x < p.x1)
    };
    let tri_parts: Vec<Option<usize>> = mesh.triangles.iter().map(part_of_tri).collect();
    let shared_ref = &shared;
    type Part = (Vec<[u32; 3]>, Vec<f64>, SimplifyStats);
    let results: Vec<Part> = parts
        .par_iter()
        .enumerate()
        .map(|(k, p)| {
            let tris: Vec<[u32; 3]> = mesh
                .triangles
                .iter()
                .zip(&tri_parts)
                .filter(|(_, q)| **q == Some(k))
                .map(|(t, _)| *t)
                .collect();
            let own = tris.len();
            let known = done.get(p.g as usize).and_then(Option::as_ref).filter(|e| e.len() == own);
            let mut all = tris;
            all.extend(
                mesh.triangles
                    .iter()
                    .zip(&tri_parts)
                    .filter(|(t, q)| q.is_none() && touches(t, p))
                    .map(|(t, _)| *t),
            );
            let movable: Vec<bool> = (0..n).map(|v| interior(v, p)).collect();
            let seeds: Vec<u32> = (0..n as u32).filter(|&v| movable[v as usize]).collect();
            // Known errors of the lattice's own triangles spare their scans.
            let terr = known.map(|e| {
                let mut terr = e.clone();
                terr.extend(all[own..].iter().map(|t| shared_ref.max_error(*t, f64::INFINITY)));
                terr
            });
            let mut run = Run::new(shared_ref, all, terr, movable);
            run.run(seeds.into_iter());
            let keep: Vec<usize> = (0..own).filter(|&i| run.alive[i]).collect();
            (
                keep.iter().map(|&i| run.tris[i]).collect(),
                keep.iter().map(|&i| run.terr[i]).collect(),
                run.stats,
            )
        })
        .collect();
    let (mut tris, mut terr) = (Vec::new(), Vec::new());
    for (t, e, s) in results {
        tris.extend(t);
        terr.extend(e);
        stats.collapses += s.collapses;
        stats.tested += s.tested;
        stats.planar += s.planar;
    }
    for (t, _) in mesh.triangles.iter().zip(&tri_parts).filter(|(_, q)| q.is_none()) {
        tris.push(*t);
        terr.push(shared.max_error(*t, f64::INFINITY));
    }
    // Phase 2 starts from every movable vertex that no part could move (sides, band boundaries).
    let mut phase2_seed: Vec<bool> =
        (0..n).map(|v| !fixed[v] && !parts.iter().any(|p| interior(v, p))).collect();
    // A band's run sees only one side of its cut columns, so collapses onto a cut-column vertex may
    // have been refused there: their neighbours get another chance in phase 2.
    if parts.len() > 1 && grids.len() == 1 {
        let on_cut = |v: u32| {
            lattice_x(v).is_some_and(|(_, x)| {
                parts.iter().any(|p| (x == p.x0 && x > 0) || (x == p.x1 && x + 1 < grids[0].w as u32))
            })
        };
        for t in &mesh.triangles {
            if t.iter().any(|&v| on_cut(v)) {
                for &v in t {
                    phase2_seed[v as usize] |= !fixed[v as usize];
                }
            }
        }
    }

    stats.lattice_ms = clock.elapsed().as_secs_f64() * 1e3;
    let clock = std::time::Instant::now();
    // Phase 2: the whole mesh, from the vertices phase 1 left (their stars span parts).
    let movable: Vec<bool> = (0..n).map(|v| !fixed[v]).collect();
    let mut run = Run::new(&shared, tris, Some(terr), movable);
    let seeds: Vec<u32> = (0..n as u32).filter(|&v| phase2_seed[v as usize]).collect();
    run.run(seeds.into_iter());
    stats.collapses += run.stats.collapses;
    stats.tested += run.stats.tested;
    stats.planar += run.stats.planar;
    stats.stitch_ms = clock.elapsed().as_secs_f64() * 1e3;

    // Compact the surviving vertices (sources stay sorted).
    let tris: Vec<[u32; 3]> = run.alive_triangles().collect();
    let mut used = vec![false; n];
    for t in &tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut remap = vec![u32::MAX; n];
    let (mut sources, mut positions) = (Vec::new(), Vec::new());
    for v in 0..n {
        if used[v] {
            remap[v] = sources.len() as u32;
            sources.push(mesh.sources[v]);
            positions.push(mesh.positions[v]);
        }
    }
    let triangles = tris.iter().map(|t| t.map(|v| remap[v as usize])).collect();
    (LayerMesh { width: w, height: h, sources, positions, triangles }, stats)
}
