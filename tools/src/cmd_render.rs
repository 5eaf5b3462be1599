//! `pomc render`: a view of a panorama from a camera near its centre (spec §9).

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use pomc::layer_io::ReadLimits;
use pomc::mesh::MeshParams;
use pomc::panorama::Panorama;
use pomc::render::{
    self, image, rasterize, Camera, EquirectCamera, Frame, MeshOptions, Perspective, RenderLayer,
    SplatOptions,
};

use crate::output::Output;
use crate::Failure;

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum CameraArg {
    /// Pinhole camera: --eye, --look-at, --up, --fov, --size
    Perspective,
    /// A new 2:1 equirect panorama centred at --eye (world axes, +Z up)
    Equirect,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum MethodArg {
    /// Adaptive 8-neighbourhood point splatting (thesis Alg. 10)
    Splat,
    /// Z-buffered rasterisation of each layer's adaptive quadtree mesh (thesis 7.4); a mesh stored
    /// with `pomc mesh --store` is decoded instead of rebuilt
    Mesh,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or manifest.
    pano: PathBuf,
    /// Colour output: .exr (linear float) or .png (clamped, sRGB-encoded 8-bit).
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long, value_enum, default_value = "perspective")]
    camera: CameraArg,
    /// Eye position in the world, metres: x,y,z (default: the panorama centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<DVec3>,
    /// Point looked at, world: x,y,z (default: eye + 1,0,0).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    look_at: Option<DVec3>,
    /// Up direction, world: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,0,1")]
    up: DVec3,
    /// Horizontal field of view, degrees (perspective).
    #[arg(long, default_value_t = 60.0)]
    fov: f64,
    /// Output size WxH (default 960x540 perspective, 2048x1024 equirect).
    #[arg(long, value_parser = parse_size)]
    size: Option<(usize, usize)>,
    #[arg(long, value_enum, default_value = "splat")]
    method: MethodArg,
    /// Also write the distance from the eye (EXR, channel Z; +inf for infinity content, -1 in holes).
    #[arg(long)]
    depth: Option<PathBuf>,
    /// Also write the coverage mask (PNG: 255 covered, 0 hole).
    #[arg(long)]
    mask: Option<PathBuf>,
}

fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> =
        s.split(',').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got `{s}`")),
    }
}

fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WxH, got `{s}`"))?;
    let w = w.trim().parse::<usize>().map_err(|e| e.to_string())?;
    let h = h.trim().parse::<usize>().map_err(|e| e.to_string())?;
    Ok((w, h))
}

fn camera(args: &Args, eye: DVec3) -> Result<Camera, pomc::Error> {
    Ok(match args.camera {
        CameraArg::Perspective => {
            let (w, h) = args.size.unwrap_or((960, 540));
            let at = args.look_at.unwrap_or(eye + DVec3::X);
            Camera::Perspective(Perspective::new(eye, at, args.up, args.fov, w, h)?)
        }
        CameraArg::Equirect => {
            let (w, h) = args.size.unwrap_or((2048, 1024));
            Camera::Equirect(EquirectCamera::new(eye, w, h)?)
        }
    })
}

/// What a method produced, in the terms of the JSON report.
struct Outcome {
    frame: Frame,
    width: usize,
    height: usize,
    layers: usize,
    holes: usize,
    hole_ratio: f64,
    counts: serde_json::Value,
    stages: Vec<(String, f64)>,
    extra: serde_json::Value,
}

fn render_splat(layers: &[RenderLayer], to_world: glam::DMat4, cam: &Camera) -> Result<Outcome, Failure> {
    let r = render::render(layers, to_world, cam, &SplatOptions::default()).map_err(pomc::Error::from)?;
    let s = r.stats;
    Ok(Outcome {
        frame: r.frame,
        width: s.width,
        height: s.height,
        layers: s.layers,
        holes: s.holes,
        hole_ratio: s.hole_ratio,
        counts: serde_json::json!(s.counts),
        stages: s.stages.iter().map(|st| (st.name.to_string(), st.seconds)).collect(),
        extra: serde_json::json!({}),
    })
}

fn render_mesh(
    pano: &Panorama,
    layers: &[RenderLayer],
    to_world: glam::DMat4,
    cam: &Camera,
    out: &Output,
) -> Result<Outcome, Failure> {
    let t = Instant::now();
    let (meshes, sources, warnings) =
        rasterize::panorama_meshes(pano, layers, &MeshParams::default(), &MeshOptions::default())
            .map_err(pomc::Error::from)?;
    let mesh_s = t.elapsed().as_secs_f64();
    if !out.quiet && !out.json {
        for w in &warnings {
            eprintln!("warning: {w}");
        }
    }
    let triangles: usize = meshes.iter().map(|m| m.mesh_triangles).sum();
    let border: usize = meshes.iter().map(|m| m.border_pixels).sum();
    let r = rasterize::render_mesh(layers, &meshes, to_world, cam, &MeshOptions::default())
        .map_err(pomc::Error::from)?;
    let s = r.stats;
    let mut stages = vec![("mesh".to_string(), mesh_s)];
    stages.extend(s.stages.iter().map(|st| (st.name.to_string(), st.seconds)));
    Ok(Outcome {
        frame: r.frame,
        width: s.width,
        height: s.height,
        layers: s.layers,
        holes: s.holes,
        hole_ratio: s.hole_ratio,
        counts: serde_json::json!(s.counts),
        stages,
        extra: serde_json::json!({
            "mesh": {"sources": sources, "triangles": triangles, "border_pixels": border, "warnings": warnings},
        }),
    })
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let start = Instant::now();
    let bar = out.spinner("reading");
    let pano = Panorama::open(&args.pano)?;
    let to_world = pano.manifest.local_to_world();
    let eye = args.eye.unwrap_or_else(|| render::centre(to_world));
    let cam = camera(&args, eye)?;
    let layers = render::read_layers(&pano, &ReadLimits::default())?;
    let read_s = start.elapsed().as_secs_f64();

    bar.set_message("rendering");
    let refs: Vec<RenderLayer> =
        layers.iter().map(|(image, mapping)| RenderLayer { image, mapping: *mapping }).collect();
    let r = match args.method {
        MethodArg::Splat => render_splat(&refs, to_world, &cam)?,
        MethodArg::Mesh => render_mesh(&pano, &refs, to_world, &cam, &out)?,
    };

    bar.set_message("writing");
    let t = Instant::now();
    image::save_colour(&r.frame, &args.output)?;
    if let Some(p) = &args.depth {
        image::save_depth(&r.frame, p)?;
    }
    if let Some(p) = &args.mask {
        image::save_mask(&r.frame, p)?;
    }
    let write_s = t.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let mut stages = serde_json::json!({"read_s": read_s, "write_s": write_s});
    for (name, seconds) in &r.stages {
        stages[format!("{name}_s")] = serde_json::json!(seconds);
    }
    stages["total_s"] = serde_json::json!(start.elapsed().as_secs_f64());
    let method = format!("{:?}", args.method).to_lowercase();
    let mut report = serde_json::json!({
        "output": args.output,
        "method": method,
        "camera": format!("{:?}", args.camera).to_lowercase(),
        "eye": eye.to_array(),
        "width": r.width,
        "height": r.height,
        "layers": r.layers,
        "holes": r.holes,
        "hole_ratio": r.hole_ratio,
        "counts": r.counts,
        "stages": stages,
    });
    if let (Some(obj), Some(extra)) = (report.as_object_mut(), r.extra.as_object()) {
        obj.extend(extra.clone());
    }
    out.json(&report);
    out.say(format!(
        "rendered {}x{} ({method}) from {} layer(s) at eye ({:.3}, {:.3}, {:.3}) in {:.2} s, {:.3} % holes -> {}",
        r.width,
        r.height,
        r.layers,
        eye.x,
        eye.y,
        eye.z,
        start.elapsed().as_secs_f64(),
        100.0 * r.hole_ratio,
        args.output.display()
    ));
    Ok(0)
}
