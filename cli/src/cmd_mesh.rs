//! `pomc mesh PANO [--layer K] -o OUT.{ply,obj,glb}`: adaptive quadtree meshes of every layer (one
//! scene, the sky on a dome) or of layer K, their 3D error against the layers, encoded sizes, and
//! per-stage times.

use std::path::PathBuf;

use pomc::jobs::{self, MeshSettings};
use pomc::mesh::scene::SceneSettings;
use pomc_flags::MeshArgs;

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
    let settings = MeshSettings {
        scene: SceneSettings {
            mesh: args.mesh.params(),
            only: args.layer,
            sky_radius: args.mesh.sky_radius,
            store: args.store,
            metric: !args.no_metric,
        },
        output: args.output,
        local: args.local,
    };
    let spin = out.spinner("reading");
    let report = jobs::mesh_files(&args.pano, &settings, &|stage| spin.set_message(stage.to_string()))?;
    spin.finish_and_clear();
    out.json(&serde_json::to_value(&report).expect("report serialises"));
    for line in report.summary() {
        out.say(line);
    }
    Ok(0)
}
