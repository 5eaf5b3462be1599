//! One fixture per manifest code (fixtures/manifests/CODE.xml): it must raise that code at the
//! stated line:col and path, and nothing else. The table below is the expectation.

use pomc::manifest::{diagnose, Severity, CODES};

/// (code = fixture name, line, col, path).
const EXPECTED: &[(&str, u32, u32, &str)] = &[
    ("XML_MALFORMED", 8, 1, "/"),
    ("XML_DTD_FORBIDDEN", 2, 1, "/"),
    ("XML_ENCODING_UNSUPPORTED", 1, 31, "/"),
    ("XML_ENCODING_INVALID", 5, 19, "/"),
    ("MANIFEST_ROOT_NOT_PANORAMA", 2, 1, "/Scene"),
    ("MANIFEST_VERSION_UNSUPPORTED", 2, 11, "/Panorama"),
    ("MANIFEST_UNKNOWN_ELEMENT", 5, 3, "/Panorama/Lights"),
    ("MANIFEST_UNKNOWN_ATTRIBUTE", 3, 34, "/Panorama/Mapping"),
    ("MANIFEST_MISSING_ATTRIBUTE", 6, 5, "/Panorama/Layer/Image"),
    ("MANIFEST_NUMBER_INVALID", 4, 16, "/Panorama/TransformGroup/Translate"),
    ("MANIFEST_MAPPING_MISSING", 2, 1, "/Panorama"),
    ("MANIFEST_MAPPING_UNKNOWN", 3, 12, "/Panorama/Mapping"),
    ("MANIFEST_DUPLICATE_ELEMENT", 4, 3, "/Panorama/Mapping[2]"),
    ("MANIFEST_ROTATE_AXIS_ZERO", 4, 13, "/Panorama/TransformGroup/Rotate"),
    ("MANIFEST_SCALE_ZERO", 4, 12, "/Panorama/TransformGroup/Scale"),
    ("MANIFEST_TRANSFORM_INVALID", 3, 3, "/Panorama/TransformGroup"),
    ("MANIFEST_FREEDOM_INVALID", 4, 12, "/Panorama/Freedom"),
    ("MANIFEST_FREEDOM_MISSING", 2, 1, "/Panorama"),
    ("MANIFEST_NO_LAYERS", 2, 1, "/Panorama"),
    ("MANIFEST_LAYER_NO_SOURCE", 8, 3, "/Panorama/Layer[2]"),
    ("MANIFEST_LAYER_MULTIPLE_SOURCES", 7, 5, "/Panorama/Layer/Textures"),
    ("MANIFEST_FILE_NAME_UNSAFE", 9, 31, "/Panorama/Layer[2]/Textures"),
    ("MANIFEST_ROLE_UNKNOWN", 5, 10, "/Panorama/Layer"),
    ("MANIFEST_DEPTH_RANGE_INVALID", 5, 10, "/Panorama/Layer"),
    ("MANIFEST_ORDER_DUPLICATE", 8, 3, "/Panorama/Layer[2]"),
    ("MANIFEST_PACKING_INVALID", 7, 14, "/Panorama/Layer/Packing"),
];

/// Codes without a fixture: the validator raises XML_TOO_LARGE before parsing (its own tests
/// cover it), and the truncation notice is tested below with a generated document.
/// The limits' codes are tested below with generated documents too (fixtures would be large).
const NOT_FROM_FIXTURES: &[&str] =
    &["XML_TOO_LARGE", "MANIFEST_DIAGNOSTICS_TRUNCATED", "XML_LIMIT_EXCEEDED", "MANIFEST_TOO_MANY_LAYERS"];

fn fixture(name: &str) -> Vec<u8> {
    let path = format!("{}/fixtures/manifests/{name}.xml", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn each_fixture_raises_exactly_its_code_at_its_position() {
    for &(code, line, col, path) in EXPECTED {
        let d = diagnose(&fixture(code), code);
        let found: Vec<_> = d.diagnostics.iter().map(|x| (x.code, x.line, x.col, x.path.as_str())).collect();
        assert_eq!(found, [(code, line, col, path)], "{code}: {:#?}", d.diagnostics);
        let severity = CODES.iter().find(|c| c.0 == code).unwrap().1;
        assert_eq!(d.diagnostics[0].severity, severity, "{code}");
        assert_eq!(d.manifest.is_some(), severity != Severity::Error, "{code}: manifest only without errors");
        assert!(!d.diagnostics[0].message.is_empty());
    }
}

#[test]
fn every_code_has_a_fixture() {
    for (code, _, _) in CODES {
        let covered = EXPECTED.iter().any(|e| e.0 == *code) || NOT_FROM_FIXTURES.contains(code);
        assert!(covered, "{code} has no fixture in fixtures/manifests/");
    }
}

#[test]
fn valid_fixtures_have_no_findings() {
    for name in ["valid-minimal", "native-packed", "thesis-example"] {
        let d = diagnose(&fixture(name), name);
        assert!(d.diagnostics.is_empty(), "{name}: {:#?}", d.diagnostics);
        assert!(d.manifest.is_some());
    }
}

#[test]
fn too_many_findings_are_truncated_with_a_notice() {
    let mut xml = String::from("<Panorama><Mapping type=\"CubeMapping\"/><Freedom radius=\"1\"/>");
    xml.push_str("<Layer><Image file=\"a.exr\"/></Layer>");
    for _ in 0..(pomc::manifest::MAX_DIAGNOSTICS + 10) {
        xml.push_str("<X/>");
    }
    xml.push_str("</Panorama>");
    let d = diagnose(xml.as_bytes(), "big");
    assert_eq!(d.diagnostics.len(), pomc::manifest::MAX_DIAGNOSTICS + 1);
    let last = d.diagnostics.last().unwrap();
    assert_eq!(last.code, "MANIFEST_DIAGNOSTICS_TRUNCATED");
    assert_eq!(last.severity, Severity::Info);
    assert!(d.manifest.is_some(), "warnings only");
}

#[test]
fn billion_laughs_is_refused_quickly() {
    let t = std::time::Instant::now();
    let d = diagnose(&fixture("XML_DTD_FORBIDDEN"), "lol");
    assert!(t.elapsed() < std::time::Duration::from_millis(200));
    assert_eq!(d.diagnostics[0].code, "XML_DTD_FORBIDDEN");
}

#[test]
fn all_problems_are_collected_not_only_the_first() {
    let xml = br#"<Panorama version="1">
  <TransformGroup><Scale vector="0 1 1"/><Rotate axis="0 0 0" angle="x"/></TransformGroup>
  <Layer order="3"><Image file="/abs.exr"/></Layer>
  <Layer order="3" role="sky"/>
</Panorama>"#;
    let d = diagnose(xml, "many");
    let codes: Vec<_> = d.diagnostics.iter().map(|x| x.code).collect();
    assert_eq!(
        codes,
        [
            "MANIFEST_SCALE_ZERO",
            "MANIFEST_ROTATE_AXIS_ZERO",
            "MANIFEST_NUMBER_INVALID",
            "MANIFEST_FILE_NAME_UNSAFE",
            "MANIFEST_ROLE_UNKNOWN",
            "MANIFEST_LAYER_NO_SOURCE",
            "MANIFEST_MAPPING_MISSING",
            "MANIFEST_FREEDOM_MISSING",
        ]
    );
    let e = pomc::manifest::parse(xml, "many.xml").unwrap_err();
    assert_eq!(e.code(), "MANIFEST_SCALE_ZERO");
    assert_eq!((e.line, e.col), (2, 26));
    assert!(e.to_string().starts_with("many.xml:2:26 /Panorama/TransformGroup/Scale: "), "{e}");
}

#[test]
fn deep_nesting_and_large_inputs_stay_cheap() {
    let depth = 100_000;
    let mut xml = String::from("<Panorama><Mapping type=\"Cube\"/><Freedom radius=\"1\"/>");
    xml.push_str("<Layer><Image file=\"a.exr\"/>");
    xml.push_str(&"<Deep>".repeat(depth));
    xml.push_str(&"</Deep>".repeat(depth));
    xml.push_str("</Layer>");
    // Many siblings, each an unknown element with an unknown attribute.
    for k in 0..100_000 {
        xml.push_str(&format!("<Extra n=\"{k}\"/>"));
    }
    xml.push_str("</Panorama>");
    let t = std::time::Instant::now();
    let d = diagnose(xml.as_bytes(), "deep");
    assert!(t.elapsed() < std::time::Duration::from_secs(5), "{:?}", t.elapsed());
    let m = d.manifest.expect("warnings only");
    assert_eq!(m.layers[0].extra.len(), 1);
    assert!(m.layers[0].extra[0].starts_with("<Deep><Deep>"));
}

#[test]
fn children_of_leaf_elements_are_unknown() {
    let xml = b"<Panorama><Mapping type=\"Cube\"><Faces/></Mapping><Freedom radius=\"1\"/>\n<Layer><Image file=\"a.exr\"><Alpha/></Image></Layer></Panorama>";
    let d = diagnose(xml, "leaf");
    let found: Vec<_> = d.diagnostics.iter().map(|x| (x.code, x.line, x.col, x.path.as_str())).collect();
    assert_eq!(
        found,
        [
            ("MANIFEST_UNKNOWN_ELEMENT", 1, 32, "/Panorama/Mapping/Faces"),
            ("MANIFEST_UNKNOWN_ELEMENT", 2, 28, "/Panorama/Layer/Image/Alpha"),
        ]
    );
    assert!(d.manifest.is_some());
}

#[test]
fn versions() {
    let with = |v: &str| {
        format!("<Panorama version=\"{v}\"><Mapping type=\"Cube\"/><Freedom radius=\"1\"/><Layer><Image file=\"a.exr\"/></Layer></Panorama>")
    };
    for ok in ["1", "1.0", "1.12", " 1 "] {
        let d = diagnose(with(ok).as_bytes(), ok);
        assert!(d.diagnostics.is_empty() && d.manifest.is_some(), "{ok}: {:?}", d.diagnostics);
    }
    for bad in ["2", "2.0", "1.x", "", "1.", "v1", "10"] {
        // Only the version is reported: the rest of a POMC 2 file is not judged by POMC 1 rules.
        let xml = with(bad).replace("<Freedom radius=\"1\"/>", "<Unknown/>");
        let codes: Vec<_> = diagnose(xml.as_bytes(), bad).diagnostics.iter().map(|d| d.code).collect();
        assert_eq!(codes, ["MANIFEST_VERSION_UNSUPPORTED"], "{bad}");
    }
}

/// `<Mesh>` is a typed part of a layer (spec §2, §8.1): read without warnings, written back,
/// allowed once, all three attributes required, any encoding kept for the reader to skip.
#[test]
fn mesh_element_is_typed_and_round_trips() {
    let xml = |mesh: &str| {
        format!(
            "<Panorama version=\"1\"><Mapping type=\"LatLongMapping\"/><Freedom radius=\"0.5\"/>\
             <Layer><Image file=\"a.exr\"/>{mesh}</Layer></Panorama>"
        )
    };
    let codes = |x: &str| diagnose(x.as_bytes(), "m").diagnostics.iter().map(|d| d.code).collect::<Vec<_>>();
    let ok = xml("<Mesh file=\"a.pomcmesh\" encoding=\"quadtree-bfs-zstd\" version=\"1\"/>");
    assert!(codes(&ok).is_empty(), "{:?}", codes(&ok));
    let m = diagnose(ok.as_bytes(), "m").manifest.unwrap();
    let decl = m.layers[0].mesh.clone().unwrap();
    assert!(decl.is_quadtree_v1() && decl.file == "a.pomcmesh" && m.layers[0].extra.is_empty());
    let again = diagnose(m.to_xml().as_bytes(), "m").manifest.unwrap();
    assert_eq!(again.layers[0].mesh, Some(decl));

    let other = xml("<Mesh file=\"a.obj\" encoding=\"wavefront\" version=\"7\"/>");
    let m = diagnose(other.as_bytes(), "m").manifest.unwrap();
    assert!(!m.layers[0].mesh.as_ref().unwrap().is_quadtree_v1());
    assert!(m.to_xml().contains("encoding=\"wavefront\""));

    let twice =
        xml("<Mesh file=\"a\" encoding=\"e\" version=\"1\"/><Mesh file=\"b\" encoding=\"e\" version=\"1\"/>");
    assert_eq!(codes(&twice), ["MANIFEST_DUPLICATE_ELEMENT"]);
    assert_eq!(codes(&xml("<Mesh file=\"a\" version=\"1\"/>")), ["MANIFEST_MISSING_ATTRIBUTE"]);
    let escape = xml("<Mesh file=\"../../etc/passwd\" encoding=\"quadtree-bfs-zstd\" version=\"1\"/>");
    assert_eq!(codes(&escape), ["MANIFEST_FILE_NAME_UNSAFE"]);
}

/// Limits that keep one manifest's cost linear (issue 12): 100,000 attributes on one element took
/// 30 s (the XML parser checks each against the ones before it); now they are refused by a linear
/// scan. Layers past 1024 are reported once and not read.
#[test]
fn attribute_floods_and_layer_floods_are_refused() {
    let head = "<?xml version=\"1.0\"?>\n<Panorama version=\"1\"><Freedom radius=\"0.5\"/>";
    let attrs: String = (0..100_000).map(|i| format!(" a{i}=\"1\"")).collect();
    let xml = format!(
        "{head}<Mapping type=\"LatLongMapping\"{attrs}/><Layer><Image file=\"a.exr\"/></Layer></Panorama>"
    );
    let t = std::time::Instant::now();
    let d = diagnose(xml.as_bytes(), "m");
    assert!(t.elapsed().as_secs_f64() < 2.0, "linear, not quadratic: {:?}", t.elapsed());
    let codes: Vec<_> = d.diagnostics.iter().map(|x| (x.code, x.line, x.col)).collect();
    assert_eq!(codes, [("XML_LIMIT_EXCEEDED", 2, 46)]);
    // 256 attributes are still parsed (`=` in values, comments and declarations does not count).
    let attrs: String = (0..255).map(|i| format!(" a{i}=\"x=y\"")).collect();
    let xml = format!("{head}<!-- a=b c=d --><Mapping type=\"LatLongMapping\"{attrs}/><Layer><Image file=\"a.exr\"/></Layer></Panorama>");
    let d = diagnose(xml.as_bytes(), "m");
    let expected = ["MANIFEST_UNKNOWN_ATTRIBUTE", "MANIFEST_DIAGNOSTICS_TRUNCATED"];
    let other: Vec<_> =
        d.diagnostics.iter().filter(|x| !expected.contains(&x.code)).map(|x| (x.code, &x.message)).collect();
    assert!(other.is_empty() && d.manifest.is_some(), "{other:?}");

    let layers: String = (0..3000).map(|i| format!("<Layer><Image file=\"l{i}.exr\"/></Layer>")).collect();
    let xml = format!("{head}<Mapping type=\"LatLongMapping\"/>{layers}</Panorama>");
    let d = diagnose(xml.as_bytes(), "m");
    let codes: Vec<_> = d.diagnostics.iter().map(|x| x.code).collect();
    assert_eq!(codes, ["MANIFEST_TOO_MANY_LAYERS"]);
    assert!(d.diagnostics[0].path.ends_with("Layer[1025]"), "{}", d.diagnostics[0].path);
}
