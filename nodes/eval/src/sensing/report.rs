//! The figures of the sensing report, `sensing.json` and the printed table.

use super::measure::{
    Bucket, ErrorStats, FrameStats, MATCH_IOU, OCCLUSION_LIMITS, RPE_DELTA_S, SIZE_LIMITS_640,
    Tally,
};
use crate::{EvalError, write_json};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// File name of the report.
pub const SENSING_FILE: &str = "sensing.json";

/// An accepted range (inclusive; `max: None` = no upper bound).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// Lower bound.
    pub min: f64,
    /// Upper bound, if any.
    #[serde(default)]
    pub max: Option<f64>,
}

impl Range {
    /// Whether `v` lies in the range.
    pub fn contains(&self, v: f64) -> bool {
        v >= self.min && self.max.is_none_or(|m| v <= m)
    }

    fn label(&self, scale: f64) -> String {
        // Scaled bounds print without the binary fraction's tail (0.07 * 100 = 7.000000000000001).
        let show = |v: f64| format!("{}", (v * scale * 1e6).round() / 1e6);
        match self.max {
            Some(m) => format!("{}–{}", show(self.min), show(m)),
            None => format!("≥ {}", show(self.min)),
        }
    }
}

/// The bands the default sensing must land in (`[sensing.bands]`), printed next to each figure
/// and checked by `nodes/vpsom/tests/sensing_bands.rs` on the paper scenes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Acceptance {
    /// Recall of visible objects.
    pub recall: Range,
    /// False positives per frame.
    pub fp_per_frame: Range,
    /// False positives scoring at least [`super::measure::CONFIDENT_SCORE`], per frame.
    pub fp_confident_per_frame: Range,
    /// Mean box IoU of matched pairs.
    pub box_iou: Range,
    /// Share of matches with another class.
    pub confusion: Range,
    /// Invalid depth among pixels whose true depth is within the camera range.
    pub invalid_depth_in_range: Range,
    /// ATE RMSE, metres.
    pub ate_rmse_m: Range,
}

impl Acceptance {
    /// The figures of `f` outside their band, as `name value (band)`; empty when all are in.
    pub fn failures(&self, f: &Figures) -> Vec<String> {
        let checks = [
            ("recall", self.recall, f.recall),
            ("fp_per_frame", self.fp_per_frame, Some(f.fp_per_frame)),
            (
                "fp_confident_per_frame",
                self.fp_confident_per_frame,
                Some(f.fp_confident_per_frame),
            ),
            ("box_iou", self.box_iou, f.box_iou),
            ("confusion", self.confusion, f.confusion),
            (
                "invalid_depth_in_range",
                self.invalid_depth_in_range,
                f.invalid_depth_in_range,
            ),
            ("ate_rmse_m", self.ate_rmse_m, f.ate_rmse_m),
        ];
        checks
            .into_iter()
            .filter(|(_, r, v)| !v.is_some_and(|v| r.contains(v)))
            .map(|(name, r, v)| format!("{name} {v:?} (band {})", r.label(1.0)))
            .collect()
    }

    /// Every band has `min ≤ max`; the name of the first that does not.
    pub fn inverted(&self) -> Option<&'static str> {
        [
            ("recall", self.recall),
            ("fp_per_frame", self.fp_per_frame),
            ("fp_confident_per_frame", self.fp_confident_per_frame),
            ("box_iou", self.box_iou),
            ("confusion", self.confusion),
            ("invalid_depth_in_range", self.invalid_depth_in_range),
            ("ate_rmse_m", self.ate_rmse_m),
        ]
        .into_iter()
        .find(|(_, r)| r.max.is_some_and(|m| m < r.min))
        .map(|(n, _)| n)
    }
}

/// Recall of one bucket.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BucketFigure {
    /// Visible objects (object-frames).
    pub visible: u64,
    /// Matched by a detection.
    pub matched: u64,
    /// matched / visible (`null` if none visible).
    pub recall: Option<f64>,
}

impl From<Bucket> for BucketFigure {
    fn from(b: Bucket) -> Self {
        Self {
            visible: b.visible,
            matched: b.matched,
            recall: b.recall(),
        }
    }
}

/// Recall by size (COCO area buckets scaled to the image).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BySize {
    /// < 32² px at 640×480.
    pub small: BucketFigure,
    /// 32²–96² px at 640×480.
    pub medium: BucketFigure,
    /// ≥ 96² px at 640×480.
    pub large: BucketFigure,
}

/// Recall by visible fraction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ByOcclusion {
    /// Visible fraction ≥ 0.9.
    pub visible_at_least_0_9: BucketFigure,
    /// 0.5 ≤ visible fraction < 0.9.
    pub visible_0_5_to_0_9: BucketFigure,
    /// Visible fraction < 0.5.
    pub visible_below_0_5: BucketFigure,
}

/// Recall by truncation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ByTruncation {
    /// True visible box inside the image.
    pub not_truncated: BucketFigure,
    /// True visible box touches the border.
    pub truncated: BucketFigure,
}

/// The figures of one scene (or of all scenes pooled).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Figures {
    /// Scene name (`overall` for the pooled figures).
    pub scene: String,
    /// Frames scored.
    pub frames: u64,
    /// Mean visible objects per frame.
    pub visible_per_frame: f64,
    /// Mean detections per frame.
    pub detections_per_frame: f64,
    /// Recall of visible objects.
    pub recall: Option<f64>,
    /// Recall by size.
    pub recall_by_size: BySize,
    /// Recall by visible fraction.
    pub recall_by_occlusion: ByOcclusion,
    /// Recall by truncation.
    pub recall_by_truncation: ByTruncation,
    /// False positives per frame.
    pub fp_per_frame: f64,
    /// False positives scoring at least [`super::measure::CONFIDENT_SCORE`], per frame.
    pub fp_confident_per_frame: f64,
    /// Unmatched detections / detections.
    pub fp_share: Option<f64>,
    /// Mean box IoU of matched pairs.
    pub box_iou: Option<f64>,
    /// Matched pairs with another class / matched pairs.
    pub confusion: Option<f64>,
    /// Matched pairs, false positives and confusions (counts).
    pub matched: u64,
    /// Unmatched detections (count).
    pub false_positives: u64,
    /// Matched pairs with another class (count).
    pub confused: u64,
    /// Invalid depth among pixels whose true depth is within the camera range.
    pub invalid_depth_in_range: Option<f64>,
    /// Invalid depth among all pixels.
    pub invalid_depth_all: Option<f64>,
    /// ATE RMSE, m.
    pub ate_rmse_m: Option<f64>,
    /// Largest camera-position error, m.
    pub ate_max_m: Option<f64>,
    /// RPE RMSE over 1 s, m.
    pub rpe_rmse_m: Option<f64>,
    /// Pose pairs of the RPE.
    pub rpe_pairs: u64,
}

fn ratio(a: u64, b: u64) -> Option<f64> {
    (b > 0).then(|| a as f64 / b as f64)
}

impl Figures {
    /// The figures of a tally and its pose errors.
    pub fn new(scene: &str, t: &Tally, ate: &ErrorStats, rpe: &ErrorStats) -> Self {
        let per_frame = |v: u64| ratio(v, t.frames).unwrap_or(0.0);
        Figures {
            scene: scene.to_string(),
            frames: t.frames,
            visible_per_frame: per_frame(t.all.visible),
            detections_per_frame: per_frame(t.detections),
            recall: t.all.recall(),
            recall_by_size: BySize {
                small: t.size[0].into(),
                medium: t.size[1].into(),
                large: t.size[2].into(),
            },
            recall_by_occlusion: ByOcclusion {
                visible_at_least_0_9: t.occlusion[0].into(),
                visible_0_5_to_0_9: t.occlusion[1].into(),
                visible_below_0_5: t.occlusion[2].into(),
            },
            recall_by_truncation: ByTruncation {
                not_truncated: t.truncation[0].into(),
                truncated: t.truncation[1].into(),
            },
            fp_per_frame: per_frame(t.false_positives),
            fp_confident_per_frame: per_frame(t.confident_false_positives),
            fp_share: ratio(t.false_positives, t.detections),
            box_iou: (t.matched > 0).then(|| t.iou_sum / t.matched as f64),
            confusion: ratio(t.confused, t.matched),
            matched: t.matched,
            false_positives: t.false_positives,
            confused: t.confused,
            invalid_depth_in_range: ratio(t.depth[1], t.depth[0]),
            invalid_depth_all: ratio(t.depth[3], t.depth[2]),
            ate_rmse_m: ate.rmse(),
            ate_max_m: (ate.n > 0).then_some(ate.max),
            rpe_rmse_m: rpe.rmse(),
            rpe_pairs: rpe.n,
        }
    }
}

/// How the report was made (for the JSON).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Settings {
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Camera rate of the tour, Hz.
    pub camera_hz: f64,
    /// Frames per scene.
    pub frames_per_scene: u64,
    /// Seed.
    pub seed: u64,
    /// Minimum visible pixels of a visible object at this size.
    pub min_visible_pixels: f64,
    /// Box IoU of a match.
    pub match_iou: f64,
    /// Small/medium and medium/large limits, visible pixels at this size.
    pub size_limits_px: [f64; 2],
    /// Visible-fraction limits of the occlusion buckets.
    pub occlusion_limits: [f32; 2],
    /// Camera depth range `[min, max]`, m (invalid-depth reference).
    pub depth_range_m: [f32; 2],
    /// RPE interval, s.
    pub rpe_delta_s: f64,
    /// The tour, in words.
    pub tour: String,
}

impl Settings {
    /// The measurement settings for a `width × height` camera (tour fields as given).
    pub fn new(width: u32, height: u32, depth_range_m: [f32; 2]) -> Self {
        let scale = f64::from(width) * f64::from(height) / (640.0 * 480.0);
        Settings {
            width,
            height,
            camera_hz: 0.0,
            frames_per_scene: 0,
            seed: 0,
            min_visible_pixels: super::measure::min_visible_pixels(width, height),
            match_iou: MATCH_IOU,
            size_limits_px: SIZE_LIMITS_640.map(|l| l * scale),
            occlusion_limits: OCCLUSION_LIMITS,
            depth_range_m,
            rpe_delta_s: RPE_DELTA_S,
            tour: String::new(),
        }
    }
}

/// One scene of the report: figures and the per-frame record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneReport {
    /// The scene's figures.
    pub figures: Figures,
    /// Per frame.
    pub per_frame: Vec<FrameStats>,
}

/// The whole report (`sensing.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensingReport {
    /// How it was made.
    pub settings: Settings,
    /// The bands of `[sensing.bands]`.
    pub acceptance: Acceptance,
    /// Per scene.
    pub scenes: Vec<SceneReport>,
    /// All scenes pooled (counts summed; pose errors pooled).
    pub overall: Figures,
}

impl SensingReport {
    /// Write `sensing.json` into `dir` (created); returns its path.
    pub fn write(&self, dir: &Path) -> Result<std::path::PathBuf, EvalError> {
        let path = dir.join(SENSING_FILE);
        write_json(&path, self)?;
        Ok(path)
    }

    /// The report as a Markdown table: one column per scene, the pooled figures, the accepted
    /// range and whether the pooled figure is in it.
    pub fn table(&self) -> String {
        let cols: Vec<&Figures> = self
            .scenes
            .iter()
            .map(|s| &s.figures)
            .chain([&self.overall])
            .collect();
        let mut out = String::new();
        let head: Vec<&str> = cols.iter().map(|f| f.scene.as_str()).collect();
        let _ = writeln!(
            out,
            "| figure | {} | accepted | overall ok |",
            head.join(" | ")
        );
        let _ = writeln!(out, "|---|{}---|---|", "---:|".repeat(cols.len()));
        let num = |v: Option<f64>, scale: f64, d: usize| {
            v.map_or("-".into(), |x| format!("{:.d$}", x * scale))
        };
        let mut row = |name: &str,
                       cell: &dyn Fn(&Figures) -> String,
                       acc: Option<(Range, f64, Option<f64>)>| {
            let cells: Vec<String> = cols.iter().map(|f| cell(f)).collect();
            let (range, ok) = match acc {
                Some((r, scale, v)) => (
                    r.label(scale),
                    v.map_or("-", |v| if r.contains(v) { "yes" } else { "NO" }),
                ),
                None => (String::new(), ""),
            };
            let _ = writeln!(out, "| {name} | {} | {range} | {ok} |", cells.join(" | "));
        };
        let o = &self.overall;
        let a = &self.acceptance;
        row("frames", &|f| f.frames.to_string(), None);
        row(
            "visible objects / frame",
            &|f| format!("{:.2}", f.visible_per_frame),
            None,
        );
        row(
            "detections / frame",
            &|f| format!("{:.2}", f.detections_per_frame),
            None,
        );
        row(
            "recall",
            &|f| num(f.recall, 1.0, 3),
            Some((a.recall, 1.0, o.recall)),
        );
        let bucket = |b: &BucketFigure| format!("{} ({})", num(b.recall, 1.0, 3), b.visible);
        let s = &self.settings;
        let small = format!("recall small (< {:.0} px)", s.size_limits_px[0]);
        row(&small, &|f| bucket(&f.recall_by_size.small), None);
        row("recall medium", &|f| bucket(&f.recall_by_size.medium), None);
        let large = format!("recall large (≥ {:.0} px)", s.size_limits_px[1]);
        row(&large, &|f| bucket(&f.recall_by_size.large), None);
        row(
            "recall visible ≥ 0.9",
            &|f| bucket(&f.recall_by_occlusion.visible_at_least_0_9),
            None,
        );
        row(
            "recall visible 0.5–0.9",
            &|f| bucket(&f.recall_by_occlusion.visible_0_5_to_0_9),
            None,
        );
        row(
            "recall visible < 0.5",
            &|f| bucket(&f.recall_by_occlusion.visible_below_0_5),
            None,
        );
        row(
            "recall not truncated",
            &|f| bucket(&f.recall_by_truncation.not_truncated),
            None,
        );
        row(
            "recall truncated",
            &|f| bucket(&f.recall_by_truncation.truncated),
            None,
        );
        row(
            "false positives / frame",
            &|f| format!("{:.3}", f.fp_per_frame),
            Some((a.fp_per_frame, 1.0, Some(o.fp_per_frame))),
        );
        row(
            "confident false positives / frame",
            &|f| format!("{:.3}", f.fp_confident_per_frame),
            Some((
                a.fp_confident_per_frame,
                1.0,
                Some(o.fp_confident_per_frame),
            )),
        );
        row(
            "box IoU (matched)",
            &|f| num(f.box_iou, 1.0, 3),
            Some((a.box_iou, 1.0, o.box_iou)),
        );
        row(
            "confusion (%)",
            &|f| num(f.confusion, 100.0, 1),
            Some((a.confusion, 100.0, o.confusion)),
        );
        row(
            "invalid depth, in range (%)",
            &|f| num(f.invalid_depth_in_range, 100.0, 2),
            Some((a.invalid_depth_in_range, 100.0, o.invalid_depth_in_range)),
        );
        row(
            "invalid depth, all (%)",
            &|f| num(f.invalid_depth_all, 100.0, 2),
            None,
        );
        row(
            "ATE RMSE (cm)",
            &|f| num(f.ate_rmse_m, 100.0, 2),
            Some((a.ate_rmse_m, 100.0, o.ate_rmse_m)),
        );
        row("ATE max (cm)", &|f| num(f.ate_max_m, 100.0, 2), None);
        row(
            "RPE RMSE over 1 s (cm)",
            &|f| num(f.rpe_rmse_m, 100.0, 2),
            None,
        );
        out
    }
}
