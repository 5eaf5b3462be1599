//! `pomc mesh` end to end on the room fixture: JSON figures, the three export formats, `--store`; and on
//! an outdoor panorama (infinity layer 0): every layer in one scene, the sky on a dome.

use std::path::{Path, PathBuf};
use std::process::Command;

use pomc::manifest::Role;
use pomc::mapping::{AnyMapping, MappingKind};
use pomc::panorama::Panorama;
use serde_json::Value;

use crate::pomc;

fn room(dir: &Path, kind: MappingKind, w: usize, h: usize) {
    let m = AnyMapping::new(kind, w, h).unwrap();
    pomc_fixtures::layers::write_room(dir, &m).unwrap();
}

#[test]
fn mesh_reports_figures_and_writes_every_format() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path(), MappingKind::Cube3x2, 144, 96);
    let d = dir.path().to_str().unwrap();
    for (layer, ext) in [("0", "glb"), ("1", "ply"), ("0", "obj")] {
        let out_path = dir.path().join(format!("m{layer}.{ext}"));
        let out = pomc(&["mesh", d, "--layer", layer, "-o", out_path.to_str().unwrap(), "--json"]);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(v["triangles"].as_u64().unwrap() > 0);
        assert!(v["error"]["p99_rel"].as_f64().unwrap() <= 0.005);
        // Clean cube faces (all six of the background) take greedy insertion and build no quadtree,
        // so the encoding is only computed with --store.
        let greedy_faces = v["greedy_faces"].as_u64().unwrap();
        if layer == "0" {
            assert_eq!(greedy_faces, 6, "{v}");
        }
        if greedy_faces == 0 {
            assert!(v["encoded_bytes"].as_u64().unwrap() > 9);
        } else {
            assert!(v["encoded_bytes"].is_null() && v["quadtree_triangles"].is_null(), "{v}");
        }
        assert!(std::fs::metadata(&out_path).unwrap().len() > 0);
    }
}

#[test]
fn store_references_the_mesh_from_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path(), MappingKind::Equirect, 128, 64);
    let d = dir.path().to_str().unwrap();
    // Without --layer every layer is meshed and stored.
    let out = pomc(&["mesh", d, "--store", "--no-metric", "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let xml = std::fs::read_to_string(dir.path().join("panorama.xml")).unwrap();
    for name in ["room", "objects"] {
        assert!(xml.contains(&format!("<Mesh file=\"{name}.pomcmesh\"")), "{xml}");
        assert!(dir.path().join(format!("{name}.pomcmesh")).is_file());
    }
    // Storing again replaces the reference instead of adding a second one.
    assert_eq!(
        pomc(&["mesh", d, "--layer", "0", "--store", "--no-metric", "--quiet"]).status.code(),
        Some(0)
    );
    let xml = std::fs::read_to_string(dir.path().join("panorama.xml")).unwrap();
    assert_eq!(xml.matches("<Mesh").count(), 2);
}

/// `validate --json` of a panorama: (errors, warnings, codes).
fn validate(pano: &Path) -> (u64, u64, Vec<String>) {
    let out = pomc(&["validate", pano.to_str().unwrap(), "--json"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let codes =
        v["issues"].as_array().unwrap().iter().map(|i| i["code"].as_str().unwrap().to_string()).collect();
    (v["errors"].as_u64().unwrap(), v["warnings"].as_u64().unwrap(), codes)
}

/// The render's mesh sources (`stored`/`built`) for one view of the mesh method.
fn mesh_sources(pano: &Path) -> Value {
    let view = pano.join("view.png");
    let (p, v) = (pano.to_str().unwrap(), view.to_str().unwrap());
    let out = pomc(&["render", p, "-o", v, "--method", "mesh", "--size", "64x36", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_file(&view).unwrap();
    serde_json::from_slice::<Value>(&out.stdout).unwrap()["mesh"]["sources"].clone()
}

/// `<Mesh>` is part of the manifest (spec §8.1): validated without warnings, kept and copied by
/// `pack` and `unpack` (into a new directory and in place), dropped by `convert` (the pixels
/// change), and a broken one is a warning with its own code.
#[test]
fn stored_meshes_survive_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    room(&src, MappingKind::Equirect, 128, 64);
    let s = src.to_str().unwrap();
    assert_eq!(pomc(&["mesh", s, "--store", "--no-metric", "--quiet"]).status.code(), Some(0));
    assert_eq!(validate(&src), (0, 0, vec![]));
    let stored = serde_json::json!(["stored", "stored"]);
    assert_eq!(mesh_sources(&src), stored);

    for (cmd, name) in [("pack", "packed"), ("unpack", "unpacked")] {
        let out_dir = dir.path().join(name);
        let out = pomc(&[cmd, s, "-o", out_dir.to_str().unwrap(), "--quiet"]);
        assert_eq!(out.status.code(), Some(0), "{cmd}: {}", String::from_utf8_lossy(&out.stderr));
        for mesh in ["room.pomcmesh", "objects.pomcmesh"] {
            assert_eq!(
                std::fs::read(out_dir.join(mesh)).unwrap(),
                std::fs::read(src.join(mesh)).unwrap(),
                "{cmd}"
            );
        }
        assert_eq!(validate(&out_dir), (0, 0, vec![]), "{cmd}");
        assert_eq!(mesh_sources(&out_dir), stored, "{cmd}");
    }
    // In place: the mesh files stay (and are not truncated by copying onto themselves).
    let packed = dir.path().join("packed");
    let p = packed.to_str().unwrap();
    assert_eq!(pomc(&["unpack", p, "-o", p, "--quiet"]).status.code(), Some(0));
    assert_eq!(validate(&packed), (0, 0, vec![]));
    assert_eq!(mesh_sources(&packed), stored);

    // convert changes every pixel: the references go, the result validates.
    let cube = dir.path().join("cube");
    let out = pomc(&["convert", s, "-o", cube.to_str().unwrap(), "--to", "cube", "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!std::fs::read_to_string(cube.join("panorama.xml")).unwrap().contains("<Mesh"));
    assert_eq!(validate(&cube), (0, 0, vec![]));

    // Broken meshes: a warning each, with its own code; the panorama stays valid.
    std::fs::write(src.join("room.pomcmesh"), b"POMCMESH\x01garbage").unwrap();
    std::fs::remove_file(src.join("objects.pomcmesh")).unwrap();
    let (errors, warnings, mut codes) = validate(&src);
    codes.sort();
    assert_eq!((errors, warnings), (0, 2));
    assert_eq!(codes, ["MESH_NOT_FOUND", "MESH_UNREADABLE"]);
    // A mesh file outside the directory is a manifest error, like a layer file.
    let xml = std::fs::read_to_string(src.join("panorama.xml")).unwrap();
    std::fs::write(
        src.join("panorama.xml"),
        xml.replace("file=\"room.pomcmesh\"", "file=\"../../etc/passwd\""),
    )
    .unwrap();
    let (errors, _, codes) = validate(&src);
    assert!(errors >= 1 && codes.contains(&"MANIFEST_FILE_NAME_UNSAFE".to_string()), "{codes:?}");
}

#[test]
fn mesh_errors_are_coded() {
    let out = pomc(&["mesh", "/nonexistent/pano", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let dir = tempfile::tempdir().unwrap();
    let out = pomc(&["mesh", dir.path().to_str().unwrap(), "--max-error", "NaN"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn simplification_is_the_default_and_never_changes_the_stored_encoding() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path(), MappingKind::Cube3x2, 192, 128);
    let d = dir.path().to_str().unwrap();
    let run = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["mesh", d, "--layer", "0", "--json", "--store"];
        args.extend_from_slice(extra);
        let out = pomc(&args);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let simplified = run(&[]);
    let stored_simplified = std::fs::read(dir.path().join("room.pomcmesh")).unwrap();
    let collapsed = run(&["--no-greedy"]);
    let stored_collapsed = std::fs::read(dir.path().join("room.pomcmesh")).unwrap();
    let raw = run(&["--no-simplify"]);
    let stored_raw = std::fs::read(dir.path().join("room.pomcmesh")).unwrap();
    assert_eq!(stored_simplified, stored_raw, "--store writes the quadtree encoding either way");
    assert_eq!(stored_collapsed, stored_raw);
    assert_eq!(simplified["greedy_faces"].as_u64(), Some(6));
    assert_eq!(collapsed["greedy_faces"].as_u64(), Some(0));
    let count = |v: &serde_json::Value, k: &str| v[k].as_u64().unwrap();
    let nq = count(&collapsed, "quadtree_triangles");
    assert_eq!(count(&raw, "triangles"), nq);
    assert!(raw["simplify"].is_null() && collapsed["simplify"]["collapses"].as_u64().unwrap() > 0);
    let (ng, nc) = (count(&simplified, "triangles"), count(&collapsed, "triangles"));
    assert!(nc * 4 < nq, "{nc} of {nq}");
    // With the default 20° cap on this small canvas greedy insertion gives about as many triangles
    // (766 vs 764 measured); on large canvases fewer (6×1024²: 642 vs 768). It must stay close.
    assert!(ng * 4 <= nc * 5, "greedy {ng} vs collapses {nc}");
    for v in [&simplified, &collapsed, &raw] {
        assert_eq!(v["error"]["unhit"].as_u64().unwrap(), 0);
        assert!(v["error"]["max_rel"].as_f64().unwrap() <= 0.005 * (1.0 + 1e-6), "{v}");
    }
}

/// `pomc build` of the outdoor fixture (ground, objects, a building, sky at infinity): layer 0 is the
/// infinity layer.
fn sky_pano(dir: &Path, width: usize) -> PathBuf {
    let m = AnyMapping::new(MappingKind::Equirect, width, width / 2).unwrap();
    let input = dir.join("rgbd");
    pomc_fixtures::layers::write_scene_rgbd(&input, &m, &pomc_fixtures::Scene::open_sky()).unwrap();
    let pano = dir.join("pano");
    let (colour, depth) = (input.join("colour.png"), input.join("depth.exr"));
    let out = pomc(&[
        "build",
        "--colour",
        colour.to_str().unwrap(),
        "--depth",
        depth.to_str().unwrap(),
        "-o",
        pano.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let manifest = Panorama::open(&pano).unwrap().manifest;
    assert_eq!(manifest.layers[0].role, Some(Role::Infinity));
    assert!(manifest.layers.len() >= 2);
    pano
}

fn mesh_json(pano: &Path, out_path: &Path) -> Value {
    let out =
        pomc(&["mesh", pano.to_str().unwrap(), "-o", out_path.to_str().unwrap(), "--json", "--no-metric"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The manifest's layer names in painter's order.
fn painter_names(pano: &Path) -> Vec<String> {
    let m = Panorama::open(pano).unwrap().manifest;
    m.painter_order().into_iter().map(|k| m.layers[k].name.clone().unwrap()).collect()
}

/// sRGB transfer function to 8 bits, written independently of the exporter's.
fn srgb_byte(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0) as f64;
    let s = if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0).round() as u8
}

#[test]
fn outdoor_scene_glb_has_every_layer_and_a_sky_dome() {
    let dir = tempfile::tempdir().unwrap();
    let pano = sky_pano(dir.path(), 512);
    let glb_path = dir.path().join("scene.glb");
    let v = mesh_json(&pano, &glb_path);
    let names = painter_names(&pano);
    let layers = v["layers"].as_array().unwrap();
    assert_eq!(layers.iter().map(|l| l["name"].as_str().unwrap()).collect::<Vec<_>>(), names);
    let sum: u64 = layers.iter().map(|l| l["triangles"].as_u64().unwrap()).sum();
    assert_eq!(v["triangles"].as_u64(), Some(sum));
    // Layers with no triangles (a few isolated pixels, as the self-occlusion cut of §7 can leave) are
    // skipped with a note; every other layer is a node.
    let skipped: Vec<&str> = v["skipped"].as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect();
    for l in layers {
        let name = l["name"].as_str().unwrap();
        assert_eq!(l["triangles"].as_u64().unwrap() == 0, skipped.contains(&name), "{v}");
    }
    assert!(skipped.len() < names.len() / 2, "{v}");
    let meshed: Vec<String> = names.iter().filter(|n| !skipped.contains(&n.as_str())).cloned().collect();
    // The documented default radius: 10 × the farthest finite depth (the layers' depth ranges).
    let manifest = Panorama::open(&pano).unwrap().manifest;
    let far = manifest.layers.iter().filter_map(|l| l.depth_range).map(|r| r.1 as f64).fold(0.0, f64::max);
    let radius = v["sky_radius"].as_f64().unwrap();
    assert!((radius - 10.0 * far).abs() <= 1e-6 * radius, "{radius} vs 10 × {far}");

    let glb = std::fs::read(&glb_path).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin = &glb[20 + json_len + 8..];
    let nodes = doc["nodes"].as_array().unwrap();
    assert_eq!(nodes.iter().map(|n| n["name"].as_str().unwrap()).collect::<Vec<_>>(), meshed);
    assert_eq!(doc["scenes"][0]["nodes"], serde_json::json!((0..meshed.len()).collect::<Vec<_>>()));
    let view = |index: &Value| -> &[u8] {
        let bv = &doc["bufferViews"][index.as_u64().unwrap() as usize];
        let off = bv["byteOffset"].as_u64().unwrap() as usize;
        &bin[off..off + bv["byteLength"].as_u64().unwrap() as usize]
    };
    // Node 0 is the sky dome: every vertex at the radius from the centre (identity LocalToWorld).
    assert_eq!(nodes[0]["extras"]["sky_radius"].as_f64(), Some(radius));
    let prim = &doc["meshes"][nodes[0]["mesh"].as_u64().unwrap() as usize]["primitives"][0];
    let pos = &doc["accessors"][prim["attributes"]["POSITION"].as_u64().unwrap() as usize];
    let data = view(&pos["bufferView"]);
    let n = pos["count"].as_u64().unwrap() as usize;
    let mut top = f64::NEG_INFINITY;
    for p in data[..n * 12].chunks(12) {
        let c: Vec<f64> = p.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap()) as f64).collect();
        let r = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        assert!((r - radius).abs() <= 1e-5 * radius, "dome vertex at {r}, radius {radius}");
        top = top.max(c[1]);
    }
    assert!(top > 0.99 * radius, "the dome reaches the zenith (glTF +Y)");
    // Its texture is the infinity layer's colour, sRGB-encoded.
    let material = &doc["materials"][prim["material"].as_u64().unwrap() as usize];
    let texture = &doc["textures"]
        [material["pbrMetallicRoughness"]["baseColorTexture"]["index"].as_u64().unwrap() as usize];
    let png = view(&doc["images"][texture["source"].as_u64().unwrap() as usize]["bufferView"]);
    let tex = image::load_from_memory(png).unwrap().to_rgb8();
    let sky = Panorama::open(&pano).unwrap().read_layer(0, &Default::default()).unwrap();
    // The sky goes round the circle, from the zenith down: full width, cropped to the rows it uses.
    assert_eq!(tex.width() as usize, sky.width);
    assert!(
        tex.height() as usize > sky.height / 2 && (tex.height() as usize) < sky.height,
        "{}",
        tex.height()
    );
    let red = &sky.channel("R").unwrap().data;
    let mut distinct = 0;
    for i in (0..sky.width * tex.height() as usize).step_by(97) {
        let (x, y) = ((i % sky.width) as u32, (i / sky.width) as u32);
        assert_eq!(tex.get_pixel(x, y)[0], srgb_byte(red[i]), "pixel {x},{y}: linear {}", red[i]);
        distinct += (srgb_byte(red[i]) as i32 - (red[i].clamp(0.0, 1.0) * 255.0).round() as i32).abs().min(1);
    }
    assert!(distinct > 10, "the sample checks the transfer function, not only 0 and 1");

    let Ok(modules) = std::env::var("POMC_GLTF_VALIDATOR") else { return };
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../tools/gltf_validate.mjs");
    let out = Command::new("node")
        .arg(script)
        .arg(&glb_path)
        .env("POMC_GLTF_VALIDATOR", &modules)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&out.stdout);
    eprintln!("glTF-Validator on the outdoor scene: {report}");
    assert!(
        out.status.success(),
        "glTF-Validator reports errors:\n{report}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: Value = serde_json::from_str(&report).unwrap();
    assert_eq!(r["numErrors"].as_u64(), Some(0));
}

#[test]
fn outdoor_scene_obj_and_ply_hold_every_layer() {
    let dir = tempfile::tempdir().unwrap();
    let pano = sky_pano(dir.path(), 256);
    let names = painter_names(&pano);
    let count = |v: &Value, k: &str| v[k].as_u64().unwrap() as usize;

    let obj_path = dir.path().join("scene.obj");
    let v = mesh_json(&pano, &obj_path);
    let obj = std::fs::read_to_string(&obj_path).unwrap();
    let lines = |prefix: &str| obj.lines().filter(|l| l.starts_with(prefix)).count();
    assert_eq!(lines("v "), count(&v, "exported_vertices"));
    assert_eq!(lines("vt "), count(&v, "exported_vertices"));
    assert_eq!(lines("f "), count(&v, "triangles"));
    let objects: Vec<&str> = obj.lines().filter_map(|l| l.strip_prefix("o ")).collect();
    assert_eq!(objects, names);
    assert_eq!(lines("usemtl "), names.len());
    let mtllib = obj.lines().find_map(|l| l.strip_prefix("mtllib ")).unwrap();
    let mtl = std::fs::read_to_string(dir.path().join(mtllib)).unwrap();
    let textures: Vec<&str> = mtl.lines().filter_map(|l| l.strip_prefix("map_Kd ")).collect();
    assert_eq!(textures.len(), names.len());
    // Each texture holds what its layer's triangles use (spec §8.9), so none is larger than the
    // 256×128 canvas, and the objects' are smaller.
    let sizes: Vec<(u32, u32)> =
        textures.iter().map(|t| image::image_dimensions(dir.path().join(t)).unwrap()).collect();
    assert!(sizes.iter().all(|&(w, h)| w <= 256 && h <= 128), "{sizes:?}");
    assert!(sizes.iter().any(|&(w, h)| w * h < 256 * 128 / 2), "{sizes:?}");
    // Every face index is within its file's vertices.
    let nv = count(&v, "exported_vertices");
    for l in obj.lines().filter_map(|l| l.strip_prefix("f ")) {
        for c in l.split(' ') {
            let i: usize = c.split('/').next().unwrap().parse().unwrap();
            assert!((1..=nv).contains(&i));
        }
    }

    let ply_path = dir.path().join("scene.ply");
    let v = mesh_json(&pano, &ply_path);
    let ply = std::fs::read(&ply_path).unwrap();
    let end = ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let head = String::from_utf8_lossy(&ply[..end]).to_string();
    let element = |what: &str| -> usize {
        head.split(&format!("element {what} ")).nth(1).unwrap().split('\n').next().unwrap().parse().unwrap()
    };
    let (nv, nf) = (element("vertex"), element("face"));
    assert_eq!(nv, count(&v, "exported_vertices"));
    assert_eq!(nf, count(&v, "triangles"));
    assert!(head.contains("property int layer\n"), "{head}");
    assert_eq!(ply.len(), end + nv * 27 + nf * 13);
    let mut seen = std::collections::BTreeSet::new();
    for k in 0..nv {
        let o = end + k * 27 + 23;
        seen.insert(i32::from_le_bytes(ply[o..o + 4].try_into().unwrap()));
    }
    assert_eq!(seen.len(), names.len(), "vertices of every layer");
}

/// The JSON chunk of a `.glb`.
fn glb_json(glb: &[u8]) -> Value {
    assert_eq!(&glb[..4], b"glTF");
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    serde_json::from_slice(&glb[20..20 + len]).unwrap()
}

#[test]
fn view_exports_a_self_contained_site_of_every_layer_and_the_sky() {
    let dir = tempfile::tempdir().unwrap();
    let pano = sky_pano(dir.path(), 256);
    let site = dir.path().join("site");
    // A stale file from an earlier export must not survive: the site is replaced as a whole.
    std::fs::create_dir_all(&site).unwrap();
    std::fs::write(site.join("stale.txt"), "old").unwrap();
    let out = pomc(&["view", pano.to_str().unwrap(), "--export", site.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(!site.join("stale.txt").exists());
    let mut bytes = 0;
    for e in walk(&site) {
        bytes += std::fs::metadata(&e).unwrap().len();
    }
    assert_eq!(v["bytes"].as_u64(), Some(bytes));

    // Nothing is fetched from elsewhere: every script the page names is in the site.
    let html = std::fs::read_to_string(site.join("index.html")).unwrap();
    assert!(!html.contains("http://") && !html.contains("https://"), "{html}");
    for path in ["vendor/three/build/three.module.min.js", "pomc-viewer.js"] {
        assert!(html.contains(path), "{path}");
    }
    for path in ["vendor/three/build/three.core.min.js", "vendor/three/LICENSE", "scene.glb", "pano.json"] {
        assert!(site.join(path).is_file(), "{path}");
    }
    let js = std::fs::read_to_string(site.join("pomc-viewer.js")).unwrap();
    assert!(!js.contains("http://") && !js.contains("https://"));

    let manifest = Panorama::open(&pano).unwrap().manifest;
    let info: Value = serde_json::from_slice(&std::fs::read(site.join("pano.json")).unwrap()).unwrap();
    assert_eq!(info["freedom_radius"].as_f64(), Some(manifest.freedom_radius));
    assert_eq!(info["mapping"]["kind"], "equirect");

    // One node per drawn piece: the sky dome of the infinity layer first, then every layer with
    // triangles in painter's order; each samples its layer by direction (TEXCOORD_1 canvas uv).
    let glb = std::fs::read(site.join("scene.glb")).unwrap();
    let doc = glb_json(&glb);
    let nodes = doc["nodes"].as_array().unwrap();
    let layers = info["layers"].as_array().unwrap();
    assert_eq!(nodes.len(), layers.len());
    assert!(nodes[0]["extras"]["sky_radius"].as_f64().unwrap() > 0.0);
    assert_eq!(nodes[0]["extras"]["layer"].as_u64(), Some(0));
    let order: Vec<u64> = nodes[1..].iter().map(|n| n["extras"]["layer"].as_u64().unwrap()).collect();
    let painter: Vec<u64> =
        manifest.painter_order().into_iter().map(|k| k as u64).filter(|&k| k != 0).collect();
    assert_eq!(order, painter);
    for m in doc["meshes"].as_array().unwrap() {
        assert!(m["primitives"][0]["attributes"]["TEXCOORD_1"].is_u64(), "{m}");
    }
    let Ok(modules) = std::env::var("POMC_GLTF_VALIDATOR") else { return };
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../tools/gltf_validate.mjs");
    let out = Command::new("node")
        .arg(script)
        .arg(site.join("scene.glb"))
        .env("POMC_GLTF_VALIDATOR", &modules)
        .output()
        .unwrap();
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["numErrors"].as_u64(), Some(0), "{r}");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// A GET over plain HTTP/1.0: status line, `Content-Type` and body.
fn http_get(port: u16, path: &str) -> (String, String, Vec<u8>) {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).unwrap();
    let split = buf.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&buf[..split]).to_string();
    let status = head.lines().next().unwrap().to_string();
    let ctype = head
        .lines()
        .find_map(|l| l.to_ascii_lowercase().strip_prefix("content-type:").map(|v| v.trim().to_string()))
        .unwrap_or_default();
    (status, ctype, buf[split + 4..].to_vec())
}

#[test]
fn view_serves_the_site_on_localhost_and_reports_a_busy_port() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    room(dir.path(), MappingKind::Cube3x2, 96, 64);
    let pano = dir.path().join("panorama.xml");
    let mut child = Command::new(env!("CARGO_BIN_EXE_pomc"))
        .args(["view", pano.to_str().unwrap(), "--port", "0", "--json"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The JSON summary (with the URL) is printed once the server listens.
    let mut stdout = child.stdout.take().unwrap();
    let mut text = String::new();
    let mut byte = [0u8; 1];
    let summary: Value = loop {
        assert_eq!(stdout.read(&mut byte).unwrap(), 1, "pomc view ended early: {text}");
        text.push(byte[0] as char);
        if byte[0] == b'}' {
            if let Ok(v) = serde_json::from_str(&text) {
                break v;
            }
        }
    };
    let url = summary["url"].as_str().unwrap();
    let port: u16 = url.trim_start_matches("http://127.0.0.1:").trim_end_matches('/').parse().unwrap();
    let (status, ctype, body) = http_get(port, "/");
    assert!(status.contains("200"), "{status}");
    assert!(ctype.starts_with("text/html"), "{ctype}");
    assert!(String::from_utf8_lossy(&body).contains("pomc-viewer.js"));
    let (status, ctype, body) = http_get(port, "/pano.json?cache=1");
    assert!(status.contains("200") && ctype == "application/json", "{status} {ctype}");
    let info: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(info["mapping"]["kind"], "cube3x2");
    assert_eq!(info["mapping"]["faces"].as_array().unwrap().len(), 6);
    let (status, ctype, body) = http_get(port, "/scene.glb");
    assert!(status.contains("200") && ctype == "model/gltf-binary", "{status} {ctype}");
    assert_eq!(&body[..4], b"glTF");
    let (status, ..) = http_get(port, "/../panorama.xml");
    assert!(status.contains("404"), "{status}");

    // A second server on the same port: a clear error with a code, exit 2.
    let busy = pomc(&["view", pano.to_str().unwrap(), "--port", &port.to_string(), "--json"]);
    child.kill().unwrap();
    let _ = child.wait();
    assert_eq!(busy.status.code(), Some(2));
    let e: Value = serde_json::from_slice(&busy.stdout).unwrap();
    assert_eq!(e["error"]["code"], "VIEW_SERVE_FAILED", "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("--port"));
    // Serving options make no sense with --export: refused, not ignored.
    let both = pomc(&["view", pano.to_str().unwrap(), "--export", "site", "--open", "--json"]);
    assert_eq!(both.status.code(), Some(2));
    assert_eq!(serde_json::from_slice::<Value>(&both.stdout).unwrap()["error"]["code"], "CLI_USAGE");
}
