//! Summed-area tables (thesis eq. 7.6-7.9): O(1) sums over any node rectangle.
//!
//! Sums are kept in `u64`: counts are exact, and real-valued maps (the residual `V_R`) are quantised to
//! fixed point first ([`FIXED_ONE`]) so that a rectangle sum is the *exact* sum of the quantised values,
//! whatever the canvas size. A floating-point table loses the small terms of an 8K-wide row of large
//! constants; integers do not.

/// Fixed-point scale for real-valued maps: `1.0` is stored as `2^32`.
pub const FIXED_ONE: f64 = 4_294_967_296.0;

/// Quantise a non-negative value to the fixed-point scale (negative and NaN give 0).
#[inline]
pub fn to_fixed(v: f64) -> u64 {
    if v > 0.0 {
        (v * FIXED_ONE).round() as u64
    } else {
        0
    }
}

/// Cell type of a table: unsigned integers with wrapping sums. Counts (at most the number of cells
/// of a rectangle) use `u32` while the lattice has fewer than 2³² cells, halving the table's memory;
/// fixed-point maps use `u64`.
pub trait SatValue: Copy + Default + Send + Sync + PartialEq {
    /// `self + o`, wrapping around at the type's bounds.
    fn wrapping_add(self, o: Self) -> Self;
    /// `self − o`, wrapping around at the type's bounds.
    fn wrapping_sub(self, o: Self) -> Self;
}

macro_rules! sat_value {
    ($($t:ty),*) => {$(
        impl SatValue for $t {
            #[inline]
            fn wrapping_add(self, o: Self) -> Self {
                <$t>::wrapping_add(self, o)
            }
            #[inline]
            fn wrapping_sub(self, o: Self) -> Self {
                <$t>::wrapping_sub(self, o)
            }
        }
    )*};
}
sat_value!(u32, u64);

/// A `(w+1) × (h+1)` table of prefix sums of a `w × h` map.
#[derive(Clone, Debug)]
pub struct Sat<T = u64> {
    w: usize,
    h: usize,
    data: Vec<T>,
}

impl<T: SatValue> Sat<T> {
    /// Table of the map `f(x, y)`, `0 ≤ x < w`, `0 ≤ y < h`. Rows are summed in parallel, then each
    /// row adds the one above (a streaming pass); the result does not depend on the thread count.
    pub fn from_fn(w: usize, h: usize, f: impl Fn(usize, usize) -> T + Sync) -> Sat<T> {
        use rayon::prelude::*;
        let stride = w + 1;
        let mut data = vec![T::default(); stride * (h + 1)];
        data[stride..].par_chunks_mut(stride).enumerate().for_each(|(y, row)| {
            let mut acc = T::default();
            for x in 0..w {
                acc = acc.wrapping_add(f(x, y));
                row[x + 1] = acc;
            }
        });
        for y in 1..h {
            let (above, rest) = data[y * stride..].split_at_mut(stride);
            for (r, a) in rest[..stride].iter_mut().zip(above.iter()) {
                *r = r.wrapping_add(*a);
            }
        }
        Sat { w, h, data }
    }

    /// Sum over the half-open rectangle `[x0, x1) × [y0, y1)` (clamped to the map).
    #[inline]
    pub fn sum(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> T {
        let (x1, y1) = (x1.min(self.w), y1.min(self.h));
        if x0 >= x1 || y0 >= y1 {
            return T::default();
        }
        let s = self.w + 1;
        let d = &self.data;
        // Wrapping arithmetic: intermediate differences may wrap, the final sum never does.
        d[y1 * s + x1].wrapping_sub(d[y0 * s + x1]).wrapping_sub(d[y1 * s + x0]).wrapping_add(d[y0 * s + x0])
    }
}

/// A table of counts (0/1 flags): `u32` cells when every rectangle sum fits, else `u64`.
#[derive(Clone, Debug)]
pub enum CountSat {
    /// `u32` cells: the lattice has fewer than `u32::MAX` cells.
    Narrow(Sat<u32>),
    /// `u64` cells, for larger lattices.
    Wide(Sat<u64>),
}

impl CountSat {
    /// Table of the flags `f(x, y)`.
    pub fn from_fn(w: usize, h: usize, f: impl Fn(usize, usize) -> bool + Sync) -> CountSat {
        if (w as u64) * (h as u64) < u32::MAX as u64 {
            CountSat::Narrow(Sat::from_fn(w, h, |x, y| f(x, y) as u32))
        } else {
            CountSat::Wide(Sat::from_fn(w, h, |x, y| f(x, y) as u64))
        }
    }

    /// Number of set flags in `[x0, x1) × [y0, y1)`.
    #[inline]
    pub fn count(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> u64 {
        match self {
            CountSat::Narrow(s) => s.sum(x0, y0, x1, y1) as u64,
            CountSat::Wide(s) => s.sum(x0, y0, x1, y1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_match_brute_force() {
        let f = |x: usize, y: usize| ((x * 7 + y * 13) % 5) as u64;
        let sat = Sat::from_fn(9, 6, f);
        let narrow = Sat::from_fn(9, 6, |x, y| f(x, y) as u32);
        let flags = CountSat::from_fn(9, 6, |x, y| f(x, y) >= 2);
        for (x0, y0, x1, y1) in [(0, 0, 9, 6), (2, 1, 5, 4), (3, 3, 4, 4), (4, 2, 4, 5), (8, 5, 9, 6)] {
            let brute: u64 = (y0..y1).flat_map(|y| (x0..x1).map(move |x| f(x, y))).sum();
            assert_eq!(sat.sum(x0, y0, x1, y1), brute);
            assert_eq!(narrow.sum(x0, y0, x1, y1) as u64, brute);
            let count = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (f(x, y) >= 2) as u64)).sum::<u64>();
            assert_eq!(flags.count(x0, y0, x1, y1), count);
        }
    }

    /// 8K-wide rows of a large constant plus tiny variations: the quantised sums stay exact, where a
    /// float64 table of the raw values would round the small terms away.
    #[test]
    fn stiff_case_is_exact() {
        let (w, h) = (8192, 8);
        let v = |x: usize, y: usize| 1.25 + 1e-9 * ((x * 31 + y * 17) % 11) as f64;
        let sat = Sat::from_fn(w, h, |x, y| to_fixed(v(x, y)));
        let q: Vec<u64> = (0..h).flat_map(|y| (0..w).map(move |x| to_fixed(v(x, y)))).collect();
        for (x0, y0, x1, y1) in [(0, 0, w, h), (4095, 3, 4100, 5), (8190, 7, 8192, 8), (1, 1, 2, 2)] {
            let brute: u64 = (y0..y1).flat_map(|y| (x0..x1).map(|x| q[y * w + x]).collect::<Vec<_>>()).sum();
            assert_eq!(sat.sum(x0, y0, x1, y1), brute);
        }
        // One tiny variation is visible in a difference of two huge prefix sums.
        let a = sat.sum(0, 0, 4001, 1) - sat.sum(0, 0, 4000, 1);
        assert_eq!(a, to_fixed(v(4000, 0)));
    }
}
