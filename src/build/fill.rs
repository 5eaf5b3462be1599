//! Filling what nearer layers hide, in the band a camera inside the freedom radius can see.
//!
//! From every pixel of a layer that borders an occluder (a nearer layer, across a depth jump), a
//! breadth-first front grows into the occluder's pixels while the angle to its source stays
//! within the largest parallax a camera within the freedom radius can open between the two
//! depths. Depth continues the background surface (the ray meets the source's tangent plane:
//! a wall stays planar behind a box); colour is copied from the background side only, from an
//! interior pixel, so foreground colour never bleeds into the fill.

use std::collections::{HashMap, VecDeque};

use glam::Vec3;

use super::edges::Links;
use super::graph::Neighbours;

/// The fill of one layer: extra pixels with their depth and the pixel whose colour they take.
#[derive(Clone, Debug, Default)]
pub struct Fill {
    /// (pixel, depth, colour source pixel).
    pub pixels: Vec<(usize, f32, usize)>,
    /// Widest angle (radians) between a filled pixel and its source.
    pub max_angle: f64,
}

/// Inputs shared by the fills of all layers.
pub struct FillContext<'a> {
    pub nb: &'a Neighbours,
    /// Pixel-centre unit directions.
    pub dirs: &'a [Vec3],
    /// Input depth (+inf for infinitely far content).
    pub depth: &'a [f32],
    /// Unit normals facing the centre (zero = unknown).
    pub normals: &'a [Vec3],
    /// Layer index per pixel (larger = nearer), `u32::MAX` for none.
    pub layer_of: &'a [u32],
    pub freedom_radius: f64,
    /// Extra band, radians (a couple of pixels: reconstruction filters reach that far).
    pub margin: f64,
    pub links: &'a Links,
}

/// Largest angle (radians) a camera within `r` of the centre can open between an occluding
/// edge at distance `near` and the surface behind it at `far` (`+inf` allowed): each point's
/// direction moves by at most `asin(r/d)`, and both move the same way. `π` when the occluder is
/// within the radius (the camera can walk around it).
pub fn parallax_band(r: f64, near: f64, far: f64) -> f64 {
    if near <= r {
        return std::f64::consts::PI;
    }
    let shift = |d: f64| if d.is_finite() { (r / d).min(1.0).asin() } else { 0.0 };
    (shift(near) - shift(far)).max(0.0)
}

/// Fill layer `k` behind its occluders.
pub fn fill_layer(cx: &FillContext, k: u32) -> Fill {
    let n = cx.nb.len();
    let mut src = vec![u32::MAX; n];
    let mut queue = VecDeque::new();
    for (p, seed) in src.iter_mut().enumerate() {
        // NaN (unknown) depth never seeds a fill.
        if cx.layer_of[p] != k || cx.depth[p].is_nan() || cx.depth[p] <= 0.0 {
            continue;
        }
        let borders = (0..8).any(|j| {
            cx.nb
                .get(p, j)
                .is_some_and(|q| cx.layer_of[q] != u32::MAX && cx.layer_of[q] > k && cx.links.is_jump(p, j))
        });
        if borders {
            *seed = p as u32;
            queue.push_back(p);
        }
    }
    let mut fill = Fill::default();
    let colour_src = |s: usize| interior_neighbour(cx, s, k);
    let mut colour_of_seed: HashMap<usize, usize> = HashMap::new();
    while let Some(p) = queue.pop_front() {
        let s = src[p] as usize;
        for j in 0..8 {
            let Some(q) = cx.nb.get(p, j) else { continue };
            if src[q] != u32::MAX || cx.layer_of[q] == u32::MAX || cx.layer_of[q] <= k {
                continue;
            }
            let near = cx.depth[q] as f64;
            if near.is_nan() || near <= 0.0 {
                continue;
            }
            let far = cx.depth[s] as f64;
            let angle = cx.dirs[q].dot(cx.dirs[s]).clamp(-1.0, 1.0).acos() as f64;
            if angle > parallax_band(cx.freedom_radius, near, far) + cx.margin {
                continue;
            }
            src[q] = s as u32;
            let d = continue_surface(cx, s, q);
            let c = *colour_of_seed.entry(s).or_insert_with(|| colour_src(s));
            fill.pixels.push((q, d, c));
            fill.max_angle = fill.max_angle.max(angle);
            queue.push_back(q);
        }
    }
    fill
}

/// Depth at pixel `q` of the surface of source pixel `s` continued behind the occluder: the ray
/// through `q` meets the tangent plane at `s`; when it cannot (plane seen edge-on, or behind the
/// centre), or the hit is implausible, the source's depth is kept.
fn continue_surface(cx: &FillContext, s: usize, q: usize) -> f32 {
    let ds = cx.depth[s];
    let occluder = cx.depth[q];
    if ds.is_infinite() {
        return f32::INFINITY;
    }
    let behind = |d: f32| d.max(occluder * 1.0001);
    let nrm = cx.normals[s];
    if nrm == Vec3::ZERO {
        return behind(ds);
    }
    let ps = cx.dirs[s] * ds;
    let denom = nrm.dot(cx.dirs[q]);
    if denom > -1e-3 {
        return behind(ds);
    }
    let t = nrm.dot(ps) / denom;
    if t.is_finite() && t > occluder && t < 8.0 * ds {
        t
    } else {
        behind(ds)
    }
}

/// The neighbour of a border pixel `s` that is deepest inside its layer (most neighbours in the
/// same layer): its colour is free of any mixing with the occluder at the border.
fn interior_neighbour(cx: &FillContext, s: usize, k: u32) -> usize {
    let inside = |p: usize| (0..8).filter(|&j| cx.nb.get(p, j).is_some_and(|q| cx.layer_of[q] == k)).count();
    let mut best = (inside(s), s);
    for j in 0..8 {
        if let Some(q) = cx.nb.get(s, j) {
            if cx.layer_of[q] == k && cx.depth[q] > 0.0 {
                let c = inside(q);
                if c > best.0 {
                    best = (c, q);
                }
            }
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_is_the_parallax_difference() {
        // r = 0.5, occluder at 1 m, wall at 2 m: asin(0.5) − asin(0.25).
        let b = parallax_band(0.5, 1.0, 2.0);
        assert!((b - (0.5f64.asin() - 0.25f64.asin())).abs() < 1e-12);
        assert_eq!(parallax_band(0.5, 0.05, 2.0), std::f64::consts::PI);
        assert!((parallax_band(0.5, 1.0, f64::INFINITY) - 0.5f64.asin()).abs() < 1e-12);
        assert_eq!(parallax_band(0.5, 3.0, 3.0), 0.0);
    }
}
