//! Global best view (paper section 3.2, Algorithm 1 lines 2–13).
//!
//! For the first unfinished cluster (by first sighting), `N` base poses are sampled evenly on a
//! ring around it at radius `footprint radius + safe_distance`; each faces the cluster centre
//! (neck yaw 0, the mount's pitch), so the camera's line of sight goes to the centre. Poses in
//! collision or unreachable on the inflated navigation grid are dropped; the rest are evaluated
//! in parallel (rayon, on whatever pool runs the job) with α = 1, β = 0.2 and the tracked
//! cluster as the f_c target. Candidates within `revisit_radius` of one of the cluster's earlier
//! GBV goals are dropped, so that every round moves the base to a view it has not had (without
//! this, a view that keeps the highest F(v) is chosen again where the robot already stands, the
//! goal is reached at once and the cluster's rounds run out within a fraction of a second). For a
//! cluster without any foreground object yet (f_a is 0 there), candidates in sectors it was
//! already seen from are dropped too, so that successive rounds look at it from new sides (see
//! [`crate::planner::clusters`]). If every candidate of a cluster is dropped, the next unfinished
//! cluster is tried within the same round. The best candidate
//! becomes the [`NavGoal`](shm_types::NavGoal).
//!
//! [`GbvJob`] owns copies of its inputs (`Send + 'static`) so a host can run it on a
//! low-priority pool and poll for the [`GbvResult`], which hands the buffers back for reuse.

use crate::planner::clusters::{ClusterInfo, unfinished_centroid};
use crate::planner::evaluate::{EvalParams, Target, Weights, evaluate_view};
use crate::planner::reach::NavParams;
use rayon::prelude::*;
use shm_types::{
    Candidate, MAX_CANDIDATES, ObjectMap, OccupancyGrid, PlannerDecision, boxed_zeroed,
    decision_kind, planner_state,
};
use std::f32::consts::TAU;

/// Parameters of a GBV round.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GbvParams {
    /// Evaluation parameters.
    pub eval: EvalParams,
    /// α, β.
    pub weights: Weights,
    /// Candidates per cluster (N).
    pub candidates: usize,
    /// Clearance between the cluster's footprint and the ring, metres.
    pub safe_distance: f32,
    /// Reading of the navigation grid.
    pub nav: NavParams,
    /// Candidates this close to an earlier goal of their cluster are dropped, metres.
    pub revisit_radius: f32,
    /// Angular sectors around a cluster (`bootstrap.sectors`).
    pub sectors: usize,
}

impl GbvParams {
    /// From the `[planner]` and `[camera]` configuration.
    pub fn new(
        cfg: &crate::planner::config::PlannerConfig,
        camera: &crate::config::CameraConfig,
    ) -> Self {
        Self {
            eval: EvalParams::new(cfg, camera),
            weights: Weights {
                alpha: cfg.gbv.alpha,
                beta: cfg.gbv.beta,
            },
            candidates: cfg.gbv.candidates,
            safe_distance: cfg.gbv.safe_distance,
            nav: NavParams::new(cfg),
            revisit_radius: cfg.gbv.revisit_radius,
            sectors: cfg.bootstrap.sectors,
        }
    }
}

/// `N` base poses `[x, y, yaw]` evenly on the ring around a cluster, each facing its centre;
/// the first is on the side of `from` (the robot), the rest follow counter-clockwise.
pub fn ring_poses(
    info: &ClusterInfo,
    n: usize,
    safe_distance: f32,
    from: [f32; 2],
) -> Vec<[f32; 3]> {
    let r = info.radius + safe_distance;
    let a0 = (from[1] - info.center.y).atan2(from[0] - info.center.x);
    (0..n)
        .map(|k| {
            let a = a0 + TAU * k as f32 / n as f32;
            let (s, c) = a.sin_cos();
            let yaw = crate::geom::wrap_angle(a + std::f32::consts::PI);
            [info.center.x + r * c, info.center.y + r * s, yaw]
        })
        .collect()
}

/// Evaluate base poses (neck 0, mount pitch) in parallel on the current rayon pool.
pub fn evaluate_poses(
    map: &ObjectMap,
    poses: &[[f32; 3]],
    target: Option<&Target>,
    p: &GbvParams,
) -> Vec<Candidate> {
    let pitch = p.eval.mount.pitch();
    poses
        .par_iter()
        .map(|b| {
            let pose = p.eval.mount.camera_pose(*b, 0.0, pitch);
            evaluate_view(map, &pose, target, p.weights, &p.eval)
        })
        .collect()
}

/// The chosen global best view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GbvChoice {
    /// Base pose `[x, y, yaw]`.
    pub pose: [f32; 3],
    /// F(v).
    pub score: f32,
    /// Cluster served.
    pub cluster_id: i32,
    /// The evaluated candidate.
    pub candidate: Candidate,
}

/// One GBV round as an owned job.
#[derive(Debug)]
pub struct GbvJob {
    /// Map snapshot.
    pub map: Box<ObjectMap>,
    /// Navigation grid snapshot.
    pub nav: Box<OccupancyGrid>,
    /// Robot base pose `[x, y, yaw]` (estimated).
    pub base: [f32; 3],
    /// Unfinished clusters in processing order; the first with a reachable candidate is served.
    pub clusters: Vec<ClusterInfo>,
    /// Earlier GBV goals: cluster id and base position.
    pub visited: Vec<(i32, [f32; 2])>,
    /// Parameters.
    pub params: GbvParams,
}

/// Outcome of a [`GbvJob`].
#[derive(Debug)]
pub struct GbvResult {
    /// Best view, `None` if no cluster had a reachable candidate.
    pub best: Option<GbvChoice>,
    /// Clusters tried before the served one (or all, if none) whose candidates were all dropped.
    pub unreachable: Vec<i32>,
    /// The evaluated candidates (top [`MAX_CANDIDATES`] by value, then dropped ones), for tracing.
    pub decision: Box<PlannerDecision>,
    /// The map buffer, handed back for reuse.
    pub map: Box<ObjectMap>,
    /// The grid buffer, handed back for reuse.
    pub nav: Box<OccupancyGrid>,
}

impl GbvJob {
    /// Run the round (uses rayon's current pool for the candidates).
    pub fn run(self) -> GbvResult {
        let p = self.params;
        let nav = p.nav.flooded(&self.nav, [self.base[0], self.base[1]]);
        let r2 = p.revisit_radius * p.revisit_radius;
        let mut decision = boxed_zeroed::<PlannerDecision>();
        decision.kind = decision_kind::GBV;
        decision.map_seq = self.map.header.seq;
        decision.cluster_id = -1;
        let mut unreachable = Vec::new();
        let mut best = None;
        for info in &self.clusters {
            let poses = ring_poses(
                info,
                p.candidates,
                p.safe_distance,
                [self.base[0], self.base[1]],
            );
            let sectors = p.sectors.clamp(1, 64);
            let fresh = |b: &[f32; 3]| {
                if info.foreground > 0 {
                    return true;
                }
                let d = glam::Vec2::new(b[0] - info.center.x, b[1] - info.center.y);
                let a = d.y.atan2(d.x).rem_euclid(TAU);
                let s = ((a / TAU * sectors as f32) as usize) % sectors;
                info.sides_seen & (1u64 << s) == 0
            };
            let new = |b: &[f32; 3]| {
                !self.visited.iter().any(|(id, v)| {
                    *id == info.id && (b[0] - v[0]).powi(2) + (b[1] - v[1]).powi(2) < r2
                })
            };
            let (ok, dropped): (Vec<[f32; 3]>, Vec<[f32; 3]>) = poses
                .iter()
                .partition(|b| fresh(b) && new(b) && nav.reachable([b[0], b[1]]));
            if ok.is_empty() {
                unreachable.push(info.id);
                continue;
            }
            let target = Target {
                cluster_id: info.id,
                centroid: unfinished_centroid(&self.map, info, p.eval.eps_sopm),
            };
            let cands = evaluate_poses(&self.map, &ok, Some(&target), &p);
            let Some(k) = argmax(&cands) else {
                continue;
            };
            best = Some(GbvChoice {
                pose: ok[k],
                score: cands[k].value,
                cluster_id: info.id,
                candidate: cands[k],
            });
            fill_decision(&mut decision, &cands, k, &dropped, &p);
            decision.cluster_id = info.id;
            break;
        }
        decision.state = if best.is_some() {
            planner_state::RUNNING
        } else {
            planner_state::NO_CANDIDATES
        };
        GbvResult {
            best,
            unreachable,
            decision,
            map: self.map,
            nav: self.nav,
        }
    }
}

/// Index of the highest value (first on ties).
pub fn argmax(c: &[Candidate]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, v) in c.iter().enumerate() {
        if best.is_none_or(|b| v.value > c[b].value) {
            best = Some(i);
        }
    }
    best
}

fn fill_decision(
    d: &mut PlannerDecision,
    cands: &[Candidate],
    chosen: usize,
    dropped: &[[f32; 3]],
    p: &GbvParams,
) {
    let mut order: Vec<usize> = (0..cands.len()).collect();
    order.sort_by(|a, b| cands[*b].value.total_cmp(&cands[*a].value));
    let mut n = 0;
    for i in order.into_iter().take(MAX_CANDIDATES) {
        d.candidates[n] = cands[i];
        d.candidates[n].chosen = (i == chosen) as u8;
        n += 1;
    }
    let pitch = p.eval.mount.pitch();
    for b in dropped.iter().take(MAX_CANDIDATES - n) {
        let pose = p.eval.mount.camera_pose(*b, 0.0, pitch);
        let (yaw, pitch) = crate::geom::yaw_pitch_of(&pose);
        d.candidates[n] = Candidate {
            position: pose.translation.to_array(),
            yaw,
            pitch,
            dropped: 1,
            ..Default::default()
        };
        n += 1;
    }
    d.count = n as u32;
    d.evaluated = cands.len() as u32;
}
