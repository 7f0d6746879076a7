//! The solid world for ray casting: the scene's objects plus floor, ceiling and four walls, in a
//! parry3d bounding-volume hierarchy.

use super::scene::{Scene, SolidShape};
use glam::Vec3;
use parry3d::bounding_volume::Aabb;
use parry3d::math::Pose;
use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::Cuboid as PCuboid;
use std::cell::Cell;

/// Instance id of walls, floor and ceiling (not objects).
pub const STRUCTURE: u8 = 0;
/// Thickness of the walls, floor and ceiling slabs, metres.
pub const WALL_THICKNESS: f32 = 0.1;

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (equals depth for camera rays with z = 1).
    pub t: f32,
    /// Unit outward surface normal, world frame.
    pub normal: Vec3,
    /// `k + 1` for scene object `k`, [`STRUCTURE`] for walls, floor and ceiling.
    pub instance: u8,
}

#[derive(Debug, Clone)]
struct Prim {
    pose: Pose,
    shape: SolidShape,
    instance: u8,
}

/// The scene as solids in a BVH, ready for ray casting from any number of threads.
#[derive(Debug, Clone)]
pub struct World {
    prims: Vec<Prim>,
    bvh: Bvh,
}

impl World {
    /// Build the world of a scene: every object (instance `k + 1`) and the room's floor, ceiling
    /// and walls ([`STRUCTURE`]).
    pub fn new(scene: &Scene) -> World {
        let mut prims: Vec<Prim> = scene
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| Prim {
                pose: o.pose(),
                shape: o.shape_shrunk(0.0),
                instance: (k + 1) as u8,
            })
            .collect();
        let r = scene.room;
        let t = WALL_THICKNESS;
        let c = (r.min + r.max) * 0.5;
        let h = (r.max - r.min) * 0.5;
        let mut slab = |center: Vec3, half: Vec3| {
            prims.push(Prim {
                pose: Pose::from_translation(center),
                shape: SolidShape::Cuboid(PCuboid::new(half)),
                instance: STRUCTURE,
            })
        };
        let half_z = r.height * 0.5 + t;
        slab(
            Vec3::new(c.x, c.y, -t * 0.5),
            Vec3::new(h.x + t, h.y + t, t * 0.5),
        );
        slab(
            Vec3::new(c.x, c.y, r.height + t * 0.5),
            Vec3::new(h.x + t, h.y + t, t * 0.5),
        );
        slab(
            Vec3::new(r.min.x - t * 0.5, c.y, r.height * 0.5),
            Vec3::new(t * 0.5, h.y + t, half_z),
        );
        slab(
            Vec3::new(r.max.x + t * 0.5, c.y, r.height * 0.5),
            Vec3::new(t * 0.5, h.y + t, half_z),
        );
        slab(
            Vec3::new(c.x, r.min.y - t * 0.5, r.height * 0.5),
            Vec3::new(h.x + t, t * 0.5, half_z),
        );
        slab(
            Vec3::new(c.x, r.max.y + t * 0.5, r.height * 0.5),
            Vec3::new(h.x + t, t * 0.5, half_z),
        );
        let aabbs: Vec<Aabb> = prims
            .iter()
            .map(|p| match &p.shape {
                SolidShape::Cuboid(s) => s.aabb(&p.pose),
                SolidShape::Cylinder(s) => s.aabb(&p.pose),
            })
            .collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
        World { prims, bvh }
    }

    /// Number of solids (objects + 6 room slabs).
    pub fn solid_count(&self) -> usize {
        self.prims.len()
    }

    /// Nearest hit of the ray `origin + t·dir`, `0 < t ≤ max_t` (`dir` need not be unit).
    /// Allocation-free; safe to call from many threads.
    pub fn cast(&self, origin: Vec3, dir: Vec3, max_t: f32) -> Option<Hit> {
        let ray = Ray::new(origin, dir);
        let normal = Cell::new(Vec3::Z);
        let (leaf, t) = self.bvh.cast_ray(&ray, max_t, |i, best| {
            let p = &self.prims[i as usize];
            let local = ray.inverse_transform_by(&p.pose);
            let hit = match &p.shape {
                SolidShape::Cuboid(s) => s.cast_local_ray_and_get_normal(&local, best, true),
                SolidShape::Cylinder(s) => cast_cylinder(s, &local, best),
            }?;
            normal.set(p.pose.rotation * hit.normal);
            Some(hit.time_of_impact)
        })?;
        Some(Hit {
            t,
            normal: normal.get(),
            instance: self.prims[leaf as usize].instance,
        })
    }
}

/// Ray against an upright parry cylinder (axis = local y), in its local frame, analytically
/// (parry's generic support-map ray cast is exact too but several times slower).
fn cast_cylinder(
    c: &parry3d::shape::Cylinder,
    ray: &Ray,
    max_t: f32,
) -> Option<parry3d::query::RayIntersection> {
    use parry3d::query::RayIntersection;
    use parry3d::shape::FeatureId;
    let (o, d) = (ray.origin, ray.dir);
    let (r, hh) = (c.radius, c.half_height);
    let mut best: Option<(f32, Vec3)> = None;
    let mut consider = |t: f32, n: Vec3| {
        if t >= 0.0 && t <= max_t && best.is_none_or(|(b, _)| t < b) {
            best = Some((t, n));
        }
    };
    // Side: (ox + t dx)² + (oz + t dz)² = r².
    let a = d.x * d.x + d.z * d.z;
    if a > 1e-12 {
        let b = o.x * d.x + o.z * d.z;
        let cc = o.x * o.x + o.z * o.z - r * r;
        let disc = b * b - a * cc;
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let y = o.y + t * d.y;
            if y.abs() <= hh {
                let p = o + d * t;
                consider(t, Vec3::new(p.x, 0.0, p.z) / r);
            }
        }
    }
    // Caps: y = ±hh.
    if d.y.abs() > 1e-12 {
        for (cap, n) in [(hh, Vec3::Y), (-hh, Vec3::NEG_Y)] {
            let t = (cap - o.y) / d.y;
            let p = o + d * t;
            if p.x * p.x + p.z * p.z <= r * r && d.y * n.y < 0.0 {
                consider(t, n);
            }
        }
    }
    best.map(|(t, n)| RayIntersection::new(t, n, FeatureId::Unknown))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scene() -> Scene {
        Scene::parse(
            Path::new("t.toml"),
            "name = \"t\"\n[room]\nmin = [-3.0, -3.0]\nmax = [3.0, 3.0]\nheight = 2.5\n\
             [[object]]\nname = \"can\"\nclass = \"cup\"\ncenter = [2.0, 0.0, 0.5]\n\
             size = [0.2, 0.2, 1.0]\nshape = \"cylinder\"\n\
             [[object]]\nname = \"box\"\nclass = \"book\"\ncenter = [-2.0, 0.0, 0.5]\n\
             size = [0.4, 0.4, 1.0]\nyaw = 0.7853982\n",
        )
        .unwrap()
    }

    #[test]
    fn rays_hit_cylinder_box_and_walls_at_analytic_distances() {
        let w = World::new(&scene());
        assert_eq!(w.solid_count(), 8);
        let o = Vec3::new(0.0, 0.0, 0.5);
        let h = w.cast(o, Vec3::X, 100.0).unwrap();
        assert!((h.t - 1.9).abs() < 1e-4 && h.instance == 1, "{h:?}");
        assert!((h.normal - Vec3::NEG_X).length() < 1e-4);
        // The box is turned 45°: its corner points at the origin, 0.2·√2 from the centre.
        let h = w.cast(o, Vec3::NEG_X, 100.0).unwrap();
        assert!(
            (h.t - (2.0 - 0.2 * 2f32.sqrt())).abs() < 1e-4 && h.instance == 2,
            "{h:?}"
        );
        let h = w.cast(o, Vec3::Y, 100.0).unwrap();
        assert!((h.t - 3.0).abs() < 1e-4 && h.instance == STRUCTURE);
        let h = w.cast(o, Vec3::NEG_Z * 2.0, 100.0).unwrap();
        assert!((h.t - 0.25).abs() < 1e-4 && (h.normal - Vec3::Z).length() < 1e-4);
        // Onto the cylinder's top cap from above.
        let h = w
            .cast(Vec3::new(2.0, 0.05, 2.0), Vec3::NEG_Z, 100.0)
            .unwrap();
        assert!(
            (h.t - 1.0).abs() < 1e-4 && (h.normal - Vec3::Z).length() < 1e-4,
            "{h:?}"
        );
        assert!(w.cast(o, Vec3::X, 1.0).is_none(), "max_t limits the ray");
    }
}
