//! Visual localization failure model.
//!
//! Simulated features are points sampled on object surfaces (dense: textured) and on the walls
//! (sparse: mostly plain); the floor has none. A feature is seen in a frame when it is inside the
//! frustum and range and not occluded (its depth matches the noise-free render). Tracking holds
//! while at least K features are seen in both of two consecutive frames and the camera turns no
//! faster than the motion-blur limit; otherwise the robot is lost until a frame in which tracking
//! holds again (re-observation). An episode counts as a localization failure (paper, section 4)
//! once it has lasted longer than a minimum time while the base drove farther than a minimum
//! distance.

use super::camera::RenderBuffers;
use super::config::SimConfig;
use super::scene::{Scene, Shape};
use geom::Camera;
use glam::{Affine3A, Mat3, Vec3};
use rand::Rng;
use rand_pcg::Pcg64;

/// Sample `density` points per m² on the rectangle `c ± u ± v` with normal `n`.
fn sample_face(
    rng: &mut Pcg64,
    (c, u, v, n): (Vec3, Vec3, Vec3, Vec3),
    density: f32,
    points: &mut Vec<Vec3>,
    normals: &mut Vec<Vec3>,
) {
    let want = 4.0 * u.length() * v.length() * density;
    let count = want.floor() as usize + usize::from(rng.random::<f32>() < want.fract());
    for _ in 0..count {
        let (a, b) = (
            rng.random_range(-1.0..1.0f32),
            rng.random_range(-1.0..1.0f32),
        );
        points.push(c + u * a + v * b);
        normals.push(n);
    }
}

/// Feature points and the tracking state.
#[derive(Debug, Clone)]
pub struct Localization {
    points: Vec<Vec3>,
    normals: Vec<Vec3>,
    prev: Vec<u64>,
    cur: Vec<u64>,
    have_prev: bool,
    min_tracked: u32,
    max_rate: f32,
    min_duration_ns: u64,
    min_distance: f32,
    ok: bool,
    lost_since_ns: u64,
    lost_distance: f32,
    counted: bool,
    failures: u32,
    last_tracked: u32,
}

impl Localization {
    /// Sample features on the scene's objects and walls (deterministic for a scene and config).
    pub fn new(scene: &Scene, cfg: &SimConfig) -> Self {
        let mut rng = Pcg64::new(0x5eed_f00d, 0x0da3_e39c_b94b_95bd);
        let mut points = Vec::new();
        let mut normals = Vec::new();
        let mut face = |rng: &mut Pcg64, c: Vec3, u: Vec3, v: Vec3, n: Vec3, density: f32| {
            sample_face(rng, (c, u, v, n), density, &mut points, &mut normals);
        };
        let mut side_points = Vec::new();
        let mut side_normals = Vec::new();
        for o in &scene.objects {
            let rot = Mat3::from_rotation_z(o.yaw);
            let h = o.size * 0.5;
            let d = cfg.feature_density_objects;
            let top = o.center + Vec3::Z * h.z;
            match o.shape {
                Shape::Box => {
                    let (x, y) = (rot * Vec3::X, rot * Vec3::Y);
                    face(&mut rng, top, x * h.x, y * h.y, Vec3::Z, d);
                    for (n, t, ht, hn) in [(x, y, h.y, h.x), (y, x, h.x, h.y)] {
                        for s in [1.0, -1.0] {
                            let c = o.center + n * (s * hn);
                            face(&mut rng, c, t * ht, Vec3::Z * h.z, n * s, d);
                        }
                    }
                }
                Shape::Cylinder => {
                    let r = h.x;
                    let side = std::f32::consts::TAU * r * o.size.z * d;
                    let cap = std::f32::consts::PI * r * r * d;
                    for _ in 0..side.round() as usize {
                        let a = rng.random_range(0.0..std::f32::consts::TAU);
                        let n = Vec3::new(a.cos(), a.sin(), 0.0);
                        let z = rng.random_range(-h.z..h.z);
                        side_points.push(o.center + n * r + Vec3::Z * z);
                        side_normals.push(n);
                    }
                    for _ in 0..cap.round() as usize {
                        let (a, q) = (
                            rng.random_range(0.0..std::f32::consts::TAU),
                            rng.random::<f32>().sqrt() * r,
                        );
                        side_points.push(top + Vec3::new(a.cos() * q, a.sin() * q, 0.0));
                        side_normals.push(Vec3::Z);
                    }
                }
            }
        }
        let r = scene.room;
        let (c, hh) = ((r.min + r.max) * 0.5, (r.max - r.min) * 0.5);
        let zc = Vec3::Z * (r.height * 0.5);
        let vz = Vec3::Z * (r.height * 0.5);
        let dw = cfg.feature_density_walls;
        face(
            &mut rng,
            Vec3::new(r.min.x, c.y, 0.0) + zc,
            Vec3::Y * hh.y,
            vz,
            Vec3::X,
            dw,
        );
        face(
            &mut rng,
            Vec3::new(r.max.x, c.y, 0.0) + zc,
            Vec3::Y * hh.y,
            vz,
            Vec3::NEG_X,
            dw,
        );
        face(
            &mut rng,
            Vec3::new(c.x, r.min.y, 0.0) + zc,
            Vec3::X * hh.x,
            vz,
            Vec3::Y,
            dw,
        );
        face(
            &mut rng,
            Vec3::new(c.x, r.max.y, 0.0) + zc,
            Vec3::X * hh.x,
            vz,
            Vec3::NEG_Y,
            dw,
        );
        // Partition walls carry wall texture on their four sides.
        for p in &scene.partitions {
            let rot = Mat3::from_rotation_z(p.yaw);
            let (x, y) = (rot * Vec3::X, rot * Vec3::Y);
            let (h, mid) = (p.size * 0.5, p.center.extend(r.height * 0.5));
            for (n, t, ht, hn) in [(x, y, h.y, h.x), (y, x, h.x, h.y)] {
                for s in [1.0, -1.0] {
                    face(&mut rng, mid + n * (s * hn), t * ht, vz, n * s, dw);
                }
            }
        }
        points.extend(side_points);
        normals.extend(side_normals);
        let words = points.len().div_ceil(64);
        Self {
            points,
            normals,
            prev: vec![0; words],
            cur: vec![0; words],
            have_prev: false,
            min_tracked: cfg.min_tracked_features,
            max_rate: cfg.max_track_rate_deg_s.to_radians(),
            min_duration_ns: (cfg.failure_min_duration_s as f64 * 1e9) as u64,
            min_distance: cfg.failure_min_distance_m,
            ok: true,
            lost_since_ns: 0,
            lost_distance: 0.0,
            counted: false,
            failures: 0,
            last_tracked: 0,
        }
    }

    /// Number of feature points in the world.
    pub fn feature_count(&self) -> usize {
        self.points.len()
    }

    /// Whether tracking currently holds.
    pub fn is_ok(&self) -> bool {
        self.ok
    }

    /// Localization-failure episodes counted so far.
    pub fn failures(&self) -> u32 {
        self.failures
    }

    /// Features tracked between the last two frames.
    pub fn last_tracked(&self) -> u32 {
        self.last_tracked
    }

    /// Features seen in a frame rendered from `world_from_camera` (the true pose) into `buf`.
    /// Allocation-free.
    pub fn count_visible(
        &mut self,
        camera: &Camera,
        world_from_camera: &Affine3A,
        buf: &RenderBuffers,
    ) -> u32 {
        let cam_from_world = world_from_camera.inverse();
        let eye = Vec3::from(world_from_camera.translation);
        let w = camera.width as usize;
        let mut seen = 0;
        self.cur.fill(0);
        for (i, (p, n)) in self.points.iter().zip(&self.normals).enumerate() {
            if n.dot(eye - *p) <= 0.0 {
                continue;
            }
            let pc = cam_from_world.transform_point3(*p);
            if !camera.sees(pc) {
                continue;
            }
            let Some(px) = camera.project(pc) else {
                continue;
            };
            let z = buf.depth_true[px.y as usize * w + px.x as usize];
            if (z - pc.z).abs() <= 0.02 + 0.01 * pc.z {
                self.cur[i / 64] |= 1 << (i % 64);
                seen += 1;
            }
        }
        seen
    }

    /// Update the tracking state after a frame: `turn_rate` is the camera's yaw rate (rad/s),
    /// `distance` the base's total driven distance (m), `now_ns` the simulated time.
    /// Call right after [`Localization::count_visible`] for the same frame.
    pub fn update(&mut self, turn_rate: f32, distance: f32, now_ns: u64) {
        let tracked: u32 = if self.have_prev {
            self.prev
                .iter()
                .zip(&self.cur)
                .map(|(a, b)| (a & b).count_ones())
                .sum()
        } else {
            self.cur.iter().map(|b| b.count_ones()).sum()
        };
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.have_prev = true;
        self.last_tracked = tracked;
        let ok = tracked >= self.min_tracked && turn_rate.abs() <= self.max_rate;
        match (self.ok, ok) {
            (true, false) => {
                self.ok = false;
                self.lost_since_ns = now_ns;
                self.lost_distance = distance;
                self.counted = false;
            }
            (false, true) => self.ok = true,
            _ => {}
        }
        if !self.ok
            && !self.counted
            && now_ns.saturating_sub(self.lost_since_ns) > self.min_duration_ns
            && distance - self.lost_distance > self.min_distance
        {
            self.counted = true;
            self.failures += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn episodes_count_only_when_long_and_far() {
        let scene = Scene::builtin("paper-scene-1").unwrap();
        let mut loc = Localization::new(&scene, &SimConfig::default());
        assert!(loc.feature_count() > 500, "{}", loc.feature_count());
        let s = 1_000_000_000u64;
        // Frames with no features seen: lost at once.
        loc.update(0.0, 0.0, 0);
        assert!(!loc.is_ok());
        // Lost 2 s but only 0.2 m driven: not a failure.
        loc.update(0.0, 0.2, 2 * s);
        assert_eq!(loc.failures(), 0);
        // Then 0.4 m: a failure, counted once.
        loc.update(0.0, 0.4, 2 * s + 1);
        loc.update(0.0, 0.9, 3 * s);
        assert_eq!(loc.failures(), 1);
        // Re-observation: every feature seen in two consecutive frames.
        loc.cur.iter_mut().for_each(|w| *w = u64::MAX);
        loc.update(0.0, 1.0, 4 * s);
        assert!(!loc.is_ok(), "previous frame saw nothing");
        loc.cur.iter_mut().for_each(|w| *w = u64::MAX);
        loc.update(0.0, 1.0, 5 * s);
        assert!(loc.is_ok());
        // Motion blur: too fast a turn loses tracking even with features in view.
        loc.cur.iter_mut().for_each(|w| *w = u64::MAX);
        loc.update(10.0, 1.0, 6 * s);
        assert!(!loc.is_ok());
        // Short episode: 0.5 s, 1 m.
        loc.cur.iter_mut().for_each(|w| *w = u64::MAX);
        loc.update(0.0, 2.0, 6 * s + s / 2);
        assert!(loc.is_ok());
        assert_eq!(loc.failures(), 1);
    }
}
