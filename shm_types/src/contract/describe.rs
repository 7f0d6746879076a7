//! The field lists of every message type. Each line names a field and its unit; the offset,
//! size, element type and array dimensions are read from the Rust type (`offset_of!`,
//! `size_of`, the field's declared type), and a pattern that destructures the struct
//! exhaustively makes a field missing from a list a compile error.

use super::{Constant, Elem, Field, Scalar, Topic, TypeLayout};
use crate::*;
use core::mem::{align_of, offset_of, size_of};
use iceoryx2::prelude::ZeroCopySend;

/// How a field's declared type maps to an element type and array dimensions.
trait Kind {
    fn elem() -> Elem;
    fn dims(_out: &mut Vec<usize>) {}
}

macro_rules! scalar_kind {
    ($($t:ty => $s:ident),*) => { $(
        impl Kind for $t {
            fn elem() -> Elem {
                Elem::Scalar(Scalar::$s)
            }
        }
    )* };
}
scalar_kind!(u8 => U8, u16 => U16, u32 => U32, u64 => U64, i32 => I32, i64 => I64, f32 => F32);

impl<T: Kind, const N: usize> Kind for [T; N] {
    fn elem() -> Elem {
        T::elem()
    }
    fn dims(out: &mut Vec<usize>) {
        out.push(N);
        T::dims(out);
    }
}

macro_rules! struct_kind {
    ($($t:ident),*) => { $(
        impl Kind for $t {
            fn elem() -> Elem {
                Elem::Struct(stringify!($t))
            }
        }
    )* };
}
struct_kind!(
    Header,
    Pose3,
    Intrinsics,
    Detection,
    MapObject,
    Candidate,
    FrameReceipt,
    ObjectVisibility,
    InputHealth
);

/// A field whose type `T` is inferred from the accessor `get`.
fn field<S, T: Kind>(
    _get: impl Fn(&S) -> &T,
    name: &'static str,
    offset: usize,
    unit: &'static str,
) -> Field {
    let mut dims = Vec::new();
    T::dims(&mut dims);
    Field {
        name,
        offset,
        size: size_of::<T>(),
        elem: T::elem(),
        dims,
        unit,
    }
}

/// `layout!(Type { field: "unit", ... })`: the [`TypeLayout`] of `Type`.
macro_rules! layout {
    ($t:ident { $($f:ident: $unit:literal),* $(,)? }) => {{
        // Never called: it does not compile if a field of `$t` is missing from the list.
        fn exhaustive(v: &$t) {
            let $t { $($f: _),* } = v;
        }
        let _ = exhaustive;
        let mut fields = vec![$( field(|s: &$t| &s.$f, stringify!($f), offset_of!($t, $f), $unit) ),*];
        fields.sort_by_key(|f| f.offset);
        TypeLayout {
            name: stringify!($t),
            // SAFETY: reading the derived type name has no preconditions; the layout contract it
            // stands for is what this module describes.
            type_name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: size_of::<$t>(),
            align: align_of::<$t>(),
            fields,
        }
    }};
}

pub(super) fn types() -> Vec<TypeLayout> {
    vec![
        layout!(Header {
            seq: "count",
            stamp_ns: "ns",
            sim_time_ns: "ns"
        }),
        layout!(Pose3 {
            translation: "m",
            rotation: "1"
        }),
        layout!(Intrinsics {
            fx: "px",
            fy: "px",
            cx: "px",
            cy: "px",
            min_range: "m",
            max_range: "m",
        }),
        layout!(DepthFrame {
            header: "struct",
            width: "px",
            height: "px",
            intrinsics: "struct",
            camera_pose: "struct",
            reserved: "pad",
            depth_mm: "mm",
        }),
        layout!(Detection {
            class_id: "id",
            label: "id",
            score: "1",
            bbox: "px",
            mask_pixels: "count",
        }),
        layout!(Detections {
            header: "struct",
            frame_seq: "id",
            width: "px",
            height: "px",
            count: "count",
            masks: "enum mask_mode",
            items: "struct",
            labels: "id",
        }),
        layout!(RobotState {
            header: "struct",
            nav_goal_id: "id",
            base_pose: "m,m,rad",
            neck_yaw: "rad",
            neck_pitch: "rad",
            odom_cov: "cov(m,m,rad)",
            speed: "m/s",
            distance_m: "m",
            localization_ok: "bool",
            nav_status: "enum nav_status",
            reserved: "pad",
            localization_failures: "count",
        }),
        layout!(MapObject {
            first_seen_ns: "ns",
            id: "id",
            class_id: "id",
            background: "bool",
            complete: "bool",
            center: "m",
            size: "m",
            yaw: "rad",
            point_count: "count",
            cluster_id: "id",
            observations: "count",
            h_sopm: "1",
            c_asso: "1",
            l_best: "m",
            sopm_shape: "enum sopm_shape",
            reserved: "pad",
            sopm_cols: "count",
            sopm_rows: "count",
            sample_count: "count",
            sopm_prob: "1",
            sopm_obs: "count",
            points: "m",
            point_los: "1",
            support_height: "m",
        }),
        layout!(FrameReceipt {
            frame_seq: "id",
            state_seq: "id",
            outcome: "enum frame_outcome",
            reserved: "pad",
        }),
        layout!(ObjectMap {
            header: "struct",
            last_frame_seq: "id",
            last_frame_stamp_ns: "ns",
            count: "count",
            eps_sopm: "1",
            frames_integrated: "count",
            frames_rejected: "count",
            frames_unmatched: "count",
            receipt_count: "count",
            objects: "struct",
            receipts: "struct",
        }),
        layout!(OccupancyGrid {
            header: "struct",
            origin: "m",
            resolution: "m",
            width: "count",
            height: "count",
            reserved: "pad",
            cells: "enum grid_cell",
        }),
        layout!(NavGoal {
            header: "struct",
            goal_id: "id",
            pose: "m,m,rad",
            score: "1",
            cluster_id: "id",
            kind: "enum goal_kind",
            reserved: "pad",
        }),
        layout!(NeckGoal {
            header: "struct",
            map_seq: "id",
            frame_stamp_ns: "ns",
            yaw: "rad",
            pitch: "rad",
            score: "1",
            round_done: "bool",
            state_seq: "id",
            nav_seq: "id",
            explore_seq: "id",
        }),
        layout!(DeadlineEvent {
            header: "struct",
            cycle: "count",
            period_ns: "ns",
            budget_ns: "ns",
            lateness_ns: "ns",
            exec_ns: "ns",
            cpu_ns: "ns",
            run_wait_ns: "ns",
            consecutive_misses: "count",
            missed: "bool",
            miss_cause: "enum miss_cause",
            sched_stats: "bool",
            backup_wake: "bool",
            thread: "utf8",
        }),
        layout!(Candidate {
            position: "m",
            yaw: "rad",
            pitch: "rad",
            value: "1",
            f_a: "1",
            f_c: "1",
            h_sopm: "1",
            h_iou: "1",
            cos_theta_sopm: "1",
            c_asso: "1",
            n_cp: "count",
            cos_theta_c: "1",
            objects_in_view: "count",
            chosen: "bool",
            dropped: "bool",
        }),
        layout!(PlannerDecision {
            header: "struct",
            map_seq: "id",
            eval_ns: "ns",
            cluster_id: "id",
            count: "count",
            evaluated: "count",
            kind: "enum decision_kind",
            state: "enum planner_state",
            reserved: "pad",
            candidates: "struct",
        }),
        layout!(ObjectVisibility {
            object: "id",
            visible_px: "px",
            silhouette_px: "px",
            truncated: "bool",
            reserved: "pad",
            bbox: "px",
        }),
        layout!(FrameVisibility {
            header: "struct",
            frame_seq: "id",
            count: "count",
            reserved: "pad",
            items: "struct",
        }),
        layout!(InputHealth {
            received: "count",
            invalid: "count",
            overflow: "count",
            topic: "utf8",
        }),
        layout!(NodeHealth {
            header: "struct",
            steps: "count",
            pid: "id",
            count: "count",
            node: "utf8",
            inputs: "struct",
        }),
    ]
}

pub(super) static TOPICS: &[Topic] = &[
    Topic {
        topic: "depth",
        payload: "DepthFrame",
        producer: "sim (robot: depth camera driver)",
        doc: "depth image, u16 mm, with intrinsics and the estimated world_from_camera pose",
    },
    Topic {
        topic: "detections",
        payload: "Detections",
        producer: "sim (robot: object detector)",
        doc: "detections of one depth frame (frame_seq = that frame's header.seq)",
    },
    Topic {
        topic: "robot/state",
        payload: "RobotState",
        producer: "sim (robot: base controller + localization)",
        doc: "estimated base pose, neck angles, odometry covariance, navigation status",
    },
    Topic {
        topic: "sim/truth",
        payload: "RobotState",
        producer: "sim only",
        doc: "true robot state (evaluation and recording; absent on a robot)",
    },
    Topic {
        topic: "sim/visibility",
        payload: "FrameVisibility",
        producer: "sim only",
        doc: "ground-truth visibility per rendered frame (evaluation; absent on a robot)",
    },
    Topic {
        topic: "nav/grid",
        payload: "OccupancyGrid",
        producer: "sim (robot: navigation stack)",
        doc: "navigation occupancy grid (obstacles only)",
    },
    Topic {
        topic: "map",
        payload: "ObjectMap",
        producer: "mapper",
        doc: "sparse object map",
    },
    Topic {
        topic: "map/resume",
        payload: "ObjectMap",
        producer: "launcher",
        doc: "the newest map, handed to a restarted mapper (history 1)",
    },
    Topic {
        topic: "map/grid",
        payload: "OccupancyGrid",
        producer: "mapper",
        doc: "exploration grid built from depth (with unknown cells)",
    },
    Topic {
        topic: "nav/goal",
        payload: "NavGoal",
        producer: "planner",
        doc: "chassis goal (consumed by the base controller)",
    },
    Topic {
        topic: "neck/goal",
        payload: "NeckGoal",
        producer: "planner",
        doc: "neck goal relative to the base (consumed by the neck controller)",
    },
    Topic {
        topic: "planner/decision",
        payload: "PlannerDecision",
        producer: "planner",
        doc: "evaluated candidates of each GBV round and LBV cycle",
    },
    Topic {
        topic: "deadline",
        payload: "DeadlineEvent",
        producer: "planner (real-time threads)",
        doc: "one record per periodic executor cycle",
    },
    Topic {
        topic: "health",
        payload: "NodeHealth",
        producer: "every node host (a few Hz)",
        doc: "heartbeat and per-input received / invalid / overflow counts (the launcher's liveness check)",
    },
];

macro_rules! constants {
    ($($group:ident: [$($name:ident),* $(,)?]),* $(,)?) => {
        vec![$($(Constant {
            group: stringify!($group),
            name: stringify!($name),
            value: $group::$name as u64,
        }),*),*]
    };
}

/// The capacity constants, as a module so that `constants!` can name them like the enums.
mod capacity {
    pub use crate::{HEALTH_NODE_LEN, HEALTH_TOPIC_LEN, MAX_HEALTH_INPUTS};
    pub use crate::{
        MAX_CANDIDATES, MAX_DETECTIONS, MAX_FRAME_RECEIPTS, MAX_GRID_CELLS, MAX_HEIGHT,
        MAX_OBJECT_POINTS, MAX_OBJECTS, MAX_PIXELS, MAX_SOPM_CELLS, MAX_WIDTH, THREAD_NAME_LEN,
    };
    /// Number of COCO classes (valid class ids are `0..COCO_CLASS_COUNT`).
    pub const COCO_CLASS_COUNT: usize = crate::COCO_CLASSES.len();
}

pub(super) fn constants() -> Vec<Constant> {
    constants!(
        capacity: [
            MAX_WIDTH,
            MAX_HEIGHT,
            MAX_PIXELS,
            MAX_DETECTIONS,
            MAX_OBJECTS,
            MAX_SOPM_CELLS,
            MAX_OBJECT_POINTS,
            MAX_GRID_CELLS,
            MAX_CANDIDATES,
            MAX_FRAME_RECEIPTS,
            THREAD_NAME_LEN,
            MAX_HEALTH_INPUTS,
            HEALTH_TOPIC_LEN,
            HEALTH_NODE_LEN,
            COCO_CLASS_COUNT,
        ],
        mask_mode: [BOXES, MASKS],
        nav_status: [IDLE, MOVING, REACHED, UNREACHABLE],
        sopm_shape: [CYLINDER, HEMISPHERE, SPHERE],
        grid_cell: [FREE, OCCUPIED, UNKNOWN],
        goal_kind: [GBV, COVERAGE, FRONTIER, RECOVERY],
        miss_cause: [NONE, EXECUTION, RUN_QUEUE, LATE_WAKEUP, BLOCKED, UNKNOWN],
        decision_kind: [GBV, LBV],
        planner_state: [RUNNING, TERMINATED, NO_CANDIDATES],
        frame_outcome: [INTEGRATED, SKIPPED_LOST, NO_DETECTIONS, REFUSED],
    )
}
