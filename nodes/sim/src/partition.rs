//! Partition walls of a scene (`[[partition]]` in a scene file): upright boxes from the floor to
//! the ceiling that divide a room. They are structure, not objects: the simulator renders them
//! with the walls' instance ([`super::STRUCTURE`]), the navigation grid treats them as
//! obstacles, and the detector, the ground-truth clusters and the evaluation ignore them.
//!
//! ```toml
//! [[partition]]
//! name = "partition_1"   # unique among partitions
//! center = [1.2, -0.8]   # footprint centre x, y, metres
//! size = [0.1, 3.0]      # footprint extent along the partition's x, y, metres
//! yaw = 0.0              # rad about +z (default 0)
//! ```
//!
//! Validation: finite values, positive sizes, footprint inside the room, no overlap with an
//! object, no robot start inside; each error names the file, the partition and the field.

use super::scene::{OVERLAP_TOLERANCE, Room, SceneError, SceneObject, SolidShape};
use glam::{Vec2, Vec3};
use parry3d::math::{Pose, Rot3};
use parry3d::shape::Cuboid as PCuboid;
use serde::Deserialize;
use std::path::Path;

/// Keys of a `[[partition]]` table.
pub(crate) const PARTITION_KEYS: [&str; 4] = ["name", "center", "size", "yaw"];

/// A partition wall: an upright box over the whole room height.
#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    /// Unique name among partitions.
    pub name: String,
    /// Footprint centre, world frame, metres.
    pub center: Vec2,
    /// Footprint extent along the partition's x, y, metres.
    pub size: Vec2,
    /// Yaw about +z, radians.
    pub yaw: f32,
}

impl Partition {
    /// Distance (metres) from a floor point to the footprint (0 inside).
    pub fn footprint_distance(&self, p: Vec2) -> f32 {
        let d = p - self.center;
        let (s, c) = self.yaw.sin_cos();
        let local = Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y);
        (local.abs() - self.size * 0.5).max(Vec2::ZERO).length()
    }

    /// The four footprint corners, world frame.
    pub fn corners(&self) -> [Vec2; 4] {
        let (s, c) = self.yaw.sin_cos();
        let h = self.size * 0.5;
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(a, b)| {
            let l = Vec2::new(a * h.x, b * h.y);
            self.center + Vec2::new(c * l.x - s * l.y, s * l.x + c * l.y)
        })
    }

    /// parry pose of the solid in a room of height `height` (centre at mid-height).
    pub(crate) fn pose(&self, height: f32) -> Pose {
        Pose::from_parts(
            self.center.extend(height * 0.5),
            Rot3::from_rotation_z(self.yaw),
        )
    }

    /// The solid, floor to ceiling of a room of height `height`, shrunk by `shrink` per side.
    pub(crate) fn shape(&self, height: f32, shrink: f32) -> SolidShape {
        let h = (Vec3::new(self.size.x, self.size.y, height) * 0.5 - Vec3::splat(shrink))
            .max(Vec3::splat(1e-4));
        SolidShape::Cuboid(PCuboid::new(h))
    }
}

/// A `[[partition]]` table as read.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPartition {
    name: String,
    center: [f32; 2],
    size: [f32; 2],
    #[serde(default)]
    yaw: f32,
}

/// Validate the partitions of a scene whose room and objects are already valid.
pub(crate) fn build(
    file: &Path,
    room: &Room,
    objects: &[SceneObject],
    raw: Vec<RawPartition>,
) -> Result<Vec<Partition>, SceneError> {
    let invalid = |object: &str, field: &'static str, value: String, reason: &'static str| {
        SceneError::Invalid {
            file: file.to_path_buf(),
            object: object.to_string(),
            field,
            value,
            reason,
        }
    };
    let mut out: Vec<Partition> = Vec::with_capacity(raw.len());
    for r in raw {
        if out.iter().any(|p| p.name == r.name) {
            return Err(SceneError::DuplicateName {
                file: file.to_path_buf(),
                object: r.name,
            });
        }
        if !r.center.iter().all(|v| v.is_finite()) {
            let v = format!("{:?}", r.center);
            return Err(invalid(&r.name, "center", v, "must be finite"));
        }
        if !r.size.iter().all(|v| v.is_finite() && *v > 0.0) {
            let v = format!("{:?}", r.size);
            return Err(invalid(
                &r.name,
                "size",
                v,
                "both extents must be finite and > 0",
            ));
        }
        if !r.yaw.is_finite() {
            return Err(invalid(&r.name, "yaw", r.yaw.to_string(), "must be finite"));
        }
        let p = Partition {
            name: r.name,
            center: Vec2::from(r.center),
            size: Vec2::from(r.size),
            yaw: r.yaw,
        };
        let outside = |field| SceneError::OutsideRoom {
            file: file.to_path_buf(),
            object: p.name.clone(),
            field,
        };
        if !room.contains(p.center, 0.0) {
            return Err(outside("center"));
        }
        if !p
            .corners()
            .iter()
            .all(|c| room.contains(*c, -OVERLAP_TOLERANCE))
        {
            return Err(outside("size"));
        }
        let (pose, shape) = (
            p.pose(room.height),
            p.shape(room.height, OVERLAP_TOLERANCE * 0.5),
        );
        for o in objects {
            let hit = parry3d::query::intersection_test(
                &pose,
                shape.as_shape(),
                &o.pose(),
                o.shape_shrunk(OVERLAP_TOLERANCE * 0.5).as_shape(),
            )
            .map(|i| i.intersecting)
            .unwrap_or(true);
            if hit {
                return Err(SceneError::Overlap {
                    file: file.to_path_buf(),
                    object: p.name.clone(),
                    other: o.name.clone(),
                });
            }
        }
        out.push(p);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{NavGrid, STRUCTURE, Scene, World};

    const HEAD: &str = "name = \"t\"\n[room]\nmin = [-3.0, -2.0]\nmax = [3.0, 2.0]\nheight = 2.5\n\
                        [robot]\nstart = [-2.0, 0.0, 0.0]\n\
                        [[object]]\nname = \"cup\"\nclass = \"cup\"\ncenter = [2.0, 0.0, 0.05]\n\
                        size = [0.1, 0.1, 0.1]\n";

    fn parse(body: &str) -> Result<Scene, SceneError> {
        Scene::parse(Path::new("p.toml"), &format!("{HEAD}{body}"))
    }

    fn wall(name: &str, x: f32, y: f32, sy: f32) -> String {
        format!("[[partition]]\nname = \"{name}\"\ncenter = [{x}, {y}]\nsize = [0.1, {sy}]\n")
    }

    #[test]
    fn a_partition_blocks_rays_as_structure_and_the_grid_around_it() {
        let s = parse(&wall("p", 0.0, -0.5, 3.0)).unwrap();
        assert_eq!(s.partitions.len(), 1);
        assert_eq!(s.clusters.len(), 1, "not an object");
        let w = World::new(&s);
        let h = w.cast(Vec3::new(-2.0, -0.5, 1.0), Vec3::X, 100.0).unwrap();
        assert!(
            (h.t - 1.95).abs() < 1e-4 && h.instance == STRUCTURE,
            "{h:?}"
        );
        // Above the partition's end (y > 1) the ray reaches the cup's side of the room.
        let h = w.cast(Vec3::new(-2.0, 1.5, 1.0), Vec3::X, 100.0).unwrap();
        assert!((h.t - 5.0).abs() < 1e-4, "{h:?}");
        let g = NavGrid::build(&s, 0.3, 0.05).unwrap();
        assert!(g.is_blocked(Vec2::new(0.3, 0.0)));
        assert!(!g.is_blocked(Vec2::new(0.4, 0.0)));
        assert!(g.plan(Vec2::new(-2.0, 0.0), Vec2::new(2.0, -1.0)).is_ok());
        let closed = parse(&wall("p", 0.0, 0.0, 4.0)).unwrap();
        let g = NavGrid::build(&closed, 0.3, 0.05).unwrap();
        assert!(g.plan(Vec2::new(-2.0, 0.0), Vec2::new(2.0, -1.0)).is_err());
    }

    #[test]
    fn bad_partitions_are_errors_naming_the_partition_and_field() {
        let e = parse(&wall("p", 2.0, 0.0, 1.0)).unwrap_err();
        assert!(
            matches!(&e, SceneError::Overlap { object, other, .. } if object == "p" && other == "cup"),
            "{e}"
        );
        let e = parse(&wall("p", 0.0, 1.5, 2.0)).unwrap_err();
        assert!(
            matches!(&e, SceneError::OutsideRoom { object, field: "size", .. } if object == "p"),
            "{e}"
        );
        let e = parse(&wall("p", 0.0, 0.0, -1.0)).unwrap_err();
        assert!(
            matches!(&e, SceneError::Invalid { field: "size", .. }),
            "{e}"
        );
        let e = parse(&(wall("p", 0.0, 0.0, 1.0) + &wall("p", 1.0, 0.0, 1.0))).unwrap_err();
        assert!(matches!(&e, SceneError::DuplicateName { .. }), "{e}");
        let e = parse(&wall("p", -2.0, 0.0, 1.0)).unwrap_err();
        assert!(
            matches!(&e, SceneError::Invalid { field: "start", .. }),
            "{e}"
        );
        let e = parse(
            "[[partition]]\nname = \"p\"\ncenter = [0.0, 0.0]\nsize = [0.1, 1.0]\nheight = 2\n",
        )
        .unwrap_err();
        assert!(
            matches!(&e, SceneError::UnknownKey { object, key, .. } if object == "p" && key == "height"),
            "{e}"
        );
    }
}
