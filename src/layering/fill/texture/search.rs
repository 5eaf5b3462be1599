//! Where a part of the exemplar fill copies from: the few offsets in its plane that best carry
//! the visible ring around it onto matching texture while landing the part itself on visible
//! surface (a coarse grid search, refined by halving steps).

use glam::Vec3;
use rayon::prelude::*;

use super::{spread, Plane, HOLE_SAMPLES, MIN_RING, RING_SAMPLES};
use crate::layering::fill::FillContext;

/// Cost of a ring sample whose source is not visible surface, and of an uncovered hole sample
/// (features lie in [0, 1); a good match costs ~1e-4).
const INVALID: f32 = 0.05;
const UNCOVERED: f32 = 0.02;
/// A part is copied when its best offset's ring mismatch is at most this share of what random
/// texture would give.
const COPY_MATCH: f32 = 0.5;
/// Smallest gain (per channel) a match may apply to its source, and the largest its inverse: the
/// lighting correction's range ([`super::MAX_LOG_RATIO`]).
const MIN_GAIN: f32 = 0.25;
/// Cost of relighting a source, per (log gain)² and unit of the ring's variance.
const LIGHT_COST: f32 = 0.25;

fn ln_sq(g: Vec3) -> Vec3 {
    let l = Vec3::new(g.x.ln(), g.y.ln(), g.z.ln());
    l * l
}

/// How well an offset carries the ring onto visible surface: the ring's mean mismatch after the best
/// gain and offset of its colours (`lit`) and as they are (`raw`), and the share of the hole it
/// leaves uncovered.
#[derive(Debug)]
struct Match {
    lit: f32,
    raw: f32,
    uncovered: f32,
}

/// Offsets kept per part: each pixel takes the first that lands on visible surface.
const OFFSETS: usize = 4;

/// One part's search: its ring samples (point, feature) and hole samples (points), and which
/// pixels are its surface's visible texture.
pub(super) struct Search<'a, 'b, V> {
    pub(super) tx: &'a FillContext<'b>,
    pub(super) valid: &'a V,
    pub(super) ring: Vec<(Vec3, Vec3)>,
    pub(super) hole: Vec<Vec3>,
}

impl<V: Fn(usize) -> bool + Sync> Search<'_, '_, V> {
    /// Mean mismatch of the ring carried by `t` and the share of the hole it leaves uncovered;
    /// `None` as soon as the ring's invalid sources alone cannot beat `bound`.
    fn parts(&self, t: Vec3, ring_n: usize, hole_n: usize, bound: f32) -> Option<Match> {
        let (ring_n, hole_n) = (self.ring.len().min(ring_n), self.hole.len().min(hole_n));
        let cap = bound * ring_n as f32;
        // Per channel over the valid sources: sums of ring, source and their products, so that the
        // mismatch is taken after the best gain and offset (the copy's lighting is corrected
        // afterwards; a far source is lit differently).
        let (mut r1, mut s1, mut rr, mut rs, mut ss) =
            (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        let (mut n, mut invalid) = (0.0, 0.0);
        for (x, feat) in spread(&self.ring, ring_n) {
            let p = self.tx.pixel(x + t);
            if (self.valid)(p) {
                let f = self.tx.feature(p);
                n += 1.0;
                r1 += feat;
                s1 += f;
                rr += feat * feat;
                rs += feat * f;
                ss += f * f;
            } else {
                invalid += INVALID;
                if invalid >= cap {
                    return None;
                }
            }
        }
        let raw = (rr - 2.0 * rs + ss).max(Vec3::ZERO).element_sum();
        // A fit to a few sources fits anything: below `MIN_RING` of them, colours as they are.
        let lit = if n >= MIN_RING as f32 {
            let (mr, ms) = (r1 / n, s1 / n);
            let (var_r, cov, var_s) = (rr / n - mr * mr, rs / n - mr * ms, ss / n - ms * ms);
            let gain = (cov / var_s.max(Vec3::splat(1e-12)))
                .clamp(Vec3::splat(MIN_GAIN), Vec3::splat(1.0 / MIN_GAIN));
            // A source lit like the ring is preferred: its correction is smaller, so surer.
            let relit = LIGHT_COST * (var_r * ln_sq(gain)).element_sum();
            n * ((var_r - 2.0 * gain * cov + gain * gain * var_s).max(Vec3::ZERO).element_sum() + relit)
        } else {
            raw
        };
        let mut uncovered = 0;
        for x in spread(&self.hole, hole_n) {
            uncovered += !(self.valid)(self.tx.pixel(x + t)) as u32;
        }
        let per = |sum: f32| (sum + invalid) / ring_n as f32;
        Some(Match { lit: per(lit), raw: per(raw), uncovered: uncovered as f32 / hole_n as f32 })
    }

    fn score(&self, t: Vec3, ring_n: usize, hole_n: usize, bound: f32) -> f32 {
        self.parts(t, ring_n, hole_n, bound).map_or(f32::INFINITY, |m| m.lit + UNCOVERED * m.uncovered)
    }

    /// The best offsets, at most [`OFFSETS`] at least two footprints apart, best first; `None`
    /// when even the best does not match clearly better than texture at random (`random`: the
    /// ring's variance).
    pub(super) fn offsets(
        &self,
        plane: &Plane,
        footprint: f32,
        extent: f32,
        random: f32,
    ) -> Option<Vec<Vec3>> {
        // Coarse grid over a disc a few hole sizes wide, then each of the best few refined by
        // halving steps down to half a pixel.
        let reach = 4.0 * extent + 32.0 * footprint;
        let step = (2.0 * footprint).max(reach / 24.0);
        let cells = (reach / step).ceil() as i32;
        let mut best: Vec<(f32, Vec3)> = Vec::new();
        for a in -cells..=cells {
            for b in -cells..=cells {
                let t = plane.e1 * (a as f32 * step) + plane.e2 * (b as f32 * step);
                if t.length() > reach || t.length() < 2.0 * footprint {
                    continue;
                }
                best.push((self.score(t, 64, 32, f32::INFINITY), t));
            }
        }
        best.sort_by(|a, b| a.0.total_cmp(&b.0));
        best.truncate(2 * OFFSETS);
        // Each candidate refined on its own (in parallel: a large part is one long search).
        best.par_iter_mut().for_each(|c| {
            c.0 = self.score(c.1, RING_SAMPLES, HOLE_SAMPLES, f32::INFINITY);
            let mut step = step;
            while step > 0.5 * footprint {
                step *= 0.5;
                let centre = c.1;
                for (a, b) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1)] {
                    let t = centre + plane.e1 * (a as f32 * step) + plane.e2 * (b as f32 * step);
                    let s = self.score(t, RING_SAMPLES, HOLE_SAMPLES, c.0);
                    if s < c.0 {
                        *c = (s, t);
                    }
                }
            }
        });
        best.sort_by(|a, b| a.0.total_cmp(&b.0));
        let clear = best
            .first()
            .and_then(|b| self.parts(b.1, RING_SAMPLES, HOLE_SAMPLES, f32::INFINITY))
            .is_some_and(|m| {
                (m.lit <= COPY_MATCH * random || m.raw <= 2.0 * COPY_MATCH * random) && m.uncovered <= 0.5
            });
        if !clear {
            return None;
        }
        let mut offsets: Vec<Vec3> = Vec::new();
        for (_, t) in best {
            if offsets.len() < OFFSETS && offsets.iter().all(|o| (*o - t).length() > 2.0 * footprint) {
                offsets.push(t);
            }
        }
        Some(offsets)
    }
}
