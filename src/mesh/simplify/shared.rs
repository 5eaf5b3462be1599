//! What every run reads: the vertices, where they are on the lattices, and the error bounds.

use glam::DVec3;

use super::overlap::{clip, disjoint, LatticeTri};
use super::quadric::Loc;
use super::{SimplifyOptions, PAIR_SKIP};
use crate::mesh::is_pole;
use crate::mesh::LayerMesh;

use crate::mapping::{AnyMapping, DirTable};
use crate::mesh::accuracy::{candidates, ray_hit};
use crate::mesh::grid::{Grid, PlaneDot};

/// Read-only description of the vertices shared by all runs.
pub(super) struct Shared<'a> {
    pub(super) grids: &'a [Grid],
    pub(super) mapping: &'a AnyMapping,
    pub(super) dirs: DirTable,
    pub(super) cube: bool,
    pub(super) e: f64,
    pub(super) cos_cap: Option<f64>,
    pub(super) pos: Vec<DVec3>,
    pub(super) dist: Vec<f64>,
    pub(super) loc: Vec<Loc>,
    /// Lattice sides the vertex lies on (bit k: side k; 0 top, 1 right, 2 bottom, 3 left).
    pub(super) sides: Vec<u8>,
}

impl<'a> Shared<'a> {
    /// The vertices of `mesh` on `grids`: where each is on its lattice, and which sides it lies on.
    pub(super) fn new(
        mesh: &LayerMesh,
        grids: &'a [Grid],
        mapping: &'a AnyMapping,
        params: &SimplifyOptions,
    ) -> Shared<'a> {
        let (w, h) = (mesh.width, mesh.height);
        let mut shared = Shared {
            grids,
            mapping,
            dirs: DirTable::new(*mapping),
            cube: matches!(mapping, AnyMapping::Cube(_)),
            e: params.max_error,
            cos_cap: params.max_angle_deg.map(|d| d.to_radians().cos()),
            pos: mesh.positions.clone(),
            dist: mesh.positions.iter().map(|p| p.length()).collect(),
            loc: Vec::with_capacity(mesh.sources.len()),
            sides: Vec::with_capacity(mesh.sources.len()),
        };
        for &id in &mesh.sources {
            let on = if is_pole(id, w, h) { None } else { shared.grid_of(id as usize % w, id as usize / w) };
            let (loc, sides) = match on {
                Some((g, lx, ly)) => {
                    let gr = &grids[g];
                    let sides = (ly == 0) as u8
                        | ((lx == gr.w - 1) as u8) << 1
                        | ((ly == gr.h - 1) as u8) << 2
                        | ((lx == 0) as u8) << 3;
                    (Loc::Lattice { g: g as u8, x: lx as u32, y: ly as u32 }, sides)
                }
                None => (Loc::Pole, 0),
            };
            shared.loc.push(loc);
            shared.sides.push(sides);
        }
        shared
    }
}

impl Shared<'_> {
    /// Lattice point of canvas pixel `(x, y)`.
    pub(super) fn grid_of(&self, x: usize, y: usize) -> Option<(usize, usize, usize)> {
        self.grids.iter().enumerate().find_map(|(k, g)| {
            (x >= g.ox && x < g.ox + g.w && y >= g.oy && y < g.oy + g.h).then(|| (k, x - g.ox, y - g.oy))
        })
    }

    pub(super) fn lattice(&self, v: u32) -> Option<(usize, i64, i64)> {
        match self.loc[v as usize] {
            Loc::Lattice { g, x, y } => Some((g as usize, x as i64, y as i64)),
            Loc::Pole => None,
        }
    }

    /// Largest relative error over the pixels triangle `t` covers (`∞` when it covers an invalid
    /// pixel); the scan stops as soon as it exceeds `limit`.
    pub(super) fn max_error(&self, t: [u32; 3], limit: f64) -> f64 {
        let l = t.map(|v| self.lattice(v));
        if let (true, [Some(a), Some(b), Some(c)]) = (self.cube, l) {
            if a.0 == b.0 && b.0 == c.0 {
                return self.lattice_max(&self.grids[a.0], (a.1, a.2), (b.1, b.2), (c.1, c.2), limit);
            }
        }
        self.raycast_max(t.map(|v| self.pos[v as usize]), limit)
    }

    /// Exact scan of a triangle of one cube-face lattice: its lattice points, against its plane.
    pub(super) fn lattice_max(
        &self,
        g: &Grid,
        a: (i64, i64),
        b: (i64, i64),
        c: (i64, i64),
        limit: f64,
    ) -> f64 {
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
    pub(super) fn raster(
        &self,
        g: &Grid,
        t: &LatticeTri,
        clip: &[&LatticeTri],
        stride: i64,
        limit: f64,
    ) -> f64 {
        let (mut x0, mut y0, mut x1, mut y1) = t.bbox();
        for c in clip {
            let b = c.bbox();
            (x0, y0, x1, y1) = (x0.max(b.0), y0.max(b.1), x1.min(b.2), y1.min(b.3));
        }
        let PlaneDot::Affine { a: da, bx, by } = t.dot else { return f64::INFINITY };
        let k = t.k;
        let edges = edge_equations(t, clip);
        let mut worst = 0.0f64;
        let mut y = y0;
        while y <= y1 {
            let (mut lo, hi) = row_span(&edges, y, x0, x1);
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
    pub(super) fn pairwise_bound(
        &self,
        g: &Grid,
        new: &[LatticeTri],
        old: &[(LatticeTri, f64)],
    ) -> Option<Vec<f64>> {
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
    pub(super) fn raycast_max(&self, p: [DVec3; 3], limit: f64) -> f64 {
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

/// Each edge of `t` and of the triangles of `clip` as `A·x + B(y) ≥ 0` with `B(y) = B0 + C·y`:
/// `(A, B0, C, 1/A)`.
fn edge_equations(t: &LatticeTri, clip: &[&LatticeTri]) -> Vec<(i64, i64, i64, f64)> {
    let mut edges = Vec::with_capacity(3 + 3 * clip.len());
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
    edges
}

/// The columns `lo..=hi` of row `y` (within `x0..=x1`) inside every edge: a float estimate
/// corrected with exact integer arithmetic. Empty when `lo > hi`.
#[inline]
fn row_span(edges: &[(i64, i64, i64, f64)], y: i64, x0: i64, x1: i64) -> (i64, i64) {
    let (mut lo, mut hi) = (x0, x1);
    for &(aa, b0, c, inv) in edges {
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
    (lo, hi)
}
