//! `<Layer>` and what it holds: one source (`<Image>` or the thesis's `<Textures>`), an optional
//! `<Packing>` table, an optional `<Mesh>`, and unknown children kept verbatim in
//! [`LayerDecl::extra`].

use std::collections::HashMap;

use super::codes;
use super::element::{Ctx, El};
use super::file_name::unsafe_reason;
use super::number;
use super::{LayerDecl, LayerOrigin, LayerSource, MeshDecl, Origin, Packing, Role};
use crate::pack::Patch;

const LAYER_ATTRIBUTES: &[&str] = &["name", "role", "order", "width", "height", "depthrange", "miplevels"];
const LAYER_CHILDREN: &[&str] = &["Image", "Textures", "Packing", "Mesh"];

const ROLES: &[Role] =
    &[Role::Background, Role::Object, Role::Floor, Role::Ceiling, Role::Wall, Role::Infinity, Role::Light];

fn origin(ctx: &Ctx, el: &El) -> Origin {
    Origin { pos: ctx.pos(el.start()), path: el.path.clone() }
}

/// One `<Layer>`; `None` when it has no usable source (an error has then been reported).
pub fn layer(ctx: &mut Ctx, el: &El) -> Option<LayerDecl> {
    ctx.check_attributes(el, LAYER_ATTRIBUTES);
    let name = el.attr("name").map(|(v, _)| v.to_string());
    let role = role(ctx, el);
    let order = uint_attr(ctx, el, "order", 0);
    let (width, height) = canvas(ctx, el);
    let depth_range = depth_range(ctx, el);
    let mip_levels = uint_attr(ctx, el, "miplevels", 1);

    let mut sources: Vec<(El, Option<LayerSource>)> = Vec::new();
    let mut packing: Option<(Packing, Vec<Origin>)> = None;
    let mut mesh = None;
    let mut extra = Vec::new();
    for child in el.children() {
        match child.name() {
            "Image" => sources.push((child.clone(), image(ctx, &child))),
            "Textures" => sources.push((child.clone(), textures(ctx, &child))),
            "Packing" if packing.is_some() => ctx.duplicate(&child, "Layer"),
            "Packing" => packing = Some(packing_table(ctx, &child)),
            "Mesh" if mesh.is_some() => ctx.duplicate(&child, "Layer"),
            "Mesh" => mesh = Some(mesh_decl(ctx, &child)),
            _ => {
                ctx.unknown_element(&child, "Layer", LAYER_CHILDREN);
                extra.push(ctx.text[child.node.range()].to_string());
            }
        }
    }
    if sources.is_empty() {
        let msg = "<Layer> has no pixels: add <Image file=\"layer.exr\"/> (or the thesis's <Textures>)";
        ctx.report(codes::LAYER_NO_SOURCE, el.start(), &el.path, msg.to_string());
        return None;
    }
    for (extra_source, _) in sources.iter().skip(1) {
        let msg = "<Layer> has more than one <Image>/<Textures>; keep one source per layer (split the layer otherwise)";
        ctx.report(codes::LAYER_MULTIPLE_SOURCES, extra_source.start(), &extra_source.path, msg.to_string());
    }
    let source = sources.into_iter().next().and_then(|(_, s)| s)?;
    let (packing, patches) = match packing {
        Some((p, o)) => (Some(p), o),
        None => (None, Vec::new()),
    };
    Some(LayerDecl {
        name,
        role,
        order,
        source,
        width,
        height,
        depth_range,
        mip_levels,
        packing,
        mesh: mesh.flatten(),
        extra,
        origin: LayerOrigin { layer: origin(ctx, el), patches },
    })
}

fn role(ctx: &mut Ctx, el: &El) -> Option<Role> {
    let (v, at) = el.attr("role")?;
    let found = ROLES.iter().copied().find(|r| r.as_str() == v);
    if found.is_none() {
        let names: Vec<&str> = ROLES.iter().map(|r| r.as_str()).collect();
        let msg = format!(
            "role `{v}` is not a POMC 1 role ({}); the layer is read without a role",
            names.join(", ")
        );
        ctx.report(codes::ROLE_UNKNOWN, at, &el.path, msg);
    }
    found
}

/// An optional integer attribute that must be at least `min`.
fn uint_attr(ctx: &mut Ctx, el: &El, name: &str, min: u32) -> Option<u32> {
    let (v, at) = el.attr(name)?;
    match number::uint(v) {
        Ok(n) if n >= min => Some(n),
        _ => {
            ctx.report(codes::NUMBER_INVALID, at, &el.path, int_message(el, name, v, min));
            None
        }
    }
}

fn int_message(el: &El, name: &str, v: &str, min: u32) -> String {
    format!(
        "<{}> `{name}` = `{v}` must be a whole number from {min} to 4294967295 (decimal digits only)",
        el.name()
    )
}

/// `width` and `height` go together.
fn canvas(ctx: &mut Ctx, el: &El) -> (Option<u32>, Option<u32>) {
    let w = uint_attr(ctx, el, "width", 1);
    let h = uint_attr(ctx, el, "height", 1);
    for (name, present, other) in
        [("height", el.attr("height").is_some(), "width"), ("width", el.attr("width").is_some(), "height")]
    {
        if !present && el.attr(other).is_some() {
            let msg = format!(
                "<Layer> gives `{other}` without `{name}`; declare both (the full canvas size in pixels)"
            );
            ctx.report(codes::MISSING_ATTRIBUTE, el.start(), &el.path, msg);
        }
    }
    (w, h)
}

fn depth_range(ctx: &mut Ctx, el: &El) -> Option<(f32, f32)> {
    let (v, at) = el.attr("depthrange")?;
    let [min, max] = number::floats32::<2>(v).map_err(|e| ctx.number_error(el, "depthrange", at, &e)).ok()?;
    if min > 0.0 && min <= max {
        Some((min, max))
    } else {
        let msg = format!("depthrange `{v}` must be `min max` in metres with 0 < min <= max");
        ctx.report(codes::DEPTH_RANGE_INVALID, at, &el.path, msg);
        None
    }
}

/// A file name attribute, checked for safety.
fn file_attr(ctx: &mut Ctx, el: &El, name: &str, example: &str) -> Option<String> {
    let (v, at) = ctx.required(el, name, example)?;
    if let Some(why) = unsafe_reason(v) {
        let msg = format!("<{}> `{name}` = `{v}` {why}", el.name());
        ctx.report(codes::FILE_NAME_UNSAFE, at, &el.path, msg);
        return None;
    }
    Some(v.to_string())
}

fn image(ctx: &mut Ctx, el: &El) -> Option<LayerSource> {
    ctx.leaf(el, &["file"]);
    file_attr(ctx, el, "file", "layer0.exr").map(|file| LayerSource::Native { file })
}

fn textures(ctx: &mut Ctx, el: &El) -> Option<LayerSource> {
    ctx.leaf(el, &["mapname", "depthname", "normals"]);
    let mapname = file_attr(ctx, el, "mapname", "Background.png");
    let depthname = file_attr(ctx, el, "depthname", "Background_d.exr");
    // `normals=""` (the thesis) or no attribute: no normals file.
    let normals = match el.attr("normals") {
        Some((n, _)) if !n.is_empty() => Some(file_attr(ctx, el, "normals", "")?),
        _ => None,
    };
    Some(LayerSource::Thesis { mapname: mapname?, depthname: depthname?, normals })
}

/// `<Mesh>`: all three attributes required; any encoding is kept (readers skip unknown ones).
fn mesh_decl(ctx: &mut Ctx, el: &El) -> Option<MeshDecl> {
    ctx.leaf(el, &["file", "encoding", "version"]);
    let file = file_attr(ctx, el, "file", "layer0.pomcmesh");
    let encoding = ctx.required(el, "encoding", MeshDecl::QUADTREE_ENCODING).map(|(v, _)| v.to_string());
    let version = ctx.required(el, "version", "1").map(|(v, _)| v.to_string());
    Some(MeshDecl { file: file?, encoding: encoding?, version: version? })
}

fn packing_table(ctx: &mut Ctx, el: &El) -> (Packing, Vec<Origin>) {
    ctx.check_attributes(el, &["atlaswidth", "atlasheight"]);
    let atlas_width = atlas_side(ctx, el, "atlaswidth");
    let atlas_height = atlas_side(ctx, el, "atlasheight");
    let mut patches = Vec::new();
    let mut origins = Vec::new();
    for child in el.children() {
        if child.name() != "Patch" {
            ctx.unknown_element(&child, "Packing", &["Patch"]);
            continue;
        }
        if let Some(p) = patch(ctx, &child) {
            patches.push(p);
            origins.push(origin(ctx, &child));
        }
    }
    (Packing { atlas_width, atlas_height, patches }, origins)
}

/// `atlaswidth`/`atlasheight`: required, at least 1 (0 stands for "refused" after reporting).
fn atlas_side(ctx: &mut Ctx, el: &El, name: &str) -> u32 {
    let fix = "declare the atlas image size in pixels, e.g. atlaswidth=\"512\" atlasheight=\"256\"";
    let Some((v, at)) = el.attr(name) else {
        ctx.report(codes::PACKING_INVALID, el.start(), &el.path, format!("<Packing> has no `{name}`; {fix}"));
        return 0;
    };
    match number::uint(v) {
        Ok(0) => {
            ctx.report(codes::PACKING_INVALID, at, &el.path, format!("<Packing> `{name}` is 0; {fix}"));
            0
        }
        Ok(n) => n,
        Err(_) => {
            ctx.report(codes::NUMBER_INVALID, at, &el.path, int_message(el, name, v, 1));
            0
        }
    }
}

fn patch(ctx: &mut Ctx, el: &El) -> Option<Patch> {
    const FIELDS: [&str; 6] = ["u", "v", "x", "y", "w", "h"];
    ctx.leaf(el, &FIELDS);
    let mut vals = [0u32; 6];
    let mut ok = true;
    for (slot, name) in vals.iter_mut().zip(FIELDS) {
        let Some((v, at)) = ctx.required(el, name, "0") else {
            ok = false;
            continue;
        };
        match number::uint(v) {
            Ok(n) => *slot = n,
            Err(_) => {
                ctx.report(codes::NUMBER_INVALID, at, &el.path, int_message(el, name, v, 0));
                ok = false;
            }
        }
    }
    let [u, v, x, y, w, h] = vals;
    ok.then_some(Patch { u, v, x, y, w, h })
}

/// Two layers with the same `order` have no defined painter's order between them.
pub fn check_orders(ctx: &mut Ctx, layers: &[LayerDecl]) {
    let mut first: HashMap<u32, &str> = HashMap::new();
    for l in layers {
        let Some(o) = l.order else { continue };
        match first.get(&o) {
            Some(prev) => {
                let msg = format!(
                    "order {o} is also used by {prev}; give each layer its own order (smaller = farther)"
                );
                let pos = l.origin.layer.pos;
                ctx.sink.push(codes::ORDER_DUPLICATE, pos, &l.origin.layer.path, msg);
            }
            None => {
                first.insert(o, &l.origin.layer.path);
            }
        }
    }
}
