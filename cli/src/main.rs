//! `pomc`: the command line of the POMC toolkit. A thin layer over the `pomc` library: parse
//! arguments, call the library, print human or JSON output, map errors to exit codes.
//!
//! Exit codes: 0 success, 1 the input is invalid (`validate`), 2 usage, I/O or processing error.

#![forbid(unsafe_code)]

mod args;
mod cmd_build;
mod cmd_codes;
mod cmd_convert;
mod cmd_info;
mod cmd_mesh;
mod cmd_pack;
mod cmd_prepare;
mod cmd_render;
mod cmd_scene;
mod cmd_validate;
mod cmd_view;
mod failure;
mod output;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use failure::usage_error;
pub use failure::Failure;
use output::Output;

#[derive(Parser, Debug)]
#[command(
    name = "pomc",
    version,
    about = "Layered omnidirectional RGB-D panoramas (POMC): build, scene, validate, inspect, convert, pack, mesh, render, view"
)]
struct Cli {
    /// Machine-readable JSON on stdout (no progress bars).
    #[arg(long, global = true)]
    json: bool,
    /// No progress bars or human messages.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check a panorama against the POMC 1 spec (exit 0 valid, 1 invalid, 2 usage/I-O error).
    Validate(cmd_validate::Args),
    /// List every code pomc gives (validation findings and errors) with its severity and meaning.
    Codes(cmd_codes::Args),
    /// Describe a panorama, a layer file or an image.
    Info(cmd_info::Args),
    /// Convert images or layers between equirect and 3×2 cube-map mappings.
    Convert(cmd_convert::Args),
    /// Build a layered POMC from a plain RGB-D panorama (colour + depth).
    Build(cmd_build::Args),
    /// Make a layered POMC from a 3D scene (glTF, OBJ) by tracing every surface along every ray.
    Scene(cmd_scene::Args),
    /// Prepare a depth panorama as `build` does (kinds, resolution, holes, noise, soft edges) and
    /// write it as a float EXR on the colour's grid, to inspect.
    Prepare(cmd_prepare::Args),
    /// Patch-pack the sparse layers of a panorama (atlas + patch table).
    Pack(cmd_pack::PackArgs),
    /// Restore full canvases of packed layers.
    Unpack(cmd_pack::UnpackArgs),
    /// Adaptive quadtree meshes of the layers: error, encoded size, PLY/OBJ/glTF scene export.
    Mesh(cmd_mesh::Args),
    /// Render views from cameras near the panorama centre (point splatting or mesh rasterisation).
    Render(cmd_render::Args),
    /// Step inside a panorama in the browser: serve the viewer on localhost, or export it as a static site.
    View(cmd_view::Args),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    let out = Output { json: cli.json, quiet: cli.quiet };
    let result = match cli.command {
        Command::Validate(a) => cmd_validate::run(a, out),
        Command::Codes(a) => cmd_codes::run(a, out),
        Command::Info(a) => cmd_info::run(a, out),
        Command::Convert(a) => cmd_convert::run(a, out),
        Command::Build(a) => cmd_build::run(a, out),
        Command::Prepare(a) => cmd_prepare::run(a, out),
        Command::Scene(a) => cmd_scene::run(a, out),
        Command::Pack(a) => cmd_pack::run_pack(a, out),
        Command::Unpack(a) => cmd_pack::run_unpack(a, out),
        Command::Mesh(a) => cmd_mesh::run(a, out),
        Command::Render(a) => cmd_render::run(a, out),
        Command::View(a) => cmd_view::run(a, out),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(f) => {
            if out.json {
                out.json(&serde_json::json!({"error": {"code": f.code, "message": f.message}}));
            }
            eprintln!("error[{}]: {}", f.code, f.message);
            ExitCode::from(f.exit)
        }
    }
}
