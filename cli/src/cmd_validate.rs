//! `pomc validate PATH [--json]`.

use std::path::PathBuf;

use pomc::validate::{self, Severity, ValidateSettings};

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
        crate::cmd_codes::print(&validate::codes::all(), out);
        return Ok(0);
    }
    let options = ValidateSettings { jump_threshold: args.jump_threshold, ..Default::default() };
    let path = args.path.unwrap_or_default();
    let report = validate::validate(&path, &options)?;
    if out.json {
        out.json(&serde_json::to_value(&report).expect("report serialises"));
    } else if !out.quiet {
        for i in &report.issues {
            crate::output::line(format!(
                "{}[{}]: {}\n  --> {}",
                i.severity.as_str(),
                i.code,
                i.message,
                i.location
            ));
        }
        let infos = report.issues.iter().filter(|i| i.severity == Severity::Info).count();
        crate::output::line(format!(
            "{}: {} ({} error(s), {} warning(s), {} note(s))",
            path.display(),
            if report.valid { "valid" } else { "INVALID" },
            report.errors,
            report.warnings,
            infos
        ));
    }
    Ok(if report.valid { 0 } else { 1 })
}
