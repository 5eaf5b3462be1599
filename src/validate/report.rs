//! The validation report: the JSON shape printed by `pomc validate --json`.

use serde::Serialize;

pub use crate::codes::Severity;

/// One finding. `location` is either `file:line:col /Element/Path` for the manifest or
/// `file layer[k] channel (x,y)` for pixels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Issue {
    pub code: &'static str,
    pub severity: Severity,
    pub message: String,
    pub location: String,
}

/// All findings for one panorama.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    pub valid: bool,
    pub errors: usize,
    pub warnings: usize,
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
