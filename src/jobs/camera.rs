//! The camera of a view (`pomc render`'s camera options, Python's `Panorama.render`): which
//! camera, where, how large, and for stereo the eyes; [`CameraSettings::view_camera`] makes it.

use glam::DVec3;

use super::ViewCamera;
use crate::mapping::layout::CubeLayout;
use crate::render::stereo::Orientation;
use crate::render::{
    Camera, CubeCamera, EquirectCamera, Perspective, PoleMerge, RenderError, StereoCamera, StereoLayout,
};

crate::choice::choices! {
    /// The output camera of a view (`pomc render`, Python `Panorama.render`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum CameraKind (default Perspective) {
        /// Pinhole camera: --eye, --look-at, --up, --fov, --size.
        Perspective = "perspective",
        /// A new 2:1 equirect panorama centred at --eye (world axes, +Z up).
        Equirect = "equirect",
        /// Omnidirectional stereo: two equirect eyes on a viewing circle of diameter --ipd around --eye,
        /// stacked by --stereo-layout.
        Ods = "ods",
        /// VR180: two 180° × 180° half equirects looking along --look-at from eyes --ipd apart, side by
        /// side unless --stereo-layout tb.
        Vr180 = "vr180",
        /// A cube map in --cube-layout seen from --eye; with --stereo, one per eye (the ODS eyes' rays),
        /// stacked by --stereo-layout.
        Cube = "cube",
    }
}

/// How a view is seen: its camera and, for stereo, the eyes. `Default` is `pomc render` without
/// camera options.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSettings {
    /// Output camera.
    pub camera: CameraKind,
    /// Eye position in the world, metres (`None`: the panorama centre).
    pub eye: Option<DVec3>,
    /// Point looked at, world (`None`: the centre of the panorama image).
    pub look_at: Option<DVec3>,
    /// Up direction, world.
    pub up: DVec3,
    /// Horizontal field of view, degrees (perspective).
    pub fov: f64,
    /// Output size, the whole image (`None`: the camera's default).
    pub size: Option<(usize, usize)>,
    /// Stereo layout (`None`: tb for ODS and cube, sbs for VR180).
    pub stereo_layout: Option<StereoLayout>,
    /// Interpupillary distance of stereo cameras, metres.
    pub ipd: f64,
    /// Stereo fades to mono between these elevations, degrees (`None`: full separation to the poles).
    pub pole_merge: Option<(f64, f64)>,
    /// A stereo cube map.
    pub stereo: bool,
    /// Face layout of a cube map.
    pub cube_layout: CubeLayout,
    /// Columns of stereo panoramas.
    pub orientation: Orientation,
}

impl Default for CameraSettings {
    fn default() -> Self {
        CameraSettings {
            camera: CameraKind::Perspective,
            eye: None,
            look_at: None,
            up: DVec3::Z,
            fov: 60.0,
            size: None,
            stereo_layout: None,
            ipd: 0.064,
            pole_merge: Some((60.0, 75.0)),
            stereo: false,
            cube_layout: CubeLayout::Canonical,
            orientation: Orientation::World,
        }
    }
}

impl CameraSettings {
    /// The pole merge these settings ask for.
    fn merge(&self) -> Option<PoleMerge> {
        self.pole_merge.map(|(from, to)| PoleMerge::new(from.to_radians(), to.to_radians()))
    }

    /// The camera at `eye` (looking at `look_at`, else along `look` from it); `panorama_width` is
    /// the width of an equirect at the panorama's resolution (the default ODS eye width).
    pub fn view_camera(
        &self,
        eye: DVec3,
        look_at: Option<DVec3>,
        look: DVec3,
        panorama_width: usize,
    ) -> Result<ViewCamera, RenderError> {
        Ok(match self.camera {
            CameraKind::Perspective => {
                let (w, h) = self.size.unwrap_or((960, 540));
                let at = look_at.unwrap_or(eye + look);
                ViewCamera::Mono(Camera::Perspective(Perspective::new(eye, at, self.up, self.fov, w, h)?))
            }
            CameraKind::Equirect => {
                let (w, h) = self.size.unwrap_or((2048, 1024));
                ViewCamera::Mono(Camera::Equirect(EquirectCamera::new(eye, w, h)?))
            }
            CameraKind::Ods => {
                let w = panorama_width.max(2) / 2 * 2;
                let layout = self.stereo_layout.unwrap_or(StereoLayout::Tb);
                let (w, h) = self.size.unwrap_or(match layout {
                    StereoLayout::Tb => (w, w),
                    StereoLayout::Sbs => (2 * w, w / 2),
                });
                let mut cam = StereoCamera::ods(eye, w, h, self.ipd, self.merge(), layout)?;
                if self.orientation == Orientation::Player {
                    let forward = look_at.map_or(look, |at| at - eye);
                    cam.player_yaw = Some(forward.y.atan2(forward.x));
                }
                ViewCamera::Stereo(cam)
            }
            CameraKind::Cube => {
                let layout = self.stereo_layout.unwrap_or(StereoLayout::Tb);
                let face = match self.size {
                    None => (panorama_width / 4).max(1),
                    Some((w, h)) => {
                        let need =
                            "a stereo cube map is two cube maps stacked top-bottom (--stereo-layout tb) \
                                    or side by side";
                        let (w, h) = if self.stereo {
                            layout.eye_size(w, h).ok_or(RenderError::BadSize { width: w, height: h, need })?
                        } else {
                            (w, h)
                        };
                        self.cube_layout.face_size(w, h).map_err(|e| RenderError::BadCamera(e.to_string()))?
                    }
                };
                ViewCamera::Cube(if self.stereo {
                    CubeCamera::ods(eye, face, self.ipd, self.merge(), self.cube_layout, layout)?
                } else {
                    CubeCamera::mono(eye, face, self.cube_layout)?
                })
            }
            CameraKind::Vr180 => {
                let side = (panorama_width / 4 * 2).max(2);
                let layout = self.stereo_layout.unwrap_or(StereoLayout::Sbs);
                let (w, h) = self.size.unwrap_or(match layout {
                    StereoLayout::Tb => (side, 2 * side),
                    StereoLayout::Sbs => (2 * side, side),
                });
                let forward = look_at.map_or(look, |at| at - eye);
                ViewCamera::Stereo(StereoCamera::vr180(eye, forward, self.up, w, h, self.ipd, layout)?)
            }
        })
    }
}

/// A vector `x,y,z` (finite numbers; spaces allowed after commas; a leading `-` is a number, not
/// an option, when the argument is declared with `allow_hyphen_values`).
pub fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers x,y,z, got `{s}`"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got `{s}`")),
    }
}
