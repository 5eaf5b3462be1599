//! The validation report: the JSON shape printed by `pomc validate --json`.

use serde::Serialize;

/// Severity of a validation issue.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    Error,
    Warning,
    Info,
}

impl Severity {
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
            Severity::Info => "info",
        }
    }
}

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

impl From<crate::manifest::Severity> for Severity {
    fn from(s: crate::manifest::Severity) -> Self {
        match s {
            crate::manifest::Severity::Error => Severity::Error,
            crate::manifest::Severity::Warning => Severity::Warning,
            crate::manifest::Severity::Info => Severity::Info,
        }
    }
}
