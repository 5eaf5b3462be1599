//! Figures for docs/mesh.md (ignored by default: large canvases; run in release):
//! `cargo test --release -p pomc --test it mesh_figures -- --ignored --nocapture`.
//! Meshing time: `cargo bench -p pomc --bench mesh`.

use std::time::Instant;

use pomc::mapping::{AnyMapping, Cube3x2};
use pomc::mesh::simplify::SimplifyOptions;
use pomc::mesh::{self, accuracy, MeshOptions};
use pomc_fixtures::layers::{render_on, to_layer};
use pomc_fixtures::Scene;

fn background(n: usize) -> (AnyMapping, pomc::layer::LayerImage) {
    let m = AnyMapping::Cube(Cube3x2::new(3 * n, 2 * n).unwrap());
    let r = render_on(&Scene::room(), &m);
    (m, to_layer(&r.background, true))
}

/// Thesis 7.4: the adaptive mesh of the room background (6×1024² cube map) has ≤ 8% of the uniform
/// mesh's triangles at a p99 relative error ≤ 0.5%.
#[test]
#[ignore]
fn thesis_reproduction_cube_1024() {
    let (m, bg) = background(1024);
    let uniform =
        mesh::mesh_layer(&bg, &m, &MeshOptions { uniform: Some(1), ..MeshOptions::quadtree() }).unwrap();
    let nu = uniform.mesh.triangles.len();
    for (name, p) in [
        ("pomc mesh default: max-error 0.005 + max-angle 20, simplified", simplified(0.005, Some(20.0))),
        ("max-error 0.005 + simplified", simplified(0.005, None)),
        ("max-error 0.005 + max-angle 20, collapses only (--no-greedy)", {
            let mut p = simplified(0.005, Some(20.0));
            if let Some(s) = p.simplify.as_mut() {
                s.greedy = false;
            }
            p
        }),
        ("max-error 0.005 + max-angle 20", MeshOptions::quadtree()),
        ("max-error 0.005", MeshOptions { max_angle_deg: None, ..MeshOptions::quadtree() }),
        (
            "thesis: feature 10deg + max-angle 20",
            MeshOptions { max_error: None, feature_angle_deg: Some(10.0), ..MeshOptions::quadtree() },
        ),
    ] {
        let t = Instant::now();
        let a = mesh::mesh_layer(&bg, &m, &p).unwrap();
        let secs = t.elapsed().as_secs_f64();
        let s = accuracy::measure(&a.mesh.positions, &a.mesh.triangles, &bg, &m);
        let na = a.mesh.triangles.len();
        // Greedy faces build no quadtree; the stored encoding is the quadtrees' (built here).
        let trees = mesh::quadtrees(&bg, &m, &p).unwrap();
        let encoded = mesh::encode::encode(&trees, &m).unwrap();
        let bytes = encoded.len();
        let qt = mesh::encode::decode(&encoded, &bg, &m).unwrap().triangles.len();
        println!(
            "{name}: {na} triangles = {:.3}% of uniform {nu}; p99 rel {:.2e}, max rel {:.2e}, rms rel {:.2e}; \
             {secs:.3} s; encoded {bytes} B ({qt} quadtree triangles; {} before collapses)",
            100.0 * na as f64 / nu as f64,
            s.p99_rel,
            s.max_rel,
            s.rms_rel,
            a.quadtree_triangles
        );
        assert!(na as f64 <= 0.08 * nu as f64);
        assert!(s.p99_rel <= 0.005);
        // Thesis 7.4.2.7: a mesh of 1 M triangles in < 122 KB (the encoding is the quadtree's).
        assert!(bytes as f64 * 1e6 / (qt as f64) < 122_000.0);
    }
}

fn simplified(e: f64, max_angle_deg: Option<f64>) -> MeshOptions {
    MeshOptions {
        max_error: Some(e),
        max_angle_deg,
        simplify: Some(SimplifyOptions { max_error: e, max_angle_deg, greedy: true }),
        ..MeshOptions::quadtree()
    }
}

/// Sweep of `--max-error` on the room background (6×N² cube map, N from `POMC_MESH_N`, default 1024):
/// the quadtree alone (`--no-simplify`), quadtree + collapses (`--no-greedy`) and the default (greedy
/// insertion on clean faces, then collapses). CSV lines
/// `pomc|pomc-collapse|pomc-simplify,E,triangles,p99_rel,max_rel,seconds,face_triangles,mesh_seconds`
/// for tools/bench/plot_mesh.py: `face_triangles` leaves out the strips joining the faces (Delatin's
/// meshes have none), `mesh_seconds` the sampling of the layer into lattices (Delatin is given its
/// heightmap). Each timing is the best of `POMC_MESH_REPEAT` runs (default 3; the machine is shared).
#[test]
#[ignore]
fn sweep_max_error() {
    let n = std::env::var("POMC_MESH_N").ok().and_then(|v| v.parse().ok()).unwrap_or(1024);
    let repeat = std::env::var("POMC_MESH_REPEAT").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let (m, bg) = background(n);
    let only = std::env::var("POMC_MESH_ONLY").unwrap_or_default();
    let es: Vec<f64> = std::env::var("POMC_MESH_E")
        .map(|v| v.split(',').filter_map(|e| e.parse().ok()).collect())
        .unwrap_or_else(|_| vec![0.01, 0.005, 0.002, 0.001, 0.0005, 0.0002, 0.0001]);
    for e in es {
        let raw = MeshOptions { max_error: Some(e), max_angle_deg: None, ..MeshOptions::quadtree() };
        let mut collapse = simplified(e, None);
        if let Some(s) = collapse.simplify.as_mut() {
            s.greedy = false;
        }
        for (name, p) in [("pomc", raw), ("pomc-collapse", collapse), ("pomc-simplify", simplified(e, None))]
        {
            if !only.is_empty() && !only.split(',').any(|o| o == name) {
                continue;
            }
            let (mut secs, mut mesh_secs) = (f64::INFINITY, f64::INFINITY);
            let mut a = None;
            for _ in 0..repeat {
                let t = Instant::now();
                let out = mesh::mesh_layer(&bg, &m, &p).unwrap();
                let s = t.elapsed().as_secs_f64();
                secs = secs.min(s);
                mesh_secs = mesh_secs.min(s - out.times.sample_ms / 1e3);
                a = Some(out);
            }
            let a = a.unwrap();
            let s = accuracy::measure(&a.mesh.positions, &a.mesh.triangles, &bg, &m);
            let face = |v: u32| {
                let id = a.mesh.sources[v as usize] as usize;
                (id % (3 * n) / n, id / (3 * n) / n)
            };
            let faces = a
                .mesh
                .triangles
                .iter()
                .filter(|t| face(t[0]) == face(t[1]) && face(t[1]) == face(t[2]))
                .count();
            println!(
                "CSV {name},{e},{},{},{},{secs},{faces},{mesh_secs}",
                a.mesh.triangles.len(),
                s.p99_rel,
                s.max_rel
            );
            println!("  {:?} {:?} {:?}", a.times, a.simplify, a.greedy);
        }
    }
}
