//! Refinement of log depth: sensor noise smoothed without rounding edges (a sigma filter whose
//! range follows the noise measured block by block), and soft edges — ramps of in-between depths
//! across an occlusion, as estimators, resizing and blur leave them — snapped onto the colour edge,
//! each in-between pixel continuing one side's surface.

use rayon::prelude::*;

use crate::mapping::{opposite, Neighbours};

/// Per-pixel colour for the snap's decisions: square root of linear RGB (near perceptual steps).
pub(crate) fn guide(rgb: &[Vec<f32>; 3]) -> Vec<[f32; 3]> {
    (0..rgb[0].len()).into_par_iter().map(|p| [0, 1, 2].map(|c| rgb[c][p].max(0.0).sqrt())).collect()
}

/// What the scan of depth edges along rows found.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct EdgeScan {
    /// Depth edges found (monotone runs over a jump, at most 64 pixels wide).
    pub edges: usize,
    /// Median share of an edge's change taken by its steepest step (1: every edge one step).
    pub sharpness: f64,
    /// Width in pixels that 80 % of the soft edges stay within (0 when none is soft).
    pub width: usize,
}

impl EdgeScan {
    /// Whether the depth's edges are spread over several pixels.
    pub fn is_soft(&self) -> bool {
        self.edges >= 8 && self.sharpness < SOFT_SHARPNESS
    }
}

/// An edge whose steepest step takes less than this share of it is soft.
const SOFT_SHARPNESS: f64 = 0.45;

/// Scan rows for depth edges: runs of same-signed steps over `jump_log` in all, at most 64 pixels
/// long, between flanks flatter than a quarter of the run's mean step (a wall turning away from the
/// ray climbs as steadily as a soft edge, but has no flat flanks).
pub(crate) fn scan_edges(log: &[f32], w: usize, jump_log: f32) -> EdgeScan {
    const FLANK: usize = 4;
    let runs: Vec<(usize, f64)> = log
        .par_chunks(w)
        .flat_map_iter(|row| {
            let step = |x: usize| row[x] - row[x - 1];
            // Mean absolute step over `FLANK` steps from `from` on (backwards when `back`); NaN
            // (unknown depth) or the row's end is no flank.
            let flank = |from: usize, back: bool| -> Option<f32> {
                let xs: Vec<usize> = if back {
                    (from.saturating_sub(FLANK).max(1)..from).collect()
                } else {
                    (from..(from + FLANK).min(row.len())).collect()
                };
                let sum: f32 = xs.iter().map(|&x| step(x).abs()).sum();
                (xs.len() == FLANK && sum.is_finite()).then(|| sum / FLANK as f32)
            };
            let mut out = Vec::new();
            let (mut start, mut len, mut total, mut widest, mut sign) =
                (0usize, 0usize, 0.0f32, 0.0f32, 0.0f32);
            let mut close = |start: usize, len: usize, total: f32, widest: f32| {
                if len == 0 || len > 64 || total.abs() <= 1.5 * jump_log {
                    return;
                }
                // An edge to the sky stays a step under any blur (infinite depth blurs to itself):
                // it tells nothing of how soft the depth is.
                if row[start - 1].max(row[start + len - 1]) >= super::complete::SKY_LOG - 1e-3 {
                    return;
                }
                let mean = total.abs() / len as f32;
                let flat = |f: Option<f32>| f.is_some_and(|f| f < 0.25 * mean);
                if flat(flank(start, true)) && flat(flank(start + len, false)) {
                    out.push((len, f64::from(widest / total.abs())));
                }
            };
            for x in 1..row.len() {
                let s = step(x);
                let small = s.is_nan() || s.abs() <= 0.003;
                if small || s.signum() != sign {
                    close(start, len, total, widest);
                    (start, len, total, widest, sign) = (x, 0, 0.0, 0.0, 0.0);
                    if small {
                        continue;
                    }
                    sign = s.signum();
                }
                len += 1;
                total += s;
                widest = widest.max(s.abs());
            }
            close(start, len, total, widest);
            out
        })
        .collect();
    if runs.is_empty() {
        return EdgeScan::default();
    }
    let mut sharp: Vec<f64> = runs.iter().map(|r| r.1).collect();
    sharp.sort_by(f64::total_cmp);
    let mut widths: Vec<usize> = runs.iter().filter(|r| r.1 < SOFT_SHARPNESS).map(|r| r.0).collect();
    widths.sort_unstable();
    let width = if widths.is_empty() { 0 } else { widths[(widths.len() * 4 / 5).min(widths.len() - 1)] };
    EdgeScan { edges: runs.len(), sharpness: sharp[sharp.len() / 2], width }
}

/// Noise of log depth (standard deviation) in blocks of `BLOCK` pixels, from the median absolute
/// second difference along rows of known pixels away from edges; `None` where a block has too few.
pub(crate) fn noise(log: &[f32], known: &[bool], w: usize, h: usize, jump_log: f32) -> (Vec<f32>, f32) {
    let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    let blocks: Vec<f32> = (0..bw * bh)
        .into_par_iter()
        .map(|b| {
            let (bx, by) = (b % bw * BLOCK, b / bw * BLOCK);
            let mut d = Vec::with_capacity(BLOCK * BLOCK);
            for y in by..(by + BLOCK).min(h) {
                for x in bx.max(1)..(bx + BLOCK).min(w - 1) {
                    let p = y * w + x;
                    if !(known[p - 1] && known[p] && known[p + 1]) {
                        continue;
                    }
                    let s = (log[p - 1] - 2.0 * log[p] + log[p + 1]).abs();
                    if s < 0.5 * jump_log {
                        d.push(s);
                    }
                }
            }
            if d.len() < 32 {
                return f32::NAN;
            }
            let mid = d.len() / 2;
            let (_, m, _) = d.select_nth_unstable_by(mid, f32::total_cmp);
            // MAD → σ of the differences, which have six times the variance of the samples.
            *m / (0.6745 * 6f32.sqrt())
        })
        .collect();
    let mut known_blocks: Vec<f32> = blocks.iter().copied().filter(|s| !s.is_nan()).collect();
    known_blocks.sort_by(f32::total_cmp);
    let median = known_blocks.get(known_blocks.len() / 2).copied().unwrap_or(0.0);
    (blocks, median)
}

/// Side of the noise blocks, pixels.
pub(crate) const BLOCK: usize = 32;

/// Edge-preserving smoothing: each pixel takes the mean of the pixels within `RADIUS` along the
/// row (then the column) whose log depth is within three of its block's noise deviations, twice.
pub(crate) fn smooth(log: &mut [f32], w: usize, h: usize, blocks: &[f32], median: f32, jump_log: f32) {
    const RADIUS: usize = 3;
    let bw = w.div_ceil(BLOCK);
    let thr: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let s = blocks[(p / w / BLOCK) * bw + (p % w) / BLOCK];
            (3.0 * if s.is_nan() { median } else { s }).min(0.5 * jump_log)
        })
        .collect();
    for _ in 0..2 {
        for vertical in [false, true] {
            let src = log.to_vec();
            log.par_iter_mut().enumerate().for_each(|(p, out)| {
                let v = src[p];
                if !v.is_finite() {
                    return;
                }
                let (x, y) = (p % w, p / w);
                let (mut sum, mut n) = (0.0f32, 0.0f32);
                for o in -(RADIUS as isize)..=RADIUS as isize {
                    let q = if vertical {
                        let yy = y as isize + o;
                        if yy < 0 || yy >= h as isize {
                            continue;
                        }
                        yy as usize * w + x
                    } else {
                        y * w + (x as isize + o).rem_euclid(w as isize) as usize
                    };
                    let u = src[q];
                    if (u - v).abs() <= thr[p] {
                        sum += u;
                        n += 1.0;
                    }
                }
                *out = sum / n;
            });
        }
    }
}

/// Snap the in-between pixels of soft edges onto the side whose colour they share. Returns the
/// pixels changed.
///
/// Along a row or column, the two sides' surfaces at `±r` are continued to the pixel
/// (`continued = side + r · side slope`), for the smallest `r` up to `max_radius` at which they
/// differ by more than a jump with sides flatter than the ramp between them: a pixel whose depth
/// lies between the two is on neither surface. It takes the continued depth of the side whose
/// colour is nearer its own (the nearer depth decides where the colours do not differ).
pub(crate) fn snap(
    nb: &Neighbours,
    log: &mut [f32],
    guide: &[[f32; 3]],
    max_radius: usize,
    jump_log: f32,
) -> usize {
    let src = log.to_vec();
    // The 1D analysis: which pixels are on a soft step, and its radius.
    let found: Vec<(usize, usize)> = (0..src.len())
        .into_par_iter()
        .filter(|&p| steepest_step(nb, &src, p) >= MIN_STEP)
        .filter_map(|p| {
            // Of the two axes, the one across the larger jump decides.
            [0, 2]
                .into_iter()
                .filter_map(|k| snap_along(nb, &src, p, k, max_radius, jump_log))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(v, _)| (p, v))
        })
        .collect();
    let mut zone = vec![false; src.len()];
    for &(p, _) in &found {
        zone[p] = true;
    }
    // Pixels on a step take the colour-weighted median of the settled depths around them (actual
    // depths of either side, so the snapped pixels join a side's surface, not a shell of their own).
    let updates: Vec<(usize, f32)> = found
        .par_iter()
        .map(|&(p, r)| (p, weighted_median(nb, &src, guide, &zone, p, r).unwrap_or(src[p])))
        .collect();
    for &(p, v) in &updates {
        log[p] = v;
    }
    updates.len()
}

/// The colour-weighted median of the log depths within `r` of `p` (sampled on a grid of about
/// 9 × 9), settled pixels (outside `zone`) weighing twenty times more.
fn weighted_median(
    nb: &Neighbours,
    log: &[f32],
    guide: &[[f32; 3]],
    zone: &[bool],
    p: usize,
    r: usize,
) -> Option<f32> {
    let (w, h) = (nb.width() as isize, nb.height() as isize);
    let (x, y) = ((p % nb.width()) as isize, (p / nb.width()) as isize);
    let (tile, wrap) = match nb.mapping() {
        crate::mapping::AnyMapping::Equirect(_) => (w.max(h), true),
        crate::mapping::AnyMapping::Cube(_) => (h / 2, false),
    };
    let (fx, fy) = (x / tile, y / tile);
    let stride = (r / 4).max(1) as isize;
    let r = r as isize;
    let sigma_s = (r as f32 / 2.0).max(1.0);
    let c0 = guide[p];
    let mut samples: Vec<(f32, f32)> = Vec::with_capacity(100);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (x + dx, y + dy);
            let inside = if wrap {
                (0..h).contains(&qy)
            } else {
                qx.div_euclid(tile) == fx
                    && qy.div_euclid(tile) == fy
                    && (0..w).contains(&qx)
                    && (0..h).contains(&qy)
            };
            if inside {
                let q = (qy * w + qx.rem_euclid(w)) as usize;
                let c = guide[q];
                let dc = (c[0] - c0[0]).powi(2) + (c[1] - c0[1]).powi(2) + (c[2] - c0[2]).powi(2);
                let ds = (dx * dx + dy * dy) as f32;
                let wgt = (-ds / (2.0 * sigma_s * sigma_s) - dc / (2.0 * 0.06 * 0.06)).exp()
                    * if zone[q] { 0.05 } else { 1.0 };
                if log[q].is_finite() && wgt > 1e-12 {
                    samples.push((log[q], wgt));
                }
            }
            dx += stride;
        }
        dy += stride;
    }
    if samples.is_empty() {
        return None;
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let half = 0.5 * samples.iter().map(|s| s.1).sum::<f32>();
    let mut acc = 0.0;
    samples
        .into_iter()
        .find(|s| {
            acc += s.1;
            acc >= half
        })
        .map(|s| s.0)
}

/// A pixel whose log depth steps less than this to every 4-neighbour is on no ramp.
const MIN_STEP: f32 = 0.002;

/// The largest log-depth step from `p` to a 4-neighbour.
fn steepest_step(nb: &Neighbours, log: &[f32], p: usize) -> f32 {
    (0..4).filter_map(|k| nb.get(p, k)).map(|q| (log[q] - log[p]).abs()).fold(0.0, f32::max)
}

/// Whether the line from `-r` to `r` (`minus`, the pixel's `l0`, `plus`) climbs from one side to
/// the other without turning back (beyond noise), and the pixel itself is on the climb: it is one
/// ramp, not a pixel on a plateau between two other surfaces.
fn monotone_ramp(log: &[f32], minus: &[usize], l0: f32, plus: &[usize], rise: f32, r: f32) -> bool {
    let line =
        minus.iter().rev().map(|&q| log[q]).chain(std::iter::once(l0)).chain(plus.iter().map(|&q| log[q]));
    let tolerance = -0.02 * rise.abs();
    let mut prev = None;
    for v in line {
        if let Some(u) = prev {
            if (v - u) * rise.signum() < tolerance {
                return false;
            }
        }
        prev = Some(v);
    }
    let centre = (log[plus[0]] - log[minus[0]]) * rise.signum();
    centre >= 0.2 * rise.abs() / r
}

/// Radii tried, smallest first.
const RADII: [usize; 9] = [2, 3, 4, 5, 6, 8, 11, 16, 24];

/// If `p` is an in-between pixel of a soft step along axis `k` (0: row, 2: column): the step's
/// window radius and its size.
fn snap_along(
    nb: &Neighbours,
    log: &[f32],
    p: usize,
    k: usize,
    max_r: usize,
    jump_log: f32,
) -> Option<(usize, f32)> {
    // The pixels 1..=max_r+1 steps away each way (fewer where the sphere has no neighbour).
    let walk = |dir: usize| -> Vec<usize> {
        let mut line = Vec::with_capacity(max_r + 1);
        let mut q = p;
        while line.len() <= max_r {
            match nb.get(q, dir) {
                Some(n) => {
                    q = n;
                    line.push(q);
                }
                None => break,
            }
        }
        line
    };
    let (minus, plus) = (walk(opposite(k)), walk(k));
    let l0 = log[p];
    for r in RADII.into_iter().take_while(|&r| r <= max_r) {
        let (Some(&m_out), Some(&p_out)) = (minus.get(r), plus.get(r)) else { break };
        let (m_r, p_r) = (minus[r - 1], plus[r - 1]);
        let (lm, lp) = (log[m_r], log[p_r]);
        let (sm, sp) = (lm - log[m_out], log[p_out] - lp);
        let rf = r as f32;
        let (em, ep) = (lm + rf * sm, lp - rf * sp);
        let e = (ep - em).abs();
        // Sides flatter than the ramp; a jump to the sky counts as four jumps at most, so ground
        // steepening towards the horizon is not taken for an edge.
        if e.is_nan() || e <= jump_log || sm.abs().max(sp.abs()) > 0.3 * e.min(4.0 * jump_log) / rf {
            continue;
        }
        let t = (l0 - em) / (ep - em);
        if !(t > 0.02 && t < 0.98 && monotone_ramp(log, &minus[..r], l0, &plus[..r], ep - em, rf)) {
            return None;
        }
        return Some((r + 1, e));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of `pattern(x)` log depth, 16 of them, 256 wide.
    fn rows(pattern: impl Fn(usize) -> f32) -> Vec<f32> {
        (0..256 * 16).map(|p| pattern(p % 256)).collect()
    }

    /// A step is an edge, sharp; the same step blurred is soft; a steady climb (a wall turning
    /// away from the ray) is no edge at all.
    #[test]
    fn edges_are_told_from_walls() {
        let jump = 1.08f32.ln();
        let step = |x: usize| if (x / 32) % 2 == 0 { 0.5 } else { 1.2 };
        let sharp = scan_edges(&rows(step), 256, jump);
        assert!(sharp.edges >= 8 && !sharp.is_soft() && sharp.sharpness > 0.99, "{sharp:?}");
        let blurred = |x: usize| {
            let t = (((x % 64) as f32 - 32.0).abs() - 16.0) / 3.0;
            0.5 + 0.7 / (1.0 + (-t).exp())
        };
        let soft = scan_edges(&rows(blurred), 256, jump);
        assert!(soft.is_soft() && soft.width >= 8, "{soft:?}");
        let wall = scan_edges(&rows(|x| 0.01 * x as f32), 256, jump);
        assert_eq!(wall.edges, 0, "{wall:?}");
    }
}
