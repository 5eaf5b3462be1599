//! `pomc prepare`: the depth `pomc build` layers, written out to inspect (spec §7.1).

use std::path::PathBuf;

use pomc::jobs;

use crate::cmd_build::InputArgs;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output depth: float OpenEXR (channel Z, metres along the ray, +inf infinitely far) on the
    /// colour's grid.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let mut settings = pomc::jobs::BuildSettings::default();
    args.input.options.apply(&mut settings);
    let spinner = out.spinner("preparing depth");
    let prepared = jobs::prepare_depth_files(&args.input.colour, &args.input.depth, &settings)?;
    let (w, h) = (prepared.width, prepared.height);
    jobs::write_depth(&args.output, w, h, &prepared.depth)?;
    spinner.finish_and_clear();
    for w in &prepared.report.warnings {
        out.warn(w.code, &w.message);
    }
    let mut report = serde_json::to_value(&prepared.report).expect("report serialises");
    report["output"] = serde_json::json!(args.output);
    out.json(&report);
    let r = &prepared.report;
    out.say(format!(
        "prepared {}x{} depth from {}x{}: {} px completed, {} made sky, {} px snapped (radius {}), {} px of specks, noise {:.4}{} -> {}",
        w,
        h,
        r.source_size.0,
        r.source_size.1,
        r.completed_pixels,
        r.sky_pixels,
        r.snapped_pixels,
        r.snap_radius,
        r.speck_pixels,
        r.noise,
        if r.smoothed { " (smoothed)" } else { "" },
        args.output.display()
    ));
    Ok(0)
}
