//! `pomc render`: a view of a panorama from a camera near its centre (spec §9).

use std::cell::RefCell;
use std::path::PathBuf;

use indicatif::ProgressBar;
use pomc::jobs::{read_camera_path, render_panorama, RenderMethod, RenderSettings};
use pomc_flags::CameraArgs;

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
    #[arg(long, value_parser = pomc_flags::choice::<RenderMethod>(), default_value = "splat")]
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

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let shots = args.path.as_deref().map(read_camera_path).transpose().map_err(pomc::Error::from)?;
    let path = shots.is_some();
    let s = RenderSettings {
        output: args.output,
        depth: args.depth,
        mask: args.mask,
        camera: args.view.settings(),
        method: args.method,
        shots,
    };
    // A spinner while the layers are read (and meshed), then a bar over a camera path's frames.
    let bar = RefCell::new(out.spinner("reading"));
    let report = render_panorama(&args.pano, &s, &|stage, done, total| {
        let mut bar = bar.borrow_mut();
        match stage {
            "rendering" if !path => bar.finish_and_clear(),
            "rendering" if done == 0 => {
                bar.finish_and_clear();
                *bar = out.progress(total as u64, "rendering");
            }
            "rendering" => bar.set_position(done as u64),
            _ => bar.set_message(stage.to_string()),
        }
    });
    let bar: ProgressBar = bar.into_inner();
    bar.finish_and_clear();
    let report = report?;
    if !out.quiet && !out.json {
        for w in report.warnings() {
            eprintln!("warning: {w}");
        }
    }
    out.json(&serde_json::to_value(&report).expect("reports serialise"));
    for line in report.summary() {
        out.say(line);
    }
    Ok(0)
}
