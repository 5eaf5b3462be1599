//! Pixel-centre direction tables.

use glam::DVec3;

use super::{AnyMapping, Mapping};

/// Pixel-centre directions of a canvas ([`Mapping::pixel_dir`], bit for bit), with a separable
/// table for the equirect canvas: no trigonometry per pixel in the loops that visit every pixel.
pub enum DirTable {
    /// Separable equirect table: direction = `(sinθ·cosφ, sinθ·sinφ, cosθ)`.
    Equirect {
        /// Per row j: `(sin θ, cos θ)` of the polar angle of the row centre.
        rows: Vec<(f64, f64)>,
        /// Per column i: `(cos φ, sin φ)` of the azimuth of the column centre.
        cols: Vec<(f64, f64)>,
    },
    /// No table: directions computed by [`Mapping::pixel_dir`] (cube maps).
    Generic(AnyMapping),
}

impl DirTable {
    /// The table of mapping `m`: tabulated for an equirect canvas, generic otherwise.
    pub fn new(m: AnyMapping) -> DirTable {
        match m {
            AnyMapping::Equirect(_) => {
                let (w, h) = (m.width(), m.height());
                let rows = (0..h).map(|j| (std::f64::consts::PI * (j as f64 + 0.5) / h as f64).sin_cos());
                let cols = (0..w).map(|i| {
                    let (s, c) = (std::f64::consts::TAU * (i as f64 + 0.5) / w as f64).sin_cos();
                    (c, s)
                });
                DirTable::Equirect { rows: rows.collect(), cols: cols.collect() }
            }
            AnyMapping::Cube(_) => DirTable::Generic(m),
        }
    }

    /// Unit direction through the centre of pixel `(i, j)`, as [`Mapping::pixel_dir`] gives it.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> DVec3 {
        match self {
            DirTable::Equirect { rows, cols } => {
                let ((st, ct), (cp, sp)) = (rows[j], cols[i]);
                DVec3::new(st * cp, st * sp, ct)
            }
            DirTable::Generic(m) => m.pixel_dir(i, j),
        }
    }
}

/// Pixel-centre unit directions in `f32` by row-major pixel index, for loops that look them up
/// pixel by pixel: from the separable table on an equirect canvas (no per-pixel storage: 12 bytes a
/// pixel less on big canvases), from a full table otherwise. Equal to `m.pixel_dir(i, j).as_vec3()`.
pub(crate) enum PixelDirs {
    /// Equirect: [`DirTable::Equirect`]'s rows and columns, and the canvas width.
    Separable {
        /// Canvas width, pixels (divides pixel indices by multiplication).
        width: strength_reduce::StrengthReducedUsize,
        /// Per row: `(sin θ, cos θ)`.
        rows: Vec<(f64, f64)>,
        /// Per column: `(cos φ, sin φ)`.
        cols: Vec<(f64, f64)>,
    },
    /// One direction per pixel.
    Full(Vec<glam::Vec3>),
}

impl PixelDirs {
    /// The directions of mapping `m`'s pixels.
    pub(crate) fn new(m: AnyMapping) -> PixelDirs {
        use rayon::prelude::*;
        match DirTable::new(m) {
            DirTable::Equirect { rows, cols } => PixelDirs::Separable {
                width: strength_reduce::StrengthReducedUsize::new(m.width()),
                rows,
                cols,
            },
            DirTable::Generic(m) => {
                let w = m.width();
                let dir = |p: usize| m.pixel_dir(p % w, p / w).as_vec3();
                PixelDirs::Full((0..w * m.height()).into_par_iter().map(dir).collect())
            }
        }
    }

    /// Unit direction through the centre of pixel `p` (row-major), `f32`.
    #[inline(always)]
    pub(crate) fn at(&self, p: usize) -> glam::Vec3 {
        match self {
            PixelDirs::Separable { width, rows, cols } => {
                let (j, i) = strength_reduce::StrengthReducedUsize::div_rem(p, *width);
                let ((st, ct), (cp, sp)) = (rows[j], cols[i]);
                glam::Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32)
            }
            PixelDirs::Full(v) => v[p],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::MappingKind;

    /// `PixelDirs::at` is the pixel-centre direction of `Mapping::pixel_dir`, bit for bit (poles
    /// and seam included).
    #[test]
    fn pixel_dirs_are_the_mapping_directions() {
        for (kind, w, h) in [
            (MappingKind::Equirect, 64, 32),
            (MappingKind::Equirect, 4000, 2000),
            (MappingKind::Cube3x2, 48, 32),
        ] {
            let m = AnyMapping::new(kind, w, h).unwrap();
            let dirs = PixelDirs::new(m);
            for p in (0..w * h).step_by(7).chain([0, w - 1, w * h - 1]) {
                let want = m.pixel_dir(p % w, p / w).as_vec3();
                assert_eq!(dirs.at(p), want, "pixel {p} of {w}x{h}");
            }
        }
    }
}
