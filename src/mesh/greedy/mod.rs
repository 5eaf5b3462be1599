//! Greedy insertion meshing of a *clean* cube-face lattice (every pixel valid, no depth jump): the
//! Garland–Heckbert (1995) refinement that Delatin/hmm use on heightmaps, driven by pomc's exact 3D
//! error instead of a height difference. Start from two corner triangles, insert the worst pixel of the
//! worst triangle, flip edges by error (Delaunay below `E/4`), rescan what changed; a triangle wider
//! than `max_angle` is split at its widest edge. Why the scan is exact: `docs/mesh.md`, "Greedy
//! insertion".

mod delaunay;
mod queue;

use super::grid::{Grid, Rays};
use super::subdivide::row_span;
use delaunay::edge;
#[cfg(test)]
use delaunay::in_circle;

/// A lattice point.
type P = (i64, i64);

/// `true` when every vertex is valid and no two neighbours (sides and diagonals of every cell) differ
/// by a depth jump (the quadtree handles domain borders and jumps). Reads the lattice once, allocates
/// nothing.
pub fn is_clean(g: &Grid) -> bool {
    use rayon::prelude::*;
    if g.w < 2 || g.h < 2 || !matches!(g.rays, Rays::Face { .. }) {
        return false;
    }
    let (w, h) = (g.w, g.h);
    // Joined ⟺ |a − b| ≤ ½·min(a, b), as [`Grid::bad_cell`] tests it in f64: the f32 difference is
    // exact when the ratio is ≤ 2 (Sterbenz) and cannot round below ½·min otherwise, so this is the
    // same test. NaN (an invalid vertex) fails it. Branch-free so that the row loops vectorise.
    #[inline(always)]
    fn joined(a: f32, b: f32) -> bool {
        (a - b).abs() <= 0.5 * a.min(b)
    }
    (0..h).into_par_iter().all(|y| {
        let d = &g.depth[y * w..(y + 1) * w];
        let mut ok = d.iter().fold(true, |ok, &v| ok & (v > 0.0));
        ok &= d.windows(2).fold(true, |ok, p| ok & joined(p[0], p[1]));
        if y + 1 < h {
            let e = &g.depth[(y + 1) * w..(y + 2) * w];
            ok &= d.iter().zip(e).fold(true, |ok, (&a, &b)| ok & joined(a, b));
            ok &= d[..w - 1].iter().zip(&e[1..]).fold(true, |ok, (&a, &b)| ok & joined(a, b));
            ok &= d[1..].iter().zip(&e[..w - 1]).fold(true, |ok, (&a, &b)| ok & joined(a, b));
        }
        ok
    })
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Largest relative error `|w − w_m| / w_m` along a row (`w = 1/λ`, `w_m = base + gx·k`) when it
/// exceeds `best`: updates `best` and returns the position. With `t = w_m·λ` the error is
/// `|1 − t| / t` (`t > 0`: `w_m` is a convex combination of positive vertex values), so eight pixels at
/// a time are screened without a division (`|1 − t| > best·t`); only a chunk that holds an
/// improvement is searched.
#[inline]
fn row_max(lambda: &[f32], base: f64, gx: f64, best: &mut f64) -> Option<usize> {
    let mut found = None;
    let mut exact = |k0: usize, k1: usize, best: &mut f64| {
        for (k, &l) in lambda.iter().enumerate().take(k1).skip(k0) {
            let t = (base + gx * k as f64) * l as f64;
            let d = (1.0 - t).abs();
            if d > *best * t {
                *best = d / t;
                found = Some(k);
            }
        }
    };
    let mut chunks = lambda.chunks_exact(8);
    for (c, chunk) in chunks.by_ref().enumerate() {
        let k0 = c * 8;
        let b = *best;
        let mut any = false;
        for (j, &l) in chunk.iter().enumerate() {
            let t = (base + gx * (k0 + j) as f64) * l as f64;
            any |= (1.0 - t).abs() > b * t;
        }
        if any {
            exact(k0, k0 + 8, best);
        }
    }
    let rest = chunks.remainder().len();
    exact(lambda.len() - rest, lambda.len(), best);
    found
}

/// Errors below this fraction of the tolerance count as flat: the Delaunay criterion picks diagonals.
const FLAT: f64 = 0.25;

/// One scan of a triangle.
#[derive(Clone, Copy, Debug, Default)]
struct Scan {
    /// Largest relative error over its pixels.
    err: f64,
    /// Queue priority: > 1 means the triangle must be split (at `cand`).
    key: f64,
    cand: P,
    /// A cap split beside (not on) the triangle's widest edge: that edge, to be flipped away.
    away: Option<(P, P)>,
}

/// Counters of one face.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct GreedyStats {
    /// Lattice points inserted as vertices (besides the lattice's four starting corners).
    pub insertions: usize,
    /// Triangles left wider than the angle cap (slivers no split or flip could narrow); a lattice
    /// with any is meshed by the quadtree instead ([`super::mesh_layer`]).
    pub over_cap: usize,
    /// Lattice points scanned (the cost of the method).
    pub scanned: u64,
}

/// Greedy insertion over one clean lattice. Triangles are triples of vertex indices; `half[e]` is the
/// opposite half-edge of half-edge `e = 3t + k` (from vertex `k` to vertex `k + 1` of triangle `t`).
struct Mesher<'a> {
    nw: usize,
    /// `λ` per vertex.
    lambda: &'a [f32],
    rays: &'a Rays,
    e: f64,
    /// Angle cap in radians.
    cap: Option<f64>,
    pts: Vec<P>,
    tri: Vec<u32>,
    half: Vec<i32>,
    /// Last scan of each triangle, valid when `fresh`.
    scans: Vec<Scan>,
    fresh: Vec<bool>,
    qpos: Vec<i32>,
    queue: Vec<u32>,
    pending: Vec<u32>,
    stats: GreedyStats,
}

impl<'a> Mesher<'a> {
    fn new(g: &'a Grid, e: f64, cap: Option<f64>) -> Self {
        let mut m = Mesher {
            nw: g.w,
            lambda: &g.lambda,
            rays: &g.rays,
            e,
            cap,
            pts: Vec::new(),
            tri: Vec::new(),
            half: Vec::new(),
            scans: Vec::new(),
            fresh: Vec::new(),
            qpos: Vec::new(),
            queue: Vec::new(),
            pending: Vec::new(),
            stats: GreedyStats::default(),
        };
        let (x1, y1) = (g.w as i64 - 1, g.h as i64 - 1);
        let p0 = m.add_point((0, 0));
        let p1 = m.add_point((x1, 0));
        let p2 = m.add_point((0, y1));
        let p3 = m.add_point((x1, y1));
        let t0 = m.add_triangle([p3, p0, p2], [-1, -1, -1], None, None);
        m.add_triangle([p0, p3, p1], [t0 as i32, -1, -1], None, None);
        m.flush();
        m
    }

    fn add_point(&mut self, p: P) -> u32 {
        self.pts.push(p);
        self.pts.len() as u32 - 1
    }

    fn run(&mut self) {
        while let Some(&t) = self.queue.first() {
            // `!(key > 1)`: a NaN key stops too.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(self.scans[t as usize].key > 1.0) {
                break;
            }
            self.step();
            self.flush();
        }
    }

    fn flush(&mut self) {
        while let Some(t) = self.pending.pop() {
            self.ensure_scanned(t as usize);
            self.queue_push(t);
        }
    }

    fn vertices(&self, t: usize) -> [P; 3] {
        [0, 1, 2].map(|k| self.pts[self.tri[3 * t + k] as usize])
    }

    /// Scan of triangle `t`, computed now if its slot changed since the last one.
    fn ensure_scanned(&mut self, t: usize) -> Scan {
        if !self.fresh[t] {
            self.scans[t] = self.scan(self.vertices(t), f64::INFINITY);
            self.fresh[t] = true;
        }
        self.scans[t]
    }

    /// Scan a lattice triangle: its worst pixel (relative error along the ray) and its queue key
    /// (error / tolerance, or the angle overshoot when that is larger).
    /// Stops early, with `err = ∞`, once the error exceeds `limit`.
    fn scan(&mut self, [a, b, c]: [P; 3], limit: f64) -> Scan {
        // Vertex values exact (f64 from λ): the plane is the 3D triangle's.
        let at = |p: P| 1.0 / self.lambda[p.1 as usize * self.nw + p.0 as usize] as f64;
        let (wa, wb, wc) = (at(a), at(b), at(c));
        let (dx1, dy1, dx2, dy2) =
            ((b.0 - a.0) as f64, (b.1 - a.1) as f64, (c.0 - a.0) as f64, (c.1 - a.1) as f64);
        let det = dx1 * dy2 - dx2 * dy1;
        let gx = ((wb - wa) * dy2 - (wc - wa) * dy1) / det;
        let gy = (dx1 * (wc - wa) - dx2 * (wb - wa)) / det;
        let (y0, y1) = (a.1.min(b.1).min(c.1), a.1.max(b.1).max(c.1));
        let mut best = 0.0f64;
        let mut best_at = a;
        let mut scanned = 0u64;
        // Large triangles: every 4th row first, so that a scan that is going to exceed `limit`
        // usually stops after a quarter of the work; then the other rows.
        let coarse = y1 - y0 > 32 && limit.is_finite();
        let first = (y0..=y1).step_by(if coarse { 4 } else { 1 });
        let rest = (y0..=y1).filter(move |y| coarse && (y - y0) % 4 != 0);
        for y in first.chain(rest) {
            let Some((lo, hi)) = row_span([a, b, c], y) else { continue };
            let start = y as usize * self.nw;
            let (i0, i1) = (start + lo as usize, start + hi as usize + 1);
            scanned += (i1 - i0) as u64;
            let base = wa + gx * (lo - a.0) as f64 + gy * (y - a.1) as f64;
            if let Some(k) = row_max(&self.lambda[i0..i1], base, gx, &mut best) {
                best_at = (lo + k as i64, y);
            }
            if best > limit {
                self.stats.scanned += scanned;
                return Scan { err: f64::INFINITY, key: f64::INFINITY, cand: best_at, away: None };
            }
        }
        self.stats.scanned += scanned;
        let err = best;
        if best_at == a || best_at == b || best_at == c {
            best = 0.0;
        }
        let mut key = best / self.e;
        let mut cand = best_at;
        let mut away = None;
        if let Some(cap) = self.cap {
            let over = self.extent(a, b, c) / cap;
            if over > 1.0 && over > key {
                match self.split_point(a, b, c) {
                    Some((p, edge)) => {
                        key = over;
                        cand = p;
                        away = edge;
                    }
                    None if key <= 1.0 => key = 0.0,
                    None => {}
                }
            }
        }
        Scan { err, key, cand, away }
    }

    /// Largest angle between two of the vertex rays, radians.
    fn extent(&self, a: P, b: P, c: P) -> f64 {
        let r = [a, b, c].map(|p| self.rays.ray(p.0 as usize, p.1 as usize).normalize());
        let cos = r[0].dot(r[1]).min(r[1].dot(r[2])).min(r[2].dot(r[0]));
        cos.clamp(-1.0, 1.0).acos()
    }

    /// Where to split a triangle that spans too wide an angle: the lattice point of its longest edge
    /// (in angle) nearest the edge's middle, so the split shortens that edge in both triangles
    /// sharing it; when the edge holds none, the lattice point of the triangle nearest the middle,
    /// with the edge to flip away after the split.
    fn split_point(&self, a: P, b: P, c: P) -> Option<(P, Option<(P, P)>)> {
        let r = [a, b, c].map(|p| self.rays.ray(p.0 as usize, p.1 as usize).normalize());
        let (p, q) = [(0, 1), (1, 2), (2, 0)]
            .into_iter()
            .min_by(|&(i, j), &(k, l)| r[i].dot(r[j]).total_cmp(&r[k].dot(r[l])))
            .map(|(i, j)| ([a, b, c][i], [a, b, c][j]))
            .expect("three edges");
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let g = gcd(dx.unsigned_abs(), dy.unsigned_abs()) as i64;
        if g >= 2 {
            let k = g / 2;
            return Some(((p.0 + k * dx / g, p.1 + k * dy / g), None));
        }
        // No lattice point on the edge: split beside it, then flip it away ([`Self::step`]).
        self.nearest_point(a, b, c, ((p.0 + q.0) as f64 / 2.0, (p.1 + q.1) as f64 / 2.0))
            .map(|x| (x, Some((p, q))))
    }

    /// The lattice point of the triangle (not a vertex) nearest `(cx, cy)`, if any.
    fn nearest_point(&self, a: P, b: P, c: P, (cx, cy): (f64, f64)) -> Option<P> {
        let (y0, y1) = (a.1.min(b.1).min(c.1), a.1.max(b.1).max(c.1));
        let yc = (cy.round() as i64).clamp(y0, y1);
        let mut best: Option<(f64, P)> = None;
        // Rows outward from the centroid's; the first rows with points hold the nearest ones.
        for d in 0..=(y1 - y0) {
            for y in [yc - d, yc + d] {
                if y < y0 || y > y1 || (d == 0 && y != yc) {
                    continue;
                }
                let Some((lo, hi)) = row_span([a, b, c], y) else { continue };
                let x = (cx.round() as i64).clamp(lo, hi);
                for x in [x, x - 1, x + 1] {
                    let p = (x, y);
                    if x < lo || x > hi || p == a || p == b || p == c {
                        continue;
                    }
                    let dist = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
                    if best.is_none_or(|(bd, _)| dist < bd) {
                        best = Some((dist, p));
                    }
                }
            }
            if best.is_some_and(|(bd, _)| bd <= (d as f64).powi(2)) {
                break;
            }
        }
        best.map(|(_, p)| p)
    }

    fn step(&mut self) {
        let t = self.queue_pop() as usize;
        let (e0, e1, e2) = (3 * t, 3 * t + 1, 3 * t + 2);
        let [p0, p1, p2] = [self.tri[e0], self.tri[e1], self.tri[e2]];
        let [a, b, c] = self.vertices(t);
        let (p, away) = (self.scans[t].cand, self.scans[t].away);
        let pn = self.add_point(p);
        self.stats.insertions += 1;
        if edge(a, b, p) == 0 {
            self.split_edge(pn, e0);
        } else if edge(b, c, p) == 0 {
            self.split_edge(pn, e1);
        } else if edge(c, a, p) == 0 {
            self.split_edge(pn, e2);
        } else {
            let (h0, h1, h2) = (self.half[e0], self.half[e1], self.half[e2]);
            let t0 = self.add_triangle([p0, p1, pn], [h0, -1, -1], Some(e0), None);
            let t1 = self.add_triangle([p1, p2, pn], [h1, -1, t0 as i32 + 1], None, None);
            let t2 = self.add_triangle([p2, p0, pn], [h2, t0 as i32 + 2, t1 as i32 + 1], None, None);
            let mut edges = vec![t0, t1, t2];
            // A cap split beside a too-wide edge with no lattice point: flip that edge away (its
            // new triangles are refined by error like any other), so it is not split again and again.
            if let Some((u, v)) = away {
                let wide = [t0, t1, t2].into_iter().find(|&h| {
                    let (x, y) = (self.pts[self.tri[h] as usize], self.pts[self.tri[h + 1] as usize]);
                    (x, y) == (u, v) || (x, y) == (v, u)
                });
                if let Some((f0, f1)) = wide.and_then(|h| self.flip(h, None)) {
                    edges = vec![f0 + 1, f0 + 2, f1 + 1, f1 + 2];
                }
            }
            for h in edges {
                self.legalize(h);
            }
        }
    }
}

/// A meshed face.
pub struct FaceMesh {
    /// Canvas pixel ids, in the orientation of `edge` on the lattice.
    pub triangles: Vec<[u32; 3]>,
    /// Largest relative error of each triangle along the rays it covers.
    pub errors: Vec<f64>,
    /// Used-vertex flags of the lattice.
    pub used: Vec<bool>,
    /// Counters of the insertion run.
    pub stats: GreedyStats,
}

/// Mesh a clean lattice ([`is_clean`]) so that every pixel lies within relative distance `max_error`
/// of the mesh along its ray.
///
/// # Panics
/// When `max_error` is not a positive finite number ([`super::MeshOptions::check`] rejects those).
pub fn mesh_face(g: &Grid, max_error: f64, max_angle_deg: Option<f64>) -> FaceMesh {
    assert!(max_error.is_finite() && max_error > 0.0, "max_error must be positive");
    let mut m = Mesher::new(g, max_error, max_angle_deg.map(f64::to_radians));
    m.run();
    let mut used = vec![false; g.w * g.h];
    for p in &m.pts {
        used[p.1 as usize * g.w + p.0 as usize] = true;
    }
    let triangles = m
        .tri
        .chunks_exact(3)
        .map(|t| {
            [0, 1, 2].map(|k| {
                let p = m.pts[t[k] as usize];
                g.pixel(p.0 as usize, p.1 as usize)
            })
        })
        .collect();
    if let Some(cap) = m.cap {
        m.stats.over_cap = (0..m.tri.len() / 3)
            .filter(|&t| {
                let [a, b, c] = m.vertices(t);
                m.extent(a, b, c) > cap
            })
            .count();
    }
    let errors = m.scans.iter().map(|s| s.err).collect();
    FaceMesh { triangles, errors, used, stats: m.stats }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layer::{LayerImage, SampleType};
    use crate::mapping::CubeFace;
    use glam::DVec3;

    #[test]
    fn in_circle_matches_geometry() {
        // Square corners in the triangulation's orientation; the centre is inside, far points not.
        let (a, b, c) = ((4, 4), (0, 0), (0, 4));
        assert!(edge(a, b, c) > 0);
        assert!(in_circle(a, b, c, (2, 2)));
        assert!(in_circle(a, b, c, (3, 1)));
        assert!(!in_circle(a, b, c, (4, 0))); // cocircular: not strictly inside
        assert!(!in_circle(a, b, c, (9, 9)));
    }

    /// One `n × n` face lattice whose depth along each ray is `depth(unit ray)`.
    fn face_grid(face: CubeFace, n: usize, depth: impl Fn(DVec3) -> f64) -> Grid {
        let rays = Rays::face(face, n);
        let z: Vec<f32> = (0..n * n).map(|i| depth(rays.ray(i % n, i / n).normalize()) as f32).collect();
        let mut img = LayerImage::new(n, n);
        img.set_channel("Z", SampleType::F32, z);
        Grid::new(&img, 0, 0, n, n, rays)
    }

    /// Largest relative error of the face mesh over every lattice point, by ray/plane intersection in
    /// f64 (independent of the scan: barycentric location of each point, then the 3D plane).
    fn brute_max_error(g: &Grid, f: &FaceMesh) -> f64 {
        let lattice = |id: u32| ((id as usize % g.canvas_w) as i64, (id as usize / g.canvas_w) as i64);
        let mut worst = 0.0f64;
        for t in &f.triangles {
            let v = t.map(lattice);
            let p = v.map(|q| g.point(q.0 as usize, q.1 as usize));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let (y0, y1) = (v[0].1.min(v[1].1).min(v[2].1), v[0].1.max(v[1].1).max(v[2].1));
            for y in y0..=y1 {
                let Some((lo, hi)) = row_span(v, y) else { continue };
                for x in lo..=hi {
                    let r = g.rays.ray(x as usize, y as usize);
                    let hit = n.dot(p[0]) / n.dot(r);
                    let truth = g.lambda[y as usize * g.w + x as usize] as f64;
                    worst = worst.max((hit - truth).abs() / truth);
                }
            }
        }
        worst
    }

    /// Each lattice point is covered by the triangles exactly once, or on shared edges.
    fn assert_covers_lattice(g: &Grid, f: &FaceMesh) {
        let lattice = |id: u32| ((id as usize % g.canvas_w) as i64, (id as usize / g.canvas_w) as i64);
        let mut inside = vec![0u32; g.w * g.h];
        let mut area2 = 0i64;
        for t in &f.triangles {
            let v = t.map(lattice);
            assert!(edge(v[0], v[1], v[2]) > 0, "degenerate or flipped triangle {v:?}");
            area2 += edge(v[0], v[1], v[2]);
            let (y0, y1) = (v[0].1.min(v[1].1).min(v[2].1), v[0].1.max(v[1].1).max(v[2].1));
            for y in y0..=y1 {
                if let Some((lo, hi)) = row_span(v, y) {
                    for x in lo..=hi {
                        inside[y as usize * g.w + x as usize] += 1;
                    }
                }
            }
        }
        // The triangles tile the lattice rectangle: areas add up and every point is covered.
        assert_eq!(area2, 2 * (g.w as i64 - 1) * (g.h as i64 - 1));
        assert!(inside.iter().all(|&c| c >= 1));
    }

    #[test]
    fn a_plane_needs_two_triangles() {
        // The floor z = −1.5 fills the whole bottom face: nothing to insert.
        let g = face_grid(CubeFace::NegZ, 64, |d| -1.5 / d.z);
        assert!(is_clean(&g));
        let f = mesh_face(&g, 1e-6, None);
        assert_eq!((f.triangles.len(), f.stats.insertions), (2, 0));
        assert!(brute_max_error(&g, &f) < 1e-6);
        assert_covers_lattice(&g, &f);
    }

    /// Distance along `d` to a sphere of radius 3 centred off the origin: curved everywhere, seen
    /// from inside.
    fn sphere(d: DVec3) -> f64 {
        let c = DVec3::new(0.4, -0.3, 0.2);
        let b = d.dot(c);
        b + (b * b - c.length_squared() + 9.0).sqrt()
    }

    #[test]
    fn the_bound_holds_on_every_pixel_of_a_curved_surface() {
        for face in [CubeFace::PosX, CubeFace::NegY] {
            let g = face_grid(face, 96, sphere);
            assert!(is_clean(&g));
            let mut last = 0;
            for e in [1e-2, 1e-3, 1e-4] {
                let f = mesh_face(&g, e, None);
                let worst = brute_max_error(&g, &f);
                assert!(worst <= e * (1.0 + 1e-6), "{face:?} e {e}: {worst}");
                // The reported errors are the brute-force ones.
                let reported = f.errors.iter().cloned().fold(0.0, f64::max);
                assert!(
                    (reported - worst).abs() <= 1e-9 * worst.max(1e-6),
                    "reported {reported} brute {worst}"
                );
                assert_covers_lattice(&g, &f);
                assert!(f.triangles.len() >= last, "a tighter bound gave fewer triangles");
                last = f.triangles.len();
            }
        }
    }

    #[test]
    fn noise_below_the_tolerance_refines_down_to_pixels_and_stays_exact() {
        // ±0.1 % pseudo-random noise on a plane, tolerance 1e-4: most pixels must become vertices.
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut noise = vec![0.0; 48 * 48];
        for v in &mut noise {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            *v = (seed % 2001) as f64 / 1e6 - 1e-3;
        }
        let rays = Rays::face(CubeFace::NegZ, 48);
        let mut z = vec![0.0f32; 48 * 48];
        for (i, zi) in z.iter_mut().enumerate() {
            let d = rays.ray(i % 48, i / 48).normalize();
            *zi = (-1.5 / d.z * (1.0 + noise[i])) as f32;
        }
        let mut img = LayerImage::new(48, 48);
        img.set_channel("Z", SampleType::F32, z);
        let g = Grid::new(&img, 0, 0, 48, 48, rays);
        assert!(is_clean(&g));
        let f = mesh_face(&g, 1e-4, None);
        assert!(f.stats.insertions > 48 * 48 / 2, "{:?}", f.stats);
        assert!(brute_max_error(&g, &f) <= 1e-4 * (1.0 + 1e-6));
        assert_covers_lattice(&g, &f);
    }

    #[test]
    fn tiny_and_huge_depths_mesh_alike() {
        // The same curved surface at 1e-6 m and at 1e9 m: relative errors are scale-free, so the
        // meshes are the same and within the bound (no overflow, no NaN in the plane or the scan).
        let mut counts = Vec::new();
        for scale in [1e-6, 1.0, 1e9] {
            let g = face_grid(CubeFace::PosY, 64, |d| scale * sphere(d));
            assert!(is_clean(&g));
            let f = mesh_face(&g, 1e-3, None);
            let worst = brute_max_error(&g, &f);
            assert!(worst.is_finite() && worst <= 1e-3 * (1.0 + 1e-6), "scale {scale}: {worst}");
            assert_covers_lattice(&g, &f);
            counts.push(f.triangles.len());
        }
        // f32 samples round differently at each scale; the meshes agree to a few triangles.
        assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 4, "{counts:?}");
    }

    #[test]
    fn the_angle_cap_splits_large_flat_triangles() {
        let g = face_grid(CubeFace::NegZ, 64, |d| -1.5 / d.z);
        assert!(is_clean(&g));
        let cap = 20.0f64;
        let f = mesh_face(&g, 0.01, Some(cap));
        assert!(f.triangles.len() > 2);
        assert_eq!(f.stats.over_cap, 0);
        // Independent of the reported count: every triangle measured.
        assert_eq!(over_cap(&g, &f, cap).0, 0);
        assert_covers_lattice(&g, &f);
    }

    /// Triangles of `f` whose vertex rays span more than `cap` degrees, and slivers (lattice area ½).
    fn over_cap(g: &Grid, f: &FaceMesh, cap: f64) -> (usize, usize) {
        let lattice = |id: u32| ((id as usize % g.canvas_w) as i64, (id as usize / g.canvas_w) as i64);
        let mut over = 0;
        let mut slivers = 0;
        for t in &f.triangles {
            let v = t.map(lattice);
            let r = v.map(|p| g.rays.ray(p.0 as usize, p.1 as usize).normalize());
            let cos = r[0].dot(r[1]).min(r[1].dot(r[2])).min(r[2].dot(r[0]));
            over += (cos.clamp(-1.0, 1.0).acos().to_degrees() > cap + 1e-9) as usize;
            slivers += (edge(v[0], v[1], v[2]) == 1) as usize;
        }
        (over, slivers)
    }

    #[test]
    fn triangles_left_over_the_angle_cap_are_reported() {
        // A wavy wall: its long edges often hold no lattice point, so cap splits must flip them away.
        let wavy = |d: DVec3| (2.0 + 0.05 * (9.0 * d.y).sin() * (7.0 * d.z).cos()) / d.x;
        let g = face_grid(CubeFace::PosX, 128, wavy);
        assert!(is_clean(&g));
        for cap in [10.0, 20.0] {
            let free = mesh_face(&g, 1e-3, None);
            let f = mesh_face(&g, 1e-3, Some(cap));
            let (over, slivers) = over_cap(&g, &f, cap);
            let (_, free_slivers) = over_cap(&g, &free, 180.0);
            eprintln!(
                "cap {cap}: {} triangles ({} free), {over} over the cap, {slivers} slivers ({free_slivers} free)",
                f.triangles.len(),
                free.triangles.len()
            );
            // What is left over the cap is reported, so that `mesh_layer` can use the quadtree.
            assert_eq!(over, f.stats.over_cap, "cap {cap}");
            assert!(brute_max_error(&g, &f) <= 1e-3 * (1.0 + 1e-6));
            assert_covers_lattice(&g, &f);
        }
    }

    #[test]
    fn unclean_lattices_are_refused() {
        let plane = |d: DVec3| -1.5 / d.z;
        // A 60 % step (a depth jump) in one corner, then one invalid pixel.
        let g =
            face_grid(CubeFace::NegZ, 32, |d| if d.x > 0.3 && d.y > 0.3 { 1.6 * plane(d) } else { plane(d) });
        assert!(!is_clean(&g));
        let mut g = face_grid(CubeFace::NegZ, 32, plane);
        assert!(is_clean(&g));
        g.lambda[5 * 32 + 7] = f32::NAN;
        g.depth[5 * 32 + 7] = f32::NAN;
        assert!(!is_clean(&g));
    }

    /// The branch-free f32 join test of [`is_clean`] is exactly [`Grid::bad_cell`]'s f64
    /// test, also within an ulp of the 1.5 ratio.
    #[test]
    fn clean_check_agrees_with_bad_cell_at_the_threshold() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for _ in 0..20_000 {
            let a = f32::from_bits(0x3e00_0000 + (next() % 0x0400_0000) as u32); // 0.125 … 32
                                                                                 // b at a·1.5 give or take a few ulps, or random.
            let b = match next() % 3 {
                0 => f32::from_bits(((a * 1.5).to_bits() as i64 + (next() % 7) as i64 - 3) as u32),
                1 => f32::from_bits(((a / 1.5).to_bits() as i64 + (next() % 7) as i64 - 3) as u32),
                _ => a * (0.3 + (next() % 1000) as f32 / 400.0),
            };
            let mut img = LayerImage::new(2, 2);
            img.set_channel("Z", SampleType::F32, vec![a, b, a, b]);
            let g = Grid::new(&img, 0, 0, 2, 2, Rays::face(CubeFace::PosX, 2));
            // Depths along the rays differ from Z only by the ray length: compare on the grid's own.
            let clean = is_clean(&g);
            assert_eq!(clean, !g.bad_cell(0, 0), "a {a} b {b}");
        }
    }
}
