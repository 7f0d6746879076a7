//! The sparse object mapper (paper §4.1–4.3, §6): depth frames + detections + robot state in,
//! the object map (one cuboid per object with its SOPM, l_best, C_asso and sample points) and the
//! exploration occupancy grid out.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | [`config`] | `[mapper]` configuration: [`MapperConfig`] and its sub-sections |
//! | [`points`] | a detection's points: back-projection, cleaning, supporting planes |
//! | [`segment`] | box-only detections: the object's points inside its box |
//! | [`priors`] | class size priors (the mapper's own table) |
//! | [`association`], [`wilcoxon`] | detection → object association (rank-sum test) |
//! | [`object`] | one mapped object: merged cloud, cuboid, SOPM |
//! | [`register`] | frame-to-map registration of the camera pose |
//! | [`cuboid`] | cuboid fitting (minimum-area rectangle over the convex hull) |
//! | [`sopm`] | surface occupancy probability maps |
//! | [`existence`] | existence log-odds: spurious objects are deleted |
//! | [`extent`] | footprint sizes fused from per-view extents (pose-error smear) |
//! | `merge.rs` | duplicate merging |
//! | `sparse.rs` | confident detections with few points (glass, far small objects) |
//! | `flat.rs` | flat objects (phones) located by their box on the table top |
//! | [`standing`] | objects with little valid depth (glass, dark) placed from their box on the table |
//! | `publish.rs` | [`Mapper::write_map`], [`Mapper::write_grid`] |
//! | `resume.rs` | [`Mapper::resume_from`]: a restarted mapper continues from its last published map |
//! | [`grid`] | the exploration occupancy grid |
//! | `mod.rs` | [`Mapper`]: the per-frame pipeline |
//!
//! It sees only what the robot sees: the depth frame with its *estimated* camera pose, the
//! detections and the robot state — never the simulator's ground truth.
//!
//! Use:
//! ```text
//! let mut m = Mapper::new(&cfg.mapper, &cfg.camera.camera())?;
//! m.integrate(&frame, &detections, &state)?;      // every frame
//! m.write_map(&mut loaned_object_map, now_ns);     // at the map rate, in place
//! m.write_grid(&mut loaned_grid);
//! ```
//!
//! Per frame: each detection's points are extracted and cleaned ([`points`]), background
//! detections first (their supporting planes then clean the foreground detections); each is
//! associated ([`association`], [`wilcoxon`]) with an existing object or founds a new one; the
//! object's cloud is merged (voxel centroids with mean lines of sight), its cuboid refitted
//! ([`cuboid`]) and, for foreground objects, its SOPM updated ([`sopm`]). Then the objects'
//! existence is updated ([`existence`]) and duplicates are merged.
//!
//! Detections come as instance masks ([`shm_types::mask_mode::MASKS`]) or as boxes only
//! ([`shm_types::mask_mode::BOXES`], a YOLO-class detector); for boxes the object is segmented
//! out of its box ([`segment`]).
//!
//! **Paper-faithful mode.** Each addition beyond the paper has a switch in
//! `[mapper.extensions]` (duplicate merging, "inside → reject", minimum observations, existence
//! deletion, box segmentation) and look-alike classes are `[mapper.association] lookalike`
//! (`[]`: the label must match). All off / `[]` is the paper's mapper.

/// The built-in `config/default.toml`, where this crate's sections (`[mapper]`) have their defaults.
pub(crate) static DEFAULTS: settings::Defaults = settings::Defaults::new(
    "config/default.toml",
    include_str!("../../../config/default.toml"),
);

pub mod association;
pub mod calib;
pub mod config;
pub mod cuboid;
pub mod existence;
pub mod extent;
mod flat;
pub mod grid;
pub mod level;
mod merge;
pub mod object;
pub mod points;
pub mod priors;
mod publish;
pub mod register;
mod resume;
pub mod segment;
pub mod sopm;
mod sparse;
pub mod standing;
pub mod wilcoxon;

use association::voxel_centroids;
use association::{Candidate, ClassGroups};
use cuboid::CuboidScratch;
use geom::{Camera, pose_to_affine};
use glam::{Affine3A, Vec3};
use grid::ExplorationGrid;
use object::{FitParams, MappedObject};
use points::{ExtractParams, PointScratch, SupportPlane, rest_on_support};
use settings::{Checker, ConfigError};
use shm_types::{
    DepthFrame, Detections, FrameReceipt, MAX_FRAME_RECEIPTS, RobotState, Validate, frame_outcome,
    is_background_class, mask_mode,
};
use std::collections::HashMap;
use wilcoxon::RankScratch;

pub use config::{
    AssociationConfig, CAssoMode, ExistenceConfig, ExtensionsConfig, MapperConfig,
    SegmentationConfig, SopmConfig, SparseConfig,
};

/// Why a frame was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapperError {
    /// The detections belong to another frame.
    #[error("detections are for frame {detections_frame_seq}, depth frame is {frame_seq}")]
    FrameMismatch {
        /// `DepthFrame::header.seq`.
        frame_seq: u64,
        /// `Detections::frame_seq`.
        detections_frame_seq: u64,
    },
    /// Label image and depth image differ in size.
    #[error("detections are {det_w}×{det_h}, depth frame is {frame_w}×{frame_h}")]
    SizeMismatch {
        /// Frame width.
        frame_w: u32,
        /// Frame height.
        frame_h: u32,
        /// Label image width.
        det_w: u32,
        /// Label image height.
        det_h: u32,
    },
    /// A message failed validation.
    #[error("invalid {message}: {reason}")]
    Invalid {
        /// Which message.
        message: &'static str,
        /// The validation error.
        reason: String,
    },
}

/// What one call of [`Mapper::integrate`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// The frame was skipped because localization was lost.
    pub skipped: bool,
    /// Detections with enough clean points.
    pub used: u32,
    /// Detections merged into existing objects.
    pub associated: u32,
    /// Detections that founded new objects.
    pub created: u32,
    /// Detections refused (rank-sum test rejected, inside an existing object).
    pub rejected: u32,
    /// Rank-sum tests run against a visible reference (enough visible points).
    pub tests: u32,
    /// ... of which passed (`p > α`).
    pub tests_passed: u32,
    /// Duplicate objects merged into older ones after the frame.
    pub merged: u32,
    /// Objects deleted because their existence fell below the threshold.
    pub deleted: u32,
    /// The pose was levelled on the floor (`[mapper.level]`).
    pub levelled: bool,
}

impl std::ops::AddAssign for FrameStats {
    fn add_assign(&mut self, o: Self) {
        self.skipped |= o.skipped;
        self.levelled |= o.levelled;
        self.used += o.used;
        self.associated += o.associated;
        self.created += o.created;
        self.rejected += o.rejected;
        self.tests += o.tests;
        self.tests_passed += o.tests_passed;
        self.merged += o.merged;
        self.deleted += o.deleted;
    }
}

/// The mapper's state.
#[derive(Debug, Clone)]
pub struct Mapper {
    cfg: MapperConfig,
    camera: Camera,
    groups: ClassGroups,
    objects: Vec<MappedObject>,
    next_id: u32,
    grid: ExplorationGrid,
    reg: register::Registration,
    /// Floor-levelling scratch: candidate floor points.
    level_scratch: Vec<glam::DVec3>,
    /// Camera-yaw offset calibration.
    yaw_cal: calib::YawCalibration,
    last_frame_seq: u64,
    last_frame_stamp_ns: u64,
    last_sim_time_ns: u64,
    /// The frames consumed since the last [`Mapper::write_map`], the newest
    /// [`MAX_FRAME_RECEIPTS`] of `receipt_count`.
    receipts: Vec<FrameReceipt>,
    receipt_count: u32,
    // Scratch (reused every frame).
    point_scratch: PointScratch,
    cuboid_scratch: CuboidScratch,
    ranks: RankScratch,
    det_points: Vec<Vec<Vec3>>,
    det_order: Vec<usize>,
    supports: Vec<SupportPlane>,
    test_p: Vec<[f32; 3]>,
    test_q: Vec<[f32; 3]>,
    voxel_scratch: HashMap<[i32; 3], (Vec3, u32)>,
    centroids: Vec<Vec3>,
    cands: Vec<Candidate>,
    assignment: Vec<Option<usize>>,
    samples: Vec<(Vec3, Vec3)>,
}

/// Per-detection data for one frame.
struct Obs {
    index: usize,
}

impl Mapper {
    /// A mapper with an empty map. The camera gives the image size and valid depth range;
    /// each frame's own intrinsics are used for back-projection.
    pub fn new(cfg: &MapperConfig, camera: &Camera) -> Result<Self, ConfigError> {
        cfg.validate(&Checker::new("<mapper config>"))?;
        Ok(Self {
            cfg: cfg.clone(),
            camera: *camera,
            groups: ClassGroups::new(&cfg.association.lookalike),
            objects: Vec::new(),
            next_id: 1,
            grid: ExplorationGrid::new(&cfg.grid),
            reg: register::Registration::default(),
            level_scratch: Vec::new(),
            yaw_cal: calib::YawCalibration::default(),
            last_frame_seq: 0,
            last_frame_stamp_ns: 0,
            last_sim_time_ns: 0,
            receipts: Vec::with_capacity(MAX_FRAME_RECEIPTS),
            receipt_count: 0,
            point_scratch: PointScratch::default(),
            cuboid_scratch: CuboidScratch::default(),
            ranks: RankScratch::default(),
            det_points: Vec::new(),
            det_order: Vec::new(),
            supports: Vec::new(),
            test_p: Vec::new(),
            test_q: Vec::new(),
            voxel_scratch: HashMap::new(),
            centroids: Vec::new(),
            cands: Vec::new(),
            assignment: Vec::new(),
            samples: Vec::new(),
        })
    }

    /// The camera given at construction (image size and range the map was configured for).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The objects (published or not).
    pub fn objects(&self) -> &[MappedObject] {
        &self.objects
    }

    fn fit_params(&self) -> FitParams {
        FitParams {
            extent_quantile: self.cfg.extent_quantile,
            background_extent_quantile: self.cfg.background_extent_quantile,
            yaw_keep_tolerance: self.cfg.yaw_keep_tolerance,
            plane_tolerance: self.cfg.support_margin.max(0.01) * 1.5,
            min_support_height: self.cfg.min_support_height,
        }
    }

    /// Integrate one depth frame with its detections. Frames taken while localization is lost
    /// (`state.localization_ok == 0`) are skipped (their pose cannot be trusted). Every call
    /// leaves a receipt (frame, state, outcome) in the next map written.
    pub fn integrate(
        &mut self,
        frame: &DepthFrame,
        detections: &Detections,
        state: &RobotState,
    ) -> Result<FrameStats, MapperError> {
        let r = self.integrate_frame(frame, detections, state);
        let outcome = match &r {
            Ok(s) if s.skipped => frame_outcome::SKIPPED_LOST,
            Ok(_) => frame_outcome::INTEGRATED,
            Err(_) => frame_outcome::REFUSED,
        };
        self.receipt(frame.header.seq, state.header.seq, outcome);
        r
    }

    /// A frame the host skipped because no matching detections arrived: a receipt in the next
    /// map, nothing else.
    pub fn note_unmatched(&mut self, frame_seq: u64, state_seq: u64) {
        self.receipt(frame_seq, state_seq, frame_outcome::NO_DETECTIONS);
    }

    /// The camera-yaw offset applied to new frames (radians) and the current estimate
    /// (`[mapper.yaw_calibration]`).
    pub fn yaw_offset(&self) -> (f32, Option<calib::YawOffset>) {
        (
            self.yaw_cal.applied(),
            self.yaw_cal.estimate(&self.cfg.yaw_calibration),
        )
    }

    /// The next map's receipts are full: a host publishes it now, before the next frame, so that
    /// no receipt is lost.
    pub fn receipts_full(&self) -> bool {
        self.receipt_count as usize >= MAX_FRAME_RECEIPTS
    }

    fn receipt(&mut self, frame_seq: u64, state_seq: u64, outcome: u32) {
        if self.receipts.len() == MAX_FRAME_RECEIPTS {
            self.receipts.remove(0);
        }
        self.receipts.push(FrameReceipt {
            frame_seq,
            state_seq,
            outcome,
            reserved: 0,
        });
        self.receipt_count = self.receipt_count.saturating_add(1);
    }

    fn integrate_frame(
        &mut self,
        frame: &DepthFrame,
        detections: &Detections,
        state: &RobotState,
    ) -> Result<FrameStats, MapperError> {
        frame.validate().map_err(|e| MapperError::Invalid {
            message: "DepthFrame",
            reason: e.to_string(),
        })?;
        detections.validate().map_err(|e| MapperError::Invalid {
            message: "Detections",
            reason: e.to_string(),
        })?;
        if detections.frame_seq != frame.header.seq {
            return Err(MapperError::FrameMismatch {
                frame_seq: frame.header.seq,
                detections_frame_seq: detections.frame_seq,
            });
        }
        if detections.width != frame.width || detections.height != frame.height {
            return Err(MapperError::SizeMismatch {
                frame_w: frame.width,
                frame_h: frame.height,
                det_w: detections.width,
                det_h: detections.height,
            });
        }
        let mut stats = FrameStats::default();
        if state.localization_ok == 0 {
            stats.skipped = true;
            return Ok(stats);
        }
        self.last_frame_seq = frame.header.seq;
        self.last_frame_stamp_ns = frame.header.stamp_ns;
        self.last_sim_time_ns = frame.header.sim_time_ns;
        let now_ns = frame.header.sim_time_ns;

        let camera = Camera {
            width: frame.width,
            height: frame.height,
            k: frame.intrinsics,
        };
        let mut pose = pose_to_affine(&frame.camera_pose);
        if self.cfg.yaw_calibration.enabled {
            pose = self.yaw_cal.correction(&pose) * pose;
        }
        if self.cfg.level.enabled {
            let fit = level::fit_floor(
                frame,
                |u, v, z| camera.unproject(u, v, z),
                &pose,
                &self.cfg.level,
                &mut self.level_scratch,
            );
            let corr = fit.and_then(|f| f.correction(pose.translation.into(), &self.cfg.level));
            if let Some(c) = corr {
                pose = c * pose;
                stats.levelled = true;
            }
        }
        let mut pose = self.reg.begin_frame(&pose, &self.cfg.registration);
        let mut cam_pos: Vec3 = pose.translation.into();
        self.grid.integrate(frame, &camera, &pose);

        // Background detections first: their planes clean the foreground detections.
        let dets = detections.detections();
        self.det_order.clear();
        self.det_order
            .extend((0..dets.len()).filter(|i| is_background_class(dets[*i].class_id)));
        self.det_order
            .extend((0..dets.len()).filter(|i| !is_background_class(dets[*i].class_id)));
        if self.det_points.len() < dets.len() {
            self.det_points.resize_with(dets.len(), Vec::new);
        }
        let min_score = self.cfg.min_score;
        self.det_order.retain(|i| dets[*i].score >= min_score);
        let n_bg = self
            .det_order
            .iter()
            .filter(|i| is_background_class(dets[**i].class_id))
            .count();
        let order = std::mem::take(&mut self.det_order);
        for (phase, range) in [(0, 0..n_bg), (1, n_bg..order.len())] {
            if phase == 1 {
                self.refresh_supports();
            }
            let corr = self.process_group(
                frame,
                detections,
                &camera,
                &pose,
                cam_pos,
                &order[range],
                now_ns,
                &mut stats,
            );
            if let Some(d) = corr {
                pose = d.affine(cam_pos) * pose;
                cam_pos = pose.translation.into();
            }
        }
        self.reg.end_frame(&self.cfg.registration);
        if self.cfg.yaw_calibration.enabled {
            self.yaw_cal.update(&self.cfg.yaw_calibration);
        }
        self.det_order = order;
        if self.cfg.extensions.co_detection {
            self.count_co_detections();
        }
        if self.cfg.extensions.existence {
            stats.deleted = self.update_existence(frame, &camera, &pose, dets);
        } else {
            self.objects.iter_mut().for_each(|o| o.hit = false);
        }
        if self.cfg.extensions.duplicate_merge {
            stats.merged = self.merge_duplicates();
        }
        Ok(stats)
    }

    /// Every pair of foreground objects hit in this frame (each by its own detection) was
    /// detected together once more, unless the two detections' points overlap by more than
    /// `co_detection_max_overlap` of the smaller bounds (two boxes on one object). With
    /// `co_detection_min_share`, every pair overlapping as duplicates of which only one was hit
    /// was seen apart once more.
    fn count_co_detections(&mut self) {
        // Pairs overlapping as duplicates of which only one was detected: seen apart once more.
        if self.cfg.co_detection_min_share > 0.0 {
            let mut apart = Vec::new();
            for i in 0..self.objects.len() {
                for j in i + 1..self.objects.len() {
                    let (a, b) = (&self.objects[i], &self.objects[j]);
                    if a.hit != b.hit && !a.background && self.overlap_as_duplicates(i, j) {
                        apart.push((i, j));
                    }
                }
            }
            for (i, j) in apart {
                let (a, b) = (self.objects[i].id, self.objects[j].id);
                self.objects[i].add_co_apart(b, 1);
                self.objects[j].add_co_apart(a, 1);
            }
        }
        let hit: Vec<(u32, Option<(Vec3, Vec3)>)> = self
            .objects
            .iter()
            .filter(|o| o.hit && !o.background)
            .map(|o| (o.id, o.hit_bounds))
            .collect();
        if hit.len() < 2 {
            return;
        }
        let max_overlap = self.cfg.co_detection_max_overlap;
        for o in self.objects.iter_mut().filter(|o| o.hit && !o.background) {
            let me = o.id;
            for &(id, bounds) in hit.iter().filter(|&&(id, _)| id != me) {
                let one_object = match (o.hit_bounds, bounds) {
                    (Some(a), Some(b)) => bounds_overlap(a, b) > max_overlap,
                    _ => false,
                };
                if !one_object {
                    o.add_co_seen(id, 1);
                }
            }
        }
    }

    fn refresh_supports(&mut self) {
        self.supports.clear();
        for o in &self.objects {
            if let (true, Some(h)) = (o.background, o.support_height) {
                self.supports.push(SupportPlane {
                    height: h,
                    footprint: o.cuboid,
                });
            }
        }
    }

    /// Extract, associate and merge one group of detections (all background or all foreground).
    /// Returns the registration correction applied to the group's points.
    #[allow(clippy::too_many_arguments)]
    fn process_group(
        &mut self,
        frame: &DepthFrame,
        detections: &Detections,
        camera: &Camera,
        pose: &Affine3A,
        mut cam_pos: Vec3,
        order: &[usize],
        now_ns: u64,
        stats: &mut FrameStats,
    ) -> Option<register::Correction> {
        let dets = detections.detections();
        let labels = detections.label_pixels();
        let extract = ExtractParams {
            stride: self.cfg.pixel_stride as usize,
            max_points: self.cfg.max_points_per_detection as usize,
            floor_margin: self.cfg.floor_margin,
            support_margin: self.cfg.support_margin,
            gap_min: self.cfg.gap_min,
            gap_factor: self.cfg.gap_factor,
            boxes: detections.masks == mask_mode::BOXES,
            segment: self
                .cfg
                .extensions
                .box_segmentation
                .then_some(SegmentationConfig {
                    split: self.cfg.extensions.split_oversize,
                    ..self.cfg.segmentation
                }),
        };
        let a = self.cfg.association.clone();
        let cam_from_world = pose.inverse();
        let mut obs: Vec<Obs> = Vec::with_capacity(order.len());
        self.cands.clear();
        for &i in order {
            let det = &dets[i];
            let fg = !is_background_class(det.class_id);
            let mut pts = std::mem::take(&mut self.det_points[i]);
            let mut n = self.point_scratch.extract(
                frame,
                labels,
                camera,
                pose,
                det,
                fg,
                &self.supports,
                &extract,
                &mut pts,
            );
            if extract.boxes
                && fg
                && self.cfg.extensions.flat_objects
                && flat::is_flat(det.class_id, self.cfg.flat.max_height)
            {
                n = self.flat_points(frame, camera, pose, det, &mut pts);
            }
            let few = n < self.cfg.min_points as usize;
            if few && extract.boxes && fg && !flat::is_flat(det.class_id, self.cfg.flat.max_height)
            {
                let placed = self.standing_points(frame, camera, pose, det, &mut pts);
                if placed > 0 {
                    n = placed;
                }
            }
            self.det_points[i] = pts;
            if n < self.cfg.min_points as usize
                && !(extract.boxes && fg && self.sparse_ok(det, &self.det_points[i]))
            {
                continue;
            }
            stats.used += 1;
            let pts = &self.det_points[i];
            let (mut lo, mut hi, mut sum) = (
                Vec3::splat(f32::INFINITY),
                Vec3::splat(f32::NEG_INFINITY),
                Vec3::ZERO,
            );
            for p in pts {
                lo = lo.min(*p);
                hi = hi.max(*p);
                sum += *p;
            }
            let centroid = sum / pts.len() as f32;
            let k = obs.len();
            obs.push(Obs { index: i });
            let voxel = if fg {
                self.cfg.object_voxel
            } else {
                self.cfg.background_voxel
            };
            voxel_centroids(pts, voxel, &mut self.voxel_scratch, &mut self.test_p);
            for (j, o) in self.objects.iter().enumerate() {
                if o.background == fg {
                    continue;
                }
                let inside = o.contains(centroid, 0.0);
                let m = a.gate_margin;
                let centre_in_box =
                    o.cuboid.center.cmpge(lo - m).all() && o.cuboid.center.cmple(hi + m).all();
                if !self.groups.compatible(det.class_id, o.class_id) {
                    // Any foreground class at the object's place (cross_class_join); with
                    // cross_class_mutual also the object's centre in the points' box.
                    let x = &self.cfg.extensions;
                    let mutual = centre_in_box || !x.cross_class_mutual;
                    if !(fg && x.cross_class_join && inside && mutual) {
                        continue;
                    }
                }
                if !o.contains(centroid, m) && !centre_in_box {
                    continue;
                }
                o.visible_reference(
                    frame,
                    camera,
                    &cam_from_world,
                    det.bbox,
                    a.bbox_margin_px,
                    a.visibility_tolerance,
                    a.front_tolerance,
                    &mut self.test_q,
                );
                let max = a.max_test_points as usize;
                let tested = self.test_q.len() >= a.min_reference as usize;
                let (p, accepted) = if tested {
                    let r = self.ranks.test_points(&self.test_p, &self.test_q, max);
                    stats.tests += 1;
                    stats.tests_passed += (r.p > a.alpha) as u32;
                    (r.p, r.p > a.alpha)
                } else {
                    o.all_reference(&mut self.test_q);
                    let r = self.ranks.test_points(&self.test_p, &self.test_q, max);
                    (r.p, o.contains(centroid, m))
                };
                self.cands.push(Candidate {
                    detection: k,
                    object: j,
                    p,
                    tested,
                    accepted,
                    inside,
                });
            }
        }
        let mut cands = std::mem::take(&mut self.cands);
        let mut assignment = std::mem::take(&mut self.assignment);
        association::assign(&mut cands, obs.len(), &mut assignment);
        let pairs: Vec<(usize, usize)> = (0..obs.len())
            .filter_map(|k| assignment[k].map(|c| (obs[k].index, cands[c].object)))
            .collect();
        let background = order
            .first()
            .is_some_and(|i| is_background_class(dets[*i].class_id));
        let dof = if background {
            register::Dof::Z
        } else {
            register::Dof::Full
        };
        let corr = self.reg.estimate(
            &self.objects,
            &self.det_points,
            &pairs,
            cam_pos,
            dof,
            &self.cfg.registration,
        );
        if let Some(d) = corr {
            for ob in &obs {
                for p in &mut self.det_points[ob.index] {
                    *p = d.apply(*p, cam_pos);
                }
            }
            cam_pos += d.t;
        }
        let fit = self.fit_params();
        let sopm_params = self.cfg.sopm.params();
        for (k, ob) in obs.iter().enumerate() {
            let det = dets[ob.index];
            let fg = !is_background_class(det.class_id);
            let pts = std::mem::take(&mut self.det_points[ob.index]);
            let target = match assignment[k] {
                Some(c) => {
                    let c = cands[c];
                    let o = &mut self.objects[c.object];
                    association::record(&mut o.asso, &c, &self.cfg.association);
                    o.c_asso = o.asso.c_asso;
                    o.vote(det.class_id, det.score);
                    o.hit = true;
                    stats.associated += 1;
                    Some(c.object)
                }
                None => {
                    // Refused, but inside an existing compatible object: no duplicate.
                    let blocker = cands
                        .iter()
                        .filter(|c| c.detection == k && c.inside)
                        .min_by(|x, y| x.p.total_cmp(&y.p).reverse());
                    if let Some(c) = blocker.filter(|_| self.cfg.extensions.inside_reject) {
                        let o = &mut self.objects[c.object];
                        association::record(&mut o.asso, c, &self.cfg.association);
                        o.c_asso = o.asso.c_asso;
                        stats.rejected += 1;
                        None
                    } else {
                        let voxel = if fg {
                            self.cfg.object_voxel
                        } else {
                            self.cfg.background_voxel
                        };
                        self.objects.push(MappedObject::new(
                            self.next_id,
                            det.class_id,
                            det.score,
                            !fg,
                            voxel,
                            self.cfg.max_object_voxels as usize,
                            fg.then_some(sopm_params),
                            now_ns,
                        ));
                        self.next_id += 1;
                        if let Some(o) = self.objects.last_mut() {
                            o.hit = true;
                        }
                        stats.created += 1;
                        Some(self.objects.len() - 1)
                    }
                }
            };
            if let Some(j) = target {
                let o = &mut self.objects[j];
                if fg && self.cfg.yaw_calibration.enabled && !pts.is_empty() {
                    let centroid = pts.iter().copied().sum::<Vec3>() / pts.len() as f32;
                    self.yaw_cal.record(o.id, centroid, cam_pos);
                }
                o.hit_bounds = point_bounds(&pts);
                o.merge(&pts, cam_pos);
                let dyaw = o.refit(&mut self.cuboid_scratch, &mut self.centroids, &fit);
                if fg {
                    rest_on_support(&mut o.cuboid, &self.supports, self.cfg.support_margin);
                }
                o.observations += 1;
                o.update_sopm(&pts, cam_pos, dyaw);
                let ve = &self.cfg.view_extents;
                let b = ve.border_px;
                let [x0, y0, x1, y1] = det.bbox.map(f32::from);
                let cut = x0 < b
                    || y0 < b
                    || x1 > camera.width as f32 - b
                    || y1 > camera.height as f32 - b;
                if fg && self.cfg.extensions.view_extents && !cut {
                    o.views.record(&pts, cam_pos, ve);
                }
            }
            self.det_points[ob.index] = pts;
        }
        self.cands = cands;
        self.assignment = assignment;
        corr
    }
}

/// The axis-aligned bounds (min, max) of `pts`, `None` when empty.
fn point_bounds(pts: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let first = *pts.first()?;
    Some(
        pts.iter()
            .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
    )
}

/// The intersection of two bounds as a fraction of the smaller one's volume (0 when apart; a
/// degenerate bounds counts as a 1 mm slab).
fn bounds_overlap(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> f32 {
    let vol = |lo: Vec3, hi: Vec3| (hi - lo).max(Vec3::splat(1e-3)).element_product();
    let (lo, hi) = (a.0.max(b.0), a.1.min(b.1));
    if lo.cmpgt(hi).any() {
        return 0.0;
    }
    vol(lo, hi) / vol(a.0, a.1).min(vol(b.0, b.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_overlap_is_the_intersection_over_the_smaller_volume() {
        let b = |lo: [f32; 3], hi: [f32; 3]| (Vec3::from(lo), Vec3::from(hi));
        // A 0.1 m cube half inside a 0.2 m cube: 0.05 x 0.1 x 0.1 / 0.001 = 0.5.
        let small = b([0.15, 0.0, 0.0], [0.25, 0.1, 0.1]);
        let large = b([0.0, 0.0, 0.0], [0.2, 0.2, 0.2]);
        assert!((bounds_overlap(small, large) - 0.5).abs() < 1e-5);
        assert!((bounds_overlap(large, small) - 0.5).abs() < 1e-5);
        // Inside: 1; apart: 0.
        assert!((bounds_overlap(b([0.05; 3], [0.1; 3]), large) - 1.0).abs() < 1e-5);
        assert_eq!(bounds_overlap(b([0.3; 3], [0.4; 3]), large), 0.0);
        assert_eq!(point_bounds(&[]), None);
        let pts = [Vec3::new(1.0, -1.0, 0.5), Vec3::new(0.0, 2.0, 0.25)];
        assert_eq!(
            point_bounds(&pts),
            Some((Vec3::new(0.0, -1.0, 0.25), Vec3::new(1.0, 2.0, 0.5)))
        );
    }

    #[test]
    fn two_boxes_on_one_object_are_not_detected_together() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let cfg = MapperConfig::default();
        let mut m = Mapper::new(&cfg, &cam).unwrap();
        let object = |id, lo: f32, hi: f32| {
            let mut o = MappedObject::new(id, 41, 0.9, false, 0.01, 100, None, 0);
            o.hit = true;
            o.hit_bounds = Some((Vec3::splat(lo), Vec3::splat(hi)));
            o
        };
        // 0 and 1: the same cup's points (overlap 1); 2: a cup beside them.
        m.objects = vec![
            object(0, 0.0, 0.1),
            object(1, 0.02, 0.09),
            object(2, 0.3, 0.4),
        ];
        m.count_co_detections();
        let seen = |m: &Mapper, a: usize, b: u32| m.objects[a].co_seen_with(b);
        assert_eq!((seen(&m, 0, 1), seen(&m, 1, 0)), (0, 0));
        assert_eq!((seen(&m, 0, 2), seen(&m, 2, 1)), (1, 1));
        // With every pair counted (1.0), the two boxes are detected together too.
        let mut every = cfg.clone();
        every.co_detection_max_overlap = 1.0;
        let mut m2 = Mapper::new(&every, &cam).unwrap();
        m2.objects = m.objects.clone();
        m2.count_co_detections();
        assert_eq!(seen(&m2, 0, 1), 1);
    }

    #[test]
    fn a_twin_seen_together_rarely_is_a_duplicate_and_neighbours_stay_two() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let cfg = MapperConfig {
            co_detection_min_share: 0.35,
            ..MapperConfig::default()
        };
        let mut m = Mapper::new(&cfg, &cam).unwrap();
        let cup = |id, x: f32| {
            let mut o = MappedObject::new(id, 41, 0.9, false, 0.01, 100, None, 0);
            o.observations = 5;
            o.cuboid = cuboid::Box3 {
                center: Vec3::new(x, 0.0, 0.8),
                size: Vec3::new(0.08, 0.08, 0.1),
                yaw: 0.0,
            };
            o
        };
        // A twin 1 cm off the cup: its cuboid overlaps as a duplicate's.
        m.objects = vec![cup(1, 0.0), cup(2, 0.01)];
        assert!(m.overlap_as_duplicates(0, 1));
        // Frames in which one of the two was detected alone count apart.
        m.objects[0].hit = true;
        m.count_co_detections();
        assert_eq!(
            (m.objects[0].co_apart_with(2), m.objects[1].co_apart_with(1)),
            (1, 1)
        );
        // Detected together in 3 of 4 such frames (>= 0.35): two objects, never merged.
        for o in &mut m.objects {
            o.add_co_seen(3 - o.id, 3);
        }
        assert!(m.detected_apart(0, 1) && !m.duplicates(0, 1));
        // ... in 3 of 23 (a duplicate box that comes back now and then): one object.
        for o in &mut m.objects {
            o.add_co_apart(3 - o.id, 19);
        }
        assert!(!m.detected_apart(0, 1) && m.duplicates(0, 1));
        // With the share off, distinct_after (2) decides alone, as before.
        m.cfg.co_detection_min_share = 0.0;
        assert!(m.detected_apart(0, 1));
    }

    #[test]
    fn mismatched_inputs_are_refused_and_lost_localization_skips() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let mut m = Mapper::new(&MapperConfig::default(), &cam).unwrap();
        let mut f = shm_types::boxed_zeroed::<DepthFrame>();
        f.width = 64;
        f.height = 48;
        f.intrinsics = cam.k;
        f.header.seq = 5;
        f.camera_pose = shm_types::Pose3::IDENTITY;
        let mut d = shm_types::boxed_zeroed::<Detections>();
        d.width = 64;
        d.height = 48;
        d.frame_seq = 4;
        let mut ok = RobotState {
            localization_ok: 1,
            ..Default::default()
        };
        ok.header.seq = 70;
        assert!(matches!(
            m.integrate(&f, &d, &ok),
            Err(MapperError::FrameMismatch { frame_seq: 5, .. })
        ));
        d.frame_seq = 5;
        d.width = 32;
        assert!(matches!(
            m.integrate(&f, &d, &ok),
            Err(MapperError::SizeMismatch { .. })
        ));
        d.width = 64;
        assert_eq!(m.integrate(&f, &d, &ok).unwrap(), FrameStats::default());
        let lost = RobotState::default();
        assert!(m.integrate(&f, &d, &lost).unwrap().skipped);
        let mut map = shm_types::boxed_zeroed::<shm_types::ObjectMap>();
        m.note_unmatched(6, 71);
        m.write_map(&mut map, 9);
        assert_eq!(
            (map.count, map.last_frame_seq, map.header.sim_time_ns),
            (0, 5, 9)
        );
        // Every frame consumed is in the map's receipts, with its state and outcome.
        let receipt = |frame_seq, state_seq, outcome| FrameReceipt {
            frame_seq,
            state_seq,
            outcome,
            reserved: 0,
        };
        use frame_outcome::*;
        assert_eq!(
            map.receipts(),
            [
                receipt(5, 70, REFUSED),
                receipt(5, 70, REFUSED),
                receipt(5, 70, INTEGRATED),
                receipt(5, 0, SKIPPED_LOST),
                receipt(6, 71, NO_DETECTIONS),
            ]
        );
        // ... and only in that map; past the capacity the count says receipts were lost.
        m.write_map(&mut map, 10);
        assert_eq!(map.receipt_count, 0);
        for k in 0..MAX_FRAME_RECEIPTS as u64 + 2 {
            assert_eq!(m.receipts_full(), k >= MAX_FRAME_RECEIPTS as u64);
            m.note_unmatched(100 + k, 0);
        }
        m.write_map(&mut map, 11);
        assert_eq!(map.receipt_count as usize, MAX_FRAME_RECEIPTS + 2);
        assert_eq!(map.receipts()[0].frame_seq, 102);
        assert_eq!(map.validate(), Ok(()));
    }
}
