//! Filter weights and taps: which texels a filtered pixel reads, with what weight.

use super::Filter;

/// Catmull-Rom weights of taps `−1, 0, 1, 2` at fraction `t ∈ [0, 1)`.
#[inline]
pub(super) fn cubic_weights(t: f32) -> [f32; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2]
}

/// `floor` for the sample range (|p| < 2³¹) without a libm call (baseline x86-64 has no `roundps`).
#[inline]
pub(super) fn floor_i64(p: f32) -> i64 {
    let i = p as i64;
    if (i as f32) > p {
        i - 1
    } else {
        i
    }
}

/// Copy one pixel (a handful of samples: a loop beats a `memmove` call).
#[inline]
pub(super) fn copy_pixel<T: Copy>(src: &[T], ch: usize, idx: usize, out: &mut [T]) {
    let p = &src[idx * ch..idx * ch + ch];
    for (o, v) in out.iter_mut().zip(p) {
        *o = *v;
    }
}

/// Filter footprint along one axis: first tap offset, tap count and weights.
#[inline]
pub(super) fn axis_weights(filter: Filter, p: f32) -> (i64, usize, [f32; 4]) {
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
    pub(super) idx: [usize; 16],
    pub(super) w: [f32; 16],
    pub(super) n: usize,
    /// The pixel containing the sample point (used at discontinuities).
    pub(super) nearest: usize,
}

impl Taps {
    pub(super) const EMPTY: Taps = Taps { idx: [0; 16], w: [0.0; 16], n: 0, nearest: 0 };
}
