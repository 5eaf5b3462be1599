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
mod output;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

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

/// A failed command: what to print and the exit code.
pub struct Failure {
    pub code: &'static str,
    pub message: String,
    pub exit: u8,
}

impl Failure {
    /// An argument the command cannot use (a camera path, an output name), code `CLI_USAGE`.
    pub fn usage(message: String) -> Failure {
        Failure { code: pomc::codes::CLI_USAGE, message, exit: 2 }
    }
}

impl From<pomc::Error> for Failure {
    fn from(e: pomc::Error) -> Self {
        Failure { code: e.code(), message: e.to_string(), exit: 2 }
    }
}

/// A command line clap refuses (an unknown option, a value outside its range): clap's message, exit
/// status 2, and with `--json` the error object with code `CLI_USAGE` on stdout like every failure.
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        e.exit();
    }
    if std::env::args_os().any(|a| a == "--json") {
        let message = e.render().to_string();
        let first = message.lines().next().unwrap_or("").trim_start_matches("error: ").to_string();
        println!("{}", serde_json::json!({"error": {"code": pomc::codes::CLI_USAGE, "message": first}}));
    }
    let _ = e.print();
    ExitCode::from(2)
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
