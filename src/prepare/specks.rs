//! Specks: small pieces of surface cut off from everything around them, with something nearer on
//! their border — what resampled, blurred or estimated depth leaves along silhouettes (pixels of
//! neither side's depth). Each would be a segment of its own, and a chain of them lifts the
//! surface in front a level in the build (docs/build.md, "Depth preparation"). They take the depth
//! of the neighbouring surface whose colour they share.

use std::collections::VecDeque;

use rayon::prelude::*;

use crate::continuity;
use crate::mapping::{opposite, Neighbours};
use crate::prepare::complete::SKY_LOG;
use crate::prepare::mode::colour_distance;

/// Replace the specks of `log` (log depth; within 1e-3 of the sky's, [`SKY_LOG`], is infinitely far) smaller than
/// `max` pixels. Returns the pixels changed.
pub(crate) fn remove(nb: &Neighbours, log: &mut [f32], guide: &[[f32; 3]], max: usize) -> usize {
    let mut speck = find(nb, log, max);
    let changed = speck.iter().filter(|&&s| s).count();
    fill(nb, log, guide, &mut speck);
    changed
}

/// The pixels of specks: pieces of surface (flood-filled by the continuity rule) smaller than
/// `max` pixels with a nearer neighbour across their border.
fn find(nb: &Neighbours, log: &[f32], max: usize) -> Vec<bool> {
    let sky_log = SKY_LOG - 1e-3;
    let n = log.len();
    let depth: Vec<f64> =
        log.par_iter().map(|&l| if l >= sky_log { f64::INFINITY } else { f64::from(l).exp() }).collect();
    let joined = |log: &[f32], p: usize, k: usize, q: usize| {
        continuity::continuous_with(
            depth[p],
            depth[q],
            || nb.get(p, opposite(k)).map(|r| depth[r]),
            || nb.get(q, k).map(|r| depth[r]),
            continuity::JUMP,
            continuity::PLANAR,
        ) && !log[q].is_nan()
    };
    let mut piece = vec![u32::MAX; n];
    let mut speck = vec![false; n];
    let mut queue = VecDeque::new();
    let mut members = Vec::new();
    for start in 0..n {
        if piece[start] != u32::MAX || log[start].is_nan() {
            continue;
        }
        piece[start] = start as u32;
        queue.push_back(start);
        members.clear();
        let mut behind_something = false;
        while let Some(p) = queue.pop_front() {
            members.push(p);
            for k in 0..4 {
                let Some(q) = nb.get(p, k) else { continue };
                if log[q].is_nan() {
                    continue;
                }
                if joined(log, p, k, q) {
                    if piece[q] == u32::MAX {
                        piece[q] = start as u32;
                        queue.push_back(q);
                    }
                } else if log[q] < log[p] {
                    behind_something = true;
                }
            }
        }
        // The sky seen through a gap is behind everything and no speck.
        if members.len() < max && behind_something && log[start] < sky_log {
            for &p in &members {
                speck[p] = true;
            }
        }
    }
    speck
}

/// Fill the specks from their borders inwards, each pixel from the neighbour nearest in colour.
fn fill(nb: &Neighbours, log: &mut [f32], guide: &[[f32; 3]], speck: &mut [bool]) {
    let mut left: Vec<usize> = (0..log.len()).filter(|&p| speck[p]).collect();
    while !left.is_empty() {
        let settled: Vec<(usize, f32)> = left
            .iter()
            .filter_map(|&p| {
                let c = guide[p];
                (0..4)
                    .filter_map(|k| nb.get(p, k))
                    .filter(|&q| !speck[q] && !log[q].is_nan())
                    .min_by(|&a, &b| colour_distance(c, guide[a]).total_cmp(&colour_distance(c, guide[b])))
                    .map(|q| (p, log[q]))
            })
            .collect();
        if settled.is_empty() {
            break; // a speck with no settled neighbour at all (cannot happen: it has a border)
        }
        for &(p, l) in &settled {
            log[p] = l;
            speck[p] = false;
        }
        left.retain(|&p| speck[p]);
    }
}
