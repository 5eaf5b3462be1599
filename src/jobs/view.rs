//! `pomc view`: the browser viewer's site of a panorama ([`view_site`]), to write or to serve.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::panorama::Panorama;
use crate::viewer::{self, Site, SiteSettings};

/// What `pomc view --json` prints: the site made, and where it went.
#[derive(Clone, Debug, Serialize)]
pub struct SiteReport {
    /// The panorama directory.
    pub panorama: String,
    /// Total size of the site's files, bytes.
    pub bytes: usize,
    /// Number of files.
    pub files: usize,
    /// Triangles of all meshed layers.
    pub triangles: usize,
    /// Each meshed layer, in painter's order.
    pub layers: Vec<SiteLayer>,
    /// Time to open, read and mesh, seconds.
    pub seconds: f64,
    /// The directory the site was written to (`--export`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub export: Option<String>,
    /// The address it is served on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub url: Option<String>,
}

/// One meshed layer of a site.
#[derive(Clone, Debug, Serialize)]
pub struct SiteLayer {
    /// The layer's name.
    pub name: String,
    /// Its triangles.
    pub triangles: usize,
}

/// The viewer's site of panorama `pano` and its report (`export` and `url` unset:
/// [`SiteReport::exported`] and [`SiteReport::served`] set them).
pub fn view_site(pano: &Panorama, settings: &SiteSettings) -> crate::Result<(Site, SiteReport)> {
    let t = Instant::now();
    let site = viewer::site(pano, settings)?;
    let layers: Vec<SiteLayer> =
        site.triangles.iter().map(|(n, t)| SiteLayer { name: n.clone(), triangles: *t }).collect();
    let report = SiteReport {
        panorama: pano.dir.display().to_string(),
        bytes: site.bytes(),
        files: site.files.len(),
        triangles: layers.iter().map(|l| l.triangles).sum(),
        layers,
        seconds: t.elapsed().as_secs_f64(),
        export: None,
        url: None,
    };
    Ok((site, report))
}

impl SiteReport {
    /// Write `site` into `dir` (as [`Site::write`]) and note it in the report.
    pub fn exported(mut self, site: &Site, dir: &Path) -> crate::Result<Self> {
        site.write(dir)?;
        self.export = Some(dir.display().to_string());
        Ok(self)
    }

    /// Note that the site is served at `url`.
    pub fn served(mut self, url: &str) -> Self {
        self.url = Some(url.to_string());
        self
    }

    /// The line `pomc view` prints.
    pub fn summary(&self) -> String {
        let mb = self.bytes as f64 / 1e6;
        match (&self.export, &self.url) {
            (Some(dir), _) => format!(
                "wrote {dir} ({} files, {mb:.1} MB, {} triangles); serve it with any static file server, e.g. `python3 -m http.server -d {dir}`",
                self.files, self.triangles
            ),
            (None, Some(url)) => format!(
                "serving {} on {url} ({mb:.1} MB, {} triangles); Ctrl-C to stop",
                self.panorama, self.triangles
            ),
            (None, None) => format!("{}: {} files, {mb:.1} MB, {} triangles", self.panorama, self.files, self.triangles),
        }
    }
}
