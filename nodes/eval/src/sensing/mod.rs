//! The sensing report: how wrong the simulated sensing is, measured frame by frame against the
//! ground truth (`vpsom sensing`; the scripted tour that feeds it is `app::sensing`).
//!
//! | file | what |
//! |---|---|
//! | `measure.rs` | visible objects, silhouettes, box matching, per-frame counts ([`Tally`]), ATE and RPE |
//! | `report.rs` | the figures of a scene and of all scenes ([`Figures`]), `sensing.json`, the table |
//!
//! Definitions (shared by every part of issue #14):
//! - a **visible object** is a scene object (background objects included; walls and floor are
//!   not objects) with at least `50 × (W·H)/(640·480)` pixels in the TRUE instance render; its
//!   **true visible box** is the bounding box of those pixels (`x1`, `y1` exclusive);
//! - detections and visible objects are **matched** one-to-one by box IoU ≥ 0.5, highest IoU
//!   first ([`match_boxes`]); an unmatched detection is a **false positive**, a matched one with
//!   another class a **confusion** (confusion rate = confused / matched); recall = matched
//!   visible objects / visible objects; box IoU = mean IoU of the matched pairs;
//! - **truncated**: the true visible box touches the image border; **visible fraction**:
//!   visible pixels / area of the object's unoccluded silhouette clipped to the image
//!   ([`silhouette_area`]); occlusion buckets: visible fraction ≥ 0.9, 0.5–0.9, < 0.5;
//! - **size** buckets use COCO's area buckets on the visible pixel count (COCO's `area` is the
//!   mask area), scaled by `W·H/(640·480)` (COCO images are about 640×480): small < 32²,
//!   medium < 96², large ≥ 96² pixels at 640×480;
//! - **invalid depth**: share of pixels with depth 0 among the pixels whose true depth lies
//!   within the camera range `[camera.min_range, camera.max_range]`, and among all pixels;
//! - **ATE**: RMSE of the camera-position error, estimated (`DepthFrame::camera_pose`) vs true,
//!   no alignment (both are in the world frame; the start is known); **RPE**: RMSE of the
//!   translational error of the relative motion over Δ = 1 s (TUM convention), m.
//!
//! The bands each figure must land in ([`Acceptance`]) are the app's `[sensing.bands]`;
//! a **confident** false positive scores at least [`CONFIDENT_SCORE`].

mod measure;
mod report;

pub use measure::*;
pub use report::*;
