//! Shared geometry: frames, the robot's camera mount, the pinhole model, cuboids and the 2D
//! convex hull.
//!
//! Frames (see `shm_types`): world z up; camera = OpenCV optical frame (x right, y down,
//! z forward). Poses are `parent_from_child`. Scalars are `f32` (glam), like the messages.

use glam::{Affine3A, DMat3, DVec3, Mat3, Quat, Vec2, Vec3};
use serde::Deserialize;
use shm_types::{Intrinsics, Pose3};

/// The built-in `config/default.toml`, where this crate's sections (`[camera]`) have their defaults.
pub(crate) static DEFAULTS: settings::Defaults = settings::Defaults::new(
    "config/default.toml",
    include_str!("../../../config/default.toml"),
);

/// The RGB-D camera (paper: Kinect v2 on the FABO robot's head).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width, pixels (≤ 640).
    pub width: u32,
    /// Image height, pixels (≤ 480).
    pub height: u32,
    /// Horizontal field of view, degrees.
    pub hfov_deg: f32,
    /// Vertical field of view, degrees.
    pub vfov_deg: f32,
    /// Nearest valid depth, metres.
    pub min_range: f32,
    /// Farthest valid depth, metres.
    pub max_range: f32,
    /// Where the camera sits on the robot.
    pub mount: CameraMount,
}

impl Default for CameraConfig {
    /// The `[camera]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("camera")
    }
}

impl CameraConfig {
    /// The pinhole model.
    pub fn camera(&self) -> Camera {
        Camera::from_fov(
            self.width,
            self.height,
            self.hfov_deg,
            self.vfov_deg,
            self.min_range,
            self.max_range,
        )
    }

    /// Range-check the `[camera]` section and `[camera.mount]`.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        let c = &c.at("camera");
        settings::ranges!(c, self, {
            width: count(16, shm_types::MAX_WIDTH),
            height: count(16, shm_types::MAX_HEIGHT),
            [hfov_deg, vfov_deg]: in_range(10.0, 170.0),
            min_range: in_range(0.0, 100.0),
            max_range: require(
                self.max_range > self.min_range && self.max_range <= 100.0,
                &format!("must be > {} and ≤ 100", settings::key!(c, min_range)),
            ),
            mount: section,
        });
        Ok(())
    }
}

/// `world_from_camera` (or any `parent_from_child`) of a message, as a glam transform.
pub fn pose_to_affine(p: &Pose3) -> Affine3A {
    let [x, y, z, w] = p.rotation;
    Affine3A::from_rotation_translation(
        Quat::from_xyzw(x, y, z, w).normalize(),
        Vec3::from(p.translation),
    )
}

/// A glam rigid transform as a message pose.
pub fn affine_to_pose(a: &Affine3A) -> Pose3 {
    let (_, rot, t) = a.to_scale_rotation_translation();
    Pose3 {
        translation: t.to_array(),
        rotation: rot.normalize().to_array(),
    }
}

/// The optical-camera convention, written once and instantiated in `f32` (the logic) and `f64`
/// (the recorder's drawings, `vpsom::recording`): columns right, down, forward.
macro_rules! optical_rotation_fn {
    ($(#[$doc:meta])* $name:ident, $f:ty, $v:ty, $m:ty) => {
        $(#[$doc])*
        pub fn $name(yaw: $f, pitch: $f) -> $m {
            let (sy, cy) = yaw.sin_cos();
            let (sp, cp) = pitch.sin_cos();
            let forward = <$v>::new(cy * cp, sy * cp, -sp);
            let right = <$v>::new(sy, -cy, 0.0);
            let down = forward.cross(right);
            <$m>::from_cols(right, down, forward)
        }
    };
}

optical_rotation_fn!(
    /// Rotation `world_from_camera` of an optical camera whose forward axis has world yaw `yaw`
    /// and is pitched down by `pitch` (radians).
    optical_rotation, f32, Vec3, Mat3
);

optical_rotation_fn!(
    /// [`optical_rotation`] in `f64`: its columns are the camera's right, down and forward axes.
    optical_rotation_f64, f64, DVec3, DMat3
);

/// World yaw and downward pitch of an optical camera's forward axis.
pub fn yaw_pitch_of(world_from_camera: &Affine3A) -> (f32, f32) {
    let f = world_from_camera.matrix3.z_axis;
    (f.y.atan2(f.x), (-f.z).clamp(-1.0, 1.0).asin())
}

/// How the camera sits on the robot: on a neck that turns about the vertical axis.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraMount {
    /// Camera optical centre above the floor, metres (paper: 1.4).
    pub height: f32,
    /// Horizontal offset of the neck axis ahead of the base centre, metres.
    pub forward_offset: f32,
    /// Fixed downward pitch of the camera, degrees (paper: 28).
    pub pitch_deg: f32,
}

impl Default for CameraMount {
    /// The `[camera.mount]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("camera.mount")
    }
}

impl CameraMount {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        settings::ranges!(c, self, {
            height: in_range(0.05, 5.0),
            forward_offset: in_range(-2.0, 2.0),
            pitch_deg: in_range(-89.0, 89.0),
        });
        Ok(())
    }
}

impl CameraMount {
    /// `world_from_camera` for a base pose `[x, y, yaw]`, a neck yaw relative to the base and a
    /// camera pitch (radians, positive down).
    pub fn camera_pose(&self, base: [f32; 3], neck_yaw: f32, pitch: f32) -> Affine3A {
        let [x, y, yaw] = base;
        let neck = Vec3::new(
            x + self.forward_offset * yaw.cos(),
            y + self.forward_offset * yaw.sin(),
            self.height,
        );
        Affine3A::from_mat3_translation(optical_rotation(yaw + neck_yaw, pitch), neck)
    }

    /// The mount's fixed pitch in radians.
    pub fn pitch(&self) -> f32 {
        self.pitch_deg.to_radians()
    }

    /// The neck yaw (relative to the base) that points the camera at `target` from base pose
    /// `base`.
    pub fn neck_yaw_toward(&self, base: [f32; 3], target: Vec3) -> f32 {
        let cam = self.camera_pose(base, 0.0, self.pitch());
        let d = target - Vec3::from(cam.translation);
        wrap_angle(d.y.atan2(d.x) - base[2])
    }
}

/// Pinhole camera with image size and valid depth range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Intrinsics and range.
    pub k: Intrinsics,
}

impl Camera {
    /// A centred pinhole camera with the given fields of view (degrees) and depth range (metres).
    pub fn from_fov(
        width: u32,
        height: u32,
        hfov_deg: f32,
        vfov_deg: f32,
        min_range: f32,
        max_range: f32,
    ) -> Self {
        let fx = width as f32 / 2.0 / (hfov_deg.to_radians() / 2.0).tan();
        let fy = height as f32 / 2.0 / (vfov_deg.to_radians() / 2.0).tan();
        let k = Intrinsics {
            fx,
            fy,
            cx: width as f32 / 2.0,
            cy: height as f32 / 2.0,
            min_range,
            max_range,
        };
        Self { width, height, k }
    }

    /// Pixel coordinates (continuous, pixel centres at +0.5) of a camera-frame point in front
    /// of the camera, without bounds checks; `None` behind the camera.
    pub fn project(&self, p_cam: Vec3) -> Option<Vec2> {
        (p_cam.z > 1e-6).then(|| {
            Vec2::new(
                self.k.fx * p_cam.x / p_cam.z + self.k.cx,
                self.k.fy * p_cam.y / p_cam.z + self.k.cy,
            )
        })
    }

    /// Camera-frame ray through pixel `(u, v)` scaled so that its z is 1 (hit time = depth).
    pub fn ray(&self, u: f32, v: f32) -> Vec3 {
        Vec3::new(
            (u - self.k.cx) / self.k.fx,
            (v - self.k.cy) / self.k.fy,
            1.0,
        )
    }

    /// Camera-frame point of pixel `(u, v)` at depth `z` metres.
    pub fn unproject(&self, u: f32, v: f32, z: f32) -> Vec3 {
        self.ray(u, v) * z
    }

    /// Whether a camera-frame point is inside the image and the depth range.
    pub fn sees(&self, p_cam: Vec3) -> bool {
        if p_cam.z < self.k.min_range || p_cam.z > self.k.max_range {
            return false;
        }
        match self.project(p_cam) {
            Some(px) => {
                px.x >= 0.0 && px.y >= 0.0 && px.x < self.width as f32 && px.y < self.height as f32
            }
            None => false,
        }
    }
}

/// An upright cuboid: centre, size along its own axes, yaw about +z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cuboid {
    /// Centre, world frame.
    pub center: Vec3,
    /// Extent along the cuboid's x, y, z.
    pub size: Vec3,
    /// Yaw about +z, radians.
    pub yaw: f32,
}

impl Cuboid {
    /// The eight corners, world frame.
    pub fn corners(&self) -> [Vec3; 8] {
        let h = self.size * 0.5;
        let rot = Mat3::from_rotation_z(self.yaw);
        let mut out = [Vec3::ZERO; 8];
        for (i, c) in out.iter_mut().enumerate() {
            let sx = if i & 1 == 0 { -h.x } else { h.x };
            let sy = if i & 2 == 0 { -h.y } else { h.y };
            let sz = if i & 4 == 0 { -h.z } else { h.z };
            *c = self.center + rot * Vec3::new(sx, sy, sz);
        }
        out
    }

    /// Whether a world point lies inside (with a margin, metres).
    pub fn contains(&self, p: Vec3, margin: f32) -> bool {
        let local = Mat3::from_rotation_z(-self.yaw) * (p - self.center);
        let h = self.size * 0.5 + Vec3::splat(margin);
        local.x.abs() <= h.x && local.y.abs() <= h.y && local.z.abs() <= h.z
    }

    /// Axis-aligned 2D box `[x0, y0, x1, y1]` (pixels, clipped to the image) of the cuboid's
    /// projection, or `None` if no corner is in front of the camera or the box is off-image.
    /// Corners behind the camera are ignored (a conservative approximation).
    pub fn image_box(&self, camera: &Camera, world_from_camera: &Affine3A) -> Option<[f32; 4]> {
        self.image_box_in(camera, &world_from_camera.inverse())
    }

    /// [`image_box`](Self::image_box) given `camera_from_world` (the inverse pose), for callers
    /// that project many cuboids into one view.
    pub fn image_box_in(&self, camera: &Camera, cam_from_world: &Affine3A) -> Option<[f32; 4]> {
        let mut b = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        let mut any = false;
        for c in self.corners() {
            if let Some(px) = camera.project(cam_from_world.transform_point3(c)) {
                any = true;
                b = [
                    b[0].min(px.x),
                    b[1].min(px.y),
                    b[2].max(px.x),
                    b[3].max(px.y),
                ];
            }
        }
        if !any {
            return None;
        }
        let (w, h) = (camera.width as f32, camera.height as f32);
        let clipped = [
            b[0].clamp(0.0, w),
            b[1].clamp(0.0, h),
            b[2].clamp(0.0, w),
            b[3].clamp(0.0, h),
        ];
        (clipped[2] > clipped[0] && clipped[3] > clipped[1]).then_some(clipped)
    }
}

/// Convex hull of `pts` (Andrew's monotone chain), counter-clockwise starting at the point of
/// least x (then least y), written to `out[..len]`; returns `len`. Sorts `pts`; collinear and
/// duplicate points are dropped. With fewer than 3 points the hull is the sorted points.
/// Allocation-free (the simulator's detector and camera call it per object and frame).
///
/// # Panics
/// If `out` is shorter than `pts.len() + 1` (the chain's working space).
pub fn convex_hull_into(pts: &mut [Vec2], out: &mut [Vec2]) -> usize {
    assert!(
        out.len() > pts.len(),
        "convex_hull_into: output of {} for {} points",
        out.len(),
        pts.len()
    );
    pts.sort_unstable_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    if pts.len() < 3 {
        out[..pts.len()].copy_from_slice(pts);
        return pts.len();
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut k = 0;
    for &p in pts.iter() {
        while k >= 2 && cross(out[k - 2], out[k - 1], p) <= 0.0 {
            k -= 1;
        }
        out[k] = p;
        k += 1;
    }
    let lower = k + 1;
    for &p in pts.iter().rev().skip(1) {
        while k >= lower && cross(out[k - 2], out[k - 1], p) <= 0.0 {
            k -= 1;
        }
        out[k] = p;
        k += 1;
    }
    k - 1 // the last point repeats the first
}

/// [`convex_hull_into`] into a reusable vector (cleared first; allocates only to grow).
pub fn convex_hull(pts: &mut [Vec2], hull: &mut Vec<Vec2>) {
    hull.clear();
    hull.resize(pts.len() + 1, Vec2::ZERO);
    let len = convex_hull_into(pts, hull);
    hull.truncate(len);
}

/// Wrap an angle to `(-π, π]`.
pub fn wrap_angle(a: f32) -> f32 {
    let mut a = a % std::f32::consts::TAU;
    if a > std::f32::consts::PI {
        a -= std::f32::consts::TAU;
    } else if a <= -std::f32::consts::PI {
        a += std::f32::consts::TAU;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_traversal_visits_each_crossed_cell_once_in_order() {
        // From (0.5, 0.5) to (2.5, 1.5): x crossing at t = 0.25, y at 0.5, x again at 0.75.
        let cells: Vec<_> = GridTraversal::new(Vec2::new(0.5, 0.5), Vec2::new(2.5, 1.5)).collect();
        assert_eq!(cells, [(0, 0), (1, 0), (1, 1), (2, 1)]);
        let t = GridTraversal::new(Vec2::new(3.2, 0.5), Vec2::new(0.7, 0.5));
        assert_eq!(t.len(), 4);
        assert_eq!(t.collect::<Vec<_>>(), [(3, 0), (2, 0), (1, 0), (0, 0)]);
        let one: Vec<_> = GridTraversal::new(Vec2::splat(1.2), Vec2::splat(1.8)).collect();
        assert_eq!(one, [(1, 1)]);
    }
    use std::f32::consts::{FRAC_PI_2, PI};

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn optical_frame_axes() {
        let r = optical_rotation(0.0, 0.0);
        assert!(close(r.z_axis, Vec3::X) && close(r.x_axis, -Vec3::Y) && close(r.y_axis, -Vec3::Z));
        let r = optical_rotation(FRAC_PI_2, 0.0);
        assert!(close(r.z_axis, Vec3::Y));
        let r = optical_rotation(0.0, 28f32.to_radians());
        assert!(r.z_axis.z < -0.46 && r.z_axis.z > -0.47, "pitched down");
        assert!((r.determinant() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn mount_pose_round_trips_through_messages() {
        let m = CameraMount::default();
        let a = m.camera_pose([1.0, 2.0, PI], 0.5, m.pitch());
        assert!((a.translation.z - 1.4).abs() < 1e-6);
        let (yaw, pitch) = yaw_pitch_of(&a);
        assert!((wrap_angle(yaw - (PI + 0.5))).abs() < 1e-5);
        assert!((pitch - 28f32.to_radians()).abs() < 1e-5);
        let b = pose_to_affine(&affine_to_pose(&a));
        assert!(close(b.translation.into(), a.translation.into()));
        assert!(close(b.matrix3.z_axis.into(), a.matrix3.z_axis.into()));
    }

    #[test]
    fn pinhole_projects_and_unprojects() {
        let c = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 5.0);
        assert!((c.k.fx - 554.256).abs() < 1e-2);
        let p = c.unproject(100.0, 50.0, 2.0);
        let px = c.project(p).unwrap();
        assert!((px.x - 100.0).abs() < 1e-3 && (px.y - 50.0).abs() < 1e-3);
        assert!(c.sees(Vec3::new(0.0, 0.0, 2.0)));
        assert!(!c.sees(Vec3::new(0.0, 0.0, 6.0)));
        assert!(!c.sees(Vec3::new(5.0, 0.0, 2.0)));
        assert!(c.project(Vec3::new(0.0, 0.0, -1.0)).is_none());
    }

    #[test]
    fn cuboid_contains_and_projects() {
        let b = Cuboid {
            center: Vec3::new(2.0, 0.0, 0.0),
            size: Vec3::new(0.2, 0.4, 0.2),
            yaw: FRAC_PI_2,
        };
        assert!(b.contains(Vec3::new(2.19, 0.0, 0.0), 0.0));
        assert!(!b.contains(Vec3::new(2.0, 0.15, 0.0), 0.0));
        let cam = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 5.0);
        let pose = Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::ZERO);
        let bx = b.image_box(&cam, &pose).unwrap();
        assert!(bx[0] < 320.0 && bx[2] > 320.0 && bx[1] < 240.0 && bx[3] > 240.0);
        let behind = Affine3A::from_mat3_translation(optical_rotation(PI, 0.0), Vec3::ZERO);
        assert!(b.image_box(&cam, &behind).is_none());
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-5);
        assert!((wrap_angle(-3.0 * PI / 2.0) - FRAC_PI_2).abs() < 1e-5);
        assert_eq!(wrap_angle(0.25), 0.25);
    }

    #[test]
    fn hull_of_square_with_interior_points() {
        let mut pts = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(0.5, 0.5),
            Vec2::new(0.2, 0.7),
        ];
        let mut hull = Vec::new();
        convex_hull(&mut pts, &mut hull);
        assert_eq!(hull.len(), 4);
        assert!(!hull.contains(&Vec2::new(0.5, 0.5)));
    }

    #[test]
    fn hull_is_counter_clockwise_from_the_lowest_x_and_drops_collinear_points() {
        let mut pts = [
            Vec2::new(4.0, 2.0),
            Vec2::new(2.0, 0.0), // on the bottom edge
            Vec2::new(0.0, 0.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(0.0, 2.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(4.0, 0.0), // duplicate
        ];
        let mut out = [Vec2::ZERO; 8];
        let n = convex_hull_into(&mut pts, &mut out);
        let want = [(0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (0.0, 2.0)].map(|(x, y)| Vec2::new(x, y));
        assert_eq!(&out[..n], &want);
        let mut hull = vec![Vec2::ONE; 20]; // stale contents are cleared
        convex_hull(&mut pts, &mut hull);
        assert_eq!(hull, want);
    }

    #[test]
    fn hull_of_fewer_than_three_points_is_the_sorted_points() {
        let mut out = [Vec2::ZERO; 3];
        assert_eq!(convex_hull_into(&mut [], &mut out), 0);
        let mut one = [Vec2::new(1.0, 2.0)];
        assert_eq!(convex_hull_into(&mut one, &mut out), 1);
        assert_eq!(out[0], Vec2::new(1.0, 2.0));
        let mut two = [Vec2::new(3.0, 0.0), Vec2::new(1.0, 0.0)];
        assert_eq!(convex_hull_into(&mut two, &mut out), 2);
        assert_eq!(out[..2], [Vec2::new(1.0, 0.0), Vec2::new(3.0, 0.0)]);
    }
}

/// The grid cells a 2D segment crosses, in order (Amanatides–Woo traversal: each crossed cell
/// once). `a` and `b` are in cell units (world position minus grid origin, over the resolution);
/// the iterator yields `(ix, iy)` from `a`'s cell to `b`'s cell inclusive. Cells may lie outside
/// the grid: the caller bounds them.
#[derive(Debug, Clone, Copy)]
pub struct GridTraversal {
    cell: (i64, i64),
    step: (i64, i64),
    t_max: (f32, f32),
    t_delta: (f32, f32),
    left: i64,
}

impl GridTraversal {
    /// The traversal from `a` to `b` (cell units).
    pub fn new(a: Vec2, b: Vec2) -> Self {
        let cell = (a.x.floor() as i64, a.y.floor() as i64);
        let end = (b.x.floor() as i64, b.y.floor() as i64);
        let d = b - a;
        let step = (
            if d.x >= 0.0 { 1 } else { -1 },
            if d.y >= 0.0 { 1 } else { -1 },
        );
        let next = |i: i64, s: i64, p: f32, dp: f32| {
            if dp.abs() < 1e-9 {
                f32::INFINITY
            } else {
                ((i + (s > 0) as i64) as f32 - p) / dp
            }
        };
        Self {
            cell,
            step,
            t_max: (
                next(cell.0, step.0, a.x, d.x),
                next(cell.1, step.1, a.y, d.y),
            ),
            t_delta: (1.0 / d.x.abs().max(1e-9), 1.0 / d.y.abs().max(1e-9)),
            left: (end.0 - cell.0).abs() + (end.1 - cell.1).abs() + 1,
        }
    }
}

impl Iterator for GridTraversal {
    type Item = (i64, i64);

    fn next(&mut self) -> Option<(i64, i64)> {
        if self.left <= 0 {
            return None;
        }
        self.left -= 1;
        let here = self.cell;
        if self.t_max.0 < self.t_max.1 {
            self.cell.0 += self.step.0;
            self.t_max.0 += self.t_delta.0;
        } else {
            self.cell.1 += self.step.1;
            self.t_max.1 += self.t_delta.1;
        }
        Some(here)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.left.max(0) as usize;
        (n, Some(n))
    }
}

impl ExactSizeIterator for GridTraversal {}
