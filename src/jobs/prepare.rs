//! `pomc prepare`: the depth `pomc build` layers, on the colour's grid, written as an EXR.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::BuildSettings;
use crate::input;
use crate::layer::LayerImage;
use crate::prepare::{self, PrepareReport, PreparedDepth};

/// Read `colour` and `depth` and prepare the depth as `pomc build` does before layering
/// (`pomc prepare`): metres along the ray on the colour's grid, with what was found and done.
///
/// ```
/// use pomc::prelude::*;
/// let dir = std::path::Path::new("fixtures/data/room-rgbd");
/// let settings = BuildSettings::default();
/// let prepared = prepare_depth_files(&dir.join("colour.png"), &dir.join("depth.exr"), &settings)?;
/// assert_eq!(prepared.depth.len(), prepared.width * prepared.height);
/// assert!(!prepared.report.resized, "depth of the colour's size is not resampled");
/// // Estimator output instead: `settings.depth.kind = DepthKind::Inverse` with
/// // `settings.depth.camera_height = Some(1.6)` for its scale.
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn prepare_depth_files(colour: &Path, depth: &Path, s: &BuildSettings) -> crate::Result<PreparedDepth> {
    let files = input::read(colour, s.colour_space, depth, None, &s.limits)?;
    let prepared =
        prepare::prepare_depth(depth, &files.mapping, &files.rgb, &files.depth, &s.depth, &s.prepare)?;
    Ok(prepared)
}

/// Write prepared depth as a one-channel (`Z`, float) OpenEXR of the colour's size, atomically.
pub fn write_depth(path: &Path, width: usize, height: usize, depth: &[f32]) -> crate::Result<()> {
    let mut img = LayerImage::new(width, height);
    img.set_channel("Z", crate::layer::SampleType::F32, depth.to_vec());
    crate::layer_io::write_exr(path, &img, &crate::layer_io::WriteOptions::default())
}

/// What `pomc prepare --json` prints: the preparation's report and the file written.
#[derive(Clone, Debug, Serialize)]
pub struct PrepareSummary {
    /// What was found in the depth and done to it.
    #[serde(flatten)]
    pub report: PrepareReport,
    /// Width and height of the prepared depth (the colour's), pixels.
    #[serde(skip)]
    pub size: (usize, usize),
    /// The EXR written.
    pub output: PathBuf,
}

/// Prepare the depth of `colour` and `depth` ([`prepare_depth_files`]) and write it to `output`
/// ([`write_depth`]): the job `pomc prepare` runs.
pub fn prepare_to_file(
    colour: &Path,
    depth: &Path,
    output: &Path,
    s: &BuildSettings,
) -> crate::Result<PrepareSummary> {
    let prepared = prepare_depth_files(colour, depth, s)?;
    let size = (prepared.width, prepared.height);
    write_depth(output, size.0, size.1, &prepared.depth)?;
    Ok(PrepareSummary { report: prepared.report, size, output: output.to_path_buf() })
}

impl PrepareSummary {
    /// The line `pomc prepare` prints.
    pub fn summary(&self) -> String {
        let r = &self.report;
        format!(
            "prepared {}x{} depth from {}x{}: {} px completed ({} of them blends with holes), {} made sky, {} px snapped (radius {}), {} px of specks, noise {:.4}{} -> {}",
            self.size.0,
            self.size.1,
            r.source_size.0,
            r.source_size.1,
            r.completed_pixels,
            r.rim_pixels,
            r.sky_pixels,
            r.snapped_pixels,
            r.snap_radius,
            r.speck_pixels,
            r.noise,
            if r.smoothed { " (smoothed)" } else { "" },
            self.output.display()
        )
    }
}
