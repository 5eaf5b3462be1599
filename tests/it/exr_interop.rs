//! Interoperability with the OpenEXR C++ library, through its Python binding
//! (`tools/exr_interop.py`, packages from `tools/requirements-test.txt`):
//! files written by `write_exr` are read by OpenEXR bit-exactly, and files written by OpenEXR
//! are read by `read_exr` bit-exactly.
//!
//! The Python packages are required: CI installs them. Set `POMC_SKIP_INTEROP=1` to skip these
//! tests where they cannot be installed; `POMC_PYTHON` selects the interpreter (default
//! `python3`).

use std::path::{Path, PathBuf};
use std::process::Command;

use pomc::layer::{LayerImage, SampleType};
use pomc::layer_io::halfbits::{f32_to_half, half_to_f32};
use pomc::layer_io::{read_exr, read_header, write_exr, Compression, ReadLimits, WriteOptions};

const COMPRESSIONS: [(Compression, &str); 5] = [
    (Compression::Zip16, "zip"),
    (Compression::Zip1, "zips"),
    (Compression::Piz, "piz"),
    (Compression::Rle, "rle"),
    (Compression::None, "none"),
];

fn python() -> String {
    std::env::var("POMC_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/exr_interop.py")
}

/// `false` when skipping is allowed and requested; panics with instructions when the Python
/// packages are missing otherwise.
fn interop_available() -> bool {
    if std::env::var("POMC_SKIP_INTEROP").is_ok_and(|v| v == "1") {
        eprintln!("POMC_SKIP_INTEROP=1: skipping the OpenEXR interoperability test");
        return false;
    }
    let out = Command::new(python()).args(["-c", "import OpenEXR, numpy"]).output();
    match out {
        Ok(o) if o.status.success() => true,
        Ok(o) => panic!(
            "the OpenEXR interoperability test needs the Python packages OpenEXR and numpy: \
             run `pip install -r tools/requirements-test.txt` (or set POMC_SKIP_INTEROP=1 to skip).\n{}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => panic!(
            "cannot run `{}` for the OpenEXR interoperability test ({e}); install Python 3 and \
             `pip install -r tools/requirements-test.txt`, set POMC_PYTHON, or set POMC_SKIP_INTEROP=1",
            python()
        ),
    }
}

fn run(args: &[&str]) {
    let out = Command::new(python()).arg(script()).args(args).output().expect("run python");
    assert!(
        out.status.success(),
        "tools/exr_interop.py {args:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Half values covering the awkward cases: NaN payloads (quiet, signalling, negative), ±inf,
/// −0.0, denormals, the largest finite value.
const HALF_SPECIALS: [u16; 10] =
    [0x7e01, 0x7c01, 0xfe00, 0x7c00, 0xfc00, 0x8000, 0x0001, 0x83ff, 0x7bff, 0x3c00];
/// Float specials likewise.
const FLOAT_SPECIALS: [u32; 9] = [
    0x7fc0_0001,
    0x7f80_0001,
    0xffc1_2345,
    0x7f80_0000,
    0xff80_0000,
    0x8000_0000,
    0x0000_0001,
    0x807f_ffff,
    0xbf80_0000,
];

/// Half colour and normals, float depth, coverage, an integer id: the channels of a real layer.
fn test_layer(w: usize, h: usize, normals: bool) -> LayerImage {
    let n = w * h;
    let half = |k: usize| -> Vec<f32> {
        (0..n)
            .map(|i| match i % 17 {
                j if j < HALF_SPECIALS.len() => {
                    half_to_f32(half::f16::from_bits(HALF_SPECIALS[(j + k) % 10]))
                }
                _ => half_to_f32(f32_to_half((i * (k + 3)) as f32 * 0.013)),
            })
            .collect()
    };
    let mut img = LayerImage::new(w, h);
    for (k, name) in ["R", "G", "B", "A"].iter().enumerate() {
        img.set_channel(name, SampleType::F16, half(k));
    }
    let z = (0..n)
        .map(|i| match i % 13 {
            j if j < FLOAT_SPECIALS.len() => f32::from_bits(FLOAT_SPECIALS[j]),
            _ => 0.5 + i as f32 * 0.731,
        })
        .collect();
    img.set_channel("Z", SampleType::F32, z);
    if normals {
        for (k, name) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
            img.set_channel(name, SampleType::F16, half(k + 5));
        }
    }
    img.set_channel("id", SampleType::U32, (0..n).map(|i| (i * 7919 % 1_000_003) as f32).collect());
    img
}

/// Write the dump directory read by the Python helper.
fn dump(img: &LayerImage, dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let mut list = String::new();
    for c in &img.channels {
        let (typ, bytes): (&str, Vec<u8>) = match c.sample_type {
            SampleType::F16 => {
                ("half", c.data.iter().flat_map(|&x| f32_to_half(x).to_bits().to_le_bytes()).collect())
            }
            SampleType::F32 => ("float", c.data.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect()),
            SampleType::U32 => ("uint", c.data.iter().flat_map(|&x| (x as u32).to_le_bytes()).collect()),
        };
        list.push_str(&format!("{} {typ} {} {}\n", c.name, img.width, img.height));
        std::fs::write(dir.join(format!("{}.bin", c.name)), bytes).unwrap();
    }
    std::fs::write(dir.join("channels.txt"), list).unwrap();
}

fn assert_same_bits(a: &LayerImage, b: &LayerImage) {
    assert_eq!((a.width, a.height, a.channels.len()), (b.width, b.height, b.channels.len()));
    for c in &a.channels {
        let d = b.channel(&c.name).unwrap_or_else(|| panic!("channel {} missing", c.name));
        assert_eq!(c.sample_type, d.sample_type, "{}", c.name);
        for (i, (x, y)) in c.data.iter().zip(&d.data).enumerate() {
            assert_eq!(x.to_bits(), y.to_bits(), "{} sample {i}", c.name);
        }
    }
}

#[test]
fn openexr_reads_what_we_write() {
    if !interop_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for (normals, (w, h)) in [(false, (67, 33)), (true, (128, 40))] {
        let img = test_layer(w, h, normals);
        let expected = tmp.path().join(format!("expected{normals}"));
        dump(&img, &expected);
        for (c, name) in COMPRESSIONS {
            let file = tmp.path().join(format!("ours_{name}_{normals}.exr"));
            write_exr(&file, &img, &WriteOptions { compression: c }).unwrap();
            run(&["read", file.to_str().unwrap(), expected.to_str().unwrap()]);
        }
    }
}

#[test]
fn we_read_what_openexr_writes() {
    if !interop_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let img = test_layer(70, 45, true);
    let source = tmp.path().join("source");
    dump(&img, &source);
    for (_, name) in COMPRESSIONS {
        for tiled in [false, true] {
            let file = tmp.path().join(format!("theirs_{name}_{tiled}.exr"));
            let mut args = vec!["write", file.to_str().unwrap(), source.to_str().unwrap(), name];
            if tiled {
                args.push("tiled");
            }
            run(&args);
            let header = read_header(&file, &ReadLimits::default()).unwrap();
            assert_eq!((header.tiled, header.compression.name()), (tiled, name));
            let back = read_exr(&file, &ReadLimits::default())
                .unwrap_or_else(|e| panic!("reading the OpenEXR file ({name}, tiled {tiled}): {e}"));
            assert_same_bits(&img, &back);
        }
    }
}
