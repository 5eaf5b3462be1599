//! The native layer form: one single-part, flat OpenEXR image per layer (spec §4).
//!
//! Reading is done in two steps so that hostile files cost nothing: the header alone is parsed
//! and checked (part count, deep data, size limits), and only then are the pixels decoded, from
//! a file read into memory with a size cap derived from the header. The `exr` crate is wrapped in
//! `catch_unwind` as a last line of defence: malformed data must give an error, never a panic.

use std::io::{Cursor, Read};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use exr::meta::attribute::{LevelMode, SampleType as ExrSampleType};
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::{self as xr, ReadChannels, ReadLayers, WritableImage};

use super::halfbits::{f32s_to_half, halves_to_f32};
use super::{Compression, ExrHeader, LayerIoError, ReadLimits, WriteOptions};
use crate::layer::{LayerImage, SampleType};

/// OpenEXR magic number, little-endian.
const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// Version-field flag bits (OpenEXR file layout, "version field").
const FLAG_DEEP: u32 = 1 << 11;
/// Bytes allowed beyond the pixel data (headers, offset tables, compression overhead).
const SLACK_BYTES: u64 = 16 << 20;

/// Read an EXR header (no pixels), checking it against `limits`.
pub fn read_header(path: &Path, limits: &ReadLimits) -> Result<ExrHeader, LayerIoError> {
    let file = open(path)?;
    // The header is at most a few kilobytes; cap what the parser may consume anyway.
    let reader = std::io::BufReader::new(file.take(SLACK_BYTES));
    let (header, _) = parse_header(reader, path, limits)?;
    Ok(header)
}

/// [`read_header`] on bytes already in memory (`path` only names them in errors).
pub fn read_header_bytes(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<ExrHeader, LayerIoError> {
    parse_header(Cursor::new(bytes), path, limits).map(|(h, _)| h)
}

/// Read a native layer EXR: all channels of its single part as `f32`, their file types recorded.
pub fn read_exr(path: &Path, limits: &ReadLimits) -> Result<LayerImage, LayerIoError> {
    let header = read_header(path, limits)?;
    let cap = byte_cap(&header);
    let len = std::fs::metadata(path).map_err(|e| io_error(path, e))?.len();
    if len > cap {
        return Err(unreadable(
            path,
            format!("the file is {len} bytes, more than the {cap} bytes its header can account for"),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    read_exr_bytes(&bytes, path, limits)
}

/// [`read_exr`] on bytes already in memory (`path` only names them in errors).
pub fn read_exr_bytes(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<LayerImage, LayerIoError> {
    let mut cursor = Cursor::new(bytes);
    let (header, chunks) = parse_header(&mut cursor, path, limits)?;
    let chunk_count = chunks.count;
    let header_end = cursor.position();
    // A chunk placed past the end of the file: refuse before the decoder allocates the image.
    if let Some(reason) = truncation(bytes, header_end, chunk_count) {
        return Err(LayerIoError::Truncated { path: path.to_path_buf(), reason });
    }
    if let Some(reason) = misplaced_chunk(bytes, header_end, &chunks) {
        return Err(unreadable(path, reason));
    }
    let decoded = guarded(path, || {
        xr::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
    })?;
    let image = match decoded {
        Ok(image) => image,
        Err(e) => {
            if let Some(reason) = truncation(bytes, header_end, chunk_count) {
                return Err(LayerIoError::Truncated { path: path.to_path_buf(), reason });
            }
            return Err(map_exr_error(path, e));
        }
    };
    to_layer(path, &header, image.layer_data.channel_data.list)
}

/// Write a layer EXR atomically (single part, scanlines, lossless compression).
pub fn write_exr(path: &Path, image: &LayerImage, options: &WriteOptions) -> Result<(), crate::Error> {
    check_writable(path, image, options)?;
    let channels =
        image.channels.iter().map(|c| xr::AnyChannel::new(c.name.as_str(), to_samples(c))).collect();
    write_channels(path, (image.width, image.height), channels, options)
}

/// [`write_exr`] taking the layer: each channel's samples move into the encoder (`F16` ones are
/// converted one channel at a time), so a large layer is held once, not twice, and the encoded
/// file streams to disk.
pub fn write_exr_owned(path: &Path, image: LayerImage, options: &WriteOptions) -> Result<(), crate::Error> {
    check_writable(path, &image, options)?;
    let size = (image.width, image.height);
    let channels = image
        .channels
        .into_iter()
        .map(|c| {
            let name = c.name.clone();
            xr::AnyChannel::new(name.as_str(), into_samples(c))
        })
        .collect();
    write_channels(path, size, channels, options)
}

/// Encode a layer as EXR bytes (what [`write_exr`] writes; `path` only names errors).
pub fn write_exr_bytes(
    path: &Path,
    image: &LayerImage,
    options: &WriteOptions,
) -> Result<Vec<u8>, LayerIoError> {
    check_writable(path, image, options)?;
    let channels =
        image.channels.iter().map(|c| xr::AnyChannel::new(c.name.as_str(), to_samples(c))).collect();
    let mut out = Cursor::new(Vec::new());
    encode(path, (image.width, image.height), channels, options, &mut out)?;
    Ok(out.into_inner())
}

type ExrChannels = xr::SmallVec<[xr::AnyChannel<xr::FlatSamples>; 4]>;

fn check_writable(path: &Path, image: &LayerImage, options: &WriteOptions) -> Result<(), LayerIoError> {
    let unsupported = |what: String| LayerIoError::Unsupported { path: path.to_path_buf(), what };
    if !options.compression.is_lossless() {
        return Err(unsupported(format!(
            "writing with {} compression (lossy for some sample types; use zip, zips, piz, rle or none)",
            options.compression.name()
        )));
    }
    if image.width == 0 || image.height == 0 || image.channels.is_empty() {
        return Err(unsupported(format!(
            "writing an empty image ({}x{}, {} channels)",
            image.width,
            image.height,
            image.channels.len()
        )));
    }
    Ok(())
}

/// Encode straight into a temporary file that replaces `path` once complete.
fn write_channels(
    path: &Path,
    size: (usize, usize),
    channels: ExrChannels,
    options: &WriteOptions,
) -> Result<(), crate::Error> {
    let mut failed = None;
    let written = crate::fsutil::write_atomic(path, |w| {
        encode(path, size, channels, options, w).map_err(|e| {
            failed = Some(e);
            std::io::Error::other("EXR encoding failed")
        })
    });
    match (written, failed) {
        (_, Some(e)) => Err(e.into()),
        (r, None) => Ok(r?),
    }
}

fn encode(
    path: &Path,
    size: (usize, usize),
    channels: ExrChannels,
    options: &WriteOptions,
    out: impl std::io::Write + std::io::Seek,
) -> Result<(), LayerIoError> {
    let encoding = xr::Encoding {
        compression: to_exr_compression(options.compression),
        blocks: xr::Blocks::ScanLines,
        line_order: xr::LineOrder::Increasing,
    };
    let exr_image = xr::Image::from_encoded_channels(size, encoding, xr::AnyChannels::sort(channels));
    exr_image.write().to_buffered(out).map_err(|e| map_exr_error(path, e))
}

/// Where the offset table starts and how many chunks it lists.
#[cfg(test)]
pub(super) fn offset_table_for_tests(bytes: &[u8], path: &Path) -> (usize, usize) {
    let mut cursor = Cursor::new(bytes);
    let (_, chunks) = parse_header(&mut cursor, path, &ReadLimits::default()).unwrap();
    (cursor.position() as usize, chunks.count)
}

/// What the chunk checks need from the header.
struct Chunks {
    count: usize,
    /// First scanline of the data window and scanlines per chunk; `None` for tiled files.
    scanlines: Option<(i32, usize)>,
}

/// Parse and check the header; returns it with its chunk layout (for truncation checks).
fn parse_header(
    reader: impl Read,
    path: &Path,
    limits: &ReadLimits,
) -> Result<(ExrHeader, Chunks), LayerIoError> {
    let meta = read_meta(reader, path)?;
    let h = &meta.headers[0];
    check_layout(h, path, limits)?;
    let (tiled, mip_levels) = match &h.blocks {
        BlockDescription::ScanLines => (false, false),
        BlockDescription::Tiles(t) => (true, t.level_mode != LevelMode::Singular),
    };
    let header = ExrHeader {
        width: h.layer_size.0,
        height: h.layer_size.1,
        origin: (h.own_attributes.layer_position.0, h.own_attributes.layer_position.1),
        channels: h
            .channels
            .list
            .iter()
            .map(|c| (c.name.to_string(), from_exr_type(c.sample_type)))
            .collect(),
        compression: from_exr_compression(h.compression),
        tiled,
        mip_levels,
    };
    let scanlines = (!tiled).then(|| (header.origin.1, h.compression.scan_lines_per_block()));
    Ok((header, Chunks { count: h.chunk_count, scanlines }))
}

/// The metadata of a single-part, flat (not deep) EXR file.
fn read_meta(mut reader: impl Read, path: &Path) -> Result<MetaData, LayerIoError> {
    let mut prefix = [0u8; 8];
    if let Err(e) = reader.read_exact(&mut prefix) {
        return Err(if e.kind() == std::io::ErrorKind::UnexpectedEof {
            unreadable(path, "shorter than an EXR header (8 bytes)".into())
        } else {
            io_error(path, e)
        });
    }
    if prefix[..4] != MAGIC {
        return Err(unreadable(path, "not an OpenEXR file (bad magic number)".into()));
    }
    let flags = u32::from_le_bytes([prefix[4], prefix[5], prefix[6], prefix[7]]);
    if flags & FLAG_DEEP != 0 {
        return Err(LayerIoError::Deep { path: path.to_path_buf() });
    }
    let meta = guarded(path, || MetaData::read_from_buffered(Cursor::new(prefix).chain(reader), true))?
        .map_err(|e| map_header_error(path, e))?;
    if meta.headers.len() != 1 {
        return Err(LayerIoError::MultiPart { path: path.to_path_buf(), parts: meta.headers.len() });
    }
    if meta.headers[0].deep {
        return Err(LayerIoError::Deep { path: path.to_path_buf() });
    }
    Ok(meta)
}

/// A layer's size within `limits`, not empty, its channels full-resolution and uniquely named.
fn check_layout(h: &exr::meta::header::Header, path: &Path, limits: &ReadLimits) -> Result<(), LayerIoError> {
    let (w, hgt) = (h.layer_size.0, h.layer_size.1);
    limits.check(w as u64, hgt as u64, h.channels.list.len()).map_err(|limit| LayerIoError::TooLarge {
        path: path.to_path_buf(),
        width: w as u64,
        height: hgt as u64,
        channels: h.channels.list.len(),
        limit,
    })?;
    if let Some(c) = h.channels.list.iter().find(|c| c.sampling != xr::Vec2(1, 1)) {
        return Err(LayerIoError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "subsampled channel {} (1 sample per {}×{} pixels)",
                c.name, c.sampling.0, c.sampling.1
            ),
        });
    }
    if w == 0 || hgt == 0 {
        return Err(unreadable(path, "empty data window".into()));
    }
    // The list is sorted by name (the format requires it), so a repeated name is adjacent.
    if let Some(pair) = h.channels.list.windows(2).find(|p| p[0].name == p[1].name) {
        return Err(unreadable(
            path,
            format!("channel {} appears twice; each channel name must be unique", pair[0].name),
        ));
    }
    Ok(())
}

/// Largest file size a header can account for: all levels of raw pixels (RIP maps at most
/// quadruple the data) plus headers and offset tables.
fn byte_cap(h: &ExrHeader) -> u64 {
    let bytes_per_pixel: u64 =
        h.channels.iter().map(|(_, t)| if *t == SampleType::F16 { 2 } else { 4 }).sum();
    let raw = (h.width as u64).saturating_mul(h.height as u64).saturating_mul(bytes_per_pixel);
    let levels = if h.mip_levels { 4 } else { 1 };
    raw.saturating_mul(levels).saturating_add(raw / 2).saturating_add(SLACK_BYTES)
}

/// Why a file that failed to decode is truncated, if it is: its offset table or a chunk it
/// points to ends past the end of the file.
fn truncation(bytes: &[u8], header_end: u64, chunk_count: usize) -> Option<String> {
    let len = bytes.len() as u64;
    let table_end = header_end.saturating_add(8 * chunk_count as u64);
    if table_end > len {
        return Some(format!("offset table needs {table_end} bytes, file has {len}"));
    }
    let table = &bytes[header_end as usize..table_end as usize];
    let beyond = table
        .chunks_exact(8)
        .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
        .filter(|&off| off >= len)
        .count();
    (beyond > 0).then(|| {
        format!("{beyond} of {chunk_count} pixel chunks start past the end of the file ({len} bytes)")
    })
}

/// A scanline chunk whose leader names another block than its place in the offset table (the
/// table is in block order whatever the line order): OpenEXR refuses such a file
/// (`EXR_ERR_BAD_CHUNK_LEADER`), the `exr` crate would decode it over another block and lose a line.
/// Call after [`truncation`] found every offset inside the file.
fn misplaced_chunk(bytes: &[u8], header_end: u64, chunks: &Chunks) -> Option<String> {
    let (y_min, lines) = chunks.scanlines?;
    let table = bytes.get(header_end as usize..)?.chunks_exact(8).take(chunks.count);
    for (i, entry) in table.enumerate() {
        let off = u64::from_le_bytes(entry.try_into().ok()?) as usize;
        let leader = bytes.get(off..off.checked_add(4)?)?;
        let y = i64::from(i32::from_le_bytes(leader.try_into().ok()?));
        let expected = i64::from(y_min) + (i as i64) * lines as i64;
        if y != expected {
            return Some(format!(
                "pixel chunk {i} at byte {off} says it holds scanline {y}, but its place in the offset \
                 table is scanline {expected}; the file is corrupt"
            ));
        }
    }
    None
}

/// Run `f`, turning a panic of the decoder into an error.
fn guarded<T>(path: &Path, f: impl FnOnce() -> T) -> Result<T, LayerIoError> {
    catch_unwind(AssertUnwindSafe(f))
        .map_err(|_| unreadable(path, "the EXR decoder failed on malformed data".into()))
}

/// Move the decoded channels into a planar `f32` layer.
fn to_layer(
    path: &Path,
    header: &ExrHeader,
    channels: xr::SmallVec<[xr::AnyChannel<xr::FlatSamples>; 4]>,
) -> Result<LayerImage, LayerIoError> {
    let mut image = LayerImage::new(header.width, header.height);
    for c in channels {
        let (sample_type, data) = from_samples(c.sample_data);
        if data.len() != header.width * header.height {
            return Err(unreadable(path, format!("channel {} has {} samples", c.name, data.len())));
        }
        image.set_channel(&c.name.to_string(), sample_type, data);
    }
    Ok(image)
}

fn from_samples(samples: xr::FlatSamples) -> (SampleType, Vec<f32>) {
    match samples {
        xr::FlatSamples::F16(v) => (SampleType::F16, halves_to_f32(&v)),
        xr::FlatSamples::F32(v) => (SampleType::F32, v),
        xr::FlatSamples::U32(v) => (SampleType::U32, v.into_iter().map(|x| x as f32).collect()),
    }
}

/// A channel's samples in its file type. `U32` rounds to the nearest integer, saturating
/// (NaN becomes 0): in memory such channels are `f32`, exact up to 2²⁴.
fn into_samples(c: crate::layer::Channel) -> xr::FlatSamples {
    match c.sample_type {
        SampleType::F16 => to_samples(&c),
        SampleType::F32 => xr::FlatSamples::F32(c.data),
        // Same size: the collect reuses the allocation.
        SampleType::U32 => xr::FlatSamples::U32(c.data.into_iter().map(|x| x.round() as u32).collect()),
    }
}

fn to_samples(c: &crate::layer::Channel) -> xr::FlatSamples {
    match c.sample_type {
        SampleType::F16 => xr::FlatSamples::F16(f32s_to_half(&c.data)),
        SampleType::F32 => xr::FlatSamples::F32(c.data.clone()),
        SampleType::U32 => xr::FlatSamples::U32(c.data.iter().map(|&x| x.round() as u32).collect()),
    }
}

fn from_exr_type(t: ExrSampleType) -> SampleType {
    match t {
        ExrSampleType::F16 => SampleType::F16,
        ExrSampleType::F32 => SampleType::F32,
        ExrSampleType::U32 => SampleType::U32,
    }
}

fn from_exr_compression(c: xr::Compression) -> Compression {
    use xr::Compression as X;
    match c {
        X::Uncompressed => Compression::None,
        X::RLE => Compression::Rle,
        X::ZIP1 => Compression::Zip1,
        X::ZIP16 => Compression::Zip16,
        X::PIZ => Compression::Piz,
        X::PXR24 => Compression::Pxr24,
        X::B44 => Compression::B44,
        X::B44A => Compression::B44a,
        X::DWAA(_) => Compression::Dwaa,
        X::DWAB(_) => Compression::Dwab,
        #[allow(unreachable_patterns)]
        _ => Compression::Other,
    }
}

/// Only called with lossless kinds (checked by the caller).
fn to_exr_compression(c: Compression) -> xr::Compression {
    use xr::Compression as X;
    match c {
        Compression::Rle => X::RLE,
        Compression::Zip1 => X::ZIP1,
        Compression::Zip16 => X::ZIP16,
        Compression::Piz => X::PIZ,
        _ => X::Uncompressed,
    }
}

fn open(path: &Path) -> Result<std::fs::File, LayerIoError> {
    crate::fsutil::check_regular(path).map_err(|e| io_error(path, e))?;
    std::fs::File::open(path).map_err(|e| io_error(path, e))
}

pub(super) fn io_error(path: &Path, e: std::io::Error) -> LayerIoError {
    match e.kind() {
        std::io::ErrorKind::NotFound => LayerIoError::NotFound { path: path.to_path_buf() },
        _ => LayerIoError::Io { path: path.to_path_buf(), source: e },
    }
}

fn unreadable(path: &Path, reason: String) -> LayerIoError {
    LayerIoError::Unreadable { path: path.to_path_buf(), reason }
}

/// While reading the header, running out of bytes means the file is cut short.
fn map_header_error(path: &Path, e: exr::error::Error) -> LayerIoError {
    match e {
        exr::error::Error::Invalid(m) if m.contains("missing bytes") => {
            LayerIoError::Truncated { path: path.to_path_buf(), reason: "the header is incomplete".into() }
        }
        other => map_exr_error(path, other),
    }
}

fn map_exr_error(path: &Path, e: exr::error::Error) -> LayerIoError {
    match e {
        exr::error::Error::Io(io) => io_error(path, io),
        exr::error::Error::NotSupported(what) => {
            LayerIoError::Unsupported { path: path.to_path_buf(), what: what.into_owned() }
        }
        exr::error::Error::Invalid(m) if m.contains("missing bytes") => {
            LayerIoError::Truncated { path: path.to_path_buf(), reason: m.into_owned() }
        }
        exr::error::Error::Invalid(m) => unreadable(path, m.into_owned()),
        exr::error::Error::Aborted => unreadable(path, "decoding aborted".into()),
    }
}

/// Whether `path` is a layer EXR: an `.exr` whose header has a `Z` channel (spec §4); plain EXRs
/// are colour images. Only the header is read; an unreadable file is not a layer.
pub fn is_layer_exr(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if ext.as_deref() != Some("exr") || crate::fsutil::check_regular(path).is_err() {
        return false;
    }
    exr::meta::MetaData::read_from_file(path, false)
        .map(|m| m.headers.iter().any(|h| h.channels.list.iter().any(|c| c.name.to_string() == "Z")))
        .unwrap_or(false)
}
