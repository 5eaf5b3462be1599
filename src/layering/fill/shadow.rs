//! An occluder's shadow on the surface behind it (spec §7.2 step 7). The fill corrects its copied
//! texture's lighting from the visible ring around the hole, but the core of an occluder's shadow
//! lies behind the occluder: only its penumbra shows at the border. Lit from near the camera (a
//! lamp above it, a flash, the sun behind it), the shadow is the occluders' own silhouette moved
//! a little and blurred, so that shape is fitted to the ring's shading and continued into the
//! hole; a ring it does not explain keeps the plain interpolation.

use glam::Vec3;
use rayon::prelude::*;

use super::FillContext;

/// Widest a hole may be for its local frame (cosine from its centre).
const MIN_COS: f32 = 0.5;
/// Most cells a side of the local grid.
const GRID_MAX: f32 = 256.0;
/// Blur radii tried, as shares of the hole's radius (at least half a cell: under about 0.6 cells
/// the silhouette stays sharp).
const SIGMAS: [f32; 5] = [0.03, 0.07, 0.15, 0.3, 0.5];
/// Shifts tried: up to this share of the hole's radius each way.
const SHIFT: f32 = 0.6;
/// Share of what the plane of light leaves of the ring's shading that the shadow must explain.
const EXPLAINED: f32 = 0.6;
/// The ring's shading must vary at least this much after the plane (standard deviation of the
/// log ratio): a fainter pattern is as likely a copy out of phase as a penumbra.
const MIN_SPREAD: f32 = 0.1;
/// Ring pixels the shadow must reach (coverage over a quarter) for its darkness to be measured;
/// a quarter of them at least must be out of it (coverage under 0.05).
const MIN_SHADOWED: usize = 8;
/// Fewest ring samples a fit takes.
const MIN_SAMPLES: usize = 32;
/// Most ring samples a fit reads.
pub(super) const MAX_SAMPLES: usize = 512;

/// A gnomonic grid about a hole's centre direction: cell `(i, j)`'s centre is the direction of
/// `c + (u0 + i·h)·e1 + (v0 + j·h)·e2`.
struct Frame {
    c: Vec3,
    e1: Vec3,
    e2: Vec3,
    u0: f32,
    v0: f32,
    h: f32,
    w: usize,
    ht: usize,
}

impl Frame {
    /// Continuous cell coordinates of direction `d` (integers at cell centres).
    fn coords(&self, d: Vec3) -> Option<(f32, f32)> {
        let z = d.dot(self.c);
        (z >= MIN_COS)
            .then(|| ((d.dot(self.e1) / z - self.u0) / self.h, (d.dot(self.e2) / z - self.v0) / self.h))
    }

    fn dir(&self, i: usize, j: usize) -> Vec3 {
        (self.c + self.e1 * (self.u0 + i as f32 * self.h) + self.e2 * (self.v0 + j as f32 * self.h))
            .normalize()
    }

    /// Bilinear value of `grid` at `(x, y)`; 0 outside.
    fn sample(&self, grid: &[f32], x: f32, y: f32) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f32, j: f32| {
            if i < 0.0 || j < 0.0 || i >= self.w as f32 || j >= self.ht as f32 {
                0.0
            } else {
                grid[j as usize * self.w + i as usize]
            }
        };
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
        let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// A fitted shadow: `ln(1 − k·S)` per cell, `S` the occluders' silhouette blurred and shifted.
pub(super) struct Shadow {
    frame: Frame,
    log: Vec<f32>,
    /// The brightest shading seen around the hole (log ratio): what the shadow leaves in the
    /// hole never exceeds it (a fit that is wrong must not brighten the fill past its ring).
    brightest: f32,
}

impl Shadow {
    /// Log of the light left at direction `d` (0 off the grid).
    fn log_at(&self, d: Vec3) -> f32 {
        self.frame.coords(d).map_or(0.0, |(x, y)| self.frame.sample(&self.log, x, y))
    }

    /// Log ratio of the light at pixel `p` to that at `source`, the pixel it copies.
    pub(super) fn transfer(&self, tx: &FillContext, p: usize, source: usize) -> f32 {
        self.log_at(tx.dirs.at(p)) - self.log_at(tx.dirs.at(source))
    }

    /// The shading `g` (log ratio, interpolated from the ring less the shadow) of filled pixel `p`
    /// copied from `source`, with the shadow put back.
    pub(super) fn relight(&self, tx: &FillContext, g: Vec3, p: usize, source: usize) -> Vec3 {
        (g + Vec3::splat(self.transfer(tx, p, source))).min(Vec3::splat(self.brightest))
    }
}

/// Gaussian blur of a `w × ht` grid (zero outside), approximated by three box blurs each way
/// (running sums: the cost does not grow with `sigma`). The boxes' odd widths are picked so that
/// their variances add up to `sigma²` (Kovesi, "Fast almost-Gaussian filtering", 2010).
fn blur(grid: &[f32], w: usize, ht: usize, sigma: f32) -> Vec<f32> {
    let var = sigma * sigma;
    // A box of odd width d has variance (d² − 1)/12: `m` boxes of width `lo`, the rest `lo + 2`.
    let ideal = (4.0 * var + 1.0).sqrt();
    let f = ideal.floor() as usize;
    let lo = if f % 2 == 0 { f.saturating_sub(1) } else { f }.max(1);
    let l = lo as f32;
    let m = ((12.0 * var - 3.0 * l * l - 12.0 * l - 9.0) / (-4.0 * l - 4.0)).round().clamp(0.0, 3.0) as usize;
    let box_pass = |src: &[f32],
                    out: &mut [f32],
                    r: usize,
                    len: usize,
                    lines: usize,
                    at: &dyn Fn(usize, usize) -> usize| {
        let norm = 1.0 / (2 * r + 1) as f32;
        for line in 0..lines {
            let mut sum: f32 = (0..=r.min(len - 1)).map(|i| src[at(line, i)]).sum();
            for i in 0..len {
                out[at(line, i)] = sum * norm;
                if i + r + 1 < len {
                    sum += src[at(line, i + r + 1)];
                }
                if i >= r {
                    sum -= src[at(line, i - r)];
                }
            }
        }
    };
    let (mut a, mut b) = (grid.to_vec(), vec![0.0; grid.len()]);
    for pass in 0..3 {
        let r = if pass < m { lo / 2 } else { lo / 2 + 1 };
        if r == 0 {
            continue;
        }
        box_pass(&a, &mut b, r, w, ht, &|line, i| line * w + i);
        box_pass(&b, &mut a, r, ht, w, &|line, i| i * w + line);
    }
    a
}

/// Darkenings tried (share of the light blocked).
const KS: [f32; 8] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.75];
/// Those of [`KS`] the coarse search of shifts tries.
const COARSE_KS: [usize; 3] = [1, 4, 7];
/// All of [`KS`], by index.
const ALL_KS: [usize; KS.len()] = [0, 1, 2, 3, 4, 5, 6, 7];

/// One ring sample in cells: where it is, where its copy comes from, its shading (log ratio).
#[derive(Clone, Copy)]
struct Sample {
    at: (f32, f32),
    source: (f32, f32),
    y: f32,
}

/// The ring's own smooth light: least squares of a plane `a + b·x + c·y` over the samples'
/// positions, taken about their mean (far from the grid's origin the normal equations lose
/// their precision in f32).
struct LightPlane {
    mean: (f32, f32),
    /// Inverse of the centred positions' Gram matrix.
    inverse: [[f32; 3]; 3],
}

impl LightPlane {
    /// `None` when the samples lie (nearly) on a line: no plane is fitted to them.
    fn new(samples: &[Sample]) -> Option<LightPlane> {
        let n = samples.len() as f64;
        let mean = samples.iter().fold((0.0, 0.0), |m, s| (m.0 + s.at.0 as f64 / n, m.1 + s.at.1 as f64 / n));
        let mut g = [[0.0f64; 3]; 3];
        for s in samples {
            let x = [1.0, s.at.0 as f64 - mean.0, s.at.1 as f64 - mean.1];
            for i in 0..3 {
                for j in 0..3 {
                    g[i][j] += x[i] * x[j];
                }
            }
        }
        let m = glam::DMat3::from_cols_array_2d(&g);
        let det = m.determinant();
        (det > 1e-6 * g[0][0] * g[1][1] * g[2][2]).then(|| {
            let inv = m.inverse().to_cols_array_2d().map(|row| row.map(|v| v as f32));
            LightPlane { mean: (mean.0 as f32, mean.1 as f32), inverse: inv }
        })
    }

    /// Residual sum of squares of `e` (one value per sample) after the plane.
    fn residual(&self, samples: &[Sample], e: impl Iterator<Item = f32>) -> f32 {
        let (mut sq, mut xe) = (0.0, [0.0f32; 3]);
        for (s, e) in samples.iter().zip(e) {
            sq += e * e;
            xe[0] += e;
            xe[1] += e * (s.at.0 - self.mean.0);
            xe[2] += e * (s.at.1 - self.mean.1);
        }
        let mut fitted = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                fitted += xe[i] * self.inverse[i][j] * xe[j];
            }
        }
        let r = (sq - fitted).max(0.0);
        // A residual that is not a number must never read as a perfect fit.
        if r.is_finite() {
            r
        } else {
            f32::INFINITY
        }
    }
}

/// How well a shadow (blurred silhouette `b` moved by `shift`) explains the samples' shading
/// beside a smooth plane: the residual sum of squares, and the darkening, for the best `k`.
fn score(
    frame: &Frame,
    b: &[f32],
    samples: &[Sample],
    shift: (f32, f32),
    plane: &LightPlane,
    logs: &LogTable,
    ks: &[usize],
) -> Option<(f32, f32)> {
    let cover: Vec<(f32, f32)> = samples
        .iter()
        .map(|s| {
            let at = |p: (f32, f32)| frame.sample(b, p.0 - shift.0, p.1 - shift.1);
            (at(s.at), at(s.source))
        })
        .collect();
    // The shadow's edge must be in sight: some of the ring in it, and much of the ring out of it
    // (a shadow over the whole ring is a change of light the plane takes as well).
    let shadowed = cover.iter().filter(|c| c.0 > 0.25).count();
    let lit = cover.iter().filter(|c| c.0 < 0.05).count();
    if shadowed < MIN_SHADOWED || lit * 4 < samples.len() {
        return None;
    }
    ks.iter()
        .map(|&ki| {
            let e = samples.iter().zip(&cover).map(|(s, c)| s.y - (logs.at(ki, c.0) - logs.at(ki, c.1)));
            (plane.residual(samples, e), KS[ki])
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// `ln(1 − k·c)` for each of [`KS`] over `c` in [0, 1], tabulated (the fit evaluates it for
/// every sample, shift and `k`).
struct LogTable(Vec<[f32; LOG_STEPS + 1]>);

const LOG_STEPS: usize = 256;

impl LogTable {
    fn new() -> LogTable {
        LogTable(
            KS.iter()
                .map(|k| std::array::from_fn(|i| (1.0 - k * i as f32 / LOG_STEPS as f32).ln()))
                .collect(),
        )
    }

    #[inline]
    fn at(&self, ki: usize, c: f32) -> f32 {
        let x = c.clamp(0.0, 1.0) * LOG_STEPS as f32;
        let i = (x as usize).min(LOG_STEPS - 1);
        let t = &self.0[ki];
        t[i] + (t[i + 1] - t[i]) * (x - i as f32)
    }
}

/// A shadow's fit for one blur: the residual, the darkening and the shift (cells).
#[derive(Clone, Copy)]
struct Candidate {
    sse: f32,
    k: f32,
    shift: (f32, f32),
}

/// The shadow of the occluders (pixels of layers nearer than `k`) over one part of layer `k`'s
/// fill (`hole`, canvas pixels), fitted to `samples`: visible pixels of the surface around it,
/// the pixel each copies from and their shading (log ratio of the luma to the copy's). `None`
/// unless a shadow explains the ring's shading clearly. `alpha`: a pixel's mean angle.
pub(super) fn fit(
    tx: &FillContext,
    k: u32,
    hole: &[usize],
    samples: &[(usize, usize, f32)],
    alpha: f32,
) -> Option<Shadow> {
    if samples.len() < MIN_SAMPLES || hole.is_empty() {
        return None;
    }
    let radius = alpha * (hole.len() as f32 / std::f32::consts::PI).sqrt();
    let frame = frame_about(tx, hole, samples, radius, alpha)?;
    // A source off the frame (a copy from far away) is taken as unshadowed.
    let far = (f32::MAX, f32::MAX);
    let samples: Vec<Sample> = samples
        .iter()
        .filter_map(|&(p, q, y)| {
            let at = frame.coords(tx.dirs.at(p))?;
            Some(Sample { at, source: frame.coords(tx.dirs.at(q)).unwrap_or(far), y })
        })
        .collect();
    let plane = LightPlane::new(&samples)?;
    // What a smooth plane of light leaves unexplained: the shadow must explain most of it.
    let total = plane.residual(&samples, samples.iter().map(|s| s.y));
    if !(total >= samples.len() as f32 * MIN_SPREAD * MIN_SPREAD && total.is_finite()) {
        return None;
    }
    let mask = silhouette(tx, k, &frame);
    let (best, b) = search(&frame, &mask, &samples, &plane, radius / frame.h)?;
    if best.sse > (1.0 - EXPLAINED) * total {
        return None;
    }
    let (w, ht) = (frame.w, frame.ht);
    let mut log = vec![0.0f32; w * ht];
    for j in 0..ht {
        for i in 0..w {
            log[j * w + i] =
                (1.0 - best.k * frame.sample(&b, i as f32 - best.shift.0, j as f32 - best.shift.1)).ln();
        }
    }
    let brightest = samples.iter().map(|s| s.y).fold(f32::MIN, f32::max);
    Some(Shadow { frame, log, brightest })
}

/// A grid about the hole's centre direction holding the hole, the samples and room to shift
/// and blur the silhouette: a pixel's mean angle a cell, or coarser to keep [`GRID_MAX`] cells
/// a side. `None` when the hole or a sample lies more than 60° from the centre.
fn frame_about(
    tx: &FillContext,
    hole: &[usize],
    samples: &[(usize, usize, f32)],
    radius: f32,
    alpha: f32,
) -> Option<Frame> {
    let c = hole.iter().map(|&p| tx.dirs.at(p)).sum::<Vec3>().normalize_or_zero();
    let (e1, e2) = c.any_orthonormal_pair();
    let (mut lo, mut hi) = ((f32::MAX, f32::MAX), (f32::MIN, f32::MIN));
    for &p in hole.iter().chain(samples.iter().map(|s| &s.0)) {
        let d = tx.dirs.at(p);
        let z = d.dot(c);
        if z < MIN_COS {
            return None;
        }
        let (u, v) = (d.dot(e1) / z, d.dot(e2) / z);
        lo = (lo.0.min(u), lo.1.min(v));
        hi = (hi.0.max(u), hi.1.max(v));
    }
    let margin = SHIFT * radius + 3.0 * SIGMAS[SIGMAS.len() - 1] * radius + 2.0 * alpha;
    let (u0, v0) = (lo.0 - margin, lo.1 - margin);
    let h = alpha.max(((hi.0 - lo.0).max(hi.1 - lo.1) + 2.0 * margin) / GRID_MAX);
    let w = ((hi.0 + margin - u0) / h).ceil() as usize + 1;
    let ht = ((hi.1 + margin - v0) / h).ceil() as usize + 1;
    Some(Frame { c, e1, e2, u0, v0, h, w, ht })
}

/// The occluders' silhouette on the frame: 1 where a layer nearer than `k` holds the cell's pixel.
fn silhouette(tx: &FillContext, k: u32, frame: &Frame) -> Vec<f32> {
    let mut mask = vec![0.0f32; frame.w * frame.ht];
    for j in 0..frame.ht {
        for i in 0..frame.w {
            let l = tx.layer_of[tx.pixel(frame.dir(i, j))];
            mask[j * frame.w + i] = (l != u32::MAX && l > k) as u8 as f32;
        }
    }
    mask
}

/// The best shadow over the blurs (in parallel; `r_cells` the hole's radius in cells): per blur,
/// a coarse grid of shifts with a few darkenings, the best refined by halving steps with all of
/// them. The fit and its blurred silhouette.
fn search(
    frame: &Frame,
    mask: &[f32],
    samples: &[Sample],
    plane: &LightPlane,
    r_cells: f32,
) -> Option<(Candidate, Vec<f32>)> {
    let logs = LogTable::new();
    let reach = SHIFT * r_cells;
    let fits: Vec<(Candidate, Vec<f32>)> = SIGMAS
        .par_iter()
        .filter_map(|f| {
            // Under about 0.6 cells the three boxes are 1 wide: the silhouette stays sharp.
            let b = blur(mask, frame.w, frame.ht, (f * r_cells).max(0.5));
            let mut best: Option<Candidate> = None;
            let consider = |shift: (f32, f32), ks: &[usize], best: &mut Option<Candidate>| {
                if let Some((sse, k)) = score(frame, &b, samples, shift, plane, &logs, ks) {
                    if best.is_none_or(|c| sse < c.sse) {
                        *best = Some(Candidate { sse, k, shift });
                    }
                }
            };
            let mut step = (reach / 4.0).max(1.0);
            let cells = (reach / step).ceil() as i32;
            for a in -cells..=cells {
                for bb in -cells..=cells {
                    consider((a as f32 * step, bb as f32 * step), &COARSE_KS, &mut best);
                }
            }
            consider(best?.shift, &ALL_KS, &mut best);
            while step > 0.5 {
                step *= 0.5;
                let centre = best?.shift;
                for (a, bb) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1)] {
                    consider((centre.0 + a as f32 * step, centre.1 + bb as f32 * step), &ALL_KS, &mut best);
                }
            }
            best.map(|c| (c, b))
        })
        .collect();
    fits.into_iter().min_by(|a, b| a.0.sse.total_cmp(&b.0.sse))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_blur_keeps_mass_and_spreads_by_sigma() {
        let (w, ht) = (101, 101);
        for sigma in [0.5f32, 2.0, 6.0, 15.0] {
            let mut grid = vec![0.0; w * ht];
            grid[50 * w + 50] = 1.0;
            let b = blur(&grid, w, ht, sigma);
            let mass: f32 = b.iter().sum();
            let var: f32 = (0..w * ht).map(|p| b[p] * ((p % w) as f32 - 50.0).powi(2)).sum::<f32>() / mass;
            assert!((mass - 1.0).abs() < 1e-4, "sigma {sigma}: mass {mass}");
            let expect = sigma * sigma;
            assert!(
                (var - expect).abs() <= 0.1 * expect + 0.3,
                "sigma {sigma}: variance {var}, not {expect}"
            );
        }
    }

    #[test]
    fn the_log_table_matches_ln() {
        let t = LogTable::new();
        for (ki, k) in KS.iter().enumerate() {
            for i in 0..=1000 {
                let c = i as f32 / 1000.0;
                let err = (t.at(ki, c) - (1.0 - k * c).ln()).abs();
                assert!(err < 1e-3, "k {k} c {c}: off by {err}");
            }
        }
    }
}
