//! `pomc prepare`: the depth `pomc build` layers, written out to inspect (spec §7.1).

use std::path::PathBuf;

use pomc::jobs;

use crate::cmd_build::InputArgs;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output depth: float OpenEXR (channel Z, metres along the ray, +inf infinitely far) on the
    /// colour's grid.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    let mut settings = jobs::BuildSettings::default();
    args.input.options.apply(&mut settings);
    let spinner = out.spinner("preparing depth");
    let prepared = jobs::prepare_to_file(&args.input.colour, &args.input.depth, &args.output, &settings)?;
    spinner.finish_and_clear();
    for w in &prepared.report.warnings {
        out.warn(w.code, &w.message);
    }
    out.json(&serde_json::to_value(&prepared).expect("report serialises"));
    out.say(prepared.summary());
    Ok(0)
}
