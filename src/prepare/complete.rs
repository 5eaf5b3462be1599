//! Unknown depth completed from the known depth around it: push-pull in log depth (a pyramid of
//! weighted means, then each level's gaps from the coarser level), relaxed over the sphere's
//! neighbours, so holes of any size get a continuous surface; or, asked, the regions open to the
//! zenith made the sky.

use rayon::prelude::*;

use crate::mapping::{opposite, Mapping, Neighbours};

/// Known pixels that are blends of their surface with unknown depth (stored as zero): depth
/// resized with interpolation leaves a rim around every hole, one to several pixels wide, whose
/// values fall towards zero (a Matterport3D map, ¼ mm units: 19 200, 13 112, 0). Each would be a sliver
/// hanging near the camera. A known pixel is a blend when, across an unknown 4-neighbour, the
/// known pixel opposite it is farther by more than `jump` (relative) and the plane through that
/// pixel and the one beyond does not run on to it (grazing ground steps as much, on a plane; a ramp
/// down to zero is far from linear in 1/d); peeled a ring at a time,
/// up to [`RIM`] rings, so a ramp down to the hole goes whole. Returns the pixels to make unknown.
pub(crate) fn blends_with_unknown(nb: &Neighbours, depth: &[f32], unknown: &[bool], jump: f32) -> Vec<usize> {
    let mut gone = unknown.to_vec();
    let mut peeled = Vec::new();
    let mut frontier: Vec<usize> = (0..gone.len()).into_par_iter().filter(|&p| !gone[p]).collect();
    for _ in 0..RIM {
        let ring: Vec<usize> = frontier
            .par_iter()
            .copied()
            .filter(|&p| {
                !gone[p]
                    && (0..4).any(|k| {
                        nb.get(p, k).is_some_and(|h| gone[h])
                            && nb.get(p, opposite(k)).is_some_and(|o| {
                                !gone[o]
                                    && depth[o].is_finite()
                                    && depth[p] * (1.0 + jump) < depth[o]
                                    && !nb.get(o, opposite(k)).is_some_and(|b| {
                                        !gone[b]
                                            && crate::continuity::continues_plane(
                                                f64::from(depth[o]),
                                                f64::from(depth[p]),
                                                f64::from(depth[b]),
                                                crate::continuity::PLANAR,
                                            )
                                    })
                            })
                    })
            })
            .collect();
        if ring.is_empty() {
            break;
        }
        for &p in &ring {
            gone[p] = true;
        }
        frontier = ring.iter().flat_map(|&p| (0..4).filter_map(move |k| nb.get(p, k))).collect();
        frontier.sort_unstable();
        frontier.dedup();
        peeled.extend(ring);
    }
    peeled
}

/// Rings of [`blends_with_unknown`]: a ramp down to zero as wide as a ×8 bilinear upsampling's.
const RIM: usize = 8;

/// Unknown pixels of the regions open to the zenith: those reached from the unknown pixels nearest
/// the zenith through unknown pixels, after an opening of `OPEN` pixels (so thin gaps, such as
/// the missing rows between a LiDAR's scan lines, do not carry the sky down into the scene).
pub(crate) fn open_to_zenith(nb: &Neighbours, unknown: &[bool]) -> Vec<usize> {
    const OPEN: usize = 3;
    let four = |p: usize| (0..4).filter_map(move |k| nb.get(p, k));
    let mut core = unknown.to_vec();
    for _ in 0..OPEN {
        core = (0..core.len()).into_par_iter().map(|p| core[p] && four(p).all(|q| core[q])).collect();
    }
    // The sky is above the horizon: unknown ground beyond a scanner's range is not.
    let above = above_horizon(nb);
    for (c, a) in core.iter_mut().zip(&above) {
        *c &= a;
    }
    let seeds: Vec<usize> = (0..unknown.len())
        .filter(|&p| core[p] && nb.mapping().pixel_dir(p % nb.width(), p / nb.width()).z > ZENITH_COS)
        .collect();
    let mut sky = vec![false; unknown.len()];
    let mut stack = seeds;
    for &p in &stack {
        sky[p] = true;
    }
    while let Some(p) = stack.pop() {
        for q in four(p) {
            if core[q] && !sky[q] {
                sky[q] = true;
                stack.push(q);
            }
        }
    }
    // Grow back by the opening's width, through unknown pixels only.
    for _ in 0..OPEN {
        let grown: Vec<usize> = (0..sky.len())
            .filter(|&p| !sky[p] && unknown[p] && above[p] && four(p).any(|q| sky[q]))
            .collect();
        for p in grown {
            sky[p] = true;
        }
    }
    (0..sky.len()).filter(|&p| sky[p]).collect()
}

/// Directions within this cosine of the zenith (about 10°) seed the sky.
const ZENITH_COS: f64 = 0.985;

/// How far below the horizontal the sky may still be seen: 1°, the horizon's dip from about 1 km up.
const HORIZON_DIP_SIN: f64 = 0.017452;

/// Pixels whose direction is above [`HORIZON_DIP_SIN`] below the horizontal.
fn above_horizon(nb: &Neighbours) -> Vec<bool> {
    let (w, m) = (nb.width(), nb.mapping());
    (0..w * nb.height()).into_par_iter().map(|p| m.pixel_dir(p % w, p / w).z > -HORIZON_DIP_SIN).collect()
}

/// Unknown pixels below the horizon in holes that join the sky, more than two steps from known
/// depth: the push-pull blends the sky into them, but the sky is not below the horizon. Each takes
/// the known depth that reaches it first through the hole, continued as level ground when that
/// pixel is lower (depth × its height below the horizon over this pixel's: a plane's disparity
/// falls linearly to 0 at the horizon), as it is where a scanner's returns end on the ground.
pub(crate) fn ground_to_the_horizon(nb: &Neighbours, log: &mut [f32], original: &[f32], unknown: &[bool]) {
    let n = log.len();
    let sky = |p: usize| !unknown[p] && original[p] >= SKY_LOG;
    if !(0..n).into_par_iter().any(sky) {
        return;
    }
    let four = |p: usize| (0..4).filter_map(move |k| nb.get(p, k));
    let above = above_horizon(nb);
    let mut joined = vec![false; n];
    let mut stack: Vec<usize> =
        (0..n).into_par_iter().filter(|&p| unknown[p] && !above[p] && four(p).any(sky)).collect();
    for &p in &stack {
        joined[p] = true;
    }
    while let Some(p) = stack.pop() {
        for q in four(p) {
            if unknown[q] && !above[q] && !joined[q] {
                joined[q] = true;
                stack.push(q);
            }
        }
    }
    // Breadth-first through those holes from the known depth beside them (not the sky): each
    // pixel's source is the nearest (by angle) of its neighbours' sources, the farther on a tie,
    // so the front does not drift towards farther depth over many steps.
    const NONE: usize = usize::MAX;
    const SEEN: usize = usize::MAX - 1;
    let w = nb.width();
    let dir = |p: usize| nb.mapping().pixel_dir(p % w, p / w);
    let ground = |q: usize| !unknown[q] && original[q] < SKY_LOG;
    let mut source = vec![NONE; n];
    let mut frontier: Vec<usize> =
        (0..n).into_par_iter().filter(|&p| joined[p] && four(p).any(ground)).collect();
    let mut steps = 0;
    while !frontier.is_empty() {
        steps += 1;
        let chosen: Vec<usize> = frontier
            .par_iter()
            .map(|&p| {
                let d = dir(p);
                four(p)
                    .filter_map(|q| if ground(q) { Some(q) } else { Some(source[q]).filter(|&s| s < SEEN) })
                    .max_by(|&a, &b| {
                        d.dot(dir(a)).total_cmp(&d.dot(dir(b))).then(original[a].total_cmp(&original[b]))
                    })
                    .unwrap_or(NONE)
            })
            .collect();
        for (&p, &q) in frontier.iter().zip(&chosen) {
            if q == NONE {
                // Not reached (no symmetric neighbour): seen, so that the search ends.
                source[p] = SEEN;
                continue;
            }
            source[p] = q;
            // Continued as level ground only from below (more up than across) and past the
            // first two steps: a wall beside the hole, or a scan line's gap, continues as it is.
            let (dp, dq) = (dir(p), dir(q));
            let across = dp
                .truncate()
                .normalize_or_zero()
                .dot(dq.truncate().normalize_or_zero())
                .clamp(-1.0, 1.0)
                .acos();
            let up = dp.z.asin() - dq.z.asin();
            let lift = if steps > 2 && up > 2.0 * across { (dq.z / dp.z).ln() as f32 } else { 0.0 };
            log[p] = (original[q] + lift).min(SKY_LOG - 0.01);
        }
        frontier =
            frontier.iter().flat_map(|&p| four(p)).filter(|&q| joined[q] && source[q] == NONE).collect();
        frontier.sort_unstable();
        frontier.dedup();
    }
}

/// Relaxation sweeps after the push-pull.
pub(crate) const RELAX_SWEEPS: usize = 24;

/// Unknown pixels at most this many steps from known depth are a thin hole ([`nearest_across_steps`]).
const THIN: usize = 4;

/// Thin holes across a depth step (a scanner's shadows beside jumps, dropouts at an outline) are
/// not bridged: each unknown pixel within [`THIN`] steps of known depth whose completed value
/// (`log`) is more than half `jump_log` from the known depth that reaches it first through the
/// hole (the farther on a tie: shadows lie on the far side), or where the depths so reached span
/// a step within two steps of it, takes that depth instead, then is smoothed within its side.
/// The push-pull's blend of both sides would hang in mid-air between them. The sky reaches no
/// pixel below the horizon.
pub(crate) fn nearest_across_steps(
    nb: &Neighbours,
    log: &mut [f32],
    original: &[f32],
    unknown: &[bool],
    jump_log: f32,
) {
    let four = |p: usize| (0..4).filter_map(move |k| nb.get(p, k));
    let (w, m) = (nb.width(), nb.mapping());
    let below = |p: usize| m.pixel_dir(p % w, p / w).z <= -HORIZON_DIP_SIN;
    let mut reach: Vec<f32> =
        original.iter().zip(unknown).map(|(&o, &u)| if u { f32::NAN } else { o }).collect();
    let mut frontier: Vec<usize> =
        (0..unknown.len()).into_par_iter().filter(|&p| unknown[p] && four(p).any(|q| !unknown[q])).collect();
    let mut reached = Vec::new();
    for _ in 0..THIN {
        if frontier.is_empty() {
            break;
        }
        let values: Vec<(usize, f32)> = frontier
            .par_iter()
            .filter_map(|&p| {
                four(p)
                    .map(|q| reach[q])
                    .filter(|v| !(v.is_nan() || (*v >= SKY_LOG && below(p))))
                    .reduce(f32::max)
                    .map(|v| (p, v))
            })
            .collect();
        for &(p, v) in &values {
            reach[p] = v;
        }
        reached.extend(values.iter().map(|&(p, _)| p));
        frontier =
            values.iter().flat_map(|&(p, _)| four(p)).filter(|&q| unknown[q] && reach[q].is_nan()).collect();
        frontier.sort_unstable();
        frontier.dedup();
    }
    let two = |p: usize| four(p).flat_map(move |q| four(q).chain(std::iter::once(q)));
    let across: Vec<usize> = reached
        .into_par_iter()
        .filter(|&p| {
            let (lo, hi) = two(p)
                .map(|q| reach[q])
                .filter(|v| !v.is_nan())
                .fold((reach[p], reach[p]), |(lo, hi), v| (lo.min(v), hi.max(v)));
            hi - lo > jump_log || (log[p] - reach[p]).abs() > 0.5 * jump_log
        })
        .collect();
    for &p in &across {
        log[p] = reach[p];
    }
    // Then smooth within each side: the mean of the neighbours within a step of the pixel, so
    // that a gap over a slanted surface is not left in terraces and no step is bridged.
    mean_sweeps(nb, log, &across, SIDE_SWEEPS, jump_log);
}

/// Sweeps of [`nearest_across_steps`]' smoothing within a side.
const SIDE_SWEEPS: usize = 8;

/// Log depth given to infinitely far pixels while completing (10 km), so a hole beside the sky
/// completes towards it; completed values this far are infinitely far again.
pub(crate) const SKY_LOG: f32 = 9.2103;

/// Fill the NaN pixels of `log` (row-major `w` × `h`; finite elsewhere) in place.
pub(crate) fn push_pull(log: &mut [f32], w: usize, h: usize) {
    let weight: Vec<f32> = log.iter().map(|v| if v.is_nan() { 0.0 } else { 1.0 }).collect();
    let value: Vec<f32> = log.iter().map(|v| if v.is_nan() { 0.0 } else { *v }).collect();
    let filled = fill(&value, &weight, w, h);
    for (l, f) in log.iter_mut().zip(filled) {
        if l.is_nan() {
            *l = f;
        }
    }
}

/// Jacobi sweeps of the 4-neighbour mean over the `unknown` pixels of `log` (across the seam, the
/// poles and cube edges): the push-pull's blocky coarse levels relax towards the smooth
/// (harmonic) surface through the hole's rim.
pub(crate) fn relax(nb: &Neighbours, log: &mut [f32], unknown: &[bool], sweeps: usize) {
    let holes: Vec<usize> = (0..unknown.len()).filter(|&p| unknown[p]).collect();
    mean_sweeps(nb, log, &holes, sweeps, f32::INFINITY);
}

/// Jacobi sweeps over `pixels` of the mean of their 4-neighbours within `within` of them.
fn mean_sweeps(nb: &Neighbours, log: &mut [f32], pixels: &[usize], sweeps: usize, within: f32) {
    for _ in 0..sweeps {
        let next: Vec<f32> = pixels
            .par_iter()
            .map(|&p| {
                let (sum, n) = (0..4)
                    .filter_map(|k| nb.get(p, k))
                    .map(|q| log[q])
                    .filter(|v| (v - log[p]).abs() < within)
                    .fold((0.0f32, 0.0f32), |(s, n), v| (s + v, n + 1.0));
                if n > 0.0 {
                    sum / n
                } else {
                    log[p]
                }
            })
            .collect();
        for (&p, v) in pixels.iter().zip(next) {
            log[p] = v;
        }
    }
}

/// Values with weights in [0, 1] to values everywhere: the coarser level's values fill in where
/// the weight falls short of 1.
fn fill(value: &[f32], weight: &[f32], w: usize, h: usize) -> Vec<f32> {
    if weight.iter().all(|&x| x >= 1.0) || (w <= 1 && h <= 1) {
        return value.to_vec();
    }
    let (cw, chh) = (w.div_ceil(2), h.div_ceil(2));
    let mut cv = vec![0.0f32; cw * chh];
    let mut cwt = vec![0.0f32; cw * chh];
    for y in 0..h {
        for x in 0..w {
            let (p, c) = (y * w + x, (y / 2) * cw + x / 2);
            cv[c] += value[p] * weight[p];
            cwt[c] += weight[p];
        }
    }
    for (v, wt) in cv.iter_mut().zip(cwt.iter_mut()) {
        if *wt > 0.0 {
            *v /= *wt;
        }
        *wt = wt.min(1.0);
    }
    let coarse = fill(&cv, &cwt, cw, chh);
    // Bilinear from the coarser level's pixel centres.
    let sample = |x: usize, y: usize| -> f32 {
        let fx = ((x as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (cw - 1) as f32);
        let fy = ((y as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (chh - 1) as f32);
        let (x0, y0) = (fx as usize, fy as usize);
        let (x1, y1) = ((x0 + 1).min(cw - 1), (y0 + 1).min(chh - 1));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let at = |i: usize, j: usize| coarse[j * cw + i];
        (at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx) * (1.0 - ty)
            + (at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx) * ty
    };
    (0..w * h)
        .map(|p| {
            let wt = weight[p].min(1.0);
            if wt >= 1.0 {
                value[p]
            } else {
                wt * value[p] + (1.0 - wt) * sample(p % w, p / w)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hole in a ramp is completed on the ramp (linear in, linear out, to a few per cent).
    #[test]
    fn a_hole_in_a_ramp_is_completed_on_it() {
        let (w, h) = (64, 32);
        let mut log: Vec<f32> = (0..w * h).map(|p| (p % w) as f32 * 0.01).collect();
        let truth = log.clone();
        for y in 10..20 {
            for x in 20..40 {
                log[y * w + x] = f32::NAN;
            }
        }
        push_pull(&mut log, w, h);
        let worst = log.iter().zip(&truth).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst < 0.03, "{worst}");
    }
}
