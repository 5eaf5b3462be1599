//! Safety of file names written in the manifest. A panorama is a directory that gets copied,
//! zipped and served: a name must stay a portable relative path inside it. This is the lexical
//! check; `Panorama::resolve` also refuses symbolic links that lead out when opening files.

/// Why `name` is not a safe relative file name, or `None` when it is.
pub fn unsafe_reason(name: &str) -> Option<&'static str> {
    if name.is_empty() {
        return Some("is empty; name a file relative to the panorama directory");
    }
    if name.chars().any(char::is_control) {
        return Some("contains a control character; rename the file");
    }
    if name.contains('\\') {
        return Some("uses `\\`; separate directories with `/`");
    }
    if name.contains(':') {
        return Some("contains `:` (a drive letter, URL or stream name); use a plain relative path");
    }
    if name.starts_with('/') {
        return Some("is absolute; make it relative to the panorama directory");
    }
    let mut depth = 0i64;
    for part in name.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                depth -= 1;
                if depth < 0 {
                    return Some("leaves the panorama directory through `..`; move the file inside it");
                }
            }
            _ => depth += 1,
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::unsafe_reason;

    #[test]
    fn relative_names_inside_are_safe() {
        for ok in ["a.exr", "sub/a.exr", "./a.exr", "sub/../a.exr", "Background_d.exr", "é.png"] {
            assert_eq!(unsafe_reason(ok), None, "{ok}");
        }
    }

    #[test]
    fn escapes_and_non_portable_names_are_refused() {
        for bad in [
            "",
            "/etc/passwd",
            "../a.exr",
            "sub/../../a.exr",
            "a\\b.exr",
            "C:a.exr",
            "c:/x",
            "a\0b",
            "http://x/a",
        ] {
            assert!(unsafe_reason(bad).is_some(), "{bad:?}");
        }
    }
}
