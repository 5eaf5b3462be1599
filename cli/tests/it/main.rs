//! The command line's integration tests, one binary: each module runs the built `pomc` like a user.

mod cli;
mod cli_mesh;
mod render_cli;

use std::process::{Command, Output};

/// Run the `pomc` binary of this build with `args`.
fn pomc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pomc")).args(args).output().expect("pomc runs")
}
