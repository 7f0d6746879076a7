//! Map scores and the per-run metrics (`metrics.json`), following `docs/formats.md` § "Metrics".

use super::iou::aligned_iou;
use super::matching::{MatchParams, ObjectMatch, assign};
use super::occlusion::NonOcclusion;
use super::plot::{PlotInput, Room, ViewPose};
use serde::{Deserialize, Serialize};
use shm_types::{
    DeadlineEvent, FrameVisibility, ObjectMap, PlannerDecision, RobotState, class_name,
    decision_kind, goal_kind,
};

/// A ground-truth object (world frame, metres, radians), independent of the simulator's types.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GtObject {
    /// Unique name in the scene.
    pub name: String,
    /// COCO class name.
    pub class: String,
    /// Background (cluster-anchoring) object; scored separately.
    pub background: bool,
    /// Cuboid centre.
    pub center: [f32; 3],
    /// Extents along the object's own x, y, z (a cylinder: x = y = diameter).
    pub size: [f32; 3],
    /// Rotation about +z.
    pub yaw: f32,
}

/// An estimated object: one entry of `map.json` (world frame, metres, radians).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstObject {
    /// COCO class name.
    pub class: String,
    /// Background (cluster-anchoring) object; scored separately.
    pub background: bool,
    /// Cuboid centre.
    pub center: [f32; 3],
    /// Extents along the cuboid's own x, y, z.
    pub size: [f32; 3],
    /// Rotation about +z.
    pub yaw: f32,
    /// Mean SOPM cell entropy (model uncertainty, eq. 10).
    pub h_sopm: f32,
    /// Whether modelling was complete (`h_sopm < ε_sopm`).
    pub complete: bool,
}

impl EstObject {
    /// The evaluation view of one map object.
    pub fn from_map_object(o: &shm_types::MapObject) -> Self {
        Self {
            class: class_name(o.class_id).to_string(),
            background: o.is_background(),
            center: o.center,
            size: o.size,
            yaw: o.yaw,
            h_sopm: o.h_sopm,
            complete: o.is_complete(),
        }
    }
}

/// Every valid object of a map, in map order.
pub fn estimates_from_map(map: &ObjectMap) -> Vec<EstObject> {
    map.objects()
        .iter()
        .map(EstObject::from_map_object)
        .collect()
}

/// Which objects a score covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layer {
    /// Foreground objects (the headline metrics).
    Foreground,
    /// Background (cluster-anchoring) objects, reported separately.
    Background,
}

/// Scores of one layer of a map against ground truth.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MapScore {
    /// Ground-truth objects of the layer.
    pub objects_gt: usize,
    /// Estimated objects of the layer.
    pub objects_estimated: usize,
    /// Correct models: assigned pairs closer than `success_dist_m`.
    pub matched: usize,
    /// Assigned pairs (same class, within `max_pair_dist_m`).
    pub assigned: usize,
    /// `matched / objects_estimated`; 0 when nothing was estimated.
    pub precision: f64,
    /// `matched / objects_gt`; 1 when there is no ground truth.
    pub recall: f64,
    /// Mean aligned 3D IoU over assigned pairs; `None` (JSON null) when no pair was assigned.
    pub iou: Option<f64>,
    /// Mean centre distance over assigned pairs, metres; `None` when no pair was assigned.
    pub cde_m: Option<f64>,
    /// Outcome per ground-truth object of the layer.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_object: Vec<ObjectMatch>,
}

/// Score the objects of `layer` (each side filtered by its own `background` flag).
///
/// Matching is [`assign`]; precision, recall, IoU and CDE are as documented on [`MapScore`].
/// `per_object[*].estimate` indexes the full `est` slice (i.e. `map.json` order).
pub fn score_map(
    gt: &[GtObject],
    est: &[EstObject],
    params: &MatchParams,
    layer: Layer,
) -> MapScore {
    let want_bg = layer == Layer::Background;
    let gi: Vec<usize> = (0..gt.len())
        .filter(|&i| gt[i].background == want_bg)
        .collect();
    let ei: Vec<usize> = (0..est.len())
        .filter(|&j| est[j].background == want_bg)
        .collect();
    let g: Vec<GtObject> = gi.iter().map(|&i| gt[i].clone()).collect();
    let e: Vec<EstObject> = ei.iter().map(|&j| est[j].clone()).collect();
    let pairs = assign(&g, &e, params);

    let mut per_object: Vec<ObjectMatch> = g
        .iter()
        .map(|o| ObjectMatch {
            name: o.name.clone(),
            class: o.class.clone(),
            background: o.background,
            estimate: None,
            distance_m: None,
            iou: None,
            correct: false,
        })
        .collect();
    let (mut iou_sum, mut dist_sum, mut matched) = (0.0, 0.0, 0usize);
    for p in &pairs {
        let iou = aligned_iou(g[p.gt].size, g[p.gt].yaw, e[p.est].size, e[p.est].yaw);
        let correct = p.distance_m < params.success_dist_m;
        matched += usize::from(correct);
        iou_sum += iou;
        dist_sum += p.distance_m;
        let m = &mut per_object[p.gt];
        m.estimate = Some(ei[p.est]);
        m.distance_m = Some(p.distance_m);
        m.iou = Some(iou);
        m.correct = correct;
    }
    let n = pairs.len();
    MapScore {
        objects_gt: g.len(),
        objects_estimated: e.len(),
        matched,
        assigned: n,
        precision: if e.is_empty() {
            0.0
        } else {
            matched as f64 / e.len() as f64
        },
        recall: if g.is_empty() {
            1.0
        } else {
            matched as f64 / g.len() as f64
        },
        iou: (n > 0).then(|| iou_sum / n as f64),
        cde_m: (n > 0).then(|| dist_sum / n as f64),
        per_object,
    }
}

/// Identity of a run: `DIR/<scene>/<planner>/<seed>/`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunInfo {
    /// Scene name (the scene file's `name`).
    pub scene: String,
    /// Planner name (`vpsom`, `cover`, `frontier`, or an ablation such as `vpsom-no-h_iou`).
    pub planner: String,
    /// Seed of the run.
    pub seed: u64,
}

/// The metrics of one run: the content of `metrics.json`.
///
/// The first fifteen fields are the keys fixed by `docs/formats.md`; the rest are extras (all with
/// serde defaults, so a file holding only the fixed keys still parses). Object counts and the
/// four map scores cover foreground objects only; `background` scores the background objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Scene name.
    pub scene: String,
    /// Planner name.
    pub planner: String,
    /// Seed.
    pub seed: u64,
    /// Whether the planner terminated by itself (false: time limit or interruption).
    pub terminated: bool,
    /// Foreground ground-truth objects.
    pub objects_gt: usize,
    /// Foreground estimated objects.
    pub objects_estimated: usize,
    /// Correct foreground models / foreground estimates (0 with no estimate).
    pub precision: f64,
    /// Correct foreground models / foreground ground-truth objects (1 with no ground truth).
    pub recall: f64,
    /// Mean aligned 3D IoU over assigned foreground pairs (null if none).
    pub iou: Option<f64>,
    /// Mean centre distance over assigned foreground pairs, metres (null if none).
    pub cde_m: Option<f64>,
    /// Length of the true base path, metres.
    pub path_length_m: f64,
    /// Simulated seconds from start to termination.
    pub time_s: f64,
    /// Non-occlusion measured on ground truth (`eval::occlusion`): mean visible fraction of
    /// the foreground objects in view, over every (rendered frame, object) pair; null if no
    /// frame had an object in view.
    pub non_occlusion: Option<f64>,
    /// Localization-failure episodes.
    pub localization_failures: u32,
    /// Deadline misses of the periodic threads.
    pub deadline_misses: u64,

    /// Why the run ended (free text from the host).
    #[serde(default)]
    pub termination_reason: String,
    /// Correct foreground models (numerator of precision and recall).
    #[serde(default)]
    pub matched: usize,
    /// Assigned foreground pairs (IoU and CDE average over these).
    #[serde(default)]
    pub assigned: usize,
    /// (Frame, object) pairs `non_occlusion` averages over.
    #[serde(default)]
    pub non_occlusion_samples: u64,
    /// Rendered frames with at least one foreground object in view.
    #[serde(default)]
    pub non_occlusion_frames: u64,
    /// Eq. 21 on the true boxes of the same (frame, object) pairs: the paper's Table 2
    /// definition (`eval::occlusion`); null if no frame had an object in view.
    #[serde(default)]
    pub non_occlusion_eq21: Option<f64>,
    /// The planner's own H_IoU (eq. 21, on its estimated cuboids) of its chosen views (GBV and
    /// LBV), pooled over (view, object); null if no chosen view saw an object. Secondary: it is
    /// 0 when the H_IoU term is ablated.
    #[serde(default)]
    pub planner_h_iou: Option<f64>,
    /// The planner's own H_IoU over GBV decisions only.
    #[serde(default)]
    pub planner_h_iou_gbv: Option<f64>,
    /// The planner's own H_IoU over LBV decisions only.
    #[serde(default)]
    pub planner_h_iou_lbv: Option<f64>,
    /// Chosen GBVs (planner decisions of kind GBV).
    #[serde(default)]
    pub gbv_count: u64,
    /// Chosen LBVs (planner decisions of kind LBV).
    #[serde(default)]
    pub lbv_count: u64,
    /// Thresholds used for matching.
    #[serde(default)]
    pub match_params: MatchParams,
    /// Scores of the background objects (without `per_object`; null in files without it).
    #[serde(default)]
    pub background: Option<MapScore>,
    /// Outcome per ground-truth object, foreground first, then background.
    #[serde(default)]
    pub per_object: Vec<ObjectMatch>,
    /// Foreground objects the planner gave up (VP-SOM: H_sopm stopped falling, or the cluster
    /// ran out of views), with their last H_sopm.
    #[serde(default)]
    pub objects_given_up: Vec<GivenUpEntry>,
    /// Whether the room was explored (no reachable frontier left) when the planner ended; null
    /// if the host did not say.
    #[serde(default)]
    pub explored: Option<bool>,
    /// Base path driven while the current chassis goal was a GBV, metres (null if the host did
    /// not report goals).
    #[serde(default)]
    pub path_gbv_m: Option<f64>,
    /// Base path driven while the current chassis goal was a frontier (exploration), metres.
    #[serde(default)]
    pub path_explore_m: Option<f64>,
    /// Base path driven while the current chassis goal was a coverage waypoint, metres.
    #[serde(default)]
    pub path_coverage_m: Option<f64>,
    /// Base path driven while the current chassis goal was a localization-recovery drive
    /// (`[planner.recovery]`), metres.
    #[serde(default)]
    pub path_recovery_m: Option<f64>,
    /// Localization recoveries the planner ran (tracking lost longer than
    /// `planner.recovery.lost_grace_s`: a neck sweep, drives if it failed); null if the host did
    /// not say.
    #[serde(default)]
    pub localization_recoveries: Option<u32>,
    /// How each ground-truth foreground object was seen (rendered frames in which it was in
    /// view), for finding where recall is lost: never in view, or in view but not mapped.
    #[serde(default)]
    pub views: Vec<ObjectViews>,
}

/// How often one ground-truth foreground object was in the camera's view during a run (from
/// the simulator's visibility records: in front of the camera, in range, its unoccluded
/// silhouette at least the detector's minimum size).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectViews {
    /// Ground-truth name.
    pub name: String,
    /// Frames in which it was in view.
    pub frames: u64,
    /// Frames in which at least [`ObjectViews::WELL_SEEN_PX`] of its pixels and half of its
    /// silhouette were visible.
    pub frames_well_seen: u64,
    /// Most visible pixels in one frame.
    pub max_visible_px: u32,
}

impl ObjectViews {
    /// Visible pixels for a frame to count as "well seen" (COCO's small-object limit, 32², at
    /// the bench's 320×240 camera is 256 px).
    pub const WELL_SEEN_PX: u32 = 256;
}

/// A foreground object the planner gave up, as `metrics.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GivenUpEntry {
    /// Map object id.
    pub map_id: u32,
    /// Its cluster (background object id).
    pub cluster_id: i32,
    /// COCO class name.
    pub label: String,
    /// H_sopm when given up.
    pub h_sopm: f32,
    /// Why (e.g. "entropy stalled").
    pub cause: String,
}

/// The keys `docs/formats.md` requires in `metrics.json`.
pub const REQUIRED_KEYS: [&str; 15] = [
    "scene",
    "planner",
    "seed",
    "terminated",
    "objects_gt",
    "objects_estimated",
    "precision",
    "recall",
    "iou",
    "cde_m",
    "path_length_m",
    "time_s",
    "non_occlusion",
    "localization_failures",
    "deadline_misses",
];

/// Kind of a chosen view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NbvKind {
    /// Global best view (a chassis goal).
    Gbv,
    /// Local best view (a neck goal).
    Lbv,
}

#[derive(Debug, Clone, Copy, Default)]
struct Pooled {
    sum: f64,
    weight: f64,
}

impl Pooled {
    fn add(&mut self, value: f64, weight: f64) {
        self.sum += value * weight;
        self.weight += weight;
    }

    fn mean(&self) -> Option<f64> {
        (self.weight > 0.0).then(|| self.sum / self.weight)
    }
}

/// Trajectory points closer than this to the previous kept one are not kept for plots, metres.
const TRAJECTORY_STEP_M: f32 = 0.02;

/// Accumulates what a run's metrics need besides the final map, fed by the host as the session
/// runs (in either host: lockstep or processes).
#[derive(Debug, Clone, Default)]
pub struct SessionLog {
    start_ns: u64,
    end_ns: Option<u64>,
    terminated: bool,
    reason: String,
    last_xy: Option<[f32; 2]>,
    path_length_m: f64,
    trajectory: Vec<[f32; 2]>,
    localization_failures: u32,
    deadline_misses: u64,
    non_occlusion: NonOcclusion,
    h_iou_all: Pooled,
    h_iou_gbv: Pooled,
    h_iou_lbv: Pooled,
    gbv: Vec<ViewPose>,
    lbv: Vec<ViewPose>,
    given_up: Vec<GivenUpEntry>,
    explored: Option<bool>,
    goal_kind: Option<u8>,
    path_by_goal: Option<[f64; 4]>,
    recoveries: Option<u32>,
    views: std::collections::BTreeMap<u32, (u64, u64, u32)>,
}

impl SessionLog {
    /// A log for a session starting at simulated time 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// A log for a session starting at `start_ns` (simulated time).
    pub fn starting_at(start_ns: u64) -> Self {
        Self {
            start_ns,
            ..Self::default()
        }
    }

    /// Feed a *true* robot state (`sim/truth`): adds the base's planar motion to the path length,
    /// keeps the trajectory for plots and takes the localization-failure count.
    pub fn observe_truth(&mut self, state: &RobotState) {
        let xy = [state.base_pose[0], state.base_pose[1]];
        if let Some(last) = self.last_xy {
            let step = f64::from((xy[0] - last[0]).hypot(xy[1] - last[1]));
            if step.is_finite() {
                self.path_length_m += step;
                if let (Some(k), Some(by)) = (self.goal_kind, self.path_by_goal.as_mut())
                    && let Some(p) = by.get_mut(usize::from(k))
                {
                    *p += step;
                }
            }
        }
        self.last_xy = Some(xy);
        let far = self
            .trajectory
            .last()
            .is_none_or(|p| (xy[0] - p[0]).hypot(xy[1] - p[1]) >= TRAJECTORY_STEP_M);
        if far {
            self.trajectory.push(xy);
        }
        self.observe_localization_failures(state.localization_failures);
    }

    /// Take a cumulative localization-failure count (e.g. from `robot/state`); keeps the largest.
    pub fn observe_localization_failures(&mut self, count: u32) {
        self.localization_failures = self.localization_failures.max(count);
    }

    /// Feed a planner decision: its chosen candidate (if any) is an NBV of the decision's kind.
    pub fn observe_decision(&mut self, decision: &PlannerDecision) {
        let Some(c) = decision.candidates().iter().find(|c| c.chosen != 0) else {
            return;
        };
        let kind = if decision.kind == decision_kind::GBV {
            NbvKind::Gbv
        } else {
            NbvKind::Lbv
        };
        let pose = ViewPose {
            position: c.position,
            yaw: c.yaw,
            pitch: c.pitch,
        };
        self.observe_nbv(kind, pose, c.h_iou, c.objects_in_view);
    }

    /// Record one chosen view: its pose, the planner's mean H_IoU over the foreground objects
    /// it sees and their number (views seeing no object do not enter the `planner_h_iou` mean).
    pub fn observe_nbv(&mut self, kind: NbvKind, pose: ViewPose, h_iou: f32, objects_in_view: u16) {
        let n = f64::from(objects_in_view);
        let h = f64::from(h_iou);
        if n > 0.0 && h.is_finite() {
            self.h_iou_all.add(h, n);
            match kind {
                NbvKind::Gbv => self.h_iou_gbv.add(h, n),
                NbvKind::Lbv => self.h_iou_lbv.add(h, n),
            }
        }
        match kind {
            NbvKind::Gbv => self.gbv.push(pose),
            NbvKind::Lbv => self.lbv.push(pose),
        }
    }

    /// Feed the ground-truth visibility record of one rendered frame (`Sim::visibility`, or
    /// `sim/visibility` in the deployment host): the non-occlusion metric
    /// ([`occlusion`](super::occlusion)).
    pub fn observe_visibility(&mut self, frame: &FrameVisibility) {
        self.non_occlusion.observe(frame);
        for v in frame.items() {
            let e = self.views.entry(v.object).or_default();
            e.0 += 1;
            let half = u64::from(v.visible_px) * 2 >= u64::from(v.silhouette_px);
            e.1 += u64::from(v.visible_px >= ObjectViews::WELL_SEEN_PX && half);
            e.2 = e.2.max(v.visible_px);
        }
    }

    /// Feed the kind (`shm_types::goal_kind`) of a chassis goal the host issued: the path
    /// driven from now on counts as that kind's (`path_gbv_m`, `path_explore_m`, ...).
    pub fn observe_goal(&mut self, kind: u8) {
        self.goal_kind = Some(kind);
        self.path_by_goal.get_or_insert([0.0; 4]);
    }

    /// The non-occlusion accumulated so far.
    pub fn non_occlusion(&self) -> &NonOcclusion {
        &self.non_occlusion
    }

    /// Feed a deadline-monitor event; missed cycles are counted.
    pub fn observe_deadline(&mut self, event: &DeadlineEvent) {
        self.deadline_misses += u64::from(event.missed != 0);
    }

    /// Add deadline misses counted elsewhere (e.g. a monitor's total).
    pub fn add_deadline_misses(&mut self, misses: u64) {
        self.deadline_misses += misses;
    }

    /// End the session at simulated time `end_ns`; `terminated` says whether the planner stopped
    /// by itself, `reason` is kept in `metrics.json`.
    pub fn finish(&mut self, end_ns: u64, terminated: bool, reason: &str) {
        self.end_ns = Some(end_ns);
        self.terminated = terminated;
        self.reason = reason.to_string();
    }

    /// What the planner reported at its end: whether the room was explored and the objects it
    /// gave up (kept in `metrics.json`).
    pub fn planner_outcome(&mut self, explored: bool, given_up: Vec<GivenUpEntry>) {
        self.explored = Some(explored);
        self.given_up = given_up;
    }

    /// Feed the number of localization recoveries the planner ran (`localization_recoveries`).
    pub fn planner_recoveries(&mut self, recoveries: u32) {
        self.recoveries = Some(recoveries);
    }

    /// Length of the true base path so far, metres.
    pub fn path_length_m(&self) -> f64 {
        self.path_length_m
    }

    /// The kept trajectory points (x, y).
    pub fn trajectory(&self) -> &[[f32; 2]] {
        &self.trajectory
    }

    /// Chosen GBVs and LBVs so far.
    pub fn views(&self) -> (&[ViewPose], &[ViewPose]) {
        (&self.gbv, &self.lbv)
    }

    /// The run's metrics: scores `est` against `gt` and adds what was logged. If
    /// [`finish`](Self::finish) was not called, `time_s` is 0 and `terminated` false.
    pub fn metrics(
        &self,
        run: &RunInfo,
        gt: &[GtObject],
        est: &[EstObject],
        params: &MatchParams,
    ) -> Metrics {
        let fg = score_map(gt, est, params, Layer::Foreground);
        let mut bg = score_map(gt, est, params, Layer::Background);
        let mut per_object = fg.per_object.clone();
        per_object.append(&mut bg.per_object);
        let time_s = self
            .end_ns
            .map_or(0.0, |e| e.saturating_sub(self.start_ns) as f64 * 1e-9);
        Metrics {
            scene: run.scene.clone(),
            planner: run.planner.clone(),
            seed: run.seed,
            terminated: self.terminated,
            objects_gt: fg.objects_gt,
            objects_estimated: fg.objects_estimated,
            precision: fg.precision,
            recall: fg.recall,
            iou: fg.iou,
            cde_m: fg.cde_m,
            path_length_m: self.path_length_m,
            time_s,
            non_occlusion: self.non_occlusion.mean(),
            localization_failures: self.localization_failures,
            deadline_misses: self.deadline_misses,
            termination_reason: self.reason.clone(),
            matched: fg.matched,
            assigned: fg.assigned,
            non_occlusion_samples: self.non_occlusion.samples,
            non_occlusion_frames: self.non_occlusion.frames_with_objects,
            non_occlusion_eq21: self.non_occlusion.mean_eq21(),
            planner_h_iou: self.h_iou_all.mean(),
            planner_h_iou_gbv: self.h_iou_gbv.mean(),
            planner_h_iou_lbv: self.h_iou_lbv.mean(),
            gbv_count: self.gbv.len() as u64,
            lbv_count: self.lbv.len() as u64,
            match_params: *params,
            background: Some(bg),
            per_object,
            objects_given_up: self.given_up.clone(),
            explored: self.explored,
            path_gbv_m: self.path_by_goal.map(|p| p[usize::from(goal_kind::GBV)]),
            path_explore_m: self
                .path_by_goal
                .map(|p| p[usize::from(goal_kind::FRONTIER)]),
            path_coverage_m: self
                .path_by_goal
                .map(|p| p[usize::from(goal_kind::COVERAGE)]),
            path_recovery_m: self
                .path_by_goal
                .map(|p| p[usize::from(goal_kind::RECOVERY)]),
            localization_recoveries: self.recoveries,
            views: self.object_views(gt),
        }
    }

    /// Per ground-truth foreground object (scene order, as `gt`), how it was seen.
    fn object_views(&self, gt: &[GtObject]) -> Vec<ObjectViews> {
        gt.iter()
            .enumerate()
            .filter(|(_, g)| !g.background)
            .map(|(i, g)| {
                let (frames, well, max) = u32::try_from(i)
                    .ok()
                    .and_then(|i| self.views.get(&i).copied())
                    .unwrap_or_default();
                ObjectViews {
                    name: g.name.clone(),
                    frames,
                    frames_well_seen: well,
                    max_visible_px: max,
                }
            })
            .collect()
    }

    /// The input of the run's figure (LBVs subsampled to at most [`PlotInput::MAX_LBV`]).
    pub fn plot_input(
        &self,
        run: &RunInfo,
        room: Room,
        gt: &[GtObject],
        est: &[EstObject],
        metrics: &Metrics,
    ) -> PlotInput {
        PlotInput {
            run: run.clone(),
            room,
            gt: gt.to_vec(),
            estimated: est.to_vec(),
            trajectory: self.trajectory.clone(),
            gbv: self.gbv.clone(),
            lbv: subsample(&self.lbv, PlotInput::MAX_LBV),
            headline: Some(super::plot::Headline::of(metrics)),
        }
    }
}

/// At most `max` evenly spaced elements of `v` (first and last kept).
pub(crate) fn subsample<T: Clone>(v: &[T], max: usize) -> Vec<T> {
    if v.len() <= max {
        return v.to_vec();
    }
    if max < 2 {
        return v[..max].to_vec();
    }
    (0..max)
        .map(|k| v[k * (v.len() - 1) / (max - 1)].clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsample_keeps_ends_and_bounds_count() {
        let v: Vec<u32> = (0..100).collect();
        let s = subsample(&v, 5);
        assert_eq!(s, vec![0, 24, 49, 74, 99]);
        assert_eq!(subsample(&v[..3], 5), vec![0, 1, 2]);
        assert!(subsample(&v, 0).is_empty());
    }
}
