//! Layer continuity (spec §7.2): whether two neighbouring depths lie on one surface. Build splits
//! layers where it fails, validate reports layers where it fails, and the renderers never stretch a
//! surface across it: one rule, here.

use crate::mapping::{opposite, Neighbours};

/// Tolerance of the plane test, relative to the nearer inverse depth.
pub const PLANAR: f64 = 0.05;

/// Relative depth step between neighbours above which build separates surfaces (`--jump`).
pub const JUMP: f64 = 0.08;

/// Relative depth step above which two neighbours of one layer are not one surface for `validate`
/// (its default) and for `convert`, which separates them so that its output validates.
pub const LAYER_JUMP: f64 = 0.5;

/// Relative depth step above which the mesher leaves two neighbouring vertices unconnected: looser
/// than [`JUMP`], since a layer built with it is already one surface and only its remaining
/// discontinuities (object silhouettes inside a sparse layer, layers from elsewhere) must stay open.
pub const MESH_JUMP: f64 = 0.5;

/// Whether depths `a` and `b` differ by more than `jump` relative to the nearer: `|a − b| > jump ·
/// min(a, b)` (false when either is NaN).
#[inline]
pub fn steps_apart(a: f64, b: f64, jump: f64) -> bool {
    (a - b).abs() > jump * a.min(b)
}

/// Whether three depths along a line of pixels — `back`, `mid`, `next` — lie on one plane: inverse
/// depth is linear along a plane (`1/d = n·dir / h`), so `1/next` is extrapolated from `1/back` and
/// `1/mid` and compared relative to the nearer of `mid`, `next` (the scale at which a plane's `1/d`
/// is smooth).
#[inline]
pub fn continues_plane(mid: f64, next: f64, back: f64, tol: f64) -> bool {
    let extrapolated = 2.0 / mid - 1.0 / back;
    extrapolated.is_finite() && (extrapolated - 1.0 / next).abs() * mid.min(next) <= tol
}

/// Whether depth `a` and its neighbour's depth `b` (both `> 0`, `+inf` allowed) lie on one surface:
/// both infinitely far; or a relative step `|a − b| / min(a, b)` within `jump`; or the surface runs on
/// as a plane (within `tol`, [`continues_plane`]) from either side — from `behind_a` (the pixel on
/// the far side of `a`) through `a` to `b`, or from `beyond_b` through `b` to `a`. Ground seen at a
/// grazing angle changes depth by more than any step threshold a row, smoothly; one side suffices,
/// since the last row of a grazing plane has what it occludes on its far side.
#[inline]
pub fn continuous(a: f64, b: f64, behind_a: Option<f64>, beyond_b: Option<f64>, jump: f64, tol: f64) -> bool {
    continuous_with(a, b, || behind_a, || beyond_b, jump, tol)
}

/// [`continuous`] with the depths beyond the pair looked up only when the step alone does not
/// decide (most pairs: a hot loop over every pixel's 8 links saves the lookups).
#[inline]
pub fn continuous_with(
    a: f64,
    b: f64,
    behind_a: impl FnOnce() -> Option<f64>,
    beyond_b: impl FnOnce() -> Option<f64>,
    jump: f64,
    tol: f64,
) -> bool {
    if a.is_infinite() || b.is_infinite() {
        return a == b;
    }
    if (a - b).abs() <= jump * a.min(b) {
        return true;
    }
    let usable = |d: &f64| *d > 0.0 && d.is_finite();
    behind_a().filter(usable).is_some_and(|d| continues_plane(a, b, d, tol))
        || beyond_b().filter(usable).is_some_and(|d| continues_plane(b, a, d, tol))
}

/// The 4-neighbour pairs `(p, q)`, `p < q`, starting in row `y` of a canvas, that are not one
/// surface by [`continuous`] (relative step `jump`, plane tolerance [`PLANAR`], the pixels beside
/// the pair as its plane test's ends), across the equirect seam, over the poles and across cube-face
/// edges; each is passed to `visit`. `depth` is `None` outside the layer, `+inf` for infinitely far
/// content. Callers walk the rows (in parallel) and keep what they need: a count, or the pixels.
pub fn row_breaks(
    nb: &Neighbours,
    depth: impl Fn(usize) -> Option<f64>,
    jump: f64,
    y: usize,
    mut visit: impl FnMut(usize, usize),
) {
    let w = nb.width();
    for x in 0..w {
        let p = y * w + x;
        let Some(a) = depth(p) else { continue };
        // Every pair once, from its lower index: over the poles and cube-face edges "right" and
        // "down" are not the only directions a pair is seen from.
        for k in 0..4 {
            let Some(q) = nb.get_at(x, y, k).filter(|&q| q > p) else { continue };
            let Some(b) = depth(q) else { continue };
            // The plain step test first: the plane test's two lookups are rarely needed.
            if continuous(a, b, None, None, jump, PLANAR) {
                continue;
            }
            let behind = nb.get_at(x, y, opposite(k)).and_then(&depth);
            let beyond = nb.get2_at(x, y, k).and_then(&depth);
            if !continuous(a, b, behind, beyond, jump, PLANAR) {
                visit(p, q);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_planes_and_infinity() {
        assert!(continuous(1.0, 1.05, None, None, JUMP, PLANAR));
        assert!(!continuous(1.0, 1.5, None, None, JUMP, PLANAR));
        // Ground z = −1 along a column: d = 1 / sin(elevation) at 10°, 8°, 6° below the horizon.
        let d = |deg: f64| 1.0 / deg.to_radians().sin();
        assert!((d(6.0) - d(8.0)) / d(8.0) > JUMP);
        assert!(continuous(d(8.0), d(6.0), Some(d(10.0)), None, JUMP, PLANAR));
        assert!(continuous(d(6.0), d(8.0), None, Some(d(10.0)), JUMP, PLANAR));
        // A wall 3 m away behind the ground's last row is not the ground's plane.
        assert!(!continuous(d(6.0), 3.0, Some(d(8.0)), None, JUMP, PLANAR));
        assert!(continuous(f64::INFINITY, f64::INFINITY, None, None, JUMP, PLANAR));
        assert!(!continuous(1e9, f64::INFINITY, Some(1e9), None, JUMP, PLANAR));
        // Scale-free.
        assert_eq!(
            continuous(1e-6, 1.5e-6, Some(0.9e-6), None, JUMP, PLANAR),
            continuous(1e6, 1.5e6, Some(0.9e6), None, JUMP, PLANAR)
        );
    }
}
