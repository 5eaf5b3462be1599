//! `pomc render` end to end on the room fixture: outputs written, JSON figures, typed failures.

use std::path::Path;

use pomc::mapping::{AnyMapping, MappingKind};
use pomc::panorama::{self, SaveOptions};
use pomc_fixtures::layers::{render_on, room_manifest, to_layer};
use pomc_fixtures::Scene;

use crate::pomc;

/// The two-layer room, centre 1.2 m above the world origin, stored unpacked.
fn room(dir: &Path) {
    let m = AnyMapping::new(MappingKind::Equirect, 256, 128).unwrap();
    let r = render_on(&Scene::room(), &m);
    let layers = [to_layer(&r.background, false), to_layer(&r.objects, false)];
    let save = SaveOptions { pack: false, ..SaveOptions::default() };
    panorama::write_panorama(dir, &room_manifest(MappingKind::Equirect), &layers, &save).unwrap();
}

#[test]
fn render_writes_colour_depth_and_mask_with_json_figures() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let out = pomc(&[
        "render",
        dir.path().to_str().unwrap(),
        "-o",
        &p("view.png"),
        "--eye",
        "0,0.3,1.2",
        "--look-at",
        "2,0,0.4",
        "--size",
        "160x90",
        "--depth",
        &p("depth.exr"),
        "--mask",
        &p("mask.png"),
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(160), Some(90)));
    assert!(v["hole_ratio"].as_f64().unwrap() < 0.01, "{v}");
    assert!(v["stages"]["splat_s"].as_f64().is_some() && v["stages"]["total_s"].as_f64().is_some());
    for f in ["view.png", "depth.exr", "mask.png"] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    let png = image::open(dir.path().join("view.png")).unwrap();
    assert_eq!((png.width(), png.height()), (160, 90));

    // Equirect camera, EXR colour, default eye (the panorama centre).
    let out = pomc(&[
        "render",
        dir.path().to_str().unwrap(),
        "-o",
        &p("eq.exr"),
        "--camera",
        "equirect",
        "--size",
        "128x64",
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(dir.path().join("eq.exr").is_file());
}

#[test]
fn render_failures_are_typed() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let d = dir.path().to_str().unwrap();
    let o = dir.path().join("x.png");
    let o = o.to_str().unwrap();
    let code = |args: &[&str]| {
        let out = pomc(args);
        assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["error"]["code"].as_str().unwrap().to_string()
    };
    assert_eq!(code(&["render", d, "-o", o, "--fov", "200", "--json"]), "CLI_USAGE");
    assert_eq!(
        code(&["render", d, "-o", o, "--eye", "0,0,1.2", "--look-at", "0,0,1.2", "--json"]),
        "RENDER_BAD_CAMERA"
    );
    assert_eq!(
        code(&["render", d, "-o", o, "--camera", "equirect", "--size", "100x100", "--json"]),
        "RENDER_BAD_SIZE"
    );
    let bmp = dir.path().join("x.bmp");
    assert_eq!(
        code(&["render", d, "-o", bmp.to_str().unwrap(), "--size", "8x8", "--json"]),
        "RENDER_OUTPUT_FORMAT"
    );
    assert_eq!(code(&["render", "/nonexistent", "-o", o, "--json"]), "PANORAMA_NOT_FOUND");
}

#[test]
fn render_mesh_method_reports_stages_and_uses_stored_meshes() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let d = dir.path().to_str().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let view = p("mesh.png");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            d,
            "-o",
            &view,
            "--method",
            "mesh",
            "--eye",
            "0,0.3,1.2",
            "--look-at",
            "2,0,0.4",
            "--size",
            "160x90",
            "--json",
        ];
        args.extend_from_slice(extra);
        let out = pomc(&args);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let mask = p("mask.png");
    let v = render(&["--mask", &mask]);
    assert_eq!(v["method"], "mesh");
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(160), Some(90)));
    assert!(v["hole_ratio"].as_f64().unwrap() < 0.01, "{v}");
    for stage in ["read_s", "mesh_s", "raster_s", "compose_s", "write_s", "total_s"] {
        assert!(v["stages"][stage].as_f64().is_some(), "{stage} missing: {v}");
    }
    assert_eq!(v["mesh"]["sources"], serde_json::json!(["built", "built"]));
    assert!(v["mesh"]["triangles"].as_u64().unwrap() > 0);
    let holes = v["holes"].as_u64().unwrap();
    let m = image::open(dir.path().join("mask.png")).unwrap().to_luma8();
    assert_eq!(m.pixels().filter(|p| p.0[0] == 0).count() as u64, holes);

    // Stored quadtrees are decoded instead of rebuilt, and give the same image.
    let built = std::fs::read(&view).unwrap();
    for layer in ["0", "1"] {
        let out = pomc(&["mesh", d, "--layer", layer, "--store", "--no-metric", "--quiet"]);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let v = render(&[]);
    assert_eq!(v["mesh"]["sources"], serde_json::json!(["stored", "stored"]));
    assert_eq!(std::fs::read(&view).unwrap(), built);

    // A broken stored mesh is ignored with a warning (spec §8.1), never fatal.
    let stored: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pomcmesh"))
        .collect();
    assert_eq!(stored.len(), 2);
    std::fs::write(&stored[0], b"POMCMESH\x01garbage").unwrap();
    let v = render(&[]);
    let sources = v["mesh"]["sources"].as_array().unwrap();
    assert!(sources.contains(&serde_json::json!("built")) && sources.contains(&serde_json::json!("stored")));
    assert_eq!(v["mesh"]["warnings"].as_array().unwrap().len(), 1, "{v}");
    assert_eq!(std::fs::read(&view).unwrap(), built);

    // An unknown method is a usage error.
    let out = pomc(&["render", d, "-o", &view, "--method", "raytrace"]);
    assert_eq!(out.status.code(), Some(2));
}

/// A camera path renders one frame per line from one read (and one meshing) of the layers; each frame
/// is the very image a single render of that camera gives.
#[test]
fn camera_path_renders_every_frame_like_single_renders() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let pano = dir.path().to_str().unwrap().to_string();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    std::fs::write(
        p("path.txt"),
        "# eye look-at\n0,0,1.2 2,0,0.4\n\n0,0.3,1.2 2,0,0.4  # second\n-0.2,0,1.2\n",
    )
    .unwrap();
    for method in ["splat", "mesh"] {
        let out = pomc(&[
            "render",
            &pano,
            "-o",
            &p(&format!("{method}-##.png")),
            "--mask",
            &p(&format!("{method}-mask-##.png")),
            "--path",
            &p("path.txt"),
            "--size",
            "120x68",
            "--method",
            method,
            "--json",
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let frames = v["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 3, "{v}");
        assert!(v["stages"]["frame_median_s"].as_f64().unwrap() > 0.0);
        for k in 0..3 {
            assert!(dir.path().join(format!("{method}-0{k}.png")).is_file());
            assert!(dir.path().join(format!("{method}-mask-0{k}.png")).is_file());
        }
        let single = pomc(&[
            "render",
            &pano,
            "-o",
            &p(&format!("{method}-single.png")),
            "--eye",
            "0,0.3,1.2",
            "--look-at",
            "2,0,0.4",
            "--size",
            "120x68",
            "--method",
            method,
            "--quiet",
        ]);
        assert_eq!(single.status.code(), Some(0));
        let a = std::fs::read(dir.path().join(format!("{method}-01.png"))).unwrap();
        let b = std::fs::read(dir.path().join(format!("{method}-single.png"))).unwrap();
        assert!(a == b, "{method}: frame 1 differs from the single render of its camera");
    }
    // An output name without `#` and a malformed line are camera path errors that name the file.
    let out = pomc(&["render", &pano, "-o", &p("x.png"), "--path", &p("path.txt"), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["error"]["code"], "RENDER_CAMERA_PATH");
    std::fs::write(p("bad.txt"), "0,0,1.2\n0,0\n").unwrap();
    let out = pomc(&["render", &pano, "-o", &p("y-#.png"), "--path", &p("bad.txt")]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.txt: line 2"), "{err}");
    assert!(!dir.path().join("y-0.png").exists(), "nothing is rendered before the path is checked");
}
