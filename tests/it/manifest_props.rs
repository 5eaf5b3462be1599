//! Properties: `diagnose` never panics on any bytes, and `parse(to_xml(m)) == m` (origins aside).

use pomc::manifest::{
    diagnose, parse, LayerDecl, LayerOrigin, LayerSource, Manifest, MappingDecl, MappingKind, MeshDecl,
    Packing, Role, Transform,
};
use pomc::pack::Patch;
use proptest::prelude::*;

const SEED: &str = include_str!("../../fixtures/manifests/native-packed.xml");
const THESIS: &[u8] = include_bytes!("../../fixtures/manifests/thesis-example.xml");

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1e6f64..1e6,
        any::<f64>().prop_filter("finite", |v| v.is_finite()),
        Just(0.1),
        Just(-0.0),
        Just(1e-300)
    ]
}

fn nonzero() -> impl Strategy<Value = f64> {
    finite().prop_filter("non-zero", |v| *v != 0.0)
}

fn transform() -> impl Strategy<Value = Transform> {
    prop_oneof![
        prop::array::uniform3(finite()).prop_map(Transform::Translate),
        (prop::array::uniform3(finite()), finite())
            .prop_filter("axis", |(a, _)| a.iter().any(|c| *c != 0.0))
            .prop_map(|(axis, angle_deg)| Transform::Rotate { axis, angle_deg }),
        prop::array::uniform3(nonzero()).prop_map(Transform::Scale),
    ]
}

fn file() -> impl Strategy<Value = String> {
    "[a-zA-Z0-9_ é&<>'\"-]{1,10}(/[a-z]{1,4}){0,2}\\.exr"
}

fn source() -> impl Strategy<Value = LayerSource> {
    prop_oneof![
        file().prop_map(|file| LayerSource::Native { file }),
        (file(), file(), prop::option::of(file()))
            .prop_map(|(mapname, depthname, normals)| LayerSource::Thesis { mapname, depthname, normals }),
    ]
}

fn role() -> impl Strategy<Value = Role> {
    prop::sample::select(vec![
        Role::Background,
        Role::Object,
        Role::Floor,
        Role::Ceiling,
        Role::Wall,
        Role::Infinity,
        Role::Light,
    ])
}

fn packing() -> impl Strategy<Value = Packing> {
    let patch = prop::array::uniform6(any::<u32>()).prop_map(|[u, v, x, y, w, h]| Patch { u, v, x, y, w, h });
    (1u32.., 1u32.., prop::collection::vec(patch, 0..4))
        .prop_map(|(atlas_width, atlas_height, patches)| Packing { atlas_width, atlas_height, patches })
}

fn depth_range() -> impl Strategy<Value = (f32, f32)> {
    (1e-6f32..1e6, 0f32..1e6).prop_map(|(min, d)| (min, min + d))
}

fn layer(order: u32) -> impl Strategy<Value = LayerDecl> {
    (
        prop::option::of("[ -~\t\n\ré]{0,12}"),
        prop::option::of(role()),
        prop::option::of(Just(order)),
        source(),
        prop::option::of((1u32.., 1u32..)),
        prop::option::of(depth_range()),
        prop::option::of(1u32..20),
        prop::option::of(packing()),
        prop::sample::select(vec![vec![], vec!["<Mask file=\"m.png\"/>".to_string()]]),
        prop::option::of(mesh_decl()),
    )
        .prop_map(|(name, role, order, source, size, depth_range, mip_levels, packing, extra, mesh)| {
            LayerDecl {
                name,
                role,
                order,
                source,
                width: size.map(|s| s.0),
                height: size.map(|s| s.1),
                depth_range,
                mip_levels,
                packing,
                mesh,
                extra,
                origin: LayerOrigin::default(),
            }
        })
}

fn mesh_decl() -> impl Strategy<Value = MeshDecl> {
    ("[a-z][a-z0-9_]{0,8}\\.pomcmesh", prop::sample::select(vec!["quadtree-bfs-zstd", "x-other"]), "[1-3]")
        .prop_map(|(file, encoding, version)| MeshDecl { file, encoding: encoding.to_string(), version })
}

fn manifest() -> impl Strategy<Value = Manifest> {
    (
        prop::collection::vec(transform(), 0..5).prop_filter("a finite, invertible LocalToWorld", |ops| {
            let m = ops.iter().fold(glam::DMat4::IDENTITY, |m, op| m * op.matrix());
            let det = m.determinant();
            m.to_cols_array().iter().all(|x| x.abs() <= 1e150)
                && det.is_finite()
                && det != 0.0
                && m.inverse().is_finite()
        }),
        prop::sample::select(vec![MappingKind::Equirect, MappingKind::Cube3x2]),
        prop_oneof![Just(0.0), (1e-9f64..1e3)],
        prop::collection::vec(layer(0), 1..4),
    )
        .prop_map(|(transforms, kind, freedom_radius, mut layers)| {
            // Distinct orders: duplicates are only a warning, but keep the output clean.
            for (k, l) in layers.iter_mut().enumerate() {
                l.order = l.order.map(|_| k as u32);
            }
            Manifest {
                version: "1".into(),
                transforms,
                mapping: MappingDecl { kind },
                freedom_radius,
                layers,
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn to_xml_round_trips(m in manifest()) {
        let xml = m.to_xml();
        let mut back = parse(xml.as_bytes(), "rt.xml").map_err(|e| TestCaseError::fail(format!("{e}\n{xml}")))?;
        back.clear_origins();
        prop_assert_eq!(back, m, "{}", xml);
    }

    #[test]
    fn diagnose_never_panics_on_random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let _ = diagnose(&bytes, "random");
    }

    #[test]
    fn diagnose_never_panics_on_mutated_manifests(
        thesis in any::<bool>(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8)
    ) {
        let mut bytes = if thesis { THESIS.to_vec() } else { SEED.as_bytes().to_vec() };
        for (at, byte, op) in edits {
            let i = at.index(bytes.len().max(1)).min(bytes.len());
            match op {
                0 if i < bytes.len() => bytes[i] = byte,
                1 => bytes.insert(i, byte),
                _ if i < bytes.len() => { bytes.remove(i); }
                _ => {}
            }
        }
        let d = diagnose(&bytes, "mutated");
        let has_error = d.diagnostics.iter().any(|x| x.severity == pomc::manifest::Severity::Error);
        prop_assert_eq!(d.manifest.is_some(), !has_error);
        for x in &d.diagnostics {
            prop_assert!(x.line >= 1 && x.col >= 1);
            prop_assert!(x.path.starts_with('/'));
        }
    }

    #[test]
    fn diagnose_never_panics_on_attribute_garbage(value in "\\PC{0,24}") {
        let esc = pomc::manifest::escape_attr(&value);
        for attr in ["vector", "axis", "angle", "radius", "width", "depthrange", "file", "type", "version"] {
            let xml = SEED.replace("vector=\"0 0 1.15\"", &format!("{attr}=\"{esc}\""))
                .replace("radius=\"0.5\"", &format!("radius=\"{esc}\""))
                .replace("depthrange=\"1.2 7.5\"", &format!("depthrange=\"{esc}\""));
            let _ = diagnose(xml.as_bytes(), "attr");
        }
    }
}
