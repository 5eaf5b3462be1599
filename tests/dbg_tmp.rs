use pomc::mapping::{AnyMapping, Equirect, Mapping};
use pomc::mesh::simplify::SimplifyParams;
use pomc::mesh::{self, MeshParams};
use pomc_fixtures::layers::{render_on, to_layer};
use pomc_fixtures::Scene;

#[test]
fn dbg() {
    let m = AnyMapping::Equirect(Equirect::new(128, 64).unwrap());
    let r = render_on(&Scene::room(), &m);
    let bg = to_layer(&r.background, true);
    let e = 0.005;
    let p = MeshParams {
        max_error: Some(e),
        max_angle_deg: None,
        simplify: Some(SimplifyParams { max_error: e, max_angle_deg: None }),
        ..MeshParams::default()
    };
    let out = mesh::mesh_layer(&bg, &m, &p).unwrap().mesh;
    let z = bg.depth().unwrap();
    let w = 128;
    for y in 0..64 {
        for x in 0..128 {
            let d = m.pixel_dir(x, y);
            for t in &out.triangles {
                let pp = t.map(|v| out.positions[v as usize]);
                // crude MT
                let (e1, e2) = (pp[1] - pp[0], pp[2] - pp[0]);
                let h = d.cross(e2);
                let a = e1.dot(h);
                if a.abs() < 1e-300 {
                    continue;
                }
                let f = 1.0 / a;
                let s = -pp[0];
                let u = f * s.dot(h);
                if !(-1e-9..=1.0 + 1e-9).contains(&u) {
                    continue;
                }
                let q = s.cross(e1);
                let v = f * d.dot(q);
                if v < -1e-9 || u + v > 1.0 + 1e-9 {
                    continue;
                }
                let tt = f * e2.dot(q);
                if tt <= 0.0 {
                    continue;
                }
                let zz = z[y * w + x] as f64;
                if (tt - zz).abs() / zz > 0.01 {
                    let ids: Vec<(usize, usize)> = t
                        .iter()
                        .map(|&v| {
                            let id = out.sources[v as usize] as usize;
                            (id % w, id / w)
                        })
                        .collect();
                    println!(
                        "pixel ({x},{y}) err {:.3} tri {:?} {:?} t {tt} z {zz} dir {d}",
                        (tt - zz).abs() / zz,
                        ids,
                        pp
                    );
                }
            }
        }
    }
}
