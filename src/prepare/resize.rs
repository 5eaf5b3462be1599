//! Depth of another resolution onto the colour's grid, guided by the colour (a joint bilateral
//! upsampling that picks a surface rather than averaging across edges): the 4 × 4 depth samples
//! around a pixel, less those that mix two sides of an edge ([`mixes`]), are split into surfaces
//! by the build's continuity rule; the surface whose samples' colours (averaged over their
//! footprints) are nearest the pixel's own colour, and nearest in space, is the pixel's, and its
//! samples among the 2 × 2 nearest are interpolated bilinearly in inverse depth (planes stay
//! planes). Where the window is one surface this is plain bilinear.

use rayon::prelude::*;

use crate::continuity;
use crate::mapping::{AnyMapping, Mapping};

/// Colour distance (guide units, `refine::guide`) at which a sample's weight falls to `e^-1/2`.
const SIGMA_COLOUR: f32 = 0.06;

/// The sample grid of a resize: tiles (equirect: one, wrapping; cube: six faces kept apart).
struct Grid {
    dw: usize,
    tile_d: (usize, usize),
    tile_c: (usize, usize),
    wrap: bool,
}

impl Grid {
    fn new(from: &AnyMapping, to: &AnyMapping) -> Grid {
        let (dw, dh) = (from.width(), from.height());
        let (cw, ch) = (to.width(), to.height());
        let (tile_d, tile_c, wrap) = match to {
            AnyMapping::Equirect(_) => ((dw, dh), (cw, ch), true),
            AnyMapping::Cube(_) => ((dh / 2, dh / 2), (ch / 2, ch / 2), false),
        };
        Grid { dw, tile_d, tile_c, wrap }
    }

    /// Canvas coordinate `i` along an axis: its tile's origin in the source and its continuous
    /// source coordinate inside the tile.
    fn axis(&self, i: usize, horizontal: bool) -> (usize, f64) {
        let (tc, td) =
            if horizontal { (self.tile_c.0, self.tile_d.0) } else { (self.tile_c.1, self.tile_d.1) };
        let (t, l) = (i / tc, i % tc);
        (t * td, (l as f64 + 0.5) * td as f64 / tc as f64 - 0.5)
    }

    /// The source sample at integer offset `(i, j)` inside the tile at `(ox, oy)` (clamped to the
    /// tile; wrapping around the equirect's longitude).
    fn index(&self, ox: usize, oy: usize, i: i64, j: i64) -> usize {
        let (tw, th) = (self.tile_d.0 as i64, self.tile_d.1 as i64);
        let c = if self.wrap { i.rem_euclid(tw) } else { i.clamp(0, tw - 1) };
        (oy + j.clamp(0, th - 1) as usize) * self.dw + ox + c as usize
    }
}

/// `depth` (`from`'s canvas, metres) resampled onto `to`'s canvas (both of one mapping kind),
/// guided by `guide`, the colour on `to`'s canvas; mixed samples found when `find_mixes`.
pub(crate) fn resize(
    depth: &[f32],
    from: &AnyMapping,
    to: &AnyMapping,
    guide: &[[f32; 3]],
    find_mixes: bool,
) -> Vec<f32> {
    let g = Grid::new(from, to);
    let cw = to.width();
    let sample_colour = footprint_colours(&g, from, to, guide);
    let mixes = if find_mixes { mixes(&g, depth) } else { vec![false; depth.len()] };
    (0..guide.len())
        .into_par_iter()
        .map(|p| {
            let win = Window::at(&g, depth, p % cw, p / cw);
            if win.d[win.nearest].is_nan() {
                return f32::NAN;
            }
            if let Some(v) = win.one_surface() {
                return v;
            }
            let mix: [bool; 16] = std::array::from_fn(|k| mixes[win.idx[k]]);
            // Without its mixes; a window of nothing but mixes as it is.
            let pick = |mix: &[bool; 16]| {
                let surface = surfaces(&win.d, mix);
                let chosen = if surface.iter().all(|&s| s == surface[5]) && surface[5] != NONE {
                    surface[5]
                } else {
                    win.choose(&surface, guide[p], &sample_colour)
                };
                (chosen != NONE).then(|| win.depth_on(&surface, chosen))
            };
            pick(&mix).or_else(|| pick(&[false; 16])).unwrap_or(f32::NAN)
        })
        .collect()
}

/// Per source sample, whether it is a mix across an edge: between a nearer and a farther
/// neighbour along a row, column or diagonal, a jump from each, and on neither side's surface
/// continued (an area-averaged sample, which the plane test would otherwise join to both sides
/// as a slope; a slope's sample lies on its neighbours' line).
fn mixes(g: &Grid, depth: &[f32]) -> Vec<bool> {
    let (tw, th) = g.tile_d;
    let jump = 1.0 + continuity::JUMP as f32;
    // Whether the surface through `a` and then `b` continues to the sample (inverse depth is
    // linear along a plane): a slope stepping by more than a step per sample is no edge.
    let continues = |a: f32, b: f32, d: f32| {
        let (ia, ib, id) = (1.0 / a, 1.0 / b, 1.0 / d);
        (2.0 * ib - ia - id).abs() <= continuity::JUMP as f32 * id
    };
    (0..depth.len())
        .into_par_iter()
        .map(|s| {
            let d = depth[s];
            if !(d.is_finite() && d > 0.0) {
                return false;
            }
            let (x, y) = (s % g.dw, s / g.dw);
            let (ox, oy) = (x / tw * tw, y / th * th);
            let (i, j) = ((x - ox) as i64, (y - oy) as i64);
            let at = |di: i64, dj: i64| depth[g.index(ox, oy, i + di, j + dj)];
            [(1, 0), (0, 1), (1, 1), (1, -1)].iter().any(|&(di, dj)| {
                let (l1, l2, r1, r2) = (at(-di, -dj), at(-2 * di, -2 * dj), at(di, dj), at(2 * di, 2 * dj));
                let between = |far: f32, near: f32| far > jump * d && d > jump * near;
                (between(l1, r1) || between(r1, l1)) && !continues(l2, l1, d) && !continues(r2, r1, d)
            })
        })
        .collect()
}

/// The 4 × 4 source window of a target pixel, row by row; the 2 × 2 nearest are (1,1), (2,1),
/// (1,2), (2,2).
struct Window {
    /// Source sample indices.
    idx: [usize; 16],
    /// Their depths.
    d: [f32; 16],
    /// The pixel's position in the 2 × 2's cell.
    tx: f64,
    ty: f64,
    /// The nearest sample.
    nearest: usize,
}

impl Window {
    fn at(g: &Grid, depth: &[f32], x: usize, y: usize) -> Window {
        let (ox, fx) = g.axis(x, true);
        let (oy, fy) = g.axis(y, false);
        let fy = fy.clamp(0.0, (g.tile_d.1 - 1) as f64);
        let fx = if g.wrap { fx } else { fx.clamp(0.0, (g.tile_d.0 - 1) as f64) };
        let (x0, y0) = (fx.floor() as i64, fy.floor() as i64);
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let mut idx = [0usize; 16];
        let mut d = [0f32; 16];
        for (k, (i, j)) in (-1..3).flat_map(|j| (-1..3).map(move |i| (i, j))).enumerate() {
            idx[k] = g.index(ox, oy, x0 + i, y0 + j);
            d[k] = depth[idx[k]];
        }
        let nearest = 5 + (tx >= 0.5) as usize + 4 * (ty >= 0.5) as usize;
        Window { idx, d, tx, ty, nearest }
    }

    /// The 2 × 2 nearest and their bilinear weights.
    fn bilinear(&self) -> [(usize, f64); 4] {
        let (tx, ty) = (self.tx, self.ty);
        [(5, (1.0 - tx) * (1.0 - ty)), (6, tx * (1.0 - ty)), (9, (1.0 - tx) * ty), (10, tx * ty)]
    }

    /// Most windows: finite samples within one step of each other, one surface, interpolated.
    fn one_surface(&self) -> Option<f32> {
        let d = &self.d;
        let (lo, hi) = d.iter().fold((f32::INFINITY, 0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let one = lo > 0.0
            && hi.is_finite()
            && !d.iter().any(|v| v.is_nan())
            && f64::from(hi - lo) <= continuity::JUMP * f64::from(lo);
        one.then(|| {
            let inv: f64 = self.bilinear().iter().map(|&(k, wt)| wt / f64::from(d[k])).sum();
            (1.0 / inv) as f32
        })
    }

    /// The surface whose samples' colours (`sample_colour`) and positions are nearest the
    /// pixel's (colour `c0`).
    fn choose(&self, surface: &[u8; 16], c0: [f32; 3], sample_colour: &[[f32; 3]]) -> u8 {
        let (d, tx, ty) = (&self.d, self.tx, self.ty);
        let mut score = [0f32; 16];
        for k in 0..16 {
            if surface[k] == NONE {
                continue;
            }
            let (sx, sy) = ((k % 4) as f64 - 1.0 - tx, (k / 4) as f64 - 1.0 - ty);
            let c = sample_colour[self.idx[k]];
            let dc = (0..3).map(|i| (c[i] - c0[i]).powi(2)).sum::<f32>();
            score[surface[k] as usize] +=
                (-(sx * sx + sy * sy) as f32 / 2.0 - dc / (2.0 * SIGMA_COLOUR * SIGMA_COLOUR)).exp();
        }
        // A small surface between a nearer and a farther one is the mix of the two (an
        // area-averaged sample across the edge), no surface of its own.
        let between = |l: u8| {
            let of = |k: &usize| surface[*k] == l;
            let (lo, hi) =
                (0..16).filter(of).fold((f32::INFINITY, 0f32), |(lo, hi), k| (lo.min(d[k]), hi.max(d[k])));
            let others = (0..16).filter(|&k| surface[k] != l && surface[k] != NONE);
            (0..16).filter(of).count() <= 3
                && others.clone().any(|k| d[k] < lo)
                && others.into_iter().any(|k| d[k] > hi)
        };
        let best = (0..16)
            .filter(|&k| surface[k] == k as u8 && !between(k as u8))
            .max_by(|&a, &b| score[a].total_cmp(&score[b]));
        match best {
            Some(k) if score[k] > 0.0 => k as u8,
            _ => surface[self.nearest],
        }
    }

    /// The depth of surface `chosen` at the pixel: its samples among the 2 × 2 interpolated, or
    /// (none there) its nearest sample.
    fn depth_on(&self, surface: &[u8; 16], chosen: u8) -> f32 {
        let (d, tx, ty) = (&self.d, self.tx, self.ty);
        let mine: Vec<(usize, f64)> =
            self.bilinear().into_iter().filter(|&(k, _)| surface[k] == chosen).collect();
        let of_surface = if mine.is_empty() {
            let dist = |k: usize| ((k % 4) as f64 - 1.0 - tx).powi(2) + ((k / 4) as f64 - 1.0 - ty).powi(2);
            let k = (0..16).filter(|&k| surface[k] == chosen).min_by(|&a, &b| dist(a).total_cmp(&dist(b)));
            vec![(k.unwrap_or(self.nearest), 1.0)]
        } else {
            mine
        };
        if of_surface.iter().any(|&(k, _)| d[k].is_infinite()) {
            return f32::INFINITY;
        }
        let total: f64 = of_surface.iter().map(|s| s.1).sum();
        let inv: f64 = of_surface.iter().map(|&(k, wt)| wt / f64::from(d[k])).sum::<f64>();
        if total > 0.0 {
            (total / inv) as f32
        } else {
            d[of_surface[0].0]
        }
    }
}

/// No surface: an unknown sample.
const NONE: u8 = u8::MAX;

/// The 4 × 4 window's samples labelled by surface (connected by the build's continuity rule along
/// rows and columns of the window, the next sample out as the plane test's end); [`NONE`] for
/// unknown samples and `mix`es. Labels are the index of a surface's first sample.
fn surfaces(d: &[f32; 16], mix: &[bool; 16]) -> [u8; 16] {
    let mut label: [u8; 16] =
        std::array::from_fn(|k| if d[k].is_nan() || d[k] <= 0.0 || mix[k] { NONE } else { k as u8 });
    let at = |k: i32| (0..16).contains(&k).then(|| f64::from(d[k as usize]));
    // Links of the window: right and down neighbours.
    let mut links = Vec::with_capacity(24);
    for k in 0..16i32 {
        for (step, ok) in [(1, k % 4 < 3), (4, k < 12)] {
            let q = k + step;
            if !ok || label[k as usize] == NONE || label[q as usize] == NONE {
                continue;
            }
            let behind = if (step == 1 && k % 4 > 0) || (step == 4 && k >= 4) { at(k - step) } else { None };
            let beyond = if (step == 1 && q % 4 < 3) || (step == 4 && q < 12) { at(q + step) } else { None };
            let (a, b) = (f64::from(d[k as usize]), f64::from(d[q as usize]));
            if continuity::continuous(a, b, behind, beyond, continuity::JUMP, continuity::PLANAR) {
                links.push((k as usize, q as usize));
            }
        }
    }
    // Smallest label over each component (a few sweeps over 24 links settle a 4 × 4 window).
    loop {
        let mut changed = false;
        for &(a, b) in &links {
            let m = label[a].min(label[b]);
            if label[a] != m || label[b] != m {
                (label[a], label[b]) = (m, m);
                changed = true;
            }
        }
        if !changed {
            return label;
        }
    }
}

/// Each source sample's colour: the mean guide colour of the canvas pixels whose centres fall in
/// its footprint (the nearest canvas pixel where none does, when the source is the finer).
fn footprint_colours(g: &Grid, from: &AnyMapping, to: &AnyMapping, guide: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let n = from.width() * from.height();
    let cw = to.width();
    let cell = |x: usize, y: usize| -> usize {
        let (ox, fx) = g.axis(x, true);
        let (oy, fy) = g.axis(y, false);
        g.index(ox, oy, (fx + 0.5).floor() as i64, (fy + 0.5).floor() as i64)
    };
    let mut sum = vec![[0f32; 4]; n];
    for (p, c) in guide.iter().enumerate() {
        let s = &mut sum[cell(p % cw, p / cw)];
        for i in 0..3 {
            s[i] += c[i];
        }
        s[3] += 1.0;
    }
    let dw = from.width();
    sum.into_iter()
        .enumerate()
        .map(|(i, s)| {
            if s[3] > 0.0 {
                return [s[0] / s[3], s[1] / s[3], s[2] / s[3]];
            }
            // No canvas pixel in the footprint (a finer source): the canvas pixel at its centre.
            let canvas = |j: usize, td: usize, tc: usize| {
                let (t, l) = (j / td, j % td);
                t * tc + (((l as f64 + 0.5) * tc as f64 / td as f64) as usize).min(tc - 1)
            };
            guide[canvas(i / dw, g.tile_d.1, g.tile_c.1) * cw + canvas(i % dw, g.tile_d.0, g.tile_c.0)]
        })
        .collect()
}
