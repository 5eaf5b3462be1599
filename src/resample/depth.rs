//! The depth-aware rule: depth is never blended across a discontinuity, and all channels follow
//! the one decision per pixel.

use super::taps::{copy_pixel, Taps};
use super::{SampleOptions, Texel};

/// What the depth-aware rule makes of a pixel's taps.
pub(super) enum DepthTaps {
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
pub(super) fn blendable<T: Texel>(
    src: &[T],
    ch: usize,
    taps: &Taps,
    opts: &SampleOptions,
    z: usize,
) -> DepthTaps {
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
pub(super) fn tap_inside<T: Texel>(src: &[T], base: usize, z: usize, cov: Option<usize>) -> bool {
    src[base + z].to_f32() >= 0.0 && cov.is_none_or(|a| src[base + a].to_f32() > 0.0)
}

/// When the nearest texel is inside the layer but some weighted taps are not: the inside taps,
/// their weights renormalised (`None` if their weight is under half, as bicubic lobes can leave).
#[inline]
pub(super) fn inside_taps<T: Texel>(
    src: &[T],
    ch: usize,
    taps: &Taps,
    opts: &SampleOptions,
    z: usize,
) -> Option<Taps> {
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
pub(super) fn resolve<T: Texel>(src: &[T], ch: usize, taps: &Taps, opts: &SampleOptions, out: &mut [T]) {
    resolve_with(src, ch, taps, opts, || false, out)
}

/// The taps' weighted sum of every channel into `out`.
#[inline(always)]
fn blend_taps<T: Texel>(src: &[T], ch: usize, taps: &Taps, out: &mut [T]) {
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
}

/// `1 / Σ w/d` over the taps of non-zero weight: depth `z` interpolated as inverse depth.
#[inline(always)]
fn harmonic_depth<T: Texel>(src: &[T], ch: usize, taps: &Taps, z: usize) -> f32 {
    let s: f32 = (0..taps.n)
        .filter(|&k| taps.w[k] != 0.0)
        .map(|k| taps.w[k] / src[taps.idx[k] * ch + z].to_f32())
        .sum();
    1.0 / s
}

/// [`resolve`], where `on_plane` says whether taps stepping by more than the relative jump lie on
/// one plane (asked only then).
#[inline(always)]
pub(super) fn resolve_with<T: Texel>(
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
    blend_taps(src, ch, taps, out);
    if let Some((z, (lo, hi))) = range {
        // Across a steep plane, the weighted mean of inverse depths (the plane's own interpolation).
        let d = if inverse { harmonic_depth(src, ch, taps, z) } else { out[z].to_f32() };
        // Equal taps keep their depth exactly: infinitely far ones (a sky) would sum to NaN
        // (0 · inf for a tap of weight 0, inf − inf for bicubic's negative lobes).
        out[z] = T::from_f32(if lo == hi { lo } else { d.clamp(lo, hi) });
    }
}
