//! Layer images (planar channels) between canvases, in bands, with normals renormalised.

use std::ops::Range;

use rayon::prelude::*;

use super::{same_face_size, target_size, Canvas, Filter, Prepared, ResampleError, Rows, SampleOptions};

use crate::continuity;
use crate::layer::{Channel, LayerImage, SampleType};
use crate::mapping::layout::CubeLayout;
use crate::mapping::{AnyMapping, Mapping};
use crate::raster::Raster;

/// Convert a layer image (planar channels) between canvases.
///
/// Colour and other attributes are filtered; `Z` is depth-aware (see the module docs) and `A` follows
/// the same per-pixel decision; normals `N.X, N.Y, N.Z` are filtered then renormalised (they live in the
/// panorama frame, which a change of canvas does not rotate); `U32` channels (identifiers) always take
/// the nearest texel; `F16` channels are rounded to half precision.
pub fn convert_layer(
    src: &LayerImage,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
) -> Result<LayerImage, ResampleError> {
    convert_layer_in_bands(src, from, to, size, opts, BAND_SAMPLES)
}

pub(super) fn convert_layer_in_bands(
    src: &LayerImage,
    from: Canvas,
    to: Canvas,
    size: usize,
    opts: &SampleOptions,
    band_samples: usize,
) -> Result<LayerImage, ResampleError> {
    let ch = src.channels.len();
    let raster = interleaved(src)?;
    let pos = |name: &str| src.channels.iter().position(|c| c.name == name);
    let mut o = *opts;
    o.depth_channel = pos("Z");
    o.coverage_channel = pos("A");
    if let Some(same) = same_face_size(&raster, from, to, size)? {
        return Ok(planar(src, &same));
    }
    let ids = src.channels.iter().any(|c| c.sample_type == SampleType::U32);
    let nearest_opts = SampleOptions { filter: Filter::Nearest, ..o };
    let nearest = ids && opts.filter != Filter::Nearest;
    let source = Prepared::new(&raster, from, &o)?;
    let (w, h) = target_size(to, size, ch)?;
    let normals = match (pos("N.X"), pos("N.Y"), pos("N.Z")) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    // The output is made a band of rows at a time and scattered into its planar channels, so that
    // memory holds the output once (plus a band), not an interleaved copy of it too.
    let mut planes = zeroed_planes(ch, w, h)?;
    let band_rows = (band_samples / (w * ch)).clamp(1, h);
    let mut band = vec![0.0f32; band_rows * w * ch];
    let mut band_ids = if nearest { vec![0.0f32; band_rows * w * ch] } else { Vec::new() };
    let none = |_: usize| {};
    for y0 in (0..h).step_by(band_rows) {
        let rows = band_rows.min(h - y0);
        let ids_len = band_ids.len().min(rows * w * ch);
        let (band, band_ids) = (&mut band[..rows * w * ch], &mut band_ids[..ids_len]);
        source.rows(&o, Rows { to, size, y0, out: band, progress: &none })?;
        if nearest {
            source.rows(&nearest_opts, Rows { to, size, y0, out: band_ids, progress: &none })?;
        }
        let at = y0 * w;
        let ids = nearest.then_some(&*band_ids);
        scatter(&src.channels, band, ids, &mut planes, at..at + rows * w);
        if let Some([x, y, z]) = normals {
            renormalise(&mut planes, [x, y, z], at..at + rows * w);
        }
    }
    if let (Some(z), Some(from_map), Some(to_map)) =
        (o.depth_channel, layer_mapping(from, src.width, src.height), layer_mapping(to, w, h))
    {
        // Only a source that is one surface wherever it is continuous by the rule is made so again:
        // the breaks of a layer that has some (a plain RGB-D panorama) are its own.
        let cov = o.coverage_channel.map(|a| src.channels[a].data.as_slice());
        if !has_breaks(&src.channels[z].data, cov, &from_map) {
            separate(&mut planes, z, o.coverage_channel, &to_map);
        }
    }
    let mut dst = LayerImage::new(w, h);
    for (channel, data) in src.channels.iter().zip(planes) {
        dst.set_channel(&channel.name, channel.sample_type, data);
    }
    Ok(dst)
}

/// A band of interleaved samples into the planar channels' pixels `range`, ID channels taken from
/// `ids` (their nearest-neighbour band) when given; half channels rounded to half.
fn scatter(
    channels: &[Channel],
    band: &[f32],
    ids: Option<&[f32]>,
    planes: &mut [Vec<f32>],
    range: Range<usize>,
) {
    let ch = channels.len();
    for (c, channel) in channels.iter().enumerate() {
        let from_band = match ids {
            Some(ids) if channel.sample_type == SampleType::U32 => ids,
            _ => band,
        };
        let plane = &mut planes[c][range.clone()];
        for (v, px) in plane.iter_mut().zip(from_band.chunks_exact(ch)) {
            *v = px[c];
        }
        if channel.sample_type == SampleType::F16 {
            plane.iter_mut().for_each(|v| *v = half::f16::from_f32(*v).to_f32());
        }
    }
}

/// The layer's channels interleaved into one raster (every channel checked to fill the canvas).
fn interleaved(src: &LayerImage) -> Result<Raster<f32>, ResampleError> {
    let ch = src.channels.len();
    let px = src.width.checked_mul(src.height).ok_or(ResampleError::TooLarge {
        width: src.width,
        height: src.height,
        channels: ch,
    })?;
    if let Some(c) = src.channels.iter().find(|c| c.data.len() != px) {
        return Err(ResampleError::ChannelSize {
            name: c.name.clone(),
            len: c.data.len(),
            width: src.width,
            height: src.height,
            expected: px,
        });
    }
    if ch == 0 {
        return Err(ResampleError::NoChannels);
    }
    let mut inter = vec![0.0f32; px * ch];
    for (c, channel) in src.channels.iter().enumerate() {
        for (i, v) in channel.data.iter().enumerate() {
            inter[i * ch + c] = *v;
        }
    }
    Raster::from_vec(src.width, src.height, ch, inter).map_err(|_| ResampleError::Unsupported)
}

/// `ch` planes of `w × h` zeros; memory the system refuses is an error with a code, not an abort.
fn zeroed_planes(ch: usize, w: usize, h: usize) -> Result<Vec<Vec<f32>>, ResampleError> {
    let too_large = || ResampleError::TooLarge { width: w, height: h, channels: ch };
    let mut planes: Vec<Vec<f32>> = Vec::with_capacity(ch);
    for _ in 0..ch {
        let mut plane = Vec::new();
        plane.try_reserve_exact(w * h).map_err(|_| too_large())?;
        plane.resize(w * h, 0.0f32);
        planes.push(plane);
    }
    Ok(planes)
}

/// The mapping of a layer canvas: layers live on the equirect and the canonical 3 × 2 cube (an
/// exchange layout has no neighbours here).
pub(super) fn layer_mapping(canvas: Canvas, w: usize, h: usize) -> Option<AnyMapping> {
    let kind = match canvas {
        Canvas::Equirect => crate::mapping::MappingKind::Equirect,
        Canvas::Cube(CubeLayout::Canonical) => crate::mapping::MappingKind::Cube3x2,
        Canvas::Cube(_) => return None,
    };
    AnyMapping::new(kind, w, h).ok()
}

/// Depth of pixel `i` of a layer's planes for the continuity rule: inside is depth > 0 and
/// coverage > 0.
pub(super) fn layer_depth(z: &[f32], cov: Option<&[f32]>, i: usize) -> Option<f64> {
    (z[i] > 0.0 && cov.is_none_or(|a| a[i] > 0.0)).then_some(z[i] as f64)
}

/// Whether a layer's depth plane has a 4-neighbour pair that is not one surface
/// ([`continuity::row_breaks`] at [`continuity::LAYER_JUMP`], what `validate` checks); rows stop
/// being searched at the first found.
pub(super) fn has_breaks(z: &[f32], cov: Option<&[f32]>, mapping: &AnyMapping) -> bool {
    let nb = crate::mapping::Neighbours::new(*mapping);
    (0..mapping.height()).into_par_iter().any(|y| {
        let mut found = false;
        continuity::row_breaks(
            &nb,
            |i| layer_depth(z, cov, i),
            continuity::LAYER_JUMP,
            y,
            |_, _| found = true,
        );
        found
    })
}

/// The nearer pixel of each 4-neighbour pair of a layer's depth plane that is not one surface
/// ([`continuity::row_breaks`] at [`continuity::LAYER_JUMP`], what `validate` checks).
pub(super) fn nearer_of_breaks(z: &[f32], cov: Option<&[f32]>, mapping: &AnyMapping) -> Vec<usize> {
    let nb = crate::mapping::Neighbours::new(*mapping);
    let depth = |i: usize| layer_depth(z, cov, i);
    (0..mapping.height())
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut row = Vec::new();
            continuity::row_breaks(&nb, depth, continuity::LAYER_JUMP, y, |p, q| {
                row.push(if z[p] <= z[q] { p } else { q });
            });
            row
        })
        .collect()
}

/// Resampled, two parts of a layer a thin gap apart in the source (a line of pixels outside it)
/// can touch where the gap runs aslant the new grid: of each pair of neighbours that is not one
/// surface, the nearer pixel is taken out of the layer, until none is left (a pixel taken out can
/// end a plane that kept another pair one). Asked only for sources without such pairs.
pub(super) fn separate(planes: &mut [Vec<f32>], z: usize, coverage: Option<usize>, mapping: &AnyMapping) {
    for _ in 0..SEPARATE_PASSES {
        let nearer = nearer_of_breaks(&planes[z], coverage.map(|a| planes[a].as_slice()), mapping);
        if nearer.is_empty() {
            return;
        }
        for p in nearer {
            planes[z][p] = -1.0;
            if let Some(a) = coverage {
                planes[a][p] = 0.0;
            }
        }
    }
}

/// Passes of [`separate`]: each removes every break it finds; few pairs depend on another.
pub(super) const SEPARATE_PASSES: usize = 4;

/// Samples per band of [`convert_layer`]: large enough to keep both cores busy, small against the
/// output.
pub(super) const BAND_SAMPLES: usize = 1 << 22;

/// A resampled interleaved raster as the planar layer of `src`'s channels (`F16` rounded to half).
pub(super) fn planar(src: &LayerImage, out: &Raster<f32>) -> LayerImage {
    let ch = src.channels.len();
    let mut dst = LayerImage::new(out.width(), out.height());
    for (c, channel) in src.channels.iter().enumerate() {
        let mut data: Vec<f32> = out.data().iter().skip(c).step_by(ch).copied().collect();
        if channel.sample_type == SampleType::F16 {
            data.iter_mut().for_each(|v| *v = half::f16::from_f32(*v).to_f32());
        }
        dst.set_channel(&channel.name, channel.sample_type, data);
    }
    dst
}

/// Normals are filtered then renormalised (after rounding, as they are stored).
pub(super) fn renormalise(planes: &mut [Vec<f32>], [x, y, z]: [usize; 3], range: std::ops::Range<usize>) {
    for i in range {
        let (nx, ny, nz) = (planes[x][i], planes[y][i], planes[z][i]);
        let l = (nx * nx + ny * ny + nz * nz).sqrt();
        if l > 0.0 && l.is_finite() {
            planes[x][i] = nx / l;
            planes[y][i] = ny / l;
            planes[z][i] = nz / l;
        }
    }
}
