//! The analytic room fixtures end to end: generated panoramas validate clean, their depths are
//! the exact ray-cast distances, the sparse objects layer is patch-packed within the 2× bound and
//! unpacks bit-exactly, and the committed samples in `fixtures/data/` are what the generator makes.

use std::path::Path;

use glam::DVec3;
use pomc::layer::Sample;
use pomc::layer_io::ReadLimits;
use pomc::mapping::{AnyMapping, Mapping, MappingKind};
use pomc::panorama::Panorama;
use pomc::validate::{self, ValidateSettings};
use pomc_fixtures::{layers, Scene};

fn mappings() -> [AnyMapping; 2] {
    [
        AnyMapping::new(MappingKind::Equirect, 256, 128).unwrap(),
        AnyMapping::new(MappingKind::Cube3x2, 192, 128).unwrap(),
    ]
}

#[test]
fn generated_rooms_are_valid_and_exact() {
    for m in mappings() {
        let dir = tempfile::tempdir().unwrap();
        let rendered = layers::write_room(dir.path(), &m).unwrap();
        let report = validate::validate(dir.path(), &ValidateSettings::default()).unwrap();
        assert!(
            report.valid && report.errors == 0 && report.warnings == 0,
            "{:?}: {:?}",
            m.kind(),
            report.issues
        );

        let pano = Panorama::open(dir.path()).unwrap();
        assert_eq!(pano.manifest.layers.len(), 2);
        let room = pano.read_layer(0, &ReadLimits::default()).unwrap();
        let objects = pano.read_layer(1, &ReadLimits::default()).unwrap();
        // Depth is stored as float32 exactly as ray-cast; spot-check against an independent cast.
        let scene = Scene::room();
        for j in (0..m.height()).step_by(7) {
            for i in (0..m.width()).step_by(5) {
                let k = j * m.width() + i;
                let d = m.pixel_dir(i, j);
                let truth = scene.room_hit(DVec3::ZERO, d).unwrap().t as f32;
                assert_eq!(room.sample(k), Sample::Surface(truth), "room pixel ({i},{j})");
                match scene.first_object_hit(DVec3::ZERO, d) {
                    Some(h) => assert_eq!(objects.sample(k), Sample::Surface(h.t as f32)),
                    None => assert_eq!(objects.sample(k), Sample::Outside),
                }
            }
        }
        // The sparse objects layer is packed, and its atlas holds at most twice its pixels.
        let packing = pano.manifest.layers[1].packing.as_ref().expect("objects layer is packed");
        let atlas = packing.atlas_width as usize * packing.atlas_height as usize;
        let occupied = rendered.objects.occupied();
        assert!(occupied > 0 && atlas <= 2 * occupied, "atlas {atlas} for {occupied} occupied pixels");
        assert!(pano.manifest.layers[0].packing.is_none(), "a full layer must not be packed");
    }
}

/// The committed samples are reproducible: regenerating them gives the same pixels and manifest.
#[test]
fn committed_fixtures_match_the_generator() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/data");
    for (name, m) in [
        ("room-equirect", (MappingKind::Equirect, 512, 256)),
        ("room-cube", (MappingKind::Cube3x2, 384, 256)),
    ] {
        let committed = Panorama::open(&root.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let dir = tempfile::tempdir().unwrap();
        layers::write_room(dir.path(), &AnyMapping::new(m.0, m.1, m.2).unwrap()).unwrap();
        let fresh = Panorama::open(dir.path()).unwrap();
        let strip = |p: &Panorama| {
            let mut m = p.manifest.clone();
            for l in &mut m.layers {
                l.origin = Default::default();
            }
            m
        };
        assert_eq!(
            strip(&committed),
            strip(&fresh),
            "{name}: manifest differs; run `cargo run -p pomc-fixtures --release`"
        );
        for k in 0..fresh.manifest.layers.len() {
            let a = committed.read_layer(k, &ReadLimits::default()).unwrap();
            let b = fresh.read_layer(k, &ReadLimits::default()).unwrap();
            assert_eq!(a.channels.len(), b.channels.len());
            for (ca, cb) in a.channels.iter().zip(&b.channels) {
                let same = ca.data.iter().zip(&cb.data).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(ca.name == cb.name && same, "{name}: layer {k} channel {} differs", ca.name);
            }
        }
    }
}
