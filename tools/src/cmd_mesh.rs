//! `pomc mesh PANO [--layer K] -o OUT.{ply,obj,glb}`: adaptive quadtree mesh of one layer, its 3D
//! error against the layer, its encoded size, and per-stage times.

use std::path::PathBuf;
use std::time::Instant;

use pomc::layer_io::ReadLimits;
use pomc::mapping::{AnyMapping, MappingKind};
use pomc::mesh::{self, encode, error, export, MeshParams};
use pomc::panorama::Panorama;

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or panorama.xml.
    pano: PathBuf,
    /// Layer index (manifest order).
    #[arg(long, default_value_t = 0)]
    layer: usize,
    /// Output mesh: .ply (binary), .obj or .glb (glTF 2.0 binary with the colour as a PNG texture).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Maximum relative distance along each pixel's ray between mesh and depth (0 disables).
    #[arg(long, default_value_t = 0.005)]
    max_error: f64,
    /// Thesis normal test: split where neighbouring normals differ by more than DEG degrees.
    #[arg(long, value_name = "DEG")]
    feature_angle: Option<f64>,
    /// Thesis residual threshold (mean sub-feature normal variation of a node).
    #[arg(long, default_value_t = 0.05)]
    residual: f64,
    /// Weighting of normals estimated from depth when the layer has no N.* channels: area or angle.
    #[arg(long, default_value = "area", value_parser = ["area", "angle"])]
    normal_weighting: String,
    /// Cap on a node's angular extent, degrees (texture distortion; 0 disables).
    #[arg(long, default_value_t = 20.0, value_name = "DEG")]
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
    /// Store the encoded mesh next to the layer and reference it from the manifest (`<Mesh file=…/>`).
    /// The stored encoding is always the quadtree's (spec §8), simplified or not.
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
    MeshParams {
        max_error: (a.max_error > 0.0).then_some(a.max_error),
        feature_angle_deg: a.feature_angle,
        residual_threshold: a.residual,
        normal_weighting: if a.normal_weighting == "angle" {
            mesh::normals::NormalWeighting::Angle
        } else {
            mesh::normals::NormalWeighting::Area
        },
        max_angle_deg: (a.max_angle > 0.0).then_some(a.max_angle),
        uniform: a.uniform,
        simplify: (!a.no_simplify && a.uniform.is_none() && a.max_error > 0.0).then(|| {
            mesh::simplify::SimplifyParams {
                max_error: a.max_error,
                max_angle_deg: (a.max_angle > 0.0).then_some(a.max_angle),
                greedy: !a.no_greedy,
            }
        }),
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let params = params(&args);
    let spin = out.spinner("reading layer");
    let t = Instant::now();
    let pano = Panorama::open(&args.pano)?;
    let image = pano.read_layer(args.layer, &ReadLimits::default())?;
    let kind = match pano.manifest.mapping.kind {
        pomc::manifest::MappingKind::LatLong => MappingKind::Equirect,
        pomc::manifest::MappingKind::Cube => MappingKind::Cube3x2,
    };
    let mapping = AnyMapping::new(kind, image.width, image.height)
        .map_err(|e| fail("MESH_CANVAS_MISMATCH", e.to_string()))?;
    let read_ms = ms(t);
    spin.set_message("meshing");
    let meshed = mesh::mesh_layer(&image, &mapping, &params)?;
    spin.set_message("encoding");
    let t = Instant::now();
    // The encoding stores the quadtrees; lattices meshed by greedy insertion have none yet, so they
    // are built only when the encoding is to be stored.
    let greedy = meshed.greedy.iter().any(Option::is_some);
    let encoded = if !greedy {
        Some(encode::encode(&meshed.trees, &mapping)?)
    } else if args.store {
        Some(encode::encode(&mesh::quadtrees(&image, &mapping, &params)?, &mapping)?)
    } else {
        None
    };
    let encode_ms = ms(t);
    let m = &meshed.mesh;
    let stats = if args.no_metric {
        None
    } else {
        spin.set_message("measuring 3D error");
        let t = Instant::now();
        Some((error::measure(&m.positions, &m.triangles, &image, &mapping), ms(t)))
    };
    let mut export_ms = 0.0;
    if let Some(path) = &args.output {
        spin.set_message("exporting");
        let t = Instant::now();
        let format = export::Format::from_path(path)?;
        let transform = (!args.local).then(|| pano.manifest.local_to_world());
        let bytes = export::to_bytes(m, &image, transform, format)?;
        pomc::fsutil::write_bytes_atomic(path, &bytes)?;
        export_ms = ms(t);
    }
    if let (true, Some(bytes)) = (args.store, &encoded) {
        store(&pano, args.layer, bytes)?;
    }
    spin.finish_and_clear();
    report(&args, out, &meshed, encoded.map(|e| e.len()), stats, [read_ms, encode_ms, export_ms]);
    Ok(0)
}

/// Write `NAME.pomcmesh` beside the manifest and reference it from the layer (replacing an older one).
fn store(pano: &Panorama, layer: usize, bytes: &[u8]) -> Result<(), Failure> {
    let mut manifest = pano.manifest.clone();
    let decl = manifest
        .layers
        .get_mut(layer)
        .ok_or_else(|| fail("MESH_NO_SUCH_LAYER", format!("no layer {layer}")))?;
    let stem: String = decl
        .name
        .clone()
        .unwrap_or_else(|| format!("layer{layer}"))
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .collect();
    let file = format!("{stem}.{}", encode::EXTENSION);
    pomc::fsutil::write_bytes_atomic(&pano.dir.join(&file), bytes)?;
    decl.extra.retain(|e| !e.trim_start().starts_with("<Mesh"));
    decl.extra.push(format!("<Mesh file=\"{file}\" encoding=\"quadtree-bfs-zstd\" version=\"1\"/>"));
    pomc::fsutil::write_bytes_atomic(&pano.manifest_path, manifest.to_xml().as_bytes())?;
    Ok(())
}

fn report(
    args: &Args,
    out: Output,
    meshed: &mesh::Meshed,
    encoded: Option<usize>,
    stats: Option<(error::ErrorStats, f64)>,
    [read_ms, encode_ms, export_ms]: [f64; 3],
) {
    let m = &meshed.mesh;
    let tris = m.triangles.len();
    // The encoding stores the quadtree, so its density is per quadtree triangle (thesis 7.4.4); that
    // count is known when the whole layer was meshed by the quadtree.
    let greedy_faces = meshed.greedy.iter().filter(|g| g.is_some()).count();
    let qt = meshed.quadtree_triangles;
    let per_million = encoded.filter(|_| qt > 0 && greedy_faces == 0).map(|e| e as f64 * 1e6 / qt as f64);
    let t = &meshed.times;
    out.json(&serde_json::json!({
        "layer": args.layer,
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
            "encode": encode_ms, "metric": stats.as_ref().map(|s| s.1), "export": export_ms,
        },
        "output": args.output,
    }));
    out.say(format!(
        "layer {} ({}x{}): {} triangles, {} vertices{}",
        args.layer,
        m.width,
        m.height,
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
        "times (ms): read {read_ms:.0}, sample {:.0}, greedy {:.0}, quadtree {:.0}, triangulate {:.0}, assemble {:.0}, simplify {:.0}, encode {encode_ms:.0}, metric {}, export {export_ms:.0}",
        t.sample_ms,
        t.greedy_ms,
        t.quadtree_ms,
        t.triangulate_ms,
        t.assemble_ms,
        t.simplify_ms,
        stats.as_ref().map_or("-".to_string(), |s| format!("{:.0}", s.1))
    ));
}
