//! The VP-SOM planner (paper Algorithms 1 and 2): GBV rounds for the chassis, LBV for the neck,
//! termination per section 3.4.
//!
//! Modes:
//! 1. **Look-around** (no cluster known yet, start of session): the neck sweeps 360° in place
//!    through `bootstrap.look_around_steps` stops; no chassis goal.
//! 2. **Explore** (still no cluster after a full sweep): frontier goals on the exploration grid
//!    (kind FRONTIER), the neck keeps sweeping. As soon as a cluster appears, the frontier goal
//!    is superseded by a GBV round. No cluster and no reachable frontier → `NoCandidates`.
//! 3. **GBV**: for the first unfinished cluster by first sighting, a [`GbvJob`]; its best view is
//!    published (kind GBV). When the base reports REACHED or UNREACHABLE for it, the next round
//!    starts. Each round's goal is remembered for its cluster: later rounds drop candidates within
//!    `gbv.revisit_radius` of it (a view already taken, or refused, is not chosen again), so every
//!    round moves the base somewhere new. A cluster gets at most `gbv.max_rounds_per_cluster`
//!    rounds (rounds in which it had no reachable candidate count too); then it is given up.
//!
//! The LBV always tracks the cluster of the current GBV goal while it is unfinished, else the
//! first unfinished cluster; with none, the neck looks around.
//! Termination: every cluster done → `Terminated`; clusters remain but all are given up or
//! none has a reachable candidate → `NoCandidates`.

use crate::config::CameraConfig;
use crate::geom::CameraMount;
use crate::planner::clusters::{self, ClusterInfo, SideTracker};
use crate::planner::config::{PlannerConfig, PlannerKind};
use crate::planner::evaluate::{EvalParams, Target};
use crate::planner::frontier::{FrontierJob, FrontierParams};
use crate::planner::gbv::{GbvJob, GbvParams};
use crate::planner::lbv::Lbv;
use crate::planner::reach::NavParams;
use crate::planner::session::{
    Buffers, Goals, JobOutput, LookAround, Outcome, PlannerInputs, PlannerJob, PlannerStatus, Step,
    Summary, ViewPlanner, map_counts,
};
use crate::planner::terms::View;
use shm_types::{NeckGoal, ObjectMap, PlannerDecision, RobotState, goal_kind};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    LookAround,
    Explore,
    Gbv,
}

/// VP-SOM (see the module docs).
#[derive(Debug)]
pub struct VpsomPlanner {
    cfg: PlannerConfig,
    eval: EvalParams,
    gbv: GbvParams,
    frontier: FrontierParams,
    mount: CameraMount,
    lbv: Lbv,
    last_lbv: Option<usize>,
    last_cluster: i32,
    goals: Goals,
    buffers: Buffers,
    sides: SideTracker,
    look: LookAround,
    mode: Mode,
    pending: bool,
    tracked: Option<i32>,
    rounds: Vec<(i32, u32)>,
    given_up: Vec<i32>,
    blacklist: Vec<[f32; 2]>,
    visited: Vec<(i32, [f32; 2])>,
    decision: Option<Box<PlannerDecision>>,
    status: PlannerStatus,
    summary: Summary,
    jobs: u64,
}

/// Frontier parameters from the config.
pub(crate) fn frontier_params(cfg: &PlannerConfig) -> FrontierParams {
    FrontierParams {
        min_cells: cfg.frontier.min_cells,
        blacklist_radius: cfg.frontier.blacklist_radius,
        nav: NavParams::new(cfg),
    }
}

impl VpsomPlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        let gbv = GbvParams::new(cfg, camera);
        let eval = gbv.eval;
        Self {
            cfg: cfg.clone(),
            eval,
            gbv,
            frontier: frontier_params(cfg),
            mount: camera.mount,
            lbv: Lbv::new(cfg, camera),
            last_lbv: None,
            last_cluster: -1,
            goals: Goals::new(),
            buffers: Buffers::default(),
            sides: SideTracker::new(cfg.bootstrap.sectors),
            look: LookAround::new(
                cfg.bootstrap.look_around_steps,
                cfg.bootstrap.neck_tolerance_deg.to_radians(),
            ),
            mode: Mode::LookAround,
            pending: false,
            tracked: None,
            rounds: Vec::with_capacity(shm_types::MAX_OBJECTS),
            given_up: Vec::with_capacity(shm_types::MAX_OBJECTS),
            blacklist: Vec::new(),
            visited: Vec::new(),
            decision: None,
            status: PlannerStatus::Running,
            summary: Summary {
                kind: PlannerKind::Vpsom,
                status: PlannerStatus::Running,
                goals_issued: 0,
                goals_unreachable: 0,
                rounds: 0,
                clusters: 0,
                clusters_done: 0,
                clusters_given_up: 0,
                foreground: 0,
                foreground_done: 0,
                finished_ns: None,
            },
            jobs: 0,
        }
    }

    fn min_sides(&self) -> usize {
        self.cfg.bootstrap.empty_cluster_sectors
    }

    fn count_round(&mut self, id: i32) {
        match self.rounds.iter_mut().find(|(c, _)| *c == id) {
            Some((_, n)) => *n += 1,
            None => self.rounds.push((id, 1)),
        }
        let n = self
            .rounds
            .iter()
            .find(|(c, _)| *c == id)
            .map_or(0, |r| r.1);
        if n >= self.cfg.gbv.max_rounds_per_cluster && !self.given_up.contains(&id) {
            self.given_up.push(id);
        }
    }

    fn finish(&mut self, status: PlannerStatus, now_ns: u64) -> Step {
        self.status = status;
        self.summary.finished_ns = Some(now_ns);
        Step::Finished(self.summary())
    }

    fn target(&self, map: &ObjectMap) -> Option<Target> {
        let eps = self.cfg.eps_sopm;
        let tracked = self
            .tracked
            .filter(|id| !self.given_up.contains(id))
            .and_then(|id| clusters::cluster_info(map, id, eps))
            .filter(|c| {
                !(c.done || c.foreground == 0 && self.sides.sides(c.id) >= self.min_sides())
            });
        let info = tracked.or_else(|| {
            clusters::first_unfinished(map, eps, &self.sides, self.min_sides(), &self.given_up)
        })?;
        Some(Target {
            cluster_id: info.id,
            centroid: clusters::unfinished_centroid(map, &info, eps),
        })
    }

    fn frontier_job(&mut self, inputs: &PlannerInputs<'_>) -> Step {
        self.mode = Mode::Explore;
        self.pending = true;
        self.jobs += 1;
        Step::Compute(PlannerJob::Frontier(FrontierJob {
            explore: self.buffers.explore(inputs.explore),
            nav: self.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            blacklist: self.blacklist.clone(),
            params: self.frontier,
        }))
    }
}

impl ViewPlanner for VpsomPlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Vpsom
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step {
        if self.status.is_finished() {
            return Step::Finished(self.summary());
        }
        let eps = self.cfg.eps_sopm;
        map_counts(
            inputs.map,
            eps,
            &self.sides,
            self.min_sides(),
            &mut self.summary,
        );
        if self.pending {
            return Step::Wait;
        }
        let all: Vec<ClusterInfo> =
            clusters::clusters(inputs.map, eps, &self.sides, self.min_sides());
        if self.goals.poll(inputs.state) == Outcome::Pending {
            // A frontier goal is superseded as soon as a cluster is known.
            if self.mode != Mode::Explore || all.is_empty() {
                return Step::Wait;
            }
        }
        if all.is_empty() {
            if !self.look.swept() {
                self.mode = Mode::LookAround;
                return Step::Wait;
            }
            return self.frontier_job(inputs);
        }
        let open: Vec<ClusterInfo> = all
            .iter()
            .filter(|c| !c.done && !self.given_up.contains(&c.id))
            .copied()
            .collect();
        if open.is_empty() {
            let status = if all.iter().all(|c| c.done) {
                PlannerStatus::Terminated
            } else {
                PlannerStatus::NoCandidates
            };
            return self.finish(status, now_ns);
        }
        self.mode = Mode::Gbv;
        self.pending = true;
        self.jobs += 1;
        Step::Compute(PlannerJob::Gbv(GbvJob {
            map: self.buffers.map(inputs.map),
            nav: self.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            clusters: open,
            visited: self.visited.clone(),
            params: self.gbv,
        }))
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        self.pending = false;
        match output {
            JobOutput::Gbv(r) => {
                self.buffers.put_map(r.map);
                self.buffers.put_nav(r.nav);
                self.decision = Some(r.decision);
                for id in &r.unreachable {
                    self.count_round(*id);
                }
                match r.best {
                    Some(b) => {
                        self.count_round(b.cluster_id);
                        self.tracked = Some(b.cluster_id);
                        self.visited.push((b.cluster_id, [b.pose[0], b.pose[1]]));
                        Step::Goal(self.goals.issue(
                            b.pose,
                            b.score,
                            b.cluster_id,
                            goal_kind::GBV,
                            now_ns,
                        ))
                    }
                    None => self.finish(PlannerStatus::NoCandidates, now_ns),
                }
            }
            JobOutput::Frontier(r) => {
                self.buffers.put_explore(r.explore);
                self.buffers.put_nav(r.nav);
                match r.goal {
                    Some((pose, _)) => {
                        self.blacklist.push([pose[0], pose[1]]);
                        Step::Goal(self.goals.issue(pose, 0.0, -1, goal_kind::FRONTIER, now_ns))
                    }
                    None => self.finish(PlannerStatus::NoCandidates, now_ns),
                }
            }
            JobOutput::Coverage(r) => {
                self.buffers.put_nav(r.nav);
                Step::Wait
            }
        }
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, _now_ns: u64) -> NeckGoal {
        let pose = self
            .mount
            .camera_pose(state.base_pose, state.neck_yaw, state.neck_pitch);
        self.sides.observe(map, &self.eval.camera, &View::new(pose));
        let mut goal = NeckGoal {
            map_seq: map.header.seq,
            frame_stamp_ns: map.last_frame_stamp_ns,
            pitch: self.mount.pitch(),
            ..Default::default()
        };
        let target = self.target(map);
        self.last_cluster = target.map_or(-1, |t| t.cluster_id);
        match target {
            Some(t) => {
                let choice = self
                    .lbv
                    .evaluate(map, state.base_pose, state.neck_yaw, Some(&t));
                self.last_lbv = choice.map(|c| c.index);
                if let Some(c) = choice {
                    goal.yaw = c.neck_yaw;
                    goal.score = c.score;
                }
            }
            None => {
                self.last_lbv = None;
                goal.yaw = self.look.target(state.neck_yaw);
            }
        }
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.status
    }

    fn summary(&self) -> Summary {
        Summary {
            status: self.status,
            goals_issued: self.goals.issued,
            goals_unreachable: self.goals.unreachable,
            rounds: self.jobs,
            clusters_given_up: self.given_up.len() as u32,
            ..self.summary
        }
    }

    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        self.decision.take().map(|mut d| {
            d.state = self.status.code();
            d
        })
    }

    fn lbv_decision(&self, d: &mut PlannerDecision) -> bool {
        let Some(i) = self.last_lbv else {
            return false;
        };
        self.lbv.fill_decision(Some(i), d);
        d.cluster_id = self.last_cluster;
        d.state = self.status.code();
        true
    }
}
