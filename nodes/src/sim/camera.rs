//! The simulated depth camera: ray casting with rayon over image rows, Kinect-like noise.

use super::config::SimConfig;
use super::world::World;
use crate::config::CameraConfig;
use crate::geom::Camera;
use glam::{Affine3A, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Scratch images of one render, reused frame to frame (no allocation in steady state).
#[derive(Debug, Clone)]
pub struct RenderBuffers {
    /// Instance per pixel: `k + 1` for scene object `k`, 0 for structure or no hit.
    pub instance: Vec<u8>,
    /// Noise-free depth per pixel, metres (0 if the ray hit nothing), regardless of range limits.
    pub depth_true: Vec<f32>,
}

impl RenderBuffers {
    /// Buffers for the largest supported image.
    pub fn new() -> Self {
        Self {
            instance: vec![0; shm_types::MAX_PIXELS],
            depth_true: vec![0.0; shm_types::MAX_PIXELS],
        }
    }
}

impl Default for RenderBuffers {
    fn default() -> Self {
        Self::new()
    }
}

/// A pinhole depth camera with a Kinect-like noise model.
///
/// Depth noise: σ(z) = a + b·z² (Gaussian, metres). A pixel is invalid (0) if its true depth is
/// outside `[min_range, max_range]`, if the angle between the ray and the surface normal exceeds
/// the grazing limit, or at random with the dropout probability. Every pixel's noise comes from a
/// PCG stream derived from (seed, frame index, row), so a frame is the same whatever the threads.
#[derive(Debug, Clone)]
pub struct DepthCamera {
    camera: Camera,
    noise_a: f32,
    noise_b: f32,
    cos_grazing: f32,
    dropout: f32,
    seed: u64,
}

impl DepthCamera {
    /// A camera from the `[camera]` and `[sim]` sections, with a noise seed.
    pub fn new(cam: &CameraConfig, sim: &SimConfig, seed: u64) -> Self {
        Self {
            camera: cam.camera(),
            noise_a: sim.noise_a,
            noise_b: sim.noise_b,
            cos_grazing: sim.grazing_deg.to_radians().cos(),
            dropout: sim.dropout,
            seed,
        }
    }

    /// The same camera without noise or dropouts (grazing and range limits still apply).
    pub fn noiseless(mut self) -> Self {
        self.noise_a = 0.0;
        self.noise_b = 0.0;
        self.dropout = 0.0;
        self
    }

    /// The pinhole model.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Render `world` seen from `world_from_camera` (optical frame, the TRUE pose) into
    /// `depth_mm` (row-major, `width × height` entries, millimetres, 0 = invalid) and `buf`.
    /// Rows run in parallel on the current rayon pool.
    ///
    /// # Panics
    /// If `depth_mm` is shorter than `width × height`.
    pub fn render(
        &self,
        world: &World,
        world_from_camera: &Affine3A,
        frame_index: u64,
        depth_mm: &mut [u16],
        buf: &mut RenderBuffers,
    ) {
        let w = self.camera.width as usize;
        let n = w * self.camera.height as usize;
        let origin = Vec3::from(world_from_camera.translation);
        let rot = world_from_camera.matrix3;
        let k = self.camera.k;
        let far = k.max_range.max(1.0) * 4.0;
        depth_mm[..n]
            .par_chunks_mut(w)
            .zip(buf.instance[..n].par_chunks_mut(w))
            .zip(buf.depth_true[..n].par_chunks_mut(w))
            .enumerate()
            .for_each(|(v, ((depth_row, inst_row), true_row))| {
                let mut rng = row_rng(self.seed, frame_index, v as u64);
                let y = (v as f32 + 0.5 - k.cy) / k.fy;
                for (u, ((d, inst), zt)) in depth_row
                    .iter_mut()
                    .zip(inst_row.iter_mut())
                    .zip(true_row.iter_mut())
                    .enumerate()
                {
                    let dir_cam = Vec3::new((u as f32 + 0.5 - k.cx) / k.fx, y, 1.0);
                    let dir = Vec3::from(rot * dir_cam);
                    let Some(hit) = world.cast(origin, dir, far) else {
                        (*d, *inst, *zt) = (0, 0, 0.0);
                        continue;
                    };
                    *inst = hit.instance;
                    *zt = hit.t;
                    *d = self.measure(hit.t, hit.normal.dot(dir).abs() / dir.length(), &mut rng);
                }
            });
    }

    /// Depth reading (mm, 0 = invalid) of a surface at true depth `z` whose normal makes an angle
    /// with cosine `cos_incidence` with the ray.
    fn measure(&self, z: f32, cos_incidence: f32, rng: &mut Pcg64) -> u16 {
        let k = &self.camera.k;
        if z < k.min_range || z > k.max_range || cos_incidence < self.cos_grazing {
            return 0;
        }
        if self.dropout > 0.0 && rng.random::<f32>() < self.dropout {
            return 0;
        }
        let sigma = self.noise_a + self.noise_b * z * z;
        let z = if sigma > 0.0 {
            z + sigma * rng.sample::<f32, _>(StandardNormal)
        } else {
            z
        };
        (z * 1000.0).round().clamp(1.0, u16::MAX as f32) as u16
    }
}

/// A PCG stream for one row of one frame.
fn row_rng(seed: u64, frame: u64, row: u64) -> Pcg64 {
    let s = super::mix(seed, &[0x6465_7074, frame, row]);
    Pcg64::new(
        s as u128 | ((row as u128) << 64),
        0xa02b_dbf7_bb3c_0a7a_c28f_a16a_64ab_f96d,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::optical_rotation;
    use crate::sim::scene::Scene;
    use std::path::Path;

    fn world_with_box_at(x: f32) -> World {
        World::new(
            &Scene::parse(
                Path::new("t.toml"),
                &format!(
                    "name = \"t\"\n[room]\nmin = [-6.0, -6.0]\nmax = [6.0, 6.0]\nheight = 3.0\n\
                     [robot]\nstart = [0.0, 0.0, 0.0]\n\
                     [[object]]\nname = \"b\"\nclass = \"book\"\ncenter = [{x}, 0.0, 1.0]\n\
                     size = [0.5, 1.0, 1.0]\n"
                ),
            )
            .unwrap(),
        )
    }

    fn camera(width: u32, height: u32) -> DepthCamera {
        let cam = CameraConfig {
            width,
            height,
            ..CameraConfig::default()
        };
        DepthCamera::new(&cam, &SimConfig::default(), 7)
    }

    #[test]
    fn centre_pixel_sees_the_analytic_depth_of_a_box() {
        // Camera at (0, 0, 1) looking along +x; the box's near face is at x = 2.75 - 0.25.
        let world = world_with_box_at(2.75);
        let pose = Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::Z);
        for (w, h) in [(640, 480), (320, 240), (161, 97)] {
            let cam = camera(w, h).noiseless();
            let mut depth = vec![0u16; (w * h) as usize];
            let mut buf = RenderBuffers::new();
            cam.render(&world, &pose, 0, &mut depth, &mut buf);
            let centre = (h / 2 * w + w / 2) as usize;
            assert!(
                (i32::from(depth[centre]) - 2500).abs() <= 1,
                "{}",
                depth[centre]
            );
            assert_eq!(buf.instance[centre], 1);
            assert!((buf.depth_true[centre] - 2.5).abs() < 1e-4);
        }
    }

    #[test]
    fn noise_grows_with_depth_and_is_seeded() {
        let pose = Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::Z);
        let (w, h) = (64, 48);
        let stats = |x: f32, seed: u64| {
            let world = world_with_box_at(x);
            let cam = DepthCamera::new(
                &CameraConfig {
                    width: w,
                    height: h,
                    ..CameraConfig::default()
                },
                &SimConfig {
                    dropout: 0.0,
                    ..SimConfig::default()
                },
                seed,
            );
            let mut depth = vec![0u16; (w * h) as usize];
            let mut buf = RenderBuffers::new();
            cam.render(&world, &pose, 3, &mut depth, &mut buf);
            let errs: Vec<f32> = (0..depth.len())
                .filter(|&i| buf.instance[i] == 1 && depth[i] > 0)
                .map(|i| depth[i] as f32 / 1000.0 - buf.depth_true[i])
                .collect();
            let rms = (errs.iter().map(|e| e * e).sum::<f32>() / errs.len() as f32).sqrt();
            (depth, rms)
        };
        let (near, rms_near) = stats(1.25, 1);
        let (_, rms_far) = stats(3.75, 1);
        // σ(1 m) ≈ 3.1 mm, σ(3.5 m) ≈ 24.5 mm.
        assert!(rms_near > 0.0015 && rms_near < 0.0055, "{rms_near}");
        assert!(rms_far > 0.015 && rms_far < 0.035, "{rms_far}");
        assert_eq!(stats(1.25, 1).0, near, "same seed, same frame");
        assert_ne!(stats(1.25, 2).0, near, "different seed, different noise");
    }

    #[test]
    fn grazing_and_out_of_range_pixels_are_invalid() {
        let cam = camera(64, 48).noiseless();
        let mut rng = row_rng(0, 0, 0);
        let cos = |deg: f32| deg.to_radians().cos();
        assert_eq!(cam.measure(2.0, cos(60.0), &mut rng), 2000);
        assert_eq!(cam.measure(2.0, cos(85.0), &mut rng), 0, "grazing");
        assert_eq!(cam.measure(0.3, 1.0, &mut rng), 0, "nearer than min range");
        assert_eq!(cam.measure(5.2, 1.0, &mut rng), 0, "beyond max range");
        // In a render: straight ahead the wall is 6 m away, beyond 5 m.
        let world = world_with_box_at(2.75);
        let mut depth = vec![0u16; 64 * 48];
        let mut buf = RenderBuffers::new();
        let pose = Affine3A::from_mat3_translation(optical_rotation(3.14159, 0.0), Vec3::Z);
        cam.render(&world, &pose, 0, &mut depth, &mut buf);
        let centre = 24 * 64 + 32;
        assert_eq!(depth[centre], 0);
        assert!((buf.depth_true[centre] - 6.0).abs() < 1e-3);
    }
}
