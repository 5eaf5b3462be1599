//! `pomc render --method mesh` (`pomc::render::rasterize`) against exact ray-cast views of the
//! analytic room and against brute-force ray/triangle intersection: no holes inside the freedom
//! radius, quality close to the splat method's, watertight and near-plane-clipped rasterisation,
//! stiff cameras (poles, seam, the radius itself, very near and infinitely far content) without NaN.

use glam::{DMat4, DVec3};
use pomc::layer::{LayerImage, SampleType};
use pomc::layering::{self, BuildOptions};
use pomc::mapping::{AnyMapping, Mapping, MappingKind};
use pomc::mesh::LayerMesh;
use pomc::mesh::MeshOptions;
use pomc::render::rasterize::{self, LayerGeometry, MeshRendered, RasterOptions};
use pomc::render::{self, metrics, Camera, EquirectCamera, Frame, Perspective, RenderLayer, SplatOptions};
use pomc_fixtures::eval::{assert_no_nan, persp, truth};
use pomc_fixtures::layers::{render_on, rgbd_input, sphere_layer};
use pomc_fixtures::{Aabb, Scene, Shape};

/// The layered POMC of a scene and its meshes.
struct Pano {
    mapping: AnyMapping,
    layers: Vec<LayerImage>,
    meshes: Vec<LayerGeometry>,
}

impl Pano {
    fn new(scene: &Scene, kind: MappingKind, w: usize, h: usize) -> Pano {
        let mapping = AnyMapping::new(kind, w, h).unwrap();
        let r = render_on(scene, &mapping);
        let built =
            layering::build(rgbd_input(&r, mapping, true), &BuildOptions::default(), &|_| {}).unwrap();
        let layers: Vec<LayerImage> = built.layers.into_iter().map(|l| l.image).collect();
        let refs: Vec<RenderLayer> = layers.iter().map(|image| RenderLayer { image, mapping }).collect();
        let meshes =
            rasterize::mesh_layers(&refs, &MeshOptions::quadtree(), &RasterOptions::default()).unwrap();
        Pano { mapping, layers, meshes }
    }

    fn refs(&self) -> Vec<RenderLayer<'_>> {
        self.layers.iter().map(|image| RenderLayer { image, mapping: self.mapping }).collect()
    }

    fn mesh(&self, cam: &Camera) -> Frame {
        let r = rasterize::render_mesh(
            &self.refs(),
            &self.meshes,
            DMat4::IDENTITY,
            cam,
            &RasterOptions::default(),
        )
        .unwrap();
        assert_no_nan(&r.frame);
        r.frame
    }

    fn splat(&self, cam: &Camera) -> Frame {
        render::render(&self.refs(), DMat4::IDENTITY, cam, &SplatOptions::default()).unwrap().frame
    }
}

/// Eyes on the freedom sphere (r = 0.5) and half-way, looking where moving reveals hidden background.
fn views() -> Vec<Camera> {
    vec![
        persp(DVec3::new(0.0, 0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        persp(DVec3::new(0.0, -0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        persp(DVec3::new(-0.35, -0.35, 0.0), DVec3::new(-1.4, 1.5, -0.55)),
        persp(DVec3::new(0.35, 0.0, -0.35), DVec3::new(-1.45, -1.7, 0.0)),
        persp(DVec3::new(0.0, 0.25, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        persp(DVec3::new(-0.2, 0.1, 0.1), DVec3::new(-1.4, 1.5, -0.55)),
    ]
}

/// Holes tolerated at the freedom radius and half-way: none. (Before build's fill also seeded
/// from the floor where a box stands on it — no depth jump there — one pixel of 57600 stayed
/// uncovered at the box's bottom corner.)
const MAX_HOLES_EDGE: f64 = 0.0;
const MAX_HOLES_HALF: f64 = 0.0;

#[test]
fn mesh_views_inside_the_freedom_radius_have_no_holes_and_match_the_splat() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    let mut report = Vec::new();
    for cam in views() {
        let t = truth(&scene, &cam, 1);
        let (m, s) = (p.mesh(&cam), p.splat(&cam));
        let (pm, ps) = (metrics::psnr(&m, &t), metrics::psnr(&s, &t));
        let dm = metrics::depth_error(&m, &t).unwrap();
        report.push(format!(
            "eye {}: mesh holes {:.6} PSNR {pm:.2} dB depth error {dm:.4}; splat holes {:.6} PSNR {ps:.2} dB",
            cam.eye(),
            m.hole_ratio(),
            s.hole_ratio()
        ));
        let bound = if cam.eye().length() > 0.3 { MAX_HOLES_EDGE } else { MAX_HOLES_HALF };
        assert!(m.hole_ratio() <= bound, "mesh holes {} at {}", m.hole_ratio(), cam.eye());
        // Measured: mesh − splat from +0.06 to +0.55 dB.
        assert!(pm >= ps - 0.5, "mesh {pm:.2} dB vs splat {ps:.2} dB at {}", cam.eye());
        assert!(pm > 22.0, "mesh PSNR {pm:.2} at {}", cam.eye());
        assert!(dm < 0.03, "mean depth error {dm} m at {}", cam.eye());
    }
    for r in report {
        eprintln!("{r}");
    }
}

#[test]
fn centre_views_match_the_truth() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    // From the centre the layers are seen as they were captured: no hole, seam and poles included.
    let cam = persp(DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8));
    let f = p.mesh(&cam);
    assert_eq!(f.holes(), 0);
    let pm = metrics::psnr(&f, &truth(&scene, &cam, 1));
    assert!(pm > 25.0, "centre PSNR {pm}"); // measured 26.8 dB
    let eq = Camera::Equirect(EquirectCamera::new(DVec3::ZERO, 512, 256).unwrap());
    let (f, s) = (p.mesh(&eq), p.splat(&eq));
    assert_eq!(f.holes(), 0);
    let t = truth(&scene, &eq, 1);
    let (pm, ps) = (metrics::ws_psnr(&f, &t), metrics::ws_psnr(&s, &t));
    // Measured 31.6 dB (splat 28.0: its filter blurs the checkers).
    assert!(pm > 29.0 && pm >= ps - 0.5, "equirect WS-PSNR mesh {pm} splat {ps}");
}

#[test]
fn displaced_equirect_view_has_no_streaks_across_the_seam_or_poles() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    let eq = Camera::Equirect(EquirectCamera::new(DVec3::new(0.3, 0.0, 0.4), 512, 256).unwrap());
    let (f, s) = (p.mesh(&eq), p.splat(&eq));
    let t = truth(&scene, &eq, 1);
    assert!(f.hole_ratio() < 1e-4, "holes {}", f.hole_ratio()); // measured 0
    let (pm, ps) = (metrics::ws_psnr(&f, &t), metrics::ws_psnr(&s, &t));
    eprintln!("displaced equirect: mesh {pm:.2} dB, splat {ps:.2} dB, holes {}", f.hole_ratio());
    assert!(pm > 24.0 && pm >= ps - 0.5, "displaced equirect WS-PSNR mesh {pm} splat {ps}");
    // A streak (a triangle smeared over the seam or around a pole) shows as a run of wrong depth:
    // each row's median depth error stays small, the seam columns and the pole rows included.
    let w = f.width;
    for y in 0..f.height {
        let mut errs: Vec<f32> = (0..w)
            .filter(|&x| f.covered[y * w + x] && t.covered[y * w + x])
            .map(|x| (f.depth[y * w + x] - t.depth[y * w + x]).abs() / t.depth[y * w + x])
            .collect();
        errs.sort_by(f32::total_cmp);
        assert!(errs[errs.len() / 2] < 0.02, "row {y}: median relative depth error {}", errs[errs.len() / 2]);
    }
    for x in [0, 1, w - 2, w - 1] {
        let bad = (0..f.height)
            .filter(|&y| (f.depth[y * w + x] - t.depth[y * w + x]).abs() > 0.05 * t.depth[y * w + x])
            .count();
        assert!(bad <= f.height / 20, "seam column {x}: {bad} pixels off");
    }
}

fn render_one(img: &LayerImage, m: AnyMapping, cam: &Camera, o: &RasterOptions) -> MeshRendered {
    let layers = [RenderLayer { image: img, mapping: m }];
    let g = rasterize::mesh_layers(&layers, &MeshOptions::quadtree(), o).unwrap();
    let r = rasterize::render_mesh(&layers, &g, DMat4::IDENTITY, cam, o).unwrap();
    assert_no_nan(&r.frame);
    r
}

#[test]
fn very_near_far_and_infinite_content_matches_the_analytic_sphere() {
    // The analytic truth of a sphere layer of radius r seen from inside: the distance along a
    // pixel ray and the colour of the hit point's direction from the centre.
    for kind in [MappingKind::Equirect, MappingKind::Cube3x2] {
        let m = match kind {
            MappingKind::Equirect => AnyMapping::new(kind, 256, 128).unwrap(),
            MappingKind::Cube3x2 => AnyMapping::new(kind, 3 * 64, 2 * 64).unwrap(),
        };
        for r in [0.05f64, 1.0, 1e6, f64::INFINITY] {
            let img = sphere_layer(&m, r as f32);
            let off = if r.is_finite() { 0.4 * r } else { 0.3 };
            let eye = DVec3::new(0.3, -0.5, 0.2).normalize() * off;
            let cams = [
                // Straight up and down (the layer's and the output's poles), across the seam (+X).
                Camera::Perspective(Perspective::new(eye, eye + DVec3::Z, DVec3::Z, 90.0, 96, 64).unwrap()),
                Camera::Perspective(Perspective::new(eye, eye - DVec3::Z, DVec3::Z, 90.0, 96, 64).unwrap()),
                Camera::Perspective(Perspective::new(eye, eye + DVec3::X, DVec3::Z, 120.0, 96, 64).unwrap()),
                Camera::Equirect(EquirectCamera::new(eye, 128, 64).unwrap()),
            ];
            for cam in cams {
                // One ray per pixel: the rasteriser's own geometry, pixel centre by pixel centre.
                let o = RasterOptions { supersample: 1, ..RasterOptions::default() };
                let f = render_one(&img, m, &cam, &o).frame;
                assert_eq!(f.holes(), 0, "{kind:?} r={r} {cam:?}");
                let (mut worst_c, mut worst_d) = (0.0f64, 0.0f64);
                for y in 0..f.height {
                    for x in 0..f.width {
                        let i = y * f.width + x;
                        let d = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
                        let (t, dir) = if r.is_finite() {
                            let b = eye.dot(d);
                            let t = -b + (b * b - eye.length_squared() + r * r).sqrt();
                            (t, (eye + d * t).normalize())
                        } else {
                            (f64::INFINITY, d)
                        };
                        for k in 0..3 {
                            worst_c = worst_c.max((f.rgb[k][i] as f64 - (0.5 + 0.5 * dir[k])).abs());
                        }
                        if r.is_finite() {
                            worst_d = worst_d.max((f.depth[i] as f64 - t).abs() / t);
                        } else {
                            assert_eq!(f.depth[i], f32::INFINITY);
                        }
                    }
                }
                // One layer pixel is 1.4° (equirect) or 1.4° at most (cube 64): colour steps ≤ 0.013.
                assert!(worst_c < 0.03, "{kind:?} r={r} {cam:?}: colour error {worst_c}");
                // The mesh's 0.5 % relative bound, plus its footprint-free interior.
                assert!(worst_d < 0.01, "{kind:?} r={r} {cam:?}: depth error {worst_d}");
            }
        }
    }
}

#[test]
fn hard_room_cameras_never_give_nan() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 512, 256);
    let r = 0.5;
    let cams = [
        persp(DVec3::new(0.0, 0.0, r), DVec3::new(0.0, 0.0, 2.0)),
        persp(DVec3::new(0.0, 0.0, -r), DVec3::new(0.0, 0.0, -2.0)),
        persp(DVec3::new(r, 0.0, 0.0), DVec3::new(5.0, 0.0, 0.0)),
        // The lamp sphere above is 0.4 m away; 0.85 m up it is 0.05 m away (outside the radius).
        persp(DVec3::new(0.0, 0.0, r), DVec3::new(0.05, 0.0, 1.0)),
        persp(DVec3::new(0.0, 0.0, 0.85), DVec3::new(0.05, 0.0, 1.0)),
        Camera::Perspective(Perspective::new(DVec3::ZERO, DVec3::Y, DVec3::Z, 170.0, 64, 48).unwrap()),
        Camera::Perspective(Perspective::new(DVec3::ZERO, DVec3::Y, DVec3::Z, 0.5, 64, 48).unwrap()),
        Camera::Equirect(EquirectCamera::new(DVec3::new(0.0, 0.0, r), 128, 64).unwrap()),
    ];
    for (k, cam) in cams.iter().enumerate() {
        let f = p.mesh(cam);
        if k != 4 {
            assert!(f.hole_ratio() < 0.01, "{cam:?}: holes {}", f.hole_ratio());
        }
    }
}

#[test]
fn triangles_across_depth_jumps_are_not_drawn() {
    // One layer: a sphere of radius 2 over half the azimuths, 2.5 over the other half — a 25 %
    // jump, which the mesh joins (it cuts at 50 %, spec §8.2) but the renderer must not draw.
    let m = AnyMapping::new(MappingKind::Equirect, 256, 128).unwrap();
    let mut img = sphere_layer(&m, 2.0);
    let z: Vec<f32> = (0..256 * 128).map(|p| if p % 256 < 128 { 2.0 } else { 2.5 }).collect();
    img.set_channel("Z", SampleType::F32, z);
    let layers = [RenderLayer { image: &img, mapping: m }];
    let mesh = pomc::mesh::mesh_layer(&img, &m, &MeshOptions::quadtree()).unwrap().mesh;
    let g = LayerGeometry::new(0, mesh.clone(), &layers[0], 0.1).unwrap();
    assert!(g.jump_triangles > 0, "the mesh should join the two halves");
    // Looking at the step at azimuth 0 from an eye moved towards −Y: between the far half's
    // (y < 0) edge and the near half (y ≥ 0) rays meet no surface.
    let eye = DVec3::new(0.0, -0.8, 0.0);
    let cam = Camera::Perspective(
        Perspective::new(eye, DVec3::new(2.2, 0.0, 0.0), DVec3::Z, 40.0, 160, 90).unwrap(),
    );
    // Truth: the first hit of the two half-spheres.
    let hit = |d: DVec3| -> bool {
        [(2.0f64, true), (2.5, false)].iter().any(|&(r, near_half)| {
            let b = eye.dot(d);
            let t = -b + (b * b - eye.length_squared() + r * r).sqrt();
            let p = eye + d * t;
            let phi = p.y.atan2(p.x).rem_euclid(std::f64::consts::TAU);
            (phi < std::f64::consts::PI) == near_half
        })
    };
    let o = RasterOptions::default();
    let f = rasterize::render_mesh(&layers, &[g], DMat4::IDENTITY, &cam, &o).unwrap().frame;
    assert_no_nan(&f);
    let mut gap = 0;
    let mut drawn_in_gap = 0;
    for y in 0..cam.height() {
        for x in 0..cam.width() {
            if !hit(cam.ray(x as f64 + 0.5, y as f64 + 0.5)) {
                gap += 1;
                drawn_in_gap += f.covered[y * cam.width() + x] as usize;
            }
        }
    }
    assert!(gap > 200, "the view should show the disocclusion ({gap} px)");
    // Footprints may reach half a layer pixel into the gap; a skin would fill all of it.
    assert!(drawn_in_gap * 4 < gap, "{drawn_in_gap} of {gap} gap pixels drawn: a skin across the jump");
    // Without the renderer's test (jump 1.0: only the mesh's own 50 % cut) the skin is drawn.
    let loose = RasterOptions { jump: 1.0, ..o };
    let g = LayerGeometry::new(0, mesh, &layers[0], loose.jump).unwrap();
    let f = rasterize::render_mesh(&layers, &[g], DMat4::IDENTITY, &cam, &loose).unwrap().frame;
    assert!(f.holes() * 4 < gap, "the skin should cover the gap without the test");
}

/// A flat floor `z = -1` over `[-40, 40]²` as a jittered grid of triangles (shared vertices), as a
/// layer geometry of a tiny layer (its colour does not matter here).
fn floor_geometry(n: usize) -> (LayerImage, AnyMapping, LayerGeometry) {
    let m = AnyMapping::new(MappingKind::Equirect, 16, 8).unwrap();
    let mut img = LayerImage::new(16, 8);
    img.set_channel("Z", SampleType::F32, vec![1.0; 128]);
    for c in ["R", "G", "B"] {
        img.set_channel(c, SampleType::F32, vec![0.5; 128]);
    }
    let mut positions = Vec::new();
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
    };
    let step = 80.0 / n as f64;
    for j in 0..=n {
        for i in 0..=n {
            let inner = i > 0 && i < n && j > 0 && j < n;
            let (jx, jy) = if inner { (rnd() * 0.6 * step, rnd() * 0.6 * step) } else { (0.0, 0.0) };
            positions.push(DVec3::new(-40.0 + i as f64 * step + jx, -40.0 + j as f64 * step + jy, -1.0));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let mesh = LayerMesh { width: 16, height: 8, sources: vec![0; positions.len()], positions, triangles };
    let g = LayerGeometry {
        mesh_triangles: mesh.triangles.len(),
        jump_triangles: 0,
        border_pixels: 0,
        has_infinity: false,
        mesh,
    };
    (img, m, g)
}

/// Brute force: whether the ray from `eye` along `d` hits any triangle (Möller–Trumbore), and
/// how close to a triangle edge (barycentric margin) the nearest decision was.
fn brute(g: &LayerGeometry, eye: DVec3, d: DVec3) -> (bool, f64) {
    let (mut hit, mut margin) = (false, f64::INFINITY);
    for t in &g.mesh.triangles {
        let [a, b, c] = t.map(|i| g.mesh.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-15 {
            continue;
        }
        let s = eye - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        if t <= 0.0 {
            continue;
        }
        let m = u.min(v).min(1.0 - u - v);
        margin = margin.min(m.abs());
        if m >= 0.0 {
            hit = true;
        }
    }
    (hit, margin)
}

#[test]
fn rasterisation_is_watertight_and_clipped_at_the_near_plane() {
    let (img, m, g) = floor_geometry(24);
    let layers = [RenderLayer { image: &img, mapping: m }];
    // One ray per pixel, compared with ray casting through each pixel centre.
    let o = RasterOptions { supersample: 1, ..RasterOptions::default() };
    let eye = DVec3::new(0.3, -0.2, 0.0);
    let cams = [
        // Horizontal: the floor runs under and behind the camera (triangles cross the eye plane).
        Camera::Perspective(
            Perspective::new(eye, eye + DVec3::new(1.0, 0.2, 0.0), DVec3::Z, 100.0, 120, 80).unwrap(),
        ),
        // Looking down steeply and up (the floor only at the bottom edge).
        Camera::Perspective(
            Perspective::new(eye, eye + DVec3::new(0.1, 0.0, -1.0), DVec3::Z, 90.0, 96, 64).unwrap(),
        ),
        Camera::Perspective(
            Perspective::new(eye, eye + DVec3::new(1.0, 0.0, 0.9), DVec3::Z, 120.0, 96, 64).unwrap(),
        ),
        Camera::Equirect(EquirectCamera::new(eye, 160, 80).unwrap()),
    ];
    for cam in cams {
        let r = rasterize::render_mesh(&layers, std::slice::from_ref(&g), DMat4::IDENTITY, &cam, &o).unwrap();
        assert_no_nan(&r.frame);
        let f = &r.frame;
        let mut mismatches = 0;
        let mut covered = 0;
        for y in 0..f.height {
            for x in 0..f.width {
                let d = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
                let (hit, margin) = brute(&g, eye, d);
                covered += hit as usize;
                if hit != f.covered[y * f.width + x] && margin > 1e-9 {
                    mismatches += 1;
                }
                if hit {
                    // The floor's true distance along the ray.
                    let t = (-1.0 - eye.z) / d.z;
                    let got = f.depth[y * f.width + x] as f64;
                    assert!((got - t).abs() <= 1e-5 * t, "{cam:?} ({x}, {y}): depth {got} vs {t}");
                }
            }
        }
        assert_eq!(mismatches, 0, "{cam:?}: coverage differs from ray casting");
        assert!(covered > 0);
    }
}

/// A box 2 m away inside a room 10⁶ m across: the room is the build's infinity layer.
fn box_against_the_sky() -> Scene {
    Scene {
        room: Aabb { min: DVec3::splat(-1e6), max: DVec3::splat(1e6) },
        objects: vec![Shape::Box(Aabb { min: DVec3::new(2.0, -0.5, -0.5), max: DVec3::new(2.5, 0.5, 0.5) })],
    }
}

#[test]
fn infinity_layer_is_drawn_behind_everything() {
    let scene = box_against_the_sky();
    let p = Pano::new(&scene, MappingKind::Equirect, 512, 256);
    assert!(p.layers.iter().any(|l| l.depth().unwrap().iter().any(|z| z.is_infinite())));
    let cam = persp(DVec3::new(0.0, 0.4, 0.0), DVec3::new(2.0, 0.0, 0.0));
    let f = p.mesh(&cam);
    assert_eq!(f.holes(), 0);
    assert!(f.depth[90 * 320 + 160].is_finite(), "the box hides the sky");
    assert!(f.depth.iter().any(|d| d.is_infinite()));
    let t = truth(&scene, &cam, 1);
    let (pm, ps) = (metrics::psnr(&f, &t), metrics::psnr(&p.splat(&cam), &t));
    // Within issue 10's 1 dB of each other: the mesh's footprint quads grow the box by ¼ layer
    // pixel (3.7 output pixels here), the splat's coverage keeps its silhouette.
    assert!(pm >= ps - 1.0, "mesh {pm} vs splat {ps}");
}

#[test]
fn cube_map_layers_render_like_equirect_ones() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Cube3x2, 3 * 384, 2 * 384);
    for cam in views().into_iter().take(2) {
        let f = p.mesh(&cam);
        let t = truth(&scene, &cam, 1);
        let (pm, ps) = (metrics::psnr(&f, &t), metrics::psnr(&p.splat(&cam), &t));
        eprintln!("cube {}: holes {:.5} PSNR {pm:.2} (splat {ps:.2})", cam.eye(), f.hole_ratio());
        assert_eq!(f.holes(), 0, "cube holes {}", f.hole_ratio());
        assert!(pm > 20.0 && pm >= ps - 0.5, "cube PSNR {pm} vs splat {ps}");
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let m = AnyMapping::new(MappingKind::Equirect, 8, 4).unwrap();
    let img = LayerImage::new(8, 4);
    let cam = persp(DVec3::ZERO, DVec3::X);
    let layers = [RenderLayer { image: &img, mapping: m }];
    let o = RasterOptions::default();
    let e = rasterize::mesh_layers(&layers, &MeshOptions::quadtree(), &o).unwrap_err();
    assert_eq!(e.code(), "RENDER_LAYER_CHANNEL");
    let bad = RasterOptions { jump: f64::NAN, ..o };
    assert_eq!(
        rasterize::render_mesh(&[], &[], DMat4::IDENTITY, &cam, &bad).unwrap_err().code(),
        "RENDER_BAD_OPTIONS"
    );
    let bad = MeshOptions { max_error: Some(-1.0), ..MeshOptions::quadtree() };
    let good = sphere_layer(&m, 1.0);
    let layers = [RenderLayer { image: &good, mapping: m }];
    assert_eq!(rasterize::mesh_layers(&layers, &bad, &o).unwrap_err().code(), "RENDER_BAD_OPTIONS");
    // Meshes that do not belong to the layers.
    let g = rasterize::mesh_layers(&layers, &MeshOptions::quadtree(), &o).unwrap();
    assert_eq!(
        rasterize::render_mesh(&layers, &[], DMat4::IDENTITY, &cam, &o).unwrap_err().code(),
        "RENDER_BAD_OPTIONS"
    );
    let other = AnyMapping::new(MappingKind::Equirect, 16, 8).unwrap();
    let big = sphere_layer(&other, 1.0);
    let wrong = [RenderLayer { image: &big, mapping: other }];
    assert_eq!(
        rasterize::render_mesh(&wrong, &g, DMat4::IDENTITY, &cam, &o).unwrap_err().code(),
        "RENDER_MESH"
    );
    let broken = LayerMesh {
        width: 8,
        height: 4,
        sources: vec![0],
        positions: vec![DVec3::X],
        triangles: vec![[0, 0, 7]],
    };
    assert_eq!(LayerGeometry::new(0, broken, &layers[0], 0.1).unwrap_err().code(), "RENDER_MESH");
    let singular = DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0));
    assert_eq!(
        rasterize::render_mesh(&layers, &g, singular, &cam, &o).unwrap_err().code(),
        "RENDER_BAD_CAMERA"
    );
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
        render_one(&img, m, &cam, &RasterOptions::default());
    }
}

/// Ground under an open sky near the horizon: its depth grows by more than the 10 % jump per
/// pixel, smoothly. Walking each long mesh edge pixel by pixel (spec §9.4b) keeps those triangles;
/// from the centre no pixel is left uncovered (1.1–2.2 % were before).
#[test]
fn grazing_ground_under_the_sky_is_drawn() {
    let scene = Scene::open_sky();
    let p = Pano::new(&scene, MappingKind::Equirect, 2048, 1024);
    for dir in [DVec3::new(0.955, 0.296, -0.36), DVec3::new(-0.955, -0.296, -0.36)] {
        let cam = Camera::Perspective(Perspective::new(DVec3::ZERO, dir, DVec3::Z, 90.0, 960, 540).unwrap());
        let f = p.mesh(&cam);
        assert_eq!(f.holes(), 0, "looking {dir}: holes {}", f.hole_ratio());
    }
    // From above the centre, the ground filled behind the object on the seam shows: the seam's
    // stitching strip must join vertices 16 rows apart on the grazing ground (a 1.5 depth ratio).
    // Measured 1 pixel (an edge-on sliver); 170 along the seam before.
    let eye = DVec3::new(0.0, 0.0, 0.5);
    let cam = Camera::Perspective(
        Perspective::new(eye, eye + DVec3::new(0.955, 0.296, -0.36), DVec3::Z, 60.0, 960, 540).unwrap(),
    );
    let f = p.mesh(&cam);
    assert!(f.holes() <= 4, "displaced: {} holes", f.holes());
}

/// A box against the sky seen from aside, each layer pixel ~3.7 output pixels wide. The splat's
/// filter reaches ¾ of a pixel past each sample; a silhouette must not grow by it: the box's
/// distance shows in as many output pixels as in the truth, to within half a pixel along its
/// outline (0.35 now; 0.74 when the nearest group won whatever its coverage). The mesh's
/// footprint quads grow it by ¼ layer pixel (spec §9.4b step 3), ~1 output pixel here.
#[test]
fn the_splat_keeps_silhouettes_to_their_size() {
    let scene = box_against_the_sky();
    let p = Pano::new(&scene, MappingKind::Equirect, 512, 256);
    let cam = persp(DVec3::new(0.0, 0.4, 0.0), DVec3::new(2.0, 0.0, 0.0));
    let t = truth(&scene, &cam, 1);
    // The box is within 3 m; the room's walls (the truth's sky) are 10⁶ m away.
    let near = |d: f32| d > 0.0 && d < 100.0;
    let count = |f: &Frame| f.depth.iter().filter(|&&d| near(d)).count() as f64;
    // Outline length: truth pixels with a 4-neighbour of the sky.
    let (w, h) = (t.width, t.height);
    let finite = |x: usize, y: usize| near(t.depth[y * w + x]);
    let outline = (1..h - 1)
        .flat_map(|y| (1..w - 1).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            finite(x, y)
                && [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)].iter().any(|&(a, b)| !finite(a, b))
        })
        .count() as f64;
    let (truth_n, splat_n, mesh_n) = (count(&t), count(&p.splat(&cam)), count(&p.mesh(&cam)));
    eprintln!("box pixels: truth {truth_n}, splat {splat_n}, mesh {mesh_n}; outline {outline}");
    assert!(outline > 100.0);
    assert!((splat_n - truth_n).abs() <= 0.5 * outline, "splat {splat_n} vs truth {truth_n}");
}

/// Sub-samples: against what a camera sees (4 × 4 rays a pixel), 2 × 2 rays a pixel beat one on
/// the room's checker edges and silhouettes, and leave no hole one ray did not.
#[test]
fn sub_samples_bring_the_mesh_closer_to_a_camera() {
    let p = Pano::new(&Scene::room(), MappingKind::Equirect, 1024, 512);
    for cam in &views()[..3] {
        let t = truth(&Scene::room(), cam, 4);
        let render = |supersample| {
            let o = RasterOptions { supersample, ..RasterOptions::default() };
            rasterize::render_mesh(&p.refs(), &p.meshes, DMat4::IDENTITY, cam, &o).unwrap().frame
        };
        let (one, two) = (render(1), render(2));
        assert_no_nan(&two);
        assert_eq!((two.width, two.height), (one.width, one.height));
        assert!(two.holes() <= one.holes());
        let (p1, p2) = (metrics::psnr(&one, &t), metrics::psnr(&two, &t));
        eprintln!("PSNR against a 16-ray camera: 1 ray {p1:.2} dB, 2 × 2 rays {p2:.2} dB");
        assert!(p2 > p1 + 0.25, "1 ray {p1}, 2 × 2 rays {p2}");
    }
}

/// A pole one layer pixel wide against the sky (1.2 cm at 1.6 m, a pixel 0.7°): the mesh draws it
/// at its own footprint's width, not the ¼ pixel more on each side that lets neighbouring border
/// quads overlap (there are none across a line one pixel wide). Ground seen at a grazing angle,
/// one row thick by the 10 % step but one surface by the lattice walk, keeps the wider quads.
#[test]
fn a_line_one_pixel_wide_keeps_its_width_in_the_mesh() {
    let scene = Scene {
        room: Aabb { min: DVec3::splat(-1e6), max: DVec3::splat(1e6) },
        // Around the first column's pixel centres (azimuth 0.35°), narrower than the column.
        objects: vec![Shape::Box(Aabb {
            min: DVec3::new(1.6, 0.0038, -0.6),
            max: DVec3::new(1.612, 0.0158, 0.6),
        })],
    };
    let p = Pano::new(&scene, MappingKind::Equirect, 512, 256);
    let cam = persp(DVec3::new(0.0, 0.2, 0.0), DVec3::new(1.6, 0.0, 0.0));
    let t = truth(&scene, &cam, 4);
    let near = |d: f32| d > 0.0 && d < 100.0;
    let count = |f: &Frame| f.depth.iter().filter(|&&d| near(d)).count() as f64;
    // The pole's width in the layer: pixels of the middle row nearer than the sky.
    let z = p.layers.iter().find_map(|l| l.depth().filter(|z| z.iter().any(|d| near(*d)))).unwrap();
    let wide = (0..512).filter(|&x| near(z[128 * 512 + x])).count();
    let (truth_n, mesh_n) = (count(&t), count(&p.mesh(&cam)));
    eprintln!("pole: {wide} layer pixel(s) wide; output pixels: truth {truth_n}, mesh {mesh_n}");
    assert_eq!(wide, 1);
    // One footprint is ~1.6 truth widths here (720 output pixels with sub-samples), 1.5 of them 2.5
    // (900 before).
    assert!(mesh_n < 2.1 * truth_n, "mesh {mesh_n} vs truth {truth_n}");
}

#[test]
fn ground_to_the_horizon_across_the_seam_has_no_crack() {
    // An endless ground 1.6 m below the centre (the sky above the horizon), seen from an eye off
    // the centre looking along +X across the seam at a grazing angle: the quadtree's leaves on
    // the two sides of the seam end on different rows, so the stitch joins rows a few pixels
    // apart whose depths differ by more than one step's jump. Such a stitch edge is not a lattice
    // line; it is continuous when a row then a column are, and must not open a crack.
    let m = AnyMapping::new(MappingKind::Equirect, 1024, 512).unwrap();
    let (w, h) = (1024, 512);
    let mut img = LayerImage::new(w, h);
    let z = (0..w * h)
        .map(|p| {
            let d = m.pixel_dir(p % w, p / w);
            if d.z < -1e-3 {
                (1.6 / -d.z) as f32
            } else {
                f32::INFINITY
            }
        })
        .collect();
    img.set_channel("Z", SampleType::F32, z);
    for c in ["R", "G", "B"] {
        img.set_channel(c, SampleType::F32, vec![0.5; w * h]);
    }
    let eye = DVec3::new(0.19, 0.51, 0.64);
    let cam = Camera::Perspective(
        Perspective::new(eye, DVec3::new(2.16, 0.61, 0.30), DVec3::Z, 75.0, 480, 270).unwrap(),
    );
    let f = render_one(&img, m, &cam, &RasterOptions::default()).frame;
    let ground = f.depth.iter().filter(|d| d.is_finite() && **d > 0.0).count();
    assert!(ground > f.width * f.height / 3, "ground pixels {ground}");
    assert_eq!(f.holes(), 0, "cracks in the ground");
}
