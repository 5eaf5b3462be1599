//! One case per validator code (like glTF-Validator's one test file per code): each case builds a
//! small panorama that breaks exactly one rule and checks the report names that code, with a
//! location. A last test checks every code of the table has a case, and that the spec's table
//! and the code table agree.

use std::path::Path;

use pomc::codes;
use pomc::layer::{LayerImage, SampleType};
use pomc::layer_io::{self, WriteOptions};
use pomc::validate::{self, Report, ValidateSettings};

const W: usize = 16;
const H: usize = 8;

/// A full-sphere layer at 2 m with grey colour (valid on its own).
fn layer(w: usize, h: usize) -> LayerImage {
    let n = w * h;
    let mut img = LayerImage::new(w, h);
    for c in ["R", "G", "B"] {
        img.set_channel(c, SampleType::F16, vec![0.5; n]);
    }
    img.set_channel("Z", SampleType::F32, vec![2.0; n]);
    img
}

fn write(dir: &Path, name: &str, img: &LayerImage) {
    layer_io::write_exr(&dir.join(name), img, &WriteOptions::default()).unwrap();
}

fn manifest(dir: &Path, mapping: &str, layers: &str) {
    let xml = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Panorama version=\"1\">\n  <Mapping type=\"{mapping}\"/>\n  <Freedom radius=\"0.5\"/>\n{layers}</Panorama>\n"
    );
    std::fs::write(dir.join("panorama.xml"), xml).unwrap();
}

fn one_layer(dir: &Path, img: &LayerImage) {
    write(dir, "l0.exr", img);
    manifest(dir, "LatLongMapping", "  <Layer name=\"bg\">\n    <Image file=\"l0.exr\"/>\n  </Layer>\n");
}

/// A valid background layer `l0.exr` plus a second layer `l1.exr` built by the caller.
fn with_background(dir: &Path, second: &LayerImage, attrs: &str, inner: &str) {
    write(dir, "l0.exr", &layer(W, H));
    write(dir, "l1.exr", second);
    manifest(
        dir,
        "LatLongMapping",
        &format!(
            "  <Layer name=\"bg\" order=\"0\"><Image file=\"l0.exr\"/></Layer>\n  <Layer name=\"fg\" order=\"1\" {attrs}><Image file=\"l1.exr\"/>{inner}</Layer>\n"
        ),
    );
}

fn set(img: &mut LayerImage, ch: &str, i: usize, v: f32) {
    img.channel_mut(ch).unwrap().data[i] = v;
}

fn run(dir: &Path) -> Report {
    validate::validate(dir, &ValidateSettings::default()).expect("validate runs")
}

type Case = (&'static str, fn(&Path) -> Report);

fn cases() -> Vec<Case> {
    vec![
        ("MANIFEST_IO_ERROR", |_| {
            // A regular file that fails to read even as root: reading offset 0 of a process's
            // memory is an I/O error (EIO). It used to be reported as XML_TOO_LARGE.
            run(Path::new("/proc/self/mem"))
        }),
        ("LAYER_NOT_FOUND", |d| {
            manifest(d, "LatLongMapping", "  <Layer><Image file=\"missing.exr\"/></Layer>\n");
            run(d)
        }),
        ("LAYER_PATH_ESCAPES", |d| {
            let outside = tempfile::tempdir().unwrap();
            write(outside.path(), "x.exr", &layer(W, H));
            std::os::unix::fs::symlink(outside.path().join("x.exr"), d.join("l0.exr")).unwrap();
            manifest(d, "LatLongMapping", "  <Layer><Image file=\"l0.exr\"/></Layer>\n");
            run(d)
        }),
        ("LAYER_IO_ERROR", |d| {
            // A directory where a file should be: it exists but cannot be read as a file.
            std::fs::create_dir(d.join("l0.exr")).unwrap();
            manifest(d, "LatLongMapping", "  <Layer><Image file=\"l0.exr\"/></Layer>\n");
            run(d)
        }),
        ("LAYER_UNREADABLE", |d| {
            std::fs::write(d.join("l0.exr"), b"this is not an OpenEXR file at all, just text").unwrap();
            manifest(d, "LatLongMapping", "  <Layer><Image file=\"l0.exr\"/></Layer>\n");
            run(d)
        }),
        ("LAYER_TRUNCATED", |d| {
            one_layer(d, &layer(64, 32));
            let bytes = std::fs::read(d.join("l0.exr")).unwrap();
            std::fs::write(d.join("l0.exr"), &bytes[..bytes.len() * 2 / 3]).unwrap();
            run(d)
        }),
        ("LAYER_TOO_LARGE", |d| {
            one_layer(d, &layer(W, H));
            let mut options = ValidateSettings::default();
            options.limits.max_pixels = 64;
            validate::validate(d, &options).unwrap()
        }),
        ("LAYER_DEPTH_NOT_FLOAT32", |d| {
            let mut img = layer(W, H);
            img.channel_mut("Z").unwrap().sample_type = SampleType::F16;
            one_layer(d, &img);
            run(d)
        }),
        ("LAYER_SIZE_MISMATCH", |d| {
            write(d, "l0.exr", &layer(W, H));
            manifest(
                d,
                "LatLongMapping",
                "  <Layer width=\"32\" height=\"16\"><Image file=\"l0.exr\"/></Layer>\n",
            );
            run(d)
        }),
        ("LAYER_NO_DEPTH", |d| {
            let mut img = layer(W, H);
            img.channels.retain(|c| c.name != "Z");
            one_layer(d, &img);
            run(d)
        }),
        ("LAYER_DIMENSIONS_MAPPING", |d| {
            one_layer(d, &layer(W, W));
            run(d)
        }),
        ("LAYER_EMPTY", |d| {
            let mut fg = layer(W, H);
            fg.channel_mut("Z").unwrap().data.fill(-1.0);
            with_background(d, &fg, "", "");
            run(d)
        }),
        ("CHANNELS_INCOMPLETE", |d| {
            let mut img = layer(W, H);
            img.channels.retain(|c| c.name != "B");
            one_layer(d, &img);
            run(d)
        }),
        ("DEPTH_NEGATIVE_IN_DOMAIN", |d| {
            let mut img = layer(W, H);
            img.set_channel("A", SampleType::F16, vec![1.0; W * H]);
            set(&mut img, "Z", 5, -2.0);
            one_layer(d, &img);
            run(d)
        }),
        ("DEPTH_ZERO_IN_DOMAIN", |d| {
            let mut img = layer(W, H);
            set(&mut img, "Z", 7, 0.0);
            one_layer(d, &img);
            run(d)
        }),
        ("DEPTH_UNKNOWN_IN_DOMAIN", |d| {
            let mut img = layer(W, H);
            set(&mut img, "Z", 9, f32::NAN);
            one_layer(d, &img);
            run(d)
        }),
        ("DEPTH_OUT_OF_RANGE", |d| {
            let mut fg = layer(W, H);
            fg.channel_mut("Z").unwrap().data.fill(1.5);
            with_background(d, &fg, "depthrange=\"1.0 1.2\"", "");
            run(d)
        }),
        ("DEPTH_DISCONTINUITY", |d| {
            let mut img = layer(W, H);
            for i in 0..W * H {
                if i % W >= W / 2 {
                    set(&mut img, "Z", i, 9.0);
                }
            }
            one_layer(d, &img);
            run(d)
        }),
        ("MASK_OUT_OF_RANGE", |d| {
            let mut img = layer(W, H);
            img.set_channel("A", SampleType::F16, vec![1.0; W * H]);
            set(&mut img, "A", 3, 2.0);
            one_layer(d, &img);
            run(d)
        }),
        ("MASK_DEPTH_DISAGREE", |d| {
            let mut fg = layer(W, H);
            fg.set_channel("A", SampleType::F16, vec![1.0; W * H]);
            set(&mut fg, "A", 3, 0.0);
            with_background(d, &fg, "", "");
            run(d)
        }),
        ("COLOUR_NOT_FINITE", |d| {
            let mut img = layer(W, H);
            set(&mut img, "R", 4, f32::INFINITY);
            one_layer(d, &img);
            run(d)
        }),
        ("NORMALS_NOT_UNIT", |d| {
            let mut img = layer(W, H);
            for c in ["N.X", "N.Y", "N.Z"] {
                img.set_channel(c, SampleType::F16, vec![1.0; W * H]);
            }
            one_layer(d, &img);
            run(d)
        }),
        ("COVERAGE_INCOMPLETE", |d| {
            let mut img = layer(W, H);
            set(&mut img, "Z", 20, -1.0);
            one_layer(d, &img);
            run(d)
        }),
        ("PATCH_EMPTY", |d| packed(d, "<Patch u=\"0\" v=\"0\" x=\"0\" y=\"0\" w=\"0\" h=\"2\"/>")),
        ("PATCH_OUT_OF_CANVAS", |d| packed(d, "<Patch u=\"15\" v=\"0\" x=\"0\" y=\"0\" w=\"2\" h=\"2\"/>")),
        ("PATCH_OUT_OF_ATLAS", |d| packed(d, "<Patch u=\"0\" v=\"0\" x=\"3\" y=\"0\" w=\"2\" h=\"2\"/>")),
        ("PATCH_OVERLAP_ATLAS", |d| {
            packed(
                    d,
                    "<Patch u=\"0\" v=\"0\" x=\"0\" y=\"0\" w=\"2\" h=\"2\"/><Patch u=\"8\" v=\"4\" x=\"1\" y=\"1\" w=\"2\" h=\"2\"/>",
                )
        }),
        ("PATCH_OVERLAP_CANVAS", |d| {
            packed(
                    d,
                    "<Patch u=\"0\" v=\"0\" x=\"0\" y=\"0\" w=\"2\" h=\"2\"/><Patch u=\"1\" v=\"1\" x=\"2\" y=\"2\" w=\"2\" h=\"2\"/>",
                )
        }),
        ("PATCH_CANVAS_UNDECLARED", |d| {
            write(d, "l0.exr", &layer(W, H));
            write(d, "l1.exr", &layer(4, 4));
            manifest(
                d,
                "LatLongMapping",
                "  <Layer><Image file=\"l0.exr\"/></Layer>\n  <Layer><Image file=\"l1.exr\"/><Packing atlaswidth=\"4\" atlasheight=\"4\"><Patch u=\"0\" v=\"0\" x=\"0\" y=\"0\" w=\"2\" h=\"2\"/></Packing></Layer>\n",
            );
            run(d)
        }),
        ("LAYER_DEPTH_LOSSY", |d| {
            // PXR24 rounds float32 to 24 bits: spec §4 forbids lossy compression for depth.
            use exr::prelude::*;
            let ch = |name: &str, v: f32| AnyChannel::new(name, FlatSamples::F32(vec![v; W * H]));
            let channels = vec![ch("R", 0.5), ch("G", 0.5), ch("B", 0.5), ch("Z", 2.0)];
            let encoding =
                Encoding { compression: exr::compression::Compression::PXR24, ..Encoding::FAST_LOSSLESS };
            let layer = Layer::new(
                (W, H),
                LayerAttributes::default(),
                encoding,
                AnyChannels::sort(SmallVec::from_vec(channels)),
            );
            Image::from_layer(layer).write().to_file(d.join("l0.exr")).unwrap();
            manifest(d, "LatLongMapping", "  <Layer><Image file=\"l0.exr\"/></Layer>\n");
            run(d)
        }),
        ("MESH_NOT_FOUND", |d| {
            write(d, "l0.exr", &layer(W, H));
            let mesh = "<Mesh file=\"l0.pomcmesh\" encoding=\"quadtree-bfs-zstd\" version=\"1\"/>";
            manifest(d, "LatLongMapping", &format!("  <Layer><Image file=\"l0.exr\"/>{mesh}</Layer>\n"));
            run(d)
        }),
        ("MESH_UNREADABLE", |d| {
            write(d, "l0.exr", &layer(W, H));
            std::fs::write(d.join("l0.pomcmesh"), b"POMCMESH\x01 not a mesh").unwrap();
            let mesh = "<Mesh file=\"l0.pomcmesh\" encoding=\"quadtree-bfs-zstd\" version=\"1\"/>";
            manifest(d, "LatLongMapping", &format!("  <Layer><Image file=\"l0.exr\"/>{mesh}</Layer>\n"));
            run(d)
        }),
        ("MESH_ENCODING_UNKNOWN", |d| {
            write(d, "l0.exr", &layer(W, H));
            let mesh = "<Mesh file=\"l0.obj\" encoding=\"wavefront-obj\" version=\"1\"/>";
            manifest(d, "LatLongMapping", &format!("  <Layer><Image file=\"l0.exr\"/>{mesh}</Layer>\n"));
            run(d)
        }),
    ]
}

/// A background plus a packed 4×4 atlas for a 16×8 canvas with the given patch table.
fn packed(d: &Path, patches: &str) -> Report {
    write(d, "l0.exr", &layer(W, H));
    write(d, "l1.exr", &layer(4, 4));
    manifest(
        d,
        "LatLongMapping",
        &format!(
            "  <Layer><Image file=\"l0.exr\"/></Layer>\n  <Layer width=\"{W}\" height=\"{H}\"><Image file=\"l1.exr\"/><Packing atlaswidth=\"4\" atlasheight=\"4\">{patches}</Packing></Layer>\n"
        ),
    );
    run(d)
}

#[test]
fn every_case_raises_its_code_with_a_location() {
    let mut failures = Vec::new();
    for (code, case) in cases() {
        let dir = tempfile::tempdir().unwrap();
        let report = case(dir.path());
        match report.issues.iter().find(|i| i.code == code) {
            Some(i) => {
                assert!(!i.location.is_empty(), "{code}: empty location");
                assert!(!i.message.is_empty(), "{code}: empty message");
                assert_eq!(i.severity, codes::severity(code), "{code}: severity differs from the table");
                if i.severity == validate::Severity::Error {
                    assert!(!report.valid, "{code}: an error must make the report invalid");
                }
            }
            None => failures.push(format!("{code}: not raised; got {:?}", report.issues)),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_clean_panorama_has_no_issue() {
    let dir = tempfile::tempdir().unwrap();
    let mut fg = layer(W, H);
    let z = &mut fg.channel_mut("Z").unwrap().data;
    for (i, v) in z.iter_mut().enumerate() {
        // A 4×2 block of foreground at 1 m; the rest outside.
        *v = if (4..8).contains(&(i % W)) && (2..4).contains(&(i / W)) { 1.0 } else { -1.0 };
    }
    with_background(dir.path(), &fg, "role=\"object\" depthrange=\"1 1\"", "");
    let report = run(dir.path());
    assert!(report.valid && report.issues.is_empty(), "{:?}", report.issues);
}

#[test]
fn every_layer_code_has_a_case() {
    let covered: Vec<&str> = cases().iter().map(|c| c.0).collect();
    // Codes whose trigger needs a crafted file are covered in tests/layer_io_hostile.rs.
    let elsewhere = ["LAYER_MULTIPART", "LAYER_DEEP", "LAYER_UNSUPPORTED"];
    for (code, _, _) in codes::CODES {
        assert!(covered.contains(code) || elsewhere.contains(code), "validator code {code} has no test case");
    }
}

#[test]
fn spec_table_matches_the_code_table() {
    let spec =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/spec/06-validation.md")).unwrap();
    let rows: Vec<(String, String)> = spec
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (cells.len() >= 4 && cells[1].starts_with('`'))
                .then(|| (cells[1].trim_matches('`').to_string(), cells[2].to_string()))
        })
        .collect();
    for (code, sev, _) in codes::CODES {
        assert!(
            rows.iter().any(|(c, s)| c == code && s == sev.as_str()),
            "{code} ({}) missing from spec/06-validation.md",
            sev.as_str()
        );
    }
    assert_eq!(rows.len(), codes::CODES.len(), "spec table has codes the validator does not know");
}

#[test]
fn oversized_manifest_is_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let f = std::fs::File::create(dir.path().join("panorama.xml")).unwrap();
    // A sparse 17 MiB file: refused from its size, not parsed.
    f.set_len(17 << 20).unwrap();
    let report = run(dir.path());
    assert!(report.has("XML_TOO_LARGE") && !report.valid, "{:?}", report.issues);
}

/// Patch-table findings are capped per layer (issue 12: 300,000 overlapping patches made 146 MB of
/// JSON), with a notice counting them all, and messages read as text (no Rust debug output).
#[test]
fn patch_findings_are_capped_and_readable() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "l0.exr", &layer(W, H));
    write(d.path(), "l1.exr", &layer(4, 4));
    let patches: String =
        (0..500).map(|_| "<Patch u=\"0\" v=\"0\" x=\"0\" y=\"0\" w=\"2\" h=\"2\"/>").collect();
    let l1 = format!(
        "  <Layer width=\"{W}\" height=\"{H}\"><Image file=\"l1.exr\"/><Packing atlaswidth=\"4\" atlasheight=\"4\">{patches}</Packing></Layer>\n"
    );
    manifest(d.path(), "LatLongMapping", &format!("  <Layer><Image file=\"l0.exr\"/></Layer>\n{l1}"));
    let r = run(d.path());
    let patch_issues: Vec<_> = r.issues.iter().filter(|i| i.code.starts_with("PATCH_")).collect();
    assert_eq!(patch_issues.len(), 100);
    let notice = r.issues.iter().find(|i| i.code == "MANIFEST_DIAGNOSTICS_TRUNCATED").expect("a notice");
    let counted: usize = notice.message.split(' ').next().unwrap().parse().unwrap();
    assert!(counted >= 998, "{}", notice.message);
    assert!(patch_issues[0].message.contains("overlaps patch 1 in the atlas"), "{}", patch_issues[0].message);
    assert!(r.issues.iter().all(|i| !i.message.contains('{')), "debug formatting in a message");
}
