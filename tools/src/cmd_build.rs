//! `pomc build`: a layered POMC from a plain RGB-D panorama.

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;
use pomc::colour::ColourSpace;
use pomc::jobs::{self, BuildSettings};
use pomc::layer_io::ReadLimits;
use pomc::layering::input::{Convention, DepthKind, Preset};
use pomc::layering::{BuildOptions, Classify, FillColour};
use pomc::panorama::SaveOptions;
use pomc::prepare::{PrepareOptions, Refine, UnknownDepth};

use crate::args::{parse_known_distance, parse_range, parse_vec3, Range};
use crate::output::Output;
use crate::Failure;

/// The colour and depth inputs and how the depth is read and prepared (`build` and `prepare`).
#[derive(clap::Args, Debug)]
pub struct InputArgs {
    /// Colour panorama (PNG, JPEG, EXR, HDR), equirect 2:1 or 3×2 cube map.
    #[arg(long)]
    pub colour: PathBuf,
    /// Encoding of an 8/16-bit colour image: auto (sRGB for PNG/JPEG, linear for EXR/HDR), srgb or
    /// linear. Layers are linear; sRGB is decoded on read.
    #[arg(long, value_enum, default_value = "auto")]
    colour_space: ColourSpace,
    /// Depth panorama: float EXR (channel Z, or any single channel), 16-bit PNG, or with a relative
    /// --depth-kind an 8/16-bit PNG or JPEG; any resolution (upsampled onto the colour's grid).
    #[arg(long)]
    pub depth: PathBuf,
    /// Dataset preset for the depth encoding.
    #[arg(long, value_enum)]
    preset: Option<Preset>,
    /// Metres per stored depth unit (16-bit PNG); overrides the preset.
    #[arg(long, value_parser = Range::POSITIVE.parser())]
    depth_scale: Option<f64>,
    /// Stored depth value meaning "unknown" (0, NaN and negatives always are).
    #[arg(long, value_parser = Range::FINITE.parser())]
    depth_invalid: Option<f64>,
    /// What the depth values are: metric (ray, z) or relative (inverse, nearness: give
    /// --camera-height or --depth-range).
    #[arg(long, value_enum, default_value = "ray")]
    depth_kind: DepthKind,
    /// Nearest and farthest distance (m) of relative depth: NEAR,FAR.
    #[arg(long, value_name = "NEAR,FAR", value_parser = parse_range, allow_hyphen_values = true)]
    depth_range: Option<(f64, f64)>,
    /// Camera height above a level floor (m): relative depth is made metric by fitting the floor.
    #[arg(long, value_name = "H", value_parser = Range::POSITIVE.parser())]
    camera_height: Option<f64>,
    /// One distance you know: pixel X,Y of the colour image is METRES away along its ray; gives the
    /// scale of depth of unknown unit, or of inverse depth taken as having no shift.
    #[arg(long, value_name = "X,Y,METRES", value_parser = parse_known_distance)]
    known_distance: Option<pomc::prepare::KnownDistance>,
    /// Snap soft depth edges onto colour edges and smooth depth noise: auto (when measured soft,
    /// noisy, resized or completed), on, off.
    #[arg(long, value_enum, default_value = "auto")]
    refine: Refine,
    /// What unknown depth means: complete (a surface, completed from around it) or sky (nothing there).
    #[arg(long, value_enum, default_value = "complete")]
    unknown_depth: UnknownDepth,
    /// Largest input accepted, in pixels (width × height), checked from the file headers before
    /// decoding; the default, 268435456 (2^28), takes a 16384 × 8192 equirect.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1 << 34))]
    max_pixels: Option<u64>,
}

impl InputArgs {
    /// The library settings these arguments stand for (the rest default).
    pub fn settings(&self) -> BuildSettings {
        let mut enc = self.preset.map(Preset::encoding).unwrap_or_default();
        if let Some(s) = self.depth_scale {
            enc.scale = Some(s);
        }
        if let Some(i) = self.depth_invalid {
            enc.invalid = Some(i);
        }
        enc.kind = self.depth_kind;
        enc.range = self.depth_range;
        enc.camera_height = self.camera_height;
        enc.known_distance = self.known_distance;
        BuildSettings {
            colour_space: self.colour_space,
            depth: enc,
            prepare: PrepareOptions { refine: self.refine, unknown: self.unknown_depth },
            limits: self.max_pixels.map(ReadLimits::with_max_pixels).unwrap_or_default(),
            ..BuildSettings::default()
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Normals EXR (N.X,N.Y,N.Z or R,G,B, panorama frame); estimated from depth when absent.
    #[arg(long)]
    normals_in: Option<PathBuf>,
    /// Output panorama directory.
    #[arg(short, long)]
    output: PathBuf,
    /// Azimuth convention of the input, recorded in the manifest's LocalToWorld.
    #[arg(long, value_enum, default_value = "thesis")]
    convention: Convention,
    /// Position of the panorama centre in the world, metres: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    center: Option<DVec3>,
    /// Freedom radius (m): cameras within it see no holes.
    #[arg(long, default_value_t = BuildOptions::default().freedom_radius, value_parser = Range::POSITIVE.parser())]
    freedom_radius: f64,
    /// Relative depth jump between neighbours that separates surfaces.
    #[arg(long, default_value_t = pomc::layering::EdgeOptions::default().jump, value_parser = Range::POSITIVE.parser())]
    jump: f64,
    /// Normal angle (degrees) that closes regions where depth is continuous but the surface folds.
    #[arg(long, default_value_t = pomc::layering::EdgeOptions::default().fold_deg.unwrap_or(35.0), value_parser = Range::ANGLE.parser())]
    fold_deg: f64,
    /// Extra fill band (pixels) beyond the parallax band of the freedom radius.
    #[arg(long, default_value_t = BuildOptions::default().margin_px, value_parser = Range::NON_NEGATIVE.parser())]
    fill_margin: f64,
    /// How the fill behind occluders is coloured.
    #[arg(long, value_enum, default_value = "exemplar")]
    fill_colour: FillColour,
    /// Do not split at folds (depth discontinuities only).
    #[arg(long)]
    no_fold: bool,
    /// Split layers by depth at these distances (m), e.g. 2,5 (thesis 6.2.4.1).
    #[arg(long, value_delimiter = ',', value_parser = Range::POSITIVE.parser())]
    depth_bands: Vec<f64>,
    /// Layer classification: by depth only, or also floor / ceiling / walls (thesis 6.2.4.2).
    #[arg(long, value_enum, default_value = "depth")]
    classify: Classify,
    /// Write normals into the layers.
    #[arg(long)]
    normals: bool,
    /// Keep far content in the finite layers (no infinity layer).
    #[arg(long)]
    no_infinity: bool,
    /// Keep mixed pixels (depth between a nearer and a farther neighbour across jumps to both, as an
    /// anti-aliased depth pass makes at edges) instead of treating them as unknown.
    #[arg(long)]
    keep_mixed: bool,
    /// Depth edges spread over a few pixels (resized or network-estimated depth) are cut at their
    /// steepest step: the in-between pixels join the far side. Off by default: the limb of a near
    /// curved object looks the same and would be cut (docs/build.md, "Soft depth edges").
    #[arg(long, conflicts_with = "keep_mixed")]
    soft_edges: bool,
    /// Store every layer as a full canvas (no patch packing).
    #[arg(long)]
    no_pack: bool,
    /// Also write the JSON report to this file.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// Whether `--report FILE` can be written: not a directory, its directory creatable and writable.
fn check_report_path(p: &std::path::Path) -> Result<(), Failure> {
    let bad = |why: String| Failure::usage(format!("{}: cannot write the report there ({why})", p.display()));
    if p.is_dir() {
        return Err(bad("it is a directory".into()));
    }
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| bad(e.to_string()))?;
    let probe = dir.join(format!(".pomc-tmp-report-{}", std::process::id()));
    std::fs::OpenOptions::new().write(true).create_new(true).open(&probe).map_err(|e| bad(e.to_string()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    // The report is checked before any work: failing on it after the panorama is written would
    // report an error for a run that did its job.
    if let Some(p) = &args.report {
        check_report_path(p)?;
    }
    let start = Instant::now();
    let settings = BuildSettings {
        normals_in: args.normals_in.clone(),
        convention: args.convention,
        center: args.center,
        options: build_options(&args),
        save: SaveOptions { pack: !args.no_pack, ..SaveOptions::default() },
        ..args.input.settings()
    };
    // Reading, then every stage the job names: a bar with an ETA.
    let bar = out.progress(jobs::build_stages(&settings).len() as u64, "reading");
    let progress = |stage: &str| {
        bar.set_message(stage.to_string());
        bar.inc(1);
    };
    let built = jobs::build_panorama_with_progress(
        &args.input.colour,
        &args.input.depth,
        &args.output,
        &settings,
        &progress,
    )?;
    bar.finish_and_clear();
    for w in &built.prepare.warnings {
        out.warn(w.code, &w.message);
    }

    let mut report = serde_json::to_value(&built.report).expect("report serialises");
    report["output"] = serde_json::json!(args.output);
    report["prepare"] = serde_json::to_value(&built.prepare).expect("report serialises");
    report["read_s"] = serde_json::json!(built.read_s);
    report["write_s"] = serde_json::json!(built.write_s);
    report["total_s"] = serde_json::json!(start.elapsed().as_secs_f64());
    report["packed"] =
        serde_json::json!(built.manifest.layers.iter().map(|l| l.packing.is_some()).collect::<Vec<_>>());
    if let Some(p) = &args.report {
        let text = serde_json::to_string_pretty(&report).expect("JSON values serialise");
        pomc::fsutil::write_bytes_atomic(p, text.as_bytes()).map_err(pomc::Error::from)?;
    }
    out.json(&report);
    for l in &built.report.layers {
        let depth = match l.depth_range {
            Some((lo, hi)) => format!("depth {lo:.3}–{hi:.3} m"),
            None => "no finite depth".to_string(),
        };
        out.say(format!(
            "{:>14} {:>10} order {}: {} px seen, {} px filled, {depth}",
            l.name, l.role, l.order, l.own_pixels, l.filled_pixels
        ));
    }
    out.say(format!(
        "built {} layer(s) in {:.2} s (fill band up to {:.2}°, d_dirmin {:.0} m) -> {}",
        built.manifest.layers.len(),
        start.elapsed().as_secs_f64(),
        built.report.max_band_deg,
        built.report.d_dirmin,
        args.output.display()
    ));
    Ok(0)
}

/// The library options the arguments stand for (no options: `BuildOptions::default()`).
fn build_options(args: &Args) -> BuildOptions {
    let mut options = BuildOptions {
        freedom_radius: args.freedom_radius,
        depth_bands: args.depth_bands.clone(),
        normals_out: args.normals,
        infinity: !args.no_infinity,
        drop_mixed: !args.keep_mixed,
        soft_edges: args.soft_edges,
        classify: args.classify,
        margin_px: args.fill_margin,
        fill_colour: args.fill_colour,
        ..BuildOptions::default()
    };
    options.segment.edges.jump = args.jump;
    options.segment.edges.fold_deg = (!args.no_fold).then_some(args.fold_deg);
    options
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::parse;

    /// The library's `BuildOptions::default()` is what `pomc build` does without options.
    #[test]
    fn default_options_are_the_library_default() {
        let args: Args = parse(&["pomc-build", "--colour", "c.png", "--depth", "d.exr", "-o", "out"]);
        assert_eq!(format!("{:?}", build_options(&args)), format!("{:?}", BuildOptions::default()));
    }
}
