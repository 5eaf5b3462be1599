//! Resampling and conversion between equirect and cube canvases (spec §3.6).

use glam::DVec3;
use pomc::layer::{LayerImage, SampleType};
use pomc::mapping::layout::{convert_layout, CubeLayout};
use pomc::mapping::{AnyMapping, Cube3x2, Equirect, Mapping};
use pomc::resample::{convert, convert_layer, sample_dir, Canvas, Filter, SampleOptions};
use pomc::Raster;

/// A smooth function of direction (no seam, no pole singularity).
fn f(d: DVec3) -> f64 {
    0.5 + 0.3 * d.x - 0.2 * d.y * d.z + 0.15 * (3.0 * d.z + 1.0).sin() + 0.1 * (2.0 * d.x * d.y).cos()
}

fn render(m: &dyn Mapping) -> Raster<f32> {
    let mut r = Raster::filled(m.width(), m.height(), 1, 0.0f32);
    for j in 0..m.height() {
        for i in 0..m.width() {
            r.pixel_mut(i, j)[0] = f(m.pixel_dir(i, j)) as f32;
        }
    }
    r
}

fn rms_error(r: &Raster<f32>, m: &dyn Mapping) -> f64 {
    let mut acc = 0.0;
    for j in 0..m.height() {
        for i in 0..m.width() {
            let e = r.pixel(i, j)[0] as f64 - f(m.pixel_dir(i, j));
            acc += e * e;
        }
    }
    (acc / (m.width() * m.height()) as f64).sqrt()
}

#[test]
fn analytic_round_trip_and_filter_ranking() {
    let eq = Equirect::new(512, 256).unwrap();
    let src = render(&eq);
    let cube = Cube3x2::new(3 * 128, 2 * 128).unwrap();
    let mut errs = Vec::new();
    for filter in [Filter::Nearest, Filter::Bilinear, Filter::Bicubic] {
        let o = SampleOptions::with_filter(filter);
        let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 128, &o).unwrap();
        assert_eq!((c.width(), c.height()), (384, 256));
        let e_cube = rms_error(&c, &cube);
        let back = convert(&c, Canvas::Cube(CubeLayout::Canonical), Canvas::Equirect, 512, &o).unwrap();
        let e_back = rms_error(&back, &eq);
        eprintln!("{filter}: e->c rms {e_cube:.2e}, e->c->e rms {e_back:.2e}");
        errs.push((e_cube, e_back));
    }
    assert!(errs[1].0 < errs[0].0 / 3.0 && errs[1].1 < errs[0].1 / 3.0, "bilinear beats nearest: {errs:?}");
    assert!(errs[2].0 < errs[1].0 && errs[2].1 < errs[1].1, "bicubic beats bilinear: {errs:?}");
    assert!(errs[2].1 < 2e-3, "{errs:?}");
}

#[test]
fn layouts_agree_with_canonical_plus_reordering() {
    let src = render(&Equirect::new(256, 128).unwrap());
    let o = SampleOptions::with_filter(Filter::Bilinear);
    let canon = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 48, &o).unwrap();
    for l in CubeLayout::ALL {
        let direct = convert(&src, Canvas::Equirect, Canvas::Cube(l), 48, &o).unwrap();
        let reordered = convert_layout(&canon, CubeLayout::Canonical, l).unwrap();
        let worst =
            direct.data().iter().zip(reordered.data()).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst < 1e-5, "{l}: {worst}");
        // And back to equirect from the foreign layout.
        let back = convert(&direct, Canvas::Cube(l), Canvas::Equirect, 256, &o).unwrap();
        assert!(rms_error(&back, &Equirect::new(256, 128).unwrap()) < 5e-3);
    }
}

#[test]
fn ffmpeg_layout_front_is_the_equirect_centre_column() {
    // Column-coded equirect: value = column index. ffmpeg's front face looks at the centre column,
    // its up face at row 0 (POMC +Z).
    let (w, h) = (64, 32);
    let mut src = Raster::filled(w, h, 2, 0.0f32);
    for j in 0..h {
        for i in 0..w {
            src.pixel_mut(i, j).copy_from_slice(&[i as f32, j as f32]);
        }
    }
    let o = SampleOptions::with_filter(Filter::Nearest);
    let n = 16;
    let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::FfmpegC3x2), n, &o).unwrap();
    // Slot 4 (front) centre texel (just right/below the centre): column w/2, mid rows.
    let front = c.pixel(n + n / 2, n + n / 2);
    assert_eq!(front[0] as usize, w / 2);
    assert_eq!(front[1] as usize, h / 2);
    // Moving right on ffmpeg's front face moves right in the equirect (inside view).
    assert!(c.pixel(n + n - 1, n + n / 2)[0] > front[0]);
    // Slot 2 (up) centre is the north pole row.
    assert_eq!(c.pixel(2 * n + n / 2, n / 2)[1] as usize, 0);
    // Slot 0 (right) centre: azimuth of column 3w/4 in ffmpeg's picture.
    assert_eq!(c.pixel(n / 2, n / 2)[0] as usize, 3 * w / 4);
}

fn two_depth_equirect(w: usize) -> Raster<f32> {
    let h = w / 2;
    let mut r = Raster::filled(w, h, 2, 0.0f32);
    for j in 0..h {
        for i in 0..w {
            // A step along a meridian and the seam, plus an outside (−1) cap near the south pole.
            let z = if j > h * 7 / 8 {
                -1.0
            } else if (i * 3 / w) % 2 == 0 {
                2.0
            } else {
                5.0
            };
            r.pixel_mut(i, j).copy_from_slice(&[z, if z == 2.0 { 10.0 } else { 20.0 }]);
        }
    }
    r
}

#[test]
fn depth_aware_never_blends_a_step() {
    let src = two_depth_equirect(240);
    for filter in [Filter::Bilinear, Filter::Bicubic] {
        let o = SampleOptions { filter, depth_channel: Some(0), ..Default::default() };
        let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 50, &o).unwrap();
        let back = convert(&c, Canvas::Cube(CubeLayout::Canonical), Canvas::Equirect, 240, &o).unwrap();
        for r in [&c, &back] {
            for p in r.data().chunks(2) {
                assert!([-1.0, 2.0, 5.0].contains(&p[0]), "{filter}: depth {}", p[0]);
                // The colour channel follows the depth decision at the step.
                let want = if p[0] == 2.0 { 10.0 } else { 20.0 };
                assert!(p[0] < 0.0 || (p[1] - want).abs() < 1e-4, "{p:?}");
            }
        }
        // Without the depth rule the same conversion does blend (the test can fail).
        let plain = convert(
            &src,
            Canvas::Equirect,
            Canvas::Cube(CubeLayout::Canonical),
            50,
            &SampleOptions::with_filter(filter),
        )
        .unwrap();
        assert!(plain.data().chunks(2).any(|p| p[0] > 2.0 && p[0] < 5.0));
    }
}

#[test]
fn depth_aware_still_filters_smooth_depth() {
    let eq = Equirect::new(256, 128).unwrap();
    let mut src = render(&eq);
    src.data_mut().iter_mut().for_each(|v| *v += 2.0);
    let o = SampleOptions { filter: Filter::Bilinear, depth_channel: Some(0), ..Default::default() };
    let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 64, &o).unwrap();
    let cube = Cube3x2::new(192, 128).unwrap();
    let mut worst = 0.0f64;
    for j in 0..128 {
        for i in 0..192 {
            worst = worst.max((c.pixel(i, j)[0] as f64 - 2.0 - f(cube.pixel_dir(i, j))).abs());
        }
    }
    assert!(worst < 0.02, "{worst}");
}

#[test]
fn integer_images_convert() {
    let (w, h) = (128, 64);
    let data: Vec<u8> = (0..w * h * 3).map(|k| (k * 7 % 251) as u8).collect();
    let src = Raster::from_vec(w, h, 3, data).unwrap();
    let o = SampleOptions::with_filter(Filter::Bicubic);
    let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Py360Horizon), 20, &o).unwrap();
    assert_eq!((c.width(), c.height(), c.channels()), (120, 20, 3));
    let data16: Vec<u16> = (0..w * h).map(|k| (k * 977 % 65521) as u16).collect();
    let src16 = Raster::from_vec(w, h, 1, data16).unwrap();
    let c16 = convert(&src16, Canvas::Equirect, Canvas::Cube(CubeLayout::OpenExrVStrip), 20, &o).unwrap();
    assert_eq!((c16.width(), c16.height()), (20, 120));
}

#[test]
fn bad_sizes_are_errors() {
    let src = Raster::filled(10, 10, 1, 0.0f32);
    let o = SampleOptions::default();
    let e = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 4, &o).unwrap_err();
    assert_eq!(e.code(), "RESAMPLE_NOT_EQUIRECT");
    let e = convert(&src, Canvas::Cube(CubeLayout::Canonical), Canvas::Equirect, 8, &o).unwrap_err();
    assert_eq!(e.code(), "LAYOUT_BAD_SIZE");
    let eq = Raster::filled(8, 4, 1, 0.0f32);
    let e = convert(&eq, Canvas::Equirect, Canvas::Equirect, 7, &o).unwrap_err();
    assert_eq!(e.code(), "RESAMPLE_BAD_SIZE");
    let o = SampleOptions { depth_channel: Some(3), ..o };
    assert_eq!(
        convert(&eq, Canvas::Equirect, Canvas::Equirect, 8, &o).unwrap_err().code(),
        "RESAMPLE_NO_SUCH_CHANNEL"
    );
}

#[test]
fn sample_dir_reads_both_canvases() {
    let eq = Equirect::new(64, 32).unwrap();
    let src = render(&eq);
    let cube =
        convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 32, &SampleOptions::default())
            .unwrap();
    let o = SampleOptions::with_filter(Filter::Bilinear);
    let dirs = [
        DVec3::new(0.3, -0.2, 0.9),
        DVec3::X,
        -DVec3::Z,
        DVec3::new(-1.0, 0.0, 0.0),
        // Cube edges and corners: taps come from up to three faces.
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::ZERO,
        DVec3::NAN,
    ];
    for d in dirs {
        let mut a = [0.0f32];
        let mut b = [0.0f32];
        sample_dir(&src, Canvas::Equirect, d, &o, &mut a).unwrap();
        sample_dir(&cube, Canvas::Cube(CubeLayout::Canonical), d, &o, &mut b).unwrap();
        let want = f(if d.is_nan() || d == DVec3::ZERO { DVec3::Z } else { d.normalize() });
        assert!(
            (a[0] as f64 - want).abs() < 0.02 && (b[0] as f64 - want).abs() < 0.03,
            "{d}: {a:?} {b:?} {want}"
        );
        assert!(a[0].is_finite() && b[0].is_finite());
    }
    let _ = AnyMapping::new(pomc::mapping::MappingKind::Cube3x2, 96, 64).unwrap();
}

#[test]
fn layer_conversion_keeps_channels_consistent() {
    let (w, h) = (96, 48);
    let eq = Equirect::new(w, h).unwrap();
    let mut img = LayerImage::new(w, h);
    let mut z = vec![0.0f32; w * h];
    let mut a = vec![1.0f32; w * h];
    let mut col = vec![0.0f32; w * h];
    let (mut nx, mut ny, mut nz) = (vec![0.0f32; w * h], vec![0.0f32; w * h], vec![0.0f32; w * h]);
    let mut id = vec![0.0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            let k = j * w + i;
            let d = eq.pixel_dir(i, j);
            let inside = i < w / 2;
            z[k] = if inside { 3.0 } else { -1.0 };
            a[k] = if inside { 1.0 } else { 0.0 };
            col[k] = if inside { 0.8 } else { 0.0 };
            nx[k] = -d.x as f32;
            ny[k] = -d.y as f32;
            nz[k] = -d.z as f32;
            id[k] = (i / 8) as f32;
        }
    }
    img.set_channel("R", SampleType::F16, col);
    img.set_channel("A", SampleType::F16, a);
    img.set_channel("Z", SampleType::F32, z);
    img.set_channel("N.X", SampleType::F16, nx);
    img.set_channel("N.Y", SampleType::F16, ny);
    img.set_channel("N.Z", SampleType::F16, nz);
    img.set_channel("id", SampleType::U32, id);
    let o = SampleOptions::with_filter(Filter::Bicubic);
    let out = convert_layer(&img, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 32, &o).unwrap();
    assert_eq!((out.width, out.height), (96, 64));
    let names: Vec<_> = out.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["R", "A", "Z", "N.X", "N.Y", "N.Z", "id"]);
    for k in 0..96 * 64 {
        let zv = out.depth().unwrap()[k];
        let av = out.coverage().unwrap()[k];
        assert!(zv == 3.0 || zv == -1.0, "{zv}");
        assert_eq!(av > 0.0, zv > 0.0, "coverage follows depth");
        let n = [
            &out.channel("N.X").unwrap().data[k],
            &out.channel("N.Y").unwrap().data[k],
            &out.channel("N.Z").unwrap().data[k],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((l - 1.0).abs() < 2e-3, "normal length {l}");
        let idv = out.channel("id").unwrap().data[k];
        assert_eq!(idv.fract(), 0.0, "ids are never blended");
    }
}

/// Golden samples from real ffmpeg 5.1 (`v360=e:c3x2:interp=near:w=192:h=128`) applied to a 256×128
/// equirect whose pixel (i, j) stores (i, j): `(x, y, source column, source row)` of ffmpeg's output.
/// ffmpeg rounds its equirect coordinate to the nearest integer where POMC takes the containing pixel, so
/// agreement is within one pixel (measured over every output pixel: max difference 1, 63 % exact).
const FFMPEG_GOLDEN: [(usize, usize, i32, i32); 30] = [
    (5, 7, 163, 42),
    (32, 32, 192, 64),
    (60, 3, 221, 40),
    (10, 58, 167, 88),
    (47, 20, 210, 51),
    (69, 7, 36, 42),
    (96, 32, 64, 64),
    (124, 3, 93, 40),
    (74, 58, 40, 88),
    (111, 20, 82, 51),
    (133, 7, 33, 34),
    (160, 32, 159, 1),
    (188, 3, 223, 36),
    (138, 58, 100, 33),
    (175, 20, 217, 22),
    (5, 71, 94, 93),
    (32, 96, 223, 126),
    (60, 67, 159, 91),
    (10, 122, 28, 94),
    (47, 84, 165, 105),
    (69, 71, 99, 42),
    (96, 96, 128, 64),
    (124, 67, 157, 40),
    (74, 122, 103, 88),
    (111, 84, 146, 51),
    (133, 71, 227, 42),
    (160, 96, 1, 64),
    (188, 67, 30, 40),
    (138, 122, 231, 88),
    (175, 84, 18, 51),
];

#[test]
fn ffmpeg_layout_matches_real_ffmpeg_samples() {
    let (w, h) = (256usize, 128usize);
    let data: Vec<u8> = (0..h).flat_map(|j| (0..w).flat_map(move |i| [i as u8, j as u8])).collect();
    let src = Raster::from_vec(w, h, 2, data).unwrap();
    let o = SampleOptions::with_filter(Filter::Nearest);
    let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::FfmpegC3x2), 64, &o).unwrap();
    for (x, y, col, row) in FFMPEG_GOLDEN {
        let p = c.pixel(x, y);
        let dc = (p[0] as i32 - col).rem_euclid(256);
        let dc = dc.min(256 - dc);
        // Next to the south pole (row 126-127) every column is within a pixel of the pole itself.
        let pole = row >= 126 && p[1] >= 126;
        assert!(
            (dc <= 1 || pole) && (p[1] as i32 - row).abs() <= 1,
            "({x},{y}): ours {p:?}, ffmpeg ({col},{row})"
        );
    }
    // The canonical layout does not match (the test can fail).
    let canon = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 64, &o).unwrap();
    let misses =
        FFMPEG_GOLDEN.iter().filter(|&&(x, y, col, _)| (canon.pixel(x, y)[0] as i32 - col).abs() > 1).count();
    assert!(misses > 15, "{misses}");
}

/// Golden samples from py360convert 1.0.4 (`e2c(e, face_w=64, mode="nearest", cube_format="horizon")`) on a
/// 256×128 equirect storing (column, row): `(x, y, source column, source row)`. py360convert spreads a face's
/// pixel centres edge to edge (`linspace(-0.5, 0.5, N)`), POMC puts them half a pixel inside, so agreement
/// is within one pixel (measured over every output pixel at 512×256 → 6×128²: max difference 1).
const PY360_GOLDEN: [(usize, usize, i32, i32); 30] = [
    (5, 7, 99, 42),
    (32, 32, 128, 64),
    (60, 3, 157, 39),
    (10, 58, 103, 88),
    (47, 20, 146, 51),
    (69, 7, 163, 42),
    (96, 32, 192, 64),
    (124, 3, 221, 39),
    (74, 58, 167, 88),
    (111, 20, 210, 51),
    (133, 7, 227, 42),
    (160, 32, 0, 64),
    (188, 3, 29, 39),
    (138, 58, 231, 88),
    (175, 20, 18, 51),
    (197, 7, 35, 42),
    (224, 32, 64, 64),
    (252, 3, 93, 39),
    (202, 58, 39, 88),
    (239, 20, 82, 51),
    (261, 7, 33, 34),
    (288, 32, 160, 0),
    (316, 3, 224, 36),
    (266, 58, 100, 33),
    (303, 20, 218, 22),
    (325, 7, 94, 93),
    (352, 32, 224, 127),
    (380, 3, 160, 91),
    (330, 58, 27, 94),
    (367, 20, 165, 105),
];

#[test]
fn py360_layout_matches_real_py360convert_samples() {
    let (w, h) = (256usize, 128usize);
    let data: Vec<u8> = (0..h).flat_map(|j| (0..w).flat_map(move |i| [i as u8, j as u8])).collect();
    let src = Raster::from_vec(w, h, 2, data).unwrap();
    let o = SampleOptions::with_filter(Filter::Nearest);
    let c = convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Py360Horizon), 64, &o).unwrap();
    for (x, y, col, row) in PY360_GOLDEN {
        let p = c.pixel(x, y);
        let dc = (p[0] as i32 - col).rem_euclid(256);
        let dc = dc.min(256 - dc);
        // At the poles (rows 0 and 127) every column is the same point.
        let pole = row == 0 || row == 127;
        assert!(
            (dc <= 1 || pole) && (p[1] as i32 - row).abs() <= 1,
            "({x},{y}): ours {p:?}, py360 ({col},{row})"
        );
    }
}

mod depth_props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// A two-depth step in any position, any filter, either direction: no depth strictly between.
        #[test]
        fn step_never_blends(
            near in 0.5f32..50.0,
            ratio in 1.2f32..20.0,
            split in 0.05f64..0.95,
            lat in 0.05f64..0.95,
            filter in prop_oneof![Just(Filter::Bilinear), Just(Filter::Bicubic)],
            to_cube in any::<bool>(),
        ) {
            let far = near * ratio;
            let (w, h) = (96usize, 48usize);
            let mut src = Raster::filled(w, h, 1, 0.0f32);
            for j in 0..h {
                for i in 0..w {
                    let inside = (i as f64) < split * w as f64 && (j as f64) < lat * h as f64;
                    src.pixel_mut(i, j)[0] = if inside { near } else { far };
                }
            }
            let o = SampleOptions { filter, depth_channel: Some(0), ..Default::default() };
            let out = if to_cube {
                convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 20, &o).unwrap()
            } else {
                let c = convert_layout(
                    &convert(&src, Canvas::Equirect, Canvas::Cube(CubeLayout::FfmpegC3x2), 20, &o).unwrap(),
                    CubeLayout::FfmpegC3x2,
                    CubeLayout::FfmpegC3x2,
                )
                .unwrap();
                convert(&c, Canvas::Cube(CubeLayout::FfmpegC3x2), Canvas::Equirect, 64, &o).unwrap()
            };
            for &z in out.data() {
                prop_assert!(z == near || z == far, "{z} between {near} and {far}");
            }
        }
    }
}

#[test]
fn malformed_inputs_are_errors_not_panics() {
    let o = SampleOptions::default();
    let empty = Raster::<f32>::from_vec(8, 4, 0, vec![]).unwrap();
    assert_eq!(
        convert(&empty, Canvas::Equirect, Canvas::Equirect, 8, &o).unwrap_err().code(),
        "RESAMPLE_NO_CHANNELS"
    );
    let mut img = LayerImage::new(8, 4);
    assert_eq!(
        convert_layer(&img, Canvas::Equirect, Canvas::Equirect, 8, &o).unwrap_err().code(),
        "RESAMPLE_NO_CHANNELS"
    );
    img.set_channel("Z", SampleType::F32, vec![1.0; 32]);
    img.channels[0].data.pop();
    assert_eq!(
        convert_layer(&img, Canvas::Equirect, Canvas::Equirect, 8, &o).unwrap_err().code(),
        "RESAMPLE_CHANNEL_SIZE"
    );
    let one = Raster::filled(2, 1, 1, 1.0f32);
    let mut out = [0.0f32];
    for d in [DVec3::X, DVec3::ZERO, DVec3::new(f64::INFINITY, 0.0, f64::NAN)] {
        sample_dir(&one, Canvas::Equirect, d, &SampleOptions::with_filter(Filter::Bicubic), &mut out)
            .unwrap();
        assert_eq!(out[0], 1.0);
    }
    let eq = Raster::filled(8, 4, 1, 0.0f32);
    let huge = convert(&eq, Canvas::Equirect, Canvas::Cube(CubeLayout::OpenExrVStrip), usize::MAX / 3, &o);
    assert_eq!(huge.unwrap_err().code(), "RESAMPLE_TOO_LARGE");
    let mut long = [0.0f32; 2];
    let e = sample_dir(&one, Canvas::Equirect, DVec3::X, &o, &mut long).unwrap_err();
    assert_eq!(e.code(), "RESAMPLE_OUTPUT_LENGTH");
}

/// Ground seen at a grazing angle doubles its depth a row near the horizon, smoothly: the
/// converted layer must stay one surface by the continuity rule `pomc validate` checks (its
/// depths blended along the plane, in inverse depth, not left as a staircase of nearest texels).
#[test]
fn grazing_ground_stays_one_surface_through_a_conversion() {
    let (w, h) = (1024, 512);
    let eq = Equirect::new(w, h).unwrap();
    let mut img = LayerImage::new(w, h);
    let dirs: Vec<DVec3> = (0..w * h).map(|p| eq.pixel_dir(p % w, p / w)).collect();
    // Ground 1.6 m below the centre, seen down to 0.6° below the horizon (150 m); the rest is
    // outside the layer.
    let z: Vec<f32> = dirs.iter().map(|d| if d.z < -0.01 { (1.6 / -d.z) as f32 } else { -1.0 }).collect();
    img.set_channel("R", SampleType::F16, dirs.iter().map(|d| (0.5 + 0.4 * d.x) as f32).collect());
    img.set_channel("Z", SampleType::F32, z);
    // Bicubic taps span 4 rows, stepping by more than the jump: they are blended bilinearly on the
    // plane too.
    for filter in [Filter::Bilinear, Filter::Bicubic] {
        let opts = SampleOptions { filter, ..SampleOptions::default() };
        let out =
            convert_layer(&img, Canvas::Equirect, Canvas::Cube(CubeLayout::Canonical), 256, &opts).unwrap();
        let z = &out.channel("Z").unwrap().data;
        let broken = broken_pairs(z, out.width, out.height, 256);
        // And on the plane: the depth of every pixel a few rows inside the edge against the truth.
        let c = Cube3x2::new(out.width, out.height).unwrap();
        let worst = z
            .iter()
            .enumerate()
            .map(|(p, &v)| (c.pixel_dir(p % out.width, p / out.width), v as f64))
            .filter(|(d, v)| d.z < -0.02 && *v > 0.0)
            .map(|(d, v)| (v * -d.z / 1.6 - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!("{filter:?}: pairs not one surface: {broken}; worst depth error {worst:.4}");
        assert!(worst < 0.02, "{filter:?}: depth off the ground's plane by {worst:.4}");
        assert_eq!(
            broken, 0,
            "{filter:?}: {broken} neighbour pairs of the converted ground are not one surface"
        );
    }
}

/// Two walls (2 m and 6 m away, each half the azimuths, outside the polar caps) a line of pixels
/// apart, the lines aslant: converted to a cube and back, the two may touch where a line runs
/// across the new grid; each pair of neighbours that is not one surface is opened (its nearer pixel
/// taken out), so the result validates. The same walls without the lines (a real step, which
/// `validate` reports in the source too) keep every pixel: as many as one wall converted alone.
#[test]
fn two_parts_a_line_apart_stay_apart_through_conversions() {
    let (w, h) = (1024, 512);
    let eq = Equirect::new(w, h).unwrap();
    let tau = std::f64::consts::TAU;
    let gap = 1.2 * tau / w as f64;
    // Azimuth sheared by elevation, in [0, 2π): the near wall on one half, the far on the other,
    // lines `gap` wide (or none) at both of their borders; `None`: one wall over both halves.
    let part = |d: DVec3, lines: Option<f64>| {
        let u = (d.y.atan2(d.x) + 0.6 * d.z).rem_euclid(tau);
        let Some(gap) = lines else { return if d.z.abs() < 0.9 { 2.0 } else { -1.0 } };
        if d.z.abs() >= 0.9 || u < gap || (u >= tau / 2.0 && u < tau / 2.0 + gap) {
            -1.0
        } else if u < tau / 2.0 {
            2.0
        } else {
            6.0
        }
    };
    let opts = SampleOptions::default();
    let cube = Canvas::Cube(CubeLayout::Canonical);
    let convert_both = |lines: Option<f64>| {
        let mut img = LayerImage::new(w, h);
        let z = (0..w * h).map(|p| part(eq.pixel_dir(p % w, p / w), lines)).collect();
        img.set_channel("Z", SampleType::F32, z);
        let there = convert_layer(&img, Canvas::Equirect, cube, 256, &opts).unwrap();
        let back = convert_layer(&there, cube, Canvas::Equirect, w, &opts).unwrap();
        [(there, 256), (back, w)]
    };
    let count = |z: &[f32], lo: f32, hi: f32| z.iter().filter(|v| **v > lo && **v < hi).count();
    let one = convert_both(None);
    for lines in [Some(gap), Some(0.0)] {
        for ((out, face), (wall, _)) in convert_both(lines).iter().zip(&one) {
            let z = &out.channel("Z").unwrap().data;
            let breaks = broken_pairs(z, out.width, out.height, *face);
            let (near, far) = (count(z, 0.0, 4.0), count(z, 4.0, 10.0));
            let all = count(&wall.channel("Z").unwrap().data, 0.0, 10.0);
            eprintln!(
                "lines {lines:?}, {} × {}: {breaks} breaks, near {near}, far {far}, one wall {all}",
                out.width, out.height
            );
            assert!(near.abs_diff(far) < all / 50, "near {near} against far {far} pixels");
            if lines == Some(0.0) {
                assert_eq!(near + far, all, "a real step lost {} pixels", all - near - far);
            } else {
                assert_eq!(breaks, 0, "{breaks} pairs of the two parts touch");
            }
        }
    }
}

/// Neighbour pairs inside one `face × face` square of a canvas (a whole equirect when `face` is
/// its width: the seam is not crossed), both inside the layer (depth > 0), that are not one
/// surface by spec §7.2's rule written out: a step within 50 %, or 1/d extrapolated linearly (a
/// plane) from the pixel beyond either end within 5 % of the nearer.
fn broken_pairs(z: &[f32], w: usize, h: usize, face: usize) -> usize {
    let plane =
        |mid: f64, next: f64, back: f64| (2.0 / mid - 1.0 / back - 1.0 / next).abs() * mid.min(next) <= 0.05;
    let continuous = |a: f64, b: f64, behind: Option<f64>, beyond: Option<f64>| {
        (a - b).abs() <= 0.5 * a.min(b)
            || behind.is_some_and(|c| plane(a, b, c))
            || beyond.is_some_and(|c| plane(b, a, c))
    };
    let at = |x: usize, y: usize| Some(z[y * w + x] as f64).filter(|v| *v > 0.0);
    let (fw, fh) = (face.min(w), face.min(h));
    let mut broken = 0;
    for y in 0..h {
        for x in 0..w {
            for (dx, dy) in [(1usize, 0usize), (0, 1)] {
                let (fx, fy) = (x % fw, y % fh);
                if fx + dx >= fw || fy + dy >= fh {
                    continue;
                }
                let (Some(a), Some(b)) = (at(x, y), at(x + dx, y + dy)) else { continue };
                let behind = (fx >= dx && fy >= dy).then(|| at(x - dx, y - dy)).flatten();
                let beyond =
                    (fx + 2 * dx < fw && fy + 2 * dy < fh).then(|| at(x + 2 * dx, y + 2 * dy)).flatten();
                broken += !continuous(a, b, behind, beyond) as usize;
            }
        }
    }
    broken
}
