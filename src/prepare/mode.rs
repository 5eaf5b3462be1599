//! Soft depth steps settled by a weighted mode filter (Min, Lu and Do 2012; `--refine mode`): a
//! pixel inside a step of its disc takes the most weighted depth of the disc, the weights favouring
//! near pixels of like colour whose depth is settled, so it goes to one side's depth instead of an
//! in-between one. Measured in docs/build.md ("Weighted mode filter").

use rayon::prelude::*;

use super::complete::SKY_LOG;
use crate::mapping::{MappingKind, Neighbours};

/// Disc radius, pixels.
pub(super) const RADIUS: isize = 6;
/// Histogram bin, log depth.
const BIN: f32 = 0.02;
/// Colour likeness scale (square root of linear RGB, 3 × 3 mean).
const COLOUR_SIGMA: f32 = 0.06;
/// Log-depth step per pixel past which a depth counts as a ramp's, not a side's.
const SETTLED_STEP: f32 = 0.01;
/// A pixel whose slope in disparity over ±1 px is within this share of its slope over
/// ±`SLOPE_SPAN` px along both axes runs on as a plane (grazing ground): settled however steep.
const SLOPE_MATCH: f32 = 0.1;
const SLOPE_SPAN: isize = 5;
/// A disc whose disparity along the steeper axis fits a line within this share of its span
/// (rms) is a plane: nothing to settle.
const PLANE_FIT: f32 = 0.05;
/// Metres: a choice between sides that moves nothing by a pixel for an eye this far out is not made.
const EYE: f32 = 0.5;

/// The canvas as a grid: equirect wraps its columns and repeats its pole rows; a cube's face
/// keeps its own pixels.
#[derive(Clone, Copy)]
pub(super) struct Grid {
    pub(super) w: usize,
    pub(super) h: usize,
    /// Face size of a cube canvas; 0 for equirect.
    pub(super) face: usize,
}

impl Grid {
    pub(super) fn new(nb: &Neighbours) -> Grid {
        let (w, h) = (nb.width(), nb.height());
        let face = if nb.mapping().kind() == MappingKind::Cube3x2 { w / 3 } else { 0 };
        Grid { w, h, face }
    }

    /// One pixel's angle, radians.
    pub(super) fn pixel_angle(&self) -> f32 {
        if self.face == 0 {
            std::f32::consts::TAU / self.w as f32
        } else {
            std::f32::consts::FRAC_PI_2 / self.face as f32
        }
    }

    /// Whether every offset of up to `r` pixels from `(x, y)` stays on an equirect canvas without
    /// wrapping or clamping, so plain index offsets reach the pixels [`Grid::at`] does.
    pub(super) fn inside(&self, x: usize, y: usize, r: usize) -> bool {
        self.face == 0
            && (r..self.w.saturating_sub(r)).contains(&x)
            && (r..self.h.saturating_sub(r)).contains(&y)
    }

    pub(super) fn at(&self, x: usize, y: usize, dx: isize, dy: isize) -> Option<usize> {
        let (xx, yy) = (x as isize + dx, y as isize + dy);
        if self.face == 0 {
            let yy = yy.clamp(0, self.h as isize - 1) as usize;
            let w = self.w as isize;
            // Offsets are a few pixels: one wrap, without a division, where the canvas is wider.
            let xx = match xx {
                _ if (0..w).contains(&xx) => xx,
                _ if (-w..0).contains(&xx) => xx + w,
                _ if (w..2 * w).contains(&xx) => xx - w,
                _ => xx.rem_euclid(w),
            };
            return Some(yy * self.w + xx as usize);
        }
        let f = self.face as isize;
        let (fx, fy) = (x as isize / f * f, y as isize / f * f);
        ((fx..fx + f).contains(&xx) && (fy..fy + f).contains(&yy)).then(|| yy as usize * self.w + xx as usize)
    }
}

/// The colour guide averaged over each pixel's 3 × 3 neighbourhood.
pub(super) fn colour_mean(g: &Grid, guide: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let w = g.w;
    (0..g.w * g.h)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let (mut sum, mut n) = ([0f32; 3], 0f32);
            if g.inside(x, y, 1) {
                // Inside the canvas: the same nine pixels in the same order, by plain offsets.
                for q in [p - w - 1, p - w, p - w + 1, p - 1, p, p + 1, p + w - 1, p + w, p + w + 1] {
                    (0..3).for_each(|c| sum[c] += guide[q][c]);
                    n += 1.0;
                }
                return sum.map(|s| s / n);
            }
            for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                if let Some(q) = g.at(x, y, dx, dy) {
                    (0..3).for_each(|c| sum[c] += guide[q][c]);
                    n += 1.0;
                }
            }
            sum.map(|s| s / n)
        })
        .collect()
}

/// Squared distance between two guide colours.
pub(super) fn colour_distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum()
}

/// Disparity of a log depth, 0 for the sky.
pub(super) fn inverse(l: f32) -> f32 {
    if l >= SKY_LOG - 1e-3 {
        0.0
    } else {
        (-l).exp()
    }
}

/// Settle the soft steps of `log` (log depth, the sky at [`SKY_LOG`]); `colour` is the colour
/// guide's (square root of linear RGB) 3 × 3 mean, [`colour_mean`]. Returns how many pixels moved.
pub(crate) fn mode_filter(nb: &Neighbours, log: &mut [f32], colour: &[[f32; 3]]) -> usize {
    let g = Grid::new(nb);
    let (w, h) = (g.w, g.h);
    let pixel_angle = g.pixel_angle();
    let src: Vec<f32> = log.iter().map(|&l| l.min(SKY_LOG)).collect();
    let inv: Vec<f32> = src.par_iter().map(|&l| inverse(l)).collect();
    let settled: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let step = |dx, dy| match (g.at(x, y, dx, dy), g.at(x, y, -dx, -dy)) {
                (Some(a), Some(b)) => (src[a] - src[b]).abs() / 2.0,
                _ => 0.0,
            };
            let slope = |dx: isize, dy: isize, k: isize| match (
                g.at(x, y, k * dx, k * dy),
                g.at(x, y, -k * dx, -k * dy),
            ) {
                (Some(a), Some(b)) => Some((inv[a] - inv[b]) / (2 * k) as f32),
                _ => None,
            };
            let runs_on = |dx, dy| match (slope(dx, dy, 1), slope(dx, dy, SLOPE_SPAN)) {
                (Some(s1), Some(sk)) => (s1 - sk).abs() <= SLOPE_MATCH * sk.abs() + 1e-9,
                _ => false,
            };
            if src[p] < SKY_LOG - 1e-3 && runs_on(1, 0) && runs_on(0, 1) {
                return 1.0;
            }
            let s = step(1, 0).max(step(0, 1)) / SETTLED_STEP;
            (-s * s).exp()
        })
        .collect();
    let disc: Vec<(isize, isize, f32)> = (-RADIUS..=RADIUS)
        .flat_map(|dy| (-RADIUS..=RADIUS).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| dx * dx + dy * dy <= RADIUS * RADIUS)
        .map(|(dx, dy)| {
            let sigma = (RADIUS as f32 / 2.0).max(1.0);
            (dx, dy, (-((dx * dx + dy * dy) as f32) / (2.0 * sigma * sigma)).exp())
        })
        .collect();
    let low = src.par_iter().copied().reduce(|| f32::INFINITY, f32::min);
    // The range of the square around each pixel bounds its disc's: where the square's fails the
    // test below, the disc's does too, and the disc is not scanned.
    let (square_lo, square_hi) = square_range(&g, &src);
    let (jump, tol) = (1.1f32.ln(), 1.03f32.ln());
    let out: Vec<Option<f32>> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut hist: Vec<f32> = Vec::new();
            // Each disc pixel's (pixel, offset, bin, weight), once per candidate pixel: the
            // histogram and the side both read them.
            let mut cells: Vec<(usize, isize, isize, usize, f32)> = Vec::with_capacity(disc.len());
            let (g, src, inv, settled, disc) = (&g, &src, &inv, &settled, &disc);
            let (square_lo, square_hi) = (&square_lo, &square_hi);
            (0..w).map(move |x| {
                let p = y * w + x;
                let l = src[p];
                let (lo, hi) = (square_lo[p], square_hi[p]);
                if !(hi - lo > jump && l - lo > tol && hi - l > tol) {
                    return None;
                }
                let (mut lo, mut hi) = (l, l);
                for &(dx, dy, _) in disc {
                    if let Some(q) = g.at(x, y, dx, dy) {
                        lo = lo.min(src[q]);
                        hi = hi.max(src[q]);
                    }
                }
                if !(hi - lo > jump && l - lo > tol && hi - l > tol) {
                    return None;
                }
                if ((-lo).exp() - inverse(hi)) * EYE <= pixel_angle {
                    return None;
                }
                if is_plane(g, inv, x, y) {
                    return None;
                }
                let bin = |v: f32| ((v - low) / BIN) as usize + 1;
                let (b0, b1) = (bin(lo), bin(hi));
                hist.clear();
                hist.resize(b1 - b0 + 3, 0.0);
                let c0 = colour[p];
                let weight = |q: usize, ws: f32| {
                    let c = colour[q];
                    let d2: f32 = (0..3).map(|k| (c[k] - c0[k]).powi(2)).sum();
                    ws * (-d2 / (2.0 * COLOUR_SIGMA * COLOUR_SIGMA)).exp() * settled[q]
                };
                cells.clear();
                for &(dx, dy, ws) in disc {
                    if let Some(q) = g.at(x, y, dx, dy) {
                        let (b, wq) = (bin(src[q]) - b0 + 1, weight(q, ws));
                        hist[b] += wq;
                        cells.push((q, dx, dy, b, wq));
                    }
                }
                // Smoothed by one bin; the first (nearest) of equal maxima.
                let mut mode = 0;
                let mut best = f32::NEG_INFINITY;
                for i in 1..hist.len() - 1 {
                    let v = hist[i - 1] + hist[i] + hist[i + 1];
                    if v > best {
                        (best, mode) = (v, i);
                    }
                }
                let mut side = Side::new();
                for &(q, dx, dy, b, wq) in &cells {
                    if b.abs_diff(mode) <= 1 {
                        side.add(dx, dy, f64::from(wq), src[q], inv[q]);
                    }
                }
                side.at_centre()
            })
        })
        .collect();
    let mut moved = 0;
    for (l, o) in log.iter_mut().zip(out) {
        if let Some(v) = o {
            if v.to_bits() != l.to_bits() {
                *l = v;
                moved += 1;
            }
        }
    }
    moved
}

/// Per pixel, the least and greatest of `src` over the square of radius [`RADIUS`] around it as
/// [`Grid::at`] reaches it (a row pass, then a column pass over the rows' results).
pub(super) fn square_range(g: &Grid, src: &[f32]) -> (Vec<f32>, Vec<f32>) {
    if g.face == 0 {
        return square_range_equirect(g, src);
    }
    let pass = |v: &[f32], lo: &[f32], along_x: bool| -> (Vec<f32>, Vec<f32>) {
        (0..g.w * g.h)
            .into_par_iter()
            .map(|p| {
                let (x, y) = (p % g.w, p / g.w);
                let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
                for o in -RADIUS..=RADIUS {
                    let (dx, dy) = if along_x { (o, 0) } else { (0, o) };
                    if let Some(q) = g.at(x, y, dx, dy) {
                        a = a.min(lo[q]);
                        b = b.max(v[q]);
                    }
                }
                (a, b)
            })
            .unzip()
    };
    let (row_lo, row_hi) = pass(src, src, true);
    pass(&row_hi, &row_lo, false)
}

/// [`square_range`] on an equirect canvas a row at a time, as [`Grid::at`] reaches the square
/// (columns wrap, rows clamp at the poles): the least and greatest over shifted rows, which
/// the compiler vectorises (min and max do not depend on the order).
fn square_range_equirect(g: &Grid, src: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let (w, h, r) = (g.w, g.h, RADIUS as usize);
    let (mut row_lo, mut row_hi) = (vec![0f32; w * h], vec![0f32; w * h]);
    row_lo.par_chunks_mut(w).zip(row_hi.par_chunks_mut(w)).zip(src.par_chunks(w)).for_each(
        |((lo, hi), row)| {
            // The row with its wrapped columns either side: `ext[x + o]` is column x + o - r.
            let ext: Vec<f32> = (0..w + 2 * r).map(|i| row[(i + w * (r / w + 1) - r) % w]).collect();
            lo.copy_from_slice(&ext[..w]);
            hi.copy_from_slice(&ext[..w]);
            for o in 1..=2 * r {
                for ((l, h), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(&ext[o..o + w]) {
                    *l = l.min(v);
                    *h = h.max(v);
                }
            }
        },
    );
    let (mut lo, mut hi) = (vec![0f32; w * h], vec![0f32; w * h]);
    lo.par_chunks_mut(w).zip(hi.par_chunks_mut(w)).enumerate().for_each(|(y, (lo, hi))| {
        let start = |o: isize| (y as isize + o).clamp(0, h as isize - 1) as usize * w;
        let r = r as isize;
        lo.copy_from_slice(&row_lo[start(-r)..start(-r) + w]);
        hi.copy_from_slice(&row_hi[start(-r)..start(-r) + w]);
        for o in 1 - r..=r {
            let s = start(o);
            for ((l, h), (&a, &b)) in
                lo.iter_mut().zip(hi.iter_mut()).zip(row_lo[s..s + w].iter().zip(&row_hi[s..s + w]))
            {
                *l = l.min(a);
                *h = h.max(b);
            }
        }
    });
    (lo, hi)
}

/// The side a pixel goes to: the disc's pixels in the mode's bins, weighted. The pixel takes that
/// side's surface continued to it (a weighted plane in disparity, `inv = a + b·dx + c·dy`, at the
/// centre) rather than the side's mean, which would leave a flat ring on a sloped surface and a
/// crease (a fold between segments) where the ring meets the rest of the side.
struct Side {
    /// Weighted sums of 1, dx, dy, dx², dx·dy, dy², inv, dx·inv, dy·inv.
    s: [f64; 9],
    log_sum: f64,
    lo: f32,
    hi: f32,
    sky: bool,
}

impl Side {
    fn new() -> Side {
        Side { s: [0.0; 9], log_sum: 0.0, lo: f32::INFINITY, hi: f32::NEG_INFINITY, sky: false }
    }

    fn add(&mut self, dx: isize, dy: isize, w: f64, log: f32, inv: f32) {
        let (x, y, v) = (dx as f64, dy as f64, f64::from(inv));
        for (acc, t) in self.s.iter_mut().zip([1.0, x, y, x * x, x * y, y * y, v, x * v, y * v]) {
            *acc += w * t;
        }
        self.log_sum += w * f64::from(log);
        (self.lo, self.hi) = (self.lo.min(log), self.hi.max(log));
        self.sky |= inv == 0.0;
    }

    /// Log depth of the side at the centre: the plane's where it is well posed and lands within a
    /// bin of the side's depths, else the side's weighted mean log depth.
    fn at_centre(&self) -> Option<f32> {
        let [n, sx, sy, sxx, sxy, syy, sv, sxv, syv] = self.s;
        if n <= 0.0 {
            return None;
        }
        let mean = (self.log_sum / n) as f32;
        if self.sky {
            return Some(mean);
        }
        // Centred normal equations: the slopes from the 2 × 2 covariance, then the intercept.
        let (mx, my, mv) = (sx / n, sy / n, sv / n);
        let (cxx, cxy, cyy) = (sxx / n - mx * mx, sxy / n - mx * my, syy / n - my * my);
        let (cxv, cyv) = (sxv / n - mx * mv, syv / n - my * mv);
        let det = cxx * cyy - cxy * cxy;
        // Samples along a line or a point: no plane, the mean.
        if !(det > 1e-3 * (cxx + cyy).powi(2) && det > 0.25) {
            return Some(mean);
        }
        let b = (cxv * cyy - cyv * cxy) / det;
        let c = (cyv * cxx - cxv * cxy) / det;
        let a = mv - b * mx - c * my;
        let l = -(a as f32).ln();
        (a > 0.0 && (self.lo - BIN..=self.hi + BIN).contains(&l)).then_some(l).or(Some(mean))
    }
}

/// Disparity along the steeper axis at `(x, y)` over the disc's diameter fits a line (a plane
/// seen along it), within [`PLANE_FIT`] of its span.
fn is_plane(g: &Grid, inv: &[f32], x: usize, y: usize) -> bool {
    let diff = |dx, dy| match (g.at(x, y, dx, dy), g.at(x, y, -dx, -dy)) {
        (Some(a), Some(b)) => (inv[a] - inv[b]).abs(),
        _ => 0.0,
    };
    let (dx, dy) = if diff(1, 0) >= diff(0, 1) { (1, 0) } else { (0, 1) };
    let mut prof = [0f32; (2 * RADIUS + 1) as usize];
    for (i, o) in (-RADIUS..=RADIUS).enumerate() {
        match g.at(x, y, o * dx, o * dy) {
            Some(q) => prof[i] = inv[q],
            None => return false,
        }
    }
    let n = prof.len() as f32;
    let mean = prof.iter().sum::<f32>() / n;
    let tt: f32 = (-RADIUS..=RADIUS).map(|t| (t * t) as f32).sum();
    let slope = (-RADIUS..=RADIUS).zip(&prof).map(|(t, v)| t as f32 * v).sum::<f32>() / tt;
    let rss: f32 = (-RADIUS..=RADIUS).zip(&prof).map(|(t, v)| (v - mean - slope * t as f32).powi(2)).sum();
    let (lo, hi) = prof.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    (rss / n).sqrt() < PLANE_FIT * (hi - lo).max(1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separable square range equals the square's taken pixel by pixel through [`Grid::at`],
    /// on an equirect canvas (wrapping, narrower than the square on the smallest) and on a cube's
    /// faces, so the pre-check skips no pixel the disc's test would take.
    #[test]
    fn square_range_is_the_squares_range() {
        for g in
            [Grid { w: 8, h: 4, face: 0 }, Grid { w: 40, h: 20, face: 0 }, Grid { w: 48, h: 32, face: 16 }]
        {
            let src: Vec<f32> = (0..g.w * g.h).map(|p| ((p * 7919 + 13) % 101) as f32 / 17.0).collect();
            let (lo, hi) = square_range(&g, &src);
            for p in 0..g.w * g.h {
                let (x, y) = (p % g.w, p / g.w);
                let values = (-RADIUS..=RADIUS)
                    .flat_map(|dy| (-RADIUS..=RADIUS).map(move |dx| (dx, dy)))
                    .filter_map(|(dx, dy)| g.at(x, y, dx, dy))
                    .map(|q| src[q]);
                let (a, b) =
                    values.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
                assert_eq!((lo[p], hi[p]), (a, b), "pixel {p} of {}x{} (face {})", g.w, g.h, g.face);
            }
        }
    }

    /// The 3 × 3 mean's plain offsets inside the canvas give the bits of the mean taken through
    /// [`Grid::at`] in the same order, at the poles, the seam and a cube's face edges too.
    #[test]
    fn colour_mean_is_the_nine_pixels_mean() {
        for g in
            [Grid { w: 2, h: 1, face: 0 }, Grid { w: 40, h: 20, face: 0 }, Grid { w: 48, h: 32, face: 16 }]
        {
            let guide: Vec<[f32; 3]> = (0..g.w * g.h)
                .map(|p| [((p * 7919 + 13) % 101) as f32 / 17.0, (p % 7) as f32 * 0.1, 1.0 / (1 + p) as f32])
                .collect();
            for (p, got) in colour_mean(&g, &guide).into_iter().enumerate() {
                let (x, y) = (p % g.w, p / g.w);
                let (mut sum, mut n) = ([0f32; 3], 0f32);
                for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                    if let Some(q) = g.at(x, y, dx, dy) {
                        (0..3).for_each(|c| sum[c] += guide[q][c]);
                        n += 1.0;
                    }
                }
                let want = sum.map(|s| s / n);
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "pixel {p} of {}x{}", g.w, g.h);
            }
        }
    }
}
