//! Stereo outputs (spec §9.2, docs/stereo.md): two eye cameras and how their frames share one image.

use glam::DVec3;

use super::camera::{Camera, HalfEquirect, OdsEye, PoleMerge};
use super::checks::{finite, VR180};
use super::frame::Frame;
use super::RenderError;

crate::choice::choices! {
    /// Where each eye goes in a stereo image.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum StereoLayout (default Tb) {
        /// Top-bottom (over-under): the left eye on top, as YouTube and most players expect of 360°.
        Tb = "tb",
        /// Side by side: the left eye on the left.
        Sbs = "sbs",
    }
}

impl StereoLayout {
    /// The size of one eye in a whole image of `width × height`; `None` when it does not split.
    pub fn eye_size(self, width: usize, height: usize) -> Option<(usize, usize)> {
        match self {
            StereoLayout::Tb => (height % 2 == 0).then_some((width, height / 2)),
            StereoLayout::Sbs => (width % 2 == 0).then_some((width / 2, height)),
        }
    }
}

crate::choice::choices! {
    /// How the columns of a panoramic output run.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Orientation (default World) {
        /// The world axes of `--camera equirect` (spec §3: column 0 at azimuth +X, azimuth growing
        /// towards +Y to the right; the sphere seen from outside).
        World = "world",
        /// What 360° players and headsets expect (the sphere seen from inside): the centre column looks
        /// along the panorama's forward (the centre of its image) and moving right turns right.
        Player = "player",
    }
}

/// A stereo camera: the left and right eyes, and the layout of the image they make.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoCamera {
    /// The left eye's camera.
    pub left: Camera,
    /// The right eye's camera.
    pub right: Camera,
    /// How the eyes share the image.
    pub layout: StereoLayout,
    /// `None`: each eye in the world axes; `Some(a)`: in the players' orientation, the centre
    /// column at world azimuth `a` (radians, from +X towards +Y), rounded to a whole column.
    pub player_yaw: Option<f64>,
}

impl StereoCamera {
    /// Omnidirectional stereo centred at `eye`: the whole image is `width × height` in `layout`
    /// (each eye 2:1), the eyes `ipd` metres apart on the viewing circle.
    pub fn ods(
        eye: DVec3,
        width: usize,
        height: usize,
        ipd: f64,
        pole_merge: Option<PoleMerge>,
        layout: StereoLayout,
    ) -> Result<StereoCamera, RenderError> {
        check_ipd(ipd)?;
        let bad = || RenderError::BadSize { width, height, need: ODS };
        let (w, h) = layout.eye_size(width, height).ok_or_else(bad)?;
        if w != 2 * h {
            return Err(bad());
        }
        let eye_cam = |offset| OdsEye::new(eye, w, h, offset, pole_merge).map(Camera::Ods);
        Ok(StereoCamera { left: eye_cam(ipd / 2.0)?, right: eye_cam(-ipd / 2.0)?, layout, player_yaw: None })
    }

    /// VR180 at `eye` looking along `forward` (`up` up): two half equirects (180° × 180°) side by
    /// side or top-bottom in a `width × height` image, from eyes `ipd` apart across the view (as a
    /// two-lens VR180 camera has them), already in the players' orientation.
    pub fn vr180(
        eye: DVec3,
        forward: DVec3,
        up: DVec3,
        width: usize,
        height: usize,
        ipd: f64,
        layout: StereoLayout,
    ) -> Result<StereoCamera, RenderError> {
        check_ipd(ipd)?;
        let bad = || RenderError::BadSize { width, height, need: VR180 };
        let (w, h) = layout.eye_size(width, height).ok_or_else(bad)?;
        if w != h || w % 2 != 0 {
            return Err(bad());
        }
        let centre = HalfEquirect::new(eye, forward, up, w)?;
        let eye_cam = |offset: f64| {
            let c = HalfEquirect { eye: eye - centre.right * offset, ..centre };
            finite(c.eye, "eye").map(|_| Camera::HalfEquirect(c))
        };
        Ok(StereoCamera { left: eye_cam(ipd / 2.0)?, right: eye_cam(-ipd / 2.0)?, layout, player_yaw: None })
    }

    /// Width and height of the whole image.
    pub fn size(&self) -> (usize, usize) {
        let (w, h) = (self.left.width(), self.left.height());
        match self.layout {
            StereoLayout::Tb => (w, 2 * h),
            StereoLayout::Sbs => (2 * w, h),
        }
    }
}

/// What an ODS image needs.
const ODS: &str =
    "ODS eyes are 2:1 each: top-bottom 1:1 (e.g. 2048x2048), side by side 4:1 (--stereo-layout sbs)";

fn check_ipd(ipd: f64) -> Result<(), RenderError> {
    if ipd >= 0.0 && ipd.is_finite() {
        Ok(())
    } else {
        Err(RenderError::BadCamera(format!("interpupillary distance {ipd} m must be ≥ 0")))
    }
}

/// The two eyes' frames (of one size, world axes) as the camera's image: turned to the players'
/// orientation if it asks, stacked in its layout.
pub fn stack(left: &Frame, right: &Frame, camera: &StereoCamera) -> Frame {
    match camera.player_yaw {
        Some(yaw) => stack_eyes(&to_player(left, yaw), &to_player(right, yaw), camera.layout),
        None => stack_eyes(left, right, camera.layout),
    }
}

/// A world-axes equirect frame in the players' orientation with its centre column at azimuth
/// `yaw`: output column `x` is input column `k − 1 − x` (mod width), `k = round(w (yaw + π) / 2π)`,
/// so pixel centres map onto pixel centres (a mirror and a turn, no resampling).
pub fn to_player(f: &Frame, yaw: f64) -> Frame {
    let w = f.width as i64;
    let k = (w as f64 * (yaw + std::f64::consts::PI) / std::f64::consts::TAU).round() as i64;
    let mut out = Frame::holes_only(f.width, f.height);
    for y in 0..f.height {
        let row = y * f.width;
        for x in 0..w {
            let (o, i) = (row + x as usize, row + (k - 1 - x).rem_euclid(w) as usize);
            for c in 0..3 {
                out.rgb[c][o] = f.rgb[c][i];
            }
            out.depth[o] = f.depth[i];
            out.covered[o] = f.covered[i];
        }
    }
    out
}

/// Two frames of one size as one image in `layout`.
pub fn stack_eyes(left: &Frame, right: &Frame, layout: StereoLayout) -> Frame {
    let (w, h) = (left.width, left.height);
    debug_assert_eq!((w, h), (right.width, right.height));
    let (ow, oh) = match layout {
        StereoLayout::Tb => (w, 2 * h),
        StereoLayout::Sbs => (2 * w, h),
    };
    let mut f = Frame::holes_only(ow, oh);
    for (k, eye) in [left, right].into_iter().enumerate() {
        for y in 0..h {
            let (src, dst) = match layout {
                StereoLayout::Tb => (y * w, (k * h + y) * w),
                StereoLayout::Sbs => (y * w, y * ow + k * w),
            };
            for c in 0..3 {
                f.rgb[c][dst..dst + w].copy_from_slice(&eye.rgb[c][src..src + w]);
            }
            f.depth[dst..dst + w].copy_from_slice(&eye.depth[src..src + w]);
            f.covered[dst..dst + w].copy_from_slice(&eye.covered[src..src + w]);
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_put_the_left_eye_first() {
        let mut l = Frame::holes_only(4, 2);
        l.rgb[0].fill(1.0);
        let r = Frame::holes_only(4, 2);
        let tb = stack_eyes(&l, &r, StereoLayout::Tb);
        assert_eq!((tb.width, tb.height), (4, 4));
        assert!(tb.rgb[0][..8].iter().all(|&v| v == 1.0) && tb.rgb[0][8..].iter().all(|&v| v == 0.0));
        let sbs = stack_eyes(&l, &r, StereoLayout::Sbs);
        assert_eq!((sbs.width, sbs.height), (8, 2));
        assert_eq!(&sbs.rgb[0][..8], &[1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    }

    /// In the players' orientation the centre column looks along the forward azimuth and moving
    /// right turns right (clockwise seen from above: decreasing azimuth).
    #[test]
    fn player_orientation_centres_forward_and_turns_right() {
        let (w, h) = (16, 8);
        let mut f = Frame::holes_only(w, h);
        for x in 0..w {
            f.rgb[0][x] = (x as f32 + 0.5) / w as f32 * 360.0; // azimuth of the column, degrees
        }
        for (yaw, centre) in [(0.0, 0.0), (90.0, 90.0), (-90.0, 270.0)] {
            let p = to_player(&f, f64::to_radians(yaw));
            // Pixel w/2 − 1 and w/2 straddle the centre: their azimuths average to the forward.
            let (a, b) = (p.rgb[0][w / 2 - 1], p.rgb[0][w / 2]);
            let mid = if (a - b).abs() > 180.0 { ((a + b + 360.0) / 2.0) % 360.0 } else { (a + b) / 2.0 };
            assert!((mid - centre).abs() < 1e-4, "{yaw}: {a} {b}");
            assert!(((a - b).rem_euclid(360.0) - 22.5).abs() < 1e-4, "turns right: {a} then {b}");
        }
    }

    #[test]
    fn ods_sizes_and_checks() {
        let c = StereoCamera::ods(DVec3::ZERO, 256, 256, 0.064, None, StereoLayout::Tb).unwrap();
        assert_eq!((c.left.width(), c.left.height(), c.size()), (256, 128, (256, 256)));
        let Camera::Ods(l) = c.left else { panic!() };
        assert_eq!(l.offset, 0.032);
        assert!(StereoCamera::ods(DVec3::ZERO, 256, 255, 0.064, None, StereoLayout::Tb).is_err());
        assert!(StereoCamera::ods(DVec3::ZERO, 256, 256, 0.064, None, StereoLayout::Sbs).is_err());
        assert!(StereoCamera::ods(DVec3::ZERO, 512, 128, 0.064, None, StereoLayout::Sbs).is_ok());
        assert!(StereoCamera::ods(DVec3::ZERO, 256, 256, f64::NAN, None, StereoLayout::Tb).is_err());
    }
}
