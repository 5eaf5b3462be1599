//! Sphere-aware sampling and conversion between canvases (spec §3.6).
//!
//! A conversion walks the *target* canvas, computes each pixel's direction cheaply (per-row and
//! per-column tables for equirect targets, `centre + a·right + b·down` on cube faces), and asks the
//! *source* canvas for the filter taps of that direction. Taps never fall off the canvas:
//! - equirect: columns wrap around the seam; the row above row 0 is row 0 shifted by `W/2` (stepping
//!   over the pole), likewise below the last row;
//! - cube: a tap beyond a face's edge is the texel of the neighbouring face that its direction hits.
//!
//! Filters are nearest, bilinear and bicubic (Keys `a = −0.5`, i.e. Catmull-Rom). Depth is never blended
//! across a discontinuity: with [`SampleOptions::depth_channel`] set, a pixel is filtered only when every
//! tap with a non-zero weight is inside the layer and their depths are within
//! [`SampleOptions::max_relative_jump`] (or, bilinear, on one plane by the continuity rule: then
//! blended in inverse depth); otherwise **all** channels take the nearest tap, so colour,
//! coverage and depth stay consistent. Filtered depth is clamped to the taps' range.
//!
//! The hot loop is `f32`; the only trigonometry per pixel is a polynomial `atan2` (error below
//! 1e-5 rad, i.e. < 0.02 px on a 16K equirect) when the source is an equirect.

use std::f32::consts::{PI, TAU};
use std::fmt;
use std::str::FromStr;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::continuity;
use crate::layer::{LayerImage, SampleType};
use crate::mapping::layout::{convert_layout, CubeLayout, LayoutError};
use crate::mapping::{AnyMapping, CubeFace, FacePoint, Mapping};
use crate::raster::Raster;

/// Errors of sampling and conversion.
#[derive(Debug, thiserror::Error)]
pub enum ResampleError {
    /// Internal: a buffer whose length does not match its canvas (not expected from public calls).
    #[error("unsupported")]
    Unsupported,
    /// A cube canvas's size does not fit its layout ([`LayoutError`]).
    #[error(transparent)]
    Layout(#[from] LayoutError),
    #[error("a {width}x{height} image is not an equirect canvas (width must be twice the height)")]
    /// A source read as equirect is not `2H × H` with `H ≥ 1`.
    NotEquirect {
        /// Source width, pixels.
        width: usize,
        /// Source height, pixels.
        height: usize,
    },
    #[error("output size {0} is invalid: an equirect width must be even and positive, a face size positive")]
    /// The target size (equirect width or cube face size, pixels) is 0, or odd for an equirect.
    BadTargetSize(usize),
    #[error("output of {width}x{height} pixels x {channels} channels is too large")]
    /// An image's `width · height · channels` samples are too many to allocate.
    TooLarge {
        /// Image width, pixels.
        width: usize,
        /// Image height, pixels.
        height: usize,
        /// Number of channels.
        channels: usize,
    },
    #[error("depth channel {channel} does not exist (the image has {channels} channels)")]
    /// [`SampleOptions::depth_channel`] or `coverage_channel` is not below the channel count.
    NoSuchChannel {
        /// The channel index asked for.
        channel: usize,
        /// How many channels the image has.
        channels: usize,
    },
    /// The source image has no channels.
    #[error("the image has no channels")]
    NoChannels,
    #[error("output buffer holds {got} samples but the image has {channels} channels")]
    /// [`sample_dir`]: the output slice's length differs from the channel count.
    OutputLength {
        /// Length of the output slice given.
        got: usize,
        /// Channels of the image (the length required).
        channels: usize,
    },
    #[error("layer channel '{name}' holds {len} samples where its {width}x{height} canvas needs {expected}")]
    /// [`convert_layer`]: a channel's sample count is not `width · height`.
    ChannelSize {
        /// The channel's name.
        name: String,
        /// Samples the channel holds.
        len: usize,
        /// Layer width, pixels.
        width: usize,
        /// Layer height, pixels.
        height: usize,
        /// Samples required, `width · height`.
        expected: usize,
    },
}

impl ResampleError {
    /// Stable code for reports: `RESAMPLE_*`, or the layout's code for [`ResampleError::Layout`].
    pub fn code(&self) -> &'static str {
        match self {
            ResampleError::Unsupported => crate::codes::RESAMPLE_UNSUPPORTED,
            ResampleError::Layout(e) => e.code(),
            ResampleError::NotEquirect { .. } => crate::codes::RESAMPLE_NOT_EQUIRECT,
            ResampleError::BadTargetSize(_) => crate::codes::RESAMPLE_BAD_SIZE,
            ResampleError::TooLarge { .. } => crate::codes::RESAMPLE_TOO_LARGE,
            ResampleError::NoSuchChannel { .. } => crate::codes::RESAMPLE_NO_SUCH_CHANNEL,
            ResampleError::NoChannels => crate::codes::RESAMPLE_NO_CHANNELS,
            ResampleError::OutputLength { .. } => crate::codes::RESAMPLE_OUTPUT_LENGTH,
            ResampleError::ChannelSize { .. } => crate::codes::RESAMPLE_CHANNEL_SIZE,
        }
    }
}

/// Reconstruction filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Filter {
    /// The texel containing the sample point, 1 tap.
    Nearest,
    /// Bilinear over the 2×2 nearest texel centres; the default.
    #[default]
    Bilinear,
    /// Keys cubic with `a = −0.5` (Catmull-Rom): interpolating, 4×4 taps.
    Bicubic,
}

impl Filter {
    /// Stable name for the command line: `nearest`, `bilinear` or `bicubic`.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Nearest => "nearest",
            Filter::Bilinear => "bilinear",
            Filter::Bicubic => "bicubic",
        }
    }
}

impl fmt::Display for Filter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Filter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "nearest" => Ok(Filter::Nearest),
            "bilinear" | "linear" => Ok(Filter::Bilinear),
            "bicubic" | "cubic" => Ok(Filter::Bicubic),
            _ => Err(format!("unknown filter '{s}'; expected nearest, bilinear or bicubic")),
        }
    }
}

/// A canvas kind on either side of a conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Canvas {
    /// 2:1 equirect (spec §3.2).
    Equirect,
    /// A cube map in the given layout (spec §3.3, §3.5).
    Cube(CubeLayout),
}

/// How to sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleOptions {
    /// Reconstruction filter (default [`Filter::Bilinear`]).
    pub filter: Filter,
    /// Channel holding depth (distance along the ray; negative = outside, NaN = unknown). Enables the
    /// depth-aware rule.
    pub depth_channel: Option<usize>,
    /// Channel holding coverage (`A`); a tap with coverage `<= 0` is outside the layer.
    pub coverage_channel: Option<usize>,
    /// Largest accepted `max/min` depth ratio minus one among the taps of a filtered pixel.
    pub max_relative_jump: f32,
}

impl Default for SampleOptions {
    fn default() -> Self {
        SampleOptions {
            filter: Filter::Bilinear,
            depth_channel: None,
            coverage_channel: None,
            max_relative_jump: 0.1,
        }
    }
}

impl SampleOptions {
    /// The default options with `filter` instead of bilinear.
    pub fn with_filter(filter: Filter) -> Self {
        SampleOptions { filter, ..Default::default() }
    }
}

/// A sample type the samplers read and write; filtering happens in `f32`.
pub trait Texel: Copy + Send + Sync + 'static {
    /// The sample's value as `f32` (integers by value, not normalised).
    fn to_f32(self) -> f32;
    /// Rounded and saturated for integer types.
    fn from_f32(v: f32) -> Self;
}

impl Texel for u8 {
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        (v + 0.5) as u8 // `as` saturates (and maps NaN to 0)
    }
}

impl Texel for u16 {
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        (v + 0.5) as u16
    }
}

impl Texel for f32 {
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        v
    }
}

/// `atan(x)` for `x ∈ [0, 1]`: odd minimax polynomial, |error| < 1e-5 rad.
#[inline]
fn atan_unit(x: f32) -> f32 {
    let x2 = x * x;
    x * (0.999_977_26
        + x2 * (-0.332_623_47
            + x2 * (0.193_543_46 + x2 * (-0.116_432_87 + x2 * (0.052_653_32 + x2 * -0.011_721_2)))))
}

/// Fast `atan2(y, x)` in `(−π, π]`; `0` for `(0, 0)`.
#[inline]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    // Selects rather than early returns, so batches vectorise.
    let (ax, ay) = (x.abs(), y.abs());
    let (mx, mn) = (ax.max(ay), ax.min(ay));
    let r = atan_unit(mn / mx.max(f32::MIN_POSITIVE));
    let r = if ay > ax { PI / 2.0 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// Catmull-Rom weights of taps `−1, 0, 1, 2` at fraction `t ∈ [0, 1)`.
#[inline]
fn cubic_weights(t: f32) -> [f32; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2]
}

/// `floor` for the sample range (|p| < 2³¹) without a libm call (baseline x86-64 has no `roundps`).
#[inline]
fn floor_i64(p: f32) -> i64 {
    let i = p as i64;
    if (i as f32) > p {
        i - 1
    } else {
        i
    }
}

/// Copy one pixel (a handful of samples: a loop beats a `memmove` call).
#[inline]
fn copy_pixel<T: Copy>(src: &[T], ch: usize, idx: usize, out: &mut [T]) {
    let p = &src[idx * ch..idx * ch + ch];
    for (o, v) in out.iter_mut().zip(p) {
        *o = *v;
    }
}

/// Filter footprint along one axis: first tap offset, tap count and weights.
#[inline]
fn axis_weights(filter: Filter, p: f32) -> (i64, usize, [f32; 4]) {
    match filter {
        Filter::Nearest => (floor_i64(p), 1, [1.0, 0.0, 0.0, 0.0]),
        Filter::Bilinear => {
            let f = p - 0.5;
            let i0 = floor_i64(f);
            let t = f - i0 as f32;
            (i0, 2, [1.0 - t, t, 0.0, 0.0])
        }
        Filter::Bicubic => {
            let f = p - 0.5;
            let i0 = floor_i64(f);
            (i0 - 1, 4, cubic_weights(f - i0 as f32))
        }
    }
}

/// Taps of one sample: pixel indices into the source canvas and their weights.
#[derive(Clone, Copy, Debug)]
pub struct Taps {
    idx: [usize; 16],
    w: [f32; 16],
    n: usize,
    /// The pixel containing the sample point (used at discontinuities).
    nearest: usize,
}

impl Taps {
    const EMPTY: Taps = Taps { idx: [0; 16], w: [0.0; 16], n: 0, nearest: 0 };
}

/// A canvas that turns directions into taps.
trait Source: Sync {
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
        let mut c = Coords::with_len(1);
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
struct Dirs {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Dirs {
    fn with_len(n: usize) -> Self {
        Dirs { x: vec![0.0; n], y: vec![0.0; n], z: vec![0.0; n] }
    }
}

/// Source coordinates of a batch of directions.
struct Coords {
    face: Vec<u8>,
    x: Vec<f32>,
    y: Vec<f32>,
}

impl Coords {
    fn with_len(n: usize) -> Self {
        Coords { face: vec![0; n], x: vec![0.0; n], y: vec![0.0; n] }
    }
}

/// Equirect source of `w × h` pixels.
struct EquirectSource {
    w: usize,
    h: usize,
}

impl EquirectSource {
    /// Index of pixel `(x, y)` after wrapping the seam and stepping over the poles. Taps lie within a
    /// few pixels of the canvas, so wrapping is two conditional adds (no integer division).
    #[inline]
    fn index(&self, x: i64, y: i64) -> usize {
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
        let (w00, w01) = ((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty));
        let (w10, w11) = ((1.0 - tx) * ty, tx * ty);
        let (p00, p01, p10, p11) =
            (&data[i00..i00 + ch], &data[i01..i01 + ch], &data[i10..i10 + ch], &data[i11..i11 + ch]);
        for c in 0..ch {
            out[c] = T::from_f32(
                w00 * p00[c].to_f32() + w01 * p01[c].to_f32() + w10 * p10[c].to_f32() + w11 * p11[c].to_f32(),
            );
        }
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
struct CubeSource {
    n: usize,
}

impl CubeSource {
    #[inline]
    fn face_index(&self, face: usize, i: usize, j: usize) -> usize {
        let (s0, t0) = (face % 3, face / 3);
        (t0 * self.n + j) * 3 * self.n + s0 * self.n + i
    }

    /// Texel `(i, j)` of `face`, where `i` or `j` may lie outside the face: then the texel of the
    /// neighbouring face hit by the direction of that (virtual) texel centre.
    #[inline]
    fn texel(&self, face: usize, i: i64, j: i64) -> usize {
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
        let (w00, w01) = ((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty));
        let (w10, w11) = ((1.0 - tx) * ty, tx * ty);
        let (p00, p01, p10, p11) =
            (&data[i00..i00 + ch], &data[i01..i01 + ch], &data[i10..i10 + ch], &data[i11..i11 + ch]);
        for c in 0..ch {
            out[c] = T::from_f32(
                w00 * p00[c].to_f32() + w01 * p01[c].to_f32() + w10 * p10[c].to_f32() + w11 * p11[c].to_f32(),
            );
        }
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

/// What the depth-aware rule makes of a pixel's taps.
enum DepthTaps {
    /// Some tap outside or unknown: the nearest texel.
    Apart,
    /// Within the relative jump: blended, clamped to the range.
    Close(f32, f32),
    /// All inside, stepping by more than the jump: blended only on one plane (then in inverse
    /// depth, which is linear along a plane), else the nearest texel.
    Steep(f32, f32),
}

/// The taps under the depth-aware rule, with their depth range.
#[inline]
fn blendable<T: Texel>(src: &[T], ch: usize, taps: &Taps, opts: &SampleOptions, z: usize) -> DepthTaps {
    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
    for k in 0..taps.n {
        if taps.w[k] == 0.0 {
            continue;
        }
        let base = taps.idx[k] * ch;
        // Outside or unknown mixes with nothing.
        if !tap_inside(src, base, z, opts.coverage_channel) {
            return DepthTaps::Apart;
        }
        let zv = src[base + z].to_f32();
        lo = lo.min(zv);
        hi = hi.max(zv);
    }
    // All-infinite taps (sky) blend; finite next to infinite does not.
    if hi <= lo * (1.0 + opts.max_relative_jump) {
        DepthTaps::Close(lo, hi)
    } else if hi.is_finite() && lo > 0.0 {
        DepthTaps::Steep(lo, hi)
    } else {
        DepthTaps::Apart
    }
}

/// Whether the texel at `base` is inside the layer: a known depth ≥ 0 (negative = outside, NaN =
/// unknown) and, with a coverage channel `cov`, covered.
#[inline]
fn tap_inside<T: Texel>(src: &[T], base: usize, z: usize, cov: Option<usize>) -> bool {
    src[base + z].to_f32() >= 0.0 && cov.map_or(true, |a| src[base + a].to_f32() > 0.0)
}

/// When the nearest texel is inside the layer but some weighted taps are not: the inside taps,
/// their weights renormalised (`None` if their weight is under half, as bicubic lobes can leave).
#[inline]
fn inside_taps<T: Texel>(src: &[T], ch: usize, taps: &Taps, opts: &SampleOptions, z: usize) -> Option<Taps> {
    let is_in = |i: usize| tap_inside(src, i * ch, z, opts.coverage_channel);
    if !is_in(taps.nearest) || (0..taps.n).all(|k| taps.w[k] == 0.0 || is_in(taps.idx[k])) {
        return None;
    }
    let mut kept = Taps { nearest: taps.nearest, ..Taps::EMPTY };
    for k in (0..taps.n).filter(|&k| taps.w[k] != 0.0 && is_in(taps.idx[k])) {
        kept.idx[kept.n] = taps.idx[k];
        kept.w[kept.n] = taps.w[k];
        kept.n += 1;
    }
    let sum: f32 = kept.w[..kept.n].iter().sum();
    // NaN weights fail too.
    if sum.is_nan() || sum < 0.5 {
        return None;
    }
    kept.w[..kept.n].iter_mut().for_each(|w| *w /= sum);
    Some(kept)
}

/// Write the filtered value of `taps` into `out` (one pixel, `ch` samples).
#[inline(always)]
fn resolve<T: Texel>(src: &[T], ch: usize, taps: &Taps, opts: &SampleOptions, out: &mut [T]) {
    resolve_with(src, ch, taps, opts, || false, out)
}

/// [`resolve`], where `on_plane` says whether taps stepping by more than the relative jump lie on
/// one plane (asked only then).
#[inline(always)]
fn resolve_with<T: Texel>(
    src: &[T],
    ch: usize,
    taps: &Taps,
    opts: &SampleOptions,
    on_plane: impl FnOnce() -> bool,
    out: &mut [T],
) {
    if taps.n == 1 {
        copy_pixel(src, ch, taps.nearest, out);
        return;
    }
    let mut range = None;
    let mut inverse = false;
    let inside;
    let mut taps = taps;
    if let Some(z) = opts.depth_channel {
        // At a layer's edge the texel the point falls in decides inside or outside; inside, the
        // taps that are blend alone (a nearest texel there would break the surface into steps).
        if let Some(t) = inside_taps(src, ch, taps, opts, z) {
            inside = t;
            taps = &inside;
        }
        match blendable(src, ch, taps, opts, z) {
            DepthTaps::Close(lo, hi) => range = Some((z, (lo, hi))),
            DepthTaps::Steep(lo, hi) if on_plane() => {
                range = Some((z, (lo, hi)));
                inverse = true;
            }
            _ => {
                copy_pixel(src, ch, taps.nearest, out);
                return;
            }
        }
    }
    if ch <= 4 {
        let mut acc = [0.0f32; 4];
        for k in 0..taps.n {
            let w = taps.w[k];
            let p = &src[taps.idx[k] * ch..taps.idx[k] * ch + ch];
            for (a, v) in acc.iter_mut().zip(p) {
                *a += w * v.to_f32();
            }
        }
        for (o, a) in out.iter_mut().zip(acc) {
            *o = T::from_f32(a);
        }
    } else {
        for (c, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0f32;
            for k in 0..taps.n {
                acc += taps.w[k] * src[taps.idx[k] * ch + c].to_f32();
            }
            *o = T::from_f32(acc);
        }
    }
    if let Some((z, (lo, hi))) = range {
        let d = if inverse {
            let s: f32 = (0..taps.n)
                .filter(|&k| taps.w[k] != 0.0)
                .map(|k| taps.w[k] / src[taps.idx[k] * ch + z].to_f32())
                .sum();
            1.0 / s
        } else {
            out[z].to_f32()
        };
        // Equal taps keep their depth exactly: infinitely far ones (a sky) would sum to NaN
        // (0 · inf for a tap of weight 0, inf − inf for bicubic's negative lobes).
        out[z] = T::from_f32(if lo == hi { lo } else { d.clamp(lo, hi) });
    }
}

/// Walk the target canvas row by row, in parallel, calling `pixel(x, d, out)` with each direction.
/// Width and height of a `target` canvas of `size`, checked so that `channels` interleaved samples
/// of it can be allocated.
fn target_size(target: Canvas, size: usize, ch: usize) -> Result<(usize, usize), ResampleError> {
    let (w, h) = match target {
        Canvas::Equirect if size > 0 && size % 2 == 0 => (size, size / 2),
        Canvas::Cube(l) if size > 0 => l.canvas_size(size),
        _ => return Err(ResampleError::BadTargetSize(size)),
    };
    match w.checked_mul(h).and_then(|p| p.checked_mul(ch)) {
        Some(len) if len <= isize::MAX as usize / 8 => Ok((w, h)),
        _ => Err(ResampleError::TooLarge { width: w, height: h, channels: ch }),
    }
}

/// Fill `data`, target rows `y0..` of a `target` canvas of `size` (whole rows of `ch` interleaved
/// samples), calling `segment` on runs of directions and `progress(1)` per row.
fn render_rows<T: Texel>(
    target: Canvas,
    size: usize,
    ch: usize,
    y0: usize,
    data: &mut [T],
    progress: &(dyn Fn(usize) + Sync),
    segment: impl Fn(&Dirs, &mut Coords, &mut [T]) + Sync,
) -> Result<(), ResampleError> {
    let (w, h) = target_size(target, size, ch)?;
    if data.len() % (w * ch) != 0 || y0 + data.len() / (w * ch) > h {
        return Err(ResampleError::Unsupported);
    }
    match target {
        Canvas::Equirect => {
            let (cos_phi, sin_phi): (Vec<f32>, Vec<f32>) = (0..w)
                .map(|x| {
                    let (s, c) = (std::f64::consts::TAU * (x as f64 + 0.5) / w as f64).sin_cos();
                    (c as f32, s as f32)
                })
                .unzip();
            data.par_chunks_mut(w * ch).enumerate().for_each_init(
                || (Dirs::with_len(w), Coords::with_len(w)),
                |(dirs, coords), (y, row)| {
                    let y = y0 + y;
                    let (st, ct) = (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin_cos();
                    let (st, ct) = (st as f32, ct as f32);
                    for x in 0..w {
                        dirs.x[x] = st * cos_phi[x];
                        dirs.y[x] = st * sin_phi[x];
                        dirs.z[x] = ct;
                    }
                    segment(dirs, coords, row);
                    progress(1);
                },
            );
        }
        Canvas::Cube(layout) => {
            let n = size;
            let (cols, _) = layout.grid();
            let frames = layout.frames();
            let a_tab: Vec<f32> = (0..n).map(|i| ((2 * i + 1) as f64 / n as f64 - 1.0) as f32).collect();
            let v = |a: [i32; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
            data.par_chunks_mut(w * ch).enumerate().for_each_init(
                || (Dirs::with_len(n), Coords::with_len(n)),
                |(dirs, coords), (y, row)| {
                    let y = y0 + y;
                    let b = a_tab[y % n];
                    for (sc, out) in row.chunks_mut(n * ch).enumerate().take(cols) {
                        let [c, r, d] = frames[(y / n) * cols + sc];
                        let base = v(c) + b * v(d);
                        let r = v(r);
                        for (i, &a) in a_tab.iter().enumerate() {
                            dirs.x[i] = base.x + a * r.x;
                            dirs.y[i] = base.y + a * r.y;
                            dirs.z[i] = base.z + a * r.z;
                        }
                        segment(dirs, coords, out);
                    }
                    progress(1);
                },
            );
        }
    }
    Ok(())
}

fn check_channels(ch: usize, opts: &SampleOptions) -> Result<(), ResampleError> {
    if ch == 0 {
        return Err(ResampleError::NoChannels);
    }
    for c in [opts.depth_channel, opts.coverage_channel].into_iter().flatten() {
        if c >= ch {
            return Err(ResampleError::NoSuchChannel { channel: c, channels: ch });
        }
    }
    Ok(())
}

/// Convert `src` (a `from` canvas) to a `to` canvas of `size` (equirect width, or cube face size).
pub fn convert<T: Texel>(
    src: &Raster<T>,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
) -> Result<Raster<T>, ResampleError> {
    convert_with_progress(src, from, to, size, opts, &|_| {})
}

/// Like [`convert`], calling `progress(rows)` as target rows complete (from worker threads).
pub fn convert_with_progress<T: Texel>(
    src: &Raster<T>,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Raster<T>, ResampleError> {
    check_channels(src.channels(), opts)?;
    if let Some(same) = same_face_size(src, from, to, size)? {
        return Ok(same);
    }
    let source = Prepared::new(src, from, opts)?;
    let (w, h) = target_size(to, size, src.channels())?;
    let mut data = vec![T::from_f32(0.0); w * h * src.channels()];
    source.rows(to, size, opts, 0, &mut data, progress)?;
    Ok(Raster::from_vec(w, h, src.channels(), data).expect("length checked by target_size"))
}

/// A cube canvas converted to a cube of its own face size only changes layout: no resampling.
fn same_face_size<T: Texel>(
    src: &Raster<T>,
    from: Canvas,
    to: Canvas,
    size: usize,
) -> Result<Option<Raster<T>>, ResampleError> {
    if let (Canvas::Cube(layout), Canvas::Cube(to_layout)) = (from, to) {
        if layout.face_size(src.width(), src.height())? == size {
            return Ok(Some(convert_layout(src, layout, to_layout)?));
        }
    }
    Ok(None)
}

/// A source canvas ready to be sampled: checked, and cube maps in the canonical layout.
enum Prepared<'a, T> {
    Equirect(&'a [T], usize, EquirectSource),
    Cube(Canonical<'a, T>, usize, CubeSource),
}

/// A cube canvas's samples in the canonical layout: the source's own, or a re-laid-out copy.
enum Canonical<'a, T> {
    Borrowed(&'a [T]),
    Owned(Vec<T>),
}

impl<T> Canonical<'_, T> {
    fn data(&self) -> &[T] {
        match self {
            Canonical::Borrowed(d) => d,
            Canonical::Owned(d) => d,
        }
    }
}

impl<'a, T: Texel> Prepared<'a, T> {
    fn new(src: &'a Raster<T>, from: Canvas, opts: &SampleOptions) -> Result<Self, ResampleError> {
        let ch = src.channels();
        check_channels(ch, opts)?;
        match from {
            Canvas::Equirect => {
                let (w, h) = (src.width(), src.height());
                if w == 0 || w != 2 * h {
                    return Err(ResampleError::NotEquirect { width: w, height: h });
                }
                Ok(Prepared::Equirect(src.data(), ch, EquirectSource { w, h }))
            }
            Canvas::Cube(layout) => {
                let n = layout.face_size(src.width(), src.height())?;
                let data = if layout == CubeLayout::Canonical {
                    Canonical::Borrowed(src.data())
                } else {
                    Canonical::Owned(convert_layout(src, layout, CubeLayout::Canonical)?.into_vec())
                };
                Ok(Prepared::Cube(data, ch, CubeSource { n }))
            }
        }
    }

    /// Resample target rows `y0..` (as many as `out` holds) of a `to` canvas of `size`.
    fn rows(
        &self,
        to: Canvas,
        size: usize,
        opts: &SampleOptions,
        y0: usize,
        out: &mut [T],
        progress: &(dyn Fn(usize) + Sync),
    ) -> Result<(), ResampleError> {
        match self {
            Prepared::Equirect(data, ch, s) => run(data, *ch, s, to, size, opts, y0, out, progress),
            Prepared::Cube(data, ch, s) => run(data.data(), *ch, s, to, size, opts, y0, out, progress),
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn run<T: Texel, S: Source>(
    data: &[T],
    ch: usize,
    source: &S,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
    y0: usize,
    out: &mut [T],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(), ResampleError> {
    let plain = opts.depth_channel.is_none();
    render_rows(to, size, ch, y0, out, progress, |dirs: &Dirs, coords: &mut Coords, out: &mut [T]| {
        source.coords(dirs, coords);
        if plain && opts.filter == Filter::Bilinear {
            for (i, px) in out.chunks_exact_mut(ch).enumerate() {
                source.bilinear(data, ch, coords.face[i], coords.x[i], coords.y[i], px);
            }
            return;
        }
        if plain && opts.filter == Filter::Bicubic {
            for (i, px) in out.chunks_exact_mut(ch).enumerate() {
                source.bicubic(data, ch, coords.face[i], coords.x[i], coords.y[i], px);
            }
            return;
        }
        let mut taps = Taps::EMPTY;
        for (i, px) in out.chunks_exact_mut(ch).enumerate() {
            source.sample(data, ch, (coords.face[i], coords.x[i], coords.y[i]), opts, &mut taps, px);
        }
    })
}

/// Sample a canvas at a direction (any `f64` direction; zero/NaN read the `+Z` pole) into `out`
/// (`channels` samples). Cube canvases are read in `layout`.
pub fn sample_dir<T: Texel>(
    src: &Raster<T>,
    canvas: Canvas,
    d: DVec3,
    opts: &SampleOptions,
    out: &mut [T],
) -> Result<(), ResampleError> {
    let ch = src.channels();
    check_channels(ch, opts)?;
    if out.len() != ch {
        return Err(ResampleError::OutputLength { got: out.len(), channels: ch });
    }
    let d = crate::mapping::sanitize_dir(d).unwrap_or(DVec3::Z).normalize().as_vec3();
    let mut taps = Taps::EMPTY;
    match Prepared::new(src, canvas, opts)? {
        Prepared::Equirect(data, _, s) => s.sample(data, ch, s.coords_of(d), opts, &mut taps, out),
        Prepared::Cube(data, _, s) => s.sample(data.data(), ch, s.coords_of(d), opts, &mut taps, out),
    }
    Ok(())
}

/// Convert a layer image (planar channels) between canvases.
///
/// Colour and other attributes are filtered; `Z` is depth-aware (see the module docs) and `A` follows
/// the same per-pixel decision; normals `N.X, N.Y, N.Z` are filtered then renormalised (they live in the
/// panorama frame, which a change of canvas does not rotate); `U32` channels (identifiers) always take
/// the nearest texel; `F16` channels are rounded to half precision.
pub fn convert_layer(
    src: &LayerImage,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
) -> Result<LayerImage, ResampleError> {
    convert_layer_in_bands(src, from, to, size, opts, BAND_SAMPLES)
}

fn convert_layer_in_bands(
    src: &LayerImage,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
    band_samples: usize,
) -> Result<LayerImage, ResampleError> {
    let ch = src.channels.len();
    let px = src.width.checked_mul(src.height).ok_or(ResampleError::TooLarge {
        width: src.width,
        height: src.height,
        channels: ch,
    })?;
    if let Some(c) = src.channels.iter().find(|c| c.data.len() != px) {
        return Err(ResampleError::ChannelSize {
            name: c.name.clone(),
            len: c.data.len(),
            width: src.width,
            height: src.height,
            expected: px,
        });
    }
    if ch == 0 {
        return Err(ResampleError::NoChannels);
    }
    let mut inter = vec![0.0f32; px * ch];
    for (c, channel) in src.channels.iter().enumerate() {
        for (i, v) in channel.data.iter().enumerate() {
            inter[i * ch + c] = *v;
        }
    }
    let raster =
        Raster::from_vec(src.width, src.height, ch, inter).map_err(|_| ResampleError::Unsupported)?;
    let pos = |name: &str| src.channels.iter().position(|c| c.name == name);
    let mut o = *opts;
    o.depth_channel = pos("Z");
    o.coverage_channel = pos("A");
    if let Some(same) = same_face_size(&raster, from, to, size)? {
        return Ok(planar(src, &same));
    }
    let ids = src.channels.iter().any(|c| c.sample_type == SampleType::U32);
    let nearest_opts = SampleOptions { filter: Filter::Nearest, ..o };
    let nearest = ids && opts.filter != Filter::Nearest;
    let source = Prepared::new(&raster, from, &o)?;
    let (w, h) = target_size(to, size, ch)?;
    let normals = match (pos("N.X"), pos("N.Y"), pos("N.Z")) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    // The output is made a band of rows at a time and scattered into its planar channels, so that
    // memory holds the output once (plus a band), not an interleaved copy of it too.
    let too_large = || ResampleError::TooLarge { width: w, height: h, channels: ch };
    let mut planes: Vec<Vec<f32>> = Vec::with_capacity(ch);
    for _ in 0..ch {
        // Memory the system refuses is an error with a code, not an abort.
        let mut plane = Vec::new();
        plane.try_reserve_exact(w * h).map_err(|_| too_large())?;
        plane.resize(w * h, 0.0f32);
        planes.push(plane);
    }
    let band_rows = (band_samples / (w * ch)).clamp(1, h);
    let mut band = vec![0.0f32; band_rows * w * ch];
    let mut band_ids = if nearest { vec![0.0f32; band_rows * w * ch] } else { Vec::new() };
    let none = |_: usize| {};
    for y0 in (0..h).step_by(band_rows) {
        let rows = band_rows.min(h - y0);
        let ids_len = band_ids.len().min(rows * w * ch);
        let (band, band_ids) = (&mut band[..rows * w * ch], &mut band_ids[..ids_len]);
        source.rows(to, size, &o, y0, band, &none)?;
        if nearest {
            source.rows(to, size, &nearest_opts, y0, band_ids, &none)?;
        }
        let at = y0 * w;
        for (c, channel) in src.channels.iter().enumerate() {
            let from_band: &[f32] =
                if nearest && channel.sample_type == SampleType::U32 { band_ids } else { band };
            let plane = &mut planes[c][at..at + rows * w];
            for (v, px) in plane.iter_mut().zip(from_band.chunks_exact(ch)) {
                *v = px[c];
            }
            if channel.sample_type == SampleType::F16 {
                plane.iter_mut().for_each(|v| *v = half::f16::from_f32(*v).to_f32());
            }
        }
        if let Some([x, y, z]) = normals {
            renormalise(&mut planes, [x, y, z], at..at + rows * w);
        }
    }
    if let (Some(z), Some(from_map), Some(to_map)) =
        (o.depth_channel, layer_mapping(from, src.width, src.height), layer_mapping(to, w, h))
    {
        // Only a source that is one surface wherever it is continuous by the rule is made so again:
        // the breaks of a layer that has some (a plain RGB-D panorama) are its own.
        let cov = o.coverage_channel.map(|a| src.channels[a].data.as_slice());
        if !has_breaks(&src.channels[z].data, cov, &from_map) {
            separate(&mut planes, z, o.coverage_channel, &to_map);
        }
    }
    let mut dst = LayerImage::new(w, h);
    for (channel, data) in src.channels.iter().zip(planes) {
        dst.set_channel(&channel.name, channel.sample_type, data);
    }
    Ok(dst)
}

/// The mapping of a layer canvas: layers live on the equirect and the canonical 3 × 2 cube (an
/// exchange layout has no neighbours here).
fn layer_mapping(canvas: Canvas, w: usize, h: usize) -> Option<AnyMapping> {
    let kind = match canvas {
        Canvas::Equirect => crate::mapping::MappingKind::Equirect,
        Canvas::Cube(CubeLayout::Canonical) => crate::mapping::MappingKind::Cube3x2,
        Canvas::Cube(_) => return None,
    };
    AnyMapping::new(kind, w, h).ok()
}

/// Depth of pixel `i` of a layer's planes for the continuity rule: inside is depth > 0 and
/// coverage > 0.
fn layer_depth(z: &[f32], cov: Option<&[f32]>, i: usize) -> Option<f64> {
    (z[i] > 0.0 && cov.map_or(true, |a| a[i] > 0.0)).then_some(z[i] as f64)
}

/// Whether a layer's depth plane has a 4-neighbour pair that is not one surface
/// ([`continuity::row_breaks`] at [`continuity::LAYER_JUMP`], what `validate` checks); rows stop
/// being searched at the first found.
fn has_breaks(z: &[f32], cov: Option<&[f32]>, mapping: &AnyMapping) -> bool {
    let nb = crate::mapping::Neighbours::new(*mapping);
    (0..mapping.height()).into_par_iter().any(|y| {
        let mut found = false;
        continuity::row_breaks(
            &nb,
            |i| layer_depth(z, cov, i),
            continuity::LAYER_JUMP,
            y,
            |_, _| found = true,
        );
        found
    })
}

/// The nearer pixel of each 4-neighbour pair of a layer's depth plane that is not one surface
/// ([`continuity::row_breaks`] at [`continuity::LAYER_JUMP`], what `validate` checks).
fn nearer_of_breaks(z: &[f32], cov: Option<&[f32]>, mapping: &AnyMapping) -> Vec<usize> {
    let nb = crate::mapping::Neighbours::new(*mapping);
    let depth = |i: usize| layer_depth(z, cov, i);
    (0..mapping.height())
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut row = Vec::new();
            continuity::row_breaks(&nb, depth, continuity::LAYER_JUMP, y, |p, q| {
                row.push(if z[p] <= z[q] { p } else { q });
            });
            row
        })
        .collect()
}

/// Resampled, two parts of a layer a thin gap apart in the source (a line of pixels outside it)
/// can touch where the gap runs aslant the new grid: of each pair of neighbours that is not one
/// surface, the nearer pixel is taken out of the layer, until none is left (a pixel taken out can
/// end a plane that kept another pair one). Asked only for sources without such pairs.
fn separate(planes: &mut [Vec<f32>], z: usize, coverage: Option<usize>, mapping: &AnyMapping) {
    for _ in 0..SEPARATE_PASSES {
        let nearer = nearer_of_breaks(&planes[z], coverage.map(|a| planes[a].as_slice()), mapping);
        if nearer.is_empty() {
            return;
        }
        for p in nearer {
            planes[z][p] = -1.0;
            if let Some(a) = coverage {
                planes[a][p] = 0.0;
            }
        }
    }
}

/// Passes of [`separate`]: each removes every break it finds; few pairs depend on another.
const SEPARATE_PASSES: usize = 4;

/// Samples per band of [`convert_layer`]: large enough to keep both cores busy, small against the
/// output.
const BAND_SAMPLES: usize = 1 << 22;

/// A resampled interleaved raster as the planar layer of `src`'s channels (`F16` rounded to half).
fn planar(src: &LayerImage, out: &Raster<f32>) -> LayerImage {
    let ch = src.channels.len();
    let mut dst = LayerImage::new(out.width(), out.height());
    for (c, channel) in src.channels.iter().enumerate() {
        let mut data: Vec<f32> = out.data().iter().skip(c).step_by(ch).copied().collect();
        if channel.sample_type == SampleType::F16 {
            data.iter_mut().for_each(|v| *v = half::f16::from_f32(*v).to_f32());
        }
        dst.set_channel(&channel.name, channel.sample_type, data);
    }
    dst
}

/// Normals are filtered then renormalised (after rounding, as they are stored).
fn renormalise(planes: &mut [Vec<f32>], [x, y, z]: [usize; 3], range: std::ops::Range<usize>) {
    for i in range {
        let (nx, ny, nz) = (planes[x][i], planes[y][i], planes[z][i]);
        let l = (nx * nx + ny * ny + nz * nz).sqrt();
        if l > 0.0 && l.is_finite() {
            planes[x][i] = nx / l;
            planes[y][i] = ny / l;
            planes[z][i] = nz / l;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_atan2_is_accurate() {
        let mut worst = 0.0f64;
        for k in 0..100_000 {
            let a = k as f64 / 100_000.0 * std::f64::consts::TAU;
            for r in [1e-3, 1.0, 7.0] {
                let (y, x) = (r * a.sin(), r * a.cos());
                let e = (fast_atan2(y as f32, x as f32) as f64 - y.atan2(x)).abs();
                let e = e.min((e - std::f64::consts::TAU).abs());
                worst = worst.max(e);
            }
        }
        assert!(worst < 1e-5, "worst {worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn pole_and_seam_taps_wrap() {
        let s = EquirectSource { w: 8, h: 4 };
        assert_eq!(s.index(-1, 0), 7);
        assert_eq!(s.index(8, 0), 0);
        assert_eq!(s.index(1, -1), 5); // row 0, column 1 + 4
        assert_eq!(s.index(1, 4), 3 * 8 + 5);
        assert_eq!(s.index(0, -2), 8 + 4);
    }

    #[test]
    fn cube_taps_cross_edges() {
        let c = CubeSource { n: 4 };
        // Right of +X's right edge (s = +1 → direction −Y side) is the −Y face.
        let i = c.texel(0, 4, 1);
        let (x, y) = (i % 12, i / 12);
        assert_eq!((x / 4, y / 4), (1, 1), "{x},{y}");
    }

    /// A layer of every sample type, with normals, depth and coverage.
    fn mixed_layer(w: usize, h: usize) -> LayerImage {
        let n = w * h;
        let mut img = LayerImage::new(w, h);
        let f = |k: f32| (0..n).map(|i| (i as f32 * k).sin() * 0.5 + 0.5).collect::<Vec<_>>();
        img.set_channel("R", SampleType::F16, f(0.37));
        img.set_channel("N.X", SampleType::F16, f(0.11));
        img.set_channel("N.Y", SampleType::F16, f(0.05));
        img.set_channel("N.Z", SampleType::F32, f(0.02));
        img.set_channel("Z", SampleType::F32, (0..n).map(|i| 1.0 + ((i / 7) % 3) as f32).collect());
        img.set_channel("A", SampleType::F32, (0..n).map(|i| (i % 11 != 0) as u8 as f32).collect());
        img.set_channel("id", SampleType::U32, (0..n).map(|i| (i % 97) as f32).collect());
        img
    }

    #[test]
    fn a_layer_converted_in_bands_equals_the_whole_raster_conversion() {
        let src = mixed_layer(64, 32);
        let opts = SampleOptions::default();
        let cube = Canvas::Cube(CubeLayout::Canonical);
        for (from, to, size, src) in [
            (Canvas::Equirect, cube, 12, src.clone()),
            (cube, Canvas::Equirect, 40, convert_layer(&src, Canvas::Equirect, cube, 16, &opts).unwrap()),
        ] {
            let whole = convert_layer_in_bands(&src, from, to, size, &opts, usize::MAX).unwrap();
            for band in [1, 7 * 40, 1000] {
                let banded = convert_layer_in_bands(&src, from, to, size, &opts, band).unwrap();
                for (a, b) in whole.channels.iter().zip(&banded.channels) {
                    assert_eq!((&a.name, a.sample_type), (&b.name, b.sample_type));
                    let same = a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits());
                    assert!(same, "channel {} differs with bands of {band} samples", a.name);
                }
            }
            // Against the interleaved conversion it is made of (depth-aware, ids nearest).
            let ch = src.channels.len();
            let mut inter = vec![0.0f32; src.width * src.height * ch];
            for (c, channel) in src.channels.iter().enumerate() {
                for (i, v) in channel.data.iter().enumerate() {
                    inter[i * ch + c] = *v;
                }
            }
            let raster = Raster::from_vec(src.width, src.height, ch, inter).unwrap();
            let o = SampleOptions { depth_channel: Some(4), coverage_channel: Some(5), ..opts };
            let plain = convert(&raster, from, to, size, &o).unwrap();
            let near =
                convert(&raster, from, to, size, &SampleOptions { filter: Filter::Nearest, ..o }).unwrap();
            let at = |r: &Raster<f32>, i: usize, c: usize| r.data()[i * ch + c];
            for i in 0..whole.width * whole.height {
                // (The source steps by more than `LAYER_JUMP`: [`separate`] leaves it as it is.)
                assert_eq!(whole.channels[4].data[i].to_bits(), at(&plain, i, 4).to_bits(), "Z at {i}");
                assert_eq!(whole.channels[6].data[i], at(&near, i, 6), "id at {i}");
                let r = half::f16::from_f32(at(&plain, i, 0)).to_f32();
                assert_eq!(whole.channels[0].data[i], r, "R rounded to half at {i}");
                let n: f32 = (1..4).map(|c| whole.channels[c].data[i].powi(2)).sum();
                assert!((n - 1.0).abs() < 1e-5 || n == 0.0, "normal length² {n} at {i}");
            }
        }
    }

    /// Infinitely far depth (a sky) stays infinite through every filter: a tap of weight 0 on
    /// +inf must not make a NaN (0 · inf).
    #[test]
    fn an_infinitely_far_layer_converts_without_nan() {
        let cube = Canvas::Cube(CubeLayout::Canonical);
        for (w, h, size) in [(64, 32, 12), (1024, 512, 256), (100, 50, 30)] {
            let mut sky = LayerImage::new(w, h);
            sky.set_channel("R", SampleType::F16, vec![0.5; w * h]);
            sky.set_channel("Z", SampleType::F32, vec![f32::INFINITY; w * h]);
            for filter in [Filter::Bilinear, Filter::Bicubic] {
                let opts = SampleOptions { filter, ..SampleOptions::default() };
                let out = convert_layer(&sky, Canvas::Equirect, cube, size, &opts).unwrap();
                let back = convert_layer(&out, cube, Canvas::Equirect, w, &opts).unwrap();
                for img in [&out, &back] {
                    let z = &img.channel("Z").unwrap().data;
                    let nan = z.iter().filter(|v| v.is_nan()).count();
                    assert_eq!(nan, 0, "{w}x{h} {filter:?}: {nan} NaN depths");
                }
            }
        }
    }

    /// At a layer's edge, a point whose nearest texel is inside blends the inside taps (here on a
    /// plane, in inverse depth) instead of taking the nearest texel, a row's step away: resampled
    /// grazing ground near its edge otherwise steps against its blended neighbours.
    #[test]
    fn a_point_at_a_layers_edge_blends_its_inside_taps() {
        use crate::mapping::{Equirect, Mapping};
        let (w, h) = (16, 8);
        // Ground-like: inverse depth linear in the row, 0.1 + 0.15 y (4 m at row 1, 1.43 m at 4).
        let plane = |y: f64| 1.0 / (0.1 + 0.15 * y);
        let mut z: Vec<f32> = (0..w * h).map(|p| plane((p / w) as f64) as f32).collect();
        z[2 * w + 4] = -1.0;
        let src = Raster::from_vec(w, h, 1, z).unwrap();
        let opts = SampleOptions { depth_channel: Some(0), ..SampleOptions::default() };
        // Source point (5.3, 3.3): taps (4..=5, 2..=3), (4, 2) outside; the nearest is (5, 3).
        let d = Equirect::new(w, h).unwrap().pixel_to_dir(5.3, 3.3);
        let mut out = [0.0f32];
        sample_dir(&src, Canvas::Equirect, d, &opts, &mut out).unwrap();
        let truth = plane(2.8);
        let err = (out[0] as f64 / truth - 1.0).abs();
        assert!(
            err < 0.02,
            "depth {} against the plane's {truth:.3} (nearest texel {:.3})",
            out[0],
            plane(3.0)
        );
    }

    #[test]
    fn cubic_weights_sum_to_one() {
        for k in 0..10 {
            let w = cubic_weights(k as f32 / 10.0);
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        }
    }
}
