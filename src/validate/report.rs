//! The validation report: the JSON shape printed by `pomc validate --json`.

use serde::Serialize;

pub use crate::codes::Severity;

/// One finding. `location` is either `file:line:col /Element/Path` for the manifest or
/// `file layer[k] channel (x,y)` for pixels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Issue {
    /// Stable code, e.g. `LAYER_NOT_FOUND` (see [`crate::codes::findings`]).
    pub code: &'static str,
    /// Error, warning or info.
    pub severity: Severity,
    /// Human-readable explanation, usually with the fix.
    pub message: String,
    /// Where the finding is, in one of the two forms above.
    pub location: String,
}

/// All findings for one panorama.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    /// `true` when there is no error (warnings and infos allowed).
    pub valid: bool,
    /// Number of issues of severity error.
    pub errors: usize,
    /// Number of issues of severity warning.
    pub warnings: usize,
    /// Every finding, errors first, then warnings, then infos, each in order of appearance.
    pub issues: Vec<Issue>,
}

impl Report {
    /// Build a report from issues, sorted by severity then appearance, with counts.
    pub fn from_issues(mut issues: Vec<Issue>) -> Self {
        issues.sort_by_key(|i| i.severity);
        let errors = issues.iter().filter(|i| i.severity == Severity::Error).count();
        let warnings = issues.iter().filter(|i| i.severity == Severity::Warning).count();
        Report { valid: errors == 0, errors, warnings, issues }
    }

    /// Does the report contain this code?
    pub fn has(&self, code: &str) -> bool {
        self.issues.iter().any(|i| i.code == code)
    }
}
