//! Adaptive 8-neighbourhood point splatting (thesis 7.3.2, Alg. 10; spec §9.3).
//!
//! Every layer pixel is reprojected into the output camera (or the cameras of one pass, such as
//! two stereo eyes: [`views`]). Its *spread* — the longest quad edge, in output pixels, between the
//! reprojections of it and its 8 neighbours — says how many sub-samples the
//! pixel needs so that consecutive samples land less than [`SplatOptions::spacing`] apart: the
//! pixel is resampled on an `nx × ny` grid whose points are bilinear interpolations of the camera
//! space points (and colours) of the pixel and its neighbours, i.e. of the piecewise-planar surface
//! through the samples. Only neighbours on the same continuous surface take part: a relative depth
//! jump above [`SplatOptions::jump`] is a discontinuity inside the layer, and a splat never
//! stretches across it (that would draw a skin between an object and what is behind it). Each
//! sample is filtered into the output with a tent (bilinear) kernel of radius
//! [`SplatOptions::radius`] (Alg. 9) and a per-pixel depth test ([`super::accum`]).
//!
//! Work is split in tiles of layer pixels (never straddling a cube face) with a one-pixel apron
//! resolved across the equirect seam, the poles and cube-face edges; tiles outside the camera's
//! view cone are culled before any trigonometry. Tiles are dealt round-robin to one accumulation
//! buffer per thread and camera, merged at the end.

use glam::{DMat4, DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;

mod footprint;
mod views;

use super::accum::Accum;
use super::camera::{Camera, AT_INFINITY};
use crate::continuity;
use crate::layer::{classify, LayerImage, Sample};
use crate::mapping::{AnyMapping, Mapping};
use crate::mapping::{DirTable, Neighbours, OFFSETS};
use footprint::{extent, fills_only, interpolate, Footprint, Rect};
pub use views::MAX_VIEWS;
use views::{Cull, PerView, Views};

/// Tuning of the splatting renderer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SplatOptions {
    /// Radius of the tent reconstruction filter, output pixels (thesis: 0.75; 0.5, with samples as
    /// far apart, blurs the layers' already filtered colour least, spec §9.3 step 5).
    pub radius: f64,
    /// Relative depth jump between 8-neighbours above which they are different surfaces.
    pub jump: f64,
    /// Relative camera-distance tolerance within which samples blend as one surface.
    pub tolerance: f64,
    /// Target distance between consecutive sub-samples, output pixels (≤ 2 × radius leaves no gap).
    pub spacing: f64,
    /// Cap on sub-samples per layer pixel along each axis (bounds the work for content very near
    /// the camera; beyond it a splat may show gaps).
    pub max_subsamples: usize,
}

impl Default for SplatOptions {
    fn default() -> Self {
        SplatOptions { radius: 0.5, jump: 0.1, tolerance: 0.01, spacing: 0.5, max_subsamples: 32 }
    }
}

/// Side of the square tiles of layer pixels processed as a unit.
const TILE: usize = 32;

/// Work counters of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SplatCounts {
    /// Tiles of layer pixels visited, culled or not.
    pub tiles: usize,
    /// Tiles skipped: no surface or infinitely far sample in them, or outside the camera's view cone.
    pub tiles_culled: usize,
    /// Layer pixels reprojected (inside a layer's domain, in a tile not culled).
    pub pixels: u64,
    /// Samples filtered into the output (pixels × their sub-samples).
    pub samples: u64,
}

add_counts!(SplatCounts: tiles, tiles_culled, pixels, samples);

/// One layer's planes, borrowed for splatting.
#[derive(Clone, Copy, Debug)]
pub struct LayerPlanes<'a> {
    /// The layer's canvas mapping.
    pub mapping: AnyMapping,
    /// Depth channel `Z`, row-major over the canvas.
    pub z: &'a [f32],
    /// Coverage channel `A`; `None` when the layer has none.
    pub coverage: Option<&'a [f32]>,
    /// Linear colour channels `R`, `G`, `B`.
    pub rgb: [&'a [f32]; 3],
}

impl<'a> LayerPlanes<'a> {
    /// The planes of `image`; `None` if a channel among `R`,`G`,`B`,`Z` is missing (the name is
    /// returned) — checked by the caller, which knows the layer's index.
    pub fn new(image: &'a LayerImage, mapping: AnyMapping) -> Result<Self, &'static str> {
        let get = |name: &'static str| image.channel(name).map(|c| c.data.as_slice()).ok_or(name);
        Ok(LayerPlanes {
            mapping,
            z: get("Z")?,
            coverage: image.coverage(),
            rgb: [get("R")?, get("G")?, get("B")?],
        })
    }
}

/// A rectangle of layer pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Tile {
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
}

/// Split `len` into runs of at most [`TILE`] that never cross a multiple of `segment`.
fn runs(len: usize, segment: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    while s < len {
        let end = (s + segment).min(len);
        let mut a = s;
        while a < end {
            let b = (a + TILE).min(end);
            out.push((a, b - a));
            a = b;
        }
        s = end;
    }
    out
}

fn tiles(m: &AnyMapping) -> Vec<Tile> {
    let seg = match m {
        AnyMapping::Equirect(_) => m.width().max(m.height()),
        AnyMapping::Cube(c) => c.face_size(),
    };
    let xs = runs(m.width(), seg);
    runs(m.height(), seg)
        .into_iter()
        .flat_map(|(y0, h)| xs.iter().map(move |&(x0, w)| Tile { x0, y0, w, h }))
        .collect()
}

/// Index into [`OFFSETS`] of a neighbour offset.
#[inline]
const fn offset_index(dx: i64, dy: i64) -> usize {
    match (dx, dy) {
        (1, 0) => 0,
        (-1, 0) => 1,
        (0, 1) => 2,
        (0, -1) => 3,
        (1, 1) => 4,
        (-1, 1) => 5,
        (1, -1) => 6,
        _ => 7,
    }
}

/// One reprojected layer pixel.
#[derive(Clone, Copy, Debug, Default)]
struct Pt {
    /// Camera-space point (a direction for infinity samples).
    cam: DVec3,
    /// Output pixel coordinates in each view, where `vis`.
    q: PerView<DVec2>,
    /// Distance along each view's ray (`+inf` for infinity samples).
    dist: PerView<f32>,
    /// Layer depth (for the continuity test).
    z: f32,
    rgb: [f32; 3],
    /// Inside the domain with a usable depth.
    ok: bool,
    /// An infinity sample.
    far: bool,
    /// `q` is valid, per view.
    vis: PerView<bool>,
    /// Camera-space direction of the pixel's ray (set for every pixel of the canvas, inside the
    /// domain or not): a neighbour's ray at the centre pixel's own depth bounds its footprint.
    ray: DVec3,
}

/// Everything a tile needs, shared by all tiles of one layer.
struct LayerCtx<'a> {
    /// Index of the layer (its samples never blend with another layer's).
    index: u32,
    planes: LayerPlanes<'a>,
    dirs: DirTable,
    nb: Neighbours,
    views: &'a Views<'a>,
    /// Panorama-local → camera space.
    to_cam: DMat4,
    /// The panorama centre in camera space.
    centre: DVec3,
    /// Each view's view-cone culling, if it has one.
    culls: PerView<Option<Cull>>,
    o: SplatOptions,
}

/// Samples filtered into each view.
type Done = PerView<u64>;

impl LayerCtx<'_> {
    #[inline]
    fn sample(&self, p: usize) -> Sample {
        classify(self.planes.z[p], self.planes.coverage.map(|a| a[p]))
    }

    fn point(&self, p: usize) -> Pt {
        let w = self.planes.mapping.width();
        let (i, j) = (p % w, p / w);
        let ray = self.to_cam.transform_vector3(self.dirs.get(i, j));
        let (cam, proj, far) = match self.sample(p) {
            Sample::Surface(d) if d >= 0.0 && d.is_finite() => {
                let c = self.centre + ray * d as f64;
                (c, self.views.project_and_distance(c), false)
            }
            Sample::Infinite => {
                let c = ray * AT_INFINITY;
                (c, self.views.project(c).map(|q| q.map(|q| (q, f64::INFINITY))), true)
            }
            _ => return Pt { ray, ..Pt::default() },
        };
        let rgb = [self.planes.rgb[0][p], self.planes.rgb[1][p], self.planes.rgb[2][p]];
        Pt {
            cam,
            q: proj.map(|v| v.map_or(DVec2::ZERO, |v| v.0)),
            dist: proj.map(|v| v.map_or(0.0, |v| v.1 as f32)),
            z: self.planes.z[p],
            rgb,
            ok: true,
            far,
            vis: proj.map(|v| v.is_some()),
            ray,
        }
    }

    /// Whether the tile may be skipped: nothing in the domain, or outside every view's cone.
    fn skip(&self, t: &Tile) -> bool {
        let w = self.planes.mapping.width();
        let mut zmin = f64::INFINITY;
        let mut any = false;
        for y in t.y0..t.y0 + t.h {
            for p in y * w + t.x0..y * w + t.x0 + t.w {
                match self.sample(p) {
                    Sample::Surface(d) if d >= 0.0 && d.is_finite() => {
                        any = true;
                        zmin = zmin.min(d as f64);
                    }
                    Sample::Infinite => any = true,
                    _ => {}
                }
            }
        }
        if !any {
            return true;
        }
        if self.culls[..self.views.n()].iter().any(Option::is_none) {
            return false;
        }
        let m = &self.planes.mapping;
        let (x0, y0, x1, y1) = (t.x0 as f64, t.y0 as f64, (t.x0 + t.w) as f64, (t.y0 + t.h) as f64);
        let centre = m.pixel_to_dir((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let mut spread = 0.0f64;
        for (x, y) in [
            (x0, y0),
            (x1, y0),
            (x0, y1),
            (x1, y1),
            ((x0 + x1) / 2.0, y0),
            ((x0 + x1) / 2.0, y1),
            (x0, (y0 + y1) / 2.0),
            (x1, (y0 + y1) / 2.0),
        ] {
            spread = spread.max(centre.dot(m.pixel_to_dir(x, y)).clamp(-1.0, 1.0).acos());
        }
        // Two pixels of margin for the apron and sub-samples reaching into neighbouring tiles.
        let pixel = std::f64::consts::PI / m.height() as f64;
        self.culls[..self.views.n()].iter().flatten().all(|c| c.outside(centre, spread + 2.0 * pixel, zmin))
    }

    /// Layer pixel index of apron cell `(ax, ay)` (tile-relative, `-1 ..= w`), across edges.
    fn apron_index(&self, t: &Tile, ax: i64, ay: i64) -> Option<usize> {
        let w = self.planes.mapping.width();
        let bx = ax.clamp(0, t.w as i64 - 1);
        let by = ay.clamp(0, t.h as i64 - 1);
        let (x, y) = (t.x0 + bx as usize, t.y0 + by as usize);
        if (ax, ay) == (bx, by) {
            return Some(y * w + x);
        }
        self.nb.get_at(x, y, offset_index(ax - bx, ay - by))
    }

    fn splat_tile(&self, t: &Tile, buf: &mut Vec<Pt>, accs: &mut [Accum], n: &mut [SplatCounts]) {
        for n in n.iter_mut() {
            n.tiles += 1;
        }
        if self.skip(t) {
            for n in n.iter_mut() {
                n.tiles_culled += 1;
            }
            return;
        }
        let stride = t.w + 2;
        buf.clear();
        for ay in -1..=t.h as i64 {
            for ax in -1..=t.w as i64 {
                buf.push(self.apron_index(t, ax, ay).map(|p| self.point(p)).unwrap_or_default());
            }
        }
        for ly in 0..t.h {
            for lx in 0..t.w {
                let at =
                    |dx: i64, dy: i64| (ly as i64 + 1 + dy) as usize * stride + (lx as i64 + 1 + dx) as usize;
                if buf[at(0, 0)].ok {
                    let nbrs: [&Pt; 8] =
                        std::array::from_fn(|k| &buf[at(OFFSETS[k].0 as i64, OFFSETS[k].1 as i64)]);
                    let done = self.splat_pixel(&buf[at(0, 0)], &nbrs, accs);
                    for (n, d) in n.iter_mut().zip(done) {
                        n.pixels += 1;
                        n.samples += d;
                    }
                }
            }
        }
    }

    /// Whether the centre pixel `c` and its neighbour `n` are one surface by the shared rule
    /// ([`continuity::continuous`]); the tile's one-pixel apron holds the opposite neighbour `o`
    /// (behind `c`) but not the pixel beyond `n`, so the plane is followed from `c`'s side only.
    fn continuous(&self, c: f32, n: f32, o: &Pt) -> bool {
        let behind = o.ok.then_some(o.z as f64);
        continuity::continuous(c as f64, n as f64, behind, None, self.o.jump, continuity::PLANAR)
    }

    /// Splat one pixel and its sub-samples into every view that sees it; returns the number of
    /// samples per view.
    fn splat_pixel(&self, c: &Pt, nbrs: &[&Pt; 8], accs: &mut [Accum]) -> Done {
        let mut done = [0; MAX_VIEWS];
        if !c.vis.contains(&true) {
            return done;
        }
        let Footprint { linked, own, sx, sy } = self.footprint(c, nbrs);
        let ([x_lo, x_hi], [y_lo, y_hi]) = (extent(&linked, 0, 1), extent(&linked, 2, 3));
        let cap = self.o.max_subsamples.max(1);
        if sx.max(sy) > self.o.spacing * cap as f64 {
            // Past the uniform grid's reach: the footprint is very large on screen (the surface is
            // near the eye, or near the camera plane where projection diverges). Refine it where
            // it lands on the output only, so work and sample size follow what is visible.
            // Quadrants of one bilinear patch each, the border strips apart (they fill only).
            let pieces = |lo: f64, hi: f64| {
                [(lo, -0.5), (-0.5, 0.0), (0.0, 0.5), (0.5, hi)].into_iter().filter(|(a, b)| b > a)
            };
            for (x0, x1) in pieces(x_lo, x_hi) {
                for (y0, y1) in pieces(y_lo, y_hi) {
                    let sq = Rect { x0, y0, w: x1 - x0, h: y1 - y0 };
                    self.refine(c, &linked, &own, sq, 1, c.vis, accs, &mut done);
                }
            }
            return done;
        }
        let count = |s: f64| ((s / self.o.spacing).ceil() as usize).clamp(1, cap);
        let (nx, ny) = (count(sx), count(sy));
        let radius = self.o.radius;
        let mut active = c.vis;
        for (v, a) in active.iter_mut().enumerate().take(self.views.n()) {
            *a = *a && !self.views.off_screen(v, c.q[v], sx.max(sy) + radius);
        }
        if !active.contains(&true) {
            return done;
        }
        // The footprint's area on each output, shared by its samples.
        let areas = self.footprint_area(c, &linked, &own);
        let cover = areas.map(|a| a.unwrap_or(sx * sy) / (nx * ny) as f64 / (radius * radius));
        if nx == 1 && ny == 1 {
            let proj = std::array::from_fn(|v| c.vis[v].then(|| (c.q[v], f64::from(c.dist[v]))));
            self.filter(c, proj, c.rgb, radius, cover, active, accs, &mut done);
        } else {
            for b in 0..ny {
                let oy = (b as f64 + 0.5) / ny as f64 - 0.5;
                for a in 0..nx {
                    let ox = (a as f64 + 0.5) / nx as f64 - 0.5;
                    self.emit(c, &linked, &own, (ox, oy), radius, cover, active, accs, &mut done);
                }
            }
        }
        // The border strips: the grid over the whole extent at the same spacing, its samples past
        // `[−½, ½]²` only (they cover nothing: they fill).
        let (span_x, span_y) = (x_hi - x_lo, y_hi - y_lo);
        if span_x > 1.0 || span_y > 1.0 {
            let (ex, ey) = (count(sx * span_x), count(sy * span_y));
            for b in 0..ey {
                let oy = y_lo + (b as f64 + 0.5) / ey as f64 * span_y;
                for a in 0..ex {
                    let ox = x_lo + (a as f64 + 0.5) / ex as f64 * span_x;
                    if fills_only(ox, oy) {
                        self.emit(
                            c,
                            &linked,
                            &own,
                            (ox, oy),
                            radius,
                            [0.0; MAX_VIEWS],
                            active,
                            accs,
                            &mut done,
                        );
                    }
                }
            }
        }
        done
    }

    /// The neighbours `c` is linked to (one surface), where its footprint ends towards the others
    /// (their rays at `c`'s depth), and its extent along x and y on the views that see it (the
    /// largest).
    #[inline]
    fn footprint<'p>(&self, c: &Pt, nbrs: &[&'p Pt; 8]) -> Footprint<'p> {
        let mut linked: [Option<&'p Pt>; 8] = [None; 8];
        // Where a neighbour is not linked, the pixel still covers its own footprint: up to the
        // neighbour's ray at the pixel's own depth.
        let mut own: [Option<DVec3>; 8] = [None; 8];
        let mut reach = [[None; MAX_VIEWS]; 8];
        for k in 0..8 {
            let nb = nbrs[k];
            let (dx, dy) = OFFSETS[k];
            let opposite = nbrs[offset_index(-dx as i64, -dy as i64)];
            reach[k] = if nb.ok && self.continuous(c.z, nb.z, opposite) {
                linked[k] = Some(nb);
                std::array::from_fn(|v| nb.vis[v].then_some(nb.q[v]))
            } else if nb.ray != DVec3::ZERO {
                let p = if c.far { nb.ray * AT_INFINITY } else { self.centre + nb.ray * c.z as f64 };
                own[k] = Some(p);
                self.views.project(p)
            } else {
                [None; MAX_VIEWS]
            };
        }
        // The sub-samples run in rows and columns across the four quads of the footprint: the
        // longest quad edge along each direction bounds their spacing (the diagonals, √2 longer,
        // would oversample by half as much again). An edge whose start does not project is
        // measured from the pixel.
        let (mut sx, mut sy) = (0.0f64, 0.0f64);
        for v in (0..self.views.n()).filter(|&v| c.vis[v]) {
            let at = |dx: i64, dy: i64| {
                if (dx, dy) == (0, 0) {
                    Some(c.q[v])
                } else {
                    reach[offset_index(dx, dy)][v]
                }
            };
            let edge = |from: (i64, i64), to: (i64, i64)| match (at(from.0, from.1), at(to.0, to.1)) {
                (Some(a), Some(b)) => self.views.gap(v, a, b),
                (None, Some(b)) => self.views.gap(v, c.q[v], b),
                _ => 0.0,
            };
            for d in [-1, 1] {
                for e in [-1, 0, 1] {
                    sx = sx.max(edge((0, e), (d, e)));
                    sy = sy.max(edge((e, 0), (e, d)));
                }
            }
        }
        Footprint { linked, own, sx, sy }
    }

    /// Area on each output (equirect metric) of pixel `c`'s footprint, as its samples cover it:
    /// the parallelogram through the midpoints of its sides. `None` where one does not project.
    fn footprint_area(
        &self,
        c: &Pt,
        linked: &[Option<&Pt>; 8],
        own: &[Option<DVec3>; 8],
    ) -> PerView<Option<f64>> {
        let [l, r, t, b] = [(-0.5, 0.0), (0.5, 0.0), (0.0, -0.5), (0.0, 0.5)]
            .map(|(ox, oy)| self.views.project(interpolate(c, linked, own, ox, oy).0));
        std::array::from_fn(|v| {
            if v >= self.views.n() {
                return None;
            }
            let u = self.views.delta(v, l[v]?, r[v]?);
            let w = self.views.delta(v, t[v]?, b[v]?);
            Some(u.perp_dot(w).abs())
        })
    }

    /// Filter the footprint point at offset `o` into the `active` views with coverage `cover` per
    /// unit of filter weight, counting the samples that project in `done`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn emit(
        &self,
        c: &Pt,
        linked: &[Option<&Pt>; 8],
        own: &[Option<DVec3>; 8],
        o: (f64, f64),
        radius: f64,
        cover: PerView<f64>,
        active: PerView<bool>,
        accs: &mut [Accum],
        done: &mut Done,
    ) {
        let (cam, rgb) = interpolate(c, linked, own, o.0, o.1);
        let proj = self.views.project_and_distance(cam);
        self.filter(c, proj, rgb, radius, cover, active, accs, done);
    }

    /// Filter a sample of pixel `c` (projected as `proj` into each view) into the `active` views.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn filter(
        &self,
        c: &Pt,
        proj: PerView<Option<(DVec2, f64)>>,
        rgb: [f32; 3],
        radius: f64,
        cover: PerView<f64>,
        active: PerView<bool>,
        accs: &mut [Accum],
        done: &mut Done,
    ) {
        for v in 0..self.views.n() {
            let Some((q, dist)) = proj[v].filter(|_| active[v]) else { continue };
            let dist = if c.far { f32::INFINITY } else { dist as f32 };
            let s = Splat { q, dist, rgb, layer: self.index, cover: cover[v] };
            splat(&self.views.cameras[v], &self.views.scales[v], radius, &s, &mut accs[v]);
            done[v] += 1;
        }
    }

    /// Adaptive resampling of one rectangle of a pixel's footprint (inside one quadrant, where the
    /// surface is one bilinear patch, inside the hull of its corners): a rectangle whose hull lies
    /// outside every view's frustum is dropped, one whose projected sides are at most
    /// [`SplatOptions::spacing`] long is one sample, any other is halved across each direction
    /// whose sides are longer (a grazing sliver L pixels long costs ~L samples, not L²).
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        c: &Pt,
        linked: &[Option<&Pt>; 8],
        own: &[Option<DVec3>; 8],
        sq: Rect,
        depth: u32,
        mut active: PerView<bool>,
        accs: &mut [Accum],
        done: &mut Done,
    ) {
        let cams = sq.corners().map(|(ox, oy)| interpolate(c, linked, own, ox, oy).0);
        for (v, a) in active.iter_mut().enumerate().take(self.views.n()) {
            *a = *a && !self.views.cameras[v].hull_outside(&cams, self.o.radius + 1.0);
        }
        if !active.contains(&true) {
            return;
        }
        let (cx, cy) = (sq.x0 + sq.w / 2.0, sq.y0 + sq.h / 2.0);
        let q = cams.map(|p| self.views.project(p));
        let corners = |v: usize| [q[0][v], q[1][v], q[2][v], q[3][v]];
        let (mut along_x, mut along_y) = (0.0f64, 0.0f64);
        for v in (0..self.views.n()).filter(|&v| active[v]) {
            let (x, y) = match corners(v) {
                [Some(a), Some(b), Some(d), Some(e)] => {
                    let g = |p, q| self.views.gap(v, p, q);
                    (g(a, b).max(g(e, d)), g(b, d).max(g(e, a)))
                }
                // Straddles the camera plane: split until what projects is sampled finely.
                _ => (f64::INFINITY, f64::INFINITY),
            };
            along_x = along_x.max(x);
            along_y = along_y.max(y);
        }
        let side = along_x.max(along_y);
        // The rectangle's area on view `v`: its projected quad (shoelace).
        let area = |v: usize| {
            let [Some(a), Some(b), Some(d), Some(e)] = corners(v) else { return None };
            let (b, d, e) = (self.views.delta(v, a, b), self.views.delta(v, a, d), self.views.delta(v, a, e));
            Some((b.perp_dot(d) + d.perp_dot(e)).abs() / 2.0)
        };
        let r = self.o.radius;
        let fills = fills_only(cx, cy);
        if side <= self.o.spacing {
            let cover =
                std::array::from_fn(|v| if fills { 0.0 } else { area(v).unwrap_or(side * side) / (r * r) });
            return self.emit(c, linked, own, (cx, cy), r, cover, active, accs, done);
        }
        if depth >= MAX_REFINE {
            // Only a surface touching the eye gets here (one layer pixel wider than 2^16 samples
            // at the spacing); its samples grow so the footprint stays covered.
            let grow = if side.is_finite() { side / self.o.spacing } else { 1.0 };
            let r = r * grow;
            let cover = std::array::from_fn(|v| {
                if fills {
                    0.0
                } else {
                    area(v).filter(|a| a.is_finite()).map_or(1.0, |a| a / (r * r))
                }
            });
            return self.emit(c, linked, own, (cx, cy), r, cover, active, accs, done);
        }
        let (nx, ny) = (1 + (along_x > self.o.spacing) as usize, 1 + (along_y > self.o.spacing) as usize);
        let (w, h) = (sq.w / nx as f64, sq.h / ny as f64);
        for j in 0..ny {
            for i in 0..nx {
                let child = Rect { x0: sq.x0 + i as f64 * w, y0: sq.y0 + j as f64 * h, w, h };
                self.refine(c, linked, own, child, depth + 1, active, accs, done);
            }
        }
    }
}

/// Deepest subdivision of a footprint: 16 halvings (`2^-16` of a layer pixel along a direction).
const MAX_REFINE: u32 = 16;

/// One sample ready to filter into the output.
#[derive(Clone, Copy, Debug)]
struct Splat {
    /// Output pixel coordinates.
    q: DVec2,
    /// Camera distance.
    dist: f32,
    rgb: [f32; 3],
    layer: u32,
    /// Coverage of the output per unit of filter weight: the sample's area over the filter's
    /// integral `r²` ([`super::accum::Cell::cover`]).
    cover: f64,
}

/// The horizontal metric at output row coordinate `y` (clamped into the image).
#[inline]
fn row_scale(scales: &[f64], y: f64) -> f64 {
    scales[(y.max(0.0) as usize).min(scales.len() - 1)]
}

/// Filter one sample into the output with a tent of radius `r` (thesis Alg. 9). Equirect outputs
/// widen the kernel horizontally by `1 / sin θ` so it covers the same solid angle near the poles,
/// and wrap it around the seam.
#[inline]
fn splat(camera: &Camera, scales: &[f64], r: f64, s: &Splat, acc: &mut Accum) {
    let q = s.q;
    let (w, h) = (acc.width as i64, acc.height as i64);
    let y0 = ((q.y - r - 0.5).ceil() as i64).max(0);
    let y1 = ((q.y + r - 0.5).floor() as i64).min(h - 1);
    let wraps = camera.wraps();
    for py in y0..=y1 {
        let fy = 1.0 - (py as f64 + 0.5 - q.y).abs() / r;
        if fy <= 0.0 {
            continue;
        }
        let sc = scales[py as usize];
        let rx = (r / sc).min(w as f64 / 2.0);
        let mut x0 = (q.x - rx - 0.5).ceil() as i64;
        let mut x1 = (q.x + rx - 0.5).floor() as i64;
        if wraps {
            x1 = x1.min(x0 + w - 1);
        } else {
            x0 = x0.max(0);
            x1 = x1.min(w - 1);
        }
        let row = (py * w) as usize;
        for px in x0..=x1 {
            let fx = 1.0 - (px as f64 + 0.5 - q.x).abs() * sc / r;
            if fx > 0.0 {
                let wt = fx * fy;
                acc.add(
                    row + px.rem_euclid(w) as usize,
                    s.dist,
                    wt as f32,
                    (wt * s.cover) as f32,
                    s.rgb,
                    s.layer,
                );
            }
        }
    }
}

/// Splat every layer into one accumulation buffer per camera, in one pass: 1 to [`MAX_VIEWS`]
/// cameras sharing one camera space ([`Camera::to_camera`]; the caller checks), such as the eyes of
/// an ODS camera. The tiles, pixels and sub-samples are found once for all of them.
pub fn splat_layers(
    layers: &[LayerPlanes],
    local_to_world: DMat4,
    cameras: &[Camera],
    o: &SplatOptions,
) -> (Vec<Accum>, Vec<SplatCounts>) {
    assert!((1..=MAX_VIEWS).contains(&cameras.len()), "1 to {MAX_VIEWS} views a pass");
    let views = Views::new(cameras);
    let to_cam = cameras[0].to_camera() * local_to_world;
    let mut culls = [None; MAX_VIEWS];
    for (c, camera) in culls.iter_mut().zip(cameras) {
        *c = Cull::new(camera, local_to_world);
    }
    let ctxs: Vec<LayerCtx> = layers
        .iter()
        .enumerate()
        .map(|(index, &planes)| LayerCtx {
            index: index as u32,
            planes,
            dirs: DirTable::new(planes.mapping),
            nb: Neighbours::new(planes.mapping),
            views: &views,
            to_cam,
            centre: to_cam.transform_point3(DVec3::ZERO),
            culls,
            o: *o,
        })
        .collect();
    let jobs: Vec<(usize, Tile)> = ctxs
        .iter()
        .enumerate()
        .flat_map(|(k, c)| tiles(&c.planes.mapping).into_iter().map(move |t| (k, t)))
        .collect();
    let groups = rayon::current_num_threads().max(1);
    let new_accs =
        || -> Vec<Accum> { cameras.iter().map(|c| Accum::new(c.width(), c.height(), o.tolerance)).collect() };
    let parts: Vec<(Vec<Accum>, Vec<SplatCounts>)> = (0..groups)
        .into_par_iter()
        .map(|g| {
            let mut accs = new_accs();
            let mut counts = vec![SplatCounts::default(); cameras.len()];
            let mut buf = Vec::with_capacity((TILE + 2) * (TILE + 2));
            for (k, t) in jobs.iter().skip(g).step_by(groups) {
                ctxs[*k].splat_tile(t, &mut buf, &mut accs, &mut counts);
            }
            (accs, counts)
        })
        .collect();
    let mut parts = parts.into_iter();
    let (mut accs, mut counts) = parts.next().expect("at least one group");
    for (a, c) in parts {
        for (acc, a) in accs.iter_mut().zip(&a) {
            acc.merge(a);
        }
        for (n, c) in counts.iter_mut().zip(c) {
            *n = n.add(c);
        }
    }
    (accs, counts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::MappingKind;

    #[test]
    fn tiles_cover_the_canvas_once_and_never_straddle_a_face() {
        for (kind, w, h) in [(MappingKind::Equirect, 200, 100), (MappingKind::Cube3x2, 3 * 45, 2 * 45)] {
            let m = AnyMapping::new(kind, w, h).unwrap();
            let mut seen = vec![0u8; w * h];
            for t in tiles(&m) {
                if kind == MappingKind::Cube3x2 {
                    assert_eq!(t.x0 / 45, (t.x0 + t.w - 1) / 45);
                    assert_eq!(t.y0 / 45, (t.y0 + t.h - 1) / 45);
                }
                for y in t.y0..t.y0 + t.h {
                    for x in t.x0..t.x0 + t.w {
                        seen[y * w + x] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1));
        }
    }

    #[test]
    fn offsets_round_trip() {
        for (k, &(dx, dy)) in OFFSETS.iter().enumerate() {
            assert_eq!(offset_index(dx as i64, dy as i64), k);
        }
    }
}
