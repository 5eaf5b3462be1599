//! The document walk: XML tree to [`Manifest`], reporting every problem on the way.
//!
//! Only the known element structure is descended (Panorama > Layer > Packing > Patch), so the
//! walk's depth is bounded whatever the input nests. Elements and attributes in an XML namespace
//! are extensions and skipped silently; unknown plain ones are warnings (forward compatibility).

use roxmltree::{Document, ParsingOptions};

use super::decode::decode;
use super::diag::{LineIndex, Sink};
use super::element::{Ctx, El};
use super::number::{self, NumberError};
use super::{Diagnosed, Manifest, MappingDecl, MappingKind, Pos, Transform};
use crate::codes::manifest as codes;

/// The parser's options: no DTD (so no entity expansion at all, hence no billion laughs).
fn parsing_options<'i>() -> ParsingOptions<'i> {
    ParsingOptions { allow_dtd: false, ..ParsingOptions::default() }
}

/// Check a manifest's bytes (see [`super::diagnose`]).
pub fn diagnose(bytes: &[u8]) -> Diagnosed {
    let mut sink = Sink::default();
    let Some(text) = decode(bytes, &mut sink) else {
        return sink.finish(None);
    };
    if let Some(offset) = attribute_flood(&text) {
        let pos = LineIndex::new(&text).pos(&text, offset);
        let msg =
            format!("an element has more than {MAX_ATTRIBUTES} attributes; a POMC element has at most 7");
        sink.push(codes::XML_LIMIT_EXCEEDED, pos, "/", msg);
        return sink.finish(None);
    }
    let doc = match Document::parse_with_options(&text, parsing_options()) {
        Ok(doc) => doc,
        Err(e) => {
            xml_error(&text, &e, &mut sink);
            return sink.finish(None);
        }
    };
    let mut ctx = Ctx::new(&text, sink);
    let manifest = panorama(&mut ctx, &doc);
    ctx.sink.finish(manifest)
}

/// Attributes allowed on one element: the XML parser checks each against the ones before it.
pub const MAX_ATTRIBUTES: usize = 256;

/// Layers read from one manifest (each costs a file, and every command reads them all).
pub const MAX_LAYERS: usize = 1024;

/// The offset of the first tag with more than [`MAX_ATTRIBUTES`] attributes (a scan for `=`
/// outside quotes inside `<…>`, comments and declarations skipped), found in linear time.
fn attribute_flood(text: &str) -> Option<usize> {
    let b = text.as_bytes();
    let (mut i, mut tag_start, mut count, mut quote) = (0, None::<usize>, 0usize, 0u8);
    while i < b.len() {
        let c = b[i];
        match tag_start {
            None if c == b'<' => {
                if b.get(i + 1).is_some_and(|&n| n == b'!' || n == b'?') {
                    // Skip to the end of the comment, CDATA or declaration.
                    let end = if b[i..].starts_with(b"<!--") {
                        "-->"
                    } else if b[i..].starts_with(b"<![CDATA[") {
                        "]]>"
                    } else {
                        ">"
                    };
                    i = text[i..].find(end).map_or(b.len(), |k| i + k + end.len());
                    continue;
                }
                (tag_start, count, quote) = (Some(i), 0, 0);
            }
            Some(start) => {
                if quote != 0 {
                    if c == quote {
                        quote = 0;
                    }
                } else if c == b'"' || c == b'\'' {
                    quote = c;
                } else if c == b'=' {
                    count += 1;
                    if count > MAX_ATTRIBUTES {
                        return Some(start);
                    }
                } else if c == b'>' {
                    tag_start = None;
                }
            }
            None => {}
        }
        i += 1;
    }
    None
}

fn xml_error(text: &str, e: &roxmltree::Error, sink: &mut Sink) {
    if matches!(e, roxmltree::Error::DtdDetected) {
        let offset = text.find("<!DOCTYPE").unwrap_or(0);
        let pos = LineIndex::new(text).pos(text, offset);
        let msg = "the manifest has a DOCTYPE; remove it (POMC manifests use no DTD or entities)".to_string();
        sink.push(codes::XML_DTD_FORBIDDEN, pos, "/", msg);
    } else {
        let p = e.pos();
        let pos = Pos { line: p.row, col: p.col };
        sink.push(codes::XML_MALFORMED, pos, "/", format!("not well-formed XML: {e}; fix the syntax there"));
    }
}

const PANORAMA_CHILDREN: &[&str] = &["TransformGroup", "Mapping", "Freedom", "Layer"];

fn panorama(ctx: &mut Ctx, doc: &Document) -> Option<Manifest> {
    let el = root(ctx, doc)?;
    ctx.check_attributes(&el, &["version"]);
    // A POMC 2 file is not judged by POMC 1 rules: stop at the version.
    let version = version(ctx, &el)?;
    let mut transforms: Option<Vec<Transform>> = None;
    let mut mapping: Option<MappingDecl> = None;
    let mut freedom: Option<f64> = None;
    let mut layers = Vec::new();
    let mut saw_layer = false;
    let mut layer_count = 0;
    for child in el.children() {
        match child.name() {
            "TransformGroup" if transforms.is_some() => ctx.duplicate(&child, "Panorama"),
            "TransformGroup" => transforms = Some(transform_group(ctx, &child)),
            "Mapping" if mapping.is_some() => ctx.duplicate(&child, "Panorama"),
            "Mapping" => mapping = Some(mapping_decl(ctx, &child)),
            "Freedom" if freedom.is_some() => ctx.duplicate(&child, "Panorama"),
            "Freedom" => freedom = Some(freedom_radius(ctx, &child)),
            "Layer" if layer_count == MAX_LAYERS => {
                let msg = format!("more than {MAX_LAYERS} layers; merge layers (a scene needs a handful) — the rest are not read");
                ctx.report(codes::TOO_MANY_LAYERS, child.start(), &child.path, msg);
                layer_count += 1;
            }
            "Layer" if layer_count > MAX_LAYERS => {}
            "Layer" => {
                saw_layer = true;
                layer_count += 1;
                layers.extend(super::read_layer::layer(ctx, &child));
            }
            _ => ctx.unknown_element(&child, "Panorama", PANORAMA_CHILDREN),
        }
    }
    missing(ctx, &el, [mapping.is_none(), freedom.is_none(), !saw_layer]);
    super::read_layer::check_orders(ctx, &layers);
    Some(Manifest {
        version,
        transforms: transforms.unwrap_or_default(),
        mapping: mapping.unwrap_or(MappingDecl { kind: MappingKind::Equirect }),
        freedom_radius: freedom.unwrap_or(0.0),
        layers,
    })
}

/// The root element, when it is a `<Panorama>` in no namespace.
fn root<'a, 'i>(ctx: &mut Ctx, doc: &'a Document<'i>) -> Option<El<'a, 'i>> {
    let root = doc.root_element();
    let el = El { node: root, path: format!("/{}", root.tag_name().name()) };
    if el.name() != "Panorama" || root.tag_name().namespace().is_some() {
        let msg = format!(
            "the root element is <{}>{}; a POMC manifest starts with <Panorama version=\"1\">",
            el.name(),
            root.tag_name().namespace().map(|n| format!(" in namespace {n}")).unwrap_or_default()
        );
        ctx.report(codes::ROOT_NOT_PANORAMA, el.start(), &el.path, msg);
        return None;
    }
    Some(el)
}

/// Report the required children of `<Panorama>` that are missing: `[mapping, freedom, layer]`.
fn missing(ctx: &mut Ctx, el: &El, [mapping, freedom, layer]: [bool; 3]) {
    let end_msg = |what: &str| format!("<Panorama> has no {what}");
    if mapping {
        let msg = end_msg("<Mapping>") + "; add <Mapping type=\"LatLongMapping\"/> (or CubeMapping)";
        ctx.report(codes::MAPPING_MISSING, el.start(), &el.path, msg);
    }
    if freedom {
        let msg = end_msg("<Freedom>") + "; the radius is taken as 0: add <Freedom radius=\"0.5\"/> (metres)";
        ctx.report(codes::FREEDOM_MISSING, el.start(), &el.path, msg);
    }
    if layer {
        let msg = end_msg("<Layer>") + "; add at least one <Layer> with an <Image file=\"…\"/>";
        ctx.report(codes::NO_LAYERS, el.start(), &el.path, msg);
    }
}

/// `version`: absent means "1" (the thesis form); any `1` or `1.x` is read as POMC 1.
fn version(ctx: &mut Ctx, el: &El) -> Option<String> {
    let Some((v, at)) = el.attr("version") else {
        return Some("1".to_string());
    };
    let t = v.trim();
    let minor_ok = |m: &str| !m.is_empty() && m.bytes().all(|b| b.is_ascii_digit());
    let ok = t == "1" || t.strip_prefix("1.").is_some_and(minor_ok);
    if !ok {
        let msg = format!(
            "version `{v}` is not POMC 1; this reader understands version=\"1\" (and 1.x) — use a newer reader or re-export as POMC 1"
        );
        ctx.report(codes::VERSION_UNSUPPORTED, at, &el.path, msg);
        return None;
    }
    Some(t.to_string())
}

const TRANSFORM_OPS: &[&str] = &["Translate", "Rotate", "Scale"];

fn transform_group(ctx: &mut Ctx, el: &El) -> Vec<Transform> {
    ctx.check_attributes(el, &[]);
    let mut ops = Vec::new();
    for op in el.children() {
        let t = match op.name() {
            "Translate" => translate(ctx, &op),
            "Rotate" => rotate(ctx, &op),
            "Scale" => scale(ctx, &op),
            _ => {
                ctx.unknown_element(&op, "TransformGroup", TRANSFORM_OPS);
                None
            }
        };
        ops.extend(t);
    }
    // Each operation may be fine and their product not: three `<Scale 1e300>` overflow. Entries
    // beyond 1e150 would overflow on the first point they move (`Translate 1e308`).
    if !super::transform::is_usable(&super::transform::compose(&ops)) {
        let msg = "the composed LocalToWorld is not a finite, invertible matrix (an operation overflows or \
                   cancels another); keep translations, scales and their products well inside ±1e150";
        ctx.report(codes::TRANSFORM_INVALID, el.start(), &el.path, msg.to_string());
        return Vec::new();
    }
    ops
}

fn translate(ctx: &mut Ctx, el: &El) -> Option<Transform> {
    ctx.leaf(el, &["vector"]);
    ctx.vector3(el, "vector", "0 0 1.15").map(Transform::Translate)
}

fn rotate(ctx: &mut Ctx, el: &El) -> Option<Transform> {
    ctx.leaf(el, &["axis", "angle"]);
    let axis = ctx.vector3(el, "axis", "0 0 1").filter(|axis| {
        let zero = axis.iter().all(|&c| c == 0.0);
        if zero {
            let at = el.attr("axis").map_or(el.start(), |(_, at)| at);
            let msg =
                "<Rotate> axis is (0,0,0), which names no direction; give a non-zero axis such as \"0 0 1\"";
            ctx.report(codes::ROTATE_AXIS_ZERO, at, &el.path, msg.to_string());
        }
        !zero
    });
    let angle = ctx
        .required(el, "angle", "90")
        .and_then(|(v, at)| number::float(v).map_err(|e| ctx.number_error(el, "angle", at, &e)).ok());
    Some(Transform::Rotate { axis: axis?, angle_deg: angle? })
}

fn scale(ctx: &mut Ctx, el: &El) -> Option<Transform> {
    ctx.leaf(el, &["vector"]);
    let v = ctx.vector3(el, "vector", "-1 1 1")?;
    if v.contains(&0.0) {
        let at = el.attr("vector").map_or(el.start(), |(_, at)| at);
        let msg =
            "<Scale> has a zero component, which flattens the panorama; use non-zero factors (-1 mirrors)";
        ctx.report(codes::SCALE_ZERO, at, &el.path, msg.to_string());
        return None;
    }
    Some(Transform::Scale(v))
}

/// Accepted `type` names: the primary ones first (written by `to_xml`), then aliases.
const MAPPING_NAMES: &[(&str, MappingKind)] = &[
    ("LatLongMapping", MappingKind::Equirect),
    ("CubeMapping", MappingKind::Cube3x2),
    ("EquirectMapping", MappingKind::Equirect),
    ("Equirect", MappingKind::Equirect),
    ("Cube3x2", MappingKind::Cube3x2),
    ("Cube", MappingKind::Cube3x2),
];

fn mapping_decl(ctx: &mut Ctx, el: &El) -> MappingDecl {
    ctx.leaf(el, &["type"]);
    let fallback = MappingDecl { kind: MappingKind::Equirect };
    let Some((ty, at)) = ctx.required(el, "type", "LatLongMapping") else {
        return fallback;
    };
    if let Some(&(_, kind)) = MAPPING_NAMES.iter().find(|(n, _)| *n == ty) {
        return MappingDecl { kind };
    }
    let hint = MAPPING_NAMES
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(ty.trim()))
        .map(|(n, _)| format!(" (names are case-sensitive: did you mean `{n}`?)"))
        .unwrap_or_default();
    let msg = format!("mapping type `{ty}` is unknown{hint}; use LatLongMapping or CubeMapping");
    ctx.report(codes::MAPPING_UNKNOWN, at, &el.path, msg);
    fallback
}

fn freedom_radius(ctx: &mut Ctx, el: &El) -> f64 {
    ctx.leaf(el, &["radius"]);
    let Some((v, at)) = ctx.required(el, "radius", "0.5") else {
        return 0.0;
    };
    let bad = |ctx: &mut Ctx| {
        let msg = format!("freedom radius `{v}` must be a finite number of metres greater than 0");
        ctx.report(codes::FREEDOM_INVALID, at, &el.path, msg);
        0.0
    };
    match number::float(v) {
        Ok(r) if r > 0.0 => r,
        Ok(_) | Err(NumberError::NotFinite(_)) => bad(ctx),
        Err(e) => {
            ctx.number_error(el, "radius", at, &e);
            0.0
        }
    }
}
