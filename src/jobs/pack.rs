//! `pomc pack` and `pomc unpack`: a panorama written again with its sparse layers patch-packed, or
//! with every layer on its full canvas.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::layer_io::ReadLimits;
use crate::pack::PackOptions;
use crate::panorama::{Panorama, SaveOptions};

/// Settings of [`repack_panorama`]; the default is what `pomc pack` does.
#[derive(Clone, Copy, Debug)]
pub struct RepackSettings {
    /// Patch-pack sparse layers (`pomc pack`), or write every layer's full canvas (`pomc unpack`).
    pub pack: bool,
    /// Pack a layer only when its atlas is at most this fraction of its canvas.
    pub threshold: f64,
    /// Guard band copied around each patch, pixels.
    pub padding: u32,
    /// Size limits of the layers read.
    pub limits: ReadLimits,
}

impl Default for RepackSettings {
    fn default() -> Self {
        RepackSettings {
            pack: true,
            threshold: SaveOptions::default().pack_threshold,
            padding: PackOptions::default().padding,
            limits: ReadLimits::default(),
        }
    }
}

/// One layer as [`repack_panorama`] wrote it.
#[derive(Clone, Debug, Serialize)]
pub struct RepackedLayer {
    /// The layer's name in the manifest, if it has one.
    pub name: Option<String>,
    /// Whether it is stored patch-packed.
    pub packed: bool,
    /// Its canvas, width and height.
    pub canvas: [usize; 2],
    /// What is stored: the atlas, or the canvas when not packed.
    pub atlas: [usize; 2],
    /// Patches in the atlas (0 when not packed).
    pub patches: usize,
    /// Pixels of the canvas the layer covers.
    pub occupied_pixels: usize,
    /// Covered pixels over stored pixels.
    pub occupancy: f64,
    /// Stored pixels over canvas pixels.
    pub stored_fraction: f64,
}

/// Seconds spent reading, writing and in all.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RepackTimings {
    /// Reading every layer's full canvas.
    pub read: f64,
    /// Writing the panorama.
    pub write: f64,
    /// The whole job.
    pub total: f64,
}

/// What [`repack_panorama`] wrote (`pomc pack --json`).
#[derive(Clone, Debug, Serialize)]
pub struct RepackReport {
    /// The output panorama directory.
    pub output: PathBuf,
    /// Each layer as written, in manifest order.
    pub layers: Vec<RepackedLayer>,
    /// Where the time went.
    pub timings_s: RepackTimings,
}

/// Read every layer of the panorama `input` on its full canvas and write the panorama to `output`
/// (which may be `input`'s directory) packed or unpacked as `s` says; `progress(done, total)` after
/// each layer read.
pub fn repack_panorama(
    input: &Path,
    output: &Path,
    s: &RepackSettings,
    progress: &dyn Fn(usize, usize),
) -> crate::Result<RepackReport> {
    let start = Instant::now();
    let pano = Panorama::open(input)?;
    let n = pano.manifest.layers.len();
    progress(0, n);
    let mut images = Vec::with_capacity(n);
    for k in 0..n {
        images.push(pano.read_layer(k, &s.limits)?);
        progress(k + 1, n);
    }
    let read = start.elapsed().as_secs_f64();
    let t = Instant::now();
    let options = SaveOptions {
        pack: s.pack,
        pack_threshold: s.threshold,
        pack_options: PackOptions { padding: s.padding },
        ..SaveOptions::default()
    };
    let written = pano.save(output, &images, &options)?;
    let write = t.elapsed().as_secs_f64();
    let layers = written
        .layers
        .iter()
        .zip(&images)
        .map(|(decl, image)| {
            let canvas = image.width * image.height;
            let occupied = image.occupied();
            let (atlas, patches) = match &decl.packing {
                Some(p) => ([p.atlas_width as usize, p.atlas_height as usize], p.patches.len()),
                None => ([image.width, image.height], 0),
            };
            let stored = atlas[0] * atlas[1];
            RepackedLayer {
                name: decl.name.clone(),
                packed: decl.packing.is_some(),
                canvas: [image.width, image.height],
                atlas,
                patches,
                occupied_pixels: occupied,
                occupancy: occupied as f64 / stored.max(1) as f64,
                stored_fraction: stored as f64 / canvas.max(1) as f64,
            }
        })
        .collect();
    let timings_s = RepackTimings { read, write, total: start.elapsed().as_secs_f64() };
    Ok(RepackReport { output: output.to_path_buf(), layers, timings_s })
}
