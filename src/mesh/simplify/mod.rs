//! Second stage (not part of the `.pomcmesh` encoding): greedy half-edge collapses `v → u` of the
//! stitched quadtree mesh, ordered by relative Garland–Heckbert quadrics, each accepted only when every
//! pixel its new triangles cover stays within the tolerance along its ray, nothing flips or crosses a
//! jump, and the mesh stays a watertight 2-manifold. Constraints, error bounds and parallel parts:
//! `docs/mesh.md`, "Simplification".

// `!(x <= limit)` is deliberate throughout: a NaN (an invalid pixel, a degenerate plane) must fail.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use rayon::prelude::*;

use super::grid::Grid;
use super::LayerMesh;
use crate::mapping::AnyMapping;

/// Tolerances of the simplification stage.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifyOptions {
    /// Maximum relative distance along each pixel's ray between the simplified mesh and the sample.
    pub max_error: f64,
    /// Cap on the angle between the rays of two vertices of a triangle (texture distortion), degrees.
    pub max_angle_deg: Option<f64>,
    /// Mesh clean cube faces (every pixel valid, no depth jump) by greedy insertion
    /// (`super::greedy`) instead of quadtree + collapses: faster and fewer triangles there.
    pub greedy: bool,
}

/// Counters of one run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SimplifyStats {
    /// Half-edge collapses performed (one vertex removed each).
    pub collapses: usize,
    /// Collapses that reached the pixel test.
    pub tested: usize,
    /// Collapses accepted by the planar shortcut (no pixel scan).
    pub planar: usize,
    /// Wall-clock milliseconds of the per-lattice phase and of the whole-mesh phase.
    pub lattice_ms: f64,
    /// Milliseconds of the whole-mesh phase (vertices whose stars span lattices or stitching).
    pub stitch_ms: f64,
}

impl SimplifyStats {
    /// Add the counts of another run (not its times).
    fn add(&mut self, o: &SimplifyStats) {
        self.collapses += o.collapses;
        self.tested += o.tested;
        self.planar += o.planar;
    }
}

/// Smallest `|det[d0, d1, d2]|` (unit rays) of a created triangle: twice its solid angle, about. A
/// half-pixel stitching strip one pixel long on a 6×16384² cube is ~5e-9; an edge-on triangle is ~1e-16.
const MIN_DET: f64 = 1e-12;

/// A pair (new, old) of triangles is bounded without a scan when their hit distances differ by at
/// most this fraction of the tolerance over their intersection.
const PAIR_SKIP: f64 = 0.05;

mod overlap;
mod quadric;
mod run;
mod shared;

use self::quadric::Loc;

use self::run::Run;

use self::shared::Shared;

/// A part of phase 1: lattice `g`, columns `x0..=x1`; its interior vertices (strictly between) are
/// simplified independently of the other parts'.
struct PhasePart {
    g: u8,
    x0: u32,
    x1: u32,
}

/// Vertical bands of the equirect simplified in parallel (at most).
const EQUIRECT_BANDS: usize = 4;

/// Phase-1 parts: each lattice whole, except a lone lattice (the equirect), which is cut into up to
/// [`EQUIRECT_BANDS`] vertical bands at columns no lattice triangle crosses (the quadtree's split columns
/// usually are such), chosen nearest to even spacing.
fn phase_parts(mesh: &LayerMesh, shared: &Shared, grids: &[Grid]) -> Vec<PhasePart> {
    let whole = |g: usize| PhasePart { g: g as u8, x0: 0, x1: grids[g].w as u32 - 1 };
    if grids.len() != 1 || grids[0].w < 64 {
        return (0..grids.len()).map(whole).collect();
    }
    let w = grids[0].w;
    // crossed[c] > 0 when some lattice triangle has vertices strictly on both sides of column c.
    // Triangles joining the first and last columns (the equirect seam strip) and pole fans are not
    // lattice triangles of any band.
    let mut diff = vec![0i64; w + 1];
    for t in &mesh.triangles {
        let xs = t.map(|v| match shared.loc[v as usize] {
            Loc::Lattice { x, .. } => Some(x as usize),
            Loc::Pole => None,
        });
        let [Some(a), Some(b), Some(c)] = xs else { continue };
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        if lo == 0 && hi == w - 1 {
            continue;
        }
        if hi > lo + 1 {
            diff[lo + 1] += 1;
            diff[hi] -= 1;
        }
    }
    let mut crossed = vec![false; w];
    let mut run = 0i64;
    for c in 0..w {
        run += diff[c];
        crossed[c] = run > 0;
    }
    // A fixed count, not the thread count: the output must not depend on the machine.
    let k = EQUIRECT_BANDS;
    let mut cuts = vec![0usize];
    for i in 1..k {
        let ideal = i * (w - 1) / k;
        let window = w / (4 * k);
        let found = (0..=window)
            .flat_map(|d| [ideal.saturating_sub(d), ideal + d])
            .find(|&c| c > *cuts.last().expect("non-empty") + 1 && c + 1 < w - 1 && !crossed[c]);
        if let Some(c) = found {
            cuts.push(c);
        }
    }
    cuts.push(w - 1);
    cuts.windows(2).map(|p| PhasePart { g: 0, x0: p[0] as u32, x1: p[1] as u32 }).collect()
}

/// Simplify a mesh made by [`super::mesh_layer`] from `grids` (its lattices) on `mapping`. `done[g]`,
/// when set, holds the exact error of each of lattice `g`'s own triangles, in mesh order (a lattice
/// meshed by `super::greedy`), which spares their first scans.
pub fn simplify(
    mesh: &LayerMesh,
    grids: &[Grid],
    mapping: &AnyMapping,
    params: &SimplifyOptions,
    done: &[Option<Vec<f64>>],
) -> (LayerMesh, SimplifyStats) {
    let shared = Shared::new(mesh, grids, mapping, params);
    let n = mesh.positions.len();
    // Poles, lattice corners and anything not on a lattice never move.
    let fixed: Vec<bool> = (0..n)
        .map(|v| {
            shared.loc[v] == Loc::Pole || shared.sides[v].count_ones() >= 2 || !shared.pos[v].is_finite()
        })
        .collect();
    let clock = std::time::Instant::now();

    // Phase 1: interior vertices of independent parts, in parallel — each cube face; the equirect in
    // vertical bands split at columns that no lattice triangle crosses (so a band's interior stars never
    // leave it). A part's run holds every triangle touching the part; only its interior stars change.
    let phases = Phases { shared: &shared, parts: phase_parts(mesh, &shared, grids), fixed };
    let (tris, terr, mut stats) = phases.run_parts(mesh, done);
    let phase2_seed = phases.phase2_seeds(mesh, grids);

    stats.lattice_ms = clock.elapsed().as_secs_f64() * 1e3;
    let clock = std::time::Instant::now();
    // Phase 2: the whole mesh, from the vertices phase 1 left (their stars span parts).
    let movable: Vec<bool> = phases.fixed.iter().map(|&f| !f).collect();
    let mut run = Run::new(&shared, tris, Some(terr), movable);
    let seeds: Vec<u32> = (0..n as u32).filter(|&v| phase2_seed[v as usize]).collect();
    run.run(seeds.into_iter());
    stats.add(&run.stats);
    stats.stitch_ms = clock.elapsed().as_secs_f64() * 1e3;

    (compact(mesh, run.alive_triangles().collect()), stats)
}

/// The independent parts of phase 1 and the vertices that never move.
struct Phases<'a> {
    shared: &'a Shared<'a>,
    parts: Vec<PhasePart>,
    fixed: Vec<bool>,
}

impl Phases<'_> {
    fn lattice_x(&self, v: u32) -> Option<(u8, u32)> {
        match self.shared.loc[v as usize] {
            Loc::Lattice { g, x, .. } => Some((g, x)),
            Loc::Pole => None,
        }
    }

    /// The part that holds all three vertices of `t`, if one does.
    fn part_of(&self, t: &[u32; 3]) -> Option<usize> {
        let l = t.map(|v| self.lattice_x(v));
        let [Some(a), Some(b), Some(c)] = l else { return None };
        self.parts.iter().position(|p| [a, b, c].iter().all(|&(g, x)| g == p.g && x >= p.x0 && x <= p.x1))
    }

    fn touches(&self, t: &[u32; 3], p: &PhasePart) -> bool {
        t.iter().any(|&v| self.lattice_x(v).is_some_and(|(g, x)| g == p.g && x >= p.x0 && x <= p.x1))
    }

    /// Whether vertex `v` moves in part `p`'s run: inside it, off every lattice side.
    fn interior(&self, v: usize, p: &PhasePart) -> bool {
        !self.fixed[v]
            && self.shared.sides[v] == 0
            && self.lattice_x(v as u32).is_some_and(|(g, x)| g == p.g && x > p.x0 && x < p.x1)
    }

    /// Phase 1: each part's run, in parallel; the triangles (with their errors) of every part in
    /// turn, then those of no part.
    fn run_parts(
        &self,
        mesh: &LayerMesh,
        done: &[Option<Vec<f64>>],
    ) -> (Vec<[u32; 3]>, Vec<f64>, SimplifyStats) {
        let n = mesh.positions.len();
        let tri_parts: Vec<Option<usize>> = mesh.triangles.iter().map(|t| self.part_of(t)).collect();
        type Part = (Vec<[u32; 3]>, Vec<f64>, SimplifyStats);
        let results: Vec<Part> = self
            .parts
            .par_iter()
            .enumerate()
            .map(|(k, p)| {
                let tris: Vec<[u32; 3]> = mesh
                    .triangles
                    .iter()
                    .zip(&tri_parts)
                    .filter(|(_, q)| **q == Some(k))
                    .map(|(t, _)| *t)
                    .collect();
                let own = tris.len();
                let known = done.get(p.g as usize).and_then(Option::as_ref).filter(|e| e.len() == own);
                let mut all = tris;
                all.extend(
                    mesh.triangles
                        .iter()
                        .zip(&tri_parts)
                        .filter(|(t, q)| q.is_none() && self.touches(t, p))
                        .map(|(t, _)| *t),
                );
                let movable: Vec<bool> = (0..n).map(|v| self.interior(v, p)).collect();
                let seeds: Vec<u32> = (0..n as u32).filter(|&v| movable[v as usize]).collect();
                // Known errors of the lattice's own triangles spare their scans.
                let terr = known.map(|e| {
                    let mut terr = e.clone();
                    terr.extend(all[own..].iter().map(|t| self.shared.max_error(*t, f64::INFINITY)));
                    terr
                });
                let mut run = Run::new(self.shared, all, terr, movable);
                run.run(seeds.into_iter());
                let keep: Vec<usize> = (0..own).filter(|&i| run.alive[i]).collect();
                (
                    keep.iter().map(|&i| run.tris[i]).collect(),
                    keep.iter().map(|&i| run.terr[i]).collect(),
                    run.stats,
                )
            })
            .collect();
        let (mut tris, mut terr, mut stats) = (Vec::new(), Vec::new(), SimplifyStats::default());
        for (t, e, s) in results {
            tris.extend(t);
            terr.extend(e);
            stats.add(&s);
        }
        for (t, _) in mesh.triangles.iter().zip(&tri_parts).filter(|(_, q)| q.is_none()) {
            tris.push(*t);
            terr.push(self.shared.max_error(*t, f64::INFINITY));
        }
        (tris, terr, stats)
    }

    /// Where phase 2 starts: every movable vertex that no part could move (sides, band
    /// boundaries), and the neighbours of cut columns.
    fn phase2_seeds(&self, mesh: &LayerMesh, grids: &[Grid]) -> Vec<bool> {
        let fixed = &self.fixed;
        let mut seed: Vec<bool> = (0..mesh.positions.len())
            .map(|v| !fixed[v] && !self.parts.iter().any(|p| self.interior(v, p)))
            .collect();
        // A band's run sees only one side of its cut columns, so collapses onto a cut-column vertex
        // may have been refused there: their neighbours get another chance in phase 2.
        if self.parts.len() > 1 && grids.len() == 1 {
            let on_cut = |v: u32| {
                self.lattice_x(v).is_some_and(|(_, x)| {
                    self.parts
                        .iter()
                        .any(|p| (x == p.x0 && x > 0) || (x == p.x1 && x + 1 < grids[0].w as u32))
                })
            };
            for t in &mesh.triangles {
                if t.iter().any(|&v| on_cut(v)) {
                    for &v in t {
                        seed[v as usize] |= !fixed[v as usize];
                    }
                }
            }
        }
        seed
    }
}

/// `mesh`'s vertices that `tris` use, in their order (sources stay sorted), and `tris` on them.
fn compact(mesh: &LayerMesh, tris: Vec<[u32; 3]>) -> LayerMesh {
    let n = mesh.positions.len();
    let mut used = vec![false; n];
    for t in &tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut remap = vec![u32::MAX; n];
    let (mut sources, mut positions) = (Vec::new(), Vec::new());
    for v in 0..n {
        if used[v] {
            remap[v] = sources.len() as u32;
            sources.push(mesh.sources[v]);
            positions.push(mesh.positions[v]);
        }
    }
    let triangles = tris.iter().map(|t| t.map(|v| remap[v as usize])).collect();
    LayerMesh { width: mesh.width, height: mesh.height, sources, positions, triangles }
}
