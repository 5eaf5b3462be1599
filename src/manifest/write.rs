//! [`Manifest::to_xml`]: POMC 1 XML, UTF-8, two-space indentation.
//!
//! Numbers use Rust's `Display`, which prints the shortest text that parses back to the same
//! value (`f64` for transforms and the radius, `f32` for depth ranges), so `parse(to_xml(m))`
//! gives `m` back apart from source origins.

use std::fmt::Write;

use super::{LayerDecl, LayerSource, Manifest, Packing, Transform};

/// Escape an attribute value for double quotes. Tab, LF and CR are written as character
/// references: literally they would be normalised to spaces by the reader. Characters XML 1.0
/// cannot carry at all (other C0 controls) are replaced by U+FFFD.
pub fn escape_attr(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\t' => out.push_str("&#9;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

fn vec3(v: [f64; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

/// Serialise (see the module documentation). A freedom radius of 0 — the value a missing
/// `<Freedom>` is read as — is written by omitting the element.
pub fn to_xml(m: &Manifest) -> String {
    let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Panorama version=\"1\">\n");
    if !m.transforms.is_empty() {
        out.push_str("  <TransformGroup>\n");
        for t in &m.transforms {
            let line = match *t {
                Transform::Translate(v) => format!("<Translate vector=\"{}\"/>", vec3(v)),
                Transform::Rotate { axis, angle_deg } => {
                    format!("<Rotate axis=\"{}\" angle=\"{angle_deg}\"/>", vec3(axis))
                }
                Transform::Scale(v) => format!("<Scale vector=\"{}\"/>", vec3(v)),
            };
            let _ = writeln!(out, "    {line}");
        }
        out.push_str("  </TransformGroup>\n");
    }
    let _ = writeln!(out, "  <Mapping type=\"{}\"/>", m.mapping.kind.primary_name());
    if m.freedom_radius != 0.0 {
        let _ = writeln!(out, "  <Freedom radius=\"{}\"/>", m.freedom_radius);
    }
    for layer in &m.layers {
        write_layer(&mut out, layer);
    }
    out.push_str("</Panorama>\n");
    out
}

fn layer_attributes(l: &LayerDecl) -> String {
    let mut a = String::new();
    if let Some(n) = &l.name {
        let _ = write!(a, " name=\"{}\"", escape_attr(n));
    }
    if let Some(r) = l.role {
        let _ = write!(a, " role=\"{}\"", r.as_str());
    }
    if let Some(o) = l.order {
        let _ = write!(a, " order=\"{o}\"");
    }
    if let Some(w) = l.width {
        let _ = write!(a, " width=\"{w}\"");
    }
    if let Some(h) = l.height {
        let _ = write!(a, " height=\"{h}\"");
    }
    if let Some((min, max)) = l.depth_range {
        let _ = write!(a, " depthrange=\"{min} {max}\"");
    }
    if let Some(n) = l.mip_levels {
        let _ = write!(a, " miplevels=\"{n}\"");
    }
    a
}

fn write_layer(out: &mut String, l: &LayerDecl) {
    let _ = writeln!(out, "  <Layer{}>", layer_attributes(l));
    match &l.source {
        LayerSource::Native { file } => {
            let _ = writeln!(out, "    <Image file=\"{}\"/>", escape_attr(file));
        }
        LayerSource::Thesis { mapname, depthname, normals } => {
            let _ = writeln!(
                out,
                "    <Textures mapname=\"{}\" depthname=\"{}\" normals=\"{}\"/>",
                escape_attr(mapname),
                escape_attr(depthname),
                escape_attr(normals.as_deref().unwrap_or(""))
            );
        }
    }
    if let Some(p) = &l.packing {
        write_packing(out, p);
    }
    if let Some(m) = &l.mesh {
        let _ = writeln!(
            out,
            "    <Mesh file=\"{}\" encoding=\"{}\" version=\"{}\"/>",
            escape_attr(&m.file),
            escape_attr(&m.encoding),
            escape_attr(&m.version)
        );
    }
    for e in &l.extra {
        let _ = writeln!(out, "    {e}");
    }
    out.push_str("  </Layer>\n");
}

fn write_packing(out: &mut String, p: &Packing) {
    let _ =
        writeln!(out, "    <Packing atlaswidth=\"{}\" atlasheight=\"{}\">", p.atlas_width, p.atlas_height);
    for t in &p.patches {
        let _ = writeln!(
            out,
            "      <Patch u=\"{}\" v=\"{}\" x=\"{}\" y=\"{}\" w=\"{}\" h=\"{}\"/>",
            t.u, t.v, t.x, t.y, t.w, t.h
        );
    }
    out.push_str("    </Packing>\n");
}

#[cfg(test)]
mod tests {
    use super::escape_attr;

    #[test]
    fn escapes_markup_quotes_and_whitespace_controls() {
        assert_eq!(escape_attr("a&<>\"'\t\n\r\u{1}"), "a&amp;&lt;&gt;&quot;'&#9;&#10;&#13;\u{FFFD}");
    }
}
