//! The 3D error of a mesh against its layer: every valid pixel's ray is intersected with the mesh and
//! the hit distance compared with the sample (absolute, metres, and relative to the sample).
//!
//! This is independent of how the mesh was built (it measures Delatin meshes the same way): each
//! triangle is projected onto the canvas (the cube face planes, or azimuth/polar angle), and the pixels
//! of its bounding box are ray-cast exactly (Möller–Trumbore). When a ray hits several triangles the
//! nearest hit counts, as a renderer would show it. Pixels no triangle covers are counted, not scored.

use glam::DVec3;
use rayon::prelude::*;

use crate::layer::{classify, LayerImage, Sample};
use crate::mapping::{AnyMapping, CubeFace, DirTable, Equirect, FacePoint, Mapping};

/// Error figures over the valid pixels that the mesh covers.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    /// Valid (finite-depth) pixels of the layer.
    pub pixels: usize,
    /// Valid pixels whose ray misses the mesh.
    pub unhit: usize,
    /// Largest distance along the ray between hit and sample, metres (0 when nothing is hit).
    pub max_abs: f64,
    /// 99th percentile of the absolute distance, metres.
    pub p99_abs: f64,
    /// Root mean square of the absolute distance, metres.
    pub rms_abs: f64,
    /// Largest absolute distance divided by the sample's depth (0.01 = 1 %).
    pub max_rel: f64,
    /// 99th percentile of the relative distance.
    pub p99_rel: f64,
    /// Root mean square of the relative distance.
    pub rms_rel: f64,
}

const EPS: f64 = 1e-9;

/// Distance along unit ray `d` (origin at the centre) to triangle `p`, if hit.
#[inline]
pub(crate) fn ray_hit(d: DVec3, p: [DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-300 {
        return None;
    }
    let f = 1.0 / a;
    let s = -p[0];
    let u = f * s.dot(h);
    if !(-EPS..=1.0 + EPS).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = f * d.dot(q);
    if v < -EPS || u + v > 1.0 + EPS {
        return None;
    }
    let t = f * e2.dot(q);
    (t > 0.0).then_some(t)
}

/// Canvas pixel rectangles `[x0, x1] × [y0, y1]` (inclusive) that may see the triangle.
pub(crate) fn candidates(mapping: &AnyMapping, p: [DVec3; 3]) -> Vec<[usize; 4]> {
    match mapping {
        AnyMapping::Cube(c) => cube_candidates(c.face_size(), p),
        AnyMapping::Equirect(e) => equirect_candidates(e, p),
    }
}

fn cube_candidates(n: usize, p: [DVec3; 3]) -> Vec<[usize; 4]> {
    let mut faces: Vec<CubeFace> = p.iter().map(|v| FacePoint::from_dir(*v).face).collect();
    faces.sort_by_key(|f| f.index());
    faces.dedup();
    let nf = n as f64;
    faces
        .into_iter()
        .map(|f| {
            let [c, r, d] = f.frame();
            let (s0, t0) = f.grid();
            let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
            for v in p {
                let z = v.dot(c);
                if z <= 1e-12 * v.length() {
                    b = [0.0, 0.0, nf, nf];
                    break;
                }
                let (x, y) = ((v.dot(r) / z + 1.0) * 0.5 * nf - 0.5, (v.dot(d) / z + 1.0) * 0.5 * nf - 0.5);
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
            let lo = |v: f64| (v.floor() - 1.0).clamp(0.0, nf - 1.0) as usize;
            let hi = |v: f64| (v.ceil() + 1.0).clamp(0.0, nf - 1.0) as usize;
            [s0 * n + lo(b[0]), t0 * n + lo(b[1]), s0 * n + hi(b[2]), t0 * n + hi(b[3])]
        })
        .collect()
}

fn equirect_candidates(e: &Equirect, p: [DVec3; 3]) -> Vec<[usize; 4]> {
    let (w, h) = (e.width() as f64, e.height() as f64);
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let (mut north, mut south) = (false, false);
    // A great-circle edge bulges towards a pole beyond its ends: add its extreme latitudes.
    for k in 0..3 {
        let (a, b) = (p[k].normalize(), p[(k + 1) % 3].normalize());
        let n = a.cross(b);
        let l2 = n.length_squared();
        if l2.is_nan() || l2 <= 1e-30 {
            continue;
        }
        let n = n.normalize();
        let top = DVec3::Z - n * n.z;
        if top.length_squared() <= 1e-30 {
            continue;
        }
        let top = top.normalize();
        for q in [top, -top] {
            if a.cross(q).dot(n) >= 0.0 && q.cross(b).dot(n) >= 0.0 {
                ys.push(q.z.clamp(-1.0, 1.0).acos() / std::f64::consts::PI * h - 0.5);
            }
        }
    }
    for v in p {
        let Some((phi, theta)) = Equirect::angles(v) else { continue };
        ys.push(theta / std::f64::consts::PI * h - 0.5);
        if v.x.hypot(v.y) <= 1e-9 * v.length() {
            north |= v.z > 0.0;
            south |= v.z < 0.0;
        } else {
            xs.push(phi / std::f64::consts::TAU * w - 0.5);
        }
    }
    let ymin = if north { 0.0 } else { ys.iter().copied().fold(f64::INFINITY, f64::min) };
    let ymax = if south { h } else { ys.iter().copied().fold(f64::NEG_INFINITY, f64::max) };
    let y0 = (ymin.floor() - 1.0).clamp(0.0, h - 1.0) as usize;
    let y1 = (ymax.ceil() + 1.0).clamp(0.0, h - 1.0) as usize;
    if xs.is_empty() {
        return vec![[0, y0, w as usize - 1, y1]];
    }
    let (mn, mx) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    if mx - mn > 0.5 * w {
        // Across the seam: shift the low side by one turn.
        for x in xs.iter_mut() {
            if *x < 0.5 * w {
                *x += w;
            }
        }
    }
    let mn = xs.iter().copied().fold(f64::INFINITY, f64::min).floor() as i64 - 1;
    let mx = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max).ceil() as i64 + 1;
    let wi = w as i64;
    if mx - mn + 1 >= wi {
        return vec![[0, y0, w as usize - 1, y1]];
    }
    let (a, b) = (mn.rem_euclid(wi) as usize, mx.rem_euclid(wi) as usize);
    if a <= b {
        vec![[a, y0, b, y1]]
    } else {
        vec![[a, y0, w as usize - 1, y1], [0, y0, b, y1]]
    }
}

/// Nearest hit distance along every canvas pixel's ray (`+∞` where the mesh is missed). Triangles are
/// cast in parallel chunks, each into its own buffer, merged by minimum (exact: the result does not
/// depend on the split).
pub fn hit_distances(positions: &[DVec3], triangles: &[[u32; 3]], mapping: &AnyMapping) -> Vec<f64> {
    let (w, h) = (mapping.width(), mapping.height());
    let dirs = DirTable::new(*mapping);
    // A full-canvas buffer per chunk: a few chunks keep both cores busy without memory growing with them.
    let chunk = triangles.len().div_ceil(rayon::current_num_threads().clamp(1, 4)).max(1);
    let cast = |tris: &[[u32; 3]]| {
        let mut hits = vec![f64::INFINITY; w * h];
        for t in tris {
            let p = t.map(|i| positions[i as usize]);
            for [x0, y0, x1, y1] in candidates(mapping, p) {
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        if let Some(d) = ray_hit(dirs.get(x, y), p) {
                            let slot = &mut hits[y * w + x];
                            *slot = slot.min(d);
                        }
                    }
                }
            }
        }
        hits
    };
    triangles
        .par_chunks(chunk)
        .map(cast)
        .reduce_with(|mut a, b| {
            a.iter_mut().zip(&b).for_each(|(x, y)| *x = x.min(*y));
            a
        })
        .unwrap_or_else(|| vec![f64::INFINITY; w * h])
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let k = (((v.len() - 1) as f64) * q).round() as usize;
    *v.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
}

/// Error of a mesh (panorama-local positions) against a full-canvas layer.
pub fn measure(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    image: &LayerImage,
    mapping: &AnyMapping,
) -> ErrorStats {
    let hits = hit_distances(positions, triangles, mapping);
    let (Some(z), a) = (image.depth(), image.coverage()) else { return ErrorStats::default() };
    let mut stats = ErrorStats::default();
    let (mut abs, mut rel) = (Vec::new(), Vec::new());
    for (i, &t) in hits.iter().enumerate() {
        let Sample::Surface(d) = classify(z[i], a.map(|a| a[i])) else { continue };
        if !(d > 0.0 && d.is_finite()) {
            continue;
        }
        stats.pixels += 1;
        if !t.is_finite() {
            stats.unhit += 1;
            continue;
        }
        let e = (t - d as f64).abs();
        abs.push(e);
        rel.push(e / d as f64);
    }
    let rms = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
        }
    };
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    stats.max_abs = max(&abs);
    stats.max_rel = max(&rel);
    stats.rms_abs = rms(&abs);
    stats.rms_rel = rms(&rel);
    stats.p99_abs = percentile(&mut abs, 0.99);
    stats.p99_rel = percentile(&mut rel, 0.99);
    stats
}
