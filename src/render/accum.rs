//! Per-output-pixel visibility and filtering (thesis Alg. 9 with the visibility rule of Alg. 10).
//!
//! Each output pixel keeps the nearest *surface group* seen so far: the layer and smallest camera
//! distance `z` of its nearest sample and the filter sums of the samples of that layer within a
//! relative tolerance of it. A sample nearer than the group (clearly nearer, for the same layer)
//! replaces it — nearer surfaces win, whatever the painter's order; a sample of the same layer
//! within the tolerance joins it (samples of one surface blend, which anti-aliases); anything else
//! is dropped. As in the thesis (Alg. 10), samples of another layer never blend in: hidden fill
//! of a back layer a few centimetres behind an object's base does not speckle through it.
//! Infinitely far samples (`z = +inf`) group together behind all finite ones. The rule is
//! order-independent up to the tolerance, so per-thread buffers can be merged in any order
//! ([`Accum::merge`]).

/// Filter sums of one output pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Camera distance of the nearest sample in the group (`+inf` for infinity samples).
    pub z: f32,
    /// Sum of filter weights (0 = no sample: a hole).
    pub w: f32,
    /// Weighted sum of camera distances.
    pub wz: f32,
    /// Weighted sum of linear colour.
    pub rgb: [f32; 3],
    /// Layer of the group.
    pub layer: u32,
}

const EMPTY: Cell = Cell { z: f32::INFINITY, w: 0.0, wz: 0.0, rgb: [0.0; 3], layer: 0 };

/// An accumulation buffer over the output image.
#[derive(Clone, Debug)]
pub struct Accum {
    /// Output width, pixels.
    pub width: usize,
    /// Output height, pixels.
    pub height: usize,
    /// One cell per output pixel, row-major, top row first.
    pub cells: Vec<Cell>,
    /// Relative depth tolerance of a surface group.
    tolerance: f32,
}

/// Where a sample at distance `z` stands against a group whose nearest distance is `group`.
#[derive(PartialEq, Eq)]
enum Rank {
    Nearer,
    Same,
    Farther,
}

#[inline]
fn rank(s: &Cell, group: &Cell, tol: f32) -> Rank {
    let (z, g) = (s.z, group.z);
    if s.layer != group.layer {
        return if z < g { Rank::Nearer } else { Rank::Farther };
    }
    if z < g * (1.0 - tol) {
        Rank::Nearer
    } else if z <= g * (1.0 + tol) {
        // inf <= inf: infinity samples form one group.
        Rank::Same
    } else {
        Rank::Farther
    }
}

impl Accum {
    /// An empty buffer of `width × height` pixels; `tolerance` is the relative depth range (e.g.
    /// 0.01 = 1 %) within which samples of one layer join a surface group.
    pub fn new(width: usize, height: usize, tolerance: f64) -> Self {
        Accum { width, height, cells: vec![EMPTY; width * height], tolerance: tolerance as f32 }
    }

    /// Add a sample of `layer` at camera distance `z` with weight `w > 0` at pixel index `i`.
    #[inline]
    pub fn add(&mut self, i: usize, z: f32, w: f32, rgb: [f32; 3], layer: u32) {
        let c = &mut self.cells[i];
        let sample = Cell { z, w, wz: w * z, rgb: [w * rgb[0], w * rgb[1], w * rgb[2]], layer };
        if c.w == 0.0 {
            *c = sample;
            return;
        }
        match rank(&sample, c, self.tolerance) {
            Rank::Nearer => *c = sample,
            Rank::Same => join(c, &sample),
            Rank::Farther => {}
        }
    }

    /// Fold another buffer of the same size into this one with the same rule.
    pub fn merge(&mut self, other: &Accum) {
        let tol = self.tolerance;
        for (c, o) in self.cells.iter_mut().zip(&other.cells) {
            if o.w == 0.0 {
                continue;
            }
            if c.w == 0.0 {
                *c = *o;
                continue;
            }
            match rank(o, c, tol) {
                Rank::Nearer => *c = *o,
                Rank::Same => join(c, o),
                Rank::Farther => {}
            }
        }
    }
}

#[inline]
fn join(c: &mut Cell, s: &Cell) {
    c.z = c.z.min(s.z);
    c.w += s.w;
    c.wz += s.wz;
    for k in 0..3 {
        c.rgb[k] += s.rgb[k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearer_wins_same_surface_blends_infinity_stays_behind() {
        let mut a = Accum::new(1, 1, 0.03);
        a.add(0, f32::INFINITY, 1.0, [1.0, 0.0, 0.0], 2);
        a.add(0, 2.0, 0.5, [0.0, 1.0, 0.0], 1);
        a.add(0, 2.02, 0.5, [0.0, 0.0, 1.0], 1);
        a.add(0, 3.0, 1.0, [1.0, 1.0, 1.0], 1);
        a.add(0, f32::INFINITY, 1.0, [1.0, 0.0, 0.0], 2);
        // Another layer just behind the group's surface does not blend in.
        a.add(0, 2.01, 1.0, [1.0, 1.0, 1.0], 0);
        let c = a.cells[0];
        assert_eq!((c.z, c.w, c.rgb), (2.0, 1.0, [0.0, 0.5, 0.5]));
        assert!((c.wz - 2.01).abs() < 1e-6);
    }

    #[test]
    fn merging_gives_the_same_result_as_one_buffer() {
        let (mut a, mut b, mut one) =
            (Accum::new(1, 1, 0.03), Accum::new(1, 1, 0.03), Accum::new(1, 1, 0.03));
        for (buf, z) in [(&mut a, 5.0), (&mut b, 2.0)] {
            buf.add(0, z, 1.0, [z, z, z], 0);
            one.add(0, z, 1.0, [z, z, z], 0);
        }
        a.merge(&b);
        assert_eq!(a.cells[0], one.cells[0]);
        let mut inf = Accum::new(1, 1, 0.03);
        inf.add(0, f32::INFINITY, 1.0, [1.0; 3], 1);
        a.merge(&inf);
        assert_eq!(a.cells[0], one.cells[0]);
    }
}
