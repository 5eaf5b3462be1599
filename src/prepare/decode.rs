//! Stored depth values to metres along the ray: metric kinds (scale, invalid value), relative kinds
//! (inverse depth with unknown scale and shift, 8/16-bit "nearness") made metric by a given range
//! or by fitting the floor under a camera of known height, and the checks of what cannot be depth.

use crate::choice::Choice;
use std::path::Path;

use super::{DepthSamples, PrepareError, SampleFormat, Warning};
use crate::mapping::{AnyMapping, Mapping};

/// How depth values are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthEncoding {
    /// Metres per stored unit (`--depth-scale`); `None`: float EXR depth is in metres, and integer
    /// (PNG) depth is refused, as its unit cannot be guessed. For [`DepthKind::Inverse`]: metres
    /// times stored units (`depth = scale / value`, a disparity of known baseline and focal length).
    pub scale: Option<f64>,
    /// Stored value meaning "no depth" (besides NaN, and 0 and negatives for metric kinds).
    pub invalid: Option<f64>,
    /// What the stored values are.
    pub kind: DepthKind,
    /// Nearest and farthest distance (m) of a relative kind (`--depth-range NEAR,FAR`): the
    /// largest stored value is `NEAR`, the smallest `FAR` (nearness: 1 and 0).
    pub range: Option<(f64, f64)>,
    /// Height of the camera above a level floor (m) (`--camera-height`): a relative kind is made
    /// metric by fitting the floor seen below the horizon.
    pub camera_height: Option<f64>,
    /// One distance the user knows (`--known-distance X,Y,METRES`): the scale of depth of unknown
    /// unit (metric kinds) or of inverse depth taken as having no shift.
    pub known_distance: Option<KnownDistance>,
    /// The dataset preset these values came from, if any: a file of another sample format is refused.
    pub preset: Option<Preset>,
}

impl Default for DepthEncoding {
    fn default() -> Self {
        DepthEncoding {
            scale: None,
            invalid: None,
            kind: DepthKind::Ray,
            range: None,
            camera_height: None,
            known_distance: None,
            preset: None,
        }
    }
}

/// The distance along the ray of one pixel of the colour image.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct KnownDistance {
    /// Column of the colour image, pixels from the left (fractions allowed).
    pub x: f64,
    /// Row of the colour image, pixels from the top.
    pub y: f64,
    /// Distance from the panorama's centre along that pixel's ray, metres.
    pub metres: f64,
}

crate::choice::choices! {
    /// What stored depth values mean.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum DepthKind (default Ray) {
        /// Distance along the ray (metres, or units × --depth-scale).
        ///
        /// The Euclidean distance from the centre along the pixel's ray.
        Ray = "ray",
        /// Planar depth along each cube face's axis (cube maps only).
        ///
        /// Converted to ray distance.
        Z = "z",
        /// Inverse depth / disparity, larger = nearer, unknown scale and shift (MiDaS, Depth Anything).
        ///
        /// Inverse depth / disparity with unknown scale and shift, as monocular estimators give it
        /// (MiDaS, Depth Anything): `1/depth = a·value + b`, larger = nearer.
        Inverse = "inverse",
        /// 8/16-bit nearness map: brighter = nearer, 0 = far, linear in distance (three.js, krpano).
        ///
        /// "Nearness" as in web viewers (three.js, krpano): brighter = nearer, 0 = far, linear in
        /// distance between the range's ends; 8/16-bit values are taken as 0–1.
        Nearness = "nearness",
    }
}

impl DepthKind {
    /// Whether the stored values have no metric meaning of their own.
    pub fn is_relative(self) -> bool {
        matches!(self, DepthKind::Inverse | DepthKind::Nearness)
    }
}

crate::choice::choices! {
    /// Dataset presets (each documented in spec/07-build.md with its source).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Preset {
        /// uint16 PNG, metres = value / 4000, 0 invalid.
        ///
        /// Matterport3D.
        Matterport3d = "matterport3d",
        /// uint16 PNG, value / 512, 65535 invalid, Euclidean.
        ///
        /// Stanford 2D-3D-S equirect panoramas.
        Stanford2d3ds = "stanford2d3ds",
        /// uint16 PNG in millimetres, 0 invalid.
        ///
        /// Structured3D.
        Structured3d = "structured3d",
        /// float EXR in metres.
        ///
        /// Pano3D / 3D60.
        Pano3d = "pano3d",
    }
}

impl Preset {
    /// The preset's depth scale, invalid value and kind (all ray distance).
    pub fn encoding(self) -> DepthEncoding {
        let (scale, invalid) = match self {
            Preset::Matterport3d => (1.0 / 4000.0, Some(0.0)),
            Preset::Stanford2d3ds => (1.0 / 512.0, Some(65535.0)),
            Preset::Structured3d => (1.0 / 1000.0, Some(0.0)),
            Preset::Pano3d => (1.0, None),
        };
        DepthEncoding { scale: Some(scale), invalid, preset: Some(self), ..DepthEncoding::default() }
    }

    /// The sample format the dataset stores depth in.
    pub fn format(self) -> SampleFormat {
        match self {
            Preset::Pano3d => SampleFormat::F32,
            _ => SampleFormat::U16,
        }
    }
}

/// Planar z-depth on a cube map to distance along the ray: `ray = z / max(|x|,|y|,|z|)` of the
/// unit direction (the face axis component).
pub fn z_to_ray(m: &AnyMapping, depth: &mut [f32]) {
    for (p, d) in depth.iter_mut().enumerate() {
        let dir = m.pixel_dir(p % m.width(), p / m.width());
        let axis = dir.x.abs().max(dir.y.abs()).max(dir.z.abs());
        *d = (*d as f64 / axis) as f32;
    }
}

/// Float depth at or beyond this (m) is no measurement (100 000 km): a "no depth" sentinel.
const SENTINEL_M: f64 = 1e7;

/// How a relative kind was made metric: `target = a·value + b`, with target `1/depth` for
/// [`DepthKind::Inverse`] and `depth` for [`DepthKind::Nearness`].
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct MetricFit {
    /// Slope.
    pub a: f64,
    /// Offset.
    pub b: f64,
    /// `range` or `camera-height`.
    pub from: &'static str,
    /// Share of the floor candidates (pixels 20° or more below the horizon) the floor fit
    /// explained within 3 %; `None` for a given range.
    pub floor_share: Option<f64>,
}

/// Stored values to metres along the stored convention (z-depth is converted later): unknown = NaN,
/// `+inf` = infinitely far. `mapping` is the depth canvas's own mapping (for the floor fit).
pub(crate) fn to_metres(
    path: &Path,
    samples: &DepthSamples,
    mapping: &AnyMapping,
    enc: &DepthEncoding,
    warnings: &mut Vec<Warning>,
) -> Result<(Vec<f32>, Option<MetricFit>), PrepareError> {
    check_kind(path, samples, enc)?;
    if matches!(enc.kind, DepthKind::Inverse | DepthKind::Nearness) {
        return relative_to_metres(path, samples, mapping, enc);
    }
    let (scale, fit) = metric_scale(path, samples, mapping, enc)?;
    let sentinel = sentinels(samples, scale, enc, warnings, path);
    let d = samples
        .values
        .iter()
        .map(|&v| {
            let metres = f64::from(v) * scale;
            let m = metres as f32;
            // A finite value whose metres f32 cannot hold (under- or overflow) is no depth either.
            let lost = v.is_finite() && !(m > 0.0 && m.is_finite());
            // Sentinels are finite; a stored +inf is the sky, as the sentinel warning advises.
            let far_sentinel = sentinel && v.is_finite() && metres >= SENTINEL_M;
            if is_invalid(enc, v) || v <= 0.0 || lost || far_sentinel {
                f32::NAN
            } else {
                m
            }
        })
        .collect();
    Ok((d, fit))
}

/// Whether a stored value means "no depth".
fn is_invalid(enc: &DepthEncoding, v: f32) -> bool {
    v.is_nan() || enc.invalid.is_some_and(|i| f64::from(v) == i)
}

/// The unit of metric depth (ray or z), metres per stored value: given, known from one distance,
/// or fitted to the floor under a camera of known height.
fn metric_scale(
    path: &Path,
    samples: &DepthSamples,
    mapping: &AnyMapping,
    enc: &DepthEncoding,
) -> Result<(f64, Option<MetricFit>), PrepareError> {
    let invalid = |v: f32| is_invalid(enc, v);
    Ok(match (enc.scale, samples.format, enc.camera_height) {
        (Some(s), _, _) => (s, None),
        // One known distance gives the unit (float depth too: an estimator's depth up to scale).
        _ if enc.known_distance.is_some() => {
            let (k, v) = known_value(path, samples, mapping, enc, &invalid)?;
            let along = if enc.kind == DepthKind::Z { v / z_axis(mapping, k) } else { v };
            let a = k.metres / along;
            (a, Some(MetricFit { a, b: 0.0, from: "known-distance", floor_share: None }))
        }
        (None, SampleFormat::F32, _) => (1.0, None),
        // Integer depth of unknown unit: the floor under a camera of known height gives it.
        (None, _, Some(h)) => {
            let raw: Vec<f64> = samples
                .values
                .iter()
                .map(|&v| if invalid(v) || v <= 0.0 { f64::NAN } else { f64::from(v) })
                .collect();
            let f = floor_fit(path, &raw, mapping, h, Line::Scale)?;
            (f.a, Some(f))
        }
        (None, _, None) => return Err(PrepareError::ScaleNeeded { path: path.into() }),
    })
}

/// Relative depth (inverse, nearness) in metres by the fit of its scale and shift.
fn relative_to_metres(
    path: &Path,
    samples: &DepthSamples,
    mapping: &AnyMapping,
    enc: &DepthEncoding,
) -> Result<(Vec<f32>, Option<MetricFit>), PrepareError> {
    let invalid = |v: f32| is_invalid(enc, v);
    let unit = samples.format.unit();
    let values: Vec<f64> = samples
        .values
        .iter()
        .map(|&v| if invalid(v) || !v.is_finite() { f64::NAN } else { f64::from(v) * unit })
        .collect();
    let fit = match enc.known_distance {
        // Inverse depth without shift: 1/depth = a·value.
        Some(_) if enc.kind == DepthKind::Inverse => {
            let (k, v) = known_value(path, samples, mapping, enc, &invalid)?;
            let v = v * unit;
            if v <= 0.0 {
                return Err(PrepareError::BadOption {
                    option: "--known-distance",
                    why: format!("{}: the inverse depth at pixel ({},{}) is {v}, not above 0: pick a pixel nearer than the farthest", path.display(), k.x, k.y),
                });
            }
            MetricFit { a: 1.0 / (k.metres * v), b: 0.0, from: "known-distance", floor_share: None }
        }
        _ => relative_fit(path, &values, mapping, enc)?,
    };
    let inverse = enc.kind == DepthKind::Inverse;
    let d = values
        .iter()
        .map(|&v| {
            if v.is_nan() {
                return f32::NAN;
            }
            let t = fit.a * v + fit.b;
            if inverse && (t <= 0.0 || 1.0 / t > f64::from(f32::MAX)) {
                // 1/depth at or below 0 (or so small f32 cannot hold the distance): beyond any
                // finite distance.
                return f32::INFINITY;
            }
            let m = if inverse { (1.0 / t) as f32 } else { t as f32 };
            // At or below 0, or metres f32 cannot hold (under- or overflow): no depth.
            if m > 0.0 && m.is_finite() {
                m
            } else {
                f32::NAN
            }
        })
        .collect();
    Ok((d, Some(fit)))
}

/// The known distance (its pixel on the depth's canvas) and the median stored value within 2
/// pixels of it.
fn known_value(
    path: &Path,
    samples: &DepthSamples,
    mapping: &AnyMapping,
    enc: &DepthEncoding,
    invalid: &dyn Fn(f32) -> bool,
) -> Result<(KnownDistance, f64), PrepareError> {
    let k = enc.known_distance.expect("called with a known distance");
    let (w, h) = (mapping.width() as i64, mapping.height() as i64);
    let (cx, cy) = (k.x.floor() as i64, k.y.floor() as i64);
    let mut near: Vec<f64> = (-2..=2)
        .flat_map(|dy| (-2..=2).map(move |dx| (cx + dx, cy + dy)))
        .filter(|&(x, y)| (0..w).contains(&x) && (0..h).contains(&y))
        .map(|(x, y)| samples.values[(y * w + x) as usize])
        .filter(|&v| !invalid(v) && v.is_finite() && v > 0.0)
        .map(f64::from)
        .collect();
    near.sort_by(f64::total_cmp);
    match near.get(near.len() / 2) {
        Some(&v) => Ok((k, v)),
        None => Err(PrepareError::BadOption {
            option: "--known-distance",
            why: format!(
                "{}: no depth within 2 pixels of ({},{}) (on the depth's {}x{} canvas): pick a pixel with depth",
                path.display(),
                k.x,
                k.y,
                w,
                h
            ),
        }),
    }
}

/// The face-axis component of the direction of the canvas pixel at `k` (z-depth over ray distance).
fn z_axis(mapping: &AnyMapping, k: KnownDistance) -> f64 {
    let x = (k.x.max(0.0) as usize).min(mapping.width() - 1);
    let y = (k.y.max(0.0) as usize).min(mapping.height() - 1);
    let dir = mapping.pixel_dir(x, y);
    dir.x.abs().max(dir.y.abs()).max(dir.z.abs())
}

/// Refuse what cannot be the depth the kind says: 8-bit metric depth (256 levels; a web nearness
/// map read as metres turns brighter-is-nearer into farther) and colour images.
fn check_kind(path: &Path, s: &DepthSamples, enc: &DepthEncoding) -> Result<(), PrepareError> {
    if let Some(p) = enc.preset.filter(|p| p.format() != s.format) {
        return Err(PrepareError::PresetMismatch {
            path: path.into(),
            preset: p.name(),
            expected: p.format().name(),
            found: s.format.name(),
        });
    }
    if s.colour_channels {
        return Err(PrepareError::NotDepth {
            path: path.into(),
            why: "its red, green and blue channels differ: it is a colour image".into(),
        });
    }
    if s.format == SampleFormat::U8
        && !enc.kind.is_relative()
        && enc.scale.is_none()
        && enc.camera_height.is_none()
        && enc.known_distance.is_none()
    {
        return Err(PrepareError::EightBit { path: path.into() });
    }
    if enc.kind.is_relative() && enc.range.is_none() && enc.camera_height.is_none() {
        let disparity =
            enc.kind == DepthKind::Inverse && (enc.scale.is_some() || enc.known_distance.is_some());
        if !disparity {
            return Err(PrepareError::RelativeNeedsScale { path: path.into(), kind: enc.kind.name() });
        }
    }
    Ok(())
}

/// Whether float depth holds "no depth" sentinels (values of 10 000 km and more); warns once.
fn sentinels(s: &DepthSamples, scale: f64, enc: &DepthEncoding, w: &mut Vec<Warning>, path: &Path) -> bool {
    let far: Vec<f32> =
        s.values.iter().copied().filter(|&v| v.is_finite() && f64::from(v) * scale >= SENTINEL_M).collect();
    let Some(&first) = far.first() else { return false };
    if enc.invalid.is_none() {
        w.push(Warning::new(
            crate::codes::INPUT_DEPTH_SENTINEL,
            format!(
                "{}: {} pixel(s) hold depths of {:e} m and more (e.g. {first:e}), no measurement: taken as \
                 unknown; give --depth-invalid {first:e} to say so, or store +inf for the sky",
                path.display(),
                far.len(),
                SENTINEL_M
            ),
        ));
    }
    true
}

/// The map from relative values to metres: from the range, or from the floor.
fn relative_fit(
    path: &Path,
    values: &[f64],
    mapping: &AnyMapping,
    enc: &DepthEncoding,
) -> Result<MetricFit, PrepareError> {
    let inverse = enc.kind == DepthKind::Inverse;
    if let Some(h) = enc.camera_height {
        return floor_fit(path, values, mapping, h, if inverse { Line::Inverse } else { Line::Nearness });
    }
    if let Some((near, far)) = enc.range {
        let (lo, hi) = values
            .iter()
            .filter(|v| !v.is_nan())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if inverse {
            // The largest value is NEAR, the smallest FAR, linear in 1/depth.
            let span = (hi - lo).max(f64::MIN_POSITIVE);
            let a = (1.0 / near - 1.0 / far) / span;
            return Ok(MetricFit { a, b: 1.0 / far - a * lo, from: "range", floor_share: None });
        }
        // Nearness 0 is FAR and 1 is NEAR, linear in distance.
        return Ok(MetricFit { a: near - far, b: far, from: "range", floor_share: None });
    }
    let scale = enc.scale.expect("checked by check_kind");
    Ok(MetricFit { a: 1.0 / scale, b: 0.0, from: "depth-scale", floor_share: None })
}

/// The line a floor fit looks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Line {
    /// `1/depth = a·value + b`, `a > 0`.
    Inverse,
    /// `depth = a·value + b`, `a < 0`.
    Nearness,
    /// `depth = a·value`, `a > 0`: metric depth of unknown unit.
    Scale,
}

/// Fit `target = a·value + b` on the floor: pixels 20° or more below the horizon whose target
/// (`1/depth` or `depth` of a level floor `h` below the camera, `h / sin(elevation below)`) the
/// line explains; a deterministic RANSAC over pairs, then least squares on the inliers.
fn floor_fit(
    path: &Path,
    values: &[f64],
    mapping: &AnyMapping,
    h: f64,
    line: Line,
) -> Result<MetricFit, PrepareError> {
    let pts = floor_candidates(values, mapping, h, line == Line::Inverse);
    let none = || PrepareError::NoFloor { path: path.into() };
    if pts.len() < 16 {
        return Err(none());
    }
    let (best, best_n) = ransac(&pts, line);
    if best_n < pts.len() / 10 || best_n < 16 {
        return Err(none());
    }
    // Least squares on the inliers, weighted by 1/t² (relative error).
    let (a0, b0) = best;
    let (mut sw, mut sv, mut st, mut svv, mut svt) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(v, t) in pts.iter().filter(|&&(v, t)| on_line(a0, b0, v, t)) {
        let wgt = 1.0 / (t * t);
        (sw, sv, st, svv, svt) = (sw + wgt, sv + wgt * v, st + wgt * t, svv + wgt * v * v, svt + wgt * v * t);
    }
    let det = sw * svv - sv * sv;
    let (a, b) = if line == Line::Scale {
        (svt / svv, 0.0)
    } else if det.abs() > 1e-12 * sw * svv {
        ((sw * svt - sv * st) / det, (st * svv - sv * svt) / det)
    } else {
        best
    };
    Ok(MetricFit { a, b, from: "camera-height", floor_share: Some(best_n as f64 / pts.len() as f64) })
}

/// Whether `(v, t)` is an inlier of the line `t = a·v + b` (within 3 % of `t`).
fn on_line(a: f64, b: f64, v: f64, t: f64) -> bool {
    ((a * v + b) - t).abs() <= 0.03 * t
}

/// `(value, target)` of the pixels 20° or more below the horizon, subsampled to at most ~20 000:
/// the target is the distance to a floor `h` below the camera (its inverse for inverse depth).
fn floor_candidates(values: &[f64], mapping: &AnyMapping, h: f64, inverse: bool) -> Vec<(f64, f64)> {
    let (w, ht) = (mapping.width(), mapping.height());
    let sin_min = 20f64.to_radians().sin();
    let step = ((w * ht) as f64 / 80_000.0).sqrt().max(1.0) as usize;
    let mut pts = Vec::new();
    for y in (0..ht).step_by(step) {
        for x in (0..w).step_by(step) {
            let v = values[y * w + x];
            let down = -mapping.pixel_dir(x, y).z;
            if v.is_nan() || down < sin_min {
                continue;
            }
            let d = h / down;
            pts.push((v, if inverse { 1.0 / d } else { d }));
        }
    }
    pts
}

/// The line `t = a·v + b` of `line`'s kind through two random points (600 draws, a fixed seed)
/// with the most inliers, and their count.
fn ransac(pts: &[(f64, f64)], line: Line) -> ((f64, f64), usize) {
    let inliers = |a: f64, b: f64| pts.iter().filter(|&&(v, t)| on_line(a, b, v, t)).count();
    let (mut best, mut best_n) = ((0.0, 0.0), 0);
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % pts.len() as u64) as usize
    };
    for _ in 0..600 {
        let ((v1, t1), (v2, t2)) = (pts[next()], pts[next()]);
        let (a, b) = if line == Line::Scale {
            (t1 / v1, 0.0)
        } else if (v1 - v2).abs() < 1e-12 {
            continue;
        } else {
            let a = (t1 - t2) / (v1 - v2);
            (a, t1 - a * v1)
        };
        // Inverse depth and a metric value grow with the value, nearness distance falls with it.
        if !a.is_finite() || (line == Line::Nearness) != (a < 0.0) || a == 0.0 {
            continue;
        }
        let n = inliers(a, b);
        if n > best_n {
            (best, best_n) = ((a, b), n);
        }
    }
    (best, best_n)
}
