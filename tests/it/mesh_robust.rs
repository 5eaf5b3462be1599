//! No panics on hostile layers: NaN, ±∞, negative and huge depths, empty domains, tiny canvases.

use pomc::layer::{LayerImage, SampleType};
use pomc::mapping::{AnyMapping, Cube3x2, Equirect};
use pomc::mesh::simplify::SimplifyOptions;
use pomc::mesh::{self, accuracy, encode, export, MeshOptions};
use proptest::prelude::*;

fn image(w: usize, h: usize, z: Vec<f32>) -> LayerImage {
    let mut img = LayerImage::new(w, h);
    img.set_channel("Z", SampleType::F32, z);
    img
}

fn check(m: AnyMapping, z: Vec<f32>, p: &MeshOptions) {
    let img = image(m_w(&m), m_h(&m), z);
    simplified_is_sound(&m, &img, p);
    let out = mesh::mesh_layer(&img, &m, p).unwrap();
    assert!(out.mesh.positions.iter().all(|v| v.is_finite()));
    let s = accuracy::measure(&out.mesh.positions, &out.mesh.triangles, &img, &m);
    assert!(s.max_rel.is_finite());
    let bytes = encode::encode(&out.trees, &m).unwrap();
    assert!(encode::decode(&bytes, &img, &m).unwrap() == out.mesh);
    let r = export::to_bytes(&out.mesh, &img, None, export::Format::Glb);
    assert_eq!(r.is_err(), out.mesh.triangles.is_empty());
}

/// The simplified mesh of a hostile layer: finite, every edge in at most two triangles, no flipped
/// or edge-on triangle, within the bound wherever the quadtree mesh was, covering the same pixels.
fn simplified_is_sound(m: &AnyMapping, img: &LayerImage, p: &MeshOptions) {
    let e = p.max_error.unwrap_or(0.005);
    let raw = mesh::mesh_layer(img, m, &MeshOptions { simplify: None, ..p.clone() }).unwrap();
    let sp = SimplifyOptions { max_error: e, max_angle_deg: None, greedy: true };
    let out = mesh::mesh_layer(img, m, &MeshOptions { simplify: Some(sp), ..p.clone() }).unwrap().mesh;
    assert!(out.positions.iter().all(|v| v.is_finite()));
    assert!(out.triangles.len() <= raw.mesh.triangles.len());
    let mut edges = std::collections::BTreeMap::new();
    for t in &out.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
        let d = t.map(|v| out.positions[v as usize].normalize());
        assert!(d[0].dot(d[1].cross(d[2])) < 0.0, "flipped triangle");
    }
    assert!(edges.values().all(|&c| c <= 2), "non-manifold edge");
    let covered = |mm: &mesh::LayerMesh| {
        accuracy::hit_distances(&mm.positions, &mm.triangles, m)
            .iter()
            .map(|t| t.is_finite())
            .collect::<Vec<_>>()
    };
    assert!(covered(&out) == covered(&raw.mesh));
    let before = accuracy::measure(&raw.mesh.positions, &raw.mesh.triangles, img, m);
    let after = accuracy::measure(&out.positions, &out.triangles, img, m);
    assert!(after.max_rel <= before.max_rel.max(e) * (1.0 + 1e-6), "{before:?} -> {after:?}");
}

fn m_w(m: &AnyMapping) -> usize {
    pomc::mapping::Mapping::width(m)
}
fn m_h(m: &AnyMapping) -> usize {
    pomc::mapping::Mapping::height(m)
}

fn depth() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 0.5f32..20.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(-1.0f32),
        1 => Just(0.0f32),
        1 => Just(1e30f32),
        1 => Just(1e-30f32),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn cube_layers_never_panic(n in 1usize..7, seed in proptest::collection::vec(depth(), 6 * 6 * 6)) {
        let m = AnyMapping::Cube(Cube3x2::new(3 * n, 2 * n).unwrap());
        let z: Vec<f32> = (0..6 * n * n).map(|i| seed[i % seed.len()]).collect();
        check(m, z, &MeshOptions::quadtree());
    }

    #[test]
    fn equirect_layers_never_panic(h in 1usize..7, seed in proptest::collection::vec(depth(), 72)) {
        let m = AnyMapping::Equirect(Equirect::new(2 * h, h).unwrap());
        let z: Vec<f32> = (0..2 * h * h).map(|i| seed[i % seed.len()]).collect();
        check(m, z, &MeshOptions { feature_angle_deg: Some(5.0), ..MeshOptions::quadtree() });
    }
}

#[test]
fn empty_domain_gives_an_empty_mesh() {
    let m = AnyMapping::Cube(Cube3x2::new(24, 16).unwrap());
    check(m, vec![-1.0; 24 * 16], &MeshOptions::quadtree());
    check(m, vec![f32::NAN; 24 * 16], &MeshOptions { uniform: Some(2), ..MeshOptions::quadtree() });
}
