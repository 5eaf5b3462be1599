//! Layer file I/O (spec §4): native single-part OpenEXR layers, and the thesis form (8/16-bit PNG
//! colour + EXR depth).
//!
//! Every reader checks the header against [`ReadLimits`] before decoding pixels, so a hostile
//! header claiming a gigantic image costs a few hundred bytes of reading, not gigabytes of memory.
//!
//! - `exr`: the native form ([`read_header`], [`read_exr`], [`write_exr`], and their in-memory
//!   variants for fuzzing and tests);
//! - `thesis`: the thesis form ([`read_thesis_layer`]);
//! - [`halfbits`]: bit-exact half ↔ float conversion (NaN payloads kept).

mod exr;
pub mod halfbits;
mod thesis;

use std::path::PathBuf;

use crate::layer::SampleType;

pub use self::exr::{
    is_layer_exr, read_exr, read_exr_bytes, read_header, read_header_bytes, write_exr, write_exr_bytes,
    write_exr_owned,
};
pub use self::thesis::read_thesis_layer;

/// Size limits checked from file headers before any pixel is decoded.
#[derive(Clone, Copy, Debug)]
pub struct ReadLimits {
    /// Largest width or height accepted.
    pub max_dimension: usize,
    /// Largest pixel count accepted.
    pub max_pixels: u64,
    /// Largest channel count accepted.
    pub max_channels: usize,
    /// Largest decoded size in memory, in bytes (pixels × channels × 4: every channel is `f32`
    /// in memory). Bounds what a small, highly compressed file can make the reader allocate.
    pub max_decoded_bytes: u64,
}

impl ReadLimits {
    /// The default limits with the pixel count raised (or lowered) to `max_pixels`, and the side
    /// and decoded-size limits that go with it (`pomc build --max-pixels`).
    pub fn with_max_pixels(max_pixels: u64) -> ReadLimits {
        let mut l = ReadLimits::default();
        l.max_pixels = max_pixels;
        l.max_dimension = l.max_dimension.max((2.0 * max_pixels as f64).sqrt().ceil() as usize);
        l.max_decoded_bytes = l.max_decoded_bytes.max(max_pixels.saturating_mul(16));
        l
    }

    /// Refuse `width × height × channels` when beyond these limits (checked in u64: no overflow).
    pub fn check(&self, width: u64, height: u64, channels: usize) -> Result<(), String> {
        let max_dim = self.max_dimension as u64;
        if width > max_dim || height > max_dim {
            return Err(format!("at most {} pixels wide and high", self.max_dimension));
        }
        if width.saturating_mul(height) > self.max_pixels {
            return Err(format!("at most {} pixels", self.max_pixels));
        }
        if channels > self.max_channels {
            return Err(format!("at most {} channels", self.max_channels));
        }
        let bytes = width.saturating_mul(height).saturating_mul(channels as u64).saturating_mul(4);
        if bytes > self.max_decoded_bytes {
            return Err(format!("at most {} decoded bytes", self.max_decoded_bytes));
        }
        Ok(())
    }
}

impl Default for ReadLimits {
    fn default() -> Self {
        // 16K × 8K equirect, a few attribute channels; 4 GiB decoded (16K × 8K × 8 channels).
        ReadLimits {
            max_dimension: 1 << 15,
            max_pixels: 1 << 28,
            max_channels: 64,
            max_decoded_bytes: 4 << 30,
        }
    }
}

/// EXR compression used when writing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Compression {
    /// Uncompressed (`none`); lossless.
    None,
    /// Run-length encoding (`rle`); lossless.
    Rle,
    /// ZIP, one scanline per block (`zips`); lossless.
    Zip1,
    /// ZIP, 16 scanlines per block (`zip`); lossless, the default for writing.
    Zip16,
    /// Wavelet + Huffman (`piz`); lossless.
    Piz,
    /// PXR24 (`pxr24`): rounds 32-bit floats to 24 bits; lossy, read only.
    Pxr24,
    /// B44 (`b44`): fixed-rate 4×4 blocks of half samples; lossy, read only.
    B44,
    /// B44 with flat blocks stored smaller (`b44a`); lossy, read only.
    B44a,
    /// DWAA (`dwaa`): DCT-based, 32 scanlines per block; lossy, read only.
    Dwaa,
    /// DWAB (`dwab`): DCT-based, 256 scanlines per block; lossy, read only.
    Dwab,
    /// Any other method the EXR reader reports; read only.
    Other,
}

impl Compression {
    /// Lossless for every sample type, hence allowed when writing (bit-exact round trips).
    pub fn is_lossless(self) -> bool {
        matches!(
            self,
            Compression::None | Compression::Rle | Compression::Zip1 | Compression::Zip16 | Compression::Piz
        )
    }

    /// Lower-case name, as in reports and messages (`zip` is [`Compression::Zip16`], `zips` is
    /// [`Compression::Zip1`]).
    pub fn name(self) -> &'static str {
        match self {
            Compression::None => "none",
            Compression::Rle => "rle",
            Compression::Zip1 => "zips",
            Compression::Zip16 => "zip",
            Compression::Piz => "piz",
            Compression::Pxr24 => "pxr24",
            Compression::B44 => "b44",
            Compression::B44a => "b44a",
            Compression::Dwaa => "dwaa",
            Compression::Dwab => "dwab",
            Compression::Other => "other",
        }
    }
}

/// How layers are written.
#[derive(Clone, Copy, Debug)]
pub struct WriteOptions {
    /// Lossless compression only (ZIP by default) so round trips are bit-exact.
    pub compression: Compression,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions { compression: Compression::Zip16 }
    }
}

/// What an EXR header says, read without decoding pixels.
///
/// `width × height` is the size of the data window: the layer canvas is the data window, whatever
/// its origin and whatever the display window (spec §4.6).
#[derive(Clone, Debug, PartialEq)]
pub struct ExrHeader {
    /// Width of the data window, pixels.
    pub width: usize,
    /// Height of the data window, pixels.
    pub height: usize,
    /// Origin of the data window (informative; pixel `(0,0)` of the layer is this corner).
    pub origin: (i32, i32),
    /// Channel names and sample types, in file order.
    pub channels: Vec<(String, SampleType)>,
    /// The file's compression method.
    pub compression: Compression,
    /// Stored in tiles rather than scanlines.
    pub tiled: bool,
    /// Tiled with MIP or RIP levels (only the full-resolution level is read).
    pub mip_levels: bool,
}

/// Errors reading or writing layer files. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum LayerIoError {
    /// The file does not exist; [`crate::codes::LAYER_NOT_FOUND`].
    #[error("{path}: file not found; check the file name in the manifest")]
    NotFound {
        /// The missing file.
        path: PathBuf,
    },
    /// Opening, reading or writing the file failed otherwise; [`crate::codes::LAYER_IO_ERROR`].
    #[error("{path}: {source}")]
    Io {
        /// The file the operation was on.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Not a decodable image (bad magic number, corrupt header or data, empty data window);
    /// [`crate::codes::LAYER_UNREADABLE`].
    #[error("{path}: not a readable image: {reason}")]
    Unreadable {
        /// The layer file.
        path: PathBuf,
        /// What is wrong, from the decoder.
        reason: String,
    },
    /// The file ends before its header or pixel data does; [`crate::codes::LAYER_TRUNCATED`].
    #[error("{path}: the file ends before its data does ({reason}); re-export it")]
    Truncated {
        /// The layer file.
        path: PathBuf,
        /// Where the data stops.
        reason: String,
    },
    /// The header declares more than [`ReadLimits`] allow; refused before decoding;
    /// [`crate::codes::LAYER_TOO_LARGE`].
    #[error("{path}: declares {width}x{height} pixels × {channels} channels, beyond the reader limit ({limit}); refused before decoding")]
    TooLarge {
        /// The layer file.
        path: PathBuf,
        /// Declared width, pixels.
        width: u64,
        /// Declared height, pixels.
        height: u64,
        /// Declared channel count.
        channels: usize,
        /// The limit exceeded, from [`ReadLimits::check`].
        limit: String,
    },
    /// The EXR has more than one part; [`crate::codes::LAYER_MULTIPART`].
    #[error(
        "{path}: has {parts} parts; a POMC 1 layer is a single-part EXR, split it into one file per layer"
    )]
    MultiPart {
        /// The layer file.
        path: PathBuf,
        /// Number of parts in the file.
        parts: usize,
    },
    /// The EXR holds deep data; [`crate::codes::LAYER_DEEP`].
    #[error("{path}: holds deep data; POMC 1 layers are flat images")]
    Deep {
        /// The layer file.
        path: PathBuf,
    },
    /// A feature this reader or writer does not handle (subsampled channels, lossy or empty
    /// writes, a thesis-form file without the expected channels); [`crate::codes::LAYER_UNSUPPORTED`].
    #[error("{path}: {what} is not supported")]
    Unsupported {
        /// The layer file.
        path: PathBuf,
        /// The unsupported feature.
        what: String,
    },
    /// Two files of one thesis-form layer differ in size; [`crate::codes::LAYER_SIZE_MISMATCH`].
    #[error("{path}: size {found:?} differs from {expected:?} of {other}; the files of one layer must have the same size")]
    SizeMismatch {
        /// The file whose size differs.
        path: PathBuf,
        /// Its `(width, height)`, pixels.
        found: (usize, usize),
        /// `(width, height)` of `other`, pixels.
        expected: (usize, usize),
        /// The layer's reference file.
        other: PathBuf,
    },
}

crate::codes::error_codes! {
    LayerIoError:
        NotFound LAYER_NOT_FOUND,
        Io LAYER_IO_ERROR,
        Unreadable LAYER_UNREADABLE,
        Truncated LAYER_TRUNCATED,
        TooLarge LAYER_TOO_LARGE,
        MultiPart LAYER_MULTIPART,
        Deep LAYER_DEEP,
        Unsupported LAYER_UNSUPPORTED,
        SizeMismatch LAYER_SIZE_MISMATCH
}

#[cfg(test)]
mod tests;
