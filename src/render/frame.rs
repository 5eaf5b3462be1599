//! The rendered frame and its files (spec §9.5): linear colour (EXR, or PNG through a fixed tone
//! map), camera distance (EXR) and the coverage mask (PNG).
//!
//! Per pixel: colour is the filter-weighted mean of the visible samples, depth the weighted mean
//! distance from the eye (`+inf` where only infinitely far content is seen). A *hole* is a pixel no
//! sample reached: colour 0, depth −1 (the layers' "outside" value), mask 0. No pixel is ever NaN.

use std::path::Path;

use image::{ExtendedColorType, ImageEncoder};

use super::accum::{Accum, Cell};
use super::RenderError;
use crate::layer::{LayerImage, SampleType, OUTSIDE_DEPTH};

/// A rendered image.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels; planes are row-major, top row first.
    pub height: usize,
    /// Linear RGB, planar.
    pub rgb: [Vec<f32>; 3],
    /// Distance from the eye (world units); `+inf` for infinity content; −1 in holes.
    pub depth: Vec<f32>,
    /// Whether any sample reached the pixel.
    pub covered: Vec<bool>,
}

impl Frame {
    /// A `width × height` frame that is all holes (black, depth −1).
    pub fn holes_only(width: usize, height: usize) -> Frame {
        let n = width * height;
        Frame {
            width,
            height,
            rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            depth: vec![OUTSIDE_DEPTH; n],
            covered: vec![false; n],
        }
    }

    /// Normalise the filter sums (the division of Alg. 9), guarding every value against NaN.
    pub(crate) fn from_accum(acc: &Accum) -> Frame {
        let n = acc.cells.len();
        let mut f = Frame::holes_only(acc.width, acc.height);
        let colour = |c: &Cell, k: usize| {
            let v = c.rgb[k] / c.w;
            if v.is_finite() {
                v
            } else {
                0.0
            }
        };
        for i in 0..n {
            let (c, behind) = acc.resolve(i);
            if !(c.w > 0.0 && c.w.is_finite()) {
                continue;
            }
            f.covered[i] = true;
            for k in 0..3 {
                f.rgb[k][i] = match behind {
                    Some((b, alpha)) => alpha * colour(c, k) + (1.0 - alpha) * colour(b, k),
                    None => colour(c, k),
                };
            }
            // The distance is the one of the group that shows most.
            let c = match behind {
                Some((b, alpha)) if alpha < 0.5 && b.w > 0.0 && b.w.is_finite() => b,
                _ => c,
            };
            let d = if c.z.is_infinite() { f32::INFINITY } else { c.wz / c.w };
            f.depth[i] = if d.is_nan() { c.z } else { d };
        }
        f
    }

    /// Each `factor × factor` block as one pixel: the mean colour of its covered sub-pixels, the
    /// distance of its nearest one, covered if any is (the frame's size must be a multiple).
    pub(crate) fn downsampled(&self, factor: usize) -> Frame {
        let (w, h) = (self.width / factor, self.height / factor);
        let mut f = Frame::holes_only(w, h);
        for y in 0..h {
            for x in 0..w {
                let (mut n, mut sum, mut near) = (0u32, [0.0f32; 3], f32::INFINITY);
                for sy in 0..factor {
                    let row = (y * factor + sy) * self.width;
                    for i in row + x * factor..row + (x + 1) * factor {
                        if self.covered[i] {
                            n += 1;
                            for (s, plane) in sum.iter_mut().zip(&self.rgb) {
                                *s += plane[i];
                            }
                            near = near.min(self.depth[i]);
                        }
                    }
                }
                if n > 0 {
                    let o = y * w + x;
                    for (plane, s) in f.rgb.iter_mut().zip(sum) {
                        plane[o] = s / n as f32;
                    }
                    f.depth[o] = near;
                    f.covered[o] = true;
                }
            }
        }
        f
    }

    /// Columns `x0 .. x0 + width` of the frame.
    pub(crate) fn columns(&self, x0: usize, width: usize) -> Frame {
        let mut f = Frame::holes_only(width, self.height);
        for y in 0..self.height {
            let (src, dst) = (y * self.width + x0, y * width);
            for c in 0..3 {
                f.rgb[c][dst..dst + width].copy_from_slice(&self.rgb[c][src..src + width]);
            }
            f.depth[dst..dst + width].copy_from_slice(&self.depth[src..src + width]);
            f.covered[dst..dst + width].copy_from_slice(&self.covered[src..src + width]);
        }
        f
    }

    /// Pixels no sample reached.
    pub fn holes(&self) -> usize {
        self.covered.iter().filter(|&&c| !c).count()
    }

    /// Fraction of pixels that are holes, in [0, 1] (0 for an empty frame).
    pub fn hole_ratio(&self) -> f64 {
        self.holes() as f64 / self.covered.len().max(1) as f64
    }

    /// Colour as a layer image (`R`,`G`,`B` float32).
    pub fn colour_image(&self) -> LayerImage {
        let mut img = LayerImage::new(self.width, self.height);
        for (k, name) in ["R", "G", "B"].iter().enumerate() {
            img.set_channel(name, SampleType::F32, self.rgb[k].clone());
        }
        img
    }

    /// Camera distance as a layer image (`Z` float32).
    pub fn depth_image(&self) -> LayerImage {
        let mut img = LayerImage::new(self.width, self.height);
        img.set_channel("Z", SampleType::F32, self.depth.clone());
        img
    }

    /// 8-bit sRGB, interleaved: [`tone_map`] of each channel.
    pub fn to_srgb8(&self) -> Vec<u8> {
        (0..self.covered.len()).flat_map(|i| (0..3).map(move |k| tone_map(self.rgb[k][i]))).collect()
    }

    /// 8-bit coverage mask: 255 where covered, 0 in holes.
    pub fn mask8(&self) -> Vec<u8> {
        self.covered.iter().map(|&c| if c { 255 } else { 0 }).collect()
    }
}

/// The PNG tone map: clamp linear values to `[0, 1]`, then the sRGB transfer function
/// (IEC 61966-2-1), rounded to 8 bits. No exposure, no curve: a linear 0.5 is sRGB 188.
pub fn tone_map(linear: f32) -> u8 {
    crate::colour::srgb8(linear)
}

/// Which file a path asks for, by extension.
fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

fn write_png(
    path: &Path,
    data: &[u8],
    width: usize,
    height: usize,
    ty: ExtendedColorType,
) -> crate::Result<()> {
    let written = crate::fsutil::write_atomic(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(data, width as u32, height as u32, ty)
            .map_err(std::io::Error::other)
    });
    Ok(written?)
}

/// Write the colour: `.exr` linear float, `.png` tone-mapped 8-bit sRGB.
pub fn save_colour(frame: &Frame, path: &Path) -> crate::Result<()> {
    match extension(path).as_str() {
        "exr" => crate::layer_io::write_exr(path, &frame.colour_image(), &Default::default()),
        "png" => write_png(path, &frame.to_srgb8(), frame.width, frame.height, ExtendedColorType::Rgb8),
        _ => Err(RenderError::OutputFormat { path: path.to_path_buf(), expected: "png or exr" }.into()),
    }
}

/// Write the camera distance (`.exr`, channel `Z`).
pub fn save_depth(frame: &Frame, path: &Path) -> crate::Result<()> {
    match extension(path).as_str() {
        "exr" => crate::layer_io::write_exr(path, &frame.depth_image(), &Default::default()),
        _ => Err(RenderError::OutputFormat { path: path.to_path_buf(), expected: "exr" }.into()),
    }
}

/// Write the coverage mask (`.png`, 8-bit grey).
pub fn save_mask(frame: &Frame, path: &Path) -> crate::Result<()> {
    match extension(path).as_str() {
        "png" => write_png(path, &frame.mask8(), frame.width, frame.height, ExtendedColorType::L8),
        _ => Err(RenderError::OutputFormat { path: path.to_path_buf(), expected: "png" }.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_map_is_clamped_srgb() {
        assert_eq!(tone_map(0.0), 0);
        assert_eq!(tone_map(1.0), 255);
        assert_eq!(tone_map(7.0), 255);
        assert_eq!(tone_map(-1.0), 0);
        assert_eq!(tone_map(f32::NAN), 0);
        assert_eq!(tone_map(0.5), 188);
    }

    #[test]
    fn downsampling_averages_the_covered_sub_pixels() {
        // 4 × 2 sub-pixels → 2 × 1: the left block half covered, the right one a hole.
        let mut f = Frame::holes_only(4, 2);
        for (i, v, d) in [(0, 1.0, 3.0), (5, 0.5, 2.0)] {
            f.rgb[0][i] = v;
            f.depth[i] = d;
            f.covered[i] = true;
        }
        let g = f.downsampled(2);
        assert_eq!((g.width, g.height), (2, 1));
        assert_eq!(g.covered, vec![true, false]);
        assert_eq!((g.rgb[0][0], g.depth[0]), (0.75, 2.0));
        assert_eq!((g.rgb[0][1], g.depth[1]), (0.0, OUTSIDE_DEPTH));
    }

    #[test]
    fn empty_cells_are_holes_without_nan() {
        let mut acc = Accum::new(2, 1, 0.03);
        acc.add(1, f32::INFINITY, 0.5, 1.0, [1.0, 0.5, 0.25], 0);
        let f = Frame::from_accum(&acc);
        assert_eq!(f.covered, vec![false, true]);
        assert_eq!(f.depth, vec![OUTSIDE_DEPTH, f32::INFINITY]);
        assert_eq!([f.rgb[0][1], f.rgb[1][1], f.rgb[2][1]], [1.0, 0.5, 0.25]);
        assert_eq!(f.hole_ratio(), 0.5);
    }
}
