//! Cuboid estimation from an object's merged points.
//!
//! - Yaw: the minimum-area bounding rectangle of the footprint (xy) — exact rotating calipers over
//!   the edges of the footprint's convex hull (the minimum-area rectangle has a side collinear
//!   with a hull edge). Boxes have a 90° symmetry, so the returned yaw is in `[-π/4, π/4)` unless a
//!   previous yaw is given, in which case the equivalent closest to it is chosen (and x/y sizes
//!   swapped accordingly); if the previous yaw's rectangle is within `keep_tolerance` of the
//!   optimum (near-isotropic footprints such as cylinders), the previous yaw is kept, so the
//!   SOPM's angular reference does not wander.
//! - Extents: robust percentiles (`q`, `1 − q`) of the points along the cuboid axes, so a few
//!   outliers do not inflate the box.
//! - Background objects: the supporting plane is the most populated 1 cm height bin among the
//!   upper points; the footprint comes from the points on that plane, and the cuboid extends from
//!   the plane down to the floor (z = 0).

use geom::{Cuboid, convex_hull};
use glam::{Mat3, Vec2, Vec3};

/// An estimated upright cuboid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Box3 {
    /// Centre.
    pub center: Vec3,
    /// Size along the cuboid axes.
    pub size: Vec3,
    /// Yaw about +z.
    pub yaw: f32,
}

/// Reusable buffers.
#[derive(Debug, Clone, Default)]
pub struct CuboidScratch {
    xy: Vec<Vec2>,
    hull: Vec<Vec2>,
    vals: Vec<f32>,
    plane: Vec<Vec3>,
}

/// Area of the bounding rectangle of `hull` aligned with angle `yaw`.
fn rect_area(hull: &[Vec2], yaw: f32) -> f32 {
    let (s, c) = yaw.sin_cos();
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for p in hull {
        let q = Vec2::new(c * p.x + s * p.y, -s * p.x + c * p.y);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let d = hi - lo;
    d.x * d.y
}

/// Yaw in `[-π/4, π/4)` of the minimum-area rectangle around a convex hull (rotating calipers).
pub fn min_area_yaw(hull: &[Vec2]) -> (f32, f32) {
    if hull.len() < 2 {
        return (0.0, 0.0);
    }
    let mut best = (0.0f32, f32::INFINITY);
    for i in 0..hull.len() {
        let e = hull[(i + 1) % hull.len()] - hull[i];
        if e.length_squared() < 1e-12 {
            continue;
        }
        let yaw = reduce_quarter(e.y.atan2(e.x));
        let a = rect_area(hull, yaw);
        if a < best.1 {
            best = (yaw, a);
        }
    }
    best
}

/// An angle reduced to `[-π/4, π/4)` (the 90° symmetry of a rectangle).
pub fn reduce_quarter(a: f32) -> f32 {
    use std::f32::consts::FRAC_PI_2;
    let r = (a + FRAC_PI_2 / 2.0).rem_euclid(FRAC_PI_2) - FRAC_PI_2 / 2.0;
    if r >= FRAC_PI_2 / 2.0 {
        r - FRAC_PI_2
    } else {
        r
    }
}

/// The yaw among `yaw + k·90°` closest to `reference`.
pub fn closest_equivalent(yaw: f32, reference: f32) -> f32 {
    use std::f32::consts::FRAC_PI_2;
    let k = ((reference - yaw) / FRAC_PI_2).round();
    yaw + k * FRAC_PI_2
}

/// Value at quantile `q` of `v` (partially reorders `v`); `v` must be non-empty.
fn quantile(v: &mut [f32], q: f32) -> f32 {
    let i = ((v.len() - 1) as f32 * q).round() as usize;
    *v.select_nth_unstable_by(i, |a, b| a.total_cmp(b)).1
}

impl CuboidScratch {
    /// Yaw of a footprint: minimum-area rectangle, stabilised against `previous` (see module).
    fn footprint_yaw(&mut self, pts: &[Vec3], previous: Option<f32>, keep_tolerance: f32) -> f32 {
        self.xy.clear();
        self.xy.extend(pts.iter().map(|p| p.truncate()));
        convex_hull(&mut self.xy, &mut self.hull);
        let (yaw, area) = min_area_yaw(&self.hull);
        match previous {
            None => yaw,
            Some(prev) => {
                let prev_area = rect_area(&self.hull, prev);
                if prev_area <= area * (1.0 + keep_tolerance) {
                    prev
                } else {
                    closest_equivalent(yaw, prev)
                }
            }
        }
    }

    /// Robust extents of `pts` along the axes of `yaw`: (centre, size).
    fn extents(&mut self, pts: &[Vec3], yaw: f32, q: f32) -> (Vec3, Vec3) {
        let (s, c) = yaw.sin_cos();
        let mut lo = [0.0f32; 3];
        let mut hi = [0.0f32; 3];
        for axis in 0..3 {
            self.vals.clear();
            self.vals.extend(pts.iter().map(|p| match axis {
                0 => c * p.x + s * p.y,
                1 => -s * p.x + c * p.y,
                _ => p.z,
            }));
            lo[axis] = quantile(&mut self.vals, q);
            hi[axis] = quantile(&mut self.vals, 1.0 - q);
        }
        let mid_local = Vec3::new(
            (lo[0] + hi[0]) / 2.0,
            (lo[1] + hi[1]) / 2.0,
            (lo[2] + hi[2]) / 2.0,
        );
        let center = Vec3::new(
            c * mid_local.x - s * mid_local.y,
            s * mid_local.x + c * mid_local.y,
            mid_local.z,
        );
        let size = Vec3::new(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
        (center, size)
    }

    /// Cuboid of a foreground object's points (at least 3 points).
    pub fn fit_foreground(
        &mut self,
        pts: &[Vec3],
        previous_yaw: Option<f32>,
        q: f32,
        keep_tolerance: f32,
    ) -> Option<Box3> {
        if pts.len() < 3 {
            return None;
        }
        let yaw = self.footprint_yaw(pts, previous_yaw, keep_tolerance);
        let (center, size) = self.extents(pts, yaw, q);
        Some(Box3 { center, size, yaw })
    }

    /// Supporting plane height of a background object: the most populated 1 cm height bin among
    /// points above `min_height`, refined to the mean height of the points within ±1 cm of it.
    pub fn support_height(&mut self, pts: &[Vec3], min_height: f32) -> Option<f32> {
        const BIN: f32 = 0.01;
        let top = pts.iter().map(|p| p.z).fold(f32::NEG_INFINITY, f32::max);
        if !top.is_finite() || top < min_height {
            return None;
        }
        let nbins = ((top - min_height) / BIN) as usize + 1;
        let mut hist = vec![0u32; nbins];
        for p in pts.iter().filter(|p| p.z >= min_height) {
            hist[(((p.z - min_height) / BIN) as usize).min(nbins - 1)] += 1;
        }
        let (mode, _) = hist.iter().enumerate().max_by_key(|(i, n)| (**n, *i))?;
        let z0 = min_height + (mode as f32 + 0.5) * BIN;
        let (sum, n) = pts
            .iter()
            .filter(|p| (p.z - z0).abs() <= BIN * 1.5)
            .fold((0.0f32, 0u32), |(s, n), p| (s + p.z, n + 1));
        (n > 0).then(|| sum / n as f32)
    }

    /// Cuboid of a background object: footprint from the points within `plane_tol` of the
    /// supporting plane at `height`, extent from the plane down to the floor.
    pub fn fit_background(
        &mut self,
        pts: &[Vec3],
        height: f32,
        plane_tol: f32,
        previous_yaw: Option<f32>,
        q: f32,
        keep_tolerance: f32,
    ) -> Option<Box3> {
        let mut top3 = std::mem::take(&mut self.plane);
        top3.clear();
        top3.extend(
            pts.iter()
                .copied()
                .filter(|p| (p.z - height).abs() <= plane_tol),
        );
        if top3.len() < 3 {
            self.plane = top3;
            return None;
        }
        let yaw = self.footprint_yaw(&top3, previous_yaw, keep_tolerance);
        let (c, s) = self.extents(&top3, yaw, q);
        self.plane = top3;
        Some(Box3 {
            center: Vec3::new(c.x, c.y, height / 2.0),
            size: Vec3::new(s.x, s.y, height),
            yaw,
        })
    }
}

impl Box3 {
    /// The smallest box of this one's yaw that holds this one and `other`'s corners (only
    /// their footprints with `footprint_only`: z stays this box's).
    pub fn grown_to_hold(&self, other: &Box3, footprint_only: bool) -> Box3 {
        let to_local = Mat3::from_rotation_z(-self.yaw);
        let h = self.size.max(Vec3::ZERO) * 0.5;
        let (mut lo, mut hi) = (-h, h);
        let corners = Cuboid {
            center: other.center,
            size: other.size.max(Vec3::ZERO),
            yaw: other.yaw,
        }
        .corners();
        for p in corners {
            let q = to_local * (p - self.center);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        if footprint_only {
            (lo.z, hi.z) = (-h.z, h.z);
        }
        Box3 {
            center: self.center + Mat3::from_rotation_z(self.yaw) * ((lo + hi) * 0.5),
            size: hi - lo,
            yaw: self.yaw,
        }
    }

    /// Volume, m³.
    pub fn volume(&self) -> f32 {
        self.size.x.max(0.0) * self.size.y.max(0.0) * self.size.z.max(0.0)
    }

    /// The footprint's corners (counter-clockwise), world xy.
    pub fn footprint(&self) -> [Vec2; 4] {
        let (s, c) = self.yaw.sin_cos();
        let (hx, hy) = (self.size.x.max(0.0) * 0.5, self.size.y.max(0.0) * 0.5);
        let o = self.center.truncate();
        [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
            .map(|(x, y)| o + Vec2::new(c * x - s * y, s * x + c * y))
    }

    /// Area of the intersection of the two footprints (convex polygon clipping), m².
    pub fn footprint_intersection(&self, other: &Box3) -> f32 {
        let mut poly: Vec<Vec2> = self.footprint().to_vec();
        let clip = other.footprint();
        let mut next = Vec::with_capacity(8);
        for k in 0..4 {
            let (a, b) = (clip[k], clip[(k + 1) % 4]);
            let e = b - a;
            // Inside = left of the counter-clockwise edge.
            let side = |p: Vec2| e.perp_dot(p - a);
            next.clear();
            for i in 0..poly.len() {
                let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                let (sp, sq) = (side(p), side(q));
                if sp >= 0.0 {
                    next.push(p);
                }
                if (sp >= 0.0) != (sq >= 0.0) {
                    next.push(p + (q - p) * (sp / (sp - sq)));
                }
            }
            std::mem::swap(&mut poly, &mut next);
            if poly.len() < 3 {
                return 0.0;
            }
        }
        let mut area = 0.0;
        for i in 0..poly.len() {
            area += poly[i].perp_dot(poly[(i + 1) % poly.len()]);
        }
        (area * 0.5).max(0.0)
    }

    /// Volume of the intersection of two upright cuboids, m³.
    pub fn intersection_volume(&self, other: &Box3) -> f32 {
        let top = (self.center.z + self.size.z * 0.5).min(other.center.z + other.size.z * 0.5);
        let bottom = (self.center.z - self.size.z * 0.5).max(other.center.z - other.size.z * 0.5);
        if top <= bottom {
            return 0.0;
        }
        self.footprint_intersection(other) * (top - bottom)
    }

    /// 3D intersection over union.
    pub fn iou(&self, other: &Box3) -> f32 {
        let i = self.intersection_volume(other);
        let u = self.volume() + other.volume() - i;
        if u > 0.0 { i / u } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bx(c: [f32; 3], s: [f32; 3], yaw: f32) -> Box3 {
        Box3 {
            center: Vec3::from(c),
            size: Vec3::from(s),
            yaw,
        }
    }

    #[test]
    fn a_box_grown_to_hold_another_keeps_its_yaw_and_covers_both() {
        let a = bx([0.0, 0.0, 0.5], [1.0, 1.0, 1.0], 0.0);
        // A 0.5 m cube at x = 1 turned 90°: its corners reach x 1.25, y ±0.25, z 0.25..0.75.
        let b = bx(
            [1.0, 0.0, 0.5],
            [0.5, 0.5, 0.5],
            std::f32::consts::FRAC_PI_2,
        );
        let g = a.grown_to_hold(&b, false);
        assert!(
            (g.center - Vec3::new(0.375, 0.0, 0.5)).length() < 1e-5,
            "{g:?}"
        );
        assert!(
            (g.size - Vec3::new(1.75, 1.0, 1.0)).length() < 1e-5,
            "{g:?}"
        );
        assert_eq!(g.yaw, 0.0);
        // A higher box: only the footprint grows with `footprint_only`.
        let high = bx([0.0, 0.0, 2.0], [2.0, 0.5, 0.2], 0.0);
        let f = a.grown_to_hold(&high, true);
        assert!(
            (f.center - Vec3::new(0.0, 0.0, 0.5)).length() < 1e-5,
            "{f:?}"
        );
        assert!((f.size - Vec3::new(2.0, 1.0, 1.0)).length() < 1e-5, "{f:?}");
        // A box inside changes nothing.
        let inner = bx([0.1, 0.1, 0.5], [0.2, 0.2, 0.2], 0.3);
        let same = a.grown_to_hold(&inner, false);
        assert!((same.center - a.center).length() < 1e-6 && (same.size - a.size).length() < 1e-6);
    }

    #[test]
    fn box_intersections_by_hand() {
        let a = bx([0.0, 0.0, 0.5], [2.0, 2.0, 1.0], 0.0);
        // Shifted by 1 m in x and 0.5 m in z: overlap 1 × 2 × 0.5 = 1, union 4 + 4 − 1 = 7.
        let b = bx([1.0, 0.0, 1.0], [2.0, 2.0, 1.0], 0.0);
        assert!((a.intersection_volume(&b) - 1.0).abs() < 1e-5);
        assert!((a.iou(&b) - 1.0 / 7.0).abs() < 1e-5);
        // A square turned by 45° about the same centre: intersection is the regular octagon of
        // inradius 1, area 8(√2 − 1).
        let c = bx(
            [0.0, 0.0, 0.5],
            [2.0, 2.0, 1.0],
            std::f32::consts::FRAC_PI_4,
        );
        let octagon = 8.0 * (2f32.sqrt() - 1.0);
        assert!((a.footprint_intersection(&c) - octagon).abs() < 1e-4);
        // Disjoint boxes, and a quarter turn (same box).
        let d = bx([3.0, 0.0, 0.5], [2.0, 2.0, 1.0], 0.3);
        assert_eq!(a.intersection_volume(&d), 0.0);
        let e = bx(
            [0.0, 0.0, 0.5],
            [2.0, 2.0, 1.0],
            std::f32::consts::FRAC_PI_2,
        );
        assert!((a.iou(&e) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn min_area_rectangle_of_rotated_rectangle() {
        let yaw = 0.5f32;
        let (s, c) = yaw.sin_cos();
        let mut pts: Vec<Vec2> = [(-2.0, -1.0), (2.0, -1.0), (2.0, 1.0), (-2.0, 1.0)]
            .iter()
            .map(|&(x, y)| Vec2::new(c * x - s * y, s * x + c * y))
            .collect();
        let mut hull = Vec::new();
        convex_hull(&mut pts, &mut hull);
        let (got, area) = min_area_yaw(&hull);
        assert!((got - reduce_quarter(yaw)).abs() < 1e-5, "{got}");
        assert!((area - 8.0).abs() < 1e-4);
    }

    #[test]
    fn quarter_reduction_and_equivalents() {
        use std::f32::consts::FRAC_PI_2;
        assert!((reduce_quarter(0.5 + FRAC_PI_2) - 0.5).abs() < 1e-6);
        assert!((reduce_quarter(-0.9) - (-0.9 + FRAC_PI_2)).abs() < 1e-6);
        assert!((closest_equivalent(0.1, 1.6) - (0.1 + FRAC_PI_2)).abs() < 1e-6);
    }
}
