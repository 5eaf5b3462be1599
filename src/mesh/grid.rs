//! The vertex lattice one quadtree is built on.
//!
//! **Vertices are pixel centres.** A lattice of `w × h` vertices covers one cube face (`N × N`) or the
//! whole equirect canvas (`W × H`); vertex `(x, y)` is the centre of pixel `(ox + x, oy + y)` and carries
//! that pixel's depth. A quadtree node `[x0, x1] × [y0, y1]` is a rectangle of the lattice (inclusive
//! vertex bounds, `x1 − x0` cells wide); a *cell* is the square between four neighbouring pixel centres.
//! Meshing pixel centres keeps every vertex an exact sample (no invented depth); the half-pixel gaps
//! between cube faces, across the equirect seam and around the poles are closed by `super::stitch`.
//!
//! Each vertex stores `λ = depth / |r|`, where `r` is the lattice ray (unnormalised on a cube face), so
//! that the 3D point is `λ·r`. Invalid vertices (outside, infinite or unknown depth) hold `NaN`.

use glam::DVec3;

use crate::layer::{classify, LayerImage, Sample};
use crate::mapping::{CubeFace, Equirect, Mapping};

/// Relative depth jump above which two neighbouring samples are not connected.
pub const JUMP_THRESHOLD: f64 = crate::continuity::MESH_JUMP;

/// `true` when two depths are too far apart to be one continuous surface (the continuity rule's
/// `continuity::steps_apart` at [`JUMP_THRESHOLD`]).
#[inline]
pub fn is_jump(a: f64, b: f64) -> bool {
    crate::continuity::steps_apart(a, b, JUMP_THRESHOLD)
}

/// How lattice rays are computed.
#[derive(Clone, Debug)]
pub enum Rays {
    /// A cube face: `r = c + s·R + t·D`, `s = 2(x+½)/N − 1`, `t = 2(y+½)/N − 1`.
    Face {
        /// The cube face.
        face: CubeFace,
        /// Face size `N`, pixels a side.
        n: usize,
    },
    /// The equirect canvas: unit rays from per-column and per-row tables.
    Equirect {
        /// `cos φ` per column, azimuth `φ = 2π(x+½)/W` radians.
        cos_phi: Vec<f64>,
        /// `sin φ` per column.
        sin_phi: Vec<f64>,
        /// `cos θ` per row, polar angle `θ = π(y+½)/H` radians from the zenith (+Z).
        cos_theta: Vec<f64>,
        /// `sin θ` per row.
        sin_theta: Vec<f64>,
    },
}

impl Rays {
    /// Rays of cube face `face` of `n × n` pixels.
    pub fn face(face: CubeFace, n: usize) -> Rays {
        Rays::Face { face, n }
    }

    /// Ray tables of the whole canvas of equirect mapping `m`.
    pub fn equirect(m: &Equirect) -> Rays {
        let (w, h) = (m.width(), m.height());
        let phi: Vec<f64> = (0..w).map(|i| std::f64::consts::TAU * (i as f64 + 0.5) / w as f64).collect();
        let theta: Vec<f64> = (0..h).map(|j| std::f64::consts::PI * (j as f64 + 0.5) / h as f64).collect();
        Rays::Equirect {
            cos_phi: phi.iter().map(|p| p.cos()).collect(),
            sin_phi: phi.iter().map(|p| p.sin()).collect(),
            cos_theta: theta.iter().map(|t| t.cos()).collect(),
            sin_theta: theta.iter().map(|t| t.sin()).collect(),
        }
    }

    /// `n·r(x, y)` as a function of the lattice position: affine on a cube face (`r` is affine in
    /// `x, y` there), through the ray tables on the equirect.
    #[inline]
    pub fn plane_dot(&self, n: DVec3) -> PlaneDot<'_> {
        match self {
            Rays::Face { face, n: size } => {
                let [c, r, d] = face.frame();
                let k = 2.0 / *size as f64;
                // s = k(x + ½) − 1, t = k(y + ½) − 1.
                let (nr, nd) = (n.dot(r), n.dot(d));
                let a = n.dot(c) + nr * (0.5 * k - 1.0) + nd * (0.5 * k - 1.0);
                PlaneDot::Affine { a, bx: nr * k, by: nd * k }
            }
            Rays::Equirect { cos_phi, sin_phi, cos_theta, sin_theta } => {
                PlaneDot::Rays { cos_phi, sin_phi, cos_theta, sin_theta, n }
            }
        }
    }

    /// Ray through lattice vertex `(x, y)` (unit for the equirect, on the cube for a face).
    #[inline]
    pub fn ray(&self, x: usize, y: usize) -> DVec3 {
        match self {
            Rays::Face { face, n } => {
                let s = 2.0 * (x as f64 + 0.5) / *n as f64 - 1.0;
                let t = 2.0 * (y as f64 + 0.5) / *n as f64 - 1.0;
                face.cube_point(s, t)
            }
            Rays::Equirect { cos_phi, sin_phi, cos_theta, sin_theta } => {
                let st = sin_theta[y];
                DVec3::new(st * cos_phi[x], st * sin_phi[x], cos_theta[y])
            }
        }
    }
}

/// `n·r` over the lattice, see [`Rays::plane_dot`].
pub enum PlaneDot<'a> {
    /// A cube face: `n·r(x, y) = a + bx·x + by·y`.
    Affine {
        /// Value at vertex `(0, 0)`.
        a: f64,
        /// Change per lattice column.
        bx: f64,
        /// Change per lattice row.
        by: f64,
    },
    /// The equirect's ray tables (unit rays `(sinθ cosφ, sinθ sinφ, cosθ)`).
    Rays {
        /// `cos φ` per column.
        cos_phi: &'a [f64],
        /// `sin φ` per column.
        sin_phi: &'a [f64],
        /// `cos θ` per row.
        cos_theta: &'a [f64],
        /// `sin θ` per row.
        sin_theta: &'a [f64],
        /// The vector dotted with the rays (a plane normal).
        n: DVec3,
    },
}

impl PlaneDot<'_> {
    /// `n·r` at lattice vertex `(x, y)`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f64 {
        self.row(y).at(x)
    }

    /// `n·r` along lattice row `y`, with the row's terms computed once.
    #[inline]
    pub fn row(&self, y: usize) -> RowDot<'_> {
        match self {
            PlaneDot::Affine { a, bx, by } => RowDot::Affine { base: a + by * y as f64, bx: *bx },
            PlaneDot::Rays { cos_phi, sin_phi, cos_theta, sin_theta, n } => RowDot::Equirect {
                cos_phi,
                sin_phi,
                st: sin_theta[y],
                z: n.z * cos_theta[y],
                nx: n.x,
                ny: n.y,
            },
        }
    }
}

/// `n·r` along one lattice row, see [`PlaneDot::row`].
pub enum RowDot<'a> {
    /// A cube face: `n·r(x) = base + bx·x`.
    Affine {
        /// Value at column 0 of the row.
        base: f64,
        /// Change per lattice column.
        bx: f64,
    },
    /// The equirect: `n·r(x) = nx·st·cos φ + ny·st·sin φ + z`.
    Equirect {
        /// `cos φ` per column.
        cos_phi: &'a [f64],
        /// `sin φ` per column.
        sin_phi: &'a [f64],
        /// `sin θ` of the row.
        st: f64,
        /// `n.z · cos θ` of the row.
        z: f64,
        /// `n.x`.
        nx: f64,
        /// `n.y`.
        ny: f64,
    },
}

impl RowDot<'_> {
    /// `n·r` at column `x` of the row.
    #[inline]
    pub fn at(&self, x: usize) -> f64 {
        match self {
            RowDot::Affine { base, bx } => base + bx * x as f64,
            RowDot::Equirect { cos_phi, sin_phi, st, z, nx, ny } => {
                nx * (st * cos_phi[x]) + ny * (st * sin_phi[x]) + z
            }
        }
    }
}

/// One lattice with its samples.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Canvas origin of vertex `(0, 0)`.
    pub ox: usize,
    /// Canvas row of vertex `(0, 0)`.
    pub oy: usize,
    /// Lattice size in vertices.
    pub w: usize,
    /// Lattice height in vertices.
    pub h: usize,
    /// Canvas width (for canvas pixel indices).
    pub canvas_w: usize,
    /// How the ray through each vertex is computed.
    pub rays: Rays,
    /// `λ` per vertex, `NaN` when the pixel cannot be meshed.
    pub lambda: Vec<f32>,
    /// Depth per vertex (`NaN` when invalid).
    pub depth: Vec<f32>,
}

impl Grid {
    /// Sample the lattice `w × h` at canvas origin `(ox, oy)` from a full-canvas layer image.
    pub fn new(image: &LayerImage, ox: usize, oy: usize, w: usize, h: usize, rays: Rays) -> Grid {
        use rayon::prelude::*;
        let (Some(z), a) = (image.depth(), image.coverage()) else {
            let (lambda, depth) = (vec![f32::NAN; w * h], vec![f32::NAN; w * h]);
            return Grid { ox, oy, w, h, canvas_w: image.width, rays, lambda, depth };
        };
        // Zeroed allocations come lazily from the OS: the pages are first touched (and zeroed by the
        // kernel) by the parallel loop below, which writes every element, instead of by one thread.
        let mut lambda = vec![0.0f32; w * h];
        let mut depth = vec![0.0f32; w * h];
        // |r|² = 1 + s² + t² on a cube face (orthonormal frame); equirect rays are unit.
        let (s2, t2): (Vec<f64>, Vec<f64>) = match &rays {
            Rays::Face { n, .. } => {
                let sq = |i: usize| (2.0 * (i as f64 + 0.5) / *n as f64 - 1.0).powi(2);
                ((0..w).map(sq).collect(), (0..h).map(sq).collect())
            }
            Rays::Equirect { .. } => (vec![0.0; w], vec![0.0; h]),
        };
        lambda.par_chunks_mut(w.max(1)).zip(depth.par_chunks_mut(w.max(1))).enumerate().for_each(
            |(y, (lrow, drow))| {
                let start = (oy + y) * image.width + ox;
                let zrow = &z[start..start + w];
                let arow = a.map(|a| &a[start..start + w]);
                for x in 0..w {
                    // `classify` gives a surface; meshing also needs it at a positive finite depth.
                    let d = zrow[x];
                    if d > 0.0 && d.is_finite() && arow.is_none_or(|a| a[x] > 0.0) {
                        debug_assert!(matches!(classify(d, arow.map(|a| a[x])), Sample::Surface(_)));
                        drow[x] = d;
                        lrow[x] = (d as f64 / (1.0 + s2[x] + t2[y]).sqrt()) as f32;
                    } else {
                        drow[x] = f32::NAN;
                        lrow[x] = f32::NAN;
                    }
                }
            },
        );
        Grid { ox, oy, w, h, canvas_w: image.width, rays, lambda, depth }
    }

    /// Canvas pixel index of vertex `(x, y)`.
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> u32 {
        ((self.oy + y) * self.canvas_w + self.ox + x) as u32
    }

    /// Whether vertex `(x, y)` has a positive finite depth and can be meshed.
    #[inline]
    pub fn valid(&self, x: usize, y: usize) -> bool {
        !self.lambda[y * self.w + x].is_nan()
    }

    /// Depth of vertex `(x, y)`: distance from the panorama centre, metres; `NaN` when invalid.
    #[inline]
    pub fn depth_at(&self, x: usize, y: usize) -> f64 {
        self.depth[y * self.w + x] as f64
    }

    /// 3D point (panorama frame) of vertex `(x, y)`; meaningless when invalid.
    #[inline]
    pub fn point(&self, x: usize, y: usize) -> DVec3 {
        self.rays.ray(x, y) * self.lambda[y * self.w + x] as f64
    }

    /// Two valid vertices that may be joined by an edge.
    #[inline]
    pub fn connected(&self, a: (usize, usize), b: (usize, usize)) -> bool {
        self.valid(a.0, a.1)
            && self.valid(b.0, b.1)
            && !is_jump(self.depth_at(a.0, a.1), self.depth_at(b.0, b.1))
    }

    /// A cell that cannot be one continuous quad: a corner invalid or a jump along a side or diagonal.
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x <= y)` is deliberate: NaN must count as apart.
    pub fn bad_cell(&self, x: usize, y: usize) -> bool {
        let i = y * self.w + x;
        let d = &self.depth;
        // A vertex is valid exactly when its depth is not NaN; NaN fails every `<=`, so a pair with an
        // invalid vertex counts as apart, as with `!connected`.
        let apart = |a: f32, b: f32| {
            let (a, b) = (a as f64, b as f64);
            !((a - b).abs() <= JUMP_THRESHOLD * a.min(b))
        };
        let (d0, d1, d2, d3) = (d[i], d[i + 1], d[i + self.w + 1], d[i + self.w]);
        apart(d0, d1) || apart(d1, d2) || apart(d2, d3) || apart(d3, d0) || apart(d0, d2) || apart(d1, d3)
    }
}
