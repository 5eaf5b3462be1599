//! No panics on hostile layers: NaN, ±∞, negative and huge depths, empty domains, tiny canvases.

use pomc::layer::{LayerImage, SampleType};
use pomc::mapping::{AnyMapping, Cube3x2, Equirect};
use pomc::mesh::{self, encode, error, export, MeshParams};
use proptest::prelude::*;

fn image(w: usize, h: usize, z: Vec<f32>) -> LayerImage {
    let mut img = LayerImage::new(w, h);
    img.set_channel("Z", SampleType::F32, z);
    img
}

fn check(m: AnyMapping, z: Vec<f32>, p: &MeshParams) {
    let img = image(m_w(&m), m_h(&m), z);
    let out = mesh::mesh_layer(&img, &m, p).unwrap();
    assert!(out.mesh.positions.iter().all(|v| v.is_finite()));
    let s = error::measure(&out.mesh.positions, &out.mesh.triangles, &img, &m);
    assert!(s.max_rel.is_finite());
    let bytes = encode::encode(&out.trees, &m).unwrap();
    assert!(encode::decode(&bytes, &img, &m).unwrap() == out.mesh);
    let r = export::to_bytes(&out.mesh, &img, None, export::Format::Glb);
    assert_eq!(r.is_err(), out.mesh.triangles.is_empty());
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
        check(m, z, &MeshParams::default());
    }

    #[test]
    fn equirect_layers_never_panic(h in 1usize..7, seed in proptest::collection::vec(depth(), 72)) {
        let m = AnyMapping::Equirect(Equirect::new(2 * h, h).unwrap());
        let z: Vec<f32> = (0..2 * h * h).map(|i| seed[i % seed.len()]).collect();
        check(m, z, &MeshParams { feature_angle_deg: Some(5.0), ..MeshParams::default() });
    }
}

#[test]
fn empty_domain_gives_an_empty_mesh() {
    let m = AnyMapping::Cube(Cube3x2::new(24, 16).unwrap());
    check(m, vec![-1.0; 24 * 16], &MeshParams::default());
    check(m, vec![f32::NAN; 24 * 16], &MeshParams { uniform: Some(2), ..MeshParams::default() });
}
