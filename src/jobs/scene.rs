//! `pomc scene`: layers from a 3D scene by tracing every hit from the centre.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use serde::Serialize;

use super::WRITING_STAGE;
use crate::layer::LayerImage;
use crate::layering;
use crate::manifest::{Manifest, Transform};
use crate::panorama;

/// What [`scene_panorama`] wrote and measured: `pomc scene --json` prints it, Python's `scene`
/// returns it.
#[derive(Clone, Debug, Serialize)]
pub struct SceneSummary {
    /// The manifest as written.
    #[serde(skip)]
    pub manifest: Manifest,
    /// What making the layers did, stage by stage.
    #[serde(flatten)]
    pub report: crate::scene::BakeReport,
    /// The panorama directory written.
    pub output: PathBuf,
    /// Seconds spent reading the scene (geometry and textures).
    pub read_s: f64,
    /// Seconds spent writing the layer files and the manifest.
    pub write_s: f64,
    /// Seconds for the whole job, reading to writing.
    pub total_s: f64,
}

/// Every stage [`scene_panorama`] names, in order: `reading`, the tracing's
/// ([`crate::scene::STAGES`]), `writing` (a progress bar's length).
pub fn scene_stages() -> Vec<&'static str> {
    let mut v = vec![READING_STAGE];
    v.extend(crate::scene::STAGES);
    v.push(WRITING_STAGE);
    v
}

/// The name of the scene reading stage in progress.
pub const READING_STAGE: &str = "reading";

/// Make a layered panorama from a 3D scene (`.gltf`, `.glb`, `.obj`) by tracing every hit from the
/// centre (thesis 6.3.2) and write it into `output`, as `pomc scene` does; `progress` is called
/// with each stage's name as it starts.
///
/// ```no_run
/// use pomc::prelude::*;
/// let mut settings = BakeSettings::default();
/// settings.center = glam::DVec3::new(0.0, 0.0, 1.6);
/// let made = scene_panorama("room.glb".as_ref(), "room-pomc".as_ref(), &settings, &|_| {})?;
/// println!("{} layers", made.manifest.layers.len());
/// # Ok::<(), pomc::Error>(())
/// ```
pub fn scene_panorama(
    input: &Path,
    output: &Path,
    s: &crate::scene::BakeSettings,
    progress: &dyn Fn(&str),
) -> crate::Result<SceneSummary> {
    let start = Instant::now();
    s.mapping()?;
    progress(READING_STAGE);
    let scene = crate::scene::load::read(input, s.center, s.max_triangles)?;
    let read_s = start.elapsed().as_secs_f64();
    let baked = crate::scene::bake(&scene, s, progress)?;
    drop(scene);
    progress(WRITING_STAGE);
    let t = Instant::now();
    let transforms =
        if s.center == DVec3::ZERO { vec![] } else { vec![Transform::Translate(s.center.to_array())] };
    let manifest = layering::layers_manifest(&baked.layers, s.mapping, s.freedom_radius, transforms);
    let images: Vec<LayerImage> = baked.layers.into_iter().map(|l| l.image).collect();
    let manifest = panorama::write_panorama(output, &manifest, &images, &s.save)?;
    let write_s = t.elapsed().as_secs_f64();
    let (output, total_s) = (output.to_path_buf(), start.elapsed().as_secs_f64());
    Ok(SceneSummary { manifest, report: baked.report, output, read_s, write_s, total_s })
}
