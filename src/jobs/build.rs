//! `pomc build`: a layered panorama from a colour and a depth image, read, prepared, layered and
//! written.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use serde::Serialize;

use crate::colour::ColourSpace;
use crate::input::{self, Convention};
use crate::layer::LayerImage;
use crate::layer_io::ReadLimits;
use crate::layering::{self, BuildOptions, BuildReport};
use crate::manifest::{Manifest, Transform};
use crate::panorama::{self, SaveOptions};
use crate::prepare::DepthEncoding;
use crate::prepare::{self, DepthSamples, PrepareOptions, PrepareReport, SampleFormat};

/// Everything `pomc build` takes besides its input and output paths.
#[derive(Clone, Debug, Default)]
pub struct BuildSettings {
    /// Encoding of 8/16-bit colour (`--colour-space`).
    pub colour_space: ColourSpace,
    /// How depth is stored (`--preset`, `--depth-scale`, `--depth-invalid`, `--depth-kind`,
    /// `--depth-range`, `--camera-height`).
    pub depth: DepthEncoding,
    /// How the depth is prepared for layering (`--refine`, `--unknown-depth`).
    pub prepare: PrepareOptions,
    /// Normals image (`--normals-in`).
    pub normals_in: Option<PathBuf>,
    /// Azimuth convention of the input (`--convention`).
    pub convention: Convention,
    /// Panorama centre in the world (`--center`).
    pub center: Option<DVec3>,
    /// The build itself: freedom radius, edges, fill (the other `build` options).
    pub options: BuildOptions,
    /// How layers are stored (`--no-pack`).
    pub save: SaveOptions,
    /// Input size limits (`--max-pixels`).
    pub limits: ReadLimits,
}

/// What [`build_panorama`] wrote and measured: `pomc build --json` prints it, Python's
/// `build_files` returns it (docs/api.md has the schema).
#[derive(Clone, Debug, Serialize)]
pub struct BuildSummary {
    /// The manifest as written (canvas sizes and packing filled in).
    #[serde(skip)]
    pub manifest: Manifest,
    /// Per-layer figures of the build (its `stages` start with `prepare`).
    #[serde(flatten)]
    pub report: BuildReport,
    /// The panorama directory written.
    pub output: PathBuf,
    /// Whether each layer, in manifest order, was written patch-packed.
    pub packed: Vec<bool>,
    /// What the depth preparation found and did.
    pub prepare: PrepareReport,
    /// Seconds spent reading the input images (colour, depth, normals).
    pub read_s: f64,
    /// Seconds spent building the layers in memory.
    pub build_s: f64,
    /// Seconds spent writing the layer files and the manifest.
    pub write_s: f64,
    /// Seconds for the whole job, reading to writing.
    pub total_s: f64,
}

/// Build a layered panorama from a colour and a depth image and write it into `output`, as
/// `pomc build` does.
///
/// ```
/// use pomc::prelude::*;
/// let (dir, out) = (std::path::Path::new("fixtures/data/room-rgbd"), std::env::temp_dir().join("pomc-doc-build"));
/// let mut settings = BuildSettings::default();
/// settings.options.freedom_radius = 0.5;
/// let built = build_panorama(&dir.join("colour.png"), &dir.join("depth.exr"), &out, &settings)?;
/// assert!(built.manifest.layers.len() >= 2, "background and objects");
/// assert!(validate(&out, &ValidateSettings::default())?.valid);
/// # std::fs::remove_dir_all(&out).ok();
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn build_panorama(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
) -> crate::Result<BuildSummary> {
    build_panorama_with_progress(colour, depth, output, s, &|_| {})
}

/// The name of the depth preparation stage in progress and timings.
pub const PREPARE_STAGE: &str = "prepare";

/// Every stage [`build_panorama_with_progress`] names, in order: `prepare`, the build's
/// ([`layering::stages`]), `writing` (a progress bar's length).
pub fn build_stages(s: &BuildSettings) -> Vec<&'static str> {
    let mut v = vec![PREPARE_STAGE];
    v.extend(layering::stages(&s.options));
    v.push(WRITING_STAGE);
    v
}

/// The name of the writing stage in progress.
pub const WRITING_STAGE: &str = "writing";

/// [`build_panorama`], calling `progress` with each stage's name as it starts (`prepare`, the
/// build's stages, then `writing`).
pub fn build_panorama_with_progress(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuildSummary> {
    let start = Instant::now();
    let files = input::read(colour, s.colour_space, depth, s.normals_in.as_deref(), &s.limits)?;
    let read_s = start.elapsed().as_secs_f64();
    let t = Instant::now();
    let (rgbd, prepare, prepare_s) = prepare_stage(files, depth, s, progress)?;
    let kind = rgbd.mapping.kind();
    let layered = layering::layer(rgbd, &layering_options(s, &prepare), progress)?;
    let build_s = t.elapsed().as_secs_f64();
    progress(WRITING_STAGE);
    let t = Instant::now();
    // Each layer's image is made as it is written (its time counts in `write_s`): one full
    // canvas in memory at a time.
    let manifest = layered.manifest(kind, s.options.freedom_radius, transforms(s));
    let manifest = panorama::write_panorama_with(output, &manifest, &|k| Ok(layered.image(k)), &s.save)?;
    let write_s = t.elapsed().as_secs_f64();
    let mut report = layered.report;
    report.stages.insert(0, (PREPARE_STAGE, prepare_s));
    let packed = manifest.layers.iter().map(|l| l.packing.is_some()).collect();
    let output = output.to_path_buf();
    let total_s = start.elapsed().as_secs_f64();
    Ok(BuildSummary { manifest, report, output, packed, prepare, read_s, build_s, write_s, total_s })
}

/// A panorama built in memory: its manifest (without canvas sizes or packing yet) and full-canvas
/// layers, in manifest order.
#[derive(Clone, Debug)]
pub struct BuiltPanorama {
    /// The manifest, with no canvas sizes or packing filled in yet.
    pub manifest: Manifest,
    /// Full-canvas layer images, in manifest order.
    pub layers: Vec<LayerImage>,
    /// Per-layer figures of the build.
    pub report: BuildReport,
}

/// Build from an RGB-D panorama already read ([`build_panorama`] without the files).
pub fn build_rgbd(
    rgbd: layering::RgbdInput,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuiltPanorama> {
    let kind = rgbd.mapping.kind();
    let built = layering::build(rgbd, &s.options, progress)?;
    let manifest = layering::manifest(&built, kind, s.options.freedom_radius, transforms(s));
    let layers = built.layers.into_iter().map(|l| l.image).collect();
    Ok(BuiltPanorama { manifest, layers, report: built.report })
}

/// The manifest's transforms of a build: the centre (`--center`), then the input's convention.
fn transforms(s: &BuildSettings) -> Vec<Transform> {
    let mut transforms = Vec::new();
    if let Some(c) = s.center {
        transforms.push(Transform::Translate(c.to_array()));
    }
    transforms.extend(s.convention.transforms());
    transforms
}

/// Build from images in memory: `colour` interleaved RGB and `depth` (stored values, read with
/// `s.depth` as files are: float metres by default), both `width` × `height`.
pub fn build_arrays(
    width: usize,
    height: usize,
    colour: input::ColourSamples,
    depth: &[f32],
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<BuiltPanorama> {
    let name = Path::new("<array>");
    let n = width.saturating_mul(height);
    let colour_len = match colour {
        input::ColourSamples::U8(v) => v.len(),
        input::ColourSamples::U16(v) => v.len(),
        input::ColourSamples::F32(v) => v.len(),
    };
    if colour_len != n.saturating_mul(3) || depth.len() != n {
        return Err(input::InputError::SizeMismatch {
            colour: name.into(),
            cw: width,
            ch: colour_len / width.max(1) / 3,
            depth: name.into(),
            dw: width,
            dh: depth.len() / width.max(1),
        }
        .into());
    }
    s.limits.check(width as u64, height as u64, 4).map_err(|limit| input::InputError::TooLarge {
        path: name.into(),
        width: width as u64,
        height: height as u64,
        limit,
    })?;
    let mapping = input::mapping_for(name, width, height)?;
    let rgb = input::colour_planes(colour, s.colour_space);
    let normals = s
        .normals_in
        .as_deref()
        .map(|p| input::read_normals(p, name, width, height, &s.limits))
        .transpose()?;
    let samples = DepthSamples {
        width,
        height,
        values: depth.to_vec(),
        format: SampleFormat::F32,
        colour_channels: false,
    };
    let files = input::RgbdFiles { mapping, rgb, depth: samples, normals };
    let (rgbd, prepare, prepare_s) = prepare_stage(files, name, s, progress)?;
    let s = BuildSettings { options: layering_options(s, &prepare), ..s.clone() };
    let mut built = build_rgbd(rgbd, &s, progress)?;
    built.report.stages.insert(0, (PREPARE_STAGE, prepare_s));
    Ok(built)
}

/// The layering's options for depth as `prepared`: `s`'s, soft when the depth is not exact.
fn layering_options(s: &BuildSettings, prepared: &PrepareReport) -> BuildOptions {
    let soft_depth = s.options.soft_depth || prepared.inexact();
    BuildOptions { soft_depth, ..s.options.clone() }
}

/// The `prepare` stage: the build's input, what preparing found, and its time (the report's
/// first stage).
fn prepare_stage(
    files: input::RgbdFiles,
    depth: &Path,
    s: &BuildSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<(layering::RgbdInput, PrepareReport, f64)> {
    progress(PREPARE_STAGE);
    let t = Instant::now();
    let (rgbd, report) = prepare_input(files, depth, s)?;
    Ok((rgbd, report, t.elapsed().as_secs_f64()))
}

/// The layering's input from the files as read: the depth prepared as `s` asks (`depth` names
/// the depth file in messages).
pub fn prepare_input(
    files: input::RgbdFiles,
    depth: &Path,
    s: &BuildSettings,
) -> crate::Result<(layering::RgbdInput, PrepareReport)> {
    let prepared =
        prepare::prepare_depth(depth, &files.mapping, &files.rgb, &files.depth, &s.depth, &s.prepare)?;
    let rgbd = layering::RgbdInput {
        mapping: files.mapping,
        rgb: files.rgb,
        depth: prepared.depth,
        normals: files.normals,
    };
    Ok((rgbd, prepared.report))
}
