//! Depth of another resolution onto the colour's grid: bilinear in inverse depth (planes stay
//! planes), the nearest sample where a tap is unknown or infinitely far. The soft edges this
//! leaves (a ramp about as wide as the ratio) are snapped onto the colour edges by the refinement.

use rayon::prelude::*;

use crate::mapping::{AnyMapping, Mapping};

/// `depth` (`from`'s canvas, metres) resampled onto `to`'s canvas; both of one mapping kind.
pub(crate) fn resize(depth: &[f32], from: &AnyMapping, to: &AnyMapping) -> Vec<f32> {
    let (dw, dh) = (from.width(), from.height());
    let (cw, ch) = (to.width(), to.height());
    // Equirect: one tile; cube: faces of side h/2, the same 3×2 grid on both canvases.
    let (tile_d, tile_c, wrap) = match to {
        AnyMapping::Equirect(_) => ((dw, dh), (cw, ch), true),
        AnyMapping::Cube(_) => ((dh / 2, dh / 2), (ch / 2, ch / 2), false),
    };
    let axis = |i: usize, tc: usize, td: usize| -> (usize, f64) {
        let (t, l) = (i / tc, i % tc);
        (t * td, (l as f64 + 0.5) * td as f64 / tc as f64 - 0.5)
    };
    (0..cw * ch)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % cw, p / cw);
            let (ox, fx) = axis(x, tile_c.0, tile_d.0);
            let (oy, fy) = axis(y, tile_c.1, tile_d.1);
            let fy = fy.clamp(0.0, (tile_d.1 - 1) as f64);
            let fx = if wrap { fx } else { fx.clamp(0.0, (tile_d.0 - 1) as f64) };
            let (x0, y0) = (fx.floor(), fy.floor());
            let (tx, ty) = (fx - x0, fy - y0);
            let col = |i: f64| -> usize {
                let i = i as i64;
                let c = if wrap { i.rem_euclid(tile_d.0 as i64) } else { i.clamp(0, tile_d.0 as i64 - 1) };
                ox + c as usize
            };
            let row = |j: f64| oy + (j as usize).min(tile_d.1 - 1);
            let at = |i: f64, j: f64| depth[row(j) * dw + col(i)];
            let taps = [at(x0, y0), at(x0 + 1.0, y0), at(x0, y0 + 1.0), at(x0 + 1.0, y0 + 1.0)];
            if taps.iter().all(|&d| d > 0.0 && d.is_finite()) {
                let inv = |d: f32| 1.0 / f64::from(d);
                let top = inv(taps[0]) * (1.0 - tx) + inv(taps[1]) * tx;
                let bottom = inv(taps[2]) * (1.0 - tx) + inv(taps[3]) * tx;
                (1.0 / (top * (1.0 - ty) + bottom * ty)) as f32
            } else {
                taps[(tx >= 0.5) as usize + 2 * (ty >= 0.5) as usize]
            }
        })
        .collect()
}
