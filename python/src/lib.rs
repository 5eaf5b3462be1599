//! `pomc._pomc`: the Python binding. It translates arguments and calls `pomc::jobs`; the Python
//! package (`pomc/__init__.py`) wraps it in the documented API. Heavy calls release the GIL.

#![forbid(unsafe_code)]

use std::path::PathBuf;
use std::sync::Mutex;

use glam::DVec3;
use numpy::{
    IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyInt, PyString};

use pomc::input::ColourSamples;
use pomc::jobs::{self, BuildSettings, RenderMethod, Renderer};
use pomc::layer::{LayerImage, Sample};
use pomc::layer_io::ReadLimits;
use pomc::manifest::Manifest;
use pomc::mesh::scene::{self, SceneSettings};
use pomc::mesh::MeshOptions;
use pomc::panorama::{Panorama, SaveOptions};
use pomc_flags::{self as options, BuildArgs, CameraArgs, Keyword, MeshArgs, SceneArgs};

create_exception!(_pomc, PomcError, PyException, "A pomc failure; `.code` is its stable code.");

fn fail(code: &str, message: String) -> PyErr {
    let err = PomcError::new_err(message);
    Python::with_gil(|py| {
        let _ = err.value(py).setattr("code", code);
    });
    err
}

fn to_py(e: pomc::Error) -> PyErr {
    fail(e.code(), e.to_string())
}

fn usage(message: String) -> PyErr {
    fail(pomc::codes::CLI_USAGE, message)
}

/// A panorama in memory: manifest and full-canvas layers (manifest order), and the directory it was
/// read from (until changed).
#[pyclass(module = "pomc._pomc", name = "Panorama")]
struct PyPanorama {
    manifest: Manifest,
    layers: Vec<LayerImage>,
    dir: Option<PathBuf>,
    renderers: Mutex<Vec<(RenderMethod, std::sync::Arc<Renderer>)>>,
}

impl PyPanorama {
    fn new(manifest: Manifest, layers: Vec<LayerImage>, dir: Option<PathBuf>) -> Self {
        PyPanorama { manifest, layers, dir, renderers: Mutex::new(Vec::new()) }
    }

    fn renderer(&self, method: RenderMethod) -> Result<std::sync::Arc<Renderer>, pomc::Error> {
        if let Ok(cache) = self.renderers.lock() {
            if let Some((_, r)) = cache.iter().find(|(m, _)| *m == method) {
                return Ok(r.clone());
            }
        }
        let r = std::sync::Arc::new(Renderer::from_layers(&self.manifest, self.layers.clone(), method)?);
        if let Ok(mut cache) = self.renderers.lock() {
            cache.push((method, r.clone()));
        }
        Ok(r)
    }
}

#[pymethods]
impl PyPanorama {
    /// Number of layers.
    fn __len__(&self) -> usize {
        self.layers.len()
    }

    /// The directory this panorama was read from or last saved to.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.dir.clone()
    }

    /// The manifest as XML (what `panorama.xml` holds).
    fn manifest_xml(&self) -> String {
        self.manifest.to_xml()
    }

    /// Freedom radius in metres.
    #[getter]
    fn freedom_radius(&self) -> f64 {
        self.manifest.freedom_radius
    }

    /// `(name, role, order)` of layer `k`.
    fn layer_info(&self, k: usize) -> PyResult<(String, Option<String>, u32)> {
        let decl = self.manifest.layers.get(k).ok_or_else(|| usage(format!("no layer {k}")))?;
        let name = self.manifest.layer_name(k);
        let order = decl.order.unwrap_or(k as u32);
        Ok((name, decl.role.map(|r| r.as_str().to_string()), order))
    }

    /// Colour (H×W×3 float32 linear, 0 where absent), depth (H×W float32) and mask (H×W bool) of
    /// layer `k`.
    #[allow(clippy::type_complexity)]
    fn layer_arrays<'py>(
        &self,
        py: Python<'py>,
        k: usize,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let l = self.layers.get(k).ok_or_else(|| usage(format!("no layer {k}")))?;
        let (w, h, n) = (l.width, l.height, l.width * l.height);
        let mut rgb = vec![0f32; n * 3];
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            if let Some(ch) = l.channel(name) {
                for (i, v) in ch.data.iter().enumerate() {
                    rgb[i * 3 + c] = *v;
                }
            }
        }
        let depth = l.depth().map(<[f32]>::to_vec).unwrap_or_else(|| vec![f32::NAN; n]);
        let sample = l.sampler();
        let mask: Vec<bool> = (0..n).map(|i| sample(i) != Sample::Outside).collect();
        let shape =
            |a: Bound<'py, PyArray1<f32>>, dims: &[usize]| a.reshape(dims.to_vec()).map(Bound::into_any);
        Ok((
            shape(rgb.into_pyarray(py), &[h, w, 3])?,
            shape(depth.into_pyarray(py), &[h, w])?,
            mask.into_pyarray(py).reshape(vec![h, w])?.into_any(),
        ))
    }

    /// Write the panorama into `dir` (patch-packing sparse layers), as `pomc build -o` does.
    #[staticmethod]
    fn save_into(slf: &Bound<'_, Self>, dir: PathBuf) -> PyResult<()> {
        let py = slf.py();
        // A shared borrow while the GIL is released (other threads may render meanwhile).
        let written = {
            let this = slf.borrow();
            let (manifest, layers) = (&this.manifest, &this.layers);
            py.allow_threads(|| {
                pomc::panorama::write_panorama(&dir, manifest, layers, &SaveOptions::default())
            })
            .map_err(to_py)?
        };
        let mut this = slf.borrow_mut();
        this.manifest = written;
        this.dir = Some(dir);
        Ok(())
    }

    /// Validate (as `pomc validate`) and return the report as JSON.
    fn validate_json(&self, py: Python<'_>) -> PyResult<String> {
        let report = py
            .allow_threads(|| -> Result<_, pomc::Error> {
                let options = pomc::validate::ValidateSettings::default();
                match &self.dir {
                    Some(dir) => pomc::validate::validate(dir, &options),
                    None => {
                        let tmp = tempfile::tempdir()
                            .map_err(|source| pomc::Error::io(std::env::temp_dir(), source))?;
                        pomc::panorama::write_panorama(
                            tmp.path(),
                            &self.manifest,
                            &self.layers,
                            &SaveOptions::default(),
                        )?;
                        pomc::validate::validate(tmp.path(), &options)
                    }
                }
            })
            .map_err(to_py)?;
        serde_json::to_string(&report).map_err(|e| usage(e.to_string()))
    }

    /// Render a view through the camera the keyword options describe (`pomc render`'s camera
    /// options): colour (H×W×3 float32 linear), depth (H×W float32), mask (H×W bool: covered), and
    /// the hole ratio. Stereo cameras return both eyes stacked as the layout says.
    #[pyo3(signature = (eye, look_at, method, options))]
    #[allow(clippy::type_complexity)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        eye: Option<[f64; 3]>,
        look_at: Option<[f64; 3]>,
        method: &str,
        options: &Bound<'py, PyDict>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, f64)> {
        let method = render_method(method)?;
        let camera =
            options::from_keywords::<CameraArgs>("render", &keywords(options)?).map_err(usage)?.settings();
        let eye = eye.map(DVec3::from).unwrap_or(pomc::manifest::centre(self.manifest.local_to_world()));
        let look = self.manifest.default_look();
        let view = py
            .allow_threads(|| {
                let renderer = self.renderer(method)?;
                let cam =
                    camera.view_camera(eye, look_at.map(DVec3::from), look, renderer.panorama_width())?;
                renderer.render_view(&cam)
            })
            .map_err(to_py)?;
        let f = view.frame;
        let n = f.width * f.height;
        let mut rgb = vec![0f32; n * 3];
        for (c, plane) in f.rgb.iter().enumerate() {
            for (i, v) in plane.iter().enumerate() {
                rgb[i * 3 + c] = *v;
            }
        }
        let (fw, fh) = (f.width, f.height);
        Ok((
            rgb.into_pyarray(py).reshape(vec![fh, fw, 3])?.into_any(),
            f.depth.into_pyarray(py).reshape(vec![fh, fw])?.into_any(),
            f.covered.into_pyarray(py).reshape(vec![fh, fw])?.into_any(),
            view.hole_ratio,
        ))
    }

    /// Mesh every layer (painter's order) or layer `layer`: a list of dicts with `name`, `layer`,
    /// `vertices` (N×3 float64, panorama-local), `triangles` (M×3 uint32), `uv` (N×2 float32),
    /// `sky_radius`. `options`: the `pomc mesh` options as keywords.
    #[pyo3(signature = (layer, options))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        layer: Option<usize>,
        options: &Bound<'py, PyDict>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let (params, sky_radius) = mesh_settings(options)?;
        let settings =
            SceneSettings { mesh: params, only: layer, sky_radius, metric: false, ..Default::default() };
        let scene = py
            .allow_threads(|| scene::mesh_images(&self.manifest, &self.layers, &settings))
            .map_err(to_py)?;
        scene
            .layers
            .into_iter()
            .map(|m| {
                let d = PyDict::new(py);
                let mesh = &m.meshed.mesh;
                let (w, h) = (mesh.width, mesh.height);
                let uv: Vec<f32> = mesh
                    .sources
                    .iter()
                    .flat_map(|&id| pomc::mesh::export::canvas_uv(id, w, h).map(|c| c as f32))
                    .collect();
                let v: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
                let t: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
                let (nv, nt) = (mesh.positions.len(), mesh.triangles.len());
                d.set_item("name", &m.name)?;
                d.set_item("layer", m.index)?;
                d.set_item("vertices", v.into_pyarray(py).reshape(vec![nv, 3])?)?;
                d.set_item("triangles", t.into_pyarray(py).reshape(vec![nt, 3])?)?;
                d.set_item("uv", uv.into_pyarray(py).reshape(vec![nv, 2])?)?;
                d.set_item("sky_radius", m.sky_radius)?;
                Ok(d)
            })
            .collect()
    }

    /// Mesh every layer and write one scene file (.glb, .obj, .ply), as `pomc mesh PANO -o PATH`.
    #[pyo3(signature = (path, options, local=false))]
    fn export_mesh(
        &self,
        py: Python<'_>,
        path: PathBuf,
        options: &Bound<'_, PyDict>,
        local: bool,
    ) -> PyResult<Vec<PathBuf>> {
        let (params, sky_radius) = mesh_settings(options)?;
        let exported = py
            .allow_threads(|| {
                let settings =
                    SceneSettings { mesh: params, sky_radius, metric: false, ..Default::default() };
                let scene = scene::mesh_images(&self.manifest, &self.layers, &settings)?;
                scene::export_scene(&path, &scene.layers, (!local).then(|| self.manifest.local_to_world()))
            })
            .map_err(to_py)?;
        Ok(exported.files)
    }
}

/// Mesh parameters and the sky radius from the keyword options, parsed and checked by the
/// library's declaration of `pomc mesh`'s options (`simplify` and `greedy` for `--no-simplify` and
/// `--no-greedy`).
fn mesh_settings(o: &Bound<'_, PyDict>) -> PyResult<(MeshOptions, Option<f64>)> {
    let args: MeshArgs = options::from_keywords("mesh", &keywords(o)?).map_err(usage)?;
    Ok((args.params(), args.sky_radius))
}

/// Write a rendered colour (H×W×3 float32, linear) as `pomc render -o` does: `.png` 8-bit sRGB
/// through the same tone map, `.exr` linear float.
#[pyfunction]
fn save_colour(py: Python<'_>, path: PathBuf, colour: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    let shape = colour.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(usage(format!("colour must be H×W×3 (as render returns), got {shape:?}")));
    }
    let data = contiguous(&colour)?;
    let (h, w) = (shape[0], shape[1]);
    let mut frame = pomc::render::Frame::holes_only(w, h);
    for (i, px) in data.chunks_exact(3).enumerate() {
        for (plane, &v) in frame.rgb.iter_mut().zip(px) {
            plane[i] = v;
        }
    }
    py.allow_threads(|| pomc::render::frame::save_colour(&frame, &path)).map_err(to_py)
}

/// Open a panorama directory (or its manifest), reading every layer.
#[pyfunction]
fn open(py: Python<'_>, path: PathBuf) -> PyResult<PyPanorama> {
    let (manifest, layers, dir) = py
        .allow_threads(|| -> Result<_, pomc::Error> {
            let pano = Panorama::open(&path)?;
            let layers = pano.read_layers(&ReadLimits::default())?;
            Ok((pano.manifest, layers, pano.dir))
        })
        .map_err(to_py)?;
    Ok(PyPanorama::new(manifest, layers, Some(dir)))
}

/// Build a panorama from arrays; `options` holds the `pomc build` options as keywords.
#[pyfunction]
fn build(
    py: Python<'_>,
    colour: &Bound<'_, PyAny>,
    depth: PyReadonlyArray2<'_, f32>,
    options: &Bound<'_, PyDict>,
) -> PyResult<PyPanorama> {
    let settings = settings(options)?;
    let shape = depth.shape();
    let (h, w) = (shape[0], shape[1]);
    if !depth.is_c_contiguous() {
        return Err(usage("depth must be a C-contiguous array (np.ascontiguousarray)".into()));
    }
    let depth = depth.as_slice().map_err(|e| usage(format!("depth: {e}")))?.to_vec();
    let built = if let Ok(c) = colour.extract::<PyReadonlyArray3<'_, u8>>() {
        check_colour(c.shape(), h, w)?;
        let c = contiguous(&c)?;
        py.allow_threads(|| jobs::build_arrays(w, h, ColourSamples::U8(&c), &depth, &settings, &|_| {}))
    } else if let Ok(c) = colour.extract::<PyReadonlyArray3<'_, u16>>() {
        check_colour(c.shape(), h, w)?;
        let c = contiguous(&c)?;
        py.allow_threads(|| jobs::build_arrays(w, h, ColourSamples::U16(&c), &depth, &settings, &|_| {}))
    } else if let Ok(c) = colour.extract::<PyReadonlyArray3<'_, f32>>() {
        check_colour(c.shape(), h, w)?;
        let c = contiguous(&c)?;
        py.allow_threads(|| jobs::build_arrays(w, h, ColourSamples::F32(&c), &depth, &settings, &|_| {}))
    } else {
        return Err(usage("colour must be an H×W×3 uint8, uint16 or float32 array".into()));
    }
    .map_err(to_py)?;
    Ok(PyPanorama::new(built.manifest, built.layers, None))
}

/// Build from image files into `output` as `pomc build` does (the library reads and writes the
/// files, atomically); returns the JSON report `pomc build --json` prints.
#[pyfunction]
fn build_files(
    py: Python<'_>,
    colour: PathBuf,
    depth: PathBuf,
    output: PathBuf,
    options: &Bound<'_, PyDict>,
) -> PyResult<String> {
    let settings = settings(options)?;
    let summary =
        py.allow_threads(|| jobs::build_panorama(&colour, &depth, &output, &settings)).map_err(to_py)?;
    report_json(&summary)
}

/// Make a panorama from a 3D scene file (glTF, GLB, OBJ) into `output` as `pomc scene` does (the
/// library reads the scene and writes the panorama atomically); returns the JSON report.
#[pyfunction]
fn scene_files(
    py: Python<'_>,
    scene: PathBuf,
    output: PathBuf,
    options: &Bound<'_, PyDict>,
) -> PyResult<String> {
    let args: SceneArgs = options::from_keywords("scene", &keywords(options)?).map_err(usage)?;
    let settings = args.settings();
    let made =
        py.allow_threads(|| jobs::scene_panorama(&scene, &output, &settings, &|_| {})).map_err(to_py)?;
    report_json(&made)
}

/// Write the panorama `input` again into `output` (may be the same directory) with its sparse
/// layers patch-packed (`pack`) or every layer on its full canvas, as `pomc pack` / `pomc unpack`
/// do; returns the JSON report (`layers`, `output`, `timings_s`).
#[pyfunction]
fn repack_files(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    pack: bool,
    threshold: f64,
    padding: u32,
) -> PyResult<String> {
    if !(threshold > 0.0 && threshold <= 1.0) {
        return Err(usage(format!("threshold {threshold} must lie in (0, 1]")));
    }
    let s = jobs::RepackSettings { pack, threshold, padding, ..jobs::RepackSettings::default() };
    let report =
        py.allow_threads(|| jobs::repack_panorama(&input, &output, &s, &|_, _| {})).map_err(to_py)?;
    serde_json::to_string(&report).map_err(|e| usage(e.to_string()))
}

/// `pomc render --method`'s names.
fn render_method(name: &str) -> PyResult<RenderMethod> {
    match name {
        "splat" => Ok(RenderMethod::Splat),
        "mesh" => Ok(RenderMethod::Mesh),
        other => Err(usage(format!("method `{other}`: use \"splat\" or \"mesh\""))),
    }
}

/// Render views of the panorama `pano` into files as `pomc render` does: one view, or one per
/// line of the camera path `path` (output names numbered at their run of `#`); returns the JSON
/// report `pomc render --json` prints.
#[pyfunction]
#[pyo3(signature = (pano, output, depth, mask, path, method, options))]
#[allow(clippy::too_many_arguments)]
fn render_files(
    py: Python<'_>,
    pano: PathBuf,
    output: PathBuf,
    depth: Option<PathBuf>,
    mask: Option<PathBuf>,
    path: Option<PathBuf>,
    method: &str,
    options: &Bound<'_, PyDict>,
) -> PyResult<String> {
    let method = render_method(method)?;
    let camera =
        options::from_keywords::<CameraArgs>("render", &keywords(options)?).map_err(usage)?.settings();
    let shots = path.map(|p| jobs::read_camera_path(&p)).transpose().map_err(|e| to_py(e.into()))?;
    let s = jobs::RenderSettings { output, depth, mask, camera, method, shots };
    let report = py.allow_threads(|| jobs::render_panorama(&pano, &s, &|_, _, _| {})).map_err(to_py)?;
    serde_json::to_string(&report).map_err(|e| usage(e.to_string()))
}

/// Read and prepare depth as `pomc prepare` does: the depth on the colour's grid (H×W float32,
/// metres along the ray, `inf` far) and the JSON report.
#[pyfunction]
fn prepare_files<'py>(
    py: Python<'py>,
    colour: PathBuf,
    depth: PathBuf,
    options: &Bound<'py, PyDict>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f32>>, String)> {
    let settings = settings(options)?;
    let prepared =
        py.allow_threads(|| jobs::prepare_depth_files(&colour, &depth, &settings)).map_err(to_py)?;
    let report = serde_json::to_string(&prepared.report).map_err(|e| usage(e.to_string()))?;
    let array = numpy::ndarray::Array2::from_shape_vec((prepared.height, prepared.width), prepared.depth)
        .map_err(|e| usage(e.to_string()))?;
    Ok((numpy::IntoPyArray::into_pyarray(array, py), report))
}

/// A job's report as the command prints it with `--json` (through `serde_json::Value`, as the
/// command does, so floats read back the same).
fn report_json(report: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_value(report).map(|v| v.to_string()).map_err(|e| usage(e.to_string()))
}

fn contiguous<T: numpy::Element + Copy>(a: &PyReadonlyArray3<'_, T>) -> PyResult<Vec<T>> {
    if !a.is_c_contiguous() {
        return Err(usage("colour must be a C-contiguous array (np.ascontiguousarray)".into()));
    }
    Ok(a.as_slice().map_err(|e| usage(format!("colour: {e}")))?.to_vec())
}

fn check_colour(shape: &[usize], h: usize, w: usize) -> PyResult<()> {
    if shape != [h, w, 3] {
        return Err(fail(
            pomc::codes::INPUT_SIZE_MISMATCH,
            format!(
                "colour is {shape:?} but depth is {h}×{w}: colour must be H×W×3 with the depth's H and W"
            ),
        ));
    }
    Ok(())
}

/// `BuildSettings` from the keyword options, parsed and checked by the library's declaration of
/// `pomc build`'s options (names as the command's, `-` as `_`).
fn settings(o: &Bound<'_, PyDict>) -> PyResult<BuildSettings> {
    let args: BuildArgs = options::from_keywords("build", &keywords(o)?).map_err(usage)?;
    Ok(args.settings())
}

/// Keyword values in the command line's syntax: `None` unset, `True`/`False` as flags, an integer
/// as written, any other number (NumPy's too) as the shortest text of its `f64` (so it parses back
/// to the same value), a path as its text, a sequence (list, tuple, array) as comma-separated
/// values; an empty sequence is unset.
fn keywords(o: &Bound<'_, PyDict>) -> PyResult<Vec<(String, Keyword)>> {
    fn scalar(v: &Bound<'_, PyAny>) -> PyResult<String> {
        if v.is_instance_of::<PyInt>() {
            return Ok(v.str()?.to_string());
        }
        if let Ok(x) = v.extract::<f64>() {
            return Ok(format!("{x}"));
        }
        match v.extract::<PathBuf>() {
            Ok(p) => Ok(p.to_string_lossy().into_owned()),
            Err(_) => Ok(v.str()?.to_string()),
        }
    }
    let mut out = Vec::new();
    for (k, v) in o.iter() {
        let key: String = k.extract()?;
        let value = if v.is_none() {
            Keyword::Unset
        } else if let Ok(b) = v.downcast::<PyBool>() {
            Keyword::Flag(b.is_true())
        } else if v.is_instance_of::<PyString>() || v.is_instance_of::<PyBytes>() {
            Keyword::Value(scalar(&v)?)
        } else if let Ok(items) = v.try_iter() {
            let parts: Vec<String> = items.map(|x| scalar(&x?)).collect::<PyResult<_>>()?;
            if parts.is_empty() {
                Keyword::Unset
            } else {
                Keyword::Value(parts.join(","))
            }
        } else {
            Keyword::Value(scalar(&v)?)
        };
        out.push((key, value));
    }
    Ok(out)
}

/// `(keyword, default)` of every option of `pomc build` (`"build"`), `pomc mesh` (`"mesh"`) or the
/// camera of `pomc render` (`"render"`), the
/// default as the command line shows it (`None`: none).
#[pyfunction]
fn option_defaults(job: &str) -> PyResult<Vec<(String, Option<String>)>> {
    match job {
        "build" => Ok(options::keyword_defaults::<BuildArgs>()),
        "mesh" => Ok(options::keyword_defaults::<MeshArgs>()),
        "render" => Ok(options::keyword_defaults::<CameraArgs>()),
        "scene" => Ok(options::keyword_defaults::<SceneArgs>()),
        other => Err(usage(format!("no options of `{other}`: build, mesh, render or scene"))),
    }
}

#[pymodule]
fn _pomc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("PomcError", m.py().get_type::<PomcError>())?;
    m.add_class::<PyPanorama>()?;
    m.add_function(wrap_pyfunction!(open, m)?)?;
    m.add_function(wrap_pyfunction!(save_colour, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(build_files, m)?)?;
    m.add_function(wrap_pyfunction!(prepare_files, m)?)?;
    m.add_function(wrap_pyfunction!(scene_files, m)?)?;
    m.add_function(wrap_pyfunction!(repack_files, m)?)?;
    m.add_function(wrap_pyfunction!(render_files, m)?)?;
    m.add_function(wrap_pyfunction!(option_defaults, m)?)?;
    Ok(())
}
