//! Short blurred ramps told from real slopes (issue 51): after the mode filter, a pixel still
//! between the two sides of a strong step goes to one side when, along two of the four lines
//! through it, it sits in a short run of in-between depths with kinks at both ends and a colour
//! edge across it, and no side continued linearly in disparity predicts it (a wall or the ground
//! running between a near object and a far one keeps its depths). Measured: docs/build.md,
//! "Short ramps to a side" (`--refine ramps` only: it loses on some inputs).

use rayon::prelude::*;

use super::complete::SKY_LOG;
use super::mode::{colour_distance, inverse, square_range, Grid, RADIUS};

/// A step: the disc's nearest and farthest depths more than this ratio apart (log, `ln 1.5`).
const JUMP: f32 = 0.405_465_1;
/// In between: more than this ratio (log, `ln 1.1`) from both ends of the disc or line.
const TOL: f32 = 0.095_310_18;
/// Longest run of in-between pixels along a line.
const RUN: isize = 6;
/// A side's disparity continued linearly predicts the pixel within this share: a slope.
const SLOPE_FIT: f32 = 0.05;
/// Disparity changes this many times faster across the run than just beyond its ends.
const KINK: f32 = 2.0;
/// Lines (of four) on which the pixel must sit in such a run.
const LINES: usize = 2;
/// The run's log-depth fraction lies within this margin of neither end.
const FRACTION: f32 = 0.2;
/// Four pixels whose disparity steps stay within this ratio of each other (one sign) are a slope.
const EVEN: f32 = 1.3;
/// Colour distance (square root of linear RGB, 3 × 3 mean) across the run: an occlusion edge.
const COLOUR_EDGE: f32 = 0.1;
/// A pixel whose colour is this far from both sides' is a third surface (a box's top seen edge on)
/// and goes to the near side.
const THIRD: f32 = 0.1;
/// Metres: both ends must move off the pixel by over a pixel for an eye this far out.
const EYE: f32 = 0.5;

const LINE_DIRS: [(isize, isize); 4] = [(1, 0), (0, 1), (1, 1), (-1, 1)];

/// Move the pixels of `log` (log depth, the sky at [`SKY_LOG`]) that sit in short blurred ramps to
/// one side's depth; `colour` is [`super::mode::colour_mean`]'s. Returns how many moved.
pub(super) fn settle_ramps(g: &Grid, log: &mut [f32], colour: &[[f32; 3]]) -> usize {
    let (lo, hi) = square_range(g, log);
    let src: &[f32] = log;
    let moves: Vec<(usize, f32)> = (0..g.w * g.h)
        .into_par_iter()
        // The square holds the disc: no step in the square, none in the disc.
        .filter(|&p| hi[p] - lo[p] > JUMP)
        .filter_map(|p| ramp_side(g, src, colour, p).map(|v| (p, v)))
        .collect();
    for &(p, v) in &moves {
        log[p] = v;
    }
    moves.len()
}

/// The side pixel `p` goes to, if it sits in a blurred ramp.
fn ramp_side(g: &Grid, log: &[f32], colour: &[[f32; 3]], p: usize) -> Option<f32> {
    let (x, y) = (p % g.w, p / g.w);
    let lp = log[p];
    if !lp.is_finite() {
        return None;
    }
    // The disc's extremes and their colours (the first in scan order where several tie).
    let r = RADIUS;
    let (mut lo, mut hi, mut c_lo, mut c_hi) = (lp, lp, colour[p], colour[p]);
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            // Off a cube's face: not in the disc.
            let Some(q) = g.at(x, y, dx, dy) else { continue };
            let v = log[q];
            if v < lo {
                (lo, c_lo) = (v, colour[q]);
            }
            if v > hi {
                (hi, c_hi) = (v, colour[q]);
            }
        }
    }
    let in_step = hi - lo > JUMP && lp - lo > TOL && hi - lp > TOL && hi < SKY_LOG - 1e-3;
    if !in_step {
        return None;
    }
    let c = colour[p];
    let (dn, df) = (colour_distance(c, c_lo), colour_distance(c, c_hi));
    let pick_far = dn.min(df) <= THIRD * THIRD && df < dn;
    let ip = inverse(lp);
    let pixel = g.pixel_angle();
    let (mut lines, mut side, mut slope) = (0usize, None, false);
    for (ux, uy) in LINE_DIRS {
        let at = |k: isize| g.at(x, y, k * ux, k * uy);
        let Some(prof) = (-r..=r).map(|k| at(k).map(|q| log[q])).collect::<Option<Vec<f32>>>() else {
            continue;
        };
        let (lo_u, hi_u) =
            prof.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if !prof.iter().all(|v| v.is_finite()) || hi_u - lo_u <= JUMP {
            continue;
        }
        let inv_at = |k: isize| at(k).map(|q| inverse(log[q]));
        if is_slope(ip, &inv_at) {
            slope = true;
            break;
        }
        // The first pixel out either way that is at the line's near (1) or far (2) end.
        let end = |s: isize| {
            (1..=r).find_map(|k| {
                let v = prof[(r + s * k) as usize];
                if v <= lo_u + TOL {
                    Some((k, 1))
                } else if v >= hi_u - TOL {
                    Some((k, 2))
                } else {
                    None
                }
            })
        };
        let (Some((kp, tp)), Some((km, tm))) = (end(1), end(-1)) else { continue };
        if tp == tm || kp + km - 1 > RUN {
            continue;
        }
        let f = (lp - lo_u) / (hi_u - lo_u).max(1e-9);
        if !(FRACTION..=1.0 - FRACTION).contains(&f) {
            continue;
        }
        let (Some(a), Some(b), Some(a3), Some(b3)) =
            (inv_at(kp), inv_at(-km), inv_at(kp + 3), inv_at(-km - 3))
        else {
            continue;
        };
        let run = (a - b).abs() / (kp + km) as f32;
        if run <= KINK * ((a3 - a).abs() / 3.0).max((b3 - b).abs() / 3.0) {
            continue;
        }
        let (near, far) = (inverse(lo_u), inverse(hi_u));
        if !((ip - far) * EYE > pixel && (near - ip) * EYE > pixel) {
            continue;
        }
        let (Some(qa), Some(qb)) = (at(kp + 1), at(-km - 1)) else { continue };
        if colour_distance(colour[qa], colour[qb]) <= COLOUR_EDGE * COLOUR_EDGE {
            continue;
        }
        lines += 1;
        if side.is_none() {
            // Each half of the line: the near end's nearest, the far end's farthest.
            let (plus, minus) = (&prof[r as usize + 1..], &prof[..r as usize]);
            let min = |s: &[f32]| s.iter().copied().fold(f32::INFINITY, f32::min);
            let max = |s: &[f32]| s.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            side = Some(if pick_far {
                max(if tp == 2 { plus } else { minus })
            } else {
                min(if tp == 1 { plus } else { minus })
            });
        }
    }
    if slope || lines < LINES {
        return None;
    }
    side
}

/// Whether the disparity through a pixel (`ip`) along a line (`inv_at(k)`, k pixels on) is a
/// slope: one side's disparity 3–6 px out continued linearly predicts it, or four pixels in a row
/// through it or a neighbour step evenly (a slanted face between an edge and a crease).
fn is_slope(ip: f32, inv_at: &dyn Fn(isize) -> Option<f32>) -> bool {
    let scale = ip.max(1e-9);
    for s in [1, -1] {
        // Least squares of inv = a·t + b over t = 3..6; the prediction is b.
        let Some(v) = (3..=6).map(|t| inv_at(s * t)).collect::<Option<Vec<f32>>>() else { continue };
        let (mt, mv) = (4.5f32, v.iter().sum::<f32>() / 4.0);
        let a = v.iter().zip(3..=6).map(|(&v, t)| (t as f32 - mt) * (v - mv)).sum::<f32>() / 5.0;
        if (mv - a * mt - ip).abs() <= SLOPE_FIT * scale {
            return true;
        }
    }
    let Some(q) = (-4..=4).map(inv_at).collect::<Option<Vec<f32>>>() else { return false };
    let steps: Vec<f32> = q.windows(2).map(|w| w[1] - w[0]).collect();
    steps.windows(3).any(|st| {
        let one_sign = st.iter().all(|&s| s > 0.0) || st.iter().all(|&s| s < 0.0);
        let (mx, mn) = st.iter().fold((0f32, f32::INFINITY), |(a, b), s| (a.max(s.abs()), b.min(s.abs())));
        one_sign && mx <= EVEN * mn && mx > 1e-3 * scale
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prepare::mode::colour_mean;

    const G: Grid = Grid { w: 256, h: 128, face: 0 };
    const NEAR: f32 = 1.0;
    const FAR: f32 = 3.0;

    /// A near half (columns 0–127, red) and a far half (blue) of an equirect canvas, the log depth
    /// across each of the two edges (at column 128 and at the seam) given by `profile(signed
    /// distance to the edge, positive on the far side)` as a share of the way from near to far.
    fn halves(profile: impl Fn(f32) -> f32) -> (Vec<f32>, Vec<[f32; 3]>) {
        let (ln, lf) = (NEAR.ln(), FAR.ln());
        let mut log = vec![0f32; G.w * G.h];
        let mut guide = vec![[0f32; 3]; G.w * G.h];
        for p in 0..G.w * G.h {
            let x = (p % G.w) as f32 + 0.5;
            // Signed distance to the nearer edge: positive on the far half.
            let t = if x < 128.0 { -(x.min(128.0 - x)) } else { (x - 128.0).min(256.0 - x) };
            log[p] = ln + (lf - ln) * profile(t);
            guide[p] = if x < 128.0 { [0.8, 0.2, 0.2] } else { [0.2, 0.2, 0.8] };
        }
        (log, colour_mean(&G, &guide))
    }

    fn in_between(log: &[f32]) -> usize {
        log.iter().filter(|&&l| l - NEAR.ln() > TOL && FAR.ln() - l > TOL).count()
    }

    /// A step blurred like an estimator's (a Gaussian of σ 1.5 px in log depth): most of its
    /// in-between pixels go to a side, each to the side of its own colour at that side's depth
    /// (the near side where the colour is a mix of both).
    #[test]
    fn a_blurred_step_goes_to_the_side_of_its_colour() {
        let erf_like = |t: f32| 0.5 * (1.0 + (1.128 * t / 1.5 * (1.0 + 0.0886 * (t / 1.5).powi(2))).tanh());
        let (mut log, colour) = halves(erf_like);
        let before = log.clone();
        let was = in_between(&log);
        let moved = settle_ramps(&G, &mut log, &colour);
        assert!(was > 0 && moved > 0);
        assert!(in_between(&log) * 3 < was, "{} of {was} in-between pixels left", in_between(&log));
        for p in (0..log.len()).filter(|&p| log[p] != before[p]) {
            // The two columns either side of an edge mix both colours in their 3 × 3 mean, a
            // third colour: they go to the near side.
            let x = p % G.w;
            let mixed = [127, 128, 255, 0].contains(&x);
            let want = if x < 128 || mixed { NEAR.ln() } else { FAR.ln() };
            assert!((log[p] - want).abs() < 0.05, "pixel {p}: {} for {want}", log[p]);
        }
    }

    /// Exact depth: a step with no pixel in between moves nothing.
    #[test]
    fn an_exact_step_moves_nothing() {
        let (mut log, colour) = halves(|t| if t > 0.0 { 1.0 } else { 0.0 });
        let before = log.clone();
        assert_eq!(settle_ramps(&G, &mut log, &colour), 0);
        assert_eq!(log, before);
    }

    /// A run whose disparity steps evenly (a slanted face between a near edge and a far crease)
    /// is a slope, however short: it keeps its depths.
    #[test]
    fn an_even_run_in_disparity_is_a_slope() {
        let (ln, lf) = (NEAR.ln(), FAR.ln());
        let (i_near, i_far) = (1.0 / NEAR, 1.0 / FAR);
        let (mut log, colour) = halves(|t| {
            // Disparity linear over 5 px across the edge, flat beyond.
            let s = ((t + 2.5) / 5.0).clamp(0.0, 1.0);
            let inv = i_near + (i_far - i_near) * s;
            ((-inv.ln()) - ln) / (lf - ln)
        });
        assert!(in_between(&log) > 0);
        let before = log.clone();
        assert_eq!(settle_ramps(&G, &mut log, &colour), 0);
        assert_eq!(log, before);
    }
}
