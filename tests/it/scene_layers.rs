//! `pomc scene` (thesis 6.3.2) against the analytic multi-hit truth: exact depths, the truth's
//! layer assignment, every surface an eye in the freedom radius sees (checked with eyes of its
//! own, not the tracer's), nothing most eyes cannot see; and a glTF with textures read back.

use glam::{DMat4, DVec3};
use pomc::layer::LayerImage;
use pomc::manifest::Role;
use pomc::mapping::{AnyMapping, Equirect, Mapping};
use pomc::scene::{self, BakeSettings};
use pomc_fixtures::{Scene, Shape};

fn bake(path: &std::path::Path, s: &BakeSettings) -> scene::Baked {
    let tri = scene::load::read(path, s.center, s.max_triangles).unwrap();
    scene::bake(&tri, s, &|_| {}).unwrap()
}

/// Layers (role, image) holding depth within `rel` of `t` at pixel `p`.
fn layers_at<'a>(layers: &'a [(Role, &'a LayerImage)], p: usize, t: f64, rel: f64) -> Vec<Role> {
    layers
        .iter()
        .filter(|(_, img)| {
            let z = img.channel("Z").unwrap().data[p] as f64;
            z > 0.0 && (z - t).abs() <= rel * t
        })
        .map(|(r, _)| *r)
        .collect()
}

/// Deterministic eyes spread through the ball of radius `r` (a Fibonacci sphere at three radii).
fn truth_eyes(r: f64) -> Vec<DVec3> {
    let n = 64;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    [1.0, 0.75, 0.4]
        .iter()
        .flat_map(|&f| {
            (0..n).map(move |i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let s = (1.0 - z * z).sqrt();
                let a = golden * i as f64;
                DVec3::new(s * a.cos(), s * a.sin(), z) * r * f
            })
        })
        .collect()
}

#[test]
fn analytic_scenes_give_exact_depths_and_the_truths_layers() {
    for name in ["room", "near-far", "sky"] {
        // Boxes only: their triangles are the analytic surfaces exactly.
        let mut truth = Scene::by_name(name).unwrap();
        truth.objects.retain(|s| matches!(s, Shape::Box(_)));
        check_scene(name, &truth);
    }
}

fn check_scene(name: &str, truth: &Scene) {
    let dir = tempfile::tempdir().unwrap();
    let (obj, mtl) = pomc_fixtures::obj::to_obj(truth, 8, 1000.0, "s.mtl");
    std::fs::write(dir.path().join("s.obj"), obj).unwrap();
    std::fs::write(dir.path().join("s.mtl"), mtl).unwrap();
    let s = BakeSettings { width: 256, samples: 1, ..BakeSettings::default() };
    let baked = bake(&dir.path().join("s.obj"), &s);
    let layers: Vec<(Role, &LayerImage)> = baked.layers.iter().map(|l| (l.role, &l.image)).collect();
    let sky =
        layers.iter().find(|(r, _)| *r == Role::Infinity).map(|(_, img)| &img.channel("Z").unwrap().data);

    let m = Equirect::new(256, 128).unwrap();
    let eyes = truth_eyes(s.freedom_radius);
    let (mut first, mut first_ok, mut seen, mut seen_ok, mut worst) = (0, 0, 0, 0, 0f64);
    let (mut unseen, mut unseen_kept) = (0, 0);
    for j in 0..m.height() {
        for i in 0..m.width() {
            let p = j * m.width() + i;
            let d = m.pixel_dir(i, j);
            let hits = truth.hits(DVec3::ZERO, d);
            for (k, h) in hits.iter().enumerate() {
                // The OBJ's open ground ends 1 km out; the analytic one does not.
                if h.t > 500.0 {
                    if k == 0 && h.t.is_infinite() {
                        first += 1;
                        first_ok += usize::from(sky.is_some_and(|z| z[p] == f32::INFINITY));
                    }
                    continue;
                }
                let point = d * h.t;
                let want = if h.object == 0 { Role::Background } else { Role::Object };
                let found = layers_at(&layers, p, h.t, 1e-5);
                if k == 0 {
                    first += 1;
                    first_ok += usize::from(found == [want]);
                    if found == [want] {
                        let err = layers
                            .iter()
                            .filter(|(r, _)| *r == want)
                            .map(|(_, img)| (img.channel("Z").unwrap().data[p] as f64 - h.t).abs() / h.t)
                            .fold(f64::INFINITY, f64::min);
                        worst = worst.max(err);
                    }
                    continue;
                }
                // Behind the first hit (the room behind objects, an object's sides seen from
                // its back by the centre): is it seen from an eye of the ball?
                let visible = eyes.iter().any(|&e| {
                    let to = point - e;
                    truth.hits(e, to).first().is_some_and(|f| (f.t - to.length()).abs() < 1e-6 * to.length())
                });
                if visible {
                    seen += 1;
                    seen_ok += usize::from(found.contains(&want));
                    if !found.contains(&want) && std::env::var_os("SCENE_DEBUG").is_some() {
                        eprintln!(
                            "missing {name} px ({i},{j}) k {k} obj {} t {:.3} n {:?} found {found:?}",
                            h.object, h.t, h.normal
                        );
                    }
                } else if h.object == 0 {
                    unseen += 1;
                    unseen_kept += usize::from(!found.is_empty());
                }
            }
        }
    }
    eprintln!("{name}: first {first_ok}/{first}, seen {seen_ok}/{seen}, unseen kept {unseen_kept}/{unseen}, worst {worst:e}");
    // Rays through a box edge may meet the edge's other side: a few pixels.
    assert!(
        first_ok as f64 >= 0.998 * first as f64,
        "{name}: first hits in the truth's layer: {first_ok} of {first}"
    );
    assert!(worst <= 1e-5, "{name}: depth error {worst:e} relative");
    assert!(seen > 100, "{name}: the test must see surfaces behind the first ({seen})");
    assert!(
        seen_ok as f64 >= 0.995 * seen as f64,
        "{name}: hidden hits seen from the ball: {seen_ok} of {seen}"
    );
    // What no eye sees (the floor under the boxes) is left out, but for a margin at its edge.
    assert!(
        unseen > 100 && (unseen_kept as f64) < 0.4 * unseen as f64,
        "{name}: kept {unseen_kept} of {unseen} unseen"
    );
}

#[test]
fn a_gltf_with_textures_comes_back_as_its_layer() {
    // The analytic room's background, meshed and exported as a textured GLB (+Y up, its centre
    // 1.2 m up), traced again from that centre: the same depths and colours.
    let m = AnyMapping::Equirect(Equirect::new(128, 64).unwrap());
    let r = pomc_fixtures::layers::render_on(&Scene::room(), &m);
    let img = pomc_fixtures::layers::to_layer(&r.background, false);
    let mesh = pomc::mesh::mesh_layer(&img, &m, &pomc::mesh::MeshOptions::quadtree()).unwrap().mesh;
    let centre = DVec3::new(0.3, -0.2, 1.2);
    let glb = pomc::mesh::export::to_bytes(
        &mesh,
        &img,
        Some(DMat4::from_translation(centre)),
        pomc::mesh::export::Format::Glb,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("room.glb");
    std::fs::write(&path, glb).unwrap();
    let s = BakeSettings { width: 128, samples: 1, center: centre, ..BakeSettings::default() };
    let baked = bake(&path, &s);
    let back = baked.layers.iter().find(|l| l.role == Role::Background).unwrap();
    let (z0, z1) = (&img.channel("Z").unwrap().data, &back.image.channel("Z").unwrap().data);
    let mut depth_err: Vec<f64> =
        z0.iter().zip(z1).map(|(&a, &b)| ((a - b) as f64 / a as f64).abs()).collect();
    depth_err.sort_by(f64::total_cmp);
    let median = depth_err[depth_err.len() / 2];
    assert!(median < 1e-3, "median relative depth error {median}");
    let mut colour_err: Vec<f64> = ["R", "G", "B"]
        .iter()
        .flat_map(|c| {
            let (a, b) = (&img.channel(c).unwrap().data, &back.image.channel(c).unwrap().data);
            a.iter().zip(b.iter()).map(|(&x, &y)| (x - y).abs() as f64).collect::<Vec<_>>()
        })
        .collect();
    colour_err.sort_by(f64::total_cmp);
    let median = colour_err[colour_err.len() / 2];
    assert!(median < 0.01, "median colour error {median} (sRGB textures decoded to linear)");
}

#[test]
fn a_bad_scene_is_a_coded_error() {
    let dir = tempfile::tempdir().unwrap();
    let s = BakeSettings::default();
    let read = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        scene::load::read(&p, DVec3::ZERO, s.max_triangles).map(|_| ()).unwrap_err()
    };
    assert_eq!(pomc::Error::from(read("a.ply", "ply")).code(), "SCENE_UNSUPPORTED");
    assert_eq!(pomc::Error::from(read("b.obj", "v 0 0 0\nv 1 0 0\n")).code(), "SCENE_EMPTY");
    assert_eq!(pomc::Error::from(read("c.gltf", "{not json")).code(), "SCENE_UNREADABLE");
    // An attribute naming an accessor that does not exist (the `gltf` crate's validation indexes it).
    let bad_accessor =
        r#"{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 99}}]}]}"#;
    assert_eq!(pomc::Error::from(read("e.gltf", bad_accessor)).code(), "SCENE_UNREADABLE");
    let big = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\n";
    let p = dir.path().join("d.obj");
    std::fs::write(&p, big).unwrap();
    let e = scene::load::read(&p, DVec3::ZERO, 1).unwrap_err();
    assert_eq!(pomc::Error::from(e).code(), "SCENE_TOO_LARGE");
    let bad = BakeSettings { width: 101, ..BakeSettings::default() };
    assert_eq!(pomc::Error::from(bad.mapping().unwrap_err()).code(), "SCENE_BAD_OPTION");
}

#[test]
fn renders_from_the_centre_colour_the_hits_in_order() {
    // The analytic room (boxes only) with three "renders" whose colours are smooth functions of
    // the direction (one per peel): every pixel's k-th hit (by the analytic truth's order) takes
    // render k's colour, exactly on the renders' own grid and within the bilinear error on a cube
    // map; but a box's back reached through its inside (which a render shades as seen from inside)
    // keeps its material, as hits past the last render would.
    let mut truth = Scene::room();
    truth.objects.retain(|s| matches!(s, Shape::Box(_)));
    // A floating box below the centre whose far side an eye of the ball faces (its plane is
    // 0.4 m out, inside the 0.5 m radius): the centre's rays reach that side through the box.
    let floating = pomc_fixtures::Aabb { min: DVec3::new(0.15, -0.1, -0.9), max: DVec3::new(0.4, 0.1, -0.7) };
    truth.objects.push(Shape::Box(floating));
    let dir = tempfile::tempdir().unwrap();
    let (obj, mtl) = pomc_fixtures::obj::to_obj(&truth, 8, 1000.0, "s.mtl");
    std::fs::write(dir.path().join("s.obj"), obj).unwrap();
    std::fs::write(dir.path().join("s.mtl"), mtl).unwrap();
    let render = Equirect::new(256, 128).unwrap();
    let colour_of = |d: DVec3| (0.5 + 0.4 * d).as_vec3().to_array();
    let second_of = |d: DVec3| (0.5 - 0.3 * d).as_vec3().to_array();
    let third_of = |d: DVec3| (0.5 + 0.2 * DVec3::new(d.z, d.x, d.y)).as_vec3().to_array();
    let renders = [colour_of as fn(DVec3) -> [f32; 3], second_of, third_of];
    let paths: Vec<_> = (0..3).map(|k| dir.path().join(format!("hit-{k}.exr"))).collect();
    let truth_hits: Vec<_> =
        (0..256 * 128).map(|p| truth.hits(DVec3::ZERO, render.pixel_dir(p % 256, p / 256))).collect();
    // The far side of a step in render k: a neighbour's k-th hit is another object's, nearer by
    // more than an eye of the ball (radius 0.5 m) sees within a pixel.
    let parallax = std::f64::consts::TAU / 256.0 / 0.5;
    let step = |p: usize, k: usize| {
        let (x, y) = ((p % 256) as i64, (p / 256) as i64);
        let Some(h) = truth_hits[p].get(k) else { return false };
        (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))).any(|(dx, dy)| {
            let (qx, qy) = ((x + dx).rem_euclid(256), y + dy);
            let q = truth_hits.get((qy * 256 + qx) as usize).filter(|_| (0..128).contains(&qy));
            q.and_then(|q| q.get(k)).is_some_and(|g| g.object != h.object && 1.0 / g.t - 1.0 / h.t > parallax)
        })
    };
    // An anti-aliased render mixes the near surface into the far side of its steps: there render
    // 0 is poisoned (pure red), which parallax would pull away from the near surface.
    const POISON: (f32, f32, f32) = (1.0, 0.0, 0.0);
    let clean = dir.path().join("clean.exr");
    for (k, (path, f)) in paths.iter().chain([&clean]).zip(renders.iter().chain(&renders[..1])).enumerate() {
        exr::prelude::write_rgb_file(path, 256, 128, |i, j| {
            if k == 0 && step(j * 256 + i, 0) {
                return POISON;
            }
            let [r, g, b] = f(render.pixel_dir(i, j));
            (r, g, b)
        })
        .unwrap();
    }
    let plain = BakeSettings { width: 256, samples: 4, ..BakeSettings::default() };
    let lit = BakeSettings { colour: paths.to_vec(), ..plain.clone() };
    let cube = BakeSettings {
        mapping: pomc::mapping::MappingKind::Cube3x2,
        width: 192,
        colour: vec![clean.clone()],
        ..plain.clone()
    };
    let (a, b) = (bake(&dir.path().join("s.obj"), &plain), bake(&dir.path().join("s.obj"), &lit));
    let half = |v: f32| half::f16::from_f32(v).to_f32();
    // A ray through a box meets its front, its back (the solid's inside: kept only where an eye
    // faces it) and the room.
    let (mut rendered, mut inside, mut far_side) = ([0; 3], 0, 0);
    for (p, hits) in truth_hits.iter().enumerate() {
        let d = render.pixel_dir(p % 256, p / 256);
        for (k, l) in b.layers.iter().enumerate() {
            let z = l.image.channel("Z").unwrap().data[p];
            if !(z > 0.0 && z.is_finite()) {
                continue;
            }
            let rgb =
                |l: &pomc::layering::BuiltLayer| ["R", "G", "B"].map(|c| l.image.channel(c).unwrap().data[p]);
            let near = |h: &pomc_fixtures::Hit| (h.t - z as f64).abs() <= 1e-5 * h.t;
            // Coincident surfaces (a box's bottom on the floor) are one hit in either order.
            if hits.iter().filter(|h| near(h)).count() != 1 {
                continue;
            }
            let Some(i) = hits.iter().position(near) else { continue };
            if i > 0 && hits[i - 1].object == hits[i].object {
                // The same layers as without the renders: the colour is the material's.
                assert_eq!(rgb(l), rgb(&a.layers[k]), "inside hit {i} at pixel {p}");
                inside += 1;
            } else if step(p, i) {
                // The mean of its neighbours on its own surface: the render's colour within its
                // slope over a pixel, and no poison.
                let (got, want) = (rgb(l), renders[i](d));
                assert!((0..3).all(|c| (got[c] - want[c]).abs() < 0.03), "hit {i} at pixel {p}: {got:?}");
                far_side += 1;
            } else {
                assert_eq!(rgb(l), renders[i](d).map(half), "hit {i} at pixel {p}");
                rendered[i] += 1;
            }
        }
    }
    assert!(
        rendered[0] + far_side == 256 * 128 && rendered[2] > 100 && inside > 10 && far_side > 100,
        "rendered {rendered:?}, inside {inside}, far side of a step {far_side}"
    );
    let c = bake(&dir.path().join("s.obj"), &cube);
    let m = AnyMapping::Cube(pomc::mapping::Cube3x2::new(192, 128).unwrap());
    // Within the bilinear error, but the far side of a step (a few pixels) takes the mean of its
    // neighbours on its own surface: within the render's slope over a pixel.
    let (mut worst, mut beyond_bilinear) = (0f32, 0);
    for p in 0..192 * 128 {
        let near = c
            .layers
            .iter()
            .map(|l| l.image.channel("Z").unwrap().data[p])
            .enumerate()
            .filter(|&(_, z)| z > 0.0)
            .min_by(|x, y| x.1.total_cmp(&y.1));
        let Some((k, _)) = near else { continue };
        let want = colour_of(m.pixel_dir(p % 192, p / 192));
        let err = ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(i, ch)| (c.layers[k].image.channel(ch).unwrap().data[p] - want[i]).abs())
            .fold(0f32, f32::max);
        worst = worst.max(err);
        beyond_bilinear += (err >= 5e-3) as usize;
    }
    assert!(
        worst < 0.02 && beyond_bilinear < 192 * 128 / 50,
        "cube map: colour error {worst} against the render's function, {beyond_bilinear} pixels beyond 5e-3"
    );

    // Open sky: where the centre sees the sky, the infinity layer holds the render too.
    let mut open = Scene::by_name("sky").unwrap();
    open.objects.retain(|s| matches!(s, Shape::Box(_)));
    let (obj, _) = pomc_fixtures::obj::to_obj(&open, 8, 1000.0, "s.mtl");
    std::fs::write(dir.path().join("open.obj"), obj).unwrap();
    let o = bake(&dir.path().join("open.obj"), &BakeSettings { colour: vec![clean], ..plain.clone() });
    let sky = o.layers.iter().find(|l| l.role == Role::Infinity).unwrap();
    let mut seen = 0;
    for p in 0..256 * 128 {
        let only_sky =
            o.layers.iter().all(|l| l.role == Role::Infinity || l.image.channel("Z").unwrap().data[p] <= 0.0);
        if only_sky && sky.image.channel("Z").unwrap().data[p].is_infinite() {
            let got = ["R", "G", "B"].map(|c| sky.image.channel(c).unwrap().data[p]);
            assert_eq!(got, colour_of(render.pixel_dir(p % 256, p / 256)).map(half), "sky pixel {p}");
            seen += 1;
        }
    }
    assert!(seen > 1000, "sky pixels seen from the centre: {seen}");
}

#[test]
fn a_side_seen_edge_on_from_the_centre_renders_without_cracks() {
    // A low box under the centre: its side at x = −0.15 faces away from the centre, which meets it
    // only through the box, edge-on (a band a few pixels high); an eye of the ball out along −x
    // sees it squarely. Its layer's edges (and the top's, in another layer) are sampled at pixel
    // centres: footprints that stopped half a pixel past them would leave cracks into the box.
    let mut truth = Scene::room();
    truth.objects.retain(|s| matches!(s, Shape::Box(_)));
    let low = pomc_fixtures::Aabb { min: DVec3::new(-0.15, -0.3, -1.2), max: DVec3::new(0.35, 0.3, -1.05) };
    truth.objects.push(Shape::Box(low));
    let dir = tempfile::tempdir().unwrap();
    let (obj, mtl) = pomc_fixtures::obj::to_obj(&truth, 8, 1000.0, "s.mtl");
    std::fs::write(dir.path().join("s.obj"), obj).unwrap();
    std::fs::write(dir.path().join("s.mtl"), mtl).unwrap();
    let s = BakeSettings { width: 1024, ..BakeSettings::default() };
    let baked = bake(&dir.path().join("s.obj"), &s);
    let m = AnyMapping::new(pomc::mapping::MappingKind::Equirect, 1024, 512).unwrap();
    let layers: Vec<pomc::render::RenderLayer> =
        baked.layers.iter().map(|l| pomc::render::RenderLayer { image: &l.image, mapping: m }).collect();
    for eye in [DVec3::new(-0.48, -0.03, -0.07), DVec3::new(-0.35, 0.3, -0.15)] {
        let cam = pomc::render::Camera::Perspective(
            pomc::render::Perspective::new(eye, DVec3::new(-0.15, 0.0, -1.15), DVec3::Z, 60.0, 480, 270)
                .unwrap(),
        );
        let r = pomc::render::render(&layers, DMat4::IDENTITY, &cam, &pomc::render::SplatOptions::default())
            .unwrap();
        // Measured 2 and 0 pixels (66 and 9 with footprints ending half a pixel out).
        assert!(r.frame.holes() <= 4, "{} holes seen from {eye}", r.frame.holes());
    }
}
