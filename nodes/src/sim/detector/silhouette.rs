//! Unoccluded image silhouettes of scene objects (for the visible fraction).

use super::super::scene::{Scene, Shape};
use crate::geom::{Camera, convex_hull_into};
use glam::{Affine3A, Mat3, Vec2, Vec3};

/// Points per silhouette (32 rim points for a cylinder, 8 corners for a box).
const SIL_POINTS: usize = 32;
/// Capacity of the clipped hull polygon.
pub(in crate::sim) const POLY_CAP: usize = SIL_POINTS + 8;

/// The 3D outline points of every scene object.
#[derive(Debug, Clone)]
pub(super) struct Silhouettes(Vec<([Vec3; SIL_POINTS], usize)>);

impl Silhouettes {
    /// Outline points of `scene`'s objects.
    pub(super) fn new(scene: &Scene) -> Self {
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
                            for (i, p) in pts.iter_mut().enumerate() {
                                let a = (i / 2) as f32 * std::f32::consts::TAU / 16.0;
                                // Circumscribed 16-gon so the hull does not under-cover the disc.
                                let rr = r / (std::f32::consts::PI / 16.0).cos();
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
        let (pts, n) = self.0.get(k)?;
        let mut img = [Vec2::ZERO; SIL_POINTS];
        for (q, p) in img.iter_mut().zip(&pts[..*n]) {
            let pc = cam_from_world.transform_point3(*p);
            if pc.z < 0.05 {
                return None;
            }
            *q = camera.project(pc)?;
        }
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = convex_hull_into(&mut img[..*n], &mut hull);
        Some(clipped_area(
            &hull[..m],
            Vec2::new(camera.width as f32, camera.height as f32),
        ))
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
