//! Reading RGB-D panoramas for [`super::build`]: colour from PNG/JPEG/EXR/HDR, depth from float
//! EXR or 16-bit PNG with a scale and an invalid value, dataset presets, z-depth to ray distance,
//! and the azimuth conventions of other tools expressed as a LocalToWorld prefix.

use std::path::{Path, PathBuf};

use glam::Vec3;
use rayon::prelude::*;

use super::RgbdInput;
use crate::colour::{srgb_to_linear, ColourSpace};
use crate::layer_io::{self, ReadLimits};
use crate::manifest::Transform;
use crate::mapping::{AnyMapping, Mapping, MappingKind};

/// How depth values are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthEncoding {
    /// Metres per stored unit; `None`: float EXR depth is in metres, and integer (PNG) depth is
    /// refused, as its unit cannot be guessed.
    pub scale: Option<f64>,
    /// Stored value meaning "no depth" (besides 0, NaN and negatives, which always do).
    pub invalid: Option<f64>,
    /// Distance along the ray, or planar z-depth (cube faces: along the face axis).
    pub kind: DepthKind,
}

impl Default for DepthEncoding {
    fn default() -> Self {
        DepthEncoding { scale: None, invalid: None, kind: DepthKind::Ray }
    }
}

/// Ray distance or planar depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum DepthKind {
    /// Euclidean distance from the centre along the pixel's ray (the default).
    Ray,
    /// Planar depth along a cube face's axis; converted to ray distance (cube maps only).
    Z,
}

/// Dataset presets (each documented in spec/07-build.md with its source).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Preset {
    /// Matterport3D: uint16 PNG, metres = value / 4000, 0 invalid.
    #[cfg_attr(feature = "clap", value(help = "uint16 PNG, metres = value / 4000, 0 invalid"))]
    Matterport3d,
    /// Stanford 2D-3D-S equirect panoramas: uint16 PNG, value / 512, 65535 invalid, Euclidean.
    #[cfg_attr(feature = "clap", value(help = "uint16 PNG, value / 512, 65535 invalid, Euclidean"))]
    Stanford2d3ds,
    /// Structured3D: uint16 PNG in millimetres, 0 invalid.
    #[cfg_attr(feature = "clap", value(help = "uint16 PNG in millimetres, 0 invalid"))]
    Structured3d,
    /// Pano3D / 3D60: float EXR in metres.
    #[cfg_attr(feature = "clap", value(help = "float EXR in metres"))]
    Pano3d,
}

impl Preset {
    /// The preset's depth scale, invalid value and kind (all ray distance).
    pub fn encoding(self) -> DepthEncoding {
        let ray = DepthKind::Ray;
        match self {
            Preset::Matterport3d => {
                DepthEncoding { scale: Some(1.0 / 4000.0), invalid: Some(0.0), kind: ray }
            }
            Preset::Stanford2d3ds => {
                DepthEncoding { scale: Some(1.0 / 512.0), invalid: Some(65535.0), kind: ray }
            }
            Preset::Structured3d => {
                DepthEncoding { scale: Some(1.0 / 1000.0), invalid: Some(0.0), kind: ray }
            }
            Preset::Pano3d => DepthEncoding { scale: Some(1.0), invalid: None, kind: ray },
        }
    }
}

/// Azimuth conventions of the tools panoramas come from, as the LocalToWorld operations that
/// map our (the thesis's) local frame onto theirs. Pixels are never resampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Convention {
    /// The thesis and POMC: azimuth `φ = 2πu` from +X towards +Y, `+Z` up.
    #[default]
    #[cfg_attr(feature = "clap", value(help = "POMC / thesis: azimuth 2πu from +X towards +Y, +Z up"))]
    Thesis,
    /// Blender's equirect camera: azimuth `π(1 − 2u)`, centre column along +X, `+Z` up:
    /// `world = Scale(−1, 1, 1) · local`.
    #[cfg_attr(
        feature = "clap",
        value(help = "Blender equirect camera: azimuth π(1−2u), centre column along +X")
    )]
    Blender,
    /// OpenEXR lat-long: longitude `π − 2πu`, latitude `π/2 − πv`, `+Y` up, direction
    /// `(sin lon cos lat, sin lat, cos lon cos lat)`: `world = Rotate((1,1,1), −120°) ·
    /// Scale(−1, 1, 1) · local`.
    #[cfg_attr(
        feature = "clap",
        value(help = "OpenEXR lat-long: longitude decreasing, +Y up", name = "openexr")
    )]
    OpenExr,
}

impl Convention {
    /// The LocalToWorld operations, outermost first, to append to the manifest (none for `Thesis`).
    pub fn transforms(self) -> Vec<Transform> {
        match self {
            Convention::Thesis => vec![],
            Convention::Blender => vec![Transform::Scale([-1.0, 1.0, 1.0])],
            Convention::OpenExr => vec![
                Transform::Rotate { axis: [1.0, 1.0, 1.0], angle_deg: -120.0 },
                Transform::Scale([-1.0, 1.0, 1.0]),
            ],
        }
    }
}

/// Errors reading RGB-D inputs; each names the file and the fix.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A PNG/JPEG/HDR input cannot be opened or decoded (or a JPEG is truncated); `INPUT_UNREADABLE`.
    #[error("{path}: cannot read the image ({reason})")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong, from the file system or the decoder.
        reason: String,
    },
    /// Reading an EXR input (depth or normals) failed; the layer reader's code.
    #[error(transparent)]
    Layer(#[from] layer_io::LayerIoError),
    /// A depth EXR has none of `Z`, `Y`, `R`, `depth`, `D` and more than one channel; `INPUT_NO_DEPTH`.
    #[error("{path}: no depth channel (looked for Z, Y, R, or a single channel); name the depth channel Z")]
    NoDepthChannel {
        /// The depth file.
        path: PathBuf,
    },
    /// The canvas size is neither 2:1 (equirect) nor 3:2 with square faces (cube); `INPUT_NOT_PANORAMA`.
    #[error("{path}: {width}x{height} fits neither a 2:1 equirect nor a 3:2 cube map")]
    NotAPanorama {
        /// The colour file (or `<array>` for in-memory input).
        path: PathBuf,
        /// Width, pixels.
        width: usize,
        /// Height, pixels.
        height: usize,
    },
    /// The header declares a size beyond [`ReadLimits`]; refused before decoding; `INPUT_TOO_LARGE`.
    #[error("{path}: declares {width}x{height} pixels, beyond the reader limit ({limit}); refused before decoding (raise it with `pomc build --max-pixels N`)")]
    TooLarge {
        /// The input file (or `<array>`).
        path: PathBuf,
        /// Declared width, pixels.
        width: u64,
        /// Declared height, pixels.
        height: u64,
        /// The limit exceeded, e.g. `at most N pixels`.
        limit: String,
    },
    /// Colour and depth (or a normals image) differ in size, or the normals image lacks a channel;
    /// `INPUT_SIZE_MISMATCH`.
    #[error("{colour}: is {cw}x{ch} but the depth {depth} is {dw}x{dh}; resample one to the other's size")]
    SizeMismatch {
        /// The colour file.
        colour: PathBuf,
        /// Colour width, pixels.
        cw: usize,
        /// Colour height, pixels.
        ch: usize,
        /// The depth (or normals) file.
        depth: PathBuf,
        /// Depth (or normals) width, pixels.
        dw: usize,
        /// Depth (or normals) height, pixels.
        dh: usize,
    },
    /// [`DepthKind::Z`] was asked for an equirect input; `INPUT_Z_DEPTH_EQUIRECT`.
    #[error("{path}: z-depth needs a cube-map input (an equirect has no image plane); use --depth-kind ray")]
    ZDepthOnEquirect {
        /// The depth file (or `<array>`).
        path: PathBuf,
    },
    /// Integer (PNG) depth was given without [`DepthEncoding::scale`]; `INPUT_DEPTH_SCALE_NEEDED`.
    #[error(
        "{path}: integer depth has no unit; give --depth-scale (metres per stored unit, e.g. 0.001 for \
         millimetres) or a dataset --preset (matterport3d, stanford2d3ds, structured3d), or store float \
         metres in an OpenEXR"
    )]
    DepthScaleNeeded {
        /// The depth file.
        path: PathBuf,
    },
}

impl InputError {
    /// Stable code, e.g. `INPUT_UNREADABLE`; a [`InputError::Layer`] error keeps the layer reader's.
    pub fn code(&self) -> &'static str {
        match self {
            InputError::Image { .. } => "INPUT_UNREADABLE",
            InputError::TooLarge { .. } => "INPUT_TOO_LARGE",
            InputError::Layer(e) => e.code(),
            InputError::NoDepthChannel { .. } => "INPUT_NO_DEPTH",
            InputError::NotAPanorama { .. } => "INPUT_NOT_PANORAMA",
            InputError::SizeMismatch { .. } => "INPUT_SIZE_MISMATCH",
            InputError::ZDepthOnEquirect { .. } => "INPUT_Z_DEPTH_EQUIRECT",
            InputError::DepthScaleNeeded { .. } => "INPUT_DEPTH_SCALE_NEEDED",
        }
    }
}

/// The mapping a canvas size implies: 2:1 equirect or 3:2 cube.
pub fn mapping_for(path: &Path, width: usize, height: usize) -> Result<AnyMapping, InputError> {
    AnyMapping::new(MappingKind::Equirect, width, height)
        .or_else(|_| AnyMapping::new(MappingKind::Cube3x2, width, height))
        .map_err(|_| InputError::NotAPanorama { path: path.to_path_buf(), width, height })
}

fn is_exr(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

fn image_limits(limits: &ReadLimits) -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(limits.max_dimension as u32);
    l.max_image_height = Some(limits.max_dimension as u32);
    l.max_alloc = Some(limits.max_pixels.saturating_mul(16));
    l
}

fn reader(path: &Path) -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>, InputError> {
    let err =
        |e: &dyn std::fmt::Display| InputError::Image { path: path.to_path_buf(), reason: e.to_string() };
    crate::fsutil::check_regular(path).map_err(|e| err(&e))?;
    image::ImageReader::open(path).map_err(|e| err(&e))?.with_guessed_format().map_err(|e| err(&e))
}

/// Width and height from the file's header, checked against `limits` (for `channels` planes of
/// `f32`, what the build holds) before any pixel is decoded.
pub fn header_size(path: &Path, channels: usize, limits: &ReadLimits) -> Result<(usize, usize), InputError> {
    let (w, h) = if is_exr(path) {
        let header = layer_io::read_header(path, limits)?;
        (header.width as u64, header.height as u64)
    } else {
        let dims = reader(path)?.into_dimensions();
        let (w, h) =
            dims.map_err(|e| InputError::Image { path: path.to_path_buf(), reason: e.to_string() })?;
        (u64::from(w), u64::from(h))
    };
    limits.check(w, h, channels).map_err(|limit| InputError::TooLarge {
        path: path.to_path_buf(),
        width: w,
        height: h,
        limit,
    })?;
    Ok((w as usize, h as usize))
}

fn open_image(path: &Path, limits: &ReadLimits) -> Result<image::DynamicImage, InputError> {
    let err =
        |e: &dyn std::fmt::Display| InputError::Image { path: path.to_path_buf(), reason: e.to_string() };
    let mut reader = reader(path)?;
    reader.limits(image_limits(limits));
    let is_jpeg = reader.format() == Some(image::ImageFormat::Jpeg);
    let image = reader.decode().map_err(|e| err(&e))?;
    // The JPEG decoder fills a cut-off scan with grey rather than failing.
    if is_jpeg && !jpeg_is_complete(&std::fs::read(path).map_err(|e| err(&e))?) {
        return Err(err(&"the JPEG data stops before its end-of-image marker (a truncated file?); \
                          download or export it again"));
    }
    Ok(image)
}

/// Whether the primary image reaches its end-of-image marker (`FF D9`): the marker segments are
/// walked from the start by their lengths and each scan's entropy-coded data up to the next marker
/// (its `FF` bytes are stuffed), so data after the image (a thumbnail inside `APP1`, a trailer such
/// as a motion photo's video) cannot be mistaken for it.
fn jpeg_is_complete(b: &[u8]) -> bool {
    if !b.starts_with(&[0xFF, 0xD8]) {
        return false;
    }
    let mut i = 2;
    loop {
        // Fill bytes (`FF FF …`) may precede a marker.
        while b.get(i) == Some(&0xFF) && b.get(i + 1) == Some(&0xFF) {
            i += 1;
        }
        let (Some(&0xFF), Some(&m)) = (b.get(i), b.get(i + 1)) else { return false };
        i += 2;
        match m {
            0xD9 => return true,
            // Restart markers and TEM stand alone.
            0xD0..=0xD7 | 0x01 => continue,
            _ => {}
        }
        let Some(len) = b.get(i..i + 2).map(|l| usize::from(u16::from_be_bytes([l[0], l[1]]))) else {
            return false;
        };
        if len < 2 {
            return false;
        }
        i += len;
        if m == 0xDA {
            // Entropy-coded data: runs to the next marker that is not a stuffed `FF 00` or a restart.
            loop {
                let Some(k) = b.get(i..).and_then(|r| r.iter().position(|&x| x == 0xFF)) else {
                    return false;
                };
                i += k;
                match b.get(i + 1) {
                    None => return false,
                    Some(0x00) | Some(0xD0..=0xD7) => i += 2,
                    Some(_) => break,
                }
            }
        }
    }
}

/// Colour as planar linear RGB f32: 8/16-bit images are decoded from sRGB unless `space` says
/// linear, float images (OpenEXR, Radiance HDR) are linear as stored.
pub fn read_colour(
    path: &Path,
    space: ColourSpace,
    limits: &ReadLimits,
) -> Result<(usize, usize, [Vec<f32>; 3]), InputError> {
    let img = open_image(path, limits)?;
    let float = matches!(img, image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_));
    let decode = match space {
        ColourSpace::Auto => !float,
        ColourSpace::Srgb => true,
        ColourSpace::Linear => false,
    };
    let img = img.to_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let plane = |c: usize| -> Vec<f32> {
        let values = img.as_raw().par_chunks_exact(3).map(|px| px[c]);
        if decode {
            values.map(srgb_to_linear).collect()
        } else {
            values.collect()
        }
    };
    Ok((w, h, [plane(0), plane(1), plane(2)]))
}

/// Depth in metres along the stored convention (before z → ray conversion): unknown = NaN.
pub fn read_depth(
    path: &Path,
    enc: &DepthEncoding,
    limits: &ReadLimits,
) -> Result<(usize, usize, Vec<f32>), InputError> {
    let (w, h, raw, scale) = if is_exr(path) {
        let layer = layer_io::read_exr(path, limits)?;
        let ch = ["Z", "Y", "R", "depth", "D"]
            .iter()
            .find_map(|n| layer.channel(n))
            .or_else(|| (layer.channels.len() == 1).then(|| &layer.channels[0]))
            .ok_or_else(|| InputError::NoDepthChannel { path: path.to_path_buf() })?;
        (layer.width, layer.height, ch.data.clone(), enc.scale.unwrap_or(1.0))
    } else {
        // Integer depth has a dataset-specific unit: read without one it builds silently into
        // garbage (millimetres taken for metres put everything beyond d_dirmin).
        let scale = enc.scale.ok_or_else(|| InputError::DepthScaleNeeded { path: path.to_path_buf() })?;
        let img = open_image(path, limits)?.to_luma16();
        let (w, h) = (img.width() as usize, img.height() as usize);
        (w, h, img.into_raw().into_iter().map(f32::from).collect(), scale)
    };
    Ok((w, h, depth_from_raw(raw, scale, enc.invalid)))
}

/// Stored depth values to metres along the ray: `scale` metres per unit; NaN, zero, negative and
/// `invalid` values become unknown (NaN); `+inf` stays infinitely far.
pub fn depth_from_raw(raw: Vec<f32>, scale: f64, invalid: Option<f64>) -> Vec<f32> {
    raw.into_iter()
        .map(|v| {
            let unknown = v.is_nan() || v <= 0.0 || invalid.is_some_and(|i| v as f64 == i);
            if unknown {
                f32::NAN
            } else {
                (v as f64 * scale) as f32
            }
        })
        .collect()
}

/// Interleaved RGB samples of an image in memory, row-major.
#[derive(Clone, Copy, Debug)]
pub enum ColourSamples<'a> {
    /// 8-bit (sRGB unless the colour space says linear).
    U8(&'a [u8]),
    /// 16-bit (sRGB unless the colour space says linear).
    U16(&'a [u16]),
    /// Float (linear unless the colour space says sRGB).
    F32(&'a [f32]),
}

/// Planar linear RGB from samples in memory, decoded as [`read_colour`] decodes files.
pub fn colour_planes(samples: ColourSamples, space: ColourSpace) -> [Vec<f32>; 3] {
    let (values, float): (Vec<f32>, bool) = match samples {
        ColourSamples::U8(v) => (v.iter().map(|&x| x as f32 / 255.0).collect(), false),
        ColourSamples::U16(v) => (v.iter().map(|&x| x as f32 / 65535.0).collect(), false),
        ColourSamples::F32(v) => (v.to_vec(), true),
    };
    let decode = match space {
        ColourSpace::Auto => !float,
        ColourSpace::Srgb => true,
        ColourSpace::Linear => false,
    };
    let n = values.len() / 3;
    let mut rgb = [Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n)];
    for px in values.chunks_exact(3) {
        for (plane, &v) in rgb.iter_mut().zip(px) {
            plane.push(if decode { srgb_to_linear(v) } else { v });
        }
    }
    rgb
}

/// Planar z-depth on a cube map to distance along the ray: `ray = z / max(|x|,|y|,|z|)` of the
/// unit direction (the face axis component).
pub fn z_to_ray(m: &AnyMapping, depth: &mut [f32]) {
    for (p, d) in depth.iter_mut().enumerate() {
        let dir = m.pixel_dir(p % m.width(), p / m.width());
        let axis = dir.x.abs().max(dir.y.abs()).max(dir.z.abs());
        *d = (*d as f64 / axis) as f32;
    }
}

/// Colour and depth must have one size.
fn same_size(
    colour: &Path,
    (cw, ch): (usize, usize),
    depth: &Path,
    (dw, dh): (usize, usize),
) -> Result<(), InputError> {
    if (cw, ch) == (dw, dh) {
        return Ok(());
    }
    Err(InputError::SizeMismatch { colour: colour.to_path_buf(), cw, ch, depth: depth.to_path_buf(), dw, dh })
}

/// Load colour + depth (+ optional normals EXR) into an [`RgbdInput`].
pub fn load(
    colour: &Path,
    space: ColourSpace,
    depth: &Path,
    normals: Option<&Path>,
    enc: &DepthEncoding,
    limits: &ReadLimits,
) -> Result<RgbdInput, InputError> {
    // Sizes from the headers first: a small file declaring a huge canvas, or two files of different
    // sizes, are refused before either is decoded (4 planes: colour and depth).
    same_size(colour, header_size(colour, 4, limits)?, depth, header_size(depth, 4, limits)?)?;
    let (cw, ch, rgb) = read_colour(colour, space, limits)?;
    let (dw, dh, mut d) = read_depth(depth, enc, limits)?;
    same_size(colour, (cw, ch), depth, (dw, dh))?;
    let mapping = mapping_for(colour, cw, ch)?;
    if enc.kind == DepthKind::Z {
        if mapping.kind() == MappingKind::Equirect {
            return Err(InputError::ZDepthOnEquirect { path: depth.to_path_buf() });
        }
        z_to_ray(&mapping, &mut d);
    }
    let normals = normals.map(|p| read_normals(p, colour, cw, ch, limits)).transpose()?;
    Ok(RgbdInput { mapping, rgb, depth: d, normals })
}

/// The normals image `path` (`N.X N.Y N.Z`, or `R G B`) of a `cw` × `ch` colour image `colour`.
pub fn read_normals(
    path: &Path,
    colour: &Path,
    cw: usize,
    ch: usize,
    limits: &ReadLimits,
) -> Result<Vec<Vec3>, InputError> {
    let l = layer_io::read_exr(path, limits)?;
    let get = |names: [&str; 2]| names.iter().find_map(|n| l.channel(n)).map(|c| c.data.clone());
    match (get(["N.X", "R"]), get(["N.Y", "G"]), get(["N.Z", "B"])) {
        (Some(x), Some(y), Some(z)) if l.width == cw && l.height == ch => {
            Ok((0..x.len()).map(|i| Vec3::new(x[i], y[i], z[i])).collect())
        }
        _ => Err(InputError::SizeMismatch {
            colour: colour.to_path_buf(),
            cw,
            ch,
            depth: path.to_path_buf(),
            dw: l.width,
            dh: l.height,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncated_jpegs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.jpg");
        let img = image::RgbImage::from_fn(512, 256, |x, y| {
            image::Rgb([(x * 7 % 256) as u8, ((x ^ y) % 256) as u8, (y * 13 % 256) as u8])
        });
        img.save(&path).unwrap();
        let whole = std::fs::read(&path).unwrap();
        assert!(jpeg_is_complete(&whole));
        let limits = ReadLimits::default();
        assert!(open_image(&path, &limits).is_ok());
        // Data after the end-of-image marker (a motion photo's video, a trailer) is no truncation,
        // even when it holds `FF DA` bytes.
        let mut trailer = whole.clone();
        trailer.extend_from_slice(&[0xFF, 0xDA, 0x00, 0x08, 1, 2, 3, 4, 5, 6, 0xAB, 0xFF, 0xDA, 0x12]);
        assert!(jpeg_is_complete(&trailer));
        let cut = &whole[..whole.len() * 2 / 3];
        assert!(!jpeg_is_complete(cut));
        // The decoder alone accepts the cut file (the missing rows come out grey).
        assert!(image::load_from_memory(cut).is_ok());
        std::fs::write(&path, cut).unwrap();
        let err = open_image(&path, &limits).unwrap_err();
        assert_eq!(err.code(), "INPUT_UNREADABLE");
        assert!(err.to_string().contains("truncated"), "{err}");
    }

    /// 16-bit PNG depth without a unit is refused with the fix; with one it is read in metres.
    #[test]
    fn integer_depth_needs_a_unit() {
        let path = std::env::temp_dir().join(format!("pomc-depth16-{}.png", std::process::id()));
        let img =
            image::ImageBuffer::<image::Luma<u16>, _>::from_fn(8, 4, |x, _| image::Luma([1000 + x as u16]));
        img.save(&path).unwrap();
        let limits = ReadLimits::default();
        let err = read_depth(&path, &DepthEncoding::default(), &limits).unwrap_err();
        assert_eq!(err.code(), "INPUT_DEPTH_SCALE_NEEDED");
        assert!(err.to_string().contains("--depth-scale") && err.to_string().contains("--preset"), "{err}");
        let mm = DepthEncoding { scale: Some(0.001), ..DepthEncoding::default() };
        let (w, h, d) = read_depth(&path, &mm, &limits).unwrap();
        assert_eq!((w, h), (8, 4));
        assert_eq!(d[3], 1.003);
        std::fs::remove_file(&path).ok();
    }
}
