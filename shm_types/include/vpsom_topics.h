/* vpsom_topics.h: the vpsom-rt topic contract, for C11 and C++17 publishers and
 * subscribers of a run's iceoryx2 (0.10) publish-subscribe services.
 *
 * GENERATED from the Rust types by shm_types/src/contract; do not edit. Regenerate with
 *     UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract
 *
 * A service is VPSOM_SERVICE(namespace, VPSOM_TOPIC_...): "vpsom/<namespace>/<topic>".
 * Its payload type details must be: variant FixedSize, type name VPSOM_TYPE_NAME_...
 * (C++: the struct's IOX2_TYPE_NAME), size sizeof(vpsom_...), alignment
 * VPSOM_ALIGNOF(vpsom_...); no user header (iceoryx2: "()", size 0, alignment 1).
 * After each send, notify the event service of the same name (subscribers block on it).
 * Units: m, rad, ns, mm, px; "1" = dimensionless; world frame x forward, y left, z up;
 * camera frame = OpenCV optical (x right, y down, z forward); quaternions [x, y, z, w].
 */
#pragma once

#include <stddef.h>
#include <stdint.h>

#if defined(__cplusplus)
#define VPSOM_STATIC_ASSERT(cond, msg) static_assert(cond, msg)
#define VPSOM_ALIGNOF(type) alignof(type)
#else
#define VPSOM_STATIC_ASSERT(cond, msg) _Static_assert(cond, msg)
#define VPSOM_ALIGNOF(type) _Alignof(type)
#endif

/* ---- services ---- */
#define VPSOM_SERVICE_ROOT "vpsom"
/* Full service name; namespace and topic are string literals. */
#define VPSOM_SERVICE(namespace, topic) VPSOM_SERVICE_ROOT "/" namespace "/" topic
#define VPSOM_USER_HEADER_TYPE_NAME "()"
/* iceoryx2 global.root-path and global.prefix of a run: printf formats of the uid. */
#define VPSOM_IOX2_ROOT_FMT "/tmp/vpsom-iox2-u%u/"
#define VPSOM_IOX2_PREFIX_FMT "vpsom_u%u_"
#define VPSOM_TOPIC_DEPTH             "depth" /* vpsom_DepthFrame (vpsom::DepthFrame); from sim (robot: depth camera driver): depth image, u16 mm, with intrinsics and the estimated world_from_camera pose */
#define VPSOM_TOPIC_DETECTIONS        "detections" /* vpsom_Detections (vpsom::Detections); from sim (robot: object detector): detections of one depth frame (frame_seq = that frame's header.seq) */
#define VPSOM_TOPIC_ROBOT_STATE       "robot/state" /* vpsom_RobotState (vpsom::RobotState); from sim (robot: base controller + localization): estimated base pose, neck angles, odometry covariance, navigation status */
#define VPSOM_TOPIC_SIM_TRUTH         "sim/truth" /* vpsom_RobotState (vpsom::RobotState); from sim only: true robot state (evaluation and recording; absent on a robot) */
#define VPSOM_TOPIC_SIM_VISIBILITY    "sim/visibility" /* vpsom_FrameVisibility (vpsom::FrameVisibility); from sim only: ground-truth visibility per rendered frame (evaluation; absent on a robot) */
#define VPSOM_TOPIC_NAV_GRID          "nav/grid" /* vpsom_OccupancyGrid (vpsom::OccupancyGrid); from sim (robot: navigation stack): navigation occupancy grid (obstacles only) */
#define VPSOM_TOPIC_MAP               "map" /* vpsom_ObjectMap (vpsom::ObjectMap); from mapper: sparse object map */
#define VPSOM_TOPIC_MAP_RESUME        "map/resume" /* vpsom_ObjectMap (vpsom::ObjectMap); from launcher: the newest map, handed to a restarted mapper (history 1) */
#define VPSOM_TOPIC_MAP_GRID          "map/grid" /* vpsom_OccupancyGrid (vpsom::OccupancyGrid); from mapper: exploration grid built from depth (with unknown cells) */
#define VPSOM_TOPIC_NAV_GOAL          "nav/goal" /* vpsom_NavGoal (vpsom::NavGoal); from planner: chassis goal (consumed by the base controller) */
#define VPSOM_TOPIC_NECK_GOAL         "neck/goal" /* vpsom_NeckGoal (vpsom::NeckGoal); from planner: neck goal relative to the base (consumed by the neck controller) */
#define VPSOM_TOPIC_PLANNER_DECISION  "planner/decision" /* vpsom_PlannerDecision (vpsom::PlannerDecision); from planner: evaluated candidates of each GBV round and LBV cycle */
#define VPSOM_TOPIC_DEADLINE          "deadline" /* vpsom_DeadlineEvent (vpsom::DeadlineEvent); from planner (real-time threads): one record per periodic executor cycle */
#define VPSOM_TOPIC_HEALTH            "health" /* vpsom_NodeHealth (vpsom::NodeHealth); from every node host (a few Hz): heartbeat and per-input received / invalid / overflow counts (the launcher's liveness check) */

/* ---- iceoryx2 payload type names ---- */
#define VPSOM_TYPE_NAME_HEADER             "vpsom::Header"
#define VPSOM_TYPE_NAME_POSE3              "vpsom::Pose3"
#define VPSOM_TYPE_NAME_INTRINSICS         "vpsom::Intrinsics"
#define VPSOM_TYPE_NAME_DEPTH_FRAME        "vpsom::DepthFrame"
#define VPSOM_TYPE_NAME_DETECTION          "vpsom::Detection"
#define VPSOM_TYPE_NAME_DETECTIONS         "vpsom::Detections"
#define VPSOM_TYPE_NAME_ROBOT_STATE        "vpsom::RobotState"
#define VPSOM_TYPE_NAME_MAP_OBJECT         "vpsom::MapObject"
#define VPSOM_TYPE_NAME_FRAME_RECEIPT      "vpsom::FrameReceipt"
#define VPSOM_TYPE_NAME_OBJECT_MAP         "vpsom::ObjectMap"
#define VPSOM_TYPE_NAME_OCCUPANCY_GRID     "vpsom::OccupancyGrid"
#define VPSOM_TYPE_NAME_NAV_GOAL           "vpsom::NavGoal"
#define VPSOM_TYPE_NAME_NECK_GOAL          "vpsom::NeckGoal"
#define VPSOM_TYPE_NAME_DEADLINE_EVENT     "vpsom::DeadlineEvent"
#define VPSOM_TYPE_NAME_CANDIDATE          "vpsom::Candidate"
#define VPSOM_TYPE_NAME_PLANNER_DECISION   "vpsom::PlannerDecision"
#define VPSOM_TYPE_NAME_OBJECT_VISIBILITY  "vpsom::ObjectVisibility"
#define VPSOM_TYPE_NAME_FRAME_VISIBILITY   "vpsom::FrameVisibility"
#define VPSOM_TYPE_NAME_INPUT_HEALTH       "vpsom::InputHealth"
#define VPSOM_TYPE_NAME_NODE_HEALTH        "vpsom::NodeHealth"

/* ---- capacities and enum values ---- */
#define VPSOM_MAX_WIDTH                    640
#define VPSOM_MAX_HEIGHT                   480
#define VPSOM_MAX_PIXELS                   307200
#define VPSOM_MAX_DETECTIONS               64
#define VPSOM_MAX_OBJECTS                  128
#define VPSOM_MAX_SOPM_CELLS               648
#define VPSOM_MAX_OBJECT_POINTS            64
#define VPSOM_MAX_GRID_CELLS               65536
#define VPSOM_MAX_CANDIDATES               64
#define VPSOM_MAX_FRAME_RECEIPTS           16
#define VPSOM_THREAD_NAME_LEN              32
#define VPSOM_MAX_HEALTH_INPUTS            16
#define VPSOM_HEALTH_TOPIC_LEN             32
#define VPSOM_HEALTH_NODE_LEN              16
#define VPSOM_COCO_CLASS_COUNT             80
#define VPSOM_MASK_MODE_BOXES              0
#define VPSOM_MASK_MODE_MASKS              1
#define VPSOM_NAV_STATUS_IDLE              0
#define VPSOM_NAV_STATUS_MOVING            1
#define VPSOM_NAV_STATUS_REACHED           2
#define VPSOM_NAV_STATUS_UNREACHABLE       3
#define VPSOM_SOPM_SHAPE_CYLINDER          0
#define VPSOM_SOPM_SHAPE_HEMISPHERE        1
#define VPSOM_SOPM_SHAPE_SPHERE            2
#define VPSOM_GRID_CELL_FREE               0
#define VPSOM_GRID_CELL_OCCUPIED           100
#define VPSOM_GRID_CELL_UNKNOWN            255
#define VPSOM_GOAL_KIND_GBV                0
#define VPSOM_GOAL_KIND_COVERAGE           1
#define VPSOM_GOAL_KIND_FRONTIER           2
#define VPSOM_GOAL_KIND_RECOVERY           3
#define VPSOM_MISS_CAUSE_NONE              0
#define VPSOM_MISS_CAUSE_EXECUTION         1
#define VPSOM_MISS_CAUSE_RUN_QUEUE         2
#define VPSOM_MISS_CAUSE_LATE_WAKEUP       3
#define VPSOM_MISS_CAUSE_BLOCKED           4
#define VPSOM_MISS_CAUSE_UNKNOWN           5
#define VPSOM_DECISION_KIND_GBV            0
#define VPSOM_DECISION_KIND_LBV            1
#define VPSOM_PLANNER_STATE_RUNNING        0
#define VPSOM_PLANNER_STATE_TERMINATED     1
#define VPSOM_PLANNER_STATE_NO_CANDIDATES  2
#define VPSOM_FRAME_OUTCOME_INTEGRATED     0
#define VPSOM_FRAME_OUTCOME_SKIPPED_LOST   1
#define VPSOM_FRAME_OUTCOME_NO_DETECTIONS  2
#define VPSOM_FRAME_OUTCOME_REFUSED        3
/* COCO class names by class id: static const char *names[] = VPSOM_COCO_CLASSES; */
#define VPSOM_COCO_CLASSES { \
    "person", "bicycle", "car", "motorcycle", "airplane", "bus", \
    "train", "truck", "boat", "traffic light", "fire hydrant", "stop sign", \
    "parking meter", "bench", "bird", "cat", "dog", "horse", \
    "sheep", "cow", "elephant", "bear", "zebra", "giraffe", \
    "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee", \
    "skis", "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", \
    "skateboard", "surfboard", "tennis racket", "bottle", "wine glass", "cup", \
    "fork", "knife", "spoon", "bowl", "banana", "apple", \
    "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", \
    "donut", "cake", "chair", "couch", "potted plant", "bed", \
    "dining table", "toilet", "tv", "laptop", "mouse", "remote", \
    "keyboard", "cell phone", "microwave", "oven", "toaster", "sink", \
    "refrigerator", "book", "clock", "vase", "scissors", "teddy bear", \
    "hair drier", "toothbrush", \
}

/* ---- layouts ---- */
/* vpsom::Header: 24 bytes, alignment 8 */
typedef struct vpsom_Header {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Header";
#endif
    uint64_t seq;                            /* offset 0, count */
    uint64_t stamp_ns;                       /* offset 8, ns */
    uint64_t sim_time_ns;                    /* offset 16, ns */
} vpsom_Header;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Header) == 24, "vpsom_Header: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Header) == 8, "vpsom_Header: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Header, seq) == 0, "vpsom_Header.seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Header, stamp_ns) == 8, "vpsom_Header.stamp_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Header, sim_time_ns) == 16, "vpsom_Header.sim_time_ns: offset");

/* vpsom::Pose3: 28 bytes, alignment 4 */
typedef struct vpsom_Pose3 {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Pose3";
#endif
    float translation[3];                    /* offset 0, m */
    float rotation[4];                       /* offset 12, 1 */
} vpsom_Pose3;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Pose3) == 28, "vpsom_Pose3: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Pose3) == 4, "vpsom_Pose3: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Pose3, translation) == 0, "vpsom_Pose3.translation: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Pose3, rotation) == 12, "vpsom_Pose3.rotation: offset");

/* vpsom::Intrinsics: 24 bytes, alignment 4 */
typedef struct vpsom_Intrinsics {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Intrinsics";
#endif
    float fx;                                /* offset 0, px */
    float fy;                                /* offset 4, px */
    float cx;                                /* offset 8, px */
    float cy;                                /* offset 12, px */
    float min_range;                         /* offset 16, m */
    float max_range;                         /* offset 20, m */
} vpsom_Intrinsics;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Intrinsics) == 24, "vpsom_Intrinsics: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Intrinsics) == 4, "vpsom_Intrinsics: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, fx) == 0, "vpsom_Intrinsics.fx: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, fy) == 4, "vpsom_Intrinsics.fy: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, cx) == 8, "vpsom_Intrinsics.cx: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, cy) == 12, "vpsom_Intrinsics.cy: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, min_range) == 16, "vpsom_Intrinsics.min_range: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Intrinsics, max_range) == 20, "vpsom_Intrinsics.max_range: offset");

/* vpsom::DepthFrame: 614488 bytes, alignment 8 */
typedef struct vpsom_DepthFrame {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::DepthFrame";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint32_t width;                          /* offset 24, px */
    uint32_t height;                         /* offset 28, px */
    vpsom_Intrinsics intrinsics;             /* offset 32, struct */
    vpsom_Pose3 camera_pose;                 /* offset 56, struct */
    uint32_t reserved;                       /* offset 84, pad */
    uint16_t depth_mm[307200];               /* offset 88, mm */
} vpsom_DepthFrame;
VPSOM_STATIC_ASSERT(sizeof(vpsom_DepthFrame) == 614488, "vpsom_DepthFrame: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_DepthFrame) == 8, "vpsom_DepthFrame: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, header) == 0, "vpsom_DepthFrame.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, width) == 24, "vpsom_DepthFrame.width: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, height) == 28, "vpsom_DepthFrame.height: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, intrinsics) == 32, "vpsom_DepthFrame.intrinsics: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, camera_pose) == 56, "vpsom_DepthFrame.camera_pose: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, reserved) == 84, "vpsom_DepthFrame.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DepthFrame, depth_mm) == 88, "vpsom_DepthFrame.depth_mm: offset");

/* vpsom::Detection: 20 bytes, alignment 4 */
typedef struct vpsom_Detection {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Detection";
#endif
    uint16_t class_id;                       /* offset 0, id */
    uint16_t label;                          /* offset 2, id */
    float score;                             /* offset 4, 1 */
    uint16_t bbox[4];                        /* offset 8, px */
    uint32_t mask_pixels;                    /* offset 16, count */
} vpsom_Detection;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Detection) == 20, "vpsom_Detection: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Detection) == 4, "vpsom_Detection: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detection, class_id) == 0, "vpsom_Detection.class_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detection, label) == 2, "vpsom_Detection.label: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detection, score) == 4, "vpsom_Detection.score: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detection, bbox) == 8, "vpsom_Detection.bbox: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detection, mask_pixels) == 16, "vpsom_Detection.mask_pixels: offset");

/* vpsom::Detections: 308528 bytes, alignment 8 */
typedef struct vpsom_Detections {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Detections";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t frame_seq;                      /* offset 24, id */
    uint32_t width;                          /* offset 32, px */
    uint32_t height;                         /* offset 36, px */
    uint32_t count;                          /* offset 40, count */
    uint32_t masks;                          /* offset 44, enum mask_mode */
    vpsom_Detection items[64];               /* offset 48, struct */
    uint8_t labels[307200];                  /* offset 1328, id */
} vpsom_Detections;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Detections) == 308528, "vpsom_Detections: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Detections) == 8, "vpsom_Detections: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, header) == 0, "vpsom_Detections.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, frame_seq) == 24, "vpsom_Detections.frame_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, width) == 32, "vpsom_Detections.width: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, height) == 36, "vpsom_Detections.height: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, count) == 40, "vpsom_Detections.count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, masks) == 44, "vpsom_Detections.masks: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, items) == 48, "vpsom_Detections.items: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Detections, labels) == 1328, "vpsom_Detections.labels: offset");

/* vpsom::RobotState: 104 bytes, alignment 8 */
typedef struct vpsom_RobotState {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::RobotState";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t nav_goal_id;                    /* offset 24, id */
    float base_pose[3];                      /* offset 32, m,m,rad */
    float neck_yaw;                          /* offset 44, rad */
    float neck_pitch;                        /* offset 48, rad */
    float odom_cov[9];                       /* offset 52, cov(m,m,rad) */
    float speed;                             /* offset 88, m/s */
    float distance_m;                        /* offset 92, m */
    uint8_t localization_ok;                 /* offset 96, bool */
    uint8_t nav_status;                      /* offset 97, enum nav_status */
    uint8_t reserved[2];                     /* offset 98, pad */
    uint32_t localization_failures;          /* offset 100, count */
} vpsom_RobotState;
VPSOM_STATIC_ASSERT(sizeof(vpsom_RobotState) == 104, "vpsom_RobotState: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_RobotState) == 8, "vpsom_RobotState: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, header) == 0, "vpsom_RobotState.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, nav_goal_id) == 24, "vpsom_RobotState.nav_goal_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, base_pose) == 32, "vpsom_RobotState.base_pose: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, neck_yaw) == 44, "vpsom_RobotState.neck_yaw: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, neck_pitch) == 48, "vpsom_RobotState.neck_pitch: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, odom_cov) == 52, "vpsom_RobotState.odom_cov: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, speed) == 88, "vpsom_RobotState.speed: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, distance_m) == 92, "vpsom_RobotState.distance_m: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, localization_ok) == 96, "vpsom_RobotState.localization_ok: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, nav_status) == 97, "vpsom_RobotState.nav_status: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, reserved) == 98, "vpsom_RobotState.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_RobotState, localization_failures) == 100, "vpsom_RobotState.localization_failures: offset");

/* vpsom::MapObject: 5512 bytes, alignment 8 */
typedef struct vpsom_MapObject {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::MapObject";
#endif
    uint64_t first_seen_ns;                  /* offset 0, ns */
    uint32_t id;                             /* offset 8, id */
    uint16_t class_id;                       /* offset 12, id */
    uint8_t background;                      /* offset 14, bool */
    uint8_t complete;                        /* offset 15, bool */
    float center[3];                         /* offset 16, m */
    float size[3];                           /* offset 28, m */
    float yaw;                               /* offset 40, rad */
    uint32_t point_count;                    /* offset 44, count */
    int32_t cluster_id;                      /* offset 48, id */
    uint32_t observations;                   /* offset 52, count */
    float h_sopm;                            /* offset 56, 1 */
    float c_asso;                            /* offset 60, 1 */
    float l_best[3];                         /* offset 64, m */
    uint8_t sopm_shape;                      /* offset 76, enum sopm_shape */
    uint8_t reserved;                        /* offset 77, pad */
    uint16_t sopm_cols;                      /* offset 78, count */
    uint16_t sopm_rows;                      /* offset 80, count */
    uint16_t sample_count;                   /* offset 82, count */
    float sopm_prob[648];                    /* offset 84, 1 */
    uint16_t sopm_obs[648];                  /* offset 2676, count */
    float points[64][3];                     /* offset 3972, m */
    float point_los[64][3];                  /* offset 4740, 1 */
    float support_height;                    /* offset 5508, m */
} vpsom_MapObject;
VPSOM_STATIC_ASSERT(sizeof(vpsom_MapObject) == 5512, "vpsom_MapObject: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_MapObject) == 8, "vpsom_MapObject: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, first_seen_ns) == 0, "vpsom_MapObject.first_seen_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, id) == 8, "vpsom_MapObject.id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, class_id) == 12, "vpsom_MapObject.class_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, background) == 14, "vpsom_MapObject.background: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, complete) == 15, "vpsom_MapObject.complete: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, center) == 16, "vpsom_MapObject.center: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, size) == 28, "vpsom_MapObject.size: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, yaw) == 40, "vpsom_MapObject.yaw: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, point_count) == 44, "vpsom_MapObject.point_count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, cluster_id) == 48, "vpsom_MapObject.cluster_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, observations) == 52, "vpsom_MapObject.observations: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, h_sopm) == 56, "vpsom_MapObject.h_sopm: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, c_asso) == 60, "vpsom_MapObject.c_asso: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, l_best) == 64, "vpsom_MapObject.l_best: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sopm_shape) == 76, "vpsom_MapObject.sopm_shape: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, reserved) == 77, "vpsom_MapObject.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sopm_cols) == 78, "vpsom_MapObject.sopm_cols: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sopm_rows) == 80, "vpsom_MapObject.sopm_rows: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sample_count) == 82, "vpsom_MapObject.sample_count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sopm_prob) == 84, "vpsom_MapObject.sopm_prob: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, sopm_obs) == 2676, "vpsom_MapObject.sopm_obs: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, points) == 3972, "vpsom_MapObject.points: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, point_los) == 4740, "vpsom_MapObject.point_los: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_MapObject, support_height) == 5508, "vpsom_MapObject.support_height: offset");

/* vpsom::FrameReceipt: 24 bytes, alignment 8 */
typedef struct vpsom_FrameReceipt {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::FrameReceipt";
#endif
    uint64_t frame_seq;                      /* offset 0, id */
    uint64_t state_seq;                      /* offset 8, id */
    uint32_t outcome;                        /* offset 16, enum frame_outcome */
    uint32_t reserved;                       /* offset 20, pad */
} vpsom_FrameReceipt;
VPSOM_STATIC_ASSERT(sizeof(vpsom_FrameReceipt) == 24, "vpsom_FrameReceipt: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_FrameReceipt) == 8, "vpsom_FrameReceipt: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameReceipt, frame_seq) == 0, "vpsom_FrameReceipt.frame_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameReceipt, state_seq) == 8, "vpsom_FrameReceipt.state_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameReceipt, outcome) == 16, "vpsom_FrameReceipt.outcome: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameReceipt, reserved) == 20, "vpsom_FrameReceipt.reserved: offset");

/* vpsom::ObjectMap: 705984 bytes, alignment 8 */
typedef struct vpsom_ObjectMap {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::ObjectMap";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t last_frame_seq;                 /* offset 24, id */
    uint64_t last_frame_stamp_ns;            /* offset 32, ns */
    uint32_t count;                          /* offset 40, count */
    float eps_sopm;                          /* offset 44, 1 */
    uint32_t frames_integrated;              /* offset 48, count */
    uint32_t frames_rejected;                /* offset 52, count */
    uint32_t frames_unmatched;               /* offset 56, count */
    uint32_t receipt_count;                  /* offset 60, count */
    vpsom_MapObject objects[128];            /* offset 64, struct */
    vpsom_FrameReceipt receipts[16];         /* offset 705600, struct */
} vpsom_ObjectMap;
VPSOM_STATIC_ASSERT(sizeof(vpsom_ObjectMap) == 705984, "vpsom_ObjectMap: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_ObjectMap) == 8, "vpsom_ObjectMap: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, header) == 0, "vpsom_ObjectMap.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, last_frame_seq) == 24, "vpsom_ObjectMap.last_frame_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, last_frame_stamp_ns) == 32, "vpsom_ObjectMap.last_frame_stamp_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, count) == 40, "vpsom_ObjectMap.count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, eps_sopm) == 44, "vpsom_ObjectMap.eps_sopm: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, frames_integrated) == 48, "vpsom_ObjectMap.frames_integrated: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, frames_rejected) == 52, "vpsom_ObjectMap.frames_rejected: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, frames_unmatched) == 56, "vpsom_ObjectMap.frames_unmatched: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, receipt_count) == 60, "vpsom_ObjectMap.receipt_count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, objects) == 64, "vpsom_ObjectMap.objects: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectMap, receipts) == 705600, "vpsom_ObjectMap.receipts: offset");

/* vpsom::OccupancyGrid: 65584 bytes, alignment 8 */
typedef struct vpsom_OccupancyGrid {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::OccupancyGrid";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    float origin[2];                         /* offset 24, m */
    float resolution;                        /* offset 32, m */
    uint32_t width;                          /* offset 36, count */
    uint32_t height;                         /* offset 40, count */
    uint32_t reserved;                       /* offset 44, pad */
    uint8_t cells[65536];                    /* offset 48, enum grid_cell */
} vpsom_OccupancyGrid;
VPSOM_STATIC_ASSERT(sizeof(vpsom_OccupancyGrid) == 65584, "vpsom_OccupancyGrid: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_OccupancyGrid) == 8, "vpsom_OccupancyGrid: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, header) == 0, "vpsom_OccupancyGrid.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, origin) == 24, "vpsom_OccupancyGrid.origin: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, resolution) == 32, "vpsom_OccupancyGrid.resolution: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, width) == 36, "vpsom_OccupancyGrid.width: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, height) == 40, "vpsom_OccupancyGrid.height: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, reserved) == 44, "vpsom_OccupancyGrid.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_OccupancyGrid, cells) == 48, "vpsom_OccupancyGrid.cells: offset");

/* vpsom::NavGoal: 56 bytes, alignment 8 */
typedef struct vpsom_NavGoal {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::NavGoal";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t goal_id;                        /* offset 24, id */
    float pose[3];                           /* offset 32, m,m,rad */
    float score;                             /* offset 44, 1 */
    int32_t cluster_id;                      /* offset 48, id */
    uint8_t kind;                            /* offset 52, enum goal_kind */
    uint8_t reserved[3];                     /* offset 53, pad */
} vpsom_NavGoal;
VPSOM_STATIC_ASSERT(sizeof(vpsom_NavGoal) == 56, "vpsom_NavGoal: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_NavGoal) == 8, "vpsom_NavGoal: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, header) == 0, "vpsom_NavGoal.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, goal_id) == 24, "vpsom_NavGoal.goal_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, pose) == 32, "vpsom_NavGoal.pose: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, score) == 44, "vpsom_NavGoal.score: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, cluster_id) == 48, "vpsom_NavGoal.cluster_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, kind) == 52, "vpsom_NavGoal.kind: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NavGoal, reserved) == 53, "vpsom_NavGoal.reserved: offset");

/* vpsom::NeckGoal: 80 bytes, alignment 8 */
typedef struct vpsom_NeckGoal {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::NeckGoal";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t map_seq;                        /* offset 24, id */
    uint64_t frame_stamp_ns;                 /* offset 32, ns */
    float yaw;                               /* offset 40, rad */
    float pitch;                             /* offset 44, rad */
    float score;                             /* offset 48, 1 */
    uint32_t round_done;                     /* offset 52, bool */
    uint64_t state_seq;                      /* offset 56, id */
    uint64_t nav_seq;                        /* offset 64, id */
    uint64_t explore_seq;                    /* offset 72, id */
} vpsom_NeckGoal;
VPSOM_STATIC_ASSERT(sizeof(vpsom_NeckGoal) == 80, "vpsom_NeckGoal: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_NeckGoal) == 8, "vpsom_NeckGoal: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, header) == 0, "vpsom_NeckGoal.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, map_seq) == 24, "vpsom_NeckGoal.map_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, frame_stamp_ns) == 32, "vpsom_NeckGoal.frame_stamp_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, yaw) == 40, "vpsom_NeckGoal.yaw: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, pitch) == 44, "vpsom_NeckGoal.pitch: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, score) == 48, "vpsom_NeckGoal.score: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, round_done) == 52, "vpsom_NeckGoal.round_done: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, state_seq) == 56, "vpsom_NeckGoal.state_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, nav_seq) == 64, "vpsom_NeckGoal.nav_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NeckGoal, explore_seq) == 72, "vpsom_NeckGoal.explore_seq: offset");

/* vpsom::DeadlineEvent: 120 bytes, alignment 8 */
typedef struct vpsom_DeadlineEvent {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::DeadlineEvent";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t cycle;                          /* offset 24, count */
    uint64_t period_ns;                      /* offset 32, ns */
    uint64_t budget_ns;                      /* offset 40, ns */
    int64_t lateness_ns;                     /* offset 48, ns */
    uint64_t exec_ns;                        /* offset 56, ns */
    uint64_t cpu_ns;                         /* offset 64, ns */
    uint64_t run_wait_ns;                    /* offset 72, ns */
    uint32_t consecutive_misses;             /* offset 80, count */
    uint8_t missed;                          /* offset 84, bool */
    uint8_t miss_cause;                      /* offset 85, enum miss_cause */
    uint8_t sched_stats;                     /* offset 86, bool */
    uint8_t backup_wake;                     /* offset 87, bool */
    uint8_t thread[32];                      /* offset 88, utf8 */
} vpsom_DeadlineEvent;
VPSOM_STATIC_ASSERT(sizeof(vpsom_DeadlineEvent) == 120, "vpsom_DeadlineEvent: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_DeadlineEvent) == 8, "vpsom_DeadlineEvent: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, header) == 0, "vpsom_DeadlineEvent.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, cycle) == 24, "vpsom_DeadlineEvent.cycle: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, period_ns) == 32, "vpsom_DeadlineEvent.period_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, budget_ns) == 40, "vpsom_DeadlineEvent.budget_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, lateness_ns) == 48, "vpsom_DeadlineEvent.lateness_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, exec_ns) == 56, "vpsom_DeadlineEvent.exec_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, cpu_ns) == 64, "vpsom_DeadlineEvent.cpu_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, run_wait_ns) == 72, "vpsom_DeadlineEvent.run_wait_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, consecutive_misses) == 80, "vpsom_DeadlineEvent.consecutive_misses: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, missed) == 84, "vpsom_DeadlineEvent.missed: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, miss_cause) == 85, "vpsom_DeadlineEvent.miss_cause: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, sched_stats) == 86, "vpsom_DeadlineEvent.sched_stats: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, backup_wake) == 87, "vpsom_DeadlineEvent.backup_wake: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_DeadlineEvent, thread) == 88, "vpsom_DeadlineEvent.thread: offset");

/* vpsom::Candidate: 60 bytes, alignment 4 */
typedef struct vpsom_Candidate {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::Candidate";
#endif
    float position[3];                       /* offset 0, m */
    float yaw;                               /* offset 12, rad */
    float pitch;                             /* offset 16, rad */
    float value;                             /* offset 20, 1 */
    float f_a;                               /* offset 24, 1 */
    float f_c;                               /* offset 28, 1 */
    float h_sopm;                            /* offset 32, 1 */
    float h_iou;                             /* offset 36, 1 */
    float cos_theta_sopm;                    /* offset 40, 1 */
    float c_asso;                            /* offset 44, 1 */
    float n_cp;                              /* offset 48, count */
    float cos_theta_c;                       /* offset 52, 1 */
    uint16_t objects_in_view;                /* offset 56, count */
    uint8_t chosen;                          /* offset 58, bool */
    uint8_t dropped;                         /* offset 59, bool */
} vpsom_Candidate;
VPSOM_STATIC_ASSERT(sizeof(vpsom_Candidate) == 60, "vpsom_Candidate: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_Candidate) == 4, "vpsom_Candidate: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, position) == 0, "vpsom_Candidate.position: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, yaw) == 12, "vpsom_Candidate.yaw: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, pitch) == 16, "vpsom_Candidate.pitch: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, value) == 20, "vpsom_Candidate.value: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, f_a) == 24, "vpsom_Candidate.f_a: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, f_c) == 28, "vpsom_Candidate.f_c: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, h_sopm) == 32, "vpsom_Candidate.h_sopm: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, h_iou) == 36, "vpsom_Candidate.h_iou: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, cos_theta_sopm) == 40, "vpsom_Candidate.cos_theta_sopm: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, c_asso) == 44, "vpsom_Candidate.c_asso: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, n_cp) == 48, "vpsom_Candidate.n_cp: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, cos_theta_c) == 52, "vpsom_Candidate.cos_theta_c: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, objects_in_view) == 56, "vpsom_Candidate.objects_in_view: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, chosen) == 58, "vpsom_Candidate.chosen: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_Candidate, dropped) == 59, "vpsom_Candidate.dropped: offset");

/* vpsom::PlannerDecision: 3896 bytes, alignment 8 */
typedef struct vpsom_PlannerDecision {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::PlannerDecision";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t map_seq;                        /* offset 24, id */
    uint64_t eval_ns;                        /* offset 32, ns */
    int32_t cluster_id;                      /* offset 40, id */
    uint32_t count;                          /* offset 44, count */
    uint32_t evaluated;                      /* offset 48, count */
    uint8_t kind;                            /* offset 52, enum decision_kind */
    uint8_t state;                           /* offset 53, enum planner_state */
    uint8_t reserved[2];                     /* offset 54, pad */
    vpsom_Candidate candidates[64];          /* offset 56, struct */
} vpsom_PlannerDecision;
VPSOM_STATIC_ASSERT(sizeof(vpsom_PlannerDecision) == 3896, "vpsom_PlannerDecision: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_PlannerDecision) == 8, "vpsom_PlannerDecision: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, header) == 0, "vpsom_PlannerDecision.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, map_seq) == 24, "vpsom_PlannerDecision.map_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, eval_ns) == 32, "vpsom_PlannerDecision.eval_ns: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, cluster_id) == 40, "vpsom_PlannerDecision.cluster_id: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, count) == 44, "vpsom_PlannerDecision.count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, evaluated) == 48, "vpsom_PlannerDecision.evaluated: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, kind) == 52, "vpsom_PlannerDecision.kind: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, state) == 53, "vpsom_PlannerDecision.state: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, reserved) == 54, "vpsom_PlannerDecision.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_PlannerDecision, candidates) == 56, "vpsom_PlannerDecision.candidates: offset");

/* vpsom::ObjectVisibility: 32 bytes, alignment 4 */
typedef struct vpsom_ObjectVisibility {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::ObjectVisibility";
#endif
    uint32_t object;                         /* offset 0, id */
    uint32_t visible_px;                     /* offset 4, px */
    uint32_t silhouette_px;                  /* offset 8, px */
    uint8_t truncated;                       /* offset 12, bool */
    uint8_t reserved[3];                     /* offset 13, pad */
    float bbox[4];                           /* offset 16, px */
} vpsom_ObjectVisibility;
VPSOM_STATIC_ASSERT(sizeof(vpsom_ObjectVisibility) == 32, "vpsom_ObjectVisibility: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_ObjectVisibility) == 4, "vpsom_ObjectVisibility: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, object) == 0, "vpsom_ObjectVisibility.object: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, visible_px) == 4, "vpsom_ObjectVisibility.visible_px: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, silhouette_px) == 8, "vpsom_ObjectVisibility.silhouette_px: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, truncated) == 12, "vpsom_ObjectVisibility.truncated: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, reserved) == 13, "vpsom_ObjectVisibility.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_ObjectVisibility, bbox) == 16, "vpsom_ObjectVisibility.bbox: offset");

/* vpsom::FrameVisibility: 4136 bytes, alignment 8 */
typedef struct vpsom_FrameVisibility {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::FrameVisibility";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t frame_seq;                      /* offset 24, id */
    uint32_t count;                          /* offset 32, count */
    uint32_t reserved;                       /* offset 36, pad */
    vpsom_ObjectVisibility items[128];       /* offset 40, struct */
} vpsom_FrameVisibility;
VPSOM_STATIC_ASSERT(sizeof(vpsom_FrameVisibility) == 4136, "vpsom_FrameVisibility: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_FrameVisibility) == 8, "vpsom_FrameVisibility: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameVisibility, header) == 0, "vpsom_FrameVisibility.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameVisibility, frame_seq) == 24, "vpsom_FrameVisibility.frame_seq: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameVisibility, count) == 32, "vpsom_FrameVisibility.count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameVisibility, reserved) == 36, "vpsom_FrameVisibility.reserved: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_FrameVisibility, items) == 40, "vpsom_FrameVisibility.items: offset");

/* vpsom::InputHealth: 56 bytes, alignment 8 */
typedef struct vpsom_InputHealth {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::InputHealth";
#endif
    uint64_t received;                       /* offset 0, count */
    uint64_t invalid;                        /* offset 8, count */
    uint64_t overflow;                       /* offset 16, count */
    uint8_t topic[32];                       /* offset 24, utf8 */
} vpsom_InputHealth;
VPSOM_STATIC_ASSERT(sizeof(vpsom_InputHealth) == 56, "vpsom_InputHealth: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_InputHealth) == 8, "vpsom_InputHealth: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_InputHealth, received) == 0, "vpsom_InputHealth.received: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_InputHealth, invalid) == 8, "vpsom_InputHealth.invalid: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_InputHealth, overflow) == 16, "vpsom_InputHealth.overflow: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_InputHealth, topic) == 24, "vpsom_InputHealth.topic: offset");

/* vpsom::NodeHealth: 952 bytes, alignment 8 */
typedef struct vpsom_NodeHealth {
#ifdef __cplusplus
    static constexpr const char *IOX2_TYPE_NAME = "vpsom::NodeHealth";
#endif
    vpsom_Header header;                     /* offset 0, struct */
    uint64_t steps;                          /* offset 24, count */
    uint32_t pid;                            /* offset 32, id */
    uint32_t count;                          /* offset 36, count */
    uint8_t node[16];                        /* offset 40, utf8 */
    vpsom_InputHealth inputs[16];            /* offset 56, struct */
} vpsom_NodeHealth;
VPSOM_STATIC_ASSERT(sizeof(vpsom_NodeHealth) == 952, "vpsom_NodeHealth: size");
VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF(vpsom_NodeHealth) == 8, "vpsom_NodeHealth: alignment");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, header) == 0, "vpsom_NodeHealth.header: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, steps) == 24, "vpsom_NodeHealth.steps: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, pid) == 32, "vpsom_NodeHealth.pid: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, count) == 36, "vpsom_NodeHealth.count: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, node) == 40, "vpsom_NodeHealth.node: offset");
VPSOM_STATIC_ASSERT(offsetof(vpsom_NodeHealth, inputs) == 56, "vpsom_NodeHealth.inputs: offset");

