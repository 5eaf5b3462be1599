//! `pomc mesh PANO [--layer K] -o OUT.{ply,obj,glb}`: adaptive quadtree meshes of every layer (one
//! scene, the sky on a dome) or of layer K, their 3D error against the layers, encoded sizes, and
//! per-stage times.

use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;

use pomc::layer::LayerImage;
use pomc::layer_io::ReadLimits;
use pomc::mapping::AnyMapping;
use pomc::mesh::{self, accuracy, encode, export, MeshParams};
use pomc::panorama::Panorama;

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or panorama.xml.
    pano: PathBuf,
    /// Mesh only this layer (manifest index); by default every layer, exported as one scene in
    /// painter's order.
    #[arg(long, value_name = "K")]
    layer: Option<usize>,
    /// Output mesh: .ply (binary, vertex colours), .obj (+ .mtl + PNG textures beside it) or .glb
    /// (glTF 2.0 binary, sRGB PNG textures embedded); one node/object per layer, named after it.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Radius (m, panorama-local) of the sky dome the infinitely far samples (the infinity layer) are
    /// meshed on; default 10 × the panorama's farthest finite depth (1000 m when it has none).
    #[arg(long, value_name = "R", value_parser = Range::POSITIVE.parser())]
    sky_radius: Option<f64>,
    /// Maximum relative distance along each pixel's ray between mesh and depth (0 disables).
    #[arg(long, default_value_t = mesh::DEFAULT_MAX_ERROR, value_parser = Range::NON_NEGATIVE.parser())]
    max_error: f64,
    /// Thesis normal test: split where neighbouring normals differ by more than DEG degrees.
    #[arg(long, value_name = "DEG", value_parser = Range::OPEN_ANGLE.parser())]
    feature_angle: Option<f64>,
    /// Thesis residual threshold (mean sub-feature normal variation of a node).
    #[arg(long, default_value_t = mesh::DEFAULT_RESIDUAL, value_parser = Range::POSITIVE.parser())]
    residual: f64,
    /// Weighting of normals estimated from depth when the layer has no N.* channels: area or angle.
    #[arg(long, default_value = "area", value_parser = ["area", "angle"])]
    normal_weighting: String,
    /// Cap on a node's angular extent, degrees (texture distortion; 0 disables).
    #[arg(long, default_value_t = mesh::DEFAULT_MAX_ANGLE_DEG, value_name = "DEG", value_parser = Range::ANGLE_OR_OFF.parser())]
    max_angle: f64,
    /// Uniform 4-8 baseline with leaves of at most STEP cells a side (overrides the other tests).
    #[arg(long, value_name = "STEP")]
    uniform: Option<u32>,
    /// Keep panorama-local coordinates (default: LocalToWorld applied).
    #[arg(long)]
    local: bool,
    /// Skip the 3D error measurement (it ray-casts every pixel).
    #[arg(long)]
    no_metric: bool,
    /// Store each meshed layer's encoding beside the manifest and reference it from the layer
    /// (`<Mesh file=…/>`). The stored encoding is always the quadtree's of the layer itself (spec §8),
    /// simplified or not, without the sky dome.
    #[arg(long)]
    store: bool,
    /// Output the raw quadtree mesh: skip the error-bounded edge-collapse stage (which runs by default
    /// with the same --max-error and --max-angle, unless --uniform or --max-error 0).
    #[arg(long)]
    no_simplify: bool,
    /// Simplify clean cube faces with quadtree + collapses too, instead of greedy insertion (which is
    /// faster and gives fewer triangles; faces with a domain border or a depth jump always take the
    /// quadtree).
    #[arg(long)]
    no_greedy: bool,
}

fn fail(code: &'static str, message: String) -> Failure {
    Failure { code, message, exit: 2 }
}

impl From<mesh::MeshError> for Failure {
    fn from(e: mesh::MeshError) -> Self {
        pomc::Error::from(e).into()
    }
}

fn params(a: &Args) -> MeshParams {
    mesh::MeshSettings {
        max_error: a.max_error,
        feature_angle: a.feature_angle,
        residual: a.residual,
        normal_weighting: if a.normal_weighting == "angle" {
            mesh::normals::NormalWeighting::Angle
        } else {
            mesh::normals::NormalWeighting::Area
        },
        max_angle: a.max_angle,
        uniform: a.uniform,
        simplify: !a.no_simplify,
        greedy: !a.no_greedy,
    }
    .params()
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// One meshed layer.
struct Layer {
    index: usize,
    name: String,
    role: Option<&'static str>,
    /// The meshed pixels: the layer, or its sky-dome version.
    image: LayerImage,
    sky: bool,
    meshed: mesh::Meshed,
    encoded: Option<Vec<u8>>,
    stats: Option<(accuracy::ErrorStats, f64)>,
    /// Read and encode times (ms).
    times: [f64; 2],
}

fn mapping_of(pano: &Panorama, image: &LayerImage) -> Result<AnyMapping, Failure> {
    let kind = pano.manifest.mapping.kind;
    AnyMapping::new(kind, image.width, image.height)
        .map_err(|e| fail(pomc::codes::MESH_CANVAS_MISMATCH, e.to_string()))
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let params = params(&args);
    params.check()?;
    let spin = out.spinner("reading layers");
    let pano = Panorama::open(&args.pano)?;
    let limits = ReadLimits::default();
    let order = match args.layer {
        Some(k) => vec![k],
        None => pano.manifest.painter_order(),
    };
    // Layers are read and meshed in parallel: one layer's stages do not keep both cores busy.
    let images = order
        .par_iter()
        .map(|&k| {
            let t = Instant::now();
            Ok((pano.read_layer(k, &limits)?, ms(t)))
        })
        .collect::<Result<Vec<_>, Failure>>()?;
    // The default radius depends on every layer's depths, also when one layer is meshed.
    let sky_radius = match args.sky_radius {
        Some(r) => r,
        None if args.layer.is_some() && images.iter().any(|(im, _)| mesh::has_sky(im)) => {
            let others = (0..pano.manifest.layers.len()).filter(|k| !order.contains(k));
            let others = others.map(|k| pano.read_layer(k, &limits)).collect::<Result<Vec<_>, _>>()?;
            mesh::default_sky_radius(images.iter().map(|i| &i.0).chain(&others))
        }
        None => mesh::default_sky_radius(images.iter().map(|i| &i.0)),
    };
    spin.set_message(format!("meshing {} layer(s)", order.len()));
    let layers = order
        .par_iter()
        .zip(images)
        .map(|(&k, (image, read_ms))| {
            let decl = &pano.manifest.layers[k];
            let mut l = mesh_one(&args, &params, &pano, image, sky_radius)?;
            l.name = pano.manifest.layer_name(k);
            (l.index, l.role, l.times[0]) = (k, decl.role.map(|r| r.as_str()), read_ms);
            Ok(l)
        })
        .collect::<Result<Vec<_>, Failure>>()?;
    let mut export_ms = 0.0;
    let mut exported = export::Exported::default();
    if let Some(path) = &args.output {
        spin.set_message("exporting");
        let t = Instant::now();
        let scene: Vec<export::SceneLayer> = layers
            .iter()
            .map(|l| export::SceneLayer {
                name: l.name.clone(),
                index: l.index,
                mesh: &l.meshed.mesh,
                image: &l.image,
                sky_radius: l.sky.then_some(sky_radius),
            })
            .collect();
        let transform = (!args.local).then(|| pano.manifest.local_to_world());
        exported = export::export_scene(path, &scene, transform)?;
        export_ms = ms(t);
    }
    if args.store {
        let encoded: Vec<(usize, &[u8])> =
            layers.iter().filter_map(|l| Some((l.index, l.encoded.as_deref()?))).collect();
        pomc::mesh::stored::store(&pano, &encoded)?;
    }
    spin.finish_and_clear();
    let sky = Some(sky_radius).filter(|_| layers.iter().any(|l| l.sky));
    let mut reports: Vec<serde_json::Value> = layers.iter().map(|l| report(&args, out, l, sky)).collect();
    for (r, v) in reports.iter_mut().zip(&exported.vertices) {
        r["exported_vertices"] = serde_json::json!(v);
    }
    let files = &exported.files;
    let skipped: Vec<&str> =
        layers.iter().filter(|l| l.meshed.mesh.triangles.is_empty()).map(|l| l.name.as_str()).collect();
    if args.output.is_some() && !skipped.is_empty() {
        out.say(format!("note: left out of the scene (no triangles): {}", skipped.join(", ")));
    }
    if args.layer.is_some() {
        let mut v = reports.swap_remove(0);
        v["times_ms"]["export"] = serde_json::json!(export_ms);
        v["files"] = serde_json::json!(files);
        out.json(&v);
        out.say(format!("times (ms): export {export_ms:.0}"));
        return Ok(0);
    }
    let count =
        |f: &dyn Fn(&mesh::LayerMesh) -> usize| layers.iter().map(|l| f(&l.meshed.mesh)).sum::<usize>();
    let (tris, verts) = (count(&|m| m.triangles.len()), count(&|m| m.positions.len()));
    let sum = |f: &dyn Fn(&Layer) -> f64| layers.iter().map(f).sum::<f64>();
    let read_ms = sum(&|l| l.times[0]);
    let mesh_ms = sum(&|l| {
        let t = &l.meshed.times;
        t.sample_ms + t.greedy_ms + t.quadtree_ms + t.triangulate_ms + t.assemble_ms + t.simplify_ms
    });
    let metric_ms = sum(&|l| l.stats.as_ref().map_or(0.0, |s| s.1));
    out.json(&serde_json::json!({
        "layers": reports,
        "triangles": tris, "vertices": verts,
        "exported_vertices": args.output.as_ref().map(|_| exported.vertices.iter().sum::<usize>()),
        "skipped": skipped,
        "sky_radius": sky,
        "times_ms": {
            "read": read_ms, "mesh": mesh_ms, "encode": sum(&|l| l.times[1]), "metric": metric_ms,
            "export": export_ms,
        },
        "output": args.output, "files": files,
    }));
    out.say(format!(
        "scene: {} layers, {tris} triangles, {verts} vertices{}; times (ms): read {read_ms:.0}, mesh {mesh_ms:.0}, metric {metric_ms:.0}, export {export_ms:.0}",
        layers.len(),
        sky.map_or(String::new(), |r| format!(", sky dome radius {r:.2} m")),
    ));
    Ok(0)
}

/// Mesh one layer (its sky on the dome of `sky_radius`), encode and measure it.
fn mesh_one(
    args: &Args,
    params: &MeshParams,
    pano: &Panorama,
    image: LayerImage,
    sky_radius: f64,
) -> Result<Layer, Failure> {
    let mapping = mapping_of(pano, &image)?;
    let (meshed, dome) = mesh::mesh_scene_layer(&image, &mapping, params, sky_radius)?;
    let t = Instant::now();
    // The encoding stores the quadtrees of the layer itself (the dome is not part of it); lattices
    // meshed by greedy insertion have none yet, so they are built only when the encoding is stored.
    let greedy = meshed.greedy.iter().any(Option::is_some);
    let encoded = if !greedy && dome.is_none() {
        Some(encode::encode(&meshed.trees, &mapping)?)
    } else if args.store {
        Some(encode::encode(&mesh::quadtrees(&image, &mapping, params)?, &mapping)?)
    } else {
        None
    };
    let encode_ms = ms(t);
    let sky = dome.is_some();
    let image = dome.unwrap_or(image);
    let m = &meshed.mesh;
    let stats = (!args.no_metric).then(|| {
        let t = Instant::now();
        (accuracy::measure(&m.positions, &m.triangles, &image, &mapping), ms(t))
    });
    Ok(Layer {
        index: 0,
        name: String::new(),
        role: None,
        image,
        sky,
        meshed,
        encoded,
        stats,
        times: [0.0, encode_ms],
    })
}

/// Print one layer's lines and return its JSON (`sky`: the dome's radius, when the scene has one).
fn report(args: &Args, out: Output, l: &Layer, sky: Option<f64>) -> serde_json::Value {
    let (meshed, stats) = (&l.meshed, &l.stats);
    let [read_ms, encode_ms] = l.times;
    let encoded = l.encoded.as_ref().map(Vec::len);
    let m = &meshed.mesh;
    let tris = m.triangles.len();
    // The encoding stores the quadtree, so its density is per quadtree triangle (thesis 7.4.4); that
    // count is known when the whole layer was meshed by the quadtree.
    let greedy_faces = meshed.greedy.iter().filter(|g| g.is_some()).count();
    let qt = meshed.quadtree_triangles;
    let per_million = encoded.filter(|_| qt > 0 && greedy_faces == 0).map(|e| e as f64 * 1e6 / qt as f64);
    let t = &meshed.times;
    let json = serde_json::json!({
        "layer": l.index, "name": l.name, "role": l.role,
        "sky_radius": sky.filter(|_| l.sky),
        "width": m.width, "height": m.height,
        "triangles": tris, "vertices": m.positions.len(),
        "quadtree_triangles": (greedy_faces == 0).then_some(qt),
        "before_collapses_triangles": qt,
        "greedy_faces": greedy_faces, "greedy": meshed.greedy,
        "simplify": meshed.simplify,
        "encoded_bytes": encoded, "encoded_bytes_per_million_triangles": per_million,
        "error": stats.as_ref().map(|s| &s.0),
        "times_ms": {
            "read": read_ms, "sample": t.sample_ms, "quadtree": t.quadtree_ms,
            "greedy": t.greedy_ms, "triangulate": t.triangulate_ms, "assemble": t.assemble_ms,
            "simplify": t.simplify_ms,
            "encode": encode_ms, "metric": stats.as_ref().map(|s| s.1),
        },
        "output": args.output,
    });
    out.say(format!(
        "layer {} {} ({}x{}{}): {} triangles, {} vertices{}",
        l.index,
        l.name,
        m.width,
        m.height,
        sky.filter(|_| l.sky).map_or(String::new(), |r| format!(", sky dome at {r:.2} m")),
        tris,
        m.positions.len(),
        match &meshed.simplify {
            Some(s) if greedy_faces > 0 => format!(
                " (greedy insertion on {greedy_faces} of {} faces; {} triangles before {} collapses)",
                meshed.greedy.len(),
                meshed.quadtree_triangles,
                s.collapses
            ),
            Some(s) => format!(
                " (simplified from {} quadtree triangles, {} collapses)",
                meshed.quadtree_triangles, s.collapses
            ),
            None => String::new(),
        }
    ));
    match (encoded, per_million) {
        (None, _) if l.sky => {
            out.say("encoded: not computed (the sky dome is no part of the layer's mesh, spec §8.9)")
        }
        (Some(e), Some(p)) => {
            out.say(format!("encoded: {e} bytes ({p:.0} bytes per million quadtree triangles)"))
        }
        (Some(e), None) => out.say(format!("encoded: {e} bytes (quadtree)")),
        (None, _) => out.say("encoded: not computed (greedy faces build no quadtree; --store encodes it)"),
    }
    if let Some((s, _)) = &stats {
        out.say(format!(
            "error over {} pixels ({} unhit): relative max {:.3e} p99 {:.3e} rms {:.3e}; absolute max {:.3e} m p99 {:.3e} m rms {:.3e} m",
            s.pixels, s.unhit, s.max_rel, s.p99_rel, s.rms_rel, s.max_abs, s.p99_abs, s.rms_abs
        ));
    }
    out.say(format!(
        "times (ms): read {read_ms:.0}, sample {:.0}, greedy {:.0}, quadtree {:.0}, triangulate {:.0}, assemble {:.0}, simplify {:.0}, encode {encode_ms:.0}, metric {}",
        t.sample_ms,
        t.greedy_ms,
        t.quadtree_ms,
        t.triangulate_ms,
        t.assemble_ms,
        t.simplify_ms,
        stats.as_ref().map_or("-".to_string(), |s| format!("{:.0}", s.1))
    ));
    json
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::parse;

    /// The library's `MeshParams::default()` is what `pomc mesh` does without options.
    #[test]
    fn default_options_are_the_library_default() {
        assert_eq!(params(&parse(&["pomc-mesh", "pano"])), MeshParams::default());
        assert_eq!(params(&parse(&["pomc-mesh", "pano", "--no-simplify"])), MeshParams::quadtree());
    }
}
