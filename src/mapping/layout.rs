//! Cube-map layouts of other tools, as exact re-orderings of the canonical 3×2 canvas (spec §3.5).
//!
//! Every layout is a grid of six `N × N` slots; slot `k` (row-major) shows one cube face through a
//! *frame* `(centre, right, down)` of signed unit axes **in the POMC panorama frame**: the slot's texel at
//! face coordinates `a, b ∈ [−1, 1]` (rightwards, downwards) looks along `centre + a·right + b·down`.
//! Two layouts showing the same face differ by a 2×2 signed permutation of `(a, b)`, so conversion is a
//! pixel copy with flips, transposes and rotations, exact for any face size.
//!
//! Foreign layouts are defined by identifying *equirect pictures*: a foreign tool and `pomc` reading the
//! same equirect image must produce the same cube image. Each tool's equirect convention fixes a linear
//! map from its frame to ours, and the frames below are the tool's own face formulas pushed through it
//! (derivations in spec §3.5). All three foreign tools view the sphere from inside, while the POMC
//! equirect (azimuth growing rightwards from `+X` towards `+Y`, `+Z` up) is seen from outside, so their
//! faces are mirror images of the canonical faces (`right × down = −centre` instead of `+centre`).

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use crate::raster::Raster;

/// A signed unit axis as an integer vector, so frame algebra is exact.
type Axis = [i32; 3];

const PX: Axis = [1, 0, 0];
const NX: Axis = [-1, 0, 0];
const PY: Axis = [0, 1, 0];
const NY: Axis = [0, -1, 0];
const PZ: Axis = [0, 0, 1];
const NZ: Axis = [0, 0, -1];

/// A slot's view of a face: `(centre, right, down)`.
pub type SlotFrame = [[i32; 3]; 3];

/// Canonical 3×2 (thesis A.3): `+X +Y +Z / −X −Y −Z`.
const CANONICAL: [SlotFrame; 6] =
    [[PX, NY, NZ], [PY, PX, NZ], [PZ, NX, NY], [NX, PY, NZ], [NY, NX, NZ], [NZ, PX, NY]];

/// ffmpeg `v360` `c3x2` with the default `out_forder=rludfb`, `out_frot=000000`.
/// ffmpeg frame (right, down, forward) = POMC `(−y, −z, −x)`.
const FFMPEG_C3X2: [SlotFrame; 6] = [
    [NY, PX, NZ], // right
    [PY, NX, NZ], // left
    [PZ, NY, NX], // up
    [NZ, NY, PX], // down
    [NX, NY, NZ], // front
    [PX, PY, NZ], // back
];

/// OpenEXR `envmap=cube` (ImfEnvmap): faces `+X −X +Y −Y +Z −Z` of the EXR frame stacked vertically.
/// EXR frame (x, y up, z) = POMC `(y, z, −x)`.
const OPENEXR_VSTRIP: [SlotFrame; 6] = [
    [PY, NX, NZ], // +X exr
    [NY, PX, NZ], // −X exr
    [PZ, PY, PX], // +Y exr (up)
    [NZ, PY, NX], // −Y exr (down)
    [NX, NY, NZ], // +Z exr
    [PX, PY, NZ], // −Z exr
];

/// py360convert `cube_format="horizon"`: `F R B L U D` side by side.
/// py360convert frame (x right, y up, z front) = POMC `(−y, z, −x)`.
const PY360_HORIZON: [SlotFrame; 6] = [
    [NX, NY, NZ], // F
    [NY, PX, NZ], // R
    [PX, PY, NZ], // B
    [PY, NX, NZ], // L
    [PZ, NY, NX], // U
    [NZ, NY, PX], // D
];

/// A cube-map image layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CubeLayout {
    /// The thesis's 3×2 canvas, POMC's storage layout.
    Canonical,
    /// ffmpeg `v360=…:c3x2` (default face order `rludfb`, no rotations), 3×2.
    FfmpegC3x2,
    /// OpenEXR cube environment map: a vertical strip 1×6.
    OpenExrVStrip,
    /// py360convert `horizon`: a horizontal strip 6×1.
    Py360Horizon,
}

/// A canvas that cannot hold a given layout, or a malformed layout name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LayoutError {
    /// The image is not `cols·N × rows·N` for the layout's slot grid (code `LAYOUT_BAD_SIZE`).
    #[error(
        "a {width}x{height} image is not a {layout} cube map (expected {cols}N x {rows}N with square faces)"
    )]
    BadSize {
        /// The layout asked for.
        layout: CubeLayout,
        /// The image width, pixels.
        width: usize,
        /// The image height, pixels.
        height: usize,
        /// Slot columns of the layout.
        cols: usize,
        /// Slot rows of the layout.
        rows: usize,
    },
    #[error("unknown cube layout '{0}'; expected canonical, ffmpeg-c3x2, openexr-vstrip or py360-horizon")]
    /// A layout name other than those of [`CubeLayout::name`] (code `LAYOUT_UNKNOWN`).
    UnknownName(String),
}

crate::codes::error_codes! {
    LayoutError:
        BadSize LAYOUT_BAD_SIZE,
        UnknownName LAYOUT_UNKNOWN
}

impl CubeLayout {
    /// Every layout, canonical first.
    pub const ALL: [CubeLayout; 4] =
        [CubeLayout::Canonical, CubeLayout::FfmpegC3x2, CubeLayout::OpenExrVStrip, CubeLayout::Py360Horizon];

    /// Stable name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            CubeLayout::Canonical => "canonical",
            CubeLayout::FfmpegC3x2 => "ffmpeg-c3x2",
            CubeLayout::OpenExrVStrip => "openexr-vstrip",
            CubeLayout::Py360Horizon => "py360-horizon",
        }
    }

    /// Grid of slots `(columns, rows)`.
    pub fn grid(self) -> (usize, usize) {
        match self {
            CubeLayout::Canonical | CubeLayout::FfmpegC3x2 => (3, 2),
            CubeLayout::OpenExrVStrip => (1, 6),
            CubeLayout::Py360Horizon => (6, 1),
        }
    }

    /// Frames of the six slots, row-major.
    pub fn frames(self) -> &'static [SlotFrame; 6] {
        match self {
            CubeLayout::Canonical => &CANONICAL,
            CubeLayout::FfmpegC3x2 => &FFMPEG_C3X2,
            CubeLayout::OpenExrVStrip => &OPENEXR_VSTRIP,
            CubeLayout::Py360Horizon => &PY360_HORIZON,
        }
    }

    /// Canvas size for faces of `n` pixels (saturating: absurd sizes stay absurd, they do not wrap).
    pub fn canvas_size(self, n: usize) -> (usize, usize) {
        let (c, r) = self.grid();
        (c.saturating_mul(n), r.saturating_mul(n))
    }

    /// Face size of a `width × height` canvas in this layout.
    pub fn face_size(self, width: usize, height: usize) -> Result<usize, LayoutError> {
        let (cols, rows) = self.grid();
        let n = width / cols;
        if n == 0 || n * cols != width || n.checked_mul(rows) != Some(height) {
            return Err(LayoutError::BadSize { layout: self, width, height, cols, rows });
        }
        Ok(n)
    }

    /// Top-left pixel of slot `k`, for faces of `n` pixels.
    pub fn slot_origin(self, k: usize, n: usize) -> (usize, usize) {
        let (cols, _) = self.grid();
        ((k % cols) * n, (k / cols) * n)
    }
}

impl fmt::Display for CubeLayout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for CubeLayout {
    type Err = LayoutError;
    fn from_str(s: &str) -> Result<Self, LayoutError> {
        CubeLayout::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| LayoutError::UnknownName(s.to_string()))
    }
}

fn dot(a: Axis, b: Axis) -> i32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// How a destination slot reads its source slot: `src slot`, and for the source coordinates
/// `a = pa·a' + qa·b'`, `b = pb·a' + qb·b'` (one non-zero coefficient per row, each ±1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotMap {
    /// Index of the source slot (row-major) showing the same face.
    pub src_slot: usize,
    /// `(pa, qa)`: source `a` from destination `(a', b')`.
    pub a: (i32, i32),
    /// `(pb, qb)`: source `b` from destination `(a', b')`.
    pub b: (i32, i32),
}

/// The slot maps taking layout `from` to layout `to`, indexed by destination slot.
pub fn slot_maps(from: CubeLayout, to: CubeLayout) -> [SlotMap; 6] {
    let src = from.frames();
    std::array::from_fn(|k| {
        let [c2, r2, d2] = to.frames()[k];
        // Every layout shows each axis exactly once (checked by a unit test).
        let m = src.iter().position(|f| f[0] == c2).unwrap_or(0);
        let [_, r, d] = src[m];
        // Same direction: a'·r2 + b'·d2 = a·r + b·d, with r, d orthonormal.
        SlotMap { src_slot: m, a: (dot(r2, r), dot(d2, r)), b: (dot(r2, d), dot(d2, d)) }
    })
}

/// Source texel index along one axis of a face of `n` texels for destination texel `(i, j)`.
#[inline]
fn pick(coef: (i32, i32), i: usize, j: usize, n: usize) -> usize {
    match coef {
        (1, _) => i,
        (-1, _) => n - 1 - i,
        (_, 1) => j,
        _ => n - 1 - j,
    }
}

/// Re-order a cube map from layout `from` to layout `to` (exact pixel copy; any channel count).
pub fn convert_layout<T: Copy + Send + Sync>(
    src: &Raster<T>,
    from: CubeLayout,
    to: CubeLayout,
) -> Result<Raster<T>, LayoutError> {
    let n = from.face_size(src.width(), src.height())?;
    if from == to {
        return Ok(src.clone());
    }
    let maps = slot_maps(from, to);
    let (w, h) = to.canvas_size(n);
    let ch = src.channels();
    let (cols, _) = to.grid();
    let mut data: Vec<T> = src.data().to_vec(); // same length; every sample is overwritten below
    data.par_chunks_mut(w * ch).enumerate().for_each(|(y, row)| {
        let j = y % n;
        for sc in 0..cols {
            let k = (y / n) * cols + sc;
            let m = maps[k];
            let (ox, oy) = from.slot_origin(m.src_slot, n);
            for i in 0..n {
                let si = pick(m.a, i, j, n);
                let sj = pick(m.b, i, j, n);
                let s = src.pixel(ox + si, oy + sj);
                let o = (sc * n + i) * ch;
                row[o..o + ch].copy_from_slice(s);
            }
        }
    });
    Ok(Raster::from_vec(w, h, ch, data).expect("same sample count"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::CubeFace;

    fn cross(a: Axis, b: Axis) -> Axis {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }

    #[test]
    fn layouts_cover_every_face_once_with_orthonormal_frames() {
        for l in CubeLayout::ALL {
            let mut seen = std::collections::HashSet::new();
            for [c, r, d] in l.frames() {
                assert!(seen.insert(*c), "{l}: face {c:?} twice");
                assert_eq!(dot(*c, *r), 0);
                assert_eq!(dot(*c, *d), 0);
                assert_eq!(dot(*r, *d), 0);
                let want = if l == CubeLayout::Canonical { *c } else { c.map(|v| -v) };
                assert_eq!(cross(*r, *d), want, "{l}: handedness");
            }
        }
    }

    #[test]
    fn canonical_frames_match_cube_faces() {
        for f in CubeFace::ALL {
            let [c, r, d] = f.frame();
            let k = CANONICAL[f.index()];
            let v = |a: Axis| glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
            assert_eq!([v(k[0]), v(k[1]), v(k[2])], [c, r, d]);
        }
    }

    #[test]
    fn round_trips_are_identity() {
        let n = 5;
        for l in CubeLayout::ALL {
            let (w, h) = CubeLayout::Canonical.canvas_size(n);
            let src = Raster::from_vec(w, h, 2, (0..w * h * 2).map(|v| v as u32).collect()).unwrap();
            let there = convert_layout(&src, CubeLayout::Canonical, l).unwrap();
            assert_eq!(there.width(), l.canvas_size(n).0);
            let back = convert_layout(&there, l, CubeLayout::Canonical).unwrap();
            assert_eq!(back, src, "{l}");
        }
    }

    #[test]
    fn names_parse() {
        for l in CubeLayout::ALL {
            assert_eq!(l.name().parse::<CubeLayout>().unwrap(), l);
        }
        assert!("dice".parse::<CubeLayout>().is_err());
    }
}
