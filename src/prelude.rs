//! `use pomc::prelude::*;` brings the main jobs and the types they take, as in
//! `exr::prelude`. Each job is one call whose options' `Default` is the `pomc` command's default:
//!
//! | job | call | command |
//! |---|---|---|
//! | open | [`Panorama::open`]; [`describe`] for the report | `pomc info` |
//! | build | [`build_panorama`] with [`BuildSettings`] | `pomc build` |
//! | validate | [`validate()`] with [`ValidateSettings`] | `pomc validate` |
//! | mesh | [`mesh_files`] with [`MeshSettings`]; in memory [`mesh_panorama`] with [`SceneSettings`] (one layer: [`mesh_layer`] with [`MeshOptions`]) | `pomc mesh` |
//! | layers from a 3D scene | [`scene_panorama`] with [`BakeSettings`] | `pomc scene` |
//! | render | [`render_panorama`] with [`RenderSettings`]; in memory [`Renderer::render`] | `pomc render` |
//! | convert | [`convert_file`] with [`ConvertSettings`] (or [`convert_layer`] in memory) | `pomc convert` |
//! | view | [`view_site`] with [`SiteSettings`], then [`SiteReport::exported`] (or serve with [`Site::get`]) | `pomc view` |
//!
//! ```
//! use pomc::prelude::*;
//! let pano = Panorama::open("fixtures/data/room-equirect".as_ref())?;
//! let report = validate(&pano.dir, &ValidateSettings::default())?;
//! assert!(report.valid, "{:?}", report.issues);
//!
//! // Mesh the background layer as `pomc mesh` does.
//! let layer = pano.read_layer(0, &ReadLimits::default())?;
//! let mapping = AnyMapping::new(MappingKind::Equirect, layer.width, layer.height)?;
//! let meshed = mesh_layer(&layer, &mapping, &MeshOptions::default())?;
//! assert!(meshed.mesh.triangles.len() > 100);
//!
//! // A view 20 cm off-centre, looking along +Y.
//! let renderer = Renderer::new(&pano, RenderMethod::Splat)?;
//! let eye = renderer.centre() + DVec3::new(0.2, 0.0, 0.0);
//! let camera = Camera::Perspective(Perspective::new(eye, eye + DVec3::Y, DVec3::Z, 60.0, 160, 90)?);
//! let view = renderer.render(&camera)?;
//! assert!(view.hole_ratio < 0.01);
//!
//! // The layer as a 3×2 cube map with 64-pixel faces.
//! let cube = convert_layer(&layer, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 64, &SampleOptions::default())?;
//! assert_eq!((cube.width, cube.height), (192, 128));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use crate::choice::Choice;
pub use crate::colour::ColourSpace;
pub use crate::error::{Error, Result};
pub use crate::input::Convention;
pub use crate::jobs::{
    build_panorama, build_panorama_with_progress, prepare_depth_files, prepare_to_file, write_depth,
    write_report, BuildSettings, BuildSummary, PrepareSummary, RenderMethod, Renderer, View, ViewCamera,
};
pub use crate::jobs::{convert_file, ConvertReport, ConvertSettings};
pub use crate::jobs::{describe, InfoReport};
pub use crate::jobs::{mesh_files, MeshJobReport, MeshSettings};
pub use crate::jobs::{
    read_camera_path, render_panorama, CameraKind, CameraSettings, RenderReport, RenderSettings, Shot,
};
pub use crate::jobs::{repack_panorama, RepackReport, RepackSettings};
pub use crate::jobs::{scene_panorama, SceneSummary};
pub use crate::jobs::{view_site, SiteReport};
pub use crate::layer::{LayerImage, Sample};
pub use crate::layer_io::ReadLimits;
pub use crate::layering::{BuildOptions, BuildReport};
pub use crate::manifest::Manifest;
pub use crate::mapping::{layout::CubeLayout, AnyMapping, MappingKind};
pub use crate::mesh::scene::{mesh_panorama, Scene, SceneSettings};
pub use crate::mesh::{mesh_layer, MeshOptions};
pub use crate::panorama::{write_panorama, Panorama, SaveOptions};
pub use crate::prepare::{DepthEncoding, Preset};
pub use crate::prepare::{DepthKind, PrepareOptions, PrepareReport, PreparedDepth, Refine, UnknownDepth};
pub use crate::render::{
    Camera, EquirectCamera, Frame, OdsEye, Perspective, PoleMerge, StereoCamera, StereoLayout,
};
pub use crate::resample::{convert_layer, Canvas, Filter, SampleOptions};
pub use crate::scene::{BakeReport, BakeSettings};
pub use crate::validate::{validate, Report, Severity, ValidateSettings};
pub use crate::viewer::{self, Site, SiteSettings};
pub use glam::DVec3;
