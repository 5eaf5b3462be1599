//! Tests of layer file I/O: bit-exact round trips, hostile and broken files, the thesis form.

use std::path::{Path, PathBuf};
use std::time::Instant;

use proptest::prelude::*;

use super::*;
use crate::layer::{LayerImage, SampleType};

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// A small layer with half colour, float depth and a u32 id channel.
fn sample_layer(w: usize, h: usize) -> LayerImage {
    let n = w * h;
    let mut img = LayerImage::new(w, h);
    let ramp = |k: f32| (0..n).map(|i| ((i as f32) * k).fract()).collect::<Vec<_>>();
    img.set_channel(
        "R",
        SampleType::F16,
        ramp(0.37).iter().map(|&x| halfbits::half_to_f32(halfbits::f32_to_half(x))).collect(),
    );
    img.set_channel("G", SampleType::F16, vec![0.5; n]);
    img.set_channel("Z", SampleType::F32, (0..n).map(|i| 1.0 + i as f32 * 0.001).collect());
    img.set_channel("id", SampleType::U32, (0..n).map(|i| (i % 1000) as f32).collect());
    img
}

/// Bitwise comparison by channel name (file order is alphabetical, not insertion order).
fn assert_same_bits(a: &LayerImage, b: &LayerImage) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    assert_eq!(a.channels.len(), b.channels.len());
    for c in &a.channels {
        let d = b.channel(&c.name).unwrap_or_else(|| panic!("channel {} missing", c.name));
        assert_eq!(c.sample_type, d.sample_type, "type of {}", c.name);
        for (i, (x, y)) in c.data.iter().zip(&d.data).enumerate() {
            assert_eq!(x.to_bits(), y.to_bits(), "channel {} sample {i}: {x} vs {y}", c.name);
        }
    }
}

fn write(dir: &Path, name: &str, img: &LayerImage, compression: Compression) -> PathBuf {
    let p = dir.join(name);
    write_exr(&p, img, &WriteOptions { compression }).unwrap();
    p
}

#[test]
fn a_layer_written_owned_is_the_same_file() {
    let d = tmp();
    for c in [Compression::None, Compression::Zip16, Compression::Piz] {
        let img = sample_layer(37, 19);
        let options = WriteOptions { compression: c };
        let bytes = write_exr_bytes(Path::new("x.exr"), &img, &options).unwrap();
        let (by_ref, owned) = (d.path().join("ref.exr"), d.path().join("owned.exr"));
        write_exr(&by_ref, &img, &options).unwrap();
        super::write_exr_owned(&owned, img, &options).unwrap();
        assert_eq!(std::fs::read(&by_ref).unwrap(), bytes, "{c:?}");
        assert_eq!(std::fs::read(&owned).unwrap(), bytes, "{c:?}");
    }
    let lossy = super::write_exr_owned(
        &d.path().join("p.exr"),
        sample_layer(4, 4),
        &WriteOptions { compression: Compression::Pxr24 },
    );
    assert!(lossy.is_err());
    assert!(!d.path().join("p.exr").exists());
}

#[test]
fn round_trip_all_lossless_compressions() {
    let d = tmp();
    let img = sample_layer(37, 19);
    for c in [Compression::None, Compression::Rle, Compression::Zip1, Compression::Zip16, Compression::Piz] {
        let p = write(d.path(), "a.exr", &img, c);
        let h = read_header(&p, &ReadLimits::default()).unwrap();
        assert_eq!((h.width, h.height, h.compression, h.tiled), (37, 19, c, false));
        assert_eq!(h.channels.len(), 4);
        assert_same_bits(&img, &read_exr(&p, &ReadLimits::default()).unwrap());
    }
}

#[test]
fn lossy_and_empty_writes_are_refused() {
    let d = tmp();
    let img = sample_layer(4, 4);
    let e = write_exr(&d.path().join("a.exr"), &img, &WriteOptions { compression: Compression::Pxr24 });
    assert_eq!(e.unwrap_err().code(), "LAYER_UNSUPPORTED");
    let e = write_exr(&d.path().join("b.exr"), &LayerImage::new(0, 0), &WriteOptions::default());
    assert_eq!(e.unwrap_err().code(), "LAYER_UNSUPPORTED");
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0, "nothing written on error");
}

/// Special values: NaN payloads (quiet and signalling, both signs), ±inf, −0.0, denormals.
fn special_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(-0.0f32),
        Just(f32::from_bits(1)),
        Just(f32::from_bits(0x7f80_0001)),
        Just(f32::from_bits(0xffc0_1234)),
    ]
}

fn any_half_as_f32() -> impl Strategy<Value = f32> {
    any::<u16>().prop_map(|b| halfbits::half_to_f32(half::f16::from_bits(b)))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn round_trip_is_bit_exact(
        w in 1usize..24,
        h in 1usize..24,
        seed_f in proptest::collection::vec(special_f32(), 1..64),
        seed_h in proptest::collection::vec(any_half_as_f32(), 1..64),
        c in prop_oneof![Just(Compression::Zip16), Just(Compression::Piz), Just(Compression::Rle), Just(Compression::None)],
    ) {
        let n = w * h;
        let mut img = LayerImage::new(w, h);
        img.set_channel("Z", SampleType::F32, (0..n).map(|i| seed_f[i % seed_f.len()]).collect());
        img.set_channel("R", SampleType::F16, (0..n).map(|i| seed_h[(i * 7) % seed_h.len()]).collect());
        let d = tmp();
        let p = write(d.path(), "p.exr", &img, c);
        assert_same_bits(&img, &read_exr(&p, &ReadLimits::default()).unwrap());
    }
}

#[test]
fn missing_file_is_not_found() {
    let p = Path::new("/nonexistent/dir/layer.exr");
    assert_eq!(read_header(p, &ReadLimits::default()).unwrap_err().code(), "LAYER_NOT_FOUND");
    assert_eq!(read_exr(p, &ReadLimits::default()).unwrap_err().code(), "LAYER_NOT_FOUND");
}

#[test]
fn garbage_is_unreadable() {
    let d = tmp();
    let p = d.path().join("g.exr");
    std::fs::write(&p, b"this is not an EXR file at all, just text").unwrap();
    assert_eq!(read_exr(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_UNREADABLE");
    std::fs::write(&p, b"v/1").unwrap();
    assert_eq!(read_header(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_UNREADABLE");
}

#[test]
fn truncated_files_are_reported_as_truncated() {
    let d = tmp();
    let img = sample_layer(64, 48);
    let p = write(d.path(), "t.exr", &img, Compression::Zip16);
    let bytes = std::fs::read(&p).unwrap();
    for cut in [20, bytes.len() / 3, bytes.len() / 2, bytes.len() - 10] {
        let q = d.path().join(format!("cut{cut}.exr"));
        std::fs::write(&q, &bytes[..cut]).unwrap();
        let e = read_exr(&q, &ReadLimits::default()).unwrap_err();
        assert_eq!(e.code(), "LAYER_TRUNCATED", "cut at {cut}: {e}");
        assert!(e.to_string().contains("cut"), "error names the file: {e}");
    }
}

/// A minimal scanline header (no pixels) declaring `w × h` pixels and one float channel `Z`.
pub(crate) fn handmade_header(w: i32, h: i32, flags: u32) -> Vec<u8> {
    fn attr(out: &mut Vec<u8>, name: &str, ty: &str, value: &[u8]) {
        for s in [name, ty] {
            out.extend_from_slice(s.as_bytes());
            out.push(0);
        }
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
    }
    let boxed =
        |w: i32, h: i32| [0i32, 0, w - 1, h - 1].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
    let mut out = vec![0x76, 0x2f, 0x31, 0x01];
    out.extend_from_slice(&(2u32 | flags).to_le_bytes());
    let mut ch = b"Z\0".to_vec();
    ch.extend_from_slice(&2i32.to_le_bytes()); // FLOAT
    ch.extend_from_slice(&[0, 0, 0, 0]);
    ch.extend_from_slice(&1i32.to_le_bytes());
    ch.extend_from_slice(&1i32.to_le_bytes());
    ch.push(0);
    attr(&mut out, "channels", "chlist", &ch);
    attr(&mut out, "compression", "compression", &[0]);
    attr(&mut out, "dataWindow", "box2i", &boxed(w, h));
    attr(&mut out, "displayWindow", "box2i", &boxed(w, h));
    attr(&mut out, "lineOrder", "lineOrder", &[0]);
    attr(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attr(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attr(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    out.push(0);
    out
}

#[test]
fn huge_header_is_refused_before_decoding() {
    let d = tmp();
    let p = d.path().join("huge.exr");
    std::fs::write(&p, handmade_header(1_000_000, 1_000_000, 0)).unwrap();
    let t = Instant::now();
    let e = read_exr(&p, &ReadLimits::default()).unwrap_err();
    assert_eq!(e.code(), "LAYER_TOO_LARGE", "{e}");
    assert_eq!(read_header(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_TOO_LARGE");
    assert!(t.elapsed().as_millis() < 200, "took {:?}", t.elapsed());
    // Same header within limits parses, and the missing pixels are a truncation.
    std::fs::write(&p, handmade_header(16, 8, 0)).unwrap();
    let h = read_header(&p, &ReadLimits::default()).unwrap();
    assert_eq!((h.width, h.height), (16, 8));
    assert_eq!(read_exr(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_TRUNCATED");
    // Large but within limits, with no pixel data: refused before the image is allocated.
    std::fs::write(&p, handmade_header(30_000, 8_000, 0)).unwrap();
    let t = Instant::now();
    assert_eq!(read_exr(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_TRUNCATED");
    assert!(t.elapsed().as_millis() < 200, "took {:?}", t.elapsed());
    let small = ReadLimits { max_decoded_bytes: 1 << 20, ..ReadLimits::default() };
    assert_eq!(read_header(&p, &small).unwrap_err().code(), "LAYER_TOO_LARGE");
}

#[test]
fn deep_and_multipart_flags_are_refused() {
    let d = tmp();
    let p = d.path().join("deep.exr");
    std::fs::write(&p, handmade_header(16, 8, 1 << 11)).unwrap();
    assert_eq!(read_header(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_DEEP");
}

#[test]
fn multipart_files_are_refused() {
    use ::exr::prelude::*;
    let d = tmp();
    let p = d.path().join("multi.exr");
    let layer = |name: &str| {
        Layer::new(
            (4, 4),
            LayerAttributes::named(name),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(
                "Z",
                FlatSamples::F32(vec![1.0; 16]),
            )])),
        )
    };
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((4, 4))),
        vec![layer("a"), layer("b")],
    );
    image.write().to_file(&p).unwrap();
    let e = read_exr(&p, &ReadLimits::default()).unwrap_err();
    assert_eq!(e.code(), "LAYER_MULTIPART", "{e}");
}

#[test]
fn data_window_off_origin_is_the_canvas() {
    use ::exr::prelude::*;
    let d = tmp();
    let p = d.path().join("off.exr");
    let attrs = LayerAttributes { layer_position: Vec2(100, -7), ..Default::default() };
    let layer = Layer::new(
        (5, 3),
        attrs,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(
            "Z",
            FlatSamples::F32((0..15).map(|i| i as f32).collect()),
        )])),
    );
    Image::from_layer(layer).write().to_file(&p).unwrap();
    let h = read_header(&p, &ReadLimits::default()).unwrap();
    assert_eq!((h.width, h.height, h.origin), (5, 3, (100, -7)));
    let img = read_exr(&p, &ReadLimits::default()).unwrap();
    assert_eq!(img.depth().unwrap()[7], 7.0);
}

#[test]
fn limits_apply_to_channels_and_dimensions() {
    let d = tmp();
    let p = write(d.path(), "l.exr", &sample_layer(40, 10), Compression::Zip16);
    let narrow = ReadLimits { max_dimension: 32, ..ReadLimits::default() };
    assert_eq!(read_exr(&p, &narrow).unwrap_err().code(), "LAYER_TOO_LARGE");
    let few = ReadLimits { max_channels: 3, ..ReadLimits::default() };
    assert_eq!(read_header(&p, &few).unwrap_err().code(), "LAYER_TOO_LARGE");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Mutated valid files give Ok or a typed error, never a panic.
    #[test]
    fn mutated_files_never_panic(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in proptest::option::of(any::<prop::sample::Index>()),
        c in prop_oneof![Just(Compression::Zip16), Just(Compression::Piz), Just(Compression::Rle), Just(Compression::None)],
    ) {
        let mut bytes = exr_bytes(c);
        for (i, b) in edits {
            let k = i.index(bytes.len());
            bytes[k] = b;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut.index(bytes.len()));
        }
        let p = Path::new("mutated.exr");
        let _ = read_header_bytes(&bytes, p, &ReadLimits::default());
        let _ = read_exr_bytes(&bytes, p, &ReadLimits::default());
    }
}

fn exr_bytes(c: Compression) -> Vec<u8> {
    write_exr_bytes(Path::new("x.exr"), &sample_layer(20, 20), &WriteOptions { compression: c }).unwrap()
}

// ---- thesis form ----

/// The colour map and depth file of a thesis layer in `d`.
fn thesis_paths(d: &tempfile::TempDir) -> (PathBuf, PathBuf) {
    (d.path().join("c.png"), d.path().join("c_d.exr"))
}

/// A thesis layer of 6 × 4 RGB pixels, its depth `w` × 4 in channel `channel`.
fn thesis_pair(w: usize, channel: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let d = tmp();
    let (map, depth) = thesis_paths(&d);
    write_png_rgba(&map, 6, 4, false);
    write_depth(&depth, w, 4, channel);
    (d, map, depth)
}

fn read_thesis(map: &Path, depth: &Path) -> Result<LayerImage, LayerIoError> {
    read_thesis_layer(map, depth, None, &ReadLimits::default())
}

fn write_png_rgba(p: &Path, w: u32, h: u32, alpha: bool) {
    if alpha {
        let img = image::RgbaImage::from_fn(w, h, |x, y| {
            image::Rgba([x as u8, y as u8, 200, if x == 0 { 0 } else { 255 }])
        });
        img.save(p).unwrap();
    } else {
        let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8, y as u8, 7]));
        img.save(p).unwrap();
    }
}

fn write_depth(p: &Path, w: usize, h: usize, name: &str) {
    let mut d = LayerImage::new(w, h);
    d.set_channel(name, SampleType::F32, (0..w * h).map(|i| if i % w == 1 { -1.0 } else { 2.5 }).collect());
    write_exr(p, &d, &WriteOptions::default()).unwrap();
}

#[test]
fn thesis_layer_without_alpha_uses_negative_depth() {
    let (_d, map, depth) = thesis_pair(6, "Y");
    let l = read_thesis(&map, &depth).unwrap();
    let r = l.channel("R").unwrap();
    assert_eq!(r.sample_type, SampleType::F16);
    // sRGB-decoded to linear: code 5 is 0.00152 linear, and encodes back to 5.
    assert!((r.data[5] - crate::colour::srgb_to_linear(5.0 / 255.0)).abs() < 1e-5, "{}", r.data[5]);
    assert_eq!(crate::colour::srgb8(r.data[5]), 5);
    assert_eq!(l.channel("Z").unwrap().sample_type, SampleType::F32);
    let a = l.coverage().unwrap();
    assert_eq!((a[0], a[1]), (1.0, 0.0));
    assert_eq!(l.occupied(), 6 * 4 - 4);
}

#[test]
fn thesis_layer_with_alpha_and_normals() {
    let d = tmp();
    let ((map, depth), normals) = (thesis_paths(&d), d.path().join("n.exr"));
    write_png_rgba(&map, 6, 4, true);
    write_depth(&depth, 6, 4, "Z");
    let mut n = LayerImage::new(6, 4);
    for (name, v) in [("R", 0.0), ("G", 0.0), ("B", 1.0)] {
        n.set_channel(name, SampleType::F16, vec![v; 24]);
    }
    write_exr(&normals, &n, &WriteOptions::default()).unwrap();
    let l = read_thesis_layer(&map, &depth, Some(&normals), &ReadLimits::default()).unwrap();
    assert_eq!(l.coverage().unwrap()[0], 0.0);
    assert_eq!(l.coverage().unwrap()[1], 1.0);
    assert_eq!(l.channel("N.Z").unwrap().data[3], 1.0);
    assert_eq!(l.channel("N.Z").unwrap().sample_type, SampleType::F16);
}

#[test]
fn thesis_layer_size_mismatch_names_both_files() {
    let (d, map, depth) = thesis_pair(5, "Z");
    let e = read_thesis(&map, &depth).unwrap_err();
    assert_eq!(e.code(), "LAYER_SIZE_MISMATCH");
    let msg = e.to_string();
    assert!(msg.contains("c.png") && msg.contains("c_d.exr"), "{msg}");
    let missing = read_thesis_layer(&d.path().join("none.png"), &depth, None, &ReadLimits::default());
    assert_eq!(missing.unwrap_err().code(), "LAYER_NOT_FOUND");
}

#[test]
fn thesis_16_bit_colour_is_float() {
    let d = tmp();
    let (map, depth) = thesis_paths(&d);
    image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(6, 4, |x, _| image::Rgb([x as u16 * 1000, 0, 65535]))
        .save(&map)
        .unwrap();
    write_depth(&depth, 6, 4, "Z");
    let l = read_thesis(&map, &depth).unwrap();
    let r = l.channel("R").unwrap();
    assert_eq!(r.sample_type, SampleType::F32);
    assert_eq!(r.data[3], crate::colour::srgb_to_linear(3000.0 / 65535.0));
}

/// Every 8-bit thesis code is decoded to linear and stored as half precisely enough that sRGB
/// encoding gives the code back; alpha is coverage and is not decoded.
#[test]
fn thesis_8_bit_codes_round_trip_through_linear_half() {
    let d = tmp();
    let (map, depth) = thesis_paths(&d);
    let img = image::RgbaImage::from_fn(256, 2, |x, _| image::Rgba([x as u8, 0, 255, x as u8]));
    img.save(&map).unwrap();
    write_depth(&depth, 256, 2, "Z");
    let l = read_thesis(&map, &depth).unwrap();
    let (r, a) = (&l.channel("R").unwrap().data, &l.channel("A").unwrap().data);
    for code in 0..256usize {
        assert_eq!(crate::colour::srgb8(r[code]) as usize, code);
        assert_eq!((a[code] * 255.0).round() as usize, code);
    }
    assert!((r[128] - 0.2158).abs() < 1e-3, "mid-grey code 128 is 0.216 linear, got {}", r[128]);
}

/// Found by the `layer_exr` fuzz target: a B44 chunk that makes the `exr` crate's decoder
/// overflow (a panic with overflow checks on). The reader must turn it into an error.
#[test]
fn fuzz_regression_b44_overflow_is_an_error() {
    let bytes = include_bytes!("testdata/fuzz_b44_overflow.exr");
    let r = read_exr_bytes(bytes, Path::new("fuzz_b44_overflow.exr"), &ReadLimits::default());
    // With overflow checks (tests) the decoder panics and the guard reports it; without, the
    // arithmetic wraps and the data decodes to something or fails otherwise. Never a panic.
    if cfg!(debug_assertions) {
        let e = r.unwrap_err();
        assert_eq!(e.code(), "LAYER_UNREADABLE", "{e}");
    }
}

/// A channel list naming one channel twice (issue 12: it was accepted, and one of the two lost).
#[test]
fn duplicate_channel_names_are_refused() {
    use ::exr::prelude::*;
    let d = tmp();
    let p = d.path().join("dup.exr");
    let ch = |name: &str, v: f32| AnyChannel::new(name, FlatSamples::F32(vec![v; 16]));
    let layer = Layer::new(
        (4, 4),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(SmallVec::from_vec(vec![ch("Y", 1.0), ch("Z", 2.0)])),
    );
    Image::from_layer(layer).write().to_file(&p).unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    // Rename "Y" to "Z" in the channel list (the list stays sorted).
    let list = bytes.windows(16).position(|w| w == b"channels\0chlist\0").unwrap();
    let y = list + bytes[list..].windows(2).position(|w| w == b"Y\0").unwrap();
    bytes[y] = b'Z';
    std::fs::write(&p, &bytes).unwrap();
    let e = read_exr(&p, &ReadLimits::default()).unwrap_err();
    assert_eq!(e.code(), "LAYER_UNREADABLE", "{e}");
    assert!(e.to_string().contains("Z appears twice"), "{e}");
}

/// The DWAA file of `layer_io::tests` with one counter of its first chunk's DWA header replaced:
/// the header's attributes are walked to the offset table, then to the chunk.
fn dwaa_with_counter(counter: usize, value: u64) -> Vec<u8> {
    use ::exr::prelude::*;
    let (w, h) = (64usize, 32usize);
    let planes: Vec<AnyChannel<FlatSamples>> = ["B", "G", "R"]
        .iter()
        .enumerate()
        .map(|(c, n)| {
            // Smooth, so that DWA compresses it (a chunk that does not shrink is stored raw).
            let v = (0..w * h).map(|i| f16::from_f32(((i % w) + (i / w) * (c + 1)) as f32 / 160.0)).collect();
            AnyChannel::new(*n, FlatSamples::F16(v))
        })
        .collect();
    let encoding =
        Encoding { compression: ::exr::compression::Compression::DWAA(None), ..Encoding::FAST_LOSSLESS };
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(SmallVec::from_vec(planes)),
    );
    let mut bytes = Vec::new();
    Image::from_layer(layer).write().to_buffered(std::io::Cursor::new(&mut bytes)).unwrap();
    let mut at = 8;
    loop {
        let name_end = at + bytes[at..].iter().position(|&b| b == 0).unwrap();
        if name_end == at {
            at += 1;
            break;
        }
        let type_end = name_end + 1 + bytes[name_end + 1..].iter().position(|&b| b == 0).unwrap();
        let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap()) as usize;
        at = type_end + 5 + size;
    }
    let chunk = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    // The chunk's leader (line and data size), then the DWA header: version 2 first.
    let dwa = chunk + bytes[chunk..chunk + 64].windows(8).position(|v| v == 2u64.to_le_bytes()).unwrap();
    if counter < 11 {
        let field = dwa + 8 * counter;
        bytes[field..field + 8].copy_from_slice(&value.to_le_bytes());
    }
    bytes
}

/// Found by the issue-12 probe: one flipped byte in a DWAA layer's `ac_count` made the `exr`
/// crate's Huffman decoder reserve 721 GB and abort every command. The vendored patch bounds the
/// counts by the chunk's block; the reader reports the file instead.
#[test]
fn dwa_chunk_counts_beyond_the_block_are_an_error() {
    let path = Path::new("dwaa.exr");
    let good = dwaa_with_counter(usize::MAX, 0);
    let img = read_exr_bytes(&good, path, &ReadLimits::default()).unwrap();
    assert_eq!((img.width, img.height), (64, 32));
    // ac_count (counter 8) and dc_count (counter 9) far beyond 64 × 32 pixels, and section sizes.
    for (counter, value) in [(8, 360_000_000_000u64), (9, 1 << 40), (1, 1 << 41), (6, 1 << 42)] {
        let bad = dwaa_with_counter(counter, value);
        let e = read_exr_bytes(&bad, path, &ReadLimits::default()).unwrap_err();
        assert_eq!(e.code(), "LAYER_UNREADABLE", "counter {counter}: {e}");
    }
}

#[test]
fn a_chunk_relabelled_as_another_scanline_is_refused() {
    let d = tmp();
    let p = write(d.path(), "c.exr", &sample_layer(16, 40), Compression::Zip16);
    let mut bytes = std::fs::read(&p).unwrap();
    assert!(read_exr_bytes(&bytes, &p, &ReadLimits::default()).is_ok());
    // The offset table follows the header: 3 chunks of 16 scanlines; relabel the second as line 0.
    let (table, chunks) = super::exr::offset_table_for_tests(&bytes, &p);
    assert_eq!(chunks, 3);
    let second = u64::from_le_bytes(bytes[table + 8..table + 16].try_into().unwrap()) as usize;
    assert_eq!(i32::from_le_bytes(bytes[second..second + 4].try_into().unwrap()), 16);
    bytes[second..second + 4].copy_from_slice(&0i32.to_le_bytes());
    let e = read_exr_bytes(&bytes, &p, &ReadLimits::default()).unwrap_err();
    assert_eq!(e.code(), "LAYER_UNREADABLE", "{e}");
    assert!(e.to_string().contains("scanline 0") && e.to_string().contains("scanline 16"), "{e}");
}

#[test]
fn an_inverted_data_window_is_unreadable_not_truncated() {
    let d = tmp();
    let p = d.path().join("inv.exr");
    std::fs::write(&p, handmade_header(-2, 8, 0)).unwrap();
    let e = read_exr(&p, &ReadLimits::default()).unwrap_err();
    assert_eq!(e.code(), "LAYER_UNREADABLE", "{e}");
    assert_eq!(read_header(&p, &ReadLimits::default()).unwrap_err().code(), "LAYER_UNREADABLE");
}
