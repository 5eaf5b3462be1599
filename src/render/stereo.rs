//! Stereo outputs (spec §9.2, docs/stereo.md): two eye cameras and how their frames share one image.

use glam::DVec3;

use super::camera::{Camera, OdsEye, PoleMerge};
use super::frame::Frame;
use super::RenderError;

/// Where each eye goes in a stereo image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum StereoLayout {
    /// Top-bottom (over-under): the left eye on top, as YouTube and most players expect of 360°.
    #[default]
    Tb,
    /// Side by side: the left eye on the left.
    Sbs,
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

/// A stereo camera: the left and right eyes, and the layout of the image they make.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoCamera {
    /// The left eye's camera.
    pub left: Camera,
    /// The right eye's camera.
    pub right: Camera,
    /// How the eyes share the image.
    pub layout: StereoLayout,
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
        if !(ipd >= 0.0 && ipd.is_finite()) {
            return Err(RenderError::BadCamera(format!("interpupillary distance {ipd} m must be ≥ 0")));
        }
        let (w, h) = layout.eye_size(width, height).ok_or(RenderError::BadSize { width, height })?;
        let eye_cam = |offset| OdsEye::new(eye, w, h, offset, pole_merge).map(Camera::Ods);
        Ok(StereoCamera { left: eye_cam(ipd / 2.0)?, right: eye_cam(-ipd / 2.0)?, layout })
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

/// The two eyes' frames (of one size) as one image in `layout`.
pub fn stack(left: &Frame, right: &Frame, layout: StereoLayout) -> Frame {
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
        let tb = stack(&l, &r, StereoLayout::Tb);
        assert_eq!((tb.width, tb.height), (4, 4));
        assert!(tb.rgb[0][..8].iter().all(|&v| v == 1.0) && tb.rgb[0][8..].iter().all(|&v| v == 0.0));
        let sbs = stack(&l, &r, StereoLayout::Sbs);
        assert_eq!((sbs.width, sbs.height), (8, 2));
        assert_eq!(&sbs.rgb[0][..8], &[1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
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
