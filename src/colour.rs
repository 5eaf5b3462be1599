//! Colour encodings at the edges: pomc works in linear RGB inside (OpenEXR layers); 8/16-bit
//! images and glTF textures are sRGB-encoded (IEC 61966-2-1).

/// sRGB-encoded value in [0, 1] → linear.
#[inline]
pub fn srgb_to_linear(s: f32) -> f32 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear value → sRGB-encoded, both in [0, 1] (clamped; NaN → 0).
#[inline]
pub fn linear_to_srgb(l: f32) -> f32 {
    let x = if l.is_nan() { 0.0 } else { l.clamp(0.0, 1.0) };
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear value → sRGB-encoded 8-bit code (clamped to [0, 1], rounded; NaN → 0). A linear 0.5 is 188.
#[inline]
pub fn srgb8(l: f32) -> u8 {
    (linear_to_srgb(l) * 255.0).round().clamp(0.0, 255.0) as u8
}

crate::choice::choices! {
    /// How the values of an 8/16-bit input image are encoded.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum ColourSpace (default Auto) {
        /// sRGB for 8/16-bit images, linear for float ones.
        ///
        /// 8/16-bit: PNG, JPEG; float: OpenEXR, Radiance HDR.
        Auto = "auto",
        /// sRGB-encoded values.
        ///
        /// Whatever the format.
        Srgb = "srgb",
        /// Linear values.
        ///
        /// Already linear (e.g. a PNG written from linear values without encoding).
        Linear = "linear",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_8_bit_code_round_trips() {
        for code in 0..=255u8 {
            assert_eq!(srgb8(srgb_to_linear(code as f32 / 255.0)), code);
        }
        assert_eq!(srgb8(0.5), 188);
        assert_eq!(srgb8(f32::NAN), 0);
        assert_eq!(srgb8(7.0), 255);
        // The two branches meet: continuous at the knee.
        assert!((srgb_to_linear(0.040_45) - 0.040_45 / 12.92).abs() < 1e-7);
    }
}
