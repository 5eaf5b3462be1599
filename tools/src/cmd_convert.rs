//! `pomc convert`: equirect ↔ 3×2 cube conversion of plain images and layer EXRs (spec §3.6).
//!
//! Stages: decode (with size limits checked from the header), resample (parallel, see
//! `pomc::resample`), encode (fast PNG settings), each timed for `--json`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use pomc::image_io::{self, extension, Pixels};
use pomc::layer_io::{self, ReadLimits, WriteOptions};
use pomc::mapping::layout::CubeLayout;
use pomc::raster::Raster;
use pomc::resample::{self, Canvas, Filter, SampleOptions, Texel};

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
    #[arg(long, value_enum)]
    to: pomc::mapping::MappingKind,
    /// Cube face size in pixels (default: a quarter of the equirect width, ffmpeg's default).
    #[arg(long)]
    face_size: Option<usize>,
    /// Equirect width in pixels, even (default: four face sizes, or the input width).
    #[arg(long)]
    width: Option<usize>,
    /// Reconstruction filter: nearest, bilinear or bicubic (Catmull-Rom).
    #[arg(long, default_value = "bilinear")]
    interp: Filter,
    /// Cube-map layout of the cube side: canonical (POMC/thesis 3×2), ffmpeg-c3x2 (ffmpeg v360 c3x2),
    /// openexr-vstrip (OpenEXR cube envmap), py360-horizon (py360convert horizon).
    #[arg(long, default_value = "canonical")]
    layout: CubeLayout,
    /// Layout of a cube-map input, when it differs from `--layout`.
    #[arg(long)]
    in_layout: Option<CubeLayout>,
    /// The image holds depth (channel 0): never blend across depth discontinuities or with
    /// outside (negative) / unknown (NaN) pixels. Layer EXRs always get this treatment for `Z`.
    #[arg(long)]
    depth: bool,
    /// Largest relative depth difference between the taps of a filtered pixel (with --depth).
    #[arg(long, default_value_t = 0.1, value_parser = Range::POSITIVE.parser_f32())]
    depth_jump: f32,
}

fn fail(code: &'static str, message: String) -> Failure {
    Failure { code, message, exit: 2 }
}

fn ms(t: Instant) -> f64 {
    (t.elapsed().as_secs_f64() * 1e4).round() / 10.0
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let total = Instant::now();
    if args.input.is_dir() || args.input.file_name().is_some_and(|n| n == "panorama.xml") {
        return run_panorama(&args, out, total);
    }
    if !args.input.is_file() {
        return Err(fail(
            pomc::codes::CONVERT_NOT_FOUND,
            format!("{}: no such file; check the input path", args.input.display()),
        ));
    }
    if args.depth_jump.is_nan() || args.depth_jump < 0.0 {
        return Err(fail(
            pomc::codes::CONVERT_USAGE,
            format!("--depth-jump {} must be a non-negative number", args.depth_jump),
        ));
    }
    let opts = SampleOptions {
        filter: args.interp,
        depth_channel: args.depth.then_some(0),
        coverage_channel: None,
        max_relative_jump: args.depth_jump,
    };
    let ext = extension(&args.output);
    let layer = is_layer_exr(&args.input);
    let known = if layer { ["exr"].as_slice() } else { ["png", "jpg", "jpeg", "exr", "hdr"].as_slice() };
    if !known.contains(&ext.as_str()) {
        let what = if layer {
            "a layer converts to a layer EXR; use an .exr output"
        } else {
            "unknown output format; use a .png, .jpg, .exr or .hdr extension"
        };
        return Err(fail(pomc::codes::CONVERT_USAGE, format!("{}: {what}", args.output.display())));
    }
    if layer {
        return run_layer(&args, opts, out, total);
    }

    let t = Instant::now();
    let pixels = image_io::decode(&args.input).map_err(pomc::Error::from)?;
    let decode_ms = ms(t);
    let (w, h, ch) = pixels.dims();
    let (from, to, size) = plan(&args, w, h)?;

    let t = Instant::now();
    let rows = target_rows(to, size);
    let bar = out.progress(rows as u64, "resample");
    let tick = |n: usize| bar.inc(n as u64);
    let converted = match &pixels {
        Pixels::U8(r) => Pixels::U8(resample_with(r, from, to, size, &opts, &tick, &args.input)?),
        Pixels::U16(r) => Pixels::U16(resample_with(r, from, to, size, &opts, &tick, &args.input)?),
        Pixels::F32(r) => Pixels::F32(resample_with(r, from, to, size, &opts, &tick, &args.input)?),
    };
    bar.finish_and_clear();
    drop(pixels);
    let resample_ms = ms(t);

    let t = Instant::now();
    image_io::encode(&args.output, &converted).map_err(pomc::Error::from)?;
    let encode_ms = ms(t);
    let (ow, oh, _) = converted.dims();
    report(
        &args,
        out,
        Report {
            kind: "image",
            sample_type: converted.type_name(),
            from,
            to,
            input: (w, h),
            output: (ow, oh),
            channels: ch,
            timings: [decode_ms, resample_ms, encode_ms, ms(total)],
        },
    );
    Ok(0)
}

fn resample_with<T: Texel>(
    r: &Raster<T>,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
    tick: &(dyn Fn(usize) + Sync),
    input: &Path,
) -> Result<Raster<T>, Failure> {
    resample::convert_with_progress(r, from, to, size, opts, tick).map_err(|e| {
        let code = e.code();
        fail(code, format!("{}: {e}", input.display()))
    })
}

struct Report {
    kind: &'static str,
    sample_type: &'static str,
    from: Canvas,
    to: Canvas,
    input: (usize, usize),
    output: (usize, usize),
    channels: usize,
    timings: [f64; 4],
}

fn canvas_name(c: Canvas) -> String {
    match c {
        Canvas::Equirect => "equirect".into(),
        Canvas::Cube(l) => format!("cube ({l})"),
    }
}

fn report(args: &Args, out: Output, r: Report) {
    let size = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    let [decode, resample, encode, total] = r.timings;
    out.json(&serde_json::json!({
        "kind": r.kind,
        "input": args.input, "output": args.output,
        "from": canvas_name(r.from), "to": canvas_name(r.to),
        "interp": args.interp.name(),
        "input_size": [r.input.0, r.input.1], "output_size": [r.output.0, r.output.1],
        "channels": r.channels, "sample_type": r.sample_type,
        "input_bytes": size(&args.input), "output_bytes": size(&args.output),
        "threads": rayon::current_num_threads(),
        "timings_ms": {"decode": decode, "resample": resample, "encode": encode, "total": total},
    }));
    out.say(format!(
        "{} {}x{} {} -> {} {}x{} {} ({}): decode {decode} ms, resample {resample} ms, encode {encode} ms, total {total} ms",
        args.input.display(),
        r.input.0,
        r.input.1,
        canvas_name(r.from),
        args.output.display(),
        r.output.0,
        r.output.1,
        canvas_name(r.to),
        args.interp
    ));
}

/// Source canvas, target canvas and target size (equirect width or face size).
fn plan(args: &Args, w: usize, h: usize) -> Result<(Canvas, Canvas, usize), Failure> {
    let in_layout = args.in_layout.unwrap_or(args.layout);
    let from = if w == 2 * h { Canvas::Equirect } else { Canvas::Cube(in_layout) };
    let in_face = match from {
        Canvas::Equirect => None,
        Canvas::Cube(l) => Some(l.face_size(w, h).map_err(|e| {
            fail(
                e.code(),
                format!(
                    "{}: {e}; a 2:1 image is read as an equirect, other shapes as cube maps (choose the layout with --in-layout)",
                    args.input.display()
                ),
            )
        })?),
    };
    let (to, size) = match args.to {
        pomc::mapping::MappingKind::Cube3x2 => {
            let n = args.face_size.unwrap_or(match in_face {
                Some(n) => n,
                None => w / 4,
            });
            (Canvas::Cube(args.layout), n)
        }
        pomc::mapping::MappingKind::Equirect => {
            let width = args.width.unwrap_or(match in_face {
                Some(n) => 4 * n,
                None => w,
            });
            if width == 0 || width % 2 != 0 {
                return Err(fail(
                    pomc::codes::CONVERT_USAGE,
                    format!("--width {width} must be even and positive"),
                ));
            }
            (Canvas::Equirect, width)
        }
    };
    let limits = ReadLimits::default();
    let (ow, oh) = match to {
        Canvas::Equirect => (size, size / 2),
        Canvas::Cube(l) => l.canvas_size(size),
    };
    if size == 0 || ow.max(oh) > limits.max_dimension || (ow as u64 * oh as u64) > limits.max_pixels {
        return Err(fail(
            pomc::codes::CONVERT_TOO_LARGE,
            format!(
                "{}: an output of {ow}x{oh} pixels is outside the supported range (1..={} per side, {} pixels); choose a smaller --face-size/--width",
                args.output.display(),
                limits.max_dimension,
                limits.max_pixels
            ),
        ));
    }
    Ok((from, to, size))
}

fn target_rows(to: Canvas, size: usize) -> usize {
    match to {
        Canvas::Equirect => size / 2,
        Canvas::Cube(l) => l.canvas_size(size).1,
    }
}

/// A layer EXR is an EXR with a `Z` channel (spec §4); plain EXRs are colour images.
fn is_layer_exr(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if ext.as_deref() != Some("exr") {
        return false;
    }
    exr::meta::MetaData::read_from_file(path, false)
        .map(|m| m.headers.iter().any(|h| h.channels.list.iter().any(|c| c.name.to_string() == "Z")))
        .unwrap_or(false)
}

fn run_layer(args: &Args, opts: SampleOptions, out: Output, total: Instant) -> Result<u8, Failure> {
    let t = Instant::now();
    let layer = layer_io::read_exr(&args.input, &ReadLimits::default()).map_err(pomc::Error::from)?;
    let decode_ms = ms(t);
    let (from, to, size) = plan(args, layer.width, layer.height)?;
    let t = Instant::now();
    let converted = resample::convert_layer(&layer, from, to, size, &opts)
        .map_err(|e| fail(e.code(), format!("{}: {e}", args.input.display())))?;
    let resample_ms = ms(t);
    let (output, channels) = ((converted.width, converted.height), converted.channels.len());
    let t = Instant::now();
    layer_io::write_exr_owned(&args.output, converted, &WriteOptions::default())?;
    let encode_ms = ms(t);
    report(
        args,
        out,
        Report {
            kind: "layer",
            sample_type: "f32",
            from,
            to,
            input: (layer.width, layer.height),
            output,
            channels,
            timings: [decode_ms, resample_ms, encode_ms, ms(total)],
        },
    );
    Ok(0)
}

/// Convert a whole panorama: every layer (packed ones read as full canvases) to the other mapping,
/// written as a panorama (sparse layers packed again) with the manifest's mapping changed. A POMC
/// cube map is in the canonical layout.
fn run_panorama(args: &Args, out: Output, total: Instant) -> Result<u8, Failure> {
    use pomc::panorama::{self, Panorama, SaveOptions};
    if args.layout != CubeLayout::Canonical || args.in_layout.is_some_and(|l| l != CubeLayout::Canonical) {
        return Err(fail(
            pomc::codes::CONVERT_USAGE,
            "a POMC cube map is in the canonical layout: --layout and --in-layout do not apply to panoramas"
                .into(),
        ));
    }
    let pano = Panorama::open(&args.input)?;
    let target = args.to;
    if pano.manifest.mapping.kind == target {
        return Err(fail(
            pomc::codes::CONVERT_USAGE,
            format!("{}: is already a {} panorama", args.input.display(), target.primary_name()),
        ));
    }
    // Depth (`Z`) is never blended across discontinuities: layers get the depth treatment.
    let opts = SampleOptions {
        filter: args.interp,
        depth_channel: None,
        coverage_channel: None,
        max_relative_jump: args.depth_jump,
    };
    let count = pano.manifest.layers.len();
    let bar = out.progress(count as u64, "converting");
    let sizes = std::sync::Mutex::new((0, 0, 0, 0));
    let mut manifest = pano.manifest.clone();
    manifest.mapping.kind = target;
    for decl in &mut manifest.layers {
        decl.packing = None;
    }
    // One layer in memory at a time: read, resample, write, drop. A size the command refuses is
    // kept here (the library's error type has no place for it) and reported instead.
    let refused = std::sync::Mutex::new(None);
    let convert = |k: usize| -> Result<pomc::layer::LayerImage, pomc::Error> {
        let layer = pano.read_layer(k, &ReadLimits::default())?;
        let (from, to, size) = plan(args, layer.width, layer.height).map_err(|f| {
            if let Ok(mut r) = refused.lock() {
                *r = Some(f);
            }
            pomc::Error::from(resample::ResampleError::Unsupported)
        })?;
        let converted = resample::convert_layer(&layer, from, to, size, &opts)?;
        if let Ok(mut s) = sizes.lock() {
            *s = (layer.width, layer.height, converted.width, converted.height);
        }
        bar.inc(1);
        Ok(converted)
    };
    let written = panorama::write_panorama_with(&args.output, &manifest, &convert, &SaveOptions::default());
    if let Some(f) = refused.into_inner().ok().flatten() {
        return Err(f);
    }
    written?;
    bar.finish_and_clear();
    let sizes = sizes.into_inner().unwrap_or_default();
    out.json(&serde_json::json!({
        "kind": "panorama", "input": args.input, "output": args.output,
        "to": target.primary_name(), "layers": count,
        "input_size": [sizes.0, sizes.1], "output_size": [sizes.2, sizes.3],
        "total_ms": ms(total),
    }));
    out.say(format!(
        "converted a panorama of {count} layer(s) {}x{} -> {} {}x{} in {:.0} ms -> {}",
        sizes.0,
        sizes.1,
        target.primary_name(),
        sizes.2,
        sizes.3,
        ms(total),
        args.output.display()
    ));
    Ok(0)
}
