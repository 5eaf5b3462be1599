//! Equirect images read around the panorama centre: the sky's environment map (`--sky`) and a
//! render from the centre that colours the surfaces the centre sees (`--colour`).

use std::path::Path;

use glam::{DMat3, DVec3};

use super::SceneError;
use crate::input::Convention;
use crate::manifest::compose;
use crate::mapping::{AnyMapping, Equirect, Mapping};

/// An equirect image, linear RGB.
pub(crate) struct EnvMap {
    mapping: Equirect,
    rgb: Vec<[f32; 3]>,
    /// World direction to the map's own (thesis) frame.
    to_map: DMat3,
}

impl EnvMap {
    /// Read `path` (`what` names the option in errors); 8/16-bit images are sRGB.
    pub(crate) fn read(path: &Path, convention: Convention, what: &str) -> crate::Result<EnvMap> {
        use crate::image_io::{decode, to_f32, Pixels};
        let pixels = decode(path)?;
        let srgb = !matches!(pixels, Pixels::F32(_));
        let r = to_f32(&pixels);
        let (w, h, ch) = (r.width(), r.height(), r.channels());
        let mapping = Equirect::new(w, h).map_err(|_| {
            SceneError::BadOption(format!(
                "{}: {what} is an equirect image, 2:1; this one is {w}x{h}",
                path.display()
            ))
        })?;
        let decode = |v: f32| if srgb { crate::colour::srgb_to_linear(v) } else { v };
        let rgb = r
            .data()
            .chunks_exact(ch)
            .map(|px| {
                let c = |i: usize| decode(px[i.min(ch - 1)]);
                if ch < 3 {
                    [c(0); 3]
                } else {
                    [c(0), c(1), c(2)]
                }
            })
            .collect();
        let to_world = compose(&convention.transforms());
        let to_map = DMat3::from_mat4(to_world).inverse();
        Ok(EnvMap { mapping, rgb, to_map })
    }

    /// Bilinear sample along world direction `d`.
    pub(crate) fn sample(&self, d: DVec3) -> DVec3 {
        let (w, h) = (self.mapping.width(), self.mapping.height());
        let px = self.mapping.dir_to_pixel(self.to_map * d);
        let (x, y) = (px.x - 0.5, (px.y - 0.5).clamp(0.0, h as f64 - 1.0));
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f64, j: f64| {
            let i = (i as i64).rem_euclid(w as i64) as usize;
            let j = (j as usize).min(h - 1);
            DVec3::from_array(self.rgb[j * w + i].map(f64::from))
        };
        let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
        let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }

    /// The map over canvas pixel (`x`, `y`) of `m`: the mean of the sub-pixel samples `offsets`
    /// where the map is finer than the canvas, else the sample at the pixel centre (a map pixel
    /// already averages its own footprint: sampling it again at sub-pixel offsets would blur it).
    pub(crate) fn over_pixel(&self, m: &AnyMapping, x: f64, y: f64, offsets: &[(f64, f64)]) -> DVec3 {
        let map_pixel = std::f64::consts::TAU / self.mapping.width() as f64;
        if offsets.len() < 2 || map_pixel * 1.5 > crate::layering::pixel_angle(m) {
            return self.sample(m.pixel_to_dir(x + 0.5, y + 0.5));
        }
        let sum = offsets
            .iter()
            .fold(DVec3::ZERO, |acc, &(ox, oy)| acc + self.sample(m.pixel_to_dir(x + ox, y + oy)));
        sum / offsets.len() as f64
    }
}
