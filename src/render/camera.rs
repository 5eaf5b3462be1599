//! Output cameras (spec §9.2): a pinhole perspective camera (eye, look-at, up, horizontal field of
//! view; seed 002's model) and an equirect camera (a new panorama seen from another centre).
//!
//! A camera has two jobs: [`Camera::to_camera`] gives the rigid world → camera transform applied
//! to every reprojected point, and [`Camera::project`] maps a camera-space point (or a direction,
//! for content at infinity) to continuous output pixel coordinates. [`Camera::ray`] is the inverse
//! used by ground-truth ray casting, so both sides of an evaluation use the same pixel centres.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DMat4, DVec2, DVec3};

use super::checks::{check_size, finite, EQUIRECT, VR180};
pub use super::checks::{MAX_PIXELS, MAX_SIDE};
pub use super::ods::{OdsEye, PoleMerge};
use super::RenderError;

/// A camera-space point is projected only if it lies at least this far (cosine of its angle with
/// the optical axis) in front of the eye: keeps `x/z` finite for points grazing the eye plane.
const MIN_FORWARD_COS: f64 = 1e-6;
/// Content at infinity is projected as a point this far along its direction (camera units): far
/// enough that an ODS eye's offset turns it by < 1e-13 rad, a power of two so that scaling keeps
/// the other cameras' projections bit for bit.
pub(crate) const AT_INFINITY: f64 = (1u64 << 40) as f64;

/// A pinhole camera: `x` right, `y` down in the image; camera space is `x` right, `y` up, `z`
/// forward (the viewing direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perspective {
    /// Camera centre in world coordinates, metres.
    pub eye: DVec3,
    /// Unit right, up and forward vectors in the world (orthonormal, right-handed view frame).
    pub right: DVec3,
    /// Unit up vector of the image, orthogonal to `right` and `forward`.
    pub up: DVec3,
    /// Unit viewing direction (from the eye towards the look-at point).
    pub forward: DVec3,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Focal length in pixels: `(width / 2) / tan(hfov / 2)`.
    pub focal: f64,
}

/// An equirect output camera: the world's axes (`+Z` up, azimuth from `+X` towards `+Y`), the
/// POMC pixel-centre convention, centred at `eye`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EquirectCamera {
    /// Centre of the output panorama in world coordinates, metres.
    pub eye: DVec3,
    /// Image width, pixels (twice the height).
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
}

/// One eye of a VR180 image: a half equirect, 180° × 180° around `forward`, in the orientation
/// players show (the centre column looks along `forward`, moving right turns right; row 0 looks
/// along `up`). Camera space is `(−forward, −right, up)`, in which the image is the middle half of
/// a `2·width`-wide equirect of spec §3 — a mirror, so the mesh rasteriser draws it as one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfEquirect {
    /// The eye in world coordinates, metres.
    pub eye: DVec3,
    /// Unit right, up and forward vectors in the world (orthonormal).
    pub right: DVec3,
    /// Unit up vector: the image's top row.
    pub up: DVec3,
    /// Unit viewing direction: the image's centre.
    pub forward: DVec3,
    /// Image width, pixels (equal to the height: 180° each way).
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
}

impl HalfEquirect {
    /// A half equirect of `side × side` pixels (`side` even) at `eye` looking along `forward`
    /// (`up` need not be orthogonal to it, as for [`Perspective::new`]).
    pub fn new(eye: DVec3, forward: DVec3, up: DVec3, side: usize) -> Result<Self, RenderError> {
        // Even, so that the mesh method's full equirect of twice the width has the half in whole
        // columns; that full width must fit the limits too.
        check_size(side.saturating_mul(2), side)?;
        if side % 2 != 0 {
            return Err(RenderError::BadSize { width: side, height: side, need: VR180 });
        }
        let p = Perspective::new(DVec3::ZERO, finite(forward, "look direction")?, up, 90.0, 1, 1)?;
        let eye = finite(eye, "eye")?;
        Ok(HalfEquirect { eye, right: p.right, up: p.up, forward: p.forward, width: side, height: side })
    }

    /// World → camera rotation (rows: −forward, −right, up).
    fn rotation(&self) -> DMat4 {
        DMat4::from_cols(
            (-self.forward).extend(0.0),
            (-self.right).extend(0.0),
            self.up.extend(0.0),
            glam::DVec4::W,
        )
        .transpose()
    }
}

/// Any output camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// A pinhole perspective view.
    Perspective(Perspective),
    /// A full equirect panorama from another centre.
    Equirect(EquirectCamera),
    /// One eye of an omnidirectional stereo panorama.
    Ods(OdsEye),
    /// One eye of a VR180 image.
    HalfEquirect(HalfEquirect),
}

impl Perspective {
    /// A camera at `eye` looking at `look_at`. `up` need not be orthogonal to the view direction;
    /// when it is (nearly) parallel to it — e.g. looking straight at a pole with the default `+Z`
    /// up — the world axis least aligned with the view is used instead, so every viewing direction
    /// gives a camera.
    pub fn new(
        eye: DVec3,
        look_at: DVec3,
        up: DVec3,
        hfov_deg: f64,
        width: usize,
        height: usize,
    ) -> Result<Self, RenderError> {
        check_size(width, height)?;
        let (eye, look_at, up) = (finite(eye, "eye")?, finite(look_at, "look-at")?, finite(up, "up")?);
        if !(hfov_deg > 0.0 && hfov_deg < 180.0) {
            return Err(RenderError::BadCamera(format!(
                "horizontal field of view {hfov_deg}° must lie strictly between 0 and 180"
            )));
        }
        let forward = (look_at - eye).try_normalize().ok_or_else(|| {
            RenderError::BadCamera(format!("look-at {look_at} coincides with the eye {eye}"))
        })?;
        let side = forward.cross(up);
        let right = if side.length() > 1e-9 * up.length() && side.length() > 0.0 {
            side.normalize()
        } else {
            forward.cross(least_aligned_axis(forward)).normalize()
        };
        let up = right.cross(forward);
        let focal = width as f64 / 2.0 / (hfov_deg.to_radians() / 2.0).tan();
        Ok(Perspective { eye, right, up, forward, width, height, focal })
    }

    /// Half-angle of the cone around `forward` that contains the whole image (its corners).
    pub fn half_diagonal_angle(&self) -> f64 {
        (self.width as f64 / 2.0).hypot(self.height as f64 / 2.0).atan2(self.focal)
    }
}

/// The world axis most orthogonal to `d` (a fallback up vector).
fn least_aligned_axis(d: DVec3) -> DVec3 {
    let a = d.abs();
    if a.x <= a.y && a.x <= a.z {
        DVec3::X
    } else if a.y <= a.z {
        DVec3::Y
    } else {
        DVec3::Z
    }
}

impl EquirectCamera {
    /// An equirect output of `width × height` (2:1) centred at `eye`.
    pub fn new(eye: DVec3, width: usize, height: usize) -> Result<Self, RenderError> {
        check_size(width, height)?;
        if width != 2 * height {
            return Err(RenderError::BadSize { width, height, need: EQUIRECT });
        }
        Ok(EquirectCamera { eye: finite(eye, "eye")?, width, height })
    }
}

impl Camera {
    /// The same view at `factor` times the resolution along each axis (sub-samples of a pixel are
    /// the pixels of the finer grid inside it); `None` beyond the size limits.
    pub fn scaled(&self, factor: usize) -> Option<Camera> {
        let (w, h) = (self.width().checked_mul(factor)?, self.height().checked_mul(factor)?);
        check_size(w, h).ok()?;
        Some(match *self {
            Camera::Perspective(c) => {
                Camera::Perspective(Perspective { width: w, height: h, focal: c.focal * factor as f64, ..c })
            }
            Camera::Equirect(c) => Camera::Equirect(EquirectCamera { width: w, height: h, ..c }),
            Camera::Ods(c) => Camera::Ods(OdsEye { width: w, height: h, ..c }),
            Camera::HalfEquirect(c) => Camera::HalfEquirect(HalfEquirect { width: w, height: h, ..c }),
        })
    }

    /// Output width, pixels.
    pub fn width(&self) -> usize {
        match self {
            Camera::Perspective(c) => c.width,
            Camera::Equirect(c) => c.width,
            Camera::Ods(c) => c.width,
            Camera::HalfEquirect(c) => c.width,
        }
    }

    /// Output height, pixels.
    pub fn height(&self) -> usize {
        match self {
            Camera::Perspective(c) => c.height,
            Camera::Equirect(c) => c.height,
            Camera::Ods(c) => c.height,
            Camera::HalfEquirect(c) => c.height,
        }
    }

    /// Camera centre in world coordinates, metres.
    pub fn eye(&self) -> DVec3 {
        match self {
            Camera::Perspective(c) => c.eye,
            Camera::Equirect(c) => c.eye,
            Camera::Ods(c) => c.eye,
            Camera::HalfEquirect(c) => c.eye,
        }
    }

    /// Whether every camera-space point lies outside one side of the view frustum widened by
    /// `margin` output pixels — then so does their convex hull, which is never seen (points behind
    /// the eye included). Always `false` for equirect outputs, which see every direction; for a
    /// half equirect, whether every point lies behind it beyond the margin's angle (a cone of
    /// half-angle under 90° is convex, so it holds the hull).
    pub fn hull_outside(&self, pts: &[DVec3], margin: f64) -> bool {
        if let Camera::HalfEquirect(c) = self {
            // Twice the margin's angle: near the poles a splat's columns widen by 1 / sin θ, so it
            // reaches farther in azimuth than its radius in rows.
            let beyond = (2.0 * margin * PI / c.height as f64).min(FRAC_PI_2).sin();
            // Camera space x is −forward: behind is x > 0.
            return pts.iter().all(|p| p.x > beyond * p.length());
        }
        let Camera::Perspective(c) = self else { return false };
        let (hw, hh) = (c.width as f64 / 2.0 + margin, c.height as f64 / 2.0 + margin);
        let all = |f: &dyn Fn(DVec3) -> f64| pts.iter().all(|&p| f(p) > 0.0);
        // Behind the eye (the four side planes meet there, so they alone would keep such a hull).
        all(&|p| -p.z)
            || all(&|p| c.focal * p.x - hw * p.z)
            || all(&|p| -c.focal * p.x - hw * p.z)
            || all(&|p| c.focal * p.y - hh * p.z)
            || all(&|p| -c.focal * p.y - hh * p.z)
    }

    /// Whether output columns wrap around (the equirect seam).
    pub fn wraps(&self) -> bool {
        matches!(self, Camera::Equirect(_) | Camera::Ods(_))
    }

    /// Distance from where the ray that sees camera-space point `p` starts to `p`: its length, but
    /// for an ODS eye, whose rays start on the viewing circle.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        match self {
            Camera::Ods(c) => c.distance(p),
            _ => p.length(),
        }
    }

    /// [`Camera::project`] and [`Camera::distance`] of `p` at once (one solve for an ODS eye); the
    /// distance is `p`'s length when it does not project.
    #[inline]
    pub fn project_and_distance(&self, p: DVec3) -> (Option<DVec2>, f64) {
        match self {
            Camera::Ods(c) => match c.project_and_distance(p) {
                Some((q, t)) => (Some(q), t),
                None => (None, p.length()),
            },
            _ => (self.project(p), p.length()),
        }
    }

    /// Camera-space start of the ray through continuous output pixel `(x, y)`: the eye, but for an
    /// ODS eye.
    #[inline]
    pub fn origin(&self, x: f64, y: f64) -> DVec3 {
        match self {
            Camera::Ods(c) => c.origin(x, y),
            _ => DVec3::ZERO,
        }
    }

    /// World → camera space: camera space has the eye at the origin; rigid, but a mirror for a
    /// [`HalfEquirect`] (its axes are `−forward, −right, up`).
    pub fn to_camera(&self) -> DMat4 {
        match self {
            Camera::Perspective(c) => {
                let rot = DMat4::from_cols(
                    c.right.extend(0.0),
                    c.up.extend(0.0),
                    c.forward.extend(0.0),
                    glam::DVec4::W,
                )
                .transpose();
                rot * DMat4::from_translation(-c.eye)
            }
            Camera::Equirect(c) => DMat4::from_translation(-c.eye),
            Camera::Ods(c) => DMat4::from_translation(-c.eye),
            Camera::HalfEquirect(c) => c.rotation() * DMat4::from_translation(-c.eye),
        }
    }

    /// Continuous output pixel coordinates of a camera-space point or direction; `None` when it
    /// is behind (or beside) a perspective camera or at the eye itself. Never NaN.
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        match self {
            Camera::Perspective(c) => {
                let len = p.length();
                if p.z.is_nan() || p.z <= MIN_FORWARD_COS * len || !len.is_finite() {
                    return None;
                }
                let q = DVec2::new(
                    c.width as f64 / 2.0 + c.focal * p.x / p.z,
                    c.height as f64 / 2.0 - c.focal * p.y / p.z,
                );
                q.is_finite().then_some(q)
            }
            Camera::Equirect(c) => {
                if !p.is_finite() || p == DVec3::ZERO {
                    return None;
                }
                let mut phi = p.y.atan2(p.x);
                if phi < 0.0 {
                    phi += TAU;
                }
                let theta = p.x.hypot(p.y).atan2(p.z);
                let x = (phi / TAU * c.width as f64).min(c.width as f64 - 1e-9);
                Some(DVec2::new(x.max(0.0), theta / PI * c.height as f64))
            }
            Camera::Ods(c) => c.project(p),
            Camera::HalfEquirect(c) => {
                if !p.is_finite() || p == DVec3::ZERO {
                    return None;
                }
                // Azimuth in (−π, π] from −forward's opposite: 0 straight ahead, growing to the right.
                let phi = (-p.y).atan2(-p.x);
                let theta = p.x.hypot(p.y).atan2(p.z);
                let (w, h) = (c.width as f64, c.height as f64);
                Some(DVec2::new(w / 2.0 + phi / PI * w, theta / PI * h))
            }
        }
    }

    /// Horizontal metric of the output at row coordinate `y`: how much one output column is worth
    /// compared with one row. 1 for perspective images; `sin θ` for equirect ones (columns shrink
    /// towards the poles), clamped at the first row's centre so it never reaches 0.
    #[inline]
    pub fn x_scale(&self, y: f64) -> f64 {
        match self {
            Camera::Perspective(_) => 1.0,
            Camera::Equirect(EquirectCamera { height, .. })
            | Camera::Ods(OdsEye { height, .. })
            | Camera::HalfEquirect(HalfEquirect { height, .. }) => {
                let h = *height as f64;
                (PI * y / h).sin().max((PI * 0.5 / h).sin())
            }
        }
    }

    /// World-space unit direction through continuous output pixel `(x, y)` (pixel centres at
    /// `i + 0.5`); the ray starts at [`Camera::origin`].
    pub fn ray(&self, x: f64, y: f64) -> DVec3 {
        match self {
            Camera::Perspective(c) => (c.forward * c.focal
                + c.right * (x - c.width as f64 / 2.0)
                + c.up * (c.height as f64 / 2.0 - y))
                .normalize(),
            Camera::Equirect(EquirectCamera { width, height, .. })
            | Camera::Ods(OdsEye { width, height, .. }) => {
                let phi = TAU * x / *width as f64;
                let theta = PI * y / *height as f64;
                let (st, ct) = theta.sin_cos();
                let (sp, cp) = phi.sin_cos();
                DVec3::new(st * cp, st * sp, ct)
            }
            Camera::HalfEquirect(c) => {
                let phi = PI * (x / c.width as f64 - 0.5);
                let theta = PI * y / c.height as f64;
                let (st, ct) = theta.sin_cos();
                let (sp, cp) = phi.sin_cos();
                (c.forward * (st * cp) + c.right * (st * sp) + c.up * ct).normalize()
            }
        }
    }

    /// The cone that contains everything the camera sees: world axis and half-angle; `None` when
    /// it sees every direction.
    pub fn view_cone(&self) -> Option<(DVec3, f64)> {
        match self {
            Camera::Perspective(c) => Some((c.forward, c.half_diagonal_angle())),
            // Everything in view is within 90° of forward (its edges and poles are at 90°).
            Camera::HalfEquirect(c) => Some((c.forward, std::f64::consts::FRAC_PI_2)),
            Camera::Equirect(_) | Camera::Ods(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(eye: DVec3, at: DVec3, up: DVec3) -> Camera {
        Camera::Perspective(Perspective::new(eye, at, up, 60.0, 96, 54).unwrap())
    }

    /// A half equirect sees the front hemisphere: hulls wholly behind it beyond the margin are
    /// outside, hulls across its edge or the poles are not.
    #[test]
    fn half_equirect_hulls_behind_are_outside() {
        let c = Camera::HalfEquirect(HalfEquirect::new(DVec3::ZERO, DVec3::X, DVec3::Z, 64).unwrap());
        let to = |p: DVec3| c.to_camera().transform_point3(p);
        let behind = [DVec3::new(-1.0, -1.0, 0.2), DVec3::new(-1.0, 1.0, 0.2), DVec3::new(-2.0, 0.0, -1.0)];
        let edge = [DVec3::new(-0.01, 1.0, 0.0), DVec3::new(-0.01, 1.0, 0.1), DVec3::new(-0.02, 1.0, 0.0)];
        let pole = [DVec3::new(-0.5, 0.0, 1.0), DVec3::new(0.5, 0.0, 1.0), DVec3::new(0.0, 0.5, 1.0)];
        assert!(c.hull_outside(&behind.map(to), 1.0));
        // 0.01–0.02 rad behind the edge: within a margin of one pixel (culled beyond 2π / 64 rad).
        assert!(!c.hull_outside(&edge.map(to), 1.0));
        assert!(c.hull_outside(&edge.map(to), 0.0));
        assert!(!c.hull_outside(&pole.map(to), 1.0));
    }

    #[test]
    fn hulls_behind_the_eye_or_beside_the_frustum_are_outside() {
        let c = cam(DVec3::ZERO, DVec3::X, DVec3::Z);
        // Camera space: z forward. A square behind the eye spanning left and right, one beside the
        // frustum in the camera plane, one straddling it across the view, one in view.
        let behind = [DVec3::new(-1.0, -1.0, -0.5), DVec3::new(1.0, -1.0, -0.5), DVec3::new(1.0, 1.0, -2.0)];
        let beside = [DVec3::new(5.0, 0.0, 1e-9), DVec3::new(6.0, 1.0, -1e-3), DVec3::new(5.0, -1.0, 0.1)];
        let across = [DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 0.0, 2.0), DVec3::new(0.0, 0.5, 2.0)];
        let ahead = [DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.1, 0.0, 1.0), DVec3::new(0.0, 0.1, 1.0)];
        assert!(c.hull_outside(&behind, 1.0));
        assert!(c.hull_outside(&beside, 1.0));
        assert!(!c.hull_outside(&across, 1.0));
        assert!(!c.hull_outside(&ahead, 1.0));
    }

    #[test]
    fn centre_pixel_is_the_look_at_direction() {
        let c = cam(DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 2.0, 3.0), DVec3::Z);
        let p = c.to_camera().transform_point3(DVec3::new(4.0, 2.0, 3.0));
        let q = c.project(p).unwrap();
        assert!((q - DVec2::new(48.0, 27.0)).length() < 1e-9, "{q}");
        assert!((c.ray(48.0, 27.0) - DVec3::X).length() < 1e-12);
        // Up in the world is up in the image (smaller y); +Y is to the left when looking along +X.
        let up = c.project(c.to_camera().transform_point3(DVec3::new(4.0, 2.0, 3.5))).unwrap();
        assert!(up.y < 27.0);
        let left = c.project(c.to_camera().transform_point3(DVec3::new(4.0, 2.5, 3.0))).unwrap();
        assert!(left.x < 48.0);
    }

    #[test]
    fn ray_and_project_are_inverse() {
        for c in [
            cam(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.3), DVec3::Z),
            Camera::Equirect(EquirectCamera::new(DVec3::new(0.1, 0.2, 0.3), 64, 32).unwrap()),
            Camera::HalfEquirect(
                HalfEquirect::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 0.3), DVec3::Z, 48).unwrap(),
            ),
        ] {
            for (x, y) in [(0.5, 0.5), (10.25, 20.75), (40.0, 17.0)] {
                let d = c.ray(x, y);
                let q = c.project(c.to_camera().transform_vector3(d)).unwrap();
                assert!((q - DVec2::new(x, y)).length() < 1e-9, "{c:?} {x},{y} -> {q}");
            }
        }
    }

    /// VR180 eyes are seen from inside: the centre looks forward, the right edge right, the top up.
    #[test]
    fn half_equirect_is_seen_from_inside() {
        let c = Camera::HalfEquirect(HalfEquirect::new(DVec3::ZERO, DVec3::Y, DVec3::Z, 100).unwrap());
        assert!((c.ray(50.0, 50.0) - DVec3::Y).length() < 1e-12);
        // Looking along +Y with +Z up, right is +X.
        assert!((c.ray(100.0, 50.0) - DVec3::X).length() < 1e-12);
        assert!((c.ray(25.0, 0.0) - DVec3::Z).length() < 1e-12);
        let right = c.project(c.to_camera().transform_vector3(DVec3::new(1.0, 1.0, 0.0))).unwrap();
        assert!((right - DVec2::new(75.0, 50.0)).length() < 1e-9, "{right}");
    }

    #[test]
    fn looking_at_a_pole_falls_back_to_another_up() {
        let c = Perspective::new(DVec3::ZERO, DVec3::Z, DVec3::Z, 90.0, 10, 10).unwrap();
        assert!(c.right.is_finite() && (c.right.length() - 1.0).abs() < 1e-12);
        assert!(c.up.dot(c.forward).abs() < 1e-12);
    }

    #[test]
    fn bad_cameras_are_typed_errors() {
        let bad = [
            Perspective::new(DVec3::ZERO, DVec3::ZERO, DVec3::Z, 60.0, 10, 10),
            Perspective::new(DVec3::ZERO, DVec3::X, DVec3::Z, 180.0, 10, 10),
            Perspective::new(DVec3::ZERO, DVec3::X, DVec3::Z, f64::NAN, 10, 10),
            Perspective::new(DVec3::NAN, DVec3::X, DVec3::Z, 60.0, 10, 10),
            Perspective::new(DVec3::ZERO, DVec3::X, DVec3::Z, 60.0, 0, 10),
        ];
        for b in bad {
            assert!(b.is_err());
        }
        assert!(EquirectCamera::new(DVec3::ZERO, 30, 10).is_err());
        // Behind the camera and at the eye: no projection.
        let c = cam(DVec3::ZERO, DVec3::X, DVec3::Z);
        assert!(c.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
        assert!(c.project(DVec3::ZERO).is_none());
        assert!(c.project(DVec3::new(1.0, 0.0, 1e-12)).is_none());
    }
}
