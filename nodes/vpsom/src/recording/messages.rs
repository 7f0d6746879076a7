//! The app's own channels' messages: protobuf with schemas derived by `foxglove::Encode` (the
//! schema in the file is a `FileDescriptorSet` named `<lowercase name>.<Name>`, e.g.
//! `plannerdecision.PlannerDecision`). Field numbers follow declaration order, so a field is only
//! ever appended. Every type also derives `Deserialize`: `runtime::recorder::decode` reads any of
//! them back (through the schema stored in the file), which is how `vpsom trace export` and
//! `vpsom replay` read a trace.
//!
//! The `*Raw` types (and [`DepthMeta`]) carry a shared-memory message field for field, so a trace
//! of the `replay` profile holds every input of the mapper and planner exactly.

use foxglove::Encode;
use foxglove::bytes::Bytes;
use serde::{Deserialize, Serialize};

/// One candidate view with every F(v) term (`/planner/decisions`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct Candidate {
    /// Camera position, world frame, metres.
    pub position: Vec<f32>,
    /// Yaw of the view, radians.
    pub yaw: f32,
    /// Downward pitch of the view, radians.
    pub pitch: f32,
    /// F(v).
    pub value: f32,
    /// Object term F_a.
    pub f_a: f32,
    /// Coverage term F_c.
    pub f_c: f32,
    /// H_sopm term.
    pub h_sopm: f32,
    /// H_iou term.
    pub h_iou: f32,
    /// cos θ_sopm.
    pub cos_theta_sopm: f32,
    /// C_asso.
    pub c_asso: f32,
    /// N_cp.
    pub n_cp: f32,
    /// cos θ_c.
    pub cos_theta_c: f32,
    /// Objects in the view.
    pub objects_in_view: u32,
    /// The view chosen.
    pub chosen: bool,
    /// Dropped before scoring (e.g. unreachable).
    pub dropped: bool,
}

/// A GBV or LBV decision (`/planner/decisions`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct PlannerDecision {
    /// Sequence number of the decision.
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns.
    pub sim_time_ns: u64,
    /// `gbv` or `lbv`.
    pub kind: String,
    /// `running`, `terminated` or `no_candidates`.
    pub state: String,
    /// Sequence number of the map the decision was computed on (the input it consumed).
    pub map_seq: u64,
    /// Evaluation time, ns.
    pub eval_ns: u64,
    /// Cluster targeted (-1: none).
    pub cluster_id: i32,
    /// Candidates evaluated.
    pub evaluated: u32,
    /// F(v) of the chosen view (0 if none).
    pub chosen_value: f32,
    /// Every candidate.
    pub candidates: Vec<Candidate>,
}

/// What an object map consumed (`/map/meta`): which frames, how many, when.
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct MapMeta {
    /// Header seq of the map.
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns.
    pub sim_time_ns: u64,
    /// Sequence number of the newest depth frame integrated.
    pub last_frame_seq: u64,
    /// Stamp of that frame, ns.
    pub last_frame_stamp_ns: u64,
    /// Objects in the map.
    pub count: u32,
    /// Frames integrated so far.
    pub frames_integrated: u32,
    /// Frames rejected so far (failed validation).
    pub frames_rejected: u32,
    /// Frames with no matching detections so far.
    pub frames_unmatched: u32,
    /// Frames consumed since the previous map (more than `receipts` holds: receipts were lost).
    #[serde(default)]
    pub receipt_count: u32,
    /// What the mapper did with each of them, oldest first: the inputs this map consumed.
    #[serde(default)]
    pub receipts: Vec<FrameReceipt>,
}

/// One depth frame a map consumed (`/map/meta` `receipts`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct FrameReceipt {
    /// Header seq of the depth frame.
    pub frame_seq: u64,
    /// Header seq of the robot state the mapper held for it (0: none yet).
    pub state_seq: u64,
    /// `integrated`, `skipped_lost`, `no_detections` or `refused`.
    pub outcome: String,
}

/// A navigation goal (`/planner/nav_goal`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct NavGoal {
    /// Sequence number.
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns.
    pub sim_time_ns: u64,
    /// Goal id.
    pub goal_id: u64,
    /// x, metres.
    pub x: f32,
    /// y, metres.
    pub y: f32,
    /// Yaw, radians.
    pub yaw: f32,
    /// Score of the goal.
    pub score: f32,
    /// Cluster targeted.
    pub cluster_id: i32,
    /// `gbv`, `coverage` or `frontier`.
    pub kind: String,
}

/// A neck goal (`/planner/neck_goal`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct NeckGoal {
    /// Sequence number.
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns.
    pub sim_time_ns: u64,
    /// Sequence number of the map it was computed on.
    pub map_seq: u64,
    /// Stamp of the newest frame in that map, ns.
    pub frame_stamp_ns: u64,
    /// Neck yaw, radians.
    pub yaw: f32,
    /// Neck pitch, radians.
    pub pitch: f32,
    /// Score.
    pub score: f32,
    /// A chassis-goal round's result was taken in the cycle (after this goal).
    #[serde(default)]
    pub round_done: bool,
    /// Sequence number of the robot state the cycle used.
    #[serde(default)]
    pub state_seq: u64,
    /// Sequence number of the navigation grid the cycle held (0: none).
    #[serde(default)]
    pub nav_seq: u64,
    /// Sequence number of the exploration grid the cycle held (0: none).
    #[serde(default)]
    pub explore_seq: u64,
}

/// `shm_types::RobotState`, every field (`/robot/state`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct RobotStateRaw {
    /// Header seq.
    pub seq: u64,
    /// Header stamp, ns.
    pub stamp_ns: u64,
    /// Header simulated time, ns.
    pub sim_time_ns: u64,
    /// Goal being driven to.
    pub nav_goal_id: u64,
    /// x, y, yaw.
    pub base_pose: Vec<f32>,
    /// Neck yaw, radians.
    pub neck_yaw: f32,
    /// Neck pitch, radians.
    pub neck_pitch: f32,
    /// Odometry covariance, row-major 3×3.
    pub odom_cov: Vec<f32>,
    /// Speed, m/s.
    pub speed: f32,
    /// Distance driven, m.
    pub distance_m: f32,
    /// Localisation ok.
    pub localization_ok: u32,
    /// Navigation status.
    pub nav_status: u32,
    /// Localisation failures so far.
    pub localization_failures: u32,
}

/// One detection of [`DetectionsRaw`].
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct DetectionRaw {
    /// COCO class id.
    pub class_id: u32,
    /// Label value in the mask.
    pub label: u32,
    /// Score.
    pub score: f32,
    /// x0, y0, x1, y1, pixels.
    pub bbox: Vec<u32>,
    /// Mask pixels.
    pub mask_pixels: u32,
}

/// `shm_types::Detections`, every field (`/detections`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct DetectionsRaw {
    /// Header seq.
    pub seq: u64,
    /// Header stamp, ns.
    pub stamp_ns: u64,
    /// Header simulated time, ns.
    pub sim_time_ns: u64,
    /// Sequence number of the depth frame they belong to.
    pub frame_seq: u64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Label masks present.
    pub masks: u32,
    /// The detections.
    pub items: Vec<DetectionRaw>,
    /// Per-pixel labels (empty without masks).
    #[serde(with = "b64")]
    pub labels: Bytes,
}

/// The rest of a `shm_types::DepthFrame` (`/camera/depth/meta`; the pixels are on `/camera/depth`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct DepthMeta {
    /// Header seq.
    pub seq: u64,
    /// Header stamp, ns.
    pub stamp_ns: u64,
    /// Header simulated time, ns.
    pub sim_time_ns: u64,
    /// Width, pixels (full resolution).
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// fx, fy, cx, cy, min_range, max_range.
    pub intrinsics: Vec<f32>,
    /// Camera pose: translation x, y, z then rotation x, y, z, w.
    pub camera_pose: Vec<f32>,
    /// Decimation of the pixels on `/camera/depth` (1 = exact).
    pub decimation: u32,
}

/// `shm_types::OccupancyGrid`, every field (`/nav/grid`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct OccupancyGridRaw {
    /// Header seq.
    pub seq: u64,
    /// Header stamp, ns.
    pub stamp_ns: u64,
    /// Header simulated time, ns.
    pub sim_time_ns: u64,
    /// World x, y of cell (0, 0), metres.
    pub origin: Vec<f32>,
    /// Cell size, metres.
    pub resolution: f32,
    /// Cells per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Cells, row-major.
    #[serde(with = "b64")]
    pub cells: Bytes,
}

/// `bytes` fields: base64 in the protobuf JSON mapping `runtime::recorder::decode` reads.
mod b64 {
    use base64::Engine;
    use base64::engine::general_purpose::STANDARD;
    use foxglove::bytes::Bytes;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(b: &Bytes, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&STANDARD.encode(b))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Bytes, D::Error> {
        let s = String::deserialize(d)?;
        STANDARD
            .decode(s)
            .map(Bytes::from)
            .map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use runtime::recorder::decode::MessageType;
    use serde::de::DeserializeOwned;

    fn roundtrip<T: Encode + DeserializeOwned>(v: &T) -> T {
        let s = T::get_schema().unwrap();
        let t = MessageType::from_schema(&s.name, &s.encoding, &s.data).unwrap();
        let mut buf = Vec::new();
        v.encode(&mut buf).unwrap();
        t.to_value(&buf).unwrap()
    }

    #[test]
    fn own_types_read_back_exactly() {
        let d = PlannerDecision {
            seq: u64::MAX - 3,
            kind: "gbv".into(),
            cluster_id: -1,
            chosen_value: 0.1 + 0.2,
            candidates: vec![
                Candidate {
                    position: vec![1.0e-7, -3.25, 1.4],
                    value: f32::MAX,
                    chosen: true,
                    ..Default::default()
                },
                Candidate::default(),
            ],
            ..Default::default()
        };
        assert_eq!(roundtrip(&d), d);
        let x = DetectionsRaw {
            frame_seq: 7,
            items: vec![DetectionRaw {
                class_id: 56,
                bbox: vec![1, 2, 3, 4],
                score: 0.3,
                ..Default::default()
            }],
            labels: Bytes::from_static(&[0, 1, 2, 255]),
            ..Default::default()
        };
        assert_eq!(roundtrip(&x), x);
    }
}
