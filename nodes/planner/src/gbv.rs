//! Global best view (paper section 3.2, Algorithm 1 lines 2–13).
//!
//! For the first unfinished cluster (by first sighting), `N` base poses are sampled evenly on a
//! ring around it at radius `footprint radius + safe_distance`; each faces the cluster centre.
//! Poses in collision or unreachable on the inflated navigation grid are dropped; the rest are
//! evaluated in parallel (rayon, on whatever pool runs the job) with α = 1, β = 0.2 and the
//! tracked cluster as the f_c target. Each base pose is scored with the camera where it will
//! be: at the neck yaw the LBV (α = 0, β = 1, its `M` neck candidates) chooses at that pose for
//! the same cluster (`gbv.neck_aware`; off: neck 0, line of sight to the centre), so the view
//! scored is the view taken; the chosen candidate's traced yaw is that camera's. f_a's in-view
//! test treats the navigation grid's unexplained obstacles as walls ([`crate::sight`]). Candidates within `revisit_radius` of one of the cluster's earlier
//! GBV goals are dropped, so that every round moves the base to a view it has not had (without
//! this, a view that keeps the highest F(v) is chosen again where the robot already stands, the
//! goal is reached at once and the cluster's rounds run out within a fraction of a second). For a
//! cluster without any foreground object yet (f_a is 0 there), candidates in sectors it was
//! already seen from are dropped too, so that successive rounds look at it from new sides (see
//! [`crate::clusters`]). If every candidate of a cluster is dropped, the next unfinished
//! cluster is tried within the same round. The candidate maximising
//! `F(v) / F_max − distance_weight × path` (path on the navigation grid from the robot, metres;
//! F_max the best F of the round; plain F(v) when `distance_weight` is 0 or F_max ≤ 0) becomes the
//! [`NavGoal`](shm_types::NavGoal): of views worth about the same, the near one.
//!
//! [`GbvJob`] owns copies of its inputs (`Send + 'static`) so a host can run it on a
//! low-priority pool and poll for the [`GbvResult`], which hands the buffers back for reuse.

use crate::clusters::{ClusterInfo, unfinished_centroid};
use crate::evaluate::{EvalParams, FaFilter, Target, Weights, evaluate_view_in};
use crate::lbv::{Lbv, neck_yaws};
use crate::reach::NavParams;
use crate::sight::Walls;
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
    /// How the neck yaw of a candidate is chosen.
    pub neck: GbvNeck,
    /// Which objects f_a counts.
    pub fa: FaFilter,
    /// Travel cost per metre of path, relative to the round's best F(v) (`gbv.distance_weight`).
    pub distance_weight: f32,
}

/// The neck yaw a GBV candidate is scored at: the LBV's choice (its candidates and weights).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GbvNeck {
    /// Use the LBV's choice; false: neck 0.
    pub aware: bool,
    /// LBV neck candidates M.
    pub candidates: usize,
    /// Neck range, radians.
    pub min: f32,
    /// Neck range, radians.
    pub max: f32,
    /// The LBV's α, β.
    pub weights: Weights,
}

impl GbvNeck {
    /// From the `[planner]` configuration (`gbv.neck_aware`, `[planner.lbv]`).
    pub fn new(cfg: &crate::config::PlannerConfig) -> Self {
        let l = &cfg.lbv;
        Self {
            aware: cfg.gbv.neck_aware,
            candidates: l.candidates,
            min: l.neck_min_deg.to_radians(),
            max: l.neck_max_deg.to_radians(),
            weights: Weights {
                alpha: l.alpha,
                beta: l.beta,
            },
        }
    }
}

impl GbvParams {
    /// From the `[planner]` and `[camera]` configuration.
    pub fn new(cfg: &crate::config::PlannerConfig, camera: &geom::CameraConfig) -> Self {
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
            neck: GbvNeck::new(cfg),
            fa: FaFilter::new(cfg),
            distance_weight: cfg.gbv.distance_weight,
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
            let yaw = geom::wrap_angle(a + std::f32::consts::PI);
            [info.center.x + r * c, info.center.y + r * s, yaw]
        })
        .collect()
}

/// Evaluate base poses in parallel on the current rayon pool, without walls (see
/// [`evaluate_poses_in`]).
pub fn evaluate_poses(
    map: &ObjectMap,
    poses: &[[f32; 3]],
    target: Option<&Target>,
    p: &GbvParams,
) -> Vec<Candidate> {
    evaluate_poses_in(map, poses, target, None, p).0
}

/// The neck yaw the LBV chooses at base pose `b` for `target` (ties: nearest to neck 0); 0 when
/// neck-awareness is off or there is no target.
pub fn neck_for(lbv: &mut Lbv, map: &ObjectMap, b: [f32; 3], target: Option<&Target>) -> f32 {
    target
        .and_then(|t| lbv.evaluate(map, b, 0.0, Some(t)))
        .map_or(0.0, |c| c.neck_yaw)
}

/// Evaluate base poses in parallel on the current rayon pool, each at the neck yaw the LBV
/// would choose there ([`GbvNeck`]; mount pitch), with `walls` as extra occluders. Returns the
/// candidates and their neck yaws.
pub fn evaluate_poses_in(
    map: &ObjectMap,
    poses: &[[f32; 3]],
    target: Option<&Target>,
    walls: Option<&Walls<'_>>,
    p: &GbvParams,
) -> (Vec<Candidate>, Vec<f32>) {
    let pitch = p.eval.mount.pitch();
    let n = p.neck;
    let aware = n.aware && target.is_some();
    let lbv = Lbv::with(
        p.eval,
        n.weights,
        if aware {
            neck_yaws(n.min, n.max, n.candidates)
        } else {
            Vec::new()
        },
    );
    poses
        .par_iter()
        .map_init(
            || lbv.clone(),
            |lbv, b| {
                let yaw = if aware {
                    neck_for(lbv, map, *b, target)
                } else {
                    0.0
                };
                let pose = p.eval.mount.camera_pose(*b, yaw, pitch);
                (
                    evaluate_view_in(map, &pose, target, walls, &p.fa, p.weights, &p.eval),
                    yaw,
                )
            },
        )
        .unzip()
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

impl GbvChoice {
    /// The neck yaw (relative to the base) the view was scored at: the traced camera yaw minus
    /// the base yaw.
    pub fn neck_yaw(&self) -> f32 {
        geom::wrap_angle(self.candidate.yaw - self.pose[2])
    }
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
        let walls = Walls {
            grid: &self.nav,
            inflation: if p.nav.inflated {
                p.nav.robot_radius
            } else {
                0.0
            },
            slack: p.fa.wall_slack,
        };
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
            // Sectors matter for a cluster without foreground objects that was approached;
            // any ring pose approaches one that was not.
            let fresh = |b: &[f32; 3]| {
                if info.foreground > 0 || !info.approached {
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
            let (cands, _) = evaluate_poses_in(&self.map, &ok, Some(&target), Some(&walls), &p);
            let paths: Vec<f32> = ok
                .iter()
                .map(|b| {
                    nav.path_length([b[0], b[1]])
                        .unwrap_or_else(|| (b[0] - self.base[0]).hypot(b[1] - self.base[1]))
                })
                .collect();
            let Some(k) = choose(&cands, &paths, p.distance_weight) else {
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

/// Index of the candidate maximising `value / max value − weight × path` (first on ties); plain
/// [`argmax`] when `weight` is 0 or no value is positive.
pub fn choose(c: &[Candidate], paths: &[f32], weight: f32) -> Option<usize> {
    let k = argmax(c)?;
    let top = c[k].value;
    if weight <= 0.0 || top <= 0.0 {
        return Some(k);
    }
    let adj = |i: usize| c[i].value / top - weight * paths[i];
    (0..c.len()).fold(None, |best: Option<usize>, i| match best {
        Some(b) if adj(i) <= adj(b) => Some(b),
        _ => Some(i),
    })
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
        let (yaw, pitch) = geom::yaw_pitch_of(&pose);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clusters::cluster_info;
    use crate::config::PlannerConfig;
    use geom::CameraConfig;
    use glam::Vec3;

    /// A 4 m long table (cluster 7) with one unfinished cup at its east end, (1.9, 0, 0.8).
    fn long_table() -> Box<ObjectMap> {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.count = 2;
        let t = &mut m.objects[0];
        t.id = 7;
        t.background = 1;
        t.cluster_id = 7;
        t.center = [0.0, 0.0, 0.375];
        t.size = [4.0, 0.8, 0.75];
        let c = &mut m.objects[1];
        c.id = 8;
        c.cluster_id = 7;
        c.center = [1.9, 0.0, 0.8];
        c.size = [0.1, 0.1, 0.1];
        c.h_sopm = 0.9;
        c.c_asso = 1.0;
        m
    }

    /// From the ring pose south of the table's middle, facing its centre, the cup lies 35.7° to
    /// the right: outside the 60° field of view at neck 0. The LBV there turns the neck to the
    /// candidate nearest the cup (−40°, candidates every 20°); the neck-aware GBV scores the pose
    /// at that yaw, so the cup is in view and f_a counts it, and the traced camera yaw is base
    /// yaw + neck yaw. At neck 0 the same pose sees nothing.
    #[test]
    fn neck_aware_gbv_scores_the_yaw_that_sees_the_cluster() {
        let cfg = PlannerConfig::default();
        let mut p = GbvParams::new(&cfg, &CameraConfig::default());
        assert!(p.neck.aware);
        // The cup is 3.3 m from the ring: count the target cluster's objects.
        p.fa.relevance = crate::config::FaRelevance::Cluster;
        let m = long_table();
        let info = cluster_info(&m, 7, cfg.eps_sopm).unwrap();
        let target = Target {
            cluster_id: 7,
            centroid: unfinished_centroid(&m, &info, cfg.eps_sopm),
        };
        let ring = ring_poses(&info, 36, p.safe_distance, [0.0, -5.0]);
        let south = ring[0];
        assert!(south[0].abs() < 1e-4 && south[1] < -2.0, "{south:?}");
        let (c, necks) = evaluate_poses_in(&m, &[south], Some(&target), None, &p);
        assert!(
            (necks[0] + 40f32.to_radians()).abs() < 1e-4,
            "neck {}°",
            necks[0].to_degrees()
        );
        assert_eq!(c[0].objects_in_view, 1, "{:?}", c[0]);
        assert!(c[0].f_a > 0.5);
        let expect = geom::wrap_angle(south[2] + necks[0]);
        assert!((c[0].yaw - expect).abs() < 1e-4, "{} vs {expect}", c[0].yaw);
        let mut blind = p;
        blind.neck.aware = false;
        let (c0, n0) = evaluate_poses_in(&m, &[south], Some(&target), None, &blind);
        assert_eq!((n0[0], c0[0].objects_in_view, c0[0].f_a), (0.0, 0, 0.0));

        // The whole round: the chosen goal carries the neck yaw the LBV takes there, and the
        // traced chosen candidate is the camera at that yaw.
        let job = GbvJob {
            map: m,
            nav: boxed_zeroed::<OccupancyGrid>(),
            base: [0.0, -5.0, 0.0],
            clusters: vec![info],
            visited: Vec::new(),
            params: p,
        };
        let r = job.run();
        let b = r.best.expect("a reachable candidate");
        let mut lbv = Lbv::new(&cfg, &CameraConfig::default());
        let taken = neck_for(&mut lbv, &r.map, b.pose, Some(&target));
        assert!(
            (b.neck_yaw() - taken).abs() < 1e-4,
            "{} vs {taken}",
            b.neck_yaw()
        );
        assert!(b.candidate.objects_in_view >= 1);
        let chosen = r.decision.candidates[..r.decision.count as usize]
            .iter()
            .find(|c| c.chosen == 1)
            .unwrap();
        let yaw = geom::wrap_angle(b.pose[2] + taken);
        assert!((chosen.yaw - yaw).abs() < 1e-4);
        let cam = p
            .eval
            .mount
            .camera_pose(b.pose, taken, p.eval.mount.pitch());
        assert!(Vec3::from(cam.translation).distance(Vec3::from(chosen.position)) < 1e-4);
    }
}
