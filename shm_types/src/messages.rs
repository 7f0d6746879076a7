//! The message types. Field order is chosen so that `#[repr(C)]` leaves no hidden padding holes
//! that differ between targets (sizes are pinned by tests at the bottom of this file).
//!
//! These layouts are a published contract: [`crate::contract`] describes them field by field
//! (offsets read from these types) and generates the C header and Python module that drivers in
//! other languages use. Changing a field here changes that contract: regenerate it
//! (`UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract`) and add the field's
//! unit to `contract/describe.rs` (the build fails until every field is listed there).

use crate::ClassId;
use crate::bounds::{MAX_PITCH_RAD, MAX_WORLD_COORD_M, MAX_YAW_RAD};
use crate::validate::{Checker, Field, Validate, ValidationError};
#[cfg(feature = "ipc")]
use iceoryx2::prelude::ZeroCopySend;

/// Largest depth image: 640 × 480 (the paper's Kinect v2 is 512 × 424; smaller sizes by config).
pub const MAX_WIDTH: usize = 640;
/// Largest depth image height.
pub const MAX_HEIGHT: usize = 480;
/// Pixel capacity of a frame.
pub const MAX_PIXELS: usize = MAX_WIDTH * MAX_HEIGHT;
/// Instances per [`Detections`] message.
pub const MAX_DETECTIONS: usize = 64;
/// Objects per [`ObjectMap`].
pub const MAX_OBJECTS: usize = 128;
/// SOPM cells per object (e.g. 18 × 18 cylinder = 324, 36 × 18 sphere = 648).
pub const MAX_SOPM_CELLS: usize = 648;
/// Sample points per object carried in the map (for co-visibility, eq. 22).
pub const MAX_OBJECT_POINTS: usize = 64;
/// Cells of an [`OccupancyGrid`] (256 × 256; 12.8 m square at 5 cm).
pub const MAX_GRID_CELLS: usize = 256 * 256;
/// Candidates per [`PlannerDecision`].
pub const MAX_CANDIDATES: usize = 64;
/// Frame receipts per [`ObjectMap`]: the depth frames a map consumed since the previous one
/// (a host publishes a map at least every this many frames).
pub const MAX_FRAME_RECEIPTS: usize = 16;
/// Bytes of a thread name in [`DeadlineEvent`].
pub const THREAD_NAME_LEN: usize = 32;

/// Common header of every message.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::AnyBitPattern)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Header"))]
pub struct Header {
    /// Per-publisher sequence number, starting at 1 (0 means "never written").
    pub seq: u64,
    /// Monotonic clock (`CLOCK_MONOTONIC`) of the producer when the data was produced, ns.
    pub stamp_ns: u64,
    /// Simulation (or robot) time the data refers to, ns.
    pub sim_time_ns: u64,
}

/// A rigid transform `parent_from_child`: translation and unit quaternion `[x, y, z, w]`.
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::AnyBitPattern)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Pose3"))]
pub struct Pose3 {
    /// Translation, metres.
    pub translation: [f32; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
}

impl Default for Pose3 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose3 {
    /// The identity transform.
    pub const IDENTITY: Pose3 = Pose3 {
        translation: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
    };

    /// Translation finite and within [`MAX_WORLD_COORD_M`]; rotation finite with norm² within
    /// 1e-3 of 1.
    fn check(&self, c: &Checker, field: &'static str) -> Result<(), ValidationError> {
        c.within(field, &self.translation, MAX_WORLD_COORD_M)?;
        c.finite(field, &self.rotation)?;
        let n2: f32 = self.rotation.iter().map(|q| q * q).sum();
        if (n2 - 1.0).abs() > 1e-3 {
            return Err(c.err(
                field,
                format!("rotation quaternion has norm² {n2}, expected 1"),
            ));
        }
        Ok(())
    }
}

/// Pinhole intrinsics of the depth camera (pixels) and its valid range (metres).
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::AnyBitPattern)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Intrinsics"))]
pub struct Intrinsics {
    /// Focal length x, pixels.
    pub fx: f32,
    /// Focal length y, pixels.
    pub fy: f32,
    /// Principal point x, pixels.
    pub cx: f32,
    /// Principal point y, pixels.
    pub cy: f32,
    /// Nearest valid depth, metres.
    pub min_range: f32,
    /// Farthest valid depth, metres.
    pub max_range: f32,
}

/// One depth image, `u16` millimetres, 0 = invalid. (`Copy` only because
/// `bytemuck::AnyBitPattern` requires it: never copy one by value, see [`crate::AnyBitPattern`].)
#[derive(Debug, Clone, Copy, bytemuck::AnyBitPattern)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::DepthFrame"))]
pub struct DepthFrame {
    /// Header.
    pub header: Header,
    /// Actual width in pixels (≤ [`MAX_WIDTH`]).
    pub width: u32,
    /// Actual height in pixels (≤ [`MAX_HEIGHT`]).
    pub height: u32,
    /// Camera intrinsics.
    pub intrinsics: Intrinsics,
    /// `world_from_camera` as the robot believes it (estimated base pose + neck), optical frame.
    pub camera_pose: Pose3,
    /// Padding, always 0.
    pub reserved: u32,
    /// Row-major depth, millimetres, first `width * height` entries used.
    pub depth_mm: [u16; MAX_PIXELS],
}

impl DepthFrame {
    /// The used pixels, row-major.
    pub fn pixels(&self) -> &[u16] {
        &self.depth_mm[..self.pixel_count()]
    }

    /// The used pixels, row-major, mutable.
    pub fn pixels_mut(&mut self) -> &mut [u16] {
        let n = self.pixel_count();
        &mut self.depth_mm[..n]
    }

    fn pixel_count(&self) -> usize {
        (self.width as usize * self.height as usize).min(MAX_PIXELS)
    }
}

/// Rules: `width` ≤ [`MAX_WIDTH`], `height` ≤ [`MAX_HEIGHT`]; intrinsics finite, focal
/// lengths positive, `0 ≤ min_range < max_range`; `camera_pose` a valid [`Pose3`] within the
/// world bounds ([`crate::bounds`]). Depth values are data: every `u16` is a valid depth (0 = none).
impl Validate for DepthFrame {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "DepthFrame",
        };
        c.count("width", self.width as usize, MAX_WIDTH)?;
        c.count("height", self.height as usize, MAX_HEIGHT)?;
        let i = &self.intrinsics;
        c.finite(
            "intrinsics",
            &[i.fx, i.fy, i.cx, i.cy, i.min_range, i.max_range],
        )?;
        if i.fx <= 0.0 || i.fy <= 0.0 {
            return Err(c.err(
                "intrinsics",
                format!("focal lengths {} {} must be > 0", i.fx, i.fy),
            ));
        }
        if !(i.min_range >= 0.0 && i.max_range > i.min_range) {
            return Err(c.err(
                "intrinsics",
                format!("range [{}, {}] is empty", i.min_range, i.max_range),
            ));
        }
        self.camera_pose.check(&c, "camera_pose")
    }
}

/// One detected instance.
// `Pod` (no padding, any bits), not only `AnyBitPattern`: bytemuck makes an array
// `AnyBitPattern` only through `Pod`, and `Detections` holds `[Detection; 64]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Detection"))]
pub struct Detection {
    /// COCO class id (see [`crate::COCO_CLASSES`]).
    pub class_id: ClassId,
    /// Value of this instance in [`Detections::labels`] (1-based; 0 is background).
    pub label: u16,
    /// Detector confidence in `[0, 1]`.
    pub score: f32,
    /// 2D box `[x0, y0, x1, y1]`, pixels, `x1`/`y1` exclusive.
    pub bbox: [u16; 4],
    /// Number of mask pixels.
    pub mask_pixels: u32,
}

/// Instance detections for one depth frame, with an instance label image. (`Copy` only because
/// `bytemuck::AnyBitPattern` requires it: never copy one by value.)
#[derive(Debug, Clone, Copy, bytemuck::AnyBitPattern)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Detections"))]
pub struct Detections {
    /// Header (stamps equal to the frame's).
    pub header: Header,
    /// `header.seq` of the [`DepthFrame`] these detections belong to.
    pub frame_seq: u64,
    /// Image width (same as the frame).
    pub width: u32,
    /// Image height (same as the frame).
    pub height: u32,
    /// Number of valid entries in `items`.
    pub count: u32,
    /// What the detector gave: [`mask_mode::BOXES`] (0: class, score and box only, as a
    /// YOLO-class detector; `labels` is unused and `mask_pixels` is 0) or [`mask_mode::MASKS`]
    /// (1: instance segmentation; `labels` holds each item's mask).
    pub masks: u32,
    /// Detected instances, first `count` valid.
    pub items: [Detection; MAX_DETECTIONS],
    /// Row-major instance label image: 0 = none, `k` = the item whose `label == k`. Valid only
    /// when `masks == mask_mode::MASKS`.
    pub labels: [u8; MAX_PIXELS],
}

impl Detections {
    /// The valid detections.
    pub fn detections(&self) -> &[Detection] {
        &self.items[..(self.count as usize).min(MAX_DETECTIONS)]
    }

    /// The used part of the label image.
    pub fn label_pixels(&self) -> &[u8] {
        &self.labels[..(self.width as usize * self.height as usize).min(MAX_PIXELS)]
    }

    /// The used part of the label image, mutable.
    pub fn label_pixels_mut(&mut self) -> &mut [u8] {
        let n = (self.width as usize * self.height as usize).min(MAX_PIXELS);
        &mut self.labels[..n]
    }
}

/// Rules: `width` ≤ [`MAX_WIDTH`], `height` ≤ [`MAX_HEIGHT`], `count` ≤ [`MAX_DETECTIONS`],
/// `masks` one of [`mask_mode`]. Each of the first `count` items: `score` in `[0, 1]`,
/// `class_id` in the COCO table, `bbox` not inverted (`x0 ≤ x1`, `y0 ≤ y1`) and inside the
/// image (`x1 ≤ width`, `y1 ≤ height`).
/// - [`mask_mode::BOXES`]: every `mask_pixels` is 0; `label` and the label image are unused and
///   not checked.
/// - [`mask_mode::MASKS`]: every `label` is in `1..=255` (the label image is `u8`) and differs
///   from the other items' labels; every pixel of the label image's first `width × height` is 0
///   or some item's `label`; each item's `mask_pixels` is at most `width × height` and equals
///   the number of pixels that carry its label. (The box need not hold the whole mask: a
///   detector's box is its own estimate.)
impl Validate for Detections {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "Detections",
        };
        c.count("width", self.width as usize, MAX_WIDTH)?;
        c.count("height", self.height as usize, MAX_HEIGHT)?;
        c.count("count", self.count as usize, MAX_DETECTIONS)?;
        c.count("masks", self.masks as usize, mask_mode::MASKS as usize)?;
        if self.masks == mask_mode::MASKS {
            self.check_masks(&c)?;
        }
        for (k, d) in self.detections().iter().enumerate() {
            if self.masks == mask_mode::BOXES && d.mask_pixels != 0 {
                return Err(c.err(
                    Field::item("items", k, "mask_pixels"),
                    format!(
                        "{} in boxes mode (masks = 0 carries no masks)",
                        d.mask_pixels
                    ),
                ));
            }
            c.range(Field::item("items", k, "score"), d.score, 0.0, 1.0)?;
            c.count(
                Field::item("items", k, "class_id"),
                d.class_id as usize,
                crate::COCO_CLASSES.len() - 1,
            )?;
            if d.bbox[0] > d.bbox[2] || d.bbox[1] > d.bbox[3] {
                return Err(c.err(
                    Field::item("items", k, "bbox"),
                    format!("{:?} is inverted", d.bbox),
                ));
            }
            c.count(
                Field::item("items", k, "bbox.x1"),
                d.bbox[2] as usize,
                self.width as usize,
            )?;
            c.count(
                Field::item("items", k, "bbox.y1"),
                d.bbox[3] as usize,
                self.height as usize,
            )?;
        }
        Ok(())
    }
}

impl Detections {
    /// The masks-mode rules of [`Validate`]: labels unique in `1..=255`, every label-image
    /// value some item's label, `mask_pixels` the pixel count of that label. Uses 1.3 KB of
    /// stack, no heap.
    fn check_masks(&self, c: &Checker) -> Result<(), ValidationError> {
        // Item index + 1 of each label value (0: no item has it).
        let mut item_of = [0u8; 256];
        for (k, d) in self.detections().iter().enumerate() {
            let field = Field::item("items", k, "label");
            if d.label == 0 || d.label > 255 {
                return Err(c.err(
                    field,
                    format!("{} (masks mode: labels are 1..=255)", d.label),
                ));
            }
            let l = d.label as usize;
            if item_of[l] != 0 {
                return Err(c.err(
                    field,
                    format!("{} is also items[{}].label", d.label, item_of[l] - 1),
                ));
            }
            item_of[l] = k as u8 + 1;
        }
        let mut pixels = [0u32; 256];
        for &v in self.label_pixels() {
            pixels[v as usize] += 1;
        }
        if let Some(v) = (1..256).find(|&v| pixels[v] > 0 && item_of[v] == 0) {
            return Err(c.err(
                "labels",
                format!(
                    "value {v} (on {} pixels) is no item's label ({} items)",
                    pixels[v], self.count
                ),
            ));
        }
        let image = self.label_pixels().len();
        for (k, d) in self.detections().iter().enumerate() {
            let field = Field::item("items", k, "mask_pixels");
            c.count(field, d.mask_pixels as usize, image)?;
            let n = pixels[d.label as usize];
            if d.mask_pixels != n {
                return Err(c.err(
                    field,
                    format!(
                        "{} but the label image has {n} pixels of label {}",
                        d.mask_pixels, d.label
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Values of [`Detections::masks`].
pub mod mask_mode {
    /// Boxes only (YOLO-class detector): the label image is unused.
    pub const BOXES: u32 = 0;
    /// Instance masks in the label image.
    pub const MASKS: u32 = 1;
}

/// Navigation status reported in [`RobotState::nav_status`].
pub mod nav_status {
    /// No goal received yet.
    pub const IDLE: u8 = 0;
    /// Driving to `nav_goal_id`.
    pub const MOVING: u8 = 1;
    /// `nav_goal_id` reached.
    pub const REACHED: u8 = 2;
    /// `nav_goal_id` refused or became unreachable.
    pub const UNREACHABLE: u8 = 3;
}

/// State of the robot: base pose, neck, odometry uncertainty, localization and navigation status.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::RobotState"))]
pub struct RobotState {
    /// Header.
    pub header: Header,
    /// Id of the [`NavGoal`] the base is working on (0 = none).
    pub nav_goal_id: u64,
    /// Base pose in the world `[x, y, yaw]` (estimated on `robot/state`, true on `sim/truth`).
    pub base_pose: [f32; 3],
    /// Neck yaw relative to the base, radians.
    pub neck_yaw: f32,
    /// Neck (camera) pitch, radians, positive = looking down.
    pub neck_pitch: f32,
    /// Odometry covariance of `[x, y, yaw]`, row-major 3 × 3.
    pub odom_cov: [f32; 9],
    /// Base linear speed, m/s.
    pub speed: f32,
    /// Distance driven since start, metres.
    pub distance_m: f32,
    /// 1 while visual localization is tracking, 0 while lost.
    pub localization_ok: u8,
    /// One of [`nav_status`].
    pub nav_status: u8,
    /// Padding, always 0.
    pub reserved: [u8; 2],
    /// Number of localization-failure episodes so far.
    pub localization_failures: u32,
}

/// Rules: `base_pose` x, y within [`MAX_WORLD_COORD_M`] and yaw within [`MAX_YAW_RAD`];
/// `neck_yaw` within [`MAX_YAW_RAD`], `neck_pitch` within [`MAX_PITCH_RAD`]; `odom_cov` finite
/// with a non-negative diagonal; `speed` finite; `distance_m` finite and ≥ 0;
/// `localization_ok` 0 or 1; `nav_status` one of [`nav_status`].
impl Validate for RobotState {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "RobotState",
        };
        c.within("base_pose", &self.base_pose[..2], MAX_WORLD_COORD_M)?;
        c.within("base_pose.yaw", &self.base_pose[2..], MAX_YAW_RAD)?;
        c.within("neck_yaw", &[self.neck_yaw], MAX_YAW_RAD)?;
        c.within("neck_pitch", &[self.neck_pitch], MAX_PITCH_RAD)?;
        c.finite("odom_cov", &self.odom_cov)?;
        if let Some(i) = [0, 4, 8].into_iter().find(|i| self.odom_cov[*i] < 0.0) {
            return Err(c.err(
                "odom_cov",
                format!(
                    "diagonal element {i} is {} (a variance is >= 0)",
                    self.odom_cov[i]
                ),
            ));
        }
        c.finite("speed", &[self.speed])?;
        c.range("distance_m", self.distance_m, 0.0, f32::MAX)?;
        c.flag("localization_ok", self.localization_ok)?;
        c.count(
            "nav_status",
            self.nav_status as usize,
            nav_status::UNREACHABLE as usize,
        )
    }
}

/// Shape of a surface occupancy probability map (paper Figure 3).
pub mod sopm_shape {
    /// Cylinder around the object's z axis (ground robots: x, y, z, yaw DOF).
    pub const CYLINDER: u8 = 0;
    /// Upper hemisphere around the centre.
    pub const HEMISPHERE: u8 = 1;
    /// Full sphere around the centre.
    pub const SPHERE: u8 = 2;
}

/// One object of the sparse object map.
#[derive(Debug, Clone, Copy, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::MapObject"))]
pub struct MapObject {
    /// Monotonic timestamp (ns) when the object was first seen (clusters are sorted by it).
    pub first_seen_ns: u64,
    /// Stable id of the object within a session.
    pub id: u32,
    /// COCO class id.
    pub class_id: ClassId,
    /// 1 for background (cluster-anchoring) objects.
    pub background: u8,
    /// 1 when `h_sopm < ε_sopm` (foreground objects only).
    pub complete: u8,
    /// Cuboid centre, world frame, metres.
    pub center: [f32; 3],
    /// Cuboid size along its own x, y, z, metres.
    pub size: [f32; 3],
    /// Cuboid yaw about +z, radians.
    pub yaw: f32,
    /// Points merged into the object.
    pub point_count: u32,
    /// Id of the background object whose cluster this belongs to (its own id for a background
    /// object), -1 if none.
    pub cluster_id: i32,
    /// Number of observations (associated detections).
    pub observations: u32,
    /// Mean cell entropy of the SOPM (eq. 10), 1.0 when unobserved.
    pub h_sopm: f32,
    /// Association confidence C_asso (eq. 20; the mapper's `[mapper.association] c_asso` says how).
    pub c_asso: f32,
    /// Best line of sight (eq. 11), world frame, not normalised; zero if undefined.
    pub l_best: [f32; 3],
    /// One of [`sopm_shape`].
    pub sopm_shape: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// SOPM columns (angular cells).
    pub sopm_cols: u16,
    /// SOPM rows (height or elevation cells).
    pub sopm_rows: u16,
    /// Number of valid entries in `points`.
    pub sample_count: u16,
    /// Occupancy probability per cell, row-major (`row * cols + col`), first `rows * cols` used.
    pub sopm_prob: [f32; MAX_SOPM_CELLS],
    /// Observation count `n_o` per cell.
    pub sopm_obs: [u16; MAX_SOPM_CELLS],
    /// Sample of the object's points, world frame.
    pub points: [[f32; 3]; MAX_OBJECT_POINTS],
    /// Mean unit line of sight (camera → point) of each sample point over the views that saw it.
    pub point_los: [[f32; 3]; MAX_OBJECT_POINTS],
    /// Background objects: world z (m) of the supporting plane whose foreground objects form
    /// its cluster (0 while the mapper has fitted none); 0 for foreground objects.
    pub support_height: f32,
}

impl MapObject {
    /// Number of SOPM cells in use.
    pub fn cell_count(&self) -> usize {
        (self.sopm_rows as usize * self.sopm_cols as usize).min(MAX_SOPM_CELLS)
    }

    /// Occupancy probabilities of the cells in use.
    pub fn cells(&self) -> &[f32] {
        &self.sopm_prob[..self.cell_count()]
    }

    /// Valid sample points with their mean lines of sight.
    pub fn samples(&self) -> impl Iterator<Item = (&[f32; 3], &[f32; 3])> {
        let n = (self.sample_count as usize).min(MAX_OBJECT_POINTS);
        self.points[..n].iter().zip(&self.point_los[..n])
    }

    /// Whether this is a background object.
    pub fn is_background(&self) -> bool {
        self.background != 0
    }

    /// Whether modelling of this (foreground) object is complete.
    pub fn is_complete(&self) -> bool {
        self.complete != 0
    }

    /// The per-object rules of [`ObjectMap`]'s [`Validate`] (object `k`).
    fn check(&self, c: &Checker, k: usize) -> Result<(), ValidationError> {
        let f = |name: &'static str| Field::item("objects", k, name);
        c.within(f("center"), &self.center, MAX_WORLD_COORD_M)?;
        c.within(f("size"), &self.size, MAX_WORLD_COORD_M)?;
        if self.size.iter().any(|s| *s < 0.0) {
            return Err(c.err(f("size"), format!("{:?} has a negative extent", self.size)));
        }
        c.within(f("yaw"), &[self.yaw], MAX_YAW_RAD)?;
        c.flag(f("background"), self.background)?;
        c.flag(f("complete"), self.complete)?;
        c.cluster(f("cluster_id"), self.cluster_id)?;
        if self.is_background() && i64::from(self.cluster_id) != i64::from(self.id) {
            return Err(c.err(
                f("cluster_id"),
                format!(
                    "{} on background object {} (a background object anchors its own cluster)",
                    self.cluster_id, self.id
                ),
            ));
        }
        c.range(f("h_sopm"), self.h_sopm, 0.0, 1.0 + 1e-4)?;
        c.range(f("c_asso"), self.c_asso, 0.0, 1.0)?;
        c.finite(f("l_best"), &self.l_best)?;
        c.count(
            f("sopm_shape"),
            self.sopm_shape as usize,
            sopm_shape::SPHERE as usize,
        )?;
        c.count(
            f("sopm_cells"),
            self.sopm_rows as usize * self.sopm_cols as usize,
            MAX_SOPM_CELLS,
        )?;
        if (self.sopm_rows == 0) != (self.sopm_cols == 0) {
            return Err(c.err(
                f("sopm_cells"),
                format!(
                    "{} rows x {} cols (a SOPM has both or neither)",
                    self.sopm_rows, self.sopm_cols
                ),
            ));
        }
        c.count(
            f("sample_count"),
            self.sample_count as usize,
            MAX_OBJECT_POINTS,
        )?;
        c.count(
            f("class_id"),
            self.class_id as usize,
            crate::COCO_CLASSES.len() - 1,
        )?;
        for (i, p) in self.cells().iter().enumerate() {
            if !(0.0..=1.0).contains(p) {
                return Err(c.err(f("sopm_prob"), format!("cell {i} is {p}, outside [0, 1]")));
            }
        }
        for (p, l) in self.samples() {
            c.within(f("points"), p, MAX_WORLD_COORD_M)?;
            // A mean of unit vectors, normalised or not: each component within [-1, 1].
            c.within(f("point_los"), l, 1.0 + 1e-3)?;
        }
        c.within(
            f("support_height"),
            &[self.support_height],
            MAX_WORLD_COORD_M,
        )?;
        Ok(())
    }
}

/// The sparse object map: one cuboid per object, with the per-object view-planning information.
#[derive(Debug, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::ObjectMap"))]
pub struct ObjectMap {
    /// Header.
    pub header: Header,
    /// `header.seq` of the newest [`DepthFrame`] integrated into this map.
    pub last_frame_seq: u64,
    /// `header.stamp_ns` of that frame (for end-to-end latency).
    pub last_frame_stamp_ns: u64,
    /// Number of valid entries in `objects`.
    pub count: u32,
    /// Completion threshold ε_sopm used to set `complete`.
    pub eps_sopm: f32,
    /// Depth frames integrated so far (the mapper's running count).
    pub frames_integrated: u32,
    /// Depth frames or detections rejected so far because they failed validation (NaN pose,
    /// counts out of range, ...): received, counted, not integrated.
    pub frames_rejected: u32,
    /// Depth frames skipped so far because no matching detections arrived (or their size or
    /// sequence number did not match the frame).
    pub frames_unmatched: u32,
    /// Depth frames the mapper consumed since the previous map (integrated, skipped or
    /// refused). `receipts` holds the newest `min(receipt_count, MAX_FRAME_RECEIPTS)` of them;
    /// a count above [`MAX_FRAME_RECEIPTS`] says that receipts were lost.
    pub receipt_count: u32,
    /// The objects, first `count` valid.
    pub objects: [MapObject; MAX_OBJECTS],
    /// What the mapper did with each frame it consumed since the previous map, oldest first
    /// (see `receipt_count`): which inputs this map consumed, so that a replay can follow them.
    pub receipts: [FrameReceipt; MAX_FRAME_RECEIPTS],
}

/// What the mapper did with one depth frame: which frame, with which robot state, and what came
/// of it ([`frame_outcome`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::FrameReceipt")
)]
pub struct FrameReceipt {
    /// `header.seq` of the [`DepthFrame`].
    pub frame_seq: u64,
    /// `header.seq` of the [`RobotState`] the mapper held for it (0: none received yet).
    pub state_seq: u64,
    /// One of [`frame_outcome`].
    pub outcome: u32,
    /// Padding, always 0.
    pub reserved: u32,
}

/// Values of [`FrameReceipt::outcome`].
pub mod frame_outcome {
    /// Integrated into the map.
    pub const INTEGRATED: u32 = 0;
    /// Skipped: the robot state said localization was lost.
    pub const SKIPPED_LOST: u32 = 1;
    /// Skipped: no matching detections arrived.
    pub const NO_DETECTIONS: u32 = 2;
    /// Refused: the frame or its detections failed validation, or they disagree (size, seq).
    pub const REFUSED: u32 = 3;
}

impl ObjectMap {
    /// The valid objects.
    pub fn objects(&self) -> &[MapObject] {
        &self.objects[..(self.count as usize).min(MAX_OBJECTS)]
    }

    /// The valid receipts, oldest first.
    pub fn receipts(&self) -> &[FrameReceipt] {
        &self.receipts[..(self.receipt_count as usize).min(MAX_FRAME_RECEIPTS)]
    }

    /// Make `self` a copy of `src` (e.g. into a reusable buffer): the header fields and the used
    /// objects. `count` becomes the number of objects copied (`src.count` clamped to
    /// [`MAX_OBJECTS`]); entries past it are left as they were.
    pub fn copy_from(&mut self, src: &ObjectMap) {
        let objects = src.objects();
        self.header = src.header;
        self.last_frame_seq = src.last_frame_seq;
        self.last_frame_stamp_ns = src.last_frame_stamp_ns;
        self.eps_sopm = src.eps_sopm;
        self.frames_integrated = src.frames_integrated;
        self.frames_rejected = src.frames_rejected;
        self.frames_unmatched = src.frames_unmatched;
        self.count = objects.len() as u32;
        self.objects[..objects.len()].copy_from_slice(objects);
        self.receipt_count = src.receipt_count;
        self.receipts = src.receipts;
    }
}

/// Rules: `count` ≤ [`MAX_OBJECTS`], `eps_sopm` in `[0, 1]`, object ids unique. Each of the
/// first `count` objects: `center` within [`MAX_WORLD_COORD_M`]; `size` non-negative and within
/// it; `yaw` within [`MAX_YAW_RAD`]; `background` and `complete` 0 or 1; `class_id` in the COCO
/// table; `cluster_id` ≥ -1, and a background object's equal to its own `id`; `h_sopm` in
/// `[0, 1]` (1e-4 slack), `c_asso` in `[0, 1]`; `l_best` finite; `sopm_shape` one of
/// [`sopm_shape`]; `sopm_rows × sopm_cols` ≤ [`MAX_SOPM_CELLS`], both zero (no SOPM yet) or both
/// non-zero; every used `sopm_prob` in `[0, 1]`; `sample_count` ≤ [`MAX_OBJECT_POINTS`]; each
/// used point within [`MAX_WORLD_COORD_M`] and each component of its `point_los` within
/// `[-1, 1]` (1e-3 slack); `support_height` within [`MAX_WORLD_COORD_M`]. Each used receipt's
/// `outcome` one of [`frame_outcome`] (`receipt_count` itself is any count).
///
/// Not checked: that a foreground object's `cluster_id` names a background object of the same
/// message. The map is cut at [`MAX_OBJECTS`], which may leave out the background object, and a
/// cluster without it is still a well-defined set of objects to its receivers.
impl Validate for ObjectMap {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "ObjectMap",
        };
        c.count("count", self.count as usize, MAX_OBJECTS)?;
        c.range("eps_sopm", self.eps_sopm, 0.0, 1.0)?;
        let objects = self.objects();
        for (k, o) in objects.iter().enumerate() {
            o.check(&c, k)?;
            if let Some(j) = objects[..k].iter().position(|p| p.id == o.id) {
                return Err(c.err(
                    Field::item("objects", k, "id"),
                    format!("{} is also objects[{j}].id", o.id),
                ));
            }
        }
        for (k, r) in self.receipts().iter().enumerate() {
            if r.outcome > frame_outcome::REFUSED {
                return Err(c.err(
                    Field::item("receipts", k, "outcome"),
                    format!("{} is not one of frame_outcome", r.outcome),
                ));
            }
        }
        Ok(())
    }
}

/// Cell values of an [`OccupancyGrid`]. Values `1..=99` between [`FREE`](grid_cell::FREE) and
/// [`OCCUPIED`](grid_cell::OCCUPIED) are occupancy percentages (as in a ROS
/// `nav_msgs/OccupancyGrid`; our receivers take `< 50` as free); `101..=254` are invalid.
pub mod grid_cell {
    /// Free space.
    pub const FREE: u8 = 0;
    /// Occupied (obstacle).
    pub const OCCUPIED: u8 = 100;
    /// Never observed.
    pub const UNKNOWN: u8 = 255;
}

/// A 2D occupancy grid in the world frame: the navigation map (obstacles only) or the
/// depth-built exploration grid (with unknown cells, for frontiers).
#[derive(Debug, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::OccupancyGrid")
)]
pub struct OccupancyGrid {
    /// Header.
    pub header: Header,
    /// World coordinates `[x, y]` of the corner of cell (0, 0), metres.
    pub origin: [f32; 2],
    /// Cell edge, metres.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// Padding, always 0.
    pub reserved: u32,
    /// Row-major (`iy * width + ix`) cells, values from [`grid_cell`].
    pub cells: [u8; MAX_GRID_CELLS],
}

impl OccupancyGrid {
    /// The used cells.
    pub fn used(&self) -> &[u8] {
        &self.cells[..(self.width as usize * self.height as usize).min(MAX_GRID_CELLS)]
    }
}

/// Rules: `origin` within [`MAX_WORLD_COORD_M`]; `resolution` in `[1 mm, 10 m]`; `width` and
/// `height` ≥ 1 with `width × height` ≤ [`MAX_GRID_CELLS`]; the far corner
/// (`origin + (width, height) × resolution`) within [`MAX_WORLD_COORD_M`]; every used cell
/// `0..=100` or [`grid_cell::UNKNOWN`].
impl Validate for OccupancyGrid {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "OccupancyGrid",
        };
        c.within("origin", &self.origin, MAX_WORLD_COORD_M)?;
        c.range("resolution", self.resolution, 1e-3, 10.0)?;
        for (field, n) in [("width", self.width), ("height", self.height)] {
            if n == 0 {
                return Err(c.err(field, "0 (a grid has at least one cell)".into()));
            }
        }
        c.count(
            "cells",
            self.width as usize * self.height as usize,
            MAX_GRID_CELLS,
        )?;
        let far = [
            self.origin[0] + self.width as f32 * self.resolution,
            self.origin[1] + self.height as f32 * self.resolution,
        ];
        c.within("far corner (origin + size)", &far, MAX_WORLD_COORD_M)?;
        match self
            .used()
            .iter()
            .position(|v| *v > grid_cell::OCCUPIED && *v != grid_cell::UNKNOWN)
        {
            None => Ok(()),
            Some(i) => Err(c.err(
                "cells",
                format!(
                    "cell {i} is {} (cells are 0..=100 or 255 = unknown)",
                    self.used()[i]
                ),
            )),
        }
    }
}

/// Kind of a [`NavGoal`].
pub mod goal_kind {
    /// VP-SOM global best view.
    pub const GBV: u8 = 0;
    /// Waypoint of the all-views coverage baseline.
    pub const COVERAGE: u8 = 1;
    /// Frontier of the frontier-exploration baseline.
    pub const FRONTIER: u8 = 2;
    /// A drive of the localization recovery (any planner; see `[planner.recovery]`).
    pub const RECOVERY: u8 = 3;
}

/// A chassis goal.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::NavGoal"))]
pub struct NavGoal {
    /// Header.
    pub header: Header,
    /// Unique, increasing goal id (echoed in [`RobotState::nav_goal_id`]).
    pub goal_id: u64,
    /// Target base pose `[x, y, yaw]`, world frame.
    pub pose: [f32; 3],
    /// Evaluation value F(v) of the chosen view (0 for baselines).
    pub score: f32,
    /// Cluster (background object id) the goal serves, -1 if none.
    pub cluster_id: i32,
    /// One of [`goal_kind`].
    pub kind: u8,
    /// Padding, always 0.
    pub reserved: [u8; 3],
}

/// Rules: `pose` x, y within [`MAX_WORLD_COORD_M`] and yaw within [`MAX_YAW_RAD`]; `score`
/// finite; `cluster_id` ≥ -1; `kind` one of [`goal_kind`].
impl Validate for NavGoal {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker { message: "NavGoal" };
        c.within("pose", &self.pose[..2], MAX_WORLD_COORD_M)?;
        c.within("pose.yaw", &self.pose[2..], MAX_YAW_RAD)?;
        c.finite("score", &[self.score])?;
        c.cluster("cluster_id", self.cluster_id)?;
        c.count("kind", self.kind as usize, goal_kind::RECOVERY as usize)
    }
}

/// A neck (sensor) goal relative to the base.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::NeckGoal"))]
pub struct NeckGoal {
    /// Header.
    pub header: Header,
    /// `header.seq` of the [`ObjectMap`] the goal was computed from.
    pub map_seq: u64,
    /// `last_frame_stamp_ns` of that map (end-to-end latency frame → LBV).
    pub frame_stamp_ns: u64,
    /// Neck yaw relative to the base, radians.
    pub yaw: f32,
    /// Camera pitch, radians, positive = down.
    pub pitch: f32,
    /// Evaluation value F(v) of the chosen view.
    pub score: f32,
    /// 1 when a chassis-goal round's result was taken in the planner cycle that computed this
    /// goal (after it), 0 otherwise.
    pub round_done: u32,
    /// `header.seq` of the [`RobotState`] the cycle used.
    pub state_seq: u64,
    /// `header.seq` of the navigation grid the cycle held (0: none yet).
    pub nav_seq: u64,
    /// `header.seq` of the exploration grid the cycle held (0: none yet).
    pub explore_seq: u64,
}

/// Rules: `yaw` within [`MAX_YAW_RAD`], `pitch` within [`MAX_PITCH_RAD`], `score` finite,
/// `round_done` 0 or 1.
impl Validate for NeckGoal {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "NeckGoal",
        };
        c.within("yaw", &[self.yaw], MAX_YAW_RAD)?;
        c.within("pitch", &[self.pitch], MAX_PITCH_RAD)?;
        c.finite("score", &[self.score])?;
        c.flag(
            "round_done",
            u8::try_from(self.round_done).unwrap_or(u8::MAX),
        )
    }
}

/// One record of a deadline monitor (periodic executor cycle).
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::DeadlineEvent")
)]
pub struct DeadlineEvent {
    /// Header.
    pub header: Header,
    /// Cycle index since the executor started.
    pub cycle: u64,
    /// Period, ns.
    pub period_ns: u64,
    /// Budget (allowed execution time), ns.
    pub budget_ns: u64,
    /// Actual − intended wake-up, ns (negative = early).
    pub lateness_ns: i64,
    /// Execution time of the cycle body, ns.
    pub exec_ns: u64,
    /// CPU time the thread got from the end of the previous cycle to the end of this one, ns
    /// (valid if `sched_stats` = 1).
    pub cpu_ns: u64,
    /// Time the thread spent runnable but waiting for a CPU over the same span, ns (valid if
    /// `sched_stats` = 1).
    pub run_wait_ns: u64,
    /// Consecutive misses including this one.
    pub consecutive_misses: u32,
    /// 1 if the cycle missed its deadline.
    pub missed: u8,
    /// Why it missed ([`miss_cause`]); `NONE` if it did not.
    pub miss_cause: u8,
    /// 1 if `cpu_ns` and `run_wait_ns` were measured (the kernel reports per-thread scheduler
    /// statistics and the clock is real time).
    pub sched_stats: u8,
    /// 1 if the executor's backup waker woke the thread for this cycle (its own timer was late).
    pub backup_wake: u8,
    /// Thread name, UTF-8, zero-padded.
    pub thread: [u8; THREAD_NAME_LEN],
}

impl DeadlineEvent {
    /// The thread name.
    pub fn thread_name(&self) -> &str {
        let end = self
            .thread
            .iter()
            .position(|b| *b == 0)
            .unwrap_or(THREAD_NAME_LEN);
        std::str::from_utf8(&self.thread[..end]).unwrap_or("?")
    }

    /// Store a thread name (truncated at a char boundary to [`THREAD_NAME_LEN`] bytes).
    pub fn set_thread_name(&mut self, name: &str) {
        self.thread = [0; THREAD_NAME_LEN];
        let mut end = name.len().min(THREAD_NAME_LEN);
        while !name.is_char_boundary(end) {
            end -= 1;
        }
        self.thread[..end].copy_from_slice(&name.as_bytes()[..end]);
    }
}

/// Rules: `missed`, `sched_stats`, `backup_wake` 0 or 1; `miss_cause` one of [`miss_cause`];
/// `period_ns` > 0.
impl Validate for DeadlineEvent {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "DeadlineEvent",
        };
        c.count("missed", self.missed as usize, 1)?;
        c.count("sched_stats", self.sched_stats as usize, 1)?;
        c.count("backup_wake", self.backup_wake as usize, 1)?;
        if self.miss_cause > miss_cause::UNKNOWN {
            return Err(c.err(
                "miss_cause",
                format!(
                    "{} (codes are 0..={})",
                    self.miss_cause,
                    miss_cause::UNKNOWN
                ),
            ));
        }
        if self.period_ns == 0 {
            return Err(c.err("period_ns", "0 (period must be > 0)".into()));
        }
        Ok(())
    }
}

/// One evaluated candidate view with every term of F(v) (paper eqs. 1–4).
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(feature = "ipc", derive(ZeroCopySend), type_name("vpsom::Candidate"))]
pub struct Candidate {
    /// Camera position, world frame.
    pub position: [f32; 3],
    /// Camera yaw (world), radians.
    pub yaw: f32,
    /// Camera pitch, radians, positive = down.
    pub pitch: f32,
    /// F(v).
    pub value: f32,
    /// f_a(v) (eq. 3).
    pub f_a: f32,
    /// f_c(v) (eq. 4).
    pub f_c: f32,
    /// Σ H_sopm over foreground objects in view.
    pub h_sopm: f32,
    /// Mean H_IoU (eq. 21) over foreground objects in view.
    pub h_iou: f32,
    /// Mean cos θ_sopm (eq. 12) over foreground objects in view.
    pub cos_theta_sopm: f32,
    /// Mean C_asso over foreground objects in view.
    pub c_asso: f32,
    /// N_cp (eq. 22).
    pub n_cp: f32,
    /// cos θ_c (eq. 23).
    pub cos_theta_c: f32,
    /// Foreground objects in view.
    pub objects_in_view: u16,
    /// 1 for the chosen candidate.
    pub chosen: u8,
    /// 1 if the candidate was dropped (unreachable / in collision) and not evaluated.
    pub dropped: u8,
}

/// Why a periodic cycle missed its deadline ([`DeadlineEvent::miss_cause`]): the largest share
/// of the time from its release to its end.
pub mod miss_cause {
    /// The cycle did not miss.
    pub const NONE: u8 = 0;
    /// The thread was running: the body's own work took the time.
    pub const EXECUTION: u8 = 1;
    /// The thread was runnable but another task (or non-preemptible kernel work) held the CPU.
    pub const RUN_QUEUE: u8 = 2;
    /// The thread was made runnable late: the timer wake-up itself came late (interrupts held
    /// off, or the hypervisor did not run the virtual CPU), with no run-queue wait to explain it.
    pub const LATE_WAKEUP: u8 = 3;
    /// The body was not runnable after waking: it slept or blocked (I/O, a lock, a page fault
    /// served from disk).
    pub const BLOCKED: u8 = 4;
    /// Missed, but the scheduler statistics needed to tell why are unavailable.
    pub const UNKNOWN: u8 = 5;

    /// A short name for `code` ("execution", "run-queue", "late-wakeup", "blocked", "unknown",
    /// "none"); codes out of range are "invalid".
    pub fn name(code: u8) -> &'static str {
        match code {
            NONE => "none",
            EXECUTION => "execution",
            RUN_QUEUE => "run-queue",
            LATE_WAKEUP => "late-wakeup",
            BLOCKED => "blocked",
            UNKNOWN => "unknown",
            _ => "invalid",
        }
    }
}

/// Kind of a [`PlannerDecision`].
pub mod decision_kind {
    /// Global best view round.
    pub const GBV: u8 = 0;
    /// Local best view cycle.
    pub const LBV: u8 = 1;
}

/// Planner lifecycle reported in [`PlannerDecision::state`].
pub mod planner_state {
    /// Exploring.
    pub const RUNNING: u8 = 0;
    /// Every cluster is complete (section 3.4).
    pub const TERMINATED: u8 = 1;
    /// No reachable candidate remains.
    pub const NO_CANDIDATES: u8 = 2;
}

/// A planner decision: the evaluated candidates of one GBV round or LBV cycle.
#[derive(Debug, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::PlannerDecision")
)]
pub struct PlannerDecision {
    /// Header.
    pub header: Header,
    /// `header.seq` of the map the decision was computed from.
    pub map_seq: u64,
    /// Evaluation time, ns.
    pub eval_ns: u64,
    /// Cluster being served, -1 if none.
    pub cluster_id: i32,
    /// Number of valid entries in `candidates`.
    pub count: u32,
    /// Total candidates evaluated (may exceed `count`; the best `count` are carried).
    pub evaluated: u32,
    /// One of [`decision_kind`].
    pub kind: u8,
    /// One of [`planner_state`].
    pub state: u8,
    /// Padding, always 0.
    pub reserved: [u8; 2],
    /// The candidates, first `count` valid.
    pub candidates: [Candidate; MAX_CANDIDATES],
}

impl PlannerDecision {
    /// The valid candidates.
    pub fn candidates(&self) -> &[Candidate] {
        &self.candidates[..(self.count as usize).min(MAX_CANDIDATES)]
    }
}

/// Rules: `count` ≤ [`MAX_CANDIDATES`]; `cluster_id` ≥ -1; `kind` one of [`decision_kind`],
/// `state` one of [`planner_state`]. Each of the first `count` candidates: `position` within
/// [`MAX_WORLD_COORD_M`], `yaw` within [`MAX_YAW_RAD`], `pitch` within [`MAX_PITCH_RAD`], every
/// term finite, `chosen` and `dropped` 0 or 1.
impl Validate for PlannerDecision {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "PlannerDecision",
        };
        c.count("count", self.count as usize, MAX_CANDIDATES)?;
        c.cluster("cluster_id", self.cluster_id)?;
        c.count("kind", self.kind as usize, decision_kind::LBV as usize)?;
        c.count(
            "state",
            self.state as usize,
            planner_state::NO_CANDIDATES as usize,
        )?;
        for (k, v) in self.candidates().iter().enumerate() {
            let terms = [
                v.yaw,
                v.pitch,
                v.value,
                v.f_a,
                v.f_c,
                v.h_sopm,
                v.h_iou,
                v.cos_theta_sopm,
                v.c_asso,
                v.n_cp,
                v.cos_theta_c,
            ];
            let f = |name: &'static str| Field::item("candidates", k, name);
            c.within(f("position"), &v.position, MAX_WORLD_COORD_M)?;
            c.finite(f("terms"), &terms)?;
            c.within(f("yaw"), &[v.yaw], MAX_YAW_RAD)?;
            c.within(f("pitch"), &[v.pitch], MAX_PITCH_RAD)?;
            c.flag(f("chosen"), v.chosen)?;
            c.flag(f("dropped"), v.dropped)?;
        }
        Ok(())
    }
}

/// How much of one ground-truth object a rendered frame shows (one entry of
/// [`FrameVisibility`]). Ground truth: for evaluation only.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::ObjectVisibility")
)]
pub struct ObjectVisibility {
    /// Index of the object in the scene.
    pub object: u32,
    /// Pixels of the frame's instance image that show the object.
    pub visible_px: u32,
    /// Pixels its unoccluded silhouette covers, clipped to the image.
    pub silhouette_px: u32,
    /// 1 if the unoccluded silhouette is cut by the image border.
    pub truncated: u8,
    /// Padding, always 0.
    pub reserved: [u8; 3],
    /// Bounding box `[u0, v0, u1, v1]` (pixels) of the unoccluded silhouette, clipped to the
    /// image: the true `b_i` of eq. (21).
    pub bbox: [f32; 4],
}

/// Per rendered frame, the visibility of every ground-truth foreground object in the camera's
/// view (`sim/visibility`, evaluation only; which objects count is the simulator's
/// `Sim::visibility`, the metric is `vpsom::eval::occlusion`).
#[derive(Debug, Clone, Copy, bytemuck::Zeroable)]
#[repr(C)]
#[cfg_attr(
    feature = "ipc",
    derive(ZeroCopySend),
    type_name("vpsom::FrameVisibility")
)]
pub struct FrameVisibility {
    /// Header.
    pub header: Header,
    /// `header.seq` of the depth frame rendered with it.
    pub frame_seq: u64,
    /// Valid entries of `items`.
    pub count: u32,
    /// Padding, always 0.
    pub reserved: u32,
    /// The objects in view.
    pub items: [ObjectVisibility; MAX_OBJECTS],
}

impl FrameVisibility {
    /// The valid entries.
    pub fn items(&self) -> &[ObjectVisibility] {
        &self.items[..(self.count as usize).min(MAX_OBJECTS)]
    }
}

/// Rules: `count` ≤ [`MAX_OBJECTS`]; each of the first `count` items: `bbox` finite,
/// `truncated` 0 or 1.
impl Validate for FrameVisibility {
    fn validate(&self) -> Result<(), ValidationError> {
        let c = Checker {
            message: "FrameVisibility",
        };
        c.count("count", self.count as usize, MAX_OBJECTS)?;
        for (k, v) in self.items().iter().enumerate() {
            c.finite(Field::item("items", k, "bbox"), &v.bbox)?;
            c.flag(Field::item("items", k, "truncated"), v.truncated)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boxed_zeroed;
    use std::mem::{align_of, size_of};

    /// Sizes are part of the inter-process contract: a change here breaks peers built from an
    /// older tree, so it must be deliberate.
    #[test]
    fn sizes_are_pinned() {
        assert_eq!(size_of::<Header>(), 24);
        assert_eq!(size_of::<Pose3>(), 28);
        assert_eq!(size_of::<Intrinsics>(), 24);
        assert_eq!(
            size_of::<DepthFrame>(),
            24 + 8 + 24 + 28 + 4 + 2 * MAX_PIXELS
        );
        assert_eq!(size_of::<Detection>(), 20);
        assert_eq!(
            size_of::<Detections>(),
            24 + 8 + 16 + 20 * MAX_DETECTIONS + MAX_PIXELS
        );
        assert_eq!(size_of::<RobotState>(), 104);
        assert_eq!(
            size_of::<MapObject>(),
            8 + 8 + 12 + 12 + 4 * 6 + 12 + 4 + 4 + 6 * MAX_SOPM_CELLS + 24 * MAX_OBJECT_POINTS + 4
        );
        assert_eq!(
            size_of::<ObjectMap>(),
            64 + MAX_OBJECTS * size_of::<MapObject>() + 24 * MAX_FRAME_RECEIPTS
        );
        assert_eq!(size_of::<FrameReceipt>(), 24);
        assert_eq!(size_of::<OccupancyGrid>(), 24 + 24 + MAX_GRID_CELLS);
        assert_eq!(size_of::<NavGoal>(), 56);
        assert_eq!(size_of::<NeckGoal>(), 80);
        assert_eq!(size_of::<DeadlineEvent>(), 24 + 56 + 8 + THREAD_NAME_LEN);
        assert_eq!(size_of::<Candidate>(), 60);
        assert_eq!(size_of::<PlannerDecision>(), 56 + 60 * MAX_CANDIDATES);
        assert_eq!(size_of::<ObjectVisibility>(), 32);
        assert_eq!(size_of::<FrameVisibility>(), 24 + 16 + 32 * MAX_OBJECTS);
        assert_eq!(align_of::<ObjectMap>(), 8);
    }

    #[cfg(feature = "ipc")]
    #[test]
    fn type_names_are_stable() {
        use iceoryx2::prelude::ZeroCopySend;
        // SAFETY: reading the derived type name has no preconditions beyond the layout contract.
        let names = unsafe {
            [
                <DepthFrame as ZeroCopySend>::type_name(),
                <Detections as ZeroCopySend>::type_name(),
                <RobotState as ZeroCopySend>::type_name(),
                <ObjectMap as ZeroCopySend>::type_name(),
                <NavGoal as ZeroCopySend>::type_name(),
                <NeckGoal as ZeroCopySend>::type_name(),
                <DeadlineEvent as ZeroCopySend>::type_name(),
            ]
        };
        assert_eq!(
            names,
            [
                "vpsom::DepthFrame",
                "vpsom::Detections",
                "vpsom::RobotState",
                "vpsom::ObjectMap",
                "vpsom::NavGoal",
                "vpsom::NeckGoal",
                "vpsom::DeadlineEvent"
            ]
        );
    }

    fn valid_frame() -> Box<DepthFrame> {
        let mut f = boxed_zeroed::<DepthFrame>();
        f.width = 4;
        f.height = 2;
        f.intrinsics = Intrinsics {
            fx: 2.0,
            fy: 2.0,
            cx: 2.0,
            cy: 1.0,
            min_range: 0.5,
            max_range: 5.0,
        };
        f.camera_pose = Pose3::IDENTITY;
        f
    }

    #[test]
    fn depth_frame_validation_rejects_nan_and_oversize() {
        let mut f = valid_frame();
        assert_eq!(f.validate(), Ok(()));
        assert_eq!(f.pixels().len(), 8);
        f.camera_pose.translation[1] = f32::NAN;
        let e = f.validate().unwrap_err();
        assert_eq!(e.field, "camera_pose");
        let mut f = valid_frame();
        f.width = 641;
        assert!(
            f.validate()
                .unwrap_err()
                .reason
                .contains("exceeds capacity 640")
        );
        let mut f = valid_frame();
        f.intrinsics.fx = f32::INFINITY;
        assert_eq!(f.validate().unwrap_err().field, "intrinsics");
        let mut f = valid_frame();
        f.camera_pose.rotation = [0.0; 4];
        assert!(f.validate().unwrap_err().reason.contains("norm"));
    }

    #[test]
    fn detections_validation_rejects_bad_counts_and_boxes() {
        let mut d = boxed_zeroed::<Detections>();
        d.width = 10;
        d.height = 10;
        d.count = 1;
        d.items[0] = Detection {
            class_id: 41,
            label: 1,
            score: 0.9,
            bbox: [1, 1, 5, 5],
            mask_pixels: 0,
        };
        assert_eq!(d.validate(), Ok(()));
        d.items[0].bbox = [6, 1, 5, 5];
        assert!(d.validate().unwrap_err().reason.contains("inverted"));
        d.items[0].bbox = [1, 1, 11, 5];
        assert_eq!(d.validate().unwrap_err().field, "items[0].bbox.x1");
        d.items[0].bbox = [1, 1, 5, 5];
        d.items[0].score = f32::NAN;
        assert_eq!(d.validate().unwrap_err().field, "items[0].score");
        d.items[0].score = 0.5;
        d.count = 65;
        assert_eq!(d.validate().unwrap_err().field, "count");
    }

    #[test]
    fn object_map_validation_names_the_object_and_field() {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.eps_sopm = 0.42;
        m.count = 2;
        m.objects[1].id = 1;
        m.objects[1].sopm_rows = 18;
        m.objects[1].sopm_cols = 18;
        m.objects[1].sopm_prob[..324].fill(0.5);
        m.objects[1].h_sopm = 1.0;
        assert_eq!(m.validate(), Ok(()));
        m.objects[1].center[2] = f32::NAN;
        assert_eq!(m.validate().unwrap_err().field, "objects[1].center");
        m.objects[1].center[2] = 0.0;
        m.objects[1].sopm_prob[7] = 1.5;
        assert!(m.validate().unwrap_err().reason.contains("cell 7"));
        m.objects[1].sopm_prob[7] = 0.5;
        m.objects[1].sopm_rows = 100;
        assert_eq!(m.validate().unwrap_err().field, "objects[1].sopm_cells");
        m.objects[1].sopm_rows = 18;
        m.count = 129;
        assert_eq!(m.validate().unwrap_err().field, "count");
    }

    #[test]
    fn object_map_copy_takes_the_used_part_and_clamps_the_count() {
        let mut src = boxed_zeroed::<ObjectMap>();
        src.header.seq = 9;
        src.last_frame_seq = 4;
        src.last_frame_stamp_ns = 77;
        src.eps_sopm = 0.3;
        src.count = 2;
        src.objects[1].h_sopm = 0.7;
        src.objects[2].h_sopm = 0.9;
        let mut dst = boxed_zeroed::<ObjectMap>();
        dst.count = 5;
        dst.objects[3].h_sopm = 0.5;
        dst.copy_from(&src);
        assert_eq!(dst.header.seq, 9);
        assert_eq!((dst.last_frame_seq, dst.last_frame_stamp_ns), (4, 77));
        assert_eq!(dst.eps_sopm, 0.3);
        assert_eq!(dst.count, 2);
        assert_eq!(dst.objects[1].h_sopm, 0.7);
        // Only the used objects are copied: the rest of `dst` is untouched.
        assert_eq!(dst.objects[2].h_sopm, 0.0);
        assert_eq!(dst.objects[3].h_sopm, 0.5);

        // A count past the capacity copies (and counts) at most MAX_OBJECTS objects.
        src.count = MAX_OBJECTS as u32 + 7;
        src.objects[MAX_OBJECTS - 1].h_sopm = 0.25;
        dst.copy_from(&src);
        assert_eq!(dst.count as usize, MAX_OBJECTS);
        assert_eq!(dst.objects[MAX_OBJECTS - 1].h_sopm, 0.25);
        assert_eq!(dst.objects().len(), MAX_OBJECTS);
    }

    #[test]
    fn small_messages_validate() {
        let mut s = RobotState {
            localization_ok: 1,
            ..Default::default()
        };
        assert_eq!(s.validate(), Ok(()));
        s.odom_cov[4] = f32::NEG_INFINITY;
        assert_eq!(s.validate().unwrap_err().field, "odom_cov");
        let s = RobotState {
            nav_status: 9,
            ..Default::default()
        };
        assert_eq!(s.validate().unwrap_err().field, "nav_status");

        let g = NavGoal {
            pose: [1.0, f32::NAN, 0.0],
            ..Default::default()
        };
        assert_eq!(g.validate().unwrap_err().field, "pose");
        let n = NeckGoal {
            yaw: f32::NAN,
            ..Default::default()
        };
        assert_eq!(n.validate().unwrap_err().field, "yaw");

        let mut e = DeadlineEvent {
            period_ns: 1_000_000,
            ..Default::default()
        };
        e.set_thread_name("lbv-éé-a-very-long-thread-name-that-does-not-fit");
        assert!(e.thread_name().len() <= THREAD_NAME_LEN);
        assert!(e.thread_name().starts_with("lbv-éé"));
        assert_eq!(e.validate(), Ok(()));
        e.miss_cause = miss_cause::UNKNOWN + 1;
        assert_eq!(e.validate().unwrap_err().field, "miss_cause");
        e.miss_cause = miss_cause::LATE_WAKEUP;
        e.period_ns = 0;
        assert_eq!(e.validate().unwrap_err().field, "period_ns");

        let mut grid = boxed_zeroed::<OccupancyGrid>();
        grid.resolution = 0.05;
        grid.width = 300;
        grid.height = 300;
        assert_eq!(grid.validate().unwrap_err().field, "cells");

        let mut d = boxed_zeroed::<PlannerDecision>();
        d.count = 1;
        d.candidates[0].n_cp = f32::NAN;
        assert_eq!(d.validate().unwrap_err().field, "candidates[0].terms");
    }
}
