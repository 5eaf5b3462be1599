//! `pomc pack` and `pomc unpack`: patch-packed storage of sparse layers.

use std::path::PathBuf;

use pomc::jobs::{repack_panorama, RepackSettings};

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct PackArgs {
    /// Input panorama directory or manifest.
    input: PathBuf,
    /// Output panorama directory (created; may equal the input directory to pack in place).
    #[arg(short, long)]
    output: PathBuf,
    /// Pack a layer only when its atlas is at most this fraction of its canvas.
    #[arg(long, default_value_t = RepackSettings::default().threshold, value_parser = Range::FRACTION.parser())]
    threshold: f64,
    /// Guard band copied around each patch, in pixels (for renderers that sample the atlas bilinearly).
    #[arg(long, default_value_t = RepackSettings::default().padding)]
    padding: u32,
}

#[derive(clap::Args, Debug)]
pub struct UnpackArgs {
    /// Input panorama directory or manifest.
    input: PathBuf,
    /// Output panorama directory with full-canvas layers.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run_pack(args: PackArgs, out: Output) -> Result<u8, Failure> {
    let s = RepackSettings { threshold: args.threshold, padding: args.padding, ..RepackSettings::default() };
    rewrite(&args.input, &args.output, &s, out, "packing")
}

pub fn run_unpack(args: UnpackArgs, out: Output) -> Result<u8, Failure> {
    let s = RepackSettings { pack: false, ..RepackSettings::default() };
    rewrite(&args.input, &args.output, &s, out, "unpacking")
}

fn rewrite(
    input: &std::path::Path,
    output: &std::path::Path,
    s: &RepackSettings,
    out: Output,
    what: &str,
) -> Result<u8, Failure> {
    let bar = out.progress(0, "reading");
    let report = repack_panorama(input, output, s, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    for l in &report.layers {
        out.say(format!(
            "{:>16}: canvas {}x{} -> {} {}x{} ({} patches), occupancy {:.1}%",
            l.name.as_deref().unwrap_or("-"),
            l.canvas[0],
            l.canvas[1],
            if l.packed { "atlas" } else { "full" },
            l.atlas[0],
            l.atlas[1],
            l.patches,
            100.0 * l.occupancy
        ));
    }
    out.say(format!("{what} done in {:.3} s -> {}", report.timings_s.total, output.display()));
    out.json(&serde_json::to_value(&report).expect("reports serialise"));
    Ok(0)
}
