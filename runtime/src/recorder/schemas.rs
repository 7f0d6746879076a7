//! Topic names and the schema of every channel: Foxglove's protobuf schemas
//! (`foxglove::messages::*`) and the ones `foxglove::Encode` derives for [`super::messages`].
//! Every channel's message encoding is `protobuf`, its schema a `FileDescriptorSet`.

use super::messages as own;
use foxglove::messages as fg;
use foxglove::{Encode, Schema};

/// Topic names.
pub mod topic {
    /// Depth image (`foxglove.RawImage`, `16UC1`).
    pub const DEPTH: &str = "/camera/depth";
    /// Calibration of the depth image (`foxglove.CameraCalibration`).
    pub const CALIBRATION: &str = "/camera/calibration";
    /// The rest of each depth frame: header, intrinsics, camera pose.
    pub const DEPTH_META: &str = "/camera/depth/meta";
    /// Detection boxes drawn on the depth image (`foxglove.ImageAnnotations`).
    pub const ANNOTATIONS: &str = "/camera/detections";
    /// The detections, every field (for replay).
    pub const DETECTIONS: &str = "/detections";
    /// The estimated robot state, every field (for replay).
    pub const STATE: &str = "/robot/state";
    /// The navigation grid the planner plans on (for replay).
    pub const NAV_GRID: &str = "/nav/grid";
    /// Estimated transforms world→base→neck→camera.
    pub const TF: &str = "/tf";
    /// Estimated base trajectory.
    pub const TRAJECTORY: &str = "/trajectory";
    /// True transform world→base_true.
    pub const TRUTH_TF: &str = "/truth/tf";
    /// True base trajectory.
    pub const TRUTH_TRAJECTORY: &str = "/truth/trajectory";
    /// Ground-truth cuboids.
    pub const TRUTH_OBJECTS: &str = "/truth/objects";
    /// Estimated cuboids.
    pub const MAP: &str = "/map/objects";
    /// What each map consumed (frames, counts).
    pub const MAP_META: &str = "/map/meta";
    /// GBV candidate frusta and chosen view.
    pub const GBV: &str = "/planner/gbv";
    /// LBV candidate frusta and chosen view.
    pub const LBV: &str = "/planner/lbv";
    /// Every candidate with every F(v) term.
    pub const DECISIONS: &str = "/planner/decisions";
    /// Navigation goals.
    pub const NAV_GOAL: &str = "/planner/nav_goal";
    /// Neck goals.
    pub const NECK_GOAL: &str = "/planner/neck_goal";
    /// Deadline-monitor events.
    pub const DEADLINE: &str = "/runtime/deadline";
    /// Node heartbeats with their per-input counts.
    pub const HEALTH: &str = "/runtime/health";
    /// Per-node latency summaries.
    pub const LATENCY: &str = "/runtime/latency";
    /// Log lines.
    pub const LOG: &str = "/log";
    /// Final metrics.
    pub const METRICS: &str = "/metrics";
    /// The recorder's own counters.
    pub const STATS: &str = "/recorder/stats";
}

/// Name of the MCAP Metadata record with the final drop counts.
pub const STATS_METADATA: &str = "recorder_stats";
/// Name of the MCAP Metadata record with the session facts.
pub const SESSION_METADATA: &str = "session";

/// One channel of a trace.
#[derive(Debug, Clone)]
pub struct ChannelDef {
    /// Topic.
    pub topic: &'static str,
    /// Schema (name, encoding `protobuf`, `FileDescriptorSet`).
    pub schema: Schema,
    /// Message encoding (`protobuf`).
    pub encoding: String,
}

fn def<T: Encode>(topic: &'static str) -> ChannelDef {
    ChannelDef {
        topic,
        // Every type here has a schema (the well-known ones and the derived ones).
        schema: T::get_schema().unwrap_or_else(|| Schema::new("", "", Vec::new())),
        encoding: T::get_message_encoding(),
    }
}

/// Every channel, in the order they are created.
pub fn channels() -> Vec<ChannelDef> {
    use topic::*;
    vec![
        def::<fg::RawImage>(DEPTH),
        def::<fg::CameraCalibration>(CALIBRATION),
        def::<own::DepthMeta>(DEPTH_META),
        def::<fg::ImageAnnotations>(ANNOTATIONS),
        def::<own::DetectionsRaw>(DETECTIONS),
        def::<own::RobotStateRaw>(STATE),
        def::<own::OccupancyGridRaw>(NAV_GRID),
        def::<fg::FrameTransforms>(TF),
        def::<fg::PosesInFrame>(TRAJECTORY),
        def::<fg::FrameTransforms>(TRUTH_TF),
        def::<fg::PosesInFrame>(TRUTH_TRAJECTORY),
        def::<fg::SceneUpdate>(TRUTH_OBJECTS),
        def::<fg::SceneUpdate>(MAP),
        def::<own::MapMeta>(MAP_META),
        def::<fg::SceneUpdate>(GBV),
        def::<fg::SceneUpdate>(LBV),
        def::<own::PlannerDecision>(DECISIONS),
        def::<own::NavGoal>(NAV_GOAL),
        def::<own::NeckGoal>(NECK_GOAL),
        def::<own::DeadlineEvent>(DEADLINE),
        def::<own::NodeHealth>(HEALTH),
        def::<own::LatencySummary>(LATENCY),
        def::<fg::Log>(LOG),
        def::<own::Metrics>(METRICS),
        def::<own::RecorderStats>(STATS),
    ]
}

/// True for the channels whose type is a Foxglove well-known schema (`foxglove.*`).
pub fn is_foxglove(c: &ChannelDef) -> bool {
    c.schema.name.starts_with("foxglove.")
}
