//! `pomc mesh` as one call: quadtree meshes of a panorama's layers, exported as one scene and
//! stored beside the manifest on request, with the report the command prints.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::mesh::accuracy::ErrorStats;
use crate::mesh::greedy::GreedyStats;
use crate::mesh::scene::{self, SceneMesh, SceneSettings};
use crate::mesh::simplify::SimplifyStats;
use crate::panorama::Panorama;

/// Everything `pomc mesh` takes besides the panorama.
#[derive(Clone, Debug, Default)]
pub struct MeshSettings {
    /// Which layers, how they are meshed, measured and stored.
    pub scene: SceneSettings,
    /// The scene's file: .ply, .obj (+ .mtl and textures) or .glb; `None`: mesh and measure only.
    pub output: Option<PathBuf>,
    /// Keep panorama-local coordinates (the manifest's LocalToWorld is applied otherwise).
    pub local: bool,
}

/// What [`mesh_files`] made of one layer (the `--json` schema of `pomc mesh --layer K`, and one
/// entry of [`MeshJobReport::layers`]).
#[derive(Clone, Debug, Serialize)]
pub struct LayerMeshReport {
    /// Index in the manifest.
    pub layer: usize,
    /// The layer's name.
    pub name: String,
    /// The layer's role.
    pub role: Option<&'static str>,
    /// The dome's radius when this layer is the sky.
    pub sky_radius: Option<f64>,
    /// Lattice size of the meshed layer, pixels.
    pub width: usize,
    /// Lattice height, pixels.
    pub height: usize,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Triangles of the quadtree mesh, when no face was meshed by greedy insertion.
    pub quadtree_triangles: Option<usize>,
    /// Triangles before the collapse stage.
    pub before_collapses_triangles: usize,
    /// Faces meshed by greedy insertion.
    pub greedy_faces: usize,
    /// Counters of each lattice meshed by greedy insertion.
    pub greedy: Vec<Option<GreedyStats>>,
    /// Counters of the simplification.
    pub simplify: Option<SimplifyStats>,
    /// Size of the quadtree encoding, bytes.
    pub encoded_bytes: Option<usize>,
    /// Encoded bytes per million quadtree triangles (thesis 7.4.4).
    pub encoded_bytes_per_million_triangles: Option<f64>,
    /// The mesh's 3D error against the layer.
    pub error: Option<ErrorStats>,
    /// Times of reading, each meshing stage, encoding, measuring (and with `--layer`, exporting), ms.
    pub times_ms: BTreeMap<&'static str, Option<f64>>,
    /// The scene file.
    pub output: Option<PathBuf>,
    /// Vertices written for this layer, when a scene file was written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exported_vertices: Option<usize>,
    /// The files written (with `--layer`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub files: Option<Vec<PathBuf>>,
}

/// Times of the whole scene, ms.
#[derive(Clone, Debug, Serialize)]
pub struct SceneTimes {
    /// Reading the layers.
    pub read: f64,
    /// Meshing.
    pub mesh: f64,
    /// Encoding.
    pub encode: f64,
    /// Measuring the error.
    pub metric: f64,
    /// Writing the scene file.
    pub export: f64,
}

/// What [`mesh_files`] made of every layer: the `--json` schema of `pomc mesh`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneMeshReport {
    /// One per layer, in painter's order.
    pub layers: Vec<LayerMeshReport>,
    /// Triangles of all layers.
    pub triangles: usize,
    /// Vertices of all layers.
    pub vertices: usize,
    /// Vertices written, when a scene file was written.
    pub exported_vertices: Option<usize>,
    /// Layers without triangles, left out of the scene file.
    pub skipped: Vec<String>,
    /// The sky dome's radius, when a layer is the sky.
    pub sky_radius: Option<f64>,
    /// Times, ms.
    pub times_ms: SceneTimes,
    /// The scene file.
    pub output: Option<PathBuf>,
    /// The files written, the scene file first.
    pub files: Vec<PathBuf>,
}

/// The report of [`mesh_files`]: of one layer (with [`SceneSettings::only`]) or of the scene.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum MeshJobReport {
    /// One layer (`--layer K`).
    Layer(Box<LayerMeshReport>),
    /// Every layer as one scene.
    Scene(SceneMeshReport),
}

/// Mesh the panorama at `pano` as `pomc mesh` does: read and mesh the layers, write the scene file
/// and store the encodings as `s` asks; `progress` is called with `meshing` and `exporting`.
///
/// ```
/// use pomc::jobs::{mesh_files, MeshJobReport, MeshSettings};
/// let report = mesh_files("fixtures/data/room-equirect".as_ref(), &MeshSettings::default(), &|_| {})?;
/// let MeshJobReport::Scene(scene) = report else { unreachable!() };
/// assert!(scene.triangles > 100 && scene.files.is_empty());
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn mesh_files(pano: &Path, s: &MeshSettings, progress: &dyn Fn(&str)) -> crate::Result<MeshJobReport> {
    progress("meshing");
    let pano = Panorama::open(pano)?;
    let scene = scene::mesh_panorama(&pano, &s.scene)?;
    let layers = &scene.layers;
    let (mut export_ms, mut exported) = (0.0, crate::mesh::export::Exported::default());
    if let Some(path) = &s.output {
        progress("exporting");
        let t = Instant::now();
        let transform = (!s.local).then(|| pano.manifest.local_to_world());
        exported = scene::export_scene(path, layers, transform)?;
        export_ms = t.elapsed().as_secs_f64() * 1e3;
    }
    if s.scene.store {
        scene::store(&pano, layers)?;
    }
    let sky = Some(scene.sky_radius).filter(|_| scene.has_sky());
    let mut reports: Vec<LayerMeshReport> = layers.iter().map(|l| layer_report(l, sky, &s.output)).collect();
    for (r, v) in reports.iter_mut().zip(&exported.vertices) {
        r.exported_vertices = Some(*v);
    }
    if s.scene.only.is_some() {
        let mut r = reports.swap_remove(0);
        r.times_ms.insert("export", Some(export_ms));
        r.files = Some(exported.files);
        return Ok(MeshJobReport::Layer(Box::new(r)));
    }
    let sum = |f: &dyn Fn(&SceneMesh) -> f64| layers.iter().map(f).sum::<f64>();
    let times_ms = SceneTimes {
        read: sum(&|l| l.read_ms),
        mesh: sum(&|l| l.meshed.times.total_ms()),
        encode: sum(&|l| l.encode_ms),
        metric: sum(&|l| l.metric_ms.unwrap_or(0.0)),
        export: export_ms,
    };
    Ok(MeshJobReport::Scene(SceneMeshReport {
        triangles: reports.iter().map(|r| r.triangles).sum(),
        vertices: reports.iter().map(|r| r.vertices).sum(),
        exported_vertices: s.output.as_ref().map(|_| exported.vertices.iter().sum()),
        skipped: reports.iter().filter(|r| r.triangles == 0).map(|r| r.name.clone()).collect(),
        layers: reports,
        sky_radius: sky,
        times_ms,
        output: s.output.clone(),
        files: exported.files,
    }))
}

fn layer_report(l: &SceneMesh, sky: Option<f64>, output: &Option<PathBuf>) -> LayerMeshReport {
    let meshed = &l.meshed;
    let m = &meshed.mesh;
    let encoded = l.encoded.as_ref().map(Vec::len);
    // The encoding stores the quadtree, so its density is per quadtree triangle (thesis 7.4.4); that
    // count is known when the whole layer was meshed by the quadtree.
    let greedy_faces = meshed.greedy.iter().filter(|g| g.is_some()).count();
    let qt = meshed.quadtree_triangles;
    let per_million = encoded.filter(|_| qt > 0 && greedy_faces == 0).map(|e| e as f64 * 1e6 / qt as f64);
    let mut times_ms = BTreeMap::from([
        ("read", Some(l.read_ms)),
        ("encode", Some(l.encode_ms)),
        ("metric", l.error.as_ref().and(l.metric_ms)),
    ]);
    for (stage, ms) in meshed.times.named() {
        times_ms.insert(stage, Some(ms));
    }
    LayerMeshReport {
        layer: l.index,
        name: l.name.clone(),
        role: l.role,
        sky_radius: sky.filter(|_| l.sky_radius.is_some()),
        width: m.width,
        height: m.height,
        triangles: m.triangles.len(),
        vertices: m.positions.len(),
        quadtree_triangles: (greedy_faces == 0).then_some(qt),
        before_collapses_triangles: qt,
        greedy_faces,
        greedy: meshed.greedy.clone(),
        simplify: meshed.simplify.clone(),
        encoded_bytes: encoded,
        encoded_bytes_per_million_triangles: per_million,
        error: l.error.clone().filter(|_| l.metric_ms.is_some()),
        times_ms,
        output: output.clone(),
        exported_vertices: None,
        files: None,
    }
}

impl LayerMeshReport {
    /// The command's human lines for this layer.
    pub fn summary(&self) -> Vec<String> {
        let sky = self.sky_radius.map_or(String::new(), |r| format!(", sky dome at {r:.2} m"));
        let how = match &self.simplify {
            Some(s) if self.greedy_faces > 0 => format!(
                " (greedy insertion on {} of {} faces; {} triangles before {} collapses)",
                self.greedy_faces,
                self.greedy.len(),
                self.before_collapses_triangles,
                s.collapses
            ),
            Some(s) => format!(
                " (simplified from {} quadtree triangles, {} collapses)",
                self.before_collapses_triangles, s.collapses
            ),
            None => String::new(),
        };
        let mut lines = vec![format!(
            "layer {} {} ({}x{}{sky}): {} triangles, {} vertices{how}",
            self.layer, self.name, self.width, self.height, self.triangles, self.vertices
        )];
        lines.push(match (self.encoded_bytes, self.encoded_bytes_per_million_triangles) {
            (None, _) if self.sky_radius.is_some() => {
                "encoded: not computed (the sky dome is no part of the layer's mesh, spec §8.9)".into()
            }
            (Some(e), Some(p)) => format!("encoded: {e} bytes ({p:.0} bytes per million quadtree triangles)"),
            (Some(e), None) => format!("encoded: {e} bytes (quadtree)"),
            (None, _) => "encoded: not computed (greedy faces build no quadtree; --store encodes it)".into(),
        });
        if let Some(s) = &self.error {
            lines.push(format!(
                "error over {} pixels ({} unhit): relative max {:.3e} p99 {:.3e} rms {:.3e}; absolute max {:.3e} m p99 {:.3e} m rms {:.3e} m",
                s.pixels, s.unhit, s.max_rel, s.p99_rel, s.rms_rel, s.max_abs, s.p99_abs, s.rms_abs
            ));
        }
        let time = |k: &str| self.times_ms.get(k).copied().flatten();
        let stages: Vec<String> = crate::mesh::STAGES
            .iter()
            .map(|stage| format!("{stage} {:.0}", time(stage).unwrap_or(0.0)))
            .collect();
        lines.push(format!(
            "times (ms): read {:.0}, {}, encode {:.0}, metric {}",
            time("read").unwrap_or(0.0),
            stages.join(", "),
            time("encode").unwrap_or(0.0),
            time("metric").map_or("-".to_string(), |ms| format!("{ms:.0}"))
        ));
        lines
    }
}

impl MeshJobReport {
    /// The command's human lines.
    pub fn summary(&self) -> Vec<String> {
        match self {
            MeshJobReport::Layer(l) => {
                let mut lines = l.summary();
                if l.output.is_some() && l.triangles == 0 {
                    lines.push(format!("note: left out of the scene (no triangles): {}", l.name));
                }
                let export = l.times_ms.get("export").copied().flatten().unwrap_or(0.0);
                lines.push(format!("times (ms): export {export:.0}"));
                lines
            }
            MeshJobReport::Scene(s) => {
                let mut lines: Vec<String> = s.layers.iter().flat_map(LayerMeshReport::summary).collect();
                if s.output.is_some() && !s.skipped.is_empty() {
                    lines.push(format!(
                        "note: left out of the scene (no triangles): {}",
                        s.skipped.join(", ")
                    ));
                }
                let t = &s.times_ms;
                lines.push(format!(
                    "scene: {} layers, {} triangles, {} vertices{}; times (ms): read {:.0}, mesh {:.0}, metric {:.0}, export {:.0}",
                    s.layers.len(),
                    s.triangles,
                    s.vertices,
                    s.sky_radius.map_or(String::new(), |r| format!(", sky dome radius {r:.2} m")),
                    t.read,
                    t.mesh,
                    t.metric,
                    t.export
                ));
                lines
            }
        }
    }
}
