//! What a camera accepts: output sizes within the accumulation buffers' bounds, finite positions.

use glam::DVec3;

use super::RenderError;

/// Largest output side accepted, pixels (bounds the accumulation buffers).
pub const MAX_SIDE: usize = 32768;
/// Largest output pixel count accepted.
pub const MAX_PIXELS: usize = 1 << 27;
/// What every output size needs.
const SIDES: &str = "sides 1..=32768, at most 2^27 pixels";
/// What an equirect output needs.
pub(super) const EQUIRECT: &str = "an equirect output is 2:1 (e.g. 2048x1024)";
/// What a VR180 image needs.
pub(super) const VR180: &str = "VR180 eyes are square with an even side: side by side 2:1 (e.g. 4096x2048), \
     top-bottom 1:2 (--stereo-layout tb)";

pub(super) fn check_size(width: usize, height: usize) -> Result<(), RenderError> {
    let ok = width > 0
        && height > 0
        && width <= MAX_SIDE
        && height <= MAX_SIDE
        && width.saturating_mul(height) <= MAX_PIXELS;
    if ok {
        Ok(())
    } else {
        Err(RenderError::BadSize { width, height, need: SIDES })
    }
}

pub(super) fn finite(v: DVec3, what: &str) -> Result<DVec3, RenderError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(RenderError::BadCamera(format!("{what} {v} is not finite")))
    }
}
