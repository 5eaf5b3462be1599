//! The cameras of one splatting pass: what each sees (view-cone culling) and where a point lands in
//! each (one ODS solve for both eyes of a stereo camera).

use glam::{DMat3, DMat4, DVec2, DVec3};

use super::row_scale;
use crate::render::camera::{Camera, OdsEye};

/// Culling of tiles against the camera's view cone, in the panorama's local frame (valid when
/// LocalToWorld is a similarity, which preserves angles).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cull {
    axis: DVec3,
    /// Half-angle of the view cone plus margins, radians.
    half_angle: f64,
    /// Distance of the eye from the panorama centre, local units.
    offset: f64,
}

impl Cull {
    pub(super) fn new(camera: &Camera, local_to_world: DMat4) -> Option<Cull> {
        let (axis_world, half) = camera.view_cone()?;
        let lin = DMat3::from_mat4(local_to_world);
        let m = lin.transpose() * lin;
        let s2 = (m.x_axis.x + m.y_axis.y + m.z_axis.z) / 3.0;
        let off = (m - DMat3::from_diagonal(DVec3::splat(s2)))
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        if s2.is_nan() || s2 <= 0.0 || off > 1e-9 * s2 {
            return None;
        }
        let inv = local_to_world.inverse();
        let axis = inv.transform_vector3(axis_world).try_normalize()?;
        let eye = inv.transform_point3(camera.eye());
        eye.is_finite().then_some(Cull { axis, half_angle: half + 0.02, offset: eye.length() })
    }

    /// Whether no point of a tile (directions within `spread` of `centre`, finite depths at least
    /// `zmin`, or infinitely far) can be seen.
    pub(super) fn outside(&self, centre: DVec3, spread: f64, zmin: f64) -> bool {
        let parallax = if zmin.is_infinite() {
            0.0
        } else if self.offset < zmin {
            (self.offset / zmin).asin()
        } else {
            return false;
        };
        let angle = centre.dot(self.axis).clamp(-1.0, 1.0).acos();
        angle - spread - parallax > self.half_angle
    }
}

/// Most views splatted in one pass: the two eyes of a stereo camera.
pub const MAX_VIEWS: usize = 2;

/// One value per view of a pass.
pub(super) type PerView<T> = [T; MAX_VIEWS];

/// The cameras of one pass, which share one camera space (so the surface points of a layer pixel
/// and of its sub-samples are computed once for all of them), and how a point projects into each.
pub(super) struct Views<'a> {
    pub(super) cameras: &'a [Camera],
    /// The two eyes of one ODS camera (the left one; the right is its mirror): one solve serves both.
    ods_pair: Option<OdsEye>,
    /// Per view: [`Camera::x_scale`] of each output row's centre (no trigonometry in inner loops).
    pub(super) scales: Vec<Vec<f64>>,
}

impl<'a> Views<'a> {
    pub(super) fn new(cameras: &'a [Camera]) -> Self {
        let ods_pair = match cameras {
            [Camera::Ods(l), Camera::Ods(r)] if *r == l.mirror() => Some(*l),
            _ => None,
        };
        let scales =
            cameras.iter().map(|c| (0..c.height()).map(|y| c.x_scale(y as f64 + 0.5)).collect()).collect();
        Views { cameras, ods_pair, scales }
    }

    #[inline]
    pub(super) fn n(&self) -> usize {
        self.cameras.len()
    }

    /// Output pixel coordinates of camera-space point `p` in each view, where it projects.
    #[inline]
    pub(super) fn project(&self, p: DVec3) -> PerView<Option<DVec2>> {
        if self.ods_pair.is_some() {
            return self.project_and_distance(p).map(|v| v.map(|(q, _)| q));
        }
        let mut out = [None; MAX_VIEWS];
        for (o, c) in out.iter_mut().zip(self.cameras) {
            *o = c.project(p);
        }
        out
    }

    /// [`Views::project`] and the distance along the ray that sees `p` in each view.
    #[inline]
    pub(super) fn project_and_distance(&self, p: DVec3) -> PerView<Option<(DVec2, f64)>> {
        if let Some(eye) = &self.ods_pair {
            return match eye.project_pair(p) {
                Some(([l, r], t)) => [Some((l, t)), Some((r, t))],
                None => [None; MAX_VIEWS],
            };
        }
        let mut out = [None; MAX_VIEWS];
        for (o, c) in out.iter_mut().zip(self.cameras) {
            let (q, t) = c.project_and_distance(p);
            *o = q.map(|q| (q, t));
        }
        out
    }

    /// Output-space vector from `a` to `b` in view `v`, with the equirect metric.
    #[inline]
    pub(super) fn delta(&self, v: usize, a: DVec2, b: DVec2) -> DVec2 {
        let camera = &self.cameras[v];
        let mut dx = b.x - a.x;
        if camera.wraps() {
            let w = camera.width() as f64;
            dx -= w * (dx / w).round();
        }
        DVec2::new(dx * row_scale(&self.scales[v], a.y), b.y - a.y)
    }

    /// Output-space distance between two projected points of view `v`.
    #[inline]
    pub(super) fn gap(&self, v: usize, a: DVec2, b: DVec2) -> f64 {
        self.delta(v, a, b).length()
    }

    /// Whether a pixel's splat footprint (centre `q`, reach `reach` pixels) misses view `v`.
    pub(super) fn off_screen(&self, v: usize, q: DVec2, reach: f64) -> bool {
        let camera = &self.cameras[v];
        if camera.wraps() {
            return false;
        }
        let reach = reach + 1.0;
        let (w, h) = (camera.width() as f64, camera.height() as f64);
        q.x + reach < 0.0 || q.y + reach < 0.0 || q.x - reach > w || q.y - reach > h
    }
}
