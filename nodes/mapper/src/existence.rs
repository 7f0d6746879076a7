//! Existence of objects (an addition beyond the paper, `[mapper.extensions] existence`): a
//! log-odds existence per object, as an occupancy cell's, so that false positives leave the map
//! while real objects missed now and then survive (cf. EAO-SLAM's object pruning).
//!
//! Every frame, after association, each object is
//! - **hit** when a detection was associated with it: `l += ln(p_detect / p_false)`;
//! - **missed** when it should have been seen and was not: `l += ln((1 − p_detect) / (1 − p_false))`.
//!   It should have been seen when its cuboid projects into the frame (at least `min_in_frame`
//!   of its projected box inside the image, the box at least `min_box_px` pixels), its centre is
//!   in front of the camera within `max_range`, and it is not occluded: on a grid of points on
//!   the cuboid faces turned towards the camera, at least `min_visible` of those with valid depth
//!   are not behind the frame's depth by more than `occlusion_tolerance` (a cuboid face lies at
//!   or in front of the object's surface, so the frame seeing the object or what is behind it
//!   counts as visible). It is not counted missed when a detection of a compatible class that
//!   went elsewhere (or was refused) overlaps its projected box (IoU ≥ `overlap_iou`, or the
//!   intersection ≥ `overlap_min` of the smaller box: a thin object's jittered box): nearby
//!   objects merged into one box, a jittered box failing the test. With `[mapper.extensions]
//!   cross_class`, a detection of any foreground class overlapping it by `cross_class_iou` also
//!   explains the miss (a label confusion outside the look-alike groups).
//!
//! **Detectability** (`[mapper.extensions] detectability`, beyond the above): a miss weighs
//! `ln((1 − p) / (1 − p_false))` with `p` the detector's expected recall for the object in this
//! frame — the mapper's own model of its detector ([`recall_at`]: recall against the visible
//! projected box area, i.e. the in-frame area × the unoccluded fraction, from published COCO
//! figures) — so a small, truncated or half-hidden object that the detector often
//! misses loses little, and an object hit from `confirmed_hits` viewpoints is clamped at
//! `confirmed_max_log_odds` instead of `max_log_odds` (a few misses do not undo many hits).
//!
//! A detector's misses are not independent between nearby views (10 Hz frames of one scene, a
//! persistent per-direction failure), so evidence is taken once per viewpoint: an object's `l`
//! changes only when the camera moved `min_view_change` (and, once the object is confirmed,
//! `min_view_change_per_m` × its distance to it: from afar a short step is the same view) or turned
//! `min_view_angle_deg` around the object since its last change. `l` is clamped to `±max_log_odds`; an object below
//! `delete_below` is deleted.

use super::Mapper;
use super::cuboid::Box3;
use geom::{Camera, Cuboid};
use glam::{Affine3A, Mat3, Vec3};
use shm_types::{DepthFrame, Detection, is_background_class};

/// Intersection over union of two pixel boxes `[x0, y0, x1, y1]`.
fn box_iou(a: [f32; 4], b: [f32; 4]) -> f32 {
    let iw = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let ih = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = iw * ih;
    let area = |r: [f32; 4]| (r[2] - r[0]).max(0.0) * (r[3] - r[1]).max(0.0);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// Intersection of two pixel boxes over the smaller one's area (0 when either is empty).
fn box_overlap_min(a: [f32; 4], b: [f32; 4]) -> f32 {
    let iw = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let ih = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let area = |r: [f32; 4]| (r[2] - r[0]).max(0.0) * (r[3] - r[1]).max(0.0);
    let small = area(a).min(area(b));
    if small > 0.0 { iw * ih / small } else { 0.0 }
}

/// Whether a compatible detection's box `det` explains an object's miss: box IoU with the
/// object's projected box `proj` at least `min_iou`, or (with `min_overlap > 0`) the
/// intersection at least `min_overlap` of the smaller box.
fn explains_miss(det: [f32; 4], proj: [f32; 4], min_iou: f32, min_overlap: f32) -> bool {
    box_iou(det, proj) >= min_iou
        || (min_overlap > 0.0 && box_overlap_min(det, proj) >= min_overlap)
}

/// Whether the camera at `cam` is a new viewpoint on an object at `centre` since the one at
/// `last`: it moved at least `step` (`min_view_change`, and for a confirmed object
/// `min_view_change_per_m` × its distance to the object), or the direction from the object to
/// the camera turned by `min_view_angle_deg` (`cos_min` is that angle's cosine). Views from
/// afar that differ by a short step see the object at the same angle and size, where a
/// detector fails the same way again.
fn new_viewpoint(last: Vec3, cam: Vec3, centre: Vec3, step: f32, cos_min: f32) -> bool {
    let (a, b) = (last - centre, cam - centre);
    last.distance(cam) >= step || a.normalize_or_zero().dot(b.normalize_or_zero()) <= cos_min
}

/// How much of an object a frame should have shown.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    /// Projected box area inside the image times the unoccluded fraction, pixels.
    visible_px: f32,
}

/// The detector's recall for an object of visible box area `area_px` (pixels at 640 × 480):
/// piecewise linear in log area through `(areas[i], recall[i])`, clamped outside.
pub fn recall_at(areas: &[f32], recall: &[f32], area_px: f32) -> f32 {
    let (Some(&a0), Some(&r0)) = (areas.first(), recall.first()) else {
        return 0.0;
    };
    if area_px <= a0 {
        return r0;
    }
    for (a, r) in areas.windows(2).zip(recall.windows(2)) {
        if area_px <= a[1] {
            let t = (area_px / a[0]).ln() / (a[1] / a[0]).ln();
            return r[0] + t * (r[1] - r[0]);
        }
    }
    recall.last().copied().unwrap_or(0.0)
}

/// Sample grid per visible face.
const FACE_SAMPLES: usize = 4;

/// Whether the cuboid's camera-facing faces are mostly unoccluded in `frame`: returns `None`
/// when too few samples have a valid depth.
fn unoccluded_fraction(
    b: &Box3,
    frame: &DepthFrame,
    camera: &Camera,
    cam_from_world: &Affine3A,
    cam_pos: Vec3,
    tolerance: f32,
) -> Option<f32> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let depth = frame.pixels();
    let rot = Mat3::from_rotation_z(b.yaw);
    let half = b.size * 0.5;
    let (mut seen, mut total) = (0u32, 0u32);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let normal = rot * n;
            let face_centre = b.center + rot * (n * half);
            if normal.dot(cam_pos - face_centre) <= 0.0 {
                continue;
            }
            let (u_ax, v_ax) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..FACE_SAMPLES {
                for j in 0..FACE_SAMPLES {
                    let f = |k: usize| ((k as f32 + 0.5) / FACE_SAMPLES as f32 * 2.0 - 1.0) * 0.8;
                    let mut l = n * half;
                    l[u_ax] = f(i) * half[u_ax];
                    l[v_ax] = f(j) * half[v_ax];
                    let pc = cam_from_world.transform_point3(b.center + rot * l);
                    let Some(px) = camera.project(pc) else {
                        continue;
                    };
                    if px.x < 0.0 || px.y < 0.0 || px.x >= w as f32 || px.y >= h as f32 {
                        continue;
                    }
                    let d = depth[px.y as usize * w + px.x as usize];
                    if d == 0 {
                        continue;
                    }
                    total += 1;
                    seen += (d as f32 * 1e-3 >= pc.z - tolerance) as u32;
                }
            }
        }
    }
    (total >= 4).then(|| seen as f32 / total as f32)
}

impl Mapper {
    /// Update every object's existence after the frame's associations (objects' `hit` flags)
    /// and delete those below `delete_below`. Returns the number deleted.
    pub(super) fn update_existence(
        &mut self,
        frame: &DepthFrame,
        camera: &Camera,
        pose: &Affine3A,
        dets: &[Detection],
    ) -> u32 {
        let e = self.cfg.existence.clone();
        let detectability = self.cfg.extensions.detectability;
        let hit = (e.p_detect / e.p_false).ln();
        let cam_from_world = pose.inverse();
        let scale = (camera.width * camera.height) as f32 / (640.0 * 480.0);
        let min_px = e.min_box_px * scale;
        let cam_pos: Vec3 = pose.translation.into();
        let cos_min = e.min_view_angle_deg.to_radians().cos();
        let mut deleted = 0;
        let mut k = 0;
        while k < self.objects.len() {
            let o = &self.objects[k];
            let delta = if o.hit {
                hit
            } else if let Some(v) = self.should_see(
                o.class_id,
                &o.cuboid,
                frame,
                camera,
                &cam_from_world,
                dets,
                min_px,
            ) {
                let p = if detectability {
                    recall_at(&e.recall_area_px, &e.recall, v.visible_px / scale)
                } else {
                    e.p_detect
                };
                ((1.0 - p) / (1.0 - e.p_false)).ln().min(0.0)
            } else {
                0.0
            };
            let o = &mut self.objects[k];
            let was_hit = std::mem::take(&mut o.hit);
            // Confirmed objects only: an unconfirmed one (a false positive, a duplicate) keeps
            // taking evidence at every `min_view_change`.
            let per_m = if o.hit_views >= e.confirmed_hits {
                e.min_view_change_per_m
            } else {
                0.0
            };
            let new_view = o.last_view.is_none_or(|p| {
                let step = e
                    .min_view_change
                    .max(per_m * cam_pos.distance(o.cuboid.center));
                new_viewpoint(p, cam_pos, o.cuboid.center, step, cos_min)
            });
            if delta != 0.0 && new_view {
                o.last_view = Some(cam_pos);
                o.hit_views += was_hit as u32;
                let cap = if detectability && o.hit_views >= e.confirmed_hits {
                    e.confirmed_max_log_odds
                } else {
                    e.max_log_odds
                };
                o.existence = (o.existence + delta).clamp(-cap, cap);
            }
            if o.existence < e.delete_below {
                self.objects.remove(k);
                deleted += 1;
            } else {
                k += 1;
            }
        }
        deleted
    }

    /// Whether an object with cuboid `b` should have been detected in this frame and no
    /// overlapping compatible detection explains the miss; if so, how much of it was visible.
    #[allow(clippy::too_many_arguments)]
    fn should_see(
        &self,
        class_id: shm_types::ClassId,
        b: &Box3,
        frame: &DepthFrame,
        camera: &Camera,
        cam_from_world: &Affine3A,
        dets: &[Detection],
        min_px: f32,
    ) -> Option<Seen> {
        let e = &self.cfg.existence;
        let centre = cam_from_world.transform_point3(b.center);
        if centre.z < camera.k.min_range || centre.length() > e.max_range {
            return None;
        }
        // Projected box: every corner must be in front of the camera.
        let cub = Cuboid {
            center: b.center,
            size: b.size,
            yaw: b.yaw,
        };
        let mut raw = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        for c in cub.corners() {
            let pc = cam_from_world.transform_point3(c);
            if pc.z < camera.k.min_range * 0.5 {
                return None;
            }
            let px = camera.project(pc)?;
            raw = [
                raw[0].min(px.x),
                raw[1].min(px.y),
                raw[2].max(px.x),
                raw[3].max(px.y),
            ];
        }
        let (w, h) = (camera.width as f32, camera.height as f32);
        let clipped = [
            raw[0].clamp(0.0, w),
            raw[1].clamp(0.0, h),
            raw[2].clamp(0.0, w),
            raw[3].clamp(0.0, h),
        ];
        let area = |r: [f32; 4]| (r[2] - r[0]).max(0.0) * (r[3] - r[1]).max(0.0);
        let (full, inside) = (area(raw), area(clipped));
        if full <= 0.0 || inside < e.min_in_frame * full || inside < min_px {
            return None;
        }
        let cross = self.cfg.extensions.cross_class;
        if dets.iter().any(|d| {
            let bbox = d.bbox.map(f32::from);
            let iou = box_iou(bbox, clipped);
            (self.groups.compatible(d.class_id, class_id)
                && explains_miss(bbox, clipped, e.overlap_iou, e.overlap_min))
                || (cross && !is_background_class(d.class_id) && iou >= e.cross_class_iou)
        }) {
            return None;
        }
        let cam_pos: Vec3 = cam_from_world.inverse().translation.into();
        let f = unoccluded_fraction(
            b,
            frame,
            camera,
            cam_from_world,
            cam_pos,
            e.occlusion_tolerance,
        )
        .filter(|f| *f >= e.min_visible)?;
        Some(Seen {
            visible_px: inside * f,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_iou_of_overlapping_boxes() {
        assert!((box_iou([0.0, 0.0, 2.0, 2.0], [1.0, 0.0, 3.0, 2.0]) - 1.0 / 3.0).abs() < 1e-6);
        assert_eq!(box_iou([0.0, 0.0, 1.0, 1.0], [2.0, 2.0, 3.0, 3.0]), 0.0);
    }

    #[test]
    fn a_jittered_box_of_a_thin_object_explains_its_miss() {
        // A bottle 10 px wide; its detection shifted by 5 px and a little taller: IoU 0.29.
        let (proj, det) = ([160.0, 40.0, 170.0, 90.0], [165.0, 35.0, 175.0, 95.0]);
        assert!(box_iou(det, proj) < 0.3);
        assert!(
            !explains_miss(det, proj, 0.3, 0.0),
            "IoU alone: counted as a miss"
        );
        assert!(explains_miss(det, proj, 0.3, 0.4));
        // A neighbour's box beside it does not.
        let beside = [172.0, 40.0, 182.0, 90.0];
        assert!(!explains_miss(beside, proj, 0.3, 0.4));
        assert!((box_overlap_min([0.0, 0.0, 2.0, 2.0], [1.0, 0.0, 5.0, 4.0]) - 0.5).abs() < 1e-6);
        assert_eq!(
            box_overlap_min([0.0, 0.0, 0.0, 2.0], [0.0, 0.0, 2.0, 2.0]),
            0.0
        );
    }

    #[test]
    fn a_short_step_far_from_an_object_is_the_same_viewpoint() {
        let cos_min = 10f32.to_radians().cos();
        let o = Vec3::new(0.0, 0.0, 0.8);
        let (near, far) = (Vec3::new(1.0, 0.0, 1.2), Vec3::new(3.0, 0.0, 1.2));
        let side = Vec3::new(0.0, 0.25, 0.0);
        // The step update_existence uses for a confirmed object: 0.2 m, 0.18 per metre.
        let step = |cam: Vec3| 0.2f32.max(0.18 * cam.distance(o));
        // 0.25 m sideways: a new view at 1 m (14 deg), the same view at 3 m (5 deg).
        assert!(new_viewpoint(
            near,
            near + side,
            o,
            step(near + side),
            cos_min
        ));
        assert!(!new_viewpoint(
            far,
            far + side,
            o,
            step(far + side),
            cos_min
        ));
        // Far away, a 0.6 m step (11 deg) is a new view.
        let far2 = far + side * 2.4;
        assert!(new_viewpoint(far, far2, o, step(far2), cos_min));
        // The absolute step alone (an unconfirmed object): 0.25 m is a new view at 3 m too.
        assert!(new_viewpoint(far, far + side, o, 0.2, cos_min));
    }

    #[test]
    fn recall_grows_with_the_visible_area() {
        let (a, r) = ([64.0, 256.0, 3072.0, 36864.0], [0.10, 0.39, 0.64, 0.72]);
        assert_eq!(recall_at(&a, &r, 10.0), 0.10);
        assert!((recall_at(&a, &r, 256.0) - 0.39).abs() < 1e-6);
        assert!(
            (recall_at(&a, &r, 128.0) - 0.245).abs() < 1e-3,
            "half-way in log area"
        );
        assert_eq!(recall_at(&a, &r, 1e6), 0.72);
        let mut last = 0.0;
        for k in 0..40 {
            let p = recall_at(&a, &r, 2f32.powf(k as f32 * 0.5));
            assert!(p >= last);
            last = p;
        }
    }
}
