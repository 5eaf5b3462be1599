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
//!
//! Each pixel also keeps the nearest group *behind* its nearest one, and each group the share of the
//! pixel its samples cover. A nearest group that covers only part of the pixel (the filter of the
//! samples at an object's silhouette reaching past it) is blended over the group behind by that
//! share ([`Accum::resolve`]): silhouettes neither grow by the filter's radius nor alias.
//!
//! Samples that cover nothing (`cover` 0: the border strips of a footprint) go to a third group,
//! the nearest *fill*, shown only where no other sample lands: they close cracks between two
//! layers' edges that open onto nothing, without growing silhouettes or hiding what is behind them
//! (a crack with a layer behind it still shows that layer).

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
    /// Share of the pixel the group's samples cover: the sum of each sample's filter weight times
    /// its area over the filter's integral (about 1 inside a surface, ½ on its edge).
    pub cover: f32,
}

const EMPTY: Cell = Cell { z: f32::INFINITY, w: 0.0, wz: 0.0, rgb: [0.0; 3], layer: 0, cover: 0.0 };

/// Coverage from which the nearest group shows alone; below it, it is blended over the group behind
/// in proportion. Half, not all: the sums inside a surface ripple (by −20 to +35 % with the tent of
/// stop 17; sample spacing and filter radius are not commensurate), and where a crease is judged a discontinuity the footprints
/// of its two sides leave a sliver between them; half covered, each side still hides what is behind.
const COVER_FULL: f32 = 0.5;

/// An accumulation buffer over the output image.
#[derive(Clone, Debug)]
pub struct Accum {
    /// Output width, pixels.
    pub width: usize,
    /// Output height, pixels.
    pub height: usize,
    /// One cell per output pixel, row-major, top row first: its nearest surface group.
    pub cells: Vec<Cell>,
    /// The nearest group behind each cell's (empty: `w = 0`).
    pub behind: Vec<Cell>,
    /// The nearest group of samples that cover nothing, shown where `cells` is empty.
    pub fill: Vec<Cell>,
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
        let n = width * height;
        Accum {
            width,
            height,
            cells: vec![EMPTY; n],
            behind: vec![EMPTY; n],
            fill: vec![EMPTY; n],
            tolerance: tolerance as f32,
        }
    }

    /// Add a sample of `layer` at camera distance `z` with filter weight `w > 0` and coverage
    /// `cover` (see [`Cell::cover`]) at pixel index `i`; a sample that covers nothing (`cover` 0)
    /// only fills.
    #[inline]
    pub fn add(&mut self, i: usize, z: f32, w: f32, cover: f32, rgb: [f32; 3], layer: u32) {
        let sample = Cell { z, w, wz: w * z, rgb: [w * rgb[0], w * rgb[1], w * rgb[2]], layer, cover };
        if cover == 0.0 {
            insert_fill(&mut self.fill[i], &sample, self.tolerance);
        } else {
            insert(&mut self.cells[i], &mut self.behind[i], &sample, self.tolerance);
        }
    }

    /// Fold another buffer of the same size into this one with the same rule.
    pub fn merge(&mut self, other: &Accum) {
        let tol = self.tolerance;
        for (i, (o, ob)) in other.cells.iter().zip(&other.behind).enumerate() {
            for g in [o, ob] {
                if g.w > 0.0 {
                    insert(&mut self.cells[i], &mut self.behind[i], g, tol);
                }
            }
            if other.fill[i].w > 0.0 {
                insert_fill(&mut self.fill[i], &other.fill[i], tol);
            }
        }
    }

    /// The group shown at pixel `i` and the weight of its blend: the nearest group, over the one
    /// behind it by its coverage (`(nearest, None)` when it covers the pixel or nothing is behind).
    #[inline]
    pub fn resolve(&self, i: usize) -> (&Cell, Option<(&Cell, f32)>) {
        let (c, b) = (&self.cells[i], &self.behind[i]);
        if c.w == 0.0 {
            return (&self.fill[i], None);
        }
        if b.w == 0.0 {
            return (c, None);
        }
        let alpha = c.cover / COVER_FULL;
        // A NaN coverage shows the nearest group alone, like a full one.
        let alpha = if alpha.is_nan() { 1.0 } else { alpha.clamp(0.0, 1.0) };
        if alpha >= 1.0 {
            (c, None)
        } else {
            (c, Some((b, alpha)))
        }
    }
}

/// Put group `s` into a pixel's nearest group `c` and the one behind it `b`.
#[inline]
fn insert(c: &mut Cell, b: &mut Cell, s: &Cell, tol: f32) {
    if c.w == 0.0 {
        *c = *s;
        return;
    }
    match rank(s, c, tol) {
        Rank::Nearer => {
            *b = *c;
            *c = *s;
        }
        Rank::Same => join(c, s),
        Rank::Farther if b.w == 0.0 => *b = *s,
        Rank::Farther => match rank(s, b, tol) {
            Rank::Nearer => *b = *s,
            Rank::Same => join(b, s),
            Rank::Farther => {}
        },
    }
}

/// Put group `s` into a pixel's fill group `f`: the nearest.
#[inline]
fn insert_fill(f: &mut Cell, s: &Cell, tol: f32) {
    if f.w == 0.0 {
        *f = *s;
        return;
    }
    match rank(s, f, tol) {
        Rank::Nearer => *f = *s,
        Rank::Same => join(f, s),
        Rank::Farther => {}
    }
}

#[inline]
fn join(c: &mut Cell, s: &Cell) {
    c.z = c.z.min(s.z);
    c.w += s.w;
    c.wz += s.wz;
    c.cover += s.cover;
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
        a.add(0, f32::INFINITY, 1.0, 1.0, [1.0, 0.0, 0.0], 2);
        a.add(0, 2.0, 0.5, 1.0, [0.0, 1.0, 0.0], 1);
        a.add(0, 2.02, 0.5, 1.0, [0.0, 0.0, 1.0], 1);
        a.add(0, 3.0, 1.0, 1.0, [1.0, 1.0, 1.0], 1);
        a.add(0, f32::INFINITY, 1.0, 1.0, [1.0, 0.0, 0.0], 2);
        // Another layer just behind the group's surface does not blend in.
        a.add(0, 2.01, 1.0, 1.0, [1.0, 1.0, 1.0], 0);
        let c = a.cells[0];
        assert_eq!((c.z, c.w, c.rgb), (2.0, 1.0, [0.0, 0.5, 0.5]));
        assert!((c.wz - 2.01).abs() < 1e-6);
        // Behind the nearest group: the nearest other surface, of any layer.
        assert_eq!(a.behind[0].z, 2.01);
        // Covering the pixel, the nearest group is all that shows.
        assert!(a.resolve(0).1.is_none());
    }

    /// Samples that cover nothing (a footprint's border strip) show only where nothing else lands,
    /// the nearest of them; never over a group, nor in front of what is behind one.
    #[test]
    fn samples_covering_nothing_only_fill() {
        let mut a = Accum::new(3, 1, 0.01);
        a.add(0, 5.0, 1.0, 1.0, [0.0; 3], 0);
        a.add(0, 2.0, 1.0, 0.0, [1.0; 3], 1);
        a.add(1, 5.0, 1.0, 0.2, [0.0; 3], 0);
        a.add(1, 9.0, 1.0, 1.0, [0.5; 3], 2);
        a.add(1, 2.0, 1.0, 0.0, [1.0; 3], 1);
        a.add(2, 3.0, 1.0, 0.0, [0.25; 3], 1);
        a.add(2, 2.0, 1.0, 0.0, [1.0; 3], 1);
        a.add(2, 4.0, 1.0, 0.0, [0.5; 3], 1);
        let mut b = Accum::new(3, 1, 0.01);
        b.merge(&a);
        for acc in [&a, &b] {
            assert_eq!((acc.resolve(0).0.z, acc.resolve(0).1.is_none()), (5.0, true));
            let (c, behind) = acc.resolve(1);
            assert!(c.z == 5.0 && behind.is_some_and(|(b, alpha)| b.z == 9.0 && (alpha - 0.4).abs() < 1e-6));
            assert_eq!((acc.resolve(2).0.z, acc.resolve(2).0.rgb), (2.0, [1.0; 3]));
        }
    }

    /// An object's edge covering part of a pixel over a wall: the object's colour blends in by a
    /// share that grows with its coverage, all of it from ½.
    #[test]
    fn a_partly_covering_group_blends_over_the_one_behind() {
        let mut a = Accum::new(3, 1, 0.01);
        for (i, cover) in [(0, 1e-3f32), (1, 0.2), (2, 0.6)] {
            a.add(i, 5.0, 1.0, 1.0, [0.0; 3], 0);
            a.add(i, 2.0, 0.3, cover, [1.0; 3], 1);
        }
        assert_eq!(a.resolve(0).1.map(|(b, alpha)| (b.z, alpha)), Some((5.0, 2e-3)));
        let (_, blend) = a.resolve(1);
        assert!(blend.is_some_and(|(b, alpha)| b.z == 5.0 && (alpha - 0.4).abs() < 1e-6));
        assert!(a.resolve(2).1.is_none());
        // With nothing behind, even a sliver of coverage shows: no hole opens.
        let mut lone = Accum::new(1, 1, 0.01);
        lone.add(0, 2.0, 0.3, 0.05, [1.0; 3], 1);
        assert!(lone.resolve(0).1.is_none());
    }

    #[test]
    fn merging_gives_the_same_result_as_one_buffer() {
        let (mut a, mut b, mut one) =
            (Accum::new(1, 1, 0.03), Accum::new(1, 1, 0.03), Accum::new(1, 1, 0.03));
        for (buf, z) in [(&mut a, 5.0), (&mut b, 2.0)] {
            buf.add(0, z, 1.0, 1.0, [z, z, z], 0);
            one.add(0, z, 1.0, 1.0, [z, z, z], 0);
        }
        a.merge(&b);
        assert_eq!(a.cells[0], one.cells[0]);
        let mut inf = Accum::new(1, 1, 0.03);
        inf.add(0, f32::INFINITY, 1.0, 1.0, [1.0; 3], 1);
        a.merge(&inf);
        assert_eq!(a.cells[0], one.cells[0]);
    }
}
