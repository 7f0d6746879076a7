//! Topic names of a run (services are `vpsom/<namespace>/<topic>`), fixed for every tool
//! (recorder, rt_tests e2e) that subscribes to a live run.

/// `DepthFrame` from the sim.
pub const DEPTH: &str = "depth";
/// `Detections` from the sim (`frame_seq` = the depth frame's header seq).
pub const DETECTIONS: &str = "detections";
/// Estimated `RobotState` from the sim.
pub const STATE: &str = "robot/state";
/// True `RobotState` from the sim (evaluation and recording only).
pub const TRUTH: &str = "sim/truth";
/// `FrameVisibility` per rendered frame from the sim (ground truth: the non-occlusion metric).
pub const VISIBILITY: &str = "sim/visibility";
/// Navigation `OccupancyGrid` (obstacles only) from the sim.
pub const NAV_GRID: &str = "nav/grid";
/// `ObjectMap` from the mapper.
pub const MAP: &str = "map";
/// `ObjectMap` from the launcher to a restarted mapper: the newest map the mapper published
/// before it died (one sample per restart, kept as history for the late-joining mapper).
pub const MAP_RESUME: &str = "map/resume";
/// Exploration `OccupancyGrid` (from depth) from the mapper.
pub const MAP_GRID: &str = "map/grid";
/// `NavGoal` from the planner.
pub const NAV_GOAL: &str = "nav/goal";
/// `NeckGoal` from the planner.
pub const NECK_GOAL: &str = "neck/goal";
/// `PlannerDecision` (GBV rounds and LBV cycles) from the planner.
pub const DECISION: &str = "planner/decision";
/// `DeadlineEvent` from the real-time threads.
pub const DEADLINE: &str = "deadline";
/// `NodeHealth` from every node host: heartbeat and input counts (the launcher's liveness
/// check, and the run summary's per-topic invalid and overflow counts).
pub const HEALTH: &str = "health";
