//! The simulated object detector (a YOLO stand-in) working on the true instance render.
//!
//! | file | contents |
//! |---|---|
//! | `mod.rs` | [`Detector`]: per-object misses, scores, label confusion, box jitter, NMS merging, output |
//! | `false_pos.rs` | false positives on background structure (walls, parts of tables and chairs) |
//! | `silhouette.rs` | unoccluded silhouettes of the objects (visible fraction) |
//! | `tests.rs` | statistical tests on synthetic instance images |
//!
//! Per visible scene object (background objects included, walls and floor excluded), with
//! `pixels` its visible pixels, `visible` the visible fraction (pixels over the area of the
//! unoccluded silhouette clipped to the image), `small = max(0, 1 − pixels/small_pixels)` and
//! `trunc` = 1 when its visible box touches the image border:
//! - **miss**: never below `min_pixels`; otherwise with probability
//!   `miss_rate + miss_small·small + miss_occluded·(1 − visible) + miss_truncated·trunc`;
//! - **score** `score_mean − score_occluded·(1 − visible) − score_truncated·trunc −
//!   score_small·small + N(0, score_std)`; detections below `score_min` are dropped;
//! - **label confusion** within look-alike groups, drawn once per (object, viewing-direction
//!   bin, viewing-distance bin), so it persists while the object is seen from a similar view;
//! - **box**: the visible box with each edge jittered by
//!   `N(0, box_jitter_px + box_jitter_frac·size)` (×`truncated_jitter` when truncated);
//! - **NMS**: a same-class box overlapping a higher-scoring one by IoU > `nms_iou` is
//!   suppressed; with probability `merge_union` the survivor becomes the union of both boxes;
//! - **label confusion** beyond the group (Hoiem et al.'s "other"): with probability
//!   `other_rate` per view bin, the class of another, dissimilar object of the scene;
//! - **mislocalised duplicates**: per reported object, with probability `dup_per_tp`, a second
//!   box of its class on part of it or shifted off it (IoU with its true box 0.1–0.5), scored
//!   like it (`false_pos.rs`);
//! - **false positives** on walls and object parts (`false_pos.rs`): `fp_per_frame` low-scoring
//!   ones per frame, and per reported object with probability `fp_confident_per_tp` one scored
//!   like a true positive.
//!
//! The error mix of the confident detections follows Redmon et al. 2016, Fig. 4 (Hoiem et al.'s
//! analysis of the top detections of Fast R-CNN and YOLO): `config/default.toml` gives the
//! figures beside each key.
//!
//! `mode = "boxes"` outputs class, score and box only (`masks = BOXES`, `label = 0`,
//! `mask_pixels = 0`, the label image untouched): one run-length pass over the instance image,
//! no allocation. `mode = "masks"` also writes instance masks (merged objects share one; masks
//! bleed by 0..=`mask_bleed_px` pixels; a false positive's mask is its source's pixels in its box)
//! and boxes come from the final masks.
//!
//! Calibration (`nodes/vpsom/tests/detector_calibration.rs`: rings of views around the background
//! objects of the three paper scenes, 456 frames at 640×480, shared definitions): recall of
//! visible objects 0.77 (small 0.53, truncated 0.63), 2.5 false positives per frame (0.34
//! before the confident ones and the duplicates of issue #33), mean box IoU 0.76, label confusion
//! 12 % of matches; `detect` 0.2–0.4 ms per frame in box mode.
//!
//! All randomness comes from PCG streams per (seed, frame, object), per (seed, object, view bin)
//! for confusion and per (seed, frame) for false positives: frames do not depend on threads.

mod false_pos;
mod silhouette;
#[cfg(test)]
mod tests;

pub(super) use silhouette::{POLY_CAP, RIM_EQUAL_AREA, Silhouettes};

use super::config::DetectorConfig;
use super::scene::{Room, Scene};
use geom::Camera;
use glam::{Affine3A, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use shm_types::{
    ClassId, Detection, Detections, MAX_DETECTIONS, MAX_OBJECTS, MAX_PIXELS, mask_mode,
};
use silhouette::rim_circumscribed;

/// Image area the configured pixel counts refer to (640×480).
const REF_PIXELS: f32 = 640.0 * 480.0;
/// No candidate (for [`Cand::into`]).
const NONE: u8 = u8::MAX;
/// Stream tags.
const TAG_OBJECT: u64 = 0x6465_7465;
const TAG_CONFUSION: u64 = 0x636f_6e66;
const TAG_NMS: u64 = 0x006e_6d73;
const TAG_FP: u64 = 0x0066_7073;
const TAG_DUP: u64 = 0x0064_7570;
const TAG_OTHER: u64 = 0x6f74_6872;

/// A PCG stream for `seed` and stream words.
fn stream(seed: u64, words: &[u64]) -> Pcg64 {
    Pcg64::new(
        super::mix(seed, words) as u128,
        0x5851_f42d_4c95_7f2d_1405_7b7e_f767_814f,
    )
}

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

    /// Add the pixels `[x0, x1)` of row `y`.
    fn add_run(&mut self, x0: u32, x1: u32, y: u32) {
        self.pixels += x1 - x0;
        self.bbox = [
            self.bbox[0].min(x0),
            self.bbox[1].min(y),
            self.bbox[2].max(x1),
            self.bbox[3].max(y + 1),
        ];
    }
}

/// Box IoU (`[x0, y0, x1, y1]`, exclusive ends).
pub(crate) fn iou<T: Into<f32> + Copy>(a: [T; 4], b: [T; 4]) -> f32 {
    let f = |v: [T; 4]| v.map(Into::into);
    let (a, b) = (f(a), f(b));
    let iw = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let ih = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = iw * ih;
    let area = |v: [f32; 4]| (v[2] - v[0]) * (v[3] - v[1]);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// One detection in the making.
#[derive(Debug, Clone, Copy, Default)]
struct Cand {
    /// Instance id (`k + 1`) of the object, 0 for a false positive.
    inst: u8,
    /// False positive: the instance id its box lies on (0 = wall).
    source: u8,
    class_id: ClassId,
    score: f32,
    /// The score without its noise (what a duplicate of this detection scores around).
    mean: f32,
    /// Output box (jittered).
    bbox: [u16; 4],
    /// Edge noise (standard normal) and jitter multiplier, for boxes from masks.
    noise: [f32; 4],
    jitter_scale: f32,
    bleed: u32,
    /// Instance id of the candidate that suppressed this one, [`NONE`] if it survives.
    into: u8,
    /// Suppressed into a union box (masks mode: its mask joins the survivor's).
    union: bool,
}

/// The detector with its per-frame scratch (no allocation in steady state).
#[derive(Debug, Clone)]
pub struct Detector {
    cfg: DetectorConfig,
    seed: u64,
    class_ids: Vec<ClassId>,
    centers: Vec<Vec3>,
    /// Per object: its look-alike group (index into `groups`).
    group_of: Vec<Option<usize>>,
    groups: Vec<Vec<ClassId>>,
    /// Per object: the false-positive classes seen on its parts (index into `fp_on`).
    fp_on_of: Vec<Option<usize>>,
    fp_on: Vec<Vec<ClassId>>,
    fp_wall: Vec<ClassId>,
    room: Room,
    silhouettes: Silhouettes,
    stats: Vec<Stat>,
    /// Visible pixels per scene object in the latest frame (kept past the masks pass).
    visible: Vec<u32>,
    cands: Vec<Cand>,
    scratch: Vec<u8>,
}

impl Detector {
    /// A detector for a scene's objects.
    pub fn new(scene: &Scene, cfg: &DetectorConfig, seed: u64) -> Self {
        let ids = |names: &[String]| -> Vec<ClassId> {
            names
                .iter()
                .filter_map(|n| shm_types::class_id(n))
                .collect()
        };
        let groups: Vec<Vec<ClassId>> = cfg.confusion_groups.iter().map(|g| ids(g)).collect();
        let fp_src: Vec<Option<ClassId>> = cfg
            .fp_on_objects
            .iter()
            .map(|e| e.first().and_then(|n| shm_types::class_id(n)))
            .collect();
        let fp_on = cfg
            .fp_on_objects
            .iter()
            .map(|e| ids(e.get(1..).unwrap_or_default()))
            .collect();
        let class_ids: Vec<ClassId> = scene.objects.iter().map(|o| o.class_id).collect();
        Self {
            group_of: class_ids
                .iter()
                .map(|c| groups.iter().position(|g| g.len() > 1 && g.contains(c)))
                .collect(),
            fp_on_of: class_ids
                .iter()
                .map(|c| fp_src.iter().position(|s| *s == Some(*c)))
                .collect(),
            cfg: cfg.clone(),
            seed,
            centers: scene.objects.iter().map(|o| o.center).collect(),
            groups,
            fp_on,
            fp_wall: ids(&cfg.fp_wall_classes),
            room: scene.room,
            silhouettes: Silhouettes::new(scene, rim_circumscribed()),
            class_ids,
            stats: vec![Stat::default(); MAX_OBJECTS + 1],
            visible: vec![0; scene.objects.len()],
            cands: Vec::with_capacity(MAX_OBJECTS + 64),
            scratch: vec![0; MAX_PIXELS],
        }
    }

    /// Detect objects in an instance image (`instance[p] = k + 1` for scene object `k`, 0 for
    /// none) rendered by `camera` from `world_from_camera` (true pose). Writes `out.width`,
    /// `out.height`, `out.count`, `out.masks`, `out.items` and, in masks mode, the label image;
    /// headers are the caller's.
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
        let scale = n as f32 / REF_PIXELS;
        out.width = w as u32;
        out.height = h as u32;
        out.masks = if self.cfg.masks() {
            mask_mode::MASKS
        } else {
            mask_mode::BOXES
        };
        out.count = 0;

        // 1. Visible pixels and boxes per instance (0 = structure), one run-length pass.
        let objects = self.class_ids.len();
        self.stats[..=objects].iter_mut().for_each(Stat::reset);
        for (y, row) in instance[..n].chunks_exact(w).enumerate() {
            let mut x0 = 0;
            while x0 < w {
                let k = row[x0];
                let run = row[x0..].iter().position(|&q| q != k).unwrap_or(w - x0);
                if let Some(s) = self
                    .stats
                    .get_mut(k as usize)
                    .filter(|_| k as usize <= objects)
                {
                    s.add_run(x0 as u32, (x0 + run) as u32, y as u32);
                }
                x0 += run;
            }
        }
        for (v, s) in self.visible.iter_mut().zip(&self.stats[1..]) {
            *v = s.pixels;
        }

        // 2. Per object: miss, score, class, box.
        let min_px = ((self.cfg.min_pixels as f32 * scale).round() as u32).max(1);
        let small_px = (self.cfg.small_pixels as f32 * scale).max(1.0);
        let cam_from_world = world_from_camera.inverse();
        let cam_pos = Vec3::from(world_from_camera.translation);
        self.cands.clear();
        for k in 0..objects {
            let s = self.stats[k + 1];
            if s.pixels < min_px {
                continue;
            }
            let mut rng = stream(self.seed, &[TAG_OBJECT, frame_index, k as u64]);
            let c = &self.cfg;
            let area = self.silhouettes.area(k, camera, &cam_from_world);
            let visible = area.map_or(1.0, |a| (s.pixels as f32 / a.max(1.0)).min(1.0));
            let hidden = 1.0 - visible;
            let trunc =
                s.bbox[0] == 0 || s.bbox[1] == 0 || s.bbox[2] == w as u32 || s.bbox[3] == h as u32;
            let t = f32::from(u8::from(trunc));
            let small = (1.0 - s.pixels as f32 / small_px).max(0.0);
            let p_miss = c.miss_rate
                + c.miss_small * small
                + c.miss_occluded * hidden
                + c.miss_truncated * t;
            if rng.random::<f32>() < p_miss {
                continue;
            }
            let e: f32 = rng.sample(StandardNormal);
            let mean = c.score_mean
                - c.score_occluded * hidden
                - c.score_truncated * t
                - c.score_small * small;
            let score = (mean + c.score_std * e).clamp(0.0, 0.99);
            if score < c.score_min {
                continue;
            }
            let noise = [0; 4].map(|_| rng.sample::<f32, _>(StandardNormal));
            let jitter_scale = if trunc { c.truncated_jitter } else { 1.0 };
            let bleed = rng.random_range(0..=c.mask_bleed_px);
            self.cands.push(Cand {
                inst: (k + 1) as u8,
                source: 0,
                class_id: self.view_class(k, cam_pos),
                score,
                mean,
                bbox: self.jitter(s.bbox, noise, jitter_scale, w, h),
                noise,
                jitter_scale,
                bleed,
                into: NONE,
                union: false,
            });
        }

        // 3. Class-aware NMS, highest score first.
        self.cands
            .sort_unstable_by(|a, b| b.score.total_cmp(&a.score).then(a.inst.cmp(&b.inst)));
        for i in 0..self.cands.len() {
            if self.cands[i].into != NONE {
                continue;
            }
            for j in i + 1..self.cands.len() {
                let (a, b) = (self.cands[i], self.cands[j]);
                if b.into != NONE
                    || a.class_id != b.class_id
                    || iou(a.bbox, b.bbox) <= self.cfg.nms_iou
                {
                    continue;
                }
                let mut rng = stream(
                    self.seed,
                    &[TAG_NMS, frame_index, a.inst.into(), b.inst.into()],
                );
                let union = rng.random::<f32>() < self.cfg.merge_union;
                self.cands[j].into = a.inst;
                self.cands[j].union = union;
                if union {
                    let bb = &mut self.cands[i].bbox;
                    *bb = [
                        bb[0].min(b.bbox[0]),
                        bb[1].min(b.bbox[1]),
                        bb[2].max(b.bbox[2]),
                        bb[3].max(b.bbox[3]),
                    ];
                }
            }
        }

        // 4. Mislocalised duplicates and false positives.
        let reported = self.cands.len();
        self.add_duplicates(frame_index, w, h);
        self.add_false_positives(
            reported,
            instance,
            camera,
            world_from_camera,
            frame_index,
            min_px,
        );

        // 5. Survivors by score, at most MAX_DETECTIONS.
        // (Unstable sort: no allocation; the key is total up to identical candidates.)
        self.cands.sort_unstable_by(|a, b| {
            (a.into != NONE)
                .cmp(&(b.into != NONE))
                .then(b.score.total_cmp(&a.score))
                .then(a.inst.cmp(&b.inst))
                .then(a.source.cmp(&b.source))
                .then(a.bbox.cmp(&b.bbox))
                .then(a.class_id.cmp(&b.class_id))
        });
        let count = self
            .cands
            .iter()
            .take_while(|c| c.into == NONE)
            .count()
            .min(MAX_DETECTIONS);
        for (item, c) in out.items.iter_mut().zip(&self.cands[..count]) {
            *item = Detection {
                class_id: c.class_id,
                label: 0,
                score: c.score,
                bbox: c.bbox,
                mask_pixels: 0,
            };
        }
        out.items[count..].fill(Detection::default());
        out.count = count as u32;
        if self.cfg.masks() {
            self.write_masks(instance, w, h, count, out);
        }
    }

    /// Visible pixels per scene object in the instance image of the latest [`detect`]
    /// (ground truth, for evaluation: the non-occlusion metric).
    ///
    /// [`detect`]: Self::detect
    pub fn visible_pixels(&self) -> &[u32] {
        &self.visible
    }

    /// The class reported for object `k` seen from `cam_pos`: its own; with probability
    /// `confusion_rate` another of its look-alike group; else with probability `other_rate`
    /// the class of another, dissimilar object of the scene. Drawn once per view bin.
    fn view_class(&self, k: usize, cam_pos: Vec3) -> ClassId {
        let own = self.class_ids[k];
        let d = (cam_pos - self.centers[k]).truncate();
        let bin_rad = self.cfg.confusion_bin_deg.to_radians();
        let dir = ((d.y.atan2(d.x) + std::f32::consts::PI) / bin_rad).floor() as u64;
        let dist = (d.length() / self.cfg.confusion_bin_m).floor() as u64;
        let mut rng = stream(self.seed, &[TAG_CONFUSION, k as u64, dir, dist]);
        let Some(g) = self.group_of[k].filter(|_| rng.random::<f32>() < self.cfg.confusion_rate)
        else {
            return self.other_class(k, dir, dist);
        };
        let group = &self.groups[g];
        let others = group.iter().filter(|c| **c != own).count();
        let pick = rng.random_range(0..others.max(1));
        group
            .iter()
            .filter(|c| **c != own)
            .nth(pick)
            .copied()
            .unwrap_or(own)
    }

    /// Hoiem et al.'s "other" confusion: with probability `other_rate` (per view bin) the class
    /// of another object of the scene that is not a look-alike of object `k`, else its own.
    fn other_class(&self, k: usize, dir: u64, dist: u64) -> ClassId {
        let own = self.class_ids[k];
        let mut rng = stream(self.seed, &[TAG_OTHER, k as u64, dir, dist]);
        if rng.random::<f32>() >= self.cfg.other_rate {
            return own;
        }
        let similar =
            |c: ClassId| c == own || self.group_of[k].is_some_and(|g| self.groups[g].contains(&c));
        let others = self.class_ids.iter().filter(|&&c| !similar(c)).count();
        if others == 0 {
            return own;
        }
        let pick = rng.random_range(0..others);
        self.class_ids
            .iter()
            .copied()
            .filter(|&c| !similar(c))
            .nth(pick)
            .unwrap_or(own)
    }

    /// `bbox` with each edge moved by `noise·σ`, σ = (`box_jitter_px` + `box_jitter_frac`·size)
    /// × `scale`, clamped to the image, at least one pixel wide.
    fn jitter(&self, bbox: [u32; 4], noise: [f32; 4], scale: f32, w: usize, h: usize) -> [u16; 4] {
        let c = &self.cfg;
        let sx = (c.box_jitter_px + c.box_jitter_frac * (bbox[2] - bbox[0]) as f32) * scale;
        let sy = (c.box_jitter_px + c.box_jitter_frac * (bbox[3] - bbox[1]) as f32) * scale;
        let (w, h) = (w as f32, h as f32);
        let x0 = (bbox[0] as f32 + sx * noise[0]).round().clamp(0.0, w - 1.0);
        let y0 = (bbox[1] as f32 + sy * noise[1]).round().clamp(0.0, h - 1.0);
        let x1 = (bbox[2] as f32 + sx * noise[2]).round().clamp(x0 + 1.0, w);
        let y1 = (bbox[3] as f32 + sy * noise[3]).round().clamp(y0 + 1.0, h);
        [x0 as u16, y0 as u16, x1 as u16, y1 as u16]
    }

    /// Masks mode: the label image for the first `count` candidates (the reported ones), mask
    /// bleed, and boxes and pixel counts from the final masks.
    fn write_masks(
        &mut self,
        instance: &[u8],
        w: usize,
        h: usize,
        count: usize,
        out: &mut Detections,
    ) {
        let n = w * h;
        // Instance → label (1-based); merged objects share the survivor's label.
        let mut map = [0u8; 256];
        let mut bleed = [0u32; 256];
        for (l, c) in self.cands[..count].iter().enumerate() {
            out.items[l].label = (l + 1) as u16;
            bleed[l + 1] = c.bleed;
            if c.inst != 0 {
                map[c.inst as usize] = (l + 1) as u8;
            }
        }
        for c in &self.cands[count..] {
            if c.union && c.into != NONE {
                map[c.inst as usize] = map[c.into as usize];
            }
        }
        let labels = &mut out.labels[..n];
        for (l, &k) in labels.iter_mut().zip(&instance[..n]) {
            *l = map[k as usize];
        }
        // False positives: their source's pixels inside their box (not taken by an earlier one).
        for (l, c) in self.cands[..count]
            .iter()
            .enumerate()
            .filter(|(_, c)| c.inst == 0)
        {
            let b = c.bbox.map(usize::from);
            let own = map[c.source as usize];
            for y in b[1]..b[3] {
                for x in b[0]..b[2] {
                    if instance[y * w + x] == c.source && labels[y * w + x] == own {
                        labels[y * w + x] = (l + 1) as u8;
                    }
                }
            }
        }

        // Mask bleed: `max` passes of a 4-neighbour dilation, each label up to its radius,
        // only inside the detections' boxes grown by the largest radius.
        let max_bleed = self.cands[..count]
            .iter()
            .map(|c| c.bleed)
            .max()
            .unwrap_or(0);
        if max_bleed > 0 {
            let m = max_bleed as usize;
            let (mut y0, mut y1) = (h, 0);
            for c in &self.cands[..count] {
                y0 = y0.min((c.bbox[1] as usize).saturating_sub(m + 8));
                y1 = y1.max((c.bbox[3] as usize + m + 8).min(h));
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
                        for (x, out) in row.iter_mut().enumerate() {
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

        // Final masks → pixel counts and (for objects) jittered boxes.
        self.stats[..=count].iter_mut().for_each(Stat::reset);
        for (y, row) in labels.chunks_exact(w).enumerate() {
            let mut x0 = 0;
            while x0 < w {
                let l = row[x0];
                let run = row[x0..].iter().position(|&q| q != l).unwrap_or(w - x0);
                if l != 0 {
                    self.stats[l as usize].add_run(x0 as u32, (x0 + run) as u32, y as u32);
                }
                x0 += run;
            }
        }
        for (l, c) in self.cands[..count].iter().enumerate() {
            let s = self.stats[l + 1];
            out.items[l].mask_pixels = s.pixels;
            if c.inst != 0 && s.pixels > 0 {
                out.items[l].bbox = self.jitter(s.bbox, c.noise, c.jitter_scale, w, h);
            }
        }
    }
}
