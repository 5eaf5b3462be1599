//! Triangle set-up against pixel rays, near-plane clipping, the equirect candidate regions and the
//! rasterisation of one band of output rows.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use crate::render::camera::{Camera, EquirectCamera, OdsEye};

use super::{RasterCounts, RasterOptions, BAND};

/// A triangle set up for drawing.
#[derive(Clone, Copy, Debug)]
pub(super) struct Prep {
    /// Inward edge planes through the eye (camera space): a ray `r` is inside when `e[i]·r > 0`,
    /// or `= 0` and `tie[i]`.
    pub(super) e: [DVec3; 3],
    pub(super) tie: [bool; 3],
    /// Plane of the triangle: `n·p = d` (camera space).
    pub(super) n: DVec3,
    pub(super) d: f64,
    pub(super) layer: u32,
    pub(super) tri: u32,
    /// Candidate pixel rows and columns (inclusive). Columns may exceed the width on a wrapping
    /// camera (taken modulo the width).
    pub(super) y0: u32,
    pub(super) y1: u32,
    pub(super) x0: i64,
    pub(super) x1: i64,
}

/// The output camera, reduced to what the rasteriser needs.
pub(super) enum Cam {
    Persp {
        w: usize,
        h: usize,
        f: f64,
        cx: f64,
        cy: f64,
    },
    /// Per-row `(sin θ, cos θ)`, per-column `(cos φ, sin φ)` of pixel centres.
    Equi {
        w: usize,
        h: usize,
        rows: Vec<(f64, f64)>,
        cols: Vec<(f64, f64)>,
    },
}

impl Cam {
    pub(super) fn new(camera: &Camera) -> Cam {
        match camera {
            Camera::Perspective(c) => Cam::Persp {
                w: c.width,
                h: c.height,
                f: c.focal,
                cx: c.width as f64 / 2.0,
                cy: c.height as f64 / 2.0,
            },
            Camera::Equirect(EquirectCamera { width, height, .. })
            | Camera::Ods(OdsEye { width, height, .. }) => Cam::equirect(*width, *height),
            // The half equirect is the middle half of a full one in its camera space.
            Camera::HalfEquirect(c) => Cam::equirect(2 * c.width, c.height),
        }
    }

    fn equirect(w: usize, h: usize) -> Cam {
        Cam::Equi {
            w,
            h,
            rows: (0..h).map(|j| (PI * (j as f64 + 0.5) / h as f64).sin_cos()).collect(),
            cols: (0..w)
                .map(|i| {
                    let (s, c) = (TAU * (i as f64 + 0.5) / w as f64).sin_cos();
                    (c, s)
                })
                .collect(),
        }
    }

    pub(super) fn size(&self) -> (usize, usize) {
        match self {
            Cam::Persp { w, h, .. } | Cam::Equi { w, h, .. } => (*w, *h),
        }
    }

    /// Camera-space ray through the centre of pixel `(x, y)`: `(x − cx, cy − y, f)` for a
    /// perspective camera (so `t·r` has `z = t·f`), unit for the equirect.
    #[inline]
    pub(super) fn ray(&self, x: usize, y: usize) -> DVec3 {
        match self {
            Cam::Persp { f, cx, cy, .. } => DVec3::new(x as f64 + 0.5 - cx, cy - (y as f64 + 0.5), *f),
            Cam::Equi { rows, cols, .. } => {
                let ((st, ct), (cp, sp)) = (rows[y], cols[x]);
                DVec3::new(st * cp, st * sp, ct)
            }
        }
    }
}

/// Canonical edge plane: `a × b` with the vertices ordered by id, and whether that order was swapped.
#[inline]
pub(super) fn edge_plane(ia: u32, a: DVec3, ib: u32, b: DVec3) -> (DVec3, bool) {
    if ia <= ib {
        (a.cross(b), false)
    } else {
        (b.cross(a), true)
    }
}

/// Whether ray `r` is inside a triangle's edge planes.
#[inline]
pub(super) fn inside(p: &Prep, r: DVec3) -> bool {
    (0..3).all(|i| {
        let s = p.e[i].dot(r);
        s > 0.0 || (s == 0.0 && p.tie[i])
    })
}

pub(super) struct Setup<'a> {
    pub(super) cam: &'a Cam,
    pub(super) o: RasterOptions,
    /// Frustum planes through the eye (perspective): a point is inside when all dot products ≥ 0.
    pub(super) frustum: Option<[DVec3; 4]>,
}

impl Setup<'_> {
    /// Set up triangle `tri` of `layer`; `None` when it is not drawn (counted in `n`).
    pub(super) fn prep(
        &self,
        layer: u32,
        tri: u32,
        v: [u32; 3],
        cam: &[DVec3],
        n: &mut RasterCounts,
    ) -> Option<Prep> {
        n.triangles += 1;
        let c = v.map(|i| cam[i as usize]);
        if !c.iter().all(|p| p.is_finite()) {
            n.triangles_culled += 1;
            return None;
        }
        let normal = (c[1] - c[0]).cross(c[2] - c[0]);
        let det = normal.dot(c[0]);
        if !(det.is_finite() && normal.is_finite()) || det == 0.0 {
            n.triangles_culled += 1;
            return None;
        }
        let sigma = det.signum();
        let mut e = [DVec3::ZERO; 3];
        let mut tie = [false; 3];
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            let (plane, swapped) = edge_plane(v[a], c[a], v[b], c[b]);
            // Inside is where (c[a] × c[b])·r has the sign of det.
            let s = if swapped { -sigma } else { sigma };
            e[k] = plane * s;
            tie[k] = s > 0.0;
        }
        let region = match self.cam {
            Cam::Persp { w, h, f, cx, cy } => {
                if let Some(planes) = &self.frustum {
                    if planes.iter().any(|pl| c.iter().all(|p| pl.dot(*p) < 0.0)) {
                        n.triangles_culled += 1;
                        return None;
                    }
                }
                let near = self.o.near;
                if c.iter().all(|p| p.z < near) {
                    n.triangles_culled += 1;
                    return None;
                }
                let poly = clip_near(&c, near);
                if poly.len() > 3 || c.iter().any(|p| p.z < near) {
                    n.triangles_clipped += 1;
                }
                let (mut xmin, mut xmax, mut ymin, mut ymax) =
                    (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
                for p in &poly {
                    let (x, y) = (cx + f * p.x / p.z, cy - f * p.y / p.z);
                    xmin = xmin.min(x);
                    xmax = xmax.max(x);
                    ymin = ymin.min(y);
                    ymax = ymax.max(y);
                }
                pixel_range(xmin, xmax, *w, false).zip(pixel_range(ymin, ymax, *h, false))
            }
            Cam::Equi { w, h, .. } => equirect_region(&c, &e, &tie, *w, *h),
        };
        let Some(((x0, x1), (y0, y1))) = region else {
            n.triangles_culled += 1;
            return None;
        };
        n.triangles_drawn += 1;
        Some(Prep { e, tie, n: normal, d: det, layer, tri, y0: y0 as u32, y1: y1 as u32, x0, x1 })
    }
}

/// Pixel indices whose centres `i + ½` lie in `[lo, hi]` (with a small margin), clamped to
/// `0..len` unless `wrap`; `None` when empty.
pub(super) fn pixel_range(lo: f64, hi: f64, len: usize, wrap: bool) -> Option<(i64, i64)> {
    const MARGIN: f64 = 1e-3;
    if lo.is_nan() || hi.is_nan() {
        return None;
    }
    let a = (lo - 0.5 - MARGIN).ceil().max(-1e15) as i64;
    let b = (hi - 0.5 + MARGIN).floor().min(1e15) as i64;
    let (a, b) = if wrap { (a, b.min(a + len as i64 - 1)) } else { (a.max(0), b.min(len as i64 - 1)) };
    (a <= b).then_some((a, b))
}

/// Sutherland–Hodgman clip of a triangle against `z ≥ near`. Each new vertex is computed from its
/// edge's endpoints in a fixed order, so neighbouring triangles agree on it.
pub(super) fn clip_near(c: &[DVec3; 3], near: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(4);
    for k in 0..3 {
        let (a, b) = (c[k], c[(k + 1) % 3]);
        let (ina, inb) = (a.z >= near, b.z >= near);
        if ina {
            out.push(a);
        }
        if ina != inb {
            let (p, q) = if a.z < b.z { (a, b) } else { (b, a) };
            let t = (near - p.z) / (q.z - p.z);
            let mut x = p + (q - p) * t;
            x.z = near;
            out.push(x);
        }
    }
    out
}

/// Candidate region of a triangle on an equirect output: its azimuth range (unwrapped, columns may
/// exceed the width) and polar range, the latter including the extremes of the great-circle arcs
/// of its edges; all columns from the pole when the triangle contains (or touches) a pole.
pub(super) fn equirect_region(
    c: &[DVec3; 3],
    e: &[DVec3; 3],
    tie: &[bool; 3],
    w: usize,
    h: usize,
) -> Option<((i64, i64), (i64, i64))> {
    let d = c.map(|p| p.normalize());
    if !d.iter().all(|p| p.is_finite()) {
        return None;
    }
    let theta = |p: DVec3| p.x.hypot(p.y).atan2(p.z);
    let (mut tmin, mut tmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &d {
        tmin = tmin.min(theta(*p));
        tmax = tmax.max(theta(*p));
    }
    for k in 0..3 {
        let (a, b) = (d[k], d[(k + 1) % 3]);
        let m = a.cross(b);
        let Some(mn) = m.try_normalize() else { continue };
        let top = (DVec3::Z - mn * mn.z).try_normalize();
        if let Some(p) = top {
            for q in [p, -p] {
                if a.cross(q).dot(m) >= 0.0 && q.cross(b).dot(m) >= 0.0 {
                    tmin = tmin.min(theta(q));
                    tmax = tmax.max(theta(q));
                }
            }
        }
    }
    let contains = |r: DVec3| {
        (0..3).all(|i| {
            let s = e[i].dot(r);
            s > 0.0 || (s == 0.0 && tie[i])
        })
    };
    let fw = w as f64;
    let near_axis = d.iter().any(|p| p.x.hypot(p.y) < 1e-12);
    let u = d.map(|p| {
        let mut phi = p.y.atan2(p.x);
        if phi < 0.0 {
            phi += TAU;
        }
        phi / TAU * fw
    });
    let wrap = |x: f64| x - fw * (x / fw).round();
    let (w01, w12, w20) = (wrap(u[1] - u[0]), wrap(u[2] - u[1]), wrap(u[0] - u[2]));
    let winding = w01 + w12 + w20;
    let north = contains(DVec3::Z);
    let south = contains(DVec3::NEG_Z);
    let ys = |t0: f64, t1: f64| pixel_range(t0 / PI * h as f64, t1 / PI * h as f64, h, false);
    if north || south || near_axis || winding.abs() > fw / 2.0 {
        let (t0, t1) = if north || (!south && d.iter().map(|p| p.z).sum::<f64>() > 0.0) {
            (0.0, tmax)
        } else {
            (tmin, PI)
        };
        return Some(((0, w as i64 - 1), ys(t0, t1)?));
    }
    let us = [u[0], u[0] + w01, u[0] + w01 + w12];
    let lo = us.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = us.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Some((pixel_range(lo, hi, w, true)?, ys(tmin, tmax)?))
}

/// One output pixel of the z-buffer.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frag {
    /// Perspective: camera `z`; equirect: distance from the eye.
    pub(super) z: f32,
    pub(super) layer: u32,
    /// `u32::MAX`: no triangle.
    pub(super) tri: u32,
}

pub(super) const NO_FRAG: Frag = Frag { z: f32::INFINITY, layer: 0, tri: u32::MAX };

/// Rasterise the triangles binned to one band of rows into its slice of the z-buffer.
pub(super) fn raster_band(
    cam: &Cam,
    preps: &[Prep],
    bin: &[u32],
    band: usize,
    near: f64,
    buf: &mut [Frag],
) -> (u64, u64) {
    let (w, h) = cam.size();
    let (r0, r1) = (band * BAND, ((band + 1) * BAND).min(h) - 1);
    let (mut tests, mut frags) = (0u64, 0u64);
    for &k in bin {
        let p = &preps[k as usize];
        let (ya, yb) = ((p.y0 as usize).max(r0), (p.y1 as usize).min(r1));
        for y in ya..=yb {
            let row = &mut buf[(y - r0) * w..(y - r0 + 1) * w];
            for xi in p.x0..=p.x1 {
                let x = xi.rem_euclid(w as i64) as usize;
                let r = cam.ray(x, y);
                tests += 1;
                if !inside(p, r) {
                    continue;
                }
                let nr = p.n.dot(r);
                let t = p.d / nr;
                let z = match cam {
                    Cam::Persp { f, .. } => t * f,
                    Cam::Equi { .. } => t,
                };
                let usable = z > 0.0 && z.is_finite();
                if !usable || (matches!(cam, Cam::Persp { .. }) && z < near) {
                    continue;
                }
                frags += 1;
                let z = z as f32;
                let cell = &mut row[x];
                if z < cell.z || (z == cell.z && p.layer > cell.layer) {
                    *cell = Frag { z, layer: p.layer, tri: p.tri };
                }
            }
        }
    }
    (tests, frags)
}
