//! The `[scenegen]` section of the configuration: ranges and checks of the scene generator.

use serde::Deserialize;
use settings::{Checker, ConfigError};

/// `[scenegen]`: what `vpsom scene gen` and `vpsom bench --generated` generate.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneGenConfig {
    /// Shortest room side, metres.
    pub room_min_m: f32,
    /// Longest room side, metres.
    pub room_max_m: f32,
    /// Fewest support clusters (furniture carrying foreground objects).
    pub clusters_min: usize,
    /// Most support clusters.
    pub clusters_max: usize,
    /// Fewest foreground objects.
    pub objects_min: usize,
    /// Most foreground objects.
    pub objects_max: usize,
    /// Probability of a partition wall in a room whose sides are both at least
    /// `partition_min_side_m`.
    pub partition_probability: f32,
    /// Rooms need both sides at least this long for a partition, metres.
    pub partition_min_side_m: f32,
    /// Free gap kept between pieces of furniture, partitions and walls (where furniture is not
    /// against the wall), metres.
    pub passage_m: f32,
    /// Free radius around the start pose beyond the robot radius, metres.
    pub start_clearance_m: f32,
    /// Probability that the start faces the first cluster (else a random direction).
    pub start_faces_cluster: f32,
    /// Localization features the start view must see (the sim's visual-SLAM model tracks
    /// nothing below `sim.min_tracked_features`).
    pub start_min_features: u32,
    /// Viewing poses for the visibility check lie this far from an object at least, metres.
    pub view_min_m: f32,
    /// ... and at most, metres.
    pub view_max_m: f32,
    /// A pose sees an object when at least this many of its 10 sample points are in the
    /// camera's frustum and range and reached by an unobstructed ray.
    pub min_visible_points: usize,
    /// Layouts tried per scene before giving up.
    pub max_attempts: u32,
}

impl Default for SceneGenConfig {
    /// The `[scenegen]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        settings::DEFAULTS.section("scenegen")
    }
}

impl SceneGenConfig {
    /// Range-check.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        c.in_range("scenegen.room_min_m", self.room_min_m.into(), 3.0, 12.0)?;
        c.require(
            self.room_max_m >= self.room_min_m && self.room_max_m <= 12.0,
            "scenegen.room_max_m",
            self.room_max_m,
            "must be ≥ scenegen.room_min_m and ≤ 12 (the navigation grid holds 256 × 256 cells)",
        )?;
        c.count("scenegen.clusters_min", self.clusters_min, 1, 8)?;
        c.require(
            self.clusters_max >= self.clusters_min && self.clusters_max <= 8,
            "scenegen.clusters_max",
            self.clusters_max,
            "must be ≥ scenegen.clusters_min and ≤ 8",
        )?;
        c.count("scenegen.objects_min", self.objects_min, 1, 60)?;
        c.require(
            self.objects_max >= self.objects_min && self.objects_max <= 60,
            "scenegen.objects_max",
            self.objects_max,
            "must be ≥ scenegen.objects_min and ≤ 60",
        )?;
        c.in_range(
            "scenegen.partition_probability",
            self.partition_probability.into(),
            0.0,
            1.0,
        )?;
        c.in_range(
            "scenegen.partition_min_side_m",
            self.partition_min_side_m.into(),
            3.0,
            12.0,
        )?;
        c.in_range("scenegen.passage_m", self.passage_m.into(), 0.6, 3.0)?;
        c.in_range(
            "scenegen.start_clearance_m",
            self.start_clearance_m.into(),
            0.0,
            2.0,
        )?;
        c.in_range(
            "scenegen.start_faces_cluster",
            self.start_faces_cluster.into(),
            0.0,
            1.0,
        )?;
        c.count(
            "scenegen.start_min_features",
            self.start_min_features as usize,
            0,
            100_000,
        )?;
        c.in_range("scenegen.view_min_m", self.view_min_m.into(), 0.3, 5.0)?;
        c.require(
            self.view_max_m > self.view_min_m && self.view_max_m <= 8.0,
            "scenegen.view_max_m",
            self.view_max_m,
            "must be > scenegen.view_min_m and ≤ 8",
        )?;
        c.count(
            "scenegen.min_visible_points",
            self.min_visible_points,
            1,
            10,
        )?;
        c.count(
            "scenegen.max_attempts",
            self.max_attempts as usize,
            1,
            10_000,
        )
    }
}
