//! `pomc convert`: equirect ↔ 3×2 cube conversion of plain images, layer EXRs and panoramas
//! (spec §3.6): the flags become [`ConvertSettings`], [`pomc::convert`] does the work.

use std::path::PathBuf;
use std::sync::OnceLock;

use pomc::jobs::{self, ConvertProgress, ConvertSettings};
use pomc::mapping::layout::CubeLayout;
use pomc::resample::Filter;

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Input: PNG (8/16-bit), JPEG, EXR or HDR image, a layer EXR (one with a `Z` channel), or a
    /// panorama (directory or panorama.xml: every layer converted, packed layers unpacked first).
    /// A 2:1 input is an equirect; any other shape is a cube map in `--in-layout`.
    input: PathBuf,
    /// Output file (a directory for a panorama); the format follows the extension (.png, .jpg/.jpeg, .exr, .hdr). Float images written
    /// to PNG/JPEG are clamped to [0, 1] (no tone mapping); 16-bit PNGs stay 16-bit.
    #[arg(short, long)]
    output: PathBuf,
    /// Target mapping.
    #[arg(long, value_parser = pomc_flags::choice::<pomc::mapping::MappingKind>())]
    to: pomc::mapping::MappingKind,
    /// Cube face size in pixels (default: a quarter of the equirect width, ffmpeg's default).
    #[arg(long)]
    face_size: Option<usize>,
    /// Equirect width in pixels, even (default: four face sizes, or the input width).
    #[arg(long)]
    width: Option<usize>,
    /// Reconstruction filter: nearest, bilinear or bicubic (Catmull-Rom).
    #[arg(long, default_value_t = ConvertSettings::default().filter)]
    interp: Filter,
    /// Cube-map layout of the cube side: canonical (POMC/thesis 3×2), ffmpeg-c3x2 (ffmpeg v360 c3x2),
    /// openexr-vstrip (OpenEXR cube envmap), py360-horizon (py360convert horizon).
    #[arg(long, default_value_t = ConvertSettings::default().layout)]
    layout: CubeLayout,
    /// Layout of a cube-map input, when it differs from `--layout`.
    #[arg(long)]
    in_layout: Option<CubeLayout>,
    /// The image holds depth (channel 0): never blend across depth discontinuities or with
    /// outside (negative) / unknown (NaN) pixels. Layer EXRs always get this treatment for `Z`.
    #[arg(long)]
    depth: bool,
    /// Largest relative depth difference between the taps of a filtered pixel (with --depth).
    #[arg(long, default_value_t = ConvertSettings::default().depth_jump, value_parser = Range::POSITIVE.parser_f32())]
    depth_jump: f32,
}

/// The library settings the arguments stand for.
fn settings(args: &Args) -> ConvertSettings {
    ConvertSettings {
        face_size: args.face_size,
        width: args.width,
        filter: args.interp,
        layout: args.layout,
        in_layout: args.in_layout,
        depth: args.depth,
        depth_jump: args.depth_jump,
    }
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let settings = settings(&args);
    let bar = OnceLock::new();
    let progress = |p: ConvertProgress| match p {
        ConvertProgress::Steps(n) => {
            let panorama = args.input.is_dir() || args.input.ends_with("panorama.xml");
            let _ = bar.set(out.progress(n, if panorama { "converting" } else { "resample" }));
        }
        ConvertProgress::Done(n) => {
            if let Some(b) = bar.get() {
                b.inc(n)
            }
        }
    };
    let report = jobs::convert_file_with_progress(&args.input, &args.output, args.to, &settings, &progress);
    if let Some(b) = bar.get() {
        b.finish_and_clear();
    }
    let report = report?;
    out.json(&serde_json::to_value(&report).expect("report serialises"));
    out.say(report.summary());
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::parse;

    /// `ConvertSettings::default()` is what `pomc convert` does without options.
    #[test]
    fn default_options_are_the_library_default() {
        let args: Args = parse(&["pomc-convert", "in.png", "-o", "out.png", "--to", "cube"]);
        assert_eq!(settings(&args), ConvertSettings::default());
    }
}
