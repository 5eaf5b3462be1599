//! A failed command: its code, message and exit status, and clap's refusals printed the same way.

use std::process::ExitCode;

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
pub fn usage_error(e: clap::Error) -> ExitCode {
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
