//! Writing a panorama (spec §1.3) as a whole: the layers, stored meshes and manifest go into a
//! temporary sibling directory that then replaces the output in one step, under a lock against
//! concurrent writers (see `docs/security.md`). A crash or a kill leaves the old panorama or the
//! new one, never a mix; what a killed writer left behind is removed by the next one.
//!
//! An output directory that also holds files which are not the panorama's own (say the input
//! images of `build`), or whose panorama keeps files in subdirectories, is never swapped away;
//! neither is the working directory (or one above it), nor one whose parent cannot take the
//! temporary (a mount point, a read-only parent). There the files are written one by one (each
//! atomically, the manifest last).

use std::borrow::Cow;
use std::collections::HashSet;
use std::path::{Component, Path, PathBuf};

use rayon::prelude::*;

use super::{resolve_inside, Panorama, PanoramaError, MANIFEST_NAME};
use crate::error::Error;
use crate::fsutil;
use crate::layer::LayerImage;
use crate::layer_io::{self, WriteOptions};
use crate::manifest::{self, LayerSource, Manifest, Packing};
use crate::pack::{self, PackOptions};

/// How [`write_panorama`] stores layers.
#[derive(Clone, Copy, Debug)]
pub struct SaveOptions {
    /// Patch-pack layers whose atlas would be smaller than `pack_threshold` × their canvas.
    pub pack: bool,
    /// Pack only when the atlas is at most this fraction of the canvas (default 0.5).
    pub pack_threshold: f64,
    /// Tuning of the packer, e.g. the guard band (default: no padding).
    pub pack_options: PackOptions,
    /// How the layer EXRs are written (default: lossless ZIP compression).
    pub exr: WriteOptions,
}

impl Default for SaveOptions {
    fn default() -> Self {
        SaveOptions {
            pack: true,
            pack_threshold: 0.5,
            pack_options: PackOptions::default(),
            exr: WriteOptions::default(),
        }
    }
}

/// Write a native panorama into `dir`: one EXR per layer (named after the layer's `Image file`,
/// `layerK.exr` for thesis-form layers) and the manifest. The canvas sizes and packing tables are
/// filled in from `layers` (full canvases). `<Mesh>` references are dropped: there is no panorama
/// to copy their files from (see [`Panorama::save`]).
pub fn write_panorama(
    dir: &Path,
    manifest: &Manifest,
    layers: &[LayerImage],
    options: &SaveOptions,
) -> Result<Manifest, Error> {
    save(dir, |d| write_files(d, manifest, &Layers::Given(layers), options, None))
}

/// [`write_panorama`] with each layer made on demand by `layer(k)` and dropped once written: one
/// layer in memory at a time, however many the panorama has (`convert` resamples this way).
pub fn write_panorama_with(
    dir: &Path,
    manifest: &Manifest,
    layer: &(dyn Fn(usize) -> Result<LayerImage, Error> + Sync),
    options: &SaveOptions,
) -> Result<Manifest, Error> {
    save(dir, |d| write_files(d, manifest, &Layers::Made(layer), options, None))
}

/// Where [`write_files`] takes the layers from.
enum Layers<'a> {
    Given(&'a [LayerImage]),
    Made(&'a (dyn Fn(usize) -> Result<LayerImage, Error> + Sync)),
}

impl Panorama {
    /// Write this panorama with `layers` (its layers' full canvases, as [`Panorama::read_layer`]
    /// gives them) into `dir`, which may be this panorama's own directory, like
    /// [`write_panorama`]; stored meshes are copied along with their `<Mesh>` references.
    pub fn save(&self, dir: &Path, layers: &[LayerImage], options: &SaveOptions) -> Result<Manifest, Error> {
        save(dir, |d| write_files(d, &self.manifest, &Layers::Given(layers), options, Some(&self.dir)))
    }
}

/// Write a panorama into `dir` by `write` (which writes its files into the directory it is given):
/// into a sibling swapped in whole where `dir` is the panorama's own, else in place.
fn save(dir: &Path, write: impl Fn(&Path) -> Result<Manifest, Error>) -> Result<Manifest, Error> {
    if std::fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
        return Err(PanoramaError::OutputNotDirectory { path: dir.to_path_buf() }.into());
    }
    let in_place = || {
        remove_temp_files(dir);
        write(dir)
    };
    // No lock file beside a mount point or in a read-only parent: write in place, unlocked.
    let Ok(_lock) = fsutil::lock_dir(dir) else { return in_place() };
    if has_foreign_entries(dir) || holds_working_directory(dir) {
        return in_place();
    }
    let Ok(tmp) = fsutil::temp_sibling(dir) else { return in_place() };
    let written = write(tmp.path())?;
    // The swap fails before touching anything (another device, a busy mount point): in place then.
    match fsutil::swap_in(tmp, dir) {
        Ok(()) => Ok(written),
        Err(_) => in_place(),
    }
}

/// Whether `dir` is the working directory or one above it (swapping it away would leave the
/// process in a deleted directory).
fn holds_working_directory(dir: &Path) -> bool {
    match (dir.canonicalize(), std::env::current_dir().and_then(|c| c.canonicalize())) {
        (Ok(d), Ok(cwd)) => cwd.starts_with(d),
        _ => false,
    }
}

/// Whether `dir` holds entries other than a panorama's own: its manifest, the files the manifest
/// names, and temporaries of killed writes. A directory without a readable manifest holds only
/// foreign entries (unless it is empty), and so does one whose panorama names files in
/// subdirectories (what else those hold is not looked into).
fn has_foreign_entries(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else { return false };
    let names: Vec<std::ffi::OsString> = entries.flatten().map(|e| e.file_name()).collect();
    if names.is_empty() {
        return false;
    }
    let manifest_path = dir.join(MANIFEST_NAME);
    let Ok(bytes) = fsutil::read_limited(&manifest_path, super::MAX_MANIFEST_BYTES) else { return true };
    let Ok(m) = manifest::parse(&bytes, &manifest_path.display().to_string()) else { return true };
    let mut own: HashSet<String> = HashSet::from([MANIFEST_NAME.to_string()]);
    let top =
        |f: &str| Path::new(f).components().next().map(|c| c.as_os_str().to_string_lossy().into_owned());
    for l in &m.layers {
        let files: Vec<&str> = match &l.source {
            LayerSource::Native { file } => vec![file],
            LayerSource::Thesis { mapname, depthname, normals } => {
                [Some(mapname.as_str()), Some(depthname.as_str()), normals.as_deref()]
                    .into_iter()
                    .flatten()
                    .collect()
            }
        };
        let files: Vec<&str> = files.into_iter().chain(l.mesh.as_ref().map(|m| m.file.as_str())).collect();
        let nested =
            |f: &&str| Path::new(f).components().filter(|c| matches!(c, Component::Normal(_))).count() > 1;
        if files.iter().any(nested) {
            return true;
        }
        own.extend(files.into_iter().filter_map(top));
    }
    names.iter().any(|n| {
        let n = n.to_string_lossy();
        !own.contains(n.as_ref()) && !n.starts_with(".pomc-tmp-")
    })
}

/// Remove temporaries of killed atomic file writes inside `dir` (with its lock held).
fn remove_temp_files(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().starts_with(".pomc-tmp-")
            && e.file_type().is_ok_and(|t| t.is_file())
        {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Write the layers, meshes and manifest into `dir` (each file atomically, the manifest last).
fn write_files(
    dir: &Path,
    manifest: &Manifest,
    layers: &Layers,
    options: &SaveOptions,
    meshes_from: Option<&Path>,
) -> Result<Manifest, Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir.to_path_buf(), source))?;
    let mut out = manifest.clone();
    let files = destinations(dir, &out)?;
    if let Layers::Given(given) = layers {
        if given.len() != files.len() {
            let (index, count) = (given.len().min(files.len()), given.len());
            let manifest = dir.join(MANIFEST_NAME);
            return Err(PanoramaError::NoSuchLayer { manifest, index, count }.into());
        }
    }
    let write_one = |k: usize, file: String, path: &Path| write_layer(layers, options, k, file, path);
    // Given layers are packed and encoded in parallel (each EXR encode is parallel too, but packing
    // and the small layers are not); made ones one after another, to hold one at a time.
    let jobs = files.into_iter().enumerate();
    let written: Vec<Result<Written, Error>> = match layers {
        Layers::Given(_) => {
            jobs.collect::<Vec<_>>().into_par_iter().map(|(k, (f, p))| write_one(k, f, &p)).collect()
        }
        Layers::Made(_) => write_staged(jobs, write_one)?,
    };
    for (decl, result) in out.layers.iter_mut().zip(written) {
        let Written { file, size, packing } = result?;
        decl.source = LayerSource::Native { file };
        decl.width = Some(size.0);
        decl.height = Some(size.1);
        decl.packing = packing;
        let copied = match (&decl.mesh, meshes_from) {
            (Some(m), Some(from)) => copy_mesh(from, dir, &m.file)?,
            _ => false,
        };
        if !copied {
            decl.mesh = None;
        }
    }
    fsutil::write_bytes_atomic(&dir.join(MANIFEST_NAME), out.to_xml().as_bytes())?;
    Ok(out)
}

/// Each layer's file name and path in `dir`, every one checked before the first write: a name
/// that escapes through a symbolic link must not leave a half-written panorama behind.
fn destinations(dir: &Path, out: &Manifest) -> Result<Vec<(String, PathBuf)>, Error> {
    out.layers
        .iter()
        .enumerate()
        .map(|(k, decl)| {
            let file = match &decl.source {
                LayerSource::Native { file } => file.clone(),
                LayerSource::Thesis { .. } => format!("layer{k}.exr"),
            };
            inside(dir, &file).map(|path| (file, path))
        })
        .collect()
}

/// Write layer `k` to `path`, packed when that is worth it.
fn write_layer(
    layers: &Layers,
    options: &SaveOptions,
    k: usize,
    file: String,
    path: &Path,
) -> Result<Written, Error> {
    // A made layer is owned: its samples move into the encoder rather than being copied.
    let image: Cow<LayerImage> = match layers {
        Layers::Given(given) => Cow::Borrowed(&given[k]),
        Layers::Made(make) => Cow::Owned(make(k)?),
    };
    let size = (image.width as u32, image.height as u32);
    let canvas = image.width as f64 * image.height as f64;
    // An atlas never holds fewer pixels than the domain: a layer fuller than the
    // threshold is not worth cutting up.
    let worth_packing = options.pack
        && (image.domain().iter().filter(|&&m| m).count() as f64) <= options.pack_threshold * canvas;
    let packed = if worth_packing { Some(pack::pack_layer(&image, &options.pack_options)?) } else { None };
    let packing = match packed {
        Some(p) if (p.atlas_area() as f64) <= options.pack_threshold * canvas => {
            drop(image);
            let packing = Packing {
                atlas_width: p.atlas.width as u32,
                atlas_height: p.atlas.height as u32,
                patches: p.patches,
            };
            layer_io::write_exr_owned(path, p.atlas, &options.exr)?;
            Some(packing)
        }
        _ => {
            match image {
                Cow::Owned(m) => layer_io::write_exr_owned(path, m, &options.exr)?,
                Cow::Borrowed(b) => layer_io::write_exr(path, b, &options.exr)?,
            }
            None
        }
    };
    Ok(Written { file, size, packing })
}

/// Write made layers one after another. A made layer may be read from the file it replaces
/// (`convert` in place): each goes to a staged name first, and all are renamed into place only
/// once every one is written.
fn write_staged(
    jobs: impl Iterator<Item = (usize, (String, PathBuf))>,
    write_one: impl Fn(usize, String, &Path) -> Result<Written, Error>,
) -> Result<Vec<Result<Written, Error>>, Error> {
    let mut staged = Vec::new();
    let mut results = Vec::new();
    for (k, (file, path)) in jobs {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let stage = path.with_file_name(format!(".pomc-tmp-stage-{name}"));
        let result = write_one(k, file, &stage);
        let failed = result.is_err();
        staged.push((stage, path));
        results.push(result);
        if failed {
            break;
        }
    }
    if results.iter().any(Result::is_err) {
        for (stage, _) in &staged {
            let _ = std::fs::remove_file(stage);
        }
    } else {
        for (stage, path) in &staged {
            std::fs::rename(stage, path).map_err(|source| Error::io(path.clone(), source))?;
        }
    }
    Ok(results)
}

/// What writing one layer gives the manifest.
struct Written {
    file: String,
    size: (u32, u32),
    packing: Option<Packing>,
}

fn inside(dir: &Path, file: &str) -> Result<std::path::PathBuf, Error> {
    resolve_inside(dir, file).ok_or_else(|| {
        PanoramaError::PathEscapes {
            manifest: dir.join(MANIFEST_NAME),
            file: file.to_string(),
            dir: dir.to_path_buf(),
        }
        .into()
    })
}

/// Copy a stored mesh file from panorama directory `from` to `to`; `false` when `from` has no
/// usable file of that name (the reference is then dropped: readers would rebuild the mesh anyway).
fn copy_mesh(from: &Path, to: &Path, file: &str) -> Result<bool, Error> {
    let (Some(src), Ok(dst)) = (resolve_inside(from, file), inside(to, file)) else { return Ok(false) };
    if !src.is_file() {
        return Ok(false);
    }
    // Writing in place: the file is already where it belongs (copying it onto itself would
    // truncate it).
    if let (Ok(a), Ok(b)) = (src.canonicalize(), dst.canonicalize()) {
        if a == b {
            return Ok(true);
        }
    }
    let bytes = std::fs::read(&src).map_err(|source| Error::io(src.clone(), source))?;
    fsutil::write_bytes_atomic(&dst, &bytes)?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::layer::SampleType;
    use crate::manifest::{LayerDecl, MappingDecl, MappingKind};

    /// A temporary root and the output directory `out` in it (not created).
    fn root_out() -> (tempfile::TempDir, PathBuf) {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        (root, out)
    }

    /// Write a panorama with the default options.
    fn save_default(out: &Path, m: &Manifest, l: &[LayerImage]) {
        write_panorama(out, m, l, &SaveOptions::default()).unwrap();
    }

    /// A one-layer panorama whose layer file is `file`, at depth `z` everywhere.
    fn pano(file: &str, z: f32) -> (Manifest, Vec<LayerImage>) {
        let mut img = LayerImage::new(16, 8);
        for c in ["R", "G", "B"] {
            img.set_channel(c, SampleType::F16, vec![0.5; 128]);
        }
        img.set_channel("Z", SampleType::F32, vec![z; 128]);
        let m = Manifest {
            version: "1".into(),
            transforms: Vec::new(),
            mapping: MappingDecl { kind: MappingKind::Equirect },
            freedom_radius: 0.5,
            layers: vec![LayerDecl::native(file)],
        };
        (m, vec![img])
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn layers_made_on_demand_are_written_like_given_ones() {
        let root = tempfile::tempdir().unwrap();
        let (mut m, mut l) = pano("a.exr", 2.0);
        m.layers.push(LayerDecl::native("b.exr"));
        l.push(pano("b.exr", 3.0).1.remove(0));
        let given = write_panorama(&root.path().join("given"), &m, &l, &SaveOptions::default()).unwrap();
        let made = write_panorama_with(
            &root.path().join("made"),
            &m,
            &|k| Ok(l[k].clone()),
            &SaveOptions::default(),
        )
        .unwrap();
        assert_eq!(given.to_xml(), made.to_xml());
        for f in ["a.exr", "b.exr", "panorama.xml"] {
            let read = |d: &str| std::fs::read(root.path().join(d).join(f)).unwrap();
            assert_eq!(read("given"), read("made"), "{f}");
        }
        let short = write_panorama(&root.path().join("short"), &m, &l[..1], &SaveOptions::default());
        assert_eq!(short.unwrap_err().code(), "PANORAMA_NO_SUCH_LAYER");
    }

    #[test]
    fn a_made_layer_that_fails_leaves_the_old_files() {
        let (_root, out) = root_out();
        let (mut m, mut l) = pano("a.exr", 2.0);
        m.layers.push(LayerDecl::native("b.exr"));
        l.push(pano("b.exr", 3.0).1.remove(0));
        save_default(&out, &m, &l);
        // A foreign file keeps the next write in place, over the files the layers are made from.
        std::fs::write(out.join("input.png"), b"x").unwrap();
        let before: Vec<Vec<u8>> =
            ["a.exr", "b.exr"].iter().map(|f| std::fs::read(out.join(f)).unwrap()).collect();
        let failing = |k: usize| -> Result<LayerImage, Error> {
            if k == 1 {
                return Err(PanoramaError::NoSuchLayer { manifest: "x".into(), index: 1, count: 1 }.into());
            }
            let mut img = l[0].clone();
            img.channel_mut("Z").unwrap().data.fill(9.0);
            Ok(img)
        };
        assert!(write_panorama_with(&out, &m, &failing, &SaveOptions::default()).is_err());
        let after: Vec<Vec<u8>> =
            ["a.exr", "b.exr"].iter().map(|f| std::fs::read(out.join(f)).unwrap()).collect();
        assert_eq!(before, after);
        assert_eq!(names(&out), ["a.exr", "b.exr", "input.png", "panorama.xml"]);
    }

    #[cfg(unix)]
    #[test]
    fn an_escaping_symlink_stops_the_write_before_any_file() {
        let (root, out) = root_out();
        std::fs::create_dir(&out).unwrap();
        // A foreign file keeps the write in place, where the symlink is in the way.
        std::fs::write(out.join("input.png"), b"x").unwrap();
        std::fs::write(root.path().join("elsewhere.exr"), b"keep").unwrap();
        std::os::unix::fs::symlink(root.path().join("elsewhere.exr"), out.join("b.exr")).unwrap();
        let (mut m, mut l) = pano("a.exr", 2.0);
        m.layers.push(LayerDecl::native("b.exr"));
        l.push(l[0].clone());
        let e = write_panorama(&out, &m, &l, &SaveOptions::default()).unwrap_err();
        assert_eq!(e.code(), "LAYER_PATH_ESCAPES", "{e}");
        assert_eq!(names(&out), ["b.exr", "input.png"]);
        assert_eq!(std::fs::read(root.path().join("elsewhere.exr")).unwrap(), b"keep");
    }

    #[test]
    fn a_panorama_replaces_the_old_one_whole_and_cleans_up() {
        let (root, out) = root_out();
        let (m, l) = pano("a.exr", 2.0);
        save_default(&out, &m, &l);
        assert_eq!(names(&out), ["a.exr", "panorama.xml"]);
        // A killed writer's temporaries beside and inside the output.
        std::fs::create_dir(root.path().join(".out.pomc-tmp-dead")).unwrap();
        std::fs::write(out.join(".pomc-tmp-x"), b"half").unwrap();
        let (m, l) = pano("b.exr", 3.0);
        save_default(&out, &m, &l);
        // The old layer file went with the old panorama; only the lock file stays beside it.
        assert_eq!(names(&out), ["b.exr", "panorama.xml"]);
        assert_eq!(names(root.path()), [".out.pomc-lock", "out"]);
        let p = Panorama::open(&out).unwrap();
        assert_eq!(p.read_layer(0, &Default::default()).unwrap().depth().unwrap()[0], 3.0);
    }

    #[test]
    fn foreign_files_are_kept_and_written_beside() {
        let (root, out) = root_out();
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("colour.png"), b"input").unwrap();
        let (m, l) = pano("a.exr", 2.0);
        save_default(&out, &m, &l);
        assert_eq!(names(&out), ["a.exr", "colour.png", "panorama.xml"]);
        assert_eq!(std::fs::read(out.join("colour.png")).unwrap(), b"input");
        let file = root.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = write_panorama(&file, &m, &l, &SaveOptions::default()).unwrap_err();
        assert_eq!(e.code(), "OUTPUT_NOT_DIRECTORY");
    }

    #[test]
    fn files_beside_a_nested_layer_are_kept() {
        let (_root, out) = root_out();
        let (m, l) = pano("images/l0.exr", 2.0);
        save_default(&out, &m, &l);
        std::fs::write(out.join("images/colour.png"), b"input").unwrap();
        save_default(&out, &m, &l);
        assert_eq!(std::fs::read(out.join("images/colour.png")).unwrap(), b"input");
        // The working directory, or one above it, is never swapped away.
        assert!(holds_working_directory(Path::new("/")) && !holds_working_directory(&out));
    }

    #[test]
    fn a_writer_killed_between_the_fallback_renames_loses_nothing() {
        let (root, out) = root_out();
        let (m, l) = pano("a.exr", 2.0);
        save_default(&out, &m, &l);
        // The state the two-rename swap leaves when killed between its renames.
        std::fs::rename(&out, root.path().join(".out.pomc-old-4242")).unwrap();
        std::fs::create_dir(root.path().join(".out.pomc-tmp-x")).unwrap();
        drop(fsutil::lock_dir(&out).unwrap());
        assert_eq!(names(&out), ["a.exr", "panorama.xml"], "the old panorama is back");
        assert_eq!(names(root.path()), [".out.pomc-lock", "out"]);
    }

    #[test]
    fn concurrent_writers_leave_one_whole_panorama() {
        let (_root, out) = root_out();
        std::thread::scope(|s| {
            for k in 0..4 {
                let out = &out;
                s.spawn(move || {
                    let (m, l) = pano(&format!("l{k}.exr"), 1.0 + k as f32);
                    write_panorama(out, &m, &l, &SaveOptions::default()).unwrap();
                });
            }
        });
        let p = Panorama::open(&out).unwrap();
        let z = p.read_layer(0, &Default::default()).unwrap().depth().unwrap()[0];
        let LayerSource::Native { file } = &p.manifest.layers[0].source else { panic!() };
        assert_eq!(
            file,
            &format!("l{}.exr", z as usize - 1),
            "the manifest and its layer come from one writer"
        );
        assert_eq!(names(&out).len(), 2, "{:?}", names(&out));
    }
}
