//! A layer pixel's footprint: the surface between its centre and its neighbours' (bilinear
//! towards linked neighbours, extrapolated across a border), and the border strips that only fill.

use glam::DVec3;

use super::{offset_index, Pt};
use crate::render::BORDER_FOOTPRINT;

/// What [`super::LayerCtx::footprint`] finds of a pixel's footprint.
pub(super) struct Footprint<'p> {
    pub linked: [Option<&'p Pt>; 8],
    pub own: [Option<DVec3>; 8],
    pub sx: f64,
    pub sy: f64,
}

/// The surface point and colour at offset `(ox, oy)` ∈ (-½, ½)² from the pixel centre: bilinear
/// over the quad towards the neighbours on that side. A neighbour across a discontinuity (or
/// outside the layer) is replaced by the mirror image of the opposite neighbour (`2c − n`), or by
/// the pixel itself: the pixel still covers its whole footprint — so layers that abut without a
/// depth jump (an object standing on the floor) leave no crack between them — but never reaches
/// into the next pixel across a discontinuity. Synthesised corners take the pixel's colour.
#[inline]
pub(super) fn interpolate(
    c: &Pt,
    linked: &[Option<&Pt>; 8],
    own: &[Option<DVec3>; 8],
    ox: f64,
    oy: f64,
) -> (DVec3, [f32; 3]) {
    let (sx, sy) = (if ox >= 0.0 { 1 } else { -1 }, if oy >= 0.0 { 1 } else { -1 });
    let side = |dx: i64, dy: i64| -> (DVec3, [f32; 3]) {
        let k = offset_index(dx, dy);
        match (linked[k], linked[offset_index(-dx, -dy)]) {
            (Some(n), _) => (n.cam, n.rgb),
            (None, Some(m)) => (c.cam * 2.0 - m.cam, c.rgb),
            (None, None) => (own[k].unwrap_or(c.cam), c.rgb),
        }
    };
    let h = side(sx, 0);
    let v = side(0, sy);
    let d = match linked[offset_index(sx, sy)] {
        Some(n) => (n.cam, n.rgb),
        None => (h.0 + v.0 - c.cam, c.rgb),
    };
    let (wx, wy) = (ox.abs(), oy.abs());
    let w = [(1.0 - wx) * (1.0 - wy), wx * (1.0 - wy), (1.0 - wx) * wy, wx * wy];
    let pts = [(c.cam, c.rgb), h, v, d];
    let mut cam = DVec3::ZERO;
    let mut rgb = [0.0f32; 3];
    for (p, &wk) in pts.iter().zip(&w) {
        cam += p.0 * wk;
        for (out, v) in rgb.iter_mut().zip(p.1) {
            *out += v * wk as f32;
        }
    }
    (cam, rgb)
}

/// Whether footprint offset `(ox, oy)` lies in a border strip past `[−½, ½]²`: its samples cover
/// nothing ([`crate::render::accum::Cell::cover`] 0), so they show only where nothing lies behind them (a
/// crack between two layers' edges), never over what is behind a silhouette.
#[inline]
pub(super) fn fills_only(ox: f64, oy: f64) -> bool {
    ox.abs() > 0.5 || oy.abs() > 0.5
}

/// The footprint's extent along one canvas axis (`plus`, `minus`: the neighbours' offset indices):
/// `[−½, ½]`, but [`BORDER_FOOTPRINT`] towards a neighbour the pixel is not linked to while linked
/// to the other (as the mesh method's border quads: the edges of two layers that meet, each
/// sampled at pixel centres, overlap rather than leave a crack). A line one pixel wide keeps
/// `[−½, ½]`.
pub(super) fn extent(linked: &[Option<&Pt>; 8], plus: usize, minus: usize) -> [f64; 2] {
    match (linked[minus].is_some(), linked[plus].is_some()) {
        (false, false) => [-0.5, 0.5],
        (m, p) => [if m { -0.5 } else { -BORDER_FOOTPRINT }, if p { 0.5 } else { BORDER_FOOTPRINT }],
    }
}

/// A rectangle `[x0, x0 + w] × [y0, y0 + h]` of a pixel's footprint, in offsets from its centre.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub w: f64,
    pub h: f64,
}

impl Rect {
    /// Corners in cyclic order.
    pub(super) fn corners(&self) -> [(f64, f64); 4] {
        let (x1, y1) = (self.x0 + self.w, self.y0 + self.h);
        [(self.x0, self.y0), (x1, self.y0), (x1, y1), (self.x0, y1)]
    }
}
