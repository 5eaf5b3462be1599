//! The main jobs, one call each, with the command line's defaults: every settings struct's
//! `Default` is what the `pomc` command does without options. [`crate::prelude`] re-exports them.

mod build;
mod camera;
mod convert;
mod info;
mod mesh;
mod pack;
mod prepare;
mod render;
mod renderer;
mod scene;
mod validate;
mod view;

pub use build::{
    build_arrays, build_panorama, build_panorama_with_progress, build_rgbd, build_stages, prepare_input,
    BuildSettings, BuildSummary, BuiltPanorama, PREPARE_STAGE, WRITING_STAGE,
};
pub use camera::{parse_vec3, CameraKind, CameraSettings};
pub use convert::{
    convert_file, convert_file_with_progress, ConvertError, ConvertProgress, ConvertReport, ConvertSettings,
    Converted,
};
pub use info::{describe, ChannelInfo, InfoReport, LayerInfo, LayerPixels, PackedInfo};
pub use mesh::{mesh_files, LayerMeshReport, MeshJobReport, MeshSettings, SceneMeshReport, SceneTimes};
pub use pack::{repack_panorama, RepackReport, RepackSettings, RepackTimings, RepackedLayer};
pub use prepare::{prepare_depth_files, prepare_to_file, write_depth, PrepareSummary};
pub use render::{
    read_camera_path, render_panorama, FrameReport, MeshReport, PathReport, PathStages, RenderReport,
    RenderSettings, Shot, ViewReport,
};
pub use renderer::{RenderMethod, Renderer, View, ViewCamera};
pub use scene::{scene_panorama, scene_stages, SceneSummary, READING_STAGE};
pub use validate::{validate, Report, ValidateSettings};
pub use view::{view_site, SiteLayer, SiteReport};

/// Write a job's report to `path` as pretty JSON, atomically (`pomc build --report FILE`).
pub fn write_report(path: &std::path::Path, report: &impl serde::Serialize) -> crate::Result<()> {
    let text = serde_json::to_string_pretty(report)
        .map_err(|e| crate::Error::io(path.to_path_buf(), std::io::Error::other(e)))?;
    Ok(crate::fsutil::write_bytes_atomic(path, text.as_bytes())?)
}
