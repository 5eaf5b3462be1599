//! Collecting diagnostics: source positions and a bounded list of findings.
//!
//! Positions are computed from a line-start index (binary search) rather than roxmltree's
//! `text_pos_at`, which rescans the text from the start each time: a hostile 16 MiB manifest
//! with a million unknown elements must not take quadratic time.

use super::{Diagnosed, Diagnostic, Manifest, Pos, Severity};
use crate::codes::manifest as codes;

/// At most this many findings are listed; the rest are counted (the manifest is still refused
/// when any of them is an error).
pub const MAX_DIAGNOSTICS: usize = 1000;

/// Line starts and character-count checkpoints of a text. Lines end at LF (a CRLF pair is one
/// break), like roxmltree's own error positions; columns count characters, so both agree. Both
/// lookups are O(log n + [`CHUNK`]) so a 16 MiB single-line manifest stays cheap.
pub struct LineIndex {
    starts: Vec<usize>,
    /// `chars_before[k]`: characters in the first `k * CHUNK` bytes.
    chars_before: Vec<usize>,
}

const CHUNK: usize = 1024;

/// UTF-8 continuation bytes do not start a character.
fn starts_char(b: u8) -> bool {
    b & 0xC0 != 0x80
}

impl LineIndex {
    pub fn new(text: &str) -> Self {
        let bytes = text.as_bytes();
        let mut starts = vec![0];
        starts.extend(bytes.iter().enumerate().filter(|&(_, &b)| b == b'\n').map(|(i, _)| i + 1));
        let mut chars_before = vec![0];
        let mut total = 0;
        for chunk in bytes.chunks(CHUNK) {
            total += chunk.iter().filter(|&&b| starts_char(b)).count();
            chars_before.push(total);
        }
        LineIndex { starts, chars_before }
    }

    /// Characters in the first `offset` bytes.
    fn chars_to(&self, bytes: &[u8], offset: usize) -> usize {
        let k = offset / CHUNK;
        let head = self.chars_before.get(k).copied().unwrap_or(0);
        head + bytes[k * CHUNK..offset].iter().filter(|&&b| starts_char(b)).count()
    }

    /// 1-based line and column of the byte `offset` of `text` (clamped to the text).
    pub fn pos(&self, text: &str, offset: usize) -> Pos {
        let bytes = text.as_bytes();
        let offset = offset.min(bytes.len());
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let start = self.starts[line - 1];
        let col = self.chars_to(bytes, offset) - self.chars_to(bytes, start) + 1;
        Pos { line: saturate(line), col: saturate(col) }
    }
}

fn saturate(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The findings so far.
#[derive(Default)]
pub struct Sink {
    diagnostics: Vec<Diagnostic>,
    errors: usize,
    dropped: usize,
}

impl Sink {
    /// Record a finding; its severity comes from [`crate::codes::manifest::CODES`].
    pub fn push(&mut self, code: &'static str, pos: Pos, path: &str, message: String) {
        let severity = crate::codes::severity(code);
        if severity == Severity::Error {
            self.errors += 1;
        }
        if self.diagnostics.len() >= MAX_DIAGNOSTICS {
            self.dropped += 1;
            return;
        }
        let path = if path.is_empty() { "/".to_string() } else { path.to_string() };
        self.diagnostics.push(Diagnostic { code, severity, message, line: pos.line, col: pos.col, path });
    }

    /// The result: the manifest is kept only when no error was found.
    pub fn finish(mut self, manifest: Option<Manifest>) -> Diagnosed {
        if self.dropped > 0 {
            let message = format!(
                "{} more findings are not listed; fix the ones above and validate again",
                self.dropped
            );
            self.diagnostics.push(Diagnostic {
                code: codes::DIAGNOSTICS_TRUNCATED,
                severity: Severity::Info,
                message,
                line: 1,
                col: 1,
                path: "/".into(),
            });
        }
        let manifest = if self.errors == 0 { manifest } else { None };
        Diagnosed { diagnostics: self.diagnostics, manifest }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_are_one_based_and_count_chars() {
        let t = "ab\nçd\r\nef";
        let ix = LineIndex::new(t);
        assert_eq!(ix.pos(t, 0), Pos { line: 1, col: 1 });
        assert_eq!(ix.pos(t, 3), Pos { line: 2, col: 1 });
        assert_eq!(ix.pos(t, 5), Pos { line: 2, col: 2 }); // after the 2-byte ç
        assert_eq!(ix.pos(t, 8), Pos { line: 3, col: 1 });
        assert_eq!(ix.pos(t, 100), Pos { line: 3, col: 3 });
    }

    #[test]
    fn columns_on_long_lines_use_checkpoints() {
        let t = format!("{}<x/>\n{}<y/>", "é".repeat(3000), "a".repeat(5000));
        let ix = LineIndex::new(&t);
        assert_eq!(ix.pos(&t, 6000), Pos { line: 1, col: 3001 });
        assert_eq!(ix.pos(&t, 6005 + 4321), Pos { line: 2, col: 4322 });
    }
}
