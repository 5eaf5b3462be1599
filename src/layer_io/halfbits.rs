//! Bit-exact conversion between IEEE half and `f32`.
//!
//! Layers keep every channel as `f32` in memory; a channel stored as half must come back to the
//! very same 16 bits when written again. `half`'s conversions (and the F16C instructions) quiet
//! signalling NaNs, which would change the bits of a NaN-coded sample: NaNs are therefore mapped
//! by hand (payload shifted into the top of the `f32` mantissa, nothing else touched). Every other
//! value converts exactly half → f32, and f32 → half rounds to nearest-even (exact whenever the
//! value is representable as half, which is what [`SampleType::F16`](crate::layer::SampleType)
//! promises).

use std::sync::OnceLock;

use half::f16;
use rayon::prelude::*;

/// Half → `f32`, exact for all 65 536 bit patterns (NaN payloads and sign kept).
#[inline]
pub fn half_to_f32(h: f16) -> f32 {
    let bits = h.to_bits();
    if bits & 0x7c00 == 0x7c00 && bits & 0x03ff != 0 {
        let sign = u32::from(bits & 0x8000) << 16;
        let payload = u32::from(bits & 0x03ff) << 13;
        f32::from_bits(sign | 0x7f80_0000 | payload)
    } else {
        h.to_f32()
    }
}

/// `f32` → half: inverse of [`half_to_f32`] on its image; other values round to nearest-even.
/// A NaN whose payload lives only in the low 13 bits keeps being a NaN (quiet bit set).
#[inline]
pub fn f32_to_half(x: f32) -> f16 {
    if x.is_nan() {
        let bits = x.to_bits();
        let sign = ((bits >> 16) & 0x8000) as u16;
        let mut payload = ((bits >> 13) & 0x03ff) as u16;
        if payload == 0 {
            payload = 0x0200;
        }
        f16::from_bits(sign | 0x7c00 | payload)
    } else {
        f16::from_f32(x)
    }
}

/// [`half_to_f32`] over a slice, in parallel, by a table of all 65 536 patterns (built once from
/// [`half_to_f32`]): a layer's channels convert at memory speed.
pub fn halves_to_f32(v: &[f16]) -> Vec<f32> {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    let table = TABLE.get_or_init(|| (0..=u16::MAX).map(|b| half_to_f32(f16::from_bits(b))).collect());
    v.par_iter().with_min_len(1 << 14).map(|h| table[usize::from(h.to_bits())]).collect()
}

/// [`f32_to_half`] over a slice, in parallel.
pub fn f32s_to_half(v: &[f32]) -> Vec<f16> {
    v.par_iter().with_min_len(1 << 14).map(|&x| f32_to_half(x)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_half_patterns_round_trip() {
        for bits in 0..=u16::MAX {
            let h = f16::from_bits(bits);
            assert_eq!(f32_to_half(half_to_f32(h)).to_bits(), bits, "pattern {bits:#06x}");
        }
    }

    #[test]
    fn slices_convert_as_single_values() {
        let all: Vec<f16> = (0..=u16::MAX).map(f16::from_bits).collect();
        let wide = halves_to_f32(&all);
        for (h, x) in all.iter().zip(&wide) {
            assert_eq!(x.to_bits(), half_to_f32(*h).to_bits(), "pattern {:#06x}", h.to_bits());
        }
        let back = f32s_to_half(&wide);
        assert!(back.iter().zip(&all).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn finite_values_match_half_crate() {
        for x in [0.0f32, -0.0, 1.0, 0.1, 65504.0, 1e-7, -3.5, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(f32_to_half(x).to_bits(), f16::from_f32(x).to_bits());
        }
        assert!(f32_to_half(f32::from_bits(0x7f80_0001)).is_nan());
    }
}
