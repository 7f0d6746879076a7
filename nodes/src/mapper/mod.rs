//! The sparse object mapper (paper §4.1–4.3, §6): depth frames + detections + robot state in,
//! the object map (one cuboid per object with its SOPM, l_best, C_asso and sample points) and the
//! exploration occupancy grid out.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | [`config`] | `[mapper]` configuration: [`MapperConfig`] and its sub-sections |
//! | [`points`] | a detection's points: back-projection, cleaning, supporting planes |
//! | [`association`], [`wilcoxon`] | detection → object association (rank-sum test) |
//! | [`object`] | one mapped object: merged cloud, cuboid, SOPM |
//! | [`cuboid`] | cuboid fitting (minimum-area rectangle over the convex hull) |
//! | [`sopm`] | surface occupancy probability maps |
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
//! ([`cuboid`]) and, for foreground objects, its SOPM updated ([`sopm`]).

pub mod association;
pub mod config;
pub mod cuboid;
pub mod grid;
pub mod object;
pub mod points;
pub mod sopm;
pub mod wilcoxon;

use crate::geom::{Camera, pose_to_affine};
use association::{Candidate, ClassGroups};
use cuboid::CuboidScratch;
use glam::{Affine3A, Vec3};
use grid::ExplorationGrid;
use object::{FitParams, MappedObject};
use points::{ExtractParams, PointScratch, SupportPlane};
use runtime::config::{Checker, ConfigError};
use shm_types::{
    DepthFrame, Detections, MAX_OBJECT_POINTS, MAX_OBJECTS, ObjectMap, OccupancyGrid, RobotState,
    Validate, is_background_class,
};
use std::collections::HashMap;
use wilcoxon::RankScratch;

pub use config::{AssociationConfig, MapperConfig, SopmConfig};

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
}

impl std::ops::AddAssign for FrameStats {
    fn add_assign(&mut self, o: Self) {
        self.skipped |= o.skipped;
        self.used += o.used;
        self.associated += o.associated;
        self.created += o.created;
        self.rejected += o.rejected;
        self.tests += o.tests;
        self.tests_passed += o.tests_passed;
        self.merged += o.merged;
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
    last_frame_seq: u64,
    last_frame_stamp_ns: u64,
    last_sim_time_ns: u64,
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
            groups: ClassGroups::default(),
            objects: Vec::new(),
            next_id: 1,
            grid: ExplorationGrid::new(&cfg.grid),
            last_frame_seq: 0,
            last_frame_stamp_ns: 0,
            last_sim_time_ns: 0,
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
    /// (`state.localization_ok == 0`) are skipped (their pose cannot be trusted).
    pub fn integrate(
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
        let pose = pose_to_affine(&frame.camera_pose);
        let cam_pos: Vec3 = pose.translation.into();
        self.grid.integrate(frame, &camera, &pose);

        // Background detections first: their planes clean the foreground detections.
        let dets = detections.detections();
        self.det_order.clear();
        self.det_order
            .extend((0..dets.len()).filter(|i| is_background_class(dets[*i].class_id)));
        let n_bg = self.det_order.len();
        self.det_order
            .extend((0..dets.len()).filter(|i| !is_background_class(dets[*i].class_id)));
        if self.det_points.len() < dets.len() {
            self.det_points.resize_with(dets.len(), Vec::new);
        }
        let order = std::mem::take(&mut self.det_order);
        for (phase, range) in [(0, 0..n_bg), (1, n_bg..order.len())] {
            if phase == 1 {
                self.refresh_supports();
            }
            self.process_group(
                frame,
                detections,
                &camera,
                &pose,
                cam_pos,
                &order[range],
                now_ns,
                &mut stats,
            );
        }
        self.det_order = order;
        stats.merged = self.merge_duplicates();
        Ok(stats)
    }

    /// Whether objects `i` and `j` are one object seen twice: same kind (background or not),
    /// compatible classes (background: equal), and strongly overlapping cuboids (background:
    /// footprints, whatever their plane heights: a side view of a table yields a sliver whose
    /// "plane" is any height of its front face): IoU ≥ `merge_iou`, or the smaller one's centre
    /// inside the larger one with ≥ `merge_containment` of its volume (area) inside.
    fn duplicates(&self, i: usize, j: usize) -> bool {
        let (a, b) = (&self.objects[i], &self.objects[j]);
        if a.background != b.background || a.observations == 0 || b.observations == 0 {
            return false;
        }
        let (ca, cb) = (&a.cuboid, &b.cuboid);
        // Cheap reject: bounding circles apart.
        let (ra, rb) = (ca.size.truncate().length(), cb.size.truncate().length());
        if ca.center.truncate().distance(cb.center.truncate()) > 0.5 * (ra + rb) {
            return false;
        }
        let (inter, va, vb) = if a.background {
            if a.class_id != b.class_id {
                return false;
            }
            let area = |c: &cuboid::Box3| c.size.x.max(0.0) * c.size.y.max(0.0);
            (ca.footprint_intersection(cb), area(ca), area(cb))
        } else {
            if !self.groups.compatible(a.class_id, b.class_id) {
                return false;
            }
            (ca.intersection_volume(cb), ca.volume(), cb.volume())
        };
        if inter <= 0.0 {
            return false;
        }
        let union = va + vb - inter;
        if union > 0.0 && inter / union >= self.cfg.merge_iou {
            return true;
        }
        let (small, large, v_small) = if va <= vb { (a, b, va) } else { (b, a, vb) };
        let mut probe = small.cuboid.center;
        if a.background {
            probe.z = large.cuboid.center.z;
        }
        let m = self.cfg.merge_margin;
        let grown = cuboid::Box3 {
            size: large.cuboid.size + glam::Vec3::splat(2.0 * m),
            ..large.cuboid
        };
        let inside = if a.background {
            small.cuboid.footprint_intersection(&grown)
        } else {
            small.cuboid.intersection_volume(&grown)
        };
        v_small > 0.0 && inside / v_small >= self.cfg.merge_containment && large.contains(probe, m)
    }

    /// Merge duplicate objects into the older one (see [`MappedObject::absorb`]); the cuboid is
    /// refitted from the merged cloud. Returns the number of objects merged away. Clusters follow
    /// automatically: a foreground object's cluster is looked up among the surviving background
    /// objects when the map is written.
    fn merge_duplicates(&mut self) -> u32 {
        let mut merged = 0;
        let fit = self.fit_params();
        'outer: loop {
            for i in 0..self.objects.len() {
                for j in i + 1..self.objects.len() {
                    if !self.duplicates(i, j) {
                        continue;
                    }
                    let (oi, oj) = (&self.objects[i], &self.objects[j]);
                    let (keep, drop) = if (oi.first_seen_ns, oi.id) <= (oj.first_seen_ns, oj.id) {
                        (i, j)
                    } else {
                        (j, i)
                    };
                    let gone = self.objects.remove(drop);
                    let keep = if drop < keep { keep - 1 } else { keep };
                    let o = &mut self.objects[keep];
                    o.absorb(&gone);
                    let dyaw = o.refit(&mut self.cuboid_scratch, &mut self.centroids, &fit);
                    if !o.background {
                        rest_on_support(&mut o.cuboid, &self.supports, self.cfg.support_margin);
                    }
                    o.follow_yaw(dyaw);
                    merged += 1;
                    continue 'outer;
                }
            }
            break;
        }
        merged
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
    #[allow(clippy::too_many_arguments)]
    fn process_group(
        &mut self,
        frame: &DepthFrame,
        detections: &Detections,
        camera: &Camera,
        pose: &Affine3A,
        cam_pos: Vec3,
        order: &[usize],
        now_ns: u64,
        stats: &mut FrameStats,
    ) {
        let dets = detections.detections();
        let labels = detections.label_pixels();
        let extract = ExtractParams {
            stride: self.cfg.pixel_stride as usize,
            max_points: self.cfg.max_points_per_detection as usize,
            floor_margin: self.cfg.floor_margin,
            support_margin: self.cfg.support_margin,
            gap_min: self.cfg.gap_min,
            gap_factor: self.cfg.gap_factor,
        };
        let a = self.cfg.association.clone();
        let cam_from_world = pose.inverse();
        let mut obs: Vec<Obs> = Vec::with_capacity(order.len());
        self.cands.clear();
        for &i in order {
            let det = &dets[i];
            let fg = !is_background_class(det.class_id);
            let mut pts = std::mem::take(&mut self.det_points[i]);
            let n = self.point_scratch.extract(
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
            self.det_points[i] = pts;
            if n < self.cfg.min_points as usize {
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
                if o.background == fg || !self.groups.compatible(det.class_id, o.class_id) {
                    continue;
                }
                let m = a.gate_margin;
                let centre_in_box =
                    o.cuboid.center.cmpge(lo - m).all() && o.cuboid.center.cmple(hi + m).all();
                if !o.contains(centroid, m) && !centre_in_box {
                    continue;
                }
                let inside = o.contains(centroid, 0.0);
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
                let (p, accepted) = if self.test_q.len() >= a.min_reference as usize {
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
                    accepted,
                    inside,
                });
            }
        }
        let mut cands = std::mem::take(&mut self.cands);
        let mut assignment = std::mem::take(&mut self.assignment);
        association::assign(&mut cands, obs.len(), &mut assignment);
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
                    o.c_asso = (1.0 - c.p).clamp(0.0, 1.0) as f32;
                    o.vote(det.class_id, det.score);
                    stats.associated += 1;
                    Some(c.object)
                }
                None => {
                    // Refused, but inside an existing compatible object: no duplicate.
                    let blocker = cands
                        .iter()
                        .filter(|c| c.detection == k && c.inside)
                        .min_by(|x, y| x.p.total_cmp(&y.p).reverse());
                    if let Some(c) = blocker {
                        self.objects[c.object].c_asso = (1.0 - c.p).clamp(0.0, 1.0) as f32;
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
                        stats.created += 1;
                        Some(self.objects.len() - 1)
                    }
                }
            };
            if let Some(j) = target {
                let o = &mut self.objects[j];
                o.merge(&pts, cam_pos);
                let dyaw = o.refit(&mut self.cuboid_scratch, &mut self.centroids, &fit);
                if fg {
                    rest_on_support(&mut o.cuboid, &self.supports, self.cfg.support_margin);
                }
                o.observations += 1;
                o.update_sopm(&pts, cam_pos, dyaw);
            }
            self.det_points[ob.index] = pts;
        }
        self.cands = cands;
        self.assignment = assignment;
    }

    /// Write the whole map in place into `out` (e.g. a loaned shared-memory sample). Sets
    /// `header.sim_time_ns = now_ns`, `last_frame_seq`, `last_frame_stamp_ns`, `count`,
    /// `eps_sopm` and the objects (ordered by id; at most [`MAX_OBJECTS`]); the host sets
    /// `header.seq` and `header.stamp_ns`. Objects seen fewer than `min_observations` times are
    /// left out. Unused object slots are not touched.
    pub fn write_map(&mut self, out: &mut ObjectMap, now_ns: u64) {
        out.header.sim_time_ns = now_ns;
        out.last_frame_seq = self.last_frame_seq;
        out.last_frame_stamp_ns = self.last_frame_stamp_ns;
        out.eps_sopm = self.cfg.sopm.eps_sopm;
        let mut count = 0usize;
        let mut samples = std::mem::take(&mut self.samples);
        for o in &self.objects {
            if count == MAX_OBJECTS {
                break;
            }
            if o.observations < self.cfg.min_observations || o.point_count == 0 {
                continue;
            }
            let m = &mut out.objects[count];
            m.first_seen_ns = o.first_seen_ns;
            m.id = o.id;
            m.class_id = o.class_id;
            m.background = o.background as u8;
            m.center = o.cuboid.center.to_array();
            m.size = o.cuboid.size.to_array();
            m.yaw = o.cuboid.yaw;
            m.point_count = o.point_count;
            m.cluster_id = if o.background {
                o.id as i32
            } else {
                self.cluster_of(o)
            };
            m.observations = o.observations;
            m.c_asso = o.c_asso.clamp(0.0, 1.0);
            m.reserved = 0;
            m.reserved_tail = 0;
            match &o.sopm {
                Some(s) => {
                    let h = s.h_sopm();
                    m.h_sopm = h;
                    m.complete = (h < self.cfg.sopm.eps_sopm) as u8;
                    m.l_best = s.l_best(&o.sopm_frame()).to_array();
                    m.sopm_shape = s.params().shape.code();
                    m.sopm_rows = s.params().rows as u16;
                    m.sopm_cols = s.params().cols as u16;
                    for g in 0..s.len() {
                        m.sopm_prob[g] = s.prob(g).clamp(0.0, 1.0);
                        m.sopm_obs[g] = s.obs(g).min(u16::MAX as u32) as u16;
                    }
                }
                None => {
                    m.h_sopm = 0.0;
                    m.complete = 0;
                    m.l_best = [0.0; 3];
                    m.sopm_shape = self.cfg.sopm.shape.code();
                    m.sopm_rows = 0;
                    m.sopm_cols = 0;
                }
            }
            o.samples(MAX_OBJECT_POINTS, &mut samples);
            m.sample_count = samples.len() as u16;
            for (k, (p, l)) in samples.iter().enumerate() {
                m.points[k] = p.to_array();
                m.point_los[k] = l.to_array();
            }
            count += 1;
        }
        self.samples = samples;
        out.count = count as u32;
    }

    /// Background object supporting a foreground object: its footprint (grown by 5 cm) holds the
    /// object's centre and its plane is within 10 cm of the object's bottom; the closest plane
    /// wins. -1 if none.
    fn cluster_of(&self, o: &MappedObject) -> i32 {
        let bottom = o.cuboid.center.z - o.cuboid.size.z * 0.5;
        let mut best: Option<(f32, u32)> = None;
        for b in self
            .objects
            .iter()
            .filter(|b| b.background && b.observations >= self.cfg.min_observations)
        {
            let Some(h) = b.support_height else { continue };
            let probe = Vec3::new(o.cuboid.center.x, o.cuboid.center.y, b.cuboid.center.z);
            let dz = (bottom - h).abs();
            if dz <= 0.10 && b.contains(probe, 0.05) && best.is_none_or(|(d, _)| dz < d) {
                best = Some((dz, b.id));
            }
        }
        best.map_or(-1, |(_, id)| id as i32)
    }

    /// Write the exploration grid in place; sets `header.sim_time_ns` to the newest frame's time
    /// (the host sets `seq` and `stamp_ns`).
    pub fn write_grid(&self, out: &mut OccupancyGrid) {
        out.header.sim_time_ns = self.last_sim_time_ns;
        self.grid.write(out);
    }
}

/// A foreground object whose bottom lies just above a supporting plane under it (within the band
/// that bleed removal cut away) rests on that plane: extend its cuboid down to the plane.
fn rest_on_support(b: &mut cuboid::Box3, supports: &[SupportPlane], margin: f32) {
    let bottom = b.center.z - b.size.z * 0.5;
    let top = bottom + b.size.z;
    let plane = supports
        .iter()
        .filter(|s| s.under(b.center))
        .map(|s| s.height)
        .find(|h| bottom - h >= -margin && bottom - h <= 2.0 * margin);
    if let Some(h) = plane {
        b.size.z = top - h;
        b.center.z = (top + h) * 0.5;
    }
}

/// Centroids of the occupied voxels of `pts` (edge `voxel`), in first-seen order.
fn voxel_centroids(
    pts: &[Vec3],
    voxel: f32,
    map: &mut HashMap<[i32; 3], (Vec3, u32)>,
    out: &mut Vec<[f32; 3]>,
) {
    map.clear();
    out.clear();
    let inv = 1.0 / voxel;
    let mut order: Vec<[i32; 3]> = Vec::new();
    for p in pts {
        let k = [
            (p.x * inv).floor() as i32,
            (p.y * inv).floor() as i32,
            (p.z * inv).floor() as i32,
        ];
        let e = map.entry(k).or_insert_with(|| {
            order.push(k);
            (Vec3::ZERO, 0)
        });
        e.0 += *p;
        e.1 += 1;
    }
    for k in order {
        let (s, n) = map[&k];
        out.push((s / n as f32).to_array());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn bad_mapper_values_name_the_key() {
        let f = Path::new("bad.toml");
        let e =
            crate::config::Config::parse(f, "[mapper.sopm]\nrows = 40\ncols = 40\n").unwrap_err();
        assert_eq!(e.key(), "mapper.sopm.rows", "{e}");
        let e = crate::config::Config::parse(f, "[mapper.sopm]\nshape = \"cone\"\n").unwrap_err();
        assert!(e.to_string().contains("cone"), "{e}");
        let e = crate::config::Config::parse(f, "[mapper.association]\nalpha = 2.0\n").unwrap_err();
        assert_eq!(e.key(), "mapper.association.alpha");
        let e = crate::config::Config::parse(f, "[mapper.grid]\nwidth = 512\n").unwrap_err();
        assert_eq!(e.key(), "mapper.grid.height");
    }

    /// A table top: points on a plane at 0.72 m over `x0..x1 × y0..y1`.
    fn table_points(x0: f32, x1: f32, y0: f32, y1: f32) -> Vec<Vec3> {
        let mut v = Vec::new();
        let n = 30;
        for i in 0..=n {
            for j in 0..=n {
                let (fx, fy) = (i as f32 / n as f32, j as f32 / n as f32);
                v.push(Vec3::new(x0 + fx * (x1 - x0), y0 + fy * (y1 - y0), 0.72));
            }
        }
        v
    }

    fn cube_points(c: Vec3, half: f32) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                for k in 0..8 {
                    let f = |t: i32| (t as f32 / 7.0 * 2.0 - 1.0) * half;
                    v.push(c + Vec3::new(f(i), f(j), f(k)));
                }
            }
        }
        v
    }

    #[test]
    fn duplicates_merge_into_the_older_object() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let mut m = Mapper::new(&MapperConfig::default(), &cam).unwrap();
        let id = |n| shm_types::class_id(n).unwrap();
        let table = id("dining table");
        let fit = m.fit_params();
        let sopm = m.cfg.sopm.params();
        let add = |m: &mut Mapper, class, bg: bool, t: u64, pts: &[Vec3], from: Vec3| {
            let mut o = MappedObject::new(
                m.next_id,
                class,
                0.9,
                bg,
                if bg { 0.03 } else { 0.01 },
                20000,
                (!bg).then_some(sopm),
                t,
            );
            m.next_id += 1;
            o.merge(pts, from);
            o.refit(&mut m.cuboid_scratch, &mut m.centroids, &fit);
            o.observations = 1;
            o.update_sopm(pts, from, 0.0);
            m.objects.push(o);
        };
        // The same table seen from two sides: two partial footprints overlapping by 70 %.
        add(
            &mut m,
            table,
            true,
            5,
            &table_points(0.0, 1.0, 0.0, 0.8),
            Vec3::ZERO,
        );
        add(
            &mut m,
            table,
            true,
            3,
            &table_points(0.3, 1.3, 0.0, 0.8),
            Vec3::ZERO,
        );
        // Its front face seen edge-on (8 cm deep band of points from 0.3 to 0.6 m high).
        let face: Vec<Vec3> = (0..400)
            .map(|k| {
                Vec3::new(
                    0.4 + (k % 20) as f32 * 0.02,
                    0.01 + (k % 5) as f32 * 0.02,
                    0.3 + (k / 20) as f32 * 0.015,
                )
            })
            .collect();
        add(&mut m, table, true, 8, &face, Vec3::ZERO);
        // A cup and a vase (confusable) at the same place, a bottle 30 cm away, a chair table.
        let c = Vec3::new(0.5, 0.4, 0.8);
        let left = Vec3::new(0.5, -1.0, 1.0);
        let right = Vec3::new(0.5, 2.0, 1.0);
        add(&mut m, id("cup"), false, 7, &cube_points(c, 0.04), left);
        add(
            &mut m,
            id("vase"),
            false,
            9,
            &cube_points(c + Vec3::X * 0.01, 0.04),
            right,
        );
        add(
            &mut m,
            id("bottle"),
            false,
            9,
            &cube_points(c + Vec3::X * 0.3, 0.04),
            left,
        );
        let cup_h = m.objects[3].sopm.as_ref().unwrap().h_sopm();
        assert!(m.objects[2].support_height.unwrap() < 0.65);
        assert_eq!(m.merge_duplicates(), 3);
        assert_eq!(m.objects.len(), 3);
        let t = &m.objects[0];
        // Id of the one seen first (id 2, t = 3), union of the footprints.
        assert_eq!((t.id, t.first_seen_ns, t.observations), (2, 3, 3));
        assert!((t.cuboid.size.x - 1.3).abs() < 0.05, "{:?}", t.cuboid);
        assert!((t.support_height.unwrap() - 0.72).abs() < 0.02);
        let cup = &m.objects[1];
        assert_eq!((cup.id, cup.observations), (4, 2));
        assert!([id("cup"), id("vase")].contains(&cup.class_id));
        // Both sides' evidence: the merged map is more certain than either half.
        assert!(cup.sopm.as_ref().unwrap().h_sopm() < cup_h - 0.1);
        assert_eq!(m.objects[2].class_id, id("bottle"));
        // The cup's cluster is the surviving table.
        m.refresh_supports();
        assert_eq!(m.cluster_of(&m.objects[1]), 2);
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
        let ok = RobotState {
            localization_ok: 1,
            ..Default::default()
        };
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
        let mut map = shm_types::boxed_zeroed::<ObjectMap>();
        m.write_map(&mut map, 9);
        assert_eq!(
            (map.count, map.last_frame_seq, map.header.sim_time_ns),
            (0, 5, 9)
        );
    }
}
