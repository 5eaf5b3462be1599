//! The thesis form of a layer (spec §4.7): a colour image (`mapname`, PNG), a depth EXR
//! (`depthname`) and optionally a normals EXR, all of the same size.
//!
//! Thesis colour is sRGB-encoded like every 8/16-bit image pomc reads ([`crate::colour`]): R, G, B
//! are decoded to linear on read (alpha is coverage, kept as is). 8-bit codes become `F16` samples
//! (half is precise enough that re-encoding gives the code back); 16-bit codes become `F32`.

use std::path::Path;

use image::{DynamicImage, ImageReader};

use super::exr::{io_error, read_exr};
use super::halfbits::{f32_to_half, half_to_f32};
use super::{LayerIoError, ReadLimits};
use crate::colour::srgb_to_linear;
use crate::layer::{LayerImage, SampleType};

/// Depth channel names tried in order; otherwise a single-channel file's only channel.
const DEPTH_NAMES: [&str; 3] = ["Z", "Y", "R"];
/// Normal channel name triples accepted, mapped to `N.X, N.Y, N.Z`.
const NORMAL_NAMES: [[&str; 3]; 3] = [["N.X", "N.Y", "N.Z"], ["R", "G", "B"], ["X", "Y", "Z"]];

/// Read the thesis form: colour image (8/16-bit PNG, RGB or RGBA; alpha = coverage), depth EXR
/// (a `Z`, `Y`, `R` or single channel; negative = outside), optional normals EXR.
///
/// The result has `R,G,B` (and `A`), `Z` (F32) and, with normals, `N.X,N.Y,N.Z`. Without alpha
/// in the colour file, `A` is derived from the thesis convention: 0 where depth < 0, else 1.
pub fn read_thesis_layer(
    map: &Path,
    depth: &Path,
    normals: Option<&Path>,
    limits: &ReadLimits,
) -> Result<LayerImage, LayerIoError> {
    let colour = read_colour(map, limits)?;
    let depth_image = read_exr(depth, limits)?;
    same_size(depth, &depth_image, map, &colour)?;
    let z = depth_channel(depth, &depth_image)?;
    let mut layer = colour;
    if layer.channel("A").is_none() {
        let a = z.iter().map(|&d| if d < 0.0 { 0.0 } else { 1.0 }).collect();
        layer.set_channel("A", SampleType::F16, a);
    }
    layer.set_channel("Z", SampleType::F32, z);
    if let Some(npath) = normals {
        let n = read_exr(npath, limits)?;
        same_size(npath, &n, map, &layer)?;
        for (name, (t, data)) in ["N.X", "N.Y", "N.Z"].into_iter().zip(normal_channels(npath, n)?) {
            layer.set_channel(name, t, data);
        }
    }
    Ok(layer)
}

/// Decode the colour image with `limits` enforced by the decoder itself.
fn read_colour(path: &Path, limits: &ReadLimits) -> Result<LayerImage, LayerIoError> {
    crate::fsutil::check_regular(path).map_err(|e| io_error(path, e))?;
    let open = || -> Result<ImageReader<_>, LayerIoError> {
        ImageReader::open(path)
            .map_err(|e| io_error(path, e))?
            .with_guessed_format()
            .map_err(|e| io_error(path, e))
    };
    let (w, h) = open()?.into_dimensions().map_err(|e| image_error(path, e))?;
    limits.check(u64::from(w), u64::from(h), 4).map_err(|limit| LayerIoError::TooLarge {
        path: path.to_path_buf(),
        width: u64::from(w),
        height: u64::from(h),
        channels: 4,
        limit,
    })?;
    let mut reader = open()?;
    let mut il = image::Limits::default();
    let side = u32::try_from(limits.max_dimension).unwrap_or(u32::MAX);
    il.max_image_width = Some(side);
    il.max_image_height = Some(side);
    // Up to 4 channels of 16 bits, decoded once and converted once.
    il.max_alloc = Some(limits.max_pixels.saturating_mul(16));
    reader.limits(il);
    let img = reader.decode().map_err(|e| image_error(path, e))?;
    Ok(colour_layer(img))
}

/// Planar colour channels: R, G, B decoded from sRGB to linear, A as coverage.
fn colour_layer(img: DynamicImage) -> LayerImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let alpha = img.color().has_alpha();
    let names: &[&str] = if alpha { &["R", "G", "B", "A"] } else { &["R", "G", "B"] };
    let mut layer = LayerImage::new(w, h);
    let bits = img.color().bits_per_pixel() / u16::from(img.color().channel_count());
    let (t, planes) = match bits {
        8 => (SampleType::F16, planes_u8(&img, alpha)),
        16 => (SampleType::F32, planes_u16(&img, alpha)),
        _ => (SampleType::F32, planes_f32(&img, alpha)),
    };
    for (name, data) in names.iter().zip(planes) {
        layer.set_channel(name, t, data);
    }
    layer
}

fn planes_u8(img: &DynamicImage, alpha: bool) -> Vec<Vec<f32>> {
    // Quantised to half: exact enough that sRGB encoding gives the code back.
    let half = |x: f32| half_to_f32(f32_to_half(x));
    let f = |c: u8| half(srgb_to_linear(f32::from(c) / 255.0));
    let a = |c: u8| half(f32::from(c) / 255.0);
    if alpha {
        split(img.to_rgba8().pixels().map(|p| [f(p[0]), f(p[1]), f(p[2]), a(p[3])]), 4)
    } else {
        split(img.to_rgb8().pixels().map(|p| p.0.map(f)), 3)
    }
}

fn planes_u16(img: &DynamicImage, alpha: bool) -> Vec<Vec<f32>> {
    let f = |c: u16| srgb_to_linear(f32::from(c) / 65535.0);
    let a = |c: u16| f32::from(c) / 65535.0;
    if alpha {
        split(img.to_rgba16().pixels().map(|p| [f(p[0]), f(p[1]), f(p[2]), a(p[3])]), 4)
    } else {
        split(img.to_rgb16().pixels().map(|p| p.0.map(f)), 3)
    }
}

fn planes_f32(img: &DynamicImage, alpha: bool) -> Vec<Vec<f32>> {
    if alpha {
        split(img.to_rgba32f().pixels().map(|p| p.0), 4)
    } else {
        split(img.to_rgb32f().pixels().map(|p| p.0), 3)
    }
}

/// Interleaved pixels → `n` planes.
fn split<const N: usize>(pixels: impl Iterator<Item = [f32; N]>, n: usize) -> Vec<Vec<f32>> {
    let mut planes: Vec<Vec<f32>> = vec![Vec::new(); n];
    for p in pixels {
        for (plane, v) in planes.iter_mut().zip(p) {
            plane.push(v);
        }
    }
    planes
}

fn same_size(
    path: &Path,
    img: &LayerImage,
    other: &Path,
    reference: &LayerImage,
) -> Result<(), LayerIoError> {
    if (img.width, img.height) == (reference.width, reference.height) {
        return Ok(());
    }
    Err(LayerIoError::SizeMismatch {
        path: path.to_path_buf(),
        found: (img.width, img.height),
        expected: (reference.width, reference.height),
        other: other.to_path_buf(),
    })
}

/// The depth samples: `Z`, else `Y`, else `R`, else the only channel.
fn depth_channel(path: &Path, img: &LayerImage) -> Result<Vec<f32>, LayerIoError> {
    let found = DEPTH_NAMES.iter().find_map(|n| img.channel(n));
    let only = if img.channels.len() == 1 { img.channels.first() } else { None };
    match found.or(only) {
        Some(c) => Ok(c.data.clone()),
        None => Err(LayerIoError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "a depth file with channels {:?} (none is Z, Y or R); name the depth channel Z",
                names(img)
            ),
        }),
    }
}

/// The three normal channels with their file types, in X, Y, Z order.
fn normal_channels(path: &Path, mut img: LayerImage) -> Result<Vec<(SampleType, Vec<f32>)>, LayerIoError> {
    let triple = NORMAL_NAMES.iter().find(|t| t.iter().all(|n| img.channel(n).is_some()));
    let Some(triple) = triple else {
        return Err(LayerIoError::Unsupported {
            path: path.to_path_buf(),
            what: format!("a normals file with channels {:?}; expected N.X,N.Y,N.Z or R,G,B", names(&img)),
        });
    };
    Ok(triple
        .iter()
        .map(|n| {
            let c = img.channel_mut(n).expect("checked above");
            (c.sample_type, std::mem::take(&mut c.data))
        })
        .collect())
}

fn names(img: &LayerImage) -> Vec<&str> {
    img.channels.iter().map(|c| c.name.as_str()).collect()
}

fn image_error(path: &Path, e: image::ImageError) -> LayerIoError {
    match e {
        image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            LayerIoError::Truncated { path: path.to_path_buf(), reason: io.to_string() }
        }
        image::ImageError::IoError(io) => io_error(path, io),
        image::ImageError::Limits(l) => LayerIoError::TooLarge {
            path: path.to_path_buf(),
            width: 0,
            height: 0,
            channels: 4,
            limit: l.to_string(),
        },
        image::ImageError::Unsupported(u) => {
            LayerIoError::Unsupported { path: path.to_path_buf(), what: u.to_string() }
        }
        other => LayerIoError::Unreadable { path: path.to_path_buf(), reason: other.to_string() },
    }
}
