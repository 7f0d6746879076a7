//! Unoccluded image silhouettes of scene objects (for the visible fraction): the detector's
//! area estimate ([`Silhouettes::area`]) and the pixel count of the non-occlusion metric
//! ([`Silhouettes::pixels`]).

use super::super::scene::{Scene, Shape};
use geom::{Camera, convex_hull_into};
use glam::{Affine3A, Mat3, Vec2, Vec3};

/// Points per silhouette (32 rim points for a cylinder, 8 corners for a box).
const SIL_POINTS: usize = 32;
/// Capacity of the clipped hull polygon.
pub(crate) const POLY_CAP: usize = SIL_POINTS + 8;

/// Divisor of a cylinder's radius giving the radius of its rim 16-gon: the circumscribed
/// 16-gon (`cos(π/16)`; the hull never under-covers the disc), for the detector's area estimate.
pub(crate) fn rim_circumscribed() -> f32 {
    (std::f32::consts::PI / 16.0).cos()
}

/// Divisor of a cylinder's radius giving a rim 16-gon with the disc's area
/// (`R² = 2πr² / (16 sin(π/8))`, R = 1.0130016 r): its pixel count matches the rendered
/// disc's up to rasterization, for the non-occlusion metric.
pub(crate) const RIM_EQUAL_AREA: f32 = 1.0 / 1.013_001_6;

/// The 3D outline points of every scene object.
#[derive(Debug, Clone)]
pub(crate) struct Silhouettes(Vec<([Vec3; SIL_POINTS], usize)>);

impl Silhouettes {
    /// Outline points of `scene`'s objects; a cylinder's rims are 16-gons of radius
    /// its radius / `rim_divisor`.
    pub(crate) fn new(scene: &Scene, rim_divisor: f32) -> Self {
        Self(
            scene
                .objects
                .iter()
                .map(|o| {
                    let mut pts = [Vec3::ZERO; SIL_POINTS];
                    let n = match o.shape {
                        Shape::Box => {
                            for (p, c) in pts.iter_mut().zip(o.cuboid().corners()) {
                                *p = c;
                            }
                            8
                        }
                        Shape::Cylinder => {
                            let r = o.size.x * 0.5;
                            let h = o.size.z * 0.5;
                            let rot = Mat3::from_rotation_z(o.yaw);
                            let rr = r / rim_divisor;
                            for (i, p) in pts.iter_mut().enumerate() {
                                let a = (i / 2) as f32 * std::f32::consts::TAU / 16.0;
                                let z = if i % 2 == 0 { h } else { -h };
                                *p = o.center + rot * Vec3::new(a.cos() * rr, a.sin() * rr, z);
                            }
                            SIL_POINTS
                        }
                    };
                    (pts, n)
                })
                .collect(),
        )
    }

    /// Image area (pixels²) of object `k`'s unoccluded silhouette clipped to the image, `None`
    /// when part of it is behind or at the camera (then it is not estimated).
    pub(super) fn area(&self, k: usize, camera: &Camera, cam_from_world: &Affine3A) -> Option<f32> {
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = self.hull(k, camera, cam_from_world, &mut hull)?;
        Some(clipped_area(
            &hull[..m],
            Vec2::new(camera.width as f32, camera.height as f32),
        ))
    }

    /// Pixels of the image whose centre lies inside object `k`'s unoccluded silhouette (the
    /// pixels an unoccluded render would give it: exact for a box, whose silhouette is the hull
    /// of its corners), and whether the silhouette reaches past the image border; `None` when
    /// part of it is behind or at the camera. Work: one scanline per image row it covers.
    pub(crate) fn pixels(
        &self,
        k: usize,
        camera: &Camera,
        cam_from_world: &Affine3A,
    ) -> Option<(u32, bool, [f32; 4])> {
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = self.hull(k, camera, cam_from_world, &mut hull)?;
        let poly = &hull[..m];
        let (w, h) = (camera.width as f32, camera.height as f32);
        let (lo, hi) = poly.iter().fold(
            (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let truncated = lo.x < 0.0 || lo.y < 0.0 || hi.x > w || hi.y > h;
        let bbox = [lo.x.max(0.0), lo.y.max(0.0), hi.x.min(w), hi.y.min(h)];
        // Rows whose centre y + ½ lies in [lo.y, hi.y], within the image.
        let v0 = (lo.y - 0.5).ceil().max(0.0) as u32;
        let v1 = (hi.y - 0.5).floor().min(h - 1.0);
        if m < 3 || v1 < 0.0 {
            return Some((0, truncated, bbox));
        }
        let mut count = 0u32;
        for v in v0..=v1 as u32 {
            let y = v as f32 + 0.5;
            // The convex polygon's span on this scanline.
            let (mut xl, mut xr) = (f32::INFINITY, f32::NEG_INFINITY);
            for i in 0..m {
                let (p, q) = (poly[i], poly[(i + 1) % m]);
                if (p.y <= y) != (q.y <= y) {
                    let x = p.x + (y - p.y) / (q.y - p.y) * (q.x - p.x);
                    xl = xl.min(x);
                    xr = xr.max(x);
                }
            }
            if xl > xr {
                continue;
            }
            // Columns whose centre u + ½ lies in [xl, xr], within the image.
            let u0 = (xl - 0.5).ceil().max(0.0);
            let u1 = (xr - 0.5).floor().min(w - 1.0);
            if u1 >= u0 {
                count += (u1 - u0) as u32 + 1;
            }
        }
        Some((count, truncated, bbox))
    }

    /// Object `k`'s projected outline hull into `hull` (its vertex count), `None` when a point is
    /// behind or at the camera.
    fn hull(
        &self,
        k: usize,
        camera: &Camera,
        cam_from_world: &Affine3A,
        hull: &mut [Vec2; POLY_CAP],
    ) -> Option<usize> {
        let (pts, n) = self.0.get(k)?;
        let mut img = [Vec2::ZERO; SIL_POINTS];
        for (q, p) in img.iter_mut().zip(&pts[..*n]) {
            let pc = cam_from_world.transform_point3(*p);
            if pc.z < 0.05 {
                return None;
            }
            *q = camera.project(pc)?;
        }
        Some(convex_hull_into(&mut img[..*n], hull))
    }
}

/// Area of a convex polygon clipped to the rectangle `[0, size]`.
fn clipped_area(poly: &[Vec2], size: Vec2) -> f32 {
    let mut a = [Vec2::ZERO; POLY_CAP];
    let mut b = [Vec2::ZERO; POLY_CAP];
    a[..poly.len()].copy_from_slice(poly);
    let mut n = poly.len();
    // Half-planes: (axis, bound, keep ≥ bound?)
    for (axis, bound, keep_above) in [
        (0, 0.0, true),
        (0, size.x, false),
        (1, 0.0, true),
        (1, size.y, false),
    ] {
        let inside = |p: Vec2| {
            let v = if axis == 0 { p.x } else { p.y };
            if keep_above { v >= bound } else { v <= bound }
        };
        let mut m = 0;
        for i in 0..n {
            let (p, q) = (a[i], a[(i + 1) % n]);
            let (ip, iq) = (inside(p), inside(q));
            if ip {
                b[m] = p;
                m += 1;
            }
            if ip != iq && m < POLY_CAP {
                let (pv, qv) = if axis == 0 { (p.x, q.x) } else { (p.y, q.y) };
                let t = (bound - pv) / (qv - pv);
                b[m] = p + (q - p) * t;
                m += 1;
            }
        }
        std::mem::swap(&mut a, &mut b);
        n = m.min(POLY_CAP);
    }
    let mut area = 0.0;
    for i in 0..n {
        area += a[i].perp_dot(a[(i + 1) % n]);
    }
    area.abs() * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_gives_exact_areas() {
        let mut pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(4.0, 2.0),
            Vec2::new(0.0, 2.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(1.0, 1.5),
        ];
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = convex_hull_into(&mut pts, &mut hull);
        assert_eq!(m, 4);
        assert!((clipped_area(&hull[..m], Vec2::new(10.0, 10.0)) - 8.0).abs() < 1e-5);
        assert!((clipped_area(&hull[..m], Vec2::new(3.0, 1.0)) - 3.0).abs() < 1e-5);
        let tri = [
            Vec2::new(-1.0, 0.0),
            Vec2::new(3.0, 0.0),
            Vec2::new(-1.0, 4.0),
        ];
        // Clipped to x ≥ 0: a right triangle with legs 3 → 4.5.
        assert!((clipped_area(&tri, Vec2::new(10.0, 10.0)) - 4.5).abs() < 1e-5);
    }
}
