//! `pomc render`: a view of a panorama from a camera near its centre (spec §9).

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use pomc::layer_io::ReadLimits;
use pomc::panorama::Panorama;
use pomc::render::{self, image, Camera, EquirectCamera, Perspective, RenderLayer, SplatOptions};

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

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let start = Instant::now();
    let MethodArg::Splat = args.method;
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
    let rendered =
        render::render(&refs, to_world, &cam, &SplatOptions::default()).map_err(pomc::Error::from)?;

    bar.set_message("writing");
    let t = Instant::now();
    image::save_colour(&rendered.frame, &args.output)?;
    if let Some(p) = &args.depth {
        image::save_depth(&rendered.frame, p)?;
    }
    if let Some(p) = &args.mask {
        image::save_mask(&rendered.frame, p)?;
    }
    let write_s = t.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let s = &rendered.stats;
    let mut stages = serde_json::json!({"read_s": read_s, "write_s": write_s});
    for st in &s.stages {
        stages[format!("{}_s", st.name)] = serde_json::json!(st.seconds);
    }
    stages["total_s"] = serde_json::json!(start.elapsed().as_secs_f64());
    out.json(&serde_json::json!({
        "output": args.output,
        "method": "splat",
        "camera": format!("{:?}", args.camera).to_lowercase(),
        "eye": eye.to_array(),
        "width": s.width,
        "height": s.height,
        "layers": s.layers,
        "holes": s.holes,
        "hole_ratio": s.hole_ratio,
        "counts": s.counts,
        "stages": stages,
    }));
    out.say(format!(
        "rendered {}x{} from {} layer(s) at eye ({:.3}, {:.3}, {:.3}) in {:.2} s, {:.3} % holes -> {}",
        s.width,
        s.height,
        s.layers,
        eye.x,
        eye.y,
        eye.z,
        start.elapsed().as_secs_f64(),
        100.0 * s.hole_ratio,
        args.output.display()
    ));
    Ok(0)
}
