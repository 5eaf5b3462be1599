//! Cube-map outputs (spec §9.2): each eye (one for mono, two for stereo) is rendered as an equirect
//! at twice the cube's angular resolution (less for faces over 2048 pixels, within the size limits) — plain from the eye, or the ODS eye for stereo, whose
//! rays are the same whatever the image they are stored in — and resampled (bicubic, depth-aware) to
//! a cube map in any layout of spec §3.5; stereo eyes are then stacked as any stereo image.

use glam::DVec3;

use super::camera::{Camera, EquirectCamera, PoleMerge};
use super::frame::Frame;
use super::stereo::{StereoCamera, StereoLayout};
use super::RenderError;
use crate::layer::{LayerImage, SampleType, OUTSIDE_DEPTH};
use crate::mapping::layout::CubeLayout;
use crate::resample::{self, Canvas, Filter, SampleOptions};

/// A cube-map view: the equirect eyes it is resampled from, its face size and layouts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubeCamera {
    /// The left eye (or the only one), an equirect camera or an ODS eye 8 faces wide.
    pub left: Camera,
    /// The right eye of a stereo cube map.
    pub right: Option<Camera>,
    /// Face side, pixels.
    pub face: usize,
    /// Face arrangement of each eye (spec §3.5).
    pub layout: CubeLayout,
    /// How stereo eyes share the image.
    pub stereo: StereoLayout,
}

/// Equirect width rendered per face pixel: twice the cube's resolution at a face centre.
const OVERSAMPLE: usize = 8;

/// Width of the equirect each eye of a cube map of `face`-pixel faces is rendered at: 8 faces, less
/// where that passes the size limits but never below 4 (the faces' own resolution at their centres).
fn eye_width(face: usize) -> Result<usize, RenderError> {
    let largest =
        (((2 * super::camera::MAX_PIXELS) as f64).sqrt() as usize / 2 * 2).min(super::camera::MAX_SIDE);
    let w = face.saturating_mul(OVERSAMPLE).min(largest);
    if face == 0 || w < face.saturating_mul(4) {
        return Err(RenderError::BadCamera(format!(
            "cube faces of {face} pixels: each face must be 1 to {} pixels",
            largest / 4
        )));
    }
    Ok(w)
}

impl CubeCamera {
    /// A mono cube map of faces `face` pixels wide seen from `eye`.
    pub fn mono(eye: DVec3, face: usize, layout: CubeLayout) -> Result<CubeCamera, RenderError> {
        let w = eye_width(face)?;
        let left = Camera::Equirect(EquirectCamera::new(eye, w, w / 2)?);
        Ok(CubeCamera { left, right: None, face, layout, stereo: StereoLayout::Tb })
    }

    /// A stereo cube map: each eye's rays are the ODS eye's (see [`StereoCamera::ods`]).
    pub fn ods(
        eye: DVec3,
        face: usize,
        ipd: f64,
        pole_merge: Option<PoleMerge>,
        layout: CubeLayout,
        stereo: StereoLayout,
    ) -> Result<CubeCamera, RenderError> {
        let w = eye_width(face)?;
        let s = StereoCamera::ods(eye, w, w, ipd, pole_merge, StereoLayout::Tb)?;
        Ok(CubeCamera { left: s.left, right: Some(s.right), face, layout, stereo })
    }

    /// Width and height of one eye's cube map.
    pub fn eye_size(&self) -> (usize, usize) {
        self.layout.canvas_size(self.face)
    }

    /// Width and height of the whole image.
    pub fn size(&self) -> (usize, usize) {
        let (w, h) = self.eye_size();
        match (self.right, self.stereo) {
            (None, _) => (w, h),
            (Some(_), StereoLayout::Tb) => (w, 2 * h),
            (Some(_), StereoLayout::Sbs) => (2 * w, h),
        }
    }
}

/// An equirect frame resampled to a cube map of `face`-pixel faces in `layout`: colour bicubic,
/// never across depth jumps; coverage where the resampled depth is a surface or infinity.
pub fn to_cube(f: &Frame, face: usize, layout: CubeLayout) -> crate::Result<Frame> {
    let mut img = LayerImage::new(f.width, f.height);
    for (k, name) in ["R", "G", "B"].iter().enumerate() {
        img.set_channel(name, SampleType::F32, f.rgb[k].clone());
    }
    img.set_channel("Z", SampleType::F32, f.depth.clone());
    let o = SampleOptions::with_filter(Filter::Bicubic);
    let c = resample::convert_layer(&img, Canvas::Equirect, Canvas::Cube(layout), face, &o)?;
    let plane = |name: &str| c.channel(name).map(|ch| ch.data.clone()).unwrap_or_default();
    let depth = plane("Z");
    let mut out = Frame::holes_only(c.width, c.height);
    out.rgb = [plane("R"), plane("G"), plane("B")];
    out.covered = depth.iter().map(|&z| z >= 0.0).collect();
    out.depth = depth.iter().map(|&z| if z >= 0.0 { z } else { OUTSIDE_DEPTH }).collect();
    for plane in out.rgb.iter_mut() {
        for (v, &on) in plane.iter_mut().zip(&out.covered) {
            if !on || !v.is_finite() {
                *v = 0.0;
            }
        }
    }
    Ok(out)
}
