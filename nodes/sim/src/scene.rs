//! Scene files (`config/scenes/*.toml`, format fixed in `docs/formats.md` "Scene files"): parsing, full
//! validation, built-in scenes and ground-truth clusters.
//!
//! A scene is an axis-aligned room (floor at z = 0, walls around it) with upright objects (boxes or
//! cylinders, yaw about +z). Validation rejects unknown keys, unknown COCO classes, duplicate
//! names, interpenetrating objects, objects outside the room and more objects than an
//! [`shm_types::ObjectMap`] holds, each with its own [`SceneError`] variant naming the file, the
//! object and the field.
//!
//! Object keys: `name` (unique), `class` (COCO class name), `background` (optional; default from
//! the class), `center` and `size` (metres, object frame x, y, z), `yaw` (rad about +z, default
//! 0), `shape` (`"box"`, the default, or `"cylinder"` with size x = y = diameter) and
//! `material`: how the depth sensor sees the surface ([`Material`]; `"default"` if absent):
//!
//! ```toml
//! [[object]]
//! name = "bottle_tall"
//! class = "bottle"
//! center = [-2.491, 0.549, 0.8665]
//! size = [0.073, 0.073, 0.289]
//! shape = "cylinder"
//! material = "glass"   # "default" | "glass" | "dark" | "specular"
//! ```
//!
//! The material's effect on depth (rates in `config/default.toml` `[sim]`) is applied by the
//! simulator's depth artefacts (`sim/artefacts.rs`); the detector and ground truth ignore it.
//!
//! Partition walls (`[[partition]]`, floor-to-ceiling boxes that are structure, not objects) are
//! described and validated in [`super::partition`].

use super::partition::{self, PARTITION_KEYS, Partition, RawPartition};
use geom::Cuboid;
use glam::{Vec2, Vec3};
use parry3d::math::{Pose, Rot3};
use parry3d::shape::{Cuboid as PCuboid, Cylinder as PCylinder};
use serde::Deserialize;
use shm_types::ClassId;
use std::path::{Path, PathBuf};

/// Interpenetration (metres) tolerated between two objects before they count as overlapping
/// (objects resting on each other touch).
pub const OVERLAP_TOLERANCE: f32 = 0.01;
/// Vertical gap (metres) within which an object's bottom counts as resting on another's top.
pub const SUPPORT_TOLERANCE: f32 = 0.02;

/// The built-in scenes, compiled in so the binary runs from any directory.
pub const BUILTIN_SCENES: [(&str, &str); 3] = [
    (
        "paper-scene-1",
        include_str!("../../../config/scenes/paper-scene-1.toml"),
    ),
    (
        "paper-scene-2",
        include_str!("../../../config/scenes/paper-scene-2.toml"),
    ),
    (
        "paper-scene-3",
        include_str!("../../../config/scenes/paper-scene-3.toml"),
    ),
];

/// Why a scene file was refused. Every variant names the file; object errors name the object and
/// the field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read scene file: {source}")]
    Read {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not valid TOML, a missing key, or a value of the wrong type.
    #[error("{file}: {message}")]
    Parse {
        /// The file.
        file: PathBuf,
        /// The parser's message (names the key and line).
        message: String,
    },
    /// A key the format does not define.
    #[error("{file}: {object}: unknown key `{key}`")]
    UnknownKey {
        /// The file.
        file: PathBuf,
        /// `<scene>`, `room`, `robot` or the object's name (`object[k]` if it has none).
        object: String,
        /// The unknown key.
        key: String,
    },
    /// `class` is not a COCO class name.
    #[error("{file}: object {object:?}: class = {class:?} is not a COCO class name")]
    UnknownClass {
        /// The file.
        file: PathBuf,
        /// The object.
        object: String,
        /// The class as written.
        class: String,
    },
    /// Two objects have the same name.
    #[error("{file}: object {object:?}: name is used by more than one object")]
    DuplicateName {
        /// The file.
        file: PathBuf,
        /// The repeated name.
        object: String,
    },
    /// Two objects interpenetrate by more than [`OVERLAP_TOLERANCE`].
    #[error("{file}: object {object:?}: center/size make it overlap object {other:?}")]
    Overlap {
        /// The file.
        file: PathBuf,
        /// The later object.
        object: String,
        /// The earlier object it overlaps.
        other: String,
    },
    /// An object is not inside the room (`field` is `center` if the centre is outside, else
    /// `size`).
    #[error("{file}: object {object:?}: {field} puts it outside the room")]
    OutsideRoom {
        /// The file.
        file: PathBuf,
        /// The object.
        object: String,
        /// `center` or `size`.
        field: &'static str,
    },
    /// More objects than [`shm_types::MAX_OBJECTS`].
    #[error("{file}: {count} objects, more than the object map holds ({max})")]
    TooManyObjects {
        /// The file.
        file: PathBuf,
        /// Objects in the file.
        count: usize,
        /// The capacity.
        max: usize,
    },
    /// A value out of its domain (non-finite, non-positive size, empty room, cylinder with
    /// x ≠ y, robot start outside the room or inside an object).
    #[error("{file}: {object}: {field} = {value}: {reason}")]
    Invalid {
        /// The file.
        file: PathBuf,
        /// `room`, `robot` or the object's name.
        object: String,
        /// The field.
        field: &'static str,
        /// The value as read.
        value: String,
        /// What was expected.
        reason: &'static str,
    },
    /// `Scene::builtin` was given a name that is not built in.
    #[error(
        "no built-in scene named {name:?} (built in: paper-scene-1, paper-scene-2, paper-scene-3)"
    )]
    UnknownScene {
        /// The name asked for.
        name: String,
    },
}

/// Shape of an object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shape {
    /// A box of `size` along the object's axes.
    #[default]
    Box,
    /// An upright cylinder, diameter `size.x` (= `size.y`), height `size.z`.
    Cylinder,
}

/// How a surface looks to a time-of-flight depth sensor (Kinect v2). The effect of each on the
/// depth image, and its rates, are the `[sim]` keys `glass_*`, `dark_invalid` and
/// `specular_invalid` (see `sim/artefacts.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Material {
    /// Matte, diffuse, bright enough: only the camera's σ(z) noise and random dropout.
    #[default]
    Default,
    /// Transparent (glass bottles, wine glasses, glass vases): often invalid, often reads the
    /// surface behind it.
    Glass,
    /// Dark, low-reflectance (black plastic, dark fabric): often invalid (too little returned
    /// light).
    Dark,
    /// Shiny, mirror-like (polished metal, glazed ceramics): often invalid (light reflected away
    /// or saturating).
    Specular,
}

impl Material {
    /// The names accepted in scene files, in the order of the enum.
    pub const NAMES: [&'static str; 4] = ["default", "glass", "dark", "specular"];

    /// The material named `name` in a scene file, `None` if none is.
    pub fn from_name(name: &str) -> Option<Material> {
        match name {
            "default" => Some(Material::Default),
            "glass" => Some(Material::Glass),
            "dark" => Some(Material::Dark),
            "specular" => Some(Material::Specular),
            _ => None,
        }
    }

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

/// One object of a scene (ground truth).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    /// Unique name.
    pub name: String,
    /// COCO class name.
    pub class: String,
    /// COCO class id.
    pub class_id: ClassId,
    /// Background (cluster-anchoring) object.
    pub background: bool,
    /// Centre, world frame, metres.
    pub center: Vec3,
    /// Extent along the object's x, y, z, metres.
    pub size: Vec3,
    /// Yaw about +z, radians.
    pub yaw: f32,
    /// Box or cylinder.
    pub shape: Shape,
    /// Surface material as the depth sensor sees it.
    pub material: Material,
}

impl SceneObject {
    /// The object's bounding cuboid (exact for boxes).
    pub fn cuboid(&self) -> Cuboid {
        Cuboid {
            center: self.center,
            size: self.size,
            yaw: self.yaw,
        }
    }

    /// Height of the top face, metres.
    pub fn top(&self) -> f32 {
        self.center.z + self.size.z * 0.5
    }

    /// Height of the bottom face, metres.
    pub fn bottom(&self) -> f32 {
        self.center.z - self.size.z * 0.5
    }

    /// Distance (metres) from a floor point to the object's footprint (0 inside).
    pub fn footprint_distance(&self, p: Vec2) -> f32 {
        let d = p - self.center.truncate();
        match self.shape {
            Shape::Cylinder => (d.length() - self.size.x * 0.5).max(0.0),
            Shape::Box => {
                let (s, c) = self.yaw.sin_cos();
                let local = Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y);
                let h = self.size.truncate() * 0.5;
                (local.abs() - h).max(Vec2::ZERO).length()
            }
        }
    }

    /// parry pose of the object: translation to the centre, yaw about +z; for cylinders the
    /// parry y axis is turned onto world z.
    pub fn pose(&self) -> Pose {
        let yaw = Rot3::from_rotation_z(self.yaw);
        let rot = match self.shape {
            Shape::Box => yaw,
            Shape::Cylinder => yaw * Rot3::from_rotation_x(std::f32::consts::FRAC_PI_2),
        };
        Pose::from_parts(self.center, rot)
    }

    /// The parry shape, shrunk by `shrink` metres on every side.
    pub(crate) fn shape_shrunk(&self, shrink: f32) -> SolidShape {
        let h = (self.size * 0.5 - Vec3::splat(shrink)).max(Vec3::splat(1e-4));
        match self.shape {
            Shape::Box => SolidShape::Cuboid(PCuboid::new(h)),
            Shape::Cylinder => SolidShape::Cylinder(PCylinder::new(h.z, h.x)),
        }
    }
}

/// A solid primitive of the world.
#[derive(Debug, Clone, Copy)]
pub(crate) enum SolidShape {
    /// A box.
    Cuboid(PCuboid),
    /// A cylinder along its local y axis.
    Cylinder(PCylinder),
}

impl SolidShape {
    pub(crate) fn as_shape(&self) -> &dyn parry3d::shape::Shape {
        match self {
            SolidShape::Cuboid(c) => c,
            SolidShape::Cylinder(c) => c,
        }
    }
}

/// The axis-aligned room: floor at z = 0, walls along its edges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Room {
    /// Corner with the smallest x, y, metres.
    pub min: Vec2,
    /// Corner with the largest x, y, metres.
    pub max: Vec2,
    /// Wall height, metres.
    pub height: f32,
}

impl Room {
    /// Whether a floor point is inside the room (with a margin inwards).
    pub fn contains(&self, p: Vec2, margin: f32) -> bool {
        p.x >= self.min.x + margin
            && p.y >= self.min.y + margin
            && p.x <= self.max.x - margin
            && p.y <= self.max.y - margin
    }
}

/// A validated scene (ground truth: only `sim` and `eval` may read it).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Scene name.
    pub name: String,
    /// Where it was loaded from (`<built-in NAME>` for built-in scenes).
    pub source: PathBuf,
    /// The room.
    pub room: Room,
    /// Robot start `[x, y, yaw]`.
    pub robot_start: [f32; 3],
    /// The objects, in file order.
    pub objects: Vec<SceneObject>,
    /// Partition walls (structure: rendered and navigated around like walls, never detected
    /// or scored), in file order.
    pub partitions: Vec<Partition>,
    /// Ground-truth cluster of each object: the index of the background object whose top face
    /// supports it (its own index for background objects), `None` if none does.
    pub clusters: Vec<Option<usize>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    room: RawRoom,
    #[serde(default)]
    robot: RawRobot,
    #[serde(default)]
    object: Vec<RawObject>,
    #[serde(default)]
    partition: Vec<RawPartition>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRoom {
    min: [f32; 2],
    max: [f32; 2],
    height: f32,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobot {
    start: [f32; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
    name: String,
    class: String,
    background: Option<bool>,
    center: [f32; 3],
    size: [f32; 3],
    #[serde(default)]
    yaw: f32,
    #[serde(default)]
    shape: RawShape,
    material: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
enum RawShape {
    #[default]
    Box,
    Cylinder,
}

const SCENE_KEYS: [&str; 5] = ["name", "room", "robot", "object", "partition"];
const ROOM_KEYS: [&str; 3] = ["min", "max", "height"];
const ROBOT_KEYS: [&str; 1] = ["start"];
const OBJECT_KEYS: [&str; 8] = [
    "name",
    "class",
    "background",
    "center",
    "size",
    "yaw",
    "shape",
    "material",
];

impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Scene::parse(path, &text)
    }

    /// A built-in scene by name (`paper-scene-1`, `paper-scene-2`, `paper-scene-3`).
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        let (_, text) = BUILTIN_SCENES
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| SceneError::UnknownScene {
                name: name.to_string(),
            })?;
        Scene::parse(Path::new(&format!("<built-in {name}>")), text)
    }

    /// A built-in scene if `name_or_path` names one, else the scene file at that path.
    pub fn builtin_or_load(name_or_path: &str) -> Result<Scene, SceneError> {
        if BUILTIN_SCENES.iter().any(|(n, _)| *n == name_or_path) {
            Scene::builtin(name_or_path)
        } else {
            Scene::load(Path::new(name_or_path))
        }
    }

    /// Parse and validate scene text that came from `file`.
    pub fn parse(file: &Path, text: &str) -> Result<Scene, SceneError> {
        let parse_err = |message: String| SceneError::Parse {
            file: file.to_path_buf(),
            message,
        };
        let table: toml::Table = toml::from_str(text).map_err(|e| parse_err(e.to_string()))?;
        check_keys(file, &table)?;
        let raw: RawScene = table
            .try_into()
            .map_err(|e: toml::de::Error| parse_err(e.to_string()))?;
        build(file, raw)
    }

    /// Ground-truth cluster anchor of object `i` (see [`Scene::clusters`]).
    pub fn cluster_of(&self, i: usize) -> Option<usize> {
        self.clusters.get(i).copied().flatten()
    }

    /// Indices of the foreground objects.
    pub fn foreground(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.objects.len()).filter(|&i| !self.objects[i].background)
    }
}

fn check_keys(file: &Path, table: &toml::Table) -> Result<(), SceneError> {
    let unknown = |object: &str, key: &str| SceneError::UnknownKey {
        file: file.to_path_buf(),
        object: object.to_string(),
        key: key.to_string(),
    };
    for key in table.keys() {
        if !SCENE_KEYS.contains(&key.as_str()) {
            return Err(unknown("<scene>", key));
        }
    }
    let sub = [("room", &ROOM_KEYS[..]), ("robot", &ROBOT_KEYS[..])];
    for (name, keys) in sub {
        if let Some(toml::Value::Table(t)) = table.get(name)
            && let Some(k) = t.keys().find(|k| !keys.contains(&k.as_str()))
        {
            return Err(unknown(name, k));
        }
    }
    for (array, keys) in [
        ("object", &OBJECT_KEYS[..]),
        ("partition", &PARTITION_KEYS[..]),
    ] {
        let Some(toml::Value::Array(items)) = table.get(array) else {
            continue;
        };
        for (i, o) in items.iter().enumerate() {
            let Some(t) = o.as_table() else { continue };
            if let Some(k) = t.keys().find(|k| !keys.contains(&k.as_str())) {
                let name = t
                    .get("name")
                    .and_then(|n| n.as_str())
                    .map_or_else(|| format!("{array}[{i}]"), str::to_string);
                return Err(unknown(&name, k));
            }
        }
    }
    Ok(())
}

fn build(file: &Path, raw: RawScene) -> Result<Scene, SceneError> {
    let f = || file.to_path_buf();
    let invalid = |object: &str, field: &'static str, value: String, reason: &'static str| {
        SceneError::Invalid {
            file: f(),
            object: object.to_string(),
            field,
            value,
            reason,
        }
    };
    let r = &raw.room;
    if !r.min.iter().chain(&r.max).all(|v| v.is_finite())
        || r.min[0] >= r.max[0]
        || r.min[1] >= r.max[1]
    {
        return Err(invalid(
            "room",
            "max",
            format!("{:?}", r.max),
            "must be finite and greater than room.min in x and y",
        ));
    }
    if !(r.height.is_finite() && r.height > 0.1) {
        return Err(invalid(
            "room",
            "height",
            r.height.to_string(),
            "must be > 0.1 m",
        ));
    }
    let room = Room {
        min: Vec2::from(r.min),
        max: Vec2::from(r.max),
        height: r.height,
    };
    if raw.object.len() > shm_types::MAX_OBJECTS {
        return Err(SceneError::TooManyObjects {
            file: f(),
            count: raw.object.len(),
            max: shm_types::MAX_OBJECTS,
        });
    }

    let mut objects: Vec<SceneObject> = Vec::with_capacity(raw.object.len());
    for o in raw.object {
        if objects.iter().any(|p| p.name == o.name) {
            return Err(SceneError::DuplicateName {
                file: f(),
                object: o.name,
            });
        }
        let class_id = shm_types::class_id(&o.class).ok_or_else(|| SceneError::UnknownClass {
            file: f(),
            object: o.name.clone(),
            class: o.class.clone(),
        })?;
        if !o.center.iter().all(|v| v.is_finite()) {
            return Err(invalid(
                &o.name,
                "center",
                format!("{:?}", o.center),
                "must be finite",
            ));
        }
        if !o.size.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(invalid(
                &o.name,
                "size",
                format!("{:?}", o.size),
                "every extent must be finite and > 0",
            ));
        }
        if !o.yaw.is_finite() {
            return Err(invalid(&o.name, "yaw", o.yaw.to_string(), "must be finite"));
        }
        let shape = match o.shape {
            RawShape::Box => Shape::Box,
            RawShape::Cylinder => Shape::Cylinder,
        };
        if shape == Shape::Cylinder && (o.size[0] - o.size[1]).abs() > 1e-4 {
            return Err(invalid(
                &o.name,
                "size",
                format!("{:?}", o.size),
                "a cylinder needs size x = y (the diameter)",
            ));
        }
        let material = match o.material.as_deref() {
            None => Material::Default,
            Some(m) => Material::from_name(m).ok_or_else(|| {
                invalid(
                    &o.name,
                    "material",
                    format!("{m:?}"),
                    "must be \"default\", \"glass\", \"dark\" or \"specular\"",
                )
            })?,
        };
        let obj = SceneObject {
            material,
            background: o
                .background
                .unwrap_or_else(|| shm_types::is_background_class(class_id)),
            name: o.name,
            class: o.class,
            class_id,
            center: Vec3::from(o.center),
            size: Vec3::from(o.size),
            yaw: o.yaw,
            shape,
        };
        check_inside(file, &room, &obj)?;
        let (pose, shape) = (obj.pose(), obj.shape_shrunk(OVERLAP_TOLERANCE * 0.5));
        for other in &objects {
            let hit = parry3d::query::intersection_test(
                &pose,
                shape.as_shape(),
                &other.pose(),
                other.shape_shrunk(OVERLAP_TOLERANCE * 0.5).as_shape(),
            )
            .map(|i| i.intersecting)
            .unwrap_or(true);
            if hit {
                return Err(SceneError::Overlap {
                    file: f(),
                    object: obj.name.clone(),
                    other: other.name.clone(),
                });
            }
        }
        objects.push(obj);
    }

    let partitions = partition::build(file, &room, &objects, raw.partition)?;
    let start = raw.robot.start;
    let start_xy = Vec2::new(start[0], start[1]);
    if !start.iter().all(|v| v.is_finite())
        || !room.contains(start_xy, 0.0)
        || objects
            .iter()
            .any(|o| o.footprint_distance(start_xy) <= 0.0)
        || partitions
            .iter()
            .any(|p| p.footprint_distance(start_xy) <= 0.0)
    {
        return Err(invalid(
            "robot",
            "start",
            format!("{start:?}"),
            "must be finite, inside the room and not inside an object or a partition",
        ));
    }

    let clusters = clusters(&objects);
    Ok(Scene {
        name: raw.name,
        source: f(),
        room,
        robot_start: start,
        objects,
        partitions,
        clusters,
    })
}

fn check_inside(file: &Path, room: &Room, o: &SceneObject) -> Result<(), SceneError> {
    let outside = |field| SceneError::OutsideRoom {
        file: file.to_path_buf(),
        object: o.name.clone(),
        field,
    };
    let c = o.center;
    if !room.contains(c.truncate(), 0.0) || c.z < 0.0 || c.z > room.height {
        return Err(outside("center"));
    }
    let tol = OVERLAP_TOLERANCE;
    let corners_ok = match o.shape {
        Shape::Box => o
            .cuboid()
            .corners()
            .iter()
            .all(|p| room.contains(p.truncate(), -tol)),
        Shape::Cylinder => room.contains(c.truncate(), o.size.x * 0.5 - tol),
    };
    if !corners_ok || o.bottom() < -tol || o.top() > room.height + tol {
        return Err(outside("size"));
    }
    Ok(())
}

fn clusters(objects: &[SceneObject]) -> Vec<Option<usize>> {
    objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            if o.background {
                return Some(i);
            }
            let xy = o.center.truncate();
            objects
                .iter()
                .enumerate()
                .filter(|(_, b)| {
                    b.background
                        && (o.bottom() - b.top()).abs() <= SUPPORT_TOLERANCE
                        && b.footprint_distance(xy) <= 0.0
                })
                .min_by(|a, b| {
                    let da = (o.bottom() - a.1.top()).abs();
                    let db = (o.bottom() - b.1.top()).abs();
                    da.total_cmp(&db)
                })
                .map(|(j, _)| j)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "name = \"t\"\n[room]\nmin = [-3.0, -3.0]\nmax = [3.0, 3.0]\nheight = 2.5\n\
                        [robot]\nstart = [0.0, 0.0, 0.0]\n";
    const DESK: &str = "[[object]]\nname = \"desk\"\nclass = \"dining table\"\n\
                        center = [-2.0, 0.0, 0.35]\nsize = [1.0, 1.0, 0.7]\n";

    fn parse(body: &str) -> Result<Scene, SceneError> {
        Scene::parse(Path::new("bad.toml"), &format!("{HEAD}{DESK}{body}"))
    }

    fn cup(name: &str, x: f32, y: f32, z: f32) -> String {
        format!(
            "[[object]]\nname = \"{name}\"\nclass = \"cup\"\ncenter = [{x}, {y}, {z}]\n\
             size = [0.1, 0.1, 0.1]\nshape = \"cylinder\"\n"
        )
    }

    #[test]
    fn valid_scene_derives_background_and_clusters() {
        let s = parse(&(cup("cup", -2.0, 0.0, 0.75) + &cup("floor_cup", 1.0, 1.0, 0.05))).unwrap();
        assert_eq!(s.objects.len(), 3);
        assert!(
            s.objects[0].background,
            "dining table defaults to background"
        );
        assert!(!s.objects[1].background);
        assert_eq!(s.clusters, vec![Some(0), Some(0), None]);
        assert_eq!(s.objects[1].shape, Shape::Cylinder);
        assert_eq!(s.objects[1].material, Material::Default, "default material");
        let glass =
            cup("glass", -2.0, 0.0, 0.75).replace("cylinder\"", "cylinder\"\nmaterial = \"glass\"");
        assert_eq!(parse(&glass).unwrap().objects[1].material, Material::Glass);
        for (k, name) in Material::NAMES.iter().enumerate() {
            assert_eq!(Material::from_name(name).unwrap().name(), *name);
            assert_eq!(Material::from_name(name).unwrap() as usize, k);
        }
    }

    #[test]
    fn an_unknown_material_is_an_error_naming_file_object_field_and_value() {
        let body =
            cup("c", -2.0, 0.0, 0.75).replace("cylinder\"", "cylinder\"\nmaterial = \"chrome\"");
        let e = parse(&body).unwrap_err();
        assert!(
            matches!(&e, SceneError::Invalid { object, field: "material", value, .. }
                if object == "c" && value == "\"chrome\""),
            "{e}"
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with("bad.toml: c: material = \"chrome\": must be"),
            "{msg}"
        );
        let e = parse(&cup("c", -2.0, 0.0, 0.75).replace("cylinder\"", "cylinder\"\nmaterial = 3"))
            .unwrap_err();
        assert!(matches!(&e, SceneError::Parse { .. }), "{e}");
        assert!(e.to_string().contains("material"), "{e}");
    }

    #[test]
    fn each_error_class_has_its_variant() {
        let e = parse("[[object]]\nname = \"x\"\nclass = \"cup\"\ncolour = 1\n").unwrap_err();
        assert!(
            matches!(&e, SceneError::UnknownKey { object, key, .. } if object == "x" && key == "colour"),
            "{e}"
        );
        let e = Scene::parse(Path::new("bad.toml"), &format!("{HEAD}[room2]\n")).unwrap_err();
        assert!(
            matches!(&e, SceneError::UnknownKey { key, .. } if key == "room2"),
            "{e}"
        );
        let e = parse(&cup("c", -2.0, 0.0, 0.75).replace("\"cup\"", "\"mug\"")).unwrap_err();
        assert!(
            matches!(&e, SceneError::UnknownClass { object, class, .. } if object == "c" && class == "mug"),
            "{e}"
        );
        assert!(e.to_string().starts_with("bad.toml: object \"c\""), "{e}");
        let e = parse(&(cup("c", -2.0, 0.0, 0.75) + &cup("c", -2.3, 0.0, 0.75))).unwrap_err();
        assert!(
            matches!(&e, SceneError::DuplicateName { object, .. } if object == "c"),
            "{e}"
        );
        let e = parse(&(cup("a", -2.0, 0.0, 0.75) + &cup("b", -2.05, 0.0, 0.75))).unwrap_err();
        assert!(
            matches!(&e, SceneError::Overlap { object, other, .. } if object == "b" && other == "a"),
            "{e}"
        );
        let e = parse(&cup("sunk", -2.0, 0.0, 0.7)).unwrap_err();
        assert!(
            matches!(&e, SceneError::Overlap { other, .. } if other == "desk"),
            "{e}"
        );
        let e = parse(&cup("far", 5.0, 0.0, 0.05)).unwrap_err();
        assert!(
            matches!(&e, SceneError::OutsideRoom { object, field: "center", .. } if object == "far"),
            "{e}"
        );
        let e = parse(&cup("edge", 2.98, 0.0, 0.05)).unwrap_err();
        assert!(
            matches!(&e, SceneError::OutsideRoom { field: "size", .. }),
            "{e}"
        );
        let many: String = (0..shm_types::MAX_OBJECTS)
            .map(|i| {
                cup(
                    &format!("c{i}"),
                    -2.5 + 0.12 * (i % 40) as f32,
                    1.0,
                    0.05 + 0.12 * (i / 40) as f32,
                )
            })
            .collect();
        let e = parse(&many).unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::TooManyObjects {
                    count: 129,
                    max: 128,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse(&cup("neg", 1.0, 1.0, 0.05).replace("0.1, 0.1, 0.1", "0.1, 0.1, -0.1"))
            .unwrap_err();
        assert!(
            matches!(&e, SceneError::Invalid { field: "size", .. }),
            "{e}"
        );
        let e = Scene::parse(
            Path::new("bad.toml"),
            &format!("{HEAD}{DESK}").replace("start = [0.0", "start = [-2.0"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, SceneError::Invalid { field: "start", .. }),
            "{e}"
        );
        let e =
            parse("[[object]]\nname = \"x\"\nclass = \"cup\"\ncenter = \"here\"\n").unwrap_err();
        assert!(matches!(&e, SceneError::Parse { .. }), "{e}");
        let e = Scene::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
        assert!(matches!(&e, SceneError::Read { .. }), "{e}");
        let e = Scene::builtin("paper-scene-9").unwrap_err();
        assert!(matches!(&e, SceneError::UnknownScene { .. }), "{e}");
    }

    #[test]
    fn builtin_scenes_load_and_foreground_objects_rest_on_background_objects() {
        for (name, _) in BUILTIN_SCENES {
            let s = Scene::builtin(name).unwrap();
            assert_eq!(s.name, name);
            for i in s.foreground() {
                let anchor = s.cluster_of(i);
                assert!(
                    anchor.is_some(),
                    "{name}: {} rests on nothing",
                    s.objects[i].name
                );
                assert!(s.objects[anchor.unwrap()].background);
            }
        }
        let s1 = Scene::builtin("paper-scene-1").unwrap();
        assert_eq!(s1.objects.len(), 10);
        assert_eq!(s1.foreground().count(), 9);
        let s3 = Scene::builtin("paper-scene-3").unwrap();
        assert_eq!(s3.objects.iter().filter(|o| o.background).count(), 3);
        assert_eq!(s3.foreground().count(), 11);
    }
}
