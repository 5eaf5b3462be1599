//! The `pomc` binary end to end: exit codes, JSON shapes, errors that name the file, atomic
//! outputs, and pack → unpack round trips on the room fixture.

use std::path::Path;
use std::process::{Command, Output};

use pomc::layer_io::ReadLimits;
use pomc::mapping::{AnyMapping, MappingKind};
use pomc::panorama::Panorama;

use crate::pomc;

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
}

/// `pomc build` of the bundled RGB-D room into `out`, with `extra` options.
fn build_bundled(out: &Path, extra: &[&str]) -> Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd");
    let (colour, depth) = (root.join("colour.png"), root.join("depth.exr"));
    let mut args = vec!["build", "--colour", colour.to_str().unwrap(), "--depth", depth.to_str().unwrap()];
    args.extend_from_slice(&["-o", out.to_str().unwrap()]);
    args.extend_from_slice(extra);
    pomc(&args)
}

fn room(dir: &Path) {
    let m = AnyMapping::new(MappingKind::Equirect, 256, 128).unwrap();
    pomc_fixtures::layers::write_room(dir, &m).unwrap();
}

#[test]
fn validate_exit_codes_and_json() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let ok = pomc(&["validate", dir.path().to_str().unwrap(), "--json"]);
    assert_eq!(ok.status.code(), Some(0), "{}", String::from_utf8_lossy(&ok.stderr));
    let v = json(&ok);
    assert_eq!(v["valid"], true);
    assert_eq!(v["errors"], 0);
    assert!(v["issues"].is_array());

    // The manifest path works as well as the directory.
    let by_manifest = pomc(&["validate", dir.path().join("panorama.xml").to_str().unwrap()]);
    assert_eq!(by_manifest.status.code(), Some(0));

    // Break a layer: invalid (exit 1) with the code in JSON.
    std::fs::write(dir.path().join("room.exr"), b"garbage").unwrap();
    let bad = pomc(&["validate", dir.path().to_str().unwrap(), "--json"]);
    assert_eq!(bad.status.code(), Some(1));
    let v = json(&bad);
    assert_eq!(v["valid"], false);
    let issue = &v["issues"][0];
    assert_eq!(issue["code"], "LAYER_UNREADABLE");
    assert_eq!(issue["severity"], "error");
    assert!(issue["location"].as_str().unwrap().contains("room.exr"));

    // No panorama at all: usage/I-O error (exit 2), and the error names the path.
    let none = pomc(&["validate", "/nonexistent/pano"]);
    assert_eq!(none.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&none.stderr).contains("/nonexistent/pano"));
}

#[test]
fn list_codes_covers_manifest_and_layer_codes() {
    let out = pomc(&["validate", "--list-codes", "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let v = json(&out);
    let codes: Vec<&str> = v.as_array().unwrap().iter().map(|r| r["code"].as_str().unwrap()).collect();
    assert!(codes.contains(&"XML_MALFORMED") && codes.contains(&"COVERAGE_INCOMPLETE"));
}

/// `pomc codes` lists every code once, with the error a failing command gives among them.
#[test]
fn codes_lists_findings_errors_and_warnings_once() {
    let out = pomc(&["codes", "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let v = json(&out);
    let rows = v.as_array().unwrap();
    let codes: Vec<&str> = rows.iter().map(|r| r["code"].as_str().unwrap()).collect();
    let failed = pomc(&["validate", "/nonexistent/pano", "--json"]);
    let error = json(&failed)["error"]["code"].as_str().unwrap().to_string();
    for c in ["XML_MALFORMED", "COVERAGE_INCOMPLETE", "CLI_USAGE", "INPUT_DEPTH_SOFT", error.as_str()] {
        assert_eq!(codes.iter().filter(|&&x| x == c).count(), 1, "{c} in `pomc codes`");
    }
    assert!(rows.iter().all(|r| !r["description"].as_str().unwrap().is_empty()));
    let md = pomc(&["codes", "--markdown"]);
    assert!(String::from_utf8_lossy(&md.stdout).starts_with("# 10. Codes"));
}

#[test]
fn pack_unpack_round_trip_is_bit_exact() {
    let src = tempfile::tempdir().unwrap();
    room(src.path());
    let unpacked = tempfile::tempdir().unwrap();
    let repacked = tempfile::tempdir().unwrap();
    let out =
        pomc(&["unpack", src.path().to_str().unwrap(), "-o", unpacked.path().to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let out =
        pomc(&["pack", unpacked.path().to_str().unwrap(), "-o", repacked.path().to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let report = json(&out);
    let objects = &report["layers"][1];
    assert_eq!(objects["packed"], true);
    assert!(objects["occupancy"].as_f64().unwrap() >= 0.5, "occupancy {}", objects["occupancy"]);

    let a = Panorama::open(src.path()).unwrap();
    let b = Panorama::open(unpacked.path()).unwrap();
    let c = Panorama::open(repacked.path()).unwrap();
    assert!(b.manifest.layers.iter().all(|l| l.packing.is_none()));
    for k in 0..2 {
        let la = a.read_layer(k, &ReadLimits::default()).unwrap();
        for other in [&b, &c] {
            let lb = other.read_layer(k, &ReadLimits::default()).unwrap();
            assert_eq!((la.width, la.height), (lb.width, lb.height));
            for ca in &la.channels {
                let cb = lb.channel(&ca.name).unwrap();
                assert_eq!(ca.sample_type, cb.sample_type);
                assert!(
                    ca.data.iter().zip(&cb.data).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "layer {k} channel {} differs after the round trip",
                    ca.name
                );
            }
        }
    }
}

#[test]
fn info_describes_a_panorama() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let out = pomc(&["info", dir.path().to_str().unwrap(), "--stats", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v = json(&out);
    assert_eq!(v["mapping"], "LatLongMapping");
    assert_eq!(v["layers"].as_array().unwrap().len(), 2);
    assert_eq!(v["layers"][0]["stats"]["domain_pixels"], 256 * 128);
    assert!(v["layers"][0]["stats"]["depth_min"].as_f64().unwrap() > 1.0);
}

#[test]
fn failures_are_json_with_a_code_when_asked() {
    let out = pomc(&["info", "/nonexistent/pano", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let v = json(&out);
    assert_eq!(v["error"]["code"], "PANORAMA_NOT_FOUND");
}

#[test]
fn build_from_the_bundled_rgbd_fixture_is_valid() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd");
    let out = tempfile::tempdir().unwrap();
    let report_file = out.path().join("report.json");
    let pano = out.path().join("pano");
    let run = pomc(&[
        "build",
        "--colour",
        root.join("colour.png").to_str().unwrap(),
        "--depth",
        root.join("depth.exr").to_str().unwrap(),
        "-o",
        pano.to_str().unwrap(),
        "--report",
        report_file.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let v = json(&run);
    assert_eq!(v["coverage"], 1.0);
    let layers = v["layers"].as_array().unwrap();
    assert_eq!(layers.len(), 2, "{layers:?}");
    assert_eq!(layers[0]["role"], "background");
    assert!(layers[0]["filled_pixels"].as_u64().unwrap() > 0);
    let saved: serde_json::Value = serde_json::from_slice(&std::fs::read(&report_file).unwrap()).unwrap();
    assert_eq!(saved["layers"], v["layers"]);
    let check = pomc(&["validate", pano.to_str().unwrap(), "--json"]);
    assert_eq!(check.status.code(), Some(0), "{}", String::from_utf8_lossy(&check.stdout));

    // A depth file of the wrong size is refused with a code naming both files.
    let bad = pomc(&[
        "build",
        "--colour",
        root.join("colour.png").to_str().unwrap(),
        "--depth",
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-cube/room.exr").to_str().unwrap(),
        "-o",
        out.path().join("bad").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert_eq!(json(&bad)["error"]["code"], "INPUT_SIZE_MISMATCH");
}

/// A reader that stops early (`pomc validate --list-codes | head -1`) ends `pomc` quietly: no
/// panic message, success.
#[cfg(unix)]
#[test]
fn closed_stdout_is_not_a_panic() {
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_pomc"))
        .args(["validate", "--list-codes"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pomc runs");
    // Close the read end before pomc writes: every write hits a broken pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

/// One vector syntax everywhere: `--center` takes `x,y,z` like `--eye`, negatives included, and
/// the translation lands in the manifest; the old three-value form is a usage error.
#[test]
fn vectors_are_x_y_z_everywhere() {
    let out = tempfile::tempdir().unwrap();
    let pano = out.path().join("pano");
    let build = |center: &[&str], dest: &Path| {
        build_bundled(dest, &[center, &["--json", "--fill-colour", "nearest"]].concat())
    };
    let run = build(&["--center", "-1,2.5,-0.25"], &pano);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let manifest = std::fs::read_to_string(pano.join("panorama.xml")).unwrap();
    assert!(manifest.contains(r#"<Translate vector="-1 2.5 -0.25"/>"#), "{manifest}");
    let old = build(&["--center", "1", "2", "3"], &out.path().join("old"));
    assert_eq!(old.status.code(), Some(2), "{}", String::from_utf8_lossy(&old.stdout));
    let render = pomc(&[
        "render",
        pano.to_str().unwrap(),
        "-o",
        out.path().join("v.png").to_str().unwrap(),
        "--eye",
        "-0.2,0.1,1.3",
        "--look-at",
        "-1,2.5,-0.25",
        "--size",
        "64x32",
    ]);
    assert_eq!(render.status.code(), Some(0), "{}", String::from_utf8_lossy(&render.stderr));
}

/// Every output path may name directories that do not exist yet: `render` creates them as `build`
/// does.
#[test]
fn outputs_create_their_parent_directories() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let out = dir.path().join("new/sub/view.png");
    let run = pomc(&["render", dir.path().to_str().unwrap(), "-o", out.to_str().unwrap(), "--size", "64x32"]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.is_file());
}

/// An eye outside the freedom radius renders, and says so: holes are expected there.
#[test]
fn render_says_when_the_eye_is_outside_the_freedom_radius() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let pano = dir.path().to_str().unwrap();
    let manifest = Panorama::open(dir.path()).unwrap().manifest;
    let (radius, c) =
        (manifest.freedom_radius, manifest.local_to_world().transform_point3(glam::DVec3::ZERO));
    let view = |eye: &str, json: bool| {
        let out = dir.path().join("v.png");
        let mut a = vec!["render", pano, "-o", out.to_str().unwrap(), "--size", "64x32", "--eye", eye];
        if json {
            a.push("--json");
        }
        pomc(&a)
    };
    let far = format!("{},{},{}", c.x + 3.0 * radius, c.y, c.z);
    let v = json(&view(&far, true));
    assert_eq!(v["inside_freedom_radius"], false, "{v}");
    assert!((v["eye_offset"].as_f64().unwrap() - 3.0 * radius).abs() < 1e-6, "{v}");
    let human = view(&far, false);
    assert!(String::from_utf8_lossy(&human.stdout).contains("outside the freedom radius"));
    let near = format!("{},{},{}", c.x + 0.5 * radius, c.y, c.z);
    assert_eq!(json(&view(&near, true))["inside_freedom_radius"], true);
    assert!(!String::from_utf8_lossy(&view(&near, false).stdout).contains("outside"));
}

/// Without `--look-at`, `render` looks at the centre of the panorama image (issue 32), not at its
/// left/right seam: the view's centre shows the colour of the input's centre pixel.
#[test]
fn render_looks_at_the_centre_of_the_image_by_default() {
    let dir = tempfile::tempdir().unwrap();
    // The bundled room's depth under a colour that tells azimuths apart: red grows from the
    // left edge (azimuth 0, +X) to the right, blue falls.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd");
    let (w, h) = (512, 256);
    let ramp = image::RgbImage::from_fn(w, h, |x, _| {
        let r = (255 * x / (w - 1)) as u8;
        image::Rgb([r, 128, 255 - r])
    });
    let colour = dir.path().join("ramp.png");
    ramp.save(&colour).unwrap();
    let built = dir.path().join("built");
    let depth = root.join("depth.exr");
    let run = pomc(&[
        "build",
        "--colour",
        colour.to_str().unwrap(),
        "--depth",
        depth.to_str().unwrap(),
        "-o",
        built.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let out = dir.path().join("v.png");
    let run = pomc(&[
        "render",
        built.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "64x64",
        "--fov",
        "10",
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let centre = image::open(&out).unwrap().to_rgb8().get_pixel(32, 32).0;
    // The image's centre column has red ≈ blue ≈ 128; the seam has red 0 or 255.
    assert!(
        (centre[0] as i32 - 128).abs() <= 6 && (centre[2] as i32 - 128).abs() <= 6,
        "the default view's centre is {centre:?}, not the image centre's colour (128, 128, 128)"
    );
}

/// Human output prints numbers as a person reads them: no Rust debug formatting.
#[test]
fn human_output_has_no_debug_formatting() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let runs = [
        pomc(&["info", dir.path().to_str().unwrap(), "--stats"]),
        build_bundled(&dir.path().join("built"), &["--fill-colour", "nearest"]),
    ];
    for run in runs {
        assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
        let text = String::from_utf8_lossy(&run.stdout);
        for artefact in ["Some(", "None", "x_axis", "DMat4", "[inf", "[\"", "F16 {"] {
            assert!(!text.contains(artefact), "{artefact:?} in:\n{text}");
        }
    }
}

/// Long options (`--name`) in a text, and `--output` for a `-o`.
fn long_options(text: &str) -> std::collections::BTreeSet<String> {
    let mut found = std::collections::BTreeSet::new();
    for (i, _) in text.match_indices("--") {
        let name: String = text[i + 2..]
            .chars()
            .take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '-')
            .collect();
        let before = text[..i].chars().last();
        if name.chars().next().is_some_and(|c| c.is_ascii_lowercase()) && before != Some('-') {
            found.insert(format!("--{name}"));
        }
    }
    if text.contains(" -o ") || text.contains("[-o ") {
        found.insert("--output".to_string());
    }
    found
}

/// The README's command table and `pomc CMD --help` name the same commands and options.
#[test]
fn help_agrees_with_the_readme() {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md")).unwrap();
    let top = String::from_utf8(pomc(&["--help"]).stdout).unwrap();
    let mut commands = Vec::new();
    for row in readme.lines().filter(|l| l.starts_with("| `pomc ")) {
        // The first cell ends at the first `|` not escaped as `\|`.
        let cell_end =
            row[1..].match_indices('|').map(|(i, _)| i + 1).find(|&i| &row[i - 1..i] != "\\").unwrap();
        let usage = &row[1..cell_end];
        let command = usage.split('`').nth(1).unwrap().split_whitespace().nth(1).unwrap().to_string();
        let help = String::from_utf8(pomc(&[&command, "--help"]).stdout).unwrap();
        // Option lines of the help: `  -o, --output <OUTPUT>  …` or `      --json  …`.
        let options: String = help
            .lines()
            .map(str::trim_start)
            .filter(|l| l.starts_with("--") || (l.starts_with('-') && l.get(2..3) == Some(",")))
            .map(|l| l.split_whitespace().find(|w| w.starts_with("--")).unwrap_or(""))
            .collect::<Vec<_>>()
            .join(" ");
        let mut in_help = long_options(&options);
        for global in ["--help", "--json", "--quiet", "--version"] {
            in_help.remove(global);
        }
        let mut in_readme = long_options(usage);
        in_readme.remove("--json");
        assert_eq!(in_readme, in_help, "`pomc {command}`: README table vs --help");
        assert!(top.contains(&format!("  {command} ")), "`pomc --help` does not list {command}");
        commands.push(command);
    }
    for line in top.lines().skip_while(|l| !l.starts_with("Commands:")).skip(1).take_while(|l| !l.is_empty())
    {
        let name = line.split_whitespace().next().unwrap();
        assert!(name == "help" || commands.iter().any(|c| c == name), "README table lacks `pomc {name}`");
    }
}

/// Colour management: an sRGB PNG is decoded to linear layers and a PNG render encodes it again, so
/// a render from the centre gives back the input's codes (not display values taken for linear ones,
/// which came out washed out: 142 → 192). EXR input is linear as stored.
#[test]
fn srgb_in_srgb_out() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (128u32, 64u32);
    let codes = [[142u8, 129, 113], [30, 200, 90], [250, 5, 128], [0, 0, 0]];
    // Four vertical bands of one code each, so a render's filters see no edge in each band's middle.
    let band = |x: u32| codes[(x * 4 / w) as usize];
    let png = image::RgbImage::from_fn(w, h, |x, _| image::Rgb(band(x)));
    png.save(dir.path().join("c.png")).unwrap();
    let mut depth = pomc::layer::LayerImage::new(w as usize, h as usize);
    depth.set_channel("Z", pomc::layer::SampleType::F32, vec![2.0; (w * h) as usize]);
    pomc::layer_io::write_exr(&dir.path().join("d.exr"), &depth, &Default::default()).unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let run = pomc(&["build", "--colour", &p("c.png"), "--depth", &p("d.exr"), "-o", &p("pano")]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let layer =
        pomc::layer_io::read_exr(&dir.path().join("pano/background.exr"), &Default::default()).unwrap();
    let r = &layer.channel("R").unwrap().data;
    assert!(
        (r[0] - pomc::colour::srgb_to_linear(142.0 / 255.0)).abs() < 1e-3,
        "layer R {} is not linear",
        r[0]
    );
    let run = pomc(&["render", &p("pano"), "-o", &p("v.png"), "--camera", "equirect", "--size", "128x64"]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    let out = image::open(dir.path().join("v.png")).unwrap().to_rgb8();
    for (x, y, px) in out.enumerate_pixels() {
        // Away from the band edges and the poles, where every band meets (the renderer's filter
        // reaches a couple of pixels).
        if (x % (w / 4)) < 4 || (x % (w / 4)) >= w / 4 - 4 || y < 4 || y >= h - 4 {
            continue;
        }
        let want = band(x);
        assert!((0..3).all(|c| px.0[c].abs_diff(want[c]) <= 1), "pixel ({x}, {y}): {:?} vs {want:?}", px.0);
    }
}

/// `convert` takes a panorama: every layer to the other mapping (packed ones unpacked, then packed
/// again), a valid panorama out, and the same view from the centre as the input's.
#[test]
fn convert_takes_a_panorama() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("eq");
    room(&src);
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let run = pomc(&["convert", src.to_str().unwrap(), "-o", &p("cube"), "--to", "cube", "--json"]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(json(&run)["layers"], 2);
    let cube = Panorama::open(&dir.path().join("cube")).unwrap();
    assert_eq!(cube.manifest.mapping.kind, pomc::manifest::MappingKind::Cube3x2);
    assert!(cube.manifest.layers[1].packing.is_some(), "the sparse objects layer is packed again");
    let check = pomc(&["validate", &p("cube"), "--json"]);
    assert_eq!(json(&check)["errors"], 0, "{}", String::from_utf8_lossy(&check.stdout));
    assert_eq!(json(&check)["warnings"], 0, "{}", String::from_utf8_lossy(&check.stdout));
    let view = |pano: &str, out: &str| {
        let r = pomc(&["render", pano, "-o", out, "--camera", "equirect", "--size", "256x128"]);
        assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
        image::open(out).unwrap().to_rgb8()
    };
    let (a, b) = (view(src.to_str().unwrap(), &p("a.png")), view(&p("cube"), &p("b.png")));
    let diff: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y) as u64).sum();
    let mean = diff as f64 / a.as_raw().len() as f64;
    assert!(
        mean < 4.0,
        "mean difference {mean} codes between the views of the input and the converted panorama"
    );
    // Converting to the mapping it already has is a usage error.
    let same = pomc(&["convert", src.to_str().unwrap(), "-o", &p("same"), "--to", "equirect"]);
    assert_eq!(same.status.code(), Some(2));
}

/// Killing `build` (over an existing output) or an in-place `pack`/`unpack` at any moment leaves a
/// valid panorama (the old or the new one, spec §1.3), and the next run clears what was left.
#[test]
fn killed_writes_leave_a_whole_panorama() {
    let dir = tempfile::tempdir().unwrap();
    let pano = dir.path().join("pano");
    let p = pano.to_str().unwrap();
    assert_eq!(build_bundled(&pano, &["--quiet"]).status.code(), Some(0));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd");
    let (colour, depth) = (root.join("colour.png"), root.join("depth.exr"));
    let (c, d) = (colour.to_str().unwrap(), depth.to_str().unwrap());
    let runs: [Vec<&str>; 3] = [
        vec!["unpack", p, "-o", p, "--quiet"],
        vec!["pack", p, "-o", p, "--quiet"],
        vec!["build", "--colour", c, "--depth", d, "-o", p, "--no-pack", "--quiet"],
    ];
    // Kill times spread over each command's own run time (measured here: machines differ).
    for run in &runs {
        let t = std::time::Instant::now();
        assert_eq!(pomc(run).status.code(), Some(0));
        let full = t.elapsed();
        for k in 1..16u32 {
            let mut child = Command::new(env!("CARGO_BIN_EXE_pomc")).args(run).spawn().unwrap();
            std::thread::sleep(full * k / 16);
            let _ = child.kill();
            child.wait().unwrap();
            let check = pomc(&["validate", p, "--json"]);
            assert_eq!(
                check.status.code(),
                Some(0),
                "{run:?} killed at {k}/16: {}",
                String::from_utf8_lossy(&check.stdout)
            );
        }
    }
    assert_eq!(build_bundled(&pano, &["--quiet"]).status.code(), Some(0));
    let left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .chain(std::fs::read_dir(&pano).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("pomc-tmp") || n.contains("pomc-old"))
        .collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
}

/// Options outside their domain are refused before any work, with `CLI_USAGE` and the range
/// (issue 12: NaN, infinities, zero and negative values used to be accepted).
#[test]
fn options_outside_their_domain_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let d = dir.path().to_str().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    let build = |extra: &[&str]| {
        let mut a = vec!["build", "--colour", "c.png", "--depth", "d.exr", "-o", o];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let mut cases: Vec<Vec<String>> = Vec::new();
    for v in ["nan", "0", "-1", "inf"] {
        cases.push(build(&["--depth-scale", v]));
    }
    for (opt, vals) in [
        ("--center", &["nan,0,0", "1,2"][..]),
        ("--jump", &["nan", "inf", "-0.1"]),
        ("--fold-deg", &["nan", "-1", "0", "181"]),
        ("--depth-bands", &["nan", "-1", "2,inf"]),
        ("--fill-margin", &["-1", "nan"]),
        ("--freedom-radius", &["0", "nan"]),
    ] {
        for v in vals {
            cases.push(build(&[&format!("{opt}={v}")]));
        }
    }
    // 0 is allowed for these two: it turns the test off, as their help says.
    for v in ["nan", "-1", "inf"] {
        cases.push(s(&["mesh", d, "-o", "m.glb", "--max-error", v]));
        cases.push(s(&["mesh", d, "-o", "m.glb", "--max-angle", v]));
    }
    cases.push(s(&["mesh", d, "-o", "m.glb", "--max-angle", "181"]));
    for v in ["nan", "-1", "inf", "0", "1.5"] {
        cases.push(s(&["pack", d, "-o", o, "--threshold", v]));
    }
    for v in ["nan", "-1", "inf", "0"] {
        cases.push(s(&["validate", d, &format!("--jump-threshold={v}")]));
    }
    cases.push(s(&["render", d, "-o", "v.png", "--fov", "180"]));
    for mut args in cases {
        args.push("--json".into());
        let run = Command::new(env!("CARGO_BIN_EXE_pomc")).args(&args).output().unwrap();
        assert_eq!(run.status.code(), Some(2), "{args:?}");
        let v = json(&run);
        assert_eq!(v["error"]["code"], "CLI_USAGE", "{args:?}: {v}");
        assert!(!out.exists(), "{args:?} wrote its output");
    }
}

/// CRC-32 (IEEE) of PNG chunks, to craft headers.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A PNG of its signature, header and empty data: it declares `w × h` RGB8 and holds no pixels.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    for chunk in [&b"IDAT"[..], b"IEND"] {
        png.extend(0u32.to_be_bytes());
        png.extend(chunk);
        png.extend(crc32(chunk).to_be_bytes());
    }
    png
}

/// Sizes come from the headers before anything is decoded (issue 12): a 33-byte PNG declaring
/// 30000 × 15000 (57 bytes) is refused at once with INPUT_TOO_LARGE and how to raise the limit; colour and
/// depth of different sizes are refused before either is decoded.
#[test]
fn build_checks_sizes_from_headers_first() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let depth = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd/depth.exr");
    let d = depth.to_str().unwrap();
    std::fs::write(p("bomb.png"), png_header_only(30000, 15000)).unwrap();
    let t = std::time::Instant::now();
    let run = pomc(&["build", "--colour", &p("bomb.png"), "--depth", d, "-o", &p("o"), "--json"]);
    assert_eq!(run.status.code(), Some(2));
    let v = json(&run);
    assert_eq!(v["error"]["code"], "INPUT_TOO_LARGE", "{v}");
    assert!(v["error"]["message"].as_str().unwrap().contains("--max-pixels"), "{v}");
    assert!(t.elapsed().as_secs() < 30, "refused from the header, not after decoding");
    // A colour header of another shape than the depth (a 3:2 cube map beside a 2:1 equirect): the
    // mismatch, not the missing pixels, is reported. (Depth of the same shape at another
    // resolution is resampled, not refused.)
    let header = pomc::layer_io::read_header(&depth, &ReadLimits::default()).unwrap();
    std::fs::write(p("small.png"), png_header_only(header.height as u32 * 3 / 2, header.height as u32))
        .unwrap();
    let run = pomc(&["build", "--colour", &p("small.png"), "--depth", d, "-o", &p("o"), "--json"]);
    assert_eq!(json(&run)["error"]["code"], "INPUT_SIZE_MISMATCH");
    // --max-pixels lowers (or raises) the limit.
    let colour = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd/colour.png");
    let args = ["build", "--colour", colour.to_str().unwrap(), "--depth", d, "-o", &p("o"), "--json"];
    let run = pomc(&[&args[..], &["--max-pixels", "1000"]].concat());
    assert_eq!(json(&run)["error"]["code"], "INPUT_TOO_LARGE");
    assert!(!dir.path().join("o").exists());
}

/// A FIFO, a directory or a device where a file is expected is refused at once, never waited on
/// or read forever (issue 12).
#[cfg(unix)]
#[test]
fn non_regular_files_are_refused_without_hanging() {
    let dir = tempfile::tempdir().unwrap();
    room(dir.path());
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    assert!(Command::new("mkfifo").arg(p("fifo.png")).status().unwrap().success());
    let depth = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/data/room-rgbd/depth.exr");
    let runs: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "build".into(),
                "--colour".into(),
                p("fifo.png"),
                "--depth".into(),
                depth.display().to_string(),
                "-o".into(),
                p("o"),
            ],
            "INPUT_UNREADABLE",
        ),
        (
            vec!["render".into(), p(""), "-o".into(), p("v-#.png"), "--path".into(), "/dev/zero".into()],
            "RENDER_CAMERA_PATH",
        ),
        (
            vec!["render".into(), p(""), "-o".into(), p("v-#.png"), "--path".into(), p("fifo.png")],
            "RENDER_CAMERA_PATH",
        ),
    ];
    for (mut args, code) in runs {
        args.push("--json".into());
        let mut child = Command::new(env!("CARGO_BIN_EXE_pomc"))
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let t = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() {
            if t.elapsed().as_secs() > 20 {
                let _ = child.kill();
                panic!("{args:?} hangs");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert_eq!(json(&out)["error"]["code"], code, "{args:?}");
    }
    // A layer file that is a FIFO: validate reports it instead of blocking.
    std::fs::remove_file(dir.path().join("room.exr")).unwrap();
    assert!(Command::new("mkfifo").arg(p("room.exr")).status().unwrap().success());
    let check = pomc(&["validate", &p(""), "--json"]);
    assert_eq!(check.status.code(), Some(1));
    assert_eq!(
        json(&check)["issues"][0]["code"],
        "LAYER_IO_ERROR",
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );
}

/// A `--report` that cannot be written is refused before the build, not after the panorama is
/// written (the run used to write everything and then exit 2).
#[test]
fn an_unwritable_report_is_refused_before_building() {
    let dir = tempfile::tempdir().unwrap();
    let pano = dir.path().join("pano");
    let report = dir.path().to_str().unwrap();
    let run = build_bundled(&pano, &["--report", report, "--json"]);
    assert_eq!(run.status.code(), Some(2));
    assert_eq!(json(&run)["error"]["code"], "CLI_USAGE");
    assert!(!pano.exists(), "nothing written");
}
