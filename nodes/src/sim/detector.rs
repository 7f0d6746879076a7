//! The simulated instance-segmentation detector (a YOLO stand-in) working on the instance render.
//!
//! Per visible scene object (background objects included, walls and floor excluded):
//! - **miss**: never below `min_pixels`; otherwise with probability
//!   `miss_rate + miss_small·max(0, 1 − pixels/small_pixels) + miss_occluded·(1 − visible)`,
//!   where `visible` is the visible pixel count over the area of the object's unoccluded
//!   silhouette (convex hull of its projected corners / rim points, clipped to the image);
//! - **label confusion** within configured look-alike groups (cup/bottle/vase, book/keyboard);
//! - **score** lower for occluded objects, with noise;
//! - **mask bleed**: each mask grows by a random 0..=`mask_bleed_px` pixels (4-neighbour
//!   dilation) onto neighbouring objects and the background;
//! - **box jitter** on each edge of the mask's bounding box.
//!
//! All randomness comes from a PCG stream per (seed, frame, object).

use super::config::DetectorConfig;
use super::scene::{Scene, Shape};
use crate::geom::{Camera, convex_hull_into};
use glam::{Affine3A, Mat3, Vec2, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use shm_types::{ClassId, Detection, Detections, MAX_DETECTIONS, MAX_OBJECTS, MAX_PIXELS};

/// Points per silhouette (32 rim points for a cylinder, 8 corners for a box).
const SIL_POINTS: usize = 32;
/// Capacity of the clipped hull polygon.
pub(super) const POLY_CAP: usize = SIL_POINTS + 8;

#[derive(Debug, Clone, Copy, Default)]
struct Stat {
    pixels: u32,
    bbox: [u32; 4],
}

impl Stat {
    fn reset(&mut self) {
        *self = Stat {
            pixels: 0,
            bbox: [u32::MAX, u32::MAX, 0, 0],
        };
    }

    fn add(&mut self, x: u32, y: u32) {
        self.pixels += 1;
        self.bbox = [
            self.bbox[0].min(x),
            self.bbox[1].min(y),
            self.bbox[2].max(x + 1),
            self.bbox[3].max(y + 1),
        ];
    }
}

#[derive(Debug, Clone, Copy)]
struct Candidate {
    object: usize,
    pixels: u32,
    class_id: ClassId,
    score: f32,
    bleed: u32,
}

/// The detector with its per-frame scratch (no allocation in steady state).
#[derive(Debug, Clone)]
pub struct Detector {
    cfg: DetectorConfig,
    groups: Vec<Vec<ClassId>>,
    seed: u64,
    class_ids: Vec<ClassId>,
    silhouettes: Vec<([Vec3; SIL_POINTS], usize)>,
    stats: Vec<Stat>,
    scratch: Vec<u8>,
}

impl Detector {
    /// A detector for a scene's objects.
    pub fn new(scene: &Scene, cfg: &DetectorConfig, seed: u64) -> Self {
        let groups = cfg
            .confusion_groups
            .iter()
            .map(|g| g.iter().filter_map(|n| shm_types::class_id(n)).collect())
            .collect();
        let silhouettes = scene
            .objects
            .iter()
            .map(|o| {
                let mut pts = [Vec3::ZERO; SIL_POINTS];
                let n = match o.shape {
                    Shape::Box => {
                        for (p, c) in pts.iter_mut().zip(o.cuboid().corners()) {
                            *p = c;
                        }
                        8
                    }
                    Shape::Cylinder => {
                        let r = o.size.x * 0.5;
                        let h = o.size.z * 0.5;
                        let rot = Mat3::from_rotation_z(o.yaw);
                        for (i, p) in pts.iter_mut().enumerate() {
                            let a = (i / 2) as f32 * std::f32::consts::TAU / 16.0;
                            // Circumscribed 16-gon so the hull does not under-cover the disc.
                            let rr = r / (std::f32::consts::PI / 16.0).cos();
                            let z = if i % 2 == 0 { h } else { -h };
                            *p = o.center + rot * Vec3::new(a.cos() * rr, a.sin() * rr, z);
                        }
                        SIL_POINTS
                    }
                };
                (pts, n)
            })
            .collect();
        Self {
            cfg: cfg.clone(),
            groups,
            seed,
            class_ids: scene.objects.iter().map(|o| o.class_id).collect(),
            silhouettes,
            stats: vec![Stat::default(); MAX_OBJECTS + 1],
            scratch: vec![0; MAX_PIXELS],
        }
    }

    /// Detect objects in an instance image (`instance[p] = k + 1` for scene object `k`, 0 for
    /// none) rendered by `camera` from `world_from_camera` (true pose). Writes `out.width`,
    /// `out.height`, `out.count`, `out.items` and the label image; headers are the caller's.
    pub fn detect(
        &mut self,
        instance: &[u8],
        camera: &Camera,
        world_from_camera: &Affine3A,
        frame_index: u64,
        out: &mut Detections,
    ) {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let n = w * h;
        out.width = w as u32;
        out.height = h as u32;
        out.masks = shm_types::mask_mode::MASKS;
        out.count = 0;

        // 1. Visible pixels and boxes per object.
        let objects = self.class_ids.len();
        self.stats[..=objects].iter_mut().for_each(Stat::reset);
        for (y, row) in instance[..n].chunks_exact(w).enumerate() {
            for (x, &k) in row.iter().enumerate() {
                if k != 0 && (k as usize) <= objects {
                    self.stats[k as usize].add(x as u32, y as u32);
                }
            }
        }

        // 2. Decide per object.
        let mut cands = [Candidate {
            object: 0,
            pixels: 0,
            class_id: 0,
            score: 0.0,
            bleed: 0,
        }; MAX_OBJECTS];
        let mut count = 0;
        let cam_from_world = world_from_camera.inverse();
        for k in 0..objects {
            let pixels = self.stats[k + 1].pixels;
            if pixels < self.cfg.min_pixels {
                continue;
            }
            let mut rng = Pcg64::new(
                super::mix(self.seed, &[0x6465_7465, frame_index, k as u64]) as u128,
                0x5851_f42d_4c95_7f2d_1405_7b7e_f767_814f,
            );
            let area = self.silhouette_area(k, camera, &cam_from_world);
            let visible = area.map_or(1.0, |a| (pixels as f32 / a.max(1.0)).min(1.0));
            let small = (1.0 - pixels as f32 / self.cfg.small_pixels as f32).max(0.0);
            let p_miss = (self.cfg.miss_rate
                + self.cfg.miss_small * small
                + self.cfg.miss_occluded * (1.0 - visible))
                .clamp(0.0, 1.0);
            if rng.random::<f32>() < p_miss {
                continue;
            }
            let mut class_id = self.class_ids[k];
            if let Some(g) = self.groups.iter().find(|g| g.contains(&class_id))
                && g.len() > 1
                && rng.random::<f32>() < self.cfg.confusion_rate
            {
                let others = g.iter().filter(|c| **c != class_id).count();
                let pick = rng.random_range(0..others);
                class_id = *g
                    .iter()
                    .filter(|c| **c != class_id)
                    .nth(pick)
                    .unwrap_or(&class_id);
            }
            let noise: f32 = rng.sample(StandardNormal);
            let score = (self.cfg.score_mean * (0.6 + 0.4 * visible) + self.cfg.score_std * noise)
                .clamp(0.05, 0.99);
            let bleed = rng.random_range(0..=self.cfg.mask_bleed_px);
            cands[count] = Candidate {
                object: k,
                pixels,
                class_id,
                score,
                bleed,
            };
            count += 1;
        }
        if count > MAX_DETECTIONS {
            cands[..count]
                .sort_unstable_by(|a, b| b.pixels.cmp(&a.pixels).then(a.object.cmp(&b.object)));
            count = MAX_DETECTIONS;
            cands[..count].sort_unstable_by_key(|c| c.object);
        }

        // 3. Label image: instance → label (1-based), missed objects → 0.
        let mut map = [0u8; 256];
        let mut bleed = [0u32; 256];
        for (l, c) in cands[..count].iter().enumerate() {
            map[c.object + 1] = (l + 1) as u8;
            bleed[l + 1] = c.bleed;
        }
        let labels = &mut out.labels[..n];
        for (l, &k) in labels.iter_mut().zip(&instance[..n]) {
            *l = map[k as usize];
        }

        // 4. Mask bleed: `max` passes of a 4-neighbour dilation, each label up to its radius,
        //    only inside the detections' boxes grown by the largest radius.
        let max_bleed = cands[..count].iter().map(|c| c.bleed).max().unwrap_or(0);
        if max_bleed > 0 {
            let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
            for c in &cands[..count] {
                let b = self.stats[c.object + 1].bbox;
                let m = max_bleed as usize;
                x0 = x0.min((b[0] as usize).saturating_sub(m));
                y0 = y0.min((b[1] as usize).saturating_sub(m));
                x1 = x1.max((b[2] as usize + m).min(w));
                y1 = y1.max((b[3] as usize + m).min(h));
            }
            for pass in 1..=max_bleed {
                self.scratch[y0 * w..y1 * w].copy_from_slice(&labels[y0 * w..y1 * w]);
                let src = &self.scratch[..n];
                labels[y0 * w..y1 * w]
                    .par_chunks_mut(w)
                    .enumerate()
                    .for_each(|(r, row)| {
                        let y = y0 + r;
                        let grows =
                            |q: u8, own: u8| q != own && q != 0 && bleed[q as usize] >= pass;
                        for (x, out) in row.iter_mut().enumerate().take(x1).skip(x0) {
                            let i = y * w + x;
                            let own = src[i];
                            let neighbours = [
                                (x > 0).then(|| src[i - 1]),
                                (x + 1 < w).then(|| src[i + 1]),
                                (y > 0).then(|| src[i - w]),
                                (y + 1 < h).then(|| src[i + w]),
                            ];
                            if let Some(q) =
                                neighbours.into_iter().flatten().find(|q| grows(*q, own))
                            {
                                *out = q;
                            }
                        }
                    });
            }
        }

        // 5. Final masks, jittered boxes.
        self.stats[..=count].iter_mut().for_each(Stat::reset);
        for (y, row) in labels.chunks_exact(w).enumerate() {
            for (x, &l) in row.iter().enumerate() {
                if l != 0 {
                    self.stats[l as usize].add(x as u32, y as u32);
                }
            }
        }
        for (l, c) in cands[..count].iter().enumerate() {
            let s = self.stats[l + 1];
            let mut rng = Pcg64::new(
                super::mix(self.seed, &[0x0062_6f78, frame_index, c.object as u64]) as u128,
                0x2360_ed05_1fc6_5da4_4385_df64_9fcc_f645,
            );
            let mut jitter = |v: u32, size: u32, max: u32| {
                let sigma = self.cfg.box_jitter_px + self.cfg.box_jitter_frac * size as f32;
                let e: f32 = rng.sample(StandardNormal);
                (v as f32 + sigma * e).round().clamp(0.0, max as f32) as u32
            };
            let (bw, bh) = (s.bbox[2] - s.bbox[0], s.bbox[3] - s.bbox[1]);
            let x0 = jitter(s.bbox[0], bw, w as u32 - 1);
            let y0 = jitter(s.bbox[1], bh, h as u32 - 1);
            let x1 = jitter(s.bbox[2], bw, w as u32).max(x0 + 1);
            let y1 = jitter(s.bbox[3], bh, h as u32).max(y0 + 1);
            out.items[l] = Detection {
                class_id: c.class_id,
                label: (l + 1) as u16,
                score: c.score,
                bbox: [x0 as u16, y0 as u16, x1 as u16, y1 as u16],
                mask_pixels: s.pixels,
            };
        }
        out.items[count..].fill(Detection::default());
        out.count = count as u32;
    }

    /// Image area (pixels²) of object `k`'s unoccluded silhouette clipped to the image, `None`
    /// when part of it is behind or at the camera (then it is not estimated).
    fn silhouette_area(&self, k: usize, camera: &Camera, cam_from_world: &Affine3A) -> Option<f32> {
        let (pts, n) = &self.silhouettes[k];
        let mut img = [Vec2::ZERO; SIL_POINTS];
        for (q, p) in img.iter_mut().zip(&pts[..*n]) {
            let pc = cam_from_world.transform_point3(*p);
            if pc.z < 0.05 {
                return None;
            }
            *q = camera.project(pc)?;
        }
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = convex_hull_into(&mut img[..*n], &mut hull);
        Some(clipped_area(
            &hull[..m],
            Vec2::new(camera.width as f32, camera.height as f32),
        ))
    }
}

/// Area of a convex polygon clipped to the rectangle `[0, size]`.
fn clipped_area(poly: &[Vec2], size: Vec2) -> f32 {
    let mut a = [Vec2::ZERO; POLY_CAP];
    let mut b = [Vec2::ZERO; POLY_CAP];
    a[..poly.len()].copy_from_slice(poly);
    let mut n = poly.len();
    // Half-planes: (axis, bound, keep ≥ bound?)
    for (axis, bound, keep_above) in [
        (0, 0.0, true),
        (0, size.x, false),
        (1, 0.0, true),
        (1, size.y, false),
    ] {
        let inside = |p: Vec2| {
            let v = if axis == 0 { p.x } else { p.y };
            if keep_above { v >= bound } else { v <= bound }
        };
        let mut m = 0;
        for i in 0..n {
            let (p, q) = (a[i], a[(i + 1) % n]);
            let (ip, iq) = (inside(p), inside(q));
            if ip {
                b[m] = p;
                m += 1;
            }
            if ip != iq && m < POLY_CAP {
                let (pv, qv) = if axis == 0 { (p.x, q.x) } else { (p.y, q.y) };
                let t = (bound - pv) / (qv - pv);
                b[m] = p + (q - p) * t;
                m += 1;
            }
        }
        std::mem::swap(&mut a, &mut b);
        n = m.min(POLY_CAP);
    }
    let mut area = 0.0;
    for i in 0..n {
        area += a[i].perp_dot(a[(i + 1) % n]);
    }
    area.abs() * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_gives_exact_areas() {
        let mut pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(4.0, 2.0),
            Vec2::new(0.0, 2.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(1.0, 1.5),
        ];
        let mut hull = [Vec2::ZERO; POLY_CAP];
        let m = convex_hull_into(&mut pts, &mut hull);
        assert_eq!(m, 4);
        assert!((clipped_area(&hull[..m], Vec2::new(10.0, 10.0)) - 8.0).abs() < 1e-5);
        assert!((clipped_area(&hull[..m], Vec2::new(3.0, 1.0)) - 3.0).abs() < 1e-5);
        let tri = [
            Vec2::new(-1.0, 0.0),
            Vec2::new(3.0, 0.0),
            Vec2::new(-1.0, 4.0),
        ];
        // Clipped to x ≥ 0: a right triangle with legs 3 → 4.5.
        assert!((clipped_area(&tri, Vec2::new(10.0, 10.0)) - 4.5).abs() < 1e-5);
    }
}
