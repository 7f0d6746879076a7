//! False positives on background structure: wall features reported as `fp_wall_classes`
//! (a screen, a clock, a panel) and parts of objects reported as look-alikes (`fp_on_objects`:
//! a patch of a table top as a laptop or a book, part of a chair as a chair or a couch).
//!
//! Per frame, `Poisson(fp_per_frame)` low-scoring false positives are attempted, plus one
//! confident one per reported object with probability `fp_confident_per_tp`; each picks a source (the
//! walls, or a visible object listed in `fp_on_objects`) and tries a few random boxes on it: a box
//! is kept when at least 8 of 9 sample points in it lie on the source (walls: on a wall, not the
//! floor, at least `WALL_MIN_Z` high) and it overlaps no visible object's true box by IoU ≥
//! `MAX_TRUE_IOU` (so it cannot match a real object). A low-scoring one's score is uniform in
//! `[fp_score_min, fp_score_max]`; a confident one scores like a large, fully visible true
//! positive (`N(score_mean, score_std)`). A frame without a suitable place has fewer.
//!
//! Mislocalised duplicates (Hoiem et al.'s localisation errors): per reported object, with
//! probability `dup_per_tp`, a second box of its class on part of it or shifted off it (IoU with
//! its true box in `[DUP_IOU_MIN, DUP_IOU_MAX)`, with its reported box at most `nms_iou`, so that
//! NMS keeps both), scored like the object's own detection.

use super::{Cand, Detector, NONE, TAG_DUP, TAG_FP, iou, stream};
use geom::Camera;
use glam::{Affine3A, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use shm_types::MAX_OBJECTS;

/// Placement attempts per false positive.
const TRIES: usize = 8;
/// A false positive's box overlaps every visible object's true box by less than this IoU.
const MAX_TRUE_IOU: f32 = 0.4;
/// Wall false positives: box side range, pixels at 640×480.
const WALL_SIDE_PX: [f32; 2] = [30.0, 120.0];
/// Wall false positives lie at least this high on the wall, metres.
const WALL_MIN_Z: f32 = 0.3;
/// Object-part false positives: box side as a fraction of the source's visible box.
const PART_FRAC: [f32; 2] = [0.2, 0.5];
/// At most this many low-scoring false positives per frame.
const MAX_FP: usize = 8;
/// A duplicate's IoU with its object's true box lies in `[DUP_IOU_MIN, DUP_IOU_MAX)`: Hoiem et
/// al.'s localisation error (0.1 ≤ IoU < 0.5, correct class).
const DUP_IOU_MIN: f32 = 0.1;
const DUP_IOU_MAX: f32 = 0.5;

/// A Poisson draw (Knuth), at most [`MAX_FP`].
fn poisson(rng: &mut Pcg64, mean: f32) -> usize {
    let limit = (-mean).exp();
    let mut p = 1.0f32;
    let mut k = 0;
    loop {
        p *= rng.random::<f32>();
        if p <= limit || k == MAX_FP {
            return k;
        }
        k += 1;
    }
}

impl Detector {
    /// Append this frame's mislocalised duplicates of the reported objects to the candidates.
    pub(super) fn add_duplicates(&mut self, frame_index: u64, w: usize, h: usize) {
        if self.cfg.dup_per_tp <= 0.0 {
            return;
        }
        let reported = self.cands.len();
        for i in 0..reported {
            let c = self.cands[i];
            if c.into != NONE || c.inst == 0 {
                continue;
            }
            let mut rng = stream(self.seed, &[TAG_DUP, frame_index, c.inst.into()]);
            if rng.random::<f32>() >= self.cfg.dup_per_tp {
                continue;
            }
            let truth = self.stats[c.inst as usize].bbox.map(|v| v as f32);
            let (tw, th) = (truth[2] - truth[0], truth[3] - truth[1]);
            for _ in 0..TRIES {
                let (bw, bh, x0, y0) = if rng.random::<bool>() {
                    // A part of the object.
                    let (bw, bh) = (
                        tw * rng.random_range(0.3f32..0.8),
                        th * rng.random_range(0.3f32..1.0),
                    );
                    let x0 = truth[0] + rng.random::<f32>() * (tw - bw);
                    let y0 = truth[1] + rng.random::<f32>() * (th - bh);
                    (bw, bh, x0, y0)
                } else {
                    // The object's box shifted sideways (onto a neighbour or background).
                    let s = rng.random_range(0.35f32..0.75) * tw;
                    let x0 = if rng.random::<bool>() {
                        truth[0] + s
                    } else {
                        truth[0] - s
                    };
                    (tw, th, x0, truth[1])
                };
                let bbox = [
                    x0.max(0.0).floor(),
                    y0.max(0.0).floor(),
                    (x0 + bw).min(w as f32).ceil(),
                    (y0 + bh).min(h as f32).ceil(),
                ];
                if bbox[2] - bbox[0] < 4.0 || bbox[3] - bbox[1] < 4.0 {
                    continue;
                }
                let bbox = bbox.map(|v| v as u16);
                let to_truth = iou(bbox, truth.map(|v| v as u16));
                if !(DUP_IOU_MIN..DUP_IOU_MAX).contains(&to_truth)
                    || iou(bbox, c.bbox) > self.cfg.nms_iou
                {
                    continue;
                }
                let e: f32 = rng.sample(StandardNormal);
                let score = (c.mean + self.cfg.score_std * e).clamp(0.0, 0.99);
                if score >= self.cfg.score_min {
                    self.cands.push(Cand {
                        inst: 0,
                        source: c.inst,
                        class_id: c.class_id,
                        score,
                        mean: c.mean,
                        bbox,
                        into: NONE,
                        ..Cand::default()
                    });
                }
                break;
            }
        }
    }

    /// Append this frame's false positives to the candidates; `reported` is the number of
    /// candidates that are object detections (the first ones, survivors and suppressed).
    pub(super) fn add_false_positives(
        &mut self,
        reported: usize,
        instance: &[u8],
        camera: &Camera,
        world_from_camera: &Affine3A,
        frame_index: u64,
        min_px: u32,
    ) {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let scale = ((w * h) as f32 / super::REF_PIXELS).sqrt();
        let mut rng = stream(self.seed, &[TAG_FP, frame_index]);
        let low = if self.cfg.fp_per_frame > 0.0 {
            poisson(&mut rng, self.cfg.fp_per_frame)
        } else {
            0
        };
        let tps = self.cands[..reported]
            .iter()
            .filter(|c| c.into == NONE)
            .count();
        let confident = (0..tps)
            .filter(|_| rng.random::<f32>() < self.cfg.fp_confident_per_tp)
            .count();
        let wanted = low + confident;
        if wanted == 0 {
            return;
        }
        // Sources: 0 = walls, k + 1 = object k.
        let objects = self.class_ids.len();
        let mut sources = [0u8; MAX_OBJECTS + 1];
        let mut ns = 0;
        if !self.fp_wall.is_empty() && self.stats[0].pixels > 0 {
            ns = 1;
        }
        for k in 0..objects {
            if self.fp_on_of[k].is_some() && self.stats[k + 1].pixels >= 16 * min_px {
                sources[ns] = (k + 1) as u8;
                ns += 1;
            }
        }
        if ns == 0 {
            return;
        }
        let cam_pos = Vec3::from(world_from_camera.translation);
        let on_wall = |x: f32, y: f32| {
            let d = world_from_camera.transform_vector3(camera.ray(x, y));
            let hit = |o: f32, d: f32, lo: f32, hi: f32| {
                if d > 1e-6 {
                    (hi - o) / d
                } else if d < -1e-6 {
                    (lo - o) / d
                } else {
                    f32::INFINITY
                }
            };
            let r = &self.room;
            let t_wall =
                hit(cam_pos.x, d.x, r.min.x, r.max.x).min(hit(cam_pos.y, d.y, r.min.y, r.max.y));
            let t_floor = hit(cam_pos.z, d.z, 0.0, r.height);
            t_wall < t_floor && cam_pos.z + d.z * t_wall >= WALL_MIN_Z
        };
        for n in 0..wanted {
            for _ in 0..TRIES {
                let src = sources[rng.random_range(0..ns)];
                let b = self.stats[src as usize].bbox.map(|v| v as f32);
                let (bw, bh) = if src == 0 {
                    let side = rng.random_range(WALL_SIDE_PX[0]..WALL_SIDE_PX[1]) * scale;
                    let aspect = rng.random_range(0.6f32..1.6).sqrt();
                    (side * aspect, side / aspect)
                } else {
                    let fx = rng.random_range(PART_FRAC[0]..PART_FRAC[1]);
                    let fy = rng.random_range(PART_FRAC[0]..PART_FRAC[1]);
                    (((b[2] - b[0]) * fx).max(4.0), ((b[3] - b[1]) * fy).max(4.0))
                };
                let x0 = b[0] + rng.random::<f32>() * (b[2] - b[0] - bw).max(0.0);
                let y0 = b[1] + rng.random::<f32>() * (b[3] - b[1] - bh).max(0.0);
                let bbox = [
                    x0.floor(),
                    y0.floor(),
                    (x0 + bw).ceil().min(w as f32),
                    (y0 + bh).ceil().min(h as f32),
                ];
                let mut on = 0;
                for i in 0..9 {
                    let x = bbox[0] + (bbox[2] - bbox[0]) * ((i % 3) as f32 + 0.5) / 3.0;
                    let y = bbox[1] + (bbox[3] - bbox[1]) * ((i / 3) as f32 + 0.5) / 3.0;
                    let p = y as usize * w + x as usize;
                    if instance[p] == src && (src != 0 || on_wall(x, y)) {
                        on += 1;
                    }
                }
                let bbox = bbox.map(|v| v as u16);
                if on < 8
                    || (1..=objects).any(|k| {
                        let s = self.stats[k];
                        s.pixels >= min_px && iou(bbox, s.bbox.map(|v| v as u16)) >= MAX_TRUE_IOU
                    })
                {
                    continue;
                }
                let classes = match src {
                    0 => &self.fp_wall,
                    s => &self.fp_on[self.fp_on_of[s as usize - 1].unwrap_or(0)],
                };
                if classes.is_empty() {
                    continue;
                }
                let class_id = classes[rng.random_range(0..classes.len())];
                let score = if n < low {
                    rng.random_range(self.cfg.fp_score_min..=self.cfg.fp_score_max)
                } else {
                    let e: f32 = rng.sample(StandardNormal);
                    (self.cfg.score_mean + self.cfg.score_std * e).clamp(self.cfg.score_min, 0.99)
                };
                self.cands.push(Cand {
                    inst: 0,
                    source: src,
                    class_id,
                    score,
                    bbox,
                    into: NONE,
                    ..Cand::default()
                });
                break;
            }
        }
    }
}
