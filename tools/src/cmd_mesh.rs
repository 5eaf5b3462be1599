//! `pomc mesh PANO [--layer K] -o OUT.{ply,obj,glb}`: adaptive quadtree meshes of every layer (one
//! scene, the sky on a dome) or of layer K, their 3D error against the layers, encoded sizes, and
//! per-stage times.

use std::path::PathBuf;
use std::time::Instant;

use pomc::mesh::scene::{self, SceneMesh, SceneSettings};
use pomc::mesh::{self, export};
use pomc::panorama::Panorama;

use crate::output::Output;
use crate::Failure;
use pomc::options::MeshArgs;

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
    #[command(flatten)]
    mesh: MeshArgs,
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
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let settings = SceneSettings {
        mesh: args.mesh.params(),
        only: args.layer,
        sky_radius: args.mesh.sky_radius,
        store: args.store,
        metric: !args.no_metric,
    };
    let spin = out.spinner("reading and meshing layers");
    let pano = Panorama::open(&args.pano)?;
    let scene = scene::mesh_panorama(&pano, &settings)?;
    let layers = &scene.layers;
    let mut export_ms = 0.0;
    let mut exported = export::Exported::default();
    if let Some(path) = &args.output {
        spin.set_message("exporting");
        let t = Instant::now();
        let transform = (!args.local).then(|| pano.manifest.local_to_world());
        exported = scene::export_scene(path, layers, transform)?;
        export_ms = t.elapsed().as_secs_f64() * 1e3;
    }
    if args.store {
        scene::store(&pano, layers)?;
    }
    spin.finish_and_clear();
    let sky = Some(scene.sky_radius).filter(|_| scene.has_sky());
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
    let sum = |f: &dyn Fn(&SceneMesh) -> f64| layers.iter().map(f).sum::<f64>();
    let read_ms = sum(&|l| l.read_ms);
    let mesh_ms = sum(&|l| l.meshed.times.total_ms());
    let metric_ms = sum(&|l| l.metric_ms.unwrap_or(0.0));
    out.json(&serde_json::json!({
        "layers": reports,
        "triangles": tris, "vertices": verts,
        "exported_vertices": args.output.as_ref().map(|_| exported.vertices.iter().sum::<usize>()),
        "skipped": skipped,
        "sky_radius": sky,
        "times_ms": {
            "read": read_ms, "mesh": mesh_ms, "encode": sum(&|l| l.encode_ms), "metric": metric_ms,
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

fn report(args: &Args, out: Output, l: &SceneMesh, sky: Option<f64>) -> serde_json::Value {
    let meshed = &l.meshed;
    let stats = l.error.as_ref().zip(l.metric_ms);
    let (read_ms, encode_ms) = (l.read_ms, l.encode_ms);
    let is_sky = l.sky_radius.is_some();
    let encoded = l.encoded.as_ref().map(Vec::len);
    let m = &meshed.mesh;
    let tris = m.triangles.len();
    // The encoding stores the quadtree, so its density is per quadtree triangle (thesis 7.4.4); that
    // count is known when the whole layer was meshed by the quadtree.
    let greedy_faces = meshed.greedy.iter().filter(|g| g.is_some()).count();
    let qt = meshed.quadtree_triangles;
    let per_million = encoded.filter(|_| qt > 0 && greedy_faces == 0).map(|e| e as f64 * 1e6 / qt as f64);
    let t = &meshed.times;
    let mut times_json =
        serde_json::json!({"read": read_ms, "encode": encode_ms, "metric": stats.as_ref().map(|s| s.1)});
    for (stage, ms) in t.named() {
        times_json[stage] = serde_json::json!(ms);
    }
    let json = serde_json::json!({
        "layer": l.index, "name": l.name, "role": l.role,
        "sky_radius": sky.filter(|_| is_sky),
        "width": m.width, "height": m.height,
        "triangles": tris, "vertices": m.positions.len(),
        "quadtree_triangles": (greedy_faces == 0).then_some(qt),
        "before_collapses_triangles": qt,
        "greedy_faces": greedy_faces, "greedy": meshed.greedy,
        "simplify": meshed.simplify,
        "encoded_bytes": encoded, "encoded_bytes_per_million_triangles": per_million,
        "error": stats.as_ref().map(|s| &s.0),
        "times_ms": times_json,
        "output": args.output,
    });
    out.say(format!(
        "layer {} {} ({}x{}{}): {} triangles, {} vertices{}",
        l.index,
        l.name,
        m.width,
        m.height,
        sky.filter(|_| is_sky).map_or(String::new(), |r| format!(", sky dome at {r:.2} m")),
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
        (None, _) if is_sky => {
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
    let stages: Vec<String> = t.named().iter().map(|(stage, ms)| format!("{stage} {ms:.0}")).collect();
    out.say(format!(
        "times (ms): read {read_ms:.0}, {}, encode {encode_ms:.0}, metric {}",
        stages.join(", "),
        stats.as_ref().map_or("-".to_string(), |s| format!("{:.0}", s.1))
    ));
    json
}
