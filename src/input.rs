//! Reading RGB-D panoramas, the build's front door: colour from PNG/JPEG/EXR/HDR as linear planes,
//! depth samples as stored (their unit and kind are the preparation's, [`crate::prepare`]), normals,
//! sizes checked from the headers first; and the azimuth conventions of other tools as a
//! LocalToWorld prefix. Plain images are decoded by [`crate::image_io`], the one decoder.

use std::path::{Path, PathBuf};

use glam::Vec3;
use rayon::prelude::*;

use serde::Serialize;

use crate::colour::{srgb_to_linear, ColourSpace};
use crate::image_io::{self, DecodeFailure};
use crate::layer_io::{self, ReadLimits};
use crate::manifest::Transform;
use crate::mapping::{AnyMapping, MappingKind};

pub use crate::image_io::ImageHeader;

crate::choice::choices! {
    /// Azimuth conventions of the tools panoramas come from, as the LocalToWorld operations that
    /// map our (the thesis's) local frame onto theirs. Pixels are never resampled.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Convention (default Thesis) {
        /// POMC / thesis: azimuth 2πu from +X towards +Y, +Z up.
        Thesis = "thesis",
        /// Blender equirect camera: azimuth π(1−2u), centre column along +X.
        ///
        /// `+Z` up: `world = Scale(−1, 1, 1) · local`.
        Blender = "blender",
        /// OpenEXR lat-long: longitude decreasing, +Y up.
        ///
        /// Longitude `π − 2πu`, latitude `π/2 − πv`, `+Y` up, direction
        /// `(sin lon cos lat, sin lat, cos lon cos lat)`: `world = Rotate((1,1,1), −120°) ·
        /// Scale(−1, 1, 1) · local`.
        OpenExr = "openexr",
    }
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
    #[error(
        "{colour}: is {cw}x{ch} but {depth} is {dw}x{dh}; give depth of the colour's shape (2:1 or 3:2, any \
         resolution) and normals of its size"
    )]
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
}

crate::codes::error_codes! {
    InputError:
        Image INPUT_UNREADABLE,
        TooLarge INPUT_TOO_LARGE,
        NoDepthChannel INPUT_NO_DEPTH,
        NotAPanorama INPUT_NOT_PANORAMA,
        SizeMismatch INPUT_SIZE_MISMATCH;
        from Layer.0
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

/// A plain image's failure as the build reports it (`INPUT_UNREADABLE`, naming the file).
fn unreadable(path: &Path, e: DecodeFailure) -> InputError {
    InputError::Image { path: path.to_path_buf(), reason: e.to_string() }
}

/// Read a PNG/JPEG/HDR/… header ([`ImageHeader`]).
pub fn image_header(path: &Path) -> Result<ImageHeader, InputError> {
    image_io::image_header(path).map_err(|e| unreadable(path, e))
}

/// Width and height from the file's header, checked against `limits` (for `channels` planes of
/// `f32`, what the build holds) before any pixel is decoded.
pub fn header_size(path: &Path, channels: usize, limits: &ReadLimits) -> Result<(usize, usize), InputError> {
    let (w, h) = if is_exr(path) {
        let header = layer_io::read_header(path, limits)?;
        (header.width as u64, header.height as u64)
    } else {
        let (w, h) = image_io::image_size(path).map_err(|e| unreadable(path, e))?;
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
    image_io::decode_image(path, limits).map_err(|e| unreadable(path, e))
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
    let (w, h) = (img.width() as usize, img.height() as usize);
    if let image::DynamicImage::ImageRgb8(rgb) = &img {
        // 8-bit: the 256 codes decoded once, exactly as below (no float copy of the image, no
        // power per sample).
        let codes = image::RgbImage::from_fn(256, 1, |x, _| image::Rgb([x as u8; 3]));
        let codes = image::DynamicImage::ImageRgb8(codes).to_rgb32f();
        let table: Vec<f32> = codes
            .as_raw()
            .chunks_exact(3)
            .map(|c| if decode { srgb_to_linear(c[0]) } else { c[0] })
            .collect();
        let plane = |c: usize| rgb.as_raw().par_chunks_exact(3).map(|px| table[px[c] as usize]).collect();
        return Ok((w, h, [plane(0), plane(1), plane(2)]));
    }
    let img = img.to_rgb32f();
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

/// Depth samples as stored, before any unit or kind is applied ([`crate::prepare`] does that):
/// float EXR (channel `Z`, `Y`, `R`, `depth`, `D` or the only one), or an 8/16-bit image.
pub fn read_depth_samples(path: &Path, limits: &ReadLimits) -> Result<DepthSamples, InputError> {
    if is_exr(path) {
        let layer = layer_io::read_exr(path, limits)?;
        let named = ["Z", "Y", "depth", "D"].iter().find_map(|n| layer.channel(n));
        let ch = named
            .or_else(|| layer.channel("R"))
            .or_else(|| (layer.channels.len() == 1).then(|| &layer.channels[0]))
            .ok_or_else(|| InputError::NoDepthChannel { path: path.to_path_buf() })?;
        // R, G and B that differ, with no depth channel named: a colour image.
        let colour_channels = named.is_none()
            && match (layer.channel("R"), layer.channel("G"), layer.channel("B")) {
                (Some(r), Some(g), Some(b)) => differ(&r.data, &g.data, &b.data, 1e-3),
                _ => false,
            };
        return Ok(DepthSamples {
            width: layer.width,
            height: layer.height,
            values: ch.data.clone(),
            format: SampleFormat::F32,
            colour_channels,
        });
    }
    let img = open_image(path, limits)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let colour_channels = img.color().has_color() && {
        let rgb = img.to_rgb32f();
        let plane = |c: usize| rgb.as_raw().iter().skip(c).step_by(3).copied().collect::<Vec<f32>>();
        differ(&plane(0), &plane(1), &plane(2), 2.5 / 255.0)
    };
    let (values, format) = match img.color().bits_per_pixel() / u16::from(img.color().channel_count()) {
        8 => (img.to_luma8().into_raw().into_iter().map(f32::from).collect(), SampleFormat::U8),
        16 => (img.to_luma16().into_raw().into_iter().map(f32::from).collect(), SampleFormat::U16),
        _ => (img.to_luma32f().into_raw(), SampleFormat::F32),
    };
    Ok(DepthSamples { width: w, height: h, values, format, colour_channels })
}

/// Depth samples as a file stores them, before any unit or kind is applied.
#[derive(Clone, Debug)]
pub struct DepthSamples {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Stored values, row-major (integers as their value: 0–255, 0–65535).
    pub values: Vec<f32>,
    /// The stored sample format.
    pub format: SampleFormat,
    /// Whether the file's red, green and blue differ (a colour image, not depth).
    pub colour_channels: bool,
}

/// How a depth file stores its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleFormat {
    /// 8-bit integers.
    U8,
    /// 16-bit integers.
    U16,
    /// Floating point (OpenEXR, Radiance HDR).
    F32,
}

impl SampleFormat {
    /// The stored value of full scale as 1 (nearness maps), for integer formats.
    pub fn unit(self) -> f64 {
        match self {
            SampleFormat::U8 => 1.0 / 255.0,
            SampleFormat::U16 => 1.0 / 65535.0,
            SampleFormat::F32 => 1.0,
        }
    }

    /// `8-bit`, `16-bit` or `float`.
    pub fn name(self) -> &'static str {
        match self {
            SampleFormat::U8 => "8-bit",
            SampleFormat::U16 => "16-bit",
            SampleFormat::F32 => "float",
        }
    }
}

/// Whether more than 1 % of the pixels have channels apart by more than `tol`.
fn differ(r: &[f32], g: &[f32], b: &[f32], tol: f32) -> bool {
    let apart = (0..r.len()).filter(|&i| (r[i] - g[i]).abs() > tol || (g[i] - b[i]).abs() > tol).count();
    apart * 100 > r.len()
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

/// Colour, stored depth samples and normals as read, before the depth is prepared.
#[derive(Clone, Debug)]
pub struct RgbdFiles {
    /// The colour canvas's mapping.
    pub mapping: AnyMapping,
    /// Linear RGB, planar.
    pub rgb: [Vec<f32>; 3],
    /// The depth file's samples (any resolution).
    pub depth: DepthSamples,
    /// Unit normals, if given.
    pub normals: Option<Vec<Vec3>>,
}

/// Read colour, depth samples (+ optional normals EXR); the depth may have any resolution.
pub fn read(
    colour: &Path,
    space: ColourSpace,
    depth: &Path,
    normals: Option<&Path>,
    limits: &ReadLimits,
) -> Result<RgbdFiles, InputError> {
    // Sizes from the headers first: a small file declaring a huge canvas, or a colour canvas that
    // is no panorama, are refused before either is decoded (4 planes: colour and depth).
    let (cw, ch) = header_size(colour, 4, limits)?;
    let kind = mapping_for(colour, cw, ch)?.kind();
    let (dw, dh) = header_size(depth, 4, limits)?;
    if AnyMapping::new(kind, dw, dh).is_err() {
        let (colour, depth) = (colour.to_path_buf(), depth.to_path_buf());
        return Err(InputError::SizeMismatch { colour, cw, ch, depth, dw, dh });
    }
    let (cw, ch, rgb) = read_colour(colour, space, limits)?;
    let mapping = mapping_for(colour, cw, ch)?;
    let samples = read_depth_samples(depth, limits)?;
    let normals = normals.map(|p| read_normals(p, colour, cw, ch, limits)).transpose()?;
    Ok(RgbdFiles { mapping, rgb, depth: samples, normals })
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

    /// 8-bit colour goes through a table of its 256 codes: the planes equal the general path
    /// (`to_rgb32f`, then sRGB decoding unless linear) sample for sample, channels in order.
    #[test]
    fn eight_bit_colour_decodes_as_the_float_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.png");
        let img = image::RgbImage::from_fn(32, 16, |x, y| {
            image::Rgb([(x * 8) as u8, (y * 16 + x) as u8, (255 - x * 7) as u8])
        });
        img.save(&path).unwrap();
        let float = image::DynamicImage::ImageRgb8(img).to_rgb32f();
        for space in [ColourSpace::Auto, ColourSpace::Linear] {
            let (w, h, rgb) = read_colour(&path, space, &ReadLimits::default()).unwrap();
            assert_eq!((w, h), (32, 16));
            for (p, px) in float.as_raw().chunks_exact(3).enumerate() {
                for c in 0..3 {
                    let want = if space == ColourSpace::Auto { srgb_to_linear(px[c]) } else { px[c] };
                    assert_eq!(rgb[c][p].to_bits(), want.to_bits(), "{space:?} pixel {p} channel {c}");
                }
            }
        }
    }

    #[test]
    fn truncated_jpegs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.jpg");
        let img = image::RgbImage::from_fn(512, 256, |x, y| {
            image::Rgb([(x * 7 % 256) as u8, ((x ^ y) % 256) as u8, (y * 13 % 256) as u8])
        });
        img.save(&path).unwrap();
        let whole = std::fs::read(&path).unwrap();
        assert!(image_io::jpeg_is_complete(&whole));
        let limits = ReadLimits::default();
        assert!(open_image(&path, &limits).is_ok());
        // Data after the end-of-image marker (a motion photo's video, a trailer) is no truncation,
        // even when it holds `FF DA` bytes.
        let mut trailer = whole.clone();
        trailer.extend_from_slice(&[0xFF, 0xDA, 0x00, 0x08, 1, 2, 3, 4, 5, 6, 0xAB, 0xFF, 0xDA, 0x12]);
        assert!(image_io::jpeg_is_complete(&trailer));
        let cut = &whole[..whole.len() * 2 / 3];
        assert!(!image_io::jpeg_is_complete(cut));
        // The decoder alone accepts the cut file (the missing rows come out grey).
        assert!(image::load_from_memory(cut).is_ok());
        std::fs::write(&path, cut).unwrap();
        let err = open_image(&path, &limits).unwrap_err();
        assert_eq!(err.code(), "INPUT_UNREADABLE");
        assert!(err.to_string().contains("truncated"), "{err}");
    }

    /// 16-bit PNG depth is read as stored (its unit is applied by the preparation), 8-bit as
    /// 8-bit, and a colour image is flagged.
    #[test]
    fn depth_samples_keep_their_format() {
        let dir = tempfile::tempdir().unwrap();
        let limits = ReadLimits::default();
        let path = dir.path().join("d16.png");
        image::ImageBuffer::<image::Luma<u16>, _>::from_fn(8, 4, |x, _| image::Luma([1000 + x as u16]))
            .save(&path)
            .unwrap();
        let s = read_depth_samples(&path, &limits).unwrap();
        assert_eq!((s.width, s.height, s.format, s.colour_channels), (8, 4, SampleFormat::U16, false));
        assert_eq!(s.values[3], 1003.0);
        let path = dir.path().join("d8.png");
        image::GrayImage::from_fn(8, 4, |x, _| image::Luma([x as u8])).save(&path).unwrap();
        assert_eq!(read_depth_samples(&path, &limits).unwrap().format, SampleFormat::U8);
        let path = dir.path().join("rgb.png");
        image::RgbImage::from_fn(8, 4, |x, y| image::Rgb([(x * 30) as u8, (y * 60) as u8, 7]))
            .save(&path)
            .unwrap();
        assert!(read_depth_samples(&path, &limits).unwrap().colour_channels);
    }
}
