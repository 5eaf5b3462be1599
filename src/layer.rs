//! In-memory layer images and the POMC 1 depth/coverage encodings (spec §4).
//!
//! A layer image is a set of named planar channels of equal size. Standard channel names:
//! `R`,`G`,`B` (linear colour), `A` (coverage), `Z` (distance along the ray, metres, float32),
//! `N.X`,`N.Y`,`N.Z` (unit normal, panorama-local frame). Any other channel is an optional
//! attribute carried through untouched.
//!
//! Per-pixel meaning of a layer (spec §4.2):
//! - *outside the layer*: `A == 0` when `A` exists; otherwise `Z < 0` (the thesis's convention).
//!   Writers store outside pixels as `A = 0`, `Z = -1`, colour 0.
//! - *infinitely far*: `Z = +inf` (a direction-only sample, e.g. sky).
//! - *unknown depth*: `Z = NaN` inside the domain (colour known, distance not).
//! - otherwise `Z` is a finite distance `> 0` along the ray from the panorama centre.

/// Depth written for pixels outside a layer's domain.
pub const OUTSIDE_DEPTH: f32 = -1.0;

/// Sample storage type of a channel in the file. In memory every channel is `f32`;
/// `F16` channels hold values exactly representable as IEEE half.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleType {
    /// IEEE half float (16-bit).
    F16,
    /// IEEE single float (32-bit).
    F32,
    /// 32-bit unsigned integer.
    U32,
}

/// One named planar channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Channel name, e.g. `R`, `A`, `Z`, `N.X`, or any attribute name.
    pub name: String,
    /// How the samples are stored in the file.
    pub sample_type: SampleType,
    /// `width × height` samples, row-major, top row first.
    pub data: Vec<f32>,
}

/// Counts over a layer's pixels ([`LayerImage::stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LayerStats {
    /// Pixels inside the layer's domain (surface, infinite or unknown).
    pub domain_pixels: usize,
    /// Nearest finite depth, metres (`None` without one).
    pub depth_min: Option<f32>,
    /// Farthest finite depth, metres (`None` without one).
    pub depth_max: Option<f32>,
    /// Pixels of content infinitely far away.
    pub infinite_pixels: usize,
    /// Pixels in the domain whose depth is unknown.
    pub unknown_pixels: usize,
}

/// What a layer says about one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sample {
    /// The direction is not in this layer's domain.
    Outside,
    /// A surface at this finite distance (metres) along the ray.
    Surface(f32),
    /// Infinitely far content (direction only).
    Infinite,
    /// Inside the domain but the distance is unknown.
    Unknown,
}

/// Classify one pixel from its depth and (optional) coverage values.
#[inline]
pub fn classify(depth: f32, coverage: Option<f32>) -> Sample {
    let inside = match coverage {
        Some(a) => a > 0.0,
        // NaN (unknown) counts as inside: only a negative depth marks outside.
        None => depth >= 0.0 || depth.is_nan(),
    };
    if !inside {
        Sample::Outside
    } else if depth.is_nan() {
        Sample::Unknown
    } else if depth == f32::INFINITY {
        Sample::Infinite
    } else {
        Sample::Surface(depth)
    }
}

/// A layer's pixels: planar channels of `width × height` samples.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The channels, each `width × height` samples, names unique.
    pub channels: Vec<Channel>,
}

impl LayerImage {
    /// An empty image (no channels yet).
    pub fn new(width: usize, height: usize) -> Self {
        LayerImage { width, height, channels: Vec::new() }
    }

    /// Add or replace a channel. Panics if `data` has the wrong length (programming error).
    pub fn set_channel(&mut self, name: &str, sample_type: SampleType, data: Vec<f32>) {
        assert_eq!(data.len(), self.width * self.height, "channel {name} has the wrong size");
        if let Some(c) = self.channels.iter_mut().find(|c| c.name == name) {
            c.sample_type = sample_type;
            c.data = data;
        } else {
            self.channels.push(Channel { name: name.to_string(), sample_type, data });
        }
    }

    /// The channel called `name`, if present.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// The channel called `name`, mutably, if present.
    pub fn channel_mut(&mut self, name: &str) -> Option<&mut Channel> {
        self.channels.iter_mut().find(|c| c.name == name)
    }

    /// Depth channel `Z`, if present.
    pub fn depth(&self) -> Option<&[f32]> {
        self.channel("Z").map(|c| c.data.as_slice())
    }

    /// Coverage channel `A`, if present.
    pub fn coverage(&self) -> Option<&[f32]> {
        self.channel("A").map(|c| c.data.as_slice())
    }

    /// What the layer holds, pixel by pixel: its domain, the range of its finite depths, and its
    /// infinitely far and unknown pixels (`pomc info --stats`).
    pub fn stats(&self) -> LayerStats {
        let mut s = LayerStats::default();
        for i in 0..self.width * self.height {
            match self.sample(i) {
                Sample::Outside => continue,
                Sample::Surface(d) => {
                    s.depth_min = Some(s.depth_min.map_or(d, |m: f32| m.min(d)));
                    s.depth_max = Some(s.depth_max.map_or(d, |m: f32| m.max(d)));
                }
                Sample::Infinite => s.infinite_pixels += 1,
                Sample::Unknown => s.unknown_pixels += 1,
            }
            s.domain_pixels += 1;
        }
        s
    }

    /// Classification of pixel index `i` (row-major). Without a `Z` channel every pixel is
    /// [`Sample::Unknown`] where covered.
    pub fn sample(&self, i: usize) -> Sample {
        self.sampler()(i)
    }

    /// [`LayerImage::sample`] with the channels looked up once, for loops over every pixel.
    pub fn sampler(&self) -> impl Fn(usize) -> Sample + Sync + '_ {
        let (z, a) = (self.depth(), self.coverage());
        move |i| {
            let a = a.map(|a| a[i]);
            match z {
                Some(z) => classify(z[i], a),
                None => match a {
                    Some(a) if a <= 0.0 => Sample::Outside,
                    _ => Sample::Unknown,
                },
            }
        }
    }

    /// Domain mask: `true` where the pixel belongs to the layer.
    pub fn domain(&self) -> Vec<bool> {
        let sample = self.sampler();
        (0..self.width * self.height).map(|i| sample(i) != Sample::Outside).collect()
    }

    /// Number of pixels inside the domain.
    pub fn occupied(&self) -> usize {
        let sample = self.sampler();
        (0..self.width * self.height).filter(|&i| sample(i) != Sample::Outside).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_count_each_kind_of_pixel() {
        let mut img = LayerImage::new(3, 2);
        img.set_channel("Z", SampleType::F32, vec![-1.0, f32::INFINITY, 2.5, f32::NAN, 0.75, -1.0]);
        let s = img.stats();
        assert_eq!((s.domain_pixels, s.infinite_pixels, s.unknown_pixels), (4, 1, 1));
        assert_eq!((s.depth_min, s.depth_max), (Some(0.75), Some(2.5)));
        img.set_channel("Z", SampleType::F32, vec![f32::INFINITY; 6]);
        assert_eq!((img.stats().depth_min, img.stats().infinite_pixels), (None, 6));
    }

    #[test]
    fn classify_encodings() {
        assert_eq!(classify(-1.0, None), Sample::Outside);
        assert_eq!(classify(2.0, Some(0.0)), Sample::Outside);
        assert_eq!(classify(f32::NAN, None), Sample::Unknown);
        assert_eq!(classify(f32::INFINITY, Some(1.0)), Sample::Infinite);
        assert_eq!(classify(3.5, None), Sample::Surface(3.5));
        assert_eq!(classify(-1.0, Some(1.0)), Sample::Surface(-1.0));
    }
}
