//! `pomc validate`: the validator's report on a panorama ([`validate`]) and its human lines.

use std::path::Path;

use crate::codes::Severity;
pub use crate::validate::{validate, Report, ValidateSettings};

impl Report {
    /// The lines `pomc validate` prints: each finding with its location, then the verdict on
    /// `path`.
    pub fn summary(&self, path: &Path) -> Vec<String> {
        let mut lines: Vec<String> = self
            .issues
            .iter()
            .map(|i| format!("{}[{}]: {}\n  --> {}", i.severity.as_str(), i.code, i.message, i.location))
            .collect();
        let infos = self.issues.iter().filter(|i| i.severity == Severity::Info).count();
        lines.push(format!(
            "{}: {} ({} error(s), {} warning(s), {} note(s))",
            path.display(),
            if self.valid { "valid" } else { "INVALID" },
            self.errors,
            self.warnings,
            infos
        ));
        lines
    }
}
