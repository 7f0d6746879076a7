//! Visibility checks with the simulator's own geometry ([`World`] ray casts, the robot's
//! [`NavGrid`], the camera model and mount of the configuration): which foreground objects some
//! reachable pose sees, which are partly hidden by another object from such a pose, and which
//! support clusters the start pose does not see.

use crate::SimSetup;
use crate::{NavGrid, STRUCTURE, Scene, World};
use geom::Camera;
use glam::{Vec2, Vec3};

/// Spacing of the viewing poses sampled on the navigation grid, metres.
const POSE_SPACING: f32 = 0.2;

/// The configured camera's field of view and range at a fixed 160 × 120 pixels, so that the
/// generated scene does not depend on the image size.
fn camera(cfg: &SimSetup) -> Camera {
    let c = &cfg.camera;
    Camera::from_fov(160, 120, c.hfov_deg, c.vfov_deg, c.min_range, c.max_range)
}

/// Per object of a scene (background objects count as visible).
#[derive(Debug, Clone, PartialEq)]
pub struct Visibility {
    /// Some reachable pose sees the object (at least `min_visible_points` sample points).
    pub visible: Vec<bool>,
    /// From some reachable pose that sees it, another object hides part of it.
    pub occluded: Vec<bool>,
}

/// The free cells reachable from the start on the robot's navigation grid (4-connected flood
/// fill, so reachable here is reachable for the 8-connected planner too).
pub fn reachable_cells(scene: &Scene, cfg: impl Into<SimSetup>) -> (NavGrid, Vec<bool>) {
    let cfg: &SimSetup = &cfg.into();
    let grid = NavGrid::build(scene, cfg.robot.radius, cfg.robot.grid_resolution)
        .expect("generated rooms fit the navigation grid");
    let mut seen = vec![false; grid.occupied.len()];
    let start = Vec2::new(scene.robot_start[0], scene.robot_start[1]);
    let Some((sx, sy)) = grid.cell(start) else {
        return (grid, seen);
    };
    let mut stack = vec![(sx, sy)];
    seen[sy * grid.width + sx] = true;
    while let Some((x, y)) = stack.pop() {
        let next = [
            (x.wrapping_sub(1), y),
            (x + 1, y),
            (x, y.wrapping_sub(1)),
            (x, y + 1),
        ];
        for (nx, ny) in next {
            if nx >= grid.width || ny >= grid.height {
                continue;
            }
            let i = ny * grid.width + nx;
            if !seen[i] && !grid.occupied[i] {
                seen[i] = true;
                stack.push((nx, ny));
            }
        }
    }
    (grid, seen)
}

/// Ten points inside object `k` (its centre, and ±35 % of its extents along each axis: inside
/// boxes and cylinders alike); a ray that reaches one enters the object's surface first.
fn sample_points(scene: &Scene, k: usize) -> [Vec3; 10] {
    let o = &scene.objects[k];
    let (s, c) = o.yaw.sin_cos();
    let h = o.size * 0.35;
    let mut out = [o.center; 10];
    for (i, p) in out.iter_mut().enumerate().take(8) {
        let l = Vec3::new(
            if i & 1 == 0 { -h.x } else { h.x },
            if i & 2 == 0 { -h.y } else { h.y },
            if i & 4 == 0 { -h.z } else { h.z },
        );
        *p = o.center + Vec3::new(c * l.x - s * l.y, s * l.x + c * l.y, l.z);
    }
    out[9] = o.center + Vec3::Z * h.z;
    out
}

/// Check every foreground object from the reachable poses of the scene.
pub fn check(scene: &Scene, cfg: impl Into<SimSetup>) -> Visibility {
    let cfg: &SimSetup = &cfg.into();
    let (grid, reach) = reachable_cells(scene, cfg);
    let stride = ((POSE_SPACING / grid.resolution).round() as usize).max(1);
    let poses: Vec<Vec2> = (0..grid.height)
        .step_by(stride)
        .flat_map(|y| (0..grid.width).step_by(stride).map(move |x| (x, y)))
        .filter(|&(x, y)| reach[y * grid.width + x])
        .map(|(x, y)| grid.center(x, y))
        .collect();
    let world = World::new(scene);
    let camera = camera(cfg);
    let mount = cfg.camera.mount;
    let g = &cfg.scenegen;
    let n = scene.objects.len();
    let mut vis = Visibility {
        visible: scene.objects.iter().map(|o| o.background).collect(),
        occluded: vec![false; n],
    };
    for k in scene.foreground() {
        let points = sample_points(scene, k);
        let target = scene.objects[k].center;
        for p in &poses {
            let dist = (target.truncate() - *p).length();
            if dist < g.view_min_m || dist > g.view_max_m {
                continue;
            }
            let to = target.truncate() - *p;
            let pose = mount.camera_pose([p.x, p.y, to.y.atan2(to.x)], 0.0, mount.pitch());
            let cam_from_world = pose.inverse();
            let eye = Vec3::from(pose.translation);
            let (mut seen, mut hidden) = (0, false);
            for q in points {
                if !camera.sees(cam_from_world.transform_point3(q)) {
                    continue;
                }
                let d = q - eye;
                let len = d.length();
                match world.cast(eye, d / len, len + 0.01) {
                    Some(h) if h.instance as usize == k + 1 => seen += 1,
                    Some(h) if h.instance != STRUCTURE => hidden = true,
                    _ => {}
                }
            }
            if seen >= g.min_visible_points {
                vis.visible[k] = true;
                vis.occluded[k] |= hidden;
                if vis.occluded[k] {
                    break;
                }
            }
        }
    }
    vis
}

/// The support clusters of a scene: background objects carrying at least one foreground
/// object, with their objects.
pub fn support_clusters(scene: &Scene) -> Vec<(usize, Vec<usize>)> {
    (0..scene.objects.len())
        .filter(|&b| scene.objects[b].background)
        .map(|b| {
            let members: Vec<usize> = scene
                .foreground()
                .filter(|&i| scene.cluster_of(i) == Some(b))
                .collect();
            (b, members)
        })
        .filter(|(_, m)| !m.is_empty())
        .collect()
}

/// Support clusters (anchor indices) of which the start view (neck straight ahead) sees no
/// pixel: neither the support nor any of its objects, on a 64 × 48 ray grid over the image.
pub fn clusters_out_of_start_view(scene: &Scene, cfg: impl Into<SimSetup>) -> Vec<usize> {
    let cfg: &SimSetup = &cfg.into();
    let world = World::new(scene);
    let camera = camera(cfg);
    let mount = cfg.camera.mount;
    let pose = mount.camera_pose(scene.robot_start, 0.0, mount.pitch());
    let eye = Vec3::from(pose.translation);
    let mut hit = vec![false; scene.objects.len() + 1];
    let (cols, rows) = (64, 48);
    for r in 0..rows {
        for c in 0..cols {
            let u = (c as f32 + 0.5) / cols as f32 * camera.width as f32;
            let v = (r as f32 + 0.5) / rows as f32 * camera.height as f32;
            let dir = pose.matrix3 * camera.ray(u, v);
            if let Some(h) = world.cast(eye, dir, camera.k.max_range * 2.0)
                && h.t <= camera.k.max_range
            {
                hit[h.instance as usize] = true;
            }
        }
    }
    support_clusters(scene)
        .into_iter()
        .filter(|(b, m)| !hit[b + 1] && m.iter().all(|&i| !hit[i + 1]))
        .map(|(b, _)| b)
        .collect()
}
