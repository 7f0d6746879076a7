//! The solid world for ray casting: the scene's objects and partition walls in a parry3d
//! bounding-volume hierarchy, inside the room's floor, ceiling and four walls.

use super::scene::{Scene, SolidShape};
use glam::Vec3;
use parry3d::bounding_volume::Aabb;
use parry3d::math::Pose;
use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::query::{Ray, RayCast};
use std::cell::Cell;

/// Instance id of walls, floor and ceiling (not objects).
pub const STRUCTURE: u8 = 0;

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
    aabb: Aabb,
}

/// The scene as solids in a BVH, ready for ray casting from any number of threads.
#[derive(Debug, Clone)]
pub struct World {
    prims: Vec<Prim>,
    bvh: Bvh,
    room_min: Vec3,
    room_max: Vec3,
}

impl World {
    /// Build the world of a scene: every object (solid `k`, instance `k + 1`) and then every
    /// partition wall (instance [`STRUCTURE`]) in a BVH, and the room's floor, ceiling and walls
    /// ([`STRUCTURE`]).
    pub fn new(scene: &Scene) -> World {
        let prim = |pose: Pose, shape: SolidShape, instance: u8| {
            let aabb = match &shape {
                SolidShape::Cuboid(s) => s.aabb(&pose),
                SolidShape::Cylinder(s) => s.aabb(&pose),
            };
            Prim {
                pose,
                shape,
                instance,
                aabb,
            }
        };
        let height = scene.room.height;
        let prims: Vec<Prim> = scene
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| prim(o.pose(), o.shape_shrunk(0.0), (k + 1) as u8))
            .chain(
                scene
                    .partitions
                    .iter()
                    .map(|p| prim(p.pose(height), p.shape(height, 0.0), STRUCTURE)),
            )
            .collect();
        let aabbs: Vec<Aabb> = prims.iter().map(|p| p.aabb).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
        let r = scene.room;
        World {
            prims,
            bvh,
            room_min: r.min.extend(0.0),
            room_max: r.max.extend(r.height),
        }
    }

    /// Number of solids in the BVH: the scene's objects (solids `0..objects`), then its
    /// partition walls. The `object_*` accessors take a solid index.
    pub fn solid_count(&self) -> usize {
        self.prims.len()
    }

    /// Instance id of solid `k`: `k + 1` for scene object `k`, [`STRUCTURE`] for a partition.
    pub fn instance(&self, k: usize) -> u8 {
        self.prims[k].instance
    }

    /// World-axis-aligned bounds `(min, max)` of scene object `k`.
    pub fn object_bounds(&self, k: usize) -> (Vec3, Vec3) {
        (self.prims[k].aabb.mins, self.prims[k].aabb.maxs)
    }

    /// The eight corners (world frame) of scene object `k`'s oriented bounding box (exact for
    /// boxes; a cylinder's circumscribed box).
    pub fn object_corners(&self, k: usize) -> [Vec3; 8] {
        let p = &self.prims[k];
        let h = match &p.shape {
            SolidShape::Cuboid(c) => c.half_extents,
            SolidShape::Cylinder(c) => Vec3::new(c.radius, c.half_height, c.radius),
        };
        std::array::from_fn(|i| {
            let s = Vec3::new(
                if i & 1 == 0 { -h.x } else { h.x },
                if i & 2 == 0 { -h.y } else { h.y },
                if i & 4 == 0 { -h.z } else { h.z },
            );
            p.pose.transform_point(s)
        })
    }

    /// The solid of scene object `k`, in its frame ([`World::object_pose`]).
    pub(crate) fn object_shape(&self, k: usize) -> &SolidShape {
        &self.prims[k].shape
    }

    /// `world_from_object` pose of scene object `k` (parry frame: a cylinder's axis is local y).
    pub fn object_pose(&self, k: usize) -> &Pose {
        &self.prims[k].pose
    }

    /// Ray against scene object `k` alone: `(t, unit world normal)` of the entry point with
    /// `0 ≤ t ≤ max_t`.
    #[inline]
    pub fn cast_object(
        &self,
        k: usize,
        origin: Vec3,
        dir: Vec3,
        max_t: f32,
    ) -> Option<(f32, Vec3)> {
        let p = &self.prims[k];
        let local = Ray::new(origin, dir).inverse_transform_by(&p.pose);
        let (t, n) = self.cast_object_local(k, &local, max_t)?;
        Some((t, p.pose.rotation * n))
    }

    /// Like [`World::cast_object`] with the ray already in the object's frame
    /// ([`World::object_pose`]); the normal is in the object's frame too. Uses parry's ray casts.
    #[inline]
    pub fn cast_object_local(&self, k: usize, local: &Ray, max_t: f32) -> Option<(f32, Vec3)> {
        let hit = match &self.prims[k].shape {
            SolidShape::Cuboid(s) => s.cast_local_ray_and_get_normal(local, max_t, true),
            SolidShape::Cylinder(s) => cast_cylinder(s, local, max_t),
        }?;
        Some((hit.time_of_impact, hit.normal))
    }

    /// [`World::cast_object_local`] with a branch-light slab test for boxes (the camera's hot
    /// path; a test checks it against the parry path pixel by pixel).
    #[inline]
    pub fn cast_object_local_fast(&self, k: usize, local: &Ray, max_t: f32) -> Option<(f32, Vec3)> {
        match &self.prims[k].shape {
            SolidShape::Cuboid(s) => ray_box(s.half_extents, local.origin, local.dir, max_t),
            SolidShape::Cylinder(s) => {
                cast_cylinder(s, local, max_t).map(|h| (h.time_of_impact, h.normal))
            }
        }
    }

    /// The room's inside as the box `(min, max)`, world frame (floor at z = 0).
    pub fn room_bounds(&self) -> (Vec3, Vec3) {
        (self.room_min, self.room_max)
    }

    /// Where a ray from inside the room leaves it (floor, ceiling or a wall), as `(t, inward
    /// normal)`; `None` if the origin is outside the room or `dir` is zero.
    #[inline]
    pub fn room_exit(&self, origin: Vec3, dir: Vec3) -> Option<(f32, Vec3)> {
        if origin.cmplt(self.room_min).any() || origin.cmpgt(self.room_max).any() {
            return None;
        }
        let inv = dir.recip();
        // Per axis, the exit distance is the larger of the two plane distances.
        let t = ((self.room_max - origin) * inv).max((self.room_min - origin) * inv);
        let axis = if t.x <= t.y && t.x <= t.z {
            0
        } else if t.y <= t.z {
            1
        } else {
            2
        };
        if !t[axis].is_finite() {
            return None;
        }
        let mut n = Vec3::ZERO;
        n[axis] = -dir[axis].signum();
        Some((t[axis], n))
    }

    /// Nearest hit of the ray `origin + t·dir`, `0 < t ≤ max_t` (`dir` need not be unit).
    /// Objects are found through the BVH; the room's floor, ceiling and walls (the inside of
    /// an axis-aligned box) are intersected analytically and bound the BVH search, so a ray
    /// from inside the room always hits something within the room.
    /// Allocation-free; safe to call from many threads.
    pub fn cast(&self, origin: Vec3, dir: Vec3, max_t: f32) -> Option<Hit> {
        let room = self.room_exit(origin, dir).filter(|(t, _)| *t <= max_t);
        let limit = room.map_or(max_t, |(t, _)| t);
        let room_hit = room.map(|(t, normal)| Hit {
            t,
            normal,
            instance: STRUCTURE,
        });
        let ray = Ray::new(origin, dir);
        let normal = Cell::new(Vec3::Z);
        let Some((leaf, t)) = self.bvh.cast_ray(&ray, limit, |i, best| {
            let (t, n) = self.cast_object(i as usize, origin, dir, best)?;
            normal.set(n);
            Some(t)
        }) else {
            return room_hit;
        };
        Some(Hit {
            t,
            normal: normal.get(),
            instance: self.prims[leaf as usize].instance,
        })
    }
}

/// Slab test of the ray `o + t·d` against the box `[-h, h]`: entry `(t, outward normal)` with
/// `0 ≤ t ≤ max_t` (`t = 0` from inside).
#[inline]
fn ray_box(h: Vec3, o: Vec3, d: Vec3, max_t: f32) -> Option<(f32, Vec3)> {
    let inv = d.recip();
    let t1 = (-h - o) * inv;
    let t2 = (h - o) * inv;
    let near = t1.min(t2);
    let far = t1.max(t2);
    let t_in = near.max_element();
    let t_out = far.min_element();
    if t_out < t_in.max(0.0) || t_in > max_t || t_in.is_nan() {
        return None;
    }
    let axis = if near.x >= near.y && near.x >= near.z {
        0
    } else if near.y >= near.z {
        1
    } else {
        2
    };
    let mut n = Vec3::ZERO;
    n[axis] = -d[axis].signum();
    Some((t_in.max(0.0), n))
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
        assert_eq!(w.solid_count(), 2);
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
