//! The two source canvases (equirect, cube map): directions in, filter taps out, taps never off
//! the canvas.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::depth::{blendable, resolve, resolve_with, tap_inside, DepthTaps};
use super::taps::{axis_weights, cubic_weights, floor_i64, Taps};
use super::{Filter, SampleOptions, Texel};
use crate::mapping::fast_atan2;

use crate::mapping::{CubeFace, FacePoint};

/// A canvas that turns directions into taps.
pub(super) trait Source: Sync {
    /// Source coordinates (face, continuous x, y) of a batch of directions. Written as straight-line
    /// loops over structure-of-arrays buffers so the compiler can vectorise them.
    fn coords(&self, d: &Dirs, out: &mut Coords);
    /// Filter taps around continuous coordinates `(x, y)` of `face` (0 for equirect).
    fn taps_at(&self, face: u8, x: f32, y: f32, filter: Filter, out: &mut Taps);
    /// Texel `(i, j)` of `face`, wrapped, over a pole or on the neighbouring face as taps are.
    fn texel_at(&self, face: u8, i: i64, j: i64) -> usize;

    /// Whether the bilinear taps around `(x, y)` lie on one surface by the continuity rule
    /// ([`crate::continuity::continuous`]: a step within `jump`, or a plane through the texel
    /// beyond either end, along both rows and both columns): a grazing floor doubles its depth a
    /// row near the horizon, smoothly.
    #[allow(clippy::too_many_arguments)]
    fn bilinear_on_plane<T: Texel>(
        &self,
        data: &[T],
        ch: usize,
        (z, cov): (usize, Option<usize>),
        face: u8,
        x: f32,
        y: f32,
        jump: f32,
    ) -> bool {
        let (x0, _, _) = axis_weights(Filter::Bilinear, x);
        let (y0, _, _) = axis_weights(Filter::Bilinear, y);
        // Outside the layer (negative, unknown, uncovered) reads as −1.
        let depth = |i: i64, j: i64| {
            let t = self.texel_at(face, i, j) * ch;
            if tap_inside(data, t, z, cov) {
                data[t + z].to_f32() as f64
            } else {
                -1.0
            }
        };
        // Pairs with a texel outside the layer are not asked: at a layer's edge the inside taps
        // alone are blended. Some pair must be asked.
        let pair = |(ai, aj): (i64, i64), (di, dj): (i64, i64)| {
            let (bi, bj) = (ai + di, aj + dj);
            let (a, b) = (depth(ai, aj), depth(bi, bj));
            if a < 0.0 || b < 0.0 {
                return None;
            }
            Some(crate::continuity::continuous_with(
                a,
                b,
                || Some(depth(ai - di, aj - dj)),
                || Some(depth(bi + di, bj + dj)),
                jump as f64,
                crate::continuity::PLANAR,
            ))
        };
        let pairs = [
            pair((x0, y0), (1, 0)),
            pair((x0, y0 + 1), (1, 0)),
            pair((x0, y0), (0, 1)),
            pair((x0 + 1, y0), (0, 1)),
        ];
        pairs.iter().any(Option::is_some) && pairs.iter().all(|p| p.unwrap_or(true))
    }

    /// Plain bilinear sample (no depth rule) written straight into `out`; sources override this with a
    /// version that skips the generic tap list.
    #[inline(always)]
    fn bilinear<T: Texel>(&self, data: &[T], ch: usize, face: u8, x: f32, y: f32, out: &mut [T]) {
        let mut taps = Taps::EMPTY;
        self.taps_at(face, x, y, Filter::Bilinear, &mut taps);
        resolve(data, ch, &taps, &SampleOptions::default(), out);
    }

    /// Plain bicubic sample (no depth rule); same contract as [`Source::bilinear`].
    #[inline(always)]
    fn bicubic<T: Texel>(&self, data: &[T], ch: usize, face: u8, x: f32, y: f32, out: &mut [T]) {
        let mut taps = Taps::EMPTY;
        self.taps_at(face, x, y, Filter::Bicubic, &mut taps);
        resolve(data, ch, &taps, &SampleOptions::default(), out);
    }

    /// Source coordinates (face, x, y) of one direction.
    fn coords_of(&self, d: Vec3) -> (u8, f32, f32) {
        let dirs = Dirs { x: vec![d.x], y: vec![d.y], z: vec![d.z] };
        let (_, mut c) = batch(1);
        self.coords(&dirs, &mut c);
        (c.face[0], c.x[0], c.y[0])
    }

    /// One pixel under `opts` at source coordinates `(face, x, y)`: its taps, the depth-aware
    /// rule (steep bilinear taps asked [`Source::bilinear_on_plane`]) and the filtered value.
    #[inline(always)]
    fn sample<T: Texel>(
        &self,
        data: &[T],
        ch: usize,
        (face, x, y): (u8, f32, f32),
        opts: &SampleOptions,
        taps: &mut Taps,
        out: &mut [T],
    ) {
        self.taps_at(face, x, y, opts.filter, taps);
        let mut opts = opts;
        let bilinear;
        if let (Some(z), Filter::Bicubic) = (opts.depth_channel, opts.filter) {
            // Depth stepping by more than the jump over the 4 × 4 taps (ground at a grazing angle),
            // or reaching out of the layer, is sampled as the bilinear filter would (on its plane,
            // from its inside taps), not left as the nearest texel's staircase.
            if !matches!(blendable(data, ch, taps, opts, z), DepthTaps::Close(..)) {
                self.taps_at(face, x, y, Filter::Bilinear, taps);
                bilinear = SampleOptions { filter: Filter::Bilinear, ..*opts };
                opts = &bilinear;
            }
        }
        let on_plane = || match opts.depth_channel {
            Some(z) if opts.filter == Filter::Bilinear => self.bilinear_on_plane(
                data,
                ch,
                (z, opts.coverage_channel),
                face,
                x,
                y,
                opts.max_relative_jump,
            ),
            _ => false,
        };
        resolve_with(data, ch, taps, opts, on_plane, out);
    }
}

/// A batch of directions, structure of arrays.
pub(super) struct Dirs {
    pub(super) x: Vec<f32>,
    pub(super) y: Vec<f32>,
    pub(super) z: Vec<f32>,
}

/// Source coordinates of a batch of directions.
pub(super) struct Coords {
    pub(super) face: Vec<u8>,
    pub(super) x: Vec<f32>,
    pub(super) y: Vec<f32>,
}

/// Scratch for a batch of `n` directions and their source coordinates.
pub(super) fn batch(n: usize) -> (Dirs, Coords) {
    let zeros = || vec![0.0; n];
    (Dirs { x: zeros(), y: zeros(), z: zeros() }, Coords { face: vec![0; n], x: zeros(), y: zeros() })
}

/// Equirect source of `w × h` pixels.
pub(super) struct EquirectSource {
    pub(super) w: usize,
    pub(super) h: usize,
}

impl EquirectSource {
    /// Index of pixel `(x, y)` after wrapping the seam and stepping over the poles. Taps lie within a
    /// few pixels of the canvas, so wrapping is two conditional adds (no integer division).
    #[inline]
    pub(super) fn index(&self, x: i64, y: i64) -> usize {
        let (w, h) = (self.w as i64, self.h as i64);
        let (mut x, mut y) = (x, y);
        if y < 0 {
            y = -y - 1;
            x += w / 2;
        } else if y >= h {
            y = 2 * h - 1 - y;
            x += w / 2;
        }
        let y = y.clamp(0, h - 1);
        if x < 0 || x >= 2 * w {
            x = x.rem_euclid(w);
        } else if x >= w {
            x -= w;
        }
        (y * w + x) as usize
    }
}

impl Source for EquirectSource {
    /// f32 version of `Equirect::dir_to_pixel` (same seam and clamping rules).
    fn coords(&self, d: &Dirs, out: &mut Coords) {
        let (wf, hf) = (self.w as f32, self.h as f32);
        let (kx, ky) = (wf / TAU, hf / PI);
        // Largest f32 below W and H.
        let (wmax, hmax) = (f32::from_bits(wf.to_bits() - 1), f32::from_bits(hf.to_bits() - 1));
        let n = d.x.len();
        let (dx, dy, dz) = (&d.x[..n], &d.y[..n], &d.z[..n]);
        let (ox, oy) = (&mut out.x[..n], &mut out.y[..n]);
        for i in 0..n {
            let phi = fast_atan2(dy[i], dx[i]);
            let theta = fast_atan2((dx[i] * dx[i] + dy[i] * dy[i]).sqrt(), dz[i]);
            let x = phi * kx;
            let x = if x < 0.0 { x + wf } else { x };
            // max/min rather than clamp (whose argument check blocks vectorisation).
            ox[i] = x.max(0.0).min(wmax);
            oy[i] = (theta * ky).max(0.0).min(hmax);
        }
    }

    /// Separable 4×4: the four rows (stepping over the poles) and columns (wrapping) are resolved once.
    #[inline(always)]
    fn bicubic<T: Texel>(&self, data: &[T], ch: usize, face: u8, x: f32, y: f32, out: &mut [T]) {
        if ch > 4 {
            let mut taps = Taps::EMPTY;
            self.taps_at(face, x, y, Filter::Bicubic, &mut taps);
            resolve(data, ch, &taps, &SampleOptions::default(), out);
            return;
        }
        let (w, h) = (self.w as i64, self.h as i64);
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (floor_i64(fx) - 1, floor_i64(fy) - 1);
        let wx = cubic_weights(fx - (x0 + 1) as f32);
        let wy = cubic_weights(fy - (y0 + 1) as f32);
        let mut acc = [0.0f32; 4];
        for (j, wyj) in wy.iter().enumerate() {
            let mut yy = y0 + j as i64;
            let mut shift = 0;
            if yy < 0 {
                yy = -yy - 1;
                shift = w / 2;
            } else if yy >= h {
                yy = 2 * h - 1 - yy;
                shift = w / 2;
            }
            let row = yy.clamp(0, h - 1) * w;
            let mut racc = [0.0f32; 4];
            for (i, wxi) in wx.iter().enumerate() {
                let mut xx = x0 + i as i64 + shift;
                if xx < 0 {
                    xx += w;
                }
                while xx >= w {
                    xx -= w;
                }
                let k = (row + xx) as usize * ch;
                for (a, v) in racc.iter_mut().zip(&data[k..k + ch]) {
                    *a += wxi * v.to_f32();
                }
            }
            for (a, r) in acc.iter_mut().zip(racc) {
                *a += wyj * r;
            }
        }
        for (o, a) in out.iter_mut().zip(acc) {
            *o = T::from_f32(a);
        }
    }

    #[inline(always)]
    fn bilinear<T: Texel>(&self, data: &[T], ch: usize, _face: u8, x: f32, y: f32, out: &mut [T]) {
        let (w, h) = (self.w as i64, self.h as i64);
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (floor_i64(fx), floor_i64(fy));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        // Rows: only the first and last rows step over a pole (shift by W/2).
        let row = |y: i64| -> (i64, i64) {
            if y < 0 {
                (0, w / 2)
            } else if y >= h {
                (h - 1, w / 2)
            } else {
                (y, 0)
            }
        };
        let col = |x: i64| -> i64 {
            if x < 0 {
                x + w
            } else if x >= w {
                x - w
            } else {
                x
            }
        };
        let (r0, s0) = row(y0);
        let (r1, s1) = row(y0 + 1);
        let (c0, c1) = (x0, x0 + 1);
        let i00 = (r0 * w + col(col(c0 + s0))) as usize * ch;
        let i01 = (r0 * w + col(col(c1 + s0))) as usize * ch;
        let i10 = (r1 * w + col(col(c0 + s1))) as usize * ch;
        let i11 = (r1 * w + col(col(c1 + s1))) as usize * ch;
        blend4(data, ch, [i00, i01, i10, i11], tx, ty, out);
    }

    #[inline]
    fn texel_at(&self, _face: u8, i: i64, j: i64) -> usize {
        self.index(i, j)
    }

    #[inline(always)]
    fn taps_at(&self, _face: u8, x: f32, y: f32, filter: Filter, out: &mut Taps) {
        let (x0, nx, wx) = axis_weights(filter, x);
        let (y0, ny, wy) = axis_weights(filter, y);
        let mut k = 0;
        for (j, wyj) in wy.iter().enumerate().take(ny) {
            for (i, wxi) in wx.iter().enumerate().take(nx) {
                out.idx[k] = self.index(x0 + i as i64, y0 + j as i64);
                out.w[k] = wxi * wyj;
                k += 1;
            }
        }
        out.n = k;
        out.nearest = self.index(x as i64, (y as i64).min(self.h as i64 - 1));
    }
}

/// Canonical 3×2 cube source with faces of `n` pixels.
pub(super) struct CubeSource {
    pub(super) n: usize,
}

impl CubeSource {
    #[inline]
    pub(super) fn face_index(&self, face: usize, i: usize, j: usize) -> usize {
        let (s0, t0) = (face % 3, face / 3);
        (t0 * self.n + j) * 3 * self.n + s0 * self.n + i
    }

    /// Texel `(i, j)` of `face`, where `i` or `j` may lie outside the face: then the texel of the
    /// neighbouring face hit by the direction of that (virtual) texel centre.
    #[inline]
    pub(super) fn texel(&self, face: usize, i: i64, j: i64) -> usize {
        let n = self.n as i64;
        if (0..n).contains(&i) && (0..n).contains(&j) {
            return self.face_index(face, i as usize, j as usize);
        }
        let nf = self.n as f64;
        let a = 2.0 * (i as f64 + 0.5) / nf - 1.0;
        let b = 2.0 * (j as f64 + 0.5) / nf - 1.0;
        let f = CubeFace::from_index(face).unwrap_or(CubeFace::PosZ);
        let p = FacePoint::from_dir(f.cube_point(a, b));
        let ti = (((p.s + 1.0) * 0.5 * nf) as usize).min(self.n - 1);
        let tj = (((p.t + 1.0) * 0.5 * nf) as usize).min(self.n - 1);
        self.face_index(p.face.index(), ti, tj)
    }
}

impl Source for CubeSource {
    /// f32 version of `FacePoint::from_dir` (same tie rule), in face-local pixel units.
    fn coords(&self, d: &Dirs, out: &mut Coords) {
        let nf = self.n as f32;
        for i in 0..d.x.len() {
            let (x, y, z) = (d.x[i], d.y[i], d.z[i]);
            let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
            let (face, s, t) = if ax >= ay && ax >= az {
                if x > 0.0 {
                    (0, -y / ax, -z / ax)
                } else {
                    (3, y / ax, -z / ax)
                }
            } else if ay >= az {
                if y > 0.0 {
                    (1, x / ay, -z / ay)
                } else {
                    (4, -x / ay, -z / ay)
                }
            } else if z > 0.0 {
                (2, -x / az, -y / az)
            } else {
                (5, x / az, -y / az)
            };
            out.face[i] = face;
            out.x[i] = ((s + 1.0) * 0.5 * nf).clamp(0.0, nf);
            out.y[i] = ((t + 1.0) * 0.5 * nf).clamp(0.0, nf);
        }
    }

    /// Separable 4×4 inside a face; near an edge, the general tap list.
    #[inline(always)]
    fn bicubic<T: Texel>(&self, data: &[T], ch: usize, face: u8, x: f32, y: f32, out: &mut [T]) {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (floor_i64(fx) - 1, floor_i64(fy) - 1);
        let n = self.n as i64;
        if ch > 4 || x0 < 0 || y0 < 0 || x0 + 3 >= n || y0 + 3 >= n {
            let mut taps = Taps::EMPTY;
            self.taps_at(face, x, y, Filter::Bicubic, &mut taps);
            resolve(data, ch, &taps, &SampleOptions::default(), out);
            return;
        }
        let wx = cubic_weights(fx - (x0 + 1) as f32);
        let wy = cubic_weights(fy - (y0 + 1) as f32);
        let base = self.face_index(face as usize, x0 as usize, y0 as usize) * ch;
        let row = 3 * self.n * ch;
        let mut acc = [0.0f32; 4];
        for (j, wyj) in wy.iter().enumerate() {
            let mut racc = [0.0f32; 4];
            for (i, wxi) in wx.iter().enumerate() {
                let k = base + j * row + i * ch;
                for (a, v) in racc.iter_mut().zip(&data[k..k + ch]) {
                    *a += wxi * v.to_f32();
                }
            }
            for (a, r) in acc.iter_mut().zip(racc) {
                *a += wyj * r;
            }
        }
        for (o, a) in out.iter_mut().zip(acc) {
            *o = T::from_f32(a);
        }
    }

    /// Inside a face (all but the border texels) the four taps are direct; across an edge, the general
    /// tap list finds the neighbouring face's texels.
    #[inline(always)]
    fn bilinear<T: Texel>(&self, data: &[T], ch: usize, face: u8, x: f32, y: f32, out: &mut [T]) {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (floor_i64(fx), floor_i64(fy));
        let n = self.n as i64;
        if x0 < 0 || y0 < 0 || x0 + 1 >= n || y0 + 1 >= n {
            let mut taps = Taps::EMPTY;
            self.taps_at(face, x, y, Filter::Bilinear, &mut taps);
            resolve(data, ch, &taps, &SampleOptions::default(), out);
            return;
        }
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let i00 = self.face_index(face as usize, x0 as usize, y0 as usize) * ch;
        let row = 3 * self.n * ch;
        let (i01, i10) = (i00 + ch, i00 + row);
        let i11 = i10 + ch;
        blend4(data, ch, [i00, i01, i10, i11], tx, ty, out);
    }

    #[inline]
    fn texel_at(&self, face: u8, i: i64, j: i64) -> usize {
        self.texel(face as usize, i, j)
    }

    #[inline(always)]
    fn taps_at(&self, face: u8, x: f32, y: f32, filter: Filter, out: &mut Taps) {
        let face = face as usize;
        let (x0, nx, wx) = axis_weights(filter, x);
        let (y0, ny, wy) = axis_weights(filter, y);
        let mut k = 0;
        for (j, wyj) in wy.iter().enumerate().take(ny) {
            for (i, wxi) in wx.iter().enumerate().take(nx) {
                out.idx[k] = self.texel(face, x0 + i as i64, y0 + j as i64);
                out.w[k] = wxi * wyj;
                k += 1;
            }
        }
        out.n = k;
        let last = self.n - 1;
        out.nearest = self.face_index(face, (x as usize).min(last), (y as usize).min(last));
    }
}

/// Bilinear blend of the texels starting at `i` (`[i00, i01, i10, i11]`, `ch` samples each) at
/// fractions `(tx, ty)` into `out`.
#[inline(always)]
fn blend4<T: Texel>(data: &[T], ch: usize, i: [usize; 4], tx: f32, ty: f32, out: &mut [T]) {
    let (w00, w01) = ((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty));
    let (w10, w11) = ((1.0 - tx) * ty, tx * ty);
    let [p00, p01, p10, p11] = i.map(|i| &data[i..i + ch]);
    for c in 0..ch {
        out[c] = T::from_f32(
            w00 * p00[c].to_f32() + w01 * p01[c].to_f32() + w10 * p10[c].to_f32() + w11 * p11[c].to_f32(),
        );
    }
}
