//! Plain images at the edges of pomc (PNG, JPEG, OpenEXR, Radiance HDR): decoding with size limits
//! checked from the header, and encoding chosen by extension, written atomically. Samples keep
//! their type (8-bit, 16-bit, float); `pomc convert` resamples them as they are.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder, ImageReader, Limits};

use crate::layer_io::ReadLimits;
use crate::raster::Raster;
use crate::resample::Texel;

/// Reading or writing a plain image failed.
#[derive(Debug, thiserror::Error)]
pub enum ImageIoError {
    /// The file cannot be decoded (corrupt data, an EXR without parts or channels); `IMAGE_UNREADABLE`.
    #[error("{path}: {reason}")]
    Unreadable {
        /// The image file.
        path: PathBuf,
        /// What went wrong, from the decoder.
        reason: String,
    },
    /// The image declares more pixels than [`ReadLimits`] allow; refused before decoding; `IMAGE_TOO_LARGE`.
    #[error("{path}: {reason}")]
    TooLarge {
        /// The image file.
        path: PathBuf,
        /// The declared size and the limit it exceeds.
        reason: String,
    },
    /// The decoder does not support the file's format or a feature of it; `IMAGE_UNSUPPORTED`.
    #[error("{path}: cannot decode ({reason}); supported inputs are PNG, JPEG, EXR and HDR")]
    Unsupported {
        /// The image file.
        path: PathBuf,
        /// What the decoder does not support.
        reason: String,
    },
    /// Opening, reading or writing the file failed (or it is not a regular file); `IMAGE_IO`.
    #[error("{path}: {source}")]
    Io {
        /// The file the operation was on.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The output path's extension is not `.png`, `.jpg`/`.jpeg`, `.exr` or `.hdr`; `IMAGE_UNKNOWN_FORMAT`.
    #[error("{path}: unknown output format; use a .png, .jpg, .exr or .hdr extension")]
    UnknownFormat {
        /// The output file.
        path: PathBuf,
    },
    /// The encoder failed to produce the output bytes; `IMAGE_ENCODE`.
    #[error("{path}: cannot encode ({reason})")]
    Encode {
        /// The output file.
        path: PathBuf,
        /// What the encoder reported.
        reason: String,
    },
}

crate::codes::error_codes! {
    ImageIoError:
        Unreadable IMAGE_UNREADABLE,
        TooLarge IMAGE_TOO_LARGE,
        Unsupported IMAGE_UNSUPPORTED,
        Io IMAGE_IO,
        UnknownFormat IMAGE_UNKNOWN_FORMAT,
        Encode IMAGE_ENCODE
}

/// Decoded pixels of a plain image, kept in their own sample type.
pub enum Pixels {
    /// 8-bit samples (sRGB-encoded colour, as stored).
    U8(Raster<u8>),
    /// 16-bit samples.
    U16(Raster<u16>),
    /// Float samples (linear).
    F32(Raster<f32>),
}

impl Pixels {
    /// Width, height and channels.
    pub fn dims(&self) -> (usize, usize, usize) {
        match self {
            Pixels::U8(r) => (r.width(), r.height(), r.channels()),
            Pixels::U16(r) => (r.width(), r.height(), r.channels()),
            Pixels::F32(r) => (r.width(), r.height(), r.channels()),
        }
    }
    /// `u8`, `u16` or `f32`.
    pub fn type_name(&self) -> &'static str {
        match self {
            Pixels::U8(_) => "u8",
            Pixels::U16(_) => "u16",
            Pixels::F32(_) => "f32",
        }
    }
}

/// Decode a plain EXR through the `exr` crate (any channel set: RGB(A), Y(A) or a single channel), after
/// checking the header's size.
fn decode_exr(path: &Path) -> Result<Pixels, ImageIoError> {
    use exr::prelude::*;
    let limits = ReadLimits::default();
    let bad = |e: exr::error::Error| unreadable(path, format!("cannot decode EXR ({e})"));
    let meta = MetaData::read_from_file(path, false).map_err(bad)?;
    let header = meta.headers.first().ok_or_else(|| unreadable(path, "EXR without parts".into()))?;
    let (w, h) = (header.layer_size.width(), header.layer_size.height());
    if w.max(h) > limits.max_dimension || (w as u64 * h as u64) > limits.max_pixels {
        return Err(ImageIoError::TooLarge {
            path: path.to_path_buf(),
            reason: format!("declares {w}x{h} pixels, beyond the reader limit; refused before decoding"),
        });
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
        return Err(unreadable(path, "EXR without channels".into()));
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

/// Why [`decode_image`] failed; each caller's error names the file and gives its own code.
#[derive(Debug)]
pub enum DecodeFailure {
    /// Opening or reading the file failed (or it is not a regular file).
    Io(std::io::Error),
    /// The decoder refused the data: corrupt, unsupported, or beyond the limits.
    Image(image::ImageError),
    /// A JPEG stops before its end-of-image marker (the decoder alone fills the rest with grey).
    Truncated,
}

impl std::fmt::Display for DecodeFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DecodeFailure::Io(e) => e.fmt(f),
            DecodeFailure::Image(e) => e.fmt(f),
            DecodeFailure::Truncated => f.write_str(
                "the JPEG data stops before its end-of-image marker (a truncated file?); download or export it again",
            ),
        }
    }
}

/// The decoder's limits for `limits`: the sides, and the allocation of the largest accepted canvas
/// as f32 RGBA.
fn image_limits(limits: &ReadLimits) -> Limits {
    let mut l = Limits::default();
    l.max_image_width = Some(limits.max_dimension as u32);
    l.max_image_height = Some(limits.max_dimension as u32);
    l.max_alloc = Some(limits.max_pixels.saturating_mul(16));
    l
}

/// A reader of the regular file `path`, its format guessed from the content.
fn reader(path: &Path) -> Result<ImageReader<std::io::BufReader<std::fs::File>>, std::io::Error> {
    crate::fsutil::check_regular(path)?;
    ImageReader::open(path)?.with_guessed_format()
}

/// What a plain image's header says (`pomc info`): no pixel is decoded.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct ImageHeader {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The container, e.g. `Png`, `Jpeg`.
    pub format: String,
    /// Channels per pixel (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA).
    pub channels: u8,
    /// Bits per channel (8, 16, 32).
    pub bits: u16,
}

/// Read a PNG/JPEG/HDR/… header ([`ImageHeader`]).
pub fn image_header(path: &Path) -> Result<ImageHeader, DecodeFailure> {
    use image::ImageDecoder;
    let reader = reader(path).map_err(DecodeFailure::Io)?;
    let format = reader.format().map(|f| format!("{f:?}")).unwrap_or_else(|| "unknown".into());
    let decoder = reader.into_decoder().map_err(DecodeFailure::Image)?;
    let (width, height) = decoder.dimensions();
    let colour = decoder.color_type();
    let channels = colour.channel_count();
    Ok(ImageHeader { width, height, format, channels, bits: colour.bits_per_pixel() / u16::from(channels) })
}

/// Width and height from a PNG/JPEG/HDR/… header, no pixel decoded.
pub fn image_size(path: &Path) -> Result<(u32, u32), DecodeFailure> {
    reader(path).map_err(DecodeFailure::Io)?.into_dimensions().map_err(DecodeFailure::Image)
}

/// Decode a PNG/JPEG/HDR/… image within `limits`: the one decoder of pomc's plain images, for
/// `pomc convert`, the build's colour and depth, and scene textures. A truncated JPEG is refused.
pub fn decode_image(path: &Path, limits: &ReadLimits) -> Result<DynamicImage, DecodeFailure> {
    let mut reader = reader(path).map_err(DecodeFailure::Io)?;
    reader.limits(image_limits(limits));
    let is_jpeg = reader.format() == Some(image::ImageFormat::Jpeg);
    let image = reader.decode().map_err(DecodeFailure::Image)?;
    if is_jpeg && !jpeg_is_complete(&std::fs::read(path).map_err(DecodeFailure::Io)?) {
        return Err(DecodeFailure::Truncated);
    }
    Ok(image)
}

/// Whether the primary image reaches its end-of-image marker (`FF D9`): the marker segments are
/// walked from the start by their lengths and each scan's entropy-coded data up to the next marker
/// (its `FF` bytes are stuffed), so data after the image (a thumbnail inside `APP1`, a trailer such
/// as a motion photo's video) cannot be mistaken for it.
pub(crate) fn jpeg_is_complete(b: &[u8]) -> bool {
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

/// Decode a plain image, refusing oversized ones from their header.
pub fn decode(path: &Path) -> Result<Pixels, ImageIoError> {
    if extension(path) == "exr" {
        return decode_exr(path);
    }
    let limits = ReadLimits::default();
    let failed = |e: DecodeFailure| {
        let path = path.to_path_buf();
        match e {
            DecodeFailure::Io(source) => ImageIoError::Io { path, source },
            DecodeFailure::Image(e @ image::ImageError::Limits(_)) => {
                ImageIoError::TooLarge { path, reason: e.to_string() }
            }
            DecodeFailure::Image(e @ image::ImageError::Unsupported(_)) => {
                ImageIoError::Unsupported { path, reason: e.to_string() }
            }
            DecodeFailure::Truncated => {
                ImageIoError::Unreadable { path, reason: DecodeFailure::Truncated.to_string() }
            }
            other => ImageIoError::Unreadable {
                path,
                reason: format!("cannot decode ({other}); supported inputs are PNG, JPEG, EXR and HDR"),
            },
        }
    };
    let img = decode_image(path, &limits).map_err(failed)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if (w as u64 * h as u64) > limits.max_pixels {
        return Err(ImageIoError::TooLarge {
            path: path.to_path_buf(),
            reason: format!("{w}x{h} pixels is beyond the {} pixel limit", limits.max_pixels),
        });
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

/// 8-bit samples (float clamped to [0, 1], 16-bit truncated).
pub fn to_u8(p: &Pixels) -> Raster<u8> {
    match p {
        Pixels::U8(r) => r.clone(),
        Pixels::U16(r) => map(r, |v| (v >> 8) as u8),
        Pixels::F32(r) => map(r, |v| u8::from_f32(v.clamp(0.0, 1.0) * 255.0)),
    }
}

/// Float samples in [0, 1] for integer images.
pub fn to_f32(p: &Pixels) -> Raster<f32> {
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

/// The lower-case extension of `path` (empty without one).
pub fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

/// Encode `p` in the format `path`'s extension names (PNG keeps 16-bit; JPEG and HDR drop alpha)
/// and write it atomically.
pub fn encode(path: &Path, p: &Pixels) -> Result<(), ImageIoError> {
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
                    &ne_bytes(r.data()),
                    r.width() as u32,
                    r.height() as u32,
                    ExtendedColorType::Rgb32F,
                )
                .map(|_| buf)
        }
        "exr" => return write_exr(path, &to_f32(p)),
        _ => return Err(ImageIoError::UnknownFormat { path: path.to_path_buf() }),
    }
    .map_err(|e| ImageIoError::Encode { path: path.to_path_buf(), reason: e.to_string() })?;
    write(path, &bytes)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), ImageIoError> {
    crate::fsutil::write_atomic(path, |w| std::io::Write::write_all(w, bytes))
        .map_err(|e| ImageIoError::Io { path: e.path, source: e.source })
}

fn unreadable(path: &Path, reason: String) -> ImageIoError {
    ImageIoError::Unreadable { path: path.to_path_buf(), reason }
}

/// The samples' bytes in native order, as the `image` encoders take float data.
fn ne_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_ne_bytes()).collect()
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
fn write_exr(path: &Path, r: &Raster<f32>) -> Result<(), ImageIoError> {
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
        .map_err(|e| ImageIoError::Encode { path: path.to_path_buf(), reason: format!("EXR: {e}") })?;
    write(path, cursor.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one decoder refuses a cut-off JPEG for every reader: `pomc convert` and scene textures
    /// as the build's inputs do (the `image` decoder alone fills the missing rows with grey).
    #[test]
    fn truncated_jpegs_are_refused_by_the_one_decoder() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.jpg");
        image::RgbImage::from_fn(256, 128, |x, y| {
            image::Rgb([(x * 7 % 256) as u8, ((x ^ y) % 256) as u8, 9])
        })
        .save(&path)
        .unwrap();
        assert!(decode(&path).is_ok());
        let whole = std::fs::read(&path).unwrap();
        std::fs::write(&path, &whole[..whole.len() * 2 / 3]).unwrap();
        let Err(err) = decode(&path) else { panic!("a truncated JPEG decodes") };
        assert_eq!(err.code(), crate::codes::IMAGE_UNREADABLE);
        assert!(err.to_string().contains("truncated"), "{err}");
    }
}
