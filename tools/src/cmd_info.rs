//! `pomc info PATH [--json]`: describe a panorama, one layer file, or a plain image.

use std::path::{Path, PathBuf};

use pomc::layer_io::{self, ReadLimits};
use pomc::manifest::{LayerSource, Transform};
use pomc::panorama::Panorama;

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory, panorama.xml, a layer EXR, or an image.
    path: PathBuf,
    /// Also decode the layers to report depth ranges and domain sizes (slower).
    #[arg(long)]
    stats: bool,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let is_exr = args.path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if args.path.is_file() && !is_xml(&args.path) {
        return if is_exr { exr_info(&args.path, out) } else { image_info(&args.path, out) };
    }
    panorama_info(&args.path, args.stats, out)
}

fn is_xml(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

fn exr_info(path: &Path, out: Output) -> Result<u8, Failure> {
    let h = layer_io::read_header(path, &ReadLimits::default()).map_err(pomc::Error::from)?;
    let channels: Vec<_> =
        h.channels.iter().map(|(n, t)| serde_json::json!({"name": n, "type": t})).collect();
    out.json(&serde_json::json!({
        "kind": "exr", "path": path, "width": h.width, "height": h.height,
        "channels": channels, "compression": h.compression.name(), "tiled": h.tiled,
    }));
    out.say(format!(
        "{}: EXR {}x{}, {} compression",
        path.display(),
        h.width,
        h.height,
        h.compression.name()
    ));
    for (n, t) in &h.channels {
        out.say(format!("  channel {n:8} {t:?}"));
    }
    Ok(0)
}

fn image_info(path: &Path, out: Output) -> Result<u8, Failure> {
    let h = pomc::layering::input::image_header(path).map_err(pomc::Error::from)?;
    let mut json = serde_json::to_value(&h).expect("header serialises");
    json["kind"] = serde_json::json!("image");
    json["path"] = serde_json::json!(path);
    out.json(&json);
    let grey = if h.channels <= 2 { " grey" } else { "" };
    out.say(format!(
        "{}: image {}x{}, {}, {} channel(s){grey}, {}-bit",
        path.display(),
        h.width,
        h.height,
        h.format,
        h.channels,
        h.bits
    ));
    Ok(0)
}

fn panorama_info(path: &Path, stats: bool, out: Output) -> Result<u8, Failure> {
    let pano = Panorama::open(path)?;
    let m = &pano.manifest;
    let l2w = m.local_to_world();
    let mut layers = Vec::new();
    out.say(format!(
        "{}: POMC {} {} mapping, freedom radius {} m, {} layer(s)",
        pano.manifest_path.display(),
        m.version,
        m.mapping.kind.primary_name(),
        m.freedom_radius,
        m.layers.len()
    ));
    out.say(format!("  LocalToWorld: {}", describe_transforms(&m.transforms)));
    for (k, decl) in m.layers.iter().enumerate() {
        let file = match &decl.source {
            LayerSource::Native { file } => file.clone(),
            LayerSource::Thesis { mapname, depthname, .. } => format!("{mapname} + {depthname}"),
        };
        let mut row = serde_json::json!({
            "index": k, "name": decl.name, "role": decl.role.map(|r| r.as_str()), "order": decl.order,
            "file": file, "width": decl.width, "height": decl.height,
            "depth_range": decl.depth_range,
            "packed": decl.packing.as_ref().map(|p| serde_json::json!({
                "atlas": [p.atlas_width, p.atlas_height], "patches": p.patches.len()})),
        });
        let mut line = format!(
            "  [{k}] {} role={} order={} file={file}",
            decl.name.as_deref().unwrap_or("-"),
            decl.role.map_or("-", |r| r.as_str()),
            decl.order.map_or("-".to_string(), |o| o.to_string()),
        );
        if let Some(p) = &decl.packing {
            line +=
                &format!(" packed {}x{} atlas, {} patches", p.atlas_width, p.atlas_height, p.patches.len());
        }
        if stats {
            let img = pano.read_layer(k, &ReadLimits::default())?;
            let st = img.stats();
            let channels: Vec<_> = img.channels.iter().map(|c| c.name.clone()).collect();
            let depth = match (st.depth_min, st.depth_max) {
                (Some(lo), Some(hi)) => format!("depth {lo:.3}–{hi:.3} m"),
                _ => "no finite depth".to_string(),
            };
            let names = channels.join(",");
            line += &format!(
                " {}x{} domain {:.2}%, {depth}, {} infinite, {} unknown, channels {names}",
                img.width,
                img.height,
                100.0 * st.domain_pixels as f64 / (img.width * img.height).max(1) as f64,
                st.infinite_pixels,
                st.unknown_pixels
            );
            row["stats"] = serde_json::json!({
                "canvas": [img.width, img.height], "domain_pixels": st.domain_pixels,
                "depth_min": st.depth_min, "depth_max": st.depth_max,
                "infinite_pixels": st.infinite_pixels, "unknown_pixels": st.unknown_pixels, "channels": channels,
            });
        }
        out.say(line);
        layers.push(row);
    }
    let cols = l2w.to_cols_array();
    out.json(&serde_json::json!({
        "kind": "panorama", "manifest": pano.manifest_path, "version": m.version,
        "mapping": m.mapping.kind.primary_name(), "freedom_radius": m.freedom_radius,
        "local_to_world_cols": cols, "layers": layers,
    }));
    Ok(0)
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
