//! What a trace holds and how the robot's messages become it: the app's side of the runtime's
//! MCAP recorder (`runtime::recorder`, which writes what it is given).
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | [`SceneConverter`] (the recorder's [`Converter`]): channels, session facts, the trajectories; [`topic`] names, [`channels`] |
//! | `convert.rs` | each shared-memory message as `foxglove::messages::*` and [`messages`] values |
//! | `messages.rs` | the app's own channels' types (protobuf, schemas derived by `foxglove::Encode`) |
//!
//! # Topics
//! | topic | schema | from |
//! |---|---|---|
//! | `/camera/depth` | `foxglove.RawImage` (`16UC1`) | `RecorderHandle::record_depth` |
//! | `/camera/calibration` | `foxglove.CameraCalibration` | same |
//! | `/camera/depth/meta` | [`messages::DepthMeta`] (header, intrinsics, camera pose) | same |
//! | `/camera/detections` | `foxglove.ImageAnnotations` on the depth image | `record_detections` |
//! | `/detections` | [`messages::DetectionsRaw`] | same |
//! | `/robot/state` | [`messages::RobotStateRaw`] | `record_state` |
//! | `/nav/grid` | [`messages::OccupancyGridRaw`] | `record_nav_grid` |
//! | `/tf` | `foxglove.FrameTransforms` world→base→neck→camera | `record_state` |
//! | `/trajectory` | `foxglove.PosesInFrame` (estimated base) | state, at `[recorder] trajectory_hz` |
//! | `/truth/tf`, `/truth/trajectory` | same, frame `base_true` | `record_true_state` |
//! | `/truth/objects` | `foxglove.SceneUpdate` | [`SceneConverter::new`]'s true boxes, once |
//! | `/map/objects` | `foxglove.SceneUpdate` | `record_map` |
//! | `/map/meta` | [`messages::MapMeta`] (the frames each map consumed) | same |
//! | `/planner/gbv`, `/planner/lbv` | `foxglove.SceneUpdate` frusta | `record_decision` |
//! | `/planner/decisions` | [`messages::PlannerDecision`] (every F(v) term) | same |
//! | `/planner/nav_goal`, `/planner/neck_goal` | [`messages::NavGoal`], [`messages::NeckGoal`] | `record_*_goal` |
//!
//! The runtime adds its own channels after these: `/runtime/deadline`, `/runtime/health`,
//! `/runtime/latency`, `/log`, `/metrics` and `/recorder/stats` (`runtime::recorder` module
//! docs). `config/foxglove-layout.json` is a Foxglove layout for these topics (3D, depth with
//! the detection boxes, LBV exec time).

pub mod convert;
pub mod messages;

use foxglove::messages as fg;
use runtime::recorder::schemas::{self, ChannelDef};
use runtime::recorder::{Converter, Kind, RecorderConfig, RecorderError, Sink};
use serde::Serialize;
use shm_types::{
    DepthFrame, Detections, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision,
    RobotState, decision_kind,
};

/// Topic names of a trace: the app's, and the runtime's own (re-exported).
pub mod topic {
    pub use runtime::recorder::schemas::topic::*;

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
}

/// The app's channels, in the order they are created.
fn app_channels() -> Vec<ChannelDef> {
    use messages as own;
    use topic::*;
    vec![
        ChannelDef::of::<fg::RawImage>(DEPTH),
        ChannelDef::of::<fg::CameraCalibration>(CALIBRATION),
        ChannelDef::of::<own::DepthMeta>(DEPTH_META),
        ChannelDef::of::<fg::ImageAnnotations>(ANNOTATIONS),
        ChannelDef::of::<own::DetectionsRaw>(DETECTIONS),
        ChannelDef::of::<own::RobotStateRaw>(STATE),
        ChannelDef::of::<own::OccupancyGridRaw>(NAV_GRID),
        ChannelDef::of::<fg::FrameTransforms>(TF),
        ChannelDef::of::<fg::PosesInFrame>(TRAJECTORY),
        ChannelDef::of::<fg::FrameTransforms>(TRUTH_TF),
        ChannelDef::of::<fg::PosesInFrame>(TRUTH_TRAJECTORY),
        ChannelDef::of::<fg::SceneUpdate>(TRUTH_OBJECTS),
        ChannelDef::of::<fg::SceneUpdate>(MAP),
        ChannelDef::of::<own::MapMeta>(MAP_META),
        ChannelDef::of::<fg::SceneUpdate>(GBV),
        ChannelDef::of::<fg::SceneUpdate>(LBV),
        ChannelDef::of::<own::PlannerDecision>(DECISIONS),
        ChannelDef::of::<own::NavGoal>(NAV_GOAL),
        ChannelDef::of::<own::NeckGoal>(NECK_GOAL),
    ]
}

/// Every channel of a trace, in the order they are created: the app's, then the runtime's own.
pub fn channels() -> Vec<ChannelDef> {
    let mut c = app_channels();
    c.extend(schemas::own_channels());
    c
}

/// Every topic of a trace ([`channels`]), e.g. for `RecorderConfig::validate`.
pub fn topics() -> Vec<&'static str> {
    channels().iter().map(|c| c.topic).collect()
}

/// The topic that carries exactly one message per accepted input of `kind` (in the `replay`
/// profile; the `view` profile's rate limits leave some out, counted as throttled): the recorder
/// counts offers and drops under it.
pub fn primary_topic(kind: Kind) -> &'static str {
    use topic::*;
    match kind {
        Kind::Depth => DEPTH,
        Kind::Detections => DETECTIONS,
        Kind::NavGrid => NAV_GRID,
        Kind::State => TF,
        Kind::TrueState => TRUTH_TF,
        Kind::Map => MAP,
        Kind::Decision => DECISIONS,
        Kind::NavGoal => NAV_GOAL,
        Kind::NeckGoal => NECK_GOAL,
        Kind::Deadline => DEADLINE,
        Kind::Health => HEALTH,
        Kind::Latency => LATENCY,
        Kind::Log => LOG,
        Kind::Metrics => METRICS,
    }
}

/// A ground-truth object for `/truth/objects` (given once at start).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthBox {
    /// Unique name in the scene.
    pub name: String,
    /// COCO class name.
    pub class: String,
    /// Centre, world frame, metres.
    pub center: [f32; 3],
    /// Extent along the object's x, y, z, metres.
    pub size: [f32; 3],
    /// Yaw about +z, radians.
    pub yaw: f32,
}

/// Where the camera sits on the robot (the static part of world→base→neck→camera) and what it
/// sees (for the drawn frusta).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountGeometry {
    /// Height of the camera above the floor, metres.
    pub height: f32,
    /// Offset of the neck axis ahead of the base centre, metres.
    pub forward_offset: f32,
    /// Horizontal field of view, degrees (for the drawn frusta).
    pub hfov_deg: f32,
    /// Vertical field of view, degrees.
    pub vfov_deg: f32,
}

impl From<&geom::CameraConfig> for MountGeometry {
    /// `[camera.mount]` and the fields of view of `[camera]`.
    fn from(c: &geom::CameraConfig) -> Self {
        Self {
            height: c.mount.height,
            forward_offset: c.mount.forward_offset,
            hfov_deg: c.hfov_deg,
            vfov_deg: c.vfov_deg,
        }
    }
}

impl Default for MountGeometry {
    /// The shipped camera ([`geom::CameraConfig::default`]).
    fn default() -> Self {
        Self::from(&geom::CameraConfig::default())
    }
}

/// A base trajectory being accumulated.
#[derive(Debug, Default)]
struct Trajectory {
    poses: Vec<[f32; 3]>,
    last_sent_ns: Option<u64>,
}

impl Trajectory {
    /// Add a pose; returns true when a message is due.
    fn add(&mut self, s: &RobotState, period_ns: u64, max: usize) -> bool {
        let p = s.base_pose;
        let moved = self
            .poses
            .last()
            .is_none_or(|q| (q[0] - p[0]).hypot(q[1] - p[1]) > 0.01 || (q[2] - p[2]).abs() > 0.02);
        if moved {
            if self.poses.len() >= max {
                // Thin the older half by 2 so memory and message size stay bounded.
                let mut k = 0;
                self.poses.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
            }
            self.poses.push(p);
        }
        let t = s.header.sim_time_ns;
        let due = self
            .last_sent_ns
            .is_none_or(|l| t >= l.saturating_add(period_ns) || t < l);
        if due {
            self.last_sent_ns = Some(t);
        }
        due
    }

    /// Add a state and write the trajectory on `topic` when due.
    fn record(
        &mut self,
        s: &RobotState,
        (period_ns, max): (u64, usize),
        topic: &'static str,
        sink: &mut Sink,
    ) -> Result<(), RecorderError> {
        if !self.add(s, period_ns, max) {
            return Ok(());
        }
        let (t, p) = (s.header.sim_time_ns, s.header.stamp_ns);
        sink.emit(topic, t, p, || convert::trajectory(t, &self.poses))
    }
}

/// The recorder's [`Converter`] for a session: the camera geometry, the scene's true boxes,
/// and the `[recorder]` settings that shape the drawings (depth decimation, trajectory rate and
/// length, frustum length).
#[derive(Debug)]
pub struct SceneConverter {
    mount: MountGeometry,
    truth: Vec<TruthBox>,
    decimation: u32,
    frustum_length_m: f64,
    /// `/trajectory` period (simulated ns) and most poses kept.
    trajectory: (u64, usize),
    traj: Trajectory,
    truth_traj: Trajectory,
}

impl SceneConverter {
    /// A converter drawing with `mount` and showing `truth` (empty on a real robot), shaped by
    /// `cfg`.
    pub fn new(cfg: &RecorderConfig, mount: MountGeometry, truth: Vec<TruthBox>) -> Self {
        Self {
            mount,
            truth,
            decimation: cfg.depth_decimation(),
            frustum_length_m: cfg.frustum_length_m,
            trajectory: ((1e9 / cfg.trajectory_hz) as u64, cfg.trajectory_max_poses),
            traj: Trajectory::default(),
            truth_traj: Trajectory::default(),
        }
    }
}

impl Converter for SceneConverter {
    fn channels(&self) -> Vec<ChannelDef> {
        app_channels()
    }

    fn topic(&self, kind: Kind) -> &'static str {
        primary_topic(kind)
    }

    fn session_metadata(&self) -> Vec<(String, String)> {
        let m = self.mount;
        vec![
            ("mount_height_m".into(), m.height.to_string()),
            (
                "mount_forward_offset_m".into(),
                m.forward_offset.to_string(),
            ),
            ("hfov_deg".into(), m.hfov_deg.to_string()),
            ("vfov_deg".into(), m.vfov_deg.to_string()),
            ("truth_objects".into(), self.truth.len().to_string()),
        ]
    }

    fn start(&mut self, sink: &mut Sink) -> Result<(), RecorderError> {
        if !self.truth.is_empty() {
            sink.emit(topic::TRUTH_OBJECTS, 0, 0, || {
                convert::truth_objects(&self.truth)
            })?;
            sink.keep_for_live(topic::TRUTH_OBJECTS, 0);
        }
        Ok(())
    }

    fn depth(&mut self, f: &DepthFrame, sink: &mut Sink) -> Result<(), RecorderError> {
        let k = self.decimation;
        let (t, p) = (f.header.sim_time_ns, f.header.stamp_ns);
        sink.emit(topic::DEPTH, t, p, || convert::depth_image(f, k))?;
        sink.emit(topic::DEPTH_META, t, p, || convert::depth_meta(f, k))?;
        sink.emit(topic::CALIBRATION, t, p, || convert::calibration(f, k))
    }

    fn detections(&mut self, d: &Detections, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (d.header.sim_time_ns, d.header.stamp_ns);
        let k = self.decimation;
        sink.emit(topic::DETECTIONS, t, p, || convert::detections_raw(d))?;
        sink.emit(topic::ANNOTATIONS, t, p, || convert::annotations(d, t, k))
    }

    fn nav_grid(&mut self, g: &OccupancyGrid, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (g.header.sim_time_ns, g.header.stamp_ns);
        sink.emit(topic::NAV_GRID, t, p, || convert::grid_raw(g))?;
        sink.keep_for_live(topic::NAV_GRID, t);
        Ok(())
    }

    fn state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (s.header.sim_time_ns, s.header.stamp_ns);
        sink.emit(topic::STATE, t, p, || convert::state_raw(s))?;
        sink.emit(topic::TF, t, p, || {
            convert::transforms(s, &self.mount, false)
        })?;
        self.traj
            .record(s, self.trajectory, topic::TRAJECTORY, sink)
    }

    fn true_state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (s.header.sim_time_ns, s.header.stamp_ns);
        sink.emit(topic::TRUTH_TF, t, p, || {
            convert::transforms(s, &self.mount, true)
        })?;
        self.truth_traj
            .record(s, self.trajectory, topic::TRUTH_TRAJECTORY, sink)
    }

    fn map(&mut self, m: &ObjectMap, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (m.header.sim_time_ns, m.header.stamp_ns);
        sink.emit(topic::MAP, t, p, || convert::map_objects(m))?;
        sink.emit(topic::MAP_META, t, p, || convert::map_meta(m))
    }

    fn decision(&mut self, d: &PlannerDecision, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (d.header.sim_time_ns, d.header.stamp_ns);
        let scene = if d.kind == decision_kind::GBV {
            topic::GBV
        } else {
            topic::LBV
        };
        sink.emit(topic::DECISIONS, t, p, || convert::decision(d))?;
        let len = self.frustum_length_m;
        sink.emit(scene, t, p, || convert::frusta(d, &self.mount, len))
    }

    fn nav_goal(&mut self, g: &NavGoal, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (g.header.sim_time_ns, g.header.stamp_ns);
        sink.emit(topic::NAV_GOAL, t, p, || convert::nav_goal(g))
    }

    fn neck_goal(&mut self, g: &NeckGoal, sink: &mut Sink) -> Result<(), RecorderError> {
        let (t, p) = (g.header.sim_time_ns, g.header.stamp_ns);
        sink.emit(topic::NECK_GOAL, t, p, || convert::neck_goal(g))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_a_channel_and_the_shipped_mount_is_read() {
        let topics = topics();
        for k in Kind::ALL {
            assert!(topics.contains(&primary_topic(k)), "{k:?}");
        }
        assert_eq!(topics.len(), 25);
        assert_eq!(MountGeometry::default().height, 1.4);
        RecorderConfig::default()
            .validate(&settings::Checker::new("config/runtime.toml"), &topics)
            .unwrap();
    }
}
