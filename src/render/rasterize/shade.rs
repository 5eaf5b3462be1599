//! Deferred colour: the nearest surface point of a pixel mapped back to its layer's canvas and
//! sampled there (spec §9.4b).

use glam::DVec3;

use crate::layer::{classify, LayerImage, Sample};
use crate::mapping::{AnyMapping, Mapping};

use super::LayerGeometry;

/// One layer's planes used for colour lookups.
pub(super) struct Planes<'a> {
    pub(super) mapping: AnyMapping,
    pub(super) z: &'a [f32],
    pub(super) coverage: Option<&'a [f32]>,
    pub(super) rgb: [&'a [f32]; 3],
    /// The layer has infinity samples.
    pub(super) has_infinity: bool,
}

impl<'a> Planes<'a> {
    pub(super) fn new(image: &'a LayerImage, mapping: AnyMapping, has_infinity: bool) -> Planes<'a> {
        let get = |name: &str| image.channel(name).map(|c| c.data.as_slice()).unwrap_or(&[]);
        let z = get("Z");
        let coverage = image.coverage();
        Planes { mapping, z, coverage, rgb: [get("R"), get("G"), get("B")], has_infinity }
    }

    #[inline]
    pub(super) fn sample(&self, p: usize) -> Sample {
        classify(self.z[p], self.coverage.map(|a| a[p]))
    }

    #[inline]
    fn rgb(&self, p: usize) -> [f32; 3] {
        [self.rgb[0][p], self.rgb[1][p], self.rgb[2][p]]
    }

    /// The four bilinear taps (pixel index, weight) of local direction `d`: across the seam on the
    /// equirect (clamped at the poles), clamped to the face of the nearest pixel on a cube map.
    fn taps(&self, d: DVec3) -> [(usize, f64); 4] {
        let m = &self.mapping;
        let (w, h) = (m.width(), m.height());
        let p = m.dir_to_pixel(d);
        let (ox, oy, fw, fh, wrap) = match m {
            AnyMapping::Equirect(_) => (0, 0, w, h, true),
            AnyMapping::Cube(c) => {
                let n = c.face_size();
                let fx = ((p.x / n as f64) as usize).min(2);
                let fy = ((p.y / n as f64) as usize).min(1);
                (fx * n, fy * n, n, n, false)
            }
        };
        let u = (p.x - ox as f64 - 0.5).clamp(if wrap { -0.5 } else { 0.0 }, fw as f64 - 1.0);
        let v = (p.y - oy as f64 - 0.5).clamp(0.0, fh as f64 - 1.0);
        let (i0, j0) = (u.floor(), v.floor());
        let (ax, ay) = (u - i0, v - j0);
        let col = |i: f64| -> usize {
            let i = i as i64;
            if wrap {
                i.rem_euclid(fw as i64) as usize
            } else {
                i.clamp(0, fw as i64 - 1) as usize
            }
        };
        let row = |j: f64| (j as i64).clamp(0, fh as i64 - 1) as usize;
        let (c0, c1, r0, r1) = (col(i0), col(i0 + 1.0), row(j0), row(j0 + 1.0));
        let at = |c: usize, r: usize| (oy + r) * w + ox + c;
        [
            (at(c0, r0), (1.0 - ax) * (1.0 - ay)),
            (at(c1, r0), ax * (1.0 - ay)),
            (at(c0, r1), (1.0 - ax) * ay),
            (at(c1, r1), ax * ay),
        ]
    }

    /// Colour of the surface point at local distance `dist` along local direction `d`: bilinear
    /// over the taps of the same surface (finite depth within `jump`); `None` when no tap is.
    pub(super) fn surface_colour(&self, d: DVec3, dist: f64, jump: f64) -> Option<[f32; 3]> {
        let mut sum = [0.0f64; 3];
        let mut wsum = 0.0;
        for (p, wt) in self.taps(d) {
            if let Sample::Surface(z) = self.sample(p) {
                let z = z as f64;
                if z > 0.0 && z.is_finite() && (z - dist).abs() <= jump * z.min(dist) {
                    let c = self.rgb(p);
                    for k in 0..3 {
                        sum[k] += wt * c[k] as f64;
                    }
                    wsum += wt;
                }
            }
        }
        (wsum > 0.0).then(|| sum.map(|s| (s / wsum) as f32))
    }

    /// Colour of infinity content in local direction `d`: bilinear over the infinite taps; `None`
    /// when no tap is infinite.
    pub(super) fn infinity_colour(&self, d: DVec3) -> Option<[f32; 3]> {
        let mut sum = [0.0f64; 3];
        let mut wsum = 0.0;
        let mut any = false;
        for (p, wt) in self.taps(d) {
            if matches!(self.sample(p), Sample::Infinite) {
                any = true;
                let c = self.rgb(p);
                for k in 0..3 {
                    sum[k] += wt * c[k] as f64;
                }
                wsum += wt;
            }
        }
        if !any {
            return None;
        }
        if wsum <= 0.0 {
            // Only zero-weight taps are infinite: the pixel is at the edge of the sky; use them.
            for (p, _) in self.taps(d) {
                if matches!(self.sample(p), Sample::Infinite) {
                    return Some(self.rgb(p));
                }
            }
        }
        Some(sum.map(|s| (s / wsum) as f32))
    }
}

/// Fallback colour of a fragment whose bilinear taps are all of another surface: the colour of the
/// triangle's vertex nearest in direction (pole vertices have no pixel).
pub(super) fn nearest_vertex_colour(p: &Planes, m: &LayerGeometry, tri: u32, local: DVec3) -> [f32; 3] {
    let m = &m.mesh;
    let Some(t) = m.triangles.get(tri as usize) else { return [0.0; 3] };
    let d = local.normalize_or_zero();
    let mut best: Option<(f64, usize)> = None;
    for &v in t {
        let src = m.sources[v as usize] as usize;
        if src >= m.width * m.height {
            continue;
        }
        let cos = m.positions[v as usize].normalize_or_zero().dot(d);
        if best.is_none_or(|(b, _)| cos > b) {
            best = Some((cos, src));
        }
    }
    best.map_or([0.0; 3], |(_, src)| p.rgb(src))
}
