//! `pomc convert`: equirect ↔ 3×2 cube conversion of images and layers. STUB.

use std::path::PathBuf;

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Input image or layer EXR.
    input: PathBuf,
}

pub fn run(_args: Args, _out: Output) -> Result<u8, Failure> {
    Err(Failure { code: "NOT_IMPLEMENTED", message: "convert is not implemented yet".into(), exit: 2 })
}
