//! `pomc convert`: equirect ↔ 3×2 cube conversion of plain images and layer EXRs (spec §3.6).
//!
//! Stages: decode (with size limits checked from the header), resample (parallel, see
//! `pomc::resample`), encode (fast PNG settings), each timed for `--json`.

use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::time::Instant;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder, ImageReader, Limits};
use pomc::layer_io::{self, ReadLimits, WriteOptions};
use pomc::mapping::layout::CubeLayout;
use pomc::raster::Raster;
use pomc::resample::{self, Canvas, Filter, SampleOptions, Texel};

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

/// Target mapping.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum To {
    Cube,
    Equirect,
}

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
    to: To,
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

/// Decoded pixels of a plain image, kept in their own sample type.
enum Pixels {
    U8(Raster<u8>),
    U16(Raster<u16>),
    F32(Raster<f32>),
}

impl Pixels {
    fn dims(&self) -> (usize, usize, usize) {
        match self {
            Pixels::U8(r) => (r.width(), r.height(), r.channels()),
            Pixels::U16(r) => (r.width(), r.height(), r.channels()),
            Pixels::F32(r) => (r.width(), r.height(), r.channels()),
        }
    }
    fn type_name(&self) -> &'static str {
        match self {
            Pixels::U8(_) => "u8",
            Pixels::U16(_) => "u16",
            Pixels::F32(_) => "f32",
        }
    }
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let total = Instant::now();
    if args.input.is_dir() || args.input.file_name().is_some_and(|n| n == "panorama.xml") {
        return run_panorama(&args, out, total);
    }
    if !args.input.is_file() {
        return Err(fail(
            "CONVERT_NOT_FOUND",
            format!("{}: no such file; check the input path", args.input.display()),
        ));
    }
    if args.depth_jump.is_nan() || args.depth_jump < 0.0 {
        return Err(fail(
            "CONVERT_USAGE",
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
        return Err(fail("CONVERT_USAGE", format!("{}: {what}", args.output.display())));
    }
    if layer {
        return run_layer(&args, opts, out, total);
    }

    let t = Instant::now();
    let pixels = decode(&args.input)?;
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
    encode(&args.output, &converted)?;
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
        To::Cube => {
            let n = args.face_size.unwrap_or(match in_face {
                Some(n) => n,
                None => w / 4,
            });
            (Canvas::Cube(args.layout), n)
        }
        To::Equirect => {
            let width = args.width.unwrap_or(match in_face {
                Some(n) => 4 * n,
                None => w,
            });
            if width == 0 || width % 2 != 0 {
                return Err(fail("CONVERT_USAGE", format!("--width {width} must be even and positive")));
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
            "CONVERT_TOO_LARGE",
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
    let t = Instant::now();
    layer_io::write_exr(&args.output, &converted, &WriteOptions::default())?;
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
            output: (converted.width, converted.height),
            channels: converted.channels.len(),
            timings: [decode_ms, resample_ms, encode_ms, ms(total)],
        },
    );
    Ok(0)
}

/// Convert a whole panorama: every layer (packed ones read as full canvases) to the other mapping,
/// written as a panorama (sparse layers packed again) with the manifest's mapping changed. A POMC
/// cube map is in the canonical layout.
fn run_panorama(args: &Args, out: Output, total: Instant) -> Result<u8, Failure> {
    use pomc::manifest::MappingKind;
    use pomc::panorama::{self, Panorama, SaveOptions};
    if args.layout != CubeLayout::Canonical || args.in_layout.is_some_and(|l| l != CubeLayout::Canonical) {
        return Err(fail(
            "CONVERT_USAGE",
            "a POMC cube map is in the canonical layout: --layout and --in-layout do not apply to panoramas"
                .into(),
        ));
    }
    let pano = Panorama::open(&args.input)?;
    let target = match args.to {
        To::Cube => MappingKind::Cube,
        To::Equirect => MappingKind::LatLong,
    };
    if pano.manifest.mapping.kind == target {
        return Err(fail(
            "CONVERT_USAGE",
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

/// Decode a plain EXR through the `exr` crate (any channel set: RGB(A), Y(A) or a single channel), after
/// checking the header's size.
fn decode_exr(path: &Path) -> Result<Pixels, Failure> {
    use exr::prelude::*;
    let limits = ReadLimits::default();
    let bad = |e: exr::error::Error| {
        fail("CONVERT_UNREADABLE", format!("{}: cannot decode EXR ({e})", path.display()))
    };
    let meta = MetaData::read_from_file(path, false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| fail("CONVERT_UNREADABLE", format!("{}: EXR without parts", path.display())))?;
    let (w, h) = (header.layer_size.width(), header.layer_size.height());
    if w.max(h) > limits.max_dimension || (w as u64 * h as u64) > limits.max_pixels {
        return Err(fail(
            "CONVERT_TOO_LARGE",
            format!(
                "{}: declares {w}x{h} pixels, beyond the reader limit; refused before decoding",
                path.display()
            ),
        ));
    }
    let image = read_first_flat_layer_from_file(path).map_err(bad)?;
    let chans = &image.layer_data.channel_data.list;
    let find = |n: &str| chans.iter().position(|c| c.name.to_string() == n);
    let order: Vec<usize> = match (find("R"), find("G"), find("B"), find("Y"), find("A")) {
        (Some(r), Some(g), Some(b), _, a) => [Some(r), Some(g), Some(b), a].into_iter().flatten().collect(),
        (_, _, _, Some(y), a) => [Some(y), a].into_iter().flatten().collect(),
        _ => (0..chans.len().min(4)).collect(),
    };
    if order.is_empty() {
        return Err(fail("CONVERT_UNREADABLE", format!("{}: EXR without channels", path.display())));
    }
    let (w, h) = (image.layer_data.size.width(), image.layer_data.size.height());
    let ch = order.len();
    let mut data = vec![0.0f32; w * h * ch];
    for (c, &k) in order.iter().enumerate() {
        for (i, v) in chans[k].sample_data.values_as_f32().enumerate().take(w * h) {
            data[i * ch + c] = v;
        }
    }
    Ok(Pixels::F32(Raster::from_vec(w, h, ch, data).expect("sizes from the decoder")))
}

/// Decode a plain image, refusing oversized ones from their header.
fn decode(path: &Path) -> Result<Pixels, Failure> {
    if extension(path) == "exr" {
        return decode_exr(path);
    }
    let limits = ReadLimits::default();
    let unreadable = |e: image::ImageError| {
        let code = match e {
            image::ImageError::Limits(_) => "CONVERT_TOO_LARGE",
            image::ImageError::Unsupported(_) => "CONVERT_UNSUPPORTED",
            _ => "CONVERT_UNREADABLE",
        };
        fail(
            code,
            format!("{}: cannot decode ({e}); supported inputs are PNG, JPEG, EXR and HDR", path.display()),
        )
    };
    let mut reader = ImageReader::open(path)
        .map_err(|e| fail("CONVERT_IO", format!("{}: {e}", path.display())))?
        .with_guessed_format()
        .map_err(|e| fail("CONVERT_IO", format!("{}: {e}", path.display())))?;
    let mut l = Limits::default();
    l.max_image_width = Some(limits.max_dimension as u32);
    l.max_image_height = Some(limits.max_dimension as u32);
    // Decoded f32 RGBA of the largest accepted canvas.
    l.max_alloc = Some(limits.max_pixels * 16);
    reader.limits(l);
    let img = reader.decode().map_err(unreadable)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if (w as u64 * h as u64) > limits.max_pixels {
        return Err(fail(
            "CONVERT_TOO_LARGE",
            format!("{}: {w}x{h} pixels is beyond the {} pixel limit", path.display(), limits.max_pixels),
        ));
    }
    let r = |c: usize, v: Vec<u8>| Raster::from_vec(w, h, c, v).expect("decoder sizes");
    let r16 = |c: usize, v: Vec<u16>| Raster::from_vec(w, h, c, v).expect("decoder sizes");
    let rf = |c: usize, v: Vec<f32>| Raster::from_vec(w, h, c, v).expect("decoder sizes");
    Ok(match img {
        DynamicImage::ImageLuma8(b) => Pixels::U8(r(1, b.into_raw())),
        DynamicImage::ImageLumaA8(b) => Pixels::U8(r(2, b.into_raw())),
        DynamicImage::ImageRgb8(b) => Pixels::U8(r(3, b.into_raw())),
        DynamicImage::ImageRgba8(b) => Pixels::U8(r(4, b.into_raw())),
        DynamicImage::ImageLuma16(b) => Pixels::U16(r16(1, b.into_raw())),
        DynamicImage::ImageLumaA16(b) => Pixels::U16(r16(2, b.into_raw())),
        DynamicImage::ImageRgb16(b) => Pixels::U16(r16(3, b.into_raw())),
        DynamicImage::ImageRgba16(b) => Pixels::U16(r16(4, b.into_raw())),
        DynamicImage::ImageRgb32F(b) => Pixels::F32(rf(3, b.into_raw())),
        other => Pixels::F32(rf(4, other.into_rgba32f().into_raw())),
    })
}

fn to_u8(p: &Pixels) -> Raster<u8> {
    match p {
        Pixels::U8(r) => r.clone(),
        Pixels::U16(r) => map(r, |v| (v >> 8) as u8),
        Pixels::F32(r) => map(r, |v| u8::from_f32(v.clamp(0.0, 1.0) * 255.0)),
    }
}

fn to_f32(p: &Pixels) -> Raster<f32> {
    match p {
        Pixels::U8(r) => map(r, |v| v as f32 / 255.0),
        Pixels::U16(r) => map(r, |v| v as f32 / 65535.0),
        Pixels::F32(r) => r.clone(),
    }
}

fn map<A: Copy, B: Copy>(r: &Raster<A>, f: impl Fn(A) -> B) -> Raster<B> {
    let data = r.data().iter().map(|&v| f(v)).collect();
    Raster::from_vec(r.width(), r.height(), r.channels(), data).expect("same size")
}

/// Drop alpha (formats without it) keeping the first `keep` channels.
fn keep_channels<T: Copy>(r: Raster<T>, keep: usize) -> Raster<T> {
    let ch = r.channels();
    if ch <= keep {
        return r;
    }
    let data = r.data().chunks(ch).flat_map(|p| p[..keep].iter().copied()).collect();
    Raster::from_vec(r.width(), r.height(), keep, data).expect("same size")
}

fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

fn encode(path: &Path, p: &Pixels) -> Result<(), Failure> {
    let bytes = match extension(path).as_str() {
        "png" => match p {
            Pixels::U16(r) => png_bytes16(r),
            other => png_bytes8(&to_u8(other)),
        },
        "jpg" | "jpeg" => {
            let r = to_u8(p);
            let r = match r.channels() {
                2 => keep_channels(r, 1),
                4 => keep_channels(r, 3),
                _ => r,
            };
            let color = if r.channels() == 1 { ExtendedColorType::L8 } else { ExtendedColorType::Rgb8 };
            let mut buf = Vec::new();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 92)
                .write_image(r.data(), r.width() as u32, r.height() as u32, color)
                .map(|_| buf)
        }
        "hdr" => {
            let r = to_f32(p);
            let r = match r.channels() {
                1 | 2 => {
                    let data = r.data().chunks(r.channels()).flat_map(|v| [v[0]; 3]).collect();
                    Raster::from_vec(r.width(), r.height(), 3, data).expect("same size")
                }
                _ => keep_channels(r, 3),
            };
            let mut buf = Vec::new();
            image::codecs::hdr::HdrEncoder::new(&mut buf)
                .write_image(
                    bytemuck_f32(r.data()),
                    r.width() as u32,
                    r.height() as u32,
                    ExtendedColorType::Rgb32F,
                )
                .map(|_| buf)
        }
        "exr" => return write_exr(path, &to_f32(p)),
        _ => {
            return Err(fail(
                "CONVERT_USAGE",
                format!(
                    "{}: unknown output format; use a .png, .jpg, .exr or .hdr extension",
                    path.display()
                ),
            ))
        }
    }
    .map_err(|e| fail("CONVERT_ENCODE", format!("{}: cannot encode ({e})", path.display())))?;
    pomc::fsutil::write_bytes_atomic(path, &bytes)?;
    Ok(())
}

fn bytemuck_f32(v: &[f32]) -> &[u8] {
    // SAFETY: f32 has no padding or invalid bit patterns; u8 has alignment 1.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), std::mem::size_of_val(v)) }
}

fn color8(ch: usize) -> ExtendedColorType {
    [ExtendedColorType::L8, ExtendedColorType::La8, ExtendedColorType::Rgb8, ExtendedColorType::Rgba8][ch - 1]
}

/// PNG with fast settings: fdeflate-based `Fast` compression and the `Up` filter (cheap, and good on
/// resampled photographs and synthetic images alike).
fn png_bytes8(r: &Raster<u8>) -> Result<Vec<u8>, image::ImageError> {
    let mut buf = Vec::with_capacity(r.data().len() / 4);
    PngEncoder::new_with_quality(&mut buf, CompressionType::Fast, FilterType::Up).write_image(
        r.data(),
        r.width() as u32,
        r.height() as u32,
        color8(r.channels()),
    )?;
    Ok(buf)
}

fn png_bytes16(r: &Raster<u16>) -> Result<Vec<u8>, image::ImageError> {
    let color = [
        ExtendedColorType::L16,
        ExtendedColorType::La16,
        ExtendedColorType::Rgb16,
        ExtendedColorType::Rgba16,
    ][r.channels() - 1];
    let bytes: Vec<u8> = r.data().iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut buf = Vec::new();
    PngEncoder::new_with_quality(&mut buf, CompressionType::Fast, FilterType::Up).write_image(
        &bytes,
        r.width() as u32,
        r.height() as u32,
        color,
    )?;
    Ok(buf)
}

/// Plain EXR output through the `exr` crate (any channel count: Y, YA, RGB, RGBA), ZIP compressed.
fn write_exr(path: &Path, r: &Raster<f32>) -> Result<(), Failure> {
    use exr::prelude::*;
    let names: &[&str] = match r.channels() {
        1 => &["Y"],
        2 => &["Y", "A"],
        3 => &["R", "G", "B"],
        _ => &["R", "G", "B", "A"],
    };
    let ch = r.channels();
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
        .iter()
        .enumerate()
        .map(|(c, n)| {
            let data: Vec<f32> = r.data().iter().skip(c).step_by(ch).copied().collect();
            AnyChannel::new(*n, FlatSamples::F32(data))
        })
        .collect();
    let layer = Layer::new(
        (r.width(), r.height()),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut cursor = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut cursor)
        .map_err(|e| fail("CONVERT_ENCODE", format!("{}: cannot encode EXR ({e})", path.display())))?;
    pomc::fsutil::write_atomic(path, |w| w.write_all(cursor.get_ref()))?;
    Ok(())
}
