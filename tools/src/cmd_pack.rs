//! `pomc pack` and `pomc unpack`: patch-packed storage of sparse layers.

use std::path::PathBuf;
use std::time::Instant;

use pomc::layer_io::ReadLimits;
use pomc::pack::PackOptions;
use pomc::panorama::{Panorama, SaveOptions};

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
    #[arg(long, default_value_t = SaveOptions::default().pack_threshold, value_parser = Range::FRACTION.parser())]
    threshold: f64,
    /// Guard band copied around each patch, in pixels (for renderers that sample the atlas bilinearly).
    #[arg(long, default_value_t = PackOptions::default().padding)]
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
    let pack_options = PackOptions { padding: args.padding };
    let options =
        SaveOptions { pack: true, pack_threshold: args.threshold, pack_options, ..Default::default() };
    rewrite(&args.input, &args.output, &options, out, "packing")
}

pub fn run_unpack(args: UnpackArgs, out: Output) -> Result<u8, Failure> {
    let options = SaveOptions { pack: false, ..Default::default() };
    rewrite(&args.input, &args.output, &options, out, "unpacking")
}

/// Read every layer's full canvas and write the panorama again with `options`.
fn rewrite(
    input: &std::path::Path,
    output: &std::path::Path,
    options: &SaveOptions,
    out: Output,
    what: &str,
) -> Result<u8, Failure> {
    let start = Instant::now();
    let pano = Panorama::open(input)?;
    let n = pano.manifest.layers.len();
    let bar = out.progress(n as u64, "reading");
    let mut layers = Vec::with_capacity(n);
    for k in 0..n {
        layers.push(pano.read_layer(k, &ReadLimits::default())?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let read_s = start.elapsed().as_secs_f64();
    let t = Instant::now();
    let written = pano.save(output, &layers, options)?;
    let write_s = t.elapsed().as_secs_f64();

    let mut rows = Vec::new();
    for (decl, image) in written.layers.iter().zip(&layers) {
        let canvas = image.width * image.height;
        let occupied = image.occupied();
        let (atlas, patches) = match &decl.packing {
            Some(p) => ((p.atlas_width as usize, p.atlas_height as usize), p.patches.len()),
            None => ((image.width, image.height), 0),
        };
        let atlas_px = atlas.0 * atlas.1;
        rows.push(serde_json::json!({
            "name": decl.name,
            "packed": decl.packing.is_some(),
            "canvas": [image.width, image.height],
            "atlas": [atlas.0, atlas.1],
            "patches": patches,
            "occupied_pixels": occupied,
            "occupancy": occupied as f64 / atlas_px.max(1) as f64,
            "stored_fraction": atlas_px as f64 / canvas.max(1) as f64,
        }));
        out.say(format!(
            "{:>16}: canvas {}x{} -> {} {}x{} ({} patches), occupancy {:.1}%",
            decl.name.as_deref().unwrap_or("-"),
            image.width,
            image.height,
            if decl.packing.is_some() { "atlas" } else { "full" },
            atlas.0,
            atlas.1,
            patches,
            100.0 * occupied as f64 / atlas_px.max(1) as f64
        ));
    }
    out.say(format!("{what} done in {:.3} s -> {}", start.elapsed().as_secs_f64(), output.display()));
    out.json(&serde_json::json!({
        "output": output,
        "layers": rows,
        "timings_s": {"read": read_s, "write": write_s, "total": start.elapsed().as_secs_f64()},
    }));
    Ok(0)
}
