use super::layer::convert_layer_in_bands;
use super::taps::cubic_weights;
use super::*;
use crate::layer::{LayerImage, SampleType};

#[test]
fn pole_and_seam_taps_wrap() {
    let s = EquirectSource { w: 8, h: 4 };
    assert_eq!(s.index(-1, 0), 7);
    assert_eq!(s.index(8, 0), 0);
    assert_eq!(s.index(1, -1), 5); // row 0, column 1 + 4
    assert_eq!(s.index(1, 4), 3 * 8 + 5);
    assert_eq!(s.index(0, -2), 8 + 4);
}

#[test]
fn cube_taps_cross_edges() {
    let c = CubeSource { n: 4 };
    // Right of +X's right edge (s = +1 → direction −Y side) is the −Y face.
    let i = c.texel(0, 4, 1);
    let (x, y) = (i % 12, i / 12);
    assert_eq!((x / 4, y / 4), (1, 1), "{x},{y}");
}

/// A layer of every sample type, with normals, depth and coverage.
fn mixed_layer(w: usize, h: usize) -> LayerImage {
    let n = w * h;
    let mut img = LayerImage::new(w, h);
    let f = |k: f32| (0..n).map(|i| (i as f32 * k).sin() * 0.5 + 0.5).collect::<Vec<_>>();
    img.set_channel("R", SampleType::F16, f(0.37));
    img.set_channel("N.X", SampleType::F16, f(0.11));
    img.set_channel("N.Y", SampleType::F16, f(0.05));
    img.set_channel("N.Z", SampleType::F32, f(0.02));
    img.set_channel("Z", SampleType::F32, (0..n).map(|i| 1.0 + ((i / 7) % 3) as f32).collect());
    img.set_channel("A", SampleType::F32, (0..n).map(|i| (i % 11 != 0) as u8 as f32).collect());
    img.set_channel("id", SampleType::U32, (0..n).map(|i| (i % 97) as f32).collect());
    img
}

#[test]
fn a_layer_converted_in_bands_equals_the_whole_raster_conversion() {
    let src = mixed_layer(64, 32);
    let opts = SampleOptions::default();
    let cube = Canvas::Cube(CubeLayout::Canonical);
    for (from, to, size, src) in [
        (Canvas::Equirect, cube, 12, src.clone()),
        (cube, Canvas::Equirect, 40, convert_layer(&src, Canvas::Equirect, cube, 16, &opts).unwrap()),
    ] {
        let whole = convert_layer_in_bands(&src, from, to, size, &opts, usize::MAX).unwrap();
        for band in [1, 7 * 40, 1000] {
            let banded = convert_layer_in_bands(&src, from, to, size, &opts, band).unwrap();
            for (a, b) in whole.channels.iter().zip(&banded.channels) {
                assert_eq!((&a.name, a.sample_type), (&b.name, b.sample_type));
                let same = a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "channel {} differs with bands of {band} samples", a.name);
            }
        }
        // Against the interleaved conversion it is made of (depth-aware, ids nearest).
        let ch = src.channels.len();
        let mut inter = vec![0.0f32; src.width * src.height * ch];
        for (c, channel) in src.channels.iter().enumerate() {
            for (i, v) in channel.data.iter().enumerate() {
                inter[i * ch + c] = *v;
            }
        }
        let raster = Raster::from_vec(src.width, src.height, ch, inter).unwrap();
        let o = SampleOptions { depth_channel: Some(4), coverage_channel: Some(5), ..opts };
        let plain = convert(&raster, from, to, size, &o).unwrap();
        let near = convert(&raster, from, to, size, &SampleOptions { filter: Filter::Nearest, ..o }).unwrap();
        let at = |r: &Raster<f32>, i: usize, c: usize| r.data()[i * ch + c];
        for i in 0..whole.width * whole.height {
            // (The source steps by more than `LAYER_JUMP`: [`separate`] leaves it as it is.)
            assert_eq!(whole.channels[4].data[i].to_bits(), at(&plain, i, 4).to_bits(), "Z at {i}");
            assert_eq!(whole.channels[6].data[i], at(&near, i, 6), "id at {i}");
            let r = half::f16::from_f32(at(&plain, i, 0)).to_f32();
            assert_eq!(whole.channels[0].data[i], r, "R rounded to half at {i}");
            let n: f32 = (1..4).map(|c| whole.channels[c].data[i].powi(2)).sum();
            assert!((n - 1.0).abs() < 1e-5 || n == 0.0, "normal length² {n} at {i}");
        }
    }
}

/// Infinitely far depth (a sky) stays infinite through every filter: a tap of weight 0 on
/// +inf must not make a NaN (0 · inf).
#[test]
fn an_infinitely_far_layer_converts_without_nan() {
    let cube = Canvas::Cube(CubeLayout::Canonical);
    for (w, h, size) in [(64, 32, 12), (1024, 512, 256), (100, 50, 30)] {
        let mut sky = LayerImage::new(w, h);
        sky.set_channel("R", SampleType::F16, vec![0.5; w * h]);
        sky.set_channel("Z", SampleType::F32, vec![f32::INFINITY; w * h]);
        for filter in [Filter::Bilinear, Filter::Bicubic] {
            let opts = SampleOptions { filter, ..SampleOptions::default() };
            let out = convert_layer(&sky, Canvas::Equirect, cube, size, &opts).unwrap();
            let back = convert_layer(&out, cube, Canvas::Equirect, w, &opts).unwrap();
            for img in [&out, &back] {
                let z = &img.channel("Z").unwrap().data;
                let nan = z.iter().filter(|v| v.is_nan()).count();
                assert_eq!(nan, 0, "{w}x{h} {filter:?}: {nan} NaN depths");
            }
        }
    }
}

/// At a layer's edge, a point whose nearest texel is inside blends the inside taps (here on a
/// plane, in inverse depth) instead of taking the nearest texel, a row's step away: resampled
/// grazing ground near its edge otherwise steps against its blended neighbours.
#[test]
fn a_point_at_a_layers_edge_blends_its_inside_taps() {
    use crate::mapping::{Equirect, Mapping};
    let (w, h) = (16, 8);
    // Ground-like: inverse depth linear in the row, 0.1 + 0.15 y (4 m at row 1, 1.43 m at 4).
    let plane = |y: f64| 1.0 / (0.1 + 0.15 * y);
    let mut z: Vec<f32> = (0..w * h).map(|p| plane((p / w) as f64) as f32).collect();
    z[2 * w + 4] = -1.0;
    let src = Raster::from_vec(w, h, 1, z).unwrap();
    let opts = SampleOptions { depth_channel: Some(0), ..SampleOptions::default() };
    // Source point (5.3, 3.3): taps (4..=5, 2..=3), (4, 2) outside; the nearest is (5, 3).
    let d = Equirect::new(w, h).unwrap().pixel_to_dir(5.3, 3.3);
    let mut out = [0.0f32];
    sample_dir(&src, Canvas::Equirect, d, &opts, &mut out).unwrap();
    let truth = plane(2.8);
    let err = (out[0] as f64 / truth - 1.0).abs();
    assert!(err < 0.02, "depth {} against the plane's {truth:.3} (nearest texel {:.3})", out[0], plane(3.0));
}

#[test]
fn cubic_weights_sum_to_one() {
    for k in 0..10 {
        let w = cubic_weights(k as f32 / 10.0);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
}
