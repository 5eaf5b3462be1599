//! Rays through a triangle scene: every hit along a ray (the multi-hit of thesis 6.3.2), and
//! whether a segment or a ray is free. The BVH is `obvhs`'s compressed wide BVH; the triangle test
//! is ours, tolerant at edges so that a ray through a shared edge hits (once: equal hits merge).

use glam::{DVec3, Vec3, Vec3A};
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, CwBvh};
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::load::TriangleScene;

/// Barycentric slack of the triangle test: a ray through a shared edge must hit one side.
const EDGE_SLACK: f32 = 1e-6;

/// One intersection of a ray with a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray, metres.
    pub t: f32,
    /// Triangle index.
    pub tri: u32,
    /// Barycentric weight of corner 1.
    pub u: f32,
    /// Barycentric weight of corner 2.
    pub v: f32,
}

/// A scene's triangles in a BVH, with what the tests need.
pub struct Tracer<'a> {
    scene: &'a TriangleScene,
    bvh: CwBvh,
    /// Triangles in the BVH's primitive order.
    tris: Vec<Triangle>,
    /// Whether each triangle (BVH order) is seen from its back.
    two_sided: Vec<bool>,
    /// Unit face normal of each triangle (scene order).
    normals: Vec<Vec3>,
}

impl<'a> Tracer<'a> {
    /// Build the BVH of `scene`.
    pub fn new(scene: &'a TriangleScene) -> Tracer<'a> {
        let tris: Vec<Triangle> = scene
            .positions
            .iter()
            .map(|p| Triangle { v0: p[0].into(), v1: p[1].into(), v2: p[2].into() })
            .collect();
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Default::default());
        let order: Vec<usize> = bvh.primitive_indices.iter().map(|&i| i as usize).collect();
        let two_sided = order
            .iter()
            .map(|&i| scene.materials.get(scene.material[i] as usize).is_none_or(|m| m.double_sided))
            .collect();
        let tris = order.iter().map(|&i| tris[i]).collect();
        let normals =
            scene.positions.iter().map(|p| (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()).collect();
        Tracer { scene, bvh, tris, two_sided, normals }
    }

    /// The scene traced.
    pub fn scene(&self) -> &TriangleScene {
        self.scene
    }

    /// Unit face normal of triangle `tri` (counter-clockwise front).
    pub fn normal(&self, tri: u32) -> Vec3 {
        self.normals[tri as usize]
    }

    /// Every hit along the ray from `origin` along unit `dir` (in `out`, nearest first): back
    /// faces of single-sided materials are passed through, hits at one distance (a shared edge)
    /// count once, and each distance is refined in double precision.
    pub fn hits(&self, origin: Vec3, dir: Vec3, out: &mut Vec<Hit>) {
        out.clear();
        let ray = Ray::new(origin.into(), dir.into(), 0.0, f32::INFINITY);
        self.bvh.ray_traverse_anyhit(ray, |ray, id| {
            if let Some((t, u, v)) = self.intersect(id, ray) {
                out.push(Hit { t, tri: self.bvh.primitive_indices[id], u, v });
            }
        });
        for h in out.iter_mut() {
            h.t = self.exact_t(h.tri, origin, dir).unwrap_or(h.t);
        }
        out.sort_by(|a, b| a.t.total_cmp(&b.t));
        out.dedup_by(|b, a| b.t - a.t <= 1e-6 * a.t.max(1e-3));
    }

    /// Whether something lies between `from` and `to` (both excluded: `to` is usually on a
    /// surface).
    pub fn blocked(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return false;
        }
        let ray = Ray::new(from.into(), (d / len).into(), 0.0, len * (1.0 - 1e-4) - 1e-6);
        !self.bvh.ray_traverse_miss(ray, |ray, id| self.intersect(id, ray).map_or(f32::INFINITY, |h| h.0))
    }

    /// Whether the ray from `from` along unit `dir` meets nothing.
    pub fn escapes(&self, from: Vec3, dir: Vec3) -> bool {
        let ray = Ray::new(from.into(), dir.into(), 0.0, f32::INFINITY);
        self.bvh.ray_traverse_miss(ray, |ray, id| self.intersect(id, ray).map_or(f32::INFINITY, |h| h.0))
    }

    /// Möller–Trumbore on BVH primitive `id`, with [`EDGE_SLACK`]; `(t, u, v)` within the ray's
    /// range, `None` for a miss or a single-sided back face.
    #[inline]
    fn intersect(&self, id: usize, ray: &Ray) -> Option<(f32, f32, f32)> {
        let tri = &self.tris[id];
        let e1 = tri.v1 - tri.v0;
        let e2 = tri.v2 - tri.v0;
        let pv = ray.direction.cross(e2);
        let det = e1.dot(pv);
        // det < 0: the ray meets the back face (normal e1 × e2 along the ray).
        if det == 0.0 || !det.is_finite() || (det < 0.0 && !self.two_sided[id]) {
            return None;
        }
        let inv = 1.0 / det;
        let tv: Vec3A = ray.origin - tri.v0;
        let u = tv.dot(pv) * inv;
        if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
            return None;
        }
        let qv = tv.cross(e1);
        let v = ray.direction.dot(qv) * inv;
        if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
            return None;
        }
        let t = e2.dot(qv) * inv;
        (t > ray.tmin && t < ray.tmax).then_some((t, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)))
    }

    /// Barycentric `(u, v)` where the ray from the centre along `dir` meets triangle `tri`'s
    /// plane, clamped into the triangle (the nearest corner weights inside it).
    pub fn barycentric_clamped(&self, tri: u32, dir: Vec3) -> (f32, f32) {
        let p = &self.scene.positions[tri as usize];
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let n = e1.cross(e2);
        let t = n.dot(p[0]) / n.dot(dir);
        let q = dir * t - p[0];
        // Solve q = u·e1 + v·e2 in the plane (least squares on the 2×2 Gram matrix).
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (b1, b2) = (q.dot(e1), q.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let (mut u, mut v) = ((b1 * d22 - b2 * d12) / det, (b2 * d11 - b1 * d12) / det);
        if !(u.is_finite() && v.is_finite()) {
            return (1.0 / 3.0, 1.0 / 3.0);
        }
        u = u.max(0.0);
        v = v.max(0.0);
        let sum = u + v;
        if sum > 1.0 {
            (u, v) = (u / sum, v / sum);
        }
        (u, v)
    }

    /// The distance to triangle `tri`'s plane along the ray, in f64.
    fn exact_t(&self, tri: u32, origin: Vec3, dir: Vec3) -> Option<f32> {
        let p = self.scene.positions[tri as usize].map(|c| c.as_dvec3());
        let n: DVec3 = (p[1] - p[0]).cross(p[2] - p[0]);
        let denom = n.dot(dir.as_dvec3());
        let t = n.dot(p[0] - origin.as_dvec3()) / denom;
        (t.is_finite() && t > 0.0).then_some(t as f32)
    }
}
