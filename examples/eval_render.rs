//! Evaluation harness of `pomc::render` on the analytic room (spec §9.6).
//!
//! The room is ray-cast from its centre into a plain RGB-D panorama, `pomc::layering` turns it into
//! layers, and both systems — the **single-layer baseline** (the RGB-D panorama alone, splatted the
//! same way) and the **layered splat** — are rendered from camera positions on rings inside the
//! freedom radius, then compared with exact ray-cast views from the same positions: PSNR of
//! perspective views, WS-PSNR of equirect views, mean depth error and hole ratio.
//!
//! ```text
//! cargo run --release --example eval_render -- [--width 2048] [--size 480x270] [--bench]
//! ```
//! `--bench` instead times a 960×540 render from the 2-layer room at `--width` (default 4096).
//! With `SHOW_HOLES=1` in the environment, every uncovered pixel of a layered view is listed on
//! stderr with the surfaces the true ray meets (to trace holes back to build or render).

use std::time::Instant;

use glam::{DMat4, DVec3};
use pomc::layer::LayerImage;
use pomc::layering::{self, BuildOptions};
use pomc::mapping::{AnyMapping, MappingKind};
use pomc::mesh::{self, MeshOptions};
use pomc::render::rasterize::{self, LayerGeometry, RasterOptions};
use pomc::render::{self, metrics, Camera, EquirectCamera, Frame, Perspective, RenderLayer, SplatOptions};
use pomc_fixtures::layers::{render_on, rgbd_input, to_layer};
use pomc_fixtures::Scene;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// The two systems compared.
struct Systems {
    mapping: AnyMapping,
    layered: Vec<LayerImage>,
    single: Vec<LayerImage>,
}

fn systems(scene: &Scene, width: usize) -> Res<Systems> {
    let mapping = AnyMapping::new(MappingKind::Equirect, width, width / 2)?;
    let r = render_on(scene, &mapping);
    let built = layering::build(rgbd_input(&r, mapping, true), &BuildOptions::default(), &|_| {})?;
    Ok(Systems {
        mapping,
        layered: built.layers.into_iter().map(|l| l.image).collect(),
        single: vec![to_layer(&r.first_hit, false)],
    })
}

fn draw(images: &[LayerImage], m: AnyMapping, cam: &Camera) -> Res<Frame> {
    let layers: Vec<RenderLayer> = images.iter().map(|image| RenderLayer { image, mapping: m }).collect();
    Ok(render::render(&layers, DMat4::IDENTITY, cam, &SplatOptions::default())?.frame)
}

/// Exact view: the first surface along each pixel-centre ray (`pomc_fixtures::eval::truth`).
fn truth(scene: &Scene, cam: &Camera) -> Frame {
    pomc_fixtures::eval::truth(scene, cam, 1)
}

/// Eye positions: the centre and 8 azimuths on horizontal rings of radius 0.25 and 0.5 m, plus
/// the two poles of the freedom sphere.
fn eyes() -> Vec<DVec3> {
    let mut out = vec![DVec3::ZERO];
    for r in [0.25, 0.5] {
        for k in 0..8 {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            out.push(DVec3::new(r * a.cos(), r * a.sin(), 0.0));
        }
    }
    out.extend([DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, -0.5)]);
    out
}

/// Mean, min and max of a list.
fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (
        mean,
        v.iter().cloned().fold(f64::INFINITY, f64::min),
        v.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    )
}

#[derive(Default)]
struct Ring {
    psnr: [Vec<f64>; 2],
    ws_psnr: [Vec<f64>; 2],
    holes: [Vec<f64>; 2],
    depth: [Vec<f64>; 2],
    gain: Vec<f64>,
}

fn evaluate(width: usize, size: (usize, usize)) -> Res<()> {
    let scene = Scene::room();
    let t = Instant::now();
    let s = systems(&scene, width)?;
    eprintln!("built the room at {width}x{} in {:.2} s", width / 2, t.elapsed().as_secs_f64());
    let radii = [0.0, 0.25, 0.5];
    let mut rings: Vec<Ring> = radii.iter().map(|_| Ring::default()).collect();
    for eye in eyes() {
        let ring = radii.iter().position(|r| (eye.length() - r).abs() < 1e-9).unwrap_or(2);
        let r = &mut rings[ring];
        // Four horizontal directions 20° down, and the equirect view.
        for k in 0..4 {
            let a = k as f64 * std::f64::consts::FRAC_PI_2 + 0.3;
            let at = eye + DVec3::new(a.cos(), a.sin(), -0.36);
            let cam = Camera::Perspective(Perspective::new(eye, at, DVec3::Z, 60.0, size.0, size.1)?);
            let gt = truth(&scene, &cam);
            let mut p = [0.0; 2];
            for (sys, images) in [&s.single, &s.layered].into_iter().enumerate() {
                let f = draw(images, s.mapping, &cam)?;
                p[sys] = metrics::psnr(&f, &gt);
                r.psnr[sys].push(p[sys]);
                r.holes[sys].push(f.hole_ratio());
                if sys == 1 && f.hole_ratio() > 0.0 && std::env::var("SHOW_HOLES").is_ok() {
                    for (i, _) in f.covered.iter().enumerate().filter(|(_, &c)| !c) {
                        let ray = cam.ray((i % f.width) as f64 + 0.5, (i / f.width) as f64 + 0.5);
                        let hits = scene.hits(eye, ray);
                        eprintln!(
                            "hole eye {eye:.2} px ({}, {}) point {:.3} surfaces {:?}",
                            i % f.width,
                            i / f.width,
                            eye + ray.normalize() * gt.depth[i] as f64,
                            hits.iter()
                                .map(|h| (h.object, (h.t * 1000.0).round() / 1000.0))
                                .collect::<Vec<_>>()
                        );
                    }
                }
                r.depth[sys].extend(metrics::depth_error(&f, &gt));
            }
            r.gain.push(p[1] - p[0]);
        }
        let cam = Camera::Equirect(EquirectCamera::new(eye, size.0, size.0 / 2)?);
        let gt = truth(&scene, &cam);
        for (sys, images) in [&s.single, &s.layered].into_iter().enumerate() {
            let f = draw(images, s.mapping, &cam)?;
            r.ws_psnr[sys].push(metrics::ws_psnr(&f, &gt));
            r.holes[sys].push(f.hole_ratio());
            if sys == 1 && f.hole_ratio() > 0.0 && std::env::var("SHOW_HOLES").is_ok() {
                for (i, _) in f.covered.iter().enumerate().filter(|(_, &c)| !c) {
                    eprintln!(
                        "hole eye {eye} equirect px ({}, {}) truth depth {}",
                        i % f.width,
                        i / f.width,
                        gt.depth[i]
                    );
                }
            }
        }
    }
    println!("| eye radius (m) | system | PSNR mean / min (dB) | WS-PSNR mean / min (dB) | holes mean / max (%) | depth error mean (m) | layered − single PSNR mean / min (dB) |");
    println!("|---|---|---|---|---|---|---|");
    for (ri, r) in rings.iter().enumerate() {
        for (sys, name) in ["single layer", "layered"].iter().enumerate() {
            let (pm, pmin, _) = stats(&r.psnr[sys]);
            let (wm, wmin, _) = stats(&r.ws_psnr[sys]);
            let (hm, _, hmax) = stats(&r.holes[sys]);
            let (dm, _, _) = stats(&r.depth[sys]);
            let gain = if sys == 1 {
                let (gm, gmin, _) = stats(&r.gain);
                format!("{gm:.2} / {gmin:.2}")
            } else {
                String::new()
            };
            println!(
                "| {} | {name} | {pm:.2} / {pmin:.2} | {wm:.2} / {wmin:.2} | {:.3} / {:.3} | {dm:.4} | {gain} |",
                radii[ri],
                100.0 * hm,
                100.0 * hmax
            );
        }
    }
    Ok(())
}

fn bench(width: usize) -> Res<()> {
    let scene = Scene::room();
    let t = Instant::now();
    let s = systems(&scene, width)?;
    eprintln!("built the room at {width}x{} in {:.2} s", width / 2, t.elapsed().as_secs_f64());
    let sizes: Vec<String> = s
        .layered
        .iter()
        .map(|l| format!("{}x{} ({} px in domain)", l.width, l.height, l.occupied()))
        .collect();
    println!("layers: {}", sizes.join(", "));
    println!("threads: {}", rayon::current_num_threads());
    for (eye, at) in [
        (DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8)),
        (DVec3::new(0.0, 0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        (DVec3::new(-0.35, -0.35, 0.0), DVec3::new(-1.4, 1.5, -0.55)),
        (DVec3::new(0.0, 0.0, -0.5), DVec3::new(0.0, 0.0, -2.0)),
    ] {
        let cam = Camera::Perspective(Perspective::new(eye, at, DVec3::Z, 60.0, 960, 540)?);
        let layers: Vec<RenderLayer> =
            s.layered.iter().map(|image| RenderLayer { image, mapping: s.mapping }).collect();
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            last = Some(render::render(&layers, DMat4::IDENTITY, &cam, &SplatOptions::default())?);
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let st = last.expect("five runs").stats;
        println!(
            "eye {eye} -> {at}: 960x540 median {:.3} s (min {:.3}, max {:.3}), {} samples, {}/{} tiles culled, holes {:.4} %",
            times[2],
            times[0],
            times[4],
            st.counts.samples,
            st.counts.tiles_culled,
            st.counts.tiles,
            100.0 * st.hole_ratio
        );
    }
    let layers: Vec<RenderLayer> =
        s.layered.iter().map(|image| RenderLayer { image, mapping: s.mapping }).collect();
    bench_mesh(&layers)?;
    let cam = Camera::Equirect(EquirectCamera::new(DVec3::new(0.3, 0.0, 0.2), 2048, 1024)?);
    let t = Instant::now();
    let r = render::render(&layers, DMat4::IDENTITY, &cam, &SplatOptions::default())?;
    println!(
        "equirect 2048x1024 from (0.3, 0, 0.2): {:.3} s, holes {:.4} %",
        t.elapsed().as_secs_f64(),
        100.0 * r.stats.hole_ratio
    );
    Ok(())
}

/// The mesh method on the same views: mesh stages (per layer), then rasterisation medians.
fn bench_mesh(layers: &[RenderLayer]) -> Res<()> {
    let o = RasterOptions::default();
    let mut geoms: Vec<LayerGeometry> = Vec::new();
    for (k, l) in layers.iter().enumerate() {
        let t = Instant::now();
        let m = mesh::mesh_layer(l.image, &l.mapping, &MeshOptions::quadtree())?;
        let mesh_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let g = LayerGeometry::new(k, m.mesh, l, o.jump)?;
        println!(
            "mesh layer {k}: mesh_layer {mesh_s:.3} s ({:?}), geometry {:.3} s: {} triangles, {} across jumps, {} border pixels",
            m.times,
            t.elapsed().as_secs_f64(),
            g.mesh_triangles,
            g.jump_triangles,
            g.border_pixels
        );
        geoms.push(g);
    }
    let t = Instant::now();
    let again = rasterize::mesh_layers(layers, &MeshOptions::quadtree(), &o)?;
    println!("mesh stage (both layers in parallel): {:.3} s", t.elapsed().as_secs_f64());
    drop(again);
    for (eye, at) in [
        (DVec3::ZERO, DVec3::new(2.0, 0.0, -0.8)),
        (DVec3::new(0.0, 0.5, 0.0), DVec3::new(2.0, 0.0, -0.8)),
        (DVec3::new(-0.35, -0.35, 0.0), DVec3::new(-1.4, 1.5, -0.55)),
        (DVec3::new(0.0, 0.0, -0.5), DVec3::new(0.0, 0.0, -2.0)),
    ] {
        let cam = Camera::Perspective(Perspective::new(eye, at, DVec3::Z, 60.0, 960, 540)?);
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            last = Some(rasterize::render_mesh(layers, &geoms, DMat4::IDENTITY, &cam, &o)?);
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let st = last.expect("five runs").stats;
        println!(
            "mesh: eye {eye} -> {at}: 960x540 median {:.3} s (min {:.3}, max {:.3}; raster {:.3} s, compose {:.3} s), {} triangles drawn, {} tests, holes {:.4} %",
            times[2],
            times[0],
            times[4],
            st.stages[0].seconds,
            st.stages[1].seconds,
            st.counts.triangles_drawn,
            st.counts.tests,
            100.0 * st.hole_ratio
        );
    }
    Ok(())
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let is_bench = args.iter().any(|a| a == "--bench");
    let width: usize =
        value("--width").map(|w| w.parse()).transpose()?.unwrap_or(if is_bench { 4096 } else { 2048 });
    let size = match value("--size") {
        Some(s) => {
            let (w, h) = s.split_once('x').ok_or("--size WxH")?;
            (w.parse()?, h.parse()?)
        }
        None => (480, 270),
    };
    if is_bench {
        bench(width)
    } else {
        evaluate(width, size)
    }
}
