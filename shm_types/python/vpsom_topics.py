"""vpsom-rt topic contract: ctypes layouts of a run's iceoryx2 (0.10) payloads.

GENERATED from the Rust types by shm_types/src/contract; do not edit. Regenerate with
    UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract

A service is service_name(namespace, topic) = "vpsom/<namespace>/<topic>"; TOPICS maps
each topic to its payload class. `iceoryx2`'s `publish_subscribe(cls)` takes the type name
from `cls.type_name()` and the size and alignment from ctypes; no user header. After each
send, notify the event service of the same name (subscribers block on it). Every padding
byte is an explicit `_pad<offset>` field, so no `_pack_` is needed. LAYOUT holds the
Rust sizes, alignments and field offsets. Units: m, rad, ns, mm, px; "1" = dimensionless.
"""

# fmt: off
import ctypes


SERVICE_ROOT = "vpsom"
USER_HEADER_TYPE_NAME = "()"


def service_name(namespace: str, topic: str) -> str:
    """Full iceoryx2 service name of `topic` in a run's `namespace`."""
    return f"{SERVICE_ROOT}/{namespace}/{topic}"


def iceoryx2_config(iox2, uid=None):
    """The iceoryx2 config a run of user `uid` (default: this process's) uses: its own
    root directory and prefix (services are owner-only). Pass it to NodeBuilder.config()."""
    import os
    uid = os.geteuid() if uid is None else uid
    c = iox2.config.default()
    c.global_cfg.root_path = iox2.Path.new(f"/tmp/vpsom-iox2-u{uid}/")
    c.global_cfg.prefix = iox2.FileName.new(f"vpsom_u{uid}_")
    return c


# ---- capacities and enum values ----
MAX_WIDTH = 640
MAX_HEIGHT = 480
MAX_PIXELS = 307200
MAX_DETECTIONS = 64
MAX_OBJECTS = 128
MAX_SOPM_CELLS = 648
MAX_OBJECT_POINTS = 64
MAX_GRID_CELLS = 65536
MAX_CANDIDATES = 64
MAX_FRAME_RECEIPTS = 16
THREAD_NAME_LEN = 32
MAX_HEALTH_INPUTS = 16
HEALTH_TOPIC_LEN = 32
HEALTH_NODE_LEN = 16
COCO_CLASS_COUNT = 80
MASK_MODE_BOXES = 0
MASK_MODE_MASKS = 1
NAV_STATUS_IDLE = 0
NAV_STATUS_MOVING = 1
NAV_STATUS_REACHED = 2
NAV_STATUS_UNREACHABLE = 3
SOPM_SHAPE_CYLINDER = 0
SOPM_SHAPE_HEMISPHERE = 1
SOPM_SHAPE_SPHERE = 2
GRID_CELL_FREE = 0
GRID_CELL_OCCUPIED = 100
GRID_CELL_UNKNOWN = 255
GOAL_KIND_GBV = 0
GOAL_KIND_COVERAGE = 1
GOAL_KIND_FRONTIER = 2
GOAL_KIND_RECOVERY = 3
MISS_CAUSE_NONE = 0
MISS_CAUSE_EXECUTION = 1
MISS_CAUSE_RUN_QUEUE = 2
MISS_CAUSE_LATE_WAKEUP = 3
MISS_CAUSE_BLOCKED = 4
MISS_CAUSE_UNKNOWN = 5
DECISION_KIND_GBV = 0
DECISION_KIND_LBV = 1
PLANNER_STATE_RUNNING = 0
PLANNER_STATE_TERMINATED = 1
PLANNER_STATE_NO_CANDIDATES = 2
FRAME_OUTCOME_INTEGRATED = 0
FRAME_OUTCOME_SKIPPED_LOST = 1
FRAME_OUTCOME_NO_DETECTIONS = 2
FRAME_OUTCOME_REFUSED = 3

# COCO class names by class id.
COCO_CLASSES = (
    "person", "bicycle", "car", "motorcycle", "airplane", "bus",
    "train", "truck", "boat", "traffic light", "fire hydrant", "stop sign",
    "parking meter", "bench", "bird", "cat", "dog", "horse",
    "sheep", "cow", "elephant", "bear", "zebra", "giraffe",
    "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee",
    "skis", "snowboard", "sports ball", "kite", "baseball bat", "baseball glove",
    "skateboard", "surfboard", "tennis racket", "bottle", "wine glass", "cup",
    "fork", "knife", "spoon", "bowl", "banana", "apple",
    "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza",
    "donut", "cake", "chair", "couch", "potted plant", "bed",
    "dining table", "toilet", "tv", "laptop", "mouse", "remote",
    "keyboard", "cell phone", "microwave", "oven", "toaster", "sink",
    "refrigerator", "book", "clock", "vase", "scissors", "teddy bear",
    "hair drier", "toothbrush",
)


class Header(ctypes.Structure):
    """vpsom::Header: 24 bytes, alignment 8."""

    _fields_ = [
        ("seq", ctypes.c_uint64),  # offset 0, count
        ("stamp_ns", ctypes.c_uint64),  # offset 8, ns
        ("sim_time_ns", ctypes.c_uint64),  # offset 16, ns
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Header"


class Pose3(ctypes.Structure):
    """vpsom::Pose3: 28 bytes, alignment 4."""

    _fields_ = [
        ("translation", ctypes.c_float * 3),  # offset 0, m
        ("rotation", ctypes.c_float * 4),  # offset 12, 1
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Pose3"


class Intrinsics(ctypes.Structure):
    """vpsom::Intrinsics: 24 bytes, alignment 4."""

    _fields_ = [
        ("fx", ctypes.c_float),  # offset 0, px
        ("fy", ctypes.c_float),  # offset 4, px
        ("cx", ctypes.c_float),  # offset 8, px
        ("cy", ctypes.c_float),  # offset 12, px
        ("min_range", ctypes.c_float),  # offset 16, m
        ("max_range", ctypes.c_float),  # offset 20, m
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Intrinsics"


class DepthFrame(ctypes.Structure):
    """vpsom::DepthFrame: 614488 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("width", ctypes.c_uint32),  # offset 24, px
        ("height", ctypes.c_uint32),  # offset 28, px
        ("intrinsics", Intrinsics),  # offset 32, struct
        ("camera_pose", Pose3),  # offset 56, struct
        ("reserved", ctypes.c_uint32),  # offset 84, pad
        ("depth_mm", ctypes.c_uint16 * 307200),  # offset 88, mm
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::DepthFrame"


class Detection(ctypes.Structure):
    """vpsom::Detection: 20 bytes, alignment 4."""

    _fields_ = [
        ("class_id", ctypes.c_uint16),  # offset 0, id
        ("label", ctypes.c_uint16),  # offset 2, id
        ("score", ctypes.c_float),  # offset 4, 1
        ("bbox", ctypes.c_uint16 * 4),  # offset 8, px
        ("mask_pixels", ctypes.c_uint32),  # offset 16, count
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Detection"


class Detections(ctypes.Structure):
    """vpsom::Detections: 308528 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("frame_seq", ctypes.c_uint64),  # offset 24, id
        ("width", ctypes.c_uint32),  # offset 32, px
        ("height", ctypes.c_uint32),  # offset 36, px
        ("count", ctypes.c_uint32),  # offset 40, count
        ("masks", ctypes.c_uint32),  # offset 44, enum mask_mode
        ("items", Detection * 64),  # offset 48, struct
        ("labels", ctypes.c_uint8 * 307200),  # offset 1328, id
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Detections"


class RobotState(ctypes.Structure):
    """vpsom::RobotState: 104 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("nav_goal_id", ctypes.c_uint64),  # offset 24, id
        ("base_pose", ctypes.c_float * 3),  # offset 32, m,m,rad
        ("neck_yaw", ctypes.c_float),  # offset 44, rad
        ("neck_pitch", ctypes.c_float),  # offset 48, rad
        ("odom_cov", ctypes.c_float * 9),  # offset 52, cov(m,m,rad)
        ("speed", ctypes.c_float),  # offset 88, m/s
        ("distance_m", ctypes.c_float),  # offset 92, m
        ("localization_ok", ctypes.c_uint8),  # offset 96, bool
        ("nav_status", ctypes.c_uint8),  # offset 97, enum nav_status
        ("reserved", ctypes.c_uint8 * 2),  # offset 98, pad
        ("localization_failures", ctypes.c_uint32),  # offset 100, count
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::RobotState"


class MapObject(ctypes.Structure):
    """vpsom::MapObject: 5512 bytes, alignment 8."""

    _fields_ = [
        ("first_seen_ns", ctypes.c_uint64),  # offset 0, ns
        ("id", ctypes.c_uint32),  # offset 8, id
        ("class_id", ctypes.c_uint16),  # offset 12, id
        ("background", ctypes.c_uint8),  # offset 14, bool
        ("complete", ctypes.c_uint8),  # offset 15, bool
        ("center", ctypes.c_float * 3),  # offset 16, m
        ("size", ctypes.c_float * 3),  # offset 28, m
        ("yaw", ctypes.c_float),  # offset 40, rad
        ("point_count", ctypes.c_uint32),  # offset 44, count
        ("cluster_id", ctypes.c_int32),  # offset 48, id
        ("observations", ctypes.c_uint32),  # offset 52, count
        ("h_sopm", ctypes.c_float),  # offset 56, 1
        ("c_asso", ctypes.c_float),  # offset 60, 1
        ("l_best", ctypes.c_float * 3),  # offset 64, m
        ("sopm_shape", ctypes.c_uint8),  # offset 76, enum sopm_shape
        ("reserved", ctypes.c_uint8),  # offset 77, pad
        ("sopm_cols", ctypes.c_uint16),  # offset 78, count
        ("sopm_rows", ctypes.c_uint16),  # offset 80, count
        ("sample_count", ctypes.c_uint16),  # offset 82, count
        ("sopm_prob", ctypes.c_float * 648),  # offset 84, 1
        ("sopm_obs", ctypes.c_uint16 * 648),  # offset 2676, count
        ("points", (ctypes.c_float * 3) * 64),  # offset 3972, m
        ("point_los", (ctypes.c_float * 3) * 64),  # offset 4740, 1
        ("support_height", ctypes.c_float),  # offset 5508, m
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::MapObject"


class FrameReceipt(ctypes.Structure):
    """vpsom::FrameReceipt: 24 bytes, alignment 8."""

    _fields_ = [
        ("frame_seq", ctypes.c_uint64),  # offset 0, id
        ("state_seq", ctypes.c_uint64),  # offset 8, id
        ("outcome", ctypes.c_uint32),  # offset 16, enum frame_outcome
        ("reserved", ctypes.c_uint32),  # offset 20, pad
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::FrameReceipt"


class ObjectMap(ctypes.Structure):
    """vpsom::ObjectMap: 705984 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("last_frame_seq", ctypes.c_uint64),  # offset 24, id
        ("last_frame_stamp_ns", ctypes.c_uint64),  # offset 32, ns
        ("count", ctypes.c_uint32),  # offset 40, count
        ("eps_sopm", ctypes.c_float),  # offset 44, 1
        ("frames_integrated", ctypes.c_uint32),  # offset 48, count
        ("frames_rejected", ctypes.c_uint32),  # offset 52, count
        ("frames_unmatched", ctypes.c_uint32),  # offset 56, count
        ("receipt_count", ctypes.c_uint32),  # offset 60, count
        ("objects", MapObject * 128),  # offset 64, struct
        ("receipts", FrameReceipt * 16),  # offset 705600, struct
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::ObjectMap"


class OccupancyGrid(ctypes.Structure):
    """vpsom::OccupancyGrid: 65584 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("origin", ctypes.c_float * 2),  # offset 24, m
        ("resolution", ctypes.c_float),  # offset 32, m
        ("width", ctypes.c_uint32),  # offset 36, count
        ("height", ctypes.c_uint32),  # offset 40, count
        ("reserved", ctypes.c_uint32),  # offset 44, pad
        ("cells", ctypes.c_uint8 * 65536),  # offset 48, enum grid_cell
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::OccupancyGrid"


class NavGoal(ctypes.Structure):
    """vpsom::NavGoal: 56 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("goal_id", ctypes.c_uint64),  # offset 24, id
        ("pose", ctypes.c_float * 3),  # offset 32, m,m,rad
        ("score", ctypes.c_float),  # offset 44, 1
        ("cluster_id", ctypes.c_int32),  # offset 48, id
        ("kind", ctypes.c_uint8),  # offset 52, enum goal_kind
        ("reserved", ctypes.c_uint8 * 3),  # offset 53, pad
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::NavGoal"


class NeckGoal(ctypes.Structure):
    """vpsom::NeckGoal: 80 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("map_seq", ctypes.c_uint64),  # offset 24, id
        ("frame_stamp_ns", ctypes.c_uint64),  # offset 32, ns
        ("yaw", ctypes.c_float),  # offset 40, rad
        ("pitch", ctypes.c_float),  # offset 44, rad
        ("score", ctypes.c_float),  # offset 48, 1
        ("round_done", ctypes.c_uint32),  # offset 52, bool
        ("state_seq", ctypes.c_uint64),  # offset 56, id
        ("nav_seq", ctypes.c_uint64),  # offset 64, id
        ("explore_seq", ctypes.c_uint64),  # offset 72, id
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::NeckGoal"


class DeadlineEvent(ctypes.Structure):
    """vpsom::DeadlineEvent: 120 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("cycle", ctypes.c_uint64),  # offset 24, count
        ("period_ns", ctypes.c_uint64),  # offset 32, ns
        ("budget_ns", ctypes.c_uint64),  # offset 40, ns
        ("lateness_ns", ctypes.c_int64),  # offset 48, ns
        ("exec_ns", ctypes.c_uint64),  # offset 56, ns
        ("cpu_ns", ctypes.c_uint64),  # offset 64, ns
        ("run_wait_ns", ctypes.c_uint64),  # offset 72, ns
        ("consecutive_misses", ctypes.c_uint32),  # offset 80, count
        ("missed", ctypes.c_uint8),  # offset 84, bool
        ("miss_cause", ctypes.c_uint8),  # offset 85, enum miss_cause
        ("sched_stats", ctypes.c_uint8),  # offset 86, bool
        ("backup_wake", ctypes.c_uint8),  # offset 87, bool
        ("thread", ctypes.c_uint8 * 32),  # offset 88, utf8
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::DeadlineEvent"


class Candidate(ctypes.Structure):
    """vpsom::Candidate: 60 bytes, alignment 4."""

    _fields_ = [
        ("position", ctypes.c_float * 3),  # offset 0, m
        ("yaw", ctypes.c_float),  # offset 12, rad
        ("pitch", ctypes.c_float),  # offset 16, rad
        ("value", ctypes.c_float),  # offset 20, 1
        ("f_a", ctypes.c_float),  # offset 24, 1
        ("f_c", ctypes.c_float),  # offset 28, 1
        ("h_sopm", ctypes.c_float),  # offset 32, 1
        ("h_iou", ctypes.c_float),  # offset 36, 1
        ("cos_theta_sopm", ctypes.c_float),  # offset 40, 1
        ("c_asso", ctypes.c_float),  # offset 44, 1
        ("n_cp", ctypes.c_float),  # offset 48, count
        ("cos_theta_c", ctypes.c_float),  # offset 52, 1
        ("objects_in_view", ctypes.c_uint16),  # offset 56, count
        ("chosen", ctypes.c_uint8),  # offset 58, bool
        ("dropped", ctypes.c_uint8),  # offset 59, bool
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::Candidate"


class PlannerDecision(ctypes.Structure):
    """vpsom::PlannerDecision: 3896 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("map_seq", ctypes.c_uint64),  # offset 24, id
        ("eval_ns", ctypes.c_uint64),  # offset 32, ns
        ("cluster_id", ctypes.c_int32),  # offset 40, id
        ("count", ctypes.c_uint32),  # offset 44, count
        ("evaluated", ctypes.c_uint32),  # offset 48, count
        ("kind", ctypes.c_uint8),  # offset 52, enum decision_kind
        ("state", ctypes.c_uint8),  # offset 53, enum planner_state
        ("reserved", ctypes.c_uint8 * 2),  # offset 54, pad
        ("candidates", Candidate * 64),  # offset 56, struct
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::PlannerDecision"


class ObjectVisibility(ctypes.Structure):
    """vpsom::ObjectVisibility: 32 bytes, alignment 4."""

    _fields_ = [
        ("object", ctypes.c_uint32),  # offset 0, id
        ("visible_px", ctypes.c_uint32),  # offset 4, px
        ("silhouette_px", ctypes.c_uint32),  # offset 8, px
        ("truncated", ctypes.c_uint8),  # offset 12, bool
        ("reserved", ctypes.c_uint8 * 3),  # offset 13, pad
        ("bbox", ctypes.c_float * 4),  # offset 16, px
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::ObjectVisibility"


class FrameVisibility(ctypes.Structure):
    """vpsom::FrameVisibility: 4136 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("frame_seq", ctypes.c_uint64),  # offset 24, id
        ("count", ctypes.c_uint32),  # offset 32, count
        ("reserved", ctypes.c_uint32),  # offset 36, pad
        ("items", ObjectVisibility * 128),  # offset 40, struct
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::FrameVisibility"


class InputHealth(ctypes.Structure):
    """vpsom::InputHealth: 56 bytes, alignment 8."""

    _fields_ = [
        ("received", ctypes.c_uint64),  # offset 0, count
        ("invalid", ctypes.c_uint64),  # offset 8, count
        ("overflow", ctypes.c_uint64),  # offset 16, count
        ("topic", ctypes.c_uint8 * 32),  # offset 24, utf8
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::InputHealth"


class NodeHealth(ctypes.Structure):
    """vpsom::NodeHealth: 952 bytes, alignment 8."""

    _fields_ = [
        ("header", Header),  # offset 0, struct
        ("steps", ctypes.c_uint64),  # offset 24, count
        ("pid", ctypes.c_uint32),  # offset 32, id
        ("count", ctypes.c_uint32),  # offset 36, count
        ("node", ctypes.c_uint8 * 16),  # offset 40, utf8
        ("inputs", InputHealth * 16),  # offset 56, struct
    ]

    @staticmethod
    def type_name() -> str:
        """The iceoryx2 payload type name (used by `publish_subscribe`)."""
        return "vpsom::NodeHealth"


# Topic -> payload class.
TOPICS = {
    "depth": DepthFrame,
    "detections": Detections,
    "robot/state": RobotState,
    "sim/truth": RobotState,
    "sim/visibility": FrameVisibility,
    "nav/grid": OccupancyGrid,
    "map": ObjectMap,
    "map/resume": ObjectMap,
    "map/grid": OccupancyGrid,
    "nav/goal": NavGoal,
    "neck/goal": NeckGoal,
    "planner/decision": PlannerDecision,
    "deadline": DeadlineEvent,
    "health": NodeHealth,
}

# The Rust layout: per type, iceoryx2 type name, size, alignment and per field (offset,
# size, element type, dims, unit).
LAYOUT = {
    "Header": {"type_name": "vpsom::Header", "size": 24, "align": 8, "fields": {
        "seq": {"offset": 0, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "stamp_ns": {"offset": 8, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "sim_time_ns": {"offset": 16, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
    }},
    "Pose3": {"type_name": "vpsom::Pose3", "size": 28, "align": 4, "fields": {
        "translation": {"offset": 0, "size": 12, "type": "f32", "dims": [3], "unit": "m"},
        "rotation": {"offset": 12, "size": 16, "type": "f32", "dims": [4], "unit": "1"},
    }},
    "Intrinsics": {"type_name": "vpsom::Intrinsics", "size": 24, "align": 4, "fields": {
        "fx": {"offset": 0, "size": 4, "type": "f32", "dims": [], "unit": "px"},
        "fy": {"offset": 4, "size": 4, "type": "f32", "dims": [], "unit": "px"},
        "cx": {"offset": 8, "size": 4, "type": "f32", "dims": [], "unit": "px"},
        "cy": {"offset": 12, "size": 4, "type": "f32", "dims": [], "unit": "px"},
        "min_range": {"offset": 16, "size": 4, "type": "f32", "dims": [], "unit": "m"},
        "max_range": {"offset": 20, "size": 4, "type": "f32", "dims": [], "unit": "m"},
    }},
    "DepthFrame": {"type_name": "vpsom::DepthFrame", "size": 614488, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "width": {"offset": 24, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "height": {"offset": 28, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "intrinsics": {"offset": 32, "size": 24, "type": "Intrinsics", "dims": [], "unit": "struct"},
        "camera_pose": {"offset": 56, "size": 28, "type": "Pose3", "dims": [], "unit": "struct"},
        "reserved": {"offset": 84, "size": 4, "type": "u32", "dims": [], "unit": "pad"},
        "depth_mm": {"offset": 88, "size": 614400, "type": "u16", "dims": [307200], "unit": "mm"},
    }},
    "Detection": {"type_name": "vpsom::Detection", "size": 20, "align": 4, "fields": {
        "class_id": {"offset": 0, "size": 2, "type": "u16", "dims": [], "unit": "id"},
        "label": {"offset": 2, "size": 2, "type": "u16", "dims": [], "unit": "id"},
        "score": {"offset": 4, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "bbox": {"offset": 8, "size": 8, "type": "u16", "dims": [4], "unit": "px"},
        "mask_pixels": {"offset": 16, "size": 4, "type": "u32", "dims": [], "unit": "count"},
    }},
    "Detections": {"type_name": "vpsom::Detections", "size": 308528, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "frame_seq": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "width": {"offset": 32, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "height": {"offset": 36, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "count": {"offset": 40, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "masks": {"offset": 44, "size": 4, "type": "u32", "dims": [], "unit": "enum mask_mode"},
        "items": {"offset": 48, "size": 1280, "type": "Detection", "dims": [64], "unit": "struct"},
        "labels": {"offset": 1328, "size": 307200, "type": "u8", "dims": [307200], "unit": "id"},
    }},
    "RobotState": {"type_name": "vpsom::RobotState", "size": 104, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "nav_goal_id": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "base_pose": {"offset": 32, "size": 12, "type": "f32", "dims": [3], "unit": "m,m,rad"},
        "neck_yaw": {"offset": 44, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "neck_pitch": {"offset": 48, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "odom_cov": {"offset": 52, "size": 36, "type": "f32", "dims": [9], "unit": "cov(m,m,rad)"},
        "speed": {"offset": 88, "size": 4, "type": "f32", "dims": [], "unit": "m/s"},
        "distance_m": {"offset": 92, "size": 4, "type": "f32", "dims": [], "unit": "m"},
        "localization_ok": {"offset": 96, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "nav_status": {"offset": 97, "size": 1, "type": "u8", "dims": [], "unit": "enum nav_status"},
        "reserved": {"offset": 98, "size": 2, "type": "u8", "dims": [2], "unit": "pad"},
        "localization_failures": {"offset": 100, "size": 4, "type": "u32", "dims": [], "unit": "count"},
    }},
    "MapObject": {"type_name": "vpsom::MapObject", "size": 5512, "align": 8, "fields": {
        "first_seen_ns": {"offset": 0, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "id": {"offset": 8, "size": 4, "type": "u32", "dims": [], "unit": "id"},
        "class_id": {"offset": 12, "size": 2, "type": "u16", "dims": [], "unit": "id"},
        "background": {"offset": 14, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "complete": {"offset": 15, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "center": {"offset": 16, "size": 12, "type": "f32", "dims": [3], "unit": "m"},
        "size": {"offset": 28, "size": 12, "type": "f32", "dims": [3], "unit": "m"},
        "yaw": {"offset": 40, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "point_count": {"offset": 44, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "cluster_id": {"offset": 48, "size": 4, "type": "i32", "dims": [], "unit": "id"},
        "observations": {"offset": 52, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "h_sopm": {"offset": 56, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "c_asso": {"offset": 60, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "l_best": {"offset": 64, "size": 12, "type": "f32", "dims": [3], "unit": "m"},
        "sopm_shape": {"offset": 76, "size": 1, "type": "u8", "dims": [], "unit": "enum sopm_shape"},
        "reserved": {"offset": 77, "size": 1, "type": "u8", "dims": [], "unit": "pad"},
        "sopm_cols": {"offset": 78, "size": 2, "type": "u16", "dims": [], "unit": "count"},
        "sopm_rows": {"offset": 80, "size": 2, "type": "u16", "dims": [], "unit": "count"},
        "sample_count": {"offset": 82, "size": 2, "type": "u16", "dims": [], "unit": "count"},
        "sopm_prob": {"offset": 84, "size": 2592, "type": "f32", "dims": [648], "unit": "1"},
        "sopm_obs": {"offset": 2676, "size": 1296, "type": "u16", "dims": [648], "unit": "count"},
        "points": {"offset": 3972, "size": 768, "type": "f32", "dims": [64, 3], "unit": "m"},
        "point_los": {"offset": 4740, "size": 768, "type": "f32", "dims": [64, 3], "unit": "1"},
        "support_height": {"offset": 5508, "size": 4, "type": "f32", "dims": [], "unit": "m"},
    }},
    "FrameReceipt": {"type_name": "vpsom::FrameReceipt", "size": 24, "align": 8, "fields": {
        "frame_seq": {"offset": 0, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "state_seq": {"offset": 8, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "outcome": {"offset": 16, "size": 4, "type": "u32", "dims": [], "unit": "enum frame_outcome"},
        "reserved": {"offset": 20, "size": 4, "type": "u32", "dims": [], "unit": "pad"},
    }},
    "ObjectMap": {"type_name": "vpsom::ObjectMap", "size": 705984, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "last_frame_seq": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "last_frame_stamp_ns": {"offset": 32, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "count": {"offset": 40, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "eps_sopm": {"offset": 44, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "frames_integrated": {"offset": 48, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "frames_rejected": {"offset": 52, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "frames_unmatched": {"offset": 56, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "receipt_count": {"offset": 60, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "objects": {"offset": 64, "size": 705536, "type": "MapObject", "dims": [128], "unit": "struct"},
        "receipts": {"offset": 705600, "size": 384, "type": "FrameReceipt", "dims": [16], "unit": "struct"},
    }},
    "OccupancyGrid": {"type_name": "vpsom::OccupancyGrid", "size": 65584, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "origin": {"offset": 24, "size": 8, "type": "f32", "dims": [2], "unit": "m"},
        "resolution": {"offset": 32, "size": 4, "type": "f32", "dims": [], "unit": "m"},
        "width": {"offset": 36, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "height": {"offset": 40, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "reserved": {"offset": 44, "size": 4, "type": "u32", "dims": [], "unit": "pad"},
        "cells": {"offset": 48, "size": 65536, "type": "u8", "dims": [65536], "unit": "enum grid_cell"},
    }},
    "NavGoal": {"type_name": "vpsom::NavGoal", "size": 56, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "goal_id": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "pose": {"offset": 32, "size": 12, "type": "f32", "dims": [3], "unit": "m,m,rad"},
        "score": {"offset": 44, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "cluster_id": {"offset": 48, "size": 4, "type": "i32", "dims": [], "unit": "id"},
        "kind": {"offset": 52, "size": 1, "type": "u8", "dims": [], "unit": "enum goal_kind"},
        "reserved": {"offset": 53, "size": 3, "type": "u8", "dims": [3], "unit": "pad"},
    }},
    "NeckGoal": {"type_name": "vpsom::NeckGoal", "size": 80, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "map_seq": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "frame_stamp_ns": {"offset": 32, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "yaw": {"offset": 40, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "pitch": {"offset": 44, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "score": {"offset": 48, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "round_done": {"offset": 52, "size": 4, "type": "u32", "dims": [], "unit": "bool"},
        "state_seq": {"offset": 56, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "nav_seq": {"offset": 64, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "explore_seq": {"offset": 72, "size": 8, "type": "u64", "dims": [], "unit": "id"},
    }},
    "DeadlineEvent": {"type_name": "vpsom::DeadlineEvent", "size": 120, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "cycle": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "period_ns": {"offset": 32, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "budget_ns": {"offset": 40, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "lateness_ns": {"offset": 48, "size": 8, "type": "i64", "dims": [], "unit": "ns"},
        "exec_ns": {"offset": 56, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "cpu_ns": {"offset": 64, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "run_wait_ns": {"offset": 72, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "consecutive_misses": {"offset": 80, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "missed": {"offset": 84, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "miss_cause": {"offset": 85, "size": 1, "type": "u8", "dims": [], "unit": "enum miss_cause"},
        "sched_stats": {"offset": 86, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "backup_wake": {"offset": 87, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "thread": {"offset": 88, "size": 32, "type": "u8", "dims": [32], "unit": "utf8"},
    }},
    "Candidate": {"type_name": "vpsom::Candidate", "size": 60, "align": 4, "fields": {
        "position": {"offset": 0, "size": 12, "type": "f32", "dims": [3], "unit": "m"},
        "yaw": {"offset": 12, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "pitch": {"offset": 16, "size": 4, "type": "f32", "dims": [], "unit": "rad"},
        "value": {"offset": 20, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "f_a": {"offset": 24, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "f_c": {"offset": 28, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "h_sopm": {"offset": 32, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "h_iou": {"offset": 36, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "cos_theta_sopm": {"offset": 40, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "c_asso": {"offset": 44, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "n_cp": {"offset": 48, "size": 4, "type": "f32", "dims": [], "unit": "count"},
        "cos_theta_c": {"offset": 52, "size": 4, "type": "f32", "dims": [], "unit": "1"},
        "objects_in_view": {"offset": 56, "size": 2, "type": "u16", "dims": [], "unit": "count"},
        "chosen": {"offset": 58, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "dropped": {"offset": 59, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
    }},
    "PlannerDecision": {"type_name": "vpsom::PlannerDecision", "size": 3896, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "map_seq": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "eval_ns": {"offset": 32, "size": 8, "type": "u64", "dims": [], "unit": "ns"},
        "cluster_id": {"offset": 40, "size": 4, "type": "i32", "dims": [], "unit": "id"},
        "count": {"offset": 44, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "evaluated": {"offset": 48, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "kind": {"offset": 52, "size": 1, "type": "u8", "dims": [], "unit": "enum decision_kind"},
        "state": {"offset": 53, "size": 1, "type": "u8", "dims": [], "unit": "enum planner_state"},
        "reserved": {"offset": 54, "size": 2, "type": "u8", "dims": [2], "unit": "pad"},
        "candidates": {"offset": 56, "size": 3840, "type": "Candidate", "dims": [64], "unit": "struct"},
    }},
    "ObjectVisibility": {"type_name": "vpsom::ObjectVisibility", "size": 32, "align": 4, "fields": {
        "object": {"offset": 0, "size": 4, "type": "u32", "dims": [], "unit": "id"},
        "visible_px": {"offset": 4, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "silhouette_px": {"offset": 8, "size": 4, "type": "u32", "dims": [], "unit": "px"},
        "truncated": {"offset": 12, "size": 1, "type": "u8", "dims": [], "unit": "bool"},
        "reserved": {"offset": 13, "size": 3, "type": "u8", "dims": [3], "unit": "pad"},
        "bbox": {"offset": 16, "size": 16, "type": "f32", "dims": [4], "unit": "px"},
    }},
    "FrameVisibility": {"type_name": "vpsom::FrameVisibility", "size": 4136, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "frame_seq": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "id"},
        "count": {"offset": 32, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "reserved": {"offset": 36, "size": 4, "type": "u32", "dims": [], "unit": "pad"},
        "items": {"offset": 40, "size": 4096, "type": "ObjectVisibility", "dims": [128], "unit": "struct"},
    }},
    "InputHealth": {"type_name": "vpsom::InputHealth", "size": 56, "align": 8, "fields": {
        "received": {"offset": 0, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "invalid": {"offset": 8, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "overflow": {"offset": 16, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "topic": {"offset": 24, "size": 32, "type": "u8", "dims": [32], "unit": "utf8"},
    }},
    "NodeHealth": {"type_name": "vpsom::NodeHealth", "size": 952, "align": 8, "fields": {
        "header": {"offset": 0, "size": 24, "type": "Header", "dims": [], "unit": "struct"},
        "steps": {"offset": 24, "size": 8, "type": "u64", "dims": [], "unit": "count"},
        "pid": {"offset": 32, "size": 4, "type": "u32", "dims": [], "unit": "id"},
        "count": {"offset": 36, "size": 4, "type": "u32", "dims": [], "unit": "count"},
        "node": {"offset": 40, "size": 16, "type": "u8", "dims": [16], "unit": "utf8"},
        "inputs": {"offset": 56, "size": 896, "type": "InputHealth", "dims": [16], "unit": "struct"},
    }},
}
