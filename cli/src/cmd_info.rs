//! `pomc info PATH [--json]`: describe a panorama, one layer file, or a plain image.

use std::path::PathBuf;

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory, panorama.xml, a layer EXR, or an image.
    path: PathBuf,
    /// Also decode the layers to report depth ranges and domain sizes (slower).
    #[arg(long)]
    stats: bool,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let report = pomc::jobs::describe(&args.path, args.stats)?;
    out.json(&serde_json::to_value(&report).expect("report serialises"));
    for line in report.summary() {
        out.say(line);
    }
    Ok(0)
}
