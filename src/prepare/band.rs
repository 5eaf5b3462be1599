//! Soft bands split at their colour edge (issue 51's 1-D cut across the band): along the depth's
//! gradient through a pixel inside a soft step, the profile's band (the steps of one monotone run
//! over [`TAIL`] of its steepest) is cut once near its half-rise, where the colours on either side
//! best match each side's colour just past the band; each pixel takes its side's surface continued
//! (a line in disparity through the side's first samples). Bands wider than the mode filter's disc
//! settle so. Measured in docs/build.md ("Soft bands cut at their colour edge", "The band's cut
//! near its half-rise").

use rayon::prelude::*;

use super::complete::SKY_LOG;
use super::mode::{inverse, Grid};
use crate::mapping::Neighbours;

/// Pixels a band spans (its ends included) before it is cut here; narrower bands are the mode
/// filter's, whose disc reaches both sides of them.
const MIN_WIDTH: usize = super::mode::RADIUS as usize;
/// Pixels along the gradient each way that a band and its sides are sought within.
pub(super) const REACH: usize = 24;
/// Least log-depth step per pixel at a band's steepest.
const MIN_STEP: f32 = 0.005;
/// A band ends where its steps fall under this share of its steepest.
const TAIL: f32 = 0.02;
/// Past half its steepest, a band's steps decay by at least this ratio per pixel.
const DECAY: f32 = 0.8;
/// Samples past each end of a band that give its side.
const SIDE: usize = 3;
/// Least change across a band (log depth): a jump of 10 %.
const JUMP: f32 = 0.0953;
/// A pixel within this of a side (log depth, 3 %) is on it already.
const TOL: f32 = 0.0296;
/// Sides whose colours differ by less than this (square root of linear RGB) show no edge: the
/// band is cut where its log depth passes half its rise.
const COLOUR_EDGE: f32 = 0.03;
/// Pixels either side of the band's half-rise that its cut is sought within.
const CUT_REACH: usize = 3;
/// A pixel's colour misfit to a side is capped at this share of the squared distance between the
/// sides' colours.
const TRUNCATE: f32 = 0.1;
/// Colour steps within this share of one another are equal.
const STEP_TIE: f32 = 1e-3;
/// Neighbours (of 8) that a moved pixel's new depth must be shared by, within [`TOL`].
const ALIKE: usize = 2;
/// Metres: a band whose sides land within a pixel of each other for an eye this far out is left.
const EYE: f32 = 0.5;

/// Cut the soft bands of `log` (log depth, the sky at [`SKY_LOG`]) within [`REACH`] pixels of each
/// pixel along its gradient; `colour` is the colour guide's 3 × 3 mean
/// ([`super::mode::colour_mean`]). Returns how many pixels moved.
pub(super) fn split_bands(nb: &Neighbours, log: &mut [f32], colour: &[[f32; 3]]) -> usize {
    let g = Grid::new(nb);
    let (w, h) = (g.w, g.h);
    let angle = g.pixel_angle();
    let src: Vec<f32> = log.iter().map(|&l| l.min(SKY_LOG)).collect();
    let inv: Vec<f32> = src.par_iter().map(|&l| inverse(l)).collect();
    let out: Vec<Option<f32>> = (0..w * h)
        .into_par_iter()
        .map_init(
            || Profile::new((&src, &inv, colour)),
            |prof, p| {
                let (x, y) = (p % w, p / w);
                if src[p] >= SKY_LOG - 1e-3 {
                    return None;
                }
                let (ux, uy) = gradient(&g, &src, x, y)?;
                prof.sample(&g, x, y, (ux, uy), REACH as isize);
                prof.cut(angle)
            },
        )
        .collect();
    // Each pixel cuts its own profile: a pixel whose new depth none of its neighbours shares
    // (a profile that met another edge) keeps its depth.
    let value = |q: usize| out[q].unwrap_or(src[q]);
    let kept: Vec<Option<f32>> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let v = out[p]?;
            let (x, y) = (p % w, p / w);
            let alike = (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
                .filter(|&(dx, dy)| (dx, dy) != (0, 0))
                .filter_map(|(dx, dy)| g.at(x, y, dx, dy))
                .filter(|&q| (value(q) - v).abs() <= TOL)
                .count();
            (alike >= ALIKE).then_some(v)
        })
        .collect();
    let mut moved = 0;
    for (l, o) in log.iter_mut().zip(kept) {
        if let Some(v) = o {
            if v.to_bits() != l.to_bits() {
                *l = v;
                moved += 1;
            }
        }
    }
    moved
}

/// The unit step, along the major axis one pixel, towards farther depth at `(x, y)` (Sobel), or
/// `None` where the depth is flat.
fn gradient(g: &Grid, src: &[f32], x: usize, y: usize) -> Option<(f32, f32)> {
    let at = |dx, dy| g.at(x, y, dx, dy).map(|q| src[q]);
    let (mut gx, mut gy) = (0f32, 0f32);
    for (o, wt) in [(-1isize, 1f32), (0, 2.0), (1, 1.0)] {
        if let (Some(a), Some(b)) = (at(1, o), at(-1, o)) {
            gx += wt * (a - b) / 8.0;
        }
        if let (Some(a), Some(b)) = (at(o, 1), at(o, -1)) {
            gy += wt * (a - b) / 8.0;
        }
    }
    let m = gx.abs().max(gy.abs());
    (m >= MIN_STEP / 2.0 && m.is_finite()).then(|| (gx / m, gy / m))
}

/// Log depth, disparity and colour of the canvas.
type Maps<'a> = (&'a [f32], &'a [f32], &'a [[f32; 3]]);

/// The pixels along a line through the pixel, at `centre`, and the maps they are read from (only
/// the samples a cut looks at are read).
struct Profile<'a> {
    idx: Vec<usize>,
    maps: Maps<'a>,
    centre: usize,
}

impl<'a> Profile<'a> {
    fn new(maps: Maps<'a>) -> Self {
        Profile { idx: Vec::with_capacity(2 * REACH + 1), maps, centre: 0 }
    }

    /// Log depth of sample `i`.
    fn l(&self, i: usize) -> f32 {
        self.maps.0[self.idx[i]]
    }

    /// Disparity of sample `i`.
    fn inv(&self, i: usize) -> f32 {
        self.maps.1[self.idx[i]]
    }

    /// Colour (3 × 3 mean) of sample `i`.
    fn colour(&self, i: usize) -> [f32; 3] {
        self.maps.2[self.idx[i]]
    }

    /// The pixels through `(x, y)` along `u`, `r` steps each way or to the face's edge.
    fn sample(&mut self, g: &Grid, x: usize, y: usize, u: (f32, f32), r: isize) {
        let (ux, uy) = u;
        let offset = |t: isize| ((t as f32 * ux).round() as isize, (t as f32 * uy).round() as isize);
        self.idx.clear();
        let back = if g.inside(x, y, r as usize) {
            // Inside the canvas by the reach: plain offsets (the common case; same pixels as `at`).
            let p = (y * g.w + x) as isize;
            self.idx.extend((-r..=r).map(|t| {
                let (dx, dy) = offset(t);
                (p + dy * g.w as isize + dx) as usize
            }));
            r
        } else {
            let at = |t: isize| {
                let (dx, dy) = offset(t);
                g.at(x, y, dx, dy)
            };
            // An equirect canvas has a pixel at every offset (rows clamp, columns wrap); a cube
            // face ends.
            let reach = |sign: isize| {
                if g.face == 0 {
                    r
                } else {
                    (1..=r).take_while(|&t| at(sign * t).is_some()).count() as isize
                }
            };
            let (back, ahead) = (reach(-1), reach(1));
            self.idx.extend((-back..=ahead).map(|t| at(t).expect("within the face")));
            back
        };
        self.centre = back as usize;
    }

    /// The centre's new log depth, if it lies inside a band.
    fn cut(&self, angle: f32) -> Option<f32> {
        let (l, c) = (|i| self.l(i), self.centre);
        let n = self.idx.len();
        // Steps in disparity, where grazing ground and walls run on as lines (in log depth the
        // ground's steps shrink away from the horizon as a blur's tail does).
        let step = |i: usize| self.inv(i) - self.inv(i + 1);
        // The monotone (rising) run of pixels a0..=b0 through the centre.
        let mut a0 = c;
        while a0 > 0 && step(a0 - 1) > 0.0 {
            a0 -= 1;
        }
        let mut b0 = c;
        while b0 + 1 < n && step(b0) > 0.0 {
            b0 += 1;
        }
        if b0 == a0 {
            return None;
        }
        let k = (a0..b0).max_by(|&i, &j| step(i).total_cmp(&step(j)))?;
        let peak = step(k);
        if l(k + 1) - l(k) < MIN_STEP {
            return None;
        }
        // The band: steps i..=j, pixels i (near end) to j + 1 (far end).
        // A step past half the peak is the band's while the steps still decay beyond it (a blur's
        // tail); where they level off, a surface turning away begins (its steps run on alike).
        let in_band = |s: f32, beyond: Option<f32>| {
            s > TAIL * peak && (s >= 0.5 * peak || beyond.is_none_or(|b| b < DECAY * s))
        };
        let (mut i, mut j) = (k, k);
        while i > a0 && in_band(step(i - 1), (i >= 2).then(|| step(i - 2))) {
            i -= 1;
        }
        while j + 1 < b0 && in_band(step(j + 1), (j + 2 < n - 1).then(|| step(j + 2))) {
            j += 1;
        }
        // A ramp that keeps its slope to its ends is a surface (a plane between two corners).
        if step(i) >= 0.5 * peak || step(j) >= 0.5 * peak {
            return None;
        }
        // A band ends inside the profile, with its sides' samples past both ends.
        if j + 1 - i < MIN_WIDTH
            || i < SIDE - 1
            || j + SIDE > n - 1
            || !(i < c && c <= j)
            || l(j + 1) - l(i) < JUMP
        {
            return None;
        }
        if (inverse(l(i)) - inverse(l(j + 1))) * EYE <= angle {
            return None;
        }
        let near_side: Vec<usize> = (i.saturating_sub(SIDE - 1)..=i).collect();
        let far_side: Vec<usize> = (j + 1..=(j + SIDE).min(n - 1)).collect();
        let mean = |idx: &[usize]| {
            let mut s = [0f32; 3];
            idx.iter().for_each(|&q| (0..3).for_each(|ch| s[ch] += self.colour(q)[ch]));
            s.map(|v| v / idx.len() as f32)
        };
        let (cn, cf) = (mean(&near_side), mean(&far_side));
        let d2 = |a: [f32; 3], b: [f32; 3]| (0..3).map(|ch| (a[ch] - b[ch]).powi(2)).sum::<f32>();
        // Where the log depth passes half the band's rise: a blur's edge, wherever its steepest
        // step in disparity leans. The cut is sought near it only.
        let half = 0.5 * (l(i) + l(j + 1));
        let mid = (i..=j).find(|&q| l(q + 1) > half).unwrap_or(j);
        // The cut after pixel m: pixels i..=m near, m + 1..=j + 1 far.
        let m = if d2(cn, cf).sqrt() < COLOUR_EDGE {
            mid
        } else {
            // A pixel's misfit is capped: a third colour (an edge stripe, a shaded rim) far from
            // both sides costs the same on either, so it does not drag the cut onto its far edge.
            let cap = TRUNCATE * d2(cn, cf);
            let cost = |q: usize, side: [f32; 3]| d2(self.colour(q), side).min(cap);
            // Equal costs go to the strongest colour step between neighbours, and equal steps (an
            // edge the colour guide's 3 × 3 mean spreads over three) to the one nearest `mid`.
            let colour_step = |m: usize| d2(self.colour(m), self.colour(m + 1));
            let stronger = |m: usize, at: usize| {
                let (s, t) = (colour_step(m), colour_step(at));
                s > t * (1.0 + STEP_TIE) || (s >= t * (1.0 - STEP_TIE) && m.abs_diff(mid) < at.abs_diff(mid))
            };
            let eps = 1e-6 * cap;
            let (lo, hi) = (mid.saturating_sub(CUT_REACH).max(i), (mid + CUT_REACH).min(j));
            let (mut best, mut at) = (f32::INFINITY, mid);
            // Running cost: near-side misfit of pixels up to m plus far-side misfit after it.
            let (mut near_acc, mut far_acc) = (0f32, (i..=j + 1).map(|q| cost(q, cf)).sum::<f32>());
            for m in i..=hi {
                near_acc += cost(m, cn);
                far_acc -= cost(m, cf);
                let total = near_acc + far_acc;
                if m >= lo && (total < best - eps || (total <= best + eps && stronger(m, at))) {
                    (best, at) = (total.min(best), m);
                }
            }
            at
        };
        let (side, end) = if c <= m { (&near_side, i) } else { (&far_side, j + 1) };
        let v = self.continued(side, end);
        // A line from three samples carried across a wide band can overshoot: no further than
        // half the band's change past its end.
        let v = if (v - l(end)).abs() > 0.5 * (l(j + 1) - l(i)) { l(end) } else { v };
        let on_side = if c <= m { v < l(c) - TOL } else { v > l(c) + TOL };
        on_side.then_some(v)
    }

    /// The side's surface at the centre: a line in disparity through its samples, or the end
    /// sample's depth where the line does not land on the side of the band it continues.
    fn continued(&self, side: &[usize], end: usize) -> f32 {
        let (l, c) = (|i| self.l(i), self.centre as f32);
        if l(end) >= SKY_LOG - 1e-3 || side.len() < 2 {
            return l(end);
        }
        let pts: Vec<(f32, f32)> = side.iter().map(|&q| (q as f32, self.inv(q))).collect();
        if pts.iter().any(|&(_, v)| v <= 0.0) {
            return l(end);
        }
        let n = pts.len() as f32;
        let (mt, mv) = (pts.iter().map(|p| p.0).sum::<f32>() / n, pts.iter().map(|p| p.1).sum::<f32>() / n);
        let stt: f32 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
        let slope = pts.iter().map(|p| (p.0 - mt) * (p.1 - mv)).sum::<f32>() / stt;
        let v = mv + slope * (c - mt);
        if v > 0.0 {
            -v.ln()
        } else {
            l(end)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{AnyMapping, MappingKind};

    const W: usize = 256;
    const H: usize = 128;

    fn canvas() -> Neighbours {
        Neighbours::new(AnyMapping::new(MappingKind::Equirect, W, H).unwrap())
    }

    /// Log depth of each row blurred along it by a Gaussian of `sigma` pixels.
    fn blurred(log: &[f32], sigma: f32) -> Vec<f32> {
        let r = (3.0 * sigma).ceil() as isize;
        let k: Vec<f32> = (-r..=r).map(|t| (-(t * t) as f32 / (2.0 * sigma * sigma)).exp()).collect();
        let sum: f32 = k.iter().sum();
        (0..W * H)
            .map(|p| {
                let (x, y) = (p % W, p / W);
                (-r..=r)
                    .zip(&k)
                    .map(|(t, kt)| kt * log[y * W + (x as isize + t).rem_euclid(W as isize) as usize])
                    .sum::<f32>()
                    / sum
            })
            .collect()
    }

    /// A profile's plain offsets inside the canvas are the pixels [`Grid::at`] reaches, and
    /// near the poles and the seam it takes the slow way: every direction, every pixel.
    #[test]
    fn a_profile_takes_the_pixels_along_its_line() {
        let g = Grid::new(&canvas());
        let maps: (Vec<f32>, Vec<f32>, Vec<[f32; 3]>) =
            (vec![0.0; W * H], vec![0.0; W * H], vec![[0.0; 3]; W * H]);
        let mut prof = Profile::new((&maps.0, &maps.1, &maps.2));
        let dirs = [(1.0, 0.3), (-0.45, 1.0), (1.0, -1.0), (0.0, -1.0), (-1.0, 0.5)];
        for p in (0..W * H).step_by(37) {
            let (x, y) = (p % W, p / W);
            for u in dirs {
                prof.sample(&g, x, y, u, REACH as isize);
                assert_eq!(prof.idx.len(), 2 * REACH + 1);
                for (i, &q) in prof.idx.iter().enumerate() {
                    let t = i as isize - prof.centre as isize;
                    let want =
                        g.at(x, y, (t as f32 * u.0).round() as isize, (t as f32 * u.1).round() as isize);
                    assert_eq!(Some(q), want, "pixel ({x}, {y}), direction {u:?}, step {t}");
                }
            }
        }
    }

    /// An object 1.5 m out before a wall 4 m out, its depth blurred σ 4 px (bands of 16 px, wider
    /// than the mode filter's disc) and its colour sharp: the cut puts every pixel of the band on
    /// the side its colour is of, at that side's depth.
    #[test]
    fn a_wide_band_is_cut_at_its_colour_edge() {
        let object = |x: usize| (80..140).contains(&x);
        let exact: Vec<f32> =
            (0..W * H).map(|p| if object(p % W) { 1.5f32.ln() } else { 4f32.ln() }).collect();
        let guide: Vec<[f32; 3]> =
            (0..W * H).map(|p| if object(p % W) { [0.8, 0.2, 0.2] } else { [0.4, 0.5, 0.45] }).collect();
        let mut log = blurred(&exact, 4.0);
        let off = |log: &[f32]| log.iter().zip(&exact).filter(|(l, e)| (*l - *e).abs() > 0.05).count();
        let before = off(&log);
        assert!(before >= 10 * H, "the blur makes bands ({before} pixels off)");
        let colour = super::super::mode::colour_mean(&Grid::new(&canvas()), &guide);
        let moved = split_bands(&canvas(), &mut log, &colour);
        assert!(moved >= before / 2, "{moved} moved of {before}");
        assert!(off(&log) <= H, "{} pixels still more than 5 % off (of {before})", off(&log));
    }

    /// A mark of the background's colour on the object, beside its outline: a cut by colour alone
    /// sends the mark and the strip of face outside it to the background. The cut is sought within
    /// [`CUT_REACH`] of the depth's half-rise only, so they stay on the object.
    #[test]
    fn a_mark_inside_an_object_is_not_its_outline() {
        let object = |x: usize| (80..140).contains(&x);
        let mark = |x: usize| (128..137).contains(&x);
        let exact: Vec<f32> =
            (0..W * H).map(|p| if object(p % W) { 1.5f32.ln() } else { 4f32.ln() }).collect();
        let guide: Vec<[f32; 3]> = (0..W * H)
            .map(|p| match p % W {
                x if mark(x) => [0.42, 0.5, 0.44],
                x if object(x) => [0.8, 0.2, 0.2],
                _ => [0.4, 0.5, 0.45],
            })
            .collect();
        let mut log = blurred(&exact, 4.0);
        let colour = super::super::mode::colour_mean(&Grid::new(&canvas()), &guide);
        split_bands(&canvas(), &mut log, &colour);
        let rows = 8..H - 8;
        let off =
            |x: usize| rows.clone().filter(|&y| (log[y * W + x] - exact[y * W + x]).abs() > 0.05).count();
        for x in 128..140 {
            assert!(off(x) <= 2, "column {x}: {} rows off the object", off(x));
        }
    }

    /// A wall turning away between two corners keeps its slope to its ends: no band. A sharp
    /// step has no pixel inside it. Neither moves.
    #[test]
    fn surfaces_and_sharp_steps_are_left() {
        let guide: Vec<[f32; 3]> =
            (0..W * H).map(|p| [0.3 + (p % W) as f32 / W as f32 * 0.4, 0.4, 0.4]).collect();
        let turning: Vec<f32> = (0..W * H)
            .map(|p| {
                let x = (p % W) as f32;
                (1.0 + 0.5 * ((x - 80.0) / 60.0).clamp(0.0, 1.0)).ln()
            })
            .collect();
        let sharp: Vec<f32> =
            (0..W * H).map(|p| if (80..140).contains(&(p % W)) { 1.5f32.ln() } else { 4f32.ln() }).collect();
        for (name, depth) in [("turning", turning), ("sharp", sharp)] {
            let mut log = depth.clone();
            let colour = super::super::mode::colour_mean(&Grid::new(&canvas()), &guide);
            assert_eq!(split_bands(&canvas(), &mut log, &colour), 0, "{name}");
            assert!(log.iter().zip(&depth).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}");
        }
    }
}
