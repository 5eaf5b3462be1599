//! Exhaustive sweeps and property tests of the mappings (spec §3).

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use pomc::mapping::{Cube3x2, CubeFace, Equirect, FacePoint, Mapping};
use proptest::prelude::*;
use rayon::prelude::*;

/// Worst distance (pixels) between every pixel centre and `dir_to_pixel(pixel_dir(centre))`.
fn worst_round_trip(m: &dyn Mapping) -> f64 {
    (0..m.height())
        .into_par_iter()
        .map(|j| {
            let mut worst = 0.0f64;
            for i in 0..m.width() {
                let p = m.dir_to_pixel(m.pixel_dir(i, j));
                let e = (p - DVec2::new(i as f64 + 0.5, j as f64 + 0.5)).abs();
                // The seam: x wraps, so compare modulo the width for equirect.
                let ex = e.x.min((e.x - m.width() as f64).abs());
                worst = worst.max(ex.max(e.y));
                assert_eq!(m.pixel_of(m.pixel_dir(i, j)), (i, j));
            }
            worst
        })
        .reduce(|| 0.0, f64::max)
}

#[test]
fn equirect_4096_round_trip_every_pixel() {
    let m = Equirect::new(4096, 2048).unwrap();
    let worst = worst_round_trip(&m);
    eprintln!("equirect 4096x2048 worst round-trip error: {worst:e} px");
    assert!(worst < 1e-8, "{worst}");
}

#[test]
fn cube_1024_round_trip_every_pixel() {
    let m = Cube3x2::new(3072, 2048).unwrap();
    let worst = worst_round_trip(&m);
    eprintln!("cube 6x1024^2 worst round-trip error: {worst:e} px");
    assert!(worst < 1e-8, "{worst}");
}

fn total_solid_angle(m: &dyn Mapping) -> f64 {
    (0..m.height())
        .into_par_iter()
        .map(|j| {
            // Kahan sum along the row.
            let (mut s, mut c) = (0.0f64, 0.0f64);
            for i in 0..m.width() {
                let y = m.solid_angle(i, j) - c;
                let t = s + y;
                c = (t - s) - y;
                s = t;
            }
            s
        })
        .collect::<Vec<_>>()
        .iter()
        .sum()
}

#[test]
fn solid_angles_sum_to_four_pi() {
    for m in [&Equirect::new(4096, 2048).unwrap() as &dyn Mapping, &Equirect::new(2, 1).unwrap()] {
        let e = (total_solid_angle(m) - 4.0 * PI).abs();
        assert!(e < 1e-9, "equirect {}: {e:e}", m.width());
    }
    for m in [&Cube3x2::new(3072, 2048).unwrap() as &dyn Mapping, &Cube3x2::new(3, 2).unwrap()] {
        let e = (total_solid_angle(m) - 4.0 * PI).abs();
        assert!(e < 1e-9, "cube {}: {e:e}", m.width());
    }
    // One face of a 1-pixel cube is exactly 4π/6.
    let m = Cube3x2::new(3, 2).unwrap();
    assert!((m.solid_angle(0, 0) - 4.0 * PI / 6.0).abs() < 1e-15);
}

#[test]
fn solid_angle_matches_numeric_integration() {
    // Cube pixel: integrate dA / r³ over the pixel's square with a fine midpoint rule.
    let m = Cube3x2::new(24, 16).unwrap();
    let (i, j) = (1, 2); // near a corner of +X: strongly distorted
    let n = 8.0;
    let k = 400;
    let mut acc = 0.0;
    for u in 0..k {
        for v in 0..k {
            let a = 2.0 * (i as f64 + (u as f64 + 0.5) / k as f64) / n - 1.0;
            let b = 2.0 * (j as f64 + (v as f64 + 0.5) / k as f64) / n - 1.0;
            let da = (2.0 / n / k as f64).powi(2);
            acc += da / (1.0 + a * a + b * b).powf(1.5);
        }
    }
    assert!((acc - m.solid_angle(i, j)).abs() < 1e-7, "{acc} vs {}", m.solid_angle(i, j));
}

fn special_dirs() -> Vec<DVec3> {
    let vals =
        [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 1e-310, -1e-310, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY];
    let mut out = Vec::new();
    for &x in &vals {
        for &y in &vals {
            for &z in &vals {
                out.push(DVec3::new(x, y, z));
            }
        }
    }
    out.push(DVec3::NAN);
    out.push(DVec3::new(1.0, f64::NAN, 0.0));
    out
}

#[test]
fn every_special_direction_gives_a_valid_pixel() {
    let maps: [&dyn Mapping; 4] = [
        &Equirect::new(4096, 2048).unwrap(),
        &Equirect::new(2, 1).unwrap(),
        &Cube3x2::new(3072, 2048).unwrap(),
        &Cube3x2::new(3, 2).unwrap(),
    ];
    for m in maps {
        for d in special_dirs() {
            let p = m.dir_to_pixel(d);
            assert!(
                p.x >= 0.0 && p.x < m.width() as f64 && p.y >= 0.0 && p.y < m.height() as f64,
                "{}x{}: {d} -> {p}",
                m.width(),
                m.height()
            );
            let (i, j) = m.pixel_of(d);
            assert!(i < m.width() && j < m.height());
        }
    }
}

#[test]
fn cube_ties_land_on_a_tied_face() {
    let m = Cube3x2::new(3 * 64, 2 * 64).unwrap();
    for d in special_dirs() {
        let Some(_) = d.is_finite().then_some(()) else { continue };
        if d == DVec3::ZERO || d.is_nan() {
            continue;
        }
        let p = FacePoint::from_dir(d);
        let axis = p.face.frame()[0];
        let m_abs = d.abs().max_element();
        // The chosen face's axis component is (one of) the largest, with the right sign.
        assert_eq!(axis.dot(d), m_abs, "{d} -> {p:?}");
        assert!(p.s.abs() <= 1.0 && p.t.abs() <= 1.0);
        let px = m.face_point_to_pixel(p);
        let (s0, t0) = p.face.grid();
        assert_eq!(((px.x / 64.0) as usize, (px.y / 64.0) as usize), (s0, t0), "{d}");
    }
}

#[test]
fn equirect_exact_poles_and_antimeridian() {
    let m = Equirect::new(4096, 2048).unwrap();
    assert_eq!(m.dir_to_pixel(DVec3::Z), DVec2::new(0.0, 0.0));
    assert_eq!(m.pixel_of(-DVec3::Z).1, 2047);
    // Azimuth ±180°: y = ±0 with x < 0 lands on the centre column from either side.
    assert_eq!(m.dir_to_pixel(DVec3::new(-1.0, 0.0, 0.0)).x, 2048.0);
    // Just before 180° (y > 0) is the last column of the first half; just after, the first of the second.
    assert_eq!(m.pixel_of(DVec3::new(-1.0, 1e-12, 0.0)).0, 2047);
    assert_eq!(m.pixel_of(DVec3::new(-1.0, -1e-12, 0.0)).0, 2048);
    // Hand values: pixel centre directions of the 4x2 canvas.
    let m = Equirect::new(4, 2).unwrap();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    for i in 0..4 {
        for j in 0..2 {
            let phi = (i as f64 + 0.5) * PI / 2.0;
            let z = if j == 0 { s } else { -s };
            let want = DVec3::new(s * phi.cos(), s * phi.sin(), z);
            assert!((m.pixel_dir(i, j) - want).length() < 1e-15);
        }
    }
}

#[test]
fn cube_face_index_layout() {
    let m = Cube3x2::new(6, 4).unwrap();
    assert_eq!(m.pixel_of(DVec3::X), (1, 1));
    assert_eq!(m.pixel_of(DVec3::Y), (3, 1));
    assert_eq!(m.pixel_of(DVec3::Z), (5, 1));
    assert_eq!(m.pixel_of(-DVec3::X), (1, 3));
    assert_eq!(m.pixel_of(-DVec3::Y), (3, 3));
    assert_eq!(m.pixel_of(-DVec3::Z), (5, 3));
    // +X face: s grows towards −Y, t towards −Z (digest §6).
    let p = FacePoint::from_dir(DVec3::new(1.0, -0.5, -0.25));
    assert_eq!((p.face, p.s, p.t), (CubeFace::PosX, 0.5, 0.25));
}

fn component() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1.0f64..1.0,
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => prop::num::f64::ANY,
        1 => (-1.0f64..1.0).prop_map(|v| v * 1e-308),
        1 => (-1.0f64..1.0).prop_map(|v| v * 1e300),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn inverse_is_total_and_inverts(x in component(), y in component(), z in component()) {
        let d = DVec3::new(x, y, z);
        let e = Equirect::new(1024, 512).unwrap();
        let c = Cube3x2::new(768, 512).unwrap();
        for m in [&e as &dyn Mapping, &c] {
            let p = m.dir_to_pixel(d);
            prop_assert!(p.x >= 0.0 && p.x < m.width() as f64 && p.y >= 0.0 && p.y < m.height() as f64);
            let back = m.pixel_to_dir(p.x, p.y);
            prop_assert!(back.is_finite() && (back.length() - 1.0).abs() < 1e-12);
            if d.is_finite() && d != DVec3::ZERO {
                // Scale first: squaring denormal or huge components would lose the direction.
                let u = (d / d.abs().max_element()).normalize();
                // Clamping to the canvas moves a point by at most one ulp: angle error ~1e-12.
                prop_assert!((back - u).length() < 1e-9, "{d} -> {p} -> {back}");
            }
        }
    }

    #[test]
    fn face_point_round_trip(f in 0usize..6, s in -1.0f64..=1.0, t in -1.0f64..=1.0) {
        let face = CubeFace::from_index(f).unwrap();
        let p = FacePoint::from_dir(face.cube_point(s, t));
        let d = FacePoint { face, s, t }.dir();
        prop_assert!((p.dir() - d).length() < 1e-14);
        if s.abs() < 1.0 && t.abs() < 1.0 {
            prop_assert_eq!(p.face, face);
            prop_assert!((p.s - s).abs() < 1e-15 && (p.t - t).abs() < 1e-15);
        }
    }
}
