//! Image comparison for the evaluation harness (spec §9.6): PSNR, WS-PSNR for equirect images,
//! depth error and hole ratio of a rendered frame against a ground-truth frame of the same size.
//!
//! Colour is compared in linear RGB clamped to `[0, 1]` (peak 1); holes count as black, so a
//! renderer cannot gain by leaving pixels empty.

use super::frame::Frame;

/// PSNR reported for identical images (keeps JSON finite).
pub const PSNR_CAP: f64 = 100.0;

/// Weighted mean squared colour error; `row_weights` (one per row) defaults to uniform.
pub fn mse(frame: &Frame, truth: &Frame, row_weights: Option<&[f64]>) -> f64 {
    let (w, h) = (frame.width, frame.height);
    assert_eq!((w, h), (truth.width, truth.height), "compared frames must have the same size");
    let (mut sum, mut wsum) = (0.0f64, 0.0f64);
    for y in 0..h {
        let rw = row_weights.map_or(1.0, |r| r[y]);
        for i in y * w..(y + 1) * w {
            for k in 0..3 {
                let a = frame.rgb[k][i].clamp(0.0, 1.0) as f64;
                let b = truth.rgb[k][i].clamp(0.0, 1.0) as f64;
                let d = if a.is_nan() || b.is_nan() { 1.0 } else { a - b };
                sum += rw * d * d;
            }
            wsum += 3.0 * rw;
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        0.0
    }
}

/// PSNR (dB) with peak 1, capped at [`PSNR_CAP`].
pub fn psnr_of(mse: f64) -> f64 {
    if mse <= 0.0 {
        PSNR_CAP
    } else {
        (-10.0 * mse.log10()).min(PSNR_CAP)
    }
}

/// Unweighted colour PSNR (dB, peak 1, capped at [`PSNR_CAP`]) of `frame` against `truth`.
///
/// # Panics
/// When the frames differ in size.
pub fn psnr(frame: &Frame, truth: &Frame) -> f64 {
    psnr_of(mse(frame, truth, None))
}

/// WS-PSNR row weights of an equirect image: `cos(latitude)` of each row centre.
pub fn ws_weights(height: usize) -> Vec<f64> {
    (0..height).map(|j| (std::f64::consts::PI * (j as f64 + 0.5) / height as f64).sin()).collect()
}

/// Spherically weighted PSNR of equirect frames.
pub fn ws_psnr(frame: &Frame, truth: &Frame) -> f64 {
    psnr_of(mse(frame, truth, Some(&ws_weights(frame.height))))
}

/// Mean absolute depth error (world units) over pixels covered in both frames with finite depth
/// in both; `None` when there is none.
pub fn depth_error(frame: &Frame, truth: &Frame) -> Option<f64> {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in 0..frame.depth.len() {
        let (a, b) = (frame.depth[i], truth.depth[i]);
        if frame.covered[i] && truth.covered[i] && a.is_finite() && b.is_finite() {
            sum += (a - b).abs() as f64;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(v: f32, covered: bool) -> Frame {
        Frame {
            width: 2,
            height: 1,
            rgb: [vec![v; 2], vec![v; 2], vec![v; 2]],
            depth: vec![1.0; 2],
            covered: vec![covered; 2],
        }
    }

    #[test]
    fn psnr_values() {
        assert_eq!(psnr(&frame(0.5, true), &frame(0.5, true)), PSNR_CAP);
        assert!((psnr(&frame(0.4, true), &frame(0.5, true)) - 20.0).abs() < 1e-4);
        assert!((ws_psnr(&frame(0.4, true), &frame(0.5, true)) - 20.0).abs() < 1e-4);
        assert_eq!(depth_error(&frame(0.0, false), &frame(0.0, true)), None);
    }
}
