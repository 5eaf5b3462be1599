//! The 8-neighbourhood of every pixel on the sphere: across the equirect seam, over the poles
//! (the row beyond a pole is the same row shifted by W/2) and across cube-face edges, so that
//! every stage of layer building sees one continuous canvas.

use glam::DVec3;

use crate::mapping::{AnyMapping, Mapping};

/// Offsets of the 8 neighbours, `(dx, dy)`; the first four are the 4-neighbours.
pub const OFFSETS: [(i32, i32); 8] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1)];

/// Index of the opposite offset in [`OFFSETS`] (pairs are adjacent: 0↔1, 2↔3, 4↔7, 5↔6).
#[inline]
pub fn opposite(k: usize) -> usize {
    [1, 0, 3, 2, 7, 6, 5, 4][k]
}

/// Neighbour lookup for one canvas.
#[derive(Clone, Debug)]
pub struct Neighbours {
    mapping: AnyMapping,
    width: usize,
    height: usize,
    /// Columns / rows whose 8 neighbours are plain offsets (not at the canvas or a face edge).
    interior_col: Vec<bool>,
    interior_row: Vec<bool>,
    /// Columns / rows two steps from any such edge (two steps along any offset are plain too).
    interior2_col: Vec<bool>,
    interior2_row: Vec<bool>,
}

impl Neighbours {
    /// The neighbour lookup of `mapping`'s canvas.
    pub fn new(mapping: AnyMapping) -> Self {
        let (width, height) = (mapping.width(), mapping.height());
        let tile = match mapping {
            AnyMapping::Equirect(_) => width.max(height),
            AnyMapping::Cube(_) => height / 2,
        };
        let interior = |len: usize, r: usize| -> Vec<bool> {
            (0..len).map(|i| i % tile >= r && i % tile + r < tile && i + r < len).collect()
        };
        Neighbours {
            mapping,
            width,
            height,
            interior_col: interior(width, 1),
            interior_row: interior(height, 1),
            interior2_col: interior(width, 2),
            interior2_row: interior(height, 2),
        }
    }

    /// Canvas width, pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Canvas height, pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of pixels, `width · height`.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    /// Whether the canvas has no pixels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The canvas's mapping.
    pub fn mapping(&self) -> &AnyMapping {
        &self.mapping
    }

    /// Whether the 8 neighbours of `(x, y)` are the plain offsets `±1`, `±W` (not at the canvas or a
    /// face edge).
    #[inline]
    pub fn is_interior(&self, x: usize, y: usize) -> bool {
        self.interior_col[x] && self.interior_row[y]
    }

    /// Whether one and two steps along every offset from `(x, y)` are plain offsets
    /// ([`Neighbours::offset`], twice it).
    #[inline]
    pub fn is_interior2(&self, x: usize, y: usize) -> bool {
        self.interior2_col[x] && self.interior2_row[y]
    }

    /// Whether row `y` has pixels two steps from any edge ([`Neighbours::is_interior2`] for some column).
    #[inline]
    pub fn is_interior2_row(&self, y: usize) -> bool {
        self.interior2_row[y]
    }

    /// The pixel-index step of offset `k` where it is plain (inside the canvas or a face).
    #[inline]
    pub fn offset(&self, k: usize) -> isize {
        let (dx, dy) = OFFSETS[k];
        dy as isize * self.width as isize + dx as isize
    }

    /// Neighbour `k` (index into [`OFFSETS`]) of pixel index `p`; `None` only where the sphere
    /// has no distinct neighbour (a cube corner's missing diagonal).
    #[inline]
    pub fn get(&self, p: usize, k: usize) -> Option<usize> {
        self.get_at(p % self.width, p / self.width, k)
    }

    /// [`Neighbours::get`] for a pixel given by its coordinates (no division in the common case:
    /// hot loops walk rows and know them).
    #[inline]
    pub fn get_at(&self, x: usize, y: usize, k: usize) -> Option<usize> {
        let (dx, dy) = OFFSETS[k];
        if self.is_interior(x, y) {
            // Interior of the canvas (equirect) or of a face (cube): plain offsets.
            let nx = (x as isize + dx as isize) as usize;
            let ny = (y as isize + dy as isize) as usize;
            return Some(ny * self.width + nx);
        }
        self.get_slow(x as i64, y as i64, dx, dy, y * self.width + x)
    }

    /// The neighbour of the neighbour, two steps along `k` (continuing over edges step by step).
    #[inline]
    pub fn get2_at(&self, x: usize, y: usize, k: usize) -> Option<usize> {
        if self.is_interior2(x, y) {
            return Some((y * self.width + x).wrapping_add_signed(2 * self.offset(k)));
        }
        let (dx, dy) = OFFSETS[k];
        let q = self.get_at(x, y, k)?;
        if self.is_interior(x, y) {
            let (qx, qy) = ((x as isize + dx as isize) as usize, (y as isize + dy as isize) as usize);
            return self.get_at(qx, qy, k);
        }
        self.get(q, k)
    }

    fn get_slow(&self, x: i64, y: i64, dx: i32, dy: i32, p: usize) -> Option<usize> {
        let (nx, ny) = (x + dx as i64, y + dy as i64);
        match self.mapping {
            AnyMapping::Equirect(_) => {
                let (w, h) = (self.width as i64, self.height as i64);
                let (mut nx, mut ny) = (nx, ny);
                if ny < 0 || ny >= h {
                    // Over the pole: same latitude band, opposite azimuth.
                    ny = if ny < 0 { -ny - 1 } else { 2 * h - ny - 1 };
                    nx += w / 2;
                }
                let nx = nx.rem_euclid(w);
                Some((ny * w + nx) as usize)
            }
            AnyMapping::Cube(_) => {
                let n = self.height as i64 / 2;
                let (fx, fy) = (x / n, y / n);
                let (lx, ly) = (nx - fx * n, ny - fy * n);
                if (0..n).contains(&lx) && (0..n).contains(&ly) {
                    return Some((ny * self.width as i64 + nx) as usize);
                }
                if !(0..n).contains(&lx) && !(0..n).contains(&ly) {
                    // Diagonal step past a face corner: three faces meet there, no fourth pixel.
                    let corner_x = if lx < 0 { 0 } else { n - 1 };
                    let corner_y = if ly < 0 { 0 } else { n - 1 };
                    if (x - fx * n, y - fy * n) == (corner_x, corner_y) {
                        return None;
                    }
                }
                // Leave the face through its plane: extend the face's own parametrisation past
                // [-1, 1] and let the mapping find the pixel on the adjacent face.
                let face = (fy * 3 + fx) as usize;
                let s = 2.0 * (lx as f64 + 0.5) / n as f64 - 1.0;
                let t = 2.0 * (ly as f64 + 0.5) / n as f64 - 1.0;
                let (i, j) = self.mapping.pixel_of(face_dir(face, s, t));
                let q = j * self.width + i;
                (q != p).then_some(q)
            }
        }
    }

    /// All existing neighbours of `p` (up to 8).
    #[inline]
    pub fn all(&self, p: usize) -> impl Iterator<Item = usize> + '_ {
        (0..8).filter_map(move |k| self.get(p, k))
    }
}

/// Direction of face-local coordinates `(s, t)` (thesis A.3 inverse table; `s, t` may leave
/// `[-1, 1]`, which continues the face's plane).
fn face_dir(face: usize, s: f64, t: f64) -> DVec3 {
    match face {
        0 => DVec3::new(1.0, -s, -t),
        1 => DVec3::new(s, 1.0, -t),
        2 => DVec3::new(-s, -t, 1.0),
        3 => DVec3::new(-1.0, s, -t),
        4 => DVec3::new(-s, -1.0, -t),
        _ => DVec3::new(s, -t, -1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::MappingKind;

    /// Two steps along an offset are the neighbour of the neighbour, on every pixel of both
    /// mappings (the plain-offset fast path agrees with stepping over seams, poles and face edges).
    #[test]
    fn two_steps_are_one_step_twice() {
        for (kind, w, h) in [(MappingKind::Equirect, 24, 12), (MappingKind::Cube3x2, 36, 24)] {
            let nb = Neighbours::new(AnyMapping::new(kind, w, h).unwrap());
            for y in 0..h {
                for x in 0..w {
                    for k in 0..8 {
                        let twice = nb.get_at(x, y, k).and_then(|q| nb.get(q, k));
                        assert_eq!(nb.get2_at(x, y, k), twice, "{kind:?} ({x}, {y}) k {k}");
                    }
                }
            }
        }
    }
}
