//! The shared-memory messages as `foxglove::messages::*` and [`super::messages`] values, built
//! on the recorder's writer thread (through [`super::SceneConverter`]) and by `vpsom replay` to compare
//! what it recomputes with a trace. Rotations with glam; the camera's optical axes are
//! `geom::optical_rotation_f64`.

use super::messages as own;
use super::{MountGeometry, TruthBox};
use foxglove::bytes::Bytes;
use foxglove::messages::{
    CameraCalibration, Color, CubePrimitive, Duration, FrameTransform, FrameTransforms,
    ImageAnnotations, KeyValuePair, LinePrimitive, Point2, Point3, PointsAnnotation, Pose,
    PosesInFrame, Quaternion, RawImage, SceneEntity, SceneEntityDeletion, SceneUpdate,
    TextAnnotation, TextPrimitive, Timestamp, Vector3, line_primitive, points_annotation,
    scene_entity_deletion,
};
use glam::{DQuat, DVec3};
use runtime::recorder::convert::time;
use shm_types::{
    DepthFrame, Detections, MapObject, NavGoal, NeckGoal, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, class_name, decision_kind, frame_outcome, goal_kind,
    planner_state,
};

// ---- small helpers --------------------------------------------------------------------------

fn vec3(v: DVec3) -> Vector3 {
    Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn point(v: DVec3) -> Point3 {
    Point3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn quat(q: DQuat) -> Quaternion {
    Quaternion {
        x: q.x,
        y: q.y,
        z: q.z,
        w: q.w,
    }
}

fn pose(p: DVec3, q: DQuat) -> Pose {
    Pose {
        position: Some(vec3(p)),
        orientation: Some(quat(q)),
    }
}

fn f3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0].into(), a[1].into(), a[2].into())
}

/// Axes `(right, down, forward)` of an optical camera whose forward axis has yaw `yaw` and is
/// pitched down by `pitch`: the columns of [`geom::optical_rotation_f64`].
pub fn optical_axes(yaw: f64, pitch: f64) -> (DVec3, DVec3, DVec3) {
    let m = geom::optical_rotation_f64(yaw, pitch);
    (m.x_axis, m.y_axis, m.z_axis)
}

fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

/// A stable, well-spread colour per class id (hue steps of the golden ratio).
pub fn class_color(class_id: u16, a: f64) -> Color {
    let h6 = (f64::from(class_id) * 0.618_033_988_75).rem_euclid(1.0) * 6.0;
    let (s, v) = (0.75, 0.95);
    let c = v * s;
    let x = c * (1.0 - ((h6 % 2.0) - 1.0).abs());
    let (r, g, b) = match h6 as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    rgba(r + m, g + m, b + m, a)
}

/// Red (t = 0) to green (t = 1).
pub fn score_color(t: f64, a: f64) -> Color {
    let t = t.clamp(0.0, 1.0);
    rgba(1.0 - t, t, 0.15, a)
}

fn kv(key: &str, value: impl ToString) -> KeyValuePair {
    KeyValuePair {
        key: key.into(),
        value: value.to_string(),
    }
}

/// A scene update that first deletes everything previously shown on the topic.
fn replace_all(t: Timestamp, entities: Vec<SceneEntity>) -> SceneUpdate {
    SceneUpdate {
        deletions: vec![SceneEntityDeletion {
            timestamp: Some(t),
            r#type: scene_entity_deletion::Type::All as i32,
            id: String::new(),
        }],
        entities,
    }
}

fn entity(t: Timestamp, id: String) -> SceneEntity {
    SceneEntity {
        timestamp: Some(t),
        frame_id: "world".into(),
        id,
        lifetime: Some(Duration::new(0, 0)),
        ..Default::default()
    }
}

// ---- Foxglove well-known messages -----------------------------------------------------------

/// `RawImage` (`16UC1`, little-endian mm) of `f` decimated by `k` in x and y.
pub fn depth_image(f: &DepthFrame, k: u32) -> RawImage {
    let (w, h) = (f.width as usize, f.height as usize);
    let k = k.max(1) as usize;
    let (dw, dh) = (w.div_ceil(k), h.div_ceil(k));
    let mut data = Vec::with_capacity(dw * dh * 2);
    for row in f.pixels().chunks_exact(w.max(1)).step_by(k).take(dh) {
        for v in row.iter().step_by(k) {
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    RawImage {
        timestamp: Some(time(f.header.sim_time_ns)),
        frame_id: "camera".into(),
        width: dw as u32,
        height: dh as u32,
        encoding: "16UC1".into(),
        step: (dw * 2) as u32,
        data: Bytes::from(data),
    }
}

/// `CameraCalibration` of the image [`depth_image`] makes of `f` (intrinsics scaled by `1/k`).
pub fn calibration(f: &DepthFrame, k: u32) -> CameraCalibration {
    let i = &f.intrinsics;
    let s = 1.0 / f64::from(k.max(1));
    let (fx, fy) = (f64::from(i.fx) * s, f64::from(i.fy) * s);
    let (cx, cy) = (f64::from(i.cx) * s, f64::from(i.cy) * s);
    CameraCalibration {
        timestamp: Some(time(f.header.sim_time_ns)),
        frame_id: "camera".into(),
        width: f.width.div_ceil(k.max(1)),
        height: f.height.div_ceil(k.max(1)),
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        k: vec![fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: vec![fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    }
}

/// `ImageAnnotations` of the detections' boxes with class and score labels, on the depth
/// image's frame and timestamp (`time_ns`), in the image decimated by `k`.
pub fn annotations(d: &Detections, time_ns: u64, k: u32) -> ImageAnnotations {
    let t = time(time_ns);
    let s = 1.0 / f64::from(k.max(1));
    let mut a = ImageAnnotations {
        timestamp: Some(t),
        ..Default::default()
    };
    for det in d.detections() {
        let [x0, y0, x1, y1] = det.bbox.map(|v| f64::from(v) * s);
        let color = class_color(det.class_id, 1.0);
        let p = |x, y| Point2 { x, y };
        a.points.push(PointsAnnotation {
            timestamp: Some(t),
            r#type: points_annotation::Type::LineLoop as i32,
            points: vec![p(x0, y0), p(x1, y0), p(x1, y1), p(x0, y1)],
            outline_color: Some(color),
            thickness: 2.0,
            ..Default::default()
        });
        a.texts.push(TextAnnotation {
            timestamp: Some(t),
            position: Some(p(x0, (y0 - 2.0).max(0.0))),
            text: format!("{} {:.2}", class_name(det.class_id), det.score),
            font_size: 12.0,
            text_color: Some(rgba(1.0, 1.0, 1.0, 1.0)),
            background_color: Some(Color { a: 0.6, ..color }),
            ..Default::default()
        });
    }
    a
}

/// `FrameTransforms` world→base→neck→camera (or world→`base_true` alone for truth).
pub fn transforms(s: &RobotState, mount: &MountGeometry, truth: bool) -> FrameTransforms {
    let t = Some(time(s.header.sim_time_ns));
    let [x, y, yaw] = s.base_pose.map(f64::from);
    let tf = |parent: &str, child: &str, p: DVec3, q: DQuat| FrameTransform {
        timestamp: t,
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: Some(vec3(p)),
        rotation: Some(quat(q)),
    };
    let base = if truth { "base_true" } else { "base" };
    let mut transforms = vec![tf(
        "world",
        base,
        DVec3::new(x, y, 0.0),
        DQuat::from_rotation_z(yaw),
    )];
    if !truth {
        let neck_from_camera = geom::optical_rotation_f64(0.0, s.neck_pitch.into());
        transforms.push(tf(
            "base",
            "neck",
            DVec3::new(mount.forward_offset.into(), 0.0, mount.height.into()),
            DQuat::from_rotation_z(s.neck_yaw.into()),
        ));
        transforms.push(tf(
            "neck",
            "camera",
            DVec3::ZERO,
            DQuat::from_mat3(&neck_from_camera),
        ));
    }
    FrameTransforms { transforms }
}

/// `PosesInFrame` of base poses `[x, y, yaw]` in `world`.
pub fn trajectory(time_ns: u64, poses: &[[f32; 3]]) -> PosesInFrame {
    PosesInFrame {
        timestamp: Some(time(time_ns)),
        frame_id: "world".into(),
        poses: poses
            .iter()
            .map(|p| {
                pose(
                    DVec3::new(p[0].into(), p[1].into(), 0.0),
                    DQuat::from_rotation_z(p[2].into()),
                )
            })
            .collect(),
    }
}

fn cuboid_entity(
    t: Timestamp,
    id: String,
    (center, size, yaw): ([f32; 3], [f32; 3], f32),
    color: Color,
    label: String,
) -> SceneEntity {
    let c = f3(center);
    let mut e = entity(t, id);
    e.cubes.push(CubePrimitive {
        pose: Some(pose(c, DQuat::from_rotation_z(yaw.into()))),
        size: Some(vec3(f3(size))),
        color: Some(color),
    });
    e.texts.push(TextPrimitive {
        pose: Some(pose(
            c + DVec3::Z * (f64::from(size[2]) * 0.5 + 0.08),
            DQuat::IDENTITY,
        )),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Some(rgba(1.0, 1.0, 1.0, 1.0)),
        text: label,
    });
    e
}

/// `SceneUpdate` of the ground-truth cuboids.
pub fn truth_objects(boxes: &[TruthBox]) -> SceneUpdate {
    let t = time(0);
    let entities = boxes
        .iter()
        .map(|b| {
            let cid = shm_types::class_id(&b.class).unwrap_or(0);
            let mut e = cuboid_entity(
                t,
                format!("truth/{}", b.name),
                (b.center, b.size, b.yaw),
                class_color(cid, 0.25),
                format!("{} ({})", b.name, b.class),
            );
            e.metadata.push(kv("class", &b.class));
            e
        })
        .collect();
    replace_all(t, entities)
}

fn map_entity(t: Timestamp, o: &MapObject) -> SceneEntity {
    let class = class_name(o.class_id);
    let alpha = if o.is_background() { 0.35 } else { 0.6 };
    let mut e = cuboid_entity(
        t,
        format!("obj/{}", o.id),
        (o.center, o.size, o.yaw),
        class_color(o.class_id, alpha),
        format!(
            "{class} #{} H={:.2}{}",
            o.id,
            o.h_sopm,
            if o.is_complete() { " ✓" } else { "" }
        ),
    );
    e.metadata.extend([
        kv("class", class),
        kv("h_sopm", format!("{:.4}", o.h_sopm)),
        kv("complete", o.is_complete()),
        kv("background", o.is_background()),
        kv("cluster_id", o.cluster_id),
        kv("observations", o.observations),
    ]);
    e
}

/// `SceneUpdate` of the estimated cuboids (replaces the previous map).
pub fn map_objects(m: &ObjectMap) -> SceneUpdate {
    let t = time(m.header.sim_time_ns);
    replace_all(t, m.objects().iter().map(|o| map_entity(t, o)).collect())
}

/// `SceneUpdate` of the candidate frusta of a decision, coloured by F(v) (red = lowest,
/// green = highest of the decision); the chosen view is drawn thick and blue.
pub fn frusta(d: &PlannerDecision, mount: &MountGeometry, length: f64) -> SceneUpdate {
    let t = time(d.header.sim_time_ns);
    let cands = d.candidates();
    let (lo, hi) = cands
        .iter()
        .filter(|c| c.dropped == 0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c.value.into()), hi.max(c.value.into()))
        });
    let th = (f64::from(mount.hfov_deg).to_radians() * 0.5).tan();
    let tv = (f64::from(mount.vfov_deg).to_radians() * 0.5).tan();
    let prefix = if d.kind == decision_kind::GBV {
        "gbv"
    } else {
        "lbv"
    };
    let entities = cands
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let p = f3(c.position);
            let (r, dn, f) = optical_axes(c.yaw.into(), c.pitch.into());
            let corner = |sx: f64, sy: f64| p + (f + r * (sx * th) + dn * (sy * tv)) * length;
            let k = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            let mut points = Vec::with_capacity(16);
            for j in 0..4 {
                points.extend([p, k[j], k[j], k[(j + 1) % 4]].map(point));
            }
            let chosen = c.chosen != 0;
            let color = if chosen {
                rgba(0.1, 0.4, 1.0, 1.0)
            } else if c.dropped != 0 {
                rgba(0.5, 0.5, 0.5, 0.3)
            } else if hi > lo {
                score_color((f64::from(c.value) - lo) / (hi - lo), 0.8)
            } else {
                score_color(1.0, 0.8)
            };
            let mut e = entity(t, format!("{prefix}/{i}"));
            e.lines.push(LinePrimitive {
                r#type: line_primitive::Type::LineList as i32,
                pose: Some(pose(DVec3::ZERO, DQuat::IDENTITY)),
                thickness: if chosen { 6.0 } else { 1.5 },
                scale_invariant: true,
                points,
                color: Some(color),
                ..Default::default()
            });
            e.metadata
                .extend([kv("value", format!("{:.4}", c.value)), kv("chosen", chosen)]);
            e
        })
        .collect();
    replace_all(t, entities)
}

// ---- our own messages -----------------------------------------------------------------------

/// [`own::PlannerDecision`] with every candidate and F(v) term.
pub fn decision(d: &PlannerDecision) -> own::PlannerDecision {
    let cands = d.candidates();
    own::PlannerDecision {
        seq: d.header.seq,
        stamp_ns: d.header.stamp_ns,
        sim_time_ns: d.header.sim_time_ns,
        kind: if d.kind == decision_kind::GBV {
            "gbv"
        } else {
            "lbv"
        }
        .into(),
        state: match d.state {
            planner_state::TERMINATED => "terminated",
            planner_state::NO_CANDIDATES => "no_candidates",
            _ => "running",
        }
        .into(),
        map_seq: d.map_seq,
        eval_ns: d.eval_ns,
        cluster_id: d.cluster_id,
        evaluated: d.evaluated,
        chosen_value: cands
            .iter()
            .find(|c| c.chosen != 0)
            .map_or(0.0, |c| c.value),
        candidates: cands
            .iter()
            .map(|c| own::Candidate {
                position: c.position.to_vec(),
                yaw: c.yaw,
                pitch: c.pitch,
                value: c.value,
                f_a: c.f_a,
                f_c: c.f_c,
                h_sopm: c.h_sopm,
                h_iou: c.h_iou,
                cos_theta_sopm: c.cos_theta_sopm,
                c_asso: c.c_asso,
                n_cp: c.n_cp,
                cos_theta_c: c.cos_theta_c,
                objects_in_view: c.objects_in_view.into(),
                chosen: c.chosen != 0,
                dropped: c.dropped != 0,
            })
            .collect(),
    }
}

/// [`own::MapMeta`].
pub fn map_meta(m: &ObjectMap) -> own::MapMeta {
    own::MapMeta {
        seq: m.header.seq,
        stamp_ns: m.header.stamp_ns,
        sim_time_ns: m.header.sim_time_ns,
        last_frame_seq: m.last_frame_seq,
        last_frame_stamp_ns: m.last_frame_stamp_ns,
        count: m.count,
        frames_integrated: m.frames_integrated,
        frames_rejected: m.frames_rejected,
        frames_unmatched: m.frames_unmatched,
        receipt_count: m.receipt_count,
        receipts: m
            .receipts()
            .iter()
            .map(|r| own::FrameReceipt {
                frame_seq: r.frame_seq,
                state_seq: r.state_seq,
                outcome: frame_outcome_name(r.outcome).into(),
            })
            .collect(),
    }
}

/// The name of a [`shm_types::frame_outcome`] value in traces.
pub fn frame_outcome_name(outcome: u32) -> &'static str {
    match outcome {
        frame_outcome::INTEGRATED => "integrated",
        frame_outcome::SKIPPED_LOST => "skipped_lost",
        frame_outcome::NO_DETECTIONS => "no_detections",
        frame_outcome::REFUSED => "refused",
        _ => "invalid",
    }
}

/// [`own::NavGoal`].
pub fn nav_goal(g: &NavGoal) -> own::NavGoal {
    own::NavGoal {
        seq: g.header.seq,
        stamp_ns: g.header.stamp_ns,
        sim_time_ns: g.header.sim_time_ns,
        goal_id: g.goal_id,
        x: g.pose[0],
        y: g.pose[1],
        yaw: g.pose[2],
        score: g.score,
        cluster_id: g.cluster_id,
        kind: match g.kind {
            goal_kind::COVERAGE => "coverage",
            goal_kind::FRONTIER => "frontier",
            goal_kind::RECOVERY => "recovery",
            _ => "gbv",
        }
        .into(),
    }
}

/// [`own::NeckGoal`].
pub fn neck_goal(g: &NeckGoal) -> own::NeckGoal {
    own::NeckGoal {
        seq: g.header.seq,
        stamp_ns: g.header.stamp_ns,
        sim_time_ns: g.header.sim_time_ns,
        map_seq: g.map_seq,
        frame_stamp_ns: g.frame_stamp_ns,
        yaw: g.yaw,
        pitch: g.pitch,
        score: g.score,
        round_done: g.round_done != 0,
        state_seq: g.state_seq,
        nav_seq: g.nav_seq,
        explore_seq: g.explore_seq,
    }
}

/// [`own::RobotStateRaw`].
pub fn state_raw(s: &RobotState) -> own::RobotStateRaw {
    own::RobotStateRaw {
        seq: s.header.seq,
        stamp_ns: s.header.stamp_ns,
        sim_time_ns: s.header.sim_time_ns,
        nav_goal_id: s.nav_goal_id,
        base_pose: s.base_pose.to_vec(),
        neck_yaw: s.neck_yaw,
        neck_pitch: s.neck_pitch,
        odom_cov: s.odom_cov.to_vec(),
        speed: s.speed,
        distance_m: s.distance_m,
        localization_ok: s.localization_ok.into(),
        nav_status: s.nav_status.into(),
        localization_failures: s.localization_failures,
    }
}

/// [`own::DetectionsRaw`].
pub fn detections_raw(d: &Detections) -> own::DetectionsRaw {
    let labels = if d.masks != 0 {
        let n = (d.width * d.height) as usize;
        Bytes::copy_from_slice(&d.labels[..n.min(d.labels.len())])
    } else {
        Bytes::new()
    };
    own::DetectionsRaw {
        seq: d.header.seq,
        stamp_ns: d.header.stamp_ns,
        sim_time_ns: d.header.sim_time_ns,
        frame_seq: d.frame_seq,
        width: d.width,
        height: d.height,
        masks: d.masks,
        items: d
            .detections()
            .iter()
            .map(|x| own::DetectionRaw {
                class_id: x.class_id.into(),
                label: x.label.into(),
                score: x.score,
                bbox: x.bbox.map(u32::from).to_vec(),
                mask_pixels: x.mask_pixels,
            })
            .collect(),
        labels,
    }
}

/// [`own::DepthMeta`] of `f` whose pixels are written decimated by `k`.
pub fn depth_meta(f: &DepthFrame, k: u32) -> own::DepthMeta {
    let i = &f.intrinsics;
    let p = &f.camera_pose;
    own::DepthMeta {
        seq: f.header.seq,
        stamp_ns: f.header.stamp_ns,
        sim_time_ns: f.header.sim_time_ns,
        width: f.width,
        height: f.height,
        intrinsics: vec![i.fx, i.fy, i.cx, i.cy, i.min_range, i.max_range],
        camera_pose: p.translation.iter().chain(&p.rotation).copied().collect(),
        decimation: k.max(1),
    }
}

/// [`own::OccupancyGridRaw`].
pub fn grid_raw(g: &OccupancyGrid) -> own::OccupancyGridRaw {
    let n = (g.width as usize * g.height as usize).min(g.cells.len());
    own::OccupancyGridRaw {
        seq: g.header.seq,
        stamp_ns: g.header.stamp_ns,
        sim_time_ns: g.header.sim_time_ns,
        origin: g.origin.to_vec(),
        resolution: g.resolution,
        width: g.width,
        height: g.height,
        cells: Bytes::copy_from_slice(&g.cells[..n]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) {
        assert!((a - b).length() < 1e-9, "{a:?} vs {b:?}");
    }

    fn v(p: &Option<Vector3>) -> DVec3 {
        let p = p.unwrap();
        DVec3::new(p.x, p.y, p.z)
    }

    fn q(p: &Option<Quaternion>) -> DQuat {
        let p = p.unwrap();
        DQuat::from_xyzw(p.x, p.y, p.z, p.w)
    }

    #[test]
    fn optical_camera_looks_along_yaw_and_down_by_pitch() {
        // Pitch 90° down: forward is -z, right is (sin yaw, -cos yaw, 0).
        let (r, d, f) = optical_axes(0.0, std::f64::consts::FRAC_PI_2);
        close(f, DVec3::new(0.0, 0.0, -1.0));
        close(r, DVec3::new(0.0, -1.0, 0.0));
        close(d, DVec3::new(-1.0, 0.0, 0.0));
    }

    #[test]
    fn depth_is_decimated_row_major_little_endian() {
        let mut f = shm_types::boxed_zeroed::<DepthFrame>();
        f.width = 5;
        f.height = 3;
        for (i, p) in f.pixels_mut().iter_mut().enumerate() {
            *p = i as u16 * 300;
        }
        f.header.sim_time_ns = 2_500_000_000;
        let img = depth_image(&f, 2);
        // Kept: rows 0, 2 × columns 0, 2, 4 → pixels 0, 2, 4, 10, 12, 14.
        let expect: Vec<u8> = [0u16, 2, 4, 10, 12, 14]
            .iter()
            .flat_map(|i| (i * 300).to_le_bytes())
            .collect();
        assert_eq!(&img.data[..], &expect[..]);
        assert_eq!((img.width, img.height, img.step), (3, 2, 6));
        assert_eq!(img.timestamp, Some(Timestamp::new(2, 500_000_000)));
        // The calibration describes the decimated image: 5×3 at k = 2 is 3×2, f and c halved.
        f.intrinsics.fx = 100.0;
        f.intrinsics.cx = 2.0;
        let c = calibration(&f, 2);
        assert_eq!((c.width, c.height), (3, 2));
        assert_eq!((c.k[0], c.k[2]), (50.0, 1.0));
    }

    #[test]
    fn tf_chain_composes_to_the_camera_pose_of_the_mount() {
        // world_from_camera = world_from_base · base_from_neck · neck_from_camera must equal the
        // mount formula: neck at base + forward_offset along yaw at mount height, optical axes of
        // yaw + neck_yaw and the pitch.
        let mount = MountGeometry {
            height: 1.5,
            forward_offset: 0.25,
            ..Default::default()
        };
        let s = RobotState {
            base_pose: [1.0, -2.0, 0.5],
            neck_yaw: 0.8,
            neck_pitch: 0.45,
            ..Default::default()
        };
        let tfs = transforms(&s, &mount, false).transforms;
        let names: Vec<_> = tfs
            .iter()
            .map(|t| format!("{}->{}", t.parent_frame_id, t.child_frame_id))
            .collect();
        assert_eq!(names, ["world->base", "base->neck", "neck->camera"]);
        let apply = |i: usize, p: DVec3| q(&tfs[i].rotation) * p + v(&tfs[i].translation);
        let chain = |p: DVec3| apply(0, apply(1, apply(2, p)));
        let origin = chain(DVec3::ZERO);
        let yaw = 0.5f64;
        close(
            origin,
            DVec3::new(1.0 + 0.25 * yaw.cos(), -2.0 + 0.25 * yaw.sin(), 1.5),
        );
        let (r, d, f) = optical_axes(0.5 + f64::from(0.8f32), f64::from(0.45f32));
        assert!((chain(DVec3::Z) - origin - f).length() < 1e-6);
        assert!((chain(DVec3::X) - origin - r).length() < 1e-6);
        assert!((chain(DVec3::Y) - origin - d).length() < 1e-6);
    }

    #[test]
    fn annotations_are_boxes_with_class_and_score_on_the_decimated_image() {
        let mut d = shm_types::boxed_zeroed::<Detections>();
        d.count = 1;
        d.items[0].class_id = shm_types::class_id("chair").unwrap();
        d.items[0].score = 0.875;
        d.items[0].bbox = [10, 20, 50, 80];
        let a = annotations(&d, 1_250_000_000, 2);
        assert_eq!(a.timestamp, Some(Timestamp::new(1, 250_000_000)));
        let xy: Vec<(f64, f64)> = a.points[0].points.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(xy, [(5.0, 10.0), (25.0, 10.0), (25.0, 40.0), (5.0, 40.0)]);
        assert_eq!(a.texts[0].text, "chair 0.88");
    }
}
