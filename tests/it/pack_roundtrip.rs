//! Patch packing: pack → unpack restores every pixel of the domain bit-exactly, outside pixels
//! come back as outside, tables are valid, and sparse layers pack into at most twice their
//! occupied pixels (padding 0).

use pomc::layer::{LayerImage, Sample, SampleType};
use pomc::pack::{check_table, pack_layer, unpack, PackOptions, PackedLayer, Patch};
use proptest::prelude::*;

/// Small deterministic generator (tests must not depend on a RNG crate's stream).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// A layer with colour (half), depth (float) and, optionally, coverage; `inside` decides the domain.
fn layer(w: usize, h: usize, with_alpha: bool, inside: impl Fn(usize, usize) -> bool) -> LayerImage {
    let mut img = LayerImage::new(w, h);
    let mut z = vec![-1.0f32; w * h];
    let mut a = vec![0.0f32; w * h];
    let mut r = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if inside(x, y) {
                z[i] = match (x + y) % 11 {
                    0 => f32::INFINITY,
                    1 => f32::NAN,
                    _ => 1.0 + (x * 3 + y) as f32 * 0.01,
                };
                a[i] = 1.0;
                r[i] = ((x * 7 + y * 13) % 256) as f32 / 256.0;
            }
        }
    }
    img.set_channel("R", SampleType::F16, r);
    img.set_channel("Z", SampleType::F32, z);
    if with_alpha {
        img.set_channel("A", SampleType::F16, a);
    }
    img
}

/// Random discs and boxes covering a few percent of the canvas.
fn blobs(w: usize, h: usize, seed: u64, count: usize, with_alpha: bool) -> LayerImage {
    let mut rng = Lcg(seed);
    let shapes: Vec<(i64, i64, i64, bool)> = (0..count)
        .map(|_| {
            (
                rng.below(w as u64) as i64,
                rng.below(h as u64) as i64,
                2 + rng.below(h as u64 / 12) as i64,
                rng.below(2) == 0,
            )
        })
        .collect();
    layer(w, h, with_alpha, |x, y| {
        shapes.iter().any(|&(cx, cy, r, disc)| {
            let (dx, dy) = (x as i64 - cx, y as i64 - cy);
            if disc {
                dx * dx + dy * dy <= r * r
            } else {
                dx.abs() <= r && dy.abs() <= r / 2
            }
        })
    })
}

fn assert_round_trip(img: &LayerImage, packed: &PackedLayer) {
    let problems = check_table(
        packed.canvas_width,
        packed.canvas_height,
        packed.atlas.width as u32,
        packed.atlas.height as u32,
        &packed.patches,
    );
    assert!(problems.is_empty(), "{problems:?}");
    let back = unpack(packed).unwrap();
    assert_eq!((back.width, back.height), (img.width, img.height));
    for c in &img.channels {
        let d = back.channel(&c.name).unwrap();
        assert_eq!(c.sample_type, d.sample_type);
    }
    for i in 0..img.width * img.height {
        if img.sample(i) == Sample::Outside {
            assert_eq!(back.sample(i), Sample::Outside, "pixel {i} should stay outside");
            continue;
        }
        for c in &img.channels {
            let d = back.channel(&c.name).unwrap();
            assert_eq!(c.data[i].to_bits(), d.data[i].to_bits(), "{} at pixel {i}", c.name);
        }
    }
}

fn assert_at_most_twice(img: &LayerImage, packed: &PackedLayer, what: &str) {
    let occupied = img.occupied();
    assert!(
        packed.atlas_area() <= 2 * occupied,
        "{what}: atlas {}x{} = {} px for {occupied} occupied ({} patches)",
        packed.atlas.width,
        packed.atlas.height,
        packed.atlas_area(),
        packed.patches.len()
    );
}

#[test]
fn random_sparse_layers_pack_within_twice_occupied() {
    for seed in 1..=8u64 {
        let img = blobs(512, 256, seed, 3 + seed as usize, seed % 2 == 0);
        let packed = pack_layer(&img, &PackOptions::default()).unwrap();
        assert_round_trip(&img, &packed);
        assert_at_most_twice(&img, &packed, &format!("seed {seed}"));
    }
}

#[test]
fn thin_diagonals_pack_within_twice_occupied() {
    // One-pixel and three-pixel-wide diagonals, and a thin ring: bounding boxes are ~all empty.
    let cases: Vec<(&str, LayerImage)> = vec![
        ("diagonal", layer(400, 200, false, |x, y| x == 2 * y || x == 2 * y + 1)),
        ("anti-diagonal", layer(300, 300, true, |x, y| (x + y).abs_diff(299) <= 1)),
        (
            "ring",
            layer(256, 256, false, |x, y| {
                let d = ((x as f64 - 128.0).powi(2) + (y as f64 - 128.0).powi(2)).sqrt();
                (90.0..92.0).contains(&d)
            }),
        ),
        ("crossing lines", layer(320, 160, true, |x, y| x == y || x + y == 200 || y == 80)),
    ];
    for (what, img) in cases {
        let packed = pack_layer(&img, &PackOptions::default()).unwrap();
        assert_round_trip(&img, &packed);
        assert_at_most_twice(&img, &packed, what);
    }
}

#[test]
fn padding_copies_a_clamped_guard_band() {
    let img = blobs(200, 100, 42, 4, true);
    let packed = pack_layer(&img, &PackOptions { padding: 2 }).unwrap();
    assert_round_trip(&img, &packed);
    for p in &packed.patches {
        assert!(p.x >= 2 && p.y >= 2, "guard band fits in the atlas: {p:?}");
        // The pixel left of the patch's first row is the canvas pixel left of it (clamped).
        let (cx, cy) = (p.u.saturating_sub(1) as usize, p.v as usize);
        let (ax, ay) = (p.x as usize - 1, p.y as usize);
        let r =
            |im: &LayerImage, x: usize, y: usize| im.channel("R").unwrap().data[y * im.width + x].to_bits();
        assert_eq!(r(&packed.atlas, ax, ay), r(&img, cx, cy));
    }
}

#[test]
fn empty_full_and_channel_less_layers() {
    let empty = layer(64, 32, true, |_, _| false);
    let packed = pack_layer(&empty, &PackOptions::default()).unwrap();
    assert!(packed.patches.is_empty());
    assert_eq!(packed.atlas_area(), 1);
    assert_round_trip(&empty, &packed);

    let full = layer(64, 32, false, |_, _| true);
    let packed = pack_layer(&full, &PackOptions::default()).unwrap();
    assert_eq!(packed.patches.len(), 1);
    assert_round_trip(&full, &packed);
}

#[test]
fn unpack_refuses_bad_tables_and_huge_canvases() {
    let img = blobs(128, 64, 3, 3, true);
    let mut packed = pack_layer(&img, &PackOptions::default()).unwrap();
    let good = packed.patches.clone();
    packed.patches.push(Patch { u: 0, v: 0, x: u32::MAX, y: 0, w: 2, h: 2 });
    assert_eq!(unpack(&packed).unwrap_err().code(), "PATCH_OUT_OF_ATLAS");
    packed.patches = good.clone();
    packed.canvas_width = 1 << 20;
    packed.canvas_height = 1 << 20;
    assert_eq!(unpack(&packed).unwrap_err().code(), "LAYER_TOO_LARGE");
    packed.canvas_width = 128;
    packed.canvas_height = 64;
    if good.len() >= 2 {
        packed.patches = vec![good[0], Patch { u: good[0].u, v: good[0].v, ..good[1] }];
        let e = unpack(&packed).unwrap_err();
        assert!(e.code().starts_with("PATCH_"), "{e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn pack_unpack_round_trips(
        w in 1usize..48,
        h in 1usize..48,
        seed in any::<u64>(),
        density in 0u64..100,
        alpha in any::<bool>(),
        padding in 0u32..3,
    ) {
        let mut rng = Lcg(seed);
        let mask: Vec<bool> = (0..w * h).map(|_| rng.below(100) < density).collect();
        let img = layer(w, h, alpha, |x, y| mask[y * w + x]);
        let packed = pack_layer(&img, &PackOptions { padding }).unwrap();
        assert_round_trip(&img, &packed);
    }
}

#[test]
fn absurd_padding_is_refused() {
    let img = blobs(64, 32, 5, 2, true);
    let e = pack_layer(&img, &PackOptions { padding: u32::MAX }).unwrap_err();
    assert_eq!(e.code(), "PACK_PADDING_TOO_LARGE");
}
