//! Any depth file or stored samples with any depth options, through `pomc build`'s route:
//! header check, decode (8/16-bit PNG, JPEG, OpenEXR), then `prepare_depth`. Ok or a typed error,
//! never a panic, and an accepted depth lies in front of the camera everywhere (positive, or
//! infinitely far): no NaN, zero or negative depth reaches the build.
//!
//! The input's first bytes choose the options (see `Opts::take`); the rest is the file's bytes,
//! or, in the raw mode, the samples themselves (so that values no decoder makes, NaN, infinities
//! and negatives among them, reach `prepare` too).
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use pomc::layer_io::ReadLimits;
use pomc::input::{header_size, read_depth_samples};
use pomc::mapping::{AnyMapping, Mapping, MappingKind};
use pomc::prepare::{
    prepare_depth, DepthEncoding, DepthKind, DepthSamples, KnownDistance, PrepareOptions, Preset, Refine,
    SampleFormat, UnknownDepth,
};

/// Small limits: the fuzzer looks for crashes, not for the cost of decoding large images.
const LIMITS: ReadLimits =
    ReadLimits { max_dimension: 1024, max_pixels: 1 << 16, max_channels: 8, max_decoded_bytes: 8 << 20 };
/// The largest colour canvas prepared (the depth is resized onto it).
const MAX_COLOUR_PIXELS: usize = 256 * 128;

/// A scratch file per fuzzing process (libFuzzer's workers are processes).
fn scratch(ext: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("pomc-fuzz-prepare-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch directory");
        d
    });
    dir.join(format!("depth.{ext}"))
}

struct Bytes<'a>(&'a [u8]);

impl<'a> Bytes<'a> {
    fn u8(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }
    fn f64(&mut self) -> Option<f64> {
        let (head, rest) = self.0.split_first_chunk::<8>()?;
        self.0 = rest;
        Some(f64::from_le_bytes(*head))
    }
    /// An option's value when its presence bit is set: any f64 (NaN, infinities, negatives).
    fn opt(&mut self, present: bool) -> Option<Option<f64>> {
        if present {
            self.f64().map(Some)
        } else {
            Some(None)
        }
    }
}

/// How the depth reaches `prepare`.
enum Source {
    File(&'static str),
    Raw(SampleFormat),
}

struct Opts {
    source: Source,
    enc: DepthEncoding,
    prep: PrepareOptions,
    kind: MappingKind,
    /// Colour canvas size over depth size: 1/2, 1, 2 or 4.
    zoom: u8,
}

impl Opts {
    fn take(b: &mut Bytes) -> Option<Opts> {
        let source = match b.u8()? % 6 {
            0 => Source::File("png"),
            1 => Source::File("jpg"),
            2 => Source::File("exr"),
            3 => Source::Raw(SampleFormat::U8),
            4 => Source::Raw(SampleFormat::U16),
            _ => Source::Raw(SampleFormat::F32),
        };
        let flags = b.u8()?;
        let kind = [DepthKind::Ray, DepthKind::Z, DepthKind::Inverse, DepthKind::Nearness][usize::from(flags & 3)];
        let refine = [Refine::Auto, Refine::On, Refine::Off, Refine::Auto][usize::from((flags >> 2) & 3)];
        let unknown = if flags & 16 != 0 { UnknownDepth::Sky } else { UnknownDepth::Complete };
        let mapping = if flags & 32 != 0 { MappingKind::Cube3x2 } else { MappingKind::Equirect };
        let zoom = flags >> 6;
        let preset = [None, Some(Preset::Matterport3d), Some(Preset::Stanford2d3ds), Some(Preset::Structured3d)]
            .get(usize::from(b.u8()? & 7))
            .copied()
            .unwrap_or(Some(Preset::Pano3d));
        let present = b.u8()?;
        let mut enc = match preset {
            Some(p) => p.encoding(),
            None => DepthEncoding::default(),
        };
        enc.kind = kind;
        if let Some(s) = b.opt(present & 1 != 0)? {
            enc.scale = Some(s);
        }
        if let Some(v) = b.opt(present & 2 != 0)? {
            enc.invalid = Some(v);
        }
        if present & 4 != 0 {
            enc.range = Some((b.f64()?, b.f64()?));
        }
        enc.camera_height = b.opt(present & 8 != 0)?;
        if present & 16 != 0 {
            enc.known_distance = Some(KnownDistance { x: b.f64()?, y: b.f64()?, metres: b.f64()? });
        }
        Some(Opts { source, enc, prep: PrepareOptions { refine, unknown }, kind: mapping, zoom })
    }
}

/// Stored samples from raw bytes: a width byte, a height byte, then the values.
fn raw_samples(b: &mut Bytes, format: SampleFormat) -> Option<DepthSamples> {
    let width = usize::from(b.u8()?) + 1;
    let height = usize::from(b.u8()?) + 1;
    let n = width * height;
    let values: Vec<f32> = match format {
        SampleFormat::U8 => b.0.get(..n)?.iter().map(|&v| f32::from(v)).collect(),
        SampleFormat::U16 => {
            b.0.get(..2 * n)?.chunks_exact(2).map(|c| f32::from(u16::from_le_bytes([c[0], c[1]]))).collect()
        }
        SampleFormat::F32 => {
            b.0.get(..4 * n)?.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
        }
    };
    Some(DepthSamples { width, height, values, format, colour_channels: false })
}

/// A colour canvas with edges (blocks of a few colours), so that the snap and the guided resize
/// have colour edges to follow.
fn colour(w: usize, h: usize, seed: u8) -> [Vec<f32>; 3] {
    let px = |c: usize| {
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w / 5, i / w / 3);
                let v = (x * 7 + y * 13 + c * 5 + usize::from(seed)) % 11;
                v as f32 / 10.0
            })
            .collect()
    };
    [px(0), px(1), px(2)]
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes(data);
    let Some(opts) = Opts::take(&mut b) else { return };
    let (samples, path) = match opts.source {
        Source::File(ext) => {
            let path = scratch(ext);
            if std::fs::write(&path, b.0).is_err() {
                return;
            }
            // The build's order: sizes from the header first, then the decode.
            if header_size(&path, 4, &LIMITS).is_err() {
                return;
            }
            match read_depth_samples(&path, &LIMITS) {
                Ok(s) => (s, path),
                Err(_) => return,
            }
        }
        Source::Raw(format) => match raw_samples(&mut b, format) {
            Some(s) => (s, PathBuf::from("fuzz-depth.raw")),
            None => return,
        },
    };
    assert_eq!(samples.values.len(), samples.width * samples.height);
    let (cw, ch) = match opts.zoom {
        0 => (samples.width / 2, samples.height / 2),
        1 => (samples.width, samples.height),
        2 => (samples.width * 2, samples.height * 2),
        _ => (samples.width * 4, samples.height * 4),
    };
    if cw * ch == 0 || cw * ch > MAX_COLOUR_PIXELS {
        return;
    }
    let Ok(mapping) = AnyMapping::new(opts.kind, cw, ch) else { return };
    let rgb = colour(cw, ch, data[0]);
    if let Ok(p) = prepare_depth(&path, &mapping, &rgb, &samples, &opts.enc, &opts.prep) {
        assert_eq!((p.width, p.height), (mapping.width(), mapping.height()));
        assert_eq!(p.depth.len(), cw * ch);
        // Accepted depth is in front of the camera everywhere: positive or the sky.
        if let Some(d) = p.depth.iter().find(|d| d.is_nan() || **d <= 0.0) {
            panic!("accepted depth with a value {d} that is not in front of the camera");
        }
    }
});
