//! `pomc codes [--markdown] [--json]`.

use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print the table as Markdown (the text of spec/10-codes.md).
    #[arg(long)]
    markdown: bool,
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    if args.markdown {
        crate::output::line(pomc::codes::markdown().trim_end());
        return Ok(0);
    }
    print(&pomc::codes::all(), out);
    Ok(0)
}

/// One line per code (code, severity, meaning), or a JSON array with `--json`.
pub fn print(codes: &[(&str, pomc::codes::Severity, &str)], out: Output) {
    if out.json {
        let rows: Vec<_> = codes
            .iter()
            .map(|(c, s, d)| serde_json::json!({"code": c, "severity": s.as_str(), "description": d}))
            .collect();
        out.json(&serde_json::Value::Array(rows));
    } else {
        for (c, s, d) in codes {
            crate::output::line(format!("{c:32} {:8} {d}", s.as_str()));
        }
    }
}
