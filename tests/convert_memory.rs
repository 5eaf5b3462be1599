//! `convert` holds a layer's output about once (issue 12): resampled in bands straight into the
//! planar output, whose samples then move into the EXR encoder, which streams to disk. Measured
//! with a counting allocator, alone in its binary so no other test allocates meanwhile.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use pomc::layer::{LayerImage, SampleType};
use pomc::manifest::{LayerDecl, Manifest, MappingDecl, MappingKind};
use pomc::mapping::layout::CubeLayout;
use pomc::panorama::{write_panorama_with, SaveOptions};
use pomc::resample::{convert_layer, Canvas, SampleOptions};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

#[test]
fn converting_a_panorama_holds_its_output_about_once() {
    let (w, h) = (512, 256);
    let n = w * h;
    let mut src = LayerImage::new(w, h);
    for (c, k) in [("R", 0.37f32), ("G", 0.11), ("B", 0.05), ("N.X", 0.3), ("N.Y", 0.2), ("N.Z", 0.1)] {
        src.set_channel(c, SampleType::F16, (0..n).map(|i| (i as f32 * k).sin() * 0.5 + 0.5).collect());
    }
    src.set_channel("Z", SampleType::F32, (0..n).map(|i| 1.0 + ((i / 9) % 4) as f32).collect());
    let manifest = Manifest {
        version: "1".into(),
        transforms: Vec::new(),
        mapping: MappingDecl { kind: MappingKind::Cube3x2 },
        freedom_radius: 0.5,
        layers: vec![LayerDecl::native("a.exr")],
    };
    let face = 1024;
    let out_bytes = 6 * face * face * 7 * std::mem::size_of::<f32>();
    let dir = tempfile::tempdir().unwrap();
    let cube = Canvas::Cube(CubeLayout::Canonical);
    let make = |_: usize| Ok(convert_layer(&src, Canvas::Equirect, cube, face, &SampleOptions::default())?);
    let before = LIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let options = SaveOptions { pack: false, ..SaveOptions::default() };
    write_panorama_with(&dir.path().join("p"), &manifest, &make, &options).unwrap();
    let peak = PEAK.load(Ordering::Relaxed) - before;
    let ratio = peak as f64 / out_bytes as f64;
    println!("peak {peak} bytes for an output of {out_bytes} bytes as f32: {ratio:.3}x");
    // Before: an interleaved copy, the planar output, the encoder's copies and the encoded file in
    // memory (about 2.4x).
    assert!(ratio < 1.25, "peak {ratio:.3}x the output");
    let written = pomc::panorama::Panorama::open(&dir.path().join("p")).unwrap();
    let layer = written.read_layer(0, &Default::default()).unwrap();
    assert_eq!((layer.width, layer.height, layer.channels.len()), (3 * face, 2 * face, 7));
}
