//! Test-only synthetic renderer for the mapper: ray casts a few upright boxes / cylinders, a floor
//! and room walls into a `DepthFrame` (Kinect-style noise optional) and a `Detections` label image
//! (with optional mask bleed onto the background and onto background-class objects).
//! Shared by the mapper's integration tests and its benchmark (`#[path]` include).
#![allow(dead_code)]

use glam::{Affine3A, Mat3, Vec3};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use shm_types::{
    ClassId, DepthFrame, Detection, Detections, MAX_DETECTIONS, RobotState, class_id,
    is_background_class,
};
use vpsom::geom::{Camera, CameraMount, Cuboid, affine_to_pose};

/// One synthetic object.
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    /// COCO class.
    pub class_id: ClassId,
    /// Pose and size (a cylinder has diameter `size.x`).
    pub cuboid: Cuboid,
    /// Vertical cylinder instead of a box.
    pub cylinder: bool,
}

impl Shape {
    pub fn new(class: &str, center: [f32; 3], size: [f32; 3], yaw: f32, cylinder: bool) -> Self {
        Self {
            class_id: class_id(class).expect("COCO class"),
            cuboid: Cuboid {
                center: Vec3::from(center),
                size: Vec3::from(size),
                yaw,
            },
            cylinder,
        }
    }

    /// Hit time along `o + t d` (t > 1e-4), if any.
    fn hit(&self, o: Vec3, d: Vec3) -> Option<f32> {
        let r = Mat3::from_rotation_z(-self.cuboid.yaw);
        let q = r * (o - self.cuboid.center);
        let dl = r * d;
        let h = self.cuboid.size * 0.5;
        if !self.cylinder {
            let mut t0 = f32::NEG_INFINITY;
            let mut t1 = f32::INFINITY;
            for a in 0..3 {
                if dl[a].abs() < 1e-12 {
                    if q[a].abs() > h[a] {
                        return None;
                    }
                    continue;
                }
                let (ta, tb) = ((-h[a] - q[a]) / dl[a], (h[a] - q[a]) / dl[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
            return (t0 <= t1 && t0 > 1e-4).then_some(t0);
        }
        let rad = h.x;
        let mut best = f32::INFINITY;
        let a = dl.x * dl.x + dl.y * dl.y;
        if a > 1e-12 {
            let b = 2.0 * (q.x * dl.x + q.y * dl.y);
            let c = q.x * q.x + q.y * q.y - rad * rad;
            let disc = b * b - 4.0 * a * c;
            if disc >= 0.0 {
                let t = (-b - disc.sqrt()) / (2.0 * a);
                if t > 1e-4 && (q.z + t * dl.z).abs() <= h.z {
                    best = t;
                }
            }
        }
        if dl.z.abs() > 1e-12 {
            for zc in [-h.z, h.z] {
                let t = (zc - q.z) / dl.z;
                let p = q + dl * t;
                if t > 1e-4 && p.x * p.x + p.y * p.y <= rad * rad {
                    best = best.min(t);
                }
            }
        }
        best.is_finite().then_some(best)
    }
}

/// A scene: objects on a floor inside optional walls.
#[derive(Debug, Clone)]
pub struct Scene {
    pub objects: Vec<Shape>,
    /// Room `[xmin, ymin, xmax, ymax]`.
    pub room: [f32; 4],
}

/// Rendering options.
#[derive(Debug, Clone, Copy)]
pub struct RenderOpts {
    /// Kinect-style depth noise σ = 1.2 mm + 1.9 mm·(z − 0.4)².
    pub noise: bool,
    /// Mask dilation (pixels) onto background pixels and background-class objects.
    pub bleed_px: u32,
    /// Instances with fewer visible pixels are not detected.
    pub min_pixels: u32,
    /// Box-only detections (a YOLO-class detector): no label image, `masks = BOXES`.
    pub boxes: bool,
}

impl Default for RenderOpts {
    fn default() -> Self {
        Self {
            noise: true,
            bleed_px: 2,
            min_pixels: 30,
            boxes: false,
        }
    }
}

/// Render one frame into `frame` / `dets` (reused buffers).
#[allow(clippy::too_many_arguments)]
pub fn render(
    scene: &Scene,
    camera: &Camera,
    pose: &Affine3A,
    seq: u64,
    time_ns: u64,
    opts: &RenderOpts,
    rng: &mut impl Rng,
    frame: &mut DepthFrame,
    dets: &mut Detections,
) {
    let (w, h) = (camera.width as usize, camera.height as usize);
    frame.header.seq = seq;
    frame.header.stamp_ns = time_ns;
    frame.header.sim_time_ns = time_ns;
    frame.width = camera.width;
    frame.height = camera.height;
    frame.intrinsics = camera.k;
    frame.camera_pose = affine_to_pose(pose);
    dets.header = frame.header;
    dets.frame_seq = seq;
    dets.width = camera.width;
    dets.height = camera.height;
    let boxes: Vec<Option<[f32; 4]>> = scene
        .objects
        .iter()
        .map(|s| s.cuboid.image_box(camera, pose))
        .collect();
    let o: Vec3 = pose.translation.into();
    let [xmin, ymin, xmax, ymax] = scene.room;
    for v in 0..h {
        for u in 0..w {
            let (uf, vf) = (u as f32 + 0.5, v as f32 + 0.5);
            let d = pose.transform_vector3(camera.ray(uf, vf));
            let mut best = f32::INFINITY;
            let mut label = 0u8;
            if d.z < 0.0 {
                best = -o.z / d.z;
            }
            for (wall, comp, sign) in [
                (xmin, 0, -1.0),
                (xmax, 0, 1.0),
                (ymin, 1, -1.0),
                (ymax, 1, 1.0),
            ] {
                if d[comp] * sign > 0.0 {
                    best = best.min((wall - o[comp]) / d[comp]);
                }
            }
            for (k, s) in scene.objects.iter().enumerate() {
                let Some(b) = boxes[k] else { continue };
                if uf < b[0] - 1.0 || uf > b[2] + 1.0 || vf < b[1] - 1.0 || vf > b[3] + 1.0 {
                    continue;
                }
                if let Some(t) = s.hit(o, d)
                    && t < best
                {
                    best = t;
                    label = k as u8 + 1;
                }
            }
            let mut z = best;
            if opts.noise && z.is_finite() {
                let sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
                z += Normal::new(0.0, sigma).expect("σ > 0").sample(rng);
            }
            frame.depth_mm[v * w + u] =
                if z.is_finite() && z >= camera.k.min_range && z <= camera.k.max_range {
                    (z * 1000.0).round() as u16
                } else {
                    0
                };
            dets.labels[v * w + u] = label;
        }
    }
    // Bleed: dilate every instance onto background and background-class pixels.
    let bleed_target =
        |l: u8| l == 0 || is_background_class(scene.objects[l as usize - 1].class_id);
    for _ in 0..opts.bleed_px {
        let prev: Vec<u8> = dets.labels[..w * h].to_vec();
        for v in 0..h {
            for u in 0..w {
                if !bleed_target(prev[v * w + u]) {
                    continue;
                }
                for (du, dv) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
                    let (nu, nv) = (u as i32 + du, v as i32 + dv);
                    if nu < 0 || nv < 0 || nu >= w as i32 || nv >= h as i32 {
                        continue;
                    }
                    let l = prev[nv as usize * w + nu as usize];
                    if l != 0 && !is_background_class(scene.objects[l as usize - 1].class_id) {
                        dets.labels[v * w + u] = l;
                        break;
                    }
                }
            }
        }
    }
    // Detections from the label image.
    let n = scene.objects.len();
    let mut bb = vec![[u16::MAX, u16::MAX, 0u16, 0u16]; n];
    let mut count = vec![0u32; n];
    for v in 0..h {
        for u in 0..w {
            let l = dets.labels[v * w + u];
            if l == 0 {
                continue;
            }
            let k = l as usize - 1;
            count[k] += 1;
            let b = &mut bb[k];
            b[0] = b[0].min(u as u16);
            b[1] = b[1].min(v as u16);
            b[2] = b[2].max(u as u16 + 1);
            b[3] = b[3].max(v as u16 + 1);
        }
    }
    dets.count = 0;
    dets.masks = shm_types::mask_mode::MASKS;
    for k in 0..n {
        if count[k] >= opts.min_pixels && (dets.count as usize) < MAX_DETECTIONS {
            dets.items[dets.count as usize] = Detection {
                class_id: scene.objects[k].class_id,
                label: k as u16 + 1,
                score: 0.9,
                bbox: bb[k],
                mask_pixels: count[k],
            };
            dets.count += 1;
        } else {
            for l in dets.labels[..w * h]
                .iter_mut()
                .filter(|l| **l as usize == k + 1)
            {
                *l = 0;
            }
        }
    }
    if opts.boxes {
        to_boxes(dets);
    }
}

/// Turn mask detections into box-only ones (a YOLO-class detector's output).
pub fn to_boxes(dets: &mut Detections) {
    let n = (dets.width * dets.height) as usize;
    dets.labels[..n].fill(0);
    dets.masks = shm_types::mask_mode::BOXES;
    let count = dets.count as usize;
    for d in &mut dets.items[..count] {
        d.mask_pixels = 0;
    }
}

/// A table with five objects on it, in a 6 m × 6 m room.
pub fn table_scene() -> Scene {
    Scene {
        objects: vec![
            Shape::new(
                "dining table",
                [0.0, 0.0, 0.375],
                [1.2, 0.8, 0.75],
                0.15,
                false,
            ),
            Shape::new("cup", [0.30, 0.15, 0.80], [0.08, 0.08, 0.10], 0.0, true),
            Shape::new(
                "bottle",
                [-0.35, -0.10, 0.875],
                [0.07, 0.07, 0.25],
                0.0,
                true,
            ),
            Shape::new("book", [0.02, -0.22, 0.77], [0.25, 0.18, 0.04], 0.5, false),
            Shape::new("bowl", [-0.12, 0.20, 0.785], [0.16, 0.16, 0.07], 0.0, true),
            Shape::new(
                "teddy bear",
                [0.38, -0.18, 0.85],
                [0.15, 0.12, 0.20],
                -0.4,
                false,
            ),
        ],
        room: [-3.0, -3.0, 3.0, 3.0],
    }
}

/// A table with nine objects on it (10 visible objects), for the benchmark.
pub fn busy_scene() -> Scene {
    let mut s = table_scene();
    s.objects.extend([
        Shape::new("vase", [-0.45, 0.25, 0.85], [0.09, 0.09, 0.20], 0.0, true),
        Shape::new(
            "keyboard",
            [0.05, 0.05, 0.765],
            [0.30, 0.12, 0.03],
            0.1,
            false,
        ),
        Shape::new("clock", [0.15, 0.28, 0.80], [0.12, 0.05, 0.10], 0.3, false),
        Shape::new(
            "remote",
            [-0.25, -0.28, 0.765],
            [0.16, 0.05, 0.03],
            -0.2,
            false,
        ),
    ]);
    s
}

/// The default camera model.
pub fn camera() -> Camera {
    vpsom::config::CameraConfig::default().camera()
}

/// A robot state with localization OK (the mapper refuses frames without it).
pub fn state() -> RobotState {
    RobotState {
        localization_ok: 1,
        ..Default::default()
    }
}

/// Camera on a circle of `radius` around `target` at azimuth `deg`, looking at it.
pub fn view(target: Vec3, radius: f32, deg: f32) -> Affine3A {
    let a = deg.to_radians();
    let mount = CameraMount::default();
    let base = [
        target.x + radius * a.cos(),
        target.y + radius * a.sin(),
        a + std::f32::consts::PI,
    ];
    mount.camera_pose(base, 0.0, mount.pitch())
}

/// Index of the first detection of `class`.
pub fn find(dets: &Detections, class: &str) -> Option<usize> {
    let id = class_id(class).unwrap();
    dets.detections().iter().position(|d| d.class_id == id)
}
