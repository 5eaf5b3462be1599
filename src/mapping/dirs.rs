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
