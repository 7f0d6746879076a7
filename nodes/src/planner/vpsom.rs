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
//! first unfinished cluster; with none, the camera stays on the last GBV goal's cluster, and
//! before any GBV the neck looks around.
//! Termination: every cluster done → `Terminated`; clusters remain but all are given up or
//! none has a reachable candidate → `NoCandidates`.

use crate::config::CameraConfig;
use crate::geom::CameraMount;
use crate::planner::clusters::{self, ClusterInfo};
use crate::planner::config::{PlannerConfig, PlannerKind};
use crate::planner::evaluate::{EvalParams, Target};
use crate::planner::gbv::{GbvJob, GbvParams};
use crate::planner::lbv::Lbv;
use crate::planner::session::{
    Back, JobOutput, LookAround, Outcome, PlannerInputs, PlannerJob, PlannerStatus, Session, Step,
    Summary, ViewPlanner, neck_goal_for,
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
    mount: CameraMount,
    lbv: Lbv,
    last_lbv: Option<usize>,
    last_cluster: i32,
    session: Session,
    look: LookAround,
    mode: Mode,
    tracked: Option<i32>,
    rounds: Vec<(i32, u32)>,
    visited: Vec<(i32, [f32; 2])>,
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
            mount: camera.mount,
            lbv: Lbv::new(cfg, camera),
            last_lbv: None,
            last_cluster: -1,
            session: Session::new(PlannerKind::Vpsom, cfg, cfg.bootstrap.empty_cluster_sectors),
            look: LookAround::new(
                cfg.bootstrap.look_around_steps,
                cfg.bootstrap.neck_tolerance_deg.to_radians(),
            ),
            mode: Mode::LookAround,
            tracked: None,
            rounds: Vec::with_capacity(shm_types::MAX_OBJECTS),
            visited: Vec::new(),
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
        let given_up = &mut self.session.given_up;
        if n >= self.cfg.gbv.max_rounds_per_cluster && !given_up.contains(&id) {
            given_up.push(id);
        }
    }

    fn target(&self, map: &ObjectMap) -> Option<Target> {
        let eps = self.cfg.eps_sopm;
        let (sides, given_up) = (&self.session.sides, &self.session.given_up);
        let tracked = self
            .tracked
            .filter(|id| !given_up.contains(id))
            .and_then(|id| clusters::cluster_info(map, id, eps))
            .filter(|c| !(c.done || c.foreground == 0 && sides.sides(c.id) >= self.min_sides()));
        let info = tracked
            .or_else(|| clusters::first_unfinished(map, eps, sides, self.min_sides(), given_up))?;
        Some(Target {
            cluster_id: info.id,
            centroid: clusters::unfinished_centroid(map, &info, eps),
        })
    }
}

impl ViewPlanner for VpsomPlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Vpsom
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step {
        if let Some(step) = self.session.begin(inputs.map) {
            return step;
        }
        let eps = self.cfg.eps_sopm;
        let all: Vec<ClusterInfo> =
            clusters::clusters(inputs.map, eps, &self.session.sides, self.min_sides());
        if self.session.goals.poll(inputs.state) == Outcome::Pending {
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
            self.mode = Mode::Explore;
            return self.session.frontier_job(inputs);
        }
        let open: Vec<ClusterInfo> = all
            .iter()
            .filter(|c| !c.done && !self.session.given_up.contains(&c.id))
            .copied()
            .collect();
        if open.is_empty() {
            let status = if all.iter().all(|c| c.done) {
                PlannerStatus::Terminated
            } else {
                PlannerStatus::NoCandidates
            };
            return self.session.finish(status, now_ns);
        }
        self.mode = Mode::Gbv;
        let job = GbvJob {
            map: self.session.buffers.map(inputs.map),
            nav: self.session.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            clusters: open,
            visited: self.visited.clone(),
            params: self.gbv,
        };
        self.session.compute(PlannerJob::Gbv(job))
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        let r = match self
            .session
            .job_back(output, now_ns, PlannerStatus::NoCandidates)
        {
            Back::Gbv(r) => r,
            other => return self.session.discard(other),
        };
        self.session.buffers.put_map(r.map);
        self.session.buffers.put_nav(r.nav);
        self.session.decision = Some(r.decision);
        for id in &r.unreachable {
            self.count_round(*id);
        }
        let Some(b) = r.best else {
            return self.session.finish(PlannerStatus::NoCandidates, now_ns);
        };
        self.count_round(b.cluster_id);
        self.tracked = Some(b.cluster_id);
        self.visited.push((b.cluster_id, [b.pose[0], b.pose[1]]));
        Step::Goal(
            self.session
                .goals
                .issue(b.pose, b.score, b.cluster_id, goal_kind::GBV, now_ns),
        )
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, _now_ns: u64) -> NeckGoal {
        let pose = self
            .mount
            .camera_pose(state.base_pose, state.neck_yaw, state.neck_pitch);
        self.session
            .sides
            .observe(map, &self.eval.camera, &View::new(pose));
        let mut goal = neck_goal_for(map, self.mount.pitch());
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
                // Every known cluster done while the last GBV goal is still being driven to:
                // keep the camera on that goal's cluster. A 360° sweep on top of the base's
                // turns exceeds the tracking rate and loses localization.
                let held = self
                    .tracked
                    .and_then(|id| clusters::cluster_info(map, id, self.cfg.eps_sopm));
                goal.yaw = match held {
                    Some(c) => self.mount.neck_yaw_toward(state.base_pose, c.center),
                    None => self.look.target(state.neck_yaw),
                };
            }
        }
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.session.status()
    }

    fn summary(&self) -> Summary {
        self.session.summary()
    }

    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        self.session.take_decision()
    }

    fn lbv_decision(&self, d: &mut PlannerDecision) -> bool {
        let Some(i) = self.last_lbv else {
            return false;
        };
        self.lbv.fill_decision(Some(i), d);
        d.cluster_id = self.last_cluster;
        d.state = self.session.status().code();
        true
    }
}
