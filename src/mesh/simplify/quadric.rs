//! Relative Garland–Heckbert quadrics and the collapse candidates they order.

use std::cmp::Ordering;

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Loc {
    Pole,
    Lattice { g: u8, x: u32, y: u32 },
}

#[derive(Clone, Copy, Default)]
pub(super) struct Quadric([f64; 10]);

impl Quadric {
    pub(super) fn plane(n: DVec3, d: f64, w: f64) -> Quadric {
        let (a, b, c) = (n.x, n.y, n.z);
        Quadric([a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d].map(|v| v * w))
    }
    pub(super) fn add(&mut self, o: &Quadric) {
        for k in 0..10 {
            self.0[k] += o.0[k];
        }
    }
    /// `Σ w (n·p − d)²` with the planes stored as `(n, −d)`.
    pub(super) fn eval(&self, p: DVec3) -> f64 {
        let q = &self.0;
        let (x, y, z) = (p.x, p.y, p.z);
        q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9]
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Cand {
    pub(super) cost: f64,
    pub(super) v: u32,
    pub(super) u: u32,
    pub(super) stamp: u32,
}

impl PartialEq for Cand {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Cand {}
impl PartialOrd for Cand {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cand {
    /// Reversed: `BinaryHeap` pops the cheapest, then the lowest `(v, u)`.
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then(o.v.cmp(&self.v))
            .then(o.u.cmp(&self.u))
            .then(o.stamp.cmp(&self.stamp))
    }
}
