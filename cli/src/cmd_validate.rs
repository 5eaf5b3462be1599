//! `pomc validate PATH [--json]`.

use std::path::PathBuf;

use pomc::jobs::ValidateSettings;

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or its panorama.xml.
    #[arg(required_unless_present = "list_codes")]
    path: Option<PathBuf>,
    /// Relative depth jump inside a layer reported as a discontinuity (0.5 = 50 %).
    #[arg(long, default_value_t = pomc::validate::ValidateSettings::default().jump_threshold, value_parser = Range::POSITIVE.parser())]
    jump_threshold: f64,
    /// List every validation code with its severity and meaning, then exit.
    #[arg(long)]
    list_codes: bool,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    if args.list_codes {
        crate::cmd_codes::print(&pomc::codes::findings(), out);
        return Ok(0);
    }
    let options = ValidateSettings { jump_threshold: args.jump_threshold, ..Default::default() };
    let path = args.path.unwrap_or_default();
    let report = pomc::jobs::validate(&path, &options)?;
    out.json(&serde_json::to_value(&report).expect("report serialises"));
    if !out.json && !out.quiet {
        report.summary(&path).iter().for_each(crate::output::line);
    }
    Ok(if report.valid { 0 } else { 1 })
}
