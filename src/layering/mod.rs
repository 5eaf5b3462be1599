//! Building a layered panorama from a plain RGB-D panorama (thesis 6.2.4 and 6.3.1; spec §7).
//!
//! Stages: (1) classify depths (unknown, finite, infinitely far), (2) normals (given or estimated),
//! (3) links between 8-neighbours across the seam, poles and cube-face edges: smooth, fold or
//! jump, (4) segments and their occlusion levels — the minimal layering, (5) the infinity layer
//! for content whose parallax stays under a pixel, (6) fill each layer behind its occluders in the
//! parallax band of the freedom radius, (7) painter's order (farthest first) and layer images.

pub(crate) mod edges;
pub(crate) mod fill;
mod images;
mod pieces;
pub(crate) mod segment;

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::layer::LayerImage;
use crate::manifest::Role;
use crate::mapping::{AnyMapping, Mapping, Neighbours, PixelDirs};
pub use edges::EdgeOptions;
pub use fill::FillColour;
use fill::{fill_layer, FillContext};
use images::layer_heads;
pub use images::{layers_manifest, manifest, Layered};
use pieces::{assign_unknown, mixed_pixels_of, parts, pieces, repair_breaks};
pub use segment::SegmentOptions;
use segment::{segment, NO_SEGMENT};

/// A plain RGB-D panorama: one surface per ray.
#[derive(Clone, Debug)]
pub struct RgbdInput {
    /// The canvas's mapping (equirect or cube) and size; the planes below are row-major on it.
    pub mapping: AnyMapping,
    /// Linear (or display-referred, carried through untouched) RGB, planar.
    pub rgb: [Vec<f32>; 3],
    /// Distance along the ray (m). `NaN`, `0` or negative = unknown; `+inf` = infinitely far.
    pub depth: Vec<f32>,
    /// Unit normals (panorama frame), if the input has them.
    pub normals: Option<Vec<Vec3>>,
}

/// Tuning of [`build`].
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// Freedom radius (m): cameras within it must see no holes.
    pub freedom_radius: f64,
    /// Discontinuity tests and segmentation (default [`SegmentOptions::default`]).
    pub segment: SegmentOptions,
    /// Split layers further by depth: boundaries in metres (thesis 6.2.4.1). Empty = no split.
    pub depth_bands: Vec<f64>,
    /// Write normals into the layers.
    pub normals_out: bool,
    /// Put infinitely far content and content beyond `d_dirmin` in a direction-only layer.
    pub infinity: bool,
    /// Move mixed pixels (between a nearer and a farther surface, across jumps to both) to the farther.
    pub drop_mixed: bool,
    /// Also treat depth edges spread over a few pixels (resized or estimated depth) as mixed pixels
    /// (`edges::ramp_pixels`). Off by default: the limb of a near curved object looks the same.
    pub soft_edges: bool,
    /// The depth is soft (estimated, blurred or resized): its outlines keep small pieces of
    /// in-between depth, whose own planes the fill does not continue (the plane of their layer a
    /// few pixels inside instead). [`crate::jobs::build_panorama`] sets it when the prepared depth
    /// is not exact ([`crate::prepare::PrepareReport::inexact`]); exact depth builds as without it.
    pub soft_depth: bool,
    /// Extra fill band in pixels beyond the parallax band (reconstruction filters reach ~1-2 px).
    pub margin_px: f64,
    /// How layers are separated beyond the occlusion levels (default [`Classify::Depth`]).
    pub classify: Classify,
    /// How the fill is coloured.
    pub fill_colour: FillColour,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            freedom_radius: 0.5,
            segment: SegmentOptions::default(),
            depth_bands: Vec::new(),
            normals_out: false,
            infinity: true,
            drop_mixed: true,
            soft_edges: false,
            soft_depth: false,
            margin_px: 2.0,
            classify: Classify::Depth,
            fill_colour: FillColour::default(),
        }
    }
}

crate::choice::choices! {
    /// How layers are separated beyond the minimal layering.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Classify (default Depth) {
        /// Occlusion levels (and depth bands) only.
        Depth = "depth",
        /// Also split the background into floor, ceiling and walls.
        ///
        /// By the segments' mean normals (thesis 6.2.4.2; `+Z` is up in the panorama frame).
        Geometry = "geometry",
    }
}

/// Surface class of a background segment under [`Classify::Geometry`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SurfaceClass {
    /// Faces up (within 25° of `+Z`) and lies below the centre.
    Floor,
    /// Near-vertical: normal within 25° of horizontal.
    Wall,
    /// Faces down (within 25° of `-Z`) and lies above the centre.
    Ceiling,
    /// Anything else, and every segment under [`Classify::Depth`] or above level 0.
    Any,
}

/// Which layer a pixel goes to; the derived order is the painter's order (far first).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
struct LayerKey {
    level: u32,
    band_rev: u32,
    class: SurfaceClass,
    /// Segments of one key that meet across a discontinuity go to different parts (layers).
    part: u32,
}

/// Classify segments by their area-weighted mean normal (facing the centre) and position:
/// a floor faces up and lies below the centre, a ceiling faces down above it, a wall is
/// near-vertical; anything else stays generic background.
fn segment_classes(
    seg: &segment::Segments,
    normals: &[Vec3],
    dirs: &PixelDirs,
    depth: &[f32],
) -> Vec<SurfaceClass> {
    let count = seg.size.len();
    let mut sum_n = vec![Vec3::ZERO; count];
    let mut sum_z = vec![0.0f64; count];
    for p in 0..seg.id.len() {
        let s = seg.id[p];
        if s != NO_SEGMENT {
            sum_n[s as usize] += normals[p];
            sum_z[s as usize] += (dirs.at(p).z * depth[p]) as f64;
        }
    }
    let (cos_flat, sin_vertical) = (25f32.to_radians().cos(), 25f32.to_radians().sin());
    (0..count)
        .map(|s| {
            let n = sum_n[s].normalize_or_zero();
            let below = sum_z[s] < 0.0;
            if n.z > cos_flat && below {
                SurfaceClass::Floor
            } else if n.z < -cos_flat && !below {
                SurfaceClass::Ceiling
            } else if n != Vec3::ZERO && n.z.abs() < sin_vertical {
                SurfaceClass::Wall
            } else {
                SurfaceClass::Any
            }
        })
        .collect()
}

/// Errors of [`build`].
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// A colour plane or the depth does not hold one sample per canvas pixel; `BUILD_SIZE_MISMATCH`.
    #[error("colour is {colour} pixels but depth is {depth}; give colour and depth of the same size")]
    SizeMismatch {
        /// Samples in the (first mismatching) colour plane.
        colour: usize,
        /// Samples in the depth plane.
        depth: usize,
    },
    /// [`BuildOptions::freedom_radius`] (metres, given here) is not positive and finite; `BUILD_BAD_RADIUS`.
    #[error("freedom radius {0} m is not a positive finite number")]
    BadRadius(f64),
}

crate::codes::error_codes! {
    BuildError:
        SizeMismatch BUILD_SIZE_MISMATCH,
        BadRadius BUILD_BAD_RADIUS
}

/// One output layer.
#[derive(Clone, Debug)]
pub struct BuiltLayer {
    /// Layer name: `infinity`, `background`, `floor`, `walls`, `ceiling` or `objects-N`, numbered
    /// `-2`, `-3`… when depth bands give several of one kind.
    pub name: String,
    /// The layer's role in the manifest.
    pub role: Role,
    /// Painter's order from the centre (0 = drawn first, farthest).
    pub order: u32,
    /// Full-canvas layer image: `R`,`G`,`B`, `Z` (−1 outside), and `N.X`,`N.Y`,`N.Z` with
    /// [`BuildOptions::normals_out`].
    pub image: LayerImage,
    /// Pixels seen from the centre on this layer.
    pub own_pixels: usize,
    /// Pixels filled behind nearer layers.
    pub filled_pixels: usize,
    /// Smallest and largest finite depth in the layer image (metres); `None` if it has none.
    pub depth_range: Option<(f32, f32)>,
}

/// Per-layer figures of the report.
#[derive(Clone, Debug, Serialize)]
pub struct LayerStats {
    /// Layer name, as [`BuiltLayer::name`].
    pub name: String,
    /// The role's manifest name, e.g. `background` or `infinity`.
    pub role: &'static str,
    /// Painter's order from the centre (0 = drawn first, farthest).
    pub order: u32,
    /// Pixels seen from the centre on this layer.
    pub own_pixels: usize,
    /// Pixels filled behind nearer layers.
    pub filled_pixels: usize,
    /// Smallest and largest finite depth in the layer (metres); `None` if it has none.
    pub depth_range: Option<(f32, f32)>,
}

impl LayerStats {
    pub(crate) fn of(l: &BuiltLayer) -> LayerStats {
        LayerStats {
            name: l.name.clone(),
            role: l.role.as_str(),
            order: l.order,
            own_pixels: l.own_pixels,
            filled_pixels: l.filled_pixels,
            depth_range: l.depth_range,
        }
    }
}

/// What [`build`] did, for `--json` / `--report`.
#[derive(Clone, Debug, Serialize)]
pub struct BuildReport {
    /// Canvas width, pixels.
    pub width: usize,
    /// Canvas height, pixels.
    pub height: usize,
    /// Seconds per stage, in order.
    pub stages: Vec<(&'static str, f64)>,
    /// Figures of each output layer, in painter's order.
    pub layers: Vec<LayerStats>,
    /// Fraction of the sphere's pixels in at least one layer (1 for a valid result).
    pub coverage: f64,
    /// Input pixels of unknown depth (`NaN`, 0 or negative), after mixed pixels were moved.
    pub unknown_pixels: usize,
    /// Mixed pixels moved to the farther side of their edge.
    pub mixed_pixels: usize,
    /// Number of surface segments found.
    pub segments: usize,
    /// Distance beyond which content goes to the infinity layer (m).
    pub d_dirmin: f64,
    /// Widest fill band used, degrees.
    pub max_band_deg: f64,
    /// Freedom radius used (m).
    pub freedom_radius: f64,
    /// Relative depth jump used by the edge test ([`edges::EdgeOptions::jump`]).
    pub jump_threshold: f64,
    /// Fold angle used (degrees); `None` = no fold test.
    pub fold_deg: Option<f64>,
    /// Extra fill band used beyond the parallax band, pixels.
    pub margin_px: f64,
}

/// The result of [`build`].
#[derive(Clone, Debug)]
pub struct Built {
    /// Output layers in painter's order (farthest first); empty layers are left out.
    pub layers: Vec<BuiltLayer>,
    /// Layer (index into `layers`) each pixel was seen on from the centre.
    pub layer_of: Vec<u32>,
    /// Figures of the build.
    pub report: BuildReport,
}

/// Angular size of a pixel (radians) used for the one-pixel parallax threshold: the equirect
/// row height `π/H`, or the cube face-centre pixel `(π/2)/N`.
pub fn pixel_angle(m: &AnyMapping) -> f64 {
    match m {
        AnyMapping::Equirect(_) => std::f64::consts::PI / m.height() as f64,
        AnyMapping::Cube(c) => std::f64::consts::FRAC_PI_2 / c.face_size() as f64,
    }
}

/// `d_dirmin` (thesis 6.2.4.3): the smallest distance whose parallax, for any camera within `r`
/// of the centre, stays under one pixel: `asin(r/d) < α  ⇔  d > r / sin α`.
pub fn d_dirmin(r: f64, pixel_angle: f64) -> f64 {
    r / pixel_angle.sin()
}

/// The stages of [`build`] in order, as `progress` names them and the report times them.
pub const STAGES: &[&str] =
    &["classify", "normals", "segments", "layers", "fill", "borders", "fill colour", "images"];

/// The stages a build with options `o` runs: [`STAGES`] without `fill colour` when fills keep
/// the nearest colour.
pub fn stages(o: &BuildOptions) -> Vec<&'static str> {
    STAGES.iter().copied().filter(|&s| s != "fill colour" || o.fill_colour != FillColour::Nearest).collect()
}

/// Progress and timing of the stages, from one place: each start tells `progress` and closes the
/// stage before it.
struct Stages<'a> {
    progress: &'a dyn Fn(&str),
    current: Option<(&'static str, Instant)>,
    times: Vec<(&'static str, f64)>,
}

impl<'a> Stages<'a> {
    fn new(progress: &'a dyn Fn(&str)) -> Self {
        Stages { progress, current: None, times: Vec::new() }
    }

    fn start(&mut self, name: &'static str) {
        debug_assert!(STAGES.contains(&name), "{name} is not in STAGES");
        self.close();
        (self.progress)(name);
        self.current = Some((name, Instant::now()));
    }

    fn close(&mut self) {
        if let Some((name, t)) = self.current.take() {
            self.times.push((name, t.elapsed().as_secs_f64()));
        }
    }

    fn finish(mut self) -> Vec<(&'static str, f64)> {
        self.close();
        self.times
    }
}

/// Build layers from an RGB-D panorama. `progress` is told each stage's name as it starts.
pub fn build(input: RgbdInput, o: &BuildOptions, progress: &dyn Fn(&str)) -> Result<Built, BuildError> {
    layer(input, o, progress).map(Layered::into_built)
}

/// [`build`] up to the layer images: every stage but making the images (the `images` stage then
/// only names the layers and measures their depths). The input's depth and normals are let go
/// once read.
pub fn layer(mut input: RgbdInput, o: &BuildOptions, progress: &dyn Fn(&str)) -> Result<Layered, BuildError> {
    check_input(&input, o)?;
    let m = input.mapping;
    let n = m.width() * m.height();
    let mut stages = Stages::new(progress);
    let nb = Neighbours::new(m);
    let dirs = PixelDirs::new(m);

    // (1) Depth classes. Unknown → NaN; far content → +inf (direction only).
    stages.start("classify");
    let classified = classify(&input, o, &nb);
    input.depth = Vec::new();
    let Classified { mut depth, links, mixed_pixels, dmin } = classified;
    let unknown_pixels = depth.par_iter().filter(|d| d.is_nan()).count();

    // (2) Normals.
    stages.start("normals");
    let normals = normals(&input, &nb, &links, &dirs, &depth);
    input.normals = None;

    // (3, 4) Links, segments, levels.
    stages.start("segments");
    let seg = segment(&nb, &depth, &links, &normals, &o.segment);

    // (5) Layer keys: infinity first, then (level, depth band far→near, surface class).
    stages.start("layers");
    let (keys, layer_of, first) = assign_layers(o, &nb, &seg, &normals, &dirs, &mut depth);

    // (6) Fill behind occluders.
    stages.start("fill");
    let count = first as usize + keys.len();
    let cx = FillContext {
        nb: &nb,
        dirs: &dirs,
        depth: &depth,
        normals: &normals,
        layer_of: &layer_of,
        freedom_radius: o.freedom_radius,
        margin: o.margin_px * pixel_angle(&m),
        links: &links,
        surface: &seg.id,
        jump: o.segment.edges.jump,
        plane_tol: o.segment.edges.extrapolation,
        rgb: &input.rgb,
        soft_depth: o.soft_depth,
    };
    let fills = fill_all(&cx, count, o.fill_colour, &mut stages);
    let segments = seg.size.len();
    // What the images do not need goes before they are made.
    drop((seg, links, dirs, nb));

    // (7) Names, roles, order and depths; the images themselves on demand.
    stages.start("images");
    let (heads, fills, index) = layer_heads(&keys, first, fills, &depth, &layer_of);
    let covered = layer_of.par_iter().filter(|&&l| l != u32::MAX).count();
    let max_band_deg = fills.iter().map(|f| f.max_angle).fold(0.0, f64::max).to_degrees();
    let report = BuildReport {
        width: m.width(),
        height: m.height(),
        stages: stages.finish(),
        layers: heads.iter().map(LayerStats::of).collect(),
        coverage: covered as f64 / n as f64,
        unknown_pixels,
        mixed_pixels,
        segments,
        d_dirmin: dmin,
        max_band_deg,
        freedom_radius: o.freedom_radius,
        jump_threshold: o.segment.edges.jump,
        fold_deg: o.segment.edges.fold_deg,
        margin_px: o.margin_px,
    };
    let normals = if o.normals_out { normals } else { Vec::new() };
    Ok(Layered { input, depth, normals, layer_of, heads, fills, index, report })
}

/// The input's planes all of one size, and the freedom radius usable.
fn check_input(input: &RgbdInput, o: &BuildOptions) -> Result<(), BuildError> {
    let n = input.mapping.width() * input.mapping.height();
    for c in &input.rgb {
        if c.len() != n || input.depth.len() != n {
            return Err(BuildError::SizeMismatch { colour: c.len(), depth: input.depth.len() });
        }
    }
    if !(o.freedom_radius > 0.0 && o.freedom_radius.is_finite()) {
        return Err(BuildError::BadRadius(o.freedom_radius));
    }
    Ok(())
}

/// Step 6: the fill of each of `count` layers (stage `fill`, started by the caller), its borders
/// and its colour (stages `borders`, `fill colour`).
fn fill_all(cx: &FillContext, count: usize, colour: FillColour, stages: &mut Stages) -> Vec<fill::Fill> {
    let mut fills: Vec<fill::Fill> = (0..count as u32).into_par_iter().map(|k| fill_layer(cx, k)).collect();
    let yielded = fill::yield_to_farther(&mut fills);
    fills.par_iter_mut().zip(yielded).enumerate().filter(|(_, (_, y))| *y).for_each(|(k, (f, _))| {
        fill::keep_valid(cx, k as u32, f);
    });
    stages.start("borders");
    fill::add_borders(cx, &mut fills);
    if colour != FillColour::Nearest {
        stages.start("fill colour");
        fills.par_iter_mut().enumerate().for_each(|(k, f)| match colour {
            FillColour::Exemplar => fill::texture::synthesise(cx, k as u32, f),
            _ => fill::texture::smooth(cx, k as u32, f),
        });
    }
    fills
}

/// Step 1: depths as layering reads them, the links between neighbours, and the mixed pixels moved.
struct Classified {
    depth: Vec<f32>,
    links: edges::Links,
    mixed_pixels: usize,
    dmin: f64,
}

fn classify(input: &RgbdInput, o: &BuildOptions, nb: &Neighbours) -> Classified {
    let dmin = d_dirmin(o.freedom_radius, pixel_angle(&input.mapping));
    let mut depth: Vec<f32> = input
        .depth
        .par_iter()
        .map(|&d| {
            if d.is_nan() || d <= 0.0 {
                f32::NAN
            } else if o.infinity && (d as f64) > dmin {
                f32::INFINITY
            } else {
                d
            }
        })
        .collect();
    let mut links = edges::Links::compute(nb, &depth, &o.segment.edges);
    // Mixed pixels (an anti-aliased or filtered depth pass averages the two sides of an edge): a
    // pixel across a jump from a nearer and from a farther neighbour, between them, belongs to
    // neither surface. It joins the farther side at its depth, so the edge between the two sides
    // (and who occludes whom) stays.
    // Edges spread over several pixels (resized or blurred depth) are ramps of such pixels.
    let mut mixed_pixels = 0;
    if o.drop_mixed {
        let mut mixed = mixed_pixels_of(nb, &depth, &links);
        if o.soft_edges {
            mixed.extend(edges::ramp_pixels(nb, &depth, &o.segment.edges));
        }
        // A pixel found twice (along a row and a column) takes the farther depth.
        mixed.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
        mixed.dedup_by_key(|m| m.0);
        if !mixed.is_empty() {
            mixed_pixels = mixed.len();
            for &(p, d) in &mixed {
                depth[p] = d;
            }
            links = edges::Links::compute(nb, &depth, &o.segment.edges);
        }
    }
    Classified { depth, links, mixed_pixels, dmin }
}

/// Step 2: the given normals facing the centre, or normals estimated from the surface.
fn normals(
    input: &RgbdInput,
    nb: &Neighbours,
    links: &edges::Links,
    dirs: &PixelDirs,
    depth: &[f32],
) -> Vec<Vec3> {
    match &input.normals {
        Some(given) if given.len() == depth.len() => given
            .par_iter()
            .enumerate()
            .map(|(p, &nv)| {
                let nv = nv.normalize_or_zero();
                if nv.dot(dirs.at(p)) > 0.0 {
                    -nv
                } else {
                    nv
                }
            })
            .collect(),
        _ => edges::estimate_normals(nb, links, dirs, depth),
    }
}

/// Step 5: each pixel's layer. Returns the layer keys (after the infinity layer, when there is
/// one), the layer of each pixel (`u32::MAX`: none) and the index of the first keyed layer.
fn assign_layers(
    o: &BuildOptions,
    nb: &Neighbours,
    seg: &segment::Segments,
    normals: &[Vec3],
    dirs: &PixelDirs,
    depth: &mut [f32],
) -> (Vec<LayerKey>, Vec<u32>, u32) {
    let (keys, mut layer_of, first) = keyed_layers(o, nb, seg, normals, dirs, depth);
    assign_unknown(nb, depth, &mut layer_of, first);
    repair_breaks(nb, depth, &mut layer_of);
    (keys, layer_of, first)
}

/// Each pixel's layer before unknown depths join one: the layer keys (after the infinity
/// layer, when there is one), the layer of each pixel (`u32::MAX`: none) and the index of the
/// first keyed layer.
fn keyed_layers(
    o: &BuildOptions,
    nb: &Neighbours,
    seg: &segment::Segments,
    normals: &[Vec3],
    dirs: &PixelDirs,
    depth: &[f32],
) -> (Vec<LayerKey>, Vec<u32>, u32) {
    let n = depth.len();
    let has_infinity = depth.par_iter().any(|d| d.is_infinite());
    // Keys as indices into the distinct keys before parts (4 bytes a pixel, not 16).
    let key_of = keys_of_pixels(o, seg, normals, dirs, depth);
    let unparted = distinct(n, &key_of);
    let key_index: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|p| key_of(p).map_or(u32::MAX, |k| unparted.binary_search(&k).expect("key collected") as u32))
        .collect();
    let (piece, piece_size) = pieces(nb, depth, &seg.id, &seg.size);
    let part = parts(nb, depth, &piece, &piece_size, |p| Some(key_index[p]).filter(|&i| i != u32::MAX));
    let key_of = |p: usize| {
        let i = key_index[p];
        (i != u32::MAX).then(|| LayerKey { part: part[piece[p] as usize], ..unparted[i as usize] })
    };
    let mut keys = distinct(n, &key_of);
    if keys.is_empty() && !has_infinity {
        // All unknown: one background layer.
        keys.push(LayerKey { level: 0, band_rev: 0, class: SurfaceClass::Any, part: 0 });
    }
    let first = has_infinity as u32;
    let layer_of: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|p| match key_of(p) {
            Some(k) => first + keys.binary_search(&k).expect("key collected") as u32,
            None if depth[p].is_infinite() => 0,
            None => u32::MAX,
        })
        .collect();
    (keys, layer_of, first)
}

/// Each pixel's layer key before parts: its segment's level, depth band (far to near) and, with
/// `classify = geometry`, the background's surface class; `None` outside every segment.
fn keys_of_pixels<'a>(
    o: &'a BuildOptions,
    seg: &'a segment::Segments,
    normals: &[Vec3],
    dirs: &PixelDirs,
    depth: &'a [f32],
) -> impl Fn(usize) -> Option<LayerKey> + Sync + 'a {
    let band_of = |d: f32| o.depth_bands.iter().filter(|&&b| (d as f64) >= b).count() as u32;
    let nbands = o.depth_bands.len() as u32 + 1;
    let class = match o.classify {
        Classify::Depth => vec![SurfaceClass::Any; seg.size.len()],
        Classify::Geometry => segment_classes(seg, normals, dirs, depth),
    };
    move |p: usize| -> Option<LayerKey> {
        let s = seg.id[p];
        if s == NO_SEGMENT {
            return None;
        }
        let level = seg.level[s as usize];
        Some(LayerKey {
            level,
            band_rev: nbands - 1 - band_of(depth[p]),
            class: if level == 0 { class[s as usize] } else { SurfaceClass::Any },
            part: 0,
        })
    }
}

/// The distinct keys of pixels `0..n`, in order.
fn distinct(n: usize, key_of: &(impl Fn(usize) -> Option<LayerKey> + Sync)) -> Vec<LayerKey> {
    (0..n)
        .into_par_iter()
        // Runs of pixels share a key: the last one inserted is skipped without a tree search.
        .fold(
            || (std::collections::BTreeSet::new(), None),
            |(mut set, mut last), p| {
                if let Some(k) = key_of(p) {
                    if last != Some(k) {
                        set.insert(k);
                        last = Some(k);
                    }
                }
                (set, last)
            },
        )
        .map(|(set, _)| set)
        .reduce(std::collections::BTreeSet::new, |mut a, b| {
            a.extend(b);
            a
        })
        .into_iter()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::MappingKind;

    /// A column of pixels halfway between a near surface (2 m) and a far one (4 m), like a box
    /// filter makes at an edge, joins the far side; nothing else moves (the seam and the poles
    /// included).
    #[test]
    fn mixed_pixels_join_the_farther_side() {
        let m = AnyMapping::new(MappingKind::Equirect, 16, 8).unwrap();
        let nb = Neighbours::new(m);
        let depth: Vec<f32> = (0..16 * 8)
            .map(|p| match p % 16 {
                0..=5 => 2.0,
                6 => 3.0,
                _ => 4.0,
            })
            .collect();
        let links = edges::Links::compute(&nb, &depth, &edges::EdgeOptions::default());
        let mixed = mixed_pixels_of(&nb, &depth, &links);
        let mut cols: Vec<usize> = mixed.iter().map(|&(p, _)| p % 16).collect();
        cols.dedup();
        assert_eq!(cols, vec![6], "{mixed:?}");
        assert_eq!(mixed.len(), 8);
        assert!(mixed.iter().all(|&(_, d)| d == 4.0));
    }
}
