//! A plain interleaved image container: `width × height` pixels of `channels` samples each,
//! row-major, top row first. Pixel `(x, y)` has its centre at `(x + 0.5, y + 0.5)` in
//! continuous pixel coordinates (spec §3.1).

/// Interleaved raster of samples of type `T`.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster<T> {
    width: usize,
    height: usize,
    channels: usize,
    data: Vec<T>,
}

/// Error for a raster whose buffer length does not match its declared size.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("raster buffer holds {got} samples but {width}×{height}×{channels} needs {expected}")]
pub struct RasterSizeError {
    /// Declared width, pixels.
    pub width: usize,
    /// Declared height, pixels.
    pub height: usize,
    /// Declared samples per pixel.
    pub channels: usize,
    /// Samples the declared size needs (`usize::MAX` if the product overflows).
    pub expected: usize,
    /// Samples the buffer holds.
    pub got: usize,
}

impl<T: Copy> Raster<T> {
    /// A raster filled with `value`.
    pub fn filled(width: usize, height: usize, channels: usize, value: T) -> Self {
        Raster { width, height, channels, data: vec![value; width * height * channels] }
    }

    /// Wrap an existing buffer, checking its length.
    pub fn from_vec(
        width: usize,
        height: usize,
        channels: usize,
        data: Vec<T>,
    ) -> Result<Self, RasterSizeError> {
        let expected = width.checked_mul(height).and_then(|n| n.checked_mul(channels)).unwrap_or(usize::MAX);
        if data.len() != expected {
            return Err(RasterSizeError { width, height, channels, expected, got: data.len() });
        }
        Ok(Raster { width, height, channels, data })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Samples per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// All samples, interleaved, row-major, top row first.
    pub fn data(&self) -> &[T] {
        &self.data
    }
    /// All samples, mutably, in the order of [`Raster::data`].
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }
    /// The sample buffer, in the order of [`Raster::data`].
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// Samples of pixel `(x, y)`. Panics if out of bounds (callers index inside the canvas).
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> &[T] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }

    /// Samples of pixel `(x, y)`, mutably. Panics if out of bounds.
    #[inline]
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [T] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }

    /// One row of samples (`width × channels` long).
    #[inline]
    pub fn row(&self, y: usize) -> &[T] {
        let n = self.width * self.channels;
        &self.data[y * n..(y + 1) * n]
    }
}
