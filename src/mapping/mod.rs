//! Planar parametrisations of the sphere of directions (spec §3): pixel ↔ direction.
//! STUB — to be implemented (equirect.rs, cube.rs, layout.rs).

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
