//! `pomc render` as one call: views of a panorama from one camera or a camera path, written to
//! files, with the report the command prints.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use serde::Serialize;

use super::{CameraSettings, RenderMethod, Renderer, View, ViewCamera};
use crate::panorama::Panorama;
use crate::render::rasterize::MeshSource;
use crate::render::{frame, RenderError};

/// Everything `pomc render` takes besides the panorama.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Colour output: .exr (linear float) or .png (sRGB 8-bit). With [`RenderSettings::shots`],
    /// its run of `#` is replaced by the zero-padded frame number (as for `depth` and `mask`).
    pub output: PathBuf,
    /// Also write the distance from the eye (EXR).
    pub depth: Option<PathBuf>,
    /// Also write the coverage mask (PNG).
    pub mask: Option<PathBuf>,
    /// The camera; its eye and look-at are the single view's unless `shots` is given.
    pub camera: CameraSettings,
    /// How views are drawn.
    pub method: RenderMethod,
    /// A camera path ([`read_camera_path`]): one frame per shot, the layers read (and meshed) once.
    pub shots: Option<Vec<Shot>>,
}

/// One frame of a camera path: eye and (perspective) look-at, world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shot {
    /// Eye position, world, metres.
    pub eye: DVec3,
    /// Point looked at, world; `None`: the centre of the panorama image.
    pub look_at: Option<DVec3>,
}

/// What `pomc render --json` prints: one view, or a camera path's frames.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum RenderReport {
    /// A single view.
    View(ViewReport),
    /// A camera path.
    Path(PathReport),
}

/// One view's report: its frame's figures and stages flat, with the run's.
#[derive(Clone, Debug, Serialize)]
pub struct ViewReport {
    /// Colour file written.
    pub output: PathBuf,
    /// `splat` or `mesh`.
    pub method: String,
    /// The camera kind (`perspective`, `equirect`, `ods`, ...).
    pub camera: String,
    /// Eye, world.
    pub eye: [f64; 3],
    /// The panorama's freedom radius, metres.
    pub freedom_radius: f64,
    /// Distance of the eye from the panorama's centre, metres.
    pub eye_offset: f64,
    /// Whether the eye is inside the freedom radius.
    pub inside_freedom_radius: bool,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Layers rendered.
    pub layers: usize,
    /// Output pixels no layer covers.
    pub holes: usize,
    /// Their share of the image.
    pub hole_ratio: f64,
    /// The method's work counters.
    pub counts: serde_json::Value,
    /// Seconds: `read_s`, `mesh_s` (mesh method), each render stage's `<name>_s`, `write_s`,
    /// `total_s`.
    pub stages: BTreeMap<String, f64>,
    /// The meshes rendered (mesh method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshReport>,
}

/// A camera path's report.
#[derive(Clone, Debug, Serialize)]
pub struct PathReport {
    /// The colour output's name, its run of `#` standing for the frame number.
    #[serde(skip)]
    pub output: PathBuf,
    /// `splat` or `mesh`.
    pub method: String,
    /// The camera kind.
    pub camera: String,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Layers rendered.
    pub layers: usize,
    /// The panorama's freedom radius, metres.
    pub freedom_radius: f64,
    /// Frames whose eye is outside the freedom radius.
    pub frames_outside_freedom_radius: usize,
    /// Every frame, in order.
    pub frames: Vec<FrameReport>,
    /// The largest hole share of any frame.
    pub max_hole_ratio: f64,
    /// Seconds for the whole path.
    pub stages: PathStages,
    /// The meshes rendered (mesh method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshReport>,
}

/// One frame of a camera path.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Colour file written.
    pub output: PathBuf,
    /// Eye, world.
    pub eye: [f64; 3],
    /// Distance of the eye from the panorama's centre, metres.
    pub eye_offset: f64,
    /// Whether the eye is inside the freedom radius.
    pub inside_freedom_radius: bool,
    /// Output pixels no layer covers.
    pub holes: usize,
    /// Their share of the image.
    pub hole_ratio: f64,
    /// The method's work counters.
    pub counts: serde_json::Value,
    /// Seconds: each render stage's `<name>_s`, `write_s` and `frame_s` (render and write).
    pub stages: BTreeMap<String, f64>,
}

/// A camera path's seconds.
#[derive(Clone, Debug, Serialize)]
pub struct PathStages {
    /// Reading the layers.
    pub read_s: f64,
    /// Meshing them (mesh method; `null` otherwise).
    pub mesh_s: Option<f64>,
    /// Median of the frames' `frame_s`.
    pub frame_median_s: f64,
    /// Largest `frame_s`.
    pub frame_max_s: f64,
    /// The whole run.
    pub total_s: f64,
}

/// The meshes the mesh method rendered.
#[derive(Clone, Debug, Serialize)]
pub struct MeshReport {
    /// Where each layer's mesh came from.
    pub sources: Vec<MeshSource>,
    /// Triangles in all.
    pub triangles: usize,
    /// Border pixels meshed.
    pub border_pixels: usize,
    /// Warnings of the meshing.
    pub warnings: Vec<String>,
}

/// A camera path file: one frame per line `EYE [LOOK_AT]` (world `x,y,z` triples; `#` starts a
/// comment). Errors name the file and line.
pub fn read_camera_path(file: &Path) -> Result<Vec<Shot>, RenderError> {
    let bad = |msg: String| RenderError::CameraPath(format!("{}: {msg}", file.display()));
    // A path is a few lines a frame: 64 MiB is millions of frames, and `/dev/zero` is refused.
    let bytes = crate::fsutil::read_limited(file, 64 << 20)
        .map_err(|e| bad(format!("cannot read the camera path: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|_| bad("the camera path is not UTF-8 text".into()))?;
    let mut shots = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let parts: Vec<&str> = line.split_whitespace().collect();
        let at_line = |e: String| bad(format!("line {}: {e} (expected `x,y,z [x,y,z]`)", i + 1));
        let vec3 = |s: &str| super::parse_vec3(s).map_err(at_line);
        let (eye, look_at) = match parts.as_slice() {
            [e] => (vec3(e)?, None),
            [e, a] => (vec3(e)?, Some(vec3(a)?)),
            _ => return Err(at_line(format!("{} fields", parts.len()))),
        };
        shots.push(Shot { eye, look_at });
    }
    if shots.is_empty() {
        return Err(bad("the camera path has no frames".into()));
    }
    Ok(shots)
}

/// `name` with its (last) run of `#` replaced by `index`, zero-padded to the run's length.
fn frame_name(name: &Path, index: usize) -> Result<PathBuf, RenderError> {
    let numbered = || -> Option<PathBuf> {
        let s = name.to_str()?;
        let end = s.rfind('#')? + 1;
        let start = s[..end].rfind(|c| c != '#').map_or(0, |i| i + 1);
        let width = end - start;
        Some(PathBuf::from(format!("{}{index:0width$}{}", &s[..start], &s[end..])))
    };
    numbered().ok_or_else(|| {
        RenderError::CameraPath(format!(
            "{}: with a camera path every output name needs a run of `#` for the frame number (e.g. view-####.png)",
            name.display()
        ))
    })
}

/// Render `pano`'s views as `s` asks and write them. `progress` is told the stage (`reading`,
/// `reading and meshing`, `rendering`) with the frames done and their count.
///
/// ```
/// use pomc::prelude::*;
/// let dir = std::env::temp_dir().join(format!("pomc-doc-render-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let camera = CameraSettings { size: Some((160, 90)), ..CameraSettings::default() };
/// let shots = vec![Shot { eye: DVec3::new(0.0, 0.0, 1.2), look_at: None }; 2];
/// let s = RenderSettings {
///     output: dir.join("view-##.png"),
///     depth: None,
///     mask: None,
///     camera,
///     method: RenderMethod::Splat,
///     shots: Some(shots),
/// };
/// let report = render_panorama("fixtures/data/room-equirect".as_ref(), &s, &|_, _, _| {})?;
/// let RenderReport::Path(path) = report else { unreachable!() };
/// assert_eq!(path.frames.len(), 2);
/// assert!(dir.join("view-01.png").is_file());
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn render_panorama(
    pano: &Path,
    s: &RenderSettings,
    progress: &dyn Fn(&str, usize, usize),
) -> crate::Result<RenderReport> {
    let start = Instant::now();
    if let Some(shots) = &s.shots {
        if shots.is_empty() {
            return Err(RenderError::CameraPath("the camera path has no frames".into()).into());
        }
        if s.camera.eye.is_some() || s.camera.look_at.is_some() {
            return Err(RenderError::CameraPath(
                "a camera path gives every frame its eye and look-at: leave the camera's eye and look-at unset".into(),
            )
            .into());
        }
        // Every output name is checked before any work.
        for p in std::iter::once(&s.output).chain(&s.depth).chain(&s.mask) {
            frame_name(p, 0)?;
        }
    }
    progress("reading", 0, 0);
    let pano = Panorama::open(pano)?;
    let m = &pano.manifest;
    let single = [Shot { eye: s.camera.eye.unwrap_or(m.centre()), look_at: s.camera.look_at }];
    let shots: &[Shot] = s.shots.as_deref().unwrap_or(&single);
    // Every camera is checked before the layers are read (with a provisional panorama width).
    let look = m.default_look();
    let cameras = |width| -> crate::Result<Vec<ViewCamera>> {
        shots.iter().map(|shot| Ok(s.camera.view_camera(shot.eye, shot.look_at, look, width)?)).collect()
    };
    cameras(2048)?;
    if s.method == RenderMethod::Mesh {
        progress("reading and meshing", 0, 0);
    }
    let renderer = Renderer::new(&pano, s.method)?;
    let (_, mesh_s) = renderer.setup_seconds();
    let read_s = start.elapsed().as_secs_f64() - mesh_s.unwrap_or(0.0);
    let cams = cameras(renderer.panorama_width())?;
    let mut frames = Vec::new();
    let mut last = None;
    for (i, (cam, shot)) in cams.iter().zip(shots).enumerate() {
        progress("rendering", i, cams.len());
        let t = Instant::now();
        let r = renderer.render_view(cam)?;
        let render_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let colour = write_frame(s, &r, s.shots.as_ref().map(|_| i))?;
        let write_s = t.elapsed().as_secs_f64();
        let mut stages =
            BTreeMap::from([("write_s".into(), write_s), ("frame_s".into(), render_s + write_s)]);
        stages.extend(r.stages.iter().map(|st| (format!("{}_s", st.name), st.seconds)));
        frames.push(FrameReport {
            output: colour,
            eye: shot.eye.to_array(),
            eye_offset: m.eye_offset(shot.eye),
            inside_freedom_radius: m.inside_freedom(shot.eye),
            holes: r.holes,
            hole_ratio: r.hole_ratio,
            counts: r.counts.clone(),
            stages,
        });
        last = Some(r);
    }
    progress("rendering", cams.len(), cams.len());
    let r = last.expect("a run has at least one frame");
    let run = Run { s, pano: &pano, renderer: &renderer, start, read_s, mesh_s };
    Ok(if s.shots.is_none() { run.view_report(&r, frames.remove(0)) } else { run.path_report(&r, frames) })
}

/// Write one frame's outputs (colour, and depth and mask when asked) under `index`'s names.
fn write_frame(s: &RenderSettings, r: &View, index: Option<usize>) -> crate::Result<PathBuf> {
    let name = |p: &PathBuf| -> Result<PathBuf, RenderError> {
        match index {
            None => Ok(p.clone()),
            Some(i) => frame_name(p, i),
        }
    };
    let colour = name(&s.output)?;
    frame::save_colour(&r.frame, &colour)?;
    if let Some(p) = &s.depth {
        frame::save_depth(&r.frame, &name(p)?)?;
    }
    if let Some(p) = &s.mask {
        frame::save_mask(&r.frame, &name(p)?)?;
    }
    Ok(colour)
}

/// One finished run: what the reports are made of.
struct Run<'a> {
    s: &'a RenderSettings,
    pano: &'a Panorama,
    renderer: &'a Renderer,
    start: Instant,
    read_s: f64,
    mesh_s: Option<f64>,
}

impl Run<'_> {
    fn method(&self) -> String {
        format!("{:?}", self.s.method).to_lowercase()
    }

    fn camera(&self) -> String {
        format!("{:?}", self.s.camera.camera).to_lowercase()
    }

    fn mesh(&self) -> Option<MeshReport> {
        self.renderer.mesh_info().map(|(sources, warnings, triangles, border_pixels)| MeshReport {
            sources: sources.to_vec(),
            triangles,
            border_pixels,
            warnings: warnings.to_vec(),
        })
    }

    /// One view: its stages flat, as before paths existed.
    fn view_report(&self, r: &View, frame: FrameReport) -> RenderReport {
        let m = &self.pano.manifest;
        let mut stages = BTreeMap::from([("read_s".to_string(), self.read_s)]);
        stages.extend(self.mesh_s.map(|s| ("mesh_s".to_string(), s)));
        stages.extend(frame.stages.into_iter().filter(|(k, _)| k != "frame_s"));
        stages.insert("total_s".into(), self.start.elapsed().as_secs_f64());
        RenderReport::View(ViewReport {
            output: frame.output,
            method: self.method(),
            camera: self.camera(),
            eye: frame.eye,
            freedom_radius: m.freedom_radius,
            eye_offset: frame.eye_offset,
            inside_freedom_radius: frame.inside_freedom_radius,
            width: r.frame.width,
            height: r.frame.height,
            layers: self.renderer.layer_count(),
            holes: r.holes,
            hole_ratio: r.hole_ratio,
            counts: frame.counts,
            stages,
            mesh: self.mesh(),
        })
    }

    /// A camera path: every frame's figures and the medians.
    fn path_report(&self, r: &View, frames: Vec<FrameReport>) -> RenderReport {
        let mut per_frame: Vec<f64> = frames.iter().map(|f| f.stages["frame_s"]).collect();
        per_frame.sort_by(f64::total_cmp);
        RenderReport::Path(PathReport {
            output: self.s.output.clone(),
            method: self.method(),
            camera: self.camera(),
            width: r.frame.width,
            height: r.frame.height,
            layers: self.renderer.layer_count(),
            freedom_radius: self.pano.manifest.freedom_radius,
            frames_outside_freedom_radius: frames.iter().filter(|f| !f.inside_freedom_radius).count(),
            max_hole_ratio: frames.iter().map(|f| f.hole_ratio).fold(0.0, f64::max),
            frames,
            stages: PathStages {
                read_s: self.read_s,
                mesh_s: self.mesh_s,
                frame_median_s: per_frame[per_frame.len() / 2],
                frame_max_s: per_frame[per_frame.len() - 1],
                total_s: self.start.elapsed().as_secs_f64(),
            },
            mesh: self.mesh(),
        })
    }
}

impl RenderReport {
    /// The mesh method's warnings (none for splats).
    pub fn warnings(&self) -> &[String] {
        let mesh = match self {
            RenderReport::View(v) => &v.mesh,
            RenderReport::Path(p) => &p.mesh,
        };
        mesh.as_ref().map_or(&[], |m| &m.warnings)
    }

    /// The human summary `pomc render` prints, a line each.
    pub fn summary(&self) -> Vec<String> {
        match self {
            RenderReport::View(v) => {
                let [x, y, z] = v.eye;
                let mut lines = vec![format!(
                    "rendered {}x{} ({}) from {} layer(s) at eye ({x:.3}, {y:.3}, {z:.3}) in {:.2} s, {:.3} % holes -> {}",
                    v.width,
                    v.height,
                    v.method,
                    v.layers,
                    v.stages["total_s"],
                    100.0 * v.hole_ratio,
                    v.output.display()
                )];
                if !v.inside_freedom_radius {
                    lines.push(format!(
                        "note: the eye is {:.3} m from the centre, outside the freedom radius ({} m): holes are expected",
                        v.eye_offset, v.freedom_radius
                    ));
                }
                lines
            }
            RenderReport::Path(p) => {
                let mut lines = vec![format!(
                    "rendered {} frames {}x{} ({}) from {} layer(s) in {:.2} s ({:.3} s per frame, median), worst holes {:.3} % -> {}",
                    p.frames.len(),
                    p.width,
                    p.height,
                    p.method,
                    p.layers,
                    p.stages.total_s,
                    p.stages.frame_median_s,
                    100.0 * p.max_hole_ratio,
                    p.output.display()
                )];
                if p.frames_outside_freedom_radius > 0 {
                    lines.push(format!(
                        "note: {} of {} frames have the eye outside the freedom radius ({} m): holes are expected there",
                        p.frames_outside_freedom_radius,
                        p.frames.len(),
                        p.freedom_radius
                    ));
                }
                lines
            }
        }
    }
}
