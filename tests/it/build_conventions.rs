//! The `--convention` presets: the LocalToWorld they record maps our pixel directions onto the
//! other tool's, checked against that tool's own formula (written out independently here).

use std::f64::consts::PI;

use glam::DVec3;
use pomc::input::Convention;
use pomc::manifest::{Manifest, MappingDecl, MappingKind};
use pomc::mapping::{Equirect, Mapping};

fn world(c: Convention, d: DVec3) -> DVec3 {
    let m = Manifest {
        version: "1".into(),
        transforms: c.transforms(),
        mapping: MappingDecl { kind: MappingKind::Equirect },
        freedom_radius: 0.5,
        layers: vec![],
    };
    m.local_to_world().transform_vector3(d)
}

#[test]
fn conventions_match_the_tools_formulas() {
    let e = Equirect::new(64, 32).unwrap();
    for j in 0..32 {
        for i in 0..64 {
            let d = e.pixel_dir(i, j);
            let (u, v) = ((i as f64 + 0.5) / 64.0, (j as f64 + 0.5) / 32.0);
            let th = PI * v;
            // Blender's equirect camera: azimuth π(1 − 2u), +Z up.
            let b = PI * (1.0 - 2.0 * u);
            let blender = DVec3::new(th.sin() * b.cos(), th.sin() * b.sin(), th.cos());
            assert!((world(Convention::Blender, d) - blender).length() < 1e-12, "blender at ({i},{j})");
            // OpenEXR lat-long: longitude π − 2πu, latitude π/2 − πv, +Y up.
            let (lon, lat) = (PI - 2.0 * PI * u, PI / 2.0 - th);
            let exr = DVec3::new(lon.sin() * lat.cos(), lat.sin(), lon.cos() * lat.cos());
            assert!((world(Convention::OpenExr, d) - exr).length() < 1e-12, "openexr at ({i},{j})");
            assert!((world(Convention::Thesis, d) - d).length() < 1e-15);
        }
    }
}
