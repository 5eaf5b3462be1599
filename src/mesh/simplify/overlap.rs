//! Lattice triangles and their overlaps, for bounding a new triangle against the old ones.

use crate::mesh::grid::{Grid, PlaneDot};

/// Three lattice points.
pub(super) type LatticePts = [(i64, i64); 3];

/// A triangle of one lattice, counter-clockwise in lattice coordinates, with its plane.
pub(super) struct LatticeTri {
    pub(super) p: [(i64, i64); 3],
    pub(super) area: i64,
    pub(super) dot: PlaneDot<'static>,
    pub(super) k: f64,
}

impl LatticeTri {
    pub(super) fn new(g: &Grid, p: [(i64, i64); 3]) -> Option<LatticeTri> {
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

    pub(super) fn bbox(&self) -> (i64, i64, i64, i64) {
        let p = &self.p;
        (
            p[0].0.min(p[1].0).min(p[2].0),
            p[0].1.min(p[1].1).min(p[2].1),
            p[0].0.max(p[1].0).max(p[2].0),
            p[0].1.max(p[1].1).max(p[2].1),
        )
    }

    /// `n·r` at a continuous lattice position.
    pub(super) fn dot_at(&self, x: f64, y: f64) -> f64 {
        match self.dot {
            PlaneDot::Affine { a, bx, by } => a + bx * x + by * y,
            PlaneDot::Rays { .. } => f64::NAN,
        }
    }
}

/// Exact: do the interiors of two counter-clockwise lattice triangles not overlap (a separating edge)?
pub(super) fn disjoint(a: &LatticeTri, b: &LatticeTri) -> bool {
    let sep = |p: &[(i64, i64); 3], q: &[(i64, i64); 3]| {
        (0..3).any(|i| {
            let (u, v) = (p[i], p[(i + 1) % 3]);
            q.iter().all(|w| (v.0 - u.0) * (w.1 - u.1) - (v.1 - u.1) * (w.0 - u.0) <= 0)
        })
    };
    sep(&a.p, &b.p) || sep(&b.p, &a.p)
}

/// `a ∩ b` as a convex polygon in lattice coordinates (Sutherland–Hodgman).
pub(super) fn clip(a: &LatticeTri, b: &LatticeTri) -> Vec<(f64, f64)> {
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
