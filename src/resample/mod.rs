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

use std::fmt;
use std::str::FromStr;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::mapping::layout::{convert_layout, CubeLayout, LayoutError};
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

crate::codes::error_codes! {
    ResampleError:
        Unsupported RESAMPLE_UNSUPPORTED,
        NotEquirect RESAMPLE_NOT_EQUIRECT,
        BadTargetSize RESAMPLE_BAD_SIZE,
        TooLarge RESAMPLE_TOO_LARGE,
        NoSuchChannel RESAMPLE_NO_SUCH_CHANNEL,
        NoChannels RESAMPLE_NO_CHANNELS,
        OutputLength RESAMPLE_OUTPUT_LENGTH,
        ChannelSize RESAMPLE_CHANNEL_SIZE;
        from Layout.0
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

impl fmt::Display for Filter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
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

/// Integer samples: rounded to nearest; `as` saturates (and maps NaN to 0).
macro_rules! integer_texel {
    ($($t:ty),*) => {$(
        impl Texel for $t {
            #[inline]
            fn to_f32(self) -> f32 {
                self as f32
            }
            #[inline]
            fn from_f32(v: f32) -> Self {
                (v + 0.5) as $t
            }
        }
    )*};
}
integer_texel!(u8, u16);

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

mod depth;
mod layer;
mod source;
mod taps;
#[cfg(test)]
mod tests;

use self::source::batch;
use self::source::Coords;
use self::source::CubeSource;
use self::source::Dirs;
use self::source::EquirectSource;
use self::source::Source;
pub use layer::convert_layer;

pub use taps::Taps;

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

/// Fill `rows` (of `ch` interleaved samples), calling `segment` on runs of directions.
fn render_rows<T: Texel>(
    rows: Rows<T>,
    ch: usize,
    segment: impl Fn(&Dirs, &mut Coords, &mut [T]) + Sync,
) -> Result<(), ResampleError> {
    let Rows { to: target, size, y0, out: data, progress } = rows;
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
                || batch(w),
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
                || batch(n),
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
    source.rows(opts, Rows { to, size, y0: 0, out: &mut data, progress })?;
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

    /// Resample `rows` under `opts`.
    fn rows(&self, opts: &SampleOptions, rows: Rows<T>) -> Result<(), ResampleError> {
        match self {
            Prepared::Equirect(data, ch, s) => run(data, *ch, s, opts, rows),
            Prepared::Cube(data, ch, s) => run(data.data(), *ch, s, opts, rows),
        }
    }
}

/// Target rows `y0..` (as many as `out` holds) of a `to` canvas of `size`, whole rows of
/// interleaved samples; `progress(1)` is called per row.
pub(super) struct Rows<'a, T> {
    pub(super) to: Canvas,
    pub(super) size: usize,
    pub(super) y0: usize,
    pub(super) out: &'a mut [T],
    pub(super) progress: &'a (dyn Fn(usize) + Sync),
}

fn run<T: Texel, S: Source>(
    data: &[T],
    ch: usize,
    source: &S,
    opts: &SampleOptions,
    rows: Rows<T>,
) -> Result<(), ResampleError> {
    let plain = opts.depth_channel.is_none();
    render_rows(rows, ch, |dirs: &Dirs, coords: &mut Coords, out: &mut [T]| {
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
