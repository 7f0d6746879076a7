//! The `[sim]`, `[detector]` and `[robot]` sections of the configuration, and [`SimSetup`]: the
//! sections the simulator reads.

use crate::scenegen::SceneGenConfig;
use geom::CameraConfig;
use serde::Deserialize;
use settings::{Checker, ConfigError};

/// The configuration sections the simulator reads: `[camera]`, `[sim]`, `[detector]`, `[robot]`
/// and `[scenegen]`. The app's whole configuration converts into it (`From<&Config>`), so
/// [`crate::Sim::new`] and the scene generator take either.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimSetup {
    /// Depth camera and mount.
    pub camera: CameraConfig,
    /// World simulation (noise, seed).
    pub sim: SimConfig,
    /// Simulated detector.
    pub detector: DetectorConfig,
    /// Simulated base and neck.
    pub robot: RobotConfig,
    /// Scene generator.
    pub scenegen: SceneGenConfig,
}

impl From<&SimSetup> for SimSetup {
    fn from(s: &SimSetup) -> Self {
        s.clone()
    }
}

/// `[sim]` section: the world and the depth sensor's noise model.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Scene to load: a built-in scene name (`paper-scene-1`..`3`) or a path to a scene file.
    pub scene: String,
    /// Depth noise σ(z) = `noise_a` + `noise_b`·z² (metres, z in metres; Kinect-like).
    pub noise_a: f32,
    /// Quadratic coefficient of the depth noise, 1/m.
    pub noise_b: f32,
    /// A pixel is invalid (0) when the angle between its ray and the surface normal exceeds this, degrees.
    pub grazing_deg: f32,
    /// Probability that any valid pixel drops out (0) at random.
    pub dropout: f32,
    /// Depth artefacts (`sim/artefacts.rs`): neighbouring true depths that differ by at least
    /// this make a depth edge, metres.
    pub edge_min_jump_m: f32,
    /// Pixels on each side of a depth edge that its artefacts reach.
    pub edge_width_px: u32,
    /// Probability that a valid edge pixel becomes a mixed ("flying") pixel, its depth between
    /// the two surfaces'.
    pub edge_mixed: f32,
    /// Probability that a valid edge pixel is removed (0), as by the driver's edge filter.
    pub edge_invalid: f32,
    /// Probability that a valid pixel of a `material = "glass"` object is invalid (0).
    pub glass_invalid: f32,
    /// Probability that a valid pixel of a glass object reads the surface behind it.
    pub glass_through: f32,
    /// Probability that a valid pixel of a `material = "dark"` object is invalid (0).
    pub dark_invalid: f32,
    /// Probability that a valid pixel of a `material = "specular"` object is invalid (0).
    pub specular_invalid: f32,
    /// Localization features per m² on object surfaces (textured).
    pub feature_density_objects: f32,
    /// Localization features per m² on the room walls (mostly plain).
    pub feature_density_walls: f32,
    /// Visual tracking fails when fewer features than this are seen in two consecutive frames.
    pub min_tracked_features: u32,
    /// Tracking fails (motion blur) when the camera turns faster than this, degrees per second.
    pub max_track_rate_deg_s: f32,
    /// A lost-tracking episode counts as a localization failure once it has lasted longer than this, s.
    pub failure_min_duration_s: f32,
    /// ... and the base has driven farther than this during it, metres (paper: 1 s and 0.3 m).
    pub failure_min_distance_m: f32,
}

impl Default for SimConfig {
    /// The `[sim]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("sim")
    }
}

impl SimConfig {
    /// Range-check the `[sim]` section.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("sim");
        let (scene, empty) = (settings::key!(c, scene), "\"\"");
        c.require(!self.scene.is_empty(), &scene, empty, "must name a scene")?;
        settings::ranges!(c, self, {
            [noise_a, noise_b]: in_range(0.0, 0.5),
            grazing_deg: in_range(1.0, 90.0),
            dropout: in_range(0.0, 1.0),
        });
        self.validate_artefacts(c)?;
        settings::ranges!(c, self, {
            [feature_density_objects, feature_density_walls]: in_range(0.0, 10_000.0),
            min_tracked_features: count(0, 100_000),
            max_track_rate_deg_s: positive,
            failure_min_duration_s: in_range(0.0, 3600.0),
            failure_min_distance_m: in_range(0.0, 1000.0),
        });
        Ok(())
    }
}

impl SimConfig {
    /// Range-check the depth-artefact keys (each probability in [0, 1]; the outcomes of one
    /// pixel sum to at most 1); `c` is at `[sim]`.
    fn validate_artefacts(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            edge_min_jump_m: in_range(0.001, 10.0),
            edge_width_px: count(1, 8),
            [edge_mixed, edge_invalid, glass_invalid, glass_through]: in_range(0.0, 1.0),
            [dark_invalid, specular_invalid]: in_range(0.0, 1.0),
            edge_invalid: require(
                self.edge_mixed + self.edge_invalid <= 1.0,
                "edge_mixed + edge_invalid must be at most 1",
            ),
            glass_through: require(
                self.glass_invalid + self.glass_through <= 1.0,
                "glass_invalid + glass_through must be at most 1",
            ),
        });
        Ok(())
    }
}

/// `[detector]` section: the simulated object detector (a YOLO stand-in). Pixel counts are
/// at 640×480 and scale with the image area.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorConfig {
    /// `"boxes"` (class, score, box: a YOLO-class detector) or `"masks"` (plus instance masks).
    pub mode: String,
    /// Objects with fewer visible pixels are never detected.
    pub min_pixels: u32,
    /// Miss probability of a large, fully visible object.
    pub miss_rate: f32,
    /// Extra miss probability for a small object, scaled by `1 − pixels / small_pixels`.
    pub miss_small: f32,
    /// Objects with fewer visible pixels than this count as small.
    pub small_pixels: u32,
    /// Extra miss probability for an occluded object, scaled by its hidden fraction.
    pub miss_occluded: f32,
    /// Extra miss probability for an object cut by the image border.
    pub miss_truncated: f32,
    /// Mean score of a large, fully visible detection.
    pub score_mean: f32,
    /// Standard deviation of the score.
    pub score_std: f32,
    /// Score lost by a fully hidden object, scaled by the hidden fraction.
    pub score_occluded: f32,
    /// Score lost by an object cut by the image border.
    pub score_truncated: f32,
    /// Score lost by a tiny object, scaled by `1 − pixels / small_pixels`.
    pub score_small: f32,
    /// Confidence threshold: detections scoring below it are not reported.
    pub score_min: f32,
    /// Box edge jitter σ, pixels.
    pub box_jitter_px: f32,
    /// Box edge jitter σ as a fraction of the box size (width for x edges, height for y).
    pub box_jitter_frac: f32,
    /// Jitter multiplier for objects cut by the image border.
    pub truncated_jitter: f32,
    /// `"masks"` mode: masks grow by a random 0..=`mask_bleed_px` pixels onto neighbours.
    pub mask_bleed_px: u32,
    /// Same-class boxes overlapping by more than this IoU come out as one (non-maximum
    /// suppression); 1 disables merging.
    pub nms_iou: f32,
    /// Probability that the merged box is the union of both boxes (else the higher-score box).
    pub merge_union: f32,
    /// Probability that an object seen from a viewing-direction/distance bin gets another class
    /// of its look-alike group (the same draw for the whole bin).
    pub confusion_rate: f32,
    /// Probability that an object seen from a view bin gets the class of another, dissimilar
    /// object of the scene (Hoiem et al.'s "other" confusion; drawn after `confusion_rate`).
    pub other_rate: f32,
    /// Width of a viewing-direction bin for label confusion, degrees.
    pub confusion_bin_deg: f32,
    /// Width of a viewing-distance bin for label confusion, metres.
    pub confusion_bin_m: f32,
    /// Groups of look-alike COCO classes (an object's class uses the first group holding it).
    pub confusion_groups: Vec<Vec<String>>,
    /// Mean number of false positives per frame (Poisson; a frame without a place for one has
    /// fewer).
    pub fp_per_frame: f32,
    /// Mislocalised duplicates per reported object: a second box of the same class on part of
    /// the object (IoU with its true box in [0.1, 0.5)), scored like a true positive.
    pub dup_per_tp: f32,
    /// Confident background false positives per reported object: placed like the
    /// `fp_per_frame` ones, scored like a true positive of a large, fully visible object.
    pub fp_confident_per_tp: f32,
    /// Lowest false-positive score (the `fp_per_frame` ones).
    pub fp_score_min: f32,
    /// Highest false-positive score.
    pub fp_score_max: f32,
    /// COCO classes of false positives on walls.
    pub fp_wall_classes: Vec<String>,
    /// False positives on parts of objects: each entry is `[object class, detected class...]`.
    pub fp_on_objects: Vec<Vec<String>>,
}

impl Default for DetectorConfig {
    /// The `[detector]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("detector")
    }
}

impl DetectorConfig {
    /// Whether the detector outputs instance masks (`mode = "masks"`).
    pub fn masks(&self) -> bool {
        self.mode == "masks"
    }

    /// Range-check the `[detector]` section.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("detector");
        c.require(
            self.mode == "boxes" || self.mode == "masks",
            &settings::key!(c, mode),
            format!("{:?}", self.mode),
            "must be \"boxes\" or \"masks\"",
        )?;
        let px = shm_types::MAX_PIXELS;
        settings::ranges!(c, self, {
            [min_pixels, small_pixels]: count(1, px),
            [miss_rate, miss_small, miss_occluded, miss_truncated]: in_range(0.0, 1.0),
            [score_mean, score_std, score_occluded, score_truncated]: in_range(0.0, 1.0),
            [score_small, score_min, box_jitter_frac, nms_iou]: in_range(0.0, 1.0),
            [merge_union, confusion_rate, other_rate, fp_score_min]: in_range(0.0, 1.0),
            [dup_per_tp, fp_confident_per_tp]: in_range(0.0, 1.0),
            box_jitter_px: in_range(0.0, 100.0),
            truncated_jitter: in_range(1.0, 10.0),
            mask_bleed_px: count(0, 16),
            confusion_bin_deg: in_range(1.0, 360.0),
            confusion_bin_m: in_range(0.01, 100.0),
            fp_per_frame: in_range(0.0, 10.0),
            fp_score_max: require(
                self.fp_score_max >= self.fp_score_min && self.fp_score_max <= 1.0,
                &format!("must be ≥ {} and ≤ 1", settings::key!(c, fp_score_min)),
            ),
        });
        let coco = |key: String, name: &String| {
            c.require(
                shm_types::class_id(name).is_some(),
                &key,
                format!("{name:?}"),
                "must be a COCO class name",
            )
        };
        let groups = settings::key!(c, confusion_groups);
        for (g, group) in self.confusion_groups.iter().enumerate() {
            for (k, name) in group.iter().enumerate() {
                coco(format!("{groups}[{g}][{k}]"), name)?;
            }
        }
        let walls = settings::key!(c, fp_wall_classes);
        for (k, name) in self.fp_wall_classes.iter().enumerate() {
            coco(format!("{walls}[{k}]"), name)?;
        }
        let on_objects = settings::key!(c, fp_on_objects);
        for (g, entry) in self.fp_on_objects.iter().enumerate() {
            c.require(
                entry.len() >= 2,
                &format!("{on_objects}[{g}]"),
                format!("{entry:?}"),
                "must be [object class, detected class, ...]",
            )?;
            for (k, name) in entry.iter().enumerate() {
                coco(format!("{on_objects}[{g}][{k}]"), name)?;
            }
        }
        Ok(())
    }
}

/// `[robot]` section: base, neck, odometry and the navigation map.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// Base radius (obstacles are inflated by it), metres.
    pub radius: f32,
    /// Maximum linear speed, m/s.
    pub max_speed: f32,
    /// Maximum base turn rate, degrees per second.
    pub max_turn_rate_deg_s: f32,
    /// Maximum neck slew rate, degrees per second (the neck turns 360°).
    pub neck_rate_deg_s: f32,
    /// Lowest camera pitch the neck accepts (positive = down), degrees.
    pub pitch_min_deg: f32,
    /// Highest camera pitch the neck accepts; equal to `pitch_min_deg` = fixed pitch (paper).
    pub pitch_max_deg: f32,
    /// Position tolerance for reaching a goal, metres.
    pub goal_tolerance_m: f32,
    /// Yaw tolerance for reaching a goal, degrees.
    pub yaw_tolerance_deg: f32,
    /// Cell size of the navigation grid, metres.
    pub grid_resolution: f32,
    /// Odometry translation noise σ per √metre driven (fraction of distance).
    pub odom_trans_noise: f32,
    /// Odometry yaw noise σ per √radian turned.
    pub odom_rot_noise: f32,
    /// Odometry yaw noise σ per √metre driven, radians.
    pub odom_rot_per_m: f32,
    /// Odometry noise multiplier while visual localization is lost.
    pub lost_drift_factor: f32,
    /// Constant neck-encoder offset σ (drawn once per seed), degrees.
    pub neck_encoder_bias_deg: f32,
    /// Neck-encoder noise σ per reading, degrees.
    pub neck_encoder_noise_deg: f32,
    /// A frame's `camera_pose` is the estimate from this long before the image, milliseconds.
    pub pose_delay_ms: f32,
    /// Integration substep, seconds.
    pub substep_s: f32,
    /// `[robot.slam]`: the visual-SLAM estimate (keyframe corrections, map drift, loops).
    pub slam: SlamConfig,
}

impl Default for RobotConfig {
    /// The `[robot]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("robot")
    }
}

impl RobotConfig {
    /// Range-check the `[robot]` section and `[robot.slam]`.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("robot");
        settings::ranges!(c, self, {
            radius: in_range(0.01, 2.0),
            max_speed: in_range(0.01, 10.0),
            max_turn_rate_deg_s: in_range(1.0, 1000.0),
            neck_rate_deg_s: in_range(1.0, 2000.0),
            pitch_min_deg: in_range(-89.0, 89.0),
            pitch_max_deg: require(
                self.pitch_max_deg >= self.pitch_min_deg && self.pitch_max_deg <= 89.0,
                &format!("must be ≥ {} and ≤ 89", settings::key!(c, pitch_min_deg)),
            ),
            goal_tolerance_m: in_range(0.001, 1.0),
            yaw_tolerance_deg: in_range(0.01, 45.0),
            grid_resolution: in_range(0.01, 1.0),
            [odom_trans_noise, odom_rot_noise, odom_rot_per_m]: in_range(0.0, 1.0),
            lost_drift_factor: in_range(1.0, 100.0),
            [neck_encoder_bias_deg, neck_encoder_noise_deg]: in_range(0.0, 10.0),
            pose_delay_ms: in_range(0.0, super::slam::MAX_DELAY_MS),
            substep_s: in_range(0.0001, 0.1),
            slam: section,
        });
        Ok(())
    }
}

/// `[robot.slam]` section: the visual-SLAM pose estimate (see `sim::slam`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlamConfig {
    /// A keyframe (and its correction) after the camera moved this far from the reference keyframe, m.
    pub keyframe_distance_m: f32,
    /// ... or turned this far, degrees.
    pub keyframe_angle_deg: f32,
    /// σ per axis of the position residual a keyframe correction leaves, metres.
    pub residual_xy_m: f32,
    /// σ of the yaw residual a keyframe correction leaves, degrees.
    pub residual_yaw_deg: f32,
    /// Map drift: σ per axis of the map's position error per √m of newly mapped camera travel, m.
    pub map_drift_xy_m: f32,
    /// Map drift: σ of the map's yaw error per √m of newly mapped camera travel, degrees.
    pub map_drift_yaw_deg: f32,
    /// Camera rotation counts as this many metres of travel per radian for the map drift.
    pub turn_equiv_m_per_rad: f32,
    /// A keyframe is reused (no new map) when the camera is within this distance of it, m ...
    pub reuse_radius_m: f32,
    /// ... and this angle of its viewing direction, degrees.
    pub reuse_angle_deg: f32,
    /// Reusing a keyframe made at least this much base travel earlier is a loop closure, m.
    pub loop_min_travel_m: f32,
    /// Keyframes kept (storage preallocated; later places are not stored).
    pub max_keyframes: u32,
    /// The error has its out-of-plane part (`[z, roll, pitch]`); `false`: planar error only
    /// (a switch for the pose ablation, not a rate).
    pub out_of_plane: bool,
}

impl Default for SlamConfig {
    /// The `[robot.slam]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("robot.slam")
    }
}

impl SlamConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            keyframe_distance_m: in_range(0.0, 10.0),
            keyframe_angle_deg: in_range(0.0, 180.0),
            residual_xy_m: in_range(0.0, 1.0),
            residual_yaw_deg: in_range(0.0, 45.0),
            map_drift_xy_m: in_range(0.0, 1.0),
            map_drift_yaw_deg: in_range(0.0, 45.0),
            [turn_equiv_m_per_rad, reuse_radius_m]: in_range(0.0, 10.0),
            reuse_angle_deg: in_range(0.0, 180.0),
            loop_min_travel_m: in_range(0.0, 1000.0),
            [keyframe_distance_m, keyframe_angle_deg]: positive,
            max_keyframes: count(1, 100_000),
        });
        Ok(())
    }
}
