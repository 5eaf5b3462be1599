//! The colour of the fill. What a displaced camera sees behind an occluder is what build invents
//! there, so the fill continues the hidden surface's texture rather than smearing its border.
//! The default copies the surface from elsewhere by a few dominant offsets in its own plane
//! (after He & Sun, "Statistics of patch offsets for image completion", ECCV 2012): a wall's
//! checker or a floor's bricks continue in phase and with the right perspective (spec §7.2 step 7,
//! `docs/build.md`). Offsets are 3D vectors and sources are looked up by direction, so seams,
//! poles and cube-face edges need no special case.

use glam::Vec3;
use rayon::prelude::*;

use super::shadow::{self, Shadow};
use super::{Fill, FillContext, SAME_PLANE_COS};
use crate::mapping::Neighbours;
use search::Search;

mod search;

crate::choice::choices! {
    /// How the fill is coloured.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum FillColour (default Exemplar) {
        /// Continue the hidden surface's texture: patches matched in its plane.
        ///
        /// Exemplar: the hidden surface copied from elsewhere on it by the offsets in its plane that
        /// best continue the texture around the hole.
        Exemplar = "exemplar",
        /// Copy the nearest visible pixel (fast; textures come out as streaks).
        ///
        /// The visible pixel nearest the filled pixel's seed.
        Nearest = "nearest",
        /// Blend the border's colours smoothly across the hole.
        ///
        /// Inwards from the border, each filled pixel takes the distance-weighted mean of the known
        /// pixels around it, then relaxation sweeps smooth it: the border's colours blend
        /// across the hole without streaks or texture.
        Smooth = "smooth",
    }
}

const NONE: u32 = u32::MAX;
/// Relative distance from the continued plane within which a visible pixel counts as the same
/// surface (tessellated and gently curved surfaces, pixel quantisation).
const PLANE_TOL: f32 = 0.03;
/// Samples that score an offset: of the visible ring around the hole, of the hole itself.
const RING_SAMPLES: usize = 512;
const HOLE_SAMPLES: usize = 256;
/// A part is copied when its best offset's ring mismatch is at most [`search::COPY_MATCH`] of
/// what random texture would give, and the ring varies more than `PLAIN` (else it is a plain
/// surface) and has `MIN_RING` pixels at least; otherwise it is blended: nothing says what texture
/// continues.
const PLAIN: f32 = 1e-4;
const MIN_RING: usize = 24;

impl FillContext<'_> {
    /// Colour compressed to [0, 1): HDR highlights must not outweigh the texture in a match.
    #[inline]
    fn feature(&self, p: usize) -> Vec3 {
        let c = self.colour(p).max(Vec3::ZERO);
        c / (Vec3::ONE + c)
    }

    #[inline]
    pub(super) fn pixel(&self, y: Vec3) -> usize {
        self.nb.mapping().pixel_index_fast(y)
    }

    /// Input linear RGB of pixel `p`.
    #[inline]
    pub(super) fn colour(&self, p: usize) -> Vec3 {
        Vec3::new(self.rgb[0][p], self.rgb[1][p], self.rgb[2][p])
    }

    /// Point of pixel `p` (the unit direction when infinitely far: its tangent plane stands in).
    #[inline]
    fn point(&self, p: usize, depth: f32) -> Vec3 {
        if depth.is_finite() {
            self.dirs.at(p) * depth
        } else {
            self.dirs.at(p)
        }
    }
}

/// The plane a part of the fill continues: a point, the unit normal (facing the centre) and
/// in-plane axes. An infinitely far surface uses the unit sphere's tangent plane, a surface
/// without a trustworthy normal the plane facing the centre.
struct Plane {
    x: Vec3,
    n: Vec3,
    e1: Vec3,
    e2: Vec3,
    finite: bool,
}

impl Plane {
    fn new(tx: &FillContext, q: usize, depth: f32, surface: usize) -> Plane {
        let dq = tx.dirs.at(q);
        let finite = depth.is_finite();
        let ns = tx.normals[surface];
        let n = if finite && ns.dot(dq) < -0.05 { ns } else { -dq };
        let (e1, e2) = n.any_orthonormal_pair();
        Plane { x: tx.point(q, depth), n, e1, e2, finite }
    }
}

/// Recolour the fill of layer `k` by [`FillColour::Exemplar`]. Each connected part of the fill,
/// per surface it continues, gets a few offsets in the surface's plane: those that best carry
/// the visible ring around the part onto matching texture while landing the part itself on
/// visible surface (a coarse grid search, refined by halving steps). Each pixel then copies the
/// pixel its first valid offset lands on. Parts are independent, so they run in parallel.
pub fn synthesise(tx: &FillContext, k: u32, fill: &mut Fill) {
    if fill.pixels.is_empty() {
        return;
    }
    let n = tx.nb.len();
    // The fill's parts (a serial walk) beside the clean pixels (a parallel scan of the canvas).
    let (clean, (slot, groups)) = rayon::join(
        || clean_pixels(tx, k),
        || {
            let slot = slots(tx, fill);
            let groups = surface_groups(tx, fill, &slot);
            (slot, groups)
        },
    );
    let alpha = (4.0 * std::f32::consts::PI / n as f32).sqrt();
    let copies: Vec<Transfer> =
        groups.par_iter().map(|g| copy_group(tx, k, fill, &clean, g, alpha)).collect();
    let mut shading = Vec::new();
    let mut copied = vec![false; fill.pixels.len()];
    for c in &copies {
        for &(i, p) in &c.sources {
            fill.pixels[i as usize].rgb = tx.colour(p).to_array();
            copied[i as usize] = true;
        }
        shading.extend(c.shading.iter().copied());
    }
    carry_lighting(tx, fill, &slot, &copies, &copied, shading);
    // Infinitely far content, copied or not, is interpolated along its circles of elevation.
    let sky = along_elevation(tx, &clean, fill);
    let fixed: Vec<bool> = copied.iter().zip(&sky).map(|(&c, s)| c || s.is_some()).collect();
    for (f, c) in fill.pixels.iter_mut().zip(sky) {
        if let Some(c) = c {
            f.rgb = c.to_array();
        }
    }
    // What is left (no offset continues it: too little texture around it, or none that
    // matches) is blended, from the sky's new values too.
    if fixed.iter().any(|c| !c) {
        let start = fill.pixels.iter().map(|f| Vec3::from(f.rgb)).collect();
        let blend: Vec<bool> = fixed.iter().map(|c| !c).collect();
        let rgb = diffuse(tx, fill, &slot, start, &blend, Sources::All, |r| clean[r].then(|| tx.colour(r)));
        for ((f, c), _) in fill.pixels.iter_mut().zip(rgb).zip(&blend).filter(|(_, &b)| b) {
            f.rgb = c.to_array();
        }
    }
}

/// The fill's parts, split by the surface they continue (a hole behind a box shows floor and
/// wall) and by scale.
fn surface_groups(tx: &FillContext, fill: &Fill, slot: &[u32]) -> Vec<Vec<u32>> {
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for part in components(tx.nb, fill, slot) {
        let mut by_surface: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
        for i in part {
            by_surface.entry(tx.surface[fill.pixels[i as usize].surface]).or_default().push(i);
        }
        groups.extend(by_surface.into_values().flat_map(|g| by_scale(fill, g)));
    }
    groups
}

/// The copy brings its source's lighting: the ratio between the ring and its copy (`shading`: a
/// shadow, a lamp's glow) is carried smoothly across the hole, and behind the occluder the shadow
/// fitted to the ring's penumbra; the `copied` pixels take it.
fn carry_lighting(
    tx: &FillContext,
    fill: &mut Fill,
    slot: &[u32],
    copies: &[Transfer],
    copied: &[bool],
    mut shading: Vec<(usize, Vec3)>,
) {
    shading.sort_unstable_by_key(|e| e.0);
    shading.dedup_by_key(|e| e.0);
    let mut log_ratio =
        diffuse(tx, fill, slot, vec![Vec3::ZERO; fill.pixels.len()], copied, Sources::SameSurface, |r| {
            shading.binary_search_by_key(&r, |e| e.0).ok().map(|i| shading[i].1)
        });
    for c in copies {
        if let Some(s) = &c.shadow {
            for &(i, p) in &c.sources {
                let i = i as usize;
                log_ratio[i] = s.relight(tx, log_ratio[i], fill.pixels[i].pixel, p);
            }
        }
    }
    for ((f, g), _) in fill.pixels.iter_mut().zip(log_ratio).zip(copied).filter(|(_, &c)| c) {
        let g = g.clamp(Vec3::splat(-MAX_LOG_RATIO), Vec3::splat(MAX_LOG_RATIO));
        f.rgb = (Vec3::from(f.rgb) * g.exp()).to_array();
    }
}

/// Colours of the infinitely far filled pixels (`None` for the others), each interpolated by angle
/// between the nearest visible pixels of its layer both ways along its circle of elevation (about
/// the canvas's +Z): a sky changes with elevation far more than along it, and blended from its
/// whole ring a wide hole takes the zenith's blue down to the horizon. `None` near the poles or
/// where either way finds nothing within [`SKY_REACH`]. The pixels of one circle share its
/// samples ([`Circle`]), each looked up once: with a lookup per pixel and step, a wide hole's walks
/// cost its width squared in trigonometry.
fn along_elevation(tx: &FillContext, clean: &[bool], fill: &Fill) -> Vec<Option<Vec3>> {
    let alpha = (4.0 * std::f64::consts::PI / tx.nb.len() as f64).sqrt();
    // Circles a quarter pixel apart in elevation: a pixel's circle runs within an eighth of a pixel
    // of its centre, so within its row or face.
    let quantum = 0.25 * alpha;
    let mut circles: std::collections::BTreeMap<i64, Vec<usize>> = Default::default();
    for (i, f) in fill.pixels.iter().enumerate().filter(|(_, f)| f.depth.is_infinite()) {
        let z = f64::from(tx.dirs.at(f.pixel).z).clamp(-1.0, 1.0);
        circles.entry((z.asin() / quantum).round() as i64).or_default().push(i);
    }
    let circles: Vec<(i64, Vec<usize>)> = circles.into_iter().collect();
    let coloured: Vec<(usize, Vec3)> = circles
        .par_iter()
        .flat_map_iter(|(key, members)| {
            let mut circle = Circle::new(tx, clean, *key as f64 * quantum, alpha);
            members
                .iter()
                .filter_map(|&i| {
                    let d = tx.dirs.at(fill.pixels[i].pixel).as_dvec3();
                    circle.as_mut()?.colour(d.y.atan2(d.x)).map(|c| (i, c))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let mut sky = vec![None; fill.pixels.len()];
    for (i, c) in coloured {
        sky[i] = Some(c);
    }
    sky
}

/// One circle of elevation, sampled about one pixel apart, each sample's pixel looked up once:
/// the clean infinitely far pixel it lands on, or none.
struct Circle<'a> {
    tx: &'a FillContext<'a>,
    clean: &'a [bool],
    rho: f64,
    z: f64,
    step: f64,
    /// Samples each way within [`SKY_REACH`].
    reach: usize,
    /// Per sample: [`UNSEEN`] not yet looked up, [`NO_SKY`] no clean sky there, else the pixel.
    samples: Vec<usize>,
}

impl<'a> Circle<'a> {
    /// The circle at `elevation` (radians), `None` near the poles.
    fn new(tx: &'a FillContext<'a>, clean: &'a [bool], elevation: f64, alpha: f64) -> Option<Circle<'a>> {
        let (z, rho) = elevation.sin_cos();
        if rho < 0.05 {
            return None;
        }
        // A whole number of steps of about one pixel (the mean pixel angle over the radius).
        let count = ((std::f64::consts::TAU * rho / alpha).round() as usize).max(1);
        let step = std::f64::consts::TAU / count as f64;
        let reach = (SKY_REACH / step) as usize;
        Some(Circle { tx, clean, rho, z, step, reach, samples: vec![UNSEEN; count] })
    }

    /// The clean infinitely far pixel sample `k` (any integer, taken round the circle) lands on.
    fn sample(&mut self, k: i64) -> Option<usize> {
        let k = k.rem_euclid(self.samples.len() as i64) as usize;
        if self.samples[k] == UNSEEN {
            let a = k as f64 * self.step;
            let p = self.tx.pixel(glam::DVec3::new(self.rho * a.cos(), self.rho * a.sin(), self.z).as_vec3());
            let sky = self.clean[p] && self.tx.depth[p].is_infinite();
            self.samples[k] = if sky { p } else { NO_SKY };
        }
        Some(self.samples[k]).filter(|&p| p != NO_SKY)
    }

    /// The colour at azimuth `phi`: the nearest samples with clean sky both ways, weighted by
    /// their angles from it.
    fn colour(&mut self, phi: f64) -> Option<Vec3> {
        let u = phi / self.step;
        let first = u.floor() as i64 + 1;
        let (a, pa) =
            (first..first + self.reach as i64).find_map(|k| Some((k as f64 - u, self.sample(k)?)))?;
        let last = u.ceil() as i64 - 1;
        let (b, pb) =
            (0..self.reach as i64).find_map(|s| Some((u - (last - s) as f64, self.sample(last - s)?)))?;
        let (a, b) = (a as f32, b as f32);
        Some((self.tx.colour(pa) * b + self.tx.colour(pb) * a) / (a + b))
    }
}

/// [`Circle::samples`] not yet looked up, and without clean sky.
const UNSEEN: usize = usize::MAX;
const NO_SKY: usize = usize::MAX - 1;

/// How far (radians of azimuth) [`along_elevation`] looks each way.
const SKY_REACH: f64 = std::f64::consts::FRAC_PI_4;

/// Depth ratio within which one part of the fill keeps one set of offsets.
const SCALE_RATIO: f32 = 2.0;

/// A part split by distance, when its depths span more than a couple of [`SCALE_RATIO`]s: the
/// ground behind an object near the centre runs from the camera's feet to the horizon, and one
/// offset fit for its far end would copy the near ground from texture the distance has blurred
/// grey. Each band of depth gets offsets at its own scale.
fn by_scale(fill: &Fill, group: Vec<u32>) -> Vec<Vec<u32>> {
    let depth = |i: &u32| fill.pixels[*i as usize].depth;
    let (lo, hi) = group.iter().map(depth).fold((f32::INFINITY, 0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
    if !(lo > 0.0 && hi.is_finite() && hi > SCALE_RATIO * SCALE_RATIO * lo) {
        return vec![group];
    }
    let mut bands: std::collections::BTreeMap<i32, Vec<u32>> = Default::default();
    for i in group {
        bands.entry((depth(&i) / lo).log(SCALE_RATIO).floor() as i32).or_default().push(i);
    }
    bands.into_values().collect()
}

/// Index into `fill.pixels` of every canvas pixel filled, `NONE` elsewhere.
fn slots(tx: &FillContext, fill: &Fill) -> Vec<u32> {
    let mut slot = vec![NONE; tx.nb.len()];
    for (i, f) in fill.pixels.iter().enumerate() {
        slot[f.pixel] = i as u32;
    }
    slot
}

/// Visible pixels of layer `k` none of whose neighbours is hidden by a nearer layer: colours free
/// of the occluder's (anti-aliased borders mix them in), the only ones a fill takes colour from.
fn clean_pixels(tx: &FillContext, k: u32) -> Vec<bool> {
    let w = tx.nb.width();
    (0..tx.nb.len())
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % w, p / w);
            tx.layer_of[p] == k && (0..8).all(|j| tx.nb.get_at(x, y, j).is_none_or(|r| tx.layer_of[r] == k))
        })
        .collect()
}

/// Largest shading correction of a copy, as a log ratio (a factor of 4 either way).
const MAX_LOG_RATIO: f32 = 2.0 * std::f32::consts::LN_2;

/// Small colour added before taking ratios (dark pixels have noisy ratios).
const RATIO_EPS: f32 = 0.02;

/// What one part of the fill copies: a source per pixel (fill index, source pixel) and the
/// shading ratio (log) between the visible ring and its copy, per ring pixel.
struct Transfer {
    sources: Vec<(u32, usize)>,
    shading: Vec<(usize, Vec3)>,
    /// The occluders' shadow fitted to the ring, when one explains its shading: the shading
    /// above is what is left of it.
    shadow: Option<Shadow>,
}

/// Up to `count` items spread evenly over `items`.
fn spread<T: Copy>(items: &[T], count: usize) -> impl Iterator<Item = T> + '_ {
    let step = items.len().div_ceil(count.max(1)).max(1);
    items.iter().step_by(step).copied()
}

/// Offsets for one part of the fill on one surface, and the source each pixel takes.
fn copy_group(tx: &FillContext, k: u32, fill: &Fill, clean: &[bool], group: &[u32], alpha: f32) -> Transfer {
    let none = Transfer { sources: Vec::new(), shading: Vec::new(), shadow: None };
    let first = fill.pixels[group[0] as usize];
    let plane = Plane::new(tx, first.pixel, first.depth, first.surface);
    let surface = tx.surface[first.surface];
    // Another segment on the same plane is the same surface for its texture (a wall seen through
    // a ring's hole is cut off from the rest of the wall).
    let same =
        |p: usize| tx.surface[p] == surface || (plane.finite && tx.normals[p].dot(plane.n) >= SAME_PLANE_COS);
    let valid = |p: usize| clean[p] && same(p) && on_plane(tx, &plane, p);
    // The hole's points (each pixel's own) and its visible ring on the same surface (2 pixels
    // deep), with their colours.
    let hole: Vec<Vec3> =
        group.iter().map(|&i| fill.pixels[i as usize]).map(|f| tx.point(f.pixel, f.depth)).collect();
    let ring_pixels = ring_around(tx, k, fill, group, &valid);
    let ring: Vec<(Vec3, Vec3)> =
        spread(&ring_pixels, RING_SAMPLES).map(|r| (tx.point(r, tx.depth[r]), tx.feature(r))).collect();
    if ring.len() < MIN_RING {
        return none;
    }
    // Copy only what matches clearly better than texture at random would (the ring's variance
    // after a fitted gain and offset, twice it as it is); a plain surface (no variance) is blended.
    let mean = ring.iter().map(|r| r.1).sum::<Vec3>() / ring.len() as f32;
    let random = ring.iter().map(|r| (r.1 - mean).length_squared()).sum::<f32>() / ring.len() as f32;
    if random < PLAIN {
        return none;
    }
    let hole_samples: Vec<Vec3> = spread(&hole, HOLE_SAMPLES).collect();
    // Scale: the pixel's footprint on the plane at the hole's centre, and the hole's extent.
    let centre = hole_samples.iter().copied().sum::<Vec3>() / hole_samples.len() as f32;
    let extent = hole_samples.iter().map(|p| (*p - centre).length()).fold(0.0, f32::max);
    let cos = (-plane.n.dot(centre.normalize_or_zero())).max(0.2);
    let footprint = alpha * centre.length() / cos;
    if !(footprint > 0.0 && footprint.is_finite() && extent.is_finite()) {
        return none;
    }
    let search = Search { tx, valid: &valid, ring, hole: hole_samples };
    let Some(offsets) = search.offsets(&plane, footprint, extent, random) else { return none };
    let sources = group
        .par_iter()
        .zip(&hole)
        .filter_map(|(&i, &x)| offsets.iter().map(|&t| tx.pixel(x + t)).find(|&p| valid(p)).map(|p| (i, p)))
        .collect();
    let hole_pixels: Vec<usize> = group.iter().map(|&i| fill.pixels[i as usize].pixel).collect();
    let (shading, shadow) =
        shading(tx, k, &ring_pixels, &hole_pixels, &valid, offsets.first().copied(), alpha);
    Transfer { sources, shading, shadow }
}

/// The visible pixels of the part's surface within two steps of its border, in order.
fn ring_around(
    tx: &FillContext,
    k: u32,
    fill: &Fill,
    group: &[u32],
    valid: &(impl Fn(usize) -> bool + Sync),
) -> Vec<usize> {
    let w = tx.nb.width();
    let mut ring: Vec<usize> = group
        .par_iter()
        .map(|&i| fill.pixels[i as usize].pixel)
        // Only pixels on the hole's border reach visible surface within two steps.
        .filter(|&q| (0..8).any(|j| tx.nb.get_at(q % w, q / w, j).is_some_and(|r| tx.layer_of[r] == k)))
        .flat_map_iter(|q| within_two(tx.nb, q))
        .filter(|&r| valid(r))
        .collect();
    ring.sort_unstable();
    ring.dedup();
    ring
}

/// The shading ratio (log) between each ring pixel and its copy by the `first` offset, less the
/// occluders' shadow fitted from the surface a few pixels around the hole, and that shadow.
fn shading(
    tx: &FillContext,
    k: u32,
    ring_pixels: &[usize],
    hole_pixels: &[usize],
    valid: &impl Fn(usize) -> bool,
    first: Option<Vec3>,
    alpha: f32,
) -> (Vec<(usize, Vec3)>, Option<Shadow>) {
    let shadow = first.and_then(|t| {
        let samples = shadow_samples(tx, hole_pixels, valid, t);
        shadow::fit(tx, k, hole_pixels, &samples, alpha)
    });
    // In the ring's order (a hash map's varies from run to run; the build is deterministic).
    let raw = first.map(|t| ratios(tx, ring_pixels, valid, t)).unwrap_or_default();
    let shading = ring_pixels
        .iter()
        .filter_map(|&r| raw.get(&r).map(|e| (r, e.0)))
        .map(|(r, p)| {
            (
                r,
                median_ratio(tx, &raw, r)
                    - Vec3::splat(shadow.as_ref().map_or(0.0, |s| s.transfer(tx, r, p))),
            )
        })
        .collect();
    (shading, shadow)
}

/// The pixels one and two steps from `r` along the 8 directions.
fn within_two(nb: &Neighbours, r: usize) -> impl Iterator<Item = usize> + '_ {
    let (x, y) = (r % nb.width(), r / nb.width());
    (0..8).flat_map(move |j| [nb.get_at(x, y, j), nb.get2_at(x, y, j)]).flatten()
}

/// Per pixel, its copy by offset `t` (where that lands on the surface) and the log ratio of
/// their colours.
type Ratios = std::collections::HashMap<usize, (usize, Vec3)>;

fn ratios(tx: &FillContext, pixels: &[usize], valid: &impl Fn(usize) -> bool, t: Vec3) -> Ratios {
    let rgb = |p: usize| tx.colour(p).max(Vec3::ZERO) + Vec3::splat(RATIO_EPS);
    pixels
        .iter()
        .filter_map(|&r| {
            let p = tx.pixel(tx.point(r, tx.depth[r]) + t);
            valid(p).then(|| (r, (p, (rgb(r) / rgb(p)).ln())))
        })
        .collect()
}

/// Per channel, the median of the ratios at `r` and within two steps of it. Near an edge, a copy
/// a fraction of a pixel off reads as a false ratio as large as the edge's contrast, which a line
/// of such pixels across the ring does not move.
fn median_ratio(tx: &FillContext, raw: &Ratios, r: usize) -> Vec3 {
    let mut near: Vec<Vec3> =
        std::iter::once(r).chain(within_two(tx.nb, r)).filter_map(|q| raw.get(&q).map(|e| e.1)).collect();
    let channel = |c: usize, near: &mut Vec<Vec3>| {
        near.sort_unstable_by(|a, b| a[c].total_cmp(&b[c]));
        near[near.len() / 2][c]
    };
    Vec3::new(channel(0, &mut near), channel(1, &mut near), channel(2, &mut near))
}

/// What a shadow is fitted to: pixels of the surface (`valid`) within a few steps of the hole
/// (its radius over 2, 4 to 24 pixels; up to [`shadow::MAX_SAMPLES`] spread evenly), each with its
/// copy by offset `t` and the luma of its median ratio. The walk out starts through the hole's
/// own border band (the layer's pixels beside the occluder, in the fill for their colour).
fn shadow_samples(
    tx: &FillContext,
    hole: &[usize],
    valid: &impl Fn(usize) -> bool,
    t: Vec3,
) -> Vec<(usize, usize, f32)> {
    let depth = ((hole.len() as f32 / std::f32::consts::PI).sqrt() * 0.5).clamp(4.0, 24.0) as usize;
    // The hole's own pixels are never `valid` (hidden, or beside the occluder): not seeded.
    let mut seen: std::collections::HashSet<usize> = Default::default();
    let (mut frontier, mut around) = (hole.to_vec(), Vec::new());
    for _ in 0..depth {
        let mut next = Vec::new();
        for &q in &frontier {
            for r in (0..8).filter_map(|j| tx.nb.get(q, j)) {
                if valid(r) && seen.insert(r) {
                    next.push(r);
                }
            }
        }
        around.extend(&next);
        frontier = next;
    }
    let picked: Vec<usize> = spread(&around, shadow::MAX_SAMPLES).collect();
    // Their medians read the ratios of their neighbours too.
    let mut near: Vec<usize> =
        picked.iter().flat_map(|&r| std::iter::once(r).chain(within_two(tx.nb, r))).collect();
    near.sort_unstable();
    near.dedup();
    near.retain(|&q| valid(q));
    let raw = ratios(tx, &near, valid, t);
    picked
        .iter()
        .filter_map(|&r| raw.get(&r).map(|e| (r, e.0, median_ratio(tx, &raw, r).element_sum() / 3.0)))
        .collect()
}

/// A source must lie on the plane being continued (elsewhere the surface curves away).
fn on_plane(tx: &FillContext, plane: &Plane, p: usize) -> bool {
    let d = tx.depth[p];
    if !plane.finite {
        return d.is_infinite();
    }
    if !d.is_finite() || d <= 0.0 {
        return false;
    }
    let point = tx.dirs.at(p) * d;
    (plane.n.dot(point - plane.x)).abs() <= PLANE_TOL * d.max(plane.x.length())
}

/// Colour the fill of layer `k` by [`FillColour::Smooth`].
pub fn smooth(tx: &FillContext, k: u32, fill: &mut Fill) {
    if fill.pixels.is_empty() {
        return;
    }
    let (slot, clean) = (slots(tx, fill), clean_pixels(tx, k));
    let start = fill.pixels.iter().map(|f| Vec3::from(f.rgb)).collect();
    let rgb = diffuse(tx, fill, &slot, start, &vec![true; fill.pixels.len()], Sources::Solved, |r| {
        clean[r].then(|| tx.colour(r))
    });
    for (f, c) in fill.pixels.iter_mut().zip(rgb) {
        f.rgb = c.to_array();
    }
}

/// Which neighbours [`diffuse`] takes values from, besides the known pixels around the fill.
#[derive(Clone, Copy, PartialEq)]
enum Sources {
    /// Filled pixels being solved, once solved.
    Solved,
    /// The same, on the surface being solved only: a shading ratio measured on one surface
    /// (misread by an edge) must not tint the one beside it across a crease.
    SameSurface,
    /// Every filled pixel: the ones not solved keep their value and count as known.
    All,
}

/// A value per filled pixel spread from the pixels around the fill that have one (`known`):
/// inwards from the border (the fill's breadth-first order), each pixel takes the mean of the
/// known pixels one and two steps away along the 8 directions, weighted 1/d², then relaxation
/// sweeps average each with its 8 neighbours. Pixels nothing reaches keep their `value`.
fn diffuse(
    tx: &FillContext,
    fill: &Fill,
    slot: &[u32],
    mut value: Vec<Vec3>,
    solve: &[bool],
    sources: Sources,
    known: impl Fn(usize) -> Option<Vec3> + Sync,
) -> Vec<Vec3> {
    let d = Diffusion { tx, fill, slot, solve, sources, w: tx.nb.width() };
    d.inwards(&mut value, &known);
    let around = d.neighbour_sources();
    for _ in 0..SMOOTH_SWEEPS {
        value = d.sweep(&value, &around, &known);
    }
    value
}

/// [`Diffusion::source`] of a pixel around the fill: its value is what is known there.
const KNOWN: u32 = NONE - 1;

/// What [`diffuse`] spreads values over.
struct Diffusion<'a> {
    tx: &'a FillContext<'a>,
    fill: &'a Fill,
    slot: &'a [u32],
    solve: &'a [bool],
    sources: Sources,
    w: usize,
}

impl Diffusion<'_> {
    /// Where filled pixel `i` takes the value of canvas pixel `r` from.
    fn source(&self, i: usize, r: usize) -> u32 {
        let (tx, fill, s) = (self.tx, self.fill, self.slot[r]);
        let surface = || tx.surface[if s == NONE { r } else { fill.pixels[s as usize].surface }];
        if self.sources == Sources::SameSurface && surface() != tx.surface[fill.pixels[i].surface] {
            NONE
        } else if s == NONE {
            KNOWN
        } else if self.solve[s as usize] || self.sources == Sources::All {
            s
        } else {
            NONE
        }
    }

    /// The first pass, inwards from the border in the fill's order: each pixel to solve takes the
    /// mean of the neighbours one and two steps away along the 8 directions (weighted 1/d²) that
    /// have a value by then (a filled pixel's once solved or fixed, else what is known there).
    fn inwards(&self, value: &mut [Vec3], known: &impl Fn(usize) -> Option<Vec3>) {
        let (tx, w) = (self.tx, self.w);
        let mut done = vec![false; self.fill.pixels.len()];
        for i in (0..self.fill.pixels.len()).filter(|&i| self.solve[i]) {
            let q = self.fill.pixels[i].pixel;
            let (x, y) = (q % w, q / w);
            let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
            for j in 0..8 {
                let diag = if j >= 4 { 2.0 } else { 1.0 };
                for (r, wt) in [(tx.nb.get_at(x, y, j), 1.0 / diag), (tx.nb.get2_at(x, y, j), 0.25 / diag)] {
                    let v = r.and_then(|r| match self.source(i, r) {
                        NONE => None,
                        KNOWN => known(r),
                        s => (!self.solve[s as usize] || done[s as usize]).then(|| value[s as usize]),
                    });
                    if let Some(v) = v {
                        sum += v * wt;
                        weight += wt;
                    }
                }
            }
            if weight > 0.0 {
                value[i] = sum / weight;
                done[i] = true;
            }
        }
    }

    /// The sweeps' sources, found once: per pixel to solve, its 8 neighbours' sources, in order.
    fn neighbour_sources(&self) -> Vec<[u32; 8]> {
        (0..self.fill.pixels.len())
            .into_par_iter()
            .map(|i| {
                let mut e = [NONE; 8];
                if self.solve[i] {
                    let q = self.fill.pixels[i].pixel;
                    for (j, e) in e.iter_mut().enumerate() {
                        if let Some(r) = self.tx.nb.get_at(q % self.w, q / self.w, j) {
                            *e = self.source(i, r);
                        }
                    }
                }
                e
            })
            .collect()
    }

    /// One relaxation sweep: each pixel to solve the mean of itself and its neighbours' values.
    fn sweep(
        &self,
        value: &[Vec3],
        around: &[[u32; 8]],
        known: &(impl Fn(usize) -> Option<Vec3> + Sync),
    ) -> Vec<Vec3> {
        (0..self.fill.pixels.len())
            .into_par_iter()
            .map(|i| {
                if !self.solve[i] {
                    return value[i];
                }
                let (mut sum, mut weight) = (value[i], 1.0);
                for (j, &e) in around[i].iter().enumerate() {
                    let v = match e {
                        NONE => None,
                        KNOWN => {
                            let q = self.fill.pixels[i].pixel;
                            self.tx.nb.get_at(q % self.w, q / self.w, j).and_then(known)
                        }
                        s => Some(value[s as usize]),
                    };
                    if let Some(v) = v {
                        sum += v;
                        weight += 1.0;
                    }
                }
                sum / weight
            })
            .collect()
    }
}

/// Relaxation sweeps of [`diffuse`].
const SMOOTH_SWEEPS: usize = 8;

/// 8-connected parts of the fill, each as fill indices in the fill's (breadth-first) order.
fn components(nb: &Neighbours, fill: &Fill, slot: &[u32]) -> Vec<Vec<u32>> {
    let m = fill.pixels.len();
    let mut label = vec![NONE; m];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for start in 0..m {
        if label[start] != NONE {
            continue;
        }
        label[start] = count;
        stack.push(start);
        while let Some(i) = stack.pop() {
            for q in nb.all(fill.pixels[i].pixel) {
                let j = slot[q];
                if j != NONE && label[j as usize] == NONE {
                    label[j as usize] = count;
                    stack.push(j as usize);
                }
            }
        }
        count += 1;
    }
    let mut parts = vec![Vec::new(); count as usize];
    for (i, &l) in label.iter().enumerate() {
        parts[l as usize].push(i as u32);
    }
    // Largest first: rayon then balances the long ones.
    parts.sort_by_key(|p| std::cmp::Reverse(p.len()));
    parts
}
