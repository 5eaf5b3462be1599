//! Where a surface ends: depth discontinuities (scale-free) and folds (normal discontinuities)
//! between 8-neighbours, and normals estimated from depth when the input has none.

use glam::Vec3;
use rayon::prelude::*;

use crate::continuity::continuous_with;
use crate::mapping::{opposite, Neighbours, PixelDirs, OFFSETS};

/// Tuning of the discontinuity tests.
#[derive(Clone, Copy, Debug)]
pub struct EdgeOptions {
    /// Relative jump `|a−b| / min(a,b)` above which two neighbours *may* be on different surfaces.
    pub jump: f64,
    /// A jump is confirmed only if extrapolation (linear in 1/depth) from both sides misses by more
    /// than this fraction of the nearer pixel's inverse depth too: a plane seen at a grazing angle changes depth fast but smoothly.
    pub extrapolation: f64,
    /// Angle (degrees) between neighbouring normals above which the surface folds; `None` = no
    /// fold test.
    pub fold_deg: Option<f64>,
}

impl Default for EdgeOptions {
    fn default() -> Self {
        EdgeOptions { jump: crate::continuity::JUMP, extrapolation: 0.05, fold_deg: Some(35.0) }
    }
}

/// What separates a pixel from one neighbour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Link {
    /// Same surface.
    Smooth,
    /// Depth continuous but the surface folds (a crease, a contact line).
    Fold,
    /// Depth jumps: different surfaces; the nearer one occludes the farther.
    Jump,
}

/// Index into [`OFFSETS`] of a 4-neighbour offset.
fn axis(dx: i32, dy: i32) -> usize {
    OFFSETS.iter().position(|&o| o == (dx, dy)).expect("a 4-neighbour offset")
}

/// Depth usable by the tests: finite and positive, or +inf for content treated as infinitely far.
#[inline]
fn usable(d: f32) -> bool {
    d > 0.0 && !d.is_nan()
}

/// The depth links of every pixel to its 8 neighbours, computed once (bit `k` per pixel):
/// whether the pair can be compared at all, and whether its depth jumps. Folds are decided on
/// demand from normals, which are estimated from these links.
#[derive(Clone, Debug)]
pub struct Links {
    usable: Vec<u8>,
    jump: Vec<u8>,
    fold_cos: Option<f32>,
}

impl Links {
    /// Classify every pixel's 8 links (in parallel).
    pub fn compute(nb: &Neighbours, depth: &[f32], o: &EdgeOptions) -> Links {
        // The test is symmetric: where two steps along every offset are plain (most pixels), a
        // pixel's links backwards are its neighbours' forwards, classified once and copied below.
        const BACKWARD: [usize; 4] = [1, 3, 6, 7];
        let (usable, jump): (Vec<u8>, Vec<u8>) = (0..nb.len())
            .into_par_iter()
            .map(|p| {
                let (x, y) = (p % nb.width(), p / nb.width());
                let (mut u, mut j) = (0u8, 0u8);
                let interior = nb.is_interior2(x, y);
                for k in 0..8 {
                    if interior && BACKWARD.contains(&k) {
                        continue;
                    }
                    match depth_link(nb, depth, x, y, k, o) {
                        Some(Link::Jump) => {
                            u |= 1 << k;
                            j |= 1 << k;
                        }
                        Some(_) => u |= 1 << k,
                        None => {}
                    }
                }
                (u, j)
            })
            .unzip();
        // Each pixel's links in full: its own, and those backwards copied from its neighbours.
        let full = |p: usize| -> (u8, u8) {
            let (mut u, mut j) = (usable[p], jump[p]);
            if nb.is_interior2(p % nb.width(), p / nb.width()) {
                for k in BACKWARD {
                    let (q, back) = (p.wrapping_add_signed(nb.offset(k)), opposite(k));
                    u |= (usable[q] >> back & 1) << k;
                    j |= (jump[q] >> back & 1) << k;
                }
            }
            (u, j)
        };
        // A diagonal step is one surface when it is by the 4-neighbours around it: the last row of
        // a grazing floor beside a wall has no plane to follow along the diagonal (the pixel behind
        // is the wall, the one beyond is past the floor's end), but does along the row and column.
        let straight = |p: usize, k: usize| {
            let (u, j) = full(p);
            (u & !j) >> k & 1 == 1
        };
        let (usable, jump): (Vec<u8>, Vec<u8>) = (0..nb.len())
            .into_par_iter()
            .map(|p| {
                let (u, mut j) = full(p);
                for (k, &(dx, dy)) in OFFSETS.iter().enumerate().skip(4) {
                    if j >> k & 1 == 0 {
                        continue;
                    }
                    let Some(q) = nb.get(p, k) else { continue };
                    let (kx, ky) = (axis(dx, 0), axis(0, dy));
                    let around = |first: usize, then: usize| {
                        nb.get(p, first).is_some_and(|r| {
                            straight(p, first) && nb.get(r, then) == Some(q) && straight(r, then)
                        })
                    };
                    if around(kx, ky) || around(ky, kx) {
                        j &= !(1 << k);
                    }
                }
                (u, j)
            })
            .unzip();
        Links { usable, jump, fold_cos: o.fold_deg.map(|a| a.to_radians().cos() as f32) }
    }

    /// Both depths usable and the pair is on one surface as far as depth can tell.
    #[inline]
    pub fn continuous(&self, p: usize, k: usize) -> bool {
        (self.usable[p] & !self.jump[p]) >> k & 1 == 1
    }

    /// The depth jumps between `p` and any of its neighbours.
    #[inline]
    pub fn any_jump(&self, p: usize) -> bool {
        self.jump[p] != 0
    }

    /// The depth jumps between `p` and its neighbour `k`.
    #[inline]
    pub fn is_jump(&self, p: usize, k: usize) -> bool {
        self.jump[p] >> k & 1 == 1
    }

    /// The full link of pixel `(x, y)` to neighbour `k`, with folds from `normals` (zero
    /// normals never fold).
    #[inline]
    pub fn link(&self, nb: &Neighbours, normals: &[Vec3], x: usize, y: usize, k: usize) -> Option<Link> {
        let p = y * nb.width() + x;
        if self.usable[p] >> k & 1 == 0 {
            return None;
        }
        if self.is_jump(p, k) {
            return Some(Link::Jump);
        }
        if let Some(limit) = self.fold_cos {
            let q = nb.get_at(x, y, k)?;
            let (np, nq) = (normals[p], normals[q]);
            if np != Vec3::ZERO && nq != Vec3::ZERO && np.dot(nq) < limit {
                return Some(Link::Fold);
            }
        }
        Some(Link::Smooth)
    }
}

/// Pixels on each side of a pair that [`ramp_pixels`] looks at: edges up to about `2 · SOFT`
/// pixels wide.
const SOFT: usize = 4;

/// Largest share of a ramp's jump (in log depth) one step of it may take: a sharp edge resized
/// ×2 bilinearly takes about half in its largest step, a Gaussian blur of σ 1 px about 40 %; the
/// limb of a sphere before the jump to what is behind it, 80–90 %.
const MAX_STEP_SHARE: f64 = 0.65;

/// Pixels of depth edges spread over a few pixels (depth resized or blurred, or from a depth
/// network), with the depth of the edge's farther side. Such a ramp of in-between depths joins the
/// two surfaces, and the pair test passes on its gentler steps. Found along rows and columns: in
/// the line of `2 · SOFT + 4` pixels centred on a pair, in inverse depth, the pair's step is the
/// steepest (the first of equal ones), at least 4× the steps at both ends (the surfaces either side
/// run on flat there), and the window spans a relative jump above `o.jump`; the pixels of the
/// window more than a tenth of the way from both sides are the ramp, and take the depth of the far
/// side's first pixel past it. A plane at a grazing angle
/// changes inverse depth evenly, a crease or the limb of a curved object changes its slope
/// gradually: neither is a ramp.
pub fn ramp_pixels(nb: &Neighbours, depth: &[f32], o: &EdgeOptions) -> Vec<(usize, f32)> {
    (0..nb.len())
        .into_par_iter()
        .flat_map_iter(|p| [0, 2].into_iter().flat_map(move |k| ramp_at(nb, depth, p, k, o)))
        .collect()
}

/// [`ramp_pixels`] of the window centred on the pair `p`, `p + k`.
fn ramp_at(nb: &Neighbours, depth: &[f32], p: usize, k: usize, o: &EdgeOptions) -> Vec<(usize, f32)> {
    let inv = |i: usize| {
        let d = depth[i];
        (d > 0.0 && d.is_finite()).then(|| 1.0 / f64::from(d))
    };
    let (Some(a), Some(q)) = (inv(p), nb.get(p, k)) else { return Vec::new() };
    let Some(b) = inv(q) else { return Vec::new() };
    // The steepest step of a ramp spanning a jump over the window is at least this.
    if (a - b).abs() / a.min(b) < o.jump / (2 * SOFT + 1) as f64 {
        return Vec::new();
    }
    const N: usize = 2 * SOFT + 4;
    let mid = SOFT + 1;
    let (mut line, mut at) = ([0.0f64; N], [0usize; N]);
    (line[mid], line[mid + 1], at[mid], at[mid + 1]) = (a, b, p, q);
    for i in 1..=SOFT + 1 {
        let (Some(pb), Some(qa)) = (nb.get(at[mid + 1 - i], opposite(k)), nb.get(at[mid + i], k)) else {
            return Vec::new();
        };
        let (Some(x), Some(y)) = (inv(pb), inv(qa)) else { return Vec::new() };
        (line[mid - i], line[mid + 1 + i], at[mid - i], at[mid + 1 + i]) = (x, y, pb, qa);
    }
    let step = |i: usize| (line[i + 1] - line[i]).abs();
    let s = step(mid);
    let steepest = (1..N - 2).all(|i| if i < mid { step(i) < s } else { step(i) <= s });
    let flat_ends = 4.0 * step(0).max(step(N - 2)) < s;
    let (near, far) = (line[1].max(line[N - 2]), line[1].min(line[N - 2]));
    if !(steepest && flat_ends && (near - far) / far > o.jump) {
        return Vec::new();
    }
    // Spread over the ramp: no one step takes most of the jump (in log depth, where resized
    // and blurred edges spread most evenly). The limb of a curved object steepens into one
    // jump to what is behind it, which is most of the way: its pixels are the object's own.
    let widest = (1..N - 2).map(|i| (line[i + 1] / line[i]).ln().abs()).fold(0.0, f64::max);
    if widest > MAX_STEP_SHARE * (near / far).ln() {
        return Vec::new();
    }
    let margin = 0.1 * (near - far);
    let ramp: Vec<usize> =
        (1..N - 1).filter(|&i| line[i] < near - margin && line[i] > far + margin).collect();
    let (Some(&first), Some(&last)) = (ramp.first(), ramp.last()) else { return Vec::new() };
    // The ramp takes the depth of the far side's first pixel past it, which it then joins.
    let beyond = if line[N - 2] < line[1] { last + 1 } else { first - 1 };
    let d = (1.0 / line[beyond]) as f32;
    ramp.into_iter().map(|i| (at[i], d)).collect()
}

/// Depth-only classification of the link between pixel `(x, y)` and its neighbour `k`.
fn depth_link(nb: &Neighbours, depth: &[f32], x: usize, y: usize, k: usize, o: &EdgeOptions) -> Option<Link> {
    let p = y * nb.width() + x;
    let q = nb.get_at(x, y, k)?;
    let (a, b) = (depth[p], depth[q]);
    if !usable(a) || !usable(b) {
        return None;
    }
    let behind_a = || nb.get_at(x, y, opposite(k)).map(|i| depth[i] as f64);
    let beyond_b = || nb.get2_at(x, y, k).map(|i| depth[i] as f64);
    let (a, b) = (a as f64, b as f64);
    Some(if continuous_with(a, b, behind_a, beyond_b, o.jump, o.extrapolation) {
        Link::Smooth
    } else {
        Link::Jump
    })
}

/// Rows of the canvas [`estimate_normals`] takes per task (the points of two rows either side of a
/// band are computed twice).
const NORMAL_BAND: usize = 32;

/// Unit normals estimated from depth (facing the centre). Each tangent is a one-sided difference
/// taken on the side where the surface runs straighter (its next difference turns least), so a
/// crease gives each side its own plane's normal instead of a blurred average that would hide
/// the fold; differences never cross a depth jump. Zero where no estimate exists.
pub fn estimate_normals(nb: &Neighbours, links: &Links, dirs: &PixelDirs, depth: &[f32]) -> Vec<Vec3> {
    // 3D point of a pixel (panorama frame); non-finite where the depth is not a finite distance.
    let point =
        |p: usize| if depth[p] > 0.0 && depth[p].is_finite() { dirs.at(p) * depth[p] } else { Vec3::NAN };
    let (w, h) = (nb.width(), nb.height());
    let mut out = vec![Vec3::ZERO; nb.len()];
    out.par_chunks_mut(w * NORMAL_BAND).enumerate().for_each(|(b, band)| {
        let y0 = b * NORMAL_BAND;
        // The band's points and two rows either side, all that its pixels two steps inside look
        // at: kept per band, not for the whole canvas (12 bytes a pixel less at the peak).
        let top = y0.saturating_sub(2);
        let pts: Vec<Vec3> = (top * w..(y0 + band.len() / w + 2).min(h) * w).map(point).collect();
        let mut turns = Turns::new(w, top);
        for (i, row) in band.chunks_mut(w).enumerate() {
            let y = y0 + i;
            let slow = |x: usize| {
                normal_at(point, links, y * w + x, |k| nb.get_at(x, y, k), |k| nb.get2_at(x, y, k))
            };
            if !nb.is_interior2_row(y) {
                for (x, n) in row.iter_mut().enumerate() {
                    *n = slow(x);
                }
                continue;
            }
            turns.prepare(&pts, y);
            let (along, up, down) = (&turns.along, turns.across(y - 1), turns.across(y + 1));
            for (x, n) in row.iter_mut().enumerate() {
                *n = if nb.is_interior2(x, y) {
                    normal_inside(nb, links, &pts, (y * w + x, (y - top) * w + x), along, (up[x], down[x]))
                } else {
                    slow(x)
                };
            }
        }
    });
    out
}

/// Squared length and difference `b − a` of two points.
#[inline(always)]
fn diff(a: Vec3, b: Vec3) -> (Vec3, f32) {
    let d = b - a;
    (d, d.length_squared())
}

/// Cosine of the turn from the difference `t` to the next one `u` ([`diff`]s): the straightness
/// [`normal_at`] compares (one square root; 0 for a zero difference).
#[inline(always)]
fn turn((t, lt): (Vec3, f32), (u, lu): (Vec3, f32)) -> f32 {
    let l2 = lt * lu;
    if l2 > 0.0 {
        t.dot(u) / l2.sqrt()
    } else {
        0.0
    }
}

/// The turns of a band's rows and columns, each computed once: a pixel's forward turn is the
/// backward turn of the pixel two steps on (the same products, in another order of the factors),
/// so [`normal_at`] would find every one of them twice.
struct Turns {
    w: usize,
    /// The canvas row of the band's first point.
    top: usize,
    /// Along the row being prepared: at `x`, the turn from the step `x − 1 → x` to `x → x + 1`.
    along: Vec<f32>,
    /// Steps down the columns from row `j` to `j + 1`, by `j % 4` (with `j`; `usize::MAX`: none).
    steps: [(usize, Vec<(Vec3, f32)>); 4],
    /// Turns down the columns at row `j` (from the step `j − 1 → j` to `j → j + 1`), by `j % 3`.
    turns: [(usize, Vec<f32>); 3],
}

impl Turns {
    fn new(w: usize, top: usize) -> Turns {
        Turns {
            w,
            top,
            along: vec![0.0; w],
            steps: std::array::from_fn(|_| (usize::MAX, Vec::new())),
            turns: std::array::from_fn(|_| (usize::MAX, Vec::new())),
        }
    }

    /// The point of `(x, y)` in the band's `pts`.
    #[inline(always)]
    fn at<'a>(&self, pts: &'a [Vec3], y: usize) -> &'a [Vec3] {
        &pts[(y - self.top) * self.w..][..self.w]
    }

    /// The turns along row `y` and down the columns at rows `y ± 1` (`y` two rows from any edge).
    fn prepare(&mut self, pts: &[Vec3], y: usize) {
        let row = self.at(pts, y);
        let mut last = diff(row[0], row[1]);
        for x in 1..self.w - 1 {
            let next = diff(row[x], row[x + 1]);
            self.along[x] = turn(last, next);
            last = next;
        }
        self.turns_at(pts, y - 1);
        self.turns_at(pts, y + 1);
    }

    /// The turns down the columns at row `j`, once [`Turns::prepare`] has made them.
    fn across(&self, j: usize) -> &[f32] {
        debug_assert_eq!(self.turns[j % 3].0, j);
        &self.turns[j % 3].1
    }

    fn turns_at(&mut self, pts: &[Vec3], j: usize) {
        if self.turns[j % 3].0 == j {
            return;
        }
        self.steps_at(pts, j - 1);
        self.steps_at(pts, j);
        let (above, below) = (&self.steps[(j - 1) % 4].1, &self.steps[j % 4].1);
        let (tag, out) = &mut self.turns[j % 3];
        out.clear();
        out.extend(above.iter().zip(below).map(|(&a, &b)| turn(a, b)));
        *tag = j;
    }

    fn steps_at(&mut self, pts: &[Vec3], j: usize) {
        if self.steps[j % 4].0 == j {
            return;
        }
        let (a, b) = (self.at(pts, j), self.at(pts, j + 1));
        let (tag, out) = &mut self.steps[j % 4];
        out.clear();
        out.extend(a.iter().zip(b).map(|(&a, &b)| diff(a, b)));
        *tag = j;
    }
}

/// [`normal_at`] for a pixel two steps from any edge, `p` on the canvas and `l` in the band's
/// `pts`, with the turns along its row and `(up, down)` its column from [`Turns`].
#[inline(always)]
fn normal_inside(
    nb: &Neighbours,
    links: &Links,
    pts: &[Vec3],
    (p, l): (usize, usize),
    along: &[f32],
    (up, down): (f32, f32),
) -> Vec3 {
    let c = pts[l];
    if !c.is_finite() {
        return Vec3::ZERO;
    }
    // The straightness of the side `k` when its step stays on the surface (0 when the next does not).
    let side = |k: usize, straight: f32| -> Option<f32> {
        let s = nb.offset(k);
        let (q, lq) = (p.wrapping_add_signed(s), l.wrapping_add_signed(s));
        if !(links.continuous(p, k) && pts[lq].is_finite()) {
            return None;
        }
        let on = links.continuous(q, k) && pts[lq.wrapping_add_signed(s)].is_finite();
        Some(if on { straight } else { 0.0 })
    };
    let tangent = |fwd: usize, bwd: usize, (sf, sb): (f32, f32)| -> Option<Vec3> {
        // As `normal_at` takes it (not the stored step, whose zeros may differ in sign).
        let t = |k: usize| pts[l.wrapping_add_signed(nb.offset(k))] - c;
        match (side(fwd, sf), side(bwd, sb)) {
            (Some(f), Some(b)) => Some(if f >= b { t(fwd) } else { -t(bwd) }),
            (Some(_), None) => Some(t(fwd)),
            (None, Some(_)) => Some(-t(bwd)),
            (None, None) => None,
        }
    };
    let x = l % nb.width();
    facing(tangent(0, 1, (along[x + 1], along[x - 1])), tangent(2, 3, (down, up)), c)
}

/// The unit normal of the tangents, facing the centre from the point `c` (zero without both).
#[inline(always)]
fn facing(tx: Option<Vec3>, ty: Option<Vec3>, c: Vec3) -> Vec3 {
    match (tx, ty) {
        (Some(tx), Some(ty)) => {
            let n = tx.cross(ty).normalize_or_zero();
            if n.dot(c) > 0.0 {
                -n
            } else {
                n
            }
        }
        _ => Vec3::ZERO,
    }
}

/// [`estimate_normals`] at pixel `p`, whose neighbour `k` is `one(k)` and the one after it `two(k)`.
#[inline(always)]
fn normal_at(
    point: impl Fn(usize) -> Vec3,
    links: &Links,
    p: usize,
    one: impl Fn(usize) -> Option<usize>,
    two: impl Fn(usize) -> Option<usize>,
) -> Vec3 {
    // The neighbour `k` of `p`, and the one after it, when they lie on the same surface.
    let step = |k: usize| -> Option<(usize, Vec3)> {
        let q = one(k).filter(|_| links.continuous(p, k))?;
        let pq = point(q);
        pq.is_finite().then_some((q, pq))
    };
    let step2 = |q: usize, k: usize| -> Option<Vec3> {
        let r = two(k).filter(|_| links.continuous(q, k))?;
        let pr = point(r);
        pr.is_finite().then_some(pr)
    };
    let c = point(p);
    if !c.is_finite() {
        return Vec3::ZERO;
    }
    let tangent = |fwd: usize, bwd: usize| -> Option<Vec3> {
        let one_sided = |k: usize| -> Option<(Vec3, f32)> {
            let (q, pq) = step(k)?;
            let t = pq - c;
            // Cosine of the turn between this step and the next (one square root).
            let straight = match step2(q, k) {
                Some(pr) => {
                    let u = pr - pq;
                    let l2 = t.length_squared() * u.length_squared();
                    if l2 > 0.0 {
                        t.dot(u) / l2.sqrt()
                    } else {
                        0.0
                    }
                }
                None => 0.0,
            };
            Some((if k == fwd { t } else { -t }, straight))
        };
        match (one_sided(fwd), one_sided(bwd)) {
            (Some((f, sf)), Some((b, sb))) => Some(if sf >= sb { f } else { b }),
            (Some((f, _)), None) => Some(f),
            (None, Some((b, _))) => Some(b),
            (None, None) => None,
        }
    };
    facing(tangent(0, 1), tangent(2, 3), c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::OFFSETS;
    use crate::mapping::{AnyMapping, Mapping, MappingKind};

    /// The banded estimate with shared turns is the per-pixel one bit for bit (zero signs too), on
    /// both mappings, with planes, creases, jumps, flat runs and unusable depths.
    #[test]
    fn banded_normals_equal_per_pixel_normals() {
        for (kind, w, h) in [(MappingKind::Equirect, 144, 72), (MappingKind::Cube3x2, 108, 72)] {
            let m = AnyMapping::new(kind, w, h).unwrap();
            let (nb, dirs) = (Neighbours::new(m), PixelDirs::new(m));
            let mut seed = 12345u64;
            let mut rand = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (seed >> 33) as f32 / (1u64 << 31) as f32
            };
            let depth: Vec<f32> = (0..w * h)
                .map(|p| {
                    let (x, y) = ((p % w) as f32, (p / w) as f32);
                    match (rand() * 20.0) as u32 {
                        0 => f32::NAN,
                        1 => f32::INFINITY,
                        2 => 0.0,
                        3 => 1.0 + rand(),
                        // Flat runs (equal neighbours: zero differences).
                        4..=7 => 2.0,
                        _ if x < y => 3.0 + 0.05 * x,
                        _ => (1.5 + 0.02 * (x - y).abs()).max(0.5 + 0.01 * y),
                    }
                })
                .collect();
            let links = Links::compute(&nb, &depth, &EdgeOptions::default());
            let got = estimate_normals(&nb, &links, &dirs, &depth);
            let point = |p: usize| {
                if depth[p] > 0.0 && depth[p].is_finite() {
                    dirs.at(p) * depth[p]
                } else {
                    Vec3::NAN
                }
            };
            let mut nonzero = 0;
            for (p, got) in got.iter().enumerate() {
                let (x, y) = (p % w, p / w);
                let want = normal_at(point, &links, p, |k| nb.get_at(x, y, k), |k| nb.get2_at(x, y, k));
                assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "pixel {p}");
                nonzero += usize::from(want != Vec3::ZERO);
            }
            assert!(nonzero > w * h / 4, "{kind:?}: {nonzero} normals");
        }
    }

    #[test]
    fn opposite_offsets() {
        for k in 0..8 {
            let (dx, dy) = OFFSETS[k];
            assert_eq!(OFFSETS[opposite(k)], (-dx, -dy));
        }
    }

    #[test]
    fn jump_is_scale_free_and_needs_both_sides() {
        let m = AnyMapping::new(MappingKind::Equirect, 16, 8).unwrap();
        let nb = Neighbours::new(m);
        let o = EdgeOptions::default();
        for scale in [1e-3f32, 1.0, 1e5] {
            let mut depth = vec![2.0 * scale; 128];
            for y in 0..8 {
                for x in 8..16 {
                    depth[y * 16 + x] = 5.0 * scale;
                }
            }
            assert_eq!(depth_link(&nb, &depth, 7, 3, 0, &o), Some(Link::Jump), "scale {scale}");
            assert_eq!(depth_link(&nb, &depth, 7, 3, 1, &o), Some(Link::Smooth));
        }
        // A ramp linear in inverse depth (a plane) with a large relative step per pixel is smooth.
        let depth: Vec<f32> = (0..128).map(|i| 1.0 / (1.0 - 0.06 * (i % 16) as f32)).collect();
        assert_eq!(depth_link(&nb, &depth, 12, 3, 0, &o), Some(Link::Smooth));
    }

    /// A step from 2 m to 5 m blurred over several pixels (a resized or estimated depth): the pair
    /// test alone leaves in-between depths joined to a side (a rubber sheet) or as slivers of their
    /// own; the ramp's pixels take the far side's depth, and then each row has exactly one jump.
    #[test]
    fn an_edge_spread_over_pixels_becomes_one_jump() {
        let (w, h) = (64usize, 32usize);
        let nb = Neighbours::new(AnyMapping::new(MappingKind::Equirect, w, h).unwrap());
        let o = EdgeOptions::default();
        let cuts = |links: &Links, y: usize| {
            (20..44).filter(|&x| !links.continuous(y * w + x, 0)).collect::<Vec<_>>()
        };
        for sigma in [0.7f64, 1.0, 2.0] {
            // Gaussian-blurred step at x = 32 (the other edge, at the seam, is left sharp).
            let erf = |x: f64| (1.0 - (-1.2732 * x * x).exp()).sqrt().copysign(x);
            let row: Vec<f32> = (0..w)
                .map(|x| {
                    let t = ((x as f64 + 0.5 - 32.0) / (sigma * std::f64::consts::SQRT_2)).clamp(-6.0, 6.0);
                    (2.0 + 3.0 * 0.5 * (1.0 + erf(t))) as f32
                })
                .collect();
            let mut depth: Vec<f32> = (0..w * h).map(|p| row[p % w]).collect();
            let between = |d: &[f32]| (0..w).filter(|&x| d[16 * w + x] > 2.2 && d[16 * w + x] < 4.0).count();
            assert!(between(&depth) >= 1, "sigma {sigma}: in-between depths");
            let ramp = ramp_pixels(&nb, &depth, &o);
            assert!(!ramp.is_empty(), "sigma {sigma}");
            for (p, d) in ramp {
                assert!((27..37).contains(&(p % w)) && d > 4.0 && d <= 5.0, "sigma {sigma}: {p} -> {d}");
                depth[p] = d;
            }
            assert_eq!(between(&depth), 0, "sigma {sigma}: no in-between depth left");
            let links = Links::compute(&nb, &depth, &o);
            for y in 4..28 {
                let c = cuts(&links, y);
                assert!(c.len() == 1 && (28..34).contains(&c[0]), "sigma {sigma} row {y}: cuts at {c:?}");
            }
        }
    }

    /// The limb of a sphere near the centre (0.1 m radius, 0.3 m away, 3 m in front of a wall):
    /// along a row its depth steepens towards the silhouette, then jumps to the wall. The window
    /// has flat ends and a jump, like a blurred edge, but the jump is one step: the limb's pixels
    /// are the sphere's, not a ramp to move behind it.
    #[test]
    fn the_limb_of_a_curved_object_is_not_a_ramp() {
        let (w, h) = (256usize, 128usize);
        let m = AnyMapping::new(MappingKind::Equirect, w, h).unwrap();
        let nb = Neighbours::new(m);
        let (dist, radius) = (0.3f64, 0.1f64);
        let row: Vec<f32> = (0..w)
            .map(|x| {
                let a = (x as f64 + 0.5 - 128.0) * std::f64::consts::TAU / w as f64;
                let off = dist * a.sin();
                if a.abs() < std::f64::consts::FRAC_PI_2 && off.abs() < radius {
                    (dist * a.cos() - (radius * radius - off * off).sqrt()) as f32
                } else {
                    3.0
                }
            })
            .collect();
        assert!(row.iter().filter(|&&d| d < 3.0).count() > 20, "the sphere spans the row");
        let depth: Vec<f32> = (0..w * h).map(|p| row[p % w]).collect();
        let ramp = ramp_pixels(&nb, &depth, &EdgeOptions::default());
        assert!(ramp.is_empty(), "limb pixels taken for a ramp: {:?}", &ramp[..ramp.len().min(6)]);
    }

    #[test]
    fn a_floor_at_grazing_angles_is_one_surface_up_to_its_last_row() {
        // The floor z = -1 seen from the centre, ending at the horizon in a far wall (d = 50).
        let m = AnyMapping::new(MappingKind::Equirect, 64, 32).unwrap();
        let nb = Neighbours::new(m);
        let o = EdgeOptions::default();
        let floor = |j: usize| {
            let z = m.pixel_dir(0, j).z;
            (z < -0.02).then(|| (-1.0 / z) as f32)
        };
        let depth: Vec<f32> = (0..64 * 32).map(|p| floor(p / 64).unwrap_or(50.0)).collect();
        let last = (0..32).find(|&j| floor(j).is_some()).unwrap();
        // Down the floor, every vertical link is smooth, even where a row step exceeds the jump ratio.
        let mut steep = 0;
        for j in last..31 {
            let (a, b) = (depth[j * 64], depth[(j + 1) * 64]);
            steep += usize::from((a - b).abs() / a.min(b) > o.jump as f32);
            assert_eq!(depth_link(&nb, &depth, 5, j, 2, &o), Some(Link::Smooth), "row {j}");
        }
        assert!(steep > 0, "the test must include grazing rows");
        // Its last row against the wall is a jump.
        assert_eq!(depth_link(&nb, &depth, 5, last, 3, &o), Some(Link::Jump));
        // Nor is any of it a ramp between two surfaces: its inverse depth changes evenly.
        assert!(
            ramp_pixels(&nb, &depth, &o).iter().all(|&(p, _)| p / 64 < last),
            "floor pixels taken as a ramp"
        );
    }
}
