//! Shared output plumbing for the subcommands: progress bars (hidden with `--quiet`, `--json` or when
//! stderr is not a terminal) and JSON printing.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed_precise}")
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
            println!("{}", line.as_ref());
        }
    }

    /// Print a JSON value (pretty) to stdout when `--json` is set.
    pub fn json(&self, value: &serde_json::Value) {
        if self.json {
            println!("{}", serde_json::to_string_pretty(value).expect("JSON values always serialise"));
        }
    }
}
