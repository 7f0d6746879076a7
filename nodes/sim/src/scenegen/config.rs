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
        crate::DEFAULTS.section("scenegen")
    }
}

impl SceneGenConfig {
    /// Range-check the `[scenegen]` section.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("scenegen");
        settings::ranges!(c, self, {
            room_min_m: in_range(3.0, 12.0),
            room_max_m: require(
                self.room_max_m >= self.room_min_m && self.room_max_m <= 12.0,
                &format!(
                    "must be ≥ {} and ≤ 12 (the navigation grid holds 256 × 256 cells)",
                    settings::key!(c, room_min_m)
                ),
            ),
            clusters_min: count(1, 8),
            clusters_max: require(
                self.clusters_max >= self.clusters_min && self.clusters_max <= 8,
                &format!("must be ≥ {} and ≤ 8", settings::key!(c, clusters_min)),
            ),
            objects_min: count(1, 60),
            objects_max: require(
                self.objects_max >= self.objects_min && self.objects_max <= 60,
                &format!("must be ≥ {} and ≤ 60", settings::key!(c, objects_min)),
            ),
            partition_probability: in_range(0.0, 1.0),
            partition_min_side_m: in_range(3.0, 12.0),
            passage_m: in_range(0.6, 3.0),
            start_clearance_m: in_range(0.0, 2.0),
            start_faces_cluster: in_range(0.0, 1.0),
            start_min_features: count(0, 100_000),
            view_min_m: in_range(0.3, 5.0),
            view_max_m: require(
                self.view_max_m > self.view_min_m && self.view_max_m <= 8.0,
                &format!("must be > {} and ≤ 8", settings::key!(c, view_min_m)),
            ),
            min_visible_points: count(1, 10),
            max_attempts: count(1, 10_000),
        });
        Ok(())
    }
}
