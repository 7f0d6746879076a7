//! The `[mapper]` section of the configuration and its sub-sections (`[mapper.association]`,
//! `[mapper.extensions]`, `[mapper.existence]`, `[mapper.segmentation]`, `[mapper.sopm]`,
//! `[mapper.grid]`): one struct per table, defaults and range checks.

use super::sopm::{SopmParams, SopmShape};
use serde::Deserialize;
use settings::{Checker, ConfigError};
use shm_types::{MAX_GRID_CELLS, MAX_SOPM_CELLS};

/// `[mapper]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapperConfig {
    /// Minimum pixel stride when back-projecting a detection's mask.
    pub pixel_stride: u32,
    /// The stride grows so that about this many pixels at most are sampled per detection.
    pub max_points_per_detection: u32,
    /// Detections with fewer cleaned points are ignored.
    pub min_points: u32,
    /// Points closer than this to the floor are dropped, metres.
    pub floor_margin: f32,
    /// Half-thickness of a supporting plane, metres (bleed removal and background footprint).
    pub support_margin: f32,
    /// Smallest depth step that still connects neighbouring samples (outlier filter), metres.
    pub gap_min: f32,
    /// Depth-step allowance between neighbouring samples, in lateral sample spacings.
    pub gap_factor: f32,
    /// Voxel edge of a foreground object's merged cloud, metres.
    pub object_voxel: f32,
    /// Voxel edge of a background object's merged cloud, metres.
    pub background_voxel: f32,
    /// Voxel cap per object (later points only refine existing voxels).
    pub max_object_voxels: u32,
    /// Quantile used as robust min/max for cuboid extents.
    pub extent_quantile: f32,
    /// The same for background footprints (dense, flat tops with few outliers).
    pub background_extent_quantile: f32,
    /// Keep the previous yaw while its rectangle area is within this fraction of the optimum.
    pub yaw_keep_tolerance: f32,
    /// Lowest supporting-plane height of a background object, metres.
    pub min_support_height: f32,
    /// Objects with fewer associated detections are not published.
    pub min_observations: u32,
    /// Duplicate merge: two objects of compatible classes whose cuboids (background: footprints)
    /// have at least this IoU are one object.
    pub merge_iou: f32,
    /// Duplicate merge: ... or when this fraction of the smaller cuboid (footprint) lies inside
    /// the larger one and the smaller one's centre is inside it.
    pub merge_containment: f32,
    /// Duplicate merge: the containment test grows the larger cuboid by this margin (m), so a
    /// thin fragment split off an object's edge (mask bleed, grazing views) is still absorbed;
    /// keep it below the gap between neighbouring objects of one class (~5 cm on a desk).
    pub merge_margin: f32,
    /// Detections scoring below this are ignored.
    pub min_score: f32,
    /// Duplicate merge across classes (`[mapper.extensions] cross_class`): cuboid IoU ≥ this.
    pub cross_merge_iou: f32,
    /// `[mapper.extensions] co_detection`: two foreground objects detected together (each by
    /// its own detection of one frame) in at least this many frames are never merged.
    pub distinct_after: u32,
    /// `[mapper.extensions] co_detection`: ... and only when they were detected together in at
    /// least this share of the frames in which either was detected while their cuboids
    /// overlapped (0: `distinct_after` alone decides).
    pub co_detection_min_share: f32,
    /// `[mapper.extensions] co_detection`: two detections of one frame whose points' bounds
    /// overlap by more than this fraction of the smaller bounds' volume saw one object (a
    /// mislocalised duplicate box) and are not counted as detected together (1: every pair
    /// counts).
    pub co_detection_max_overlap: f32,
    /// Sparse fallback (`[mapper.extensions] sparse_fallback`).
    pub sparse: SparseConfig,
    /// Flat objects (`[mapper.extensions] flat_objects`).
    pub flat: FlatConfig,
    /// Objects with little valid depth placed from their box ([`super::standing`]).
    pub standing: super::standing::StandingConfig,
    /// Association.
    pub association: AssociationConfig,
    /// Switches of the additions beyond the paper.
    pub extensions: ExtensionsConfig,
    /// Existence probability of objects (spurious object removal).
    pub existence: ExistenceConfig,
    /// Segmentation of an object's points inside a box (box-only detections).
    pub segmentation: SegmentationConfig,
    /// Surface occupancy probability maps.
    pub sopm: SopmConfig,
    /// Exploration occupancy grid.
    pub grid: GridConfig,
    /// Frame-to-map registration of the camera pose ([`super::register`]).
    pub registration: RegistrationConfig,
    /// Floor levelling of the camera pose ([`super::level`]).
    pub level: super::level::LevelConfig,
    /// Online calibration of a constant camera-yaw offset ([`super::calib`]).
    pub yaw_calibration: super::calib::YawCalibrationConfig,
    /// Footprint sizes from per-view extents (`[mapper.extensions] view_extents`).
    pub view_extents: super::extent::ViewExtentConfig,
}

/// `[mapper.registration]` section: frame-to-map registration of the camera pose.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegistrationConfig {
    /// On / off.
    pub enabled: bool,
    /// ICP iterations per estimate.
    pub iterations: u32,
    /// Largest correspondence distance, metres.
    pub max_distance: f32,
    /// Fraction of the closest correspondences kept.
    pub trim: f32,
    /// A detection takes part only if this fraction of its points has a correspondence.
    pub min_overlap: f32,
    /// Fewest correspondences for an accepted correction.
    pub min_correspondences: u32,
    /// Objects associated fewer times are not registered against.
    pub min_object_observations: u32,
    /// Points per detection used (subsampled).
    pub max_points_per_detection: u32,
    /// Bound on the translation of one frame's correction, metres.
    pub max_translation: f32,
    /// Bound on the yaw of one frame's correction, degrees.
    pub max_yaw_deg: f32,
    /// Estimate the yaw (else translation only).
    pub estimate_yaw: bool,
    /// The yaw is estimated only if the correspondences spread at least this much (rms, m).
    pub yaw_min_spread: f32,
    /// Fraction of a frame's correction folded into the persistent offset.
    pub persist_gain: f32,
    /// Per-frame decay of the persistent offset.
    pub persist_decay: f32,
}

impl Default for RegistrationConfig {
    /// The `[mapper.registration]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.registration")
    }
}

impl Default for MapperConfig {
    /// The `[mapper]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper")
    }
}

/// `[mapper.association]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AssociationConfig {
    /// Significance level α: accept when p > α (eq. 19).
    pub alpha: f64,
    /// Points of each cloud entering the rank-sum test (deterministic even subsample).
    pub max_test_points: u32,
    /// Minimum visible reference points for the test; below, the overlap gate decides.
    pub min_reference: u32,
    /// Growth of the cuboid / bounding box for the 3D overlap gate, metres.
    pub gate_margin: f32,
    /// A reference point counts as visible unless it lies this far behind the observed depth, m.
    pub visibility_tolerance: f32,
    /// A reference point lying more than this in front of the observed depth is not seen by
    /// the current view either (it projects onto a surface behind it: a grazing side or
    /// another object), m.
    pub front_tolerance: f32,
    /// Growth of the detection box when selecting visible reference points, pixels.
    pub bbox_margin_px: f32,
    /// How C_asso (eq. 20) is computed.
    pub c_asso: CAssoMode,
    /// Weight of the newest test in the running rejection rate of [`CAssoMode::Acceptance`].
    pub c_asso_rate: f32,
    /// Groups of look-alike class names: an observation may join an object of another class of
    /// its group (class by score-weighted vote). `[]`: the label must match (the paper).
    pub lookalike: Vec<Vec<String>>,
}

/// How an object's association confidence C_asso (eq. 20) is computed
/// ([`super::association::acceptance_confidence`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CAssoMode {
    /// From the running rate of refused association tests (stable; the default).
    Acceptance,
    /// `1 − p` of the newest test, as eq. (20) is written.
    Newest,
}

/// `[mapper.extensions]` section: each addition beyond the paper, on (`true`) or off.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtensionsConfig {
    /// Merge duplicate objects after each frame.
    pub duplicate_merge: bool,
    /// A refused detection whose centroid lies inside a compatible object founds no new object.
    pub inside_reject: bool,
    /// Publish only objects seen `min_observations` times (off: from the first observation).
    pub min_observations: bool,
    /// Existence probability: objects that should have been seen but were not lose it and are
    /// deleted ([`ExistenceConfig`]).
    pub existence: bool,
    /// Box-only detections: remove supporting planes, pick the depth cluster fitting the box and
    /// the class size prior, reject outliers (off: the largest depth cluster of the box).
    pub box_segmentation: bool,
    /// Publish a foreground object only while it rests on a mapped supporting plane (it has a
    /// cluster): detections on walls, on table fronts and seen through glass float in the air.
    pub require_support: bool,
    /// Existence misses weighted by how detectable the object was in the frame (its visible
    /// projected size through the detector's recall-vs-size curve, truncation, occlusion), and
    /// objects hit from many viewpoints protected by a higher log-odds cap
    /// ([`ExistenceConfig::recall_area_px`], [`ExistenceConfig::confirmed_hits`]).
    pub detectability: bool,
    /// Box segmentation: a chosen depth cluster much longer than its class prior, with an empty
    /// gap across its long axis, is split there and the part that fits the box is kept
    /// (two same-class neighbours in one box, as after NMS): `[mapper.segmentation] split_factor`.
    pub split_oversize: bool,
    /// A confident box-only detection of a foreground object with fewer than `min_points`
    /// points (glass, dark or shiny surfaces, far small objects) is still used when its few points
    /// sit on a mapped table top and fit the class prior (`[mapper.sparse]`).
    pub sparse_fallback: bool,
    /// Label confusion beyond the look-alike groups: a detection of any foreground class whose
    /// box overlaps an object's projected box (`[mapper.existence] cross_class_iou`) means the
    /// object was seen (under another label), not missed; foreground objects of any classes
    /// whose cuboids overlap with IoU ≥ `[mapper] cross_merge_iou` are one object (class by vote).
    pub cross_class: bool,
    /// Label-agnostic association by place: a foreground detection of any class whose points'
    /// centroid lies inside an existing foreground object's cuboid is tested against it like a
    /// compatible one (joins it and votes for its class, or, refused, founds no object), and two
    /// foreground objects of any classes that overlap as duplicates do (IoU ≥ `[mapper] cross_merge_iou`,
    /// or the smaller one contained) are merged (class by score vote).
    pub cross_class_join: bool,
    /// With `cross_class_join`: an any-class join also needs the object's centre inside the
    /// points' bounding box, and an any-class merge each object's centre inside the other's
    /// cuboid (a neighbour inside a smeared cuboid is not swallowed).
    pub cross_class_mutual: bool,
    /// Box-only detections of flat classes (class prior height ≤ `[mapper.flat] max_height`:
    /// a phone lies within the support plane's band and its dark surface drops out) take their
    /// points from the box's rays on the mapped table top under them ([`FlatConfig`]).
    pub flat_objects: bool,
    /// Publish a foreground object's footprint size fused from its per-view extents (median
    /// over views that see each axis squarely) instead of the merged cloud's, which pose errors
    /// between views smear ([`super::extent`], `[mapper.view_extents]`).
    pub view_extents: bool,
    /// Two foreground objects detected together (each hit by its own detection of one frame)
    /// in `[mapper] distinct_after` frames are two objects: never merged as duplicates, however
    /// far their smeared cuboids grow into each other (same-class neighbours, two books 5 cm
    /// apart).
    pub co_detection: bool,
}

impl Default for ExtensionsConfig {
    /// The `[mapper.extensions]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.extensions")
    }
}

/// `[mapper.existence]` section: log-odds existence of each object.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExistenceConfig {
    /// Probability that an object in plain view is detected and associated (detector recall).
    pub p_detect: f32,
    /// Probability that a detection is associated with an object that does not exist.
    pub p_false: f32,
    /// An object whose log-odds fall below this is deleted.
    pub delete_below: f32,
    /// Log-odds are clamped to `±max_log_odds` (a long-seen object can still be removed).
    pub max_log_odds: f32,
    /// An object should be detected only if its projected box has at least this many pixels
    /// (at 640 × 480; scaled with the image area).
    pub min_box_px: f32,
    /// ... and at least this fraction of its projected box lies in the image.
    pub min_in_frame: f32,
    /// ... and its centre is not farther than this from the camera, metres.
    pub max_range: f32,
    /// ... and at least this fraction of its camera-facing sample points is not occluded.
    pub min_visible: f32,
    /// A sample point is occluded when the frame's depth is nearer than its expected depth by
    /// more than this, metres.
    pub occlusion_tolerance: f32,
    /// Evidence is taken once per viewpoint: an object's existence changes only when the camera
    /// moved at least this far (m) since its last change ...
    pub min_view_change: f32,
    /// ... and at least this much per metre of its distance to the object (a step of 0.2 m at
    /// 3 m turns the view by 4°: the detector's failure there is the same as before; 0: the
    /// absolute `min_view_change` alone) ...
    pub min_view_change_per_m: f32,
    /// ... or the direction from the object to the camera turned by at least this (degrees).
    pub min_view_angle_deg: f32,
    /// A missed object overlapped (box IoU) this much by a detection of a compatible class that
    /// was not associated with it is not counted as missed.
    pub overlap_iou: f32,
    /// ... nor one whose box overlaps it by this fraction of the smaller of the two boxes
    /// (intersection over the smaller area): the IoU of a thin object's box (a bottle 10 px
    /// wide at 320 × 240) with the projection of its slightly smeared cuboid falls below
    /// `overlap_iou` with a few pixels of box jitter (0 turns this rule off).
    pub overlap_min: f32,
    /// Detectability (`[mapper.extensions] detectability`): visible projected box areas
    /// (pixels at 640 × 480, ascending) at which the detector's recall is `recall`; linear in
    /// log area between them, clamped outside.
    pub recall_area_px: Vec<f32>,
    /// ... the detector's recall at those areas (the mapper's model of its own detector).
    pub recall: Vec<f32>,
    /// An object hit (detected and associated) from this many viewpoints is confirmed ...
    pub confirmed_hits: u32,
    /// ... and its log-odds are clamped to this instead of `max_log_odds`.
    pub confirmed_max_log_odds: f32,
    /// With `[mapper.extensions] cross_class`: a detection of any foreground class whose box
    /// overlaps the object's projected box this much (IoU) is not a miss.
    pub cross_class_iou: f32,
}

/// `[mapper.sparse]` section: confident detections with few points.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SparseConfig {
    /// Fewest points still used.
    pub min_points: u32,
    /// Lowest detector score.
    pub min_score: f32,
    /// The points' bottom lies at most this far above a mapped support plane under them, m.
    pub max_above_support: f32,
    /// The points' extent fits the class size prior at least this well ([`super::priors`]).
    pub min_prior_fit: f32,
}

/// `[mapper.flat]` section: flat objects lying on a mapped table top, located by their box.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlatConfig {
    /// Classes whose size prior is at most this high are flat, metres.
    pub max_height: f32,
    /// A box sample whose depth lies nearer than the table top along its ray by more than this
    /// shows something standing there (not the flat object), metres.
    pub stand_tolerance: f32,
    /// At least this fraction of the box's samples must hit the table top (dropout or the
    /// plane), else the box is not on a free table region.
    pub min_on_plane: f32,
    /// Box samples per detection at most.
    pub max_samples: u32,
}

impl Default for FlatConfig {
    /// The `[mapper.flat]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.flat")
    }
}

impl Default for SparseConfig {
    /// The `[mapper.sparse]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.sparse")
    }
}

impl Default for ExistenceConfig {
    /// The `[mapper.existence]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.existence")
    }
}

/// `[mapper.segmentation]` section: an object's points inside a box.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentationConfig {
    /// Height-histogram bin, metres.
    pub plane_bin: f32,
    /// A horizontal plane needs this fraction of the box's points (within ± one bin).
    pub plane_min_fraction: f32,
    /// ... and, to be a support (removed with what lies under it), this fraction above it.
    pub above_min_fraction: f32,
    /// Plausible heights `[low, high]` of a table top, metres.
    pub table_heights: [f32; 2],
    /// Points farther from the cluster's median (horizontally) than this multiple of the class
    /// prior's half diagonal are outliers.
    pub outlier_factor: f32,
    /// A cluster longer (horizontally, along its principal axis) than this multiple of its
    /// class prior's long side is split at an empty gap (`[mapper.extensions] split_oversize`).
    pub split_factor: f32,
    /// ... the gap: at least this long (m) without points across the long axis.
    pub split_gap: f32,
    /// Set from `[mapper.extensions] split_oversize` (not a key of this table).
    #[serde(skip)]
    pub split: bool,
}

impl Default for SegmentationConfig {
    /// The `[mapper.segmentation]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.segmentation")
    }
}

impl Default for AssociationConfig {
    /// The `[mapper.association]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.association")
    }
}

/// `[mapper.sopm]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SopmConfig {
    /// `"cylinder"`, `"hemisphere"` or `"sphere"`.
    pub shape: SopmShape,
    /// Height (cylinder) or elevation (hemisphere, sphere) cells.
    pub rows: u32,
    /// Angular cells.
    pub cols: u32,
    /// ε_n: minimum points in a column for a valid observation.
    pub eps_n: u32,
    /// Occupied inverse-sensor probability.
    pub p_occ: f32,
    /// Free inverse-sensor probability.
    pub p_free: f32,
    /// Prior occupancy probability.
    pub p_prior: f32,
    /// ε_sopm: a foreground object is complete when H_sopm < this.
    pub eps_sopm: f32,
    /// A cell is observed in a frame only if `normal · direction_to_camera > visible_cos`.
    pub visible_cos: f32,
}

impl Default for SopmConfig {
    /// The `[mapper.sopm]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.sopm")
    }
}

impl SopmConfig {
    /// The inverse-sensor-model parameters.
    pub fn params(&self) -> SopmParams {
        SopmParams {
            shape: self.shape,
            rows: self.rows as usize,
            cols: self.cols as usize,
            eps_n: self.eps_n,
            p_occ: self.p_occ,
            p_free: self.p_free,
            p_prior: self.p_prior,
            visible_cos: self.visible_cos,
        }
    }
}

impl MapperConfig {
    /// Range-check the `[mapper]` section and its tables.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("mapper");
        settings::ranges!(c, self, {
            pixel_stride: count(1, 32),
            max_points_per_detection: count(10, 1_000_000),
            min_points: count(3, 100_000),
            floor_margin: in_range(0.0, 1.0),
            support_margin: in_range(0.0, 0.2),
            gap_min: in_range(0.001, 1.0),
            gap_factor: in_range(0.0, 100.0),
            object_voxel: in_range(0.002, 0.2),
            background_voxel: in_range(0.002, 0.5),
            max_object_voxels: count(16, 10_000_000),
            [extent_quantile, background_extent_quantile]: in_range(0.0, 0.2),
            yaw_keep_tolerance: in_range(0.0, 1.0),
            min_support_height: in_range(0.0, 3.0),
            min_observations: count(1, 1000),
            merge_iou: in_range(0.0, 1.0),
            merge_margin: in_range(0.0, 0.5),
            [merge_containment, min_score]: in_range(0.0, 1.0),
            cross_merge_iou: in_range(0.01, 1.0),
            distinct_after: count(1, 1_000_000),
            co_detection_max_overlap: in_range(0.0, 1.0),
            co_detection_min_share: in_range(0.0, 1.0),
            [view_extents, flat, standing, sparse, existence, segmentation, association, sopm]: section,
            [registration, grid, level, yaw_calibration]: section,
        });
        Ok(())
    }
}

impl SparseConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            min_points: count(3, 100_000),
            [min_score, max_above_support, min_prior_fit]: in_range(0.0, 1.0),
        });
        Ok(())
    }
}

impl FlatConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            max_height: in_range(0.0, 0.2),
            stand_tolerance: in_range(0.001, 1.0),
            min_on_plane: in_range(0.0, 1.0),
            max_samples: count(16, 100_000),
        });
        Ok(())
    }
}

impl ExistenceConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            cross_class_iou: in_range(0.01, 1.0),
            p_detect: require(
                self.p_detect > self.p_false && self.p_detect < 1.0,
                "must be in (p_false, 1)",
            ),
            p_false: require(self.p_false > 0.0 && self.p_false < 1.0, "must be in (0, 1)"),
            max_log_odds: in_range(0.1, 50.0),
            delete_below: require(
                self.delete_below < 0.0 && self.delete_below > -self.max_log_odds,
                "must be in (-max_log_odds, 0)",
            ),
            min_box_px: in_range(0.0, 1e6),
            min_in_frame: in_range(0.0, 1.0),
            max_range: in_range(0.1, 50.0),
            [min_visible, occlusion_tolerance, overlap_iou]: in_range(0.0, 1.0),
            [min_view_change_per_m, overlap_min]: in_range(0.0, 1.0),
        });
        let (areas, recall) = (&self.recall_area_px, &self.recall);
        c.require(
            areas.len() == recall.len()
                && !recall.is_empty()
                && areas.windows(2).all(|w| w[1] > w[0])
                && areas.first().is_some_and(|a| *a > 0.0),
            &settings::key!(c, recall_area_px),
            format!("{areas:?}"),
            "must be ascending areas > 0, one per `recall` value",
        )?;
        c.require(
            recall.iter().all(|r| (0.0..1.0).contains(r)),
            &settings::key!(c, recall),
            format!("{recall:?}"),
            "must be probabilities in [0, 1)",
        )?;
        settings::ranges!(c, self, {
            confirmed_max_log_odds: require(
                self.confirmed_max_log_odds >= self.max_log_odds
                    && self.confirmed_max_log_odds <= 50.0,
                "must be in [max_log_odds, 50]",
            ),
            confirmed_hits: count(1, 100_000),
        });
        Ok(())
    }
}

impl SegmentationConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            plane_bin: in_range(0.002, 0.2),
            [plane_min_fraction, above_min_fraction]: in_range(0.0, 1.0),
        });
        let [low, high] = self.table_heights;
        c.require(
            low >= 0.0 && high > low,
            &settings::key!(c, table_heights),
            format!("{:?}", self.table_heights),
            "must be [low, high] with 0 <= low < high",
        )?;
        settings::ranges!(c, self, {
            outlier_factor: in_range(0.5, 100.0),
            split_factor: in_range(1.0, 100.0),
            split_gap: in_range(0.005, 1.0),
        });
        Ok(())
    }
}

impl AssociationConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        for (k, group) in self.lookalike.iter().enumerate() {
            for name in group {
                c.require(
                    shm_types::class_id(name).is_some(),
                    &format!("{}[{k}]", settings::key!(c, lookalike)),
                    name,
                    "must be COCO class names",
                )?;
            }
        }
        settings::ranges!(c, self, {
            alpha: in_range(0.0, 1.0),
            c_asso_rate: in_range(1e-4, 1.0),
            max_test_points: count(5, 100_000),
            min_reference: count(1, 100_000),
            gate_margin: in_range(0.0, 2.0),
            visibility_tolerance: in_range(0.0, 1.0),
            [front_tolerance, bbox_margin_px]: in_range(0.0, 100.0),
        });
        Ok(())
    }
}

impl SopmConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            rows: count(1, MAX_SOPM_CELLS),
            cols: count(3, MAX_SOPM_CELLS),
            rows: require(
                (self.rows * self.cols) as usize <= MAX_SOPM_CELLS,
                &format!("rows × cols must be ≤ {MAX_SOPM_CELLS}"),
            ),
            eps_n: count(1, 100_000),
            p_occ: require(self.p_occ > 0.5 && self.p_occ < 1.0, "must be in (0.5, 1)"),
            p_free: require(self.p_free > 0.0 && self.p_free < 0.5, "must be in (0, 0.5)"),
            p_prior: require(self.p_prior > 0.0 && self.p_prior < 1.0, "must be in (0, 1)"),
            eps_sopm: in_range(0.0, 1.0),
            visible_cos: in_range(-1.0, 1.0),
        });
        Ok(())
    }
}

impl RegistrationConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            iterations: count(1, 50),
            max_distance: in_range(0.002, 0.5),
            trim: in_range(0.1, 1.0),
            min_overlap: in_range(0.0, 1.0),
            min_correspondences: count(3, 1_000_000),
            min_object_observations: count(1, 1000),
            max_points_per_detection: count(10, 1_000_000),
            max_translation: in_range(0.0, 1.0),
            max_yaw_deg: in_range(0.0, 20.0),
            yaw_min_spread: in_range(0.0, 10.0),
            [persist_gain, persist_decay]: in_range(0.0, 1.0),
        });
        Ok(())
    }
}

/// `[mapper.grid]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    /// Build the grid at all.
    pub enabled: bool,
    /// World `[x, y]` of the corner of cell (0, 0), metres.
    pub origin: [f32; 2],
    /// Cell edge, metres.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// Lowest obstacle height, metres.
    pub min_z: f32,
    /// Highest obstacle height, metres.
    pub max_z: f32,
    /// Pixel stride of the rays.
    pub stride: u32,
    /// Longest horizontal ray, metres.
    pub max_range: f32,
}

impl Default for GridConfig {
    /// The `[mapper.grid]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.grid")
    }
}

impl GridConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        for (i, &v) in self.origin.iter().enumerate() {
            let key = format!("{}[{i}]", settings::key!(c, origin));
            c.in_range(&key, v.into(), -1e4, 1e4)?;
        }
        settings::ranges!(c, self, {
            resolution: in_range(0.01, 1.0),
            [width, height]: count(1, MAX_GRID_CELLS),
            height: require(
                self.width as usize * self.height as usize <= MAX_GRID_CELLS,
                &format!("width × height must be ≤ {MAX_GRID_CELLS}"),
            ),
            min_z: in_range(0.0, 5.0),
            max_z: require(
                self.max_z > self.min_z && self.max_z <= 10.0,
                &format!("must be > {} and ≤ 10", settings::key!(c, min_z)),
            ),
            stride: count(1, 64),
            max_range: in_range(0.1, 50.0),
        });
        Ok(())
    }
}
