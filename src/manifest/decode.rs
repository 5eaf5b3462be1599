//! Bytes to text. roxmltree takes `&str` only, so the encoding is handled here: UTF-8 (with or
//! without byte-order mark) and ISO-8859-1, which the thesis example declares. Latin-1 is decoded
//! byte for byte (each byte is the code point of the same value), so line:col positions in the
//! decoded text are those of the file. Everything else is refused with a code rather than guessed.

use super::diag::{LineIndex, Sink};
use super::Pos;
use crate::codes::manifest as codes;

const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// Encodings a reader must accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Utf8,
    Latin1,
}

/// Names accepted in `<?xml … encoding="…"?>`, compared ASCII-case-insensitively.
fn encoding_named(name: &str) -> Option<Encoding> {
    let lower = name.to_ascii_lowercase();
    match lower.as_str() {
        "utf-8" | "utf8" | "us-ascii" | "ascii" => Some(Encoding::Utf8),
        "iso-8859-1" | "iso_8859-1" | "iso8859-1" | "latin1" | "latin-1" | "l1" => Some(Encoding::Latin1),
        _ => None,
    }
}

/// Decode the manifest, reporting why when it cannot be.
pub fn decode(bytes: &[u8], sink: &mut Sink) -> Option<String> {
    let start = Pos { line: 1, col: 1 };
    if is_utf16_or_32(bytes) {
        let msg = "the manifest is UTF-16 or UTF-32; save it as UTF-8".to_string();
        sink.push(codes::XML_ENCODING_UNSUPPORTED, start, "/", msg);
        return None;
    }
    let (has_bom, body) = match bytes.strip_prefix(UTF8_BOM) {
        Some(rest) => (true, rest),
        None => (false, bytes),
    };
    if body.starts_with(UTF8_BOM) {
        let msg =
            "the file starts with two byte-order marks; remove the second (U+FEFF is not allowed before \
                   the XML declaration or the root element)"
                .to_string();
        sink.push(codes::XML_MALFORMED, start, "/", msg);
        return None;
    }
    if let Some((version, offset)) = pseudo_attribute(body, b"version") {
        if version != "1.0" {
            let pos = Pos { line: 1, col: u32::try_from(offset + 1).unwrap_or(u32::MAX) };
            let msg = format!(
                "the XML declaration says version=\"{version}\"; a POMC manifest is XML 1.0: declare \
                 <?xml version=\"1.0\" encoding=\"UTF-8\"?>"
            );
            sink.push(codes::XML_MALFORMED, pos, "/", msg);
            return None;
        }
    }
    let encoding = match pseudo_attribute(body, b"encoding") {
        None => Encoding::Utf8,
        Some((name, offset)) => {
            let pos = Pos { line: 1, col: u32::try_from(offset + 1).unwrap_or(u32::MAX) };
            match encoding_named(&name) {
                Some(e) => e,
                None => {
                    let msg = format!(
                        "encoding `{name}` is not supported; save the file as UTF-8 (or ISO-8859-1) and declare it"
                    );
                    sink.push(codes::XML_ENCODING_UNSUPPORTED, pos, "/", msg);
                    return None;
                }
            }
        }
    };
    match encoding {
        Encoding::Latin1 if has_bom => {
            let msg = "the file starts with a UTF-8 byte-order mark but declares ISO-8859-1; \
                       remove the mark or declare encoding=\"UTF-8\""
                .to_string();
            sink.push(codes::XML_ENCODING_INVALID, start, "/", msg);
            None
        }
        Encoding::Latin1 => Some(body.iter().map(|&b| char::from(b)).collect()),
        Encoding::Utf8 => utf8(body, sink),
    }
}

fn utf8(body: &[u8], sink: &mut Sink) -> Option<String> {
    match std::str::from_utf8(body) {
        Ok(s) => Some(s.to_string()),
        Err(e) => {
            let good = e.valid_up_to();
            // The prefix is valid UTF-8 by construction.
            let prefix = std::str::from_utf8(&body[..good]).unwrap_or("");
            let pos = LineIndex::new(prefix).pos(prefix, good);
            let msg = format!(
                "byte 0x{:02X} is not UTF-8; if the file is Latin-1 declare \
                 <?xml version=\"1.0\" encoding=\"iso-8859-1\"?>, otherwise re-save it as UTF-8",
                body.get(good).copied().unwrap_or(0)
            );
            sink.push(codes::XML_ENCODING_INVALID, pos, "/", msg);
            None
        }
    }
}

/// UTF-16/32 byte-order marks, or `<` encoded on two or four bytes.
fn is_utf16_or_32(b: &[u8]) -> bool {
    b.starts_with(b"\xFE\xFF")
        || b.starts_with(b"\xFF\xFE")
        || b.starts_with(b"\x00\x00\xFE\xFF")
        || b.starts_with(b"\x00<")
        || b.starts_with(b"<\x00")
}

fn is_xml_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r')
}

/// A pseudo-attribute (`version`, `encoding`) of a leading XML declaration and the byte offset of
/// its value (the declaration is ASCII in both accepted encodings). The declaration is searched to its
/// `?>` however much whitespace pads it. A malformed declaration gives `None` here and an
/// `XML_MALFORMED` from the parser.
fn pseudo_attribute(body: &[u8], key: &[u8]) -> Option<(String, usize)> {
    let after = body.strip_prefix(b"<?xml")?;
    if !after.first().is_some_and(|&b| is_xml_space(b)) {
        return None;
    }
    let end = body.windows(2).position(|w| w == b"?>")?;
    let decl = &body[..end];
    let mut i = decl.windows(key.len()).position(|w| w == key)? + key.len();
    while decl.get(i).is_some_and(|&b| is_xml_space(b)) {
        i += 1;
    }
    if decl.get(i) != Some(&b'=') {
        return None;
    }
    i += 1;
    while decl.get(i).is_some_and(|&b| is_xml_space(b)) {
        i += 1;
    }
    let quote = *decl.get(i).filter(|&&q| q == b'"' || q == b'\'')?;
    let value_start = i + 1;
    let len = decl.get(value_start..)?.iter().position(|&b| b == quote)?;
    let value = &decl[value_start..value_start + len];
    Some((String::from_utf8_lossy(value).into_owned(), value_start))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(bytes: &[u8]) -> (Option<String>, Vec<&'static str>) {
        let mut sink = Sink::default();
        let text = decode(bytes, &mut sink);
        let codes = sink.finish(None).diagnostics.iter().map(|d| d.code).collect();
        (text, codes)
    }

    #[test]
    fn latin1_is_decoded_byte_for_byte() {
        let (t, c) = run(b"<?xml version=\"1.0\" encoding='iso-8859-1'?><a n=\"\xE9\"/>");
        assert_eq!(t.unwrap(), "<?xml version=\"1.0\" encoding='iso-8859-1'?><a n=\"é\"/>");
        assert!(c.is_empty());
    }

    #[test]
    fn utf8_bom_is_stripped() {
        assert_eq!(run(b"\xEF\xBB\xBF<a/>").0.unwrap(), "<a/>");
    }

    #[test]
    fn other_encodings_are_refused() {
        assert_eq!(
            run(b"<?xml version=\"1.0\" encoding=\"Shift_JIS\"?><a/>").1,
            [codes::XML_ENCODING_UNSUPPORTED]
        );
        assert_eq!(run(b"\xFF\xFE<\x00a\x00/\x00>\x00").1, [codes::XML_ENCODING_UNSUPPORTED]);
        assert_eq!(run(b"<a n=\"\xE9\"/>").1, [codes::XML_ENCODING_INVALID]);
    }

    #[test]
    fn padded_declarations_double_marks_and_xml_1_1_are_caught() {
        let mut padded = b"<?xml version=\"1.0\"".to_vec();
        padded.extend(vec![b' '; 4000]);
        padded.extend(b"encoding=\"iso-8859-1\"?><a n=\"\xE9\"/>");
        let (t, c) = run(&padded);
        assert!(c.is_empty(), "{c:?}");
        assert!(t.unwrap().ends_with("<a n=\"é\"/>"));
        assert_eq!(run(b"\xEF\xBB\xBF\xEF\xBB\xBF<a/>").1, [codes::XML_MALFORMED]);
        assert_eq!(run(b"<?xml version=\"1.1\"?><a/>").1, [codes::XML_MALFORMED]);
        assert_eq!(run(b"<?xml version='1.0'?><a/>").1, Vec::<&str>::new());
    }
}
