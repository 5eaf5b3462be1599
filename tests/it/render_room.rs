//! `pomc::render` against exact ray-cast views of the analytic room: the layered splat fills the
//! disocclusions a single RGB-D layer leaves, inside the freedom radius; cameras at poles, across
//! the seam, at the radius and near or far content never give NaN.

use glam::{DMat4, DVec3};
use pomc::layer::LayerImage;
use pomc::layering::{self, BuildOptions};
use pomc::mapping::{AnyMapping, Mapping, MappingKind};
use pomc::render::{self, metrics, Camera, EquirectCamera, Frame, Perspective, RenderLayer, SplatOptions};
use pomc_fixtures::eval::{assert_no_nan, persp, truth};
use pomc_fixtures::layers::{render_on, rgbd_input, to_layer};
use pomc_fixtures::{Aabb, Scene, Shape};

/// The two systems compared: the layered POMC and the plain RGB-D panorama alone.
struct Systems {
    mapping: AnyMapping,
    layered: Vec<LayerImage>,
    single: LayerImage,
}

fn systems(scene: &Scene, kind: MappingKind, w: usize, h: usize) -> Systems {
    let mapping = AnyMapping::new(kind, w, h).unwrap();
    let r = render_on(scene, &mapping);
    let built = layering::build(rgbd_input(&r, mapping, true), &BuildOptions::default(), &|_| {}).unwrap();
    Systems {
        mapping,
        layered: built.layers.into_iter().map(|l| l.image).collect(),
        single: to_layer(&r.first_hit, false),
    }
}

fn draw(images: &[&LayerImage], m: AnyMapping, cam: &Camera) -> Frame {
    let layers: Vec<RenderLayer> = images.iter().map(|&image| RenderLayer { image, mapping: m }).collect();
    let r = render::render(&layers, DMat4::IDENTITY, cam, &SplatOptions::default()).unwrap();
    assert_no_nan(&r.frame);
    r.frame
}

/// Eyes on the freedom sphere (r = 0.5) with a target where moving reveals hidden background.
fn edge_views() -> Vec<Camera> {
    vec![
        persp(DVec3::new(0.0, 0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        persp(DVec3::new(0.0, -0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        persp(DVec3::new(-0.35, -0.35, 0.0), DVec3::new(-1.4, 1.5, -0.55)),
        persp(DVec3::new(0.35, 0.0, -0.35), DVec3::new(-1.45, -1.7, 0.0)),
    ]
}

/// Hole ratio tolerated at the freedom radius (measured: ≤ 0.05 % equirect, 0.19 % cube 3×2).
const MAX_HOLES: f64 = 0.0;

#[test]
fn layered_splat_fills_disocclusions_the_single_layer_leaves() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Equirect, 1024, 512);
    let mut report = Vec::new();
    for cam in edge_views() {
        let t = truth(&scene, &cam, 1);
        let layered = draw(&s.layered.iter().collect::<Vec<_>>(), s.mapping, &cam);
        let single = draw(&[&s.single], s.mapping, &cam);
        let (pl, ps) = (metrics::psnr(&layered, &t), metrics::psnr(&single, &t));
        report.push((cam.eye(), layered.hole_ratio(), single.hole_ratio(), pl, ps));
        // Not 0: behind the box, build fills the hidden floor-wall corner with the wall continued
        // down (about 30 % too far), so that sliver reprojects elsewhere (see docs/evaluation.md).
        assert!(layered.hole_ratio() <= MAX_HOLES, "layered holes {} at {}", layered.hole_ratio(), cam.eye());
        assert!(single.hole_ratio() > layered.hole_ratio(), "the baseline should show disocclusions");
        assert!(pl >= ps + 3.0, "layered {pl:.2} dB vs single {ps:.2} dB at {}", cam.eye());
        let derr = metrics::depth_error(&layered, &t).unwrap();
        assert!(derr < 0.05, "mean depth error {derr} m");
    }
    for (eye, hl, hs, pl, ps) in report {
        eprintln!("eye {eye}: holes {hl:.5} vs {hs:.5}, PSNR {pl:.2} vs {ps:.2} dB");
    }
}

#[test]
fn centre_views_match_the_truth() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Equirect, 1024, 512);
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    // Perspective from the centre: no parallax, both systems see the same thing.
    let cam = persp(DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8));
    let f = draw(&layered, s.mapping, &cam);
    assert_eq!(f.holes(), 0);
    let p = metrics::psnr(&f, &truth(&scene, &cam, 1));
    assert!(p > 22.0, "centre PSNR {p}");
    // An equirect view from the centre reproduces the panorama, seam and poles included.
    let eq = Camera::Equirect(EquirectCamera::new(DVec3::ZERO, 512, 256).unwrap());
    let f = draw(&layered, s.mapping, &eq);
    assert_eq!(f.holes(), 0);
    let p = metrics::ws_psnr(&f, &truth(&scene, &eq, 1));
    assert!(p > 22.0, "equirect WS-PSNR {p}");
}

#[test]
fn displaced_equirect_view_has_no_holes_on_the_seam_or_poles() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Equirect, 1024, 512);
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    let eq = Camera::Equirect(EquirectCamera::new(DVec3::new(0.3, 0.0, 0.4), 512, 256).unwrap());
    let f = draw(&layered, s.mapping, &eq);
    assert!(f.hole_ratio() < 1e-3, "holes {}", f.hole_ratio());
    let p = metrics::ws_psnr(&f, &truth(&scene, &eq, 1));
    assert!(p > 20.0, "displaced equirect WS-PSNR {p}");
}

#[test]
fn hard_cameras_never_give_nan() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Equirect, 512, 256);
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    let r = 0.5;
    let cams = [
        // Straight at both poles (default up parallel to the view), at the radius.
        persp(DVec3::new(0.0, 0.0, r), DVec3::new(0.0, 0.0, 2.0)),
        persp(DVec3::new(0.0, 0.0, -r), DVec3::new(0.0, 0.0, -2.0)),
        // Across the seam (+X), eye exactly on the freedom sphere.
        persp(DVec3::new(r, 0.0, 0.0), DVec3::new(5.0, 0.0, 0.0)),
        // Very near content: the lamp sphere above is 0.4 m away; the room wall far behind.
        persp(DVec3::new(0.0, 0.0, r), DVec3::new(0.05, 0.0, 1.0)),
        // Wide and narrow fields of view.
        Camera::Perspective(Perspective::new(DVec3::ZERO, DVec3::Y, DVec3::Z, 170.0, 64, 48).unwrap()),
        Camera::Perspective(Perspective::new(DVec3::ZERO, DVec3::Y, DVec3::Z, 0.5, 64, 48).unwrap()),
    ];
    for cam in cams {
        let f = draw(&layered, s.mapping, &cam);
        assert!(f.hole_ratio() < 0.01, "{cam:?}: holes {}", f.hole_ratio());
    }
}

#[test]
fn infinity_layer_is_drawn_behind_everything() {
    // An open scene: a huge room whose walls build turns into an infinity layer, one near box.
    let scene = Scene {
        room: Aabb { min: DVec3::splat(-1e6), max: DVec3::splat(1e6) },
        objects: vec![Shape::Box(Aabb { min: DVec3::new(2.0, -0.5, -0.5), max: DVec3::new(2.5, 0.5, 0.5) })],
    };
    let s = systems(&scene, MappingKind::Equirect, 512, 256);
    assert!(s.layered.iter().any(|l| l.depth().unwrap().iter().any(|z| z.is_infinite())));
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    let cam = persp(DVec3::new(0.0, 0.4, 0.0), DVec3::new(2.0, 0.0, 0.0));
    let f = draw(&layered, s.mapping, &cam);
    assert_eq!(f.holes(), 0);
    let centre = (90 * 320 + 160) as usize;
    assert!(f.depth[centre].is_finite(), "the box hides the sky");
    assert!(f.depth.iter().any(|d| d.is_infinite()));
}

#[test]
fn cube_map_layers_render_like_equirect_ones() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Cube3x2, 3 * 384, 2 * 384);
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    for cam in edge_views().into_iter().take(2) {
        let f = draw(&layered, s.mapping, &cam);
        assert!(f.hole_ratio() <= MAX_HOLES, "cube holes {}", f.hole_ratio());
        let p = metrics::psnr(&f, &truth(&scene, &cam, 1));
        assert!(p > 20.0, "cube PSNR {p}");
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let m = AnyMapping::new(MappingKind::Equirect, 8, 4).unwrap();
    let img = LayerImage::new(8, 4);
    let cam = persp(DVec3::ZERO, DVec3::X);
    let e = render::render(
        &[RenderLayer { image: &img, mapping: m }],
        DMat4::IDENTITY,
        &cam,
        &SplatOptions::default(),
    )
    .unwrap_err();
    assert_eq!(e.code(), "RENDER_LAYER_CHANNEL");
    let bad = SplatOptions { radius: f64::NAN, ..SplatOptions::default() };
    assert_eq!(render::render(&[], DMat4::IDENTITY, &cam, &bad).unwrap_err().code(), "RENDER_BAD_OPTIONS");
    let _ = m.width();
}

/// Columns of a frame's colour, mirrored left to right.
fn mirrored(f: &Frame) -> Frame {
    let mut m = f.clone();
    for k in 0..3 {
        for y in 0..f.height {
            for x in 0..f.width {
                m.rgb[k][y * f.width + x] = f.rgb[k][y * f.width + f.width - 1 - x];
            }
        }
    }
    m
}

#[test]
fn local_to_world_places_the_panorama_in_the_world() {
    let scene = Scene::room();
    let s = systems(&scene, MappingKind::Equirect, 512, 256);
    let layers: Vec<RenderLayer> =
        s.layered.iter().map(|image| RenderLayer { image, mapping: s.mapping }).collect();
    let (eye, at) = (DVec3::new(0.2, 0.3, 0.1), DVec3::new(2.0, 0.0, -0.8));
    let local = persp(eye, at);
    let base = render::render(&layers, DMat4::IDENTITY, &local, &SplatOptions::default()).unwrap().frame;
    // The thesis's example transform (translate, rotate 90° about Z, mirror X) and a uniform scale.
    let m = DMat4::from_translation(DVec3::new(0.0, 0.0, 1.15))
        * DMat4::from_rotation_z(90f64.to_radians())
        * DMat4::from_scale(DVec3::new(-2.0, 2.0, 2.0));
    let world = Camera::Perspective(
        Perspective::new(m.transform_point3(eye), m.transform_point3(at), DVec3::Z, 60.0, 320, 180).unwrap(),
    );
    let moved = render::render(&layers, m, &world, &SplatOptions::default()).unwrap().frame;
    // The mirror swaps left and right; distances double.
    let p = metrics::psnr(&mirrored(&moved), &base);
    assert!(p > 40.0, "PSNR against the identity render {p}");
    let centre = 90 * 320 + 160;
    assert!((moved.depth[centre] / base.depth[centre] - 2.0).abs() < 0.01);
    assert_eq!(moved.holes(), base.holes());
    assert_eq!(pomc::manifest::centre(m), DVec3::new(0.0, 0.0, 1.15));
}

#[test]
fn hostile_layer_values_never_give_nan() {
    let (w, h) = (64, 32);
    let m = AnyMapping::new(MappingKind::Equirect, w, h).unwrap();
    let img = pomc_fixtures::layers::hostile_layer(w, h);
    for cam in [
        persp(DVec3::ZERO, DVec3::X),
        persp(DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, 3.0)),
        Camera::Equirect(EquirectCamera::new(DVec3::new(0.1, 0.0, 0.0), 64, 32).unwrap()),
    ] {
        draw(&[&img], m, &cam);
    }
}

/// Ground under an open sky: near the horizon its depth grows by more than the 10 % jump a row,
/// smoothly, up to where the infinity layer takes over. From the centre and from inside the
/// freedom radius, looking at the horizon, no pixel is left uncovered (the views the evaluation
/// harness found holes in before the splat's plane test).
#[test]
fn grazing_ground_under_the_sky_leaves_no_holes() {
    let scene = Scene::open_sky();
    let s = systems(&scene, MappingKind::Equirect, 2048, 1024);
    let layered: Vec<&LayerImage> = s.layered.iter().collect();
    let look = DVec3::new(0.955, 0.296, -0.36);
    for (eye, dir) in [
        (DVec3::ZERO, look),
        (DVec3::new(0.0, 0.0, 0.5), DVec3::new(-0.955, -0.296, 0.14)),
        (DVec3::new(0.0, 0.0, 0.25), DVec3::new(0.3, -0.955, 0.0)),
        (DVec3::new(0.5, 0.0, 0.0), DVec3::new(1.0, 0.0, -0.05)),
        // Past the far building's left edge (20 m away) to the ground behind it: the building must be
        // a layer above the ground although the ground is nearer on average (80 holes before).
        (DVec3::new(0.0, 0.5, 0.0), look),
        (DVec3::new(0.0, 0.25, 0.0), look),
    ] {
        // Output pixels finer than the panorama's (0.09° against 0.18°), as in the harness.
        let cam = Camera::Perspective(Perspective::new(eye, eye + dir, DVec3::Z, 90.0, 960, 540).unwrap());
        let f = draw(&layered, s.mapping, &cam);
        let holes = f.covered.iter().filter(|&&c| !c).count();
        assert_eq!(holes, 0, "eye {eye} looking {dir}: {holes} holes");
    }
}

/// A floor (`z = −1`, red) under a grey dome of radius 4, seen horizontally from an eye 0.85 m off the
/// centre: the floor right below the eye lies in the camera plane, where projection diverges (its
/// pixels and their neighbours land up to millions of pixels apart). Those pixels must cost a few
/// tests and paint nothing: before the footprint refinement their splats were widened to cover the
/// screen and, nearer than the dome, painted the floor's red over the middle of the view.
#[test]
fn surfaces_beside_the_eye_never_make_screen_filling_splats() {
    let m = AnyMapping::new(MappingKind::Equirect, 1024, 512).unwrap();
    let (w, h) = (m.width(), m.height());
    let mut img = LayerImage::new(w, h);
    let (mut z, mut r, mut g) = (vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]);
    for y in 0..h {
        for x in 0..w {
            let d = m.pixel_dir(x, y);
            let floor = if d.z < 0.0 { -1.0 / d.z } else { f64::INFINITY };
            let i = y * w + x;
            z[i] = floor.min(4.0) as f32;
            (r[i], g[i]) = if floor < 4.0 { (0.8, 0.05) } else { (0.3, 0.3) };
        }
    }
    img.set_channel("R", pomc::layer::SampleType::F32, r);
    img.set_channel("G", pomc::layer::SampleType::F32, g.clone());
    img.set_channel("B", pomc::layer::SampleType::F32, g);
    img.set_channel("Z", pomc::layer::SampleType::F32, z);
    for (eye, dir) in [
        (DVec3::new(-0.6, 0.6, 0.0), DVec3::Y),
        (DVec3::new(-0.6, 0.6, 0.0), DVec3::NEG_X),
        (DVec3::new(0.85, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.05)),
    ] {
        let cam = Camera::Perspective(Perspective::new(eye, eye + dir, DVec3::Z, 90.0, 320, 180).unwrap());
        let layers = [RenderLayer { image: &img, mapping: m }];
        let out = render::render(&layers, DMat4::IDENTITY, &cam, &SplatOptions::default()).unwrap();
        let f = &out.frame;
        // The row through the horizon sees the dome (the floor meets it 14° below the horizon).
        let row = f.height / 2 * f.width;
        for x in 0..f.width {
            let (red, green) = (f.rgb[0][row + x], f.rgb[1][row + x]);
            assert!(
                (red - 0.3).abs() < 0.02 && (green - 0.3).abs() < 0.02,
                "eye {eye} dir {dir}: pixel {x} of the horizon is ({red}, {green}), not the dome"
            );
        }
        // Work follows the output: a few samples per output pixel and layer pixel, not a screen per
        // pixel beside the eye.
        let samples = out.stats.counts.samples as f64;
        assert!(samples < 8.0 * (w * h) as f64, "eye {eye} dir {dir}: {samples} samples");
        assert_eq!(f.holes(), 0, "eye {eye} dir {dir}");
    }
}
