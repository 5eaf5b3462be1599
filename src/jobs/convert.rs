//! Whole files between mappings (spec §3.6), the job `pomc convert` runs: a plain image (PNG,
//! JPEG, EXR, HDR; 8-bit, 16-bit or float, kept as it is), a layer EXR (depth-aware), or a whole
//! panorama (every layer, packed ones unpacked first and packed again). Sampling is
//! [`crate::resample`]'s; this module decides canvases and sizes, reads, writes and times.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::image_io::{self, Pixels};
use crate::layer::LayerImage;
use crate::layer_io::{self, ReadLimits, WriteOptions};
use crate::mapping::layout::{CubeLayout, LayoutError};
use crate::mapping::MappingKind;
use crate::panorama::{self, Panorama, SaveOptions};
use crate::resample::{self, Canvas, Filter, ResampleError, SampleOptions};

/// How [`convert_file`] converts; `Default` is what `pomc convert` does without options.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvertSettings {
    /// Cube face size in pixels (`None`: a quarter of the equirect width, ffmpeg's default, or
    /// the input's face size).
    pub face_size: Option<usize>,
    /// Equirect width in pixels, even (`None`: four face sizes, or the input width).
    pub width: Option<usize>,
    /// Reconstruction filter.
    pub filter: Filter,
    /// Cube-map layout of the cube side.
    pub layout: CubeLayout,
    /// Layout of a cube-map input, when it differs from [`ConvertSettings::layout`].
    pub in_layout: Option<CubeLayout>,
    /// The image holds depth (channel 0): never blend across depth discontinuities or with
    /// outside (negative) / unknown (NaN) pixels. Layer EXRs always get this for `Z`.
    pub depth: bool,
    /// Largest relative depth difference between the taps of a filtered pixel.
    pub depth_jump: f32,
}

impl Default for ConvertSettings {
    fn default() -> Self {
        ConvertSettings {
            face_size: None,
            width: None,
            filter: Filter::Bilinear,
            layout: CubeLayout::Canonical,
            in_layout: None,
            depth: false,
            depth_jump: SampleOptions::default().max_relative_jump,
        }
    }
}

/// What [`convert_file`] converted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Converted {
    /// A plain image.
    Image,
    /// A layer EXR.
    Layer,
    /// A whole panorama.
    Panorama,
}

impl Converted {
    /// `image`, `layer` or `panorama`, as in `pomc convert --json`.
    pub fn name(self) -> &'static str {
        match self {
            Converted::Image => "image",
            Converted::Layer => "layer",
            Converted::Panorama => "panorama",
        }
    }
}

/// What [`convert_file`] did, with its timings in milliseconds. It serialises to the `--json` schema
/// of `pomc convert` (one shape for an image or a layer, one for a panorama).
#[derive(Clone, Debug)]
pub struct ConvertReport {
    /// Image, layer or panorama.
    pub kind: Converted,
    /// The input converted.
    pub input: PathBuf,
    /// The file or directory written.
    pub output: PathBuf,
    /// The reconstruction filter used.
    pub filter: Filter,
    /// Sizes of the input and output files, bytes (0 for a panorama).
    pub bytes: (u64, u64),
    /// Worker threads.
    pub threads: usize,
    /// `u8`, `u16` or `f32`: the samples, kept as they were.
    pub sample_type: &'static str,
    /// Source canvas.
    pub from: Canvas,
    /// Target canvas.
    pub to: Canvas,
    /// Input width and height (a panorama's last layer).
    pub input_size: (usize, usize),
    /// Output width and height (a panorama's last layer).
    pub output_size: (usize, usize),
    /// Channels of the image or layer (0 for a panorama).
    pub channels: usize,
    /// Layers converted (1 for an image or a layer).
    pub layers: usize,
    /// Decoding, ms (0 for a panorama: read, resampled and written one layer at a time).
    pub decode_ms: f64,
    /// Resampling, ms.
    pub resample_ms: f64,
    /// Encoding and writing, ms.
    pub encode_ms: f64,
    /// The whole call, ms.
    pub total_ms: f64,
}

/// Progress of [`convert_file_with_progress`]: how many steps (rows of an image, layers of a
/// panorama) there are, then each done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConvertProgress {
    /// The number of steps, once, before the first.
    Steps(u64),
    /// This many more steps done.
    Done(u64),
}

/// Errors of [`convert_file`] beyond those of reading, sampling and writing.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    /// The input does not exist.
    #[error("{}: no such file; check the input path", .0.display())]
    NotFound(PathBuf),
    /// The settings do not fit the input or the output (the message says which and the fix).
    #[error("{0}")]
    Usage(String),
    /// The output would be larger than readers accept.
    #[error("{}: an output of {width}x{height} pixels is outside the supported range (1..={max_side} per side, {max_pixels} pixels); choose a smaller --face-size/--width", path.display())]
    TooLarge {
        /// The output path.
        path: PathBuf,
        /// Output width, pixels.
        width: usize,
        /// Output height, pixels.
        height: usize,
        /// Largest side readers accept.
        max_side: usize,
        /// Most pixels readers accept.
        max_pixels: u64,
    },
    /// A non-2:1 input is no cube map in the layout given.
    #[error("{}: {source}; a 2:1 image is read as an equirect, other shapes as cube maps (choose the layout with --in-layout)", path.display())]
    NotACube {
        /// The input path.
        path: PathBuf,
        /// Why its shape fits no face size.
        source: LayoutError,
    },
    /// Sampling refused the input.
    #[error("{}: {source}", path.display())]
    Resample {
        /// The input path.
        path: PathBuf,
        /// What sampling said.
        source: ResampleError,
    },
}

crate::codes::error_codes! {
    ConvertError:
        NotFound CONVERT_NOT_FOUND,
        Usage CONVERT_USAGE,
        TooLarge CONVERT_TOO_LARGE;
        from NotACube.source, Resample.source
}

fn ms(t: Instant) -> f64 {
    (t.elapsed().as_secs_f64() * 1e4).round() / 10.0
}

/// Convert `input` (an image, a layer EXR, or a panorama directory or `panorama.xml`) to the
/// mapping `to`, written to `output` (a directory for a panorama; the format follows the
/// extension). Float images written to PNG/JPEG are clamped to [0, 1]; 16-bit PNGs stay 16-bit.
///
/// ```
/// use pomc::prelude::*;
/// let out = std::env::temp_dir().join(format!("pomc-doc-convert-{}", std::process::id()));
/// let settings = ConvertSettings { face_size: Some(64), ..Default::default() };
/// let report = convert_file("fixtures/data/room-equirect".as_ref(), &out, MappingKind::Cube3x2, &settings)?;
/// assert_eq!(report.output_size, (192, 128));
/// assert!(validate(&out, &ValidateSettings::default())?.valid);
/// # std::fs::remove_dir_all(&out).ok();
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn convert_file(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
) -> crate::Result<ConvertReport> {
    convert_file_with_progress(input, output, to, s, &|_| {})
}

/// [`convert_file`], telling `progress` how many steps there are and each as it is done.
pub fn convert_file_with_progress(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    progress: &(dyn Fn(ConvertProgress) + Sync),
) -> crate::Result<ConvertReport> {
    let mut report = convert_any(input, output, to, s, progress)?;
    if report.kind != Converted::Panorama {
        let size = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
        report.bytes = (size(input), size(output));
    }
    report.input = input.into();
    report.output = output.into();
    report.filter = s.filter;
    report.threads = rayon::current_num_threads();
    Ok(report)
}

fn convert_any(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    progress: &(dyn Fn(ConvertProgress) + Sync),
) -> crate::Result<ConvertReport> {
    let total = Instant::now();
    if input.is_dir() || input.file_name().is_some_and(|n| n == "panorama.xml") {
        return convert_panorama(input, output, to, s, progress, total);
    }
    if !input.is_file() {
        return Err(ConvertError::NotFound(input.to_path_buf()).into());
    }
    if s.depth_jump.is_nan() || s.depth_jump < 0.0 {
        return Err(usage(format!("--depth-jump {} must be a non-negative number", s.depth_jump)));
    }
    let layer = layer_io::is_layer_exr(input);
    let ext = image_io::extension(output);
    let known = if layer { ["exr"].as_slice() } else { ["png", "jpg", "jpeg", "exr", "hdr"].as_slice() };
    if !known.contains(&ext.as_str()) {
        let what = if layer {
            "a layer converts to a layer EXR; use an .exr output"
        } else {
            "unknown output format; use a .png, .jpg, .exr or .hdr extension"
        };
        return Err(usage(format!("{}: {what}", output.display())));
    }
    let opts = SampleOptions {
        filter: s.filter,
        depth_channel: s.depth.then_some(0),
        coverage_channel: None,
        max_relative_jump: s.depth_jump,
    };
    if layer {
        convert_layer_file(input, output, to, s, &opts, total)
    } else {
        convert_image(input, output, to, s, &opts, progress, total)
    }
}

fn usage(message: String) -> crate::Error {
    ConvertError::Usage(message).into()
}

fn convert_image(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    opts: &SampleOptions,
    progress: &(dyn Fn(ConvertProgress) + Sync),
    total: Instant,
) -> crate::Result<ConvertReport> {
    let t = Instant::now();
    let pixels = image_io::decode(input)?;
    let decode_ms = ms(t);
    let (w, h, channels) = pixels.dims();
    let (from, target, size) = plan(input, output, to, s, w, h)?;

    let t = Instant::now();
    let rows = match target {
        Canvas::Equirect => size / 2,
        Canvas::Cube(l) => l.canvas_size(size).1,
    };
    progress(ConvertProgress::Steps(rows as u64));
    let tick = |n: usize| progress(ConvertProgress::Done(n as u64));
    let failed = |source| ConvertError::Resample { path: input.to_path_buf(), source };
    let converted = match &pixels {
        Pixels::U8(r) => {
            Pixels::U8(resample::convert_with_progress(r, from, target, size, opts, &tick).map_err(failed)?)
        }
        Pixels::U16(r) => {
            Pixels::U16(resample::convert_with_progress(r, from, target, size, opts, &tick).map_err(failed)?)
        }
        Pixels::F32(r) => {
            Pixels::F32(resample::convert_with_progress(r, from, target, size, opts, &tick).map_err(failed)?)
        }
    };
    drop(pixels);
    let resample_ms = ms(t);

    let t = Instant::now();
    image_io::encode(output, &converted)?;
    let (ow, oh, _) = converted.dims();
    let canvases = (from, target);
    let mut r =
        one_file(Converted::Image, canvases, ((w, h), (ow, oh)), channels, [decode_ms, resample_ms, ms(t)]);
    r.sample_type = converted.type_name();
    r.total_ms = ms(total);
    Ok(r)
}

fn convert_layer_file(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    opts: &SampleOptions,
    total: Instant,
) -> crate::Result<ConvertReport> {
    let t = Instant::now();
    let layer = layer_io::read_exr(input, &ReadLimits::default())?;
    let decode_ms = ms(t);
    let (from, target, size) = plan(input, output, to, s, layer.width, layer.height)?;
    let t = Instant::now();
    let converted = resample::convert_layer(&layer, from, target, size, opts)
        .map_err(|source| ConvertError::Resample { path: input.to_path_buf(), source })?;
    let resample_ms = ms(t);
    let (output_size, channels) = ((converted.width, converted.height), converted.channels.len());
    let t = Instant::now();
    layer_io::write_exr_owned(output, converted, &WriteOptions::default())?;
    let sizes = ((layer.width, layer.height), output_size);
    let mut r = one_file(Converted::Layer, (from, target), sizes, channels, [decode_ms, resample_ms, ms(t)]);
    r.total_ms = ms(total);
    Ok(r)
}

/// The report of one image or layer: decode, resample and encode times; `f32` samples.
fn one_file(
    kind: Converted,
    (from, to): (Canvas, Canvas),
    (input_size, output_size): ((usize, usize), (usize, usize)),
    channels: usize,
    [decode_ms, resample_ms, encode_ms]: [f64; 3],
) -> ConvertReport {
    ConvertReport {
        kind,
        input: PathBuf::new(),
        output: PathBuf::new(),
        filter: Filter::default(),
        bytes: (0, 0),
        threads: 0,
        sample_type: "f32",
        from,
        to,
        input_size,
        output_size,
        channels,
        layers: 1,
        decode_ms,
        resample_ms,
        encode_ms,
        total_ms: decode_ms + resample_ms + encode_ms,
    }
}

/// Source canvas, target canvas and target size (equirect width or face size) of a `w × h` input.
fn plan(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    w: usize,
    h: usize,
) -> Result<(Canvas, Canvas, usize), ConvertError> {
    let in_layout = s.in_layout.unwrap_or(s.layout);
    let from = if w == 2 * h { Canvas::Equirect } else { Canvas::Cube(in_layout) };
    let in_face = match from {
        Canvas::Equirect => None,
        Canvas::Cube(l) => Some(
            l.face_size(w, h)
                .map_err(|source| ConvertError::NotACube { path: input.to_path_buf(), source })?,
        ),
    };
    let (target, size) = match to {
        MappingKind::Cube3x2 => (Canvas::Cube(s.layout), s.face_size.unwrap_or(in_face.unwrap_or(w / 4))),
        MappingKind::Equirect => {
            let width = s.width.unwrap_or(in_face.map_or(w, |n| 4 * n));
            if width == 0 || width % 2 != 0 {
                return Err(ConvertError::Usage(format!("--width {width} must be even and positive")));
            }
            (Canvas::Equirect, width)
        }
    };
    let limits = ReadLimits::default();
    let (ow, oh) = match target {
        Canvas::Equirect => (size, size / 2),
        Canvas::Cube(l) => l.canvas_size(size),
    };
    if size == 0 || ow.max(oh) > limits.max_dimension || (ow as u64 * oh as u64) > limits.max_pixels {
        return Err(ConvertError::TooLarge {
            path: output.to_path_buf(),
            width: ow,
            height: oh,
            max_side: limits.max_dimension,
            max_pixels: limits.max_pixels,
        });
    }
    Ok((from, target, size))
}

/// Every layer (packed ones read as full canvases) to the other mapping, written as a panorama
/// (sparse layers packed again) with the manifest's mapping changed; one layer in memory at a
/// time. A POMC cube map is in the canonical layout.
fn convert_panorama(
    input: &Path,
    output: &Path,
    to: MappingKind,
    s: &ConvertSettings,
    progress: &(dyn Fn(ConvertProgress) + Sync),
    total: Instant,
) -> crate::Result<ConvertReport> {
    if s.layout != CubeLayout::Canonical || s.in_layout.is_some_and(|l| l != CubeLayout::Canonical) {
        return Err(usage(
            "a POMC cube map is in the canonical layout: --layout and --in-layout do not apply to panoramas"
                .into(),
        ));
    }
    let pano = Panorama::open(input)?;
    let from_kind = pano.manifest.mapping.kind;
    if from_kind == to {
        return Err(usage(format!("{}: is already a {} panorama", input.display(), to.primary_name())));
    }
    // Depth (`Z`) is never blended across discontinuities: layers get the depth treatment.
    let opts = SampleOptions {
        filter: s.filter,
        depth_channel: None,
        coverage_channel: None,
        max_relative_jump: s.depth_jump,
    };
    let count = pano.manifest.layers.len();
    progress(ConvertProgress::Steps(count as u64));
    let sizes = std::sync::Mutex::new(((0, 0), (0, 0)));
    let mut manifest = pano.manifest.clone();
    manifest.mapping.kind = to;
    for decl in &mut manifest.layers {
        decl.packing = None;
    }
    let convert = |k: usize| -> crate::Result<LayerImage> {
        let layer = pano.read_layer(k, &ReadLimits::default())?;
        let (from, target, size) = plan(input, output, to, s, layer.width, layer.height)?;
        let converted = resample::convert_layer(&layer, from, target, size, &opts)?;
        if let Ok(mut sz) = sizes.lock() {
            *sz = ((layer.width, layer.height), (converted.width, converted.height));
        }
        progress(ConvertProgress::Done(1));
        Ok(converted)
    };
    panorama::write_panorama_with(output, &manifest, &convert, &SaveOptions::default())?;
    let (input_size, output_size) = sizes.into_inner().unwrap_or_default();
    let canvas = |k: MappingKind| match k {
        MappingKind::Equirect => Canvas::Equirect,
        MappingKind::Cube3x2 => Canvas::Cube(CubeLayout::Canonical),
    };
    Ok(ConvertReport {
        kind: Converted::Panorama,
        input: PathBuf::new(),
        output: PathBuf::new(),
        filter: Filter::default(),
        bytes: (0, 0),
        threads: 0,
        sample_type: "f32",
        from: canvas(from_kind),
        to: canvas(to),
        input_size,
        output_size,
        channels: 0,
        layers: count,
        decode_ms: 0.0,
        resample_ms: 0.0,
        encode_ms: 0.0,
        total_ms: ms(total),
    })
}

fn canvas_name(c: Canvas) -> String {
    match c {
        Canvas::Equirect => "equirect".into(),
        Canvas::Cube(l) => format!("cube ({l})"),
    }
}

fn kind_name(c: Canvas) -> &'static str {
    match c {
        Canvas::Equirect => MappingKind::Equirect.primary_name(),
        Canvas::Cube(_) => MappingKind::Cube3x2.primary_name(),
    }
}

impl serde::Serialize for ConvertReport {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        let ((iw, ih), (ow, oh)) = (self.input_size, self.output_size);
        let value = if self.kind == Converted::Panorama {
            serde_json::json!({
                "kind": "panorama", "input": self.input, "output": self.output,
                "to": kind_name(self.to), "layers": self.layers,
                "input_size": [iw, ih], "output_size": [ow, oh],
                "total_ms": self.total_ms,
            })
        } else {
            serde_json::json!({
                "kind": self.kind.name(),
                "input": self.input, "output": self.output,
                "from": canvas_name(self.from), "to": canvas_name(self.to),
                "interp": self.filter.name(),
                "input_size": [iw, ih], "output_size": [ow, oh],
                "channels": self.channels, "sample_type": self.sample_type,
                "input_bytes": self.bytes.0, "output_bytes": self.bytes.1,
                "threads": self.threads,
                "timings_ms": {
                    "decode": self.decode_ms, "resample": self.resample_ms, "encode": self.encode_ms,
                    "total": self.total_ms,
                },
            })
        };
        value.serialize(ser)
    }
}

impl ConvertReport {
    /// The command's human line.
    pub fn summary(&self) -> String {
        let ((iw, ih), (ow, oh)) = (self.input_size, self.output_size);
        if self.kind == Converted::Panorama {
            return format!(
                "converted a panorama of {} layer(s) {iw}x{ih} -> {} {ow}x{oh} in {:.0} ms -> {}",
                self.layers,
                kind_name(self.to),
                self.total_ms,
                self.output.display()
            );
        }
        format!(
            "{} {iw}x{ih} {} -> {} {ow}x{oh} {} ({}): decode {} ms, resample {} ms, encode {} ms, total {} ms",
            self.input.display(),
            canvas_name(self.from),
            self.output.display(),
            canvas_name(self.to),
            self.filter,
            self.decode_ms,
            self.resample_ms,
            self.encode_ms,
            self.total_ms
        )
    }
}
