//! The manifest's stable codes, kept as data: code, severity, meaning, declared in
//! [`crate::codes::manifest`] (below every module) and re-exported here. The spec's table
//! (spec/02-manifest.md §2.9) is checked against [`CODES`] by a unit test, so the two cannot drift.
//! Codes never change meaning once published; new ones may be added.

pub use crate::codes::manifest::*;
use crate::codes::Severity;

/// Severity of a manifest code; unknown codes are errors (tests keep every emitted code in the table).
pub fn severity(code: &str) -> Severity {
    CODES.iter().find(|(c, _, _)| *c == code).map(|(_, s, _)| *s).unwrap_or(Severity::Error)
}
