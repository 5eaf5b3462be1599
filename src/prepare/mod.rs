//! Depth preparation (spec §7.1), the first stage of a build: the depth people have — metric or
//! relative, at any resolution, with holes, noise and soft edges — to the depth layering needs:
//! metres along the ray on the colour's grid, complete, with occlusion edges as real steps on the
//! colour's edges. Exact depth passes through unchanged (bit for bit).
//!
//! Steps: decode (kinds, units, range or floor fit; refuse what cannot be depth), resize onto the
//! colour grid, complete unknown depth, smooth noise, snap soft edges (`docs/build.md`).

mod band;
pub(crate) mod complete;
pub mod decode;
mod mode;
mod ramp;
pub(crate) mod refine;
pub(crate) mod resize;
pub(crate) mod specks;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

pub use decode::{DepthEncoding, DepthKind, KnownDistance, MetricFit, Preset};
pub use refine::EdgeScan;

pub use crate::input::{DepthSamples, SampleFormat};

use crate::mapping::{AnyMapping, Mapping, MappingKind, Neighbours};

crate::choice::choices! {
    /// Whether soft edges are snapped and noise smoothed (`--refine`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
    #[serde(rename_all = "lowercase")]
    pub enum Refine (default Auto) {
        /// Smooth measured noise; settle soft edges as `mode` does when the depth measures soft.
        ///
        /// Depth with sharp edges is left as it is.
        Auto = "auto",
        /// Also snap soft edges onto colour edges (experimental).
        ///
        /// Sharper depth, not yet better layers.
        On = "on",
        /// Smooth measured noise; settle soft steps by a weighted mode filter, soft or not.
        ///
        /// Each in-between pixel takes the most weighted depth within 6 pixels; wider bands are
        /// first cut at their colour edge.
        Mode = "mode",
        /// As `mode`, then short blurred ramps the filter left go to a side (experimental).
        ///
        /// Measured on path-traced scenes: better views from depth blurred σ 3 px, worse from
        /// σ 2 px (docs/build.md, "Short ramps to a side").
        Ramps = "ramps",
        /// Neither smooth nor snap.
        ///
        /// The depth as decoded and resized (holes still completed).
        Off = "off",
    }
}

crate::choice::choices! {
    /// What unknown depth (no measurement) means (`--unknown-depth`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
    #[serde(rename_all = "lowercase")]
    pub enum UnknownDepth (default Complete) {
        /// A surface not measured: completed from the depth around it.
        Complete = "complete",
        /// Unknown regions open to the zenith are the sky (a scan outdoors); the rest is completed.
        ///
        /// The sky is infinitely far, as a scanner sees it: nothing there.
        Sky = "sky",
    }
}

/// Settings of [`prepare_depth`]; the default is what `pomc build` does.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrepareOptions {
    /// Snapping of soft edges and smoothing of noise.
    pub refine: Refine,
    /// What unknown depth means.
    pub unknown: UnknownDepth,
}

/// A finding about the input that did not stop the build.
#[derive(Clone, Debug, Serialize)]
pub struct Warning {
    /// Stable code, e.g. `INPUT_DEPTH_SENTINEL`.
    pub code: &'static str,
    /// What was found and what to do.
    pub message: String,
}

impl Warning {
    pub(crate) fn new(code: &'static str, message: String) -> Self {
        Warning { code, message }
    }
}

/// What [`prepare_depth`] found and did.
#[derive(Clone, Debug, Serialize)]
pub struct PrepareReport {
    /// The depth file's width and height, pixels.
    pub source_size: (usize, usize),
    /// Whether the depth was resampled onto the colour's grid.
    pub resized: bool,
    /// Share of the colour grid's pixels without depth (after resizing).
    pub unknown_share: f64,
    /// Pixels of the depth file whose metric depth is zero or negative: unknown depth.
    pub non_positive_pixels: usize,
    /// Known pixels made unknown as blends of their surface with unknown depth (the rim that
    /// interpolated resizing leaves around holes stored as zero), counted on the depth's own grid.
    pub rim_pixels: usize,
    /// Pixels whose depth was completed.
    pub completed_pixels: usize,
    /// Unknown pixels made the sky (`--unknown-depth sky`).
    pub sky_pixels: usize,
    /// The depth edges measured along rows.
    pub edges: EdgeScan,
    /// Whether soft edges were snapped.
    pub snapped: bool,
    /// Window radius of the snap, pixels.
    pub snap_radius: usize,
    /// Pixels whose depth the snap moved onto a side.
    pub snapped_pixels: usize,
    /// Pixels of specks (small pieces of surface behind their surroundings, cut off from them)
    /// given the depth of the neighbouring surface they share the colour of.
    pub speck_pixels: usize,
    /// Median noise of log depth (a relative standard deviation).
    pub noise: f64,
    /// Whether noise was smoothed.
    pub smoothed: bool,
    /// How relative depth was made metric.
    pub metric: Option<MetricFit>,
    /// Findings that did not stop the build.
    pub warnings: Vec<Warning>,
}

impl PrepareReport {
    /// Whether the depth came soft (its edges measured spread over several pixels) or was
    /// refined: the build then distrusts small pieces of its outlines
    /// ([`crate::layering::BuildOptions::soft_depth`]).
    pub fn soft(&self) -> bool {
        self.edges.is_soft() || self.snapped
    }

    /// Whether the depth is other than exact at full resolution: soft, resampled onto the
    /// colour's grid, completed where unknown, or smoothed. The build then distrusts small pieces
    /// of its outlines ([`crate::layering::BuildOptions::soft_depth`]): resampling and completion
    /// leave in-between depths along edges as a blur does.
    pub fn inexact(&self) -> bool {
        self.soft() || self.resized || self.completed_pixels > 0 || self.rim_pixels > 0 || self.smoothed
    }
}

/// Errors of depth preparation; each names the file and the fix.
#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    /// Integer depth without a unit; `INPUT_DEPTH_SCALE_NEEDED`.
    #[error(
        "{path}: integer depth has no unit; give --depth-scale (metres per stored unit, e.g. 0.001 for \
         millimetres), a dataset --preset (matterport3d, stanford2d3ds, structured3d) or --camera-height H \
         (the unit is fitted to the floor), or store float metres in an OpenEXR; for a map where brighter \
         is nearer give --depth-kind nearness"
    )]
    ScaleNeeded {
        /// The depth file.
        path: PathBuf,
    },
    /// Planar z-depth on an equirect; `INPUT_Z_DEPTH_EQUIRECT`.
    #[error("{path}: z-depth needs a cube-map input (an equirect has no image plane); use --depth-kind ray")]
    ZDepthOnEquirect {
        /// The depth file.
        path: PathBuf,
    },
    /// 8-bit depth given as metric depth; `INPUT_DEPTH_8BIT`.
    #[error(
        "{path}: 8-bit depth holds 256 levels and no unit; if brighter is nearer (three.js, krpano) give \
         --depth-kind nearness with --depth-range NEAR,FAR or --camera-height H; if it is inverse depth \
         give --depth-kind inverse; to read the levels as metric anyway give --depth-scale"
    )]
    EightBit {
        /// The depth file.
        path: PathBuf,
    },
    /// The file cannot be depth; `INPUT_NOT_DEPTH`.
    #[error("{path}: not a depth map: {why}; give the depth image (one channel, or grey)")]
    NotDepth {
        /// The depth file.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// A relative kind without what makes it metric; `INPUT_DEPTH_RELATIVE`.
    #[error(
        "{path}: {kind} depth has no scale; give --camera-height H (metres above a level floor; the floor \
         is fitted) or --depth-range NEAR,FAR (metres)"
    )]
    RelativeNeedsScale {
        /// The depth file.
        path: PathBuf,
        /// The kind's name.
        kind: &'static str,
    },
    /// No floor found for `--camera-height`; `INPUT_NO_FLOOR`.
    #[error(
        "{path}: no level floor found below the horizon to fit --camera-height to; give --depth-range \
         NEAR,FAR instead"
    )]
    NoFloor {
        /// The depth file.
        path: PathBuf,
    },
    /// A dataset preset whose format the file does not have; `INPUT_PRESET_MISMATCH`.
    #[error(
        "{path}: the {preset} preset is for {expected} depth but the file holds {found} values; drop \
         --preset (float EXR depth is read as metres) or give --depth-scale"
    )]
    PresetMismatch {
        /// The depth file.
        path: PathBuf,
        /// The preset's name.
        preset: &'static str,
        /// The format the preset is for.
        expected: &'static str,
        /// The file's format.
        found: &'static str,
    },
    /// Depth and colour canvases of different mappings; `INPUT_SIZE_MISMATCH`.
    #[error(
        "{depth}: is {dw}x{dh}, which is not a {kind} canvas like the colour ({cw}x{ch}); give depth of \
         the colour's shape (any resolution)"
    )]
    Shape {
        /// Colour width.
        cw: usize,
        /// Colour height.
        ch: usize,
        /// The depth file.
        depth: PathBuf,
        /// Depth width.
        dw: usize,
        /// Depth height.
        dh: usize,
        /// The colour's mapping.
        kind: &'static str,
    },
    /// No depth to build from; `INPUT_DEPTH_EMPTY`.
    #[error(
        "{path}: {known} of {total} depth pixels are valid ({share:.3} %), too few to complete the rest \
         from; give the depth map that goes with the colour (a --preset's or --depth-invalid's value that is \
         real depth in this file makes it unknown), or --unknown-depth sky when the unknown pixels are the sky"
    )]
    EmptyDepth {
        /// The depth file.
        path: PathBuf,
        /// Valid pixels (finite and positive, or infinitely far).
        known: usize,
        /// Pixels of the depth file.
        total: usize,
        /// `known / total`, per cent.
        share: f64,
    },
    /// Metric depth that is zero or negative everywhere; `INPUT_DEPTH_NOT_POSITIVE`.
    #[error(
        "{path}: every depth value is zero or negative (from {min} to {max}), and a distance is positive; \
         if the map stores depth negated (a camera looking along -Z) negate it, if brighter or larger is \
         nearer give --depth-kind nearness or inverse"
    )]
    NotPositive {
        /// The depth file.
        path: PathBuf,
        /// The smallest stored value.
        min: f32,
        /// The largest stored value.
        max: f32,
    },
    /// A setting out of its range; `INPUT_BAD_OPTION`.
    #[error("{option}: {why}")]
    BadOption {
        /// The option's command-line name.
        option: &'static str,
        /// What is wrong.
        why: String,
    },
}

crate::codes::error_codes! {
    PrepareError:
        ScaleNeeded INPUT_DEPTH_SCALE_NEEDED,
        ZDepthOnEquirect INPUT_Z_DEPTH_EQUIRECT,
        EightBit INPUT_DEPTH_8BIT,
        NotDepth INPUT_NOT_DEPTH,
        RelativeNeedsScale INPUT_DEPTH_RELATIVE,
        NoFloor INPUT_NO_FLOOR,
        PresetMismatch INPUT_PRESET_MISMATCH,
        Shape INPUT_SIZE_MISMATCH,
        EmptyDepth INPUT_DEPTH_EMPTY,
        NotPositive INPUT_DEPTH_NOT_POSITIVE,
        BadOption INPUT_BAD_OPTION
}

/// Prepared depth: metres along the ray on the colour's grid (`+inf` infinitely far; NaN only
/// where nothing at all is known).
#[derive(Clone, Debug)]
pub struct PreparedDepth {
    /// The colour canvas's width, pixels.
    pub width: usize,
    /// The colour canvas's height, pixels.
    pub height: usize,
    /// Row-major on the colour's canvas.
    pub depth: Vec<f32>,
    /// What was found and done.
    pub report: PrepareReport,
}

/// A share above which unknown depth is worth a warning.
const MOSTLY_UNKNOWN: f64 = 0.5;
/// Median relative noise above which `--refine auto` smooths.
const NOISY: f64 = 0.0015;
/// The relative jump that separates surfaces in the build (`continuity::JUMP`).
const JUMP: f64 = crate::continuity::JUMP;

/// Prepare `samples` (read from `path`) for a build on the colour canvas `mapping` with colour
/// `rgb` (linear, planar): decode, resize, complete, smooth, snap.
pub fn prepare_depth(
    path: &Path,
    mapping: &AnyMapping,
    rgb: &[Vec<f32>; 3],
    samples: &DepthSamples,
    enc: &DepthEncoding,
    s: &PrepareOptions,
) -> Result<PreparedDepth, PrepareError> {
    check_encoding(enc)?;
    let (sw, sh) = (samples.width, samples.height);
    let kind = mapping.kind();
    let source = depth_canvas(path, mapping, sw, sh)?;
    let mut warnings = Vec::new();
    let enc = known_on_depth_canvas(enc, mapping, sw, sh)?;
    let enc = &enc;
    let (mut depth, metric) = decode::to_metres(path, samples, &source, enc, &mut warnings)?;
    if enc.kind == DepthKind::Z {
        if kind == MappingKind::Equirect {
            return Err(PrepareError::ZDepthOnEquirect { path: path.into() });
        }
        decode::z_to_ray(&source, &mut depth);
    }
    let non_positive = if matches!(enc.kind, DepthKind::Ray | DepthKind::Z) {
        samples.values.iter().filter(|&&v| v <= 0.0).count()
    } else {
        0
    };
    let all_sky = check_known(path, samples, &mut depth, non_positive, s.unknown)?;
    // The colour guide of the resize, the snap and the specks, made once when one needs it.
    let guide_cell = std::cell::OnceCell::new();
    let guide = || guide_cell.get_or_init(|| refine::guide(rgb)).as_slice();
    // Peeled on the depth's own grid, where a rim is as wide as the map made it; a resize first
    // would widen it past the peel's rings.
    let rim = peel_blends(&source, &mut depth);
    let resized = (sw, sh) != (mapping.width(), mapping.height());
    if resized {
        // 8-bit codes step by up to a fifth of the depth (a web map over an outdoor range): their
        // terraces would read as edges and their samples as mixes (docs/build.md).
        let mixes = samples.format != SampleFormat::U8;
        depth = resize::resize(&depth, &source, mapping, guide(), mixes);
    }
    let n = depth.len();
    let mut unknown: Vec<bool> = depth.par_iter().map(|d| d.is_nan()).collect();
    let nb = Neighbours::new(*mapping);
    let unknown_count = unknown.iter().filter(|&&u| u).count();
    let unknown_share = unknown_count as f64 / n.max(1) as f64;
    let mut report = PrepareReport::new((sw, sh), resized, unknown_share, metric, warnings);
    report.non_positive_pixels = non_positive;
    report.rim_pixels = rim;
    if all_sky {
        report.sky_pixels = n;
    }
    // Nothing known at all (what was known fell between the resize's samples): the sky, one layer
    // at infinity, so that accepted depth is in front of the camera everywhere.
    if unknown_count == n {
        depth.fill(f32::INFINITY);
        report.sky_pixels = n;
        return Ok(PreparedDepth { width: mapping.width(), height: mapping.height(), depth, report });
    }
    if s.unknown == UnknownDepth::Sky {
        for p in complete::open_to_zenith(&nb, &unknown) {
            (depth[p], unknown[p]) = (f32::INFINITY, false);
            report.sky_pixels += 1;
        }
    }
    if unknown_share > MOSTLY_UNKNOWN {
        report.warnings.push(Warning::new(
            crate::codes::INPUT_DEPTH_MOSTLY_UNKNOWN,
            format!(
                "{}: {:.0} % of the pixels have no depth: {:.0} % open to the zenith made the sky, the rest \
                 completed from the depth around it (--unknown-depth complete|sky; --depth-invalid V marks a \
                 stored value as unknown)",
                path.display(),
                100.0 * unknown_share,
                100.0 * report.sky_pixels as f64 / n as f64,
            ),
        ));
    }
    refine_depth(&nb, &guide, &mut depth, &unknown, s, &mut report);
    Ok(PreparedDepth { width: mapping.width(), height: mapping.height(), depth, report })
}

/// Make unknown the known pixels that are blends with unknown depth
/// ([`complete::blends_with_unknown`]); returns how many. A peel that would leave less than
/// [`MIN_KNOWN`] of the pixels known (sparse depth that is all rims) is not made: the rims are
/// then the only depth there is.
fn peel_blends(canvas: &AnyMapping, depth: &mut [f32]) -> usize {
    let known = depth.par_iter().filter(|d| !d.is_nan()).count();
    if known == depth.len() || known == 0 {
        return 0;
    }
    let unknown: Vec<bool> = depth.par_iter().map(|d| d.is_nan()).collect();
    let rim = complete::blends_with_unknown(&Neighbours::new(*canvas), depth, &unknown, JUMP as f32);
    if ((known - rim.len()) as f64) < MIN_KNOWN * depth.len() as f64 {
        return 0;
    }
    for &p in &rim {
        depth[p] = f32::NAN;
    }
    rim.len()
}

/// Refuse depth with too little known to build from: every metric value zero or negative, or
/// fewer than [`MIN_KNOWN`] of the pixels valid, unless the user says unknown depth is the sky
/// (nothing known at all is then the sky everywhere: returns true).
fn check_known(
    path: &Path,
    samples: &DepthSamples,
    depth: &mut [f32],
    non_positive: usize,
    unknown: UnknownDepth,
) -> Result<bool, PrepareError> {
    let total = depth.len();
    let known = depth.iter().filter(|d| !d.is_nan()).count();
    if known == 0 && non_positive == total {
        let (min, max) = samples
            .values
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        // All zero is no depth at all (and a preset's "invalid"); negative depth is another convention.
        if min < 0.0 {
            return Err(PrepareError::NotPositive { path: path.into(), min, max });
        }
    }
    if unknown == UnknownDepth::Sky {
        // What is unknown is the sky: little or no depth is still a panorama.
        if known == 0 {
            depth.fill(f32::INFINITY);
        }
        return Ok(known == 0);
    }
    if (known as f64) < MIN_KNOWN * total as f64 {
        let share = 100.0 * known as f64 / total.max(1) as f64;
        return Err(PrepareError::EmptyDepth { path: path.into(), known, total, share });
    }
    Ok(false)
}

/// The least share of valid depth pixels a panorama is completed from.
const MIN_KNOWN: f64 = 0.001;

/// The depth's own canvas: the colour's mapping at the depth's size (any size of that shape).
fn depth_canvas(path: &Path, mapping: &AnyMapping, sw: usize, sh: usize) -> Result<AnyMapping, PrepareError> {
    let kind = mapping.kind();
    AnyMapping::new(kind, sw, sh).map_err(|_| PrepareError::Shape {
        cw: mapping.width(),
        ch: mapping.height(),
        depth: path.into(),
        dw: sw,
        dh: sh,
        kind: match kind {
            MappingKind::Equirect => "2:1 equirect",
            MappingKind::Cube3x2 => "3:2 cube-map",
        },
    })
}

/// `enc` with its known distance's pixel (the colour's) moved onto the depth's `sw × sh` canvas.
fn known_on_depth_canvas(
    enc: &DepthEncoding,
    mapping: &AnyMapping,
    sw: usize,
    sh: usize,
) -> Result<DepthEncoding, PrepareError> {
    let mut enc = *enc;
    if let Some(k) = &mut enc.known_distance {
        if !(k.x >= 0.0 && k.y >= 0.0 && k.x < mapping.width() as f64 && k.y < mapping.height() as f64) {
            return Err(PrepareError::BadOption {
                option: "--known-distance",
                why: format!(
                    "pixel ({},{}) is outside the {}x{} colour image",
                    k.x,
                    k.y,
                    mapping.width(),
                    mapping.height()
                ),
            });
        }
        k.x *= sw as f64 / mapping.width() as f64;
        k.y *= sh as f64 / mapping.height() as f64;
    }
    Ok(enc)
}

impl PrepareReport {
    /// What is known before anything is completed or refined.
    fn new(
        source_size: (usize, usize),
        resized: bool,
        unknown_share: f64,
        metric: Option<MetricFit>,
        warnings: Vec<Warning>,
    ) -> Self {
        PrepareReport {
            source_size,
            resized,
            unknown_share,
            non_positive_pixels: 0,
            rim_pixels: 0,
            completed_pixels: 0,
            sky_pixels: 0,
            edges: EdgeScan::default(),
            snapped: false,
            snap_radius: 0,
            snapped_pixels: 0,
            speck_pixels: 0,
            noise: 0.0,
            smoothed: false,
            metric,
            warnings,
        }
    }
}

/// Ranges of the settings that have them (relative kinds' range and height).
fn check_encoding(enc: &DepthEncoding) -> Result<(), PrepareError> {
    if let Some((near, far)) = enc.range {
        if !(near > 0.0 && far > near && far.is_finite()) {
            return Err(PrepareError::BadOption {
                option: "--depth-range",
                why: format!("{near},{far}: give NEAR,FAR in metres with 0 < NEAR < FAR"),
            });
        }
    }
    if let Some(k) = enc.known_distance {
        if !(k.metres > 0.0 && k.metres.is_finite()) {
            return Err(PrepareError::BadOption {
                option: "--known-distance",
                why: format!("{}: give X,Y,METRES with a distance in metres above 0", k.metres),
            });
        }
        let other = if enc.range.is_some() {
            Some("--depth-range")
        } else if enc.camera_height.is_some() {
            Some("--camera-height")
        } else if enc.scale.is_some() {
            Some("--depth-scale (or a --preset)")
        } else {
            None
        };
        if let Some(other) = other {
            return Err(PrepareError::BadOption {
                option: "--known-distance",
                why: format!("it and {other} both give the depth's scale: give one"),
            });
        }
        if enc.kind == DepthKind::Nearness {
            return Err(PrepareError::BadOption {
                option: "--known-distance",
                why: "a nearness map has two unknowns (its near and far ends): give --depth-range NEAR,FAR \
                      or --camera-height H"
                    .into(),
            });
        }
    }
    if let Some(h) = enc.camera_height {
        if !(h > 0.0 && h.is_finite()) {
            return Err(PrepareError::BadOption {
                option: "--camera-height",
                why: format!("{h}: give the camera's height above the floor in metres (> 0)"),
            });
        }
    }
    Ok(())
}

/// Completion, smoothing and snapping in log depth; writes back only the pixels they change.
fn refine_depth<'a>(
    nb: &Neighbours,
    guide: &dyn Fn() -> &'a [[f32; 3]],
    depth: &mut [f32],
    unknown: &[bool],
    s: &PrepareOptions,
    report: &mut PrepareReport,
) {
    let to_log = |d: f32| if d.is_infinite() { complete::SKY_LOG } else { d.ln().min(complete::SKY_LOG) };
    let original: Vec<f32> =
        depth.par_iter().map(|&d| if d.is_nan() { f32::NAN } else { to_log(d) }).collect();
    let mut log = original.clone();
    if unknown.iter().any(|&u| u) {
        complete_unknown(nb, &mut log, &original, unknown);
        report.completed_pixels = unknown.iter().filter(|&&u| u).count();
    }
    report.edges = refine::scan_edges(&original, nb.width(), (1.0 + JUMP).ln() as f32);
    if report.edges.is_soft() && s.refine == Refine::Off {
        report.warnings.push(Warning::new(
            crate::codes::INPUT_DEPTH_SOFT,
            format!(
                "the depth's edges are spread over up to {} pixels (the steepest step takes {:.0} % of an \
                 edge) and `--refine off` leaves them: objects will stay joined to what is behind them as \
                 stretched surfaces; `--refine auto` settles them (docs/build.md, \"Depth preparation\")",
                report.edges.width,
                100.0 * report.edges.sharpness
            ),
        ));
    }
    if s.refine != Refine::Off {
        refine_known(nb, guide, &mut log, unknown, s.refine, report);
    }
    depth.par_iter_mut().zip(log.par_iter().zip(&original)).for_each(|(d, (&l, &o))| {
        if l.to_bits() != o.to_bits() {
            *d = if l >= complete::SKY_LOG - 1e-3 { f32::INFINITY } else { l.exp() };
        }
    });
}

/// Complete the `unknown` pixels of `log` (push-pull, then relaxation), never nearer or farther
/// than the finite depth known (`original`): completion interpolates, except across a step, where
/// a thin hole takes the nearest known depth.
fn complete_unknown(nb: &Neighbours, log: &mut [f32], original: &[f32], unknown: &[bool]) {
    complete::push_pull(log, nb.width(), nb.height());
    complete::relax(nb, log, unknown, complete::RELAX_SWEEPS);
    let (lo, hi) = original
        .iter()
        .filter(|l| l.is_finite() && **l < complete::SKY_LOG)
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    if lo <= hi {
        log.par_iter_mut().zip(unknown).filter(|(_, &u)| u).for_each(|(l, _)| *l = l.clamp(lo, hi));
    }
    complete::nearest_across_steps(nb, log, original, unknown, (1.0 + JUMP).ln() as f32);
    complete::ground_to_the_horizon(nb, log, original, unknown);
}

/// Refine `log` (measured noise smoothed; soft edges snapped with `on`, settled with `mode` and,
/// when `report.edges` measured them soft, `auto`; specks of resized depth removed).
fn refine_known<'a>(
    nb: &Neighbours,
    guide: &dyn Fn() -> &'a [[f32; 3]],
    log: &mut [f32],
    unknown: &[bool],
    refine: Refine,
    report: &mut PrepareReport,
) {
    let (w, h) = (nb.width(), nb.height());
    let jump_log = (1.0 + JUMP).ln() as f32;
    let known: Vec<bool> = unknown.iter().map(|u| !u).collect();
    let (blocks, median) = refine::noise(log, &known, w, h, jump_log);
    report.noise = f64::from(median);
    if f64::from(median) > NOISY {
        refine::smooth(log, w, h, &blocks, median, jump_log);
        report.smoothed = true;
    }
    // `auto` settles soft depth as `mode` does and leaves depth with sharp edges as it is
    // (measured: docs/build.md, "`--refine auto` settles soft depth").
    let wide = report.edges.is_soft() && report.edges.sharpness < BAND_SHARPNESS;
    if refine == Refine::Auto && report.edges.is_soft() {
        let mut settled = log.to_vec();
        let moved = settle(nb, &mut settled, guide(), wide, false);
        let known = unknown.iter().filter(|&&u| !u).count();
        if moved as f64 <= MAX_SETTLED_SHARE * known as f64 {
            log.copy_from_slice(&settled);
            report.snapped_pixels += moved;
            (report.snapped, report.snap_radius) = (true, mode::RADIUS as usize);
        } else {
            report.warnings.push(Warning::new(
                crate::codes::INPUT_DEPTH_SOFT,
                format!(
                    "the depth is soft everywhere, not only at its edges: settling it would move {:.0} % of \
                     its pixels and break its surfaces into pieces, so it is left as it is; objects will stay \
                     joined to what is behind them (`--refine mode` settles it anyway)",
                    100.0 * moved as f64 / known.max(1) as f64
                ),
            ));
        }
    }
    // Measured on the path-traced corpus and the analytic room (docs/build.md, "Depth
    // preparation"): snapping loses there (objects stay joined to the floor at softened
    // contacts, and their sharpened outlines split off as shells), so only `on` snaps.
    if refine == Refine::On {
        let radius = MAX_RADIUS;
        let guide = guide();
        // A second pass takes what the first left of ramps it made shorter.
        for _ in 0..SNAP_PASSES {
            report.snapped_pixels += refine::snap(nb, log, guide, radius, jump_log);
        }
        (report.snapped, report.snap_radius) = (true, radius);
    }
    if matches!(refine, Refine::Mode | Refine::Ramps) {
        report.snapped_pixels += settle(nb, log, guide(), wide, refine == Refine::Ramps);
        (report.snapped, report.snap_radius) = (true, mode::RADIUS as usize);
    }
    // Resampled depth only: the guided upsampling leaves pieces of neither side along
    // silhouettes. In blurred depth at full resolution such pieces break ramps that would
    // otherwise join into wider stretched surfaces (measured: docs/build.md).
    if report.resized {
        let max = (w * h / SPECK_SHARE).max(MIN_SPECK);
        report.speck_pixels = specks::remove(nb, log, guide(), max);
    }
}

/// Settle the soft steps of `log` (`auto` on soft depth, `mode`): with `wide` (the depth's edges
/// wider than the mode filter's disc), bands are first cut at their colour edge; then the filter
/// settles the rest (measured: docs/build.md, "Soft bands cut at their colour edge"), and with
/// `ramps` the short ramps it left go to a side. Returns how many pixels moved.
fn settle(nb: &Neighbours, log: &mut [f32], guide: &[[f32; 3]], wide: bool, ramps: bool) -> usize {
    let before = log.to_vec();
    let grid = mode::Grid::new(nb);
    let colour = mode::colour_mean(&grid, guide);
    if wide {
        band::split_bands(nb, log, &colour);
    }
    mode::mode_filter(nb, log, &colour);
    if ramps {
        ramp::settle_ramps(&grid, log, &colour);
    }
    log.par_iter().zip(&before).filter(|(a, b)| a.to_bits() != b.to_bits()).count()
}

/// Edge sharpness (the steepest step's share of an edge) under which soft edges are wider than
/// the mode filter's disc settles: a step blurred σ 1, 2, 3 px reads 0.30, 0.16, 0.11 on the
/// path-traced corpus. Cutting bands loses on σ 1 (the filter alone settles it) and gains on σ 2
/// and 3 (docs/build.md, "Soft bands cut at their colour edge").
const BAND_SHARPNESS: f64 = 0.2;

/// Pieces of surface smaller than this share of the canvas (1 / it), or [`MIN_SPECK`] pixels, are
/// specks when they are behind something on their border.
const SPECK_SHARE: usize = 1000;
const MIN_SPECK: usize = 64;

/// Largest share of the known pixels `--refine auto` lets the mode filter move. Soft edges are
/// bands along outlines: the path-traced corpus's blurred, upsampled and estimator-like depths at
/// 1024 × 512 move 1.3–6.6 %, the analytic room at 512 × 256 blurred σ 2 px 12.2 % (a band takes a
/// larger share of a smaller picture). A depth soft everywhere (HoHoNet's estimate of its `asmasu`
/// sample, 1024 × 512: 19 %) breaks into pieces that open holes off-centre (docs/build.md,
/// "`--refine auto` settles soft depth").
const MAX_SETTLED_SHARE: f64 = 0.16;

/// Passes of the snap.
const SNAP_PASSES: usize = 2;

/// Largest snap window radius, pixels (a ramp wider than twice this is left as a surface).
const MAX_RADIUS: usize = 24;
