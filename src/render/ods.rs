//! Omnidirectional stereo (ODS): one eye of a stereo panorama (spec §9.2, docs/stereo.md).
//!
//! Each output column looks along its azimuth from a point on the *viewing circle* of radius
//! `IPD / 2` around the eye centre, tangent to it: the left eye's ray for direction `d` starts at
//! `(IPD / 2) · normalize(Z × d)` (to the left of `d`), the right eye's at the opposite point, and
//! both eyes look in parallel (no convergence). This is the model of Blender Cycles' spherical
//! stereo with parallel convergence, and its "pole merge" too: above `from` degrees of elevation
//! the offset fades as `cos(π/2 · (|e| − from) / (to − from))`, reaching 0 at `to`, so the eyes
//! meet at the poles and nothing swirls there.
//!
//! A point `P` (eye-centred, horizontal distance `ρ`, azimuth `α`) is seen by the ray of azimuth
//! `α − asin(s / ρ)` (`s` the signed offset, positive for the left eye) and elevation
//! `atan2(P_z, √(ρ² − s²))`, at distance `√(ρ² − s² + P_z²)` along it. Points with `ρ ≤ |s|` — on
//! or inside the viewing circle, or within `|s|` of the vertical axis below the pole merge — are
//! seen by no ray: those more than `|s|` above or below the eye are drawn where the rays grazing
//! the cylinder `ρ = |s|` look ([`OdsEye::ray_to_or_edge`]), the others (the viewer's head) not.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DVec2, DVec3};

use super::checks::{check_size, finite};
use super::RenderError;

/// Fading of the eye offset towards the poles (Blender's "pole merge"), elevation angles in
/// radians, `0 ≤ from < to ≤ π/2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoleMerge {
    from: f64,
    to: f64,
    /// `tan² from`, `tan² to` (`+inf` at π/2): the solve's trigonometry-free first tests.
    tan2: [f64; 2],
}

impl Default for PoleMerge {
    /// Blender's defaults: 60° to 75°.
    fn default() -> Self {
        PoleMerge::new(60f64.to_radians(), 75f64.to_radians())
    }
}

impl PoleMerge {
    /// The fade from elevation `from` to `to` (radians; checked by [`OdsEye::new`]).
    pub fn new(from: f64, to: f64) -> Self {
        let t2 = |a: f64| if a >= FRAC_PI_2 { f64::INFINITY } else { a.tan().powi(2) };
        PoleMerge { from, to, tan2: [t2(from), t2(to)] }
    }

    /// Elevation (absolute, radians) where the offset starts to fade.
    pub fn from(&self) -> f64 {
        self.from
    }

    /// Elevation where it reaches 0.
    pub fn to(&self) -> f64 {
        self.to
    }

    /// The share of the eye offset kept at elevation `e` (radians): 1 below `from`, 0 above `to`.
    #[inline]
    pub fn fade(&self, e: f64) -> f64 {
        let a = e.abs();
        if a <= self.from {
            1.0
        } else if a >= self.to {
            0.0
        } else {
            (FRAC_PI_2 * (a - self.from) / (self.to - self.from)).cos()
        }
    }
}

/// One eye of an ODS panorama: an equirect in the world axes (as [`super::EquirectCamera`]) whose
/// rays start on the viewing circle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdsEye {
    /// Centre of the viewing circle in world coordinates, metres.
    pub eye: DVec3,
    /// Image width, pixels (twice the height).
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Signed eye offset, metres: `+IPD/2` for the left eye, `−IPD/2` for the right.
    pub offset: f64,
    /// Fading to mono towards the poles; `None` keeps the full offset everywhere.
    pub pole_merge: Option<PoleMerge>,
}

/// Largest number of steps of the pole-merge solve (it converges in a handful; the bound only
/// keeps a pathological point from looping).
const MERGE_STEPS: usize = 60;

impl OdsEye {
    /// One eye of `width × height` (2:1) centred at `eye`, its rays starting `offset` metres to the
    /// left of their direction (negative: to the right).
    pub fn new(
        eye: DVec3,
        width: usize,
        height: usize,
        offset: f64,
        pole_merge: Option<PoleMerge>,
    ) -> Result<Self, RenderError> {
        check_size(width, height)?;
        if width != 2 * height {
            return Err(RenderError::BadSize { width, height, need: super::checks::EQUIRECT });
        }
        if !offset.is_finite() {
            return Err(RenderError::BadCamera(format!("eye offset {offset} is not finite")));
        }
        if let Some(m) = pole_merge {
            if !(m.from >= 0.0 && m.from < m.to && m.to <= FRAC_PI_2) {
                return Err(RenderError::BadCamera(format!(
                    "pole merge from {}° to {}°: need 0 ≤ from < to ≤ 90",
                    m.from.to_degrees(),
                    m.to.to_degrees()
                )));
            }
        }
        Ok(OdsEye { eye: finite(eye, "eye")?, width, height, offset, pole_merge })
    }

    /// The signed offset for rays of elevation `e`.
    #[inline]
    fn offset_at(&self, e: f64) -> f64 {
        match &self.pole_merge {
            Some(m) => self.offset * m.fade(e),
            None => self.offset,
        }
    }

    /// The ray that sees eye-centred point `p`: its azimuth and its horizontal run to `p`
    /// (`√(ρ² − s²)`); `None` when no ray does (see the module notes) or `p` is not finite.
    #[inline]
    fn solve(&self, p: DVec3) -> Option<(f64, f64)> {
        let (alpha, turn, t_h) = self.solve_parts(p)?;
        Some((alpha - turn, t_h))
    }

    /// [`OdsEye::solve`] in parts: the point's azimuth `α`, the turn `asin(s / ρ)` the ray's azimuth
    /// is short of it, and the horizontal run. The mirror eye (offset `−s`) turns the other way by
    /// the same angle along the same run.
    #[inline]
    fn solve_parts(&self, p: DVec3) -> Option<(f64, f64, f64)> {
        if !p.is_finite() {
            return None;
        }
        let rho2 = p.x * p.x + p.y * p.y;
        let s = match &self.pole_merge {
            Some(m) if self.offset != 0.0 => self.merged_offset(m, p.z, rho2),
            _ => self.offset,
        };
        if s * s >= rho2 && s != 0.0 || rho2 + p.z * p.z == 0.0 {
            return None;
        }
        let rho = rho2.sqrt();
        if rho == 0.0 {
            return Some((0.0, 0.0, 0.0));
        }
        Some((p.y.atan2(p.x), (s / rho).asin(), (rho2 - s * s).max(0.0).sqrt()))
    }

    /// The ray that sees eye-centred point `p`: its unit direction and the distance along it;
    /// `None` when no ray does (see the module notes) or `p` is not finite.
    pub fn ray_to(&self, p: DVec3) -> Option<(DVec3, f64)> {
        let (phi, t_h) = self.solve(p)?;
        let dist = t_h.hypot(p.z);
        let (sp, cp) = phi.sin_cos();
        Some((DVec3::new(cp * t_h, sp * t_h, p.z) / dist, dist))
    }

    /// [`OdsEye::ray_to`], but a point no ray sees that lies more than `|offset|` above or below
    /// the eye is first moved out horizontally onto the cylinder of radius `|offset|` around the
    /// vertical axis (just outside it): the near-vertical rays grazing the cylinder there see what
    /// is next to it, so content around the poles stays covered without the pole merge. A point
    /// within `|offset|` of the eye both ways (the viewer's head) is not drawn.
    pub fn ray_to_or_edge(&self, p: DVec3) -> Option<(DVec3, f64)> {
        self.ray_to(self.edge(p)?)
    }

    /// `p`, or where [`OdsEye::ray_to_or_edge`] moves it; `None` inside the viewer's head.
    #[inline]
    fn edge(&self, p: DVec3) -> Option<DVec3> {
        let rho2 = p.x * p.x + p.y * p.y;
        let o = self.offset.abs();
        if rho2 > o * o || !p.is_finite() {
            return Some(p); // seen (or refused) as it is; the pole merge only lowers the offset
        }
        if self.solve(p).is_some() {
            return Some(p);
        }
        if p.z.abs() <= o {
            return None;
        }
        let rho = rho2.sqrt();
        let edge = o * (1.0 + 1e-9) + f64::MIN_POSITIVE;
        Some(if rho > 0.0 {
            DVec3::new(p.x * edge / rho, p.y * edge / rho, p.z)
        } else {
            p + DVec3::X * edge
        })
    }

    /// The offset of the ray that sees a point at height `z` and squared horizontal distance `rho2`
    /// under the pole merge, whose fade depends on that ray's elevation `e`: a root of
    /// `g(e) = atan2(|z|, √(ρ² − s(e)²)) − e`, bracketed between `from` and `to` (`g` is
    /// continuous, positive at `from` and negative at `to` whenever the root lies between them).
    fn merged_offset(&self, m: &PoleMerge, z: f64, rho2: f64) -> f64 {
        let along = |s: f64| (rho2 - s * s).max(0.0).sqrt();
        let g = |e: f64| z.abs().atan2(along(self.offset * m.fade(e))) - e;
        // g(from) ≤ 0 and g(to) ≥ 0 without trigonometry (tan is increasing on [0, π/2)): most
        // points are seen below the fade, or above it.
        let z2 = z * z;
        let full2 = rho2 - self.offset * self.offset;
        if full2 > 0.0 && z2 <= m.tan2[0] * full2 {
            return self.offset; // seen below the fade: the full offset
        }
        if z2 >= m.tan2[1] * rho2 {
            return 0.0; // seen above it: the eyes have met
        }
        let (mut a, mut b) = (m.from, m.to);
        let mut ga = g(a);
        if ga <= 0.0 {
            return self.offset;
        }
        // The root is a fixed point of `e ↦ g(e) + e`, a map that moves little with `e` unless the
        // point is near the axis: secant steps from its value at `from` converge in two or three
        // evaluations. Where they stall or leave the bracket, the bracketed solve below decides.
        let (mut x0, mut g0, mut x1) = (a, ga, a + ga);
        for _ in 0..4 {
            let g1 = g(x1);
            if g1.abs() <= 1e-14 {
                return self.offset * m.fade(x1);
            }
            let x2 = x1 - g1 * (x1 - x0) / (g1 - g0);
            if !(x2 > a && x2 < b) {
                break;
            }
            (x0, g0, x1) = (x1, g1, x2);
        }
        let mut gb = g(b);
        if gb >= 0.0 {
            return 0.0;
        }
        // Illinois false position: bracketing like bisection, superlinear like the secant.
        let mut last = 0i8;
        for _ in 0..MERGE_STEPS {
            let c = (a * gb - b * ga) / (gb - ga);
            let gc = g(c);
            if gc == 0.0 || b - a < 1e-12 {
                return self.offset * m.fade(c);
            }
            if gc > 0.0 {
                (a, ga) = (c, gc);
                if last == 1 {
                    gb *= 0.5;
                }
                last = 1;
            } else {
                (b, gb) = (c, gc);
                if last == -1 {
                    ga *= 0.5;
                }
                last = -1;
            }
        }
        self.offset * m.fade(0.5 * (a + b))
    }

    /// Continuous output pixel coordinates of eye-centred point `p` (see [`OdsEye::ray_to_or_edge`]).
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        self.project_and_distance(p).map(|(q, _)| q)
    }

    /// [`OdsEye::project`] and [`OdsEye::distance`] in one solve.
    #[inline]
    pub fn project_and_distance(&self, p: DVec3) -> Option<(DVec2, f64)> {
        let q = self.edge(p)?;
        let (phi, t_h) = self.solve(q)?;
        Some((self.pixel(phi, t_h.atan2(q.z)), t_h.hypot(q.z)))
    }

    /// This eye's mirror: the other eye of the same ODS camera (the opposite offset).
    pub fn mirror(&self) -> OdsEye {
        OdsEye { offset: -self.offset, ..*self }
    }

    /// [`OdsEye::project_and_distance`] of this eye and of its [`OdsEye::mirror`] in one solve: the
    /// two rays that see a point share their elevation and run, and turn by opposite angles
    /// (the same results as two calls, bit for bit).
    #[inline]
    pub fn project_pair(&self, p: DVec3) -> Option<([DVec2; 2], f64)> {
        let q = self.edge(p)?;
        let (alpha, turn, t_h) = self.solve_parts(q)?;
        let polar = t_h.atan2(q.z);
        Some(([self.pixel(alpha - turn, polar), self.pixel(alpha + turn, polar)], t_h.hypot(q.z)))
    }

    /// Continuous pixel coordinates of the ray of azimuth `phi` and polar angle `polar`.
    #[inline]
    fn pixel(&self, phi: f64, polar: f64) -> DVec2 {
        let (w, h) = (self.width as f64, self.height as f64);
        let x = (phi.rem_euclid(TAU) / TAU * w).min(w - 1e-9);
        DVec2::new(x.max(0.0), polar / PI * h)
    }

    /// Distance from the start of the ray that sees `p` to `p` (its length when no ray does).
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        match self.edge(p).and_then(|q| self.solve(q).map(|(_, t_h)| t_h.hypot(q.z))) {
            Some(t) => t,
            None => p.length(),
        }
    }

    /// For the rays of output row coordinate `y`: `k` such that the ray of unit direction `d`
    /// starts at `k · (−d_y, d_x, 0)` (the offset over the row's `sin θ`; 0 at the poles).
    pub fn row_origin_scale(&self, y: f64) -> f64 {
        let theta = PI * y / self.height as f64;
        let st = theta.sin();
        if st > 0.0 {
            self.offset_at(FRAC_PI_2 - theta) / st
        } else {
            0.0
        }
    }

    /// Where the ray through continuous output pixel `(x, y)` starts, relative to the eye centre.
    pub fn origin(&self, x: f64, y: f64) -> DVec3 {
        let phi = TAU * x / self.width as f64;
        let e = FRAC_PI_2 - PI * y / self.height as f64;
        let (sp, cp) = phi.sin_cos();
        DVec3::new(-sp, cp, 0.0) * self.offset_at(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eye(offset: f64, merge: bool) -> OdsEye {
        let pole_merge = merge.then(PoleMerge::default);
        OdsEye { eye: DVec3::ZERO, width: 4096, height: 2048, offset, pole_merge }
    }

    /// The ray through the pixel a point projects to, started at the pixel's origin, passes
    /// through the point at the distance `ray_to` gives (an independent inverse).
    #[test]
    fn the_pixel_ray_passes_through_the_point() {
        for merge in [false, true] {
            for offset in [0.032, -0.032] {
                let c = eye(offset, merge);
                for p in [
                    DVec3::new(2.0, 0.5, 0.3),
                    DVec3::new(-0.4, -0.9, 1.7),
                    DVec3::new(0.3, 0.2, -1.5),
                    DVec3::new(0.05, -0.06, 0.02),
                    DVec3::new(1.0, 1.0, 3.2),
                    DVec3::new(-3.0, 0.001, -0.2),
                ] {
                    let (d, t) = c.ray_to(p).unwrap();
                    let q = c.project(p).unwrap();
                    let o = c.origin(q.x, q.y);
                    let hit = o + d * t;
                    assert!((hit - p).length() < 1e-9, "{merge} {offset} {p}: {hit}");
                    // The pixel's direction is the ray's.
                    let (phi, theta) = (TAU * q.x / 4096.0, PI * q.y / 2048.0);
                    let dir = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                    assert!((dir - d).length() < 1e-9, "{p}: {dir} vs {d}");
                    assert!((c.distance(p) - t).abs() < 1e-12);
                }
            }
        }
    }

    /// The ODS disparity: a point at horizontal distance ρ is seen 2·asin(r/ρ) apart by the eyes, the
    /// left eye turning right (towards smaller azimuth: a smaller column).
    #[test]
    fn disparity_is_the_ods_formula() {
        let (l, r) = (eye(0.032, false), eye(-0.032, false));
        for rho in [0.1, 0.5, 2.0, 10.0] {
            let p = DVec3::new(rho * 0.6, rho * 0.8, 0.0);
            let (ql, qr) = (l.project(p).unwrap(), r.project(p).unwrap());
            let expect = 2.0 * (0.032f64 / rho).asin() / TAU * 4096.0;
            assert!((qr.x - ql.x - expect).abs() < 1e-9, "{rho}: {} vs {expect}", qr.x - ql.x);
            assert!((ql.y - 1024.0).abs() < 1e-9);
        }
    }

    /// One solve for both eyes gives each eye's own projection, bit for bit.
    #[test]
    fn the_pair_projects_as_each_eye() {
        for merge in [false, true] {
            let l = eye(0.032, merge);
            let r = l.mirror();
            assert_eq!(r, eye(-0.032, merge));
            for k in 0..2000 {
                let t = k as f64 * 0.618;
                let p = DVec3::new(t.cos() * (0.01 + k as f64 * 1e-3), t.sin(), (t * 1.7).sin() * 3.0);
                let pair = l.project_pair(p);
                let each = l.project_and_distance(p).zip(r.project_and_distance(p));
                assert_eq!(pair.map(|(q, t)| (q[0], q[1], t)), each.map(|(a, b)| (a.0, b.0, a.1)), "{p}");
                // The right eye's own distance is the pair's one distance too.
                assert_eq!(pair.map(|(_, t)| t), each.map(|(_, b)| b.1), "{p}");
            }
        }
    }

    #[test]
    fn inside_the_viewing_circle_nothing_is_seen() {
        let c = eye(0.032, false);
        assert!(c.project(DVec3::new(0.02, 0.01, 0.03)).is_none());
        assert!(c.ray_to(DVec3::new(0.02, 0.01, 0.5)).is_none());
        // High above the eye, inside the cylinder: drawn where the grazing rays look, at the pole.
        let q = c.project(DVec3::new(0.02, 0.01, 0.5)).unwrap();
        assert!(q.y < 2048.0 * (4.0 / 180.0), "{q}");
        assert!(c.project(DVec3::ZERO).is_none());
        assert!(c.project(DVec3::new(f64::NAN, 0.0, 1.0)).is_none());
        // With the pole merge, high above the head the eyes have met: it is seen.
        let m = eye(0.032, true);
        let q = m.project(DVec3::new(0.02, 0.01, 0.5)).unwrap();
        assert!(q.y < 2048.0 * (15.0 / 180.0), "{q}");
    }

    #[test]
    fn pole_merge_fades_as_blender() {
        let m = PoleMerge::default();
        assert_eq!(m.fade(0.5), 1.0);
        assert_eq!(m.fade(-1.4), 0.0);
        let mid = 67.5f64.to_radians();
        assert!((m.fade(mid) - (PI / 4.0).cos()).abs() < 1e-12);
        // Far points above 75° have no disparity at all.
        let (l, r) = (eye(0.032, true), eye(-0.032, true));
        let p = DVec3::new(0.2, 0.1, 2.0);
        assert!((l.project(p).unwrap() - r.project(p).unwrap()).length() < 1e-9);
    }
}
