//! Adaptive quadtree meshes of layers (thesis 7.4): build, stitch, measure, encode and export.
//!
//! Pipeline for one layer: sample one vertex lattice per cube face (or the whole equirect canvas,
//! [`grid`]), build the summed-area tables and the discrete quadtree with the subdivision function `S`
//! (`sat`, [`normals`], `subdivide`, [`quadtree`]), balance it 2:1 ([`balance`]), triangulate the
//! leaves without cracks (`triangulate`), close the gaps between lattices (`stitch`). [`accuracy`]
//! measures a mesh against the layer by casting every pixel's ray; [`encode`] stores the quadtrees as a
//! bit string; [`export`] writes PLY, OBJ and glTF binary, one layer or a whole scene, with the
//! infinitely far samples (the sky) on a dome ([`sky_at`]).

pub mod accuracy;
pub mod balance;
pub mod encode;
pub mod export;
pub(crate) mod greedy;
pub mod grid;
pub mod normals;
pub mod quadtree;
pub(crate) mod sat;
pub mod scene;
pub mod simplify;
pub(crate) mod stitch;
pub mod stored;
pub(crate) mod subdivide;
pub(crate) mod triangulate;

pub use greedy::GreedyStats;

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::layer::{classify, LayerImage, Sample};
use crate::mapping::{AnyMapping, CubeFace, Mapping};
use grid::{Grid, Rays};
use quadtree::Tree;

/// Errors of meshing, encoding and export. Codes are stable.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The layer has no depth channel `Z` to mesh.
    #[error("the layer has no depth channel Z")]
    NoDepth,
    /// The layer's size (pixels) differs from the mapping's canvas size.
    #[error("the layer is {got_w}x{got_h} but the mapping canvas is {want_w}x{want_h}")]
    CanvasMismatch {
        /// Layer width, pixels.
        got_w: usize,
        /// Layer height, pixels.
        got_h: usize,
        /// Canvas width of the mapping, pixels.
        want_w: usize,
        /// Canvas height of the mapping, pixels.
        want_h: usize,
    },
    /// A mesh parameter or the sky radius is non-finite or out of range; the message says which.
    #[error("invalid mesh parameter: {0}")]
    Params(String),
    /// A `.pomcmesh` file has a bad magic, version or payload, was made for another canvas or
    /// layer, or zstd compression failed.
    #[error("invalid mesh encoding: {0}")]
    Encoding(String),
    /// Writing PLY, OBJ or glTF failed: no triangles, unknown extension, too large, or PNG/JSON encoding.
    #[error("export failed: {0}")]
    Export(String),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: std::path::PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
}

crate::codes::error_codes! {
    MeshError:
        NoDepth MESH_NO_DEPTH,
        CanvasMismatch MESH_CANVAS_MISMATCH,
        Params MESH_PARAMS_INVALID,
        Encoding MESH_ENCODING_INVALID,
        Export MESH_EXPORT_FAILED,
        Io IO_ERROR
}

/// What drives the subdivision. Several tests may be combined; `uniform` overrides the others.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshOptions {
    /// Maximum relative distance, along each pixel's ray, between the mesh and the sample.
    pub max_error: Option<f64>,
    /// Thesis feature test: split where adjacent normals differ by more than this angle (degrees).
    pub feature_angle_deg: Option<f64>,
    /// Thesis residual test: split when the mean sub-feature variation of a node reaches this.
    pub residual_threshold: f64,
    /// Weighting of estimated normals (layers without `N.*` channels).
    pub normal_weighting: normals::NormalWeighting,
    /// Cap on the angle between the rays of a node's opposite corners (texture distortion, 7.4.3).
    pub max_angle_deg: Option<f64>,
    /// Uniform baseline: leaves of at most `STEP` cells a side (1 = the full 4-8 mesh).
    pub uniform: Option<u32>,
    /// Second stage: error-bounded edge collapses of the quadtree mesh ([`simplify`]). The trees
    /// (and so the encoding) are those of the quadtree mesh either way.
    pub simplify: Option<simplify::SimplifyOptions>,
}

/// `pomc mesh --max-error` default: 0.5 % of the distance along the ray.
pub const DEFAULT_MAX_ERROR: f64 = 0.005;
/// `pomc mesh --residual` default (thesis residual test).
pub const DEFAULT_RESIDUAL: f64 = 0.05;
/// `pomc mesh --max-angle` default, degrees.
pub const DEFAULT_MAX_ANGLE_DEG: f64 = 20.0;

/// What `pomc mesh` does by default: the quadtree mesh, then error-bounded simplification with
/// greedy re-meshing of clean cube faces, both within [`DEFAULT_MAX_ERROR`].
impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            simplify: Some(simplify::SimplifyOptions {
                max_error: DEFAULT_MAX_ERROR,
                max_angle_deg: Some(DEFAULT_MAX_ANGLE_DEG),
                greedy: true,
            }),
            ..MeshOptions::quadtree()
        }
    }
}

impl MeshOptions {
    /// The adaptive quadtree mesh alone (thesis 7.4), no simplification: what `render --method
    /// mesh` triangulates and `mesh --store` encodes.
    pub fn quadtree() -> Self {
        MeshOptions {
            max_error: Some(DEFAULT_MAX_ERROR),
            feature_angle_deg: None,
            residual_threshold: DEFAULT_RESIDUAL,
            normal_weighting: normals::NormalWeighting::Area,
            max_angle_deg: Some(DEFAULT_MAX_ANGLE_DEG),
            uniform: None,
            simplify: None,
        }
    }
}

impl MeshOptions {
    /// Reject non-finite or out-of-range values.
    pub fn check(&self) -> Result<(), MeshError> {
        let bad = |what: &str| Err(MeshError::Params(what.to_string()));
        if self.max_error.is_some_and(|e| !(e.is_finite() && e > 0.0)) {
            return bad("max-error must be a positive number");
        }
        if self.feature_angle_deg.is_some_and(|a| !(a.is_finite() && a > 0.0 && a < 180.0)) {
            return bad("feature angle must be in (0, 180) degrees");
        }
        if self.max_angle_deg.is_some_and(|a| !(a.is_finite() && a > 0.0 && a <= 180.0)) {
            return bad("max-angle must be in (0, 180] degrees");
        }
        if !(self.residual_threshold.is_finite() && self.residual_threshold > 0.0) {
            return bad("residual threshold must be positive");
        }
        if self.uniform == Some(0) {
            return bad("uniform step must be at least 1");
        }
        if let Some(s) = &self.simplify {
            if !(s.max_error.is_finite() && s.max_error > 0.0) {
                return bad("simplification max-error must be a positive number");
            }
            if s.max_angle_deg.is_some_and(|a| !(a.is_finite() && a > 0.0 && a <= 180.0)) {
                return bad("simplification max-angle must be in (0, 180] degrees");
            }
        }
        Ok(())
    }
}

/// Default sky-dome radius: this many times the farthest finite depth of the panorama (spec §8.9).
pub const SKY_RADIUS_FACTOR: f64 = 10.0;
/// Default sky-dome radius (m) of a panorama without any finite depth.
pub const SKY_RADIUS_FALLBACK: f64 = 1000.0;

/// The state (spec §4.3) of every pixel of `image` (none without a depth channel).
fn samples(image: &LayerImage) -> impl Iterator<Item = Sample> + '_ {
    let (z, a) = (image.depth().unwrap_or(&[]), image.coverage());
    (0..z.len()).map(move |i| classify(z[i], a.map(|a| a[i])))
}

/// The default sky-dome radius of a panorama of these layers: [`SKY_RADIUS_FACTOR`] times their
/// farthest finite depth, or [`SKY_RADIUS_FALLBACK`] when they have none.
pub fn default_sky_radius<'a>(images: impl IntoIterator<Item = &'a LayerImage>) -> f64 {
    let far = images
        .into_iter()
        .flat_map(samples)
        .filter_map(|s| match s {
            Sample::Surface(d) => Some(d as f64),
            _ => None,
        })
        .fold(0.0, f64::max);
    if far > 0.0 {
        // Finite as f32 (positions are stored as f32) for any finite depth.
        (SKY_RADIUS_FACTOR * far).min(f32::MAX as f64 / 16.0)
    } else {
        SKY_RADIUS_FALLBACK
    }
}

/// Relative error the sky dome is meshed to. The dome stands for directions, not a surface: its
/// radius error moves nothing a camera inside the freedom radius sees, so only the angle cap (texture
/// distortion) bounds its triangles; the layer tolerance would spend thousands of triangles on a sphere.
pub const SKY_MAX_ERROR: f64 = 0.05;

/// `p` for the sky dome: [`SKY_MAX_ERROR`] (or `p`'s own, if looser) in both stages, the rest as given.
pub fn sky_params(p: &MeshOptions) -> MeshOptions {
    let loose = |e: f64| e.max(SKY_MAX_ERROR);
    let mut q = p.clone();
    q.max_error = q.max_error.map(loose);
    if let Some(s) = &mut q.simplify {
        s.max_error = loose(s.max_error);
    }
    q
}

/// Whether `image` has infinitely far samples (`Z = +∞` inside its domain, spec §4.3): the sky.
pub fn has_sky(image: &LayerImage) -> bool {
    samples(image).any(|s| s == Sample::Infinite)
}

/// The sky dome's layer (spec §8.9): `image` with its infinitely far samples (`Z = +∞`) at distance
/// `radius`, so that [`mesh_layer`] meshes them as a sphere; `None` when the layer has none (whatever
/// `radius`).
pub fn sky_at(image: &LayerImage, radius: f64) -> Result<Option<LayerImage>, MeshError> {
    let infinite: Vec<bool> = samples(image).map(|s| s == Sample::Infinite).collect();
    if !infinite.contains(&true) {
        return Ok(None);
    }
    if !(radius > 0.0 && (radius as f32).is_finite()) {
        return Err(MeshError::Params("sky radius must be a positive finite number".into()));
    }
    let mut out = image.clone();
    if let Some(z) = out.channel_mut("Z") {
        for (d, _) in z.data.iter_mut().zip(&infinite).filter(|(_, &inf)| inf) {
            *d = radius as f32;
        }
    }
    Ok(Some(out))
}

/// Mesh `image` as a scene shows it (`pomc mesh` without `--layer`, spec §8.9): a layer with
/// infinitely far samples as the sky dome of `sky_radius` ([`sky_at`], meshed with [`sky_params`]),
/// any other as itself. Returns the mesh and, for the sky, the dome's image.
pub fn mesh_scene_layer(
    image: &LayerImage,
    mapping: &AnyMapping,
    params: &MeshOptions,
    sky_radius: f64,
) -> Result<(Meshed, Option<LayerImage>), MeshError> {
    let dome = sky_at(image, sky_radius)?;
    let meshed = match &dome {
        Some(d) => mesh_layer(d, mapping, &sky_params(params))?,
        None => mesh_layer(image, mapping, params)?,
    };
    Ok((meshed, dome))
}

/// A vertex's origin: a canvas pixel (its centre, at its depth) or, on the equirect, a pole.
pub fn is_pole(id: u32, width: usize, height: usize) -> bool {
    id as usize >= width * height
}

/// A triangle mesh of one layer, in the panorama's local frame.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerMesh {
    /// Width of the layer's canvas, pixels (to decode [`LayerMesh::sources`]).
    pub width: usize,
    /// Height of the layer's canvas, pixels.
    pub height: usize,
    /// Canvas pixel index of each vertex (`≥ W·H` for the equirect poles, see `stitch::pole_ids`).
    pub sources: Vec<u32>,
    /// Panorama-local positions.
    pub positions: Vec<DVec3>,
    /// Counter-clockwise as seen from the panorama centre.
    pub triangles: Vec<[u32; 3]>,
}

/// The stages of [`mesh_layer`], in the order they run: [`StageTimes::named`] times them.
pub const STAGES: &[&str] = &["sample", "greedy", "quadtree", "triangulate", "assemble", "simplify"];

impl StageTimes {
    /// Each of [`STAGES`] with its time, ms.
    pub fn named(&self) -> [(&'static str, f64); 6] {
        let t = [
            self.sample_ms,
            self.greedy_ms,
            self.quadtree_ms,
            self.triangulate_ms,
            self.assemble_ms,
            self.simplify_ms,
        ];
        std::array::from_fn(|i| (STAGES[i], t[i]))
    }

    /// The time of all stages, ms.
    pub fn total_ms(&self) -> f64 {
        self.named().iter().map(|s| s.1).sum()
    }
}

/// Wall-clock times of the stages, in milliseconds.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct StageTimes {
    /// Checking the layer and sampling the vertex lattices ([`lattices`]).
    pub sample_ms: f64,
    /// Building and 2:1-balancing the quadtrees.
    pub quadtree_ms: f64,
    /// Triangulating the leaves and stitching the lattices together.
    pub triangulate_ms: f64,
    /// Compacting vertices, computing positions and orienting the triangles.
    pub assemble_ms: f64,
    /// Error-bounded edge collapses (0 when [`MeshOptions::simplify`] is `None`).
    pub simplify_ms: f64,
    /// Greedy insertion of the clean cube faces (when [`simplify::SimplifyOptions::greedy`]).
    pub greedy_ms: f64,
}

/// A mesh with the quadtrees it came from.
#[derive(Clone, Debug)]
pub struct Meshed {
    /// The quadtree mesh, or its simplification when [`MeshOptions::simplify`] is set.
    pub mesh: LayerMesh,
    /// Triangles before the collapse stage: the quadtree mesh, with the greedy faces' meshes when
    /// some lattices were meshed by greedy insertion.
    pub quadtree_triangles: usize,
    /// Counters of the simplification stage, when it ran.
    pub simplify: Option<simplify::SimplifyStats>,
    /// One tree per lattice (`None` for a lattice without cells, or meshed by greedy insertion).
    pub trees: Vec<Option<Tree>>,
    /// Counters of each lattice meshed by greedy insertion (`None`: meshed by the quadtree).
    pub greedy: Vec<Option<greedy::GreedyStats>>,
    /// Wall-clock time of each stage.
    pub times: StageTimes,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The vertex lattices of a canvas: six faces, or the single equirect canvas.
pub fn lattices(image: &LayerImage, mapping: &AnyMapping) -> Result<Vec<Grid>, MeshError> {
    let (w, h) = (mapping.width(), mapping.height());
    if image.width != w || image.height != h {
        return Err(MeshError::CanvasMismatch {
            got_w: image.width,
            got_h: image.height,
            want_w: w,
            want_h: h,
        });
    }
    if image.depth().is_none() {
        return Err(MeshError::NoDepth);
    }
    Ok(match mapping {
        AnyMapping::Equirect(m) => vec![Grid::new(image, 0, 0, w, h, Rays::equirect(m))],
        AnyMapping::Cube(c) => {
            let n = c.face_size();
            CubeFace::ALL
                .par_iter()
                .map(|f| {
                    let (s0, t0) = f.grid();
                    Grid::new(image, s0 * n, t0 * n, n, n, Rays::face(*f, n))
                })
                .collect()
        }
    })
}

/// Mesh one layer.
pub fn mesh_layer(
    image: &LayerImage,
    mapping: &AnyMapping,
    params: &MeshOptions,
) -> Result<Meshed, MeshError> {
    params.check()?;
    let t = Instant::now();
    let grids = lattices(image, mapping)?;
    let sample_ms = ms(t);
    // Clean cube faces go to greedy insertion when the simplified mesh is asked for.
    let greedy_params = params.simplify.as_ref().filter(|s| s.greedy && params.uniform.is_none());
    let t = Instant::now();
    let greedy = greedy_faces(&grids, greedy_params);
    let greedy_ms = if greedy_params.is_some() { ms(t) } else { 0.0 };
    let t = Instant::now();
    let skip: Vec<bool> = greedy.iter().map(Option::is_some).collect();
    let trees = build_trees(&grids, image, params, &skip);
    let quadtree_ms = ms(t);
    let t = Instant::now();
    // Greedy faces' exact errors go to the collapses, their counters to the report.
    let (done, greedy_stats, face_parts) = unzip_greedy(greedy);
    let parts: Vec<(Vec<[u32; 3]>, Vec<bool>)> = grids
        .par_iter()
        .zip(trees.par_iter())
        .zip(face_parts.into_par_iter())
        .map(|((g, tree), face)| face.unwrap_or_else(|| tree_part(g, tree.as_ref())))
        .collect();
    let (mesh, _, assemble_ms) = mesh_from_parts(&grids, parts, mapping);
    let triangulate_ms = ms(t) - assemble_ms;
    let quadtree_triangles = mesh.triangles.len();
    let t = Instant::now();
    let (mesh, stats) = match &params.simplify {
        Some(sp) => {
            let (m, s) = simplify::simplify(&mesh, &grids, mapping, sp, &done);
            (m, Some(s))
        }
        None => (mesh, None),
    };
    let simplify_ms = if stats.is_some() { ms(t) } else { 0.0 };
    Ok(Meshed {
        mesh,
        quadtree_triangles,
        simplify: stats,
        trees,
        greedy: greedy_stats,
        times: StageTimes { sample_ms, quadtree_ms, triangulate_ms, assemble_ms, simplify_ms, greedy_ms },
    })
}

/// Each clean face meshed by greedy insertion under `params` (`None`: not asked for, not clean,
/// or left with triangles over the angle cap, which the quadtree keeps).
fn greedy_faces(grids: &[Grid], params: Option<&simplify::SimplifyOptions>) -> Vec<Option<greedy::FaceMesh>> {
    grids
        .par_iter()
        .map(|g| {
            let sp = params?;
            greedy::is_clean(g)
                .then(|| greedy::mesh_face(g, sp.max_error, sp.max_angle_deg))
                .filter(|f| f.stats.over_cap == 0)
        })
        .collect()
}

/// Greedy faces split into their exact errors, their counters and their triangles with used
/// flags (moved, not copied).
#[allow(clippy::type_complexity)]
fn unzip_greedy(
    greedy: Vec<Option<greedy::FaceMesh>>,
) -> (Vec<Option<Vec<f64>>>, Vec<Option<greedy::GreedyStats>>, Vec<Option<(Vec<[u32; 3]>, Vec<bool>)>>) {
    let mut done = Vec::with_capacity(greedy.len());
    let mut stats = Vec::with_capacity(greedy.len());
    let mut parts = Vec::with_capacity(greedy.len());
    for f in greedy {
        let (d, s, p) = match f {
            Some(f) => (Some(f.errors), Some(f.stats), Some((f.triangles, f.used))),
            None => (None, None, None),
        };
        done.push(d);
        stats.push(s);
        parts.push(p);
    }
    (done, stats, parts)
}

/// The balanced quadtree of every lattice not flagged in `skip` (`None`: no cells, or skipped).
fn build_trees(grids: &[Grid], image: &LayerImage, params: &MeshOptions, skip: &[bool]) -> Vec<Option<Tree>> {
    grids
        .par_iter()
        .enumerate()
        .map(|(k, g)| {
            if skip.get(k).copied().unwrap_or(false) {
                return None;
            }
            let c = subdivide::Criterion::new(g, image, params);
            let mut tree = Tree::build(g.w, g.h, &c)?;
            balance::balance(&mut tree, &c);
            Some(tree)
        })
        .collect()
}

/// The quadtrees of a layer alone (what `.pomcmesh` stores, [`encode`]), e.g. when [`mesh_layer`]
/// meshed some lattices by greedy insertion and did not build theirs.
pub fn quadtrees(
    image: &LayerImage,
    mapping: &AnyMapping,
    params: &MeshOptions,
) -> Result<Vec<Option<Tree>>, MeshError> {
    params.check()?;
    let grids = lattices(image, mapping)?;
    Ok(build_trees(&grids, image, params, &[]))
}

/// The quadtree's triangles and used vertices of one lattice.
fn tree_part(g: &Grid, tree: Option<&Tree>) -> (Vec<[u32; 3]>, Vec<bool>) {
    match tree {
        Some(tree) => {
            let used = triangulate::used_vertices(tree, g);
            (triangulate::triangulate(tree, g, &used), used)
        }
        None => (Vec::new(), vec![false; g.w * g.h]),
    }
}

/// Stitch the lattices' triangles and assemble the mesh; returns it with the stitching and assembly
/// times (ms).
fn mesh_from_parts(
    grids: &[Grid],
    parts: Vec<(Vec<[u32; 3]>, Vec<bool>)>,
    mapping: &AnyMapping,
) -> (LayerMesh, f64, f64) {
    let t = Instant::now();
    let mut tris: Vec<[u32; 3]> = parts.iter().flat_map(|p| p.0.iter().copied()).collect();
    let used: Vec<Vec<bool>> = parts.into_iter().map(|p| p.1).collect();
    let mut poles = [f64::NAN; 2];
    match mapping {
        AnyMapping::Cube(_) => stitch::stitch_cube(grids, &used, &mut tris),
        AnyMapping::Equirect(_) => poles = stitch::stitch_equirect(&grids[0], &used[0], &mut tris),
    }
    let stitch_ms = ms(t);
    let t = Instant::now();
    let mesh = assemble(grids, mapping, &tris, poles);
    (mesh, stitch_ms, ms(t))
}

/// Triangulate, stitch and assemble the quadtree mesh; used by the decoder.
fn mesh_from_trees(grids: &[Grid], trees: &[Option<Tree>], mapping: &AnyMapping) -> LayerMesh {
    let parts: Vec<(Vec<[u32; 3]>, Vec<bool>)> =
        grids.par_iter().zip(trees.par_iter()).map(|(g, tree)| tree_part(g, tree.as_ref())).collect();
    mesh_from_parts(grids, parts, mapping).0
}

/// Compact canvas ids into vertices, compute positions, orient towards the centre.
fn assemble(grids: &[Grid], mapping: &AnyMapping, tris: &[[u32; 3]], poles: [f64; 2]) -> LayerMesh {
    let (w, h) = (mapping.width(), mapping.height());
    let mut sources: Vec<u32> = tris.iter().flatten().copied().collect();
    sources.par_sort_unstable();
    sources.dedup();
    let depth_of = |id: u32| -> f64 {
        let (x, y) = (id as usize % w, id as usize / w);
        let g = grids.iter().find(|g| x >= g.ox && x < g.ox + g.w && y >= g.oy && y < g.oy + g.h);
        g.map_or(f64::NAN, |g| g.depth_at(x - g.ox, y - g.oy))
    };
    let positions: Vec<DVec3> = sources
        .par_iter()
        .map(|&id| {
            if is_pole(id, w, h) {
                let p = (id as usize - w * h).min(1);
                DVec3::new(0.0, 0.0, if p == 0 { 1.0 } else { -1.0 }) * poles[p]
            } else {
                mapping.pixel_dir(id as usize % w, id as usize / w) * depth_of(id)
            }
        })
        .collect();
    let index = |id: u32| sources.binary_search(&id).map_or(0, |i| i as u32);
    let triangles: Vec<[u32; 3]> = tris
        .par_iter()
        .map(|t| {
            let v = t.map(index);
            let p = v.map(|i| positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            // Counter-clockwise seen from the centre: the normal points back at the viewer.
            if n.dot(p[0] + p[1] + p[2]) > 0.0 {
                [v[0], v[2], v[1]]
            } else {
                v
            }
        })
        .collect();
    LayerMesh { width: w, height: h, sources, positions, triangles }
}
