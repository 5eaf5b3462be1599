//! `pomc mesh` end to end on the room fixture: JSON figures, the three export formats, `--store`.

use std::path::Path;
use std::process::{Command, Output};

use pomc::mapping::{AnyMapping, MappingKind};

fn pomc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pomc")).args(args).output().expect("pomc runs")
}

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
    let out = pomc(&["mesh", d, "--store", "--no-metric", "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let xml = std::fs::read_to_string(dir.path().join("panorama.xml")).unwrap();
    assert!(xml.contains("<Mesh file=\"room.pomcmesh\""), "{xml}");
    assert!(dir.path().join("room.pomcmesh").is_file());
    // Storing again replaces the reference instead of adding a second one.
    assert_eq!(pomc(&["mesh", d, "--store", "--no-metric", "--quiet"]).status.code(), Some(0));
    let xml = std::fs::read_to_string(dir.path().join("panorama.xml")).unwrap();
    assert_eq!(xml.matches("<Mesh").count(), 1);
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
        let mut args = vec!["mesh", d, "--json", "--store"];
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
