//! `pomc scene`: a layered POMC from a 3D scene by tracing every hit (thesis 6.3.2).

use std::path::PathBuf;

use pomc::jobs;
use pomc_flags::SceneArgs;

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The scene: glTF 2.0 (.gltf, .glb) or Wavefront OBJ (.obj, with its .mtl), +Y up.
    scene: PathBuf,
    /// Output panorama directory.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    options: SceneArgs,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let settings = args.options.settings();
    let bar = out.progress(jobs::scene_stages().len() as u64, "reading");
    let progress = |stage: &str| {
        bar.set_message(stage.to_string());
        bar.inc(1);
    };
    let made = jobs::scene_panorama(&args.scene, &args.output, &settings, &progress)?;
    bar.finish_and_clear();
    let r = &made.report;
    out.json(&serde_json::to_value(&made).expect("report serialises"));
    for (l, occupancy) in r.layers.iter().zip(&r.occupancy) {
        let depth = match l.depth_range {
            Some((lo, hi)) => format!("depth {lo:.3}–{hi:.3} m"),
            None => "at infinity".to_string(),
        };
        out.say(format!(
            "{:>14} {:>10} order {}: {} px seen, {} px behind, {:.1} % of the canvas, {depth}",
            l.name,
            l.role,
            l.order,
            l.own_pixels,
            l.filled_pixels,
            100.0 * occupancy
        ));
    }
    out.say(format!(
        "traced {} triangles: {} hits, {} seen from within {} m, {} pieces -> {} layer(s) in {:.2} s -> {}",
        r.triangles,
        r.hits,
        r.kept_hits,
        r.freedom_radius,
        r.pieces,
        made.manifest.layers.len(),
        made.total_s,
        args.output.display()
    ));
    Ok(0)
}
