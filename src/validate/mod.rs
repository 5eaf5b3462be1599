//! The validator (spec §6): checks a panorama directory against POMC 1 and reports every problem
//! with a stable code, a severity and a location. Codes are data ([`crate::codes::CODES`]); each has a
//! test that triggers it.
//!
//! Pixel-level findings are aggregated: one issue per (layer, code) with the number of pixels and
//! the first one found, so a broken 8K layer gives a readable report, not millions of lines.

pub mod report;

use std::path::Path;

use rayon::prelude::*;

use crate::continuity;
use crate::layer::{LayerImage, Sample, SampleType};
use crate::layer_io::{self, ReadLimits};
use crate::manifest::{self, LayerDecl, LayerSource};
use crate::mapping::{AnyMapping, Mapping, MappingKind, Neighbours};
use crate::pack;
use crate::panorama::{self, Panorama};

use crate::codes;
pub use crate::codes::CODES;
pub use report::{Issue, Report, Severity};

/// Patch-table findings listed per layer (the rest are counted).
const MAX_PATCH_FINDINGS: usize = 100;

/// Tuning of [`validate`].
#[derive(Clone, Copy, Debug)]
pub struct ValidateSettings {
    /// Size limits for layer files (checked from headers before decoding).
    pub limits: ReadLimits,
    /// Relative depth step between 4-neighbours of one layer above which they are reported as a
    /// discontinuity, unless a plane continues across them (`continuity::continuous`).
    pub jump_threshold: f64,
    /// Tolerance on `|N| = 1` for normals (half precision stores ~1e-3).
    pub normal_tolerance: f32,
}

impl Default for ValidateSettings {
    fn default() -> Self {
        ValidateSettings {
            limits: ReadLimits::default(),
            jump_threshold: continuity::LAYER_JUMP,
            normal_tolerance: 0.01,
        }
    }
}

/// Validate the panorama at `path` (its directory or manifest). I/O problems with the panorama
/// itself (no manifest) are errors of the call; everything about its content goes in the report.
///
/// ```
/// use pomc::prelude::*;
/// let report = validate("fixtures/data/room-cube".as_ref(), &ValidateSettings::default())?;
/// assert!(report.valid && report.errors == 0, "{:?}", report.issues);
/// let missing = validate("fixtures/data/no-such-panorama".as_ref(), &ValidateSettings::default());
/// assert_eq!(missing.unwrap_err().code(), pomc::codes::PANORAMA_NOT_FOUND);
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn validate(path: &Path, options: &ValidateSettings) -> Result<Report, crate::Error> {
    let manifest_path = panorama::manifest_path(path)?;
    let name = manifest_path.display().to_string();
    let mut issues = Vec::new();
    let bytes = match crate::fsutil::read_limited(&manifest_path, panorama::MAX_MANIFEST_BYTES) {
        Ok(b) => b,
        Err(e) => {
            let too_large = std::fs::metadata(&manifest_path)
                .is_ok_and(|m| m.is_file() && m.len() > panorama::MAX_MANIFEST_BYTES);
            let code = if too_large { codes::manifest::XML_TOO_LARGE } else { codes::MANIFEST_IO_ERROR };
            issues.push(issue(code, e.to_string(), name.clone()));
            return Ok(Report::from_issues(issues));
        }
    };
    let diagnosed = manifest::diagnose(&bytes, &name);
    for d in &diagnosed.diagnostics {
        issues.push(Issue {
            code: d.code,
            severity: d.severity,
            message: d.message.clone(),
            location: format!("{name}:{}:{} {}", d.line, d.col, d.path),
        });
    }
    let Some(manifest) = diagnosed.manifest else {
        return Ok(Report::from_issues(issues));
    };
    let dir = manifest_path.parent().map(Path::to_path_buf).unwrap_or_default();
    let pano = Panorama { dir, manifest_path: manifest_path.clone(), manifest };
    let kind = pano.manifest.mapping.kind;

    let mut domains: Vec<(AnyMapping, Vec<bool>)> = Vec::new();
    let mut all_layers_read = true;
    for (k, decl) in pano.manifest.layers.iter().enumerate() {
        match check_layer(&pano, k, decl, kind, options, &mut issues) {
            Some(d) => domains.push(d),
            None => all_layers_read = false,
        }
    }
    if all_layers_read && !domains.is_empty() {
        check_coverage(&name, &domains, &mut issues);
    }
    Ok(Report::from_issues(issues))
}

fn issue(code: &'static str, message: String, location: String) -> Issue {
    Issue { code, severity: codes::severity(code), message, location }
}

fn layer_label(k: usize, decl: &LayerDecl) -> String {
    match &decl.name {
        Some(n) => format!("layer[{k}] \"{n}\""),
        None => format!("layer[{k}]"),
    }
}

/// Check one layer's files and pixels; returns its mapping and domain when it could be read.
fn check_layer(
    pano: &Panorama,
    k: usize,
    decl: &LayerDecl,
    kind: MappingKind,
    options: &ValidateSettings,
    issues: &mut Vec<Issue>,
) -> Option<(AnyMapping, Vec<bool>)> {
    let label = layer_label(k, decl);
    let file = pano.stored_file(decl);
    let loc = format!("{} {label}", file.display());

    // Header checks first: cheap, and they refuse hostile sizes before any decode.
    if !check_header(pano, decl, options, &loc, issues) || !check_packing(pano, decl, &loc, issues) {
        return None;
    }

    let image = match pano.read_layer(k, &options.limits) {
        Ok(img) => img,
        Err(e) => {
            issues.push(issue(e.code(), e.to_string(), loc));
            return None;
        }
    };
    let mapping = match AnyMapping::new(kind, image.width, image.height) {
        Ok(m) => m,
        Err(e) => {
            issues.push(issue(
                codes::LAYER_DIMENSIONS_MAPPING,
                format!("{e}; the canvas of a {kind:?} layer must be {}", kind_shape(kind)),
                loc,
            ));
            return None;
        }
    };
    check_pixels(&image, &mapping, decl, options, &loc, issues);
    check_mesh(pano, k, decl, &image, &mapping, &loc, issues);
    let domain = image.domain();
    Some((mapping, domain))
}

/// A native layer's file header: found, readable, its depth stored losslessly as float32. `false`
/// when the layer cannot be read.
fn check_header(
    pano: &Panorama,
    decl: &LayerDecl,
    options: &ValidateSettings,
    loc: &str,
    issues: &mut Vec<Issue>,
) -> bool {
    if let LayerSource::Native { file: f } = &decl.source {
        let path = match pano.resolve(f) {
            Ok(p) => p,
            Err(e) => {
                issues.push(issue(e.code(), e.to_string(), loc.to_string()));
                return false;
            }
        };
        match layer_io::read_header(&path, &options.limits) {
            Ok(h) => {
                if h.channels.iter().any(|(n, _)| n == "Z") && !h.compression.is_lossless() {
                    issues.push(issue(
                        codes::LAYER_DEPTH_LOSSY,
                        format!("the layer is stored with lossy {} compression, which alters depth; re-export it with ZIP, PIZ, RLE or none", h.compression.name()),
                        loc.to_string(),
                    ));
                }
                if let Some((_, t)) = h.channels.iter().find(|(n, _)| n == "Z") {
                    if *t != SampleType::F32 {
                        issues.push(issue(
                            codes::LAYER_DEPTH_NOT_FLOAT32,
                            format!("depth channel Z is stored as {t:?}; POMC requires float32, re-export the depth as 32-bit float"),
                            loc.to_string(),
                        ));
                    }
                }
            }
            Err(e) => {
                issues.push(issue(e.code(), e.to_string(), loc.to_string()));
                return false;
            }
        }
    }
    true
}

/// A packed layer's patch table; `false` when it has errors (the layer cannot be unpacked).
fn check_packing(pano: &Panorama, decl: &LayerDecl, loc: &str, issues: &mut Vec<Issue>) -> bool {
    if let Some(p) = &decl.packing {
        if let Some((cw, ch)) = decl.size() {
            let problems = pack::check_table(cw, ch, p.atlas_width, p.atlas_height, &p.patches);
            // A table of 300,000 overlapping patches made 146 MB of JSON: the first ones tell.
            if problems.len() > MAX_PATCH_FINDINGS {
                let msg =
                    format!("{} patch problems; the first {MAX_PATCH_FINDINGS} are listed", problems.len());
                issues.push(issue(codes::manifest::DIAGNOSTICS_TRUNCATED, msg, loc.to_string()));
            }
            for prob in problems.into_iter().take(MAX_PATCH_FINDINGS) {
                let ploc = decl
                    .origin
                    .patches
                    .get(prob.patch)
                    .map(|o| {
                        format!("{}:{}:{} {}", pano.manifest_path.display(), o.pos.line, o.pos.col, o.path)
                    })
                    .unwrap_or_else(|| format!("{loc} patch {}", prob.patch));
                issues.push(issue(prob.code(), prob.to_string(), ploc));
            }
            if issues.iter().any(|i| i.code.starts_with("PATCH_") && i.severity == Severity::Error) {
                return false;
            }
        }
    }
    true
}

/// The layer's stored mesh, read as the renderer reads it ([`crate::mesh::stored`]).
fn check_mesh(
    pano: &Panorama,
    k: usize,
    decl: &LayerDecl,
    image: &LayerImage,
    mapping: &AnyMapping,
    loc: &str,
    issues: &mut Vec<Issue>,
) {
    let Some(m) = &decl.mesh else { return };
    if !m.is_quadtree_v1() {
        let msg = format!(
            "<Mesh file=\"{}\"> uses encoding `{}` version `{}`, which this reader does not know; it is kept and ignored",
            m.file, m.encoding, m.version
        );
        issues.push(issue(codes::MESH_ENCODING_UNKNOWN, msg, format!("{loc} mesh {}", m.file)));
    } else if let Some(Err(e)) = crate::mesh::stored::read_stored(pano, k, image, mapping) {
        issues.push(issue(e.code, e.to_string(), format!("{loc} mesh {}", m.file)));
    }
}

fn kind_shape(kind: MappingKind) -> &'static str {
    match kind {
        MappingKind::Equirect => "2:1 (width = 2 × height)",
        MappingKind::Cube3x2 => "3:2 with square faces (3N × 2N)",
    }
}

/// Aggregated pixel findings of one code in one layer.
#[derive(Default)]
struct Tally {
    count: usize,
    first: Option<(usize, usize)>,
}

impl Tally {
    fn add(&mut self, i: usize, w: usize) {
        self.count += 1;
        if self.first.is_none() {
            self.first = Some((i % w, i / w));
        }
    }
}

fn push_tally(issues: &mut Vec<Issue>, code: &'static str, t: &Tally, what: &str, loc: &str, channel: &str) {
    if let Some((x, y)) = t.first {
        issues.push(issue(
            code,
            format!("{} pixel(s) {what}; first at ({x},{y})", t.count),
            format!("{loc} channel {channel} pixel ({x},{y})"),
        ));
    }
}

/// Per-layer pixel findings, one tally per code.
#[derive(Default)]
struct PixelTallies {
    neg: Tally,
    zero: Tally,
    nan: Tally,
    range: Tally,
    mask_bad: Tally,
    mask_disagree: Tally,
    colour_bad: Tally,
    inside: usize,
}

fn check_pixels(
    image: &LayerImage,
    mapping: &AnyMapping,
    decl: &LayerDecl,
    options: &ValidateSettings,
    loc: &str,
    issues: &mut Vec<Issue>,
) {
    let Some(z) = image.depth() else {
        issues.push(issue(
            codes::LAYER_NO_DEPTH,
            "the layer has no depth channel Z; store the distance along the ray in a float32 channel named Z"
                .into(),
            loc.to_string(),
        ));
        return;
    };
    let t = tally_pixels(image, decl, z);
    #[rustfmt::skip]
    let findings = [
        (codes::DEPTH_NEGATIVE_IN_DOMAIN, &t.neg, "inside the domain (A > 0) have negative depth; set A = 0 there or store the true distance", "Z"),
        (codes::DEPTH_ZERO_IN_DOMAIN, &t.zero, "inside the domain have depth 0, which is no surface; store NaN for unknown depth or mark them outside", "Z"),
        (codes::DEPTH_UNKNOWN_IN_DOMAIN, &t.nan, "inside the domain have unknown depth (NaN)", "Z"),
        (codes::DEPTH_OUT_OF_RANGE, &t.range, "have depths outside the layer's declared depthrange; fix the range or the depths", "Z"),
        (codes::MASK_OUT_OF_RANGE, &t.mask_bad, "have coverage A outside [0, 1] or NaN", "A"),
        (codes::MASK_DEPTH_DISAGREE, &t.mask_disagree, "have A = 0 (outside) but a non-negative depth; write Z = -1 outside the domain", "A"),
        (codes::COLOUR_NOT_FINITE, &t.colour_bad, "inside the domain have NaN or infinite colour", "R,G,B"),
    ];
    for (code, tally, what, channel) in findings {
        push_tally(issues, code, tally, what, loc, channel);
    }
    if t.inside == 0 {
        issues.push(issue(
            codes::LAYER_EMPTY,
            "the layer has no pixel inside its domain; remove it from the manifest".into(),
            loc.to_string(),
        ));
    }
    check_channel_sets(image, loc, issues);
    check_normals(image, options, loc, issues);
    check_continuity(image, mapping, options, loc, issues);
}

/// Count, per finding, the pixels of `image` that have it (and where the first is).
fn tally_pixels(image: &LayerImage, decl: &LayerDecl, z: &[f32]) -> PixelTallies {
    let w = image.width;
    let n = image.width * image.height;
    let a = image.coverage();
    let mut t = PixelTallies::default();
    let colour: Vec<&[f32]> =
        ["R", "G", "B"].iter().filter_map(|c| image.channel(c).map(|c| c.data.as_slice())).collect();
    let sample = image.sampler();
    for i in 0..n {
        if let Some(a) = a {
            let av = a[i];
            if !(0.0..=1.0).contains(&av) {
                t.mask_bad.add(i, w);
            } else if av == 0.0 && z[i] >= 0.0 {
                t.mask_disagree.add(i, w);
            }
        }
        match sample(i) {
            Sample::Outside => continue,
            Sample::Unknown => t.nan.add(i, w),
            Sample::Infinite => {}
            Sample::Surface(d) => {
                if d < 0.0 {
                    t.neg.add(i, w);
                } else if d == 0.0 {
                    t.zero.add(i, w);
                } else if let Some((lo, hi)) = decl.depth_range {
                    if d < lo || d > hi {
                        t.range.add(i, w);
                    }
                }
            }
        }
        t.inside += 1;
        if colour.iter().any(|c| !c[i].is_finite()) {
            t.colour_bad.add(i, w);
        }
    }
    t
}

fn check_channel_sets(image: &LayerImage, loc: &str, issues: &mut Vec<Issue>) {
    for (group, names) in [("colour", ["R", "G", "B"]), ("normal", ["N.X", "N.Y", "N.Z"])] {
        let present = names.iter().filter(|c| image.channel(c).is_some()).count();
        if present != 0 && present != 3 {
            issues.push(issue(
                codes::CHANNELS_INCOMPLETE,
                format!("{group} channels {names:?} are only partly present ({present} of 3); store all three or none"),
                loc.to_string(),
            ));
        }
    }
}

fn check_normals(image: &LayerImage, options: &ValidateSettings, loc: &str, issues: &mut Vec<Issue>) {
    let (Some(nx), Some(ny), Some(nz)) = (image.channel("N.X"), image.channel("N.Y"), image.channel("N.Z"))
    else {
        return;
    };
    let mut bad = Tally::default();
    let sample = image.sampler();
    for i in 0..image.width * image.height {
        if sample(i) == Sample::Outside {
            continue;
        }
        let len = (nx.data[i].powi(2) + ny.data[i].powi(2) + nz.data[i].powi(2)).sqrt();
        // A NaN length is not unit either.
        if (len - 1.0).abs() > options.normal_tolerance || len.is_nan() {
            bad.add(i, image.width);
        }
    }
    push_tally(
        issues,
        codes::NORMALS_NOT_UNIT,
        &bad,
        "inside the domain have normals whose length is not 1",
        loc,
        "N.X,N.Y,N.Z",
    );
}

/// Depth continuity inside the layer: 4-neighbours (across the equirect seam, over the poles and
/// across cube-face edges) that are not one surface by the rule build splits layers with
/// ([`continuity::continuous`], with the relative step `jump_threshold`).
fn check_continuity(
    image: &LayerImage,
    mapping: &AnyMapping,
    options: &ValidateSettings,
    loc: &str,
    issues: &mut Vec<Issue>,
) {
    let w = image.width;
    let nb = Neighbours::new(*mapping);
    let sample = image.sampler();
    let depth = |i: usize| match sample(i) {
        Sample::Surface(d) if d > 0.0 => Some(d as f64),
        Sample::Infinite => Some(f64::INFINITY),
        _ => None,
    };
    let h = image.height;
    // Per row: the count and the first pair's pixel (a hostile layer can break at every pixel).
    let found = scan_rows(w, h, |y| {
        let (mut count, mut first) = (0, usize::MAX);
        continuity::row_breaks(&nb, depth, options.jump_threshold, y, |p, _| {
            count += 1;
            first = first.min(p);
        });
        (count, first)
    });
    if let Some((count, x, y)) = found {
        issues.push(issue(
            codes::DEPTH_DISCONTINUITY,
            format!(
                "{count} neighbour pair(s) inside the layer are not one surface: their depths step by more than {:.0}% and no plane through the pixels beside them continues (first at ({x},{y})); a layer must be continuous in depth: split it at the discontinuity",
                options.jump_threshold * 100.0
            ),
            format!("{loc} channel Z pixel ({x},{y})"),
        ));
    }
}

/// The union of all layer domains must cover the sphere. Sampled at the pixel centres of the
/// finest layer; other layers are looked up by direction.
fn check_coverage(name: &str, domains: &[(AnyMapping, Vec<bool>)], issues: &mut Vec<Issue>) {
    let finest = domains
        .iter()
        .enumerate()
        .max_by_key(|(_, (m, _))| m.width() * m.height())
        .map(|(k, _)| k)
        .unwrap_or(0);
    let (fm, _) = &domains[finest];
    let (w, h) = (fm.width(), fm.height());
    let found = scan_rows(w, h, |y| {
        let mut count = 0;
        let mut first = usize::MAX;
        for x in 0..w {
            // A layer on the finest layer's canvas is looked up by pixel, the others by direction.
            let covered = domains.iter().any(|(m, dom)| {
                if m == fm {
                    return dom[y * w + x];
                }
                let (i, j) = m.pixel_of(fm.pixel_dir(x, y));
                dom[j * m.width() + i]
            });
            if !covered {
                count += 1;
                first = first.min(y * w + x);
            }
        }
        (count, first)
    });
    if let Some((count, x, y)) = found {
        let dir = fm.pixel_dir(x, y);
        issues.push(issue(
            codes::COVERAGE_INCOMPLETE,
            format!(
                "{count} of {} directions ({:.3}%) are in no layer's domain (first at pixel ({x},{y}) of layer {finest}, direction ({:.4}, {:.4}, {:.4})); the layers together must cover the whole sphere: extend the background layer",
                w * h,
                100.0 * count as f64 / (w * h) as f64,
                dir.x,
                dir.y,
                dir.z
            ),
            format!("{name} layer[{finest}] pixel ({x},{y})"),
        ));
    }
}

/// Per row `y` of a `w × h` canvas (in parallel), `row(y)` counts what it finds and its first
/// pixel index: the total and the first pixel `(x, y)`, `None` when nothing is found.
fn scan_rows(
    w: usize,
    h: usize,
    row: impl Fn(usize) -> (usize, usize) + Send + Sync,
) -> Option<(usize, usize, usize)> {
    let rows: Vec<(usize, usize)> = (0..h).into_par_iter().map(row).collect();
    let count: usize = rows.iter().map(|r| r.0).sum();
    let first = rows.iter().map(|r| r.1).min().unwrap_or(0);
    (count > 0).then_some((count, first % w, first / w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layer::SampleType;
    use glam::DVec3;

    fn layer(m: &AnyMapping, depth: impl Fn(DVec3) -> f32) -> LayerImage {
        let (w, h) = (m.width(), m.height());
        let mut img = LayerImage::new(w, h);
        let z = (0..w * h).map(|p| depth(m.pixel_dir(p % w, p / w))).collect();
        img.set_channel("Z", SampleType::F32, z);
        img
    }

    fn continuity_issues(img: &LayerImage, m: &AnyMapping) -> usize {
        let mut issues = Vec::new();
        check_continuity(img, m, &ValidateSettings::default(), "test", &mut issues);
        issues.len()
    }

    /// Ground seen at a grazing angle steps by far more than 50 % a row near the horizon, smoothly:
    /// not a discontinuity (build keeps it one surface by the same rule). A real step is.
    #[test]
    fn grazing_ground_is_continuous_and_a_step_is_not() {
        let m = AnyMapping::new(MappingKind::Equirect, 256, 128).unwrap();
        // Ground 1.6 m below, up to 1 km away; a dome of 2 km above.
        let ground = |d: DVec3| if d.z < -1.6e-3 { (-1.6 / d.z) as f32 } else { 2000.0 };
        let img = layer(&m, |d| ground(d).min(2000.0));
        let w = m.width();
        let rows: Vec<f32> = (60..70).map(|y| img.channel("Z").unwrap().data[y * w]).collect();
        assert!(rows.windows(2).any(|r| r[0] / r[1] > 1.5 || r[1] / r[0] > 1.5), "{rows:?}");
        // Only the horizon itself (ground meeting the dome) may step: take the lower hemisphere.
        let lower = layer(&m, |d| if d.z < -0.02 { ground(d) } else { f32::NAN });
        let (a, b) = (lower.channel("Z").unwrap().data[65 * w], lower.channel("Z").unwrap().data[66 * w]);
        assert!(a / b > 1.5, "the first two rows step by {}", a / b);
        assert_eq!(continuity_issues(&lower, &m), 0);
        let step = layer(&m, |d| if d.x > 0.9 { 1.0 } else { 3.0 });
        assert_eq!(continuity_issues(&step, &m), 1);
    }
}
