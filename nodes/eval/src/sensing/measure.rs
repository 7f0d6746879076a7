//! Per-frame measurement: visible objects, box matching, silhouettes, counts, ATE and RPE
//! (definitions in the [module docs](super)).

use geom::{Camera, convex_hull};
use glam::{Affine3A, Mat3, Vec2, Vec3};
use serde::Serialize;
use shm_types::{ClassId, Detection};
use sim::{Scene, SceneObject, Shape};

/// Minimum visible pixels of a visible object at 640×480 (scaled with the image area).
pub const MIN_VISIBLE_PIXELS_640: f64 = 50.0;
/// Box IoU at which a detection matches a visible object (COCO AP50).
/// A false positive scoring at least this is counted as confident: above the mapper's default
/// `min_score` (0.5), so it can reach the map.
pub const CONFIDENT_SCORE: f32 = 0.5;
pub const MATCH_IOU: f64 = 0.5;
/// COCO's small/medium and medium/large area limits, pixels, at 640×480.
pub const SIZE_LIMITS_640: [f64; 2] = [32.0 * 32.0, 96.0 * 96.0];
/// Visible-fraction limits of the occlusion buckets: `≥ 0.9`, `[0.5, 0.9)`, `< 0.5`.
pub const OCCLUSION_LIMITS: [f32; 2] = [0.9, 0.5];
/// RPE interval, seconds.
pub const RPE_DELTA_S: f64 = 1.0;
/// Near plane for projecting silhouettes, metres (the part of an object closer than this to
/// the camera plane is cut off before projection).
const NEAR: f32 = 0.01;
/// Rim points of a cylinder's silhouette (circumscribed polygon).
const RIM: usize = 32;

/// Minimum visible pixels for a `width × height` image.
pub fn min_visible_pixels(width: u32, height: u32) -> f64 {
    MIN_VISIBLE_PIXELS_640 * f64::from(width) * f64::from(height) / (640.0 * 480.0)
}

/// Size bucket (0 small, 1 medium, 2 large) of `pixels` visible pixels in a `width × height` image.
pub fn size_bucket(pixels: u32, width: u32, height: u32) -> usize {
    let scale = f64::from(width) * f64::from(height) / (640.0 * 480.0);
    let a = f64::from(pixels);
    if a < SIZE_LIMITS_640[0] * scale {
        0
    } else if a < SIZE_LIMITS_640[1] * scale {
        1
    } else {
        2
    }
}

/// Occlusion bucket (0: visible fraction ≥ 0.9, 1: 0.5–0.9, 2: < 0.5).
pub fn occlusion_bucket(visible_fraction: f32) -> usize {
    if visible_fraction >= OCCLUSION_LIMITS[0] {
        0
    } else if visible_fraction >= OCCLUSION_LIMITS[1] {
        1
    } else {
        2
    }
}

/// IoU of two pixel boxes `[x0, y0, x1, y1]` (`x1`, `y1` exclusive); 0 if both are empty.
pub fn box_iou(a: [u32; 4], b: [u32; 4]) -> f64 {
    let area =
        |r: [u32; 4]| f64::from(r[2].saturating_sub(r[0])) * f64::from(r[3].saturating_sub(r[1]));
    let inter = area([
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].min(b[3]),
    ]);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// One visible object of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisibleObject {
    /// Scene object index.
    pub object: usize,
    /// Its true class.
    pub class_id: ClassId,
    /// Visible pixels in the true instance render.
    pub pixels: u32,
    /// True visible box `[x0, y0, x1, y1]`, exclusive ends.
    pub bbox: [u32; 4],
    /// Visible pixels / unoccluded silhouette area clipped to the image, at most 1.
    pub visible_fraction: f32,
    /// Whether the box touches the image border.
    pub truncated: bool,
}

/// A detection matched to a visible object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxMatch {
    /// Index into the visible objects.
    pub visible: usize,
    /// Index into the detections.
    pub detection: usize,
    /// Their box IoU (≥ [`MATCH_IOU`]).
    pub iou: f64,
}

/// Match detections to visible objects one-to-one by box IoU ≥ [`MATCH_IOU`], highest IoU first
/// (ties: lower visible index, then lower detection index). Class is ignored (a match with
/// another class is a confusion).
pub fn match_boxes(visible: &[VisibleObject], dets: &[Detection]) -> Vec<BoxMatch> {
    let mut pairs = Vec::new();
    for (v, o) in visible.iter().enumerate() {
        for (d, det) in dets.iter().enumerate() {
            let iou = box_iou(o.bbox, det.bbox.map(u32::from));
            if iou >= MATCH_IOU {
                pairs.push(BoxMatch {
                    visible: v,
                    detection: d,
                    iou,
                });
            }
        }
    }
    pairs.sort_by(|a, b| {
        b.iou
            .total_cmp(&a.iou)
            .then(a.visible.cmp(&b.visible))
            .then(a.detection.cmp(&b.detection))
    });
    let (mut used_v, mut used_d) = (vec![false; visible.len()], vec![false; dets.len()]);
    pairs.retain(|p| {
        let free = !used_v[p.visible] && !used_d[p.detection];
        if free {
            (used_v[p.visible], used_d[p.detection]) = (true, true);
        }
        free
    });
    pairs
}

/// Area (pixels²) of a convex polygon clipped to the rectangle `[0, size]` (Sutherland–Hodgman).
pub fn clipped_area(poly: &[Vec2], size: Vec2) -> f32 {
    let mut a = poly.to_vec();
    for (axis, bound, keep_above) in [
        (0, 0.0, true),
        (0, size.x, false),
        (1, 0.0, true),
        (1, size.y, false),
    ] {
        let inside = |p: Vec2| {
            if keep_above {
                p[axis] >= bound
            } else {
                p[axis] <= bound
            }
        };
        let mut b = Vec::with_capacity(a.len() + 4);
        for i in 0..a.len() {
            let (p, q) = (a[i], a[(i + 1) % a.len()]);
            if inside(p) {
                b.push(p);
            }
            if inside(p) != inside(q) {
                b.push(p + (q - p) * ((bound - p[axis]) / (q[axis] - p[axis])));
            }
        }
        a = b;
    }
    let n = a.len();
    (0..n)
        .map(|i| a[i].perp_dot(a[(i + 1) % n]))
        .sum::<f32>()
        .abs()
        * 0.5
}

/// The object's solid as a prism: the base polygon's corners at the bottom and at the top
/// (a box's 4 corners; a cylinder's circumscribed 32-gon), world frame.
fn prism(o: &SceneObject) -> (Vec<Vec3>, Vec<Vec3>) {
    let rot = Mat3::from_rotation_z(o.yaw);
    let base: Vec<Vec2> = match o.shape {
        Shape::Box => {
            let h = o.size.truncate() * 0.5;
            vec![
                Vec2::new(-h.x, -h.y),
                Vec2::new(h.x, -h.y),
                Vec2::new(h.x, h.y),
                Vec2::new(-h.x, h.y),
            ]
        }
        Shape::Cylinder => {
            let r = o.size.x * 0.5 / (std::f32::consts::PI / RIM as f32).cos();
            (0..RIM)
                .map(|i| Vec2::from_angle(i as f32 * std::f32::consts::TAU / RIM as f32) * r)
                .collect()
        }
    };
    let ring = |z: f32| base.iter().map(|p| o.center + rot * p.extend(z)).collect();
    (ring(-o.size.z * 0.5), ring(o.size.z * 0.5))
}

/// Area (pixels²) of scene object `o`'s unoccluded silhouette seen by `camera` from
/// `cam_from_world`, clipped to the image. The solid is first cut at a near plane in front of
/// the camera (exact for a box; a cylinder is its circumscribed 32-gon prism), so objects
/// partly behind the camera are handled.
pub fn silhouette_area(o: &SceneObject, camera: &Camera, cam_from_world: &Affine3A) -> f32 {
    let (bottom, top) = prism(o);
    let n = bottom.len();
    let cam = |p: &Vec3| cam_from_world.transform_point3(*p);
    let (bottom, top): (Vec<Vec3>, Vec<Vec3>) = (
        bottom.iter().map(cam).collect(),
        top.iter().map(cam).collect(),
    );
    let mut pts: Vec<Vec3> = bottom
        .iter()
        .chain(&top)
        .copied()
        .filter(|p| p.z >= NEAR)
        .collect();
    let edges = (0..n).flat_map(|i| {
        let j = (i + 1) % n;
        [
            (bottom[i], bottom[j]),
            (top[i], top[j]),
            (bottom[i], top[i]),
        ]
    });
    for (p, q) in edges {
        if (p.z - NEAR) * (q.z - NEAR) < 0.0 {
            pts.push(p + (q - p) * ((NEAR - p.z) / (q.z - p.z)));
        }
    }
    let mut img: Vec<Vec2> = pts.iter().filter_map(|p| camera.project(*p)).collect();
    if img.len() < 3 {
        return 0.0;
    }
    let mut hull = Vec::new();
    convex_hull(&mut img, &mut hull);
    clipped_area(&hull, Vec2::new(camera.width as f32, camera.height as f32))
}

/// The visible objects of a true instance render (`instance[p] = k + 1` for scene object `k`)
/// seen by `camera` from `world_from_camera` (the TRUE pose), in scene order.
pub fn visible_objects(
    instance: &[u8],
    scene: &Scene,
    camera: &Camera,
    world_from_camera: &Affine3A,
) -> Vec<VisibleObject> {
    let (w, h) = (camera.width, camera.height);
    let n = scene.objects.len();
    let mut pixels = vec![0u32; n + 1];
    let mut bbox = vec![[u32::MAX, u32::MAX, 0, 0]; n + 1];
    for (y, row) in instance[..(w * h) as usize]
        .chunks_exact(w as usize)
        .enumerate()
    {
        for (x, &k) in row.iter().enumerate() {
            let k = k as usize;
            if k != 0 && k <= n {
                let (x, y) = (x as u32, y as u32);
                pixels[k] += 1;
                let b = &mut bbox[k];
                *b = [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)];
            }
        }
    }
    let min_px = min_visible_pixels(w, h);
    let cam_from_world = world_from_camera.inverse();
    (0..n)
        .filter(|k| f64::from(pixels[k + 1]) >= min_px)
        .map(|k| {
            let (px, b) = (pixels[k + 1], bbox[k + 1]);
            let area = silhouette_area(&scene.objects[k], camera, &cam_from_world);
            VisibleObject {
                object: k,
                class_id: scene.objects[k].class_id,
                pixels: px,
                bbox: b,
                visible_fraction: (px as f32 / area.max(1.0)).min(1.0),
                truncated: b[0] == 0 || b[1] == 0 || b[2] == w || b[3] == h,
            }
        })
        .collect()
}

/// Visible objects and matched ones.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Bucket {
    /// Visible objects (object-frames).
    pub visible: u64,
    /// Of which matched by a detection.
    pub matched: u64,
}

impl Bucket {
    /// matched / visible, `None` if nothing was visible.
    pub fn recall(&self) -> Option<f64> {
        (self.visible > 0).then(|| self.matched as f64 / self.visible as f64)
    }

    fn add(&mut self, matched: bool) {
        self.visible += 1;
        self.matched += u64::from(matched);
    }
}

/// The figures of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct FrameStats {
    /// Simulated time, s.
    pub t_s: f64,
    /// Visible objects.
    pub visible: u32,
    /// Detections.
    pub detections: u32,
    /// Matched pairs.
    pub matched: u32,
    /// Unmatched detections.
    pub false_positives: u32,
    /// Of which scoring at least [`CONFIDENT_SCORE`].
    pub confident_false_positives: u32,
    /// Matched pairs with another class.
    pub confused: u32,
    /// Sum of the matched pairs' box IoU.
    pub iou_sum: f64,
    /// Pixels whose true depth is within the camera range.
    pub depth_in_range: u32,
    /// Of which invalid (0) in the depth frame.
    pub depth_in_range_invalid: u32,
    /// Invalid (0) pixels of the whole frame.
    pub depth_invalid: u32,
    /// Pixels of the frame.
    pub depth_pixels: u32,
    /// Camera-position error (estimated vs true), m.
    pub position_error_m: f64,
}

/// Counts of a scene (or of all scenes) from which the report's figures are computed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// Frames.
    pub frames: u64,
    /// All visible objects.
    pub all: Bucket,
    /// By size: small, medium, large.
    pub size: [Bucket; 3],
    /// By visible fraction: ≥ 0.9, 0.5–0.9, < 0.5.
    pub occlusion: [Bucket; 3],
    /// Not truncated, truncated.
    pub truncation: [Bucket; 2],
    /// Detections.
    pub detections: u64,
    /// Matched pairs.
    pub matched: u64,
    /// Unmatched detections.
    pub false_positives: u64,
    /// Of which scoring at least [`CONFIDENT_SCORE`].
    pub confident_false_positives: u64,
    /// Matched pairs with another class.
    pub confused: u64,
    /// Sum of matched IoU.
    pub iou_sum: f64,
    /// Pixels with true depth in range / of which invalid / all pixels / of which invalid.
    pub depth: [u64; 4],
}

impl Tally {
    /// Score one frame: `dets` against the visible objects `visible` of a `width × height`
    /// image; `depth_mm` (0 = invalid) against `depth_true` (m) with the camera range.
    /// Returns the frame's figures (`t_s` and `position_error_m` are the caller's).
    pub fn add_frame(
        &mut self,
        visible: &[VisibleObject],
        dets: &[Detection],
        camera: &Camera,
        depth_mm: &[u16],
        depth_true: &[f32],
    ) -> FrameStats {
        let (w, h) = (camera.width, camera.height);
        let matches = match_boxes(visible, dets);
        let mut matched = vec![false; visible.len()];
        let mut f = FrameStats {
            visible: visible.len() as u32,
            detections: dets.len() as u32,
            matched: matches.len() as u32,
            false_positives: (dets.len() - matches.len()) as u32,
            ..FrameStats::default()
        };
        let mut used = vec![false; dets.len()];
        for m in &matches {
            used[m.detection] = true;
        }
        f.confident_false_positives = dets
            .iter()
            .zip(&used)
            .filter(|(d, u)| !**u && d.score >= CONFIDENT_SCORE)
            .count() as u32;
        for m in &matches {
            matched[m.visible] = true;
            f.iou_sum += m.iou;
            f.confused += u32::from(dets[m.detection].class_id != visible[m.visible].class_id);
        }
        for (o, &hit) in visible.iter().zip(&matched) {
            self.all.add(hit);
            self.size[size_bucket(o.pixels, w, h)].add(hit);
            self.occlusion[occlusion_bucket(o.visible_fraction)].add(hit);
            self.truncation[usize::from(o.truncated)].add(hit);
        }
        let n = (w * h) as usize;
        let (lo, hi) = (camera.k.min_range, camera.k.max_range);
        for (&d, &t) in depth_mm[..n].iter().zip(&depth_true[..n]) {
            let in_range = t >= lo && t <= hi;
            f.depth_in_range += u32::from(in_range);
            f.depth_in_range_invalid += u32::from(in_range && d == 0);
            f.depth_invalid += u32::from(d == 0);
        }
        f.depth_pixels = n as u32;
        self.frames += 1;
        self.detections += u64::from(f.detections);
        self.matched += u64::from(f.matched);
        self.false_positives += u64::from(f.false_positives);
        self.confident_false_positives += u64::from(f.confident_false_positives);
        self.confused += u64::from(f.confused);
        self.iou_sum += f.iou_sum;
        let depth = [
            f.depth_in_range,
            f.depth_in_range_invalid,
            f.depth_pixels,
            f.depth_invalid,
        ];
        for (a, b) in self.depth.iter_mut().zip(depth) {
            *a += u64::from(b);
        }
        f
    }

    /// Add another tally's counts.
    pub fn merge(&mut self, o: &Tally) {
        self.frames += o.frames;
        let pairs = std::iter::once((&mut self.all, &o.all))
            .chain(self.size.iter_mut().zip(&o.size))
            .chain(self.occlusion.iter_mut().zip(&o.occlusion))
            .chain(self.truncation.iter_mut().zip(&o.truncation));
        for (a, b) in pairs {
            a.visible += b.visible;
            a.matched += b.matched;
        }
        self.detections += o.detections;
        self.matched += o.matched;
        self.false_positives += o.false_positives;
        self.confident_false_positives += o.confident_false_positives;
        self.confused += o.confused;
        self.iou_sum += o.iou_sum;
        for (a, b) in self.depth.iter_mut().zip(o.depth) {
            *a += b;
        }
    }
}

/// One camera pose pair of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseSample {
    /// Time, ns.
    pub t_ns: u64,
    /// Estimated `world_from_camera` (`DepthFrame::camera_pose`).
    pub est: Affine3A,
    /// True `world_from_camera`.
    pub truth: Affine3A,
}

/// Sum of squared errors, count and maximum (pools across scenes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Errors.
    pub n: u64,
    /// Sum of squared errors, m².
    pub sum_sq: f64,
    /// Largest error, m.
    pub max: f64,
}

impl ErrorStats {
    fn add(&mut self, e: f64) {
        self.n += 1;
        self.sum_sq += e * e;
        self.max = self.max.max(e);
    }

    /// Root mean square, `None` without errors.
    pub fn rmse(&self) -> Option<f64> {
        (self.n > 0).then(|| (self.sum_sq / self.n as f64).sqrt())
    }

    /// Pool another set.
    pub fn merge(&mut self, o: &ErrorStats) {
        self.n += o.n;
        self.sum_sq += o.sum_sq;
        self.max = self.max.max(o.max);
    }
}

/// Absolute trajectory error: camera-position errors, no alignment.
pub fn ate(track: &[PoseSample]) -> ErrorStats {
    let mut s = ErrorStats::default();
    for p in track {
        s.add(f64::from(
            (p.est.translation - p.truth.translation).length(),
        ));
    }
    s
}

/// Relative pose error (TUM): for each sample `i` and the first sample `j` at least
/// `delta_ns` later (a millisecond of slack for rounding), the translation of
/// `(Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` with `Q` true and `P` estimated poses. `track` is in time order.
pub fn rpe(track: &[PoseSample], delta_ns: u64) -> ErrorStats {
    let mut s = ErrorStats::default();
    let mut j = 0;
    for (i, a) in track.iter().enumerate() {
        j = j.max(i + 1);
        while j < track.len() && track[j].t_ns + 1_000_000 < a.t_ns + delta_ns {
            j += 1;
        }
        let Some(b) = track.get(j) else { break };
        let rel_true = a.truth.inverse() * b.truth;
        let rel_est = a.est.inverse() * b.est;
        s.add(f64::from(
            (rel_true.inverse() * rel_est).translation.length(),
        ));
    }
    s
}
