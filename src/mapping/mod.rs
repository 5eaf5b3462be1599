//! Planar parametrisations of the sphere of directions (spec §3, thesis appendix A): pixel ↔ direction.
//!
//! - [`Equirect`]: the 2:1 lat-long canvas (thesis A.2);
//! - [`Cube3x2`]: the thesis's 3×2 cube map (thesis A.3), with per-face access through [`CubeFace`] and
//!   [`FacePoint`];
//! - [`layout`]: other tools' cube-map layouts (ffmpeg `c3x2`, OpenEXR vertical strip, py360convert
//!   `horizon`) as exact face re-orderings of the canonical 3×2 canvas.
//!
//! Every `dir_to_pixel` is total: any input, including zero, NaN, infinite or denormal components, gives
//! a point inside the canvas and never NaN (spec §3.4).

use glam::{DVec2, DVec3};

mod cube;
mod dirs;
mod equirect;
mod fast;
pub mod layout;
mod neighbours;

pub use cube::{Cube3x2, CubeFace, FacePoint};
pub use dirs::DirTable;
pub(crate) use dirs::PixelDirs;
pub use equirect::Equirect;
pub use fast::fast_atan2;
pub use neighbours::{opposite, Neighbours, OFFSETS};

/// A parametrisation of the sphere by a `width × height` canvas.
/// Continuous pixel coordinates: pixel `(i, j)` covers `[i, i+1) × [j, j+1)`, centre `(i+0.5, j+0.5)`.
pub trait Mapping: Send + Sync {
    /// Canvas width W, pixels.
    fn width(&self) -> usize;
    /// Canvas height H, pixels.
    fn height(&self) -> usize;
    /// Unit direction (panorama-local frame) of continuous pixel coordinates `(x, y)`.
    fn pixel_to_dir(&self, x: f64, y: f64) -> DVec3;
    /// Continuous pixel coordinates of a non-zero direction; always inside `[0,W) × [0,H)`.
    fn dir_to_pixel(&self, d: DVec3) -> DVec2;
    /// Solid angle (steradians) of pixel `(i, j)`.
    fn solid_angle(&self, i: usize, j: usize) -> f64;

    /// Direction through the centre of pixel `(i, j)`.
    fn pixel_dir(&self, i: usize, j: usize) -> DVec3 {
        self.pixel_to_dir(i as f64 + 0.5, j as f64 + 0.5)
    }
    /// Pixel containing direction `d`.
    fn pixel_of(&self, d: DVec3) -> (usize, usize) {
        let p = self.dir_to_pixel(d);
        ((p.x as usize).min(self.width() - 1), (p.y as usize).min(self.height() - 1))
    }
    /// 3D point (panorama-local) of pixel `(i, j)` at distance `depth` along its ray (eq. 6.11).
    fn point(&self, i: usize, j: usize, depth: f64) -> DVec3 {
        self.pixel_dir(i, j) * depth
    }
}

crate::choice::choices! {
    /// Which parametrisation.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum MappingKind {
        /// Equirect (lat-long) 2:1 canvas.
        ///
        /// See [`Equirect`].
        Equirect = "equirect",
        /// 3×2 cube map.
        ///
        /// The thesis's; see [`Cube3x2`].
        Cube3x2 = "cube",
    }
}

/// A canvas size that does not fit a mapping.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a {width}x{height} canvas is not a valid {kind:?} canvas")]
pub struct MappingError {
    /// The mapping the canvas was meant for.
    pub kind: MappingKind,
    /// The refused canvas width, pixels.
    pub width: usize,
    /// The refused canvas height, pixels.
    pub height: usize,
}

/// Either mapping, chosen at run time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyMapping {
    /// An equirect canvas.
    Equirect(Equirect),
    /// A 3×2 cube-map canvas.
    Cube(Cube3x2),
}

impl AnyMapping {
    /// The `kind` mapping of a `width × height` canvas (pixels); errs when the size does not fit it.
    pub fn new(kind: MappingKind, width: usize, height: usize) -> Result<Self, MappingError> {
        Ok(match kind {
            MappingKind::Equirect => AnyMapping::Equirect(Equirect::new(width, height)?),
            MappingKind::Cube3x2 => AnyMapping::Cube(Cube3x2::new(width, height)?),
        })
    }
    /// Which parametrisation this is.
    pub fn kind(&self) -> MappingKind {
        match self {
            AnyMapping::Equirect(_) => MappingKind::Equirect,
            AnyMapping::Cube(_) => MappingKind::Cube3x2,
        }
    }
    fn inner(&self) -> &dyn Mapping {
        match self {
            AnyMapping::Equirect(m) => m,
            AnyMapping::Cube(m) => m,
        }
    }
}

impl Mapping for AnyMapping {
    fn width(&self) -> usize {
        self.inner().width()
    }
    fn height(&self) -> usize {
        self.inner().height()
    }
    fn pixel_to_dir(&self, x: f64, y: f64) -> DVec3 {
        self.inner().pixel_to_dir(x, y)
    }
    fn dir_to_pixel(&self, d: DVec3) -> DVec2 {
        self.inner().dir_to_pixel(d)
    }
    fn solid_angle(&self, i: usize, j: usize) -> f64 {
        self.inner().solid_angle(i, j)
    }
}

/// Largest `f64` strictly below a positive finite `x`: the upper end of a half-open `[0, x)` range.
#[inline]
pub(crate) fn below(x: f64) -> f64 {
    debug_assert!(x > 0.0 && x.is_finite());
    f64::from_bits(x.to_bits() - 1)
}

/// Make any direction usable by the inverse mappings (spec §3.4):
/// - a NaN component, or the zero vector, has no direction: `None` (callers map it to the +Z pole);
/// - infinite components dominate: they become `±1` and the finite ones `0`.
///
/// Finite vectors are returned unchanged; the mappings only use ratios, `atan2` and `hypot`, which are
/// safe for denormal and huge components.
#[inline]
pub(crate) fn sanitize_dir(d: DVec3) -> Option<DVec3> {
    if d.is_nan() {
        return None;
    }
    let d = if d.is_finite() {
        d
    } else {
        let f = |c: f64| if c.is_infinite() { c.signum() } else { 0.0 };
        DVec3::new(f(d.x), f(d.y), f(d.z))
    };
    if d == DVec3::ZERO {
        None
    } else {
        Some(d)
    }
}
