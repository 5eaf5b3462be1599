//! Where a surface ends: depth discontinuities (scale-free) and folds (normal discontinuities)
//! between 8-neighbours, and normals estimated from depth when the input has none.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::graph::{Neighbours, OFFSETS};
use crate::mapping::Mapping;

/// Tuning of the discontinuity tests.
#[derive(Clone, Copy, Debug)]
pub struct EdgeOptions {
    /// Relative jump `|a−b| / min(a,b)` above which two neighbours *may* be on different surfaces.
    pub jump: f64,
    /// A jump is confirmed only if linear extrapolation from both sides misses by more than this
    /// fraction too: a plane seen at a grazing angle changes depth fast but smoothly.
    pub extrapolation: f64,
    /// Angle (degrees) between neighbouring normals above which the surface folds; `None` = no
    /// fold test.
    pub fold_deg: Option<f64>,
}

impl Default for EdgeOptions {
    fn default() -> Self {
        EdgeOptions { jump: 0.08, extrapolation: 0.05, fold_deg: Some(35.0) }
    }
}

/// What separates a pixel from one neighbour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Link {
    /// Same surface.
    Smooth,
    /// Depth continuous but the surface folds (a crease, a contact line).
    Fold,
    /// Depth jumps: different surfaces; the nearer one occludes the farther.
    Jump,
}

/// Depth usable by the tests: finite and positive, or +inf for content treated as infinitely far.
#[inline]
fn usable(d: f32) -> bool {
    d > 0.0 && !d.is_nan()
}

/// Classify the link between `p` and its neighbour `k`.
pub fn link(
    nb: &Neighbours,
    depth: &[f32],
    normals: Option<&[Vec3]>,
    p: usize,
    k: usize,
    o: &EdgeOptions,
) -> Option<Link> {
    let q = nb.get(p, k)?;
    let (a, b) = (depth[p], depth[q]);
    if !usable(a) || !usable(b) {
        return None;
    }
    if a.is_infinite() || b.is_infinite() {
        return Some(if a == b { Link::Smooth } else { Link::Jump });
    }
    let (a, b) = (a as f64, b as f64);
    let rel = (a - b).abs() / a.min(b);
    if rel > o.jump && !smooth_by_extrapolation(nb, depth, p, q, k, a, b, o.extrapolation) {
        return Some(Link::Jump);
    }
    if let (Some(n), Some(limit)) = (normals, o.fold_deg) {
        let (np, nq) = (n[p], n[q]);
        if np != Vec3::ZERO && nq != Vec3::ZERO && np.dot(nq) < limit.to_radians().cos() as f32 {
            return Some(Link::Fold);
        }
    }
    Some(Link::Smooth)
}

/// Does the depth continue smoothly from either side? Linear extrapolation along the step
/// direction from `p` (using the pixel behind `p`) or from `q` (using the pixel beyond `q`).
#[allow(clippy::too_many_arguments)]
fn smooth_by_extrapolation(
    nb: &Neighbours,
    depth: &[f32],
    p: usize,
    q: usize,
    k: usize,
    a: f64,
    b: f64,
    tol: f64,
) -> bool {
    let back = opposite(k);
    let behind_p = nb.get(p, back).map(|i| depth[i] as f64);
    let beyond_q = nb.get(q, k).map(|i| depth[i] as f64);
    let min = a.min(b);
    let ok = |pred: f64, actual: f64| pred.is_finite() && (pred - actual).abs() / min <= tol;
    let from_p = behind_p.filter(|&d| d > 0.0 && d.is_finite()).is_some_and(|d| ok(2.0 * a - d, b));
    let from_q = beyond_q.filter(|&d| d > 0.0 && d.is_finite()).is_some_and(|d| ok(2.0 * b - d, a));
    // Both sides must agree: at a real discontinuity neither extrapolation reaches the other side.
    from_p && from_q
}

/// Index of the opposite offset in [`OFFSETS`].
pub fn opposite(k: usize) -> usize {
    let (dx, dy) = OFFSETS[k];
    OFFSETS.iter().position(|&o| o == (-dx, -dy)).expect("offsets are symmetric")
}

/// Unit normals estimated from depth (facing the centre). Each tangent is a one-sided difference
/// taken on the side where the surface runs straighter (its next difference turns least), so a
/// crease gives each side its own plane's normal instead of a blurred average that would hide
/// the fold; differences never cross a depth jump. Zero where no estimate exists.
pub fn estimate_normals(nb: &Neighbours, depth: &[f32], o: &EdgeOptions) -> Vec<Vec3> {
    let m = *nb.mapping();
    let point = |i: usize| -> Option<DVec3> {
        let d = depth[i];
        (d > 0.0 && d.is_finite()).then(|| m.pixel_dir(i % nb.width(), i / nb.width()) * d as f64)
    };
    let no_fold = EdgeOptions { fold_deg: None, ..*o };
    // The neighbour `k` of `p` when it lies on the same surface.
    let step = |p: usize, k: usize| -> Option<(usize, DVec3)> {
        if link(nb, depth, None, p, k, &no_fold) != Some(Link::Smooth) {
            return None;
        }
        let q = nb.get(p, k)?;
        Some((q, point(q)?))
    };
    (0..nb.len())
        .into_par_iter()
        .map(|p| {
            let Some(c) = point(p) else { return Vec3::ZERO };
            let tangent = |fwd: usize, bwd: usize| -> Option<DVec3> {
                let one_sided = |k: usize| -> Option<(DVec3, f64)> {
                    let (q, pq) = step(p, k)?;
                    let t = pq - c;
                    let straight = match step(q, k) {
                        Some((_, pr)) => t.normalize_or_zero().dot((pr - pq).normalize_or_zero()),
                        None => 0.0,
                    };
                    Some((if k == fwd { t } else { -t }, straight))
                };
                match (one_sided(fwd), one_sided(bwd)) {
                    (Some((f, sf)), Some((b, sb))) => Some(if sf >= sb { f } else { b }),
                    (Some((f, _)), None) => Some(f),
                    (None, Some((b, _))) => Some(b),
                    (None, None) => None,
                }
            };
            match (tangent(0, 1), tangent(2, 3)) {
                (Some(tx), Some(ty)) => {
                    let mut n = tx.cross(ty);
                    if n.length_squared() == 0.0 || !n.is_finite() {
                        return Vec3::ZERO;
                    }
                    n = n.normalize();
                    if n.dot(c) > 0.0 {
                        n = -n;
                    }
                    n.as_vec3()
                }
                _ => Vec3::ZERO,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{AnyMapping, MappingKind};

    #[test]
    fn opposite_offsets() {
        for k in 0..8 {
            let (dx, dy) = OFFSETS[k];
            assert_eq!(OFFSETS[opposite(k)], (-dx, -dy));
        }
    }

    #[test]
    fn jump_is_scale_free_and_needs_both_sides() {
        let m = AnyMapping::new(MappingKind::Equirect, 16, 8).unwrap();
        let nb = Neighbours::new(m);
        let o = EdgeOptions::default();
        for scale in [1e-3f32, 1.0, 1e5] {
            let mut depth = vec![2.0 * scale; 128];
            for y in 0..8 {
                for x in 8..16 {
                    depth[y * 16 + x] = 5.0 * scale;
                }
            }
            let p = 3 * 16 + 7;
            assert_eq!(link(&nb, &depth, None, p, 0, &o), Some(Link::Jump), "scale {scale}");
            assert_eq!(link(&nb, &depth, None, p, 1, &o), Some(Link::Smooth));
        }
        // A linear ramp with a large relative step per pixel is smooth, not a discontinuity.
        let depth: Vec<f32> = (0..128).map(|i| 1.0 + 0.5 * (i % 16) as f32).collect();
        assert_eq!(link(&nb, &depth, None, 3 * 16 + 2, 0, &o), Some(Link::Smooth));
    }
}
