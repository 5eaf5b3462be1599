//! `pomc`: the command line of the POMC toolkit. A thin layer over the `pomc` library: parse
//! arguments, call the library, print human or JSON output, map errors to exit codes.
//!
//! Exit codes: 0 success, 1 the input is invalid (`validate`), 2 usage, I/O or processing error.

mod args;
mod cmd_build;
mod cmd_convert;
mod cmd_info;
mod cmd_mesh;
mod cmd_pack;
mod cmd_render;
mod cmd_validate;
mod output;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use output::Output;

#[derive(Parser, Debug)]
#[command(
    name = "pomc",
    version,
    about = "Layered omnidirectional RGB-D panoramas (POMC): build, validate, inspect, convert, pack, mesh, render"
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
    /// Describe a panorama, a layer file or an image.
    Info(cmd_info::Args),
    /// Convert images or layers between equirect and 3×2 cube-map mappings.
    Convert(cmd_convert::Args),
    /// Build a layered POMC from a plain RGB-D panorama (colour + depth).
    Build(cmd_build::Args),
    /// Patch-pack the sparse layers of a panorama (atlas + patch table).
    Pack(cmd_pack::PackArgs),
    /// Restore full canvases of packed layers.
    Unpack(cmd_pack::UnpackArgs),
    /// Adaptive quadtree meshes of the layers: error, encoded size, PLY/OBJ/glTF scene export.
    Mesh(cmd_mesh::Args),
    /// Render views from cameras near the panorama centre (point splatting or mesh rasterisation).
    Render(cmd_render::Args),
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
        Failure { code: "CLI_USAGE", message, exit: 2 }
    }
}

impl From<pomc::Error> for Failure {
    fn from(e: pomc::Error) -> Self {
        Failure { code: e.code(), message: e.to_string(), exit: 2 }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let out = Output { json: cli.json, quiet: cli.quiet };
    let result = match cli.command {
        Command::Validate(a) => cmd_validate::run(a, out),
        Command::Info(a) => cmd_info::run(a, out),
        Command::Convert(a) => cmd_convert::run(a, out),
        Command::Build(a) => cmd_build::run(a, out),
        Command::Pack(a) => cmd_pack::run_pack(a, out),
        Command::Unpack(a) => cmd_pack::run_unpack(a, out),
        Command::Mesh(a) => cmd_mesh::run(a, out),
        Command::Render(a) => cmd_render::run(a, out),
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
