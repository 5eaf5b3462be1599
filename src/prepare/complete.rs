//! Unknown depth completed from the known depth around it: push-pull in log depth (a pyramid of
//! weighted means, then each level's gaps from the coarser level), relaxed over the sphere's
//! neighbours, so holes of any size get a continuous surface; or, asked, the regions open to the
//! zenith made the sky.

use rayon::prelude::*;

use crate::mapping::{Mapping, Neighbours};

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
        let grown: Vec<usize> =
            (0..sky.len()).filter(|&p| !sky[p] && unknown[p] && four(p).any(|q| sky[q])).collect();
        for p in grown {
            sky[p] = true;
        }
    }
    (0..sky.len()).filter(|&p| sky[p]).collect()
}

/// Directions within this cosine of the zenith (about 10°) seed the sky.
const ZENITH_COS: f64 = 0.985;

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
    for _ in 0..sweeps {
        let next: Vec<f32> = holes
            .par_iter()
            .map(|&p| {
                let (mut sum, mut n) = (0.0f32, 0.0f32);
                for q in (0..4).filter_map(|k| nb.get(p, k)) {
                    sum += log[q];
                    n += 1.0;
                }
                if n > 0.0 {
                    sum / n
                } else {
                    log[p]
                }
            })
            .collect();
        for (&p, v) in holes.iter().zip(next) {
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
