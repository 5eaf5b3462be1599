//! Layers from a 3D scene by rendering every hit (thesis 6.3.2, spec §7.4; `pomc scene`): rays
//! from the centre through every pixel keep every surface they cross; hits no eye inside the
//! freedom radius can see are left out; the rest join pieces of continuous surface, and pieces go
//! to layers so that no layer overlaps itself or jumps. Nothing behind objects is guessed.

mod envmap;
pub mod load;
pub mod material;
mod pieces;
pub mod trace;
mod visible;

use std::path::PathBuf;
use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::continuity;
use crate::input::Convention;
use crate::layer::{LayerImage, SampleType, OUTSIDE_DEPTH};
use crate::layering::{pixel_angle, BuiltLayer, LayerStats};
use crate::manifest::Role;
use crate::mapping::{AnyMapping, Mapping, MappingKind, Neighbours};
use envmap::EnvMap;
use pieces::continuous;

pub use load::TriangleScene;
pub use trace::{Hit, Tracer};

/// Errors of `pomc scene`; each names the file or setting and the fix.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file cannot be read or parsed as its format (`SCENE_UNREADABLE`).
    #[error("{path}: cannot read the scene ({why})")]
    Unreadable {
        /// The scene (or texture) file.
        path: PathBuf,
        /// What the reader reported.
        why: String,
    },
    /// Not a format pomc reads (`SCENE_UNSUPPORTED`).
    #[error("{path}: `.{extension}` is not a scene format pomc reads; give a .gltf, .glb or .obj file")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// Its extension.
        extension: String,
    },
    /// No triangle in the scene (`SCENE_EMPTY`).
    #[error("{path}: the scene has no triangles (points and lines are not surfaces)")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// More triangles than the limit (`SCENE_TOO_LARGE`).
    #[error("{path}: {triangles} triangles is beyond the limit of {limit}; raise --max-triangles")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Triangles found.
        triangles: usize,
        /// The limit.
        limit: usize,
    },
    /// A setting out of its range (`SCENE_BAD_OPTION`).
    #[error("{0}")]
    BadOption(String),
}

crate::codes::error_codes! {
    SceneError:
        Unreadable SCENE_UNREADABLE,
        Unsupported SCENE_UNSUPPORTED,
        Empty SCENE_EMPTY,
        TooLarge SCENE_TOO_LARGE,
        BadOption SCENE_BAD_OPTION
}

/// Everything `pomc scene` takes besides its input and output paths.
#[derive(Clone, Debug)]
pub struct BakeSettings {
    /// Panorama centre in the world (pomc's +Z-up frame), metres (`--center`).
    pub center: DVec3,
    /// Freedom radius, metres: hits no eye within it sees are left out (`--freedom-radius`).
    pub freedom_radius: f64,
    /// Canvas width, pixels: an equirect is W × W/2, a cube map W × 2W/3 (`--width`).
    pub width: usize,
    /// Mapping of the layers (`--mapping`).
    pub mapping: MappingKind,
    /// Rays per pixel for the colour; depth and normals come from the pixel centre (`--samples`).
    pub samples: u32,
    /// Environment map for the sky (equirect HDR, EXR, PNG, JPEG), `None` for a plain colour
    /// (`--sky`).
    pub sky: Option<PathBuf>,
    /// Colour of the sky without a map, linear RGB (`--sky-colour`).
    pub sky_colour: [f32; 3],
    /// Renders of the scene from the centre (equirect, e.g. Cycles' panorama camera): render `k`
    /// colours each ray's `k`-th hit in place of its material (`--colour`): the first is what the
    /// centre sees, the next ones renders with the surfaces before peeled away (thesis 6.3.2 shades
    /// every intersection). Lighting and looks a material cannot carry come through; hits past the
    /// last render keep their material's colour.
    pub colour: Vec<PathBuf>,
    /// Azimuth convention of the environment map and the render (`--convention`).
    pub convention: Convention,
    /// Write normals from the geometry (`--no-normals` turns them off).
    pub normals: bool,
    /// Largest scene accepted, triangles (`--max-triangles`).
    pub max_triangles: usize,
    /// How layers are stored (`--no-pack`).
    pub save: crate::panorama::SaveOptions,
}

impl Default for BakeSettings {
    fn default() -> Self {
        BakeSettings {
            center: DVec3::ZERO,
            freedom_radius: 0.5,
            width: 4096,
            mapping: MappingKind::Equirect,
            samples: 4,
            sky: None,
            sky_colour: [0.0; 3],
            colour: Vec::new(),
            convention: Convention::Thesis,
            normals: true,
            max_triangles: 50_000_000,
            save: Default::default(),
        }
    }
}

impl BakeSettings {
    /// The canvas of these settings, or why there is none.
    pub fn mapping(&self) -> Result<AnyMapping, SceneError> {
        let bad = |why: String| SceneError::BadOption(why);
        if !(self.freedom_radius > 0.0 && self.freedom_radius.is_finite()) {
            return Err(bad(format!("the freedom radius {} is not a positive number", self.freedom_radius)));
        }
        if !self.center.is_finite() {
            return Err(bad("the centre is not finite".into()));
        }
        if !(1..=64).contains(&self.samples) {
            return Err(bad(format!("{} samples per pixel: give 1 to 64", self.samples)));
        }
        let w = self.width;
        let height = match self.mapping {
            MappingKind::Equirect if w >= 8 && w % 2 == 0 && w <= 65536 => w / 2,
            MappingKind::Cube3x2 if w >= 6 && w % 3 == 0 && w <= 98304 => 2 * w / 3,
            _ => return Err(bad(format!("width {w}: an equirect needs an even width (8 to 65536), a cube map a multiple of 3 (6 to 98304)"))),
        };
        if (w as u64) * (height as u64) > 1 << 28 {
            return Err(bad(format!(
                "width {w}: {w}x{height} is beyond the 2^28 pixels (about 23170 x 11585) pomc makes"
            )));
        }
        AnyMapping::new(self.mapping, w, height).map_err(|e| bad(e.to_string()))
    }
}

/// The hits of every pixel's centre ray, nearest first (row-major, compressed).
pub struct HitGrid {
    /// `start[p]..start[p + 1]` are pixel `p`'s hits.
    pub start: Vec<usize>,
    /// Every hit.
    pub hits: Vec<Hit>,
    /// Each pixel's centre ray (unit).
    pub dirs: Vec<Vec3>,
}

impl HitGrid {
    /// Indices of pixel `p`'s hits.
    pub fn range(&self, p: usize) -> std::ops::Range<usize> {
        self.start[p]..self.start[p + 1]
    }

    /// Pixel `p`'s centre ray.
    pub fn dir(&self, p: usize) -> Vec3 {
        self.dirs[p]
    }
}

/// Most hits kept along one ray (the nearest): a ray through foliage can cross thousands.
pub const MAX_HITS: usize = 64;

/// The stages of [`bake`] in order, as progress names them and the report times them.
pub const STAGES: &[&str] = &["bvh", "trace", "visibility", "pieces", "layers", "colour", "images"];

/// What [`bake`] did, for `--json`.
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
    /// Canvas width, pixels.
    pub width: usize,
    /// Canvas height, pixels.
    pub height: usize,
    /// Triangles traced.
    pub triangles: usize,
    /// Primitives left out (points, lines, degenerate triangles).
    pub skipped: usize,
    /// Seconds per stage, in order.
    pub stages: Vec<(&'static str, f64)>,
    /// Hits of the centre rays.
    pub hits: usize,
    /// Hits some eye within the freedom radius sees (in layers).
    pub kept_hits: usize,
    /// Pieces of continuous surface.
    pub pieces: usize,
    /// Pixels of the infinity layer.
    pub sky_pixels: usize,
    /// Figures of each layer, painter's order.
    pub layers: Vec<LayerStats>,
    /// Share of each layer's canvas holding content (same order).
    pub occupancy: Vec<f64>,
    /// Freedom radius used (m).
    pub freedom_radius: f64,
}

/// Layers made from a scene: painter's order, images made.
pub struct Baked {
    /// The layers, farthest first (the infinity layer first when there is sky).
    pub layers: Vec<BuiltLayer>,
    /// What was done.
    pub report: BakeReport,
}

/// Make the layers of `scene` (positions relative to the panorama centre), calling `progress`
/// with each stage's name as it starts.
pub fn bake(scene: &TriangleScene, s: &BakeSettings, progress: &dyn Fn(&str)) -> crate::Result<Baked> {
    let mapping = s.mapping()?;
    let sky_map = s.sky.as_deref().map(|p| EnvMap::read(p, s.convention, "a sky map")).transpose()?;
    let views: Vec<EnvMap> = s
        .colour
        .iter()
        .map(|p| EnvMap::read(p, s.convention, "a colour render"))
        .collect::<crate::Result<_>>()?;
    let nb = Neighbours::new(mapping);
    let (w, h) = (mapping.width(), mapping.height());
    let r = s.freedom_radius as f32;
    let mut stages = Vec::new();
    let mut clock = Instant::now();
    let mut stage = |name: &'static str, stages: &mut Vec<(&'static str, f64)>| {
        if let Some(last) = stages.last_mut() {
            let (_, t): &mut (&str, f64) = last;
            *t = clock.elapsed().as_secs_f64();
        }
        clock = Instant::now();
        stages.push((name, 0.0));
        // `done` only closes the last stage's time: no stage of progress.
        if name != "done" {
            progress(name);
        }
    };
    stage("bvh", &mut stages);
    let tr = Tracer::new(scene);
    stage("trace", &mut stages);
    let grid = trace_grid(&tr, &mapping);
    stage("visibility", &mut stages);
    let kept = visible::kept(&tr, &grid, &nb, r);
    let sky = visible::sky(&tr, &grid, &nb, r, pixel_angle(&mapping));
    stage("pieces", &mut stages);
    let pieces = pieces::grow(&tr, &grid, &nb, &kept);
    stage("layers", &mut stages);
    let (piece_layer, layer_count) = pieces::layers(&tr, &grid, &nb, &pieces);
    stage("colour", &mut stages);
    let shaded = shade(&tr, &grid, &mapping, &nb, &pieces.label, &views, s);
    stage("images", &mut stages);
    let hit_layer: Vec<u32> = pieces
        .label
        .par_iter()
        .map(|&l| if l == u32::MAX { u32::MAX } else { piece_layer[l as usize] })
        .collect();
    let mut layers =
        surface_layers(&nb, &grid, &mapping, &hit_layer, layer_count, &shaded, &pieces, &piece_layer, s);
    let sky_pixels = sky.as_ref().map_or(0, |v| v.iter().filter(|&&b| b).count());
    if let Some(sky) = &sky {
        // Where the centre sees the sky: `Some(beside an object's silhouette)`.
        let seen = |p: usize| {
            let open = |q: usize| grid.range(q).is_empty();
            open(p).then(|| (0..8).filter_map(|k| nb.get(p, k)).any(|q| !open(q)))
        };
        layers.insert(0, sky_layer(&mapping, sky, sky_map.as_ref(), views.first(), &seen, s));
    }
    for (k, l) in layers.iter_mut().enumerate() {
        l.order = k as u32;
    }
    stage("done", &mut stages);
    stages.pop();
    let n = (w * h) as f64;
    let report = BakeReport {
        width: w,
        height: h,
        triangles: scene.len(),
        skipped: scene.skipped,
        stages,
        hits: grid.hits.len(),
        kept_hits: kept.iter().filter(|&&k| k).count(),
        pieces: pieces.size.len(),
        sky_pixels,
        occupancy: layers.iter().map(|l| (l.own_pixels + l.filled_pixels) as f64 / n).collect(),
        layers: layers.iter().map(LayerStats::of).collect(),
        freedom_radius: s.freedom_radius,
    };
    Ok(Baked { layers, report })
}

/// Every pixel's centre-ray hits.
fn trace_grid(tr: &Tracer, m: &AnyMapping) -> HitGrid {
    let (w, h) = (m.width(), m.height());
    let dirs: Vec<Vec3> = (0..w * h).into_par_iter().map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    let rows: Vec<(Vec<usize>, Vec<Hit>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut counts, mut hits, mut buf) = (Vec::with_capacity(w), Vec::new(), Vec::new());
            for x in 0..w {
                tr.hits(Vec3::ZERO, dirs[y * w + x], &mut buf);
                buf.truncate(MAX_HITS);
                counts.push(buf.len());
                hits.extend_from_slice(&buf);
            }
            (counts, hits)
        })
        .collect();
    let mut start = Vec::with_capacity(w * h + 1);
    start.push(0);
    let mut all = Vec::with_capacity(rows.iter().map(|r| r.1.len()).sum());
    for (counts, hits) in rows {
        for c in counts {
            start.push(start.last().copied().unwrap_or(0) + c);
        }
        all.extend(hits);
    }
    HitGrid { start, hits: all, dirs }
}

/// Sub-pixel offsets of `n` colour rays: a stratified grid, centre for one.
fn sample_offsets(n: u32) -> Vec<(f64, f64)> {
    let g = (n as f64).sqrt().ceil() as u32;
    (0..n).map(|i| (((i % g) as f64 + 0.5) / g as f64, ((i / g) as f64 + 0.5) / g as f64)).collect()
}

/// Colour and normal of each kept hit, both of the centre ray's hit; on a textured material the
/// colour is the mean over the sub-pixel rays met with the hit's triangle (clamped to it: no
/// colour of another surface, or of another island of a texture atlas, mixes in). With renders
/// from the centre (`views`), a pixel's `k`-th hit takes render `k`'s colour, but on the far side
/// of a step in render `k` ([`render_edges`]) the mean render colour of its neighbours on its own
/// surface away from the step.
#[allow(clippy::too_many_arguments)]
fn shade(
    tr: &Tracer,
    grid: &HitGrid,
    m: &AnyMapping,
    nb: &Neighbours,
    label: &[u32],
    views: &[EnvMap],
    s: &BakeSettings,
) -> Vec<(Vec3, Vec3)> {
    let w = m.width();
    let offsets = sample_offsets(s.samples);
    let scene = tr.scene();
    let edge = render_edges(tr, grid, nb, views.len(), (pixel_angle(m) / s.freedom_radius) as f32);
    let render_colour = |p: usize, k: usize| views[k].over_pixel(m, (p % w) as f64, (p / w) as f64, &offsets);
    // The `k`-th hit of pixel `q` when it continues hit `h` (on the ray along `d`) off a step.
    let inner = |q: usize, k: usize, h: &Hit, d: Vec3| {
        let j = grid.start[q] + k;
        (j < grid.start[q + 1] && !edge[j] && continuous(tr, (grid.dir(q), &grid.hits[j]), (d, h), false))
            .then_some(q)
    };
    (0..m.width() * m.height())
        .into_par_iter()
        .flat_map_iter(|p| {
            let (x, y) = (p % w, p / w);
            let d = grid.dir(p);
            let (offsets, edge, inner, render_colour) = (&offsets, &edge, &inner, &render_colour);
            grid.range(p).map(move |h| {
                if label[h] == u32::MAX {
                    return (Vec3::ZERO, Vec3::ZERO);
                }
                let hit = &grid.hits[h];
                // A render shades what the ray meets; the inside of a solid it shades dark, while
                // the eyes that keep such a hit see its outside: that keeps its material.
                let k = h - grid.start[p];
                let inside = || visible::behind_own_front(tr, &grid.hits[grid.range(p)], k, d);
                if k < views.len() && !inside() {
                    let mut colour = render_colour(p, k);
                    if edge[h] {
                        let (sum, count) = nb
                            .all(p)
                            .filter_map(|q| inner(q, k, hit, d))
                            .fold((DVec3::ZERO, 0), |(sum, n), q| (sum + render_colour(q, k), n + 1));
                        if count > 0 {
                            colour = sum / count as f64;
                        }
                    }
                    return (colour.as_vec3(), shading_normal(tr, hit, d));
                }
                let tri = hit.tri as usize;
                let textured = scene.materials[scene.material[tri] as usize].textured();
                let colour = if textured && offsets.len() > 1 {
                    let sum = offsets.iter().fold(Vec3::ZERO, |acc, &(ox, oy)| {
                        let ds = m.pixel_to_dir(x as f64 + ox, y as f64 + oy).as_vec3();
                        let (u, v) = tr.barycentric_clamped(hit.tri, ds);
                        acc + load::colour_at(scene, tri, u, v)
                    });
                    sum / offsets.len() as f32
                } else {
                    load::colour_at(scene, tri, hit.u, hit.v)
                };
                (colour, shading_normal(tr, hit, d))
            })
        })
        .collect()
}

/// Whether each hit is the `k`-th of its pixel (`k < renders`) beside a pixel whose `k`-th hit
/// is on another surface nearer by more than `parallax` in inverse depth (an eye in the freedom
/// radius sees them part by more than a pixel): the far side of a step in render `k`, whose colour
/// mixes in the near surface's, which parallax pulls away. (The near side keeps its mix: it moves
/// with its surface, as the anti-aliased edge of a silhouette.)
fn render_edges(tr: &Tracer, grid: &HitGrid, nb: &Neighbours, renders: usize, parallax: f32) -> Vec<bool> {
    if renders == 0 {
        return vec![false; grid.hits.len()];
    }
    (0..nb.len())
        .into_par_iter()
        .flat_map_iter(|p| {
            let d = grid.dir(p);
            grid.range(p).enumerate().map(move |(k, h)| {
                k < renders
                    && nb.all(p).any(|q| {
                        let j = grid.start[q] + k;
                        j < grid.start[q + 1]
                            && 1.0 / grid.hits[j].t - 1.0 / grid.hits[h].t > parallax
                            && !continuous(tr, (grid.dir(q), &grid.hits[j]), (d, &grid.hits[h]), false)
                    })
            })
        })
        .collect()
}

/// The interpolated corner normals at a hit (the face normal without them), facing the centre.
fn shading_normal(tr: &Tracer, hit: &Hit, d: Vec3) -> Vec3 {
    let n = &tr.scene().normals[hit.tri as usize];
    let (u, v) = (hit.u, hit.v);
    let mut normal = (n[0] * (1.0 - u - v) + n[1] * u + n[2] * v).normalize_or_zero();
    if normal == Vec3::ZERO {
        normal = tr.normal(hit.tri);
    }
    if normal.dot(d) > 0.0 {
        -normal
    } else {
        normal
    }
}

/// The surface layers in painter's order (farthest mean depth first); the layer holding the
/// largest piece is the background.
#[allow(clippy::too_many_arguments)]
fn surface_layers(
    nb: &Neighbours,
    grid: &HitGrid,
    m: &AnyMapping,
    hit_layer: &[u32],
    count: usize,
    shaded: &[(Vec3, Vec3)],
    pieces: &pieces::Pieces,
    piece_layer: &[u32],
    s: &BakeSettings,
) -> Vec<BuiltLayer> {
    let n = m.width() * m.height();
    let background = (0..pieces.size.len()).max_by_key(|&i| pieces.size[i]).map(|i| piece_layer[i]);
    let mut depth_sum = vec![(0f64, 0usize); count];
    for (h, &l) in hit_layer.iter().enumerate() {
        if l != u32::MAX {
            depth_sum[l as usize].0 += grid.hits[h].t as f64;
            depth_sum[l as usize].1 += 1;
        }
    }
    let mut order: Vec<usize> = (0..count).collect();
    let mean = |l: usize| depth_sum[l].0 / depth_sum[l].1.max(1) as f64;
    order.sort_by(|&a, &b| mean(b).total_cmp(&mean(a)));
    let half = |v: f32| half::f16::from_f32(v).to_f32();
    let mut objects = 0;
    order
        .into_iter()
        .map(|l| {
            // Each pixel's hit on layer `l` (`u32::MAX`: none).
            let at: Vec<u32> = (0..n)
                .into_par_iter()
                .map(|p| grid.range(p).find(|&h| hit_layer[h] == l as u32).map_or(u32::MAX, |h| h as u32))
                .collect();
            let at = drop_breaks(nb, grid, at);
            let hit = |h: u32| (h != u32::MAX).then_some(h as usize);
            let mut img = LayerImage::new(m.width(), m.height());
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                let data = at.par_iter().map(|&h| hit(h).map_or(0.0, |h| half(shaded[h].0[c]))).collect();
                img.set_channel(name, SampleType::F16, data);
            }
            let z: Vec<f32> =
                at.par_iter().map(|&h| hit(h).map_or(OUTSIDE_DEPTH, |h| grid.hits[h].t)).collect();
            if s.normals {
                for (c, name) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
                    let data = at.par_iter().map(|&h| hit(h).map_or(0.0, |h| half(shaded[h].1[c]))).collect();
                    img.set_channel(name, SampleType::F16, data);
                }
            }
            let own = (0..n).into_par_iter().filter(|&p| at[p] as usize == grid.start[p]).count();
            let total = at.par_iter().filter(|&&h| h != u32::MAX).count();
            let depth_range = z
                .par_iter()
                .filter(|&&d| d > 0.0)
                .fold(
                    || None,
                    |r: Option<(f32, f32)>, &d| Some(r.map_or((d, d), |(lo, hi)| (lo.min(d), hi.max(d)))),
                )
                .reduce(
                    || None,
                    |a, b| match (a, b) {
                        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
                        (a, b) => a.or(b),
                    },
                );
            img.set_channel("Z", SampleType::F32, z);
            let (name, role) = if Some(l as u32) == background {
                ("background".to_string(), Role::Background)
            } else {
                objects += 1;
                (format!("objects-{objects}"), Role::Object)
            };
            BuiltLayer {
                name,
                role,
                order: 0,
                image: img,
                own_pixels: own,
                filled_pixels: total - own,
                depth_range,
            }
        })
        .collect()
}

/// A layer's hits (`at`, per pixel) without the pairs `validate` would see as a jump: a surface
/// continued in 3D across a pixel step of more than [`continuity::LAYER_JUMP`] whose plane the
/// pixels beside no longer show (a grazing plane where the layer is sparse). The hidden hit of a
/// pair leaves (the farther when both are hidden); a few passes, as leaving exposes new pairs.
fn drop_breaks(nb: &Neighbours, grid: &HitGrid, mut at: Vec<u32>) -> Vec<u32> {
    for _ in 0..4 {
        let drop: Vec<usize> = {
            let depth = |p: usize| (at[p] != u32::MAX).then(|| grid.hits[at[p] as usize].t as f64);
            let first = |p: usize| at[p] as usize == grid.start[p];
            let pairs: Vec<(usize, usize)> = (0..nb.height())
                .into_par_iter()
                .flat_map_iter(|y| {
                    let mut out = Vec::new();
                    continuity::row_breaks(nb, depth, continuity::LAYER_JUMP, y, |p, q| out.push((p, q)));
                    out
                })
                .collect();
            pairs
                .into_iter()
                .filter_map(|(p, q)| match (first(p), first(q)) {
                    (true, true) => None,
                    (true, false) => Some(q),
                    (false, true) => Some(p),
                    (false, false) => Some(if depth(p) >= depth(q) { p } else { q }),
                })
                .collect()
        };
        if drop.is_empty() {
            break;
        }
        for p in drop {
            at[p] = u32::MAX;
        }
    }
    at
}

/// The infinity layer: the sky's colour (averaged over the sub-pixel rays) where it is kept; the
/// render from the centre's where the centre sees open sky (`seen`: `Some(false)`), or any sky it
/// sees (`Some`) when there is no environment map.
fn sky_layer(
    m: &AnyMapping,
    sky: &[bool],
    map: Option<&EnvMap>,
    view: Option<&EnvMap>,
    seen: &(dyn Fn(usize) -> Option<bool> + Sync),
    s: &BakeSettings,
) -> BuiltLayer {
    let w = m.width();
    let offsets = sample_offsets(s.samples);
    let half = |v: f32| half::f16::from_f32(v).to_f32();
    let colour: Vec<[f32; 3]> = (0..sky.len())
        .into_par_iter()
        .map(|p| {
            if !sky[p] {
                return [0.0; 3];
            }
            let (x, y) = ((p % w) as f64, (p / w) as f64);
            // The render is what the truth looks like where the centre sees open sky; at a
            // silhouette it mixes the object's edge in, while the infinity layer lies behind the
            // object: there the environment map's sky alone is right.
            let map = match (map, view) {
                (None, Some(view)) if seen(p).is_some() => view,
                (Some(_), Some(view)) if seen(p) == Some(false) => view,
                (Some(map), _) => map,
                _ => return s.sky_colour.map(half),
            };
            map.over_pixel(m, x, y, &offsets).as_vec3().to_array().map(half)
        })
        .collect();
    let mut img = LayerImage::new(m.width(), m.height());
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        img.set_channel(name, SampleType::F16, colour.iter().map(|v| v[c]).collect());
    }
    img.set_channel(
        "Z",
        SampleType::F32,
        sky.iter().map(|&k| if k { f32::INFINITY } else { OUTSIDE_DEPTH }).collect(),
    );
    let own = sky.iter().filter(|&&k| k).count();
    BuiltLayer {
        name: "infinity".into(),
        role: Role::Infinity,
        order: 0,
        image: img,
        own_pixels: own,
        filled_pixels: 0,
        depth_range: None,
    }
}
