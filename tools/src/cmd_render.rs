//! `pomc render`: a view of a panorama from a camera near its centre (spec §9).

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use pomc::jobs::{RenderMethod, Renderer, View, ViewCamera};
use pomc::options::CameraArgs;
use pomc::panorama::Panorama;
use pomc::render::frame;

use crate::args::parse_vec3;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or manifest.
    pano: PathBuf,
    /// Colour output: .exr (linear float) or .png (clamped, sRGB-encoded 8-bit).
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    view: CameraArgs,
    #[arg(long, value_enum, default_value = "splat")]
    method: RenderMethod,
    /// Also write the distance from the eye (EXR, channel Z; +inf for infinity content, -1 in holes).
    #[arg(long)]
    depth: Option<PathBuf>,
    /// Also write the coverage mask (PNG: 255 covered, 0 hole).
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Camera path: render one frame per line `EYE [LOOK_AT]` (world x,y,z triples; `#` starts a
    /// comment). The layers are read and meshed once. Output names must contain a run of `#`, replaced
    /// by the zero-padded frame number (e.g. `-o view-####.png`).
    #[arg(long, conflicts_with_all = ["eye", "look_at"])]
    path: Option<PathBuf>,
}

/// One frame of a camera path: eye and (perspective) look-at, world.
#[derive(Clone, Copy, Debug)]
struct Shot {
    eye: DVec3,
    look_at: Option<DVec3>,
}

/// Parse a camera path file (see `--path`); errors name the file and line.
fn read_path(file: &std::path::Path) -> Result<Vec<Shot>, Failure> {
    let bad = |msg: String| Failure::usage(format!("{}: {msg}", file.display()));
    // A path is a few lines a frame: 64 MiB is millions of frames, and `/dev/zero` is refused.
    let bytes = pomc::fsutil::read_limited(file, 64 << 20)
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
        let (eye, look_at) = match parts.as_slice() {
            [e] => (parse_vec3(e).map_err(at_line)?, None),
            [e, a] => (parse_vec3(e).map_err(at_line)?, Some(parse_vec3(a).map_err(at_line)?)),
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
fn frame_name(name: &std::path::Path, index: usize) -> Option<PathBuf> {
    let s = name.to_str()?;
    let end = s.rfind('#')? + 1;
    let start = s[..end].rfind(|c| c != '#').map_or(0, |i| i + 1);
    let width = end - start;
    Some(PathBuf::from(format!("{}{index:0width$}{}", &s[..start], &s[end..])))
}

/// The camera of one shot; without a look-at, it looks at the centre of the panorama image.
fn camera(args: &Args, shot: Shot, look: DVec3, panorama_width: usize) -> Result<ViewCamera, pomc::Error> {
    Ok(args.view.view_camera(shot.eye, shot.look_at, look, panorama_width)?)
}

/// Write one frame's outputs (colour, and depth and mask when asked) under `index`'s names.
fn write_frame(args: &Args, r: &View, index: Option<usize>) -> Result<PathBuf, Failure> {
    let name = |p: &PathBuf| -> Result<PathBuf, Failure> {
        match index {
            None => Ok(p.clone()),
            Some(i) => numbered(p, i),
        }
    };
    let colour = name(&args.output)?;
    frame::save_colour(&r.frame, &colour)?;
    if let Some(p) = &args.depth {
        frame::save_depth(&r.frame, &name(p)?)?;
    }
    if let Some(p) = &args.mask {
        frame::save_mask(&r.frame, &name(p)?)?;
    }
    Ok(colour)
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let start = Instant::now();
    let shots = match &args.path {
        Some(file) => {
            let shots = read_path(file)?;
            // Check every output name before any work.
            for p in std::iter::once(&args.output).chain(&args.depth).chain(&args.mask) {
                write_name_check(p)?;
            }
            Some(shots)
        }
        None => None,
    };
    let bar = out.spinner("reading");
    let pano = Panorama::open(&args.pano)?;
    let m = &pano.manifest;
    let single = [Shot { eye: args.view.eye.unwrap_or(m.centre()), look_at: args.view.look_at }];
    let shots: &[Shot] = shots.as_deref().unwrap_or(&single);
    // Every camera is checked before the layers are read (with a provisional panorama width).
    let look = m.default_look();
    let cameras = |width| shots.iter().map(|s| camera(&args, *s, look, width)).collect::<Result<Vec<_>, _>>();
    cameras(2048)?;
    if args.method == RenderMethod::Mesh {
        bar.set_message("reading and meshing");
    }
    let renderer = Renderer::new(&pano, args.method)?;
    let (_, mesh_s) = renderer.setup_seconds();
    let read_s = start.elapsed().as_secs_f64() - mesh_s.unwrap_or(0.0);
    bar.finish_and_clear();
    let cams = cameras(renderer.panorama_width())?;
    let mesh_extra = mesh_json(&renderer, &out);
    let progress = (args.path.is_some()).then(|| out.progress(cams.len() as u64, "rendering"));
    let mut frames = Vec::new();
    let mut last = None;
    for (i, (cam, shot)) in cams.iter().zip(shots).enumerate() {
        let t = Instant::now();
        let r = renderer.render_view(cam)?;
        let render_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let colour = write_frame(&args, &r, args.path.as_ref().map(|_| i))?;
        let write_s = t.elapsed().as_secs_f64();
        let mut stages = serde_json::json!({"write_s": write_s, "frame_s": render_s + write_s});
        for st in &r.stages {
            stages[format!("{}_s", st.name)] = serde_json::json!(st.seconds);
        }
        frames.push(serde_json::json!({
            "output": colour, "eye": shot.eye.to_array(), "eye_offset": m.eye_offset(shot.eye),
            "inside_freedom_radius": m.inside_freedom(shot.eye), "holes": r.holes, "hole_ratio": r.hole_ratio,
            "counts": r.counts, "stages": stages,
        }));
        if let Some(p) = &progress {
            p.inc(1);
        }
        last = Some((r, colour));
    }
    if let Some(p) = progress {
        p.finish_and_clear();
    }
    let Some((r, colour)) = last else { return Ok(0) };
    let run = Run { args: &args, pano: &pano, renderer: &renderer, shots, start, read_s, mesh_s };
    let mut report = if args.path.is_none() {
        run.view_report(&r, &colour, &frames[0])
    } else {
        run.path_report(&r, frames)
    };
    if let (Some(obj), Some(extra)) =
        (report.as_object_mut(), mesh_extra.as_ref().and_then(|e| e.as_object()))
    {
        obj.extend(extra.clone());
    }
    out.json(&report);
    run.say(&out, &r, &colour, &report);
    Ok(0)
}

/// The mesh renderer's sources, warnings and counts as JSON (its warnings printed).
fn mesh_json(renderer: &Renderer, out: &Output) -> Option<serde_json::Value> {
    renderer.mesh_info().map(|(sources, warnings, triangles, border)| {
        if !out.quiet && !out.json {
            for w in warnings {
                eprintln!("warning: {w}");
            }
        }
        serde_json::json!({
            "mesh": {"sources": sources, "triangles": triangles, "border_pixels": border, "warnings": warnings},
        })
    })
}

/// One finished run of `pomc render`: what the reports are made of.
struct Run<'a> {
    args: &'a Args,
    pano: &'a Panorama,
    renderer: &'a Renderer,
    shots: &'a [Shot],
    start: Instant,
    read_s: f64,
    mesh_s: Option<f64>,
}

impl Run<'_> {
    fn method(&self) -> String {
        format!("{:?}", self.args.method).to_lowercase()
    }

    fn outside(&self, eye: DVec3) -> bool {
        !self.pano.manifest.inside_freedom(eye)
    }

    /// One view: its stages flat, as before paths existed.
    fn view_report(
        &self,
        r: &View,
        colour: &std::path::Path,
        frame: &serde_json::Value,
    ) -> serde_json::Value {
        let m = &self.pano.manifest;
        let mut stages = serde_json::json!({"read_s": self.read_s});
        if let Some(s) = self.mesh_s {
            stages["mesh_s"] = serde_json::json!(s);
        }
        if let Some(f) = frame["stages"].as_object() {
            for (k, v) in f.iter().filter(|(k, _)| k.as_str() != "frame_s") {
                stages[k.as_str()] = v.clone();
            }
        }
        stages["total_s"] = serde_json::json!(self.start.elapsed().as_secs_f64());
        let eye = self.shots[0].eye;
        serde_json::json!({
            "output": colour,
            "method": self.method(),
            "camera": format!("{:?}", self.args.view.camera).to_lowercase(),
            "eye": eye.to_array(),
            "freedom_radius": m.freedom_radius,
            "eye_offset": m.eye_offset(eye),
            "inside_freedom_radius": !self.outside(eye),
            "width": r.frame.width,
            "height": r.frame.height,
            "layers": self.renderer.layer_count(),
            "holes": r.holes,
            "hole_ratio": r.hole_ratio,
            "counts": r.counts,
            "stages": stages,
        })
    }

    /// A camera path: every frame's figures and the medians.
    fn path_report(&self, r: &View, frames: Vec<serde_json::Value>) -> serde_json::Value {
        let mut per_frame: Vec<f64> = frames.iter().filter_map(|f| f["stages"]["frame_s"].as_f64()).collect();
        per_frame.sort_by(f64::total_cmp);
        let worst_holes = frames.iter().filter_map(|f| f["hole_ratio"].as_f64()).fold(0.0, f64::max);
        serde_json::json!({
            "method": self.method(),
            "camera": format!("{:?}", self.args.view.camera).to_lowercase(),
            "width": r.frame.width,
            "height": r.frame.height,
            "layers": self.renderer.layer_count(),
            "freedom_radius": self.pano.manifest.freedom_radius,
            "frames_outside_freedom_radius": self.shots.iter().filter(|s| self.outside(s.eye)).count(),
            "frames": frames,
            "max_hole_ratio": worst_holes,
            "stages": {
                "read_s": self.read_s,
                "mesh_s": self.mesh_s,
                "frame_median_s": per_frame[per_frame.len() / 2],
                "frame_max_s": per_frame[per_frame.len() - 1],
                "total_s": self.start.elapsed().as_secs_f64(),
            },
        })
    }

    /// The human summary.
    fn say(&self, out: &Output, r: &View, colour: &std::path::Path, report: &serde_json::Value) {
        let (method, radius) = (self.method(), self.pano.manifest.freedom_radius);
        if self.args.path.is_some() {
            out.say(format!(
                "rendered {} frames {}x{} ({method}) from {} layer(s) in {:.2} s ({:.3} s per frame, median), worst holes {:.3} % -> {}",
                self.shots.len(),
                r.frame.width,
                r.frame.height,
                self.renderer.layer_count(),
                self.start.elapsed().as_secs_f64(),
                report["stages"]["frame_median_s"].as_f64().unwrap_or(0.0),
                100.0 * report["max_hole_ratio"].as_f64().unwrap_or(0.0),
                self.args.output.display()
            ));
            let far = self.shots.iter().filter(|s| self.outside(s.eye)).count();
            if far > 0 {
                out.say(format!(
                    "note: {far} of {} frames have the eye outside the freedom radius ({radius} m): holes are expected there",
                    self.shots.len()
                ));
            }
        } else {
            let eye = self.shots[0].eye;
            out.say(format!(
                "rendered {}x{} ({method}) from {} layer(s) at eye ({:.3}, {:.3}, {:.3}) in {:.2} s, {:.3} % holes -> {}",
                r.frame.width,
                r.frame.height,
                self.renderer.layer_count(),
                eye.x,
                eye.y,
                eye.z,
                self.start.elapsed().as_secs_f64(),
                100.0 * r.hole_ratio,
                colour.display()
            ));
            if self.outside(eye) {
                out.say(format!(
                    "note: the eye is {:.3} m from the centre, outside the freedom radius ({radius} m): holes are expected",
                    self.pano.manifest.eye_offset(eye)
                ));
            }
        }
    }
}

fn write_name_check(p: &std::path::Path) -> Result<(), Failure> {
    numbered(p, 0).map(|_| ())
}

/// [`frame_name`], or the usage error of a name without `#`.
fn numbered(p: &std::path::Path, index: usize) -> Result<PathBuf, Failure> {
    frame_name(p, index).ok_or_else(|| {
        Failure::usage(format!(
            "{}: with --path every output name needs a run of `#` for the frame number (e.g. view-####.png)",
            p.display()
        ))
    })
}
