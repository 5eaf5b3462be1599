//! Packing a sparse 4096×2048 layer (spec §5) and writing/reading it as EXR:
//! `cargo bench -p pomc --bench pack`. The occupancy figures are printed once before timing.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use pomc::layer::{LayerImage, SampleType};
use pomc::layer_io::{read_exr, write_exr, Compression, ReadLimits, WriteOptions};
use pomc::pack::{pack_layer, unpack, PackOptions};

/// Discs ("spheres") and boxes over an equirect canvas.
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

/// A depth-only layer, inside where `inside(x, y)`.
fn z_layer(w: usize, h: usize, mut inside: impl FnMut(usize, usize) -> bool) -> LayerImage {
    let z = (0..w * h).map(|i| if inside(i % w, i / w) { 1.0 } else { -1.0 }).collect();
    let mut img = LayerImage::new(w, h);
    img.set_channel("Z", SampleType::F32, z);
    img
}

/// Worst case for the cutter: uniform noise, 5 % occupied (every pixel its own component).
fn noise(w: usize, h: usize) -> LayerImage {
    let mut state = 12345u64;
    z_layer(w, h, |_, _| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) % 100 < 5
    })
}

/// A large disc and a large triangle: many cuts each saving a little.
fn big_shapes(w: usize, h: usize) -> LayerImage {
    z_layer(w, h, |x, y| {
        let (x, y) = (x as f64, y as f64);
        let disc = (x - 1100.0).powi(2) + (y - 1024.0).powi(2) <= 1000.0f64.powi(2);
        disc || (x > 2200.0 && y > 100.0 && (x - 2200.0) < (y - 100.0))
    })
}

fn packing(c: &mut Criterion) {
    let (w, h) = (4096, 2048);
    for (name, img) in [("sparse", scene(w, h)), ("noise", noise(w, h)), ("big-shapes", big_shapes(w, h))] {
        for padding in [0, 2] {
            let options = PackOptions { padding };
            let packed = pack_layer(&img, &options).unwrap();
            assert_eq!(unpack(&packed).unwrap().occupied(), img.occupied(), "{name}: pack/unpack");
            eprintln!(
                "{name} padding {padding}: occupied {} px ({:.2} % of the canvas), atlas {}x{}, occupancy \
                 {:.1} %, {} patches",
                img.occupied(),
                100.0 * img.occupied() as f64 / (w * h) as f64,
                packed.atlas.width,
                packed.atlas.height,
                100.0 * img.occupied() as f64 / packed.atlas_area() as f64,
                packed.patches.len()
            );
            c.bench_function(&format!("pack {name} 4096x2048 padding {padding}"), |b| {
                b.iter(|| pack_layer(black_box(&img), &options).unwrap())
            });
            if name == "sparse" {
                c.bench_function(&format!("unpack {name} 4096x2048 padding {padding}"), |b| {
                    b.iter(|| unpack(black_box(&packed)).unwrap())
                });
            }
        }
    }
}

fn exr(c: &mut Criterion) {
    let img = scene(4096, 2048);
    let dir = tempfile::tempdir().unwrap();
    for compression in [Compression::Zip16, Compression::Piz, Compression::None] {
        let p = dir.path().join(format!("{}.exr", compression.name()));
        let options = WriteOptions { compression };
        write_exr(&p, &img, &options).unwrap();
        eprintln!("{}: {} bytes", compression.name(), std::fs::metadata(&p).unwrap().len());
        c.bench_function(&format!("write exr {} 4096x2048", compression.name()), |b| {
            b.iter(|| write_exr(&p, black_box(&img), &options).unwrap())
        });
        c.bench_function(&format!("read exr {} 4096x2048", compression.name()), |b| {
            b.iter(|| read_exr(&p, &ReadLimits::default()).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = packing, exr
}
criterion_main!(benches);
