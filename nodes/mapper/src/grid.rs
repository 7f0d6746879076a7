//! The exploration occupancy grid built from depth (for the frontier baseline and reachability).
//!
//! Every `stride`-th pixel with valid depth casts a 2D ray from the camera to its point: cells the
//! ray crosses become more free; the end cell becomes occupied if the point lies in the obstacle
//! height band `[min_z, max_z]`, more free if it lies below it (floor), and is left alone above
//! it. Rays are cut at `max_range` (horizontal). Each cell keeps a clamped log-odds-like score
//! (hit +4, pass −1): never touched → unknown, score > 0 → occupied, else free.

use geom::GridTraversal;
use glam::{Affine3A, Vec2};
use shm_types::{DepthFrame, OccupancyGrid, grid_cell};

pub use super::config::GridConfig;

const UNKNOWN: i8 = i8::MIN;
const HIT: i8 = 4;
const CLAMP: i8 = 20;

/// The grid's state.
#[derive(Debug, Clone)]
pub struct ExplorationGrid {
    cfg: GridConfig,
    score: Vec<i8>,
}

impl ExplorationGrid {
    /// An all-unknown grid.
    pub fn new(cfg: &GridConfig) -> Self {
        Self {
            cfg: cfg.clone(),
            score: vec![UNKNOWN; cfg.width as usize * cfg.height as usize],
        }
    }

    fn cell(&self, p: Vec2) -> Option<usize> {
        let q = (p - Vec2::from(self.cfg.origin)) / self.cfg.resolution;
        if q.x < 0.0 || q.y < 0.0 {
            return None;
        }
        let (ix, iy) = (q.x as usize, q.y as usize);
        (ix < self.cfg.width as usize && iy < self.cfg.height as usize)
            .then(|| iy * self.cfg.width as usize + ix)
    }

    fn add(&mut self, i: usize, delta: i8) {
        let s = &mut self.score[i];
        let base = if *s == UNKNOWN { 0 } else { *s };
        *s = base.saturating_add(delta).clamp(-CLAMP, CLAMP);
    }

    /// Integrate one depth frame (pose from the frame).
    pub fn integrate(&mut self, frame: &DepthFrame, camera: &geom::Camera, pose: &Affine3A) {
        if !self.cfg.enabled {
            return;
        }
        let (w, h) = (frame.width as usize, frame.height as usize);
        let depth = frame.pixels();
        let cam = Vec2::new(pose.translation.x, pose.translation.y);
        let stride = self.cfg.stride as usize;
        for v in (stride / 2..h).step_by(stride) {
            for u in (stride / 2..w).step_by(stride) {
                let d = depth[v * w + u];
                if d == 0 {
                    continue;
                }
                let z = d as f32 * 1e-3;
                if z < camera.k.min_range || z > camera.k.max_range {
                    continue;
                }
                let p = pose.transform_point3(camera.unproject(u as f32 + 0.5, v as f32 + 0.5, z));
                let mut end = p.truncate();
                let mut len = (end - cam).length();
                let mut hit = true;
                if len > self.cfg.max_range {
                    end = cam + (end - cam) * (self.cfg.max_range / len);
                    len = self.cfg.max_range;
                    hit = false;
                }
                let end_cell = self.cell(end);
                self.free_along(cam, end);
                if let Some(i) = end_cell {
                    if !hit {
                        self.add(i, -1);
                    } else if p.z >= self.cfg.min_z && p.z <= self.cfg.max_z {
                        self.add(i, HIT);
                    } else if p.z < self.cfg.min_z {
                        self.add(i, -1);
                    }
                }
            }
        }
    }

    /// Lower the score of every cell a 2D segment crosses, its end cell excluded (Amanatides–Woo
    /// traversal: each crossed cell once).
    fn free_along(&mut self, from: Vec2, to: Vec2) {
        let o = Vec2::from(self.cfg.origin);
        let (a, b) = (
            (from - o) / self.cfg.resolution,
            (to - o) / self.cfg.resolution,
        );
        let (w, h) = (self.cfg.width as i64, self.cfg.height as i64);
        let cells = GridTraversal::new(a, b);
        // Every crossed cell but the last (the end cell is excluded).
        let crossed = cells.len() - 1;
        for (ix, iy) in cells.take(crossed) {
            if ix >= 0 && iy >= 0 && ix < w && iy < h {
                self.add((iy * w + ix) as usize, -1);
            }
        }
    }

    /// Write the grid into a (possibly loaned) message; the host sets the header.
    pub fn write(&self, out: &mut OccupancyGrid) {
        out.origin = self.cfg.origin;
        out.resolution = self.cfg.resolution;
        out.width = self.cfg.width;
        out.height = self.cfg.height;
        out.reserved = 0;
        for (o, s) in out.cells.iter_mut().zip(&self.score) {
            *o = match *s {
                UNKNOWN => grid_cell::UNKNOWN,
                s if s > 0 => grid_cell::OCCUPIED,
                _ => grid_cell::FREE,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Camera, optical_rotation};
    use glam::Vec3;

    #[test]
    fn wall_in_front_is_occupied_and_the_way_there_free() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let mut f = shm_types::boxed_zeroed::<DepthFrame>();
        f.width = 64;
        f.height = 48;
        f.intrinsics = cam.k;
        f.pixels_mut().fill(2000); // a wall 2 m ahead (depth is along the optical axis)
        let pose =
            Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::new(0.0, 0.0, 1.0));
        let cfg = GridConfig {
            origin: [-1.0, -1.0],
            resolution: 0.1,
            width: 40,
            height: 20,
            stride: 4,
            ..GridConfig::default()
        };
        let mut g = ExplorationGrid::new(&cfg);
        g.integrate(&f, &cam, &pose);
        let mut out = shm_types::boxed_zeroed::<OccupancyGrid>();
        g.write(&mut out);
        let at = |x: f32, y: f32| {
            let ix = ((x + 1.0) / 0.1) as usize;
            let iy = ((y + 1.0) / 0.1) as usize;
            out.used()[iy * 40 + ix]
        };
        assert_eq!(at(2.05, 0.05), grid_cell::OCCUPIED);
        assert_eq!(at(1.0, 0.05), grid_cell::FREE);
        assert_eq!(at(0.35, 0.05), grid_cell::FREE);
        assert_eq!(at(-0.5, 0.05), grid_cell::UNKNOWN, "behind the camera");
        assert_eq!(at(2.55, 0.05), grid_cell::UNKNOWN, "behind the wall");
    }
}
