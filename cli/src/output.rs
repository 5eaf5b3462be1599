//! Shared output plumbing for the subcommands: progress bars (hidden with `--quiet`, `--json` or when
//! stderr is not a terminal) and JSON printing.

use std::io::Write;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Write a line to stdout. A closed pipe (`pomc validate --list-codes | head`) ends the process
/// quietly with success, as for other Unix tools, instead of panicking like `println!`.
pub fn line(text: impl AsRef<str>) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = writeln!(out, "{}", text.as_ref()).and_then(|_| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error[IO_ERROR]: cannot write to standard output: {e}");
        std::process::exit(2);
    }
}

/// Global output options shared by every subcommand.
#[derive(Clone, Copy, Debug)]
pub struct Output {
    pub json: bool,
    pub quiet: bool,
}

impl Output {
    /// A progress bar over `len` steps, drawn on stderr unless output is quiet or machine-readable.
    pub fn progress(&self, len: u64, what: &str) -> ProgressBar {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        if self.quiet || self.json {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed_precise}, ETA {eta}")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
        bar
    }

    /// A spinner for work of unknown length; its message names the current stage.
    pub fn spinner(&self, what: &str) -> ProgressBar {
        let bar = ProgressBar::new_spinner();
        if self.quiet || self.json {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        } else {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.enable_steady_tick(std::time::Duration::from_millis(120));
        }
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} {elapsed_precise}").expect("static template"),
        );
        bar.set_message(what.to_string());
        bar
    }

    /// Print a human line to stdout unless quiet or JSON.
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.quiet && !self.json {
            self::line(line);
        }
    }

    /// Print a warning to stderr (`warning[CODE]: message`) unless quiet; with `--json` it is in
    /// the report instead.
    pub fn warn(&self, code: &str, message: &str) {
        if !self.quiet && !self.json {
            eprintln!("warning[{code}]: {message}");
        }
    }

    /// Print a JSON value (pretty) to stdout when `--json` is set.
    pub fn json(&self, value: &serde_json::Value) {
        if self.json {
            line(serde_json::to_string_pretty(value).expect("JSON values always serialise"));
        }
    }
}
