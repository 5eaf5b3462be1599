//! Lattice normals and their variation `V_N` (thesis eq. 7.10-7.15).
//!
//! Normals come from the layer's `N.X, N.Y, N.Z` channels when present, otherwise they are estimated
//! from depth on the full-resolution triangulation of the lattice: each vertex averages the normals of
//! its incident triangles weighted by their area (eq. 7.10) or by the triangle's angle at the vertex
//! (eq. 7.11; steadier where the lattice triangles have very different sizes, e.g. near cube corners).
//!
//! The variation is measured per *cell* (the quadtree's unit): `∂x` is the larger of `1 − |⟨N, N'⟩|`
//! over the cell's two horizontal sides, `∂y` over its two vertical sides, `V_N = ‖(∂x, ∂y)‖`. Taking
//! both sides keeps a crease on a node's last row inside the node.

use glam::DVec3;

use super::grid::Grid;
use crate::layer::LayerImage;

crate::choice::choices! {
    /// How estimated normals weight the triangles of a vertex's one-ring.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum NormalWeighting (default Area) {
        /// By triangle area (eq. 7.10).
        Area = "area",
        /// By the triangle's angle at the vertex (eq. 7.11).
        Angle = "angle",
    }
}

/// Per-vertex unit normals of the lattice (zero where unknown).
pub fn lattice_normals(image: &LayerImage, grid: &Grid, weighting: NormalWeighting) -> Vec<DVec3> {
    match (image.channel("N.X"), image.channel("N.Y"), image.channel("N.Z")) {
        (Some(nx), Some(ny), Some(nz)) => from_channels(grid, [&nx.data, &ny.data, &nz.data]),
        _ => estimate(grid, weighting),
    }
}

fn from_channels(grid: &Grid, n: [&Vec<f32>; 3]) -> Vec<DVec3> {
    let mut out = vec![DVec3::ZERO; grid.w * grid.h];
    for y in 0..grid.h {
        for x in 0..grid.w {
            let i = grid.pixel(x, y) as usize;
            let v = DVec3::new(n[0][i] as f64, n[1][i] as f64, n[2][i] as f64);
            out[y * grid.w + x] = v.try_normalize().unwrap_or(DVec3::ZERO);
        }
    }
    out
}

/// One-ring normals on the full-resolution lattice triangulation (diagonal `(x,y)-(x+1,y+1)`).
pub fn estimate(grid: &Grid, weighting: NormalWeighting) -> Vec<DVec3> {
    let (w, h) = (grid.w, grid.h);
    let mut acc = vec![DVec3::ZERO; w * h];
    for y in 0..h.saturating_sub(1) {
        for x in 0..w.saturating_sub(1) {
            for tri in [[(x, y), (x + 1, y), (x + 1, y + 1)], [(x, y), (x + 1, y + 1), (x, y + 1)]] {
                let ok = (0..3).all(|k| grid.connected(tri[k], tri[(k + 1) % 3]));
                if !ok {
                    continue;
                }
                let p: Vec<DVec3> = tri.iter().map(|&(a, b)| grid.point(a, b)).collect();
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                for (k, &(a, b)) in tri.iter().enumerate() {
                    acc[b * w + a] += match weighting {
                        NormalWeighting::Area => n,
                        NormalWeighting::Angle => {
                            let (e1, e2) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                            n.try_normalize().unwrap_or(DVec3::ZERO) * e1.angle_between(e2)
                        }
                    };
                }
            }
        }
    }
    // Orient towards the panorama centre so that the sign is stable (the variation uses |⟨·,·⟩| anyway).
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let n = acc[i].try_normalize().unwrap_or(DVec3::ZERO);
            acc[i] = if n.dot(grid.rays.ray(x, y)) > 0.0 { -n } else { n };
        }
    }
    acc
}

/// `V_N` of every cell (`(w−1) × (h−1)`, row-major). Cells touching an unknown normal vary by 0.
pub fn cell_variation(grid: &Grid, normals: &[DVec3]) -> Vec<f64> {
    let (w, h) = (grid.w, grid.h);
    let cw = w.saturating_sub(1);
    let d = |a: DVec3, b: DVec3| {
        if a == DVec3::ZERO || b == DVec3::ZERO {
            0.0
        } else {
            (1.0 - a.dot(b).abs()).max(0.0)
        }
    };
    let mut out = vec![0.0; cw * h.saturating_sub(1)];
    for y in 0..h.saturating_sub(1) {
        for x in 0..cw {
            let n00 = normals[y * w + x];
            let n10 = normals[y * w + x + 1];
            let n01 = normals[(y + 1) * w + x];
            let n11 = normals[(y + 1) * w + x + 1];
            let dx = d(n00, n10).max(d(n01, n11));
            let dy = d(n00, n01).max(d(n10, n11));
            out[y * cw + x] = dx.hypot(dy);
        }
    }
    out
}
