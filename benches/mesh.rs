//! Meshing the analytic room's background (6×2048² cube map) with `pomc mesh`'s defaults and with
//! `--no-simplify`: `cargo bench -p pomc --bench mesh`. Quality figures: `tests/it/mesh_figures.rs`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use pomc::mapping::{AnyMapping, Cube3x2};
use pomc::mesh::{self, MeshOptions};
use pomc_fixtures::layers::{render_on, to_layer};
use pomc_fixtures::Scene;

fn meshing(c: &mut Criterion) {
    let n = 2048;
    let m = AnyMapping::Cube(Cube3x2::new(3 * n, 2 * n).unwrap());
    let bg = to_layer(&render_on(&Scene::room(), &m).background, true);
    for (name, p) in [("default", MeshOptions::default()), ("no-simplify", MeshOptions::quadtree())] {
        let a = mesh::mesh_layer(&bg, &m, &p).unwrap();
        eprintln!("6x2048^2 {name}: {} triangles", a.mesh.triangles.len());
        c.bench_function(&format!("mesh room background 6x2048^2 {name}"), |b| {
            b.iter(|| mesh::mesh_layer(black_box(&bg), &m, &p).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = meshing
}
criterion_main!(benches);
