use super::*;
use crate::layering::edges::EdgeOptions;
use crate::mapping::{AnyMapping, Mapping, MappingKind};

/// A fill context over the given planes with the build's default rules (freedom radius
/// 0.5 m, no margin).
#[allow(clippy::too_many_arguments)]
fn context<'a>(
    nb: &'a Neighbours,
    dirs: &'a PixelDirs,
    depth: &'a [f32],
    normals: &'a [Vec3],
    layer_of: &'a [u32],
    links: &'a Links,
    surface: &'a [u32],
    rgb: &'a [Vec<f32>; 3],
) -> FillContext<'a> {
    FillContext {
        nb,
        dirs,
        depth,
        normals,
        layer_of,
        freedom_radius: 0.5,
        margin: 0.0,
        links,
        surface,
        jump: crate::continuity::JUMP,
        plane_tol: EdgeOptions::default().extrapolation,
        rgb,
        soft_depth: false,
    }
}

/// A `w × w/2` equirect canvas: its mapping, width, pixel count and neighbours.
fn equirect(w: usize) -> (AnyMapping, usize, usize, Neighbours) {
    let m = AnyMapping::new(MappingKind::Equirect, w, w / 2).unwrap();
    (m, w, w * w / 2, Neighbours::new(m))
}

/// [`planar_reach`] in pixels of seeds on a wall at x = `wall` and on a sphere of 0.5 m radius
/// centred `dist` away along +x, on a `w` × `w/2` equirect canvas: the sphere seed `az`° off
/// the sphere's centre direction (with its own normal, then without), the wall seed 40° off.
fn sphere_and_wall_reach(w: usize, dist: f32, wall: f32, az: f64) -> (f64, f64, f64) {
    let m = AnyMapping::new(MappingKind::Equirect, w, w / 2).unwrap();
    let n = w * w / 2;
    let nb = Neighbours::new(m);
    let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    let centre = Vec3::new(dist, 0.0, 0.0);
    // The sphere where the ray meets it, else the wall.
    let hit = |d: Vec3| {
        let b = d.dot(centre);
        let disc = b * b - centre.length_squared() + 0.25;
        (disc > 0.0 && b > 0.0).then(|| b - disc.sqrt())
    };
    let (mut depth, mut normals, mut surface) = (vec![0f32; n], vec![Vec3::ZERO; n], vec![0u32; n]);
    for p in 0..n {
        let d = dirs[p];
        (depth[p], normals[p], surface[p]) = match hit(d) {
            Some(t) => (t, (d * t - centre).normalize(), 1),
            None if d.x > 0.05 => (wall / d.x, Vec3::new(-1.0, 0.0, 0.0), 0),
            None => (f32::NAN, Vec3::ZERO, u32::MAX),
        };
    }
    let layer_of = vec![0u32; n];
    let links = Links::compute(&nb, &depth, &EdgeOptions::default());
    let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
    let pixel = std::f64::consts::TAU / w as f64;
    let at = |az: f64| (w / 4 * w) + ((az.to_radians() / pixel) as usize);
    let (on_sphere, on_wall) = (at(az), at(40.0));
    assert_eq!((surface[on_sphere], surface[on_wall]), (1, 0));
    let pdirs = PixelDirs::Full(dirs.clone());
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let surfaces = Surfaces::new(&cx, 0, [on_sphere, on_wall].into_iter());
    let sphere = planar_reach(&cx, &surfaces, 0, on_sphere) / pixel;
    let wall = planar_reach(&cx, &surfaces, 0, on_wall) / pixel;
    // A seed without a normal of its own (at an object's outline) is limited by the one it borrows.
    normals[on_sphere] = Vec3::ZERO;
    let pdirs = PixelDirs::Full(dirs.clone());
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let surfaces = Surfaces::new(&cx, 0, [on_sphere].into_iter());
    let borrowed = planar_reach(&cx, &surfaces, 0, on_sphere) / pixel;
    eprintln!("{dist} m: sphere reach {sphere:.1} px, without a normal {borrowed:.1} px; wall {wall} px");
    (sphere, borrowed, wall)
}

/// The tangent plane of a wall may be continued without limit; a sphere's only about as far
/// as it fits the sphere: within the plane tolerance (0.5 m radius, 2 m away: the plane
/// leaves it within a few pixels) and while the normals stay within 20° (6 m away, 7 pixels
/// in radius: the plane stays within 5 % of the depth for 7 pixels, so the tolerance alone
/// let the fill draw the sphere up to twice as wide; the normals turn 20° within 3).
#[test]
fn a_curved_surface_is_continued_only_as_far_as_its_plane_fits() {
    for (w, dist, wall, az, most) in [(256, 2.0, 4.0, 5.0, 8.0), (512, 6.0, 8.0, 2.0, 4.0)] {
        let (sphere, borrowed, wall) = sphere_and_wall_reach(w, dist, wall, az);
        assert!(sphere > 1.0 && sphere < most, "{dist} m: sphere reach {sphere} px");
        assert!(borrowed > 1.0 && borrowed < most, "{dist} m: borrowed reach {borrowed} px");
        assert_eq!(wall, f64::INFINITY);
    }
}

/// The planes of a fill context, made by [`Planes::blocked`] or [`Planes::facing_wall`].
struct Planes {
    nb: Neighbours,
    dirs: PixelDirs,
    depth: Vec<f32>,
    layer_of: Vec<u32>,
    links: Links,
    normals: Vec<Vec3>,
    surface: Vec<u32>,
    rgb: [Vec<f32>; 3],
}

/// Whether pixel `p` of the [`Planes::blocked`] canvas is in the hidden block.
fn in_block(p: usize) -> bool {
    (20..44).contains(&(p % 64)) && (8..24).contains(&(p / 64))
}

impl Planes {
    /// A wall (depth per pixel `wall`) on a 64 × 32 equirect canvas, a block of it (x 20–43,
    /// y 8–23) hidden by a nearer layer 1 m away.
    fn blocked(wall: impl Fn(usize) -> f32) -> Planes {
        let (m, w, n, nb) = equirect(64);
        let depth: Vec<f32> = (0..n).map(|p| if in_block(p) { 1.0 } else { wall(p) }).collect();
        let dirs = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let layer_of = (0..n).map(|p| in_block(p) as u32).collect();
        Planes::of(nb, dirs, depth, layer_of, vec![0u32; n], vec![Vec3::ZERO; n])
    }

    /// A wall at x = 3 m seen on a 128 × 64 equirect canvas (the pixels facing it, `x > 0.05`;
    /// the rest unknown), each pixel's depth, layer, surface and normal given by `at(p, wall
    /// depth)`.
    fn facing_wall(at: impl Fn(usize, f32) -> (f32, u32, u32, Vec3)) -> Planes {
        let (m, w, n, nb) = equirect(128);
        let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
        let mut depth = vec![f32::NAN; n];
        let (mut normals, mut surface, mut layer_of) =
            (vec![Vec3::ZERO; n], vec![u32::MAX; n], vec![u32::MAX; n]);
        for p in (0..n).filter(|&p| dirs[p].x > 0.05) {
            (depth[p], layer_of[p], surface[p], normals[p]) = at(p, 3.0 / dirs[p].x);
        }
        Planes::of(nb, dirs, depth, layer_of, surface, normals)
    }

    fn of(
        nb: Neighbours,
        dirs: Vec<Vec3>,
        depth: Vec<f32>,
        layer_of: Vec<u32>,
        surface: Vec<u32>,
        normals: Vec<Vec3>,
    ) -> Planes {
        let n = depth.len();
        Planes {
            links: Links::compute(&nb, &depth, &EdgeOptions::default()),
            rgb: [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]],
            dirs: PixelDirs::Full(dirs),
            nb,
            depth,
            layer_of,
            normals,
            surface,
        }
    }

    fn cx(&self) -> FillContext<'_> {
        let b = self;
        context(&b.nb, &b.dirs, &b.depth, &b.normals, &b.layer_of, &b.links, &b.surface, &b.rgb)
    }

    /// The wall's depth at pixel `p`.
    fn wall(&self, p: usize) -> f32 {
        3.0 / self.dirs.at(p).x
    }
}

/// A wall at 3 m with a nearer layer (1 m) in front of a block of it. Its fill continues the
/// wall, except for a rival plane at 2 m claimed in two places: a band touching the wall's
/// fill, and an island cut off from everything (the fill pixels around it went).
#[test]
fn a_rival_plane_dropped_gives_back_the_nearest_seeds_plane_and_leaves_no_remnant() {
    let b = Planes::blocked(|_| 3.0);
    let (cx, w, n, hidden) = (b.cx(), 64, b.depth.len(), in_block);
    let band = |p: usize| (24..32).contains(&(p % w)) && (10..12).contains(&(p / w));
    let island = |p: usize| (36..40).contains(&(p % w)) && (18..20).contains(&(p / w));
    let moat = |p: usize| (35..41).contains(&(p % w)) && (17..21).contains(&(p / w)) && !island(p);
    let px = |p: usize, depth: f32| FillPixel {
        pixel: p,
        depth,
        rgb: [0.5; 3],
        surface: 0,
        angle: 0.0,
        level: false,
    };
    let mut fill = Fill::default();
    let mut own_plane = HashMap::new();
    for p in (0..n).filter(|&p| hidden(p) && !moat(p)) {
        if band(p) || island(p) {
            fill.pixels.push(px(p, 2.0));
            own_plane.insert(p, px(p, 3.0));
        } else {
            fill.pixels.push(px(p, 3.0));
        }
    }
    keep_continuous(&cx, 0, &mut fill, own_plane);
    let got: HashMap<usize, f32> = fill.pixels.iter().map(|f| (f.pixel, f.depth)).collect();
    assert!((0..n).filter(|&p| band(p)).all(|p| got.get(&p) == Some(&3.0)), "the band takes the wall back");
    assert!(got.values().all(|&d| d == 3.0), "no pixel keeps the rival's plane");
    let holes = (0..n).filter(|&p| hidden(p) && !moat(p) && !island(p) && !got.contains_key(&p)).count();
    assert_eq!(holes, 0, "the wall's fill has no hole");
}

/// A box at 1 m before a wall at 3 m, its top edge lined with in-between depths (1.3 m, as a
/// resized depth edge leaves them): one-pixel surfaces without a normal, in the wall's layer.
/// They seed no fill; the wall's fill behind the box is at the wall's depth, not a screen at
/// 1.3 m (which a camera moved aside saw as a ghost of the box).
#[test]
fn specks_without_a_plane_seed_no_fill() {
    let (m, w, n, nb) = equirect(128);
    let hidden = |p: usize| (52..76).contains(&(p % w)) && (24..40).contains(&(p / w));
    let speck = |p: usize| (52..76).contains(&(p % w)) && p / w == 23;
    let depth: Vec<f32> = (0..n)
        .map(|p| {
            if hidden(p) {
                1.0
            } else if speck(p) {
                1.3
            } else {
                3.0
            }
        })
        .collect();
    let layer_of: Vec<u32> = (0..n).map(|p| hidden(p) as u32).collect();
    let surface: Vec<u32> =
        (0..n).map(|p| if speck(p) { 10 + p as u32 % w as u32 } else { hidden(p) as u32 }).collect();
    let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    let links = Links::compute(&nb, &depth, &EdgeOptions::default());
    let normals = vec![Vec3::ZERO; n];
    let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
    let pdirs = PixelDirs::Full(dirs.clone());
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let fill = fill_layer(&cx, 0);
    let screen = fill.pixels.iter().filter(|f| f.depth < 2.0).count();
    eprintln!("{} filled, {screen} at the specks' depth", fill.pixels.len());
    assert!(fill.pixels.len() > 100, "the wall is continued behind the box");
    assert_eq!(screen, 0, "filled pixels in front of the wall");
    // Pixels of unknown depth given the wall's (a depth sensor's shadow beside the box) are on
    // no segment and have no normal: not specks. Ringing the box, they are its only seeds.
    let ring = |p: usize| (51..77).contains(&(p % w)) && (23..41).contains(&(p / w)) && !hidden(p);
    let depth: Vec<f32> = (0..n).map(|p| if hidden(p) { 1.0 } else { 3.0 }).collect();
    let surface: Vec<u32> = (0..n).map(|p| if ring(p) { u32::MAX } else { hidden(p) as u32 }).collect();
    let links = Links::compute(&nb, &depth, &EdgeOptions::default());
    let pdirs = PixelDirs::Full(dirs.clone());
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let unknown = fill_layer(&cx, 0);
    eprintln!("{} filled from a ring of unknown depth", unknown.pixels.len());
    assert!(unknown.pixels.len() > 100, "the ring of unknown depth seeds the fill");
}

/// A block hides part of a wall at x = 3 m. Its right edge meets the wall without a jump (fold
/// seeds); the wall pixels along its other edges carry a plane the rays behind the block miss
/// (as the in-between depths of a resized edge do). Those seeds claim nothing, so the fold
/// seeds fill the whole block at the wall's depth; claimed by them, 8 of its 64 pixels stayed
/// empty.
#[test]
fn a_seed_whose_plane_misses_leaves_the_pixel_to_one_whose_plane_meets_it() {
    let w = 128;
    let (x, y) = (|p: usize| p % w, |p: usize| p / w);
    let block = |p: usize| (4..12).contains(&x(p)) && (28..36).contains(&y(p));
    let bad = |p: usize| !block(p) && (3..12).contains(&x(p)) && (27..37).contains(&y(p));
    let scene = Planes::facing_wall(|p, wall| {
        if block(p) {
            // 1 m at its left edge, at the wall's depth (less 1 %) at its right.
            let t = (x(p) - 4) as f32 / 7.0;
            (1.0 + t * (0.99 * wall - 1.0), 1, 1, Vec3::new(-1.0, 0.0, 0.0))
        } else if bad(p) {
            (wall, 0, 5, Vec3::new(1.0, 0.0, 0.0))
        } else {
            (wall, 0, 0, Vec3::new(-1.0, 0.0, 0.0))
        }
    });
    let (n, wall) = (scene.depth.len(), |p| scene.wall(p));
    let mut cx = scene.cx();
    // Every part of the block is within the radius: the whole of it may be filled.
    cx.freedom_radius = 2.95;
    let fill = fill_layer(&cx, 0);
    let got: HashMap<usize, f32> = fill.pixels.iter().map(|f| (f.pixel, f.depth)).collect();
    let hidden: Vec<usize> = (0..n).filter(|&p| block(p)).collect();
    let filled =
        hidden.iter().filter(|&&p| got.get(&p).is_some_and(|&d| (d / wall(p) - 1.0).abs() < 0.01)).count();
    eprintln!("{filled} of {} hidden pixels filled at the wall", hidden.len());
    assert_eq!(filled, hidden.len());
}

#[test]
fn band_is_the_parallax_difference() {
    // r = 0.5, occluder at 1 m, wall at 2 m: asin(0.5) − asin(0.25).
    let b = parallax_band(0.5, 1.0, 2.0);
    assert!((b - (0.5f64.asin() - 0.25f64.asin())).abs() < 1e-12);
    assert_eq!(parallax_band(0.5, 0.05, 2.0), std::f64::consts::PI);
    assert!((parallax_band(0.5, 1.0, f64::INFINITY) - 0.5f64.asin()).abs() < 1e-12);
    assert_eq!(parallax_band(0.5, 3.0, 3.0), 0.0);
}

/// A wall behind a box whose two halves were continued from seeds on two planes 15 % apart
/// (3 m and 3.45 m): the fronts meet with a step over the continuity rule's 8 %, which drops the
/// nearer column. The crack is closed by depths within the step of both sides: no hole, and the
/// layer stays continuous.
#[test]
fn a_crack_where_two_fronts_meet_is_closed() {
    let wall = |p: usize| if p % 64 < 32 { 3.0 } else { 3.45 };
    let b = Planes::blocked(wall);
    let (cx, n, hidden, nb) = (b.cx(), b.depth.len(), in_block, &b.nb);
    let mut fill = Fill::default();
    for p in (0..n).filter(|&p| hidden(p)) {
        fill.pixels.push(FillPixel {
            pixel: p,
            depth: wall(p),
            rgb: [0.5; 3],
            surface: 0,
            angle: 0.0,
            level: false,
        });
    }
    keep_continuous(&cx, 0, &mut fill, HashMap::new());
    let got: HashMap<usize, f32> = fill.pixels.iter().map(|f| (f.pixel, f.depth)).collect();
    assert_eq!(got.len(), fill.pixels.len(), "each pixel filled once");
    let holes = (0..n).filter(|&p| hidden(p) && !got.contains_key(&p)).count();
    assert_eq!(holes, 0, "no crack is left");
    let at = |p: usize| if hidden(p) { got[&p] } else { wall(p) };
    for &q in got.keys() {
        for j in 0..4 {
            let r = nb.get(q, j).unwrap();
            let (a, b) = (f64::from(at(q)), f64::from(at(r)));
            assert!(!crate::continuity::steps_apart(a, b, crate::continuity::JUMP), "{a} beside {b}");
        }
    }
}

/// Where the fills of two layers overlap behind an occluder, the nearer layer keeps only what it
/// reaches from nearer than the farther one does (ties stay with it), and the farther keeps all.
#[test]
fn a_hidden_pixel_goes_to_the_layer_that_shows_nearest() {
    let px = |pixel: usize, angle: f32| FillPixel {
        pixel,
        depth: 2.0,
        rgb: [0.5; 3],
        surface: 0,
        angle,
        level: false,
    };
    let sky = Fill { pixels: vec![px(1, 0.01), px(2, 0.03), px(3, 0.02), px(5, 0.01)], ..Fill::default() };
    // Pixel 5 is on a level plane (ground below the horizon): it stays.
    let ground = FillPixel { level: true, ..px(5, 0.04) };
    let wall =
        Fill { pixels: vec![px(1, 0.02), px(2, 0.01), px(3, 0.02), px(4, 0.05), ground], ..Fill::default() };
    let mut fills = [sky, wall];
    yield_to_farther(&mut fills);
    let kept = |f: &Fill| f.pixels.iter().map(|p| p.pixel).collect::<Vec<_>>();
    assert_eq!(kept(&fills[0]), [1, 2, 3, 5]);
    assert_eq!(kept(&fills[1]), [2, 3, 4, 5]);
}

/// Real depth's normals scatter from pixel to pixel by 20° and more (completed LiDAR stripes)
/// while its depth lies on the plane. A wall whose normals turn by up to 30° either way (a fixed
/// hash of the pixel) is continued without limit, as with exact ones: a turned normal where the
/// depth still fits the plane is noise. (On a real capture the reach stopped at the first turned
/// normal, 1–3 px in, and left a slit a camera 0.3 m aside saw along a door jamb.)
#[test]
fn scattered_normals_on_a_plane_do_not_end_its_reach() {
    let (m, w, n, nb) = equirect(256);
    let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    let (mut depth, mut normals, mut surface) = (vec![f32::NAN; n], vec![Vec3::ZERO; n], vec![u32::MAX; n]);
    for p in (0..n).filter(|&p| dirs[p].x > 0.05) {
        depth[p] = 3.0 / dirs[p].x;
        surface[p] = 0;
        let turn = ((p as u32).wrapping_mul(2654435761) >> 16) as f32 / 65535.0 * 60.0 - 30.0;
        normals[p] = glam::Quat::from_rotation_z(turn.to_radians()) * Vec3::NEG_X;
    }
    let layer_of = vec![0u32; n];
    let links = Links::compute(&nb, &depth, &EdgeOptions::default());
    let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
    let pixel = std::f64::consts::TAU / w as f64;
    let seed = (w / 4 * w) + ((20f64.to_radians() / pixel) as usize);
    normals[seed] = Vec3::NEG_X;
    let turned = (0..n).filter(|&p| normals[p].dot(Vec3::NEG_X) < SAME_PLANE_COS).count();
    let pdirs = PixelDirs::Full(dirs);
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let surfaces = Surfaces::new(&cx, 0, [seed].into_iter());
    let reach = planar_reach(&cx, &surfaces, 0, seed) / pixel;
    eprintln!("{turned} of the wall's normals turned over 20°; reach {reach} px");
    assert!(turned > n / 20, "the scatter turns normals");
    assert_eq!(reach, f64::INFINITY);
}

/// A block at 1 m before a wall at x = 3 m, ringed (2 px wide) by a cone of in-between depths
/// as blurred depth leaves them: 3 % nearer than the wall, cut into surfaces of 3 px of the
/// wall's layer, their normals turned outwards from the block. From soft depth each ring seed
/// continues the wall's plane a few pixels inside ([`surface::anchor`]), so the fill behind the
/// block is the wall; continuing the cone's own planes, it is not.
#[test]
fn from_soft_depth_seeds_on_small_pieces_of_an_outline_continue_their_layer() {
    let w = 128;
    let (x, y) = (|p: usize| p % w, |p: usize| p / w);
    let block = |p: usize| (4..16).contains(&x(p)) && (26..38).contains(&y(p));
    let ring = |p: usize| !block(p) && (2..18).contains(&x(p)) && (24..40).contains(&y(p));
    let m = AnyMapping::new(MappingKind::Equirect, w, w / 2).unwrap();
    let dir = |p: usize| m.pixel_dir(x(p), y(p)).as_vec3();
    let centre = dir(31 * w + 10) * 3.0 / dir(31 * w + 10).x;
    let scene = Planes::facing_wall(|p, wall| {
        if block(p) {
            (1.0, 1, 1, Vec3::new(-1.0, 0.0, 0.0))
        } else if ring(p) {
            let out = (dir(p) * wall - centre) * Vec3::new(0.0, 1.0, 1.0);
            let n = (Vec3::new(-0.3, 0.0, 0.0) + 0.95 * out.normalize()).normalize();
            (0.97 * wall, 0, 10 + (p / 3) as u32, n)
        } else {
            (wall, 0, 0, Vec3::new(-1.0, 0.0, 0.0))
        }
    });
    let (n, wall) = (scene.depth.len(), |p| scene.wall(p));
    let mut cx = scene.cx();
    cx.freedom_radius = 1.5;
    let at_wall = |cx: &FillContext| {
        let got: HashMap<usize, f32> = fill_layer(cx, 0).pixels.iter().map(|f| (f.pixel, f.depth)).collect();
        let hidden: Vec<usize> = (0..n).filter(|&p| block(p)).collect();
        let ok = hidden
            .iter()
            .filter(|&&p| got.get(&p).is_some_and(|&d| (d / wall(p) - 1.0).abs() < 0.01))
            .count();
        ok as f64 / hidden.len() as f64
    };
    let exact = at_wall(&cx);
    cx.soft_depth = true;
    let soft = at_wall(&cx);
    eprintln!(
        "hidden pixels filled at the wall: {:.0} % as exact depth, {:.0} % as soft",
        100.0 * exact,
        100.0 * soft
    );
    // 95 %: below the block, walks along the ring end on its small pieces.
    assert!(soft >= 0.9, "from soft depth the fill continues the wall");
    assert!(exact < 0.5, "the cone's own planes leave the wall (else this test shows nothing)");
}

/// Two filled pixels of a layer side by side whose depths step by more than `validate`'s 50 % with
/// nothing beside them to continue a plane (a third pixel that made them one surface went to a
/// farther layer's fill): [`keep_valid`] drops the nearer; a pair within the step stays.
#[test]
fn a_fill_left_discontinuous_loses_its_nearer_pixel() {
    let (m, w, n, nb) = equirect(64);
    let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    let depth = vec![f32::NAN; n];
    let (normals, surface, layer_of) = (vec![Vec3::ZERO; n], vec![0u32; n], vec![1u32; n]);
    let links = Links::compute(&nb, &depth, &EdgeOptions::default());
    let rgb = [vec![0.5f32; n], vec![0.5f32; n], vec![0.5f32; n]];
    let pdirs = PixelDirs::Full(dirs);
    let cx = context(&nb, &pdirs, &depth, &normals, &layer_of, &links, &surface, &rgb);
    let px = |pixel: usize, depth: f32| FillPixel {
        pixel,
        depth,
        rgb: [0.5; 3],
        surface: 0,
        angle: 0.0,
        level: false,
    };
    let (a, b) = (16 * w + 10, 16 * w + 11);
    let (c, d) = (20 * w + 10, 20 * w + 11);
    let mut fill = Fill { pixels: vec![px(a, 5.5), px(b, 3.5), px(c, 5.5), px(d, 4.0)], ..Fill::default() };
    keep_valid(&cx, 0, &mut fill);
    let mut kept: Vec<usize> = fill.pixels.iter().map(|f| f.pixel).collect();
    kept.sort_unstable();
    assert_eq!(kept, [a, c, d]);
}

/// Rivals are weighed within 45° of their seed only: behind a nearer layer that hides a whole
/// band of the sphere, a pixel 30° from the wall's one seed has it as a rival, one 60° away has
/// none (the search once flooded every hidden pixel of the canvas).
#[test]
fn rivals_are_searched_within_45_degrees() {
    let (m, w, n, nb) = equirect(128);
    let dirs: Vec<Vec3> = (0..n).map(|p| m.pixel_dir(p % w, p / w).as_vec3()).collect();
    // Layer 0 is one column of wall (x 0), the rest a nearer layer 1 m away.
    let layer_of: Vec<u32> = (0..n).map(|p| u32::from(p % w != 0)).collect();
    let depth: Vec<f32> = (0..n).map(|p| if p % w == 0 { 3.0 } else { 1.0 }).collect();
    let b = Planes::of(nb, dirs, depth, layer_of, vec![0u32; n], vec![Vec3::X; n]);
    let cx = b.cx();
    let seed = (w / 4) * w; // On the equator.
    let (slot_of, rivals) = rivals(&cx, 0, &[seed]);
    let pixel = 360.0 / w as f64;
    let at = |deg: f64| (w / 4) * w + (deg / pixel).round() as usize;
    let holds = |p: usize| slot_of[p] != NONE && rivals[slot_of[p] as usize].contains(&(seed as u32));
    assert!(holds(at(30.0)), "30° away");
    assert!(!holds(at(60.0)), "60° away");
    assert!(!holds(at(180.0)), "opposite");
}
