//! Planar parametrisations of the sphere of directions (spec §3): pixel ↔ direction.
//! INTERFACE STUB: `Equirect` and `Cube3x2` bodies to be implemented (equirect.rs, cube.rs, layout.rs).

use glam::{DVec2, DVec3};

/// A parametrisation of the sphere by a `width × height` canvas.
/// Continuous pixel coordinates: pixel `(i, j)` covers `[i, i+1) × [j, j+1)`, centre `(i+0.5, j+0.5)`.
pub trait Mapping: Send + Sync {
    fn width(&self) -> usize;
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

/// Which parametrisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MappingKind {
    Equirect,
    Cube3x2,
}

/// A canvas size that does not fit a mapping.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a {width}x{height} canvas is not a valid {kind:?} canvas")]
pub struct MappingError {
    pub kind: MappingKind,
    pub width: usize,
    pub height: usize,
}

/// Equirect (lat-long) 2:1 canvas (thesis A.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Equirect {
    width: usize,
    height: usize,
}

impl Equirect {
    pub fn new(width: usize, height: usize) -> Result<Self, MappingError> {
        if width == 0 || width != 2 * height {
            return Err(MappingError { kind: MappingKind::Equirect, width, height });
        }
        Ok(Equirect { width, height })
    }
}

impl Mapping for Equirect {
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn pixel_to_dir(&self, _x: f64, _y: f64) -> DVec3 {
        todo!()
    }
    fn dir_to_pixel(&self, _d: DVec3) -> DVec2 {
        todo!()
    }
    fn solid_angle(&self, _i: usize, _j: usize) -> f64 {
        todo!()
    }
}

/// 3×2 cube map with square faces of `face` pixels (thesis A.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cube3x2 {
    face: usize,
}

impl Cube3x2 {
    pub fn new(width: usize, height: usize) -> Result<Self, MappingError> {
        if height == 0 || height % 2 != 0 || width * 2 != height * 3 {
            return Err(MappingError { kind: MappingKind::Cube3x2, width, height });
        }
        Ok(Cube3x2 { face: height / 2 })
    }
    /// Face size in pixels.
    pub fn face_size(&self) -> usize {
        self.face
    }
}

impl Mapping for Cube3x2 {
    fn width(&self) -> usize {
        3 * self.face
    }
    fn height(&self) -> usize {
        2 * self.face
    }
    fn pixel_to_dir(&self, _x: f64, _y: f64) -> DVec3 {
        todo!()
    }
    fn dir_to_pixel(&self, _d: DVec3) -> DVec2 {
        todo!()
    }
    fn solid_angle(&self, _i: usize, _j: usize) -> f64 {
        todo!()
    }
}

/// Either mapping, chosen at run time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyMapping {
    Equirect(Equirect),
    Cube(Cube3x2),
}

impl AnyMapping {
    pub fn new(kind: MappingKind, width: usize, height: usize) -> Result<Self, MappingError> {
        Ok(match kind {
            MappingKind::Equirect => AnyMapping::Equirect(Equirect::new(width, height)?),
            MappingKind::Cube3x2 => AnyMapping::Cube(Cube3x2::new(width, height)?),
        })
    }
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
