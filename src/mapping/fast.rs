//! Fast `f32` inverse mapping for lookups that sample at arbitrary points anyway (the resampler,
//! the fill's texture search): a polynomial `atan2` instead of the exact one.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::{AnyMapping, Mapping};

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

impl AnyMapping {
    /// Row-major index of the pixel holding direction `d` (any length), within 1e-5 rad of
    /// [`Mapping::pixel_of`]: `f32` with [`fast_atan2`] on the equirect canvas, exact on cube maps
    /// (no trigonometry there) and for degenerate input.
    #[inline]
    pub fn pixel_index_fast(&self, d: Vec3) -> usize {
        let (w, h) = (self.width(), self.height());
        if let AnyMapping::Equirect(_) = self {
            let rho2 = d.x * d.x + d.y * d.y;
            if (rho2 + d.z * d.z).is_normal() {
                let mut phi = fast_atan2(d.y, d.x);
                if phi < 0.0 {
                    phi += TAU;
                }
                let theta = fast_atan2(rho2.sqrt(), d.z);
                let i = ((phi * (w as f32 / TAU)) as usize).min(w - 1);
                let j = ((theta * (h as f32 / PI)) as usize).min(h - 1);
                return j * w + i;
            }
        }
        let (i, j) = self.pixel_of(d.as_dvec3());
        j * w + i
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::MappingKind;

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

    /// The fast lookup finds the exact pixel except within a hair of a pixel's edge.
    #[test]
    fn fast_pixel_index_matches_pixel_of() {
        for kind in [MappingKind::Equirect, MappingKind::Cube3x2] {
            let (w, h) = if kind == MappingKind::Equirect { (4096, 2048) } else { (3072, 2048) };
            let m = AnyMapping::new(kind, w, h).unwrap();
            let mut off = 0;
            for k in 0..200_000u32 {
                // A deterministic spread of directions and lengths.
                let u = (k as f64 * 0.618_033_988_749_895).fract();
                let v = (k as f64 * 0.754_877_666_246_693).fract();
                let (z, a) = (2.0 * v - 1.0, std::f64::consts::TAU * u);
                let r = (1.0 - z * z).sqrt();
                let d = glam::DVec3::new(r * a.cos(), r * a.sin(), z) * (0.01 + 300.0 * u);
                let exact = m.dir_to_pixel(d);
                let (i, j) = m.pixel_of(d);
                if m.pixel_index_fast(d.as_vec3()) != j * w + i {
                    // Only where the exact position is within the error (1e-5 rad: 0.007 px at this
                    // size) of an edge.
                    let edge = |x: f64| (x - x.round()).abs();
                    assert!(edge(exact.x).min(edge(exact.y)) < 0.01, "{d:?} at {exact:?}");
                    off += 1;
                }
            }
            // 284 of them on the equirect canvas.
            assert!(off < 500, "{off} of 200 000 lookups off by a pixel");
            // Degenerate input takes the exact path: no panic, inside the canvas, as `pixel_of`.
            for d in [
                Vec3::ZERO,
                Vec3::NAN,
                Vec3::new(f32::INFINITY, 0.0, 1.0),
                Vec3::new(f32::MAX, f32::MAX, 0.0),
                Vec3::new(1e-40, 0.0, -1e-40),
            ] {
                let (i0, j0) = m.pixel_of(d.as_dvec3());
                assert_eq!(m.pixel_index_fast(d), j0 * w + i0, "{d:?}");
            }
            // The pole: any column of its row (signed zeros give the exact `atan2` −π).
            let pole = Vec3::new(-0.0, -0.0, 1.0);
            assert_eq!(m.pixel_index_fast(pole) / w, m.pixel_of(pole.as_dvec3()).1);
        }
    }
}
