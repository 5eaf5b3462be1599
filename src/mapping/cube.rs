//! The thesis's 3×2 cube map, appendix A.3 (spec §3.3).
//!
//! Canvas `3N × 2N`; face index `3·t0 + s0`, top row `+X, +Y, +Z`, bottom row `−X, −Y, −Z`.
//! Inside a face, `s, t ∈ [−1, 1]` grow rightwards and downwards; the face's direction is the cube point
//! `c + s·R + t·D` (centre axis `c`, right axis `R`, down axis `D`, all signed unit axes) normalised.

use glam::{DVec2, DVec3};

use super::{below, sanitize_dir, Mapping, MappingError, MappingKind};

/// One face of the cube, numbered by its slot in the canonical 3×2 canvas.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CubeFace {
    /// `+X`, top row left.
    PosX = 0,
    /// `+Y`, top row middle.
    PosY = 1,
    /// `+Z` (up), top row right.
    PosZ = 2,
    /// `−X`, bottom row left.
    NegX = 3,
    /// `−Y`, bottom row middle.
    NegY = 4,
    /// `−Z` (down), bottom row right.
    NegZ = 5,
}

impl CubeFace {
    /// All six faces in index order.
    pub const ALL: [CubeFace; 6] =
        [CubeFace::PosX, CubeFace::PosY, CubeFace::PosZ, CubeFace::NegX, CubeFace::NegY, CubeFace::NegZ];

    /// Face index `3·t0 + s0`.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The face of index `i` (`None` beyond 5).
    pub fn from_index(i: usize) -> Option<CubeFace> {
        CubeFace::ALL.get(i).copied()
    }

    /// Grid position `(s0, t0)` in the canonical 3×2 canvas.
    pub fn grid(self) -> (usize, usize) {
        (self.index() % 3, self.index() / 3)
    }

    /// Face frame `(centre, right, down)` in the panorama frame (digest §6 table, inverse column).
    pub fn frame(self) -> [DVec3; 3] {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        match self {
            CubeFace::PosX => [x, -y, -z],
            CubeFace::PosY => [y, x, -z],
            CubeFace::PosZ => [z, -x, -y],
            CubeFace::NegX => [-x, y, -z],
            CubeFace::NegY => [-y, -x, -z],
            CubeFace::NegZ => [-z, x, -y],
        }
    }

    /// The (unnormalised) cube point of face coordinates `(s, t)`. `s, t` may leave `[−1, 1]`: the point
    /// then lies on the face's plane beyond its edge, which is how samplers find texels of the
    /// neighbouring faces.
    #[inline]
    pub fn cube_point(self, s: f64, t: f64) -> DVec3 {
        let [c, r, d] = self.frame();
        c + s * r + t * d
    }
}

/// A direction expressed on the cube: a face and coordinates `s, t ∈ [−1, 1]` on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacePoint {
    /// The face the direction lies on.
    pub face: CubeFace,
    /// Face coordinate in `[−1, 1]`, growing rightwards along the face's right axis.
    pub s: f64,
    /// Face coordinate in `[−1, 1]`, growing downwards along the face's down axis.
    pub t: f64,
}

impl FacePoint {
    /// Face and coordinates of a direction (total).
    ///
    /// The face is the axis of largest `|component|`. Tie rule (edges and corners): X beats Y beats Z,
    /// so a tied direction lands on the edge of the X (or Y) face, where `|s|` or `|t|` is exactly 1.
    /// Zero and NaN directions give the centre of `+Z` (the direction `+Z`, as the equirect does).
    pub fn from_dir(d: DVec3) -> FacePoint {
        let Some(d) = sanitize_dir(d) else {
            return FacePoint { face: CubeFace::PosZ, s: 0.0, t: 0.0 };
        };
        let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
        // Quotients of a smaller by a not-smaller magnitude: always in [-1, 1], never NaN.
        if ax >= ay && ax >= az {
            if d.x > 0.0 {
                FacePoint { face: CubeFace::PosX, s: -d.y / ax, t: -d.z / ax }
            } else {
                FacePoint { face: CubeFace::NegX, s: d.y / ax, t: -d.z / ax }
            }
        } else if ay >= az {
            if d.y > 0.0 {
                FacePoint { face: CubeFace::PosY, s: d.x / ay, t: -d.z / ay }
            } else {
                FacePoint { face: CubeFace::NegY, s: -d.x / ay, t: -d.z / ay }
            }
        } else if d.z > 0.0 {
            FacePoint { face: CubeFace::PosZ, s: -d.x / az, t: -d.y / az }
        } else {
            FacePoint { face: CubeFace::NegZ, s: d.x / az, t: -d.y / az }
        }
    }

    /// Unit direction of this point.
    pub fn dir(&self) -> DVec3 {
        self.face.cube_point(self.s, self.t).normalize()
    }
}

/// 3×2 cube map with square faces of `face` pixels (thesis A.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cube3x2 {
    face: usize,
}

impl Cube3x2 {
    /// A `width × height` canvas (pixels); errs unless it is `3N × 2N` with `N ≥ 1`.
    pub fn new(width: usize, height: usize) -> Result<Self, MappingError> {
        let fits = matches!((width.checked_mul(2), height.checked_mul(3)), (Some(a), Some(b)) if a == b);
        if height == 0 || height % 2 != 0 || !fits {
            return Err(MappingError { kind: MappingKind::Cube3x2, width, height });
        }
        Ok(Cube3x2 { face: height / 2 })
    }
    /// Face size in pixels.
    pub fn face_size(&self) -> usize {
        self.face
    }

    /// Face point of continuous canvas coordinates (clamped into the canvas first).
    pub fn pixel_to_face_point(&self, x: f64, y: f64) -> FacePoint {
        let n = self.face as f64;
        let x = x.clamp(0.0, 3.0 * n);
        let y = y.clamp(0.0, 2.0 * n);
        let s0 = ((x / n).floor() as usize).min(2);
        let t0 = ((y / n).floor() as usize).min(1);
        let face = CubeFace::from_index(3 * t0 + s0).unwrap_or(CubeFace::PosZ);
        FacePoint { face, s: 2.0 * (x / n - s0 as f64) - 1.0, t: 2.0 * (y / n - t0 as f64) - 1.0 }
    }

    /// Continuous canvas coordinates of a face point; always inside the face's own square (so ties at
    /// edges stay on the face the tie rule chose).
    pub fn face_point_to_pixel(&self, p: FacePoint) -> DVec2 {
        let n = self.face as f64;
        let (s0, t0) = p.face.grid();
        let (x0, y0) = (s0 as f64 * n, t0 as f64 * n);
        let fx = ((p.s + 1.0) * 0.5 * n).clamp(0.0, n);
        let fy = ((p.t + 1.0) * 0.5 * n).clamp(0.0, n);
        let fx = if fx.is_nan() { 0.0 } else { fx };
        let fy = if fy.is_nan() { 0.0 } else { fy };
        DVec2::new((x0 + fx).min(below(x0 + n)).max(x0), (y0 + fy).min(below(y0 + n)).max(y0))
    }
}

/// `∫∫ dA / (1 + a² + b²)^{3/2}` over `[0,a]×[0,b]` on the plane at distance 1: the solid angle of the
/// rectangle from the cube's centre.
#[inline]
fn corner_term(a: f64, b: f64) -> f64 {
    (a * b).atan2((a * a + b * b + 1.0).sqrt())
}

impl Mapping for Cube3x2 {
    fn width(&self) -> usize {
        3 * self.face
    }
    fn height(&self) -> usize {
        2 * self.face
    }
    fn pixel_to_dir(&self, x: f64, y: f64) -> DVec3 {
        self.pixel_to_face_point(x, y).dir()
    }
    fn dir_to_pixel(&self, d: DVec3) -> DVec2 {
        self.face_point_to_pixel(FacePoint::from_dir(d))
    }
    /// Exact solid angle of the face rectangle `[a0,a1]×[b0,b1]`: the signed sum of the corner terms.
    fn solid_angle(&self, i: usize, j: usize) -> f64 {
        let n = self.face as f64;
        let (li, lj) = ((i % self.face) as f64, (j % self.face) as f64);
        let a0 = 2.0 * li / n - 1.0;
        let a1 = 2.0 * (li + 1.0) / n - 1.0;
        let b0 = 2.0 * lj / n - 1.0;
        let b1 = 2.0 * (lj + 1.0) / n - 1.0;
        corner_term(a1, b1) - corner_term(a0, b1) - corner_term(a1, b0) + corner_term(a0, b0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_match_the_forward_table() {
        // Forward formulas of the digest §6 table, written out independently.
        let fwd = |d: DVec3| -> (CubeFace, f64, f64) {
            let (x, y, z) = (d.x, d.y, d.z);
            let p = FacePoint::from_dir(d);
            let (s, t) = match p.face {
                CubeFace::PosX => (-y / x, -z / x),
                CubeFace::PosY => (x / y, -z / y),
                CubeFace::PosZ => (-x / z, -y / z),
                CubeFace::NegX => (y / -x, -z / -x),
                CubeFace::NegY => (-x / -y, -z / -y),
                CubeFace::NegZ => (x / -z, -y / -z),
            };
            (p.face, s, t)
        };
        for face in CubeFace::ALL {
            for &(s, t) in &[(0.3, -0.7), (-0.9, 0.2), (0.0, 0.0)] {
                let d = face.cube_point(s, t);
                let (f, s2, t2) = fwd(d);
                assert_eq!(f, face);
                assert!((s2 - s).abs() < 1e-15 && (t2 - t).abs() < 1e-15, "{face:?} {s} {t}");
            }
        }
    }

    #[test]
    fn face_centres_are_axes() {
        let m = Cube3x2::new(6, 4).unwrap();
        let want = [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z];
        for (k, w) in want.iter().enumerate() {
            let (s0, t0) = (k % 3, k / 3);
            let d = m.pixel_to_dir(2.0 * s0 as f64 + 1.0, 2.0 * t0 as f64 + 1.0);
            assert!((d - *w).length() < 1e-15, "face {k}: {d}");
            let p = m.dir_to_pixel(*w);
            assert_eq!(p, DVec2::new(2.0 * s0 as f64 + 1.0, 2.0 * t0 as f64 + 1.0));
        }
    }

    #[test]
    fn ties_pick_x_then_y() {
        assert_eq!(FacePoint::from_dir(DVec3::new(1.0, 1.0, 1.0)).face, CubeFace::PosX);
        assert_eq!(FacePoint::from_dir(DVec3::new(-1.0, 1.0, 0.0)).face, CubeFace::NegX);
        assert_eq!(FacePoint::from_dir(DVec3::new(0.0, -1.0, 1.0)).face, CubeFace::NegY);
        assert_eq!(FacePoint::from_dir(DVec3::ZERO).face, CubeFace::PosZ);
    }
}
