//! `pomc info` as one call: what a panorama, a layer file or a plain image holds, from its headers
//! (and with `stats` from every layer's pixels).

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::input::ImageHeader;
use crate::layer::SampleType;
use crate::layer_io::{self, ReadLimits};
use crate::manifest::{LayerDecl, LayerSource, Transform};
use crate::panorama::Panorama;

/// What [`describe`] found: the `--json` schema of `pomc info` (its `kind` names the case).
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum InfoReport {
    /// A layer file's EXR header.
    Exr {
        /// The file.
        path: PathBuf,
        /// Width, pixels.
        width: usize,
        /// Height, pixels.
        height: usize,
        /// Channels in file order.
        channels: Vec<ChannelInfo>,
        /// The compression's name.
        compression: &'static str,
        /// Whether the file is tiled.
        tiled: bool,
    },
    /// A plain image's header.
    Image {
        /// The file.
        path: PathBuf,
        /// Its header.
        #[serde(flatten)]
        header: ImageHeader,
    },
    /// A panorama's manifest (and with `stats`, its layers' pixels).
    Panorama {
        /// The manifest's path.
        manifest: PathBuf,
        /// POMC version.
        version: String,
        /// Mapping name.
        mapping: &'static str,
        /// Freedom radius, metres.
        freedom_radius: f64,
        /// LocalToWorld, column-major.
        local_to_world_cols: [f64; 16],
        /// The LocalToWorld operations as a person reads them.
        #[serde(skip)]
        transforms: String,
        /// One per layer, in manifest order.
        layers: Vec<LayerInfo>,
    },
}

/// One EXR channel.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelInfo {
    /// Channel name.
    pub name: String,
    /// Sample type.
    #[serde(rename = "type")]
    pub sample: SampleType,
}

/// One layer of a panorama as its manifest declares it.
#[derive(Clone, Debug, Serialize)]
pub struct LayerInfo {
    /// Index in the manifest.
    pub index: usize,
    /// Name.
    pub name: Option<String>,
    /// Role.
    pub role: Option<&'static str>,
    /// Painter's order.
    pub order: Option<u32>,
    /// The layer's file(s).
    pub file: String,
    /// Declared canvas width.
    pub width: Option<u32>,
    /// Declared canvas height.
    pub height: Option<u32>,
    /// Declared depth range.
    pub depth_range: Option<(f32, f32)>,
    /// Patch packing: atlas size and patch count.
    pub packed: Option<PackedInfo>,
    /// Figures of the decoded layer (with `stats`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stats: Option<LayerPixels>,
}

/// A packed layer's atlas.
#[derive(Clone, Debug, Serialize)]
pub struct PackedInfo {
    /// Atlas width and height.
    pub atlas: [u32; 2],
    /// Patches.
    pub patches: usize,
}

/// Figures of a decoded layer.
#[derive(Clone, Debug, Serialize)]
pub struct LayerPixels {
    /// Canvas width and height.
    pub canvas: [usize; 2],
    /// Pixels in the layer's domain.
    pub domain_pixels: usize,
    /// Nearest finite depth.
    pub depth_min: Option<f32>,
    /// Farthest finite depth.
    pub depth_max: Option<f32>,
    /// Pixels at infinity.
    pub infinite_pixels: usize,
    /// Pixels of unknown depth.
    pub unknown_pixels: usize,
    /// Channel names.
    pub channels: Vec<String>,
}

/// Describe `path` as `pomc info` does: a panorama directory or manifest, a layer EXR, or a plain
/// image; `stats` decodes every layer of a panorama for its figures.
pub fn describe(path: &Path, stats: bool) -> crate::Result<InfoReport> {
    let has_ext = |e: &str| path.extension().is_some_and(|x| x.eq_ignore_ascii_case(e));
    if path.is_file() && !has_ext("xml") {
        return if has_ext("exr") { exr_info(path) } else { image_info(path) };
    }
    let pano = Panorama::open(path)?;
    let m = &pano.manifest;
    let layers = (m.layers.iter().enumerate())
        .map(|(k, decl)| layer_info(&pano, k, decl, stats))
        .collect::<crate::Result<_>>()?;
    Ok(InfoReport::Panorama {
        manifest: pano.manifest_path.clone(),
        version: m.version.clone(),
        mapping: m.mapping.kind.primary_name(),
        freedom_radius: m.freedom_radius,
        local_to_world_cols: m.local_to_world().to_cols_array(),
        transforms: describe_transforms(&m.transforms),
        layers,
    })
}

fn exr_info(path: &Path) -> crate::Result<InfoReport> {
    let h = layer_io::read_header(path, &ReadLimits::default())?;
    let channels = h.channels.into_iter().map(|(name, sample)| ChannelInfo { name, sample }).collect();
    Ok(InfoReport::Exr {
        path: path.into(),
        width: h.width,
        height: h.height,
        channels,
        compression: h.compression.name(),
        tiled: h.tiled,
    })
}

fn image_info(path: &Path) -> crate::Result<InfoReport> {
    let header = crate::input::image_header(path)?;
    Ok(InfoReport::Image { path: path.into(), header })
}

fn layer_info(pano: &Panorama, k: usize, decl: &LayerDecl, stats: bool) -> crate::Result<LayerInfo> {
    let file = match &decl.source {
        LayerSource::Native { file } => file.clone(),
        LayerSource::Thesis { mapname, depthname, .. } => format!("{mapname} + {depthname}"),
    };
    let stats = stats
        .then(|| -> crate::Result<LayerPixels> {
            let img = pano.read_layer(k, &ReadLimits::default())?;
            let st = img.stats();
            Ok(LayerPixels {
                canvas: [img.width, img.height],
                domain_pixels: st.domain_pixels,
                depth_min: st.depth_min,
                depth_max: st.depth_max,
                infinite_pixels: st.infinite_pixels,
                unknown_pixels: st.unknown_pixels,
                channels: img.channels.iter().map(|c| c.name.clone()).collect(),
            })
        })
        .transpose()?;
    Ok(LayerInfo {
        index: k,
        name: decl.name.clone(),
        role: decl.role.map(|r| r.as_str()),
        order: decl.order,
        file,
        width: decl.width,
        height: decl.height,
        depth_range: decl.depth_range,
        packed: decl
            .packing
            .as_ref()
            .map(|p| PackedInfo { atlas: [p.atlas_width, p.atlas_height], patches: p.patches.len() }),
        stats,
    })
}

/// The LocalToWorld operations as a person reads them: `Translate(0, 0, 1.2) · Scale(-1, 1, 1)`
/// (document order; the last is applied to points first), or `identity`.
fn describe_transforms(ops: &[Transform]) -> String {
    let v = |a: &[f64; 3]| format!("{}, {}, {}", a[0], a[1], a[2]);
    let parts: Vec<String> = ops
        .iter()
        .map(|t| match t {
            Transform::Translate(a) => format!("Translate({})", v(a)),
            Transform::Scale(a) => format!("Scale({})", v(a)),
            Transform::Rotate { axis, angle_deg } => format!("Rotate(axis {}, {angle_deg}°)", v(axis)),
        })
        .collect();
    if parts.is_empty() {
        "identity".to_string()
    } else {
        parts.join(" · ")
    }
}

impl InfoReport {
    /// The command's human lines.
    pub fn summary(&self) -> Vec<String> {
        match self {
            InfoReport::Exr { path, width, height, channels, compression, .. } => {
                let mut lines =
                    vec![format!("{}: EXR {width}x{height}, {compression} compression", path.display())];
                lines.extend(channels.iter().map(|c| format!("  channel {:8} {:?}", c.name, c.sample)));
                lines
            }
            InfoReport::Image { path, header: h } => {
                let grey = if h.channels <= 2 { " grey" } else { "" };
                vec![format!(
                    "{}: image {}x{}, {}, {} channel(s){grey}, {}-bit",
                    path.display(),
                    h.width,
                    h.height,
                    h.format,
                    h.channels,
                    h.bits
                )]
            }
            InfoReport::Panorama {
                manifest, version, mapping, freedom_radius, transforms, layers, ..
            } => {
                let mut lines = vec![
                    format!(
                        "{}: POMC {version} {mapping} mapping, freedom radius {freedom_radius} m, {} layer(s)",
                        manifest.display(),
                        layers.len()
                    ),
                    format!("  LocalToWorld: {transforms}"),
                ];
                lines.extend(layers.iter().map(LayerInfo::line));
                lines
            }
        }
    }
}

impl LayerInfo {
    fn line(&self) -> String {
        let mut line = format!(
            "  [{}] {} role={} order={} file={}",
            self.index,
            self.name.as_deref().unwrap_or("-"),
            self.role.unwrap_or("-"),
            self.order.map_or("-".to_string(), |o| o.to_string()),
            self.file
        );
        if let Some(p) = &self.packed {
            line += &format!(" packed {}x{} atlas, {} patches", p.atlas[0], p.atlas[1], p.patches);
        }
        if let Some(st) = &self.stats {
            let depth = match (st.depth_min, st.depth_max) {
                (Some(lo), Some(hi)) => format!("depth {lo:.3}–{hi:.3} m"),
                _ => "no finite depth".to_string(),
            };
            let [w, h] = st.canvas;
            line += &format!(
                " {w}x{h} domain {:.2}%, {depth}, {} infinite, {} unknown, channels {}",
                100.0 * st.domain_pixels as f64 / (w * h).max(1) as f64,
                st.infinite_pixels,
                st.unknown_pixels,
                st.channels.join(",")
            );
        }
        line
    }
}
