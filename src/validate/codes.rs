//! The validator's codes (defined in [`crate::codes`], below every module that raises them) and
//! [`all`]: the manifest's and the validator's together, checked against the spec's tables
//! (spec/02-manifest.md, spec/06-validation.md) by tests.

pub use crate::codes::*;

/// Every code the validator can report: the manifest's and its own.
pub fn all() -> Vec<(&'static str, Severity, &'static str)> {
    crate::codes::manifest::CODES.iter().chain(CODES).copied().collect()
}

/// Severity of a code; unknown codes are errors (a missing row is caught by the code-table test).
pub fn severity(code: &str) -> Severity {
    CODES
        .iter()
        .find(|(c, _, _)| *c == code)
        .map(|(_, s, _)| *s)
        .or_else(|| crate::codes::manifest::CODES.iter().find(|(c, _, _)| *c == code).map(|(_, s, _)| *s))
        .unwrap_or(Severity::Error)
}
