//! The subdivision function `S(v)` (thesis Alg. 16) plus this crate's error-driven and extent tests.
//!
//! Order of the tests for a node `v` (all O(1) through summed-area tables except the error test):
//! 1. no valid vertex → empty leaf; some bad cell (domain border `B` or depth jump) → split down to cells;
//! 2. `--uniform STEP`: split while a side exceeds `STEP` cells (the 4-8 baseline; nothing else applies);
//! 3. `--max-angle`: split while the angle between the rays of opposite corners exceeds the cap;
//! 4. thesis test: `SAT_F(v) ≥ 1` (a feature: `V_N ≥ 1 − cos θ`) or `SAT_VR(v)/area ≥ τ` → split;
//! 5. `--max-error E`: split unless every pixel of the node is within relative distance `E`, along its
//!    ray, of every triangulation the node may end up with (two triangles, or the centre fan with any
//!    subset of mid-side vertices). The intersection is the real ray/plane one.

use glam::DVec3;

use super::grid::{Grid, PlaneDot};
use super::normals;
use super::quadtree::{NodeKind, Rect, Subdivide};
use super::sat::{to_fixed, CountSat, Sat};
use super::MeshOptions;

/// Everything `S` needs about one lattice.
pub struct Criterion<'a> {
    /// The lattice whose quadtree this criterion subdivides.
    pub grid: &'a Grid,
    params: &'a MeshOptions,
    valid: CountSat,
    bad: CountSat,
    /// `(features, residual)` when the thesis normal test is on.
    normal_sats: Option<(CountSat, Sat)>,
    max_angle_cos: Option<f64>,
}

impl<'a> Criterion<'a> {
    /// Precompute the validity, bad-cell and (with a feature angle) normal-variation tables of
    /// `grid`; `image` supplies the normals (`N.*` channels or estimated from depth).
    pub fn new(grid: &'a Grid, image: &crate::layer::LayerImage, params: &'a MeshOptions) -> Criterion<'a> {
        let (w, h) = (grid.w, grid.h);
        let valid = CountSat::from_fn(w, h, |x, y| grid.valid(x, y));
        let (cw, ch) = (w.saturating_sub(1), h.saturating_sub(1));
        let bad = CountSat::from_fn(cw, ch, |x, y| grid.bad_cell(x, y));
        let normal_sats = params.feature_angle_deg.filter(|_| params.uniform.is_none()).map(|deg| {
            let n = normals::lattice_normals(image, grid, params.normal_weighting);
            let v = normals::cell_variation(grid, &n);
            let threshold = 1.0 - deg.to_radians().cos();
            let f = CountSat::from_fn(cw, ch, |x, y| v[y * cw + x] >= threshold);
            let r = Sat::from_fn(cw, ch, |x, y| {
                let vn = v[y * cw + x];
                if vn < threshold {
                    to_fixed(vn)
                } else {
                    0
                }
            });
            (f, r)
        });
        let max_angle_cos = params.max_angle_deg.map(|d| d.to_radians().cos());
        Criterion { grid, params, valid, bad, normal_sats, max_angle_cos }
    }

    fn too_wide(&self, r: &Rect) -> bool {
        let Some(c) = self.max_angle_cos else { return false };
        let g = self.grid;
        let ray = |x: u32, y: u32| g.rays.ray(x as usize, y as usize).normalize();
        ray(r.x0, r.y0).dot(ray(r.x1, r.y1)) < c || ray(r.x1, r.y0).dot(ray(r.x0, r.y1)) < c
    }

    fn normals_say_split(&self, r: &Rect) -> bool {
        let Some((f, res)) = &self.normal_sats else { return false };
        let (x0, y0, x1, y1) = (r.x0 as usize, r.y0 as usize, r.x1 as usize, r.y1 as usize);
        if f.count(x0, y0, x1, y1) >= 1 {
            return true;
        }
        let mean = res.sum(x0, y0, x1, y1) as f64 / (r.cells() as f64 * super::sat::FIXED_ONE);
        mean >= self.params.residual_threshold
    }

    /// Every pixel of `r` within the error bound for every triangulation the node may receive.
    pub fn error_ok(&self, r: &Rect, e: f64) -> bool {
        let t = ErrorTest { g: self.grid, e };
        let (xm, ym) = r.mid();
        let c = [(r.x0, r.y0), (r.x1, r.y0), (r.x1, r.y1), (r.x0, r.y1)];
        if r.cw() == 1 || r.ch() == 1 {
            // Every pixel lies on a long side: test each side with and without its midpoint.
            let sides: [(usize, usize, (u32, u32)); 2] = if r.cw() == 1 {
                [(0, 3, (r.x0, ym)), (1, 2, (r.x1, ym))]
            } else {
                [(0, 1, (xm, r.y0)), (3, 2, (xm, r.y1))]
            };
            let long = r.cw().max(r.ch()) >= 2;
            return sides.iter().all(|&(a, b, m)| {
                let third = c[(b + 2) % 4];
                t.segment(c[a], c[b], third)
                    && (!long || (t.segment(c[a], m, third) && t.segment(m, c[b], third)))
            });
        }
        // A sparse pass first: a node that fails usually fails somewhere on a coarse sub-lattice, at a
        // sixteenth of the cost of the full scan.
        if r.cw() >= 16
            && r.ch() >= 16
            && !(t.triangle_strided(c[0], c[1], c[2], 4) && t.triangle_strided(c[0], c[2], c[3], 4))
        {
            return false;
        }
        if !(t.triangle(c[0], c[1], c[2]) && t.triangle(c[0], c[2], c[3])) {
            return false;
        }
        let mids = [(xm, r.y0), (r.x1, ym), (xm, r.y1), (r.x0, ym)];
        let ctr = (xm, ym);
        (0..4).all(|k| {
            let (a, b) = (c[k], c[(k + 1) % 4]);
            t.triangle(ctr, a, b) && t.triangle(ctr, a, mids[k]) && t.triangle(ctr, mids[k], b)
        })
    }
}

impl Subdivide for Criterion<'_> {
    fn kind(&self, r: &Rect) -> NodeKind {
        let (x0, y0, x1, y1) = (r.x0 as usize, r.y0 as usize, r.x1 as usize, r.y1 as usize);
        if self.valid.count(x0, y0, x1 + 1, y1 + 1) == 0 {
            NodeKind::Empty
        } else if self.bad.count(x0, y0, x1, y1) > 0 {
            NodeKind::Broken
        } else {
            NodeKind::Full
        }
    }

    fn split(&self, r: &Rect, kind: NodeKind) -> bool {
        match kind {
            NodeKind::Empty => false,
            NodeKind::Broken => r.splittable(),
            NodeKind::Full => r.splittable() && self.refine(r),
        }
    }
}

impl Criterion<'_> {
    fn refine(&self, r: &Rect) -> bool {
        if let Some(step) = self.params.uniform {
            return r.cw() > step || r.ch() > step;
        }
        if self.too_wide(r) || self.normals_say_split(r) {
            return true;
        }
        match self.params.max_error {
            Some(e) => !self.error_ok(r, e),
            None => false,
        }
    }
}

/// The lattice points `x` of row `y` inside (or on) the triangle with integer corners `t`, as an
/// inclusive range; `None` when there are none or the triangle is degenerate. Exact: each edge gives
/// a linear inequality in `x` solved with floor division.
pub(crate) fn row_span(t: [(i64, i64); 3], y: i64) -> Option<(i64, i64)> {
    let [a, b, c] = t;
    // Edge function of pq at (x, y): (q.x − p.x)(y − p.y) − (q.y − p.y)(x − p.x), signed so that
    // the inside is ≥ 0 on all three edges.
    let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
    if area == 0 {
        return None;
    }
    let sign = area.signum();
    let (mut lo, mut hi) = (a.0.min(b.0).min(c.0), a.0.max(b.0).max(c.0));
    for (p, q) in [(a, b), (b, c), (c, a)] {
        // Inside: ca·x + cb ≥ 0.
        let ca = -(q.1 - p.1) * sign;
        let cb = ((q.0 - p.0) * (y - p.1) + (q.1 - p.1) * p.0) * sign;
        if ca > 0 {
            // x ≥ ⌈−cb/ca⌉ = −⌊cb/ca⌋.
            lo = lo.max(-cb.div_euclid(ca));
        } else if ca < 0 {
            // x ≤ ⌊cb/−ca⌋.
            hi = hi.min(cb.div_euclid(-ca));
        } else if cb < 0 {
            return None;
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Per-pixel check against the plane of one lattice triangle.
struct ErrorTest<'a> {
    g: &'a Grid,
    e: f64,
}

type P = (u32, u32);

impl ErrorTest<'_> {
    fn point(&self, p: P) -> DVec3 {
        self.g.point(p.0 as usize, p.1 as usize)
    }

    /// Plane `n·x = k` through three vertices; `None` when degenerate.
    fn plane(&self, a: P, b: P, c: P) -> Option<(DVec3, f64)> {
        let (pa, pb, pc) = (self.point(a), self.point(b), self.point(c));
        let n = (pb - pa).cross(pc - pa);
        let k = n.dot(pa);
        (n.length_squared() > 0.0 && k != 0.0 && k.is_finite()).then_some((n, k))
    }

    /// `k/dot` (the plane's hit, in units of `λ`) is in front and within `e` of the sample `lam`;
    /// multiplied out so the hot loops do not divide. NaN fails.
    #[inline]
    fn hit_ok(&self, k: f64, dot: f64, lam: f64) -> bool {
        k * dot > 0.0 && (k - lam * dot).abs() <= self.e * lam * dot.abs()
    }

    #[inline]
    fn pixel_ok(&self, dot: &PlaneDot, k: f64, x: u32, y: u32) -> bool {
        let (x, y) = (x as usize, y as usize);
        self.hit_ok(k, dot.at(x, y), self.g.lambda[y * self.g.w + x] as f64)
    }

    /// All lattice points of triangle `abc` (inclusive) within the bound.
    fn triangle(&self, a: P, b: P, c: P) -> bool {
        self.triangle_strided(a, b, c, 1)
    }

    /// The lattice points of triangle `abc` on every `stride`-th row and column (counted from the
    /// bounding box's corner) within the bound. Each row's span inside the triangle is solved exactly
    /// in integers, so the inner loop only tests pixels.
    fn triangle_strided(&self, a: P, b: P, c: P, stride: usize) -> bool {
        let Some((n, k)) = self.plane(a, b, c) else { return false };
        let dot = self.g.rays.plane_dot(n);
        let pt = |p: P| (p.0 as i64, p.1 as i64);
        let (a, b, c) = (pt(a), pt(b), pt(c));
        let x0 = a.0.min(b.0).min(c.0);
        let (y0, y1) = (a.1.min(b.1).min(c.1), a.1.max(b.1).max(c.1));
        let st = stride as i64;
        let w = self.g.w;
        for y in (y0..=y1).step_by(stride) {
            let Some((lo, hi)) = row_span([a, b, c], y) else { continue };
            // Onto the stride grid anchored at x0.
            let lo = x0 + (lo - x0 + st - 1).div_euclid(st) * st;
            let row = &self.g.lambda[y as usize * w..(y as usize + 1) * w];
            let rd = dot.row(y as usize);
            let mut x = lo;
            while x <= hi {
                if !self.hit_ok(k, rd.at(x as usize), row[x as usize] as f64) {
                    return false;
                }
                x += st;
            }
        }
        true
    }

    /// All lattice points of the axis-aligned segment `ab`, against the plane `(a, b, third)`.
    fn segment(&self, a: P, b: P, third: P) -> bool {
        let Some((n, k)) = self.plane(a, b, third) else { return false };
        let dot = self.g.rays.plane_dot(n);
        let (x0, x1) = (a.0.min(b.0), a.0.max(b.0));
        let (y0, y1) = (a.1.min(b.1), a.1.max(b.1));
        (y0..=y1).all(|y| (x0..=x1).all(|x| self.pixel_ok(&dot, k, x, y)))
    }
}

#[cfg(test)]
mod tests {
    use super::row_span;

    /// The row spans are exactly the lattice points the edge functions call inside, for every
    /// orientation and shape (slivers, axis-aligned edges, both windings).
    #[test]
    fn row_spans_match_brute_force() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m as u64) as i64
        };
        for _ in 0..3000 {
            let t = [(next(17), next(17)), (next(17), next(17)), (next(17), next(17))];
            let [a, b, c] = t;
            let f = |p: (i64, i64), q: (i64, i64), x: i64, y: i64| {
                (q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0)
            };
            let area = f(a, b, c.0, c.1);
            for y in -1..18 {
                let brute: Vec<i64> = (-1..18)
                    .filter(|&x| {
                        let e = [f(a, b, x, y), f(b, c, x, y), f(c, a, x, y)];
                        area != 0
                            && (if area > 0 { e.iter().all(|&v| v >= 0) } else { e.iter().all(|&v| v <= 0) })
                    })
                    .collect();
                let span: Vec<i64> = row_span(t, y).map_or(Vec::new(), |(lo, hi)| (lo..=hi).collect());
                assert_eq!(span, brute, "triangle {t:?} row {y}");
            }
        }
    }
}
