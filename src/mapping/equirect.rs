//! The equirect (lat-long) canvas, thesis appendix A.2 (spec §3.2).
//!
//! Canvas `W × H` with `W = 2H`. Continuous pixel coordinates `(x, y)`, `u = x/W`, `v = y/H`,
//! azimuth `φ = 2πu`, polar angle `θ = πv`, direction `(sinθ cosφ, sinθ sinφ, cosθ)`.
//! Row 0 touches the north pole `+Z`; column 0 starts at azimuth `+X`; azimuth grows towards `+Y`.

use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3};

use super::{below, sanitize_dir, Mapping, MappingError, MappingKind};

/// Equirect (lat-long) 2:1 canvas (thesis A.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Equirect {
    width: usize,
    height: usize,
}

impl Equirect {
    /// A `width × height` canvas (pixels); errs unless `width = 2·height > 0`.
    pub fn new(width: usize, height: usize) -> Result<Self, MappingError> {
        if width == 0 || Some(width) != height.checked_mul(2) {
            return Err(MappingError { kind: MappingKind::Equirect, width, height });
        }
        Ok(Equirect { width, height })
    }

    /// Azimuth `φ ∈ [0, 2π)` and polar angle `θ ∈ [0, π]` of a direction; `None` for zero/NaN input.
    ///
    /// `θ = atan2(hypot(x, y), z)` rather than `acos(z)`: `acos` loses half the digits near the poles
    /// and needs a unit vector.
    pub fn angles(d: DVec3) -> Option<(f64, f64)> {
        let d = sanitize_dir(d)?;
        let mut phi = d.y.atan2(d.x);
        if phi < 0.0 {
            phi += TAU;
        }
        // `-tiny + 2π` rounds to 2π: that is azimuth 0.
        if phi >= TAU {
            phi = 0.0;
        }
        Some((phi, d.x.hypot(d.y).atan2(d.z)))
    }
}

impl Mapping for Equirect {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }

    fn pixel_to_dir(&self, x: f64, y: f64) -> DVec3 {
        let phi = TAU * x / self.width as f64;
        let theta = PI * y / self.height as f64;
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        DVec3::new(st * cp, st * sp, ct)
    }

    /// Total inverse: zero or NaN directions map to `(0, 0)`, the pixel of the `+Z` pole.
    fn dir_to_pixel(&self, d: DVec3) -> DVec2 {
        let (w, h) = (self.width as f64, self.height as f64);
        let Some((phi, theta)) = Self::angles(d) else {
            return DVec2::ZERO;
        };
        let x = (phi / TAU * w).clamp(0.0, below(w));
        let y = (theta / PI * h).clamp(0.0, below(h));
        DVec2::new(x, y)
    }

    /// Exact: `(2π/W)(cos θ_top − cos θ_bottom)`, written as `2 sin(mid) sin(half)` to keep full
    /// relative precision in the polar rows.
    fn solid_angle(&self, _i: usize, j: usize) -> f64 {
        let h = self.height as f64;
        let t0 = PI * j as f64 / h;
        let t1 = PI * (j as f64 + 1.0) / h;
        TAU / self.width as f64 * 2.0 * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_2_to_1() {
        assert!(Equirect::new(0, 0).is_err());
        assert!(Equirect::new(100, 49).is_err());
        assert!(Equirect::new(4, 2).is_ok());
        assert!(Equirect::new(usize::MAX - 1, usize::MAX / 2 + 1).is_err());
        assert!(crate::mapping::Cube3x2::new(usize::MAX, usize::MAX - 1).is_err());
    }

    #[test]
    fn centres_of_4x2_by_hand() {
        let m = Equirect::new(4, 2).unwrap();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        // Pixel (0,0): φ = π/4, θ = π/4.
        let d = m.pixel_dir(0, 0);
        assert!((d - DVec3::new(0.5, 0.5, s)).length() < 1e-15, "{d}");
        // Pixel (2,1): φ = 5π/4, θ = 3π/4.
        let d = m.pixel_dir(2, 1);
        assert!((d - DVec3::new(-0.5, -0.5, -s)).length() < 1e-15, "{d}");
    }

    #[test]
    fn poles_and_seam_are_inside() {
        let m = Equirect::new(4096, 2048).unwrap();
        let cases = [
            DVec3::Z,
            -DVec3::Z,
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(-1.0, -0.0, 0.0),
            DVec3::new(1.0, -1e-300, 0.0),
            DVec3::new(1.0, -f64::MIN_POSITIVE / 4.0, 0.0),
            DVec3::new(f64::MAX, f64::MAX, f64::MAX),
            DVec3::new(f64::INFINITY, 1.0, f64::NEG_INFINITY),
            DVec3::ZERO,
            DVec3::NAN,
        ];
        for d in cases {
            let p = m.dir_to_pixel(d);
            assert!(p.x >= 0.0 && p.x < 4096.0 && p.y >= 0.0 && p.y < 2048.0, "{d} -> {p}");
        }
        assert_eq!(m.dir_to_pixel(DVec3::ZERO), DVec2::ZERO);
        assert_eq!(m.dir_to_pixel(-DVec3::Z).y, below(2048.0));
        assert_eq!(m.dir_to_pixel(DVec3::new(1.0, -1e-300, 0.0)).x, 0.0);
        assert_eq!(m.dir_to_pixel(DVec3::new(-1.0, 0.0, 0.0)).x, 2048.0);
    }
}
