//! Timing and occupancy of packing a sparse 4096×2048 layer (ignored by default: run with
//! `cargo test --release -p pomc --test pack_bench -- --ignored --nocapture`).

use std::time::Instant;

use pomc::layer::{LayerImage, SampleType};
use pomc::pack::{pack_layer, unpack, PackOptions};

/// Discs ("spheres") and boxes over an equirect canvas, about `target` of it occupied.
fn scene(w: usize, h: usize) -> LayerImage {
    let shapes: [(f64, f64, f64, bool); 9] = [
        (600.0, 1100.0, 180.0, true),
        (1400.0, 1300.0, 120.0, true),
        (2100.0, 1000.0, 220.0, false),
        (2900.0, 1250.0, 90.0, true),
        (3500.0, 1400.0, 160.0, false),
        (300.0, 1600.0, 60.0, true),
        (3900.0, 900.0, 70.0, true),
        (1800.0, 1500.0, 40.0, false),
        (2500.0, 1700.0, 110.0, true),
    ];
    let n = w * h;
    let (mut z, mut a, mut r) = (vec![-1.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
    for y in 0..h {
        for x in 0..w {
            let inside = shapes.iter().any(|&(cx, cy, rad, disc)| {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                if disc {
                    dx * dx + dy * dy <= rad * rad
                } else {
                    dx.abs() <= rad && dy.abs() <= rad * 0.6
                }
            });
            if inside {
                let i = y * w + x;
                z[i] = 2.0 + (x % 97) as f32 * 0.01;
                a[i] = 1.0;
                r[i] = 0.5;
            }
        }
    }
    let mut img = LayerImage::new(w, h);
    img.set_channel("R", SampleType::F16, r.clone());
    img.set_channel("G", SampleType::F16, r.clone());
    img.set_channel("B", SampleType::F16, r);
    img.set_channel("A", SampleType::F16, a);
    img.set_channel("Z", SampleType::F32, z);
    img
}

#[test]
#[ignore]
fn pack_sparse_4096x2048() {
    let img = scene(4096, 2048);
    let occupied = img.occupied();
    for padding in [0, 2] {
        let t = Instant::now();
        let packed = pack_layer(&img, &PackOptions { padding }).unwrap();
        let pack_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let back = unpack(&packed).unwrap();
        let unpack_s = t.elapsed().as_secs_f64();
        assert_eq!(back.occupied(), occupied);
        println!(
            "padding {padding}: occupied {occupied} px ({:.2}% of canvas), atlas {}x{} = {} px, \
             occupancy {:.1}%, {} patches, pack {:.3} s, unpack {:.3} s",
            100.0 * occupied as f64 / (4096.0 * 2048.0),
            packed.atlas.width,
            packed.atlas.height,
            packed.atlas_area(),
            100.0 * occupied as f64 / packed.atlas_area() as f64,
            packed.patches.len(),
            pack_s,
            unpack_s
        );
    }
}

#[test]
#[ignore]
fn exr_write_read_4096x2048() {
    use pomc::layer_io::{read_exr, write_exr, Compression, ReadLimits, WriteOptions};
    let img = scene(4096, 2048);
    let dir = tempfile::tempdir().unwrap();
    for c in [Compression::Zip16, Compression::Piz, Compression::None] {
        let p = dir.path().join("l.exr");
        let t = Instant::now();
        write_exr(&p, &img, &WriteOptions { compression: c }).unwrap();
        let write_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let back = read_exr(&p, &ReadLimits::default()).unwrap();
        let read_s = t.elapsed().as_secs_f64();
        assert_eq!(back.occupied(), img.occupied());
        let size = std::fs::metadata(&p).unwrap().len();
        println!("{}: {} bytes, write {write_s:.3} s, read {read_s:.3} s", c.name(), size);
    }
}

/// Worst case for the cutter: uniform noise (every pixel its own component).
#[test]
#[ignore]
fn pack_noise_4096x2048() {
    let (w, h) = (4096usize, 2048usize);
    let mut state = 12345u64;
    let mut img = LayerImage::new(w, h);
    let z: Vec<f32> = (0..w * h)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            if (state >> 33) % 100 < 5 {
                1.0
            } else {
                -1.0
            }
        })
        .collect();
    img.set_channel("Z", SampleType::F32, z);
    let t = Instant::now();
    let packed = pack_layer(&img, &PackOptions::default()).unwrap();
    println!(
        "noise 5%: occupied {}, atlas {} px, {} patches, pack {:.3} s",
        img.occupied(),
        packed.atlas_area(),
        packed.patches.len(),
        t.elapsed().as_secs_f64()
    );
}

/// A large disc and a large triangle: many cuts each saving a little.
#[test]
#[ignore]
fn pack_big_shapes_4096x2048() {
    let (w, h) = (4096usize, 2048usize);
    let mut img = LayerImage::new(w, h);
    let z: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let disc = (x - 1100.0).powi(2) + (y - 1024.0).powi(2) <= 1000.0f64.powi(2);
            let triangle = x > 2200.0 && y > 100.0 && (x - 2200.0) < (y - 100.0);
            if disc || triangle {
                1.0
            } else {
                -1.0
            }
        })
        .collect();
    img.set_channel("Z", SampleType::F32, z);
    let t = Instant::now();
    let packed = pack_layer(&img, &PackOptions::default()).unwrap();
    println!(
        "big shapes: occupied {}, atlas {} px ({:.1}% occupied), {} patches, pack {:.3} s",
        img.occupied(),
        packed.atlas_area(),
        100.0 * img.occupied() as f64 / packed.atlas_area() as f64,
        packed.patches.len(),
        t.elapsed().as_secs_f64()
    );
}
