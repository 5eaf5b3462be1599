//! The thesis's manifest (§6.2.1, fixtures/manifests/thesis-example.xml, ISO-8859-1) must parse
//! verbatim, place the panorama as worked out by hand, and survive a write/read round trip.

use glam::DVec3;
use pomc::manifest::{diagnose, parse, LayerSource, MappingKind, Transform};

/// Byte for byte the example of the thesis digest §2 (ASCII, hence also valid ISO-8859-1).
const THESIS: &str = r#"<?xml version="1.0" encoding="iso-8859-1"?>
<Panorama>
   <TransformGroup> <!-- Affine transformation LocalToWorld -->
       <Translate vector='0 0 1.15'/>
       <Rotate axis='0 0 1' angle='90'/>
       <Scale vector='-1 1 1 ' />
    </TransformGroup>
   <Mapping type='LatLongMapping'/>
   <Freedom radius="0.5" />
   <Layer>
       <Textures mapname="Background.png" depthname="Background_d.exr" normals=""/>
    </Layer>
   <Layer>
       <Textures mapname="Foreground.png" depthname="Foreground_d.exr" normals=""/>
    </Layer>
</Panorama>
"#;

#[test]
fn fixture_is_the_verbatim_example() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/manifests/thesis-example.xml");
    assert_eq!(std::fs::read(path).unwrap(), THESIS.as_bytes());
}

#[test]
fn thesis_example_parses() {
    let m = parse(THESIS.as_bytes(), "thesis.xml").unwrap();
    assert_eq!(m.version, "1");
    assert_eq!(
        m.transforms,
        [
            Transform::Translate([0.0, 0.0, 1.15]),
            Transform::Rotate { axis: [0.0, 0.0, 1.0], angle_deg: 90.0 },
            Transform::Scale([-1.0, 1.0, 1.0]),
        ]
    );
    assert_eq!(m.mapping.kind, MappingKind::Equirect);
    assert_eq!(m.freedom_radius, 0.5);
    assert_eq!(m.layers.len(), 2);
    assert_eq!(
        m.layers[1].source,
        LayerSource::Thesis {
            mapname: "Foreground.png".into(),
            depthname: "Foreground_d.exr".into(),
            normals: None
        }
    );
    assert_eq!(m.layers[1].origin.layer.path, "/Panorama/Layer[2]");
    assert_eq!((m.layers[1].origin.layer.pos.line, m.layers[1].origin.layer.pos.col), (13, 4));
}

#[test]
fn thesis_local_to_world_by_hand() {
    // p_world = T(0,0,1.15) · Rz(90°) · S(−1,1,1) · p_local, the last listed applied first:
    //   (1,0,0) --S(−1,1,1)--> (−1,0,0) --Rz(90°): (x,y)->(−y,x)--> (0,−1,0) --T--> (0,−1,1.15).
    //   (0,1,0) --S--> (0,1,0) --Rz--> (−1,0,0) --T--> (−1,0,1.15).
    //   (0,0,2) --S--> (0,0,2) --Rz--> (0,0,2) --T--> (0,0,3.15).
    let m = parse(THESIS.as_bytes(), "thesis.xml").unwrap().local_to_world();
    let cases = [
        (DVec3::X, DVec3::new(0.0, -1.0, 1.15)),
        (DVec3::Y, DVec3::new(-1.0, 0.0, 1.15)),
        (DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 0.0, 3.15)),
        (DVec3::ZERO, DVec3::new(0.0, 0.0, 1.15)),
    ];
    for (local, world) in cases {
        let got = m.transform_point3(local);
        assert!((got - world).length() < 1e-12, "{local} -> {got}, expected {world}");
    }
    // The full matrix, column-major: columns are the images of the axes, then the translation.
    let expected = [0.0, -1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.15, 1.0];
    for (g, e) in m.to_cols_array().iter().zip(expected) {
        assert!((g - e).abs() < 1e-12, "{m}");
    }
}

#[test]
fn thesis_example_round_trips_through_to_xml() {
    let mut m = parse(THESIS.as_bytes(), "thesis.xml").unwrap();
    let xml = m.to_xml();
    assert!(xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Panorama version=\"1\">"));
    assert!(
        xml.contains("<Textures mapname=\"Background.png\" depthname=\"Background_d.exr\" normals=\"\"/>")
    );
    let d = diagnose(xml.as_bytes(), "out.xml");
    assert!(d.diagnostics.is_empty(), "{:#?}", d.diagnostics);
    let mut back = d.manifest.unwrap();
    m.clear_origins();
    back.clear_origins();
    assert_eq!(back, m);
}

#[test]
fn latin1_names_are_decoded() {
    let xml = THESIS.replace("Background.png", "Fundo_sal\u{e3}o.png");
    let bytes: Vec<u8> = xml.chars().map(|c| c as u8).collect(); // Latin-1 encoding
    let m = parse(&bytes, "latin1.xml").unwrap();
    match &m.layers[0].source {
        LayerSource::Thesis { mapname, .. } => assert_eq!(mapname, "Fundo_salão.png"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn mapping_aliases_are_accepted() {
    for (name, kind) in [
        ("Equirect", MappingKind::Equirect),
        ("EquirectMapping", MappingKind::Equirect),
        ("CubeMapping", MappingKind::Cube3x2),
        ("Cube", MappingKind::Cube3x2),
        ("Cube3x2", MappingKind::Cube3x2),
    ] {
        let xml = THESIS.replace("'LatLongMapping'", &format!("'{name}'"));
        assert_eq!(parse(xml.as_bytes(), "m.xml").unwrap().mapping.kind, kind, "{name}");
    }
}

#[test]
fn the_thesis_original_comment_before_the_root_is_fine() {
    // The thesis text (not the digest) has a comment between the declaration and <Panorama>.
    let xml = THESIS.replacen("?>\n", "?>\n<!-- Panorama: anotacoes -->\n", 1);
    let d = diagnose(xml.as_bytes(), "c.xml");
    assert!(d.diagnostics.is_empty(), "{:#?}", d.diagnostics);
    assert_eq!(d.manifest.unwrap().layers.len(), 2);
}
