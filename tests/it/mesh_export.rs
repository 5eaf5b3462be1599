//! Export formats: PLY/OBJ structure, GLB structure, and (when `POMC_GLTF_VALIDATOR` points at an
//! `npm install gltf-validator` node_modules directory) the Khronos glTF-Validator with no errors.

use glam::DMat4;
use pomc::mapping::{AnyMapping, Cube3x2, Equirect};
use pomc::mesh::export::{self, Format};
use pomc::mesh::{self, MeshOptions};
use pomc_fixtures::layers::{render_on, to_layer};
use pomc_fixtures::Scene;

fn meshes() -> Vec<(AnyMapping, pomc::layer::LayerImage, mesh::LayerMesh)> {
    let maps = [
        AnyMapping::Cube(Cube3x2::new(96, 64).unwrap()),
        AnyMapping::Equirect(Equirect::new(96, 48).unwrap()),
    ];
    maps.into_iter()
        .flat_map(|m| {
            let r = render_on(&Scene::room(), &m);
            [to_layer(&r.background, false), to_layer(&r.objects, false)].map(|img| {
                let out = mesh::mesh_layer(&img, &m, &MeshOptions::quadtree()).unwrap();
                (m, img, out.mesh)
            })
        })
        .collect()
}

fn world() -> DMat4 {
    DMat4::from_translation(glam::DVec3::new(0.0, 0.0, 1.2))
        * DMat4::from_scale(glam::DVec3::new(-1.0, 1.0, 1.0))
}

#[test]
fn ply_and_obj_have_the_declared_counts() {
    for (_, img, m) in meshes() {
        let ply = export::to_bytes(&m, &img, Some(world()), Format::Ply).unwrap();
        let head = String::from_utf8_lossy(&ply[..400.min(ply.len())]).to_string();
        let end = head.find("end_header\n").unwrap() + "end_header\n".len();
        let nv: usize =
            head.split("element vertex ").nth(1).unwrap().split('\n').next().unwrap().parse().unwrap();
        let nf: usize =
            head.split("element face ").nth(1).unwrap().split('\n').next().unwrap().parse().unwrap();
        assert_eq!(nf, m.triangles.len());
        assert_eq!(ply.len(), end + nv * 23 + nf * 13);
        let obj = String::from_utf8(export::to_bytes(&m, &img, None, Format::Obj).unwrap()).unwrap();
        assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), m.triangles.len());
    }
}

/// OBJ is Y-up like glTF (importers take +Y as up): the room's 2.8 m height lies along y, its
/// 5.5 m depth (world y) along z.
#[test]
fn obj_is_y_up() {
    let (_, img, m) = meshes().swap_remove(0);
    let obj = String::from_utf8(export::to_bytes(&m, &img, Some(world()), Format::Obj).unwrap()).unwrap();
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for v in obj.lines().filter_map(|l| l.strip_prefix("v ")) {
        for (k, x) in v.split_whitespace().map(|x| x.parse::<f64>().unwrap()).enumerate() {
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
        }
    }
    let extent: Vec<f64> = (0..3).map(|k| hi[k] - lo[k]).collect();
    assert!((extent[1] - 2.8).abs() < 0.05, "height along y: {extent:?}");
    assert!((extent[2] - 5.5).abs() < 0.05, "depth along z: {extent:?}");
    // World z = 0 (the centre's floor offset aside) maps to y: the floor is at world z 1.2 − 1.2 = 0.
    assert!(lo[1].abs() < 0.05, "floor at y = {}", lo[1]);
}

#[test]
fn glb_is_well_formed_and_passes_the_khronos_validator() {
    let dir = tempfile::tempdir().unwrap();
    for (k, (_, img, m)) in meshes().into_iter().enumerate() {
        let glb = export::to_bytes(&m, &img, Some(world()), Format::Glb).unwrap();
        assert_eq!(&glb[..4], b"glTF");
        assert_eq!(u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize, glb.len());
        assert_eq!(glb.len() % 4, 0);
        let path = dir.path().join(format!("m{k}.glb"));
        std::fs::write(&path, &glb).unwrap();
        let Ok(modules) = std::env::var("POMC_GLTF_VALIDATOR") else { continue };
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tools/gltf_validate.mjs");
        let out = std::process::Command::new("node")
            .arg(script)
            .arg(&path)
            .env("POMC_GLTF_VALIDATOR", &modules)
            .output()
            .expect("node runs");
        let report = String::from_utf8_lossy(&out.stdout);
        eprintln!("glTF-Validator on {}: {report}", path.display());
        assert!(
            out.status.success(),
            "glTF-Validator reports errors:\n{report}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn unknown_extension_is_a_typed_error() {
    let e = Format::from_path(std::path::Path::new("x.stl")).unwrap_err();
    assert_eq!(e.code(), "MESH_EXPORT_FAILED");
}

#[test]
fn every_exported_triangle_samples_one_region_of_the_texture() {
    for (m, _, mesh) in meshes() {
        let e = export::prepare(&mesh, DMat4::IDENTITY, &|_| [0.0; 3]);
        let cube = matches!(m, AnyMapping::Cube(_));
        for t in &e.triangles {
            let uv = t.map(|i| e.uvs[i as usize]);
            let span = |k: usize| {
                let (a, b) =
                    uv.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |a, p| (a.0.min(p[k]), a.1.max(p[k])));
                b - a
            };
            // Within one cube face (a third by a half of the atlas), or a short step across the seam.
            let (su, sv) = if cube { (1.0 / 3.0, 0.5) } else { (0.25, 0.5) };
            assert!(span(0) <= su + 1e-6 && span(1) <= sv + 1e-6, "triangle spans {uv:?}");
        }
    }
}

#[test]
fn a_scene_leaves_empty_layers_out_and_fails_only_when_all_are() {
    let mut all = meshes();
    let (_, img, m) = all.remove(3);
    let empty = mesh::LayerMesh { triangles: Vec::new(), ..m.clone() };
    let layer = |name: &str, mesh| export::SceneLayer {
        name: name.into(),
        index: 0,
        mesh,
        image: &img,
        sky_radius: None,
    };
    let (files, vertices) =
        export::scene_files(&[layer("empty", &empty), layer("full", &m)], None, Format::Obj, "s").unwrap();
    let obj = String::from_utf8(files[0].1.clone()).unwrap();
    assert!(obj.contains("o full\n") && !obj.contains("o empty"), "{obj}");
    assert_eq!(vertices[0], 0);
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), vertices[1]);
    assert_eq!(files.iter().map(|f| f.0.as_str()).collect::<Vec<_>>(), ["s.obj", "s.mtl", "s_full.png"]);
    for format in [Format::Ply, Format::Obj, Format::Glb] {
        let e = export::scene_files(&[layer("empty", &empty)], None, format, "s").unwrap_err();
        assert_eq!(e.code(), "MESH_EXPORT_FAILED");
    }
}

#[test]
fn the_sky_goes_on_a_dome_of_the_given_radius() {
    let m = AnyMapping::Equirect(Equirect::new(64, 32).unwrap());
    let mut img = pomc::layer::LayerImage::new(64, 32);
    let z: Vec<f32> = (0..64 * 32).map(|i| if i < 64 * 16 { f32::INFINITY } else { -1.0 }).collect();
    img.set_channel("Z", pomc::layer::SampleType::F32, z);
    assert!(mesh::has_sky(&img));
    assert_eq!(mesh::default_sky_radius([&img]), mesh::SKY_RADIUS_FALLBACK);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e300] {
        assert_eq!(mesh::sky_at(&img, bad).unwrap_err().code(), "MESH_PARAMS_INVALID");
    }
    let dome = mesh::sky_at(&img, 250.0).unwrap().unwrap();
    let out = mesh::mesh_layer(&dome, &m, &MeshOptions::quadtree()).unwrap().mesh;
    assert!(!out.triangles.is_empty());
    for p in &out.positions {
        assert!((p.length() - 250.0).abs() < 1e-9 && p.z >= 0.0, "{p}");
    }
    // Without an infinite sample there is no dome; finite depths set the default radius.
    let (_, room, _) = &meshes()[0];
    assert!(mesh::sky_at(room, 250.0).unwrap().is_none());
    let far = room.depth().unwrap().iter().copied().filter(|d| d.is_finite()).fold(0.0f32, f32::max);
    assert_eq!(mesh::default_sky_radius([room, &img]), 10.0 * far as f64);
}

/// Textures are cropped to what each mesh uses (spec §8.9): a sparse layer's texture is a fraction
/// of its canvas, and every vertex still reads its own pixel's colour from the cropped texture.
#[test]
fn textures_are_cropped_and_still_address_each_vertex_pixel() {
    for (k, (_, img, mesh)) in meshes().into_iter().enumerate() {
        let rgb8 = export::colour_rgb8(&img);
        let w = img.width;
        let code = |id: u32| {
            let i = 3 * id as usize;
            [rgb8[i], rgb8[i + 1], rgb8[i + 2]]
        };
        // Vertex "colour" = its source pixel's id, to look its code up after cropping.
        let full = export::prepare(&mesh, DMat4::IDENTITY, &|id| [id as f32, 0.0, 0.0]);
        let mut e = full.clone();
        let t = export::texture::crop(&img, &mut e);
        // How many vertices read their own pixel's code from `(uvs, texture)` (nearest texel).
        let reads = |uvs: &[[f32; 2]], tex: &[u8], tw: usize, th: usize| {
            let (mut same, mut checked) = (0usize, 0usize);
            for (uv, c) in uvs.iter().zip(&e.colours) {
                let id = c[0] as u32;
                if id as usize >= img.width * img.height {
                    continue; // a pole vertex
                }
                let x = ((uv[0].rem_euclid(1.0) * tw as f32) as usize).min(tw - 1);
                let y = ((uv[1] * th as f32) as usize).min(th - 1);
                let i = 3 * (y * tw + x);
                checked += 1;
                same += usize::from(tex[i..i + 3] == code(id));
            }
            (same, checked)
        };
        let (same, checked) = reads(&e.uvs, &t.rgb, t.width as usize, t.height as usize);
        let uncropped = reads(&full.uvs, &rgb8, w, img.height);
        // Exactly the vertices that read their pixel before (nearly all: vertices of the strips
        // joining cube faces read the face they are drawn on, seam and pole copies a neighbour).
        assert_eq!((same, checked), uncropped, "case {k}: {}x{} wraps {}", t.width, t.height, t.wraps);
        assert!(same as f64 >= 0.95 * checked as f64, "case {k}: {same} of {checked}");
        let fraction = (t.width * t.height) as f64 / (w * img.height) as f64;
        eprintln!(
            "case {k}: texture {}x{} = {:.3} of the canvas, wraps {}",
            t.width, t.height, fraction, t.wraps
        );
        // The room's objects: below the centre and all round it (the equirect crop keeps every column).
        if k % 2 == 1 {
            assert!(fraction < 0.75, "case {k}: objects layer texture {fraction:.3} of its canvas");
        }
    }
}
