//! Patch-packed compression (spec §5; thesis eq. 6.16-6.17).
//!
//! A sparse layer's occupied pixels are cut into rectangles, packed into a compact atlas, and
//! recorded in a patch table: `canvas(u+s, v+t) = atlas(x+s, y+t)` for `(s,t) ∈ [0,w)×[0,h)`.
//!
//! - `cut`: domain → disjoint rectangles wasting at most a third of their area;
//! - `maxrects`: rectangles → atlas positions;
//! - `table`: validation ([`check_table`]) of a (possibly hostile) patch table;
//! - this module: copying pixels between canvas and atlas.

pub(crate) mod cut;
pub(crate) mod maxrects;
mod table;

use crate::layer::{Channel, LayerImage, OUTSIDE_DEPTH};
use crate::layer_io::ReadLimits;

pub use self::table::check_table;

/// Largest guard band [`pack_layer`] accepts (bilinear or bicubic sampling needs 1 or 2).
pub const MAX_PADDING: u32 = 64;

/// One row of the patch table: origin `(u, v)` in the full canvas, origin `(x, y)` in the atlas,
/// size `w × h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Patch {
    /// Left column of the patch in the full canvas, pixels (`<Patch u>`).
    pub u: u32,
    /// Top row of the patch in the full canvas, pixels (`<Patch v>`).
    pub v: u32,
    /// Left column of the patch in the atlas, pixels (`<Patch x>`).
    pub x: u32,
    /// Top row of the patch in the atlas, pixels (`<Patch y>`).
    pub y: u32,
    /// Width in pixels, the same in canvas and atlas (`<Patch w>`); guard bands not included.
    pub w: u32,
    /// Height in pixels, the same in canvas and atlas (`<Patch h>`); guard bands not included.
    pub h: u32,
}

/// Tuning of [`pack_layer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct PackOptions {
    /// Guard band copied around each patch in the atlas (pixels), for bilinear sampling.
    pub padding: u32,
}

/// A packed layer: atlas image plus patch table, and the full canvas size.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedLayer {
    /// Width of the full (unpacked) canvas, pixels.
    pub canvas_width: u32,
    /// Height of the full (unpacked) canvas, pixels.
    pub canvas_height: u32,
    /// The atlas image, with the layer's channels; pixels in no patch or guard band are outside.
    pub atlas: LayerImage,
    /// The patch table mapping canvas rectangles to atlas rectangles.
    pub patches: Vec<Patch>,
}

impl PackedLayer {
    /// Pixels in the atlas.
    pub fn atlas_area(&self) -> usize {
        self.atlas.width * self.atlas.height
    }
}

/// Errors of packing and unpacking.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// [`unpack`]: the patch table fails [`check_table`] (its first problem).
    #[error("patch table is invalid: {0}")]
    BadTable(TableProblem),
    /// An image side exceeds `u32`, or the atlas (packing) or canvas (unpacking) exceeds the read limits.
    #[error("canvas {width}x{height} is too large to unpack (limit {limit} pixels)")]
    TooLarge {
        /// Width of the refused image, pixels (saturated at `u32::MAX`).
        width: u32,
        /// Height of the refused image, pixels (saturated at `u32::MAX`).
        height: u32,
        /// The pixel limit in force ([`ReadLimits::max_pixels`]).
        limit: u64,
    },
    #[error("padding of {padding} pixels is more than the {max} allowed; use a guard band of a few pixels")]
    /// [`PackOptions::padding`] is above [`MAX_PADDING`].
    PaddingTooLarge {
        /// The requested guard band, pixels.
        padding: u32,
        /// The largest accepted, [`MAX_PADDING`].
        max: u32,
    },
}

crate::codes::error_codes! {
    PackError:
        TooLarge LAYER_TOO_LARGE,
        PaddingTooLarge PACK_PADDING_TOO_LARGE;
        from BadTable.0
}

/// What is wrong with one patch of a table.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TableProblemKind {
    /// `w` or `h` is 0 (`PATCH_EMPTY`).
    #[error("has zero width or height")]
    Empty,
    /// `u + w` or `v + h` exceeds the canvas size (`PATCH_OUT_OF_CANVAS`).
    #[error("extends past the layer's full canvas")]
    OutOfCanvas,
    /// `x + w` or `y + h` exceeds the atlas size (`PATCH_OUT_OF_ATLAS`).
    #[error("extends past the atlas")]
    OutOfAtlas,
    /// The patch's atlas rectangle overlaps another's (`PATCH_OVERLAP_ATLAS`).
    #[error("overlaps patch {other} in the atlas")]
    OverlapAtlas {
        /// Index of one patch it overlaps.
        other: usize,
    },
    /// The patch's canvas rectangle overlaps another's (`PATCH_OVERLAP_CANVAS`).
    #[error("overlaps patch {other} in the canvas")]
    OverlapCanvas {
        /// Index of one patch it overlaps.
        other: usize,
    },
}

/// A problem with patch number `patch` of a table.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("patch {patch} {kind}")]
pub struct TableProblem {
    /// Index of the patch in the table, from 0.
    pub patch: usize,
    /// What is wrong with it.
    pub kind: TableProblemKind,
}

impl TableProblem {
    /// Stable validator code of the problem (`PATCH_EMPTY`, `PATCH_OUT_OF_CANVAS`, …).
    pub fn code(&self) -> &'static str {
        match self.kind {
            TableProblemKind::Empty => crate::codes::PATCH_EMPTY,
            TableProblemKind::OutOfCanvas => crate::codes::PATCH_OUT_OF_CANVAS,
            TableProblemKind::OutOfAtlas => crate::codes::PATCH_OUT_OF_ATLAS,
            TableProblemKind::OverlapAtlas { .. } => crate::codes::PATCH_OVERLAP_ATLAS,
            TableProblemKind::OverlapCanvas { .. } => crate::codes::PATCH_OVERLAP_CANVAS,
        }
    }
}

/// Pack a layer's occupied pixels (its domain) into an atlas.
///
/// With `padding = 0`, the atlas of a layer whose domain is not tiny holds at most twice the
/// occupied pixels (a property of this packer, tested; not a requirement of the format). A layer
/// with an empty domain packs into a 1×1 atlas of one outside pixel and no patches.
pub fn pack_layer(image: &LayerImage, options: &PackOptions) -> Result<PackedLayer, PackError> {
    let (cw, ch) = canvas_size(image)?;
    if options.padding > MAX_PADDING {
        return Err(PackError::PaddingTooLarge { padding: options.padding, max: MAX_PADDING });
    }
    let pad = options.padding;
    let whole = cut::cover(&image.domain(), image.width, image.height, pad);
    // Splitting long rectangles usually helps (a ring around a pole) but not always: keep the
    // smaller atlas of the two.
    let (rects, packing) = [cut::limit_length(whole.clone(), pad), whole]
        .into_iter()
        .map(|rects| {
            let sizes: Vec<(u32, u32)> = rects.iter().map(|r| (r.w + 2 * pad, r.h + 2 * pad)).collect();
            let packing = maxrects::pack(&sizes);
            (rects, packing)
        })
        .min_by_key(|(_, p)| u64::from(p.width) * u64::from(p.height))
        .expect("two candidates");
    let patches: Vec<Patch> = rects
        .iter()
        .zip(&packing.positions)
        .map(|(r, &(x, y))| Patch { u: r.x, v: r.y, x: x + pad, y: y + pad, w: r.w, h: r.h })
        .collect();
    let (aw, ah) = (packing.width.max(1), packing.height.max(1));
    let limits = ReadLimits::default();
    if limits.check(u64::from(aw), u64::from(ah), image.channels.len()).is_err() {
        return Err(PackError::TooLarge { width: aw, height: ah, limit: limits.max_pixels });
    }
    let (aw, ah) = (aw as usize, ah as usize);
    let mut atlas = blank_like(image, aw, ah);
    for p in &patches {
        copy_padded(image, &mut atlas, p, pad);
    }
    Ok(PackedLayer { canvas_width: cw, canvas_height: ch, atlas, patches })
}

/// Restore the full canvas; pixels in no patch are outside (`A = 0`, `Z = -1`, other channels 0).
///
/// The table is validated first, and canvases beyond the default [`ReadLimits`] are refused,
/// both before anything is allocated.
pub fn unpack(packed: &PackedLayer) -> Result<LayerImage, PackError> {
    unpack_with_limits(packed, &ReadLimits::default())
}

/// [`unpack`] with explicit limits on the canvas (pixels, dimensions, decoded bytes).
pub fn unpack_with_limits(packed: &PackedLayer, limits: &ReadLimits) -> Result<LayerImage, PackError> {
    let (cw, ch) = (packed.canvas_width, packed.canvas_height);
    let (aw, ah) = canvas_size(&packed.atlas)?;
    if let Some(problem) = check_table(cw, ch, aw, ah, &packed.patches).into_iter().next() {
        return Err(PackError::BadTable(problem));
    }
    let channels = packed.atlas.channels.len();
    if limits.check(u64::from(cw), u64::from(ch), channels).is_err() {
        return Err(PackError::TooLarge { width: cw, height: ch, limit: limits.max_pixels });
    }
    let mut canvas = blank_like(&packed.atlas, cw as usize, ch as usize);
    for p in &packed.patches {
        copy_rect(&packed.atlas, (p.x, p.y), &mut canvas, (p.u, p.v), (p.w, p.h));
    }
    Ok(canvas)
}

/// Image size as u32 (patch tables are u32).
fn canvas_size(image: &LayerImage) -> Result<(u32, u32), PackError> {
    match (u32::try_from(image.width), u32::try_from(image.height)) {
        (Ok(w), Ok(h)) => Ok((w, h)),
        _ => Err(PackError::TooLarge {
            width: image.width.min(u32::MAX as usize) as u32,
            height: image.height.min(u32::MAX as usize) as u32,
            limit: ReadLimits::default().max_pixels,
        }),
    }
}

/// The value every channel takes outside the domain.
fn outside_value(name: &str) -> f32 {
    match name {
        "Z" => OUTSIDE_DEPTH,
        _ => 0.0,
    }
}

/// An image of `w × h` with the channels (names, types) of `like`, every pixel outside.
fn blank_like(like: &LayerImage, w: usize, h: usize) -> LayerImage {
    let channels = like
        .channels
        .iter()
        .map(|c| Channel {
            name: c.name.clone(),
            sample_type: c.sample_type,
            data: vec![outside_value(&c.name); w * h],
        })
        .collect();
    LayerImage { width: w, height: h, channels }
}

/// Copy a `w × h` block between images with the same channels (table validated by the caller).
fn copy_rect(src: &LayerImage, from: (u32, u32), dst: &mut LayerImage, to: (u32, u32), size: (u32, u32)) {
    let (w, h) = (size.0 as usize, size.1 as usize);
    for (s, d) in src.channels.iter().zip(dst.channels.iter_mut()) {
        for t in 0..h {
            let a = (from.1 as usize + t) * src.width + from.0 as usize;
            let b = (to.1 as usize + t) * dst.width + to.0 as usize;
            d.data[b..b + w].copy_from_slice(&s.data[a..a + w]);
        }
    }
}

/// Copy patch `p` and a guard band of `pad` canvas pixels around it (clamped to the canvas).
fn copy_padded(canvas: &LayerImage, atlas: &mut LayerImage, p: &Patch, pad: u32) {
    let (pad, cw, ch) = (pad as i64, canvas.width as i64, canvas.height as i64);
    for (s, d) in canvas.channels.iter().zip(atlas.channels.iter_mut()) {
        for t in -pad..i64::from(p.h) + pad {
            let cy = (i64::from(p.v) + t).clamp(0, ch - 1) as usize;
            let ay = (i64::from(p.y) + t) as usize;
            for k in -pad..i64::from(p.w) + pad {
                let cx = (i64::from(p.u) + k).clamp(0, cw - 1) as usize;
                let ax = (i64::from(p.x) + k) as usize;
                d.data[ay * atlas.width + ax] = s.data[cy * canvas.width + cx];
            }
        }
    }
}
