//! One random layout: room, optional partition, furniture (supports and chairs), start pose and
//! foreground objects resting on the supports, all snapped to millimetres.

use super::catalog::{self, CHAIR, Furniture, Item, Kind, Placement};
use super::config::SceneGenConfig;
use crate::{Material, Partition, Room, SceneObject, Shape};
use glam::{Vec2, Vec3};
use parry3d::math::{Pose, Rot3};
use parry3d::shape::Cuboid as PCuboid;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f32::consts::{FRAC_PI_2, PI};

/// Gap kept between foreground objects, metres (beyond the loader's overlap tolerance).
const OBJECT_GAP: f32 = 0.015;
/// Inset of foreground objects from a support's edge, metres.
const EDGE_INSET: f32 = 0.02;
/// Gap between wall-placed furniture and the wall, metres.
const WALL_GAP: f32 = 0.03;
/// Most foreground objects per m² of support top (a cluttered desk: 1.2 m² holds 14).
const MAX_DENSITY: f32 = 12.0;

/// A laid-out room before it is written and validated.
#[derive(Debug, Clone)]
pub(crate) struct Draft {
    /// The room.
    pub room: Room,
    /// Partition walls.
    pub partitions: Vec<Partition>,
    /// Robot start `[x, y, yaw]`.
    pub start: [f32; 3],
    /// Furniture first (supports, then chairs), then foreground objects.
    pub objects: Vec<SceneObject>,
    /// For each object, the index of the furniture it rests on (foreground objects only).
    pub support: Vec<Option<usize>>,
}

/// Millimetre snapping.
pub(crate) fn mm(v: f32) -> f32 {
    (v * 1000.0).round() / 1000.0
}

fn uniform(rng: &mut Pcg64, (lo, hi): (f32, f32)) -> f32 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

fn weighted<T: Copy>(rng: &mut Pcg64, items: &[(T, u32)]) -> T {
    let total: u32 = items.iter().map(|(_, w)| w).sum();
    let mut pick = rng.random_range(0..total);
    for (t, w) in items {
        if pick < *w {
            return *t;
        }
        pick -= w;
    }
    items[items.len() - 1].0
}

fn footprint_box(center: Vec2, half: Vec2, yaw: f32) -> (Pose, PCuboid) {
    (
        Pose::from_parts(center.extend(0.5), Rot3::from_rotation_z(yaw)),
        PCuboid::new(half.extend(0.5)),
    )
}

/// Floor distance between two oriented footprints `(centre, half extents, yaw)`.
fn footprint_distance(a: (Vec2, Vec2, f32), b: (Vec2, Vec2, f32)) -> f32 {
    let (pa, sa) = footprint_box(a.0, a.1, a.2);
    let (pb, sb) = footprint_box(b.0, b.1, b.2);
    parry3d::query::distance(&pa, &sa, &pb, &sb).map_or(0.0, |d| d.distance)
}

fn footprint_of(o: &SceneObject) -> (Vec2, Vec2, f32) {
    (o.center.truncate(), o.size.truncate() * 0.5, o.yaw)
}

fn partition_footprint(p: &Partition) -> (Vec2, Vec2, f32) {
    (p.center, p.size * 0.5, p.yaw)
}

/// Distance from an oriented footprint to the room's walls (negative if it sticks out).
fn wall_distance(room: &Room, (c, h, yaw): (Vec2, Vec2, f32)) -> f32 {
    let (s, co) = yaw.sin_cos();
    let ext = Vec2::new(
        co.abs() * h.x + s.abs() * h.y,
        s.abs() * h.x + co.abs() * h.y,
    );
    let lo = c - ext - room.min;
    let hi = room.max - (c + ext);
    lo.min(hi).min_element()
}

fn make_object(
    name: String,
    class: &str,
    center: Vec3,
    size: Vec3,
    yaw: f32,
    shape: Shape,
    material: Material,
) -> SceneObject {
    let class_id = shm_types::class_id(class).expect("catalogue classes are COCO classes");
    SceneObject {
        name,
        class: class.to_string(),
        class_id,
        background: shm_types::is_background_class(class_id),
        center: Vec3::new(mm(center.x), mm(center.y), mm(center.z)),
        size: Vec3::new(mm(size.x), mm(size.y), mm(size.z)),
        yaw: (yaw * 1e4).round() / 1e4,
        shape,
        material,
    }
}

/// Lay out one room of `kind`; `None` when the draws do not fit (the caller tries again).
pub(crate) fn layout(
    rng: &mut Pcg64,
    kind: Kind,
    cfg: &SceneGenConfig,
    robot_radius: f32,
) -> Option<Draft> {
    let room = draw_room(rng, kind, cfg);
    let partitions = draw_partition(rng, &room, cfg);
    let mut d = Draft {
        room,
        partitions,
        start: [0.0; 3],
        objects: Vec::new(),
        support: Vec::new(),
    };
    let clusters = rng.random_range(cfg.clusters_min..=cfg.clusters_max);
    let templates = catalog::furniture(kind);
    let mut counts = vec![0usize; templates.len()];
    let mut template_of = Vec::new();
    for i in 0..clusters {
        // The first cluster is the kind's main piece (desk, counter, coffee table, bench).
        let t = if i == 0 {
            0
        } else {
            rng.random_range(0..templates.len())
        };
        if templates[t].class == "couch" && counts[t] > 0 {
            continue;
        }
        if place_furniture(rng, &mut d, &templates[t], counts[t] + 1, cfg) {
            counts[t] += 1;
            template_of.push(t);
        }
    }
    let supports = d.objects.len();
    if supports < cfg.clusters_min {
        return None;
    }
    let mut chairs = 0;
    for (s, &t) in template_of.iter().enumerate() {
        if !templates[t].chairs {
            continue;
        }
        for p in [0.6, 0.3] {
            if rng.random::<f32>() < p && place_chair(rng, &mut d, s, chairs + 1) {
                chairs += 1;
            }
        }
    }
    d.support = vec![None; d.objects.len()];
    d.start = draw_start(rng, &d, cfg, robot_radius)?;
    place_items(rng, &mut d, kind, cfg, supports);
    Some(d)
}

fn draw_room(rng: &mut Pcg64, kind: Kind, cfg: &SceneGenConfig) -> Room {
    let (lo, hi) = (cfg.room_min_m, cfg.room_max_m);
    let span = hi - lo;
    // Kitchens run small, labs large; offices and living rooms take the whole range.
    let range = match kind {
        Kind::Kitchen => (lo, lo + 0.6 * span),
        Kind::Lab => (lo + 0.3 * span, hi),
        Kind::Office | Kind::Living => (lo, hi),
    };
    let (w, d) = (mm(uniform(rng, range)), mm(uniform(rng, range)));
    let min = Vec2::new(mm(-w * 0.5), mm(-d * 0.5));
    Room {
        min,
        max: min + Vec2::new(w, d),
        height: mm(uniform(rng, (2.5, 2.8))),
    }
}

/// A partition from one wall, 45–65 % across the room, at 35–65 % of the other side.
fn draw_partition(rng: &mut Pcg64, room: &Room, cfg: &SceneGenConfig) -> Vec<Partition> {
    let size = room.max - room.min;
    if size.min_element() < cfg.partition_min_side_m
        || rng.random::<f32>() >= cfg.partition_probability
    {
        return Vec::new();
    }
    let across_x = rng.random::<bool>(); // the partition runs along y, at some x
    let from_min = rng.random::<bool>();
    let (axis, other) = if across_x { (0, 1) } else { (1, 0) };
    let at = room.min[axis] + size[axis] * uniform(rng, (0.35, 0.65));
    let len = size[other] * uniform(rng, (0.45, 0.65));
    let mid = if from_min {
        room.min[other] + len * 0.5
    } else {
        room.max[other] - len * 0.5
    };
    let mut center = Vec2::ZERO;
    center[axis] = at;
    center[other] = mid;
    let mut ext = Vec2::splat(0.1);
    ext[other] = len;
    vec![Partition {
        name: "partition_1".into(),
        center: Vec2::new(mm(center.x), mm(center.y)),
        size: Vec2::new(mm(ext.x), mm(ext.y)),
        yaw: 0.0,
    }]
}

/// Clearance (metres) from a footprint to every obstacle already placed.
fn clearance(d: &Draft, fp: (Vec2, Vec2, f32), skip: Option<usize>) -> f32 {
    let objects = d
        .objects
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != skip)
        .map(|(_, o)| footprint_distance(fp, footprint_of(o)));
    let parts = d
        .partitions
        .iter()
        .map(|p| footprint_distance(fp, partition_footprint(p)));
    objects.chain(parts).fold(f32::INFINITY, f32::min)
}

fn place_furniture(
    rng: &mut Pcg64,
    d: &mut Draft,
    t: &Furniture,
    number: usize,
    cfg: &SceneGenConfig,
) -> bool {
    let room = d.room;
    for _ in 0..40 {
        let (long, short, h) = (
            uniform(rng, t.dims.length),
            uniform(rng, t.dims.width),
            uniform(rng, t.dims.height),
        );
        let (center, yaw) = match t.placement {
            Placement::Wall => {
                let wall = rng.random_range(0..4);
                // Walls 0/1: y = min/max (long side along x); 2/3: x = min/max (along y).
                let along_x = wall < 2;
                let (axis, other) = if along_x { (0, 1) } else { (1, 0) };
                let (lo, hi) = (
                    room.min[axis] + long * 0.5 + 0.05,
                    room.max[axis] - long * 0.5 - 0.05,
                );
                if hi <= lo {
                    continue;
                }
                let mut c = Vec2::ZERO;
                c[axis] = rng.random_range(lo..hi);
                c[other] = if wall % 2 == 0 {
                    room.min[other] + short * 0.5 + WALL_GAP
                } else {
                    room.max[other] - short * 0.5 - WALL_GAP
                };
                (c, if along_x { 0.0 } else { FRAC_PI_2 })
            }
            Placement::Free => {
                let quarter = rng.random_range(0..2) as f32 * FRAC_PI_2;
                let jitter = if rng.random::<bool>() {
                    uniform(rng, (-0.3, 0.3))
                } else {
                    0.0
                };
                let r = 0.5 * (long * long + short * short).sqrt() + cfg.passage_m;
                let (lo, hi) = (room.min + r, room.max - r);
                if hi.x <= lo.x || hi.y <= lo.y {
                    continue;
                }
                let c = Vec2::new(rng.random_range(lo.x..hi.x), rng.random_range(lo.y..hi.y));
                (c, quarter + jitter)
            }
        };
        let fp = (center, Vec2::new(long, short) * 0.5, yaw);
        if wall_distance(&room, fp) < 0.0 || clearance(d, fp, None) < cfg.passage_m {
            continue;
        }
        d.objects.push(make_object(
            format!("{}_{number}", t.label),
            t.class,
            center.extend(h * 0.5),
            Vec3::new(long, short, h),
            yaw,
            Shape::Box,
            Material::Default,
        ));
        return true;
    }
    false
}

/// A chair at a long side of support `s` that faces the room.
fn place_chair(rng: &mut Pcg64, d: &mut Draft, s: usize, number: usize) -> bool {
    let table = d.objects[s].clone();
    let (sin, cos) = table.yaw.sin_cos();
    let (along, across) = (Vec2::new(cos, sin), Vec2::new(-sin, cos));
    for _ in 0..10 {
        let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let (w, depth, h) = (
            uniform(rng, CHAIR.dims.length),
            uniform(rng, CHAIR.dims.width),
            uniform(rng, CHAIR.dims.height),
        );
        let gap = uniform(rng, (0.05, 0.25));
        let slide = uniform(rng, (-0.3, 0.3)) * table.size.x;
        let c = table.center.truncate()
            + across * side * (table.size.y * 0.5 + gap + depth * 0.5)
            + along * slide;
        let yaw = table.yaw + uniform(rng, (-0.4, 0.4));
        let fp = (c, Vec2::new(w, depth) * 0.5, yaw);
        if wall_distance(&d.room, fp) < 0.05 || clearance(d, fp, None) < 0.03 {
            continue;
        }
        d.objects.push(make_object(
            format!("chair_{number}"),
            CHAIR.class,
            c.extend(h * 0.5),
            Vec3::new(w, depth, h),
            yaw,
            Shape::Box,
            Material::Default,
        ));
        return true;
    }
    false
}

/// A free start pose with `start_clearance_m` around the robot, facing the first cluster or
/// a random direction.
pub(crate) fn draw_start(
    rng: &mut Pcg64,
    d: &Draft,
    cfg: &SceneGenConfig,
    robot_radius: f32,
) -> Option<[f32; 3]> {
    let need = robot_radius + cfg.start_clearance_m;
    for _ in 0..200 {
        let (lo, hi) = (d.room.min + need, d.room.max - need);
        if hi.x <= lo.x || hi.y <= lo.y {
            return None;
        }
        let p = Vec2::new(rng.random_range(lo.x..hi.x), rng.random_range(lo.y..hi.y));
        let p = Vec2::new(mm(p.x), mm(p.y));
        let free = d.objects.iter().all(|o| o.footprint_distance(p) >= need)
            && d.partitions.iter().all(|w| w.footprint_distance(p) >= need);
        if !free {
            continue;
        }
        let yaw = if rng.random::<f32>() < cfg.start_faces_cluster {
            let to = d.objects[0].center.truncate() - p;
            to.y.atan2(to.x) + uniform(rng, (-0.35, 0.35))
        } else {
            uniform(rng, (-PI, PI))
        };
        return Some([p.x, p.y, (geom::wrap_angle(yaw) * 1e4).round() / 1e4]);
    }
    None
}

/// An object's size: one of the class's size families, each as likely, then every axis uniform
/// in the family's range (a cylinder's width is its length, the diameter); snapped to mm.
fn draw_item(rng: &mut Pcg64, item: &Item) -> (Vec3, Material) {
    let family = match item.sizes {
        [one] => one,
        many => &many[rng.random_range(0..many.len())],
    };
    let length = uniform(rng, family.length);
    let width = match item.shape {
        Shape::Cylinder => length,
        Shape::Box => uniform(rng, family.width),
    };
    let size = Vec3::new(mm(length), mm(width), mm(uniform(rng, family.height)));
    (size, weighted(rng, item.materials))
}

/// Place one object of `item` on support `s`, not touching the objects already there.
fn place_on(rng: &mut Pcg64, d: &mut Draft, s: usize, item: &Item, name: String) -> bool {
    let sup = d.objects[s].clone();
    let (size, material) = draw_item(rng, item);
    let half = sup.size.truncate() * 0.5 - EDGE_INSET;
    for _ in 0..12 {
        let rel = match item.shape {
            Shape::Cylinder => 0.0,
            Shape::Box if rng.random::<bool>() => uniform(rng, (-PI, PI)),
            Shape::Box => rng.random_range(0..4) as f32 * FRAC_PI_2 + uniform(rng, (-0.2, 0.2)),
        };
        let (sr, cr) = rel.sin_cos();
        let h = size.truncate() * 0.5;
        let ext = Vec2::new(
            cr.abs() * h.x + sr.abs() * h.y,
            sr.abs() * h.x + cr.abs() * h.y,
        );
        let room = half - ext;
        if room.x < 0.0 || room.y < 0.0 {
            return false;
        }
        let local = Vec2::new(
            uniform(rng, (-room.x, room.x)),
            uniform(rng, (-room.y, room.y)),
        );
        let (ss, cs) = sup.yaw.sin_cos();
        let world = sup.center.truncate()
            + Vec2::new(cs * local.x - ss * local.y, ss * local.x + cs * local.y);
        let yaw = match item.shape {
            Shape::Cylinder => 0.0,
            Shape::Box => geom::wrap_angle(sup.yaw + rel),
        };
        let z = sup.center.z + sup.size.z * 0.5 + size.z * 0.5;
        let o = make_object(
            name.clone(),
            item.class,
            world.extend(z),
            size,
            yaw,
            item.shape,
            material,
        );
        let (pose, shape) = (o.pose(), o.shape_shrunk(-OBJECT_GAP));
        let clear = d
            .objects
            .iter()
            .zip(&d.support)
            .filter(|(_, sp)| **sp == Some(s))
            .all(|(other, _)| {
                !parry3d::query::intersection_test(
                    &pose,
                    shape.as_shape(),
                    &other.pose(),
                    other.shape_shrunk(-OBJECT_GAP).as_shape(),
                )
                .map_or(true, |i| i.intersecting)
            });
        if clear {
            d.objects.push(o);
            d.support.push(Some(s));
            return true;
        }
    }
    false
}

/// Foreground objects: one on every support first, then more on supports drawn by top area;
/// sometimes one on a chair.
fn place_items(rng: &mut Pcg64, d: &mut Draft, kind: Kind, cfg: &SceneGenConfig, supports: usize) {
    let want = rng.random_range(cfg.objects_min..=cfg.objects_max);
    let pool = catalog::items(kind);
    let mut per_class = [0usize; catalog::ITEMS.len()];
    let mut place = |rng: &mut Pcg64, d: &mut Draft, s: usize| {
        for _ in 0..6 {
            let i = weighted(rng, pool);
            let item = &catalog::ITEMS[i];
            let name = format!("{}_{}", item.class.replace(' ', "_"), per_class[i] + 1);
            if place_on(rng, d, s, item, name) {
                per_class[i] += 1;
                return true;
            }
        }
        false
    };
    for s in 0..supports {
        place(rng, d, s);
    }
    let area = |d: &Draft, s: usize| d.objects[s].size.x * d.objects[s].size.y;
    let cap: Vec<usize> = (0..supports)
        .map(|s| ((area(d, s) * MAX_DENSITY) as usize).max(1))
        .collect();
    let mut failures = 0;
    while d.objects.len() - d.support.iter().filter(|s| s.is_none()).count() < want && failures < 40
    {
        let open: Vec<(usize, u32)> = (0..supports)
            .filter(|&s| d.support.iter().filter(|x| **x == Some(s)).count() < cap[s])
            .map(|s| (s, (area(d, s) * 100.0).ceil() as u32))
            .collect();
        if open.is_empty() {
            break;
        }
        let s = weighted(rng, &open);
        if !place(rng, d, s) {
            failures += 1;
        }
    }
    let chairs: Vec<usize> = (supports..d.support.len())
        .filter(|&i| d.support[i].is_none() && d.objects[i].class == "chair")
        .collect();
    for c in chairs {
        if supports < cfg.clusters_max && rng.random::<f32>() < 0.25 {
            place(rng, d, c);
            break;
        }
    }
}
